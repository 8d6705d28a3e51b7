"""The pybullet LittleDog (littledog_mlsim.robot): URDF, servo/sensor models, moves, effects.

Independent references: LITTLEDOG.md's masses, pybullet's own bookkeeping of the loaded model,
scipy's rotations for the twist, closed-form filter responses, and the recorded pose itself for
where each move type goes.
"""
from __future__ import annotations

import dataclasses
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
from scipy.spatial.transform import Rotation

from littledog_mlsim.data.summary import move_motion, move_problems
from littledog_mlsim.gait.trot import sample_trot_params, trot_commands
from littledog_mlsim.layout import (CONTROL_DT, CONTROL_DT_NS, HOME_POSE, JOINT_LOWER, JOINT_NAMES,
                                    JOINT_UPPER, MOVE_TYPES, STEPS_PER_MOVE)
from littledog_mlsim.robot.config import (ENCODER_RESOLUTION, MEASURED_ARMATURE, URDF_PATH,
                                          RobotConfig, per_joint, robot_config)
from littledog_mlsim.robot.effects import (CommandDelay, ConstantWind, EncoderOffset, EncoderScale,
                                           JointFriction, LegMass, Payload, ReadingScale,
                                           ServoDeadband, ServoGain, SwingDrag, TorqueSpeed,
                                           load_effects, resolve_joints)
from littledog_mlsim.robot.sensors import JointEncoders
from littledog_mlsim.robot.servo import PDTorqueServo
from littledog_mlsim.robot.sim import OBS_FIELDS, InitialState, LittleDogSim, get_sim, simulate_move

# Body collision box of the URDF (centre offset and half extents in base_link).
BOX_CENTRE = np.array([0.0, 0.0, 0.045])
BOX_HALF = np.array([0.165, 0.055, 0.07])
SEEDS = (0, 1)


def quiet(name: str = "measured") -> RobotConfig:
    """The named robot without motion-capture noise."""
    return dataclasses.replace(robot_config(name), sensor_noise=False)


def commands(move_type: str, seed: int = 0) -> np.ndarray:
    return trot_commands(sample_trot_params(move_type, np.random.default_rng(seed)))


def displacement_and_yaw(rec) -> tuple[np.ndarray, float]:
    """(x, y) displacement over the move in the initial heading frame, and the yaw change."""
    rot = Rotation.from_quat(rec.orientation)
    yaw = np.unwrap(rot.as_euler("ZYX")[:, 0])
    c, s = np.cos(yaw[0]), np.sin(yaw[0])
    dx, dy = (rec.position[-1, :2] - rec.position[0, :2])
    return np.array([c * dx + s * dy, -s * dx + c * dy]), float(yaw[-1] - yaw[0])


@pytest.fixture(scope="module")
def trot_recordings():
    """Every move type on the measured robot (with sensor noise), two seeds each."""
    return {(mt, seed): simulate_move(commands(mt, seed), robot="measured", seed=seed,
                                      move_type=mt, name=f"{mt}_{seed:02d}")
            for mt in MOVE_TYPES for seed in SEEDS}


# ----------------------------------------------------------------------------- model
def test_urdf_joints_masses_and_limits():
    c = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(str(URDF_PATH), flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=c)
        info = [p.getJointInfo(body, j, physicsClientId=c) for j in range(p.getNumJoints(body, physicsClientId=c))]
        revolute = [i for i in info if i[2] == p.JOINT_REVOLUTE]
        assert [i[1].decode() for i in revolute] == list(JOINT_NAMES)
        np.testing.assert_allclose([i[8] for i in revolute], JOINT_LOWER)
        np.testing.assert_allclose([i[9] for i in revolute], JOINT_UPPER)
        axes = np.array([i[13] for i in revolute]).reshape(4, 3, 3)
        np.testing.assert_allclose(axes[:, 0], [[1, 0, 0]] * 4)       # hip roll about x
        np.testing.assert_allclose(axes[:, 1:], [[[0, 1, 0]] * 2] * 4)  # pitch and knee about y
        masses = [p.getDynamicsInfo(body, j, physicsClientId=c)[0] for j in range(-1, len(info))]
        assert sum(masses) == pytest.approx(2.746, abs=1e-3)         # LITTLEDOG.md URDF total
        upper = p.getDynamicsInfo(body, 1, physicsClientId=c)
        np.testing.assert_allclose(upper[2], [8.2e-5, 8.9e-5, 1.5e-5])  # from file, not shapes
        np.testing.assert_allclose(upper[3], [0, 0, -0.0166])
    finally:
        p.disconnect(c)


def test_measured_and_nominal_mass_models():
    measured, nominal = get_sim(quiet("measured")), get_sim(quiet("nominal"))
    assert nominal.total_mass() == pytest.approx(2.746, abs=1e-3)
    assert measured.total_mass() == pytest.approx(3.0, abs=1e-3)      # guide: 2.24 + 4 x 0.19
    c, body = measured.client, measured.robot
    assert p.getDynamicsInfo(body, -1, physicsClientId=c)[0] == pytest.approx(2.24)
    # knee: lower-leg inertia scaled by 0.19/0.2366 plus the armature about y
    knee = measured.joint_indices[2]
    iyy = p.getDynamicsInfo(body, knee, physicsClientId=c)[2][1]
    assert iyy == pytest.approx(3.5e-5 * 0.19 / 0.2366 + MEASURED_ARMATURE[2], rel=1e-6)
    assert MEASURED_ARMATURE[2] == pytest.approx(1e-7 * 126**2)


