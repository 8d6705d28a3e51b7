"""Conformance of every registered effect family (``littledog_mlsim.diagnose.families``).

Each family is checked through its public contract only: its declared range holds its neutral
value and its screening probes, its plug-ins build and carry the parameter they were given, its
physical reading and its sentence state the magnitude in its unit and name where it acts, its
learned-model feature (if any) survives a model file, its start-state adjustment touches only
its scope, and its rivals and twin are registered families. A new family passes these checks
or names what it does differently.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from littledog_mlsim.diagnose.families import (FAMILIES, KINDS, Family, Separation,
                                               register_family, scope_joints, scope_words)
from littledog_mlsim.models.features import Augmentation, augmentation_from_dict
from littledog_mlsim.robot.effects import HOOKS

NAMES = list(FAMILIES)
# how a sentence states a magnitude of each unit
UNIT_WORDS = {"1": ("%", "times"), "1/s": ("per second",)}


@dataclass
class _Fit:
    """A fitted hypothesis as the search hands it to a family."""

    family: str
    scope: str
    magnitude: float
    fitted: float | None
    direction: np.ndarray | None
    extra: dict

    def params(self, mag: float | None = None) -> dict:
        spec = FAMILIES[self.family]
        return {**spec.params_from(self.fitted if mag is None else mag, self.direction),
                **self.extra}


def _probe_value(spec: Family) -> float:
    return spec.neutral + spec.probe


def _fit(spec: Family, scope: str, m: float) -> _Fit:
    direction = np.array([0.6, 0.8]) if len(spec.components) > 1 else None
    extra = {}
    if spec.screen_style == "each":   # a probe's fixed parameters (a mass's position)
        extra = {k: v for k, v in spec.screen_probes()[1].params.items()
                 if k not in spec.params_from(1.0, direction)}
    return _Fit(spec.name, scope, m, m, direction, extra)


def _numbers(effect) -> list[float]:
    out = []
    for k, v in vars(effect).items():
        if k.startswith("_"):
            continue
        try:
            out += [float(x) for x in np.ravel(np.asarray(v, dtype=float))]
        except (TypeError, ValueError):
            pass
    return out


@pytest.mark.parametrize("name", NAMES)
def test_declared_range_probe_and_kind(name):
    spec = FAMILIES[name]
    assert spec.name == name and spec.kind in KINDS
    lo, hi = spec.bounds
    assert lo < hi and spec.probe != 0.0 and spec.unit and spec.primary
    # neutral lies in the range; a family whose zero is not physical (no payload at all) may
    # start just above it, within 5 % of a probe
    assert lo <= spec.neutral <= hi or 0 < lo - spec.neutral <= 0.05 * abs(spec.probe)
    assert lo <= _probe_value(spec) <= hi
    if spec.deep_probe is not None:
        assert spec.kind == "joints" and lo <= spec.neutral + spec.deep_probe <= hi
        assert abs(spec.deep_probe) > abs(spec.probe)
    assert spec.vocabulary and (not spec.reported_as or spec.reported_as != name)


@pytest.mark.parametrize("name", NAMES)
def test_plug_ins_build_and_carry_the_parameter(name):
    spec = FAMILIES[name]
    scopes = spec.scopes()
    assert scopes and len(set(scopes)) == len(scopes)
    for scope in (scopes[0], scopes[-1]):
        if spec.kind != "body":
            assert len(scope_joints(scope)) >= 1
        fit = _fit(spec, scope, _probe_value(spec))
        params = {**fit.params(), "t0_s": 0.0, "origin_xy": (0.0, 0.0)}
        effects = spec.build_effects(scope, params)
        assert effects, (name, scope)
        for e in effects:
            assert any(callable(getattr(e, h, None)) for h in HOOKS), type(e)
        # the value handed in is the plug-in's own (a component, or the vector's length)
        want = ([abs(v) for k, v in params.items() if k in spec.components and v]
                if len(spec.components) > 1 else [_probe_value(spec)])
        have = [abs(x) for e in effects for x in _numbers(e)]
        assert all(any(math.isclose(w, h, rel_tol=1e-9) for h in have) for w in want) or \
            any(math.isclose(math.hypot(*want), h, rel_tol=1e-9) for h in have), (name, have)


@pytest.mark.parametrize("name", NAMES)
def test_reading_and_sentence_state_the_magnitude_in_its_unit(name):
    spec = FAMILIES[name]
    for scope in (spec.scopes()[0], spec.scopes()[-1]):
        m = _probe_value(spec)
        pp = spec.physical_params(_fit(spec, scope, m), 0.8)
        assert spec.primary in pp and pp[spec.primary] == pytest.approx(m)
        text = spec.statement(scope_words(scope), pp)
        assert any(w in text for w in UNIT_WORDS.get(spec.unit, (spec.unit,))), text
        assert text[0].isupper() and f"{name} on" not in text   # its own words, not the fallback
        if spec.kind != "body":
            assert scope_words(scope).lower() in text.lower(), text


@pytest.mark.parametrize("name", NAMES)
def test_learned_feature_maps_or_says_none(name):
    spec = FAMILIES[name]
    for scope in spec.scopes()[:2]:
        fit = _fit(spec, scope, spec.bounds[1])
        aug = spec.augmentation(scope, {**spec.physical_params(fit, 0.8), **fit.params()})
        if aug is None:
            continue
        assert isinstance(aug, Augmentation) and len(aug.columns()) >= 1
        assert augmentation_from_dict(aug.to_dict()) == aug


@pytest.mark.parametrize("name", NAMES)
def test_start_state_changes_only_its_scope(name):
    spec = FAMILIES[name]
    q = np.linspace(-0.5, 0.5, 12)
    for scope in spec.scopes():
        params = _fit(spec, scope, _probe_value(spec)).params()
        for start in (spec.start_q, spec.start_dq):
            out = start(q, scope, params)
            assert out.shape == q.shape and np.array_equal(q, np.linspace(-0.5, 0.5, 12))
            if out is q:
                continue
            changed = np.flatnonzero(out != q)
            assert spec.kind == "joints" and set(changed) <= set(scope_joints(scope)), (name, scope)


def test_a_start_state_undoes_the_readings_in_the_reverse_order():
    """true_start inverts the hypotheses' readings: an encoder offset then a scale on the same
    joints read m = s (q + o), so the true angle is m / s - o, and the true rate (and the rate
    filter's state) m_dq / s."""
    from littledog_mlsim.diagnose.physical import true_start
    from littledog_mlsim.robot.sim import InitialState
    q, dq = np.linspace(-0.5, 0.5, 12), np.linspace(1.0, 2.0, 12)
    s, o = 0.9, 0.05
    measured = InitialState(np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), s * (q + o), s * dq,
                            np.zeros(3), np.zeros(3), reported_dq=s * dq)
    hyps = [("encoder_offset", "all", {"offset_rad": o}), ("encoder_scale", "all", {"scale": s})]
    start = true_start(measured, hyps)
    assert np.allclose(start.q, q) and np.allclose(start.dq, dq)
    assert np.allclose(start.reported_dq, dq)
    assert true_start(measured, []) is measured


