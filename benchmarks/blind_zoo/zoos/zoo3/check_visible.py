"""Visibility check of the zoo3 effect files: each effect dataset against the clean dataset of the
same seed and recording options (same moves, same gait randomisation and sensor noise).

For every move: how far the end (x, y) moved [cm], the change of the final yaw [rad], the mean
joint tracking RMS |q - command| [rad], the largest |roll| or |pitch| [rad] and the lowest body
height [m] (upright check). Printed per effect: medians and extremes over the moves.

    python benchmarks/blind_zoo/zoos/zoo3/check_visible.py CLEAN_DIR EFFECT_DIR [EFFECT_DIR ...]
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from littledog_mlsim.data.bags import read_bag


def _yaw(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q.T
    return np.unwrap(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def _tilt(q: np.ndarray) -> float:
    x, y, z, w = q.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    return float(max(np.abs(roll).max(), np.abs(pitch).max()))


def compare(clean: Path, effect: Path) -> str:
    dxy, dyaw, tr_c, tr_e, tilt, zmin = [], [], [], [], [], []
    for bag in sorted(b for b in clean.iterdir() if (b / "metadata.yaml").is_file()):
        a, b = read_bag(bag), read_bag(effect / bag.name)
        dxy.append(100 * np.linalg.norm(b.position[-1, :2] - a.position[-1, :2]))
        dyaw.append(abs(_yaw(b.orientation)[-1] - _yaw(a.orientation)[-1]))
        tr_c.append(np.sqrt(np.mean((a.q[1:] - a.cmd) ** 2)))
        tr_e.append(np.sqrt(np.mean((b.q[1:] - b.cmd) ** 2)))
        tilt.append(_tilt(b.orientation))
        zmin.append(float(b.position[:, 2].min()))
    return (f"{effect.name}: {len(dxy)} moves; end (x,y) shift median {np.median(dxy):.1f} cm "
            f"(max {max(dxy):.1f}); |final yaw change| median {np.median(dyaw):.3f} rad "
            f"(max {max(dyaw):.3f}); tracking RMS {np.mean(tr_c):.4f} -> {np.mean(tr_e):.4f} rad; "
            f"max |roll|,|pitch| {max(tilt):.3f} rad; min body z {min(zmin):.3f} m")


if __name__ == "__main__":
    ref = Path(sys.argv[1])
    for d in sys.argv[2:]:
        print(compare(ref, Path(d)), flush=True)
