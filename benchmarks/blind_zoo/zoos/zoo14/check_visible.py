"""zoo14's materiality and no-fall check of the recorded datasets (sealed with the truth).

Reads the datasets the harness recorded (``--work`` of ``harness/run.py --record-only``):
``effects/zNN``, ``clean/s91_e0``, ``clean/s92_e0``, ``clean/s93_e0`` and ``reference``. For
every dataset it computes summary features (means over all its moves) and calls an effect
visible when its dataset differs from clean seed 91 (same seed, same gait randomisation) by
more than three times the clean seeds' own spread (sample std over seeds 91, 92, 93; floored at
0.5 % of the clean mean's magnitude) in at least two features. Falls: a move falls if its body
height drops below 0.08 m or its roll or pitch exceeds 0.5 rad at any step.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo14/check_visible.py \
        --work WORK --out benchmarks/blind_zoo/zoos/zoo14   (WORK: the harness's --work)
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))
from littledog_mlsim.data.dataset import load_moves  # noqa: E402

LEGS = ("front_left", "front_right", "back_left", "back_right")
KINDS = ("hip_roll", "hip_pitch", "knee")
H_MIN, TILT_MAX = 0.08, 0.5
K_SIGMA, N_FEATURES_NEEDED, FLOOR_REL = 3.0, 2, 0.005
LAGS = np.arange(-8, 9)


def move_features(m) -> dict[str, float]:
    f: dict[str, float] = {}
    eul = Rotation.from_quat(m.orientation).as_euler("xyz")
    roll, pitch = eul[:, 0], eul[:, 1]
    yaw = np.unwrap(eul[:, 2])
    z = m.position[:, 2]
    f["height_mean"] = z.mean()
    f["height_std"] = z.std()
    f["roll_mean"], f["pitch_mean"] = roll.mean(), pitch.mean()
    f["roll_std"], f["pitch_std"] = roll.std(), pitch.std()
    f["final_x"], f["final_y"] = m.position[-1, 0] - m.position[0, 0], m.position[-1, 1] - m.position[0, 1]
    f["final_yaw"] = yaw[-1] - yaw[0]
    f["vx_mean"], f["vy_mean"] = m.linear_velocity[:, 0].mean(), m.linear_velocity[:, 1].mean()
    for i, a in enumerate("xyz"):
        f[f"w{a}_rms"] = np.sqrt(np.mean(m.angular_velocity[:, i] ** 2))
    f["vz_rms"] = np.sqrt(np.mean(m.linear_velocity[:, 2] ** 2))
    err = m.q[1:] - m.cmd                        # measured angle after the step - set-point
    n = len(err)
    for j in range(12):
        name = f"{LEGS[j // 3]}_{KINDS[j % 3]}"
        f[f"err_mean_{name}"] = err[:, j].mean()
        f[f"err_rms_{name}"] = np.sqrt(np.mean(err[:, j] ** 2))
        f[f"dq_rms_{name}"] = np.sqrt(np.mean(m.dq[:, j] ** 2))
    early, late = err[n // 8: n // 3], err[2 * n // 3:]
    f["err_rms_late_minus_early"] = (np.sqrt(np.mean(late ** 2)) - np.sqrt(np.mean(early ** 2)))
    return {k: float(v) for k, v in f.items()}


def pooled_lags(moves) -> dict[str, float]:
    """Body-vs-joint timing over all moves pooled: the lag (steps) at which the joint angles
    and rates best explain the body's height, roll and pitch (least squares, R^2)."""
    out = {}
    sig = {"height": lambda m, e: m.position[:, 2], "roll": lambda m, e: e[:, 0],
           "pitch": lambda m, e: e[:, 1]}
    eul = [Rotation.from_quat(m.orientation).as_euler("xyz") for m in moves]
    for name, get in sig.items():
        r2 = []
        for lag in LAGS:
            ys, xs = [], []
            for m, e in zip(moves, eul):
                y = get(m, e)
                x = np.column_stack([m.q, m.dq])
                n = len(y)
                lo, hi = 8, n - 8
                ys.append(y[lo + lag:hi + lag] - y.mean())
                xs.append(x[lo:hi] - x.mean(0))
            y, X = np.concatenate(ys), np.concatenate(xs)
            X = np.column_stack([X, np.ones(len(X))])
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            r2.append(1.0 - (y - X @ coef).var() / y.var())
        r2 = np.array(r2)
        i = int(np.argmax(r2))
        off = 0.0
        if 0 < i < len(r2) - 1:
            a, b, c = r2[i - 1], r2[i], r2[i + 1]
            den = a - 2 * b + c
            off = float(np.clip(0.5 * (a - c) / den, -0.5, 0.5)) if den != 0 else 0.0
        out[f"lag_{name}"] = float(LAGS[i] + off)
    return out