@pytest.mark.parametrize("name", NAMES)
def test_screen_probes_rivals_and_twin(name):
    spec = FAMILIES[name]
    probes = spec.screen_probes()
    assert probes and len({p.key for p in probes}) == len(probes)
    for p in probes:
        assert p.scope in spec.scopes() or (spec.kind == "joints" and p.scope.startswith("joint:"))
        assert spec.build_effects(p.scope, {**p.params, "t0_s": 0.0, "origin_xy": (0.0, 0.0)})
    if spec.screen_style == "each":
        for k in range(len(probes)):
            mag, direction, extra = spec.probe_candidate(k, 1.0)
            assert mag >= 0 and isinstance(extra, dict)
    for other in FAMILIES.values():
        sep = spec.separation(other)
        assert sep is None or (isinstance(sep, Separation) and sep.how and sep.recording)
    if spec.twin_family:
        twin = FAMILIES[spec.twin_family]
        assert twin.twin_family == name and twin.kind == spec.kind
        m, weight = 0.5 * (spec.probe + spec.bounds[1]) / 2, 25.0
        assert twin.twin_magnitude(spec.twin_magnitude(m, weight), weight) == pytest.approx(m)


def test_registry_refuses_a_second_class_under_a_taken_name():
    class Imposter(Family):
        name = "command_delay"
        kind = "joints"

    with pytest.raises(ValueError, match="already registered"):
        register_family(Imposter)

    class NoKind(Family):
        name = "nowhere"
        kind = "tail"

    with pytest.raises(ValueError, match="kind"):
        register_family(NoKind)
    assert "nowhere" not in FAMILIES


