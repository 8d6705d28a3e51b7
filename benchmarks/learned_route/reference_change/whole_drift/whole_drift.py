"""Decision 068 on read zoos: a drift with time read as the servo's whole output scaled with
time (``t (u - q)`` and ``t dq``) against the stiffness alone (``t (u - q)``).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/whole_drift/whole_drift.py --zoo-dir WORK67 \
        --truth benchmarks/blind_zoo/zoos/zoo67/truth.yaml --label zoo67 --out OUT [--only IDS]

WORK67 holds a zoo's recordings as the blind-zoo harness writes them (``reference``,
``effects/zNN``, ``clean/sNNN_eX``). For every effect and clean recording (or those of
``--only``), the search model fitted on the whole reference at the route's start feature set is
read through :func:`littledog_mlsim.diagnose.change.reference_change`, as a diagnosis whose
search accepted nothing would read it, once under each rule (``change.DRIFT_WHOLE_OUTPUT``
False, then True; the data's own held-out one-step residual is fitted once and shared). Each
rule also reads :func:`littledog_mlsim.diagnose.change.drift_through_reference` (decision 028,
which confirms a drift the search accepted) at the truth's scope for a time drift, else over all
joints. Each row gives, per rule, what is named, the kept family and scope, the share of the
excess it explains and the drift's rate, beside the truth (these zoos' truth has been read).
Writes OUT.md and OUT.json, appending each row as it is read (under a lock on OUT.lock, so
that two runs may share a study); a recording that already has a row is not read again.
"""
from __future__ import annotations

import fcntl
import json
import os
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[4]), str(Path(__file__).resolve().parents[3])]

from _common import (appended_study, study_commands, zoo_effects,  # noqa: E402
                     zoo_study_parser)

from littledog_mlsim.data.dataset import load_moves   # noqa: E402
from littledog_mlsim.diagnose import change   # noqa: E402
from littledog_mlsim.diagnose.candidates import measured_robot_features   # noqa: E402
from littledog_mlsim.diagnose.families.scopes import scope_group, scope_joints   # noqa: E402
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route   # noqa: E402
from littledog_mlsim.layout import N_STATE, S   # noqa: E402
from littledog_mlsim.models.feature_library import ElapsedTracking   # noqa: E402

#: the flags of :mod:`littledog_mlsim.diagnose.change` the drift studies set: each is False
#: under a rule unless the rule sets it, so a study reads the same whatever the package's
#: defaults (decision 071's ``COUPLED_FALLBACK`` is on in the package)
FLAGS = ("DRIFT_WHOLE_OUTPUT", "DRIFT_COUPLED", "COUPLED_CHECKED", "COUPLED_FALLBACK",
         "NARROW_FALLBACK")
#: each rule's name and the flags of :data:`FLAGS` it sets
RULES = {"stiffness": {}, "whole": {"DRIFT_WHOLE_OUTPUT": True}}
TITLE = "Decision 068 on read zoos: a drift with time as the servo's whole output"
#: the table's heads of the two readings, by rule name (a rule not here is headed by its name)
HEADS = {"stiffness": "the stiffness alone (before)", "whole": "the whole output (decision 068)",
         "before": "before", "coupled": "coupled over the scope (decision 069)",
         "checked": "coupled and checked (decision 070)",
         "fallback": "coupled where nothing is named (decision 071)",
         "narrow": "at the narrower scope whose coupled drift explains it (decision 072)"}


def _rates(r, ref, fs, scope: str) -> dict:
    """A drift's rate at the truth's scope, read beside the rule: decision 038's (each joint's
    stiffness slope, data minus reference, the median) and the same with ``t dq`` in the
    regression (a sizing decision 068 leaves unchanged)."""
    X, Y, mi = fs.features_responses(r.train)
    Xr, Yr, mir = fs.features_responses(ref.train)
    D, Dr = Y - X[:, :N_STATE], Yr - Xr[:, :N_STATE]
    joints = [int(j) for j in scope_joints(scope)]
    old = [change.stiffness_rate(X, D, mi, j) - change.stiffness_rate(Xr, Dr, mir, j)
           for j in joints]
    new = [change.stiffness_rate(X, D, mi, j, t_dq=True)
           - change.stiffness_rate(Xr, Dr, mir, j, t_dq=True) for j in joints]
    med = lambda v: round(float(np.nanmedian(v)), 4)  # noqa: E731
    return {"stiffness_slope": med(old), "with_t_dq": med(new)}


def _excitation(name: str, e: dict | None) -> float:
    """The recording's command excitation [rad]: a clean recording's from its name
    (``sNNN_eX``), an effect's from its truth entry (0 where the entry names none)."""
    if e is None:
        return float(name.rsplit("_e", 1)[1])
    return float((e.get("recording") or {}).get("excitation") or 0.0)


