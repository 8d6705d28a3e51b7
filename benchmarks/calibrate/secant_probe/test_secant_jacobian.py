"""``calibrate --jacobian secant`` (module doc 3 of littledog_mlsim.robot.twin_fit): a secant
phase of Broyden-updated Jacobians before the central-difference fit.

Independent reference: a stand-in re-simulating pool whose residual is a known smooth,
nonlinear function of three parameters with its zero at known values, and Broyden's secant
condition itself (J s = r(x + s) - r(x)).
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
PARAMS = tuple(TRUE)
LOG = {"body_mass", "leg_mass", "position_gain", "velocity_gain", "torque_limit_knee"}


class _CurvedPool:
    """Residual per move (30 states, 1 horizon, 33 elements): fixed directions times smooth
    nonlinear functions of the parameters' offsets u from ``TRUE`` (log offsets of the scale-like
    ones), each u_k + 2 (e^(u_k) - 1 - u_k) plus a product of two of them, so that the Jacobian
    changes along the way; a little noise; counts the robots simulated."""

    def __init__(self, recs) -> None:
        rng = np.random.default_rng(5)
        self.d = [rng.normal(size=(2 * len(PARAMS), 30, 1, 33)) for _ in recs]
        self.noise = [3e-2 * rng.normal(size=(30, 1, 33)) for _ in recs]
        self.robots = 0

    def map(self, fn, config, stride, horizons, initial="measured"):
        self.robots += 1
        u = []
        for name, true in TRUE.items():
            v = TWIN_PARAMETERS[name].get(config)
            u.append(math.log(v / true) if name in LOG else v - true)
        n = len(u)
        terms = [u[k] + 2.0 * (math.expm1(u[k]) - u[k]) for k in range(n)]
        terms += [3.0 * u[k] * u[(k + 1) % n] for k in range(n)]
        return [sum(t * d[k] for k, t in enumerate(terms)) + e
                for d, e in zip(self.d, self.noise)]


def _fit(monkeypatch, jacobian: str):
    from littledog_mlsim.robot import twin_fit

    pool = _CurvedPool(range(4))
    monkeypatch.setattr(twin_fit._bl, "move_pool", lambda recs, jobs=2, scheduler=None:
                        contextlib.nullcontext(pool))
    recs = [SimpleNamespace(name=f"F_0{i}", n_steps=400, position=np.zeros((400, 3)))
            for i in range(4)]
    opts = twin_fit.CalibrationOptions(params=PARAMS, horizons=(1,), initial_state="measured",
                                       test_missing=False, max_evals=400, jacobian=jacobian)
    base = dataclasses.replace(robot_config("nominal"), body_mass=1.8, leg_mass=0.22,
                               ground_friction=0.95, position_gain=0.33, velocity_gain=1.0,
                               torque_limit=(1.7, 1.7, 1.1))
    lines: list[str] = []
    cal = twin_fit.calibrate_twin(recs, [], base, opts, lines.append)
    return cal, pool.robots, lines


def test_the_secant_phase_ends_where_the_central_fit_ends(monkeypatch):
    """The same optimum and intervals (central differences there); how many re-simulations the
    secant phase saves depends on how many steps the central fit takes, and is measured on
    recordings (benchmarks/calibrate), not here."""
    central, _, _ = _fit(monkeypatch, "central")
    secant, _, lines = _fit(monkeypatch, "secant")
    assert central.report["converged"] and secant.report["converged"]
    for e_c, e_s in zip(central.estimates, secant.estimates):
        true = TRUE[e_c.name]
        assert e_c.value == pytest.approx(true, rel=2e-3), e_c
        assert e_s.value == pytest.approx(e_c.value, rel=1e-3), (e_c, e_s)
        assert e_s.ci95[0] == pytest.approx(e_c.ci95[0], rel=1e-2)   # central at the optimum
        assert e_s.ci95[1] == pytest.approx(e_c.ci95[1], rel=1e-2)
    assert secant.report["settings"]["jacobian"] == "secant"
    assert central.report["settings"]["jacobian"] == "central"
    phases = [s for s in lines if s.startswith("  secant phase:")]
    assert len(phases) == 2                                              # one per stage
    assert sum(int(s.split()[2]) for s in phases) >= 1                   # Broyden updated


def test_broyden_update_carries_the_step_and_a_short_step_keeps_the_jacobian():
    from littledog_mlsim.robot.twin_fit import _SecantJacobian

    A = np.array([[1.0, 2.0], [0.5, -1.0], [3.0, 0.0]])

    def f(x):
        return A @ x + np.array([x[0] ** 2, 0.0, x[0] * x[1]])

    prob = SimpleNamespace(params=[SimpleNamespace(x_scale=1.0), SimpleNamespace(x_scale=2.0)],
                           o=SimpleNamespace(diff_step=0.05), fun=f,
                           jac=lambda x: A.copy())
    sec = _SecantJacobian(prob)
    x0 = np.array([0.1, 0.2])
    assert np.array_equal(sec(x0), A)                     # central differences at the start
    tiny = x0 + np.array([0.01, 0.0])                     # 0.01 < 0.05 scaled: kept
    assert np.array_equal(sec(tiny), A) and sec.kept == 1 and sec.updates == 0
    x1 = x0 + np.array([0.3, -0.4])                        # measured from x0, not from tiny
    J1 = sec(x1)
    assert sec.updates == 1
    np.testing.assert_allclose(J1 @ (x1 - x0), f(x1) - f(x0), atol=1e-12)
    # the least change in the scaled coordinates: J1 - A is rank one along D^-2 s
    w = (x1 - x0) / np.array([1.0, 4.0])
    d = J1 - A
    np.testing.assert_allclose(d, np.outer(d @ w / (w @ w), w), atol=1e-12)


def test_a_bad_jacobian_choice_is_one_line():
    from littledog_mlsim.robot.twin_fit import CalibrationOptions

    with pytest.raises(ValueError, match="jacobian must be one of central, secant"):
        CalibrationOptions(jacobian="forward").check()
