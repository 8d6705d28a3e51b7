"""The held-out decision and the TestPool before/after (method, step 5).

Every fitted hypothesis of the shortlist is re-simulated on the held-out moves; the one with
the largest mean per-move cut (:func:`..stats.move_cuts`: each move's and channel's cut relative
to that move's own error, bounded) is the finding, and its tests are adjusted for that choice
(:func:`..stats.decide_all`: the rank test's max over the shortlist, the t-tests x the
shortlist's size). The library's size does not enter: the held-out moves took no part in
screening or fitting.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..families import FAMILIES, vocabulary_family
from ..stats import Decision, decide_all, move_cuts
from .advice import INSEPARABLE_SHARE, physical_params, statement
from .channels import horizon_errors, sse
from .context import SearchContext
from .records import Candidate, Finding, HeldOutDecision

__all__ = ["validate", "push_twin"]


@dataclass(frozen=True)
class _Held:
    """One hypothesis on the held-out moves: its errors by move and its SSE (M, 36)."""

    cand: Candidate
    err: Mapping[int, Mapping[str, np.ndarray]]
    S1: np.ndarray


def push_twin(c: Candidate, robot_mass: float) -> Candidate:
    """The hypothesis of the family that pushes alike (:attr:`..families.Family.twin_family`:
    a slope of theta adds m g sin(theta) downhill, fixed in odom, like a force), opposite in
    direction (uphill against the push)."""
    from ...robot.sim import GRAVITY
    d = c.direction if c.direction is not None else np.array([1.0, 0.0])
    m = c.fitted if c.fitted is not None else c.magnitude
    fam = FAMILIES[c.family]
    mag = fam.twin_magnitude(m, robot_mass * GRAVITY)
    return Candidate(fam.twin_family, "body", 0.0, mag, -d, fitted=mag)


def _held_out(ctx: SearchContext, cands: Sequence[Candidate], V: Sequence[int]) -> list[_Held]:
    runs = ctx.run([c.hyp() for c in cands], V)
    return [_Held(c, dict(zip(V, errs)), np.array([sse(e) for e in errs]))
            for c, errs in zip(cands, runs)]


def _with_twin(ctx: SearchContext, held: list[_Held], S0: np.ndarray, kb: int,
               V: Sequence[int], alpha: float, min_gain: float, robot_mass: float
               ) -> tuple[list[_Held], list[Decision], list[float], int]:
    """A push's physical twin, simulated if the shortlist lacks it (for the "cannot tell"
    statement); where the two push alike and the finding's family yields to its twin, the
    twin is the finding. A recording's odometry is taken as level in the world (motion
    capture, or an estimate aided by an IMU), where a slope is a tilted floor and a turned
    gravity is not physical; the gravity form stays the named rival."""
    best = held[kb].cand
    twins = [k for k, h in enumerate(held) if h.cand.family == FAMILIES[best.family].twin_family]
    if not twins:
        held = held + _held_out(ctx, [push_twin(best, robot_mass)], V)
        twins = [len(held) - 1]
    decs = decide_all(S0, [h.S1 for h in held], alpha, min_gain)
    score = [float(np.mean(move_cuts(S0, h.S1))) for h in held]
    k = twins[0]
    if FAMILIES[best.family].yields_to_twin and decs[k].significant and \
            score[k] >= INSEPARABLE_SHARE * score[kb]:
        kb = k
    return held, decs, score, kb


def validate(ctx: SearchContext, top: Sequence[Candidate], V: Sequence[int],
             T: Sequence[int], alpha: float, min_gain: float, horizons_s: Sequence[float],
             cands: Sequence[Candidate], robot_mass: float, foot_mu: float,
             observer: Callable[[HeldOutDecision], None] | None = None) -> Finding:
    """The finding of one round: the shortlist ``top`` decided on the held-out moves ``V``,
    before/after on the TestPool moves ``T`` (or ``V`` if there are none). ``observer``, if
    given, is called once with what the decision compared and chose (a record for benchmarks;
    it does not change the decision)."""
    S0 = ctx.sse(None, V)
    held = _held_out(ctx, top, V)
    decs = decide_all(S0, [h.S1 for h in held], alpha, min_gain)
    score = [float(np.mean(move_cuts(S0, h.S1))) for h in held]
    kb = int(np.argmax(score))
    if FAMILIES[held[kb].cand.family].twin_family:
        held, decs, score, kb = _with_twin(ctx, held, S0, kb, V, alpha, min_gain, robot_mass)
    if observer is not None:
        observer(HeldOutDecision(tuple(h.cand for h in held), len(top), S0,
                                 tuple(h.S1 for h in held), tuple(decs), tuple(score), kb))
    return _finding(ctx, held, decs, score, kb, T or V, horizons_s, cands, foot_mu)


def _finding(ctx: SearchContext, held: list[_Held], decs: list[Decision], score: list[float],
             kb: int, H: Sequence[int], horizons_s: Sequence[float],
             cands: Sequence[Candidate], foot_mu: float) -> Finding:
    best, dec = held[kb].cand, decs[kb]
    err1 = dict(held[kb].err)
    new = [i for i in H if i not in err1]
    if new:   # the TestPool moves (the held-out ones are simulated already)
        err1.update(zip(new, ctx.run([best.hyp()], new)[0]))
    params = physical_params(best, foot_mu)
    alts = [_alternative(h.cand, d, m, foot_mu) for h, d, m in zip(held, decs, score)]
    screening = [{"family": c.family, "scope": c.scope, "score": c.score,
                  "first_order_magnitude": c.magnitude} for c in cands[:10]]
    return Finding(best.family, best.scope, params, statement(best.family, best.scope, params),
                   dec.significant, dec.material, dec.p_value, dec.gain, dec.p_channel,
                   screening, best.profile,
                   horizon_errors([ctx.base_err[i] for i in H], horizons_s),
                   horizon_errors([err1[i] for i in H], horizons_s), best.hyp(), alts)


def _alternative(c: Candidate, dec: Decision, move_cut: float, foot_mu: float
                 ) -> dict[str, Any]:
    return {"family": vocabulary_family(c.family), "searched_family": c.family,
            "scope": c.scope, "params": physical_params(c, foot_mu),
            "J_relative": None if c.J is None else c.J / c.J0,
            "held_out_total_gain": float(np.nansum(dec.gain)), "held_out_move_cut": move_cut,
            "held_out_p": dec.p_value}
