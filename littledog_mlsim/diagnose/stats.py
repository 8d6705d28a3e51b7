"""Held-out statistics shared by every diagnosis route: grouped t-tests, the rank test, the decision.

A move is the independent unit (samples within a move are strongly autocorrelated), so every
test here works on per-move quantities: the held-out SSE of each move and channel without
(``S0``) and with (``S1``) a candidate effect, both (M, C) for M moves and C channels (the
learned route's 33 state elements, the physical route's 36 output channels).

- :func:`t_greater`: one-sided one-sample t-test of mean > 0 over the moves, per column;
- :func:`move_cuts` and :func:`rank_max_p`: each move's bounded cut and a signed-rank max test
  over several hypotheses compared on the same moves (common random sign flips);
- :func:`path_test` and :func:`focus_p`: the signed-rank test of each move's log SSE ratio over
  a few channels (the odom path; a scoped candidate's own joints);
- :func:`contrast_test`: does a candidate cut the error of one dataset's moves more than another's
  (the learned route's "what changed since the reference?");
- :func:`decide`: gains, the tests and the decision (significant, material) for one candidate;
  :func:`sse_decision` is the learned route's form of it, :func:`decide_all` the physical
  route's (the rank test over a shortlist).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy import stats

__all__ = ["t_greater", "move_cuts", "rank_max_p", "Decision", "decide", "decide_all",
           "SSEDecision", "sse_decision", "PathTest", "path_test", "focus_p", "contrast_test",
           "contrast_focus_p", "welch_greater", "RANK_FLIPS",
           "N_TESTS"]

RANK_FLIPS = 20000   # random sign flips of the moves for the pooled rank test's null
N_TESTS = 3          # with a rank test: pooled t, pooled rank, best channel's t


def t_greater(d: np.ndarray) -> np.ndarray:
    """One-sided one-sample t-test of mean > 0 over axis 0 (the moves); p per column.

    A column with zero spread has p 0 if its mean is positive, else 0.5; with one move the
    spread is taken as zero (one degree of freedom)."""
    M = d.shape[0]
    mean = d.mean(axis=0)
    sd = d.std(axis=0, ddof=1) if M > 1 else np.zeros_like(mean)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(sd > 0, mean / (sd / math.sqrt(max(M, 1))),
                     np.where(mean > 0, np.inf, 0.0))
    return stats.t.sf(t, df=max(M - 1, 1))


def move_cuts(S0: np.ndarray, S1: np.ndarray) -> np.ndarray:
    """Per-move held-out cut (M,) for the rank test: the sum over channels of
    (S0 - S1) / (S0 + S1), each move's cut relative to its own error on that channel, in [-1, 1].
    A channel whose 4 s replay a hypothesis re-rolls on one move (chaos, not the effect) cannot
    outweigh the other channels and moves, as it can in sums relative to the channel's total."""
    den = S0 + S1
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(den > 0, (S0 - S1) / den, 0.0)
    return np.nansum(r, axis=1)


def rank_max_p(cuts: Sequence[np.ndarray], n_flips: int = RANK_FLIPS, seed: int = 0
               ) -> np.ndarray:
    """One-sided adjusted p per hypothesis (H,) from per-move cuts (each (M,)): Wilcoxon
    signed-rank statistics over moves, with the null of their maximum over the hypotheses from
    common random sign flips of the moves (Westfall-Young single-step max-T).

    Ranks do not let a few moves that change a lot (a slipping foot) drown a consistent cut on
    the others, as a t-test's variance does; the common flips keep the hypotheses' correlation,
    so choosing the best of the shortlist costs less than Bonferroni's factor. Zero cuts (a
    move the hypothesis does not change) count for neither side."""
    D = np.nan_to_num(np.column_stack([np.asarray(c, dtype=np.float64) for c in cuts]))
    M, H = D.shape
    R = np.column_stack([stats.rankdata(np.abs(D[:, h])) for h in range(H)])
    SR = np.sign(D) * R                                    # signed ranks (M, H)
    w_obs = SR.sum(axis=0)
    rng = np.random.default_rng(seed)
    flips = rng.choice(np.array([-1.0, 1.0]), size=(n_flips, M))
    w_max = (flips @ SR).max(axis=1)                       # (B,) null of the max statistic
    exceed = (w_max[:, None] >= w_obs[None, :] - 1e-9).sum(axis=0)
    return (1.0 + exceed) / (n_flips + 1.0)


