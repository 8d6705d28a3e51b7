"""Check that every effect of zoo18 changes its recording materially against clean data of the
same seed and recording condition, and that no move falls (SEALED results: check.md, check.json).

Usage (after harness/run.py --record-only into WORK):
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo18/check_visible.py \
        --work /tmp/s53/z18 [--seed 101]

Besides WORK/effects/<id> and WORK/clean/s<seed>_e<exc>, it records (once) a *null* dataset into
WORK/check_null/e<exc>: the gap robot, the same seed, with a negligible force (1 mN) switched on,
which measures how far two recordings of the same commands drift apart from a vanishing
perturbation (contact chaos). An effect is material when at least one of its measures is both
above an absolute threshold and at least 3x the null's.

Measures per dataset, over all moves, effect minus clean, move by move (same names):
- final_xy_m: mean |final (x, y) difference| of the body [m];
- final_yaw_rad: mean |final yaw difference| [rad];
- q_rms_rad: RMS of the joint-angle difference [rad];
- state_nmse: mean over 33 state elements (z, roll, pitch, twist 6, q 12, dq 12) of
  var(difference) / var(clean);
- falls: moves whose body drops below half its starting height, tilts past 0.5 rad in roll or
  pitch, or goes non-finite (checked on the clean datasets and the reference too).
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

ABS = {"final_xy_m": 0.02, "final_yaw_rad": 0.03, "q_rms_rad": 0.01, "state_nmse": 0.01}
RATIO = 3.0
FALL_Z = 0.5
FALL_TILT = 0.5


def rpy(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], 1)


def state(m) -> np.ndarray:
    a = rpy(m.orientation)
    return np.column_stack([m.position[:, 2], a[:, 0], a[:, 1], m.linear_velocity,
                            m.angular_velocity, m.q, m.dq])


def falls(moves) -> list[str]:
    out = []
    for m in moves:
        a = rpy(m.orientation)
        z = m.position[:, 2]
        if (not np.all(np.isfinite(m.position)) or not np.all(np.isfinite(m.q))
                or z.min() < FALL_Z * z[0] or np.abs(a[:, :2]).max() > FALL_TILT):
            out.append(m.name)
    return out


def load(path: Path):
    return {m.name: m for m in load_moves(path, split="all")}


def compare(eff: dict, clean: dict) -> dict:
    names = sorted(set(eff) & set(clean))
    xy, yaw, dqs, diffs, cleans = [], [], [], [], []
    for n in names:
        e, c = eff[n], clean[n]
        xy.append(float(np.hypot(*(e.position[-1, :2] - c.position[-1, :2]))))
        ye, yc = rpy(e.orientation[-1:])[0, 2], rpy(c.orientation[-1:])[0, 2]
        yaw.append(abs(float((ye - yc + np.pi) % (2 * np.pi) - np.pi)))
        dqs.append(e.q - c.q)
        diffs.append(state(e) - state(c))
        cleans.append(state(c))
    d, cl = np.concatenate(diffs), np.concatenate(cleans)
    return {"moves": len(names),
            "final_xy_m": float(np.mean(xy)), "final_yaw_rad": float(np.mean(yaw)),
            "q_rms_rad": float(np.sqrt(np.mean(np.concatenate(dqs) ** 2))),
            "state_nmse": float(np.mean(d.var(0) / np.maximum(cl.var(0), 1e-12)))}


def record_null(work: Path, seed: int, exc: float, robot: Path, moves: int) -> Path:
    out = work / "check_null" / f"e{exc:g}"
    if (out / "dataset.yaml").is_file():
        return out
    eff = work / "check_null" / "null.yaml"
    eff.parent.mkdir(parents=True, exist_ok=True)
    eff.write_text("- class: littledog_mlsim.robot.effects:ConstantWind\n"
                   "  params: {force_xy: [0.001, 0.0]}\n")
    cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(moves), "--seed", str(seed), "--jobs", "2", "--quiet",
           "--robot", str(robot), "--effects", str(eff)]
    if exc:
        cmd += ["--excitation", f"{exc:g}"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run(cmd, check=True, env=env, cwd=str(ROOT))
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=101)
    ap.add_argument("--moves-per-type", type=int, default=10)
    ap.add_argument("--only", default="")
    a = ap.parse_args()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    only = {s for s in a.only.split(",") if s}
    rows, nulls, clean_cache = [], {}, {}
    for t in truth:
        if only and t["id"] not in only:
            continue
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        key = f"s{a.seed}_e{exc:g}"
        if key not in clean_cache:
            clean_cache[key] = load(work / "clean" / key)
        clean = clean_cache[key]
        if exc not in nulls:
            npath = record_null(work, a.seed, exc, HERE / "gap_robot.json", a.moves_per_type)
            nulls[exc] = compare(load(npath), clean)
        eff = load(work / "effects" / t["id"])
        c = compare(eff, clean)
        null = nulls[exc]
        passed = [k for k in ABS if c[k] >= ABS[k] and c[k] >= RATIO * max(null[k], 1e-12)]
        fell = falls(eff.values())
        rows.append({"id": t["id"], "excitation": exc, **c,
                     "ratio_to_null": {k: c[k] / max(null[k], 1e-12) for k in ABS},
                     "material_by": passed, "material": bool(passed),
                     "falls": fell, "ok": bool(passed) and not fell})
        print(t["id"], "material" if passed else "NOT material", passed,
              {k: round(c[k], 4) for k in ABS}, "falls:", fell, flush=True)
    other = {}
    for d in sorted((work / "clean").glob("s*")) + [work / "reference"]:
        if (d / "dataset.yaml").is_file():
            other[str(d.relative_to(work))] = falls(load(d).values())
    doc = {"work": str(work), "seed": a.seed, "thresholds": ABS, "ratio_to_null": RATIO,
           "null": {f"{k:g}": v for k, v in nulls.items()}, "effects": rows,
           "falls_in_clean_and_reference": other,
           "all_ok": all(r["ok"] for r in rows) and not any(other.values())}
    if not only:
        (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
        lines = ["# zoo18 check (SEALED): materiality against clean data of the same seed, and "
                 "falls", "",
                 f"WORK {work}, seed {a.seed}. Material: some measure >= its threshold "
                 f"({', '.join(f'{k} {v:g}' for k, v in ABS.items())}) and >= {RATIO:g}x the "
                 "null recording's (a 1 mN force: the chaos floor).", "",
                 "| null (excitation) | final_xy_m | final_yaw_rad | q_rms_rad | state_nmse |",
                 "|---|---|---|---|---|"]
        for k, v in nulls.items():
            lines.append(f"| {k:g} | {v['final_xy_m']:.4f} | {v['final_yaw_rad']:.4f} | "
                         f"{v['q_rms_rad']:.4f} | {v['state_nmse']:.4f} |")
        lines += ["", "| effect | exc. | final_xy_m | final_yaw_rad | q_rms_rad | state_nmse | "
                  "material by | falls | ok |", "|---|---|---|---|---|---|---|---|---|"]
        for r in rows:
            lines.append(f"| {r['id']} | {r['excitation']:g} | {r['final_xy_m']:.4f} | "
                         f"{r['final_yaw_rad']:.4f} | {r['q_rms_rad']:.4f} | "
                         f"{r['state_nmse']:.4f} | {', '.join(r['material_by']) or '-'} | "
                         f"{len(r['falls'])} | {'yes' if r['ok'] else 'NO'} |")
        lines += ["", "Falls in the clean datasets and the reference: " + ", ".join(
            f"{k}: {len(v)}" for k, v in other.items()), "",
            f"All effects material and no move falls: {'yes' if doc['all_ok'] else 'NO'}"]
        (HERE / "check.md").write_text("\n".join(lines) + "\n")
    return 0 if doc["all_ok"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
