"""Leg kinematics and the open-loop trot (littledog_mlsim.gait).

Independent references: LITTLEDOG.md's published home-pose foot positions and body height,
pybullet's own forward kinematics of robot/littledog.urdf, and finite differences of the foot
trajectories.
"""
from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from littledog_mlsim.gait.ik import forward_kinematics, inverse_kinematics
from littledog_mlsim.gait.trot import (DEFAULT_RANGES, LEG_PHASE_OFFSET, TrotParams, excite_commands,
                                       foot_trajectories, sample_trot_params, trot_commands)
from littledog_mlsim.layout import (HOME_BODY_HEIGHT, HOME_POSE, JOINT_LOWER, JOINT_NAMES, JOINT_UPPER,
                                    LEGS, MOVE_TYPES, STEPS_PER_MOVE)
from littledog_mlsim.robot.config import URDF_PATH

FOOT_RADIUS = 0.0103


def test_fk_home_matches_published_feet_and_height():
    feet = forward_kinematics(HOME_POSE)
    # LITTLEDOG.md: feet at x = +-0.0667, y = +-0.0736 in the body frame, body height ~0.146 m.
    sx = np.array([1, 1, -1, -1])
    sy = np.array([1, -1, 1, -1])
    np.testing.assert_allclose(feet[:, 0], 0.0667 * sx, atol=3e-4)
    np.testing.assert_allclose(feet[:, 1], 0.0736 * sy, atol=3e-4)
    np.testing.assert_allclose(-feet[:, 2] + FOOT_RADIUS, HOME_BODY_HEIGHT, atol=1.5e-3)


def test_ik_fk_round_trip_joint_space():
    rng = np.random.default_rng(0)
    q = np.clip(HOME_POSE + rng.uniform(-0.6, 0.6, size=(2000, 12)), JOINT_LOWER, JOINT_UPPER)
    q2 = inverse_kinematics(forward_kinematics(q))
    np.testing.assert_allclose(q2, q, atol=1e-9)


def test_fk_ik_round_trip_task_space():
    """Targets in a 4 cm box around each home foot position (the trot's workspace and more)."""
    rng = np.random.default_rng(1)
    feet = forward_kinematics(HOME_POSE) + rng.uniform(-0.02, 0.02, size=(2000, 4, 3))
    np.testing.assert_allclose(forward_kinematics(inverse_kinematics(feet)), feet, atol=1e-9)


def test_ik_unreachable_target_stretches_the_leg():
    far = forward_kinematics(HOME_POSE).copy()
    far[:, 2] = -0.5                                  # far below any foot's reach (< 0.18 m)
    reached = forward_kinematics(inverse_kinematics(far, clip=False))
    assert np.all(reached[:, 2] < -0.15)              # stretched towards the target
    assert np.all(np.linalg.norm(reached - far, axis=1) < 0.5 - 0.15)


def test_ik_rejects_bad_shapes():
    with pytest.raises(ValueError):
        inverse_kinematics(np.zeros((4, 2)))
    with pytest.raises(ValueError):
        forward_kinematics(np.zeros(11))


def test_fk_matches_pybullet_urdf():
    """Our analytic FK against pybullet's kinematics of the URDF, at random joint angles."""
    c = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(str(URDF_PATH), [0, 0, 0], useFixedBase=True, physicsClientId=c)
        by_name = {p.getJointInfo(body, j, physicsClientId=c)[1].decode(): j
                   for j in range(p.getNumJoints(body, physicsClientId=c))}
        joints = [by_name[n] for n in JOINT_NAMES]
        feet_links = [by_name[f"{leg}_foot_fixed"] for leg in LEGS]
        rng = np.random.default_rng(2)
        for _ in range(10):
            q = rng.uniform(JOINT_LOWER, JOINT_UPPER)
            for j, v in zip(joints, q):
                p.resetJointState(body, j, v, physicsClientId=c)
            states = p.getLinkStates(body, feet_links, computeForwardKinematics=True, physicsClientId=c)
            feet_pb = np.array([s[4] for s in states])
            np.testing.assert_allclose(forward_kinematics(q), feet_pb, atol=1e-6)
    finally:
        p.disconnect(c)


@pytest.mark.parametrize("move_type", MOVE_TYPES)
def test_commands_shape_limits_and_start(move_type):
    for seed in range(5):
        cmd = trot_commands(sample_trot_params(move_type, np.random.default_rng(seed)))
        assert cmd.shape == (STEPS_PER_MOVE, 12)
        assert np.all(np.isfinite(cmd))
        assert np.all(cmd >= JOINT_LOWER) and np.all(cmd <= JOINT_UPPER)
        # ramp-in: the first command is (almost) the home pose, no jump
        assert np.abs(cmd[0] - HOME_POSE).max() < 0.02
        assert np.abs(np.diff(cmd, axis=0)).max() < 0.25


