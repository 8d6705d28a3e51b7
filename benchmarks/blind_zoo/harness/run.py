"""The blind benchmark of the residual diagnosis (``benchmarks/blind_zoo/README.md``).

For every effect of a zoo directory (a sealed ``truth.yaml`` and the ``<id>.yaml`` effect files
in its ``effects/`` folder or beside it, written by someone who did not read the diagnosis), this
script records a dataset with the effect switched on, records clean datasets of the same seeds
and recording conditions, runs ``littledog-mlsim diagnose`` on each, and scores the reports
against the truth:

- found: the report names an effect of the true family *and* scope (vocabulary:
  ``docs/diagnosis.md``); also whether the family alone or the scope alone was right;
- parameter error: ``|estimate / truth - 1|`` of the family's primary parameter;
- one-step (mean TestPool nMSE) and rollout (mean final (x, y) error) before and after, and the
  same model's error on clean data of the same seed and recording condition;
- clean runs: ``significant`` must be false (a false alarm otherwise); a diagnosis that stops
  with an error is neither, and is counted apart;
- where the effect was not found and the report names a recording that would settle it
  (``suspected[*].recording`` with ``--excitation``), that recording is made and diagnosed too
  and scored in its own columns (the loop closed by the report's own advice);
- with ``--follow-recordings`` (an arm with a reference), where the effect was not found and the
  learned route's report asks for a recording a ``record`` argument makes (the reference under
  the data's command excitation, moves from spread starts, command excitation), that recording
  is made with the reference and a clean seed under the same conditions, and the effect and the
  clean seed are diagnosed against that reference: rows ``(recommended recording)``, and their
  own clean rows and summary entries (``follow-up: ...``); the first pass's counts leave them out.

The truth file is read by this script only; nothing of it is printed before every diagnosis of
the run has finished. Example (the command of the committed run is in its ``results.json``)::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/harness/run.py \\
        --zoo benchmarks/blind_zoo/zoos/zoo1 --work /tmp/blind --out /tmp/blind/run
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))   # the repository root
from benchmarks._common import git_state  # noqa: E402

#: Primary parameter of each family (docs/diagnosis.md, "Vocabulary").
PRIMARY = {
    "command_delay": "delay_ms", "command_filter": "time_constant_ms", "servo_gain": "gain_ratio",
    "joint_friction": "coulomb_Nm", "backlash": "width_rad",
    "torque_saturation": "torque_limit_Nm", "encoder_offset": "offset_rad",
    "encoder_scale": "scale", "torque_speed": "no_load_speed_rad_s",
    "odom_force": "force_N", "body_wrench": "force_N", "ground_slope": "slope_deg",
    "mass_com": "added_mass_kg", "leg_difference": "scale", "contact_phase": "magnitude",
    "time_drift": "rate_per_s",
}
#: The primary parameter where the truth's is zero: a pure torque (vocabulary: body_wrench
#: "or torque_Nm for a pure torque").
PRIMARY_IF_ZERO = {"body_wrench": "torque_Nm"}
#: Secondary parameters compared where both sides give them (angles: error in degrees).
ANGLES = ("direction_deg", "uphill_direction_deg")
PARAM_TOLERANCE = 0.25
CLEAN_RATIO_TARGET = 1.25
#: the CLI of the package in the tree this harness lives in (``_env`` puts that tree first on the
#: path; ``-P``: the working directory is not put before it, as ``-m`` would otherwise do)
CLI = [sys.executable, "-P", "-m", "littledog_mlsim.cli"]
ROOT = Path(__file__).resolve().parents[3]


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([env["PYTHONPATH"]]
                                                       if env.get("PYTHONPATH") else []))
    return env


@dataclass
class Dataset:
    name: str
    path: Path
    seed: int
    excitation: float
    effects: Path | None = None
    robot: Path | None = None          # a twin file recorded with; its identity is removed
    diag_seconds: float | None = None
    report: dict[str, Any] | None = field(default=None, repr=False)


def _run(cmd: list[str], log: Path) -> float:
    t0 = time.perf_counter()
    log.parent.mkdir(parents=True, exist_ok=True)
    with open(log, "w") as f:
        f.write(" ".join(cmd) + "\n")
        f.flush()
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, env=_env())
    if r.returncode != 0:
        tail = log.read_text().strip().splitlines()[-1:]
        raise RuntimeError(f"{' '.join(cmd[2:4])} failed ({log}): {tail}")
    return time.perf_counter() - t0


def record(ds: Dataset, moves: int, jobs: int, logs: Path, extra: Sequence[str] = ()) -> None:
    """Record ``ds`` unless it is there; ``extra``: further ``record`` arguments, kept beside
    the dataset (``NAME.record_args``) so that a dataset recorded with others is never reused."""
    args_file = ds.path.with_name(ds.path.name + ".record_args")
    if (ds.path / "dataset.yaml").is_file():
        was = args_file.read_text().split("\n")[:-1] if args_file.is_file() else []
        if was != list(extra):
            raise SystemExit(f"{ds.path} was recorded with record arguments {was}, not "
                             f"{list(extra)}: give another --work")
        return
    cmd = CLI + ["record", "--out", str(ds.path), "--moves-per-type", str(moves), "--seed",
                 str(ds.seed), "--jobs", str(jobs), "--quiet", *extra]
    if ds.excitation:
        cmd += ["--excitation", f"{ds.excitation:g}"]
    if ds.effects is not None:
        cmd += ["--effects", str(ds.effects)]
    if ds.robot is not None:
        cmd += ["--robot", str(ds.robot)]
    _run(cmd, logs / f"record_{ds.name}.log")
    args_file.write_text("".join(f"{x}\n" for x in extra))
    if ds.robot is not None:
        forget_robot(ds.path)


#: what ``dataset.yaml`` says about the robot that recorded it (``robot.twin.robot_source``)
ROBOT_KEYS = ("robot", "twin", "robot_config")


def forget_robot(path: Path) -> None:
    """Remove the recording robot's identity from the dataset at ``path``, as an imported
    recording of a real robot has none: the diagnosis gets a gap robot only as recordings."""
    index = path / "dataset.yaml"
    doc = yaml.safe_load(index.read_text())
    info = doc.get("info") or {}
    for k in ROBOT_KEYS:
        info.pop(k, None)
    tmp = index.with_name(index.name + ".tmp")
    tmp.write_text(yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    os.replace(tmp, index)


def diagnose(ds: Dataset, work: Path, extra: list[str], logs: Path, arm: str = "") -> None:
    out = work / ("diag" + (f"_{arm}" if arm else "")) / ds.name
    report = out / "report.json"
    if not report.is_file():
        cmd = CLI + ["diagnose", "--data", str(ds.path), "--out", str(out)] + extra
        t0 = time.perf_counter()
        try:
            ds.diag_seconds = _run(cmd, logs / f"diagnose{'_' + arm if arm else ''}_{ds.name}.log")
        except RuntimeError as exc:          # a failed diagnosis is a result, not a stop
            ds.diag_seconds = time.perf_counter() - t0
            ds.report = {"error": str(exc), "significant": False, "effects": []}
            return
        (out / "seconds.txt").write_text(f"{ds.diag_seconds:.1f}\n")
    elif (out / "seconds.txt").is_file():
        ds.diag_seconds = float((out / "seconds.txt").read_text())
    ds.report = json.loads(report.read_text())


def _first_rollout(stage: dict[str, Any] | None) -> tuple[str | None, float | None]:
    roll = (stage or {}).get("rollout") or {}
    for label, r in roll.items():
        if isinstance(r, dict) and r.get("final_xy_error_m") is not None:
            return label, float(r["final_xy_error_m"])
    return None, None


def errors(report: dict[str, Any]) -> dict[str, Any]:
    label, before = _first_rollout(report.get("before"))
    _, after = _first_rollout(report.get("after"))
    return {"projection": label,
            "onestep_before": report.get("before", {}).get("nmse_mean"),
            "onestep_after": report.get("after", {}).get("nmse_mean"),
            "rollout_before": before, "rollout_after": after}


def _angle_err(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def named_effects(report: dict[str, Any]) -> list[dict[str, Any]]:
    """Every effect the report names in the vocabulary: the physical route's
    ``effects[*].physical``, the learned route's ``vocabulary`` blocks (one-step loop and
    rollout route), the rollout route's unexplained change since the reference where it is
    significant (family ``other``), its change since the reference read through the
    reference's model where it is named (decision 027), its push confirmed by the drift
    against the reference where named (decision 037), the physical route's excess over the
    reference that its findings leave where named (family ``other``, decision 047), and the
    sensor-timing check's where it found a shift (either route)."""
    out = []
    for e in report.get("effects", []):
        p = e.get("physical") or {}
        out.append(p if "family" in p else (e.get("vocabulary") or {}))
    left = ((report.get("physics") or {}).get("reference") or {}).get("unexplained") or {}
    if left.get("named"):
        out.append(left.get("vocabulary") or {})
    for e in (report.get("rollout_route") or {}).get("effects", []):
        out.append(e.get("vocabulary") or {})
    change = (report.get("rollout_route") or {}).get("unexplained_change") or {}
    if change.get("significant"):
        out.append(change.get("vocabulary") or {})
    carried = (report.get("rollout_route") or {}).get("reference_change") or {}
    if carried.get("named"):
        out.append(carried.get("vocabulary") or {})
    pushed = (report.get("rollout_route") or {}).get("drift_change") or {}
    if pushed.get("named"):
        out.append(pushed.get("vocabulary") or {})
    for check in ("timing", "held_frames"):
        c = report.get(check) or {}
        if c.get("significant"):
            out.append(c.get("vocabulary") or {})
    return [p for p in out if p]


