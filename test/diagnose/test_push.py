"""The push in newtons without a twin: drift against a reference, over a robot's push response."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from littledog_mlsim.diagnose.push import (MIN_MOVES, describe, drift_against_reference,
                                           push_mobility, push_reading)
from littledog_mlsim.rotations import rpy_to_quat

STEPS = 400
#: each type's walk in its start frame [m/s]: opposite types walk opposite ways
WALKS = {"F": (0.05, 0.0), "B": (-0.05, 0.0), "L": (0.0, 0.04), "R": (0.0, -0.04)}


@dataclass
class _Rec:
    name: str
    move_type: str
    position: np.ndarray
    orientation: np.ndarray
    cmd: np.ndarray


def _move(kind: str, i: int, yaw0: float, drift_odom=(0.0, 0.0), gait_scale: float = 1.0,
          noise: float = 0.002, rng=None) -> _Rec:
    """A straight move of ``kind`` from heading ``yaw0``: its walk turned into odom (scaled by
    ``gait_scale``, a change in the start frame) plus a drift fixed in odom, with scatter."""
    rng = rng or np.random.default_rng(i)
    c, s = math.cos(yaw0), math.sin(yaw0)
    w = np.array(WALKS[kind]) * gait_scale
    v = np.array([c * w[0] - s * w[1], s * w[0] + c * w[1]]) + np.array(drift_odom)
    v = v + rng.normal(0.0, noise, 2)
    t = np.arange(STEPS + 1)[:, None] * 0.01
    pos = np.hstack([t * v, np.full((STEPS + 1, 1), 0.2)])
    quat = np.tile(rpy_to_quat(np.array([0.0, 0.0, yaw0])), (STEPS + 1, 1))
    return _Rec(f"{kind}_{i:02d}", kind, pos, quat, np.zeros((STEPS, 12)))


def _set(n_per_type: int, seed: int, yaws=(0.0,), **kw) -> list[_Rec]:
    rng = np.random.default_rng(seed)
    return [_move(k, i, yaws[i % len(yaws)], rng=rng, **kw)
            for k in WALKS for i in range(n_per_type)]


@pytest.mark.parametrize("yaws", [(0.0,), (0.0, 1.2, -2.5)])
def test_drift_against_the_reference_is_the_odom_fixed_part(yaws):
    ref = _set(6, 1, yaws)
    data = _set(6, 2, yaws, drift_odom=(-0.012, 0.008))
    d = drift_against_reference(data, ref)
    assert d is not None and d.n_moves == 24 and d.n_skipped == 0
    np.testing.assert_allclose(d.velocity_xy, [-0.012, 0.008], atol=0.0025)
    assert np.all(np.sqrt(np.diag(d.cov)) < 0.002)


def test_a_change_in_the_start_frame_cancels_between_opposite_types():
    """A slower gait (every type 20 % shorter) is no drift in odom."""
    d = drift_against_reference(_set(6, 2, gait_scale=0.8), _set(6, 1))
    np.testing.assert_allclose(d.velocity_xy, [0.0, 0.0], atol=0.0025)


def test_no_drift_without_enough_moves_of_the_reference_types():
    ref = [r for r in _set(6, 1) if r.move_type in ("F", "B")]
    data = _set(1, 2)                          # 4 moves, of which 2 have a reference type
    assert drift_against_reference(data, ref) is None
    assert drift_against_reference(_set(MIN_MOVES, 2), ref).n_skipped == 2 * MIN_MOVES


class _FakeRobot:
    """Drifts M f per second under a push f, on top of a walk of its own."""

    def __init__(self, M):
        self.M = np.asarray(M, dtype=float)
        self.calls = 0

    def displacement(self, rec, force_xy):
        self.calls += 1
        walk = np.array([0.1, -0.03])
        f = np.zeros(2) if force_xy is None else np.asarray(force_xy, float)
        return walk + self.M @ f * STEPS * 0.01


def test_push_mobility_and_the_force_it_reads():
    M = [[0.025, 0.002], [0.001, 0.012]]
    robot = _FakeRobot(M)
    recs = _set(3, 0)
    got, n = push_mobility(recs, robot, per_type=2)
    assert n == 8 and robot.calls == 24
    np.testing.assert_allclose(got, M, rtol=1e-9)
    F_true = np.array([-0.6, -1.1])
    d = drift_against_reference(_set(6, 2, drift_odom=tuple(np.array(M) @ F_true)), _set(6, 1))
    r = push_reading(d, got)
    assert r["force_N"] == pytest.approx(float(np.hypot(*F_true)), rel=0.25)
    assert r["force_interval_N"][0] < r["force_N"] < r["force_interval_N"][1]
    assert r["direction_deg"] == pytest.approx(math.degrees(math.atan2(-1.1, -0.6)) % 360, abs=15)
    assert d.p_value < 1e-6 and "not significant" not in describe(r, d, "fake")
    none = drift_against_reference(_set(6, 2), _set(6, 1))
    assert none.p_value > 0.001
    text = describe(push_reading(none, got), none, "fake")
    assert text.startswith("a steady force fixed in odom of about")
    assert ("not significant" in text) == (none.p_value > 0.05)


def test_no_reading_from_a_robot_that_does_not_drift():
    d = drift_against_reference(_set(6, 2, drift_odom=(0.01, 0.0)), _set(6, 1))
    assert push_reading(d, np.zeros((2, 2))) is None
    assert push_reading(d, [[0.02, 0.0], [0.0, 1e-9]]) is None


def test_a_heading_near_alpha_in_an_earlier_round_is_tested_by_the_drift():
    """Decision 066: where no heading is in the last round's ``suspected`` list but a round
    probed one with p within 10 times alpha (a later, shared finding took it up), the drift
    against the reference is the second test all the same; a heading probe further from
    alpha, or another family near it, tests nothing."""
    from littledog_mlsim.diagnose.learned import NO_TOTAL_GAIN, LearnedOptions, drift_change
    opts = LearnedOptions(push_robot=None)
    ref = _set(6, 1, yaws=(0.0, 1.2, -2.5))
    drifting = _set(6, 2, yaws=(0.0, 1.2, -2.5), drift_odom=(-0.008, -0.008))
    quiet = lambda s: None  # noqa: E731

    def report(p, family="pose (heading)"):
        probe = {"label": "heading()", "family": family, "p_value": p, "significant": False}
        return {"effects": [], "reference": {"shared": []}, "suspected": [],
                "rounds": [{"round": 0, "probes": [probe]}, {"round": 1, "probes": []}]}
    got = drift_change(report(6.7e-4), drifting, ref, opts, 2.5, quiet)
    assert got["tested"] and got["named"] and got["suspected"] == "heading()", got
    assert "in round 0 within 10 times alpha" in got["statement"]
    for far in (report(2e-3), report(1e-6, family="elapsed time")):
        r = drift_change(far, drifting, ref, opts, 2.5, quiet)
        assert not r["tested"] and r["why"] == "no heading effect suspected"
    # the model already holds position columns (a slope the one-step loop accepted): no test
    held = {**report(6.7e-4), "feature_set": {"augmentations": [
        {"name": "planar_position", "family": "pose (position)", "params": {}}]}}
    r = drift_change(held, drifting, ref, opts, 2.5, quiet)
    assert not r["tested"] and not r["named"] and "planar_position()" in r["statement"]
    # scoped probes are not read; decision 037's suspect comes first
    scoped = report(0.5)
    scoped["rounds"][0]["scoped"] = [{"label": "heading()", "family": "pose (heading)",
                                      "p_value": 1e-6}]
    assert not drift_change(scoped, drifting, ref, opts, 2.5, quiet)["tested"]
    both = {**report(6.7e-4), "suspected": [{"label": "heading()", "why": NO_TOTAL_GAIN,
                                             "vocabulary": {"family": "odom_force"}}]}
    got = drift_change(both, drifting, ref, opts, 2.5, quiet)
    assert got["named"] and "raising the total held-out rollout error" in got["statement"]


def test_a_suspected_heading_is_named_a_push_where_the_drift_confirms_it():
    """Decision 037: where the search suspects a heading effect (significant and material,
    raising the total rollout error) and accepted none, the drift against the reference is
    the second test at ``scope_alpha``; a drifting recording names ``odom_force @ body``
    toward the drift, a clean one does not, and nothing is tested without the suspicion or
    where a heading effect was accepted."""
    from littledog_mlsim.diagnose.learned import NO_TOTAL_GAIN, LearnedOptions, drift_change
    opts = LearnedOptions(push_robot=None)          # no physics robot: no size in newtons
    suspect = {"label": "heading()", "why": NO_TOTAL_GAIN,
               "vocabulary": {"family": "odom_force", "scope": "body"}}
    report = {"effects": [], "reference": {"shared": []}, "suspected": [suspect]}
    ref = _set(6, 1, yaws=(0.0, 1.2, -2.5))
    drifting = _set(6, 2, yaws=(0.0, 1.2, -2.5), drift_odom=(-0.008, -0.008))
    quiet = lambda s: None  # noqa: E731
    got = drift_change(report, drifting, ref, opts, 2.5, quiet)
    assert got["tested"] and got["named"], got
    assert got["drift"]["p_value"] < opts.scope_alpha == got["alpha"]
    v = got["vocabulary"]
    assert (v["family"], v["scope"]) == ("odom_force", "body")
    assert abs((v["params"]["direction_deg"] - 225.0 + 180.0) % 360.0 - 180.0) < 15.0
    assert v["params"]["force_N"] is None and "push_robot is off" in got["statement"]
    clean = drift_change(report, _set(6, 3, yaws=(0.0, 1.2, -2.5)), ref, opts, 2.5, quiet)
    assert clean["tested"] and not clean["named"] and "not significant" in clean["statement"]
    # no suspicion, or a suspicion of another kind: nothing tested
    for other in ([], [{**suspect, "why": "significant but below the materiality minimum"}],
                  [{**suspect, "vocabulary": {"family": "time_drift", "scope": "all"}}]):
        r = drift_change({**report, "suspected": other}, drifting, ref, opts, 2.5, quiet)
        assert not r["tested"] and not r["named"] and r["why"] == "no heading effect suspected"
    # a heading effect the search accepted (or found shared with the reference): not tested
    for where in ("effects", "shared"):
        acc = {"label": "heading()", "vocabulary": {"family": "odom_force", "scope": "body"}}
        r = dict(report, effects=[acc] if where == "effects" else [],
                 reference={"shared": [acc] if where == "shared" else []})
        got = drift_change(r, drifting, ref, opts, 2.5, quiet)
        assert not got["tested"] and not got["named"], got
