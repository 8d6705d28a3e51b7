"""``calibrate``'s common-scale check (littledog_mlsim.robot.twin_fit, module doc 12): a direction
the residuals do not change along, which the finite-difference Jacobian does not show, is
reported as not identified and its parameters get no interval. A stand-in pool, no physics."""
from __future__ import annotations

import contextlib
import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from littledog_mlsim.robot.config import robot_config


class _ScalePool:
    """Residuals that depend on the servo's gain and damping only through their ratios to the
    body mass (a = log kp_knee - log m, b = log kd_knee - log m), as a robot's motion does: a
    smooth part with its optimum at a = a0, b = b0, and a rough part in both together (contacts
    that take another course when one parameter moves alone) that a 5 % central difference
    reads as slope, whose sum over the columns does not cancel along the common scale."""

    A0, B0 = math.log(6.0 / 2.0), math.log(0.35 / 2.0)

    def __init__(self, recs) -> None:
        rng = np.random.default_rng(11)
        self.dirs = [rng.normal(size=(2, 40, 1, 33)) for _ in recs]
        self.rough = [rng.normal(size=(40, 1, 33)) for _ in recs]

    def map(self, fn, config, stride, horizons, initial="measured"):
        m = math.log(config.body_mass)
        a, b = math.log(config.kp[2]) - m, math.log(config.kd[2]) - m
        g = 0.02 * math.sin(60 * a + 1.0) * math.sin(60 * b + 2.0)
        return [d[0] * (a - self.A0) + d[1] * (b - self.B0) + g * e
                for d, e in zip(self.dirs, self.rough)]


def _case(monkeypatch, params, pool=_ScalePool, body_mass: float = 2.2, **options):
    from littledog_mlsim.robot import twin_fit

    monkeypatch.setattr(twin_fit._bl, "move_pool", lambda recs, jobs=2, scheduler=None:
                        contextlib.nullcontext(pool(recs)))
    recs = [SimpleNamespace(name=f"F_0{i}", n_steps=400, position=np.zeros((400, 3)))
            for i in range(3)]
    base = dataclasses.replace(robot_config("measured"), body_mass=body_mass, kp=(6.0, 6.0, 6.3),
                               kd=(0.35, 0.35, 0.33), sensor_noise=False)
    opts = twin_fit.CalibrationOptions(**{"params": params, "horizons": (1,),
                                          "initial_state": "measured", "test_missing": False,
                                          "max_evals": 60, **options})
    return twin_fit.calibrate_twin(recs, [], base, opts)


def test_the_common_scale_is_found_where_the_jacobian_misses_it(monkeypatch):
    """The body mass with the knee's gain and damping: along their common scale the residuals
    do not change (derivative 0) while the Jacobian's columns add up to a slope; the direction
    is reported first among the weak ones and the three get no interval; the printout says to
    weigh the robot. With the mass left out at its weighed value there is nothing to check, and
    the gain and damping come out within 1 % with intervals."""
    from littledog_mlsim.cli import format_calibration

    cal = _case(monkeypatch, ("body_mass", "kp_knee", "kd_knee"))
    sym = cal.report["scale_symmetry"]
    assert not sym["identified"] and sym["derivative"] == pytest.approx(0.0, abs=1e-9)
    assert sym["jacobian_derivative"] > 1.0
    assert set(sym["combination"]) == {"body_mass", "kp_knee", "kd_knee"}
    assert cal.weak[0].combination == sym["combination"]
    assert all(e.ci95 == (None, None) for e in cal.estimates)
    assert "the common scale of the masses and servo torques is not identified" in \
        format_calibration(cal.report)
    weighed = _case(monkeypatch, ("kp_knee", "kd_knee"))
    assert weighed.report["scale_symmetry"] is None
    for e, v in zip(weighed.estimates, (2.2 * 3.0, 2.2 * 0.175)):
        assert e.ci95 != (None, None) and e.value == pytest.approx(v, rel=0.01)


