"""Checks that every effect of zoo22 changes its recording materially, against the clean recording
of the same seed and recording condition (same gait, same sensor noise), and that no move falls.

Reads the datasets the harness recorded (``run.py --record-only --work WORK``):
WORK/effects/<id>, WORK/clean/s<seed>_e<exc>, WORK/reference. Writes check.md and check.json
beside this file. Run:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo22/check_visible.py \
        --work /tmp/s57/z22

Per effect, over the 110 moves paired by bag name: final (x, y) difference [m], final yaw
difference [rad], RMS joint-angle difference [rad] and RMS body-height difference [m].
Material: mean final (x, y) difference >= 0.01 m, or mean final yaw difference >= 0.03 rad, or
mean RMS joint difference >= 0.008 rad (8 % of the soft servo's ~0.1 rad tracking error).
Fallen move: |roll| or |pitch| above 0.5 rad, or the base 0.045 m below where it started.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves

HERE = Path(__file__).resolve().parent
XY_M, YAW_RAD, Q_RAD = 0.01, 0.03, 0.008
TILT_RAD, DROP_M = 0.5, 0.045


def euler(q: np.ndarray) -> np.ndarray:
    """roll, pitch, yaw (N, 3) of xyzw quaternions (N, 4)."""
    x, y, z, w = q.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, np.unwrap(yaw)], axis=1)


def falls(moves) -> list[str]:
    out = []
    for m in moves:
        e = euler(m.orientation)
        if (np.abs(e[:, :2]).max() > TILT_RAD
                or m.position[:, 2].min() < m.position[0, 2] - DROP_M):
            out.append(m.name)
    return out


def compare(eff, clean) -> dict:
    by = {m.name: m for m in clean}
    xy, yaw, qr, zr = [], [], [], []
    per_type: dict[str, list[float]] = {}
    for m in eff:
        c = by[m.name]
        d = float(np.linalg.norm(m.position[-1, :2] - c.position[-1, :2]))
        xy.append(d)
        yaw.append(float(abs(euler(m.orientation)[-1, 2] - euler(c.orientation)[-1, 2])))
        qr.append(float(np.sqrt(np.mean((m.q - c.q) ** 2))))
        zr.append(float(np.sqrt(np.mean((m.position[:, 2] - c.position[:, 2]) ** 2))))
        per_type.setdefault(m.move_type, []).append(d)
    r = {"moves": len(xy), "final_xy_diff_mean_m": float(np.mean(xy)),
         "final_xy_diff_median_m": float(np.median(xy)), "final_xy_diff_max_m": float(np.max(xy)),
         "moves_xy_diff_over_1cm": int(np.sum(np.array(xy) > 0.01)),
         "final_yaw_diff_mean_rad": float(np.mean(yaw)),
         "joint_rms_diff_mean_rad": float(np.mean(qr)),
         "height_rms_diff_mean_m": float(np.mean(zr)),
         "final_xy_diff_mean_by_type_m": {k: float(np.mean(v)) for k, v in per_type.items()}}
    r["material"] = bool(r["final_xy_diff_mean_m"] >= XY_M or r["final_yaw_diff_mean_rad"] >= YAW_RAD
                         or r["joint_rms_diff_mean_rad"] >= Q_RAD)
    return r


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=131)
    a = ap.parse_args()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    doc: dict = {"thresholds": {"xy_m": XY_M, "yaw_rad": YAW_RAD, "joint_rms_rad": Q_RAD,
                                "tilt_rad": TILT_RAD, "drop_m": DROP_M},
                 "effects": {}, "clean": {}}
    clean_cache: dict[float, list] = {}
    for d in sorted((work / "clean").iterdir()):
        if (d / "dataset.yaml").is_file():
            mv = load_moves(d, split="all")
            doc["clean"][d.name] = {"moves": len(mv), "fallen": falls(mv)}
            if d.name.startswith(f"s{a.seed}_e"):
                clean_cache[float(d.name.split("_e")[1])] = mv
    ref = work / "reference"
    if (ref / "dataset.yaml").is_file():
        mv = load_moves(ref, split="all")
        doc["clean"]["reference"] = {"moves": len(mv), "fallen": falls(mv)}
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        mv = load_moves(work / "effects" / t["id"], split="all")
        r = compare(mv, clean_cache[exc])
        r["excitation"] = exc
        r["fallen"] = falls(mv)
        doc["effects"][t["id"]] = r
    ok = all(r["material"] and not r["fallen"] for r in doc["effects"].values()) and \
        all(not c["fallen"] for c in doc["clean"].values())
    doc["all_material_and_upright"] = ok
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo22: every effect against the clean recording of its seed and excitation", "",
             f"Datasets: `{work}` (seed {a.seed}, 10 moves per type, gap robot). Material: mean "
             f"final (x, y) difference >= {XY_M} m, or mean final yaw difference >= {YAW_RAD} "
             f"rad, or mean RMS joint difference >= {Q_RAD} rad. Fallen: |roll| or |pitch| > "
             f"{TILT_RAD} rad, or the base {DROP_M} m below its start.", "",
             "| effect | exc. | final xy diff mean / median / max [m] | moves > 1 cm | "
             "final yaw diff mean [rad] | joint RMS diff [rad] | height RMS diff [m] | "
             "material | fallen moves |", "|---|---|---|---|---|---|---|---|---|"]
    for k, r in doc["effects"].items():
        lines.append(f"| {k} | {r['excitation']:g} | {r['final_xy_diff_mean_m']:.4f} / "
                     f"{r['final_xy_diff_median_m']:.4f} / {r['final_xy_diff_max_m']:.4f} | "
                     f"{r['moves_xy_diff_over_1cm']}/{r['moves']} | "
                     f"{r['final_yaw_diff_mean_rad']:.4f} | {r['joint_rms_diff_mean_rad']:.4f} | "
                     f"{r['height_rms_diff_mean_m']:.4f} | {'yes' if r['material'] else 'NO'} | "
                     f"{len(r['fallen'])} |")
    lines += ["", "| clean dataset | moves | fallen moves |", "|---|---|---|"]
    for k, c in doc["clean"].items():
        lines.append(f"| {k} | {c['moves']} | {len(c['fallen'])} |")
    lines += ["", f"All effects material and no move fallen: **{'yes' if ok else 'NO'}**", ""]
    (HERE / "check.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