def dataset_summary(path: Path) -> tuple[dict[str, float], list[dict]]:
    moves = load_moves(path, split="all")
    feats = [move_features(m) for m in moves]
    keys = feats[0].keys()
    mean = {k: float(np.mean([x[k] for x in feats])) for k in keys}
    mean.update(pooled_lags(moves))
    falls = []
    for m in moves:
        eul = Rotation.from_quat(m.orientation).as_euler("xyz")
        hmin = float(m.position[:, 2].min())
        tilt = float(np.abs(eul[:, :2]).max())
        if hmin < H_MIN or tilt > TILT_MAX or not np.all(np.isfinite(m.position)):
            falls.append({"move": m.name, "height_min_m": hmin, "tilt_max_rad": tilt})
    extremes = {"moves": len(moves),
                "height_min_m": float(min(m.position[:, 2].min() for m in moves)),
                "tilt_max_rad": float(max(np.abs(Rotation.from_quat(m.orientation)
                                                 .as_euler("xyz")[:, :2]).max() for m in moves))}
    return mean, [extremes] + falls


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--out", required=True, help="directory for check.md / check.json")
    ap.add_argument("--seed", type=int, default=91)
    ap.add_argument("--clean-seeds", default="91,92,93")
    a = ap.parse_args(argv)
    work, out = Path(a.work), Path(a.out)
    clean_names = [f"s{s}_e0" for s in a.clean_seeds.split(",")]
    clean = {c: dataset_summary(work / "clean" / c) for c in clean_names}
    base = clean[f"s{a.seed}_e0"][0]
    keys = list(base)
    cmat = np.array([[clean[c][0][k] for k in keys] for c in clean_names])
    spread = cmat.std(axis=0, ddof=1)
    floor = FLOOR_REL * np.abs(cmat.mean(axis=0))
    sigma = np.maximum(spread, np.maximum(floor, 1e-12))
    effects = sorted(p.name for p in (work / "effects").iterdir()
                     if p.is_dir() and (p / "dataset.yaml").is_file())
    rows, falls = [], {}
    for name, (_, extra) in clean.items():
        falls[f"clean/{name}"] = extra
    if (work / "reference" / "dataset.yaml").is_file():
        falls["reference"] = dataset_summary(work / "reference")[1]
    for e in effects:
        feats, extra = dataset_summary(work / "effects" / e)
        falls[f"effects/{e}"] = extra
        z = {k: (feats[k] - base[k]) / s for k, s in zip(keys, sigma)}
        over = sorted((k for k in keys if abs(z[k]) > K_SIGMA), key=lambda k: -abs(z[k]))
        rows.append({"effect": e, "n_features_over": len(over),
                     "visible": len(over) >= N_FEATURES_NEEDED,
                     "top": [{"feature": k, "z": z[k], "value": feats[k], "clean": base[k]}
                             for k in over[:6]],
                     "max_abs_z": max(abs(v) for v in z.values())})
    n_fall = {k: len(v) - 1 for k, v in falls.items()}
    doc = {"work": str(work), "rule": f">{K_SIGMA:g} x clean spread in >= {N_FEATURES_NEEDED} "
                                      f"features; fall: height < {H_MIN} m or |roll|,|pitch| > "
                                      f"{TILT_MAX} rad",
           "features": keys, "clean_seed_spread": dict(zip(keys, spread.tolist())),
           "effects": rows, "falls": falls, "fallen_moves": n_fall,
           "summary": {"effects": len(rows), "visible": sum(r["visible"] for r in rows),
                       "fallen_moves_total": int(sum(n_fall.values()))}}
    out.mkdir(parents=True, exist_ok=True)
    (out / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    md = [f"# zoo14 check_visible (SEALED)", "", f"work: `{work}`; rule: {doc['rule']}", "",
          "| effect | visible | features over 3 sigma | max abs z | top features (z) |",
          "|---|---|---|---|---|"]
    for r in rows:
        top = ", ".join(f"{t['feature']} ({t['z']:+.1f})" for t in r["top"])
        md.append(f"| {r['effect']} | {'yes' if r['visible'] else 'NO'} | {r['n_features_over']} | "
                  f"{r['max_abs_z']:.1f} | {top} |")
    md += ["", "| dataset | moves | fallen moves | min height [m] | max tilt [rad] |",
           "|---|---|---|---|---|"]
    for k, v in falls.items():
        md.append(f"| {k} | {v[0]['moves']} | {n_fall[k]} | {v[0]['height_min_m']:.3f} | "
                  f"{v[0]['tilt_max_rad']:.3f} |")
    md += ["", f"Summary: {doc['summary']['visible']} of {doc['summary']['effects']} effects "
               f"visible; {doc['summary']['fallen_moves_total']} fallen moves."]
    (out / "check.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
