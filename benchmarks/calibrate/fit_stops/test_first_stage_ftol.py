"""``calibrate --first-stage-ftol F`` (module doc 2 of littledog_mlsim.robot.twin_fit): the
first weighted stage, whose optimum only sets the second stage's weights, ends at the first
accepted step that lowers its cost by less than F of it; the second stage ends where it ends
with the first stage's tight tolerance.

Independent reference: a stand-in re-simulating pool whose residual is a known smooth,
nonlinear function of six parameters with its zero at known values.
"""
from __future__ import annotations

import contextlib
import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.parameters import TWIN_PARAMETERS

TRUE = {"body_mass": 2.3, "leg_mass": 0.17, "ground_friction": 0.75, "position_gain": 0.25,
        "velocity_gain": 0.8, "torque_limit_knee": 0.9}
LOG = {"body_mass", "leg_mass", "position_gain", "velocity_gain", "torque_limit_knee"}


class _CurvedPool:
    """Residual per move (30 states, 1 horizon, 33 elements): fixed directions times smooth
    nonlinear functions of the parameters' offsets u from ``TRUE`` (log offsets of the
    scale-like ones), each u_k + 2 (e^(u_k) - 1 - u_k) plus a product of two of them, a ripple
    in each (so that, as on a contact-rich re-simulation, the fit creeps at the end: the
    minimum it ends in is a ripple's, not ``TRUE``) and a little noise; counts the robots
    simulated."""

    def __init__(self, n_moves: int, ripple: float) -> None:
        rng = np.random.default_rng(5)
        self.d = [rng.normal(size=(3 * len(TRUE), 30, 1, 33)) for _ in range(n_moves)]
        self.noise = [3e-2 * rng.normal(size=(30, 1, 33)) for _ in range(n_moves)]
        self.robots, self.ripple = 0, ripple

    def map(self, fn, config, stride, horizons, initial="measured"):
        self.robots += 1
        u = [math.log(TWIN_PARAMETERS[k].get(config) / v) if k in LOG
             else TWIN_PARAMETERS[k].get(config) - v for k, v in TRUE.items()]
        n = len(u)
        terms = [u[k] + 2.0 * (math.expm1(u[k]) - u[k]) for k in range(n)]
        terms += [3.0 * u[k] * u[(k + 1) % n] for k in range(n)]
        terms += [self.ripple * math.sin(30.0 * u[k]) for k in range(n)]   # rough: fits creep
        return [sum(t * d[k] for k, t in enumerate(terms)) + e
                for d, e in zip(self.d, self.noise)]


def _fit(monkeypatch, first_stage_ftol: float = 1e-4, ripple: float = 0.2):
    from littledog_mlsim.robot import twin_fit

    pool = _CurvedPool(4, ripple)
    monkeypatch.setattr(twin_fit._bl, "move_pool", lambda recs, jobs=2, scheduler=None:
                        contextlib.nullcontext(pool))
    recs = [SimpleNamespace(name=f"F_0{i}", n_steps=400, position=np.zeros((400, 3)))
            for i in range(4)]
    opts = twin_fit.CalibrationOptions(params=tuple(TRUE), horizons=(1,),
                                       initial_state="measured", test_missing=False,
                                       max_evals=400, first_stage_ftol=first_stage_ftol)
    base = dataclasses.replace(robot_config("nominal"), body_mass=1.8, leg_mass=0.22,
                               ground_friction=0.95, position_gain=0.33, velocity_gain=1.0,
                               torque_limit=(1.7, 1.7, 1.1))
    return twin_fit.calibrate_twin(recs, [], base, opts), pool.robots


def test_a_looser_first_stage_ends_where_the_tight_one_ends(monkeypatch):
    tight, n_tight = _fit(monkeypatch, 1e-4)
    loose, n_loose = _fit(monkeypatch, 0.01)
    assert tight.report["converged"] and loose.report["converged"]
    assert loose.report["settings"]["first_stage_ftol"] == 0.01
    assert tight.report["settings"]["first_stage_ftol"] == 1e-4
    # the loose first stage stops higher, and on its cost tolerance
    assert loose.report["cost_end_stage1"] > tight.report["cost_end_stage1"]
    assert loose.report["stop_stage1"] == "converged (step below the first stage's tolerance)"
    assert tight.report["stop_stage1"] == "converged (step)"
    for t, s in zip(tight.estimates, loose.estimates):     # the second stage: the same minimum
        assert s.value == pytest.approx(t.value, rel=5e-3), (t, s)
        assert s.ci95[0] == pytest.approx(t.ci95[0], rel=2e-2)
        assert s.ci95[1] == pytest.approx(t.ci95[1], rel=2e-2)
    assert n_loose < n_tight


@pytest.mark.parametrize("bad", [1e-5, 0.5, float("nan")])
def test_a_first_stage_tolerance_out_of_range_is_one_line(bad):
    from littledog_mlsim.robot.twin_fit import CalibrationOptions

    with pytest.raises(ValueError, match="first_stage_ftol must be in"):
        CalibrationOptions(first_stage_ftol=bad).check()

