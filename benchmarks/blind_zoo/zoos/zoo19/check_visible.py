"""zoo19's check (sealed): every effect changes the recordings materially, and no move falls.

From the repository root, after the harness's --record-only run into WORK:
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo19/check_visible.py \
        --work /tmp/s54/z19
It records null datasets (the gap robot with a negligible body force, `null_effect.yaml`) of
seed 101 at each excitation the zoo uses, the chaos floor. For each effect dataset D and the
clean dataset C of the same seed and excitation, per signal group g (joint angles, joint rates,
body xy position, attitude, body linear and angular velocity):

    d_g(D) = mean over moves of the RMS over time of (D - C) in group g

and the same for the null dataset N against C. The effect is material when, for at least one
group, d_g(D) >= 3 d_g(N) and d_g(D) exceeds the group's absolute floor below (so a ratio on a
tiny null does not pass alone). Falls: a move falls where the body's height in odom drops below
0.08 m or its tilt (angle of the body z axis from the world z axis) exceeds 20 deg
(the clean trot stays below 8 deg; a collapse onto the knees reaches 35-40 deg).
Writes check.md and check.json beside this file.
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

ROOT = Path(__file__).resolve().parents[4]
sys.path.insert(0, str(ROOT))
from littledog_mlsim.data.dataset import load_moves  # noqa: E402

HERE = Path(__file__).resolve().parent
RATIO = 3.0
FLOOR = {"q": 0.005, "dq": 0.05, "xy": 0.005, "att": 0.005, "v": 0.005, "w": 0.02}
Z_MIN, TILT_MAX = 0.08, 20.0


def quat_zaxis(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q.T
    return np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=1)


def rpy(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, np.unwrap(yaw)], axis=1)


def signals(m) -> dict[str, np.ndarray]:
    return {"q": m.q, "dq": m.dq, "xy": m.position[:, :2], "att": rpy(m.orientation),
            "v": m.linear_velocity, "w": m.angular_velocity}


def load(path: Path) -> dict[str, object]:
    return {m.name: m for m in load_moves(path, "all")}


def distance(a: dict, b: dict) -> dict[str, float]:
    out = {}
    for g in FLOOR:
        vals = []
        for name, ma in a.items():
            sa, sb = signals(ma)[g], signals(b[name])[g]
            n = min(len(sa), len(sb))
            vals.append(float(np.sqrt(np.mean((sa[:n] - sb[:n]) ** 2))))
        out[g] = float(np.mean(vals))
    return out


def falls(moves: dict) -> list[str]:
    bad = []
    for name, m in moves.items():
        tilt = np.degrees(np.arccos(np.clip(quat_zaxis(m.orientation)[:, 2], -1, 1)))
        if m.position[:, 2].min() < Z_MIN or tilt.max() > TILT_MAX:
            bad.append(name)
    return bad


def record_null(work: Path, exc: float) -> Path:
    out = work / "check" / f"null_s101_e{exc:g}"
    if not (out / "dataset.yaml").is_file():
        cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
               "--moves-per-type", "10", "--seed", "101", "--jobs", "2", "--quiet",
               "--robot", str(HERE / "gap_robot.json"), "--effects",
               str(HERE / "null_effect.yaml")]
        if exc:
            cmd += ["--excitation", f"{exc:g}"]
        subprocess.run(cmd, check=True, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    excs = sorted({0.0} | {float((t.get("recording") or {}).get("excitation", 0.0))
                           for t in truth})
    clean = {e: load(work / "clean" / f"s101_e{e:g}") for e in excs}
    null = {e: load(record_null(work, e)) for e in excs}
    floor = {e: distance(null[e], clean[e]) for e in excs}
    rows, all_ok = [], True
    for t in truth:
        e = float((t.get("recording") or {}).get("excitation", 0.0))
        d = load(work / "effects" / t["id"])
        dist = distance(d, clean[e])
        ratio = {g: dist[g] / floor[e][g] if floor[e][g] > 0 else float("inf") for g in FLOOR}
        passing = [g for g in FLOOR if ratio[g] >= RATIO and dist[g] >= FLOOR[g]]
        fell = falls(d)
        ok = bool(passing) and not fell
        all_ok &= ok
        rows.append({"id": t["id"], "excitation": e, "distance": dist, "ratio": ratio,
                     "material_groups": passing, "fallen_moves": fell, "ok": ok})
    others = {}
    for p in sorted((work / "clean").iterdir()):
        if (p / "dataset.yaml").is_file():
            others[f"clean/{p.name}"] = falls(load(p))
    others["reference"] = falls(load(work / "reference"))
    for e in excs:
        others[f"check/null_s101_e{e:g}"] = falls(null[e])
    all_ok &= not any(others.values())
    doc = {"ratio_needed": RATIO, "absolute_floor": FLOOR, "fall": {"z_min_m": Z_MIN,
           "tilt_max_deg": TILT_MAX}, "null_floor": {f"{e:g}": floor[e] for e in excs},
           "effects": rows, "falls_other_datasets": others, "all_ok": all_ok}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    L = ["# zoo19 check (sealed)", "",
         f"Material: some signal group with d(effect, clean) >= {RATIO:g} x d(null, clean) and "
         "above its absolute floor; d = mean over moves of the RMS over time of the difference "
         "(same seed 101, same excitation). Falls: height < 0.08 m or tilt > 20 deg.", "",
         "Null floor (d(null, clean)): " + "; ".join(
             f"e{e:g}: " + ", ".join(f"{g} {floor[e][g]:.4g}" for g in FLOOR) for e in excs), "",
         "| effect | exc | " + " | ".join(f"{g} d (ratio)" for g in FLOOR)
         + " | material groups | fallen | ok |", "|" + "---|" * (len(FLOOR) + 5)]
    for r in rows:
        L.append(f"| {r['id']} | {r['excitation']:g} | " + " | ".join(
            f"{r['distance'][g]:.4g} ({r['ratio'][g]:.1f})" for g in FLOOR)
            + f" | {', '.join(r['material_groups']) or '-'} | {len(r['fallen_moves'])} | "
            f"{'yes' if r['ok'] else 'NO'} |")
    L += ["", "| other dataset | fallen moves |", "|---|---|"]
    L += [f"| {k} | {len(v)} |" for k, v in others.items()]
    L += ["", f"All effects material and no move fell: {'yes' if all_ok else 'NO'}"]
    (HERE / "check.md").write_text("\n".join(L) + "\n")
    print("\n".join(L))
    return 0 if all_ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