def significant(report: dict[str, Any]) -> bool:
    return bool(report.get("significant")
                or (report.get("rollout_route") or {}).get("significant")
                or (report.get("timing") or {}).get("significant")
                or (report.get("held_frames") or {}).get("significant"))


def score(truth: dict[str, Any], report: dict[str, Any]) -> dict[str, Any]:
    fam, scope = truth["family"], truth["scope"]
    named = named_effects(report)
    out: dict[str, Any] = {
        "named": [{"family": p.get("family"), "scope": p.get("scope"), "params": p.get("params"),
                   "statement": p.get("statement")} for p in named],
        "family_right": any(p.get("family") == fam for p in named),
        "scope_right": any(p.get("scope") == scope for p in named),
    }
    match = [p for p in named if p.get("family") == fam and p.get("scope") == scope]
    out["found"] = bool(match) and significant(report)
    out["param_error"] = None
    out["angle_error_deg"] = None
    key = PRIMARY.get(fam)
    true_v = (truth.get("params") or {}).get(key) if key else None
    if true_v in (None, 0) and fam in PRIMARY_IF_ZERO:
        key = PRIMARY_IF_ZERO[fam]
        true_v = (truth.get("params") or {}).get(key)
    if match and key and true_v not in (None, 0):
        est = (match[0].get("params") or {}).get(key)
        if isinstance(est, (int, float)):
            out["param_error"] = abs(float(est) / float(true_v) - 1.0)
        for a in ANGLES:
            t, e = (truth.get("params") or {}).get(a), (match[0].get("params") or {}).get(a)
            if isinstance(t, (int, float)) and isinstance(e, (int, float)):
                out["angle_error_deg"] = _angle_err(float(e), float(t))
    out["identified"] = bool(out["found"] and out["param_error"] is not None
                             and out["param_error"] <= PARAM_TOLERANCE)
    out["suspected"] = report.get("suspected") or []
    # the truth named as a rival the report says these data cannot tell from its finding
    rivals = [s_ for s_ in out["suspected"] if s_.get("kind") == "inseparable"]
    out["found_or_inseparable"] = bool(out["found"] or (
        significant(report) and any(s_.get("family") == fam and s_.get("scope") == scope
                                          for s_ in rivals)))
    return out