def test_the_reference_lists_every_registered_family():
    """docs/families.md's table names every registered family with its kind and parameter."""
    from pathlib import Path
    text = (Path(__file__).resolve().parents[2] / "docs" / "families.md").read_text()
    for f in FAMILIES.values():
        assert f"| `{f.name}` | {f.kind} | `{f.primary}` [{f.unit}] |" in text, f.name


def test_torque_saturation_reads_the_measured_robots_servo():
    """The torque family's normal limits and its learned feature's scale are the measured
    robot's knee servo (robot/config.py): 1.7 / 1.7 / 0.61 N m, and 0.61 N m / 6.7 N m/rad."""
    from littledog_mlsim.robot.config import robot_config
    spec = FAMILIES["torque_saturation"]
    fit = _Fit(spec.name, "all", 0.5, 0.5, None, {})
    params = {**spec.physical_params(fit, 0.8), **fit.params()}
    assert params["torque_limit_Nm_by_joint_type"] == {
        "hip_pitch": 0.5 * 1.7, "hip_roll": 0.5 * 1.7, "knee": 0.5 * 0.61}
    assert params["torque_limit_Nm"] == 0.5 * 0.61
    assert robot_config("measured").torque_limit == (1.7, 1.7, 0.61)
    assert spec.augmentation("all", params).limit == round(0.5 * 0.61 / 6.7, 4)


# ------------------------------------------------------------------ the learned feature families

def test_every_learned_family_reads_as_a_registered_vocabulary_family():
    """Each registered learned family's features are registered augmentations of that family,
    and it reads as a registered physical family's vocabulary name (or a phase force's), or as
    ``other`` where it reads as none (registered for another attribute, e.g. lagged state's
    ``excitation_shows``)."""
    from littledog_mlsim.diagnose.families import LEARNED_FAMILIES
    from littledog_mlsim.models.feature_base import AUGMENTATIONS
    vocab = {f.vocabulary for f in FAMILIES.values()}
    assert LEARNED_FAMILIES
    for name, lf in LEARNED_FAMILIES.items():
        assert lf.name == name
        for cls in lf.features:
            assert AUGMENTATIONS[cls.name] is cls and cls.family == name
        assert lf.vocabulary in vocab or (lf.reads_as is None and lf.vocabulary == "other"), name


def test_learned_features_read_in_the_vocabulary():
    """report.json's ``physical`` block of a learned feature: family, scope and parameter as
    docs/diagnosis.md's table states them."""
    from littledog_mlsim.diagnose.report import learned_physical
    from littledog_mlsim.models import feature_library as fl
    cases = [
        (fl.CommandLag(lag=2, joints="knees"), "command_delay", "type:knees", {"delay_ms": 20.0}),
        (fl.CommandIncrement(lag=0, joints="front_left"), "command_delay", "leg:front_left",
         {"delay_ms": None}),
        (fl.CommandFilter(time_constant_ms=40.0, joints="left"), "command_filter", "side:left",
         {"time_constant_ms": 40.0}),
        (fl.JointRateSign(joints="back_right_knee"), "joint_friction", "joint:back_right_knee",
         {"coulomb_Nm": None}),
        (fl.Play(width=0.05, source="u"), "backlash", "all", {"width_rad": 0.05}),
        (fl.Play(width=0.06, source="u", joints="front_left_hip_pitch"), "backlash",
         "joint:front_left_hip_pitch", {"width_rad": 0.06}),
        (fl.TrackingSaturation(limit=0.05), "torque_saturation", "all",
         {"torque_limit_Nm": None}),
        (fl.Heading(), "odom_force", "body", {"force_N": None}),
        (fl.ElapsedTime(), "time_drift", "all", {"rate_per_s": None}),
        (fl.GaitPhase(), "contact_phase", "body", {"magnitude": None}),
        (fl.StateLag(lag=1, group="q"), "other", "body", {"value": None}),
    ]
    for aug, family, scope, params in cases:
        got = learned_physical(aug)
        assert (got["family"], got["scope"], got["params"]) == (family, scope, params), aug
        assert aug.label() in got["statement"]


