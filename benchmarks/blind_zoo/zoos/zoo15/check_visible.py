"""Check every zoo15 effect dataset against the clean dataset of the same seed (zoo author's check).

For each effect (ids from the effect files in effects/, not from the truth) and the clean dataset of
the same seed (harness layout: WORK/effects/<id>, WORK/clean/s<seed>_e0), move by move (the same
names, hence the same gait parameters and sensor-noise seed):

- material change: the RMS difference of each signal group over the move, divided by that group's
  standard deviation over the clean dataset (nRMS), and the final (x, y) and yaw differences;
  material when the largest group nRMS (mean over moves) >= NRMS_MIN, or the mean final (x, y)
  difference >= XY_MIN_M, or the mean final yaw difference >= YAW_MIN_RAD;
- no fall: in every move the body stays above FALL_Z_FRACTION of its clean starting height and
  roll and pitch stay below FALL_TILT_RAD; every value finite.

Usage (repository root):  .venv/bin/python benchmarks/blind_zoo/zoos/zoo15/check_visible.py \
    --work WORK --seed 101 [--control DIR]   # writes check.md and check.json beside this file
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))   # the repository root

from littledog_mlsim.data.dataset import load_moves  # noqa: E402

NRMS_MIN = 0.10
XY_MIN_M = 0.03
YAW_MIN_RAD = 0.05
FALL_Z_FRACTION = 0.8
FALL_TILT_RAD = 0.35


def rpy(quat_xyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = (quat_xyzw[:, i] for i in range(4))
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, np.unwrap(yaw)], axis=1)


def groups(m) -> dict[str, np.ndarray]:
    a = rpy(m.orientation)
    return {"q": m.q, "dq": m.dq, "xy": m.position[:, :2] - m.position[:1, :2],
            "z": m.position[:, 2:3], "roll_pitch": a[:, :2], "yaw": a[:, 2:3] - a[:1, 2:3],
            "linear_velocity": m.linear_velocity, "angular_velocity": m.angular_velocity}


def fell(m, z0_clean: float) -> tuple[bool, dict]:
    a = rpy(m.orientation)
    finite = all(np.all(np.isfinite(x)) for x in (m.q, m.dq, m.position, m.orientation))
    zmin = float(np.min(m.position[:, 2]))
    tilt = float(np.max(np.abs(a[:, :2])))
    return (not finite or zmin < FALL_Z_FRACTION * z0_clean or tilt > FALL_TILT_RAD,
            {"z_min": zmin, "tilt_max": tilt, "finite": finite})


def compare(effect_dir: Path, clean_dir: Path, scale: dict[str, float]) -> dict:
    eff = {m.name: m for m in load_moves(effect_dir, split="all")}
    cln = {m.name: m for m in load_moves(clean_dir, split="all")}
    names = sorted(set(eff) & set(cln))
    per_group = {k: [] for k in scale}
    xy_final, yaw_final, falls, worst_tilt, worst_zfrac = [], [], [], 0.0, np.inf
    for n in names:
        ge, gc = groups(eff[n]), groups(cln[n])
        for k in scale:
            d = ge[k] - gc[k]
            per_group[k].append(float(np.sqrt(np.mean(d ** 2))) / scale[k])
        xy_final.append(float(np.linalg.norm(ge["xy"][-1] - gc["xy"][-1])))
        yaw_final.append(float(abs(ge["yaw"][-1, 0] - gc["yaw"][-1, 0])))
        z0 = float(cln[n].position[0, 2])
        f, info = fell(eff[n], z0)
        worst_tilt = max(worst_tilt, info["tilt_max"])
        worst_zfrac = min(worst_zfrac, info["z_min"] / z0)
        if f:
            falls.append({"move": n, **info})
    nrms = {k: float(np.mean(v)) for k, v in per_group.items()}
    top = max(nrms, key=nrms.get)
    material = (nrms[top] >= NRMS_MIN or np.mean(xy_final) >= XY_MIN_M
                or np.mean(yaw_final) >= YAW_MIN_RAD)
    return {"moves": len(names), "moves_effect": len(eff), "moves_clean": len(cln),
            "nrms": nrms, "largest_group": top, "largest_nrms": nrms[top],
            "final_xy_diff_mean_m": float(np.mean(xy_final)),
            "final_yaw_diff_mean_rad": float(np.mean(yaw_final)),
            "worst_tilt_rad": worst_tilt, "worst_z_fraction": float(worst_zfrac),
            "falls": falls, "material": bool(material),
            "complete": len(names) == len(eff) == len(cln),
            "passed": bool(material and not falls and len(names) == len(eff) == len(cln))}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=101)
    ap.add_argument("--out", default=str(HERE))
    ap.add_argument("--control", default=None,
                    help="optional: a dataset of the same seed and robot recorded with a "
                         "negligible effect (the floor of the differences), reported beside")
    a = ap.parse_args()
    work = Path(a.work)
    clean_dir = work / "clean" / f"s{a.seed}_e0"
    clean = load_moves(clean_dir, split="all")
    scale = {}
    for k in groups(clean[0]):
        allv = np.concatenate([groups(m)[k] for m in clean])
        scale[k] = float(np.sqrt(np.mean(np.var(allv, axis=0))))
    # the clean datasets of the other seeds and the reference: no fall either
    clean_falls = {}
    for d in sorted((work / "clean").glob("s*_e*")) + [work / "reference"]:
        if (d / "dataset.yaml").is_file():
            ms = load_moves(d, split="all")
            clean_falls[str(d.relative_to(work))] = sum(
                fell(m, float(m.position[0, 2]))[0] for m in ms)
    ids = sorted(p.stem for p in (HERE / "effects").glob("z*.yaml"))
    rows = {}
    for i in ids:
        d = work / "effects" / i
        if not (d / "dataset.yaml").is_file():
            rows[i] = {"passed": False, "missing": True}
            continue
        rows[i] = compare(d, clean_dir, scale)
    control = (compare(Path(a.control), clean_dir, scale) if a.control else None)
    doc = {"work": str(work), "control": control, "control_dir": a.control, "seed": a.seed, "clean": str(clean_dir),
           "thresholds": {"nrms_min": NRMS_MIN, "xy_min_m": XY_MIN_M, "yaw_min_rad": YAW_MIN_RAD,
                          "fall_z_fraction": FALL_Z_FRACTION, "fall_tilt_rad": FALL_TILT_RAD},
           "group_scale_clean": scale, "clean_datasets_falls": clean_falls, "effects": rows,
           "all_passed": all(r["passed"] for r in rows.values()),
           "passed_count": sum(r["passed"] for r in rows.values()), "count": len(rows)}
    out = Path(a.out)
    (out / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo15 check_visible results", "",
             f"Effect datasets of seed {a.seed} against the clean dataset of the same seed "
             f"(`{clean_dir}`), {doc['passed_count']} of {doc['count']} passed. Thresholds: "
             f"largest group nRMS >= {NRMS_MIN} or final (x, y) diff >= {XY_MIN_M} m or final "
             f"yaw diff >= {YAW_MIN_RAD} rad (material); z >= {FALL_Z_FRACTION} of the clean "
             f"start height and |roll|, |pitch| <= {FALL_TILT_RAD} rad in every move (no fall).",
             "", "| id | moves | largest group (nRMS) | q nRMS | xy nRMS | final xy diff [m] | "
             "final yaw diff [rad] | worst tilt [rad] | worst z / z0 | falls | material | passed |",
             "|" + "---|" * 12]
    for i, r in rows.items():
        if r.get("missing"):
            lines.append(f"| {i} | missing | | | | | | | | | | no |")
            continue
        lines.append(
            f"| {i} | {r['moves']} | {r['largest_group']} ({r['largest_nrms']:.3f}) | "
            f"{r['nrms']['q']:.3f} | {r['nrms']['xy']:.3f} | {r['final_xy_diff_mean_m']:.3f} | "
            f"{r['final_yaw_diff_mean_rad']:.3f} | {r['worst_tilt_rad']:.3f} | "
            f"{r['worst_z_fraction']:.2f} | {len(r['falls'])} | "
            f"{'yes' if r['material'] else 'no'} | {'yes' if r['passed'] else 'no'} |")
    if control is not None:
        lines += ["", f"Control (`{a.control}`, same seed and robot, a negligible effect: the "
                  f"floor of these differences): largest group {control['largest_group']} "
                  f"({control['largest_nrms']:.3f}), q nRMS {control['nrms']['q']:.3f}, final xy "
                  f"diff {control['final_xy_diff_mean_m']:.4f} m, final yaw diff "
                  f"{control['final_yaw_diff_mean_rad']:.4f} rad, falls {len(control['falls'])}."]
    lines += ["", "Clean datasets (falls per dataset): " +
              ", ".join(f"{k}: {v}" for k, v in clean_falls.items()), ""]
    (out / "check.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if doc["all_passed"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
