"""``calibrate --split-starts F`` (module doc 14 of littledog_mlsim.robot.twin_fit): second
starts across the masses' split, the lowest minimum kept, intervals over the minima the data do
not tell apart.

Independent reference: a stand-in re-simulating pool whose residual has two minima along the
leg mass by construction, at the start's legs and at 0.8 times them, with a known depth
difference.
"""
from __future__ import annotations

import contextlib
import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.parameters import TWIN_PARAMETERS, total_mass

LEGS0, BODY0 = 0.2, 2.0          # the start
LEGS_B = 0.8 * LEGS0             # the other minimum
BODY_TRUE = 2.16                 # where the body's residual is zero


class _TwoBasinPool:
    """Residual per move (40 states, 1 horizon, 33 elements): a direction times u (u - b), u the
    log leg mass over ``LEGS0`` and b = log 0.8 (zero at both), one times the log body mass off
    ``BODY_TRUE``, ``depth`` times (u - b) along a third (so the minimum at b is the deeper one
    by that much), and a little noise. A robot whose leg mass is ``fail_legs`` raises."""

    def __init__(self, recs, depth: float, fail_legs: float | None = None) -> None:
        rng = np.random.default_rng(11)
        n = len(recs)
        self.d = [rng.normal(size=(3, 40, 1, 33)) for _ in range(n)]
        self.noise = [1e-3 * rng.normal(size=(40, 1, 33)) for _ in range(n)]
        self.depth, self.fail_legs = depth, fail_legs

    def map(self, fn, config, stride, horizons, initial="measured"):
        legs = TWIN_PARAMETERS["leg_mass"].get(config)
        if self.fail_legs is not None and abs(legs - self.fail_legs) < 1e-9:
            raise RuntimeError("this robot does not simulate")
        u, b = math.log(legs / LEGS0), math.log(0.8)
        v = math.log(TWIN_PARAMETERS["body_mass"].get(config) / BODY_TRUE)
        return [d[0] * 40.0 * u * (u - b) + d[1] * v + d[2] * self.depth * (u - b) + e
                for d, e in zip(self.d, self.noise)]


def _case(monkeypatch, depth: float, fail_legs: float | None = None):
    from littledog_mlsim.robot import twin_fit

    monkeypatch.setattr(twin_fit._bl, "move_pool", lambda recs, jobs=2, scheduler=None:
                        contextlib.nullcontext(_TwoBasinPool(recs, depth, fail_legs)))
    recs = [SimpleNamespace(name=f"F_0{i}", n_steps=400, position=np.zeros((400, 3)))
            for i in range(4)]
    opts = twin_fit.CalibrationOptions(params=("body_mass", "leg_mass"), horizons=(1,),
                                       initial_state="measured", test_missing=False)
    base = dataclasses.replace(robot_config("nominal"), body_mass=BODY0, leg_mass=LEGS0)
    return recs, base, opts


def test_a_split_start_keeps_the_total_and_stays_inside_the_bounds():
    from littledog_mlsim.robot.twin_fit import split_start

    base = dataclasses.replace(robot_config("nominal"), body_mass=BODY0, leg_mass=LEGS0)
    lighter = split_start(base, 0.85)
    assert lighter.leg_mass == pytest.approx(0.17)
    assert lighter.body_mass == pytest.approx(BODY0 + 4 * 0.03)
    assert total_mass(lighter) == pytest.approx(total_mass(base))
    # a body at its upper bound cannot take the legs' mass: the legs give up only what it takes
    full = dataclasses.replace(base, body_mass=4.45)
    moved = split_start(full, 0.5)
    assert moved.body_mass == pytest.approx(4.5) and moved.leg_mass == pytest.approx(0.1875)
    assert total_mass(moved) == pytest.approx(total_mass(full))


