"""A servo stiffness drifting with time, measured per time bin against a reference."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from littledog_mlsim.diagnose.servo_drift import (joint_rates, rate_against_reference,
                                                  stiffness_by_time)
from littledog_mlsim.layout import N_STATE, StateLayout

S = StateLayout()
STEPS = 400


@dataclass
class _Arrays:
    S: list
    U: list
    Y: list


def _servo_moves(rate: float, gait_rate: float, n_moves: int = 12, seed: int = 0) -> _Arrays:
    """Moves of a PD servo whose stiffness reads k0 (1 + rate t + gait_rate t): ``gait_rate``
    stands for a gait that is not stationary either, which the regression reads as a trend of
    its own, shared with the reference."""
    rng = np.random.default_rng(seed)
    k0, c = 4.0, 0.3
    out = _Arrays([], [], [])
    for _ in range(n_moves):
        t = np.arange(STEPS) * 0.01
        k = k0 * (1 + rate * t + gait_rate * t)
        St = np.zeros((STEPS, N_STATE))
        St[:, S.q] = rng.normal(0.0, 0.3, (STEPS, 12))
        St[:, S.dq] = rng.normal(0.0, 1.0, (STEPS, 12))
        U = St[:, S.q] + rng.normal(0.0, 0.05, (STEPS, 12))
        Y = St.copy()
        Y[:, S.dq] += (k[:, None] * (U - St[:, S.q]) - c * St[:, S.dq]
                       + rng.normal(0.0, 0.002, (STEPS, 12)))
        out.S.append(St)
        out.U.append(U)
        out.Y.append(Y)
    return out


def test_the_stiffness_per_time_bin_follows_the_drift():
    tc, K = stiffness_by_time(_servo_moves(-0.1, 0.0))
    assert K.shape == (8, 12) and tc[0] < tc[-1]
    np.testing.assert_allclose(K[:, 0], 4.0 * (1 - 0.1 * tc), rtol=0.03)
    np.testing.assert_allclose(joint_rates(_servo_moves(-0.1, 0.0)), -0.1, atol=0.01)


def test_against_the_reference_the_gaits_own_trend_cancels():
    data, ref = _servo_moves(-0.08, -0.06, seed=1), _servo_moves(0.0, -0.06, seed=2)
    got = rate_against_reference(data, ref, joints=[0, 3, 6, 9])
    assert got["rate_per_s"] == pytest.approx(-0.08, abs=0.015)
    assert got["reference_rate_per_s"] == pytest.approx(-0.06, abs=0.01)
    assert set(got["joint_rates"]) == {"front_left_hip_roll", "front_right_hip_roll",
                                       "back_left_hip_roll", "back_right_hip_roll"}
    clean = rate_against_reference(_servo_moves(0.0, -0.06, seed=3), ref)
    assert abs(clean["rate_per_s"]) < 0.015