def test_a_delay_member_is_the_largest_lag_near_the_best_other_members_the_fewest_columns():
    from littledog_mlsim.diagnose.selection import estimate_member
    from littledog_mlsim.models import feature_library as fl

    @dataclass
    class _Score:
        augmentation: object
        total_gain: float

    lags = [_Score(fl.CommandLag(lag=k), g) for k, g in [(1, 0.50), (2, 0.47), (3, 0.30)]]
    assert estimate_member("command delay", lags).augmentation.lag == 2
    rates = [_Score(fl.JointRateSign(joints="all"), 0.50),
             _Score(fl.JointRateSign(joints="knees"), 0.46),
             _Score(fl.JointRateSign(joints="front_left_knee"), 0.30)]
    assert estimate_member("Coulomb friction", rates).augmentation.joints == "knees"


def _lag_score(lag: int, joints: str, total: float, landing: dict[str, float] | None = None,
               seed: int = 0):
    """A command-lag member with a per-element gain: 0.01 (+- noise) on every element, and
    ``landing``'s value on the q and dq of each joint group named there."""
    from types import SimpleNamespace

    from littledog_mlsim.layout import STATE_NAMES
    from littledog_mlsim.models import feature_library as fl
    rng = np.random.default_rng(seed)
    gain = 0.01 + 0.002 * rng.standard_normal(len(STATE_NAMES))
    for group, g in (landing or {}).items():
        for j in fl.JOINT_GROUPS[group]:
            for k in ("q", "dq"):
                gain[STATE_NAMES.index(f"{k}_{fl.JOINT_NAMES[j]}")] = g + 0.002 * rng.random()
    return SimpleNamespace(augmentation=fl.CommandLag(lag=lag, joints=joints), total_gain=total,
                           gain=gain)


def test_a_delay_is_scoped_where_its_gain_lands():
    """The lags of one side or leg carry a delayed side's old command too (a trot's legs move
    together), so the scope is read off where the best all-joint lag's gain lands: on one
    side's q and dq, that side; on one leg's, that leg; spread over every joint, all joints.
    The member is then the largest lag near the best within that scope."""
    from littledog_mlsim.diagnose.families.learned import delay_scope
    from littledog_mlsim.diagnose.selection import estimate_member
    left = {"left": 0.1}
    lags = [_lag_score(3, "all", 0.82, left), _lag_score(1, "all", 0.58, left, 1),
            _lag_score(3, "left", 0.68), _lag_score(2, "left", 0.56),
            _lag_score(4, "left", 0.60), _lag_score(3, "right", 0.50)]
    assert delay_scope(lags) == "left"
    member = estimate_member("command delay", lags)
    assert (member.augmentation.joints, member.augmentation.lag) == ("left", 3)
    leg = [_lag_score(2, "all", 0.4, {"back_left": 0.06}), _lag_score(2, "back_left", 0.3)]
    assert delay_scope(leg) == "back_left"
    spread = [_lag_score(2, "all", 0.9, {"all": 0.08}), _lag_score(2, "left", 0.5)]
    assert delay_scope(spread) == "all"
    assert estimate_member("command delay", spread).augmentation.joints == "all"
    # only all-joint lags screened: all joints, with no gains needed
    assert delay_scope([_lag_score(1, "all", 0.5)]) == "all"


