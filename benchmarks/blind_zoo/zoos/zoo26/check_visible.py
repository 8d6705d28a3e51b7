"""Checks that every zoo26 effect changes its recording materially, against the clean dataset of
the same seed and recording condition (same commands, same noise draws: every difference is the
effect's), and that no move of any dataset falls.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo26/check_visible.py \
        --work WORK

Reads WORK/effects/<id>, WORK/clean/s<seed>_e<exc> and WORK/reference (recorded by
harness/run.py --record-only); writes check.md and check.json beside this file.

The open-loop trot of the soft-servo robot is sensitive to any perturbation (a 1 mN push
already decorrelates the hip rolls' rates within a move), so every difference is also set against
a **floor**: the same clean seed recorded with a negligible effect (a constant 1 mN horizontal
force, ``WORK/floor/s<seed>_e0``, recorded here with ``record`` if absent). Material: over the
dataset's moves (all 110), at least one of
- the body's final (x, y) position moves by >= ``XY_M`` on average (the rollout metric's scale)
  and by >= ``FLOOR_RATIO`` times the floor's;
- the final heading moves by >= ``YAW_RAD`` on average and by >= ``FLOOR_RATIO`` times the
  floor's;
- the mean over the state elements of the RMS difference relative to the element's clean spread
  (standard deviation over the clean dataset) is >= ``FLOOR_RATIO`` times the floor's.
A move falls when the body drops below ``FALL_Z`` m or its roll or pitch exceeds ``FALL_TILT``.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.layout import JOINT_NAMES

HERE = Path(__file__).resolve().parent
XY_M = 0.02
YAW_RAD = 0.05
FLOOR_RATIO = 3.0
FLOOR_EFFECT = """- class: littledog_mlsim.robot.effects:ConstantWind
  params: {force_xy: [0.001, 0.0]}