@dataclass(frozen=True)
class Decision:
    """What held-out per-move SSEs say about one candidate."""

    gain: np.ndarray          # (C,) held-out SSE cut per channel, 1 - sum S1 / sum S0
    d: np.ndarray             # (M, C) per-move contributions (mean over moves = gain)
    p_channel: np.ndarray     # (C,) one-sided t-test p per channel (unadjusted)
    p_pooled: float           # unadjusted p of the t-test pooled over channels
    p_value: float            # adjusted over the tests, the channels and the candidates
    significant: bool         # p_value < alpha
    material: bool            # some channel cut by >= min_gain with its own p < alpha
    p_focus: float | None = None   # unadjusted p of the focus test (with ``focus``)


def decide(S0: np.ndarray, S1: np.ndarray, n_candidates: int, alpha: float, min_gain: float,
           p_rank: float | None = None, focus: Sequence[int] | None = None) -> Decision:
    """Gains, move-grouped tests and the decision from per-move SSEs (M, C) without (S0) and
    with (S1) a candidate.

    Per move m the contribution d_mc = M (S0_mc - S1_mc) / sum_m S0_mc has mean gain_c. The
    tests are one-sided over moves: the t-test of the contribution pooled over channels and the
    best channel's t-test (x C channels), both x ``n_candidates``. Without a rank test the
    adjusted p is Bonferroni over these two; with ``p_rank`` (a rank test's p, already adjusted
    for the candidates compared, :func:`rank_max_p` of :func:`move_cuts`) over the three.
    ``focus``: channels the candidate acts on first, named before the data are seen (a joint
    scope's joint elements); without a rank test, :func:`focus_p` on them is a third test
    (Bonferroni over three). An effect on a few channels is diluted in the pooled test and pays
    for the channel count in the best channel's.
    ``material`` does not require significance (the routes combine the two as they report)."""
    M, C = S0.shape
    tot0 = S0.sum(axis=0)
    tot0 = np.where(tot0 > 0, tot0, 1.0)
    gain = 1.0 - S1.sum(axis=0) / tot0
    d = M * (S0 - S1) / tot0
    p_ch = t_greater(d)
    p_pool = float(t_greater(d.sum(axis=1, keepdims=True))[0])
    p_focus = None
    if p_rank is None and focus is not None:
        p_focus = focus_p(S0[:, list(focus)], S1[:, list(focus)])
        p_adj = min(1.0, n_candidates * 3.0 * min(p_pool, C * float(p_ch.min()), p_focus))
    elif p_rank is None:
        p_adj = min(1.0, n_candidates * 2.0 * min(p_pool, C * float(p_ch.min())))
    else:
        p_adj = min(1.0, N_TESTS * min(p_rank, p_pool * n_candidates,
                                       float(np.min(p_ch)) * C * n_candidates))
    material = bool(np.any((p_ch < alpha) & (gain >= min_gain)))
    return Decision(gain, d, p_ch, p_pool, p_adj, bool(p_adj < alpha), material, p_focus)


def focus_p(S0: np.ndarray, S1: np.ndarray) -> float:
    """One-sided p that a candidate cuts the per-move SSE of a few channels (M, k) without
    (``S0``) and with (``S1``) it: each channel scaled by its total without, summed per move,
    the per-move log ratio tested > 0 by the Wilcoxon signed-rank test, as :func:`path_test`
    does (a few moves carry most of the SSE; ranks do not pay for that in power). Its null is
    the path test's: a column that carries nothing leaves each move's ratio symmetric about 1
    (noise that keeps the median) or below it (a held-out fit only adds variance). It is not
    the t-tests' null: a candidate that lowers the median move's SSE and raises a few moves'
    by as much can pass it, and materiality (an element's mean cut) still guards acceptance."""
    return path_test(S0, S1).p