def test_a_bounded_common_scale_widens_its_parameters_intervals(monkeypatch):
    """Where something that does not scale with the masses acts (here a smooth pull on the body
    mass alone), the scale is bounded: it is not a weak direction, and the intervals of the
    parameters in it include the width the difference along it leaves, wider than the
    Jacobian's."""
    class _Pinned(_ScalePool):
        def map(self, fn, config, stride, horizons, initial="measured"):
            out = super().map(fn, config, stride, horizons, initial)
            pull = math.log(config.body_mass / 2.2)
            return [o + 0.05 * pull * d[0] for o, d in zip(out, self.dirs)]

    cal = _case(monkeypatch, ("body_mass", "kp_knee", "kd_knee"), _Pinned, body_mass=2.0)
    sym = cal.report["scale_symmetry"]
    assert sym["identified"] and 0 < sym["derivative"] < sym["jacobian_derivative"]
    assert all(w.combination != sym["combination"] for w in cal.weak)
    mass = cal.estimates[0]
    lo, hi = mass.ci95
    sd = math.log(hi / lo) / (2 * 1.959964)
    assert sd >= sym["halfwidth95"] / 1.959964 * abs(sym["combination"]["body_mass"]) * 0.99
    assert cal.report["sd_coordinate"]["body_mass"] == pytest.approx(sd, rel=1e-6)


def test_a_weighing_sets_the_common_scale_and_its_intervals(monkeypatch):
    """Weighed at 2.9 kg (the start's total is 2.2 + 4 x 0.19 = 2.96): along the scale the
    residuals do not change, so the fit is moved to the weighing exactly (the knee's gain and
    damping keep their ratios to the body mass, the cost does not move), the scale is
    identified, and the three get intervals as wide as the weighing leaves them (its 0.02 kg
    over the body's 2.14 kg: 0.93 %), around values that contain the truth of the weighed robot. A
    weighing without a mass fitted is refused in one line."""
    from littledog_mlsim.cli import format_calibration
    from littledog_mlsim.robot.parameters import total_mass

    cal = _case(monkeypatch, ("body_mass", "kp_knee", "kd_knee"), weighed_mass=2.9,
                weighed_mass_sd=0.02)
    sym = cal.report["scale_symmetry"]
    w = sym["weighed"]
    assert sym["identified"] and w["sd_scale_data"] is None
    assert total_mass(cal.config) == pytest.approx(2.9, rel=1e-9)
    assert w["cost_weighed"] == pytest.approx(w["cost_fit"], rel=1e-9)
    assert w["sd_scale"] == pytest.approx(w["sd_scale_weighing"])
    # only the body scales (the legs, 4 x 0.19 kg, are not fitted): d log M / d t is the
    # body's share of the weighed mass, and the scale's sd 0.02 / (2.9 - 0.76)
    assert w["sd_scale"] == pytest.approx(0.02 / (2.9 - 0.76), rel=1e-6)
    m = cal.config.body_mass
    truth = {"body_mass": m, "kp_knee": m * 3.0, "kd_knee": m * 0.175}
    assert all(cal.weak[k].combination != sym["combination"] for k in range(len(cal.weak)))
    for e in cal.estimates:
        lo, hi = e.ci95
        assert lo < truth[e.name] < hi and e.value == pytest.approx(truth[e.name], rel=0.01)
        assert math.log(hi / lo) / (2 * 1.959964) >= w["sd_scale"] * 0.99
    assert "weighed 2.9 +- 0.02 kg" in format_calibration(cal.report)
    with pytest.raises(ValueError, match="needs a mass among the fitted parameters"):
        _case(monkeypatch, ("kp_knee", "kd_knee"), weighed_mass=2.9)
    with pytest.raises(ValueError, match="weighed_mass must be"):
        _case(monkeypatch, ("body_mass", "kp_knee"), weighed_mass=float("nan"))


