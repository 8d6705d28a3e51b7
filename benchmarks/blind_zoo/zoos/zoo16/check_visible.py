"""zoo16's check: every effect dataset differs materially from the clean dataset of the same
seed, and no move of any dataset fell. (Not sealed: it holds no effect value.)

Material: for each effect dataset, four distances to the clean dataset of the same seed, move
by move (same name = same gait and sensor noise): final (x, y) position [m], joint angles (RMS
over time and joints, in units of the clean data's per-joint std), body twist (likewise, the 6
twist elements) and body height/attitude (likewise: z and the gravity direction in base_link).
A control dataset with a negligible effect (a 1 mN m Coulomb friction on every joint, recorded
by this script with the same robot, seed and moves) gives each distance's floor; an effect is
material when at least one distance is >= FACTOR times its floor and at least two are >=
FACTOR_2 times theirs. Fallen: the body's z axis more than 45 deg from vertical, or the base
below half its height at t = 0, at any sample.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo16/check_visible.py \
        --work WORK --robot benchmarks/blind_zoo/zoos/zoo16/gap_robot.json --seed 101
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[3]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.data.dataset import load_moves  # noqa: E402

FACTOR = 5.0
FACTOR_2 = 2.0
CONTROL = "- class: littledog_mlsim.robot.effects:JointFriction\n  params: {coulomb: 0.001}\n"
METRICS = ("final_xy_m", "joint_angles", "twist", "height_attitude")


def up_in_body(orn: np.ndarray) -> np.ndarray:
    """World z expressed in base_link for quaternions (n, 4) xyzw: the third row of R."""
    x, y, z, w = orn.T
    return np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1)


def moves(path: Path) -> dict:
    return {m.name: m for m in load_moves(path, split="all")}


def fell(m) -> tuple[bool, float, float]:
    tilt = np.degrees(np.arccos(np.clip(up_in_body(m.orientation)[:, 2], -1, 1)))
    z = m.position[:, 2]
    rel = float(z.min() / z[0])
    return bool(tilt.max() > 45.0 or rel < 0.5), float(tilt.max()), rel


def distances(eff: dict, clean: dict) -> dict:
    names = sorted(set(eff) & set(clean))
    cq = np.concatenate([clean[n].q for n in names])
    ct = np.concatenate([np.hstack([clean[n].linear_velocity, clean[n].angular_velocity])
                         for n in names])
    ch = np.concatenate([np.hstack([clean[n].position[:, 2:], up_in_body(clean[n].orientation)])
                         for n in names])
    sq, st, sh = cq.std(0) + 1e-9, ct.std(0) + 1e-9, ch.std(0) + 1e-9
    fx, jq, tw, ha = [], [], [], []
    for n in names:
        e, c = eff[n], clean[n]
        k = min(len(e.q), len(c.q))
        fx.append(np.hypot(*(e.position[k - 1, :2] - c.position[k - 1, :2])))
        jq.append(np.sqrt(np.mean(((e.q[:k] - c.q[:k]) / sq) ** 2)))
        et = np.hstack([e.linear_velocity, e.angular_velocity])[:k]
        ctm = np.hstack([c.linear_velocity, c.angular_velocity])[:k]
        tw.append(np.sqrt(np.mean(((et - ctm) / st) ** 2)))
        eh = np.hstack([e.position[:, 2:], up_in_body(e.orientation)])[:k]
        chm = np.hstack([c.position[:, 2:], up_in_body(c.orientation)])[:k]
        ha.append(np.sqrt(np.mean(((eh - chm) / sh) ** 2)))
    return {"final_xy_m": float(np.mean(fx)), "joint_angles": float(np.mean(jq)),
            "twist": float(np.mean(tw)), "height_attitude": float(np.mean(ha)),
            "n_moves": len(names)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True, help="the harness's WORK directory")
    ap.add_argument("--robot", required=True, help="the gap robot's twin file")
    ap.add_argument("--seed", type=int, default=101)
    ap.add_argument("--moves-per-type", type=int, default=10)
    ap.add_argument("--out", default=str(HERE), help="where check.md / check.json go")
    a = ap.parse_args()
    work = Path(a.work)
    control = work / "control"
    if not (control / "dataset.yaml").is_file():
        (work / "control_effect.yaml").write_text(CONTROL)
        subprocess.run([sys.executable, "-m", "littledog_mlsim.cli", "record", "--out",
                        str(control), "--moves-per-type", str(a.moves_per_type), "--seed",
                        str(a.seed), "--jobs", "2", "--quiet", "--effects",
                        str(work / "control_effect.yaml"), "--robot", str(Path(a.robot).resolve())],
                       check=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    clean = moves(work / "clean" / f"s{a.seed}_e0")
    floor = distances(moves(control), clean)
    rows, falls = [], {}
    all_sets = ([("clean", p) for p in sorted((work / "clean").iterdir()) if p.is_dir()]
                + [("reference", work / "reference")] + [("control", control)]
                + [("effect", p) for p in sorted((work / "effects").iterdir()) if p.is_dir()])
    for kind, path in all_sets:
        ms = moves(path)
        f = [(n, *fell(m)) for n, m in ms.items()]
        falls[f"{kind}:{path.name}"] = {
            "moves": len(f), "fallen": [n for n, x, _, _ in f if x],
            "max_tilt_deg": max(t for _, _, t, _ in f),
            "min_height_ratio": min(r for _, _, _, r in f)}
        if kind == "effect":
            d = distances(ms, clean)
            ratios = {k: d[k] / floor[k] for k in METRICS}
            material = (max(ratios.values()) >= FACTOR
                        and sum(r >= FACTOR_2 for r in ratios.values()) >= 2)
            rows.append({"effect": path.name, **d, "ratios": ratios, "material": material})
    ok_falls = all(not v["fallen"] for v in falls.values())
    ok_mat = all(r["material"] for r in rows)
    doc = {"seed": a.seed, "factor": FACTOR, "factor_2": FACTOR_2, "floor_control": floor,
           "effects": rows, "falls": falls, "all_material": ok_mat, "none_fell": ok_falls,
           "passed": ok_mat and ok_falls}
    out = Path(a.out)
    (out / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    md = ["# zoo16 check: material and upright", "",
          f"Seed {a.seed}; distances to the clean dataset of the same seed; floor: a control "
          f"dataset with a negligible effect. Material: one ratio >= {FACTOR:g} and two >= "
          f"{FACTOR_2:g}.", "",
          "| dataset | final xy [m] | joint angles | twist | height/attitude | ratios to floor "
          "(xy, q, twist, h/att) | material |", "|---|---|---|---|---|---|---|",
          f"| control (floor) | {floor['final_xy_m']:.4f} | {floor['joint_angles']:.4f} | "
          f"{floor['twist']:.4f} | {floor['height_attitude']:.4f} | 1 | - |"]
    for r in rows:
        q = r["ratios"]
        md.append(f"| {r['effect']} | {r['final_xy_m']:.4f} | {r['joint_angles']:.4f} | "
                  f"{r['twist']:.4f} | {r['height_attitude']:.4f} | "
                  + ", ".join(f"{q[k]:.1f}" for k in METRICS)
                  + f" | {'yes' if r['material'] else 'NO'} |")
    md += ["", "| dataset | moves | fallen | max tilt [deg] | min height / start |",
           "|---|---|---|---|---|"]
    for k, v in falls.items():
        md.append(f"| {k} | {v['moves']} | {len(v['fallen'])} {v['fallen'] or ''} | "
                  f"{v['max_tilt_deg']:.1f} | {v['min_height_ratio']:.2f} |")
    md += ["", f"All material: {'yes' if ok_mat else 'NO'}; none fell: "
           f"{'yes' if ok_falls else 'NO'}; check {'passed' if doc['passed'] else 'FAILED'}."]
    (out / "check.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    return 0 if doc["passed"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
