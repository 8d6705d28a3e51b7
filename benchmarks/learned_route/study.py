"""The learned route (no twin) on planted effects and clean data: why the one-step screen finds
nothing, and what the rollout-based route finds.

    .venv/bin/python benchmarks/learned_route/record.py --work /tmp/learned_route_data
    .venv/bin/python benchmarks/learned_route/study.py --work /tmp/learned_route_data \
        --out benchmarks/learned_route

For every dataset: (1) the one-step screen of ``diagnose --physics off``
(:func:`littledog_mlsim.diagnose.selection.select_effects`, default search model, one round:
the scores of every library candidate, kept for the planted family's members and the best
one); (2) :func:`littledog_mlsim.diagnose.learned.diagnose_learned` (default options). Writes
``results.json`` (everything) and ``results.md`` (the tables the README quotes).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

# dataset -> (planted family of the learned library or None, truth in words)
DATASETS = {
    "wind": ("pose (heading)", "ConstantWind 1.5 N toward +y (90 deg) in odom"),
    "wind2": ("pose (heading)", "ConstantWind 1.0 N toward 210 deg in odom"),
    "delay_leg": ("command delay", "CommandDelay 3 steps (30 ms), back_left leg; 0.05 rad "
                                   "excitation"),
    "tilt": ("pose (position)", "GroundTilt 2 deg rising toward +x (level odom)"),
    "drift": ("elapsed time", "ServoGain drift -8 %/s of the start gain, all joints"),
    "clean_s1": (None, "clean, seed 1"),
    "clean_s2": (None, "clean, seed 2"),
    "clean_s1_excited": (None, "clean, seed 1, 0.05 rad excitation"),
    "clean_s2_excited": (None, "clean, seed 2, 0.05 rad excitation"),
}
SCREEN_FAMILY = {"pose (heading)": "pose (heading)", "command delay": "command delay",
                 "pose (position)": "pose (position)", "elapsed time": "elapsed time"}


def one_step_screen(train) -> dict:
    """The current learned route's first round: every candidate's one-step decision."""
    from littledog_mlsim.diagnose.candidates import measured_robot_features
    from littledog_mlsim.diagnose.selection import SearchModel, select_effects
    sel = select_effects(train, measured_robot_features(), search=SearchModel(seed=0),
                         max_rounds=0)
    return {s.label: {"family": s.augmentation.family, "p_value": s.p_value,
                      "max_gain": s.max_gain, "total_gain": s.total_gain,
                      "significant": s.significant, "material": s.material}
            for s in sel.rounds[0].scores}


def run_one(path: Path) -> dict:
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.diagnose.learned import diagnose_learned
    train, test = load_moves(path, "train"), load_moves(path, "test")
    t0 = time.perf_counter()
    screen = one_step_screen(train)
    t1 = time.perf_counter()
    report = diagnose_learned(train, test, progress=lambda s: print(f"  {s}", file=sys.stderr))
    return {"screen": screen, "screen_seconds": t1 - t0, "report": report,
            "learned_seconds": time.perf_counter() - t1}


def _fmt_p(p: float) -> str:
    return f"{p:.2g}"


def tables(results: dict) -> str:
    lines = ["## One-step screen (`diagnose --physics off` today), planted family's best member",
             "", "| dataset | truth | candidate | max one-step gain | p | significant | "
             "material |", "|---|---|---|---|---|---|---|"]
    for name, r in results.items():
        fam = DATASETS[name][0]
        cands = {k: v for k, v in r["screen"].items() if fam is None or v["family"] == fam}
        k, v = max(cands.items(), key=lambda kv: kv[1]["total_gain"])
        lines.append(f"| {name} | {DATASETS[name][1]} | {k} | {v['max_gain']:.3f} | "
                     f"{_fmt_p(v['p_value'])} | {v['significant']} | {v['material']} |")
    lines += ["", "## Learned route (rollout evidence)", "",
              "| dataset | found | p | 1 s rollout SSE cut (sum over 33) | statement | "
              "TestPool one-step nMSE before -> after | TestPool 4 s xy error [m] before -> "
              "after | residual left | smallest p of the residual tests | seconds |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for name, r in results.items():
        rep = r["report"]
        eff = rep["effects"]
        found = "; ".join(e["label"] for e in eff) or "nothing"
        p = "; ".join(_fmt_p(e["p_value"]) for e in eff) or _fmt_p(min(
            pr["p_value"] for pr in rep["rounds"][0]["probes"]))
        gain = "; ".join(f"{e['total_gain']:.2f}" for e in eff) or "-"
        st = "; ".join(e["statement"] for e in eff) or rep["verdict"]
        b, a = rep["test"]["before"], rep["test"]["after"]
        res = rep["residual"]
        lines.append(f"| {name} | {found} | {p} | {gain} | {st} | "
                     f"{b['one_step_nmse_mean']:.4f} -> {a['one_step_nmse_mean']:.4f} | "
                     f"{b['final_xy_error_m']:.4f} -> {a['final_xy_error_m']:.4f} | "
                     f"{', '.join(res['unexplained']) or 'none'} | {_fmt_p(res['smallest_p'])} | "
                     f"{r['learned_seconds']:.0f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", required=True, help="the datasets (record.py)")
    ap.add_argument("--out", required=True, help="where results.json / results.md go")
    ap.add_argument("--only", nargs="*", help="dataset names (default: all)")
    ap.add_argument("--merge", help="add the datasets of this results.json (another process's "
                                    "--out) and only rewrite the tables")
    args = ap.parse_args(argv)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    out = Path(args.out)
    path = out / "results.json"
    results = json.loads(path.read_text()) if path.exists() else {}
    if args.merge:
        results.update(json.loads(Path(args.merge).read_text()))
        path.write_text(json.dumps(results, indent=1, default=float))
    for name in ([] if args.merge else args.only or list(DATASETS)):
        print(f"{name} ...", file=sys.stderr)
        results[name] = run_one(Path(args.work) / name)
        tmp = path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(results, indent=1, default=float))
        tmp.replace(path)
    ordered = {k: results[k] for k in DATASETS if k in results}
    cmd = "Command: .venv/bin/python benchmarks/learned_route/study.py " + " ".join(
        argv if argv is not None else sys.argv[1:])
    (out / "results.md").write_text(f"# Learned route study\n\n{cmd}\n\n" + tables(ordered))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
