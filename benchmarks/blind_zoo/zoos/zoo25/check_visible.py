"""zoo25's materiality check: does every effect change the recordings materially, and does no
move fall?

Each effect's dataset (WORK/effects/zNN, recorded by ``harness/run.py --record-only`` with the
gap robot, seed 161) is compared move by move with the clean dataset of the same seed and
excitation (WORK/clean/s161_e<exc>): same gait, same sensor-noise seed, so every difference is
the effect's (or the chaos any change of a contact sets off). Against that floor the check also
records a *null* dataset, the same seed with a negligible change (a 1 mN push), and compares it
likewise.

Measures, per effect:

- ``xy_m``: mean over moves of the distance between the final (x, y) of the effect's move and
  the clean move; ``yaw_rad``: the same for the final heading;
- ``state_rms``: mean over the 33 state elements of the RMS per-step difference, each divided by
  the element's standard deviation in the clean data;
- ``onestep_ratio``: a linear one-step model (ridge, [state, command] -> next state change)
  fitted on the clean seeds 162 and 163: its mean nMSE on the effect's moves over its mean nMSE
  on the clean moves of seed 161 (same excitation);

material = at least two of four signals, each well beyond the null floor:
           xy_m >= max(0.02, 3 null), yaw_rad >= max(0.08, 2 null),
           state_rms >= 1.5 null, onestep_ratio >= 1.10
no fall  = every move of every dataset keeps the body above 0.07 m with |roll|, |pitch| < 0.7.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo25/check_visible.py --work WORK
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[3]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.data.dataset import load_moves  # noqa: E402

Z_MIN, TILT_MAX = 0.07, 0.7


def rpy(quat: np.ndarray) -> np.ndarray:
    x, y, z, w = quat.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], 1)


def states(m) -> np.ndarray:
    e = rpy(m.orientation)
    return np.column_stack([m.position[:, 2], m.linear_velocity, e[:, :2], m.angular_velocity,
                            m.q, m.dq])


def load(path: Path) -> dict:
    return {m.name: m for m in load_moves(path, split="all")}


def fit(moves: list) -> tuple[np.ndarray, np.ndarray]:
    X, Y = [], []
    for m in moves:
        s = states(m)
        X.append(np.column_stack([s[:-1], m.cmd, np.ones(len(m.cmd))]))
        Y.append(s[1:] - s[:-1])
    X, Y = np.concatenate(X), np.concatenate(Y)
    mu, sd = X.mean(0), X.std(0) + 1e-9
    mu[-1], sd[-1] = 0.0, 1.0
    Xn = (X - mu) / sd
    W = np.linalg.solve(Xn.T @ Xn + 1e-3 * len(Xn) * np.eye(Xn.shape[1]), Xn.T @ Y)
    return W, (mu, sd)


def nmse(model, moves: list, yvar: np.ndarray) -> float:
    W, (mu, sd) = model
    err = []
    for m in moves:
        s = states(m)
        X = (np.column_stack([s[:-1], m.cmd, np.ones(len(m.cmd))]) - mu) / sd
        err.append((s[1:] - s[:-1]) - X @ W)
    err = np.concatenate(err)
    return float(np.mean(np.mean(err ** 2, 0) / yvar))


def compare(eff: dict, clean: dict, scale: np.ndarray) -> dict:
    xy, yaw, rms = [], [], []
    for name, m in eff.items():
        c = clean[name]
        xy.append(float(np.hypot(*(m.position[-1, :2] - c.position[-1, :2]))))
        d = rpy(m.orientation)[-1, 2] - rpy(c.orientation)[-1, 2]
        yaw.append(float(abs((d + np.pi) % (2 * np.pi) - np.pi)))
        rms.append(np.sqrt(np.mean((states(m) - states(c)) ** 2, 0)) / scale)
    return {"xy_m": float(np.mean(xy)), "yaw_rad": float(np.mean(yaw)),
            "state_rms": float(np.mean(rms))}


def falls(moves: dict) -> list[str]:
    out = []
    for name, m in moves.items():
        e = rpy(m.orientation)
        if (m.position[:, 2].min() < Z_MIN or np.abs(e[:, 0]).max() > TILT_MAX
                or np.abs(e[:, 1]).max() > TILT_MAX or not np.all(np.isfinite(states(m)))):
            out.append(name)
    return out



def record_null(work: Path, seed: int, moves: int, robot: Path) -> Path:
    out = work / "check" / f"null_s{seed}"
    if (out / "dataset.yaml").is_file():
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    eff = out.parent / "null_effect.yaml"
    eff.write_text("- class: littledog_mlsim.robot.effects:ConstantWind\n"
                   "  params: {force_xy: [0.001, 0.0]}\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, "-P", "-m", "littledog_mlsim.cli", "record", "--out",
                    str(out), "--moves-per-type", str(moves), "--seed", str(seed), "--jobs", "2",
                    "--quiet", "--robot", str(robot), "--effects", str(eff)],
                   check=True, env=env)
    forget_robot(out)
    return out


def forget_robot(path: Path) -> None:
    """As the harness does: remove the recording robot's identity from ``dataset.yaml``."""
    index = path / "dataset.yaml"
    doc = yaml.safe_load(index.read_text())
    for k in ("robot", "twin", "robot_config"):
        (doc.get("info") or {}).pop(k, None)
    index.write_text(yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=161)
    ap.add_argument("--train-seeds", default="162,163")
    ap.add_argument("--moves-per-type", type=int, default=10)
    a = ap.parse_args()
    t0 = time.time()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    clean = {}
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        clean.setdefault(exc, load(work / "clean" / f"s{a.seed}_e{exc:g}"))
    train = [m for s in a.train_seeds.split(",")
             for m in load(work / "clean" / f"s{s}_e0").values()]
    model = fit(train)
    yvar = np.var(np.concatenate([np.diff(states(m), axis=0) for m in train]), 0) + 1e-12
    scale = {exc: np.std(np.concatenate([states(m) for m in c.values()]), 0) + 1e-9
             for exc, c in clean.items()}
    base_nmse = {exc: nmse(model, list(c.values()), yvar) for exc, c in clean.items()}
    null = load(record_null(work, a.seed, a.moves_per_type, HERE / "gap_robot.json"))
    floor = compare(null, clean[0.0], scale[0.0])
    floor["onestep_ratio"] = nmse(model, list(null.values()), yvar) / base_nmse[0.0]

    fallen = {}
    for d in sorted((work / "clean").iterdir()) + [work / "reference"]:
        if (d / "dataset.yaml").is_file():
            fallen[str(d.relative_to(work))] = falls(load(d))
    rows = []
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        eff = load(work / "effects" / t["id"])
        r = {"id": t["id"], "excitation": exc, **compare(eff, clean[exc], scale[exc]),
             "onestep_ratio": nmse(model, list(eff.values()), yvar) / base_nmse[exc]}
        r["signals"] = int(r["xy_m"] >= max(0.02, 3 * floor["xy_m"])) + int(
            r["yaw_rad"] >= max(0.08, 2 * floor["yaw_rad"])) + int(
            r["state_rms"] >= 1.5 * floor["state_rms"]) + int(r["onestep_ratio"] >= 1.10)
        r["material"] = r["signals"] >= 2
        r["fallen"] = falls(eff)
        rows.append(r)
    seconds = time.time() - t0
    doc = {"seed": a.seed, "train_seeds": a.train_seeds, "null_floor": floor,
           "baseline_onestep_nmse": {f"{k:g}": v for k, v in base_nmse.items()},
           "effects": rows, "fallen_other_datasets": fallen,
           "all_material": all(r["material"] for r in rows),
           "no_fall": not any(r["fallen"] for r in rows) and not any(fallen.values()),
           "seconds": seconds}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo25 materiality check", "",
             f"Seed {a.seed}, each effect against the clean dataset of the same seed and "
             f"excitation (gap robot); one-step model: linear, fitted on clean seeds "
             f"{a.train_seeds}. Null floor (a 1 mN push): final xy {floor['xy_m']:.4f} m, yaw "
             f"{floor['yaw_rad']:.4f} rad, state rms {floor['state_rms']:.3f}, one-step ratio "
             f"{floor['onestep_ratio']:.3f}.", "",
             "| effect | exc. | final xy diff [m] | final yaw diff [rad] | state rms (/std) | "
             "one-step nMSE ratio | signals | material | fallen moves |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['id']} | {r['excitation']:g} | {r['xy_m']:.4f} | {r['yaw_rad']:.4f} | "
                     f"{r['state_rms']:.3f} | {r['onestep_ratio']:.3f} | {r['signals']} of 4 | "
                     f"{'yes' if r['material'] else 'NO'} | {len(r['fallen'])} |")
    lines += ["", "Other datasets, fallen moves: " + ", ".join(
        f"{k} {len(v)}" for k, v in fallen.items()), "",
        f"All material: {doc['all_material']}; no move fell: {doc['no_fall']}; "
        f"check took {seconds:.0f} s."]
    (HERE / "check.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0 if doc["all_material"] and doc["no_fall"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