def test_config_validation_and_names():
    with pytest.raises(ValueError, match="unknown robot"):
        robot_config("real")
    with pytest.raises(ValueError, match="divide"):
        dataclasses.replace(robot_config("measured"), physics_dt=0.003)
    assert robot_config("measured").substeps == 5


# ----------------------------------------------------------------------------- servo and sensors
def test_pd_servo_law_and_limits():
    servo = PDTorqueServo(robot_config("measured"))
    q = np.zeros(12)
    q_des = np.tile([0.1, -0.05, 0.02], 4)
    dq = np.tile([1.0, 0.0, -1.0], 4)
    expected = np.tile([7.5 * 0.1 - 0.32, 7.5 * -0.05, 6.7 * 0.02 + 0.32], 4)
    np.testing.assert_allclose(servo.torque(q_des, q, dq), expected)
    big = servo.torque(np.full(12, 1.0), q, np.zeros(12))
    np.testing.assert_allclose(big, np.tile([1.7, 1.7, 0.61], 4))


def test_encoders_quantise_and_filter():
    dt = 0.002
    enc = JointEncoders(per_joint(ENCODER_RESOLUTION), 50.0, dt)
    enc.reset(np.zeros(12), np.zeros(12))
    rate = 2.0
    t = dt * np.arange(1, 201)
    out = []
    for tk in t:
        enc.update(np.full(12, rate * tk), np.full(12, rate))
        counts = enc.position / per_joint(ENCODER_RESOLUTION)
        np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)   # whole counts
        out.append(enc.rate[0])
    # a ramp seen through a first-order 50 Hz low-pass sampled at 500 Hz: 1 - (1 - alpha)^k
    alpha = 1 - np.exp(-2 * np.pi * 50 * dt)
    k = np.arange(1, 201)
    expected = rate * (1 - (1 - alpha) ** k)
    np.testing.assert_allclose(out, expected, atol=3.65e-5 / dt * 1.01)   # +- one count per sample


# ----------------------------------------------------------------------------- moves
@pytest.mark.parametrize("move_type", MOVE_TYPES)
def test_every_move_type_stays_upright_and_goes_where_named(trot_recordings, move_type):
    for seed in SEEDS:
        rec = trot_recordings[(move_type, seed)]
        rec.validate()
        assert rec.n_steps == STEPS_PER_MOVE
        rot = Rotation.from_quat(rec.orientation)
        roll, pitch = rot.as_euler("ZYX")[:, 2], rot.as_euler("ZYX")[:, 1]
        assert np.abs(roll).max() < 0.3 and np.abs(pitch).max() < 0.3
        corners = np.array([[sx, sy, -1.0] for sx in (-1, 1) for sy in (-1, 1)]) * BOX_HALF + BOX_CENTRE
        lowest = (rec.position[:, None, :] + np.einsum("nij,kj->nki", rot.as_matrix(), corners))[..., 2]
        assert lowest.min() > 0.08                   # body underside stays well above the floor
        (dx, dy), dyaw = displacement_and_yaw(rec)          # scipy, independent of the package
        np.testing.assert_allclose(move_motion(rec), (dx, dy, dyaw), atol=1e-9)
        assert move_problems(rec) == [], f"{move_type} seed {seed}: dx={dx:.3f} dy={dy:.3f} dyaw={dyaw:.2f}"


def test_recording_timing_and_command(trot_recordings):
    rec = trot_recordings[("F", 0)]
    assert rec.name == "F_00" and rec.move_type == "F"
    np.testing.assert_array_equal(np.diff(rec.stamps_ns), CONTROL_DT_NS)
    np.testing.assert_array_equal(rec.cmd, commands("F", 0))
    counts = rec.q / per_joint(ENCODER_RESOLUTION)
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)      # encoder quantisation
    shifted = simulate_move(commands("F", 0)[:10], seed=0, start_ns=5 * CONTROL_DT_NS)
    assert shifted.stamps_ns[0] == 5 * CONTROL_DT_NS