def _reading(c: dict, confirm: dict) -> dict:
    voc = c.get("vocabulary") or {}
    size = c.get("size") or {}
    nr = c.get("narrower") or {}
    fb = c.get("coupled_fallback")
    # decision 071's screen, where it ran (a key only then: earlier studies' rows keep theirs)
    extra = {} if fb is None else {"fallback": {
        "named": fb["named"], "family": fb.get("family"),
        "explained": None if fb.get("explained") is None else round(fb["explained"], 3),
        "first_explained": (None if fb["first"]["explained"] is None
                            else round(fb["first"]["explained"], 3))}}
    nf = (fb or {}).get("narrower")
    if nf is not None:           # decision 072's sources, where they were read
        extra["fallback"]["narrower"] = {
            "scope": nf["scope"], "all": round(nf["all"], 3),
            "shares": {r["source"]: round(r["explained"], 3) for r in nf["scopes"]},
            "ok": [r["source"] for r in nf["scopes"]
                   if r["significant"] and r["material"] and r["total_gain"] > 0]}
    return {"named": f"{voc['family']} @ {voc['scope']}" if c["named"] else None,
            "params": voc.get("params"), "family": c.get("family"),
            "kept_scope": c.get("kept_scope"),
            "explained": None if c.get("explained") is None else round(c["explained"], 3),
            "all_explained": (nr.get("all") or {}).get("explained"),
            "rate_per_s": size.get("rate_per_s") if c.get("family") == "time_drift" else None,
            "confirmed": bool(confirm["confirmed"]), "confirm_p": confirm["p_value"],
            "confirm_gain": round(confirm["total_gain"], 3), **extra}


def main(rules: dict[str, dict[str, bool]] = RULES, title: str = TITLE,
         doc: str = __doc__) -> None:
    """Read every recording under each of ``rules`` (the first is "before", the last
    "after") and append the rows to ``--out`` (``title`` heads its table)."""
    p = zoo_study_parser(doc.splitlines()[0])
    p.add_argument("--only", default=None,
                   help="comma-separated recordings (zNN, sNNN_eX) to read; default all")
    a = p.parse_args()
    opts, start = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    truth = {e["id"]: e for e in zoo_effects(a.truth)}
    ref = _Route(load_moves(a.zoo_dir / "reference", "train"), start, opts, quiet)
    ref_fit = ref.fit(start, one_step=True)
    out_json = a.out.with_suffix(".json")
    with _locked(out_json):                  # two runs may append to one study at once
        doc = appended_study(out_json)
        out_json.write_text(json.dumps(doc, indent=1))
    data = (sorted(d for d in (a.zoo_dir / "effects").iterdir() if d.is_dir())
            + sorted(d for d in (a.zoo_dir / "clean").iterdir() if d.is_dir()))
    if a.only:
        data = [d for d in data if d.name in a.only.split(",")]
    done = {(r["zoo"], r["data"]) for r in doc["rows"]}
    data = [d for d in data if (a.label, d.name) not in done]     # a resumed run reads the rest
    for d in data:
        t0 = time.perf_counter()
        e = truth.get(d.name)
        r = _Route(load_moves(d, "train"), start, opts, quiet)
        _, ev_own = r.fit(start, one_step=True)
        drift = e is not None and e["family"] == "time_drift"
        scope = e["scope"] if drift else "all"
        row = {"zoo": a.label, "data": d.name,
               "truth": "clean" if e is None else f"{e['family']} @ {e['scope']}",
               "truth_params": None if e is None else e.get("params"),
               "excitation": _excitation(d.name, e), "confirm_scope": scope}
        flags = set(FLAGS) | {f for v in rules.values() for f in v}
        for name, rule in rules.items():
            for f in sorted(flags):
                setattr(change, f, rule.get(f, False))
            c = change.reference_change(r, ref, start, None, ev_own.one_step, ref_fit)
            conf = change.drift_through_reference(
                r, ref, start, ElapsedTracking(joints=scope_group(scope)), ref_fit)
            row[name] = _reading(c, conf)
        if drift:
            row["rates_at_truth_scope"] = _rates(r, ref, start, e["scope"])
        row["seconds"] = round(time.perf_counter() - t0, 1)
        with _locked(out_json):
            doc = json.loads(out_json.read_text())
            doc["rows"].append(row)
            out_json.write_text(json.dumps(doc, indent=1))
            write_md(doc, a.out.with_suffix(".md"), rules, title)
        print(row, flush=True)


@contextmanager
def _locked(path: Path):
    """An exclusive lock on ``path``.lock for the block (``fcntl.flock``)."""
    with open(path.with_suffix(".lock"), "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def _cell(x: dict) -> str:
    named = x["named"] or "nothing"
    kept = (f"kept {x['family']} @ {x['kept_scope']}, {100 * x['explained']:.0f} %"
            if x["family"] and x["explained"] is not None else "")
    rate = "" if x["rate_per_s"] is None else f", rate {x['rate_per_s']:+.3f}/s"
    conf = f"; 028: {'yes' if x['confirmed'] else 'no'} (p {x['confirm_p']:.2g})"
    return f"{named}{rate} ({kept}){conf}" if kept else f"{named}{rate}{conf}"


def _rates_cell(x: dict | None) -> str:
    return "" if not x else f"{x['stiffness_slope']:+.3f} / {x['with_t_dq']:+.3f}"


def write_md(doc: dict, path: Path, rules: dict = RULES, title: str = TITLE) -> None:
    first, last = list(rules)[0], list(rules)[-1]
    lines = [f"# {title}", ""]
    lines += study_commands(doc)
    lines += ["", f"| zoo | data | truth | exc. | {HEADS.get(first, first)} | "
              f"{HEADS.get(last, last)} | named differently | 028 differently | a drift's rate "
              "at its scope: 038 / with t dq [1/s] |", "|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        s, w = r[first], r[last]
        truth = r["truth"] + (f" {r['truth_params']}" if r["truth_params"] else "")
        lines.append(f"| {r['zoo']} | {r['data']} | {truth} | {r['excitation']:g} | "
                     f"{_cell(s)} | {_cell(w)} | {'yes' if s['named'] != w['named'] else ''} | "
                     f"{'yes' if s['confirmed'] != w['confirmed'] else ''} | "
                     f"{_rates_cell(r.get('rates_at_truth_scope'))} |")
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
