"""The search context: what every step of the physical search reads, and its objective.

:class:`SearchContext` carries the transducer, the hypotheses already accepted (the base), the
base's errors and the measured outputs of every move. As an :class:`Objective` it gives a fit
its channel weights, the base's weighted SSE and the weighted SSE (J) of hypotheses added to
the base on a set of moves. A stand-in objective (any object with the same three methods)
lets a fit be checked without re-simulation.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Protocol, Sequence

import numpy as np

from .channels import LONG, Measured, errors, sse
from .records import Hypothesis
from .resim import Transducer

__all__ = ["Objective", "SearchContext", "weighted_sse"]


class Objective(Protocol):
    """What a fit minimises: J, the weighted output-error SSE on some moves."""

    def weights(self, moves: Sequence[int], segments_only: bool = False) -> np.ndarray:
        """Channel weights (36,): 1 / the base's SSE on ``moves``; the 4 s replay's channels
        zero if ``segments_only``."""
        ...

    def baseline(self, moves: Sequence[int], w: np.ndarray) -> float:
        """J of the base alone on ``moves``."""
        ...

    def evaluate(self, hyps: Sequence[Hypothesis], moves: Sequence[int], w: np.ndarray,
                 segments_only: bool = False) -> list[float]:
        """J of each hypothesis added to the base on ``moves`` (the replay not simulated if
        ``segments_only``)."""
        ...


def weighted_sse(errs: Sequence[Mapping[str, np.ndarray]], w: np.ndarray) -> float:
    """J: the channel-weighted SSE summed over moves (a missing horizon class counts 0)."""
    return float(sum(np.nansum(sse(e) * w) for e in errs))


@dataclass(frozen=True)
class SearchContext:
    """The transducer, the accepted hypotheses, the base's errors and the measurements."""

    runner: Transducer
    base: tuple[Hypothesis, ...]
    base_err: Sequence[Mapping[str, np.ndarray]]
    meas: Sequence[Measured]

    def run(self, hyps: Sequence[Hypothesis], moves: Sequence[int], mode: str = "full"
            ) -> list[list[dict[str, np.ndarray]]]:
        """Errors of each hypothesis added to the base, per move of ``moves``."""
        sims = self.runner.map([(i, list(self.base) + [h], mode) for h in hyps for i in moves])
        n = len(moves)
        return [[errors(sims[k * n + m], self.meas[i]) for m, i in enumerate(moves)]
                for k in range(len(hyps))]

    def sse(self, hyp: Hypothesis | None, moves: Sequence[int]) -> np.ndarray:
        """Per-move, per-channel SSE (M, 36) of the base (``hyp`` None) or the base plus
        ``hyp`` on ``moves`` (full runs)."""
        errs = ([self.base_err[i] for i in moves] if hyp is None
                else self.run([hyp], moves)[0])
        return np.array([sse(e) for e in errs])

    def weights(self, moves: Sequence[int], segments_only: bool = False) -> np.ndarray:
        S0 = np.array([sse(self.base_err[i]) for i in moves]).sum(axis=0)
        w = 1.0 / np.where(S0 > 0, S0, 1.0)
        if segments_only:
            w[LONG] = 0.0
        return w

    def baseline(self, moves: Sequence[int], w: np.ndarray) -> float:
        return weighted_sse([self.base_err[i] for i in moves], w)

    def evaluate(self, hyps: Sequence[Hypothesis], moves: Sequence[int], w: np.ndarray,
                 segments_only: bool = False) -> list[float]:
        if not hyps:
            return []
        return [weighted_sse(e, w)
                for e in self.run(hyps, moves, "segs" if segments_only else "full")]

    def with_base(self, base: Sequence[Hypothesis], base_err: Sequence[Any]) -> "SearchContext":
        return SearchContext(self.runner, tuple(base), base_err, self.meas)