def test_the_second_start_finds_the_deeper_minimum_and_the_data_tell_it(monkeypatch):
    """The plain fit from the start stays in the start's basin (legs within 3 % of 0.2 kg); with
    split starts the legs x0.85 start falls into the other basin (0.16 kg), whose k-step cost is
    lower, and it is kept; the legs x1.15 start returns to the first. The per-move cost
    differences tell the minima apart, so no interval is widened; the report and the printout
    say what was done."""
    from littledog_mlsim.cli import format_calibration
    from littledog_mlsim.robot import twin_fit

    recs, base, opts = _case(monkeypatch, depth=0.5)
    plain = twin_fit.calibrate_twin(recs, [], base, opts)
    assert plain.config.leg_mass == pytest.approx(LEGS0, rel=0.03)
    said = []
    cal = twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(opts, split_starts=0.15),
                                  said.append)
    assert cal.config.leg_mass == pytest.approx(LEGS_B, rel=1e-3)
    assert cal.config.body_mass == pytest.approx(BODY_TRUE, rel=1e-3)
    split = cal.report["split_starts"]
    assert split["chosen"] == "legs x0.85" and split["tied"] == []
    starts = {c["start"]: c for c in split["candidates"]}
    assert set(starts) == {"fit", "legs x0.85", "legs x1.15"}
    assert starts["legs x0.85"]["from"]["leg_mass"] == pytest.approx(0.85 * plain.config.leg_mass)
    assert starts["legs x1.15"]["params"][1]["value"] == pytest.approx(plain.config.leg_mass,
                                                                         rel=1e-3)
    assert starts["legs x0.85"]["k_step_cost"] < starts["fit"]["k_step_cost"]
    assert starts["fit"]["compared"]["told_apart"] and starts["fit"]["compared"]["z"] > 1.96
    assert starts["legs x0.85"]["compared"] is None
    # the public comparison gives what the calibration recorded
    again = twin_fit.minima_compared(recs, cal.config, plain.config, opts)
    assert again["z"] == pytest.approx(starts["fit"]["compared"]["z"], rel=0.05)
    assert again["told_apart"]
    assert cal.report["n_evals_total"] == sum(c["n_evals"] for c in split["candidates"])
    assert cal.report["settings"]["split_starts"] == 0.15
    legs = next(e for e in cal.estimates if e.name == "leg_mass")
    assert not legs.contains(LEGS0)
    assert any("kept legs x0.85" in s for s in said)
    text = format_calibration(cal.report)
    assert "kept the legs x0.85 start's minimum" in text and "the data tell it from the others" in text


def test_minima_the_data_do_not_tell_apart_widen_the_intervals_over_both(monkeypatch):
    """Two minima of the same depth: whichever is kept, the other is tied (every per-move cost
    difference is zero), and the leg mass's interval, which at one minimum holds only that one,
    covers both; a failing start is reported and left out; a fit without both masses is left
    alone and says so."""
    from littledog_mlsim.cli import format_calibration
    from littledog_mlsim.robot import twin_fit

    recs, base, opts = _case(monkeypatch, depth=0.0)
    plain = twin_fit.calibrate_twin(recs, [], base, opts)
    assert not next(e for e in plain.estimates if e.name == "leg_mass").contains(LEGS_B)
    said = []
    cal = twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(opts, split_starts=0.15),
                                  said.append)
    split = cal.report["split_starts"]
    assert len(split["tied"]) == 2 and "leg_mass" in split["widened"]
    assert any("the intervals cover all" in s for s in said)
    legs = next(e for e in cal.estimates if e.name == "leg_mass")
    assert legs.contains(LEGS0) and legs.contains(LEGS_B)
    assert "do not tell it from" in format_calibration(cal.report)

    # the legs x1.15 start (from the plain fit's legs, about 0.23 kg) does not simulate
    recs, base, opts = _case(monkeypatch, depth=0.5)
    first = twin_fit.calibrate_twin(recs, [], base, opts).config.leg_mass
    recs, base, opts = _case(monkeypatch, depth=0.5, fail_legs=1.15 * first)
    cal = twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(opts, split_starts=0.15))
    starts = {c["start"]: c for c in cal.report["split_starts"]["candidates"]}
    assert "this robot does not simulate" in starts["legs x1.15"]["error"]
    assert cal.report["split_starts"]["chosen"] == "legs x0.85"
    assert "legs x1.15 failed" in format_calibration(cal.report)

    body_only = twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(
        opts, params=("body_mass",), split_starts=0.15))
    assert "not both fitted" in body_only.report["split_starts"]["skipped"]
    assert "no second starts" in format_calibration(body_only.report)
    with pytest.raises(ValueError, match="split_starts"):
        dataclasses.replace(opts, split_starts=0.8).check()