def test_deterministic_for_a_seed_whatever_ran_before():
    cmd = commands("FL", 3)
    a = simulate_move(cmd, seed=7)
    simulate_move(commands("B", 1), seed=2, effects=[Payload(0.3, [0.05, 0.0, 0.0])])
    b = simulate_move(cmd, seed=7)
    with LittleDogSim("measured") as fresh:                   # a new world in a new client
        c_obs = [fresh.reset(seed=7)] + [fresh.step(u) for u in cmd]
    for field in ("q", "dq", "position", "orientation", "linear_velocity", "angular_velocity"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
        np.testing.assert_array_equal(getattr(a, field), np.array([o[field] for o in c_obs]), err_msg=field)
    d = simulate_move(cmd, seed=8)
    np.testing.assert_array_equal(a.q, d.q)                    # same physics ...
    assert np.abs(a.position - d.position).max() > 1e-5       # ... other noise


def _assert_same_observations(want: list[dict], got: list[dict]) -> None:
    """Two moves' observations equal, field by field, bit for bit."""
    assert len(want) == len(got)
    for w, g in zip(want, got):
        for field in OBS_FIELDS:
            np.testing.assert_array_equal(w[field], g[field], err_msg=field)


def test_a_robot_built_again_in_its_client_or_stood_up_late_moves_as_a_new_one():
    """``reconfigure`` (a calibration's replay robot, robot after robot in one client) and
    ``stand_up=False`` (the home stance found when a move first starts there) give a robot
    that moves as ``LittleDogSim(config)`` does, bit for bit, from home and from a given
    state."""
    cmd = commands("FL", 3)[:60]
    nominal, measured = robot_config("nominal"), robot_config("measured")
    heavier = dataclasses.replace(measured, body_mass=2.6, kp=(8.0, 7.0, 6.0))

    def run(sim: LittleDogSim, initial: InitialState | None) -> list[dict]:
        return [sim.reset(seed=5, initial=initial)] + [sim.step(u) for u in cmd]

    with LittleDogSim(measured) as a:
        a.reset(seed=0)
        for u in cmd[:30]:
            a.step(u)
        start = a.true_state()                   # mid-move: moving, feet on the ground
    with LittleDogSim(nominal, stand_up=False) as reused:
        for config in (heavier, nominal, measured):
            reused.reconfigure(config, stand_up=False)
            for initial in (start, None, start):     # home found late, between given starts
                with LittleDogSim(config) as fresh:
                    want = run(fresh, initial)
                _assert_same_observations(want, run(reused, initial))


def test_a_robot_that_fails_to_be_built_again_is_closed_not_passed_off():
    """A config that fails to build (here a servo with two gains for three joint kinds)
    closes the robot: the replay robot of ``baseline._sim_for`` is then built anew, and its
    numbers are a new robot's; it never replays with the old robot under the new name."""
    from littledog_mlsim.robot import baseline

    measured = robot_config("measured")
    bad = dataclasses.replace(measured, kp=(1.0, 2.0))
    sim = baseline._sim_for(measured)
    with pytest.raises(ValueError):
        baseline._sim_for(bad)
    assert sim.client == -1
    with pytest.raises(ValueError):          # asked again, it fails again: never the old robot
        baseline._sim_for(bad)
    other = dataclasses.replace(measured, kp=(8.0, 7.0, 6.0))
    got = baseline._sim_for(other)
    assert got is not sim and got.config == other
    cmd = commands("F", 1)[:20]
    with LittleDogSim(other) as fresh:
        want = [fresh.reset(seed=2)] + [fresh.step(u) for u in cmd]
    _assert_same_observations(want, [got.reset(seed=2)] + [got.step(u) for u in cmd])


def test_sensor_noise_on_and_off():
    cmd = commands("DL", 2)
    noisy = simulate_move(cmd, robot="measured", seed=4)
    clean = simulate_move(cmd, robot=quiet(), seed=4)
    np.testing.assert_array_equal(noisy.q, clean.q)          # noise does not touch the physics
    pos_err = noisy.position - clean.position
    assert pos_err.std() == pytest.approx(3e-4, rel=0.15)    # 0.3 mm per axis
    rot_err = (Rotation.from_quat(clean.orientation).inv() * Rotation.from_quat(noisy.orientation)).as_rotvec()
    assert rot_err.std() == pytest.approx(1e-3, rel=0.15)    # 1 mrad per axis
    # noise-free twist = finite difference of the recorded pose, in base_link (scipy as reference)
    r = Rotation.from_quat(clean.orientation)
    v = r[1:].inv().apply(np.diff(clean.position, axis=0) / CONTROL_DT)
    w = (r[:-1].inv() * r[1:]).as_rotvec() / CONTROL_DT
    np.testing.assert_allclose(clean.linear_velocity[1:], v, atol=1e-9)
    np.testing.assert_allclose(clean.angular_velocity[1:], w, atol=1e-9)
    assert np.abs(clean.linear_velocity[0]).max() < 1e-3     # standing still at the start


def test_nominal_differs_from_measured():
    cmd = commands("F", 5)
    m = simulate_move(cmd, robot=quiet("measured"))
    n = simulate_move(cmd, robot="nominal")
    assert n.position[:, 2].mean() - m.position[:, 2].mean() > 0.003   # lighter, stiffer: higher
    rms_m = np.sqrt(np.mean((m.q[1:] - m.cmd) ** 2))
    rms_n = np.sqrt(np.mean((n.q[1:] - n.cmd) ** 2))
    assert rms_n < 0.5 * rms_m                                          # idealised servo tracks
    (dx_n, _), _ = displacement_and_yaw(n)
    assert dx_n > 0.05
    roll_pitch = Rotation.from_quat(n.orientation).as_euler("ZYX")[:, 1:]
    assert np.abs(roll_pitch).max() < 0.3


def test_initial_state_starts_there():
    cmd = commands("R", 6)
    ref = simulate_move(cmd, robot=quiet())
    k = 150
    start = InitialState.from_recording(ref, k)
    rec = simulate_move(cmd[k:], robot=quiet(), initial=start, move_type="R")
    np.testing.assert_allclose(rec.position[0], ref.position[k], atol=1e-12)
    np.testing.assert_allclose(rec.q[0], ref.q[k], atol=2.5e-5)
    # continuing with the same commands follows the original closely at first
    assert np.abs(rec.position[:20] - ref.position[k:k + 20]).max() < 0.01
    assert np.abs(Rotation.from_quat(rec.orientation).as_euler("ZYX")[:, 1:]).max() < 0.3
    with pytest.raises(ValueError, match="q"):
        dataclasses.replace(start, q=np.zeros(11)).validated()


def _true_twist(t: float) -> tuple[np.ndarray, np.ndarray]:
    """The base_link twist of synthetic.make_recording's analytic motion at time t (central
    differences 1e-5 s apart of its formulas)."""
    def pose(tt):
        yaw = 2.9 + 0.6 * tt + 0.05 * np.sin(3 * tt)
        roll = 0.08 * np.sin(2 * np.pi * 1.3 * tt + 0.3) + 0.03
        pitch = 0.06 * np.cos(2 * np.pi * 0.9 * tt) - 0.02
        pos = np.array([0.3 + 0.2 * tt + 0.01 * np.sin(5 * tt), -0.1 + 0.05 * tt ** 2,
                        0.146 + 0.005 * np.sin(7 * tt)])
        return pos, Rotation.from_euler("ZYX", [yaw, pitch, roll])
    h = 1e-5
    (p0, r0), (p1, r1) = pose(t - h), pose(t + h)
    r = pose(t)[1]
    lin = r.as_matrix().T @ ((p1 - p0) / (2 * h))
    ang = (r0.inv() * r1).as_rotvec() / (2 * h)
    return lin, ang


def test_smoothed_initial_state_removes_the_noise_of_a_difference():
    """With 1 mm / 1 mrad of pose noise a 10 ms backward difference is off by about 0.1 m/s and
    0.1 rad/s; the local fit of InitialState.smoothed is several times closer, follows a
    noise-free motion to within its curvature, and keeps the joints and the encoders' rates as
    measured."""
    from synthetic import make_recording
    clean = make_recording(n=300, seed=3)
    rng = np.random.default_rng(11)
    noisy_pos = clean.position + 1e-3 * rng.standard_normal(clean.position.shape)
    noisy_orn = (Rotation.from_quat(clean.orientation)
                 * Rotation.from_rotvec(1e-3 * rng.standard_normal((clean.q.shape[0], 3)))).as_quat()
    from littledog_mlsim.robot.sensors import twist_from_poses
    lin_b, ang_b = twist_from_poses(noisy_pos[:-1], noisy_orn[:-1], noisy_pos[1:], noisy_orn[1:],
                                    0.01)
    noisy = dataclasses.replace(clean, position=noisy_pos, orientation=noisy_orn,
                                linear_velocity=np.vstack([lin_b[:1], lin_b]),
                                angular_velocity=np.vstack([ang_b[:1], ang_b]))
    err = {"measured": [], "smoothed": [], "clean": []}
    for k in range(20, 280, 7):
        lin, ang = _true_twist(k * 0.01)
        for name, s in (("measured", InitialState.from_recording(noisy, k)),
                        ("smoothed", InitialState.smoothed(noisy, k)),
                        ("clean", InitialState.smoothed(clean, k))):
            err[name].append(np.r_[s.linear_velocity - lin, s.angular_velocity - ang])
    rms = {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in err.items()}
    assert rms["measured"] > 0.05
    assert rms["smoothed"] < rms["measured"] / 4
    assert rms["clean"] < 0.01
    s = InitialState.smoothed(noisy, 100)
    np.testing.assert_array_equal(s.q, noisy.q[100])
    np.testing.assert_array_equal(s.dq, noisy.dq[100])
    np.testing.assert_array_equal(s.reported_dq, noisy.dq[100])
    assert np.linalg.norm(s.position - clean.position[100]) < 1.5e-3
    # at the ends of a move the window is clipped, not shifted
    np.testing.assert_allclose(InitialState.smoothed(clean, 0).position, clean.position[0],
                               atol=1e-4)
    with pytest.raises(ValueError, match="outside"):
        InitialState.smoothed(clean, 301)


def test_the_encoders_rate_filter_starts_from_the_reported_rates():
    cmd = commands("F", 6)
    ref = simulate_move(cmd, robot=quiet())
    start = dataclasses.replace(InitialState.from_recording(ref, 100),
                                reported_dq=np.full(12, 0.25))
    obs = get_sim(quiet()).reset(initial=start)
    np.testing.assert_allclose(obs["dq"], 0.25)
    obs = get_sim(quiet()).reset(initial=InitialState.from_recording(ref, 100))
    np.testing.assert_allclose(obs["dq"], ref.dq[100])
    with pytest.raises(ValueError, match="reported_dq"):
        dataclasses.replace(start, reported_dq=np.zeros(3)).validated()


class _TiltOnReset:
    """A plug-in whose reset carries the standing robot 3 deg about x, at rest (as a floor
    tilted under it would)."""

    def reset(self, sim):
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        tilt = p.getQuaternionFromAxisAngle([1.0, 0.0, 0.0], np.radians(3.0))
        p.resetBasePositionAndOrientation(sim.robot, pos, p.multiplyTransforms(
            [0, 0, 0], tilt, [0, 0, 0], orn)[1], physicsClientId=c)
        p.resetBaseVelocity(sim.robot, [0, 0, 0], [0, 0, 0], physicsClientId=c)


def test_first_twist_is_measured_after_the_effects_reset():
    """A reset hook that moves the body at rest must not show up as a twist at t = 0 (the first
    twist is a finite difference from the pose one step earlier, taken after the hooks)."""
    rec = simulate_move(commands("F", 6)[:5], robot=quiet(), effects=[_TiltOnReset()])
    assert Rotation.from_quat(rec.orientation[0]).as_euler("xyz")[0] == pytest.approx(
        np.radians(3.0), abs=1e-3)
    assert np.abs(rec.angular_velocity[0]).max() < 1e-6
    assert np.abs(rec.linear_velocity[0]).max() < 1e-6


def test_simulate_move_rejects_bad_input():
    with pytest.raises(ValueError, match="shape"):
        simulate_move(np.zeros((10, 11)))
    with pytest.raises(ValueError, match="NaN"):
        simulate_move(np.full((3, 12), np.nan))
    with pytest.raises(ValueError, match="move type"):
        simulate_move(np.tile(HOME_POSE, (3, 1)), move_type="X")


# ----------------------------------------------------------------------------- effects
def test_joint_groups():
    assert list(resolve_joints("knees")) == [2, 5, 8, 11]
    assert list(resolve_joints(["front_left", "back_right_knee"])) == [0, 1, 2, 11]
    assert list(resolve_joints("hips")) == [0, 1, 3, 4, 6, 7, 9, 10]
    assert list(resolve_joints("left")) == [0, 1, 2, 6, 7, 8]
    with pytest.raises(ValueError, match="elbows"):
        resolve_joints("elbows")


def test_command_delay_delays_joint_traces():
    steps = 4
    cmd = commands("F", 8)
    base = simulate_move(cmd, robot=quiet())
    delayed = simulate_move(cmd, robot=quiet(), effects=[CommandDelay(steps)])
    np.testing.assert_array_equal(delayed.cmd, cmd)           # recorded as sent
    def mismatch(lag):
        return np.sqrt(np.mean((delayed.q[lag:lag + 300] - base.q[:300]) ** 2))
    errs = [mismatch(lag) for lag in range(0, 9)]
    assert int(np.argmin(errs)) == steps
    assert errs[steps] < 0.1 * errs[0]
    # knees only: the hips follow the undelayed commands' phase
    knees = simulate_move(cmd, robot=quiet(), effects=[CommandDelay(steps, joints="knees")])
    hip = [np.sqrt(np.mean((knees.q[lag:lag + 300, 1] - base.q[:300, 1]) ** 2)) for lag in range(9)]
    assert int(np.argmin(hip)) < steps


def test_physical_effects_push_the_right_way():
    cmd = commands("S", 9)
    base = simulate_move(cmd, robot=quiet())
    wind = simulate_move(cmd, robot=quiet(), effects=[ConstantWind([0.0, 2.0])])
    assert wind.position[-1, 1] - base.position[-1, 1] > 0.01           # pushed towards +y
    heavy = simulate_move(cmd, robot=quiet(), effects=[Payload(0.5, [0.0, 0.0, 0.03])])
    assert base.position[:, 2].mean() - heavy.position[:, 2].mean() > 5e-4  # sags
    sticky = simulate_move(cmd, robot=quiet(), effects=[JointFriction(coulomb=0.15, joints="knees")])
    err = lambda r: np.sqrt(np.mean((r.q[1:, 2::3] - r.cmd[:, 2::3]) ** 2))
    assert err(sticky) > err(base) * 1.05
    np.testing.assert_allclose(JointFriction(coulomb=0.2, viscous=0.1, smoothing=0.05).torque(
        np.array([-1.0, 0.0, 1.0] * 4)), np.array([0.2 * np.tanh(20) + 0.1, 0.0, -0.2 * np.tanh(20) - 0.1] * 4))



def test_leg_swing_and_servo_plugins_act_where_named():
    """The plug-ins the diagnosis adds for leg, contact-phase, backlash and encoder hypotheses."""
    cmd = commands("F", 3)[:150]
    sim = get_sim(quiet())
    heavy = LegMass(2.0, "back_left")
    sim.reset(effects=[heavy])
    leg = [sim.joint_indices[6 + k] for k in range(3)]
    m1 = sum(p.getDynamicsInfo(sim.robot, j, physicsClientId=sim.client)[0] for j in leg)
    sim.reset(effects=[])
    m0 = sum(p.getDynamicsInfo(sim.robot, j, physicsClientId=sim.client)[0] for j in leg)
    assert m1 == pytest.approx(2.0 * m0)                 # the named leg's links, twice as heavy
    # the lower-leg form: the same leg mass ratio, all of the change on the knee's link
    whole = leg + [sim.foot_links[2]]
    mass = lambda links: [p.getDynamicsInfo(sim.robot, j, physicsClientId=sim.client)[0]
                          for j in links]
    before = mass(whole)
    sim.reset(effects=[LegMass(1.4, "back_left", where="lower")])
    after = mass(whole)
    assert sum(after) == pytest.approx(1.4 * sum(before))
    assert after[:2] == before[:2] and after[3] == before[3] and after[2] > before[2]
    sim.reset(effects=[])
    with pytest.raises(ValueError, match="where"):
        LegMass(1.4, "back_left", where="foot")
    base = simulate_move(cmd, robot=quiet())
    # swing drag on a foot: the foot swings less far, so that leg's hip pitch lags its command
    drag = simulate_move(cmd, robot=quiet(), effects=[SwingDrag(5.0, "front_left")])
    err = lambda r, j: np.sqrt(np.mean((r.q[1:, j] - r.cmd[:, j]) ** 2))
    assert err(drag, 1) > 1.1 * err(base, 1)
    assert abs(err(drag, 10) - err(base, 10)) < abs(err(drag, 1) - err(base, 1))
    # a dead band in the knee servos: knees track worse, hips hardly change
    loose = simulate_move(cmd, robot=quiet(), effects=[ServoDeadband(0.1, "knees")])
    assert err(loose, 2) > 1.1 * err(base, 2)
    # the same play with the encoder on the motor: the knees move as with the encoder on the
    # link, and the reported knee angle is the link's moved towards the set-point within the play
    motor = simulate_move(cmd, robot=quiet(), effects=[ServoDeadband(0.1, "knees", encoder="motor")])
    assert np.array_equal(motor.position, loose.position)
    shift = motor.q[1:, 2] - loose.q[1:, 2]
    assert np.all(np.abs(shift) <= 0.05 + 1e-12) and np.abs(shift).max() > 0.01
    assert np.array_equal(motor.q[:, 0], loose.q[:, 0])       # hips: as reported before
    assert err(motor, 2) < err(loose, 2)                       # nearer the set-point
    with pytest.raises(ValueError, match="encoder"):
        ServoDeadband(0.1, "knees", encoder="hall")
    # an encoder offset inside the servo loop: the reported angle follows the set-point as before,
    # the true joint sits offset_rad short of it (the measured angle minus the offset)
    off = EncoderOffset(0.05, "front_left_hip_pitch", servo_loop=True)
    u = off.command(np.asarray(cmd[0], dtype=float), 0.0)
    assert u[1] == pytest.approx(cmd[0][1] - 0.05) and u[0] == cmd[0][0]
    enc = simulate_move(cmd, robot=quiet(), effects=[off])
    assert abs(np.mean(enc.q[50:, 1] - base.q[50:, 1])) < 0.02
    assert EncoderOffset(0.05, "knees").command(np.zeros(12), 0.0).tolist() == [0.0] * 12



def test_an_encoder_read_through_a_wrong_ratio_moves_the_joint_not_its_reading():
    """EncoderScale: the readings are the true angles and rates times the scale, and the servo
    closes its loop on them, so the reported angles still follow the set-points while the
    joints stand at set-point / scale: the body stands and walks differently."""
    enc = EncoderScale(0.9, "knees")
    obs = enc.measure({"q": np.ones(12), "dq": np.full(12, 2.0)}, 0.0)
    knees = [2, 5, 8, 11]
    assert obs["q"][knees].tolist() == [0.9] * 4 and obs["dq"][knees].tolist() == [1.8] * 4
    assert obs["q"][0] == 1.0 and obs["dq"][0] == 2.0
    with pytest.raises(ValueError, match="scale"):
        EncoderScale(0.0, "knees")
    cmd = commands("F", 3)[:150]
    base = simulate_move(cmd, robot=quiet())
    same = simulate_move(cmd, robot=quiet(), effects=[EncoderScale(1.0, "all")])
    assert np.allclose(same.position, base.position, atol=1e-9)
    scaled = simulate_move(cmd, robot=quiet(), effects=[EncoderScale(0.95, "all")])
    # the readings track the set-points about as closely as before ...
    err = lambda r: np.sqrt(np.mean((r.q[51:] - r.cmd[50:]) ** 2))
    assert err(scaled) < 1.5 * err(base) + 0.005
    # ... while every knee is bent about 5 % further than its reading: the body stands lower
    assert np.mean(scaled.position[50:, 2]) < np.mean(base.position[50:, 2]) - 0.002
    # the same ratio in the report only: the robot moves as without it, its reports are scaled
    report = simulate_move(cmd, robot=quiet(), effects=[ReadingScale(0.95, "knees")])
    assert np.array_equal(report.position, base.position)
    assert np.allclose(report.q[:, knees], 0.95 * base.q[:, knees])
    assert np.array_equal(report.q[:, 0], base.q[:, 0])


def test_a_motor_torque_speed_line_takes_torque_only_while_motoring_fast():
    """TorqueSpeed: while the servo drives a joint the way it moves, its torque is capped at
    stall_ratio x limit x (1 - |rate| / no-load speed); at rest and while braking the normal
    limit holds; on the robot a slow motor lets the trot fall behind."""
    ts = TorqueSpeed(4.0, "knees")
    ts._kp, ts._kd, ts._lim0 = np.full(4, 10.0), np.zeros(4), np.full(4, 2.0)
    e = np.array([1.0, 1.0, -1.0, 0.01])           # PD torque 10, 10, -10, 0.1 -> 2, 2, -2, 0.1
    dq = np.array([2.0, -2.0, -3.0, 1.0])
    # motoring at half the no-load speed: half the limit; braking: the limit; a small torque
    # under its cap is left alone
    assert np.allclose(ts.servo(e, dq, 0.0), [1.0, 2.0, -0.5, 0.1])
    assert np.allclose(ts.servo(e, np.zeros(4), 0.0), [2.0, 2.0, -2.0, 0.1])
    strong = TorqueSpeed(4.0, "knees", stall_ratio=2.0)
    strong._kp, strong._kd, strong._lim0 = ts._kp, ts._kd, ts._lim0
    assert np.allclose(strong.servo(e, dq, 0.0), [2.0, 2.0, -1.0, 0.1])   # cap 2 x 2 x (1 - |dq|/4)
    for bad in ({"no_load_speed_rad_s": 0.0}, {"no_load_speed_rad_s": np.nan},
                {"no_load_speed_rad_s": 4.0, "stall_ratio": -1.0}):
        with pytest.raises(ValueError, match="TorqueSpeed"):
            TorqueSpeed(joints="knees", **bad)
    cmd = commands("F", 3)[:300]
    base = simulate_move(cmd, robot=quiet())
    fast = simulate_move(cmd, robot=quiet(), effects=[TorqueSpeed(1e6, "all")])
    assert np.allclose(fast.position, base.position, atol=1e-4)
    # the knees swing at up to about 4 rad/s: a motor whose no-load speed is 1.5 rad/s cannot
    # follow, and the trot covers centimetres less ground in 3 s
    slow = simulate_move(cmd, robot=quiet(), effects=[TorqueSpeed(1.5, "all")])
    err = lambda r: np.sqrt(np.mean((r.q[51:] - r.cmd[50:]) ** 2))
    assert err(slow) > 1.1 * err(base)
    assert slow.position[-1, 0] < base.position[-1, 0] - 0.03


PLUGIN = textwrap.dedent('''
    import numpy as np

    class Lift:
        """Reports the body 'height' metres higher and remembers what it saw."""
        def __init__(self, height):
            self.height = height
            self.seen = {}
            self.commands = 0

        def reset(self, sim):
            self.seen = {"client": sim.client, "robot": sim.robot, "joints": list(sim.joint_indices),
                         "physics_dt": sim.physics_dt, "control_dt": sim.control_dt,
                         "rng": sim.rng}

        def command(self, u, t):
            self.commands += 1
            return u

        def measure(self, obs, t):
            obs["position"] = obs["position"] + np.array([0.0, 0.0, self.height])
            return obs
''')


def test_effects_from_yaml_with_a_class_in_a_file(tmp_path: Path):
    (tmp_path / "plugins").mkdir()
    (tmp_path / "plugins" / "my_effects.py").write_text(PLUGIN)
    cfg = tmp_path / "effects.yaml"
    cfg.write_text(textwrap.dedent('''
        - class: plugins/my_effects.py:Lift
          params: {height: 1.0}
        - class: littledog_mlsim.robot.effects:CommandDelay
          params: {steps: 0, joints: knees}
    '''))
    effects = load_effects(cfg)
    assert [type(e).__name__ for e in effects] == ["Lift", "CommandDelay"]
    cmd = commands("L", 10)[:50]
    base = simulate_move(cmd, robot=quiet())
    rec = simulate_move(cmd, robot=quiet(), effects=effects)
    np.testing.assert_allclose(rec.position[:, 2] - base.position[:, 2], 1.0, atol=1e-12)
    np.testing.assert_array_equal(rec.q, base.q)
    lift = effects[0]
    assert lift.commands == 50
    assert len(lift.seen["joints"]) == 12 and lift.seen["physics_dt"] == pytest.approx(0.002)
    assert lift.seen["control_dt"] == pytest.approx(CONTROL_DT)
    assert isinstance(lift.seen["rng"], np.random.Generator)
    assert load_effects(_write(tmp_path / "empty.yaml", "")) == []


def _write(path: Path, text: str) -> Path:
    path.write_text(textwrap.dedent(text))
    return path


@pytest.mark.parametrize("text, fragment", [
    ("- class: no_such_module_xyz:Thing\n", "no_such_module_xyz"),
    ("- class: littledog_mlsim.robot.effects:NoSuchEffect\n", "NoSuchEffect"),
    ("- class: missing/file.py:Thing\n", "not found"),
    ("- class: littledog_mlsim.robot.effects:CommandDelay\n  params: {steps: -1}\n", "steps"),
    ("- class: littledog_mlsim.robot.effects:CommandDelay\n  params: {stepz: 2}\n", "stepz"),
    ("- class: littledog_mlsim.robot.effects:JointFriction\n  params: {joints: elbows}\n", "elbows"),
    ("- params: {steps: 2}\n", "'class'"),
    ("- class: CommandDelay\n", "ClassName"),
    ("class: x:Y\n", "list"),
    ("- [unclosed\n", "cannot read"),
    ("- class: collections:OrderedDict\n", "implements none"),
])
def test_bad_effect_yaml_gives_one_clear_line(tmp_path: Path, text, fragment):
    path = _write(tmp_path / "bad.yaml", text)
    with pytest.raises(ValueError) as err:
        load_effects(path)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg and fragment in msg
    if text.startswith("- class"):
        assert "effect #1" in msg


class _RaisingPush:
    """A declared world-neutral effect that pushes the body, then fails inside a step."""

    changes_world = False

    def substep(self, sim, t: float) -> None:
        p.applyExternalForce(sim.robot, -1, [500.0, 0.0, 0.0], [0.0, 0.0, 0.0], p.LINK_FRAME,
                             physicsClientId=sim.client)
        if t >= 0.1:
            raise RuntimeError("a hook failed")


class _FrictionPatch:
    """A plug-in that changes the world in a substep and does not say so (no changes_world)."""

    def substep(self, sim, t: float) -> None:
        if t == 0.0:
            p.changeDynamics(sim.robot, sim.foot_links[0], lateralFriction=0.3,
                             physicsClientId=sim.client)


@pytest.mark.parametrize("robot", ["measured", "nominal"])
def test_each_move_starts_in_the_world_as_built_restored_or_rebuilt(monkeypatch, robot):
    """A move starts in the world as built: restored from the snapshot after moves whose
    effects all declare ``changes_world = False``, built again after any other (a leg's mass at
    reset, a friction changed in a substep by a plug-in that says nothing). Both give the
    numbers a rebuilt world gives, bit for bit, also for segments that each start where the last
    one ended (the diagnosis's re-simulations), where the collision pass after the restore drops
    the contact points the last move left: without it one of these segments differs."""
    import littledog_mlsim.robot.sim as sim_module
    from littledog_mlsim.robot.effects import LegMass, SetpointDelay
    sim = LittleDogSim(robot)
    q0 = sim.reset(seed=0)["q"]
    rng = np.random.default_rng(4)
    cmd = q0[None] + 0.25 * np.sin(np.arange(300) * 0.09 + 4)[:, None] * rng.normal(size=12)

    def run(u, start=None, effects=(), rebuild=False):
        if rebuild:
            sim._world_as_built = False
        obs = [sim.reset(seed=0, initial=start, effects=list(effects))]
        obs += [sim.step(x) for x in u]
        return np.array([np.concatenate([o[k] for k in sorted(o)]) for o in obs]), \
            sim.true_state()

    def segments_restored_as_rebuilt() -> list[bool]:
        start, same = None, []
        for s0 in range(0, 300, 50):
            rebuilt, end = run(cmd[s0:s0 + 50], start, rebuild=True)
            restored, _ = run(cmd[s0:s0 + 50], start)
            same.append(bool(np.array_equal(rebuilt, restored)))
            start = end
        return same

    assert all(segments_restored_as_rebuilt())
    if robot == "measured":          # these segments carry a contact over on this robot
        with monkeypatch.context() as m:
            m.setattr(sim_module.p, "performCollisionDetection", lambda **kw: None)
            assert not all(segments_restored_as_rebuilt())
    built, end = run(cmd[:60], rebuild=True)
    # a move whose state overflows (finite but absurd rates) leaves state no snapshot restores
    wild = dataclasses.replace(end, dq=np.full(12, 1e200), angular_velocity=np.full(3, 1e200))
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        broken, _ = run(cmd[:20], start=wild)
    assert not np.isfinite(broken[-1]).all() and not sim._world_as_built
    assert np.array_equal(run(cmd[:60])[0], built)
    # a step cut short by a hook leaves its forces applied: the next move is built again
    with pytest.raises(RuntimeError):
        run(cmd[:60], effects=[_RaisingPush()])
    assert not sim._world_as_built
    assert np.array_equal(run(cmd[:60])[0], built)
    for effects in ([], [SetpointDelay(12.0)], [LegMass(1.5, "front_left")], [_FrictionPatch()]):
        changed, _ = run(cmd[:60], effects=effects)
        declared = all(getattr(e, "changes_world", True) is False for e in effects)
        assert sim._world_as_built is declared, effects
        again, _ = run(cmd[:60])                      # restored, or rebuilt after a change
        assert np.array_equal(again, built), effects
        if not declared:
            assert not np.array_equal(changed, built), effects
    sim.close()


class _JointStateWitness:
    """A plug-in that checks, before every physics step, that the joint state the simulator
    shares (``sim.joint_state()``) is the one pybullet holds then, bit for bit."""

    changes_world = False

    def __init__(self) -> None:
        self.checked = 0

    def substep(self, sim, t: float) -> None:
        q, dq = sim.joint_state()
        states = p.getJointStates(sim.robot, sim.joint_indices, physicsClientId=sim.client)
        assert np.array_equal(q, [s[0] for s in states]) and np.array_equal(dq, [s[1] for s in states])
        assert not q.flags.writeable and not dq.flags.writeable
        self.checked += 1


class _SetsAKnee:
    """A plug-in that sets a joint's state in a substep and says so (forget_joint_state), and
    at reset after reading the joints, where it need not: the simulator reads them again after
    the reset hooks."""

    changes_world = False

    def __init__(self) -> None:
        self.set = 0

    def reset(self, sim) -> None:
        sim.joint_state()
        p.resetJointState(sim.robot, sim.joint_indices[5], 0.9, -0.4, physicsClientId=sim.client)
        self.set += 1

    def substep(self, sim, t: float) -> None:
        if t == 0.02:
            p.resetJointState(sim.robot, sim.joint_indices[2], -1.2, 0.5, physicsClientId=sim.client)
            sim.forget_joint_state()
            self.set += 1


@pytest.mark.parametrize("robot", ["measured", "nominal"])
def test_the_joint_state_read_once_per_physics_step_is_what_pybullet_holds(robot):
    """The simulator reads the joints once after each physics step and shares that reading
    with its encoders and with plug-ins until the next step (the servo-change and friction
    families use it): after a reset, from a given start, after a world rebuilt for a changed
    mass, and after a plug-in that sets a joint itself, it equals a fresh read."""
    sim = LittleDogSim(robot)
    home = sim.reset(seed=0)["q"]
    cmd = home[None] + 0.2 * np.sin(np.arange(40) * 0.2)[:, None]
    start = None
    knee = _SetsAKnee()
    for effects in ([], [LegMass(1.3, "back_left")], [knee], [ServoGain(0.7, "knees")]):
        witness = _JointStateWitness()
        sim.reset(seed=1, initial=start, effects=[*effects, witness])
        for u in cmd:
            sim.step(u)
        assert witness.checked == len(cmd) * sim.substeps
        start = sim.true_state()
    assert knee.set == 2
    sim.close()
