"""Save a diagnosis's held-out decision inputs, and compare choice rules on them afterwards.

``run`` runs ``littledog-mlsim diagnose`` with ``physid.decide_all`` and ``physid._validate``
wrapped so that the per-move, per-channel held-out SSEs without (S0) and with (S1) each fitted
hypothesis of the shortlist, and the shortlist itself, are written to ``SAVE`` (pickle) as the
diagnosis runs; ``show`` prints, for each saved file, the finding chosen by the largest summed
cut relative to each channel's total (the rule up to zoo6) and by the largest mean bounded
per-move cut (``physid.move_cuts``, the rule since), with the decision's adjusted p
(``physid.decide_all``). How LOG.md's section "Before the seventh zoo" was measured:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/harness/heldout_decisions.py run \\
        WORK/effects/z02.pkl -- diagnose --data WORK/effects/z02 --out O --jobs 1 --no-figures
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/harness/heldout_decisions.py show \\
        WORK/effects/*.pkl
"""
from __future__ import annotations

import pickle
import sys

import numpy as np

from littledog_mlsim.diagnose import physid as P


def run(save: str, argv: list[str]) -> int:
    calls: list = []
    decide_all, validate = P.decide_all, P._validate

    def saving_decide_all(S0, S1s, alpha, min_gain):
        calls.append((S0, list(S1s)))
        with open(save, "wb") as f:
            pickle.dump(calls, f)
        return decide_all(S0, S1s, alpha, min_gain)

    def saving_validate(runner, base, top, *a, **k):
        with open(save + ".top", "wb") as f:
            pickle.dump([(c.family, c.scope, c.fitted, c.magnitude) for c in top], f)
        return validate(runner, base, top, *a, **k)

    P.decide_all, P._validate = saving_decide_all, saving_validate
    from littledog_mlsim import cli
    return cli.main(argv)


def show(paths: list[str]) -> None:
    for path in paths:
        with open(path, "rb") as f:
            S0, S1s = pickle.load(f)[0]      # the first decision: the shortlist (a push twin
        with open(path + ".top", "rb") as f:  # added later is left out)
            top = pickle.load(f)
        dec = P.decide_all(S0, S1s, 0.01, 0.05)
        summed = [float(np.nansum(d[0])) for d in dec]
        bounded = [float(np.mean(P.move_cuts(S0, S1))) for S1 in S1s]
        print(f"{path}: {len(S1s)} hypotheses, {S0.shape[0]} held-out moves, smallest adjusted "
              f"p of any {min(d[2] for d in dec):.2g}")
        for rule, vals in (("summed cut (to zoo6)", summed), ("bounded per-move cut", bounded)):
            k = int(np.argmax(vals))
            fam, scope, fitted, _ = top[k]
            print(f"  {rule:22s}: {fam} {scope} {fitted:.4g} (value {vals[k]:.2f}), adjusted p "
                  f"{dec[k][2]:.2g}, significant {dec[k][3]}, material {dec[k][4]}")


def main() -> None:
    if len(sys.argv) >= 4 and sys.argv[1] == "run" and sys.argv[3] == "--":
        sys.exit(run(sys.argv[2], sys.argv[4:]))
    if len(sys.argv) >= 3 and sys.argv[1] == "show":
        show(sys.argv[2:])
        return
    sys.exit(__doc__)


if __name__ == "__main__":
    main()
