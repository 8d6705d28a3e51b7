"""zoo13 materiality check: does every effect dataset differ materially from the clean dataset of
the same seed, by far more than clean datasets of other seeds differ from it? And does any move
fall?  Writes check.md and check.json beside this file.

Usage: .venv/bin/python benchmarks/blind_zoo/zoos/zoo13/check_visible.py WORK (the harness's --work directory)

Per dataset (TrainPool moves, split "train") a feature vector is computed:
  - per joint: mean and RMS of the tracking error q[k+1] - cmd[k]       (24)
  - per joint: RMS of the joint rate dq                                   (12)
  - per move type: mean final displacement in the start frame (dx, dy) and final yaw change (33)
  - mean body height, roll and pitch, and their RMS about the move's mean (6)
Materiality of a feature: |effect - clean81| / spread, spread = the largest difference among the
three clean seeds (81, 82, 83; different gaits and noise). An effect passes when at least two
features exceed 3 (the clean seeds' own spread, three times over). Also reported, paired with
clean81 (same commands, same noise): RMS over time of the body (x, y) path difference and of the
joint angles, mean over moves. A move falls when |roll| or |pitch| exceeds 0.8 rad or the body
height goes below 50 % of its first value.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))
from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.layout import JOINT_NAMES, MOVE_TYPES  # noqa: E402

HERE = Path(__file__).resolve().parent
RATIO = 3.0


def rpy(qxyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = qxyzw.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=1)


def features(moves) -> tuple[np.ndarray, list[str], int]:
    err = np.concatenate([m.q[1:] - m.cmd for m in moves])
    dq = np.concatenate([m.dq for m in moves])
    f = list(err.mean(0)) + list(np.sqrt((err ** 2).mean(0))) + list(np.sqrt((dq ** 2).mean(0)))
    names = ([f"track_mean:{j}" for j in JOINT_NAMES] + [f"track_rms:{j}" for j in JOINT_NAMES]
             + [f"dq_rms:{j}" for j in JOINT_NAMES])
    falls = 0
    per_type: dict[str, list] = {t: [] for t in MOVE_TYPES}
    att = []
    for m in moves:
        e = rpy(m.orientation)
        yaw0 = e[0, 2]
        c, s = np.cos(yaw0), np.sin(yaw0)
        d = m.position[-1, :2] - m.position[0, :2]
        per_type[m.move_type].append([c * d[0] + s * d[1], -s * d[0] + c * d[1],
                                      np.unwrap(e[:, 2])[-1] - yaw0])
        if (np.abs(e[:, :2]).max() > 0.8) or (m.position[:, 2].min() < 0.5 * m.position[0, 2]):
            falls += 1
        att.append([m.position[:, 2].mean(), e[:, 0].mean(), e[:, 1].mean(),
                    m.position[:, 2].std(), e[:, 0].std(), e[:, 1].std()])
    for t in MOVE_TYPES:
        v = np.mean(per_type[t], axis=0) if per_type[t] else np.zeros(3)
        f += list(v)
        names += [f"final_dx:{t}", f"final_dy:{t}", f"final_dyaw:{t}"]
    f += list(np.mean(att, axis=0))
    names += ["z_mean", "roll_mean", "pitch_mean", "z_std", "roll_std", "pitch_std"]
    return np.array(f), names, falls


def paired(a, b) -> tuple[float, float]:
    path, joints = [], []
    for x, y in zip(a, b):
        assert x.name == y.name
        n = min(len(x.position), len(y.position))
        path.append(np.sqrt(np.mean(np.sum((x.position[:n, :2] - y.position[:n, :2]) ** 2, 1))))
        joints.append(np.sqrt(np.mean((x.q[:n] - y.q[:n]) ** 2)))
    return float(np.mean(path)), float(np.mean(joints))


def main(work: Path) -> int:
    clean = {s: load_moves(work / "clean" / f"s{s}_e0", "train") for s in (81, 82, 83)}
    cf = {s: features(m) for s, m in clean.items()}
    names = cf[81][1]
    c = {s: v[0] for s, v in cf.items()}
    spread = np.max(np.abs(np.stack([c[82] - c[81], c[83] - c[81], c[82] - c[83]])), axis=0)
    spread = np.maximum(spread, 1e-9)
    out = {"clean": {str(s): {"falls": cf[s][2]} for s in cf}, "effects": {}}
    rows = []
    for d in sorted((work / "effects").iterdir()):
        if not (d / "dataset.yaml").is_file():
            continue
        moves = load_moves(d, "train")
        f, _, falls = features(moves)
        ratio = np.abs(f - c[81]) / spread
        order = np.argsort(ratio)[::-1]
        n_over = int((ratio > RATIO).sum())
        path, joints = paired(moves, clean[81])
        ok = n_over >= 2 and falls == 0
        top = [(names[i], float(ratio[i])) for i in order[:4]]
        out["effects"][d.name] = {"n_features_over": n_over, "max_ratio": float(ratio.max()),
                                  "top": top, "falls": falls, "paired_path_rms_m": path,
                                  "paired_joint_rms_rad": joints, "pass": ok}
        rows.append(f"| {d.name} | {n_over} | {ratio.max():.1f} | "
                    + ", ".join(f"{n} {r:.1f}" for n, r in top[:3])
                    + f" | {path * 1000:.1f} | {joints * 1000:.1f} | {falls} | "
                    f"{'yes' if ok else 'NO'} |")
    md = ["# zoo13 materiality check (check_visible.py)", "",
          f"Work directory: {work}. Features over the TrainPool moves; ratio = |effect - clean81| / "
          "largest difference among clean seeds 81, 82, 83. Pass: >= 2 features with ratio > 3 "
          "and no move falls. Paired: RMS over time vs clean81 (same commands and noise), mean "
          "over moves.", "",
          "Clean falls: " + ", ".join(f"s{s} {cf[s][2]}" for s in cf), "",
          "| effect | features > 3 | max ratio | top features (ratio) | paired path [mm] | "
          "paired joints [mrad] | falls | pass |", "|---|---|---|---|---|---|---|---|"] + rows
    (HERE / "check.md").write_text("\n".join(md) + "\n")
    (HERE / "check.json").write_text(json.dumps(out, indent=1) + "\n")
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    raise SystemExit(main(Path(sys.argv[1])))
