"""How the legs' swing rows overlap in a recording: for each leg A and each other leg B, the
share of B's swing rows on which A stands (decision 067's test of whether B swings apart from
A), on a dataset's TrainPool at the route's start feature set.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/swing_apart/trot_rows.py \\
        DATASET > benchmarks/learned_route/swing_apart/trot_rows.md
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.diagnose.candidates import measured_robot_features  # noqa: E402
from littledog_mlsim.diagnose.change import SWING_ROW, swing_weight  # noqa: E402
from littledog_mlsim.layout import LEGS  # noqa: E402


def main() -> None:
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    train = load_moves(sys.argv[1], "train")
    X, _, _ = measured_robot_features().features_responses(train)
    w = swing_weight(X)
    swing, stand = w > SWING_ROW, w == 0
    print(f"# Swing rows apart, `{sys.argv[1]}` ({len(X)} TrainPool rows, {len(train)} moves)\n")
    print("Share of B's swing rows on which A stands.\n")
    print("| A \\ B | " + " | ".join(LEGS) + " |")
    print("|---" * (len(LEGS) + 1) + "|")
    for a, name in enumerate(LEGS):
        cells = ["" if b == a else f"{(swing[:, b] & stand[:, a]).sum() / max(swing[:, b].sum(), 1):.2f}"
                 for b in range(len(LEGS))]
        print(f"| {name} | " + " | ".join(cells) + " |")
    print("\nEach leg's share of rows in swing: "
          + ", ".join(f"{n} {swing[:, i].mean():.3f}" for i, n in enumerate(LEGS)))


if __name__ == "__main__":
    main()