def decide_all(S0: np.ndarray, S1s: Sequence[np.ndarray], alpha: float, min_gain: float
               ) -> list[Decision]:
    """:func:`decide` for every hypothesis compared on the same held-out moves, with the rank
    test's max over them."""
    p_rank = rank_max_p([move_cuts(S0, S1) for S1 in S1s])
    return [decide(S0, S1, len(S1s), alpha, min_gain, float(p)) for S1, p in zip(S1s, p_rank)]


@dataclass
class SSEDecision:
    """The learned route's reading of :class:`Decision`: material only if significant, and the
    elements it names (``outputs``: p < alpha and gain >= min_gain / 2)."""

    gain: np.ndarray          # (C,) held-out nMSE cut per element
    d: np.ndarray             # (M, C) per-move contributions (mean over moves = gain)
    p_element: np.ndarray     # (C,) one-sided t-test p per element (unadjusted)
    p_pooled: float           # unadjusted p of the pooled (all-element) test
    p_value: float            # Bonferroni over the tests (two; three with a focus), the
    #                           elements and n_candidates
    significant: bool
    material: bool
    outputs: list[str]        # elements with p < alpha and gain >= min_gain / 2
    p_focus: float | None = None   # unadjusted p of the focus test (with ``focus``)


def sse_decision(S0: np.ndarray, S1: np.ndarray, n_candidates: int, alpha: float,
                 min_gain: float, names: Sequence[str] | None = None,
                 focus: Sequence[int] | None = None) -> SSEDecision:
    """:func:`decide` without a rank test, as the learned route and the physics baseline
    calibration read it; ``names``: the channels' names (default the 33 state elements);
    ``focus``: as for :func:`decide`."""
    if names is None:
        from ..layout import STATE_NAMES
        names = STATE_NAMES
    r = decide(S0, S1, n_candidates, alpha, min_gain, focus=focus)
    nominal = r.p_channel < alpha
    material = bool(r.significant and r.material)
    out_mask = (nominal & (r.gain >= 0.5 * min_gain) if r.significant
                else np.zeros(len(r.gain), bool))
    return SSEDecision(r.gain, r.d, r.p_channel, r.p_pooled, r.p_value, r.significant,
                       material, [names[j] for j in np.flatnonzero(out_mask)], r.p_focus)


@dataclass
class PathTest:
    """The path channels' decision: per move, the log ratio of its odom residual SSE without
    and with the candidate (each channel scaled by its total without, so every horizon weighs
    alike), tested > 0 over the moves by a one-sided Wilcoxon signed-rank test. The per-move
    SSE of a drift is heavy-tailed (a few long, fast moves carry most of it), which the
    t-test of :func:`sse_decision` on SSE differences pays for in power; the rank
    test on ratios does not, and its level holds under the same null (a column that does not
    help leaves the per-move ratio symmetric about 1 or below it)."""

    gain: np.ndarray      # (channels,) held-out SSE cut per path channel
    total_gain: float     # cut of the channel-scaled total
    p: float              # unadjusted one-sided p
    n_better: int         # moves whose scaled path SSE went down
    log_ratios: np.ndarray = field(default_factory=lambda: np.zeros(0))  # per move tested


def path_test(P0: np.ndarray, P1: np.ndarray) -> PathTest:
    """The :class:`PathTest` of per-move path SSE without (``P0``) and with (``P1``) a
    candidate, both (moves, channels)."""
    tot = P0.sum(axis=0)
    tot = np.where(tot > 0, tot, 1.0)
    a, b = (P0 / tot).sum(axis=1), (P1 / tot).sum(axis=1)
    ok = (a > 0) & (b > 0)
    r = np.log(a[ok] / b[ok])
    p = float(stats.wilcoxon(r, alternative="greater").pvalue) if np.any(r != 0) else 1.0
    return PathTest(1.0 - P1.sum(axis=0) / tot, float(1.0 - b.sum() / a.sum()), p,
                    int(np.sum(r > 0)), r)


