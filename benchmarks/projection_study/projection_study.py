"""Projection study: none / BOUND / alpha-PROJ / gated alpha-PROJ for delta and next targets.

Usage (from the repo root, in the venv; models trained beforehand with ``littledog-mlsim train``):

    OPENBLAS_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/projection_study/projection_study.py \\
        --data bags/default --model lgpr_delta=/tmp/pstudy2/lgpr_delta \\
        --model lgpr_next=/tmp/pstudy2/lgpr_next --model lr_delta=/tmp/pstudy2/lr_delta \\
        --model lr_next=/tmp/pstudy2/lr_next

For each model: every TestPool move rolled out from its measured s_1 with its recorded commands
(all moves batched, with the calls of ``littledog-mlsim rollout``/``evaluate``,
``scoring.rollout_scores``, what ``evaluate`` runs)
with each projection of ``--alphas`` (plain alpha-PROJ), none, BOUND, and the gated alpha-PROJ
(``--gate-alphas`` x ``--quantiles``; radius = that quantile of the TrainPool's leave-move-out
nearest-neighbour distances, ``evaluate.trainpool_radius``, computed on the TrainPool only).

Reported per rollout: mean / median / p90 over the moves of the final (x, y) error, NaN moves,
the paired difference to ``none`` over the moves (mean, its standard error, moves better/worse),
and how far the fed-back states are from the TrainPool: the median over the moves of the
normalised distance of the state at step 100 and 399 to its nearest TrainPool state (for
reference: held-out real states have median 1.29, see the leave-move-out quantiles).

Writes ``--out``.json and ``--out``.md (default ``benchmarks/projection_study/projection_study``).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))  # _common

from _common import command_line, run_record  # noqa: E402
from littledog_mlsim.data.dataset import features_responses, load_moves  # noqa: E402
from littledog_mlsim.apps.evaluate import projection_label  # noqa: E402
from littledog_mlsim.apps.figures import drift  # noqa: E402
from littledog_mlsim.models.onestep import OneStepModel  # noqa: E402
from littledog_mlsim.projection import (  # noqa: E402
    leave_move_out_distances, make_projection,
)
from littledog_mlsim.rollout.simulate import prepare_test_moves  # noqa: E402
from littledog_mlsim.scoring import RolloutSpec, rollout_scores  # noqa: E402

QUANTILES_REPORTED = (0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.99)


def _q(d: np.ndarray) -> dict[str, float]:
    return {f"{q:g}": float(np.quantile(d, q)) for q in QUANTILES_REPORTED}


def run(model: OneStepModel, moves, kind: str, alpha: float, radius: float, nn) -> dict:
    """The rollout and metrics of ``scoring.rollout_scores`` (what ``evaluate`` runs), plus the
    median over the moves of the normalised distance of the fed-back state to the TrainPool at
    steps 100, 399."""
    spec = RolloutSpec(kind, alpha, radius if kind == "alpha" else 0.0)
    results, preds = rollout_scores(model, moves, [spec], keep_predictions=True)
    full, pred = results[spec.label], preds[spec.label]
    out = {k: full.get(k) for k in (
        "final_xy_error_m", "final_xy_error_m_median", "final_xy_error_m_p90",
        "final_xy_error_m_finite", "n_nan_moves", "rollout_wall_s", "realtime_factor")}
    out["per_move_final_xy_error_m"] = [p["final_xy_error_m"] for p in full["per_move"]]
    for k, d in drift(nn, pred, (100, 399)).items():
        out[f"nn_dist_{k}_median"] = d
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, type=Path)
    ap.add_argument("--model", action="append", required=True, metavar="NAME=DIR")
    ap.add_argument("--alphas", default="0.1,0.25,0.5,0.75,1.0")
    ap.add_argument("--gate-alphas", default="0.5,1.0")
    ap.add_argument("--quantiles", default="0.5,0.9,0.99")
    ap.add_argument("--every", type=int, default=4, help="leave-move-out: every k-th state")
    ap.add_argument("--out", type=Path,
                    default=ROOT / "benchmarks" / "projection_study" / "projection_study")
    a = ap.parse_args(argv)
    alphas = [float(x) for x in a.alphas.split(",") if x]
    gate_alphas = [float(x) for x in a.gate_alphas.split(",") if x]
    quantiles = [float(x) for x in a.quantiles.split(",") if x]

    t0 = time.time()
    train = load_moves(a.data, split="train")
    test = load_moves(a.data, split="test")
    _, Ytr, groups = features_responses(train)
    _, Yte, _ = features_responses(test)
    moves = prepare_test_moves(test)
    plain = make_projection("alpha", Ytr)
    lmo = leave_move_out_distances(Ytr, groups, every=a.every)
    radii = {q: float(np.quantile(lmo, q)) for q in quantiles}
    res = {
        **run_record("projection_study/projection_study.py", argv),
        "python": platform.python_version(), "numpy": np.__version__,
        "data": str(a.data),
        "n_test_moves": len(moves),
        "leave_move_out_nn_distance": {"every": a.every, "n": int(lmo.size), **_q(lmo)},
        "testpool_to_trainpool_nn_distance": _q(plain.distance(Yte)),
        "radii": {f"{q:g}": r for q, r in radii.items()},
        "load_start": os.getloadavg()[0], "models": {},
    }
    print(f"radii {res['radii']}", flush=True)
    for spec in a.model:
        name, path = spec.split("=", 1)
        model = OneStepModel.load(path)
        if not np.array_equal(model.train_states, Ytr):
            raise SystemExit(f"{name}: the model's TrainPool states are not those of {a.data}")
        runs = [("none", 0.0, 0.0, None), ("bound", 0.0, 0.0, None)]
        runs += [("alpha", al, 0.0, None) for al in alphas]
        runs += [("alpha", al, radii[q], q) for al in gate_alphas for q in quantiles]
        out = {"method": model.method, "target": model.target, "path": path, "rollouts": {}}
        for kind, al, r, q in runs:
            label = projection_label(kind, al, r, q)
            entry = run(model, moves, kind, al, r, plain)
            entry.update(projection=kind, alpha=al if kind == "alpha" else None,
                         radius=r if r else None, radius_quantile=q)
            base = out["rollouts"].get("none")
            if base is not None and None not in entry["per_move_final_xy_error_m"]:
                diff = (np.array(entry["per_move_final_xy_error_m"])
                        - np.array(base["per_move_final_xy_error_m"]))
                entry["vs_none"] = {"mean_diff_m": float(diff.mean()),
                                    "se_m": float(diff.std(ddof=1) / np.sqrt(diff.size)),
                                    "n_better": int((diff < 0).sum()),
                                    "n_worse": int((diff > 0).sum())}
            out["rollouts"][label] = entry
            print(f"{name:<11} {label:<16} final {entry['final_xy_error_m']} m "
                  f"(median {entry['final_xy_error_m_median']}, nan {entry['n_nan_moves']}), "
                  f"dist@399 {entry['nn_dist_step399_median']}", flush=True)
        res["models"][name] = out
    res["load_end"] = os.getloadavg()[0]
    res["wall_s"] = time.time() - t0
    a.out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{a.out}.json").write_text(json.dumps(res, indent=1) + "\n")
    Path(f"{a.out}.md").write_text(report(res))
    print(f"wrote {a.out}.json and .md", flush=True)
    return 0


def _f(x, nd=4):
    return "NaN" if x is None else f"{x:.{nd}f}"


def report(res: dict) -> str:
    lines = ["# Projection study (generated by benchmarks/projection_study/projection_study.py)", "",
             command_line(res),
             "",
             f"Code: {res['git']}. Python {res['python']}, NumPy {res['numpy']}, {res['date']}; "
             "1-min load average "
             f"{res['load_start']:.2f} at the start, {res['load_end']:.2f} at the end (the errors "
             "do not depend on the load; the rollouts are deterministic); "
             f"{res['n_test_moves']} TestPool moves, 399 steps each. `dist. to TrainPool @k`: "
             "median over the moves of the normalised distance of the fed-back state k steps "
             "after s_1 to its nearest TrainPool state.", "",
             "Normalised nearest-TrainPool-state distances (quantiles): TrainPool states to "
             "another TrainPool move (leave-move-out, every "
             f"{res['leave_move_out_nn_distance']['every']}th state): "
             + ", ".join(f"q{k} {v:.3f}" for k, v in res["leave_move_out_nn_distance"].items()
                         if k not in ("every", "n"))
             + "; TestPool states to the TrainPool: "
             + ", ".join(f"q{k} {v:.3f}"
                         for k, v in res["testpool_to_trainpool_nn_distance"].items())
             + ".", "",
             "Gate radii (leave-move-out quantiles, TrainPool only): "
             + ", ".join(f"q{k} = {v:.3f}" for k, v in res["radii"].items()) + ".", ""]
    for name, m in res["models"].items():
        lines += [f"## {name} ({m['method']}, target {m['target']})", "",
                  "| projection | mean final (x,y) error [m] | median | p90 | NaN moves | "
                  "paired diff. vs none [m] (+- s.e.) | moves better / worse | "
                  "dist. to TrainPool @100 | @399 |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for label, e in m["rollouts"].items():
            v = e.get("vs_none")
            paired = ("" if v is None or label == "none" else
                      f"{v['mean_diff_m']:+.4f} (+- {v['se_m']:.4f})")
            bw = "" if v is None or label == "none" else f"{v['n_better']} / {v['n_worse']}"
            lines.append(f"| {label} | {_f(e['final_xy_error_m'])} | "
                         f"{_f(e['final_xy_error_m_median'])} | {_f(e['final_xy_error_m_p90'])} | "
                         f"{e['n_nan_moves']} | {paired} | {bw} | "
                         f"{_f(e['nn_dist_step100_median'], 2)} | "
                         f"{_f(e['nn_dist_step399_median'], 2)} |")
        lines.append("")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    raise SystemExit(main())
