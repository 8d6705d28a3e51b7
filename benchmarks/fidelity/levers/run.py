"""Model-input and data levers against the fidelity targets: each lever's LGPR under the same
schedules and seeds.

For each lever (``--levers``) this trains an LGPR on the dataset's TrainPool with that feature
set (the paper's 45 inputs plus the lever's augmentations, ``models.feature_library``), then
runs ``fidelity.py open-loop --scenarios straight`` (the 60 s straight trot) and ``fidelity.py
closed-loop --controllers velocity`` (the PI velocity tracker) with the gated alpha-PROJ
(``lgpr-gated``) on ``--seeds``, and tabulates gap / path (median and worst seed), the final
yaw error and the learned path. The levers:

- ``paper``: the paper's 45 inputs (the baseline);
- ``measured``: ``train --features measured`` (the previous state as well);
- ``command_increment``: u_t - u_{t-1} of every joint (the set-points' rate, which carries the
  commanded turn of the feet);
- ``command_lag8``: u_{t-8} of every joint (the set-points about a quarter gait period ago).

Model levers (the paper's inputs): ``blend`` (each query blends the 2 nearest local GPs,
``train --blend``: the paper's own suggestion that a point may belong to several clusters);
``dad`` (one round of Data as Demonstrator, ``train --dad 1``: the model's own rollouts over
the TrainPool added with the recorded next states as targets).

A lever ``A+B`` combines levers: at most one data lever and one input lever, with any model
levers (for example ``varied+command_increment``).

Data levers (the paper's 45 inputs, trained on a dataset ``record --extra`` makes: the same
seed, robot and plain moves as ``--data``, plus TrainPool moves of other kinds,
``littledog_mlsim.control.moves``; recorded into WORK once and reused):

- ``more_trots``: 4 more constant trots per type (the control: as many more moves of the kind
  the data already has);
- ``switch``: 4 trots per type with a transition to another type within the move;
- ``varied``: 4 continuously varied trots per type;
- ``closed_loop``: 22 closed-loop runs of the velocity tracker and 22 of the waypoint follower
  (the DAgger-style lever: the controllers' own runs on the robot; references and waypoints
  drawn at random, not the benchmark's);
- ``all_kinds``: switch, varied and closed_loop together.

``--scenarios``/``--controllers`` choose the open-loop schedules and closed-loop controllers
(default: the straight trot and the velocity tracker); ``--testpool`` also scores each model's
4 s TestPool rollouts on ``--data``'s TestPool (``littledog-mlsim evaluate``'s gated alpha-PROJ,
the model's own radius).

``--configs`` chooses the learned simulators and projections (``fidelity.py``'s configurations;
default ``lgpr-gated``). An ``lr-*`` configuration runs a linear regression trained on the
lever's own data and inputs (``lr_LEVER`` in WORK); the model levers (``blend``, ``dad``) are
LGPR's, so their rows run the paper's LR (the LR of the lever's data and inputs without them).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/fidelity/levers/run.py \\
        --data bags/default --work WORK --out benchmarks/fidelity/levers/result
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from benchmarks._common import command_line, run_record, uptime, write_results  # noqa: E402

FEATURE_LEVERS = ("paper", "measured", "command_increment", "command_lag8")
DATA_LEVERS = {
    "more_trots": {"trot": 4},
    "switch": {"switch": 4},
    "varied": {"varied": 4},
    "closed_loop": {"velocity": 22, "waypoints": 22},
    "all_kinds": {"switch": 4, "varied": 4, "velocity": 22, "waypoints": 22},
}
MODEL_OPTIONS = {"blend": {"blend": True}}
DAD_ROUNDS = {"dad": 1}
LEVERS = FEATURE_LEVERS + tuple(MODEL_OPTIONS) + tuple(DAD_ROUNDS) + tuple(DATA_LEVERS)


def parts(lever: str) -> dict:
    """A lever or a combination ``A+B`` (at most one data lever and one input lever): {"data":
    data lever or None, "inputs": input lever or None, "options": model options, "dad":
    rounds}. SystemExit on a name that is none of them."""
    out = {"data": None, "inputs": None, "options": {}, "dad": 0}
    for part in lever.split("+"):
        if part not in LEVERS:
            raise SystemExit(f"unknown lever {part!r} in {lever!r}; expected {', '.join(LEVERS)}")
        if part in DATA_LEVERS or (part in FEATURE_LEVERS and part != "paper"):
            key = "data" if part in DATA_LEVERS else "inputs"
            if out[key]:
                raise SystemExit(f"{lever!r} combines two {key} levers")
            out[key] = part
        out["options"].update(MODEL_OPTIONS.get(part, {}))
        out["dad"] += DAD_ROUNDS.get(part, 0)
    return out


def _lever(text: str) -> str:
    parts(text)
    return text


def feature_set(lever: str):
    from littledog_mlsim.models.feature_library import CommandIncrement, CommandLag
    from littledog_mlsim.models.features import FeatureSet
    lever = parts(lever)["inputs"] or "paper"
    if lever == "paper":
        return None
    if lever == "measured":
        from littledog_mlsim.diagnose.candidates import measured_robot_features
        return measured_robot_features()
    if lever == "command_increment":
        return FeatureSet((CommandIncrement(lag=0, joints="all"),))
    if lever == "command_lag8":
        return FeatureSet((CommandLag(lag=8, joints="all"),))
    raise SystemExit(f"unknown lever {lever!r}")


def lever_data(lever: str, base: Path, work: Path) -> Path:
    """The dataset a lever trains on: ``base`` itself, or (data levers) a dataset recorded
    like it with the lever's extra moves, in WORK (reused when present)."""
    lever = parts(lever)["data"]
    if lever is None:
        return base
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import read_index
    out = work / f"data_{lever}"
    if not out.exists():
        info = read_index(base).info
        record_dataset(out, moves_per_type=int(info["moves_per_type"]),
                       types=list(info["types"]), seed=int(info["seed"]),
                       robot=info.get("twin") or info.get("robot", "measured"),
                       storage=str(info.get("storage", "mcap")), progress=False,
                       excitation=float(info.get("command_excitation_rad", 0.0)),
                       extra=DATA_LEVERS[lever])
    return out