def test_a_scale_pinned_by_a_parameter_not_fitted_yields_to_the_weighing(monkeypatch):
    """Where a parameter left out of the fit does not scale with the rest (the knee's rotor
    inertia at its assumed value), the residuals pin the common scale to it; that pin is only
    as good as the assumed value (the consider spread, 15 % here), so the weighing, 10 g on
    2.9 kg, takes the twin to the weighed mass, and the report names the inertia as what
    loosens the data's hold on the scale."""
    from littledog_mlsim.cli import format_calibration
    from littledog_mlsim.robot.parameters import total_mass

    class _ArmaturePinned(_ScalePool):
        def map(self, fn, config, stride, horizons, initial="measured"):
            out = super().map(fn, config, stride, horizons, initial)
            pull = math.log(config.armature[2] / config.body_mass) - math.log(1.6e-3 / 2.0)
            return [o + 0.5 * pull * d[1] for o, d in zip(out, self.dirs)]

    cal = _case(monkeypatch, ("body_mass", "kp_knee", "kd_knee"), _ArmaturePinned,
                body_mass=2.0, weighed_mass=2.9, weighed_mass_sd=0.01, test_missing=True)
    w = cal.report["scale_symmetry"]["weighed"]
    assert next(iter(w["sd_scale_data_by"])) == "armature_knee"
    assert w["sd_scale_data"] > 5 * w["sd_scale_data_noise"]
    assert w["sd_scale"] < w["sd_scale_data"]
    assert abs(total_mass(cal.config) - 2.9) < 0.1 * abs(w["fitted_mass_kg"] - 2.9)
    assert "the data tie the scale to armature_knee (not fitted); fit it" in \
        format_calibration(cal.report)


def test_the_weighings_sd_reaches_each_parameter_along_the_scale():
    """``_weighed_estimates`` on hand-made estimates: three log parameters on the scale (the
    body mass, the knee's gain and damping), a linear one on it (a rotor inertia, moved by its
    value per unit of scale) and one off it (the contact's friction). With the scale's sd 0.01,
    each coordinate on the scale gains 0.01 times its move per unit of scale in quadrature
    (0.01 e-folds for a log parameter, 0.01 times the value for the inertia), the friction
    nothing; the entry's 95 % half-width is along the unit-norm combination."""
    from littledog_mlsim.robot import twin_fit
    from littledog_mlsim.robot.parameters import TWIN_PARAMETERS

    names = ["body_mass", "kp_knee", "kd_knee", "armature_knee", "ground_friction"]
    params = [TWIN_PARAMETERS[n] for n in names]
    values = [2.0, 6.0, 0.35, 1.5e-3, 0.8]
    x = np.array([p.to_x(v) for p, v in zip(params, values)])
    sd0 = {"body_mass": 0.02, "kp_knee": 0.03, "kd_knee": 0.01, "armature_knee": 2e-4,
           "ground_friction": 0.05}
    stats = {"sd_coordinate": dict(sd0), "sd_coordinate_data": dict(sd0)}
    estimates = [twin_fit.Estimate(p.name, p.unit, v, v,
                                   twin_fit._interval(p, float(xi), sd0[p.name]), None,
                                   twin_fit._interval(p, float(xi), sd0[p.name]))
                 for p, v, xi in zip(params, values, x)]
    v = np.array([1.0, 1.0, 1.0, 1.5e-3, 0.0])
    out, entry = twin_fit._weighed_estimates(estimates, stats, params, x,
                                             {"sd_scale": 0.01, "direction": v}, limit=0.5)
    for k, n in enumerate(names):
        want = math.sqrt(sd0[n] ** 2 + (0.01 * v[k]) ** 2)
        assert stats["sd_coordinate"][n] == pytest.approx(want, rel=1e-9), n
        assert stats["sd_coordinate_data"][n] == pytest.approx(want, rel=1e-9), n
        assert out[k].ci95 == pytest.approx(twin_fit._interval(params[k], float(x[k]), want))
    length = math.sqrt(3.0 + (1.5e-3 / 1e-3) ** 2)     # the inertia's coordinate unit is 1e-3
    assert entry["halfwidth95"] == pytest.approx(1.959964 * 0.01 * length, rel=1e-6)
    assert entry["identified"] and set(entry["combination"]) == set(names[:4])


