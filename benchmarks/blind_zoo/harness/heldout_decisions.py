"""Save a diagnosis's held-out decision inputs, and compare choice rules on them afterwards.

``run`` runs ``littledog-mlsim diagnose`` (its arguments after ``--``) on the physical route
with an observer on the held-out decision (``PhysicalOptions.observer``, which receives each
round's :class:`littledog_mlsim.diagnose.physical.HeldOutDecision`) and writes, as the
diagnosis runs, the per-move, per-channel held-out SSEs without (S0) and with (S1) each fitted
hypothesis of the shortlist to ``SAVE`` (pickle: one ``(S0, [S1, ...])`` per round) and the
first round's shortlist to ``SAVE.top`` (``(family, scope, fitted, magnitude)`` each). A push's
twin that the decision simulated beside the shortlist is left out of both. A diagnosis that
makes no held-out decision (the learned route) is an error.

``show`` prints, for each saved file, the finding chosen by the largest summed cut relative to
each channel's total (the rule up to zoo6) and by the largest mean bounded per-move cut
(``diagnose.stats.move_cuts``, the rule since), with the decision's adjusted p
(``diagnose.stats.decide_all``). How LOG.md's section "Before the seventh zoo" was measured:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/harness/heldout_decisions.py run \\
        WORK/effects/z02.pkl -- diagnose --data WORK/effects/z02 --out O --jobs 1 --no-figures
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/harness/heldout_decisions.py show \\
        WORK/effects/*.pkl
"""
from __future__ import annotations

import pickle
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from littledog_mlsim.diagnose import stats
from littledog_mlsim.diagnose.options import AutoRoute, PhysicalRoute
from littledog_mlsim.diagnose.physical import HeldOutDecision
from littledog_mlsim.fileio import write_synced


class _Saver:
    """The observer: writes each round's shortlist decision inputs as they come."""

    def __init__(self, save: str) -> None:
        self.save = save
        self.rounds: list[tuple[np.ndarray, list[np.ndarray]]] = []

    def __call__(self, d: HeldOutDecision) -> None:
        n = d.n_shortlist
        self.rounds.append((d.S0, list(d.S1[:n])))
        _write(self.save, self.rounds)
        if len(self.rounds) == 1:
            _write(self.save + ".top", [(c.family, c.scope, c.fitted, c.magnitude)
                                        for c in d.hypotheses[:n]])


def _write(path: str, obj: Any) -> None:
    """Pickle ``obj`` to ``path`` through a sibling file (a good file is never half-replaced)."""
    tmp = Path(path + ".partial")
    write_synced(tmp, pickle.dumps(obj))
    tmp.replace(path)


def _observed(route: Any, saver: _Saver) -> Any:
    if isinstance(route, AutoRoute):
        return replace(route, physical=_observed(route.physical, saver))
    if isinstance(route, PhysicalRoute):
        return PhysicalRoute({**route.overrides, "observer": saver})
    raise SystemExit("heldout_decisions run: the diagnosis takes the learned route "
                     "(--physics off): it makes no held-out decision to save")


def run(save: str, argv: list[str]) -> int:
    from littledog_mlsim import cli
    from littledog_mlsim.diagnose import diagnose
    a = cli.build_parser().parse_args(argv)
    if a.verb != "diagnose":
        raise SystemExit(f"heldout_decisions run: give a diagnose command after --, not {a.verb!r}")
    try:
        options = cli.diagnose_options(a)
    except cli.CliError as e:
        raise SystemExit(f"heldout_decisions run: {e}") from None
    saver = _Saver(save)
    diagnose(a.data, a.out, options.with_route(_observed(options.route, saver)))
    if not saver.rounds:
        raise SystemExit(f"heldout_decisions run: {a.data}: the diagnosis took the learned route "
                         f"(the dataset names no known robot); nothing saved")
    print(f"saved {len(saver.rounds)} held-out decision(s) to {save} and the shortlist to "
          f"{save}.top")
    return 0


def show(paths: list[str]) -> None:
    for path in paths:
        with open(path, "rb") as f:
            S0, S1s = pickle.load(f)[0]      # the first round's shortlist
        with open(path + ".top", "rb") as f:
            top = pickle.load(f)
        dec = stats.decide_all(S0, S1s, 0.01, 0.05)
        summed = [float(np.nansum(d.gain)) for d in dec]
        bounded = [float(np.mean(stats.move_cuts(S0, S1))) for S1 in S1s]
        print(f"{path}: {len(S1s)} hypotheses, {S0.shape[0]} held-out moves, smallest adjusted "
              f"p of any {min(d.p_value for d in dec):.2g}")
        for rule, vals in (("summed cut (to zoo6)", summed), ("bounded per-move cut", bounded)):
            k = int(np.argmax(vals))
            fam, scope, fitted, _ = top[k]
            print(f"  {rule:22s}: {fam} {scope} {fitted:.4g} (value {vals[k]:.2f}), adjusted p "
                  f"{dec[k].p_value:.2g}, significant {dec[k].significant}, "
                  f"material {dec[k].material}")


def main() -> None:
    if len(sys.argv) == 2 and sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        return
    if len(sys.argv) >= 4 and sys.argv[1] == "run" and sys.argv[3] == "--":
        sys.exit(run(sys.argv[2], sys.argv[4:]))
    if len(sys.argv) >= 3 and sys.argv[1] == "show":
        show(sys.argv[2:])
        return
    sys.exit(__doc__)


if __name__ == "__main__":
    main()
