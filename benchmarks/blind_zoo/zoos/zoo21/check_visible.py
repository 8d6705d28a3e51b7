"""zoo21: is every effect material, and does no recording fall over?

For each effect of truth.yaml, its dataset (WORK/effects/<id>) is compared move by move with the
clean dataset of the same seed and excitation (WORK/clean/s<seed>_e<exc>), and so is a null
recording (null_effect.yaml: a 1 mN force, WORK/null/e<exc>, recorded here if missing, same seed,
robot and excitation). Material: the mean final (x, y) difference AND the largest per-signal RMS
difference are each at least 3x the null recording's. A fall: any measurement with the body
lower than half its starting height or |roll| or |pitch| above 0.7 rad, in any dataset of WORK.

    python benchmarks/blind_zoo/zoos/zoo21/check_visible.py --work WORK [--seed 121]
Writes check.md and check.json beside this file.
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

HERE = Path(__file__).resolve().parent
RATIO = 3.0
SIGNALS = ("q", "dq", "xy", "z", "roll_pitch", "yaw", "linear_velocity", "angular_velocity")


def rpy(qxyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = qxyzw.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=1)


def signals(m) -> dict[str, np.ndarray]:
    a = rpy(m.orientation)
    return {"q": m.q, "dq": m.dq, "xy": m.position[:, :2], "z": m.position[:, 2:],
            "roll_pitch": a[:, :2], "yaw": np.unwrap(a[:, 2])[:, None],
            "linear_velocity": m.linear_velocity, "angular_velocity": m.angular_velocity}


def falls(moves) -> list[str]:
    out = []
    for m in moves:
        a = rpy(m.orientation)
        if (m.position[:, 2].min() < 0.5 * m.position[0, 2]
                or np.abs(a[:, :2]).max() > 0.7):
            out.append(m.name)
    return out


def compare(a, b) -> dict[str, float]:
    by_a = {m.name: m for m in a}
    res = {s: [] for s in SIGNALS}
    xy = []
    for mb in b:
        ma = by_a[mb.name]
        sa, sb = signals(ma), signals(mb)
        for s in SIGNALS:
            res[s].append(np.mean((sa[s] - sb[s]) ** 2))
        xy.append(float(np.hypot(*(ma.position[-1, :2] - mb.position[-1, :2]))))
    out = {s: float(np.sqrt(np.mean(v))) for s, v in res.items()}
    out["final_xy"] = float(np.mean(xy))
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=121)
    ap.add_argument("--moves-per-type", type=int, default=10)
    a = ap.parse_args()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    excs = sorted({0.0} | {float((t.get("recording") or {}).get("excitation", 0.0)) for t in truth})
    load = lambda d: load_moves(d, split="all")  # noqa: E731
    null, clean = {}, {}
    for e in excs:
        nd = work / "null" / f"e{e:g}"
        if not (nd / "dataset.yaml").is_file():
            cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(nd),
                   "--moves-per-type", str(a.moves_per_type), "--seed", str(a.seed), "--jobs",
                   "2", "--quiet", "--robot", str(HERE / "gap_robot.json"),
                   "--effects", str(HERE / "null_effect.yaml")]
            if e:
                cmd += ["--excitation", f"{e:g}"]
            subprocess.run(cmd, check=True)
        clean[e] = load(work / "clean" / f"s{a.seed}_e{e:g}")
        null[e] = compare(load(nd), clean[e])
    rows = []
    for t in truth:
        e = float((t.get("recording") or {}).get("excitation", 0.0))
        moves = load(work / "effects" / t["id"])
        d = compare(moves, clean[e])
        ratios = {k: d[k] / null[e][k] if null[e][k] > 0 else float("inf") for k in d}
        best = max(SIGNALS, key=lambda s: ratios[s])
        fl = falls(moves)
        rows.append({"id": t["id"], "excitation": e, "diff": d, "null": null[e],
                     "ratio": ratios, "best_signal": best,
                     "material": bool(ratios["final_xy"] >= RATIO and ratios[best] >= RATIO),
                     "falls": fl})
    other_falls = {}
    for d in sorted((work / "clean").glob("*")) + [work / "reference"] + sorted(
            (work / "null").glob("*")):
        if (d / "dataset.yaml").is_file():
            other_falls[str(d.relative_to(work))] = falls(load(d))
    doc = {"work": str(work), "seed": a.seed, "ratio_required": RATIO, "rows": rows,
           "falls_elsewhere": other_falls,
           "all_material": all(r["material"] for r in rows),
           "no_falls": not any(r["falls"] for r in rows) and not any(other_falls.values())}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo21 check_visible", "",
             f"WORK `{work}`, seed {a.seed}; material = final (x,y) difference and the largest "
             f"per-signal RMS difference each >= {RATIO:g}x the null recording's (1 mN force, "
             "same seed, robot and excitation).", "",
             "| id | exc. | final xy diff [m] (null) | ratio | largest-ratio signal: RMS diff (null) | "
             "ratio | material | falls |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        s = r["best_signal"]
        lines.append(f"| {r['id']} | {r['excitation']:g} | {r['diff']['final_xy']:.4f} "
                     f"({r['null']['final_xy']:.4f}) | {r['ratio']['final_xy']:.1f} | {s}: "
                     f"{r['diff'][s]:.4g} ({r['null'][s]:.3g}) | {r['ratio'][s]:.1f} | "
                     f"{'yes' if r['material'] else 'NO'} | {len(r['falls'])} |")
    lines += ["", "Falls in the clean, reference and null datasets: " + (", ".join(
        f"{k}: {len(v)}" for k, v in other_falls.items()) or "none checked"), "",
        f"All material: {doc['all_material']}; no falls: {doc['no_falls']}", ""]
    (HERE / "check.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if doc["all_material"] and doc["no_falls"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
