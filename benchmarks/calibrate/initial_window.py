"""How far off is a re-simulation's start? The k-step residuals of the gap robot itself from
measured and from smoothed starting states, per half-window.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/initial_window.py \
        --data NOISY=WORK/reference --data NO_NOISE=WORK2/reference \
        --robot benchmarks/calibrate/gap_robot.json --out benchmarks/calibrate/initial_window

WORK and WORK2 are ``calibrate_gap.py``'s work directories of a plain run and of a
``--no-sensor-noise`` run (their ``reference`` datasets). The robot re-simulates its own
recordings (motion-capture noise off in the re-simulation), so the residuals come from the
starting states and the recording's noise only: every 7th TrainPool move (8 moves), every 20th
state, 1 and 10 control steps ahead. Per starting state (``measured``:
``InitialState.from_recording``; ``smoothed bw/jw``: ``InitialState.smoothed`` with those
body and joint half-windows) the RMS of the residual over the body elements, the joint angles
and the joint rates; per dataset its body-position noise (``twin_fit.pose_noise``).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from benchmarks._common import command_line, run_record, write_results  # noqa: E402

CASES = [("measured", None, None), ("smoothed", 2, 0), ("smoothed", 3, 0), ("smoothed", 4, 0),
         ("smoothed", 5, 0),
         ("smoothed", 8, 0), ("smoothed", 5, 1)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", action="append", required=True, metavar="LABEL=DIR")
    ap.add_argument("--robot", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot.sim import InitialState
    from littledog_mlsim.robot.twin import load_twin
    from littledog_mlsim.robot.twin_fit import pose_noise
    doc = run_record("calibrate/initial_window.py", argv)
    cfg = dataclasses.replace(load_twin(a.robot).robot, sensor_noise=False)
    smoothed = InitialState.smoothed.__func__
    groups = {"body": slice(0, 9), "q": slice(9, 21), "dq": slice(21, 33)}
    rows, noise = [], {}
    try:
        for item in a.data:
            label, _, path = item.partition("=")
            every = load_moves(path, "train")
            noise[label] = pose_noise(every)
            recs = every[::7][:8]
            for kind, bw, jw in CASES:
                if bw is not None:
                    InitialState.smoothed = classmethod(
                        lambda cls, rec, k, bw=bw, jw=jw: smoothed(cls, rec, k, bw, jw))
                r1, r10 = [], []
                for rec in recs:
                    _, true, pred = bl.k_step_predictions(rec, cfg, 10, 20, initial=kind)
                    r1.append(pred[:, 0] - true[:, 0])
                    r10.append(pred[:, 9] - true[:, 9])
                r1, r10 = np.concatenate(r1), np.concatenate(r10)
                row = {"data": label, "start": kind if bw is None else f"smoothed {bw}/{jw}"}
                for h, r in (("h1", r1), ("h10", r10)):
                    for g, s in groups.items():
                        row[f"{h}_{g}"] = float(np.sqrt(np.mean(r[:, s] ** 2)))
                rows.append(row)
                print(row, flush=True)
    finally:
        InitialState.smoothed = classmethod(smoothed)
    doc["rows"], doc["pose_noise_m"] = rows, noise
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}", "",
             "| data | starting state (body/joint half-window) | 1 step: body | q | dq | "
             "10 steps: body | q | dq |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['data']} | {r['start']} | " + " | ".join(
            f"{r[f'{h}_{g}']:.4f}" for h in ("h1", "h10") for g in groups) + " |")
    lines += ["", "Body-position noise of each dataset's TrainPool (`twin_fit.pose_noise`, what "
              "`calibrate --initial-state auto` compares with 0.2 mm): " + "; ".join(
                  f"{k} {v * 1e3:.3f} mm" for k, v in noise.items())]
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