"""
FALL_Z = 0.07
FALL_TILT = 0.7


def _yaw_roll_pitch(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return yaw, roll, pitch


def _signals(m) -> dict[str, np.ndarray]:
    yaw, roll, pitch = _yaw_roll_pitch(np.asarray(m.orientation))
    out = {"z": np.asarray(m.position)[:, 2], "roll": roll, "pitch": pitch}
    for k, n in enumerate(("dx_b", "dy_b", "dz_b")):
        out[n] = np.asarray(m.linear_velocity)[:, k]
    for k, n in enumerate(("droll", "dpitch", "dyaw")):
        out[n] = np.asarray(m.angular_velocity)[:, k]
    for j, n in enumerate(JOINT_NAMES):
        out["q_" + n] = np.asarray(m.q)[:, j]
        out["dq_" + n] = np.asarray(m.dq)[:, j]
    return out


def falls(moves) -> list[str]:
    bad = []
    for m in moves:
        _, roll, pitch = _yaw_roll_pitch(np.asarray(m.orientation))
        if (np.min(np.asarray(m.position)[:, 2]) < FALL_Z
                or np.max(np.abs(roll)) > FALL_TILT or np.max(np.abs(pitch)) > FALL_TILT):
            bad.append(m.name)
    return bad


def compare(eff, clean, floor: dict | None = None) -> dict:
    by = {m.name: m for m in clean}
    xy, dyaw, diffs, ref = [], [], {}, {}
    for m in eff:
        c = by[m.name]
        xy.append(float(np.hypot(*(np.asarray(m.position)[-1, :2]
                                   - np.asarray(c.position)[-1, :2]))))
        ye, _, _ = _yaw_roll_pitch(np.asarray(m.orientation)[-1:])
        yc, _, _ = _yaw_roll_pitch(np.asarray(c.orientation)[-1:])
        dyaw.append(float(abs((ye[0] - yc[0] + np.pi) % (2 * np.pi) - np.pi)))
        se, sc = _signals(m), _signals(c)
        for k in se:
            diffs.setdefault(k, []).append(se[k] - sc[k])
            ref.setdefault(k, []).append(sc[k])
    nrms = {k: float(np.sqrt(np.mean(np.concatenate(diffs[k]) ** 2))
                     / max(np.std(np.concatenate(ref[k])), 1e-9)) for k in diffs}
    top = sorted(nrms.items(), key=lambda kv: -kv[1])[:3]
    out = {"moves": len(eff), "xy_shift_mean_m": float(np.mean(xy)),
           "yaw_shift_mean_rad": float(np.mean(dyaw)),
           "nrms_max": top[0][1], "nrms_top3": [[k, v] for k, v in top],
           "nrms_mean": float(np.mean(list(nrms.values())))}
    if floor is not None:
        k = FLOOR_RATIO
        out["vs_floor"] = {"xy": out["xy_shift_mean_m"] / floor["xy_shift_mean_m"],
                           "yaw": out["yaw_shift_mean_rad"] / floor["yaw_shift_mean_rad"],
                           "nrms_mean": out["nrms_mean"] / floor["nrms_mean"]}
        out["material"] = bool(
            (out["xy_shift_mean_m"] >= XY_M and out["vs_floor"]["xy"] >= k)
            or (out["yaw_shift_mean_rad"] >= YAW_RAD and out["vs_floor"]["yaw"] >= k)
            or out["vs_floor"]["nrms_mean"] >= k)
    return out


def floor_dataset(work: Path, seed: int) -> Path:
    """The clean seed recorded with a negligible effect, with the zoo's gap robot."""
    d = work / "floor" / f"s{seed}_e0"
    if not (d / "dataset.yaml").is_file():
        d.parent.mkdir(parents=True, exist_ok=True)
        eff = d.parent / "floor.yaml"
        eff.write_text(FLOOR_EFFECT)
        subprocess.run([sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(d),
                        "--moves-per-type", "10", "--seed", str(seed), "--jobs", "2", "--quiet",
                        "--effects", str(eff), "--robot", str(HERE / "gap_robot.json")],
                       check=True)
    return d


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=171)
    a = ap.parse_args()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    clean_cache: dict[str, list] = {}
    rows, fall_rows = [], []

    def clean(exc: float) -> list:
        key = f"s{a.seed}_e{exc:g}"
        if key not in clean_cache:
            clean_cache[key] = load_moves(work / "clean" / key, split="all")
        return clean_cache[key]

    floor = compare(load_moves(floor_dataset(work, a.seed), split="all"), clean(0.0))
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        eff = load_moves(work / "effects" / t["id"], split="all")
        r = compare(eff, clean(exc), floor)
        r.update({"id": t["id"], "excitation": exc, "falls": falls(eff)})
        rows.append(r)
    for d in sorted((work / "clean").iterdir()) + [work / "reference"]:
        if (d / "dataset.yaml").is_file():
            fall_rows.append({"dataset": str(d.relative_to(work)),
                              "falls": falls(load_moves(d, split="all"))})
    ok = all(r["material"] and not r["falls"] for r in rows) and not any(
        f["falls"] for f in fall_rows)
    doc = {"work": str(work), "seed": a.seed,
           "thresholds": {"xy_m": XY_M, "yaw_rad": YAW_RAD, "floor_ratio": FLOOR_RATIO, "fall_z_m": FALL_Z,
                          "fall_tilt_rad": FALL_TILT},
           "floor": floor, "effects": rows, "clean_and_reference": fall_rows, "all_pass": ok}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    md = ["# zoo26: materiality and falls (check_visible.py)", "",
          f"WORK `{work}`; each effect dataset (seed {a.seed}, 10 moves per type) against the clean "
          "dataset of the same seed and excitation. Material: mean final (x, y) shift >= "
          f"{XY_M} m and {FLOOR_RATIO:g}x the floor's, or mean final heading shift >= {YAW_RAD} "
          f"rad and {FLOOR_RATIO:g}x the floor's, or mean element nRMS difference >= "
          f"{FLOOR_RATIO:g}x the floor's. Floor: the same clean seed with a 1 mN push. Fall: z < "
          f"{FALL_Z} m or |roll|, |pitch| > {FALL_TILT} rad.", "",
          "| effect | exc. | mean xy shift [m] (x floor) | mean yaw shift [rad] (x floor) | "
          "mean nRMS (x floor) | material | falls |", "|---|---|---|---|---|---|---|",
          f"| floor (1 mN) | 0 | {floor['xy_shift_mean_m']:.4f} | "
          f"{floor['yaw_shift_mean_rad']:.4f} | {floor['nrms_mean']:.3f} | - | - |"]
    for r in rows:
        v = r["vs_floor"]
        md.append(f"| {r['id']} | {r['excitation']:g} | {r['xy_shift_mean_m']:.3f} "
                  f"({v['xy']:.1f}) | {r['yaw_shift_mean_rad']:.3f} ({v['yaw']:.1f}) | "
                  f"{r['nrms_mean']:.3f} ({v['nrms_mean']:.1f}) | "
                  f"{'yes' if r['material'] else 'NO'} | {len(r['falls'])} |")
    md += ["", "| dataset | falls |", "|---|---|"]
    md += [f"| {f['dataset']} | {len(f['falls'])} |" for f in fall_rows]
    md += ["", f"All pass: {'yes' if ok else 'NO'}", ""]
    (HERE / "check.md").write_text("\n".join(md))
    print("\n".join(md))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
