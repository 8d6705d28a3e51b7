"""The held-out statistics (``littledog_mlsim.diagnose.stats``) against scipy and hand-computed
values: the grouped t-test, the bounded per-move cut, the signed-rank max test and the decision."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats as sps

from littledog_mlsim.diagnose.stats import (N_TESTS, decide, decide_all, focus_p, move_cuts,
                                            rank_max_p, sse_decision, t_greater)


def test_t_greater_is_scipys_one_sided_t_test_per_column():
    rng = np.random.default_rng(0)
    d = rng.normal(0.2, 1.0, (15, 4))
    want = sps.ttest_1samp(d, 0.0, axis=0, alternative="greater").pvalue
    np.testing.assert_allclose(t_greater(d), want, rtol=1e-12)
    # no spread: a positive mean is certain, a zero mean is a coin toss
    flat = np.column_stack([np.full(5, 0.3), np.zeros(5)])
    np.testing.assert_array_equal(t_greater(flat), [0.0, 0.5])
    # one move: no spread, one degree of freedom
    assert t_greater(np.array([[0.4, -0.1]])).tolist() == [0.0, 0.5]


def test_move_cuts_by_hand():
    S0 = np.array([[1.0, 2.0, 0.0], [4.0, 1.0, 3.0]])
    S1 = np.array([[0.5, 2.0, 0.0], [1.0, 3.0, np.nan]])
    # move 0: (0.5/1.5) + 0 + (0: both zero); move 1: 3/5 - 2/4 + (NaN dropped)
    np.testing.assert_allclose(move_cuts(S0, S1), [1.0 / 3.0, 0.6 - 0.5])
    assert np.all(np.abs(move_cuts(S0, 1e9 * S0 + 1.0)) <= S0.shape[1])


def test_rank_max_p_of_one_hypothesis_is_the_exact_wilcoxon_test():
    rng = np.random.default_rng(1)
    for shift in (0.0, 0.3, 0.8):
        c = rng.normal(shift, 1.0, 14)
        exact = sps.wilcoxon(c, alternative="greater", method="exact").pvalue
        p = rank_max_p([c], n_flips=40000, seed=2)[0]
        assert p == pytest.approx(exact, abs=0.01), (shift, p, exact)
    # the max over copies of one hypothesis costs nothing; over a rival it can only grow
    c = rng.normal(0.5, 1.0, 14)
    assert np.allclose(rank_max_p([c, c]), rank_max_p([c])[0])
    assert rank_max_p([c, rng.normal(size=14)])[0] >= rank_max_p([c])[0]


def _example():
    # 4 moves x 2 channels; channel 0 improves on every move, channel 1 does not
    S0 = np.array([[2.0, 1.0], [3.0, 1.0], [1.0, 1.0], [2.0, 1.0]])
    S1 = np.array([[1.0, 1.1], [2.0, 0.9], [0.6, 1.0], [1.2, 1.0]])
    return S0, S1


def test_decide_by_hand():
    S0, S1 = _example()
    tot0 = S0.sum(axis=0)                          # [8, 4]
    d = 4 * (S0 - S1) / tot0                       # per-move contributions
    gain = 1.0 - S1.sum(axis=0) / tot0             # [1 - 4.8/8, 1 - 4/4] = [0.4, 0]
    p_ch = sps.ttest_1samp(d, 0.0, axis=0, alternative="greater").pvalue
    p_pool = sps.ttest_1samp(d.sum(axis=1), 0.0, alternative="greater").pvalue
    r = decide(S0, S1, 5, alpha=0.05, min_gain=0.1)
    np.testing.assert_allclose(r.gain, gain, atol=1e-12)
    np.testing.assert_allclose(gain, [0.4, 0.0], atol=1e-12)
    np.testing.assert_allclose(r.d, d)
    np.testing.assert_allclose(r.p_channel, p_ch, rtol=1e-10)
    assert r.p_pooled == pytest.approx(p_pool, rel=1e-10)
    # two tests, two channels, five candidates (Bonferroni)
    assert r.p_value == pytest.approx(min(1.0, 5 * 2 * min(p_pool, 2 * p_ch.min())), rel=1e-10)
    assert r.significant == (r.p_value < 0.05)
    assert r.material == bool(p_ch[0] < 0.05)      # channel 0: cut 40 % >= 10 %
    # with a rank test's p: three tests
    r3 = decide(S0, S1, 5, 0.05, 0.1, p_rank=0.004)
    assert r3.p_value == pytest.approx(N_TESTS * min(0.004, 5 * p_pool, 2 * 5 * p_ch.min()))


def test_decide_all_uses_the_rank_max_over_the_shortlist():
    S0, S1 = _example()
    S1b = S0 * 1.01                                # a rival that makes things worse
    dec = decide_all(S0, [S1, S1b], 0.05, 0.1)
    p_rank = rank_max_p([move_cuts(S0, S1), move_cuts(S0, S1b)])
    for r, S, p in zip(dec, (S1, S1b), p_rank):
        assert r.p_value == pytest.approx(decide(S0, S, 2, 0.05, 0.1, float(p)).p_value)
    assert not dec[1].significant and not dec[1].material


def test_sse_decision_is_material_only_if_significant_and_names_its_outputs():
    S0, S1 = _example()
    r = sse_decision(S0, S1, 1, alpha=0.05, min_gain=0.1, names=["a", "b"])
    base = decide(S0, S1, 1, 0.05, 0.1)
    assert r.significant == base.significant and r.p_value == base.p_value
    assert r.outputs == (["a"] if base.significant else [])
    no = sse_decision(S0, S1, 10 ** 6, alpha=0.05, min_gain=0.1, names=["a", "b"])
    assert not no.significant and not no.material and no.outputs == []


def test_path_test_is_wilcoxon_on_per_move_log_ratios_of_scaled_sse():
    """stats.path_test against its definition computed here: each channel scaled by its total
    without the candidate, per move the log ratio of the scaled sums, a one-sided Wilcoxon
    signed-rank test (scipy); the gains are the cuts of the channel totals."""
    from scipy.stats import wilcoxon

    from littledog_mlsim.diagnose.stats import path_test
    rng = np.random.default_rng(3)
    P0 = rng.gamma(2.0, 1.0, size=(20, 3)) * np.array([1.0, 10.0, 100.0])
    P1 = P0 * rng.uniform(0.6, 1.1, size=P0.shape)
    t = path_test(P0, P1)
    tot = P0.sum(axis=0)
    a, b = (P0 / tot).sum(axis=1), (P1 / tot).sum(axis=1)
    r = np.log(a / b)
    assert t.p == pytest.approx(wilcoxon(r, alternative="greater").pvalue, rel=1e-12)
    assert t.n_better == int(np.sum(r > 0))
    np.testing.assert_allclose(t.gain, 1.0 - P1.sum(axis=0) / tot, rtol=1e-12)
    assert t.total_gain == pytest.approx(1.0 - b.sum() / a.sum(), rel=1e-12)
    assert path_test(P0, P0).p == 1.0                      # nothing changed: no evidence


def test_contrast_test_is_welch_and_mann_whitney_one_sided():
    from scipy import stats as st

    from littledog_mlsim.diagnose.stats import contrast_test
    rng = np.random.default_rng(3)
    a, b = rng.normal(1.0, 1.0, 40), rng.normal(0.0, 1.0, 50)
    ra, rb = rng.normal(0.5, 1.0, 40), rng.normal(0.0, 1.0, 50)
    p_state, p_path, p = contrast_test(a, b, ra, rb)
    assert p_state == pytest.approx(st.ttest_ind(a, b, equal_var=False,
                                                 alternative="greater").pvalue)
    assert p_path == pytest.approx(st.mannwhitneyu(ra, rb, alternative="greater").pvalue)
    assert p == pytest.approx(min(1.0, 2 * min(p_state, p_path))) and p < 1e-3
    # the same distribution on both sides: no change; the reverse order: p near 1
    assert contrast_test(a, a, ra, ra)[2] == 1.0
    assert contrast_test(b, a, rb, ra)[2] > 0.5


def test_a_focus_that_only_moves_the_median_is_never_material():
    """The focus test's null is the path test's (the median move's ratio), not the t-tests'
    (the mean cut): a candidate that cuts most moves' focus SSE and raises a few moves' by as
    much can pass it, and materiality (an element's mean cut with its own p < alpha) keeps it
    from being accepted."""
    rng = np.random.default_rng(5)
    M, C, focus = 40, 33, list(range(15, 18)) + list(range(27, 30))
    S0 = rng.lognormal(0.0, 0.3, (M, C))
    S1 = S0 * rng.lognormal(0.0, 0.05, (M, C))
    S1[:37][:, focus] *= 0.8                 # most moves a little better ...
    lost = 0.2 * S0[:37][:, focus].sum(axis=0)
    S1[37:][:, focus] += lost / 3            # ... three worse by as much: no mean cut
    f = focus_p(S0[:, focus], S1[:, focus])
    r = sse_decision(S0, S1, 1, 1e-3, 0.05, focus=focus)
    assert f < 1e-3 and r.significant, (f, r.p_value)
    assert abs(r.gain[focus]).max() < 0.05 and not r.material, r.gain[focus]


def test_a_contrast_with_a_focus_sees_a_change_on_a_few_channels():
    """``contrast_test`` with focus cuts (a scoped candidate's cut over its joints' elements):
    a change on those channels that the other elements' scatter hides in the summed cut is seen
    by the focus test, at Bonferroni over three."""
    from littledog_mlsim.diagnose.stats import contrast_focus_p, contrast_test
    rng = np.random.default_rng(4)
    f, f_ref = rng.normal(0.6, 0.3, 20), rng.normal(0.0, 0.3, 20)     # the scope's elements
    rest, rest_ref = rng.normal(0.0, 3.0, 20), rng.normal(0.0, 3.0, 20)  # the other 27
    ra, rb = rng.normal(0.0, 1.0, 20), rng.normal(0.0, 1.0, 20)
    p_state, p_path, p = contrast_test(f + rest, f_ref + rest_ref, ra, rb)
    assert p > 0.01, (p_state, p_path)                     # diluted: no change seen
    _, _, p3 = contrast_test(f + rest, f_ref + rest_ref, ra, rb, f, f_ref)
    p_focus = contrast_focus_p(f, f_ref)
    assert p3 == pytest.approx(min(1.0, 3 * min(p_state, p_path, p_focus))) and p3 < 0.01
    # the same on both sides: the focus sees no change either
    assert contrast_test(f_ref + rest, f_ref + rest_ref, ra, rb, f_ref, f_ref)[2] > 0.5
    # a focus chosen among 9 scopes on the data: its p times 9
    _, _, p9 = contrast_test(f + rest, f_ref + rest_ref, ra, rb, f, f_ref, focus_choices=9)
    assert p9 == pytest.approx(min(1.0, 3 * min(p_state, p_path, min(1.0, 9 * p_focus))))


def test_a_focus_pools_the_channels_a_candidate_acts_on_at_the_level():
    """``focus``: a rank test of the per-move SSE over the channels named before the data (a
    joint scope's elements, ``focus_p``) is a third test, Bonferroni over three. A gain on 6 of 33 channels that the
    pooled and best-channel tests miss is significant with the focus; with no gain anywhere the
    adjusted p stays uniform or above (rejections at 5 % at most about 5 % of the time)."""
    rng = np.random.default_rng(4)
    M, C, focus = 40, 33, list(range(15, 18)) + list(range(27, 30))

    def draw(shift):
        S0 = rng.lognormal(0.0, 0.5, (M, C))
        S1 = S0 * rng.lognormal(0.0, 0.3, (M, C))
        S1[:, focus] *= np.exp(-shift)
        return S0, S1
    S0, S1 = draw(0.15)
    plain, focused = decide(S0, S1, 1, 1e-3, 0.05), decide(S0, S1, 1, 1e-3, 0.05, focus=focus)
    tot = S0[:, focus].sum(axis=0)
    ratio = np.log((S0[:, focus] / tot).sum(axis=1) / (S1[:, focus] / tot).sum(axis=1))
    p_focus = sps.wilcoxon(ratio, alternative="greater").pvalue
    assert focus_p(S0[:, focus], S1[:, focus]) == pytest.approx(p_focus, rel=1e-12)
    assert focused.p_value == pytest.approx(min(1.0, 3 * min(plain.p_pooled,
                                                              C * plain.p_channel.min(), p_focus)))
    assert not plain.significant and focused.significant, (plain.p_value, focused.p_value)
    assert sse_decision(S0, S1, 1, 1e-3, 0.05, focus=focus).p_value == focused.p_value
    null = [decide(*draw(0.0), 1, 0.05, 0.05, focus=focus).p_value for _ in range(400)]
    assert np.mean(np.array(null) < 0.05) <= 0.08