def recommended_excitation(report: dict[str, Any]) -> float | None:
    for s in report.get("suspected") or []:
        m = re.search(r"--excitation[ =]([0-9.eE+-]+)", str(s.get("recording", "")))
        if m:
            return float(m.group(1))
    return None


#: the ``record`` arguments a report's recommended recording may name, and their tags
RECORD_ARGS = {"--excitation": "e", "--start-spread": "spread"}


def _record_args(text: str) -> dict[str, float]:
    """The ``record`` arguments of :data:`RECORD_ARGS` a recommendation's text names."""
    out = {}
    for arg in RECORD_ARGS:
        m = re.search(re.escape(arg) + r"[ =]([0-9.eE+-]+)", text)
        if m:
            out[arg] = float(m.group(1).rstrip("."))
    return out


def recommended_recording(report: dict[str, Any]) -> dict[str, Any] | None:
    """The recording a report asks for, or None: ``{"what": "reference" | "both", "args":
    {record argument: value}, "why": the report's words}``.

    In this order: a reference recorded under other conditions than the data (the reference
    again, under the data's: ``reference_conditions.recording``, which a physical report also
    carries from decision 052 on); else, on the learned route, the first of the
    rollout route's unexplained change, its suspected findings and the one-step loop's
    suspected findings whose recording names a ``record`` argument (the data and the
    reference again, both with it)."""
    cond = str((report.get("reference_conditions") or {}).get("recording") or "")
    if _record_args(cond):
        return {"what": "reference", "args": _record_args(cond), "why": cond}
    rr = report.get("rollout_route") or {}
    texts = [(rr.get("unexplained_change") or {}).get("recording")]
    texts += [s.get("recording") for s in rr.get("suspected") or [] if isinstance(s, dict)]
    texts += [s.get("recording") for s in report.get("suspected") or [] if isinstance(s, dict)]
    for t in texts:
        if t and _record_args(str(t)):
            return {"what": "both", "args": _record_args(str(t)), "why": str(t)}
    return None


def follow_up_tag(args: dict[str, float]) -> str:
    """A dataset-name suffix for a recording made with ``args``: ``_e0.05``, ``_spread0.5``."""
    return "".join(f"_{RECORD_ARGS[k]}{v:g}" for k, v in sorted(args.items()))


def _fmt(x: Any, f: str = ".4g") -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, float):
        return format(x, f)
    return str(x)


def _named(s: dict[str, Any]) -> str:
    parts = []
    for p in s["named"]:
        params = ", ".join(f"{k}={_fmt(v, '.3g') if isinstance(v, float) else v}"
                           for k, v in (p.get("params") or {}).items())
        parts.append(f"{p.get('family')} @ {p.get('scope')} ({params})")
    return "; ".join(parts) or "nothing"