def lr_model(lever: str, data: Path, work: Path) -> Path:
    """The linear regression of a lever: trained on the lever's data with its inputs (the
    model levers do not apply to it), in WORK (reused when present)."""
    from littledog_mlsim.models.train import train_from_dataset
    pl = parts(lever)
    name = "_".join(["lr"] + [x for x in (pl["data"], pl["inputs"]) if x])
    out = work / name
    if not out.exists():
        train_from_dataset(data, "lr", progress=False,
                           feature_set=feature_set(lever)).save(out)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--work", type=Path, required=True,
                    help="models and data levers' datasets (reused when present) and each "
                         "fidelity run's files")
    ap.add_argument("--levers", nargs="+", type=_lever, default=list(FEATURE_LEVERS),
                    help=f"levers ({', '.join(LEVERS)}) or combinations A+B (one data lever, "
                         f"one input lever, model levers)")
    ap.add_argument("--seeds", nargs="+", default=["0", "1", "2"])
    ap.add_argument("--scenarios", nargs="*", default=["straight"], choices=("straight", "switch"),
                    help="open-loop schedules (none: no open-loop run)")
    ap.add_argument("--controllers", nargs="*", default=["velocity"],
                    choices=("velocity", "waypoints", "trajectory"))
    ap.add_argument("--testpool", action="store_true",
                    help="also the 4 s TestPool rollouts on --data's TestPool")
    ap.add_argument("--configs", nargs="+", default=["lgpr-gated"],
                    help="fidelity.py configurations (simulator and projection), each scored")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--duration", default=None, help="s, both schedules (default: fidelity.py's)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from littledog_mlsim.models.train import train_from_dataset
    a.work.mkdir(parents=True, exist_ok=True)
    doc = run_record("fidelity/levers/run.py", argv)
    from benchmarks.fidelity.fidelity import CONFIGS
    bad = [c for c in a.configs if c not in CONFIGS]
    if bad:
        raise SystemExit(f"unknown configuration {bad[0]!r}; expected {', '.join(CONFIGS)}")
    rows = []
    runs = [(what, [flag, *names]) for what, flag, names in (
        ("open-loop", "--scenarios", a.scenarios), ("closed-loop", "--controllers", a.controllers))
        if names]
    for lever in a.levers:
        model = a.work / f"lgpr_{lever}"
        t0 = time.perf_counter()
        data = lever_data(lever, a.data, a.work)
        record_s = time.perf_counter() - t0
        if not model.exists():
            pl = parts(lever)
            train_from_dataset(data, "lgpr", progress=False, options=pl["options"] or None,
                               feature_set=feature_set(lever), dad_rounds=pl["dad"]).save(model)
        train_s = time.perf_counter() - t0 - record_s
        lr = lr_model(lever, data, a.work)
        row = {"lever": lever, "data": data.name, "record_s": round(record_s, 1),
               "train_s": round(train_s, 1), "lr": lr.name, "load": uptime()}
        for what, extra in runs:
            out = a.work / f"{what}_{lever}"
            subprocess.run([sys.executable, str(ROOT / "benchmarks/fidelity/fidelity.py"), what,
                            "--data", str(data), "--lgpr", str(model), "--lr", str(lr),
                            "--configs", *a.configs, "--seeds", *a.seeds,
                            "--workers", str(a.workers), "--out", str(out), *extra,
                            *(["--duration", a.duration] if a.duration else [])],
                           check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
            res = json.loads(out.with_suffix(".json").read_text())
            for scen in extra[1:]:
                for cfg in a.configs:
                    s = res["summary"][f"{scen}/{cfg}"]
                    cell = {k: s.get(k) for k in ("err_per_m", "err_per_m_max", "final_err_m",
                                                  "path_m", "path_learned_m",
                                                  "final_yaw_err_rad", "rms_w",
                                                  "rms_w_pybullet", "reached",
                                                  "reached_pybullet", "rms_ref_m",
                                                  "rms_ref_m_pybullet")}
                    cell["per_seed_err_per_m"] = {
                        str(r["seed"]): r["err_per_m"] for r in res["runs"]
                        if r.get("scenario", r.get("controller")) == scen
                        and r.get("config") == cfg}
                    # the first configuration keeps the row's historical keys
                    row[scen if cfg == a.configs[0] else f"{scen}/{cfg}"] = cell
        if a.testpool:
            from littledog_mlsim.apps.evaluate import evaluate
            m = evaluate(model, a.data, a.work / f"testpool_{lever}", projections=["alpha"])
            (label, v), = m["rollout"].items()
            row["testpool"] = {"projection": label, "nmse_mean": m["nmse_mean"],
                               **{k: v.get(k) for k in ("final_xy_error_m",
                                                        "final_xy_error_m_median")}}
        rows.append(row)
        print(lever, json.dumps(row), flush=True)
    doc["rows"] = rows
    write_results(a.out, doc, table(doc, a))
    return 0


def _pct(d: dict | None) -> str:
    if not d or d.get("err_per_m") is None:
        return "-"
    return f"{100 * d['err_per_m']:.1f} % ({100 * d['err_per_m_max']:.1f} %)"


def table(doc: dict, a) -> list[str]:
    scen = [*a.scenarios, *a.controllers]
    names = {"straight": "straight trot", "switch": "gait switching",
             "velocity": "velocity tracker", "waypoints": "waypoint follower",
             "trajectory": "trajectory tracker"}
    cfgs = list(getattr(a, "configs", None) or ["lgpr-gated"])
    keys = [(sc, sc if c == cfgs[0] else f"{sc}/{c}", c) for sc in scen for c in cfgs]
    head = ["lever", "data"] + [f"{names[sc]}" + (f", {c}" if len(cfgs) > 1 else "")
                                + ": gap / path, median (worst)" for sc, _, c in keys]
    if "straight" in scen:
        head.append("straight: final yaw error")
    if a.testpool:
        head.append("4 s TestPool error, gated alpha [m]")
    head += ["train [s]", "load"]
    span = (f"{a.duration} s each" if a.duration else
            "60 s open loop, 40 s closed loop (fidelity.py's defaults)")
    what = ("LGPR with the gated alpha-PROJ" if cfgs == ["lgpr-gated"] else
            "configurations " + ", ".join(cfgs) + " (fidelity.py)")
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}; seeds "
             f"{' '.join(a.seeds)}; {span}; {what}", "",
             "| " + " | ".join(head) + " |",
             "|" + "---|" * len(head)]
    for r in doc["rows"]:
        cells = [r["lever"], r["data"]] + [_pct(r.get(k)) for _, k, _ in keys]
        if "straight" in scen:
            y = (r.get("straight") or {}).get("final_yaw_err_rad")
            cells.append("-" if y is None else f"{y:.3f} rad")
        if a.testpool:
            cells.append(f"{r['testpool']['final_xy_error_m']:.4f}")
        cells += [str(r["train_s"]), f"`{r['load']}`"]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


if __name__ == "__main__":
    sys.exit(main())