def test_a_weighing_bounds_the_scale_where_the_jacobian_sees_it_too(monkeypatch):
    """Without the rough part the Jacobian itself finds the common scale (a zero singular
    value); weighed, the scale is bounded by the weighing, so that direction is no longer weak
    and the three parameters on it keep intervals that hold the weighed robot's values."""
    class _Smooth(_ScalePool):
        def map(self, fn, config, stride, horizons, initial="measured"):
            m = math.log(config.body_mass)
            a, b = math.log(config.kp[2]) - m, math.log(config.kd[2]) - m
            return [d[0] * (a - self.A0) + d[1] * (b - self.B0) + 0.01 * e
                    for d, e in zip(self.dirs, self.rough)]

    plain = _case(monkeypatch, ("body_mass", "kp_knee", "kd_knee"), _Smooth)
    assert all(e.ci95 == (None, None) for e in plain.estimates)
    cal = _case(monkeypatch, ("body_mass", "kp_knee", "kd_knee"), _Smooth, weighed_mass=2.9,
                weighed_mass_sd=0.02)
    sym = cal.report["scale_symmetry"]
    assert sym["identified"]
    assert all(abs(twin_fit_overlap(w.combination, sym["combination"])) <= 0.9 for w in cal.weak)
    m = cal.config.body_mass
    truth = {"body_mass": m, "kp_knee": m * 3.0, "kd_knee": m * 0.175}
    for e in cal.estimates:
        assert e.ci95 != (None, None) and e.contains(truth[e.name]), e


def twin_fit_overlap(a, b):
    from littledog_mlsim.robot.twin_fit import _overlap
    return _overlap(a, b)


def test_the_weighing_inside_the_fit_fits_what_lies_off_the_scale(monkeypatch):
    """A parameter off the common scale whose best value depends on where the scale is (here the
    contact's friction, whose optimum moves with the log body mass, as one that makes up for a
    too light robot's slips would): weighed at 2.9 kg (body 2.14 kg, the truth at friction 0.9),
    the fit that holds the weighing as a residual ends at the weighed mass with the friction
    inside its interval around 0.9 (the rough part of the residuals pulls the mass 1 % off the
    weighing); the same fit moved to the weighing only afterwards (``weigh_in_fit=False``,
    the default) leaves the friction where the unweighed masses put it, further off. The report says where the fit started and ended on the scale."""
    from littledog_mlsim.robot.parameters import total_mass

    class _Coupled(_ScalePool):
        def __init__(self, recs) -> None:
            super().__init__(recs)
            rng = np.random.default_rng(12)
            self.fdir = [rng.normal(size=(40, 1, 33)) for _ in recs]

        def map(self, fn, config, stride, horizons, initial="measured"):
            out = super().map(fn, config, stride, horizons, initial)
            f = config.ground_friction - 0.9 - 0.5 * math.log(config.body_mass / 2.14)
            return [o + f * d for o, d in zip(out, self.fdir)]

    params = ("body_mass", "kp_knee", "kd_knee", "ground_friction")
    kw = dict(body_mass=2.0, weighed_mass=2.9, weighed_mass_sd=0.01, max_evals=120)
    inside = _case(monkeypatch, params, _Coupled, weigh_in_fit=True, **kw)
    after = _case(monkeypatch, params, _Coupled, **kw)
    assert total_mass(inside.config) == pytest.approx(2.9, abs=0.05)
    assert inside.config.body_mass == pytest.approx(2.14, rel=0.02)
    friction = {e.name: e for e in inside.estimates}["ground_friction"]
    assert friction.value == pytest.approx(0.9, abs=0.01) and friction.contains(0.9)
    assert abs(after.config.ground_friction - 0.9) > 3 * abs(inside.config.ground_friction - 0.9)
    w = inside.report["weighing_in_fit"]
    assert w["mass_kg_start"] == pytest.approx(2.9, rel=1e-6)
    assert w["mass_kg_end"] == pytest.approx(2.9, abs=0.05)
    assert inside.report["settings"]["weigh_in_fit"] is True
    assert "weighing_in_fit" not in after.report


def test_the_cli_puts_the_weighing_in_the_fit_on_request():
    """``calibrate --weigh-in-fit`` sets ``weigh_in_fit``; without it the weighing comes after
    the fit."""
    from littledog_mlsim.cli import build_parser

    base = ["calibrate", "--data", "D", "--out", "T.json", "--weighed-mass", "2.9"]
    assert build_parser().parse_args(base).weigh_in_fit is False
    assert build_parser().parse_args(base + ["--weigh-in-fit"]).weigh_in_fit is True