def markdown(rows: list[dict[str, Any]], clean: list[dict[str, Any]], summary: dict) -> str:
    h = ["| effect | truth (family @ scope: primary) | exc. | found | family / scope right | "
         "named by the diagnosis | or named as inseparable | param error | one-step nMSE before -> after (clean) | "
         "rollout final (x,y) [m] before -> after (clean) | after / clean | diagnose [s] |",
         "|" + "---|" * 12]
    for r in rows:
        t, s, e, c = r["truth"], r["score"], r["errors"], r["clean"]
        key = PRIMARY.get(t["family"])
        tv = (t.get("params") or {}).get(key) if key else None
        ratio = (e["rollout_after"] / c["rollout_before"]
                 if e["rollout_after"] is not None and c["rollout_before"] else None)
        h.append(
            f"| {r['id']} | {t['family']} @ {t['scope']}: {key}={_fmt(tv)} | "
            f"{_fmt(r['excitation'], 'g')} | {_fmt(s['found'])} | "
            f"{_fmt(s['family_right'])} / {_fmt(s['scope_right'])} | {_named(s)} | "
            f"{_fmt(s.get('found_or_inseparable'))} | "
            f"{_fmt(s['param_error'], '.0%')} | {_fmt(e['onestep_before'])} -> "
            f"{_fmt(e['onestep_after'])} ({_fmt(c['onestep_before'])}) | "
            f"{_fmt(e['rollout_before'])} -> {_fmt(e['rollout_after'])} "
            f"({_fmt(c['rollout_before'])}) | {_fmt(ratio, '.2f')} | {_fmt(r['seconds'], '.0f')} |")
    h += ["", "| clean dataset | seed | excitation | significant (false alarm) | named | "
          "diagnose [s] |", "|---|---|---|---|---|---|"]
    for c in clean:
        h.append(f"| {c['name']} | {c['seed']} | {_fmt(c['excitation'], 'g')} | "
                 f"{_fmt(c['significant'])} | "
                 f"{'stopped with an error' if c.get('error') else c['named']} | "
                 f"{_fmt(c['seconds'], '.0f')} |")
    h += ["", "Summary: " + "; ".join(f"{k} {_fmt(v, '.3g')}" for k, v in summary.items())]
    return "\n".join(h) + "\n"


#: the arms of a gap zoo (zoo8's runs/run1/RULE.md): diagnose arguments; "calibrated" adds
#: ``--twin`` with the twin ``calibrate`` fits on the reference, "calibrated+reference" (not an
#: arm of zoo8's rule) that twin and the reference
ARMS = {
    "learned": ["--physics", "off", "--rollout-route"],
    "learned+reference": ["--physics", "off", "--rollout-route", "--reference", "{reference}"],
    "nominal+reference": ["--twin", "nominal", "--reference", "{reference}"],
    "nominal": ["--twin", "nominal"],
    "calibrated": ["--twin", "{twin}"],
    "calibrated+reference": ["--twin", "{twin}", "--reference", "{reference}"],
}


def twin_slug(calibrate_args: list[str]) -> str:
    """The calibrated twin's file and report suffix for extra calibrate arguments: "" for
    none (``calibrated_twin.json``), else ``_servo_auto`` for ``--servo auto``, ..."""
    return "".join("_" + re.sub(r"[^A-Za-z0-9]+", "_", x).strip("_") for x in calibrate_args)


def arm_arguments(arm: str | None, reference: Dataset | None, work: Path, logs: Path,
                  calibrate_args: list[str] = ()) -> tuple[list[str], dict[str, Any] | None]:
    """(diagnose arguments of ``arm``, the calibration's record or None); the calibrated arm
    runs ``calibrate --data REFERENCE --robot nominal [calibrate_args]`` first (once per set of
    arguments: its twin is reused)."""
    if arm is None:
        return [], None
    args = ["--no-figures", "--jobs", "2"]
    calibration = None
    if any("{reference}" in x or "{twin}" in x for x in ARMS[arm]) and reference is None:
        raise SystemExit(f"--arm {arm} needs --reference-seed")
    fill = {"reference": str(reference.path) if reference else ""}
    if arm.startswith("calibrated"):
        slug = twin_slug(list(calibrate_args))
        twin = work / f"calibrated_twin{slug}.json"
        seconds_file = work / f"calibrated_twin{slug}.seconds"
        if not twin.is_file():
            secs = _run(CLI + ["calibrate", "--data", str(reference.path), "--robot", "nominal",
                               "--out", str(twin), *calibrate_args],
                        logs / f"calibrate{slug}.log")
            seconds_file.write_text(f"{secs:.1f}\n")
        fill["twin"] = str(twin)
        calibration = {"twin": str(twin), "seconds": float(seconds_file.read_text())
                       if seconds_file.is_file() else None}
    return args + [x.format(**fill) for x in ARMS[arm]], calibration