def test_a_scoped_delay_scan_replaces_only_that_scopes_commands(monkeypatch):
    """``delay_scan(joints=...)`` gives the search model u_(t-d) of the scope's joints and
    keeps u_t of the others."""
    from types import SimpleNamespace

    from littledog_mlsim.diagnose import selection
    from littledog_mlsim.layout import N_FEATURE, N_STATE
    from littledog_mlsim.models import feature_library as fl
    seen = []

    class _Fit:
        def fit(self, X, D, move_index, move_types, length_scales):
            seen.append(np.array(X))
            return SimpleNamespace(sse_=np.ones((1, N_STATE)))
    monkeypatch.setattr(selection, "_fresh", lambda model: _Fit())
    n = 5
    X = np.zeros((n, N_FEATURE))
    left = fl.JOINT_GROUPS["left"]
    columns = {fl.CommandLag(lag=2, joints="left").label(): np.full((n, len(left)), 7.0)}
    model = SimpleNamespace(sse_=np.ones((1, N_STATE)), length_scales_=None)
    profile = selection.delay_scan(model, X, np.zeros((n, N_STATE)), np.zeros(n, int), ["F"],
                                   columns, [2], "left")
    assert [r["delay"] for r in profile] == [0, 2]
    U = seen[0][:, N_STATE:N_FEATURE]
    assert np.all(U[:, list(left)] == 7.0)
    assert np.all(np.delete(U, list(left), axis=1) == 0.0)
    assert np.all(seen[0][:, :N_STATE] == 0.0)


def test_the_report_only_offset_leaves_the_motion_and_starts_from_the_true_angle():
    """Decision 055: ``report_offset`` is ``encoder_offset``'s report-only form. Its plug-in
    offsets the published angle only, so the robot moves as without it; the search starts a
    re-simulation from the measured state minus the offset, which is the true state, and the
    re-simulation with the hypothesis then reproduces the recording's motion exactly and its
    reported angle within rounding."""
    import dataclasses
    from littledog_mlsim.diagnose.physical import true_start
    from littledog_mlsim.gait.trot import sample_trot_params, trot_commands
    from littledog_mlsim.robot.config import robot_config
    from littledog_mlsim.robot.effects import EncoderOffset
    from littledog_mlsim.robot.sim import InitialState, simulate_move

    spec, loop = FAMILIES["report_offset"], FAMILIES["encoder_offset"]
    assert spec.vocabulary == "encoder_offset" and spec.form != loop.form
    scope, par = "joint:back_left_knee", {"offset_rad": -0.07}
    (plug,) = spec.build_effects(scope, par)
    assert isinstance(plug, EncoderOffset) and not plug.servo_loop and plug.offset_rad == -0.07
    assert loop.build_effects(scope, par)[0].servo_loop
    fit = _Fit("report_offset", scope, -0.07, -0.07, None, {})
    assert spec.physical_params(fit, 0.9)["form"] == spec.form
    assert "report only" in spec.statement(scope_words(scope), {"offset_rad": -0.07})

    robot = dataclasses.replace(robot_config("measured"), sensor_noise=False)
    cmd = trot_commands(sample_trot_params("F", np.random.default_rng(3)))[:60]
    knee = scope_joints(scope)
    base = simulate_move(cmd, robot=robot)
    rec = simulate_move(cmd, robot=robot, effects=spec.build_effects(scope, par))
    assert np.array_equal(rec.position, base.position)
    assert np.allclose(rec.q[:, knee], base.q[:, knee] - 0.07)
    start = true_start(InitialState.from_recording(rec, 20), [("report_offset", scope, par)])
    assert np.allclose(start.q, InitialState.from_recording(base, 20).q)
    again = simulate_move(cmd[20:], robot=robot, effects=spec.build_effects(scope, par),
                          initial=start)
    plain = simulate_move(cmd[20:], robot=robot, initial=InitialState.from_recording(base, 20))
    assert np.allclose(again.position, plain.position, atol=1e-12)
    assert np.allclose(again.q[:, knee], plain.q[:, knee] - 0.07)
