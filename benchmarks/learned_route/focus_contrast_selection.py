"""How often the learned route's focus contrast calls a shared scoped effect a change, when the
scope was chosen on the data (a stand-in: normal per-move focus cuts, no robot).

Each draw: 9 scopes, per-move focus cuts ~ N(mu_scope, 1) on the data's M moves and, with the
same means (the effect is shared: the robot's own), on the reference's M moves. The scope with
the largest mean cut on the data is kept, as the screen and scope stage keep the best, and the
contrast's focus test (``stats.contrast_focus_p``, Welch, one-sided) compares its cuts on the
data and on the reference. A change is called if 3 p < 0.01 (the focus test's share of
``p_change`` at one contrast). Nominal rate without selection: 0.01 / 3. The last column
corrects p for the choice, as ``learned.contrast`` does (``focus_choices``: times the 9 scopes).

    .venv/bin/python benchmarks/learned_route/focus_contrast_selection.py \
      > benchmarks/learned_route/focus_contrast_selection.md
"""
from __future__ import annotations

import numpy as np

from littledog_mlsim.diagnose.stats import contrast_focus_p

CASES = [(0.0, 0.0), (0.3, 0.0), (0.3, 0.25), (0.8, 0.2), (0.5, 0.45)]


def rate(mu_kept: float, mu_other: float, rng: np.random.Generator, M: int = 70,
         n_scopes: int = 9, reps: int = 4000) -> tuple[float, float]:
    """(rate of 'changed' without, with the correction for the choice)."""
    mu = np.r_[mu_kept, np.full(n_scopes - 1, mu_other)]
    hits = np.zeros(2)
    for _ in range(reps):
        D, R = rng.normal(mu, 1.0, (M, n_scopes)), rng.normal(mu, 1.0, (M, n_scopes))
        k = int(np.argmax(D.mean(axis=0)))
        p = contrast_focus_p(D[:, k], R[:, k])
        hits += [3.0 * p < 0.01, 3.0 * min(1.0, n_scopes * p) < 0.01]
    return hits[0] / reps, hits[1] / reps


def main() -> None:
    rng = np.random.default_rng(0)
    print("# Focus contrast of a shared scoped effect, scope chosen on the data\n")
    print("Command: `.venv/bin/python benchmarks/learned_route/focus_contrast_selection.py` "
          "(seed 0, 4,000 draws per row, 70 moves per side, 9 scopes).\n")
    print(f"Nominal rate without selection: {0.01 / 3:.4f}.\n")
    print("| mean cut, kept scope | mean cut, other 8 | rate of 'changed' | x nominal | "
          "corrected (x 9 scopes) |")
    print("|---|---|---|---|---|")
    for a, b in CASES:
        r, c = rate(a, b, rng)
        print(f"| {a:g} | {b:g} | {r:.4f} | {r / (0.01 / 3):.1f} | {c:.4f} |")


if __name__ == "__main__":
    main()