def learned_summary(truth: list[dict[str, Any]], rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The no-twin arm's count: found over the effects whose cause is not among a learned
    model's inputs (``learned_inputs: false``); the others are right when the report names
    them or nothing for them (a model trained on the data carries them)."""
    out_of = [r for t, r in zip(truth, rows) if not t.get("learned_inputs", False)]
    carried = [r for t, r in zip(truth, rows) if t.get("learned_inputs", False)]
    return {"learned: effects outside the model's inputs": len(out_of),
            "learned: found among them": sum(r["score"]["found"] for r in out_of),
            "learned: found fraction": (sum(r["score"]["found"] for r in out_of) / len(out_of)
                                        if out_of else None),
            "learned: carried by the model (right if named or nothing named)": sum(
                r["score"]["found"] or not r["score"]["named"] for r in carried),
            "learned: carried effects": len(carried)}


def weighing(robot: Path, resolution: float) -> float:
    """The gap robot on a scale that reads to ``resolution`` kg: its total mass, rounded (the
    only number of the gap robot the calibration gets)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
    from littledog_mlsim.robot.parameters import total_mass
    from littledog_mlsim.robot.twin import load_twin
    return round(total_mass(load_twin(robot).robot) / resolution) * resolution


def calibration_score(calibration: dict[str, Any], robot: Path | None) -> dict[str, Any]:
    """Each calibrated parameter against the gap robot's true value (read only here, after
    every diagnosis): inside its 95 % interval or not; identifiable = not at a bound and in no
    weak direction. A friction coefficient fitted without the other is scored as the contact's
    (Bullet multiplies the foot's and the floor's): its value and interval times the twin's
    other coefficient against the truth's product (``scored_as``)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
    from littledog_mlsim.robot.parameters import TWIN_PARAMETERS, twin_parameters
    from littledog_mlsim.robot.twin import load_twin
    twin = load_twin(calibration["twin"])
    truth = load_twin(robot).robot if robot is not None else None
    params = twin.provenance.get("parameters", {})
    cal = twin.provenance.get("calibration", {})
    # a parameter takes part in a weak direction with a coefficient of 0.1 or more (as
    # calibrate's own rule for intervals); the combination lists every parameter
    weak = {n for w in cal.get("weak_directions", [])
            for n, c in (w.get("combination") or {}).items() if abs(c) >= 0.1}
    rows = []
    for name, p in params.items():
        try:       # a parameter of the other servo model has no true value in the truth
            true_v = (twin_parameters([name], truth)[0].get(truth) if truth is not None
                      else None)
        except ValueError:
            true_v = None
        lo, hi = p["ci95"]
        value, scored_as = p["value"], name
        # a coefficient with one other name (the friction pair, parameters.py's same_as)
        same = TWIN_PARAMETERS[name].same_as if name in TWIN_PARAMETERS else ()
        other = same[0] if len(same) == 1 else None
        if other is not None and other not in params and true_v is not None:
            k = getattr(twin.robot, other)
            value, lo, hi = (None if v is None else v * k for v in (value, lo, hi))
            true_v, scored_as = true_v * getattr(truth, other), "contact_friction"
        ident = p.get("at_bound") is None and name not in weak
        rows.append({"name": name, "scored_as": scored_as, "value": value, "ci95": [lo, hi],
                     "truth": true_v,
                     "inside": (None if true_v is None or lo is None or hi is None
                                else bool(lo <= true_v <= hi)),
                     "at_bound": p.get("at_bound"), "identifiable": ident,
                     "rel_error": None if not true_v else abs(value / true_v - 1.0)})
    idf = [r for r in rows if r["identifiable"] and r["inside"] is not None]
    return {"seconds": calibration["seconds"], "rows": rows,
            "rollout": cal.get("rollout"),
            "summary": f"{sum(r['inside'] for r in idf)} of {len(idf)}"}


def clean_row(d: Dataset) -> dict[str, Any]:
    """A clean dataset's row: whether its diagnosis raised an alarm, and what it named."""
    return {"name": d.name, "seed": d.seed, "excitation": d.excitation,
            "significant": significant(d.report),
            "named": _named(score({"family": "", "scope": ""}, d.report)),
            "error": d.report.get("error"), "seconds": d.diag_seconds}


def follow_recordings(truth: list[dict[str, Any]], effect_sets: list[Dataset],
                      a: argparse.Namespace, work: Path, logs: Path, robot: Path | None,
                      reference: Dataset | None) -> tuple[list[dict[str, Any]], list[Dataset]]:
    """The loop closed by the learned route's own advice (``--follow-recordings``): for each
    effect not found whose report asks for a recording (:func:`recommended_recording`), record
    it (the effect under the conditions asked for, the reference and the clean seed under the
    same; each recording made once and shared), diagnose the effect and the clean seed against
    that reference, and return the effect rows ``(recommended recording)`` and the clean
    datasets diagnosed."""
    if reference is None or not (a.arm or "").endswith("+reference"):
        raise SystemExit("--follow-recordings needs an arm with a reference (--reference-seed)")

    def at(stem: str, folder: Path, seed: int, cond: dict[str, float],
           effects: Path | None) -> tuple[Dataset, list[str]]:
        tag = follow_up_tag(cond)
        spread = cond.get("--start-spread")
        extra = list(a.record_arg) + (["--start-spread", f"{spread:g}"] if spread else [])
        return (Dataset(stem + tag, folder / (stem + tag), seed,
                        cond.get("--excitation", 0.0), effects, robot), extra)

    plans = []
    for t, ds in zip(truth, effect_sets):
        if score(t, ds.report)["found"]:
            continue
        rec = recommended_recording(ds.report)
        if rec is None:
            continue
        data = {"--excitation": ds.excitation} if ds.excitation else {}
        if rec["what"] == "reference":
            eff, ref = data, {k: v for k, v in {**data, **rec["args"]}.items() if v}
        else:
            eff = {k: v for k, v in {**data, **rec["args"]}.items() if v}
            ref = eff
        if eff == data and not ref:
            continue                      # it asks for what the run already has
        plans.append((t, ds, data, eff, ref, rec))
    rows, cleans, made = [], [], set()
    jobs: list[tuple[Dataset, list[str]]] = []
    for t, ds, data, eff, ref, rec in plans:
        if eff == data:                   # the data as they are (the reference again)
            e_ds, e_rec = ds, list(a.record_arg)
            made.add(ds.path)
        else:
            e_ds, e_rec = at(t["id"], work / "effects", ds.seed, eff, ds.effects)
        r_ds, r_rec = at("reference", work, reference.seed, ref, None)
        c_ds, c_rec = at(f"s{ds.seed}", work / "clean", ds.seed, eff, None)
        for d, x in ((e_ds, e_rec), (r_ds, r_rec), (c_ds, c_rec)):
            if d.path not in made:
                print(f"record {d.path.name} (follow-up)", flush=True)
                record(d, a.moves_per_type, 2, logs, x)
                made.add(d.path)
        ref_tag = follow_up_tag(ref) or "_plain"
        extra = arm_arguments(a.arm, r_ds, work, logs)[0] + a.diagnose_arg
        e_run = Dataset(f"{t['id']}{follow_up_tag(eff)}_ref{ref_tag}", e_ds.path, e_ds.seed,
                        e_ds.excitation, e_ds.effects, robot)
        c_run = Dataset(f"clean_{c_ds.name}_ref{ref_tag}", c_ds.path, c_ds.seed,
                        c_ds.excitation, None, robot)
        jobs.append((e_run, extra))
        if c_run.name not in {c.name for c in cleans}:
            jobs.append((c_run, extra))
            cleans.append(c_run)
        rows.append((t, ds, e_run, c_run, eff, ref, rec))
    arm_tag = a.arm or ""

    def run(job: tuple[Dataset, list[str]]) -> None:
        d, extra = job
        diagnose(d, work, extra, logs, arm_tag)
        print(f"diagnosed {d.name} in {_fmt(d.diag_seconds, '.0f')} s", flush=True)

    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        list(pool.map(run, jobs))
    by_name = {c.name: c for c in cleans}
    out = []
    for t, ds, e_run, c_run, eff, ref, rec in rows:
        out.append({"id": f"{t['id']} (recommended recording)",
                    "truth": {k: t.get(k) for k in ("family", "scope", "params",
                                                    "description")},
                    "excitation": e_run.excitation, "score": score(t, e_run.report),
                    "errors": errors(e_run.report), "clean": errors(by_name[c_run.name].report),
                    "seconds": e_run.diag_seconds,
                    "recording": {"asked": rec["why"], "data": eff, "reference": ref,
                                  "dataset": e_run.path.name, "diagnosis": e_run.name}})
    return out, cleans


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--zoo", required=True,
                    help="directory with truth.yaml and the effect files (in effects/ or beside it)")
    ap.add_argument("--work", required=True, help="where datasets and reports go")
    ap.add_argument("--out", required=True, help="results directory (results.json, table.md)")
    ap.add_argument("--moves-per-type", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1, help="seed of every effect dataset")
    ap.add_argument("--clean-seeds", default="1,2,3", help="clean seeds without excitation")
    ap.add_argument("--clean-seeds-excited", default="1",
                    help="clean seeds under each excitation the zoo uses (the effect seed "
                         "is needed for the clean reference)")
    ap.add_argument("--clean-excitation", type=float, action="append", default=[],
                    metavar="RAD",
                    help="also record and diagnose --clean-seeds-excited under this command "
                         "excitation where no effect uses it (repeatable): a clean run the "
                         "rule asks for whatever the zoo's effects are")
    ap.add_argument("--jobs", type=int, default=2, help="diagnoses run side by side")
    ap.add_argument("--only", default="", help="comma-separated effect ids (default: all)")
    ap.add_argument("--record-only", action="store_true",
                    help="only record the datasets (they are reused by a later run)")
    ap.add_argument("--no-follow-up", action="store_true",
                    help="do not make the recordings the reports recommend")
    ap.add_argument("--follow-recordings", action="store_true",
                    help="arm learned+reference: where an effect was not found and its report "
                         "asks for a recording (the reference under the data's conditions, "
                         "moves from spread starts, command excitation), make it, with the "
                         "reference and a clean seed under the same conditions, and diagnose "
                         "again (rows '(recommended recording)'); the first pass is unchanged")
    ap.add_argument("--record-arg", action="append", default=[],
                    help="an argument added to every `record` (repeat for each, e.g. "
                         "--record-arg=--start-spread --record-arg=0.5)")
    ap.add_argument("--diagnose-arg", action="append", default=[],
                    help="extra argument for every diagnose run (repeatable)")
    ap.add_argument("--robot", default=None, metavar="TWIN.json",
                    help="record every dataset with this twin file (relative: to the zoo), then "
                         "remove the robot's identity from each dataset.yaml (a gap robot)")
    ap.add_argument("--reference-seed", type=int, default=None,
                    help="also record a clean reference dataset of this seed (reference/)")
    ap.add_argument("--arm", choices=sorted(ARMS), default=None,
                    help="diagnose in this arm (zoo8's RULE.md): its arguments are added, "
                         "reports go to WORK/diag_ARM")
    ap.add_argument("--calibrate-arg", action="append", default=[],
                    help="extra argument for the calibrated arm's calibrate (repeatable, e.g. "
                         "--calibrate-arg=--servo --calibrate-arg=auto); its twin and reports "
                         "get their own names")
    ap.add_argument("--weigh", type=float, default=None, metavar="KG",
                    help="weigh the gap robot (--robot) on a scale that reads to KG: its total "
                         "mass rounded to KG is given to calibrate as --weighed-mass, with "
                         "--weighed-mass-sd KG")
    ap.add_argument("--calibrate-only", action="store_true",
                    help="arm calibrated: calibrate and score the twin, diagnose nothing")
    a = ap.parse_args(argv)
    zoo, work, out = Path(a.zoo), Path(a.work), Path(a.out)
    logs = work / "logs"
    truth = yaml.safe_load((zoo / "truth.yaml").read_text())
    if isinstance(truth, dict):
        truth = truth.get("effects", truth)
    only = {s for s in a.only.split(",") if s}
    truth = [t for t in truth if not only or t["id"] in only]
    t_start = time.time()

    files = zoo / "effects" if (zoo / "effects").is_dir() else zoo
    robot = None if a.robot is None else (zoo / a.robot if not Path(a.robot).is_absolute()
                                          else Path(a.robot)).resolve()
    effect_sets = [Dataset(t["id"], work / "effects" / t["id"], a.seed,
                           float((t.get("recording") or {}).get("excitation", 0.0)),
                           (files / t.get("file", f"{t['id']}.yaml")).resolve(), robot)
                   for t in truth]
    if any(not (0 < e < float("inf")) for e in a.clean_excitation):
        raise SystemExit("--clean-excitation RAD must be a positive number")
    excitations = sorted({0.0} | {d.excitation for d in effect_sets} | set(a.clean_excitation))
    clean_sets = [Dataset(f"clean_s{s}_e{e:g}", work / "clean" / f"s{s}_e{e:g}", s, e,
                          robot=robot)
                  for e in excitations
                  for s in (int(x) for x in (a.clean_seeds if e == 0 else
                                             a.clean_seeds_excited).split(","))]
    reference = (None if a.reference_seed is None else
                 Dataset("reference", work / "reference", a.reference_seed, 0.0, robot=robot))
    # --calibrate-only needs the reference alone
    for ds in ([] if a.calibrate_only else clean_sets + effect_sets) + (
            [reference] if reference else []):
        print(f"record {ds.name}", flush=True)
        record(ds, a.moves_per_type, 2, logs, a.record_arg)
    if a.record_only:
        return 0
    if a.weigh is not None:
        if robot is None or not (a.arm or "").startswith("calibrated") or not a.weigh > 0:
            raise SystemExit("--weigh KG (> 0) weighs the gap robot (--robot) for the calibrated "
                             "arm")
        a.calibrate_arg += ["--weighed-mass", f"{weighing(robot, a.weigh):g}",
                            "--weighed-mass-sd", f"{a.weigh:g}"]
    arm_args, calibration = arm_arguments(a.arm, reference, work, logs, a.calibrate_arg)
    extra = arm_args + a.diagnose_arg
    if a.calibrate_arg and not (a.arm or "").startswith("calibrated"):
        raise SystemExit("--calibrate-arg is for --arm calibrated or calibrated+reference")
    arm_tag = (a.arm or "") + twin_slug(a.calibrate_arg)
    if a.calibrate_only:
        if calibration is None:
            raise SystemExit("--calibrate-only needs --arm calibrated or calibrated+reference")
        out.mkdir(parents=True, exist_ok=True)
        doc = {"command": "OPENBLAS_NUM_THREADS=%s .venv/bin/python %s" % (
                   os.environ.get("OPENBLAS_NUM_THREADS"), " ".join(sys.argv)),
               "code": git_state(), "load_average": os.getloadavg(),
               "calibration": calibration_score(calibration, robot)}
        (out / "calibration.json").write_text(json.dumps(doc, indent=1, default=str) + "\n")
        print(json.dumps(doc["calibration"], indent=1, default=str))
        return 0

    def run(ds: Dataset) -> Dataset:
        diagnose(ds, work, extra, logs, arm_tag)
        print(f"diagnosed {ds.name} in {_fmt(ds.diag_seconds, '.0f')} s", flush=True)
        return ds

    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        list(pool.map(run, clean_sets + effect_sets))

    clean_by = {(d.seed, d.excitation): d for d in clean_sets}
    rows = []
    follow = []
    for t, ds in zip(truth, effect_sets):
        s = score(t, ds.report)
        c = errors(clean_by[(ds.seed, ds.excitation)].report)
        rows.append({"id": t["id"], "truth": {k: t.get(k) for k in ("family", "scope", "params",
                                                                    "description")},
                     "excitation": ds.excitation, "score": s, "errors": errors(ds.report),
                     "clean": c, "seconds": ds.diag_seconds})
        exc = recommended_excitation(ds.report)
        if not s["found"] and exc and exc != ds.excitation and not a.no_follow_up:
            follow.append((t, Dataset(f"{t['id']}_e{exc:g}", work / "effects" / f"{t['id']}_e{exc:g}",
                                      a.seed, exc, ds.effects)))
    # the loop closed by the report's advice: record what it asks for, diagnose again
    for t, ds in follow:
        record(ds, a.moves_per_type, 2, logs, a.record_arg)
        key = (ds.seed, ds.excitation)
        if key not in clean_by:
            cd = Dataset(f"clean_s{ds.seed}_e{ds.excitation:g}",
                         work / "clean" / f"s{ds.seed}_e{ds.excitation:g}", ds.seed, ds.excitation,
                         robot=robot)
            record(cd, a.moves_per_type, 2, logs, a.record_arg)
            clean_by[key] = cd
            clean_sets.append(cd)
    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        list(pool.map(run, [ds for _, ds in follow] +
                      [c for c in clean_sets if c.report is None]))
    for t, ds in follow:
        s = score(t, ds.report)
        rows.append({"id": f"{t['id']} (recommended recording)",
                     "truth": {k: t.get(k) for k in ("family", "scope", "params", "description")},
                     "excitation": ds.excitation, "score": s, "errors": errors(ds.report),
                     "clean": errors(clean_by[(ds.seed, ds.excitation)].report),
                     "seconds": ds.diag_seconds})
    followed_clean: list[Dataset] = []
    if a.follow_recordings:
        rows_f, followed_clean = follow_recordings(
            truth, effect_sets, a, work, logs, robot, reference)
        rows += rows_f

    clean = [clean_row(d) for d in clean_sets]
    clean_followed = [{**clean_row(d), "follow_up": True} for d in followed_clean]
    first = [r for r in rows if "(recommended" not in r["id"]]
    n = len(first)
    ratios = [r["errors"]["rollout_after"] / r["clean"]["rollout_before"] for r in first
              if r["score"]["found"] and r["errors"]["rollout_after"] is not None
              and r["clean"]["rollout_before"]]
    times = [d.diag_seconds for d in effect_sets + clean_sets if d.diag_seconds]
    summary = {
        "effects": n,
        "found (family and scope)": sum(r["score"]["found"] for r in first),
        "found, or named as a rival the data cannot tell apart": sum(
            r["score"].get("found_or_inseparable", False) for r in first),
        "identified (found, parameter within 25 %)": sum(r["score"]["identified"] for r in first),
        "identified fraction": (sum(r["score"]["identified"] for r in first) / n) if n else None,
        # beside the target, not instead of it: an effect outside the vocabulary has no
        # parameter to size, so it is never identified; this count takes it as identified when
        # found (named other at its scope)
        "identified or, outside the vocabulary, found": sum(
            r["score"]["identified"] or (r["truth"]["family"] == "other" and r["score"]["found"])
            for r in first),
        "found after the recommended recording": sum(r["score"]["found"] for r in rows
                                                     if "(recommended" in r["id"]),
        "found with rollout after <= 1.25x clean": sum(x <= CLEAN_RATIO_TARGET for x in ratios),
        "found with a rollout ratio": len(ratios),
        "false alarms": sum(c["significant"] for c in clean),
        "clean runs": len(clean),
        "clean runs that stopped with an error (neither alarm nor pass)": sum(
            bool(c["error"]) for c in clean),
        "diagnose seconds max": max(times) if times else None,
    }
    if a.follow_recordings:
        summary.update({
            "follow-up: effects re-diagnosed with the recording their report asked for": sum(
                "(recommended" in r["id"] for r in rows),
            "follow-up: found among them": sum(r["score"]["found"] for r in rows
                                               if "(recommended" in r["id"]),
            "follow-up: clean runs under those conditions": len(clean_followed),
            "follow-up: false alarms among them": sum(c["significant"] for c in clean_followed)})
    out.mkdir(parents=True, exist_ok=True)
    doc = {"command": "OPENBLAS_NUM_THREADS=%s .venv/bin/python %s" % (
               os.environ.get("OPENBLAS_NUM_THREADS"), " ".join(sys.argv)), "started": time.strftime("%Y-%m-%d %H:%M:%S UTC",
                                                               time.gmtime(t_start)),
           "wall_seconds": time.time() - t_start, "load_average": os.getloadavg(),
           "code": git_state(),
           "moves_per_type": a.moves_per_type, "seed": a.seed, "clean_seeds": a.clean_seeds,
           "diagnose_args": extra, "record_args": a.record_arg, "arm": a.arm,
           "summary": summary, "rows": rows,
           "clean": clean, "clean_follow_up": clean_followed}
    if (a.arm or "").startswith("learned"):
        summary.update(learned_summary(truth, first))
    if calibration is not None:
        doc["calibration"] = calibration_score(calibration, robot)
        summary["calibrate: inside the 95 % interval (identifiable)"] = \
            doc["calibration"]["summary"]
    (out / "results.json").write_text(json.dumps(doc, indent=1, default=str) + "\n")
    (out / "table.md").write_text(markdown(rows, clean + clean_followed, summary))
    print(markdown(rows, clean + clean_followed, summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
