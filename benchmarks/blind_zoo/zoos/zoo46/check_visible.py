"""Check zoo46 (SEALED): every effect changes the recordings materially against clean data of the
same seed and excitation, well beyond a negligible control perturbation, and no move falls.

For every effect of ``truth.yaml`` (its ``recording.excitation``), the effect's dataset is
compared move by move with the clean dataset of the same seed and excitation (the same gait
commands and sensor-noise draws, so any difference is the effect's):

- ``D``: the paired distance: per move and state element (the 33 of docs/interface.md section
  4), the RMS over time of effect minus clean, divided by that element's standard deviation
  over the clean dataset; mean over elements and moves. The control (``control.yaml``, a
  negligible perturbation) is scored the same way at each excitation.
- ``shift``: the largest systematic change of a per-move summary (final x, y and yaw, mean
  height, roll and pitch, and per joint the mean and RMS of the reported angle minus the
  set-point): |mean over moves of (effect - clean)| / standard deviation over the clean moves.
- a move falls if its body tilts past 0.7 rad in roll or pitch, its height drops below 6 cm, or
  a reading is not finite.

An effect passes if D >= max(3 x the control's D, 0.05), its median over moves is at least 3 x
the control's median (a few moves of the control diverge chaotically, which lifts its mean),
and no move falls (the clean datasets and the controls must not fall either).

``--small``: records everything itself (3 moves per type, seed 371) under /tmp/z46/check_small
and writes ``check_small.md/.json``. Default (full): reads the harness's recordings in ``--work``
(``WORK/effects/<id>``, ``WORK/clean/s371_e<exc>``), records the controls (10 moves per type)
in ``WORK/check/``, and writes ``check.md/.json``. Run from the repository root:

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python \
        benchmarks/blind_zoo/zoos/zoo46/check_visible.py --small
    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python \
        benchmarks/blind_zoo/zoos/zoo46/check_visible.py --work /tmp/z46/work
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.data.states import states_from_recording
from littledog_mlsim.rotations import quat_to_rpy

HERE = Path(__file__).resolve().parent
ROBOT = HERE / "gap_robot.json"
SEED = 371
RATIO = 3.0
FLOOR = 0.05


def record(out: Path, moves: int, excitation: float, effects: Path | None) -> None:
    if (out / "dataset.yaml").is_file():
        return
    cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(moves), "--seed", str(SEED), "--robot", str(ROBOT),
           "--jobs", "2", "--quiet"]
    if excitation:
        cmd += ["--excitation", f"{excitation:g}"]
    if effects is not None:
        cmd += ["--effects", str(effects)]
    subprocess.run(cmd, check=True)


def moves(directory: Path) -> dict:
    return {r.name: r for r in load_moves(directory, split="all")}


def falls(recs: dict) -> list[str]:
    bad = []
    for name, r in recs.items():
        pos, orn = np.asarray(r.position), np.asarray(r.orientation)
        if not (np.isfinite(pos).all() and np.isfinite(orn).all()
                and np.isfinite(r.q).all() and np.isfinite(r.dq).all()):
            bad.append(name)
            continue
        rpy = quat_to_rpy(orn)
        if np.abs(rpy[:, :2]).max() > 0.7 or pos[:, 2].min() < 0.06:
            bad.append(name)
    return bad


def summary(r) -> np.ndarray:
    pos = np.asarray(r.position)
    rpy = quat_to_rpy(np.asarray(r.orientation))
    err = np.asarray(r.q)[1:] - np.asarray(r.cmd)
    yaw = np.unwrap(rpy[:, 2])
    return np.concatenate([[pos[-1, 0] - pos[0, 0], pos[-1, 1] - pos[0, 1], yaw[-1] - yaw[0],
                            pos[:, 2].mean(), rpy[:, 0].mean(), rpy[:, 1].mean()],
                           err.mean(0), np.sqrt((err ** 2).mean(0))])


def compare(data: dict, clean: dict) -> dict:
    names = sorted(set(data) & set(clean))
    S_clean = np.vstack([states_from_recording(clean[n]) for n in names])
    scale = S_clean.std(0)
    scale = np.where(scale > 1e-12, scale, 1.0)
    per_move = []
    for n in names:
        a, b = states_from_recording(data[n]), states_from_recording(clean[n])
        d = a - b
        d[:, 6:9] = (d[:, 6:9] + np.pi) % (2 * np.pi) - np.pi
        per_move.append(float(np.mean(np.sqrt((d ** 2).mean(0)) / scale)))
    fa = np.array([summary(data[n]) for n in names])
    fc = np.array([summary(clean[n]) for n in names])
    sd = fc.std(0)
    sd = np.where(sd > 1e-12, sd, 1.0)
    shift = np.abs((fa - fc).mean(0)) / sd
    return {"moves": len(names), "D": float(np.mean(per_move)),
            "D_move_median": float(np.median(per_move)), "shift": float(shift.max())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--small", action="store_true", help="3 moves per type, recorded here")
    ap.add_argument("--work", default="/tmp/z46/work", help="the harness's work directory")
    a = ap.parse_args(argv)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    t0 = time.time()
    if a.small:
        root, n = Path("/tmp/z46/check_small"), 3
    else:
        root, n = Path(a.work), 10
    excitations = sorted({0.0} | {float((t.get("recording") or {}).get("excitation", 0.0))
                                  for t in truth})
    clean, control = {}, {}
    for e in excitations:
        if a.small:
            cdir = root / f"clean_e{e:g}"
            record(cdir, n, e, None)
        else:
            cdir = root / "clean" / f"s{SEED}_e{e:g}"
        kdir = root / ("" if a.small else "check") / f"control_e{e:g}"
        record(kdir, n, e, HERE / "control.yaml")
        clean[e], control[e] = moves(cdir), moves(kdir)
    rows, ok = [], True
    ctrl = {}
    for e in excitations:
        ctrl[e] = {**compare(control[e], clean[e]), "falls": falls(control[e]),
                   "clean_falls": falls(clean[e])}
        ok &= not ctrl[e]["falls"] and not ctrl[e]["clean_falls"]
    for t in truth:
        e = float((t.get("recording") or {}).get("excitation", 0.0))
        ddir = root / f"{t['id']}" if a.small else root / "effects" / t["id"]
        if a.small:
            record(ddir, n, e, (HERE / "effects" / t["file"]))
        data = moves(ddir)
        c = compare(data, clean[e])
        fell = falls(data)
        need = max(RATIO * ctrl[e]["D"], FLOOR)
        med_ratio = c["D_move_median"] / max(ctrl[e]["D_move_median"], 1e-12)
        passed = (c["D"] >= need and med_ratio >= RATIO and not fell
                  and c["moves"] == len(clean[e]))
        ok &= passed
        rows.append({"id": t["id"], "excitation": e, **c, "D_control": ctrl[e]["D"],
                     "D_needed": need, "D_over_control": c["D"] / max(ctrl[e]["D"], 1e-12),
                     "median_over_control": med_ratio,
                     "falls": fell, "pass": passed})
    doc = {"command": " ".join(["check_visible.py"] + (argv or sys.argv[1:])),
           "moves_per_type": n, "seed": SEED, "robot": "gap_robot.json",
           "criterion": f"D >= max({RATIO:g} x control D, {FLOOR:g}), median D >= {RATIO:g} x "
                        f"control median D, and no move falls",
           "controls": {f"{e:g}": v for e, v in ctrl.items()}, "rows": rows,
           "all_pass": bool(ok), "seconds": round(time.time() - t0, 1)}
    stem = "check_small" if a.small else "check"
    (HERE / f"{stem}.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = [f"# zoo46 visibility check ({'small: 3' if a.small else 'full: 10'} moves per "
             f"type, seed {SEED}, the gap robot)", "",
             f"Criterion: {doc['criterion']}. D: mean paired normalised RMS state difference "
             "against clean data of the same seed and excitation; shift: largest systematic "
             "change of a per-move summary in clean standard deviations.", "",
             "| control | excitation | D | median D | shift | control falls | clean falls |",
             "|---|---|---|---|---|---|---|"]
    for e, v in ctrl.items():
        lines.append(f"| control.yaml | {e:g} | {v['D']:.4f} | {v['D_move_median']:.4f} | "
                     f"{v['shift']:.2f} | "
                     f"{len(v['falls'])} | {len(v['clean_falls'])} |")
    lines += ["", "| effect | excitation | moves | D | D / control | median D / control median "
              "| shift | falls | pass |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['id']} | {r['excitation']:g} | {r['moves']} | {r['D']:.4f} | "
                     f"{r['D_over_control']:.1f} | {r['median_over_control']:.1f} | "
                     f"{r['shift']:.2f} | {len(r['falls'])} | "
                     f"{'yes' if r['pass'] else 'NO'} |")
    lines += ["", f"All pass: {'yes' if ok else 'NO'} ({doc['seconds']:.0f} s)", ""]
    (HERE / f"{stem}.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