def test_sampled_parameters_follow_move_type():
    r = DEFAULT_RANGES
    for seed in range(20):
        for mt in MOVE_TYPES:
            prm = sample_trot_params(mt, np.random.default_rng(seed))
            vx, vy = prm.velocity
            assert r.period[0] <= prm.period <= r.period[1]
            assert r.step_height[0] <= prm.step_height <= r.step_height[1]
            if mt == "S":
                assert vx == vy == prm.yaw_rate == 0.0
                continue
            fwd = {"F": 1, "FL": 1, "FR": 1, "DL": 1, "DR": 1, "B": -1, "BL": -1, "BR": -1}.get(mt, 0)
            side = {"L": 1, "DL": 1, "R": -1, "DR": -1}.get(mt, 0)
            turn = {"FL": 1, "BL": 1, "FR": -1, "BR": -1}.get(mt, 0)
            assert np.sign(np.round(vx, 12)) == fwd and np.sign(np.round(vy, 12)) == side
            if turn:
                assert turn * prm.yaw_rate >= r.yaw_rate_turn[0]
            else:
                assert abs(prm.yaw_rate) <= r.yaw_rate_jitter
    with pytest.raises(ValueError):
        sample_trot_params("X", np.random.default_rng(0))


def test_stance_feet_move_with_the_ground():
    """In stance (after the ramp) every foot moves at -(v + w x r) through the body frame."""
    prm = TrotParams("FL", velocity=(0.12, 0.03), yaw_rate=0.4, period=0.36, step_height=0.025,
                     ramp_time=0.3)
    feet = foot_trajectories(prm)                     # (n, 4, 3) at t = (k+1) dt
    t = prm.dt * np.arange(1, prm.n_steps + 1)
    phase = np.mod(t[:, None] / prm.period + LEG_PHASE_OFFSET, 1.0)
    vel = np.diff(feet, axis=0) / prm.dt              # between samples k and k+1
    mid = 0.5 * (feet[1:] + feet[:-1])
    # both samples in the same stance, after the ramp
    ok = (phase[1:] < prm.duty) & (phase[:-1] < phase[1:]) & (t[1:, None] > prm.ramp_time)
    assert ok.sum() > 500
    expected = -np.stack([prm.velocity[0] - prm.yaw_rate * mid[..., 1],
                          prm.velocity[1] + prm.yaw_rate * mid[..., 0]], axis=-1)
    np.testing.assert_allclose(vel[..., :2][ok], expected[ok], atol=2e-4)
    np.testing.assert_allclose(vel[..., 2][ok], 0.0, atol=1e-12)
    # stance feet are on the ground plane of the home pose, swing feet lift by step_height
    home_z = forward_kinematics(HOME_POSE)[:, 2]
    lift = feet[..., 2] - home_z
    assert np.all(lift[phase < prm.duty] == 0.0)
    np.testing.assert_allclose(lift[t > prm.ramp_time].max(), prm.step_height, rtol=0.02)


def test_diagonal_pairs_alternate():
    prm = sample_trot_params("S", np.random.default_rng(3))
    lift = foot_trajectories(prm)[..., 2]
    fl, fr, bl, br = lift.T
    np.testing.assert_allclose(fl, br)
    np.testing.assert_allclose(fr, bl)
    assert not np.any((fl > 1e-4) & (fr > 1e-4))      # never both pairs in the air


def test_trot_in_place_returns_to_home():
    prm = sample_trot_params("S", np.random.default_rng(4))
    feet = foot_trajectories(prm)
    home = forward_kinematics(HOME_POSE)
    np.testing.assert_allclose(feet[..., :2], np.broadcast_to(home[:, :2], feet[..., :2].shape), atol=1e-12)


def test_excitation_is_white_noise_of_the_given_size_inside_the_limits():
    u = trot_commands(sample_trot_params("F", np.random.default_rng(0)))
    rng = np.random.default_rng(1)
    assert excite_commands(u, 0.0, rng) is u                      # 0: unchanged, nothing drawn
    assert rng.bit_generator.state == np.random.default_rng(1).bit_generator.state
    noisy = excite_commands(u, 0.03, rng)
    n = noisy - u
    assert np.all(noisy >= JOINT_LOWER) and np.all(noisy <= JOINT_UPPER)
    inside = (noisy > JOINT_LOWER) & (noisy < JOINT_UPPER)        # not clipped
    assert abs(n[inside].std() - 0.03) < 0.002 and abs(n[inside].mean()) < 0.002
    lag1 = np.mean(n[1:] * n[:-1]) / np.mean(n * n)              # white: no step-to-step correlation
    assert abs(lag1) < 0.05
    again = excite_commands(u, 0.03, np.random.default_rng(1))
    np.testing.assert_array_equal(again, noisy)
    for bad in (-0.01, float("nan")):
        with pytest.raises(ValueError, match="excitation"):
            excite_commands(u, bad, rng)