def contrast_test(cuts: np.ndarray, cuts_ref: np.ndarray, ratios: np.ndarray,
                  ratios_ref: np.ndarray, focus_cuts: np.ndarray | None = None,
                  focus_cuts_ref: np.ndarray | None = None, focus_choices: int = 1
                  ) -> tuple[float, float, float]:
    """(p_state, p_path, p): one-sided two-sample tests that a candidate gains more on the data's
    moves than on a reference's. ``cuts``: each move's held-out state contribution summed over
    the elements (``SSEDecision.d`` summed over its columns; the mean over moves is the total
    gain), tested by Welch's t-test; ``ratios``: each move's path log ratio
    (``PathTest.log_ratios``), tested by the Mann-Whitney U test. ``p`` = 2 min(p_state,
    p_path), as the learned route combines its two channel sets. ``focus_cuts`` (and
    ``focus_cuts_ref``): each move's contribution summed over the channels the candidate acts on
    (a joint scope's elements, named before the data), Welch-tested too; ``p`` is then Bonferroni
    over the three (3 min), as :func:`decide` adds its focus test. A change on one joint is
    diluted in the sum over 33 elements as it is in the pooled test. The focus test's p is
    :func:`contrast_focus_p` times ``focus_choices``: the scopes the focus was chosen among on
    the data (the kept scope's cut is the largest of them there, and not on the reference, so
    a shared effect would otherwise read as a change several times too often:
    ``benchmarks/learned_route/focus_contrast_selection.md``)."""
    def mwu(a: np.ndarray, b: np.ndarray) -> float:
        if len(a) == 0 or len(b) == 0:
            return 1.0
        return float(stats.mannwhitneyu(a, b, alternative="greater").pvalue)

    p_state = welch_greater(np.asarray(cuts, float), np.asarray(cuts_ref, float))
    p_path = mwu(np.asarray(ratios, float), np.asarray(ratios_ref, float))
    p_focus = None if focus_cuts is None else contrast_focus_p(focus_cuts, focus_cuts_ref)
    return p_state, p_path, contrast_combined(p_state, p_path, p_focus, focus_choices)


def contrast_combined(p_state: float, p_path: float, p_focus: float | None = None,
                      focus_choices: int = 1) -> float:
    """:func:`contrast_test`'s ``p`` from its tests' unadjusted p: 2 min(p_state, p_path), or
    with a focus test 3 min(p_state, p_path, ``focus_choices`` x p_focus), capped at 1."""
    if p_focus is None:
        return min(1.0, 2.0 * min(p_state, p_path))
    p_focus = min(1.0, max(1, int(focus_choices)) * float(p_focus))
    return min(1.0, 3.0 * min(p_state, p_path, p_focus))


def contrast_focus_p(focus_cuts: np.ndarray, focus_cuts_ref: np.ndarray) -> float:
    """:func:`contrast_test`'s focus test: Welch's one-sided t-test that each move's cut summed
    over the focus channels is larger on the data than on the reference."""
    return welch_greater(np.asarray(focus_cuts, float), np.asarray(focus_cuts_ref, float))


def welch_greater(a: np.ndarray, b: np.ndarray) -> float:
    """Welch's one-sided p that ``a``'s mean exceeds ``b``'s (0 or 1 where neither varies or a
    side has fewer than two values)."""
    if len(a) < 2 or len(b) < 2 or (np.ptp(a) == 0 and np.ptp(b) == 0):
        return 0.0 if np.mean(a) > np.mean(b) else 1.0
    return float(stats.ttest_ind(a, b, equal_var=False, alternative="greater").pvalue)