def test_split_starts_run_once_before_the_bootstrap(monkeypatch):
    """With a bootstrap the second starts run once, on the fit, not inside its refits; the
    bootstrap then corrects the kept minimum (a stand-in whose own recordings are the
    recording: no bias), and a tie's intervals are applied after its correction."""
    from littledog_mlsim.robot import twin_bias, twin_fit

    recs, base, opts = _case(monkeypatch, depth=0.0)
    monkeypatch.setattr(twin_bias, "synthetic_recordings", lambda recs, config, replicate=0: recs)
    monkeypatch.setattr(twin_bias, "recording_sensing", lambda recs: {
        "sensor_noise": False, "mocap_position_std": 0.0, "mocap_orientation_std": 0.0,
        "encoder_resolution": None})
    calls = []
    real = twin_fit._split_started
    monkeypatch.setattr(twin_fit, "_split_started",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    cal = twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(
        opts, split_starts=0.15, bootstrap=1))
    assert len(calls) == 1
    assert cal.report["bootstrap"]["iterations"] == 1
    assert len(cal.report["split_starts"]["tied"]) == 2
    legs = next(e for e in cal.estimates if e.name == "leg_mass")
    assert legs.contains(LEGS0) and legs.contains(LEGS_B)


def test_the_second_starts_and_the_refits_fit_one_stage_with_their_fits_weights(monkeypatch):
    """A second start is one weighted stage with the weights of the fit it starts from at
    that fit's optimum (its residual RMS there); a bootstrap refit is one stage weighted at its
    start, the twin; the fit itself keeps its two stages."""
    from littledog_mlsim.robot import twin_fit

    recs, base, opts = _case(monkeypatch, depth=0.5)
    _with_bootstrap_standins(monkeypatch)
    seen = []
    real = twin_fit._fit

    def spy(prob, x0, weights=None):
        x, stages = real(prob, x0, weights)
        seen.append((weights, prob.scale.copy(), stages, prob.raw(x)))
        return x, stages

    monkeypatch.setattr(twin_fit, "_fit", spy)
    cal = twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(
        opts, split_starts=0.15, bootstrap=1))
    assert all("error" not in c for c in cal.report["split_starts"]["candidates"])
    kinds = [w if w is None or w == "start" else "table" for w, *_ in seen]
    assert kinds == [None, "table", "table", "start"]
    assert "cost_start_stage2" in seen[0][2] and "weights" not in seen[0][2]
    assert [s[2]["weights"] for s in seen[1:]] == ["given", "given", "start"]
    assert all(s[2]["cost_start_stage2"] is None for s in seen[1:])
    assert all(s[2]["cost_end_stage1"] == s[2]["cost_end"] for s in seen[1:])
    # the starts' weights: the fit's residual RMS at its optimum, per (horizon, element)
    np.testing.assert_allclose(seen[1][1], twin_fit._rms_scale(seen[0][3]), rtol=1e-12)
    np.testing.assert_array_equal(seen[1][1], seen[2][1])
    # weights apply to one fit; a calibration of several refuses them in one line
    for extra in ({"add_asked": 1, "test_missing": True}, {"bootstrap": 1},
                  {"split_starts": 0.15}, {"servo": "auto"}):
        with pytest.raises(ValueError, match="weights apply to one fit"):
            twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(opts, **extra),
                                    weights="start")


def _with_bootstrap_standins(monkeypatch, fail: bool = False):
    from littledog_mlsim.robot import twin_bias

    def synthetic(recs, config, replicate=0):
        if fail:
            raise RuntimeError("no synthetic recording")
        return recs

    monkeypatch.setattr(twin_bias, "synthetic_recordings", synthetic)
    monkeypatch.setattr(twin_bias, "recording_sensing", lambda recs: {
        "sensor_noise": False, "mocap_position_std": 0.0, "mocap_orientation_std": 0.0,
        "encoder_resolution": None})


def test_the_kept_start_is_the_one_bootstrapped_and_a_tie_stays_widened(monkeypatch):
    """With added rounds and a bootstrap, the deeper minimum found by a second start is the
    twin the bootstrap corrects (on the stand-in its own recordings are the recording: no
    bias), and the report keeps the rounds' entries and settings. With a tie and a bootstrap
    that fails, the intervals hulled before it stay hulled and ``widened`` still names them.
    Bad steps are refused with a one-line error naming the option."""
    from littledog_mlsim.robot import twin_fit

    recs, base, opts = _case(monkeypatch, depth=0.5)
    _with_bootstrap_standins(monkeypatch)
    cal = twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(
        opts, split_starts=0.15, bootstrap=1, add_asked=1, test_missing=True))
    assert cal.report["split_starts"]["chosen"] == "legs x0.85"
    assert cal.config.leg_mass == pytest.approx(LEGS_B, rel=1e-3)
    assert cal.report["bootstrap"]["iterations"] == 1
    assert cal.report["added"] == [] and cal.report["settings"]["add_asked"] == 1
    assert cal.report["settings"]["split_starts"] == 0.15

    recs, base, opts = _case(monkeypatch, depth=0.0)
    _with_bootstrap_standins(monkeypatch, fail=True)
    cal = twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(
        opts, split_starts=0.15, bootstrap=1))
    assert "no synthetic recording" in cal.report["bootstrap"]["error"]
    assert "leg_mass" in cal.report["split_starts"]["widened"]
    legs = next(e for e in cal.estimates if e.name == "leg_mass")
    assert legs.contains(LEGS0) and legs.contains(LEGS_B)
    for bad in (-0.1, math.nan, math.inf):
        with pytest.raises(ValueError, match="split_starts"):
            dataclasses.replace(opts, split_starts=bad).check()


