"""zoo17: is every effect material, and did any move fall? SEALED results (check.md/.json).

Every effect dataset (WORK/effects/<id>, recorded by harness/run.py --record-only) is compared,
move by move (same seed, so the same commands and sensor noise), with the clean dataset of the
same seed and excitation (WORK/clean/s<seed>_e<exc>). The floor of each distance is the same
comparison for a control dataset recorded here with a negligible effect (WORK/control/e<exc>).
An effect passes if at least one distance is >= 5x its floor and at least two are >= 2x.
Every dataset in WORK (clean, effects, reference, control) is also checked for falls.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo17/check_visible.py \\
        --work WORK

This file holds no effect value: ids, excitations and seeds come from truth.yaml.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[3]
sys.path.insert(0, str(ROOT))
from littledog_mlsim.data.dataset import load_moves  # noqa: E402

#: the control's effect: negligible (a Coulomb friction a thousandth of any realistic one)
CONTROL = [{"class": "littledog_mlsim.robot.effects:JointFriction",
            "params": {"coulomb": 1.0e-5, "viscous": 0.0, "joints": "all"}}]
FALL_Z_FRACTION = 0.6       # a move fell if the body sinks below this fraction of its start
FALL_TILT_DEG = 45.0        # or tilts (roll or pitch) beyond this


def rpy(quat_xyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = quat_xyzw.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=1)


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def moves(path: Path) -> dict:
    return {m.name: m for m in load_moves(path, split="all")}


def distances(a: dict, b: dict) -> dict[str, float]:
    names = sorted(set(a) & set(b))
    dq, dqd, v, w, att, z, xy, yaw, track = [], [], [], [], [], [], [], [], []
    qj = []
    for n in names:
        A, B = a[n], b[n]
        dq.append(A.q - B.q)
        dqd.append(A.dq - B.dq)
        v.append(A.linear_velocity - B.linear_velocity)
        w.append(A.angular_velocity - B.angular_velocity)
        ra, rb = rpy(A.orientation), rpy(B.orientation)
        att.append(wrap(ra[:, :2] - rb[:, :2]))
        z.append(A.position[:, 2] - B.position[:, 2])
        xy.append(np.linalg.norm(A.position[-1, :2] - B.position[-1, :2]))
        yaw.append(abs(wrap(ra[-1, 2] - rb[-1, 2])))
        track.append(np.abs(A.cmd - A.q[1:]).mean(0) - np.abs(B.cmd - B.q[1:]).mean(0))
    rms = lambda xs: float(np.sqrt(np.mean(np.concatenate([np.ravel(x) for x in xs]) ** 2)))
    Q = np.concatenate(dq, axis=0)
    return {
        "q_rms": rms(dq),
        "q_joint_rms_max": float(np.sqrt((Q ** 2).mean(0)).max()),
        "dq_rms": rms(dqd),
        "tracking_change_max": float(np.abs(np.mean(track, axis=0)).max()),
        "lin_vel_rms": rms(v),
        "ang_vel_rms": rms(w),
        "roll_pitch_rms": rms(att),
        "height_rms": rms(z),
        "final_xy_mean": float(np.mean(xy)),
        "final_yaw_mean": float(np.mean(yaw)),
    }


def falls(path: Path) -> list[str]:
    out = []
    for m in load_moves(path, split="all"):
        z0 = m.position[0, 2]
        tilt = np.degrees(np.abs(rpy(m.orientation)[:, :2])).max()
        if m.position[:, 2].min() < FALL_Z_FRACTION * z0 or tilt > FALL_TILT_DEG \
                or not np.all(np.isfinite(m.q)):
            out.append(m.name)
    return out


def record_control(work: Path, robot: Path, seed: int, exc: float, moves_per_type: int) -> Path:
    out = work / "control" / f"e{exc:g}"
    if (out / "dataset.yaml").is_file():
        return out
    eff = work / "control" / "control_effects.yaml"
    eff.parent.mkdir(parents=True, exist_ok=True)
    eff.write_text(yaml.safe_dump(CONTROL))
    cmd = [sys.executable, "-P", "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(moves_per_type), "--seed", str(seed), "--jobs", "2",
           "--quiet", "--robot", str(robot), "--effects", str(eff)]
    if exc:
        cmd += ["--excitation", f"{exc:g}"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run(cmd, check=True, env=env)
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=101)
    ap.add_argument("--moves-per-type", type=int, default=10)
    a = ap.parse_args()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    robot = HERE / "gap_robot.json"
    excs = sorted({float((t.get("recording") or {}).get("excitation", 0.0)) for t in truth})
    clean = {e: moves(work / "clean" / f"s{a.seed}_e{e:g}") for e in excs}
    floor = {}
    for e in excs:
        ctrl = record_control(work, robot, a.seed, e, a.moves_per_type)
        floor[e] = distances(moves(ctrl), clean[e])
    rows, ok_all = [], True
    for t in truth:
        e = float((t.get("recording") or {}).get("excitation", 0.0))
        d = distances(moves(work / "effects" / t["id"]), clean[e])
        ratio = {k: d[k] / max(floor[e][k], 1e-12) for k in d}
        n5 = sum(r >= 5 for r in ratio.values())
        n2 = sum(r >= 2 for r in ratio.values())
        ok = n5 >= 1 and n2 >= 2
        ok_all &= ok
        rows.append({"id": t["id"], "excitation": e, "distances": d, "ratios": ratio,
                     "n_ge_5x": n5, "n_ge_2x": n2, "material": ok})
    datasets = sorted([p.parent for p in work.glob("*/*/dataset.yaml")]
                      + [p.parent for p in work.glob("*/dataset.yaml")])
    fell = {str(p.relative_to(work)): falls(p) for p in datasets}
    n_fell = sum(len(v) for v in fell.values())
    passed = ok_all and n_fell == 0
    doc = {"passed": passed, "seed": a.seed, "floor": {f"{k:g}": v for k, v in floor.items()},
           "effects": rows, "falls": fell, "datasets_checked": len(datasets),
           "rule": "material: one distance >= 5x its floor and two >= 2x; no move fell"}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    keys = list(rows[0]["ratios"])
    md = ["# zoo17 check (SEALED)", "",
          f"Effects vs clean seed {a.seed} (same excitation); ratio = distance / floor "
          "(control with a negligible effect vs the same clean data).", "",
          "| id | exc | " + " | ".join(keys) + " | >=5x | >=2x | material |",
          "|" + "---|" * (len(keys) + 5)]
    for r in rows:
        md.append(f"| {r['id']} | {r['excitation']:g} | "
                  + " | ".join(f"{r['ratios'][k]:.1f}" for k in keys)
                  + f" | {r['n_ge_5x']} | {r['n_ge_2x']} | {'yes' if r['material'] else 'NO'} |")
    md += ["", "Floors: " + "; ".join(
        f"e{e}: " + ", ".join(f"{k} {v:.3g}" for k, v in f.items()) for e, f in doc["floor"].items()),
        "", f"Falls: {n_fell} moves fell in {len(datasets)} datasets "
        + (str({k: v for k, v in fell.items() if v}) if n_fell else ""),
        "", f"**{'PASSED' if passed else 'FAILED'}**", ""]
    (HERE / "check.md").write_text("\n".join(md))
    print("\n".join(md))
    return 0 if passed else 1


if __name__ == "__main__":
    raise SystemExit(main())
