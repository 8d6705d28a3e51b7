"""How far each move gets against the reference's moves of its type (a check, not a decision).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/move_progress/move_progress.py \
        --work WORK20 --names clean/s111_e0 clean/s112_e0 clean/s113_e0 effects/z11 effects/z09 \
        > benchmarks/learned_route/move_progress/zoo20.txt

WORK is a blind zoo's work directory (``reference``, ``effects/zNN``, ``clean/sNNN_eE``). For
each named recording, every move's final distance from its start (odom, x and y) is divided by
the mean over the reference's moves of its type; the line gives the mean of those ratios, a
two-sided Mann-Whitney U test against the reference's own ratios, and the mean per move type.
A pull towards the start (a tether) or a floor that holds the robot back would make moves end
short.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from littledog_mlsim.data.dataset import load_moves  # noqa: E402


def distances(directory: Path) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {}
    for m in load_moves(directory, "all"):
        P = np.asarray(m.position)
        out.setdefault(m.move_type, []).append(float(np.hypot(*(P[-1, :2] - P[0, :2]))))
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work", type=Path, required=True)
    p.add_argument("--names", nargs="+", required=True)
    a = p.parse_args()
    ref = distances(a.work / "reference")
    mean_ref = {t: float(np.mean(v)) for t, v in ref.items()}
    base = np.concatenate([np.array(ref[t]) / mean_ref[t] for t in ref])
    for name in a.names:
        d = distances(a.work / name)
        types = [t for t in d if t in ref]
        r = np.concatenate([np.array(d[t]) / mean_ref[t] for t in types])
        p_value = float(stats.mannwhitneyu(r, base).pvalue)
        by_type = " ".join(f"{t} {np.mean(d[t]) / mean_ref[t]:.2f}" for t in types)
        print(f"{name}: mean progress ratio {r.mean():.3f}, p {p_value:.2g}; by type {by_type}")


if __name__ == "__main__":
    main()