def test_a_kept_start_its_budget_stopped_is_continued_and_compared_again(monkeypatch):
    """Every start stopped by a budget of a few evaluations: the bootstrap continues the kept
    one (decision 058) and the other minima are compared again with where it ended."""
    from littledog_mlsim.robot import twin_fit

    recs, base, opts = _case(monkeypatch, depth=0.5)
    _with_bootstrap_standins(monkeypatch)
    monkeypatch.setattr(twin_fit, "ROUND_EVALS_PER_COLUMN", 1)
    cal = twin_fit.calibrate_twin(recs, [], base, dataclasses.replace(
        opts, split_starts=0.15, bootstrap=1, max_evals=6))
    split = cal.report["split_starts"]
    chosen = next(c for c in split["candidates"] if c["start"] == split["chosen"])
    assert chosen["converged"] is False
    assert cal.report["continued"]["n_evals"] > 0
    assert split["compared_after"] == "continued"
    for c in split["candidates"]:
        if c["start"] != split["chosen"]:
            assert c["compared"]["moves"] == len(recs) and "z" in c["compared"]


def test_the_evaluations_so_far_count_both_structures_where_no_round_counted_them():
    """A calibration's count before its split starts or continuation: the rounds' total where
    there is one, else both servo structures' fits (the screened-out one's screen), else the
    fit's own."""
    from littledog_mlsim.robot.twin_fit import _evals_so_far

    structure = {"candidates": [{"servo": "pd_torque", "n_evals": 136},
                                {"servo": "position", "n_evals": 40, "screened": True}]}
    assert _evals_so_far({"n_evals": 136, "structure": structure}) == 176
    assert _evals_so_far({"n_evals": 188, "n_evals_total": 595, "structure": structure}) == 595
    assert _evals_so_far({"n_evals": 31}) == 31


def test_a_continued_fit_names_only_the_intervals_its_own_hull_widens(monkeypatch):
    """The continued fit's intervals are its own: where the minima tied before the
    continuation are told apart after it, no interval is hulled and none is named widened
    (zoo53 run3: `widened` had kept the 15 hulled before, and the printout said both)."""
    from littledog_mlsim.robot import twin_fit
    from littledog_mlsim.robot.twin_fit import Calibration, Estimate

    est = [Estimate("body_mass", "kg", 2.0, 2.1, (2.0, 2.2), None),
           Estimate("leg_mass", "kg", 0.2, 0.21, (0.2, 0.22), None)]
    other = {"start": "legs x0.85", "params": [
        {"name": "body_mass", "value": 2.3, "ci95": [2.25, 2.35]},
        {"name": "leg_mass", "value": 0.18, "ci95": [0.17, 0.19]}]}
    split = {"chosen": "fit", "tied": ["legs x0.85"], "widened": ["body_mass", "leg_mass"],
             "candidates": [{"start": "fit", "params": []}, other]}
    cal = Calibration(robot_config("nominal"), est, [], {"split_starts": split})
    for told_apart, widened in ((True, []), (False, ["body_mass", "leg_mass"])):
        monkeypatch.setattr(twin_fit, "_compare_minima",
                            lambda *a, t=told_apart, **k: [] if t else ["legs x0.85"])
        out = twin_fit._hull_over_tied(twin_fit._split_recompared(cal, [], None))
        assert out.report["split_starts"]["widened"] == widened
        assert out.report["split_starts"]["compared_after"] == "continued"
        body = next(e for e in out.estimates if e.name == "body_mass")
        assert body.ci95 == ((2.0, 2.2) if told_apart else (2.0, 2.35))
