"""An unexplained change since the reference: the data's rollout error against the reference's."""
from __future__ import annotations

import numpy as np

from littledog_mlsim.diagnose.excess import (MIN_RATIO, elements_of, move_mse,
                                             unexplained_change)
from littledog_mlsim.layout import N_STATE, StateLayout

S = StateLayout()
TYPES = [t for t in ("F", "B", "L", "R", "FL", "FR", "BL", "BR") for _ in range(6)]
ROWS_PER_MOVE = 6          # rollouts from starts 0, 0.5, ..., 2.5 s


def _residuals(seed: int, scale: np.ndarray | None = None):
    """Rollout residuals of 48 moves, 6 starts each; ``scale`` (33,) multiplies each element's
    spread (a change that makes those elements harder to predict)."""
    rng = np.random.default_rng(seed)
    n = len(TYPES)
    sd = np.linspace(0.5, 2.0, N_STATE) * (1.0 if scale is None else scale)
    err = rng.normal(0.0, 1.0, (n * ROWS_PER_MOVE, N_STATE)) * sd
    move = np.repeat(np.arange(n), ROWS_PER_MOVE)
    t0 = np.tile(np.arange(ROWS_PER_MOVE) * 50, n)
    return err, move, t0


def _test(data, ref):
    return unexplained_change(*data, TYPES, *ref, TYPES, 1.0, 1e-4)


def _scale(scope: str, factor: float) -> np.ndarray:
    s = np.ones(N_STATE)
    s[elements_of(scope)] = factor
    return s


def test_move_mse_is_each_moves_mean_square_per_element():
    err = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    got = move_mse(err, np.array([0, 0, 1]), 3)
    assert np.allclose(got, [[5.0, 10.0], [25.0, 36.0], [0.0, 0.0]])


def test_the_same_robot_is_no_change():
    for seed in range(5):
        u = _test(_residuals(seed), _residuals(100 + seed))
        assert not u["significant"] and u["ratio"] < MIN_RATIO, u
        assert "not a material and significant change" in u["statement"]


def test_a_change_at_the_knees_is_found_and_scoped_there():
    u = _test(_residuals(1, _scale("type:knees", 3.0)), _residuals(2))
    assert u["significant"] and u["p_value"] < 1e-4 and u["ratio"] > MIN_RATIO, u
    assert u["scope"] == "type:knees" and u["concentration"] >= 2.0
    assert u["vocabulary"] == {"family": "other", "scope": "type:knees",
                               "params": {"error_ratio": round(u["ratio"], 3)},
                               "statement": u["statement"]}
    assert "all knees" in u["statement"] and "nothing was added" in u["statement"]
    assert "excitation" in u["recording"]


def test_a_change_of_one_leg_is_scoped_to_the_leg_not_its_joints():
    u = _test(_residuals(3, _scale("leg:back_left", 3.0)), _residuals(4))
    assert u["significant"] and u["scope"] == "leg:back_left", u


def test_a_change_in_the_bodys_motion_is_scoped_to_the_body():
    u = _test(_residuals(5, _scale("body", 4.0)), _residuals(6))
    assert u["significant"] and u["scope"] == "body", u
    assert "start-spread" in u["recording"]


def test_a_change_spread_over_everything_is_all():
    u = _test(_residuals(7, np.full(N_STATE, 2.0)), _residuals(8))
    assert u["significant"] and u["scope"] == "all" and u["concentration"] == 1.0, u


def test_data_easier_than_the_reference_is_no_change():
    u = _test(_residuals(9, np.full(N_STATE, 0.5)), _residuals(10))
    assert not u["significant"] and u["ratio"] < 1.0 and u["p_value"] > 0.5, u


def test_a_small_excess_is_not_material_however_significant():
    u = _test(_residuals(11, np.full(N_STATE, 1.15)), _residuals(12))
    assert u["ratio"] < MIN_RATIO and not u["material"] and not u["significant"], u


def test_where_it_lives_by_start_time_and_move_type():
    err, move, t0 = _residuals(13)
    late = t0 >= 200
    err[late] *= 4.0                         # the excess lives in the rollouts started late
    u = _test((err, move, t0), _residuals(14))
    by = {e["start_s"]: e["ratio"] for e in u["by_start_s"]}
    assert set(by) == {0, 1, 2} and by[2] > 4 * by[0], by
    assert set(u["by_type"]) == set(TYPES)
