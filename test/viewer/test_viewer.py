"""The view's numerical parts (no browser): URDF shapes and kinematics against the analytic legs
of gait.ik, quaternion conversion, covariance ellipses, robot specs, replay tracks, and the live
message handling (bad messages counted, never a crash)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from littledog_mlsim.gait.ik import forward_kinematics
from littledog_mlsim.layout import CONTROL_DT, HOME_POSE, JOINT_LOWER, JOINT_UPPER
from littledog_mlsim.viewer.scene import ellipse_points
from littledog_mlsim.viewer.tracks import Track, joint_errors, measured_track, xy_gap
from littledog_mlsim.viewer.urdf import load_robot, matrix_to_wxyz
from synthetic import make_recording


@pytest.fixture(scope="module")
def robot():
    return load_robot()


def test_urdf_shapes(robot):
    kinds = sorted(v.kind for v in robot.visuals)
    assert kinds.count("box") == 1 and kinds.count("capsule") == 8 and kinds.count("sphere") == 4
    body = [v for v in robot.visuals if v.kind == "box"][0]
    assert body.size == (0.33, 0.11, 0.14) and body.link == robot.root == "body"


def test_feet_match_the_analytic_legs(robot):
    """Foot spheres of the URDF chain == gait.ik's closed-form legs, under a random base pose."""
    rng = np.random.default_rng(1)
    q = rng.uniform(JOINT_LOWER, JOINT_UPPER, (50, 12))
    rot = Rotation.random(50, random_state=2)
    pos = rng.normal(0, 1, (50, 3))
    p, _ = robot.visual_poses(pos, rot.as_quat(), q)
    feet = p[:, [i for i, v in enumerate(robot.visuals) if v.kind == "sphere"]]
    expect = pos[:, None] + np.einsum("nij,nkj->nki", rot.as_matrix(), forward_kinematics(q))
    np.testing.assert_allclose(feet, expect, atol=1e-12)


def test_capsules_end_at_the_joints(robot):
    """Each upper-leg capsule's axis runs from hip pitch to knee (URDF geometry)."""
    p, R = robot.visual_poses(np.zeros(3), np.array([0, 0, 0, 1.0]), HOME_POSE)
    uppers = [i for i, v in enumerate(robot.visuals) if v.kind == "capsule"
              and v.link.endswith("upper_leg")]
    for i in uppers:
        axis = R[i][:, 2]
        ends = p[i] + np.outer([-0.5, 0.5], axis) * 0.0751
        leg = robot.visuals[i].link.replace("_upper_leg", "")
        k = ["front_left", "front_right", "back_left", "back_right"].index(leg)
        q = HOME_POSE.reshape(4, 3)[k]
        hip = np.array([0.101 if k < 2 else -0.101, 0.03625 if k % 2 == 0 else -0.03625, 0.0])
        hip_pitch = hip + np.array([0, 0.0236 if k % 2 == 0 else -0.0236, 0])
        # the hip roll turns the pitch joint about x
        c, s = np.cos(q[0]), np.sin(q[0])
        hip_pitch = hip + np.array([0, c * (hip_pitch - hip)[1], s * (hip_pitch - hip)[1]])
        assert min(np.linalg.norm(ends - hip_pitch, axis=1)) < 1e-12


def test_matrix_to_wxyz_round_trip():
    rot = Rotation.random(200, random_state=3)
    wxyz = matrix_to_wxyz(rot.as_matrix())
    back = Rotation.from_quat(np.column_stack([wxyz[:, 1:], wxyz[:, 0]]))
    np.testing.assert_allclose(back.as_matrix(), rot.as_matrix(), atol=1e-12)


def test_bad_urdf_is_one_clear_error(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot><link name='a'/><joint name='j' type='revolute'><parent link='a'/>"
                   "<child link='b'/><origin xyz='0 0 nope'/></joint></robot>")
    with pytest.raises(ValueError, match=r"bad\.urdf.*origin xyz"):
        load_robot(bad)
    (tmp_path / "trunc.urdf").write_text("<robot><link")
    with pytest.raises(ValueError, match="cannot read the URDF"):
        load_robot(tmp_path / "trunc.urdf")


def test_ellipse_is_the_two_sigma_contour():
    cov = np.diag([0.03 ** 2, 0.01 ** 2])
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    pts = ellipse_points(np.array([1.0, 2.0]), R @ cov @ R.T)
    local = (pts - [1.0, 2.0]) @ R              # back to the principal axes
    np.testing.assert_allclose((local[:, 0] / 0.06) ** 2 + (local[:, 1] / 0.02) ** 2, 1.0,
                               atol=1e-9)
    assert ellipse_points(np.zeros(2), np.array([[1.0, 0], [0, -1.0]])) is None
    assert ellipse_points(np.zeros(2), np.full((2, 2), np.nan)) is None


def test_specs():
    from littledog_mlsim.viewer.live import parse_specs

    a, b, c = parse_specs(["learned=40", "pybullet=41/ns", "/robot1"])
    assert (a.label, a.domain, a.namespace) == ("learned", 40, "")
    assert (b.label, b.domain, b.topic("/littledog/odom")) == ("pybullet", 41,
                                                                "/ns/littledog/odom")
    assert (c.label, c.namespace) == ("robot1", "/robot1")
    for bad in (["x=1 2"], ["a=500"], ["a=1", "a=2"]):
        with pytest.raises(ValueError):
            parse_specs(bad)


def test_tracks_and_comparison():
    rec = make_recording(n=60)
    m = measured_track(rec)
    assert len(m) == 59 and m.t[0] == pytest.approx(2 * CONTROL_DT)
    np.testing.assert_array_equal(m.position, rec.position[2:])
    shifted = Track("b", m.t, m.position + [0.03, 0.04, 0.0], m.orientation, m.q + 0.1)
    np.testing.assert_allclose(xy_gap(shifted, m), 0.05)
    np.testing.assert_allclose(joint_errors(shifted, m), 0.1)
    with pytest.raises(ValueError, match="position has shape"):
        Track("bad", m.t, m.position[:-1], m.orientation, m.q)


def test_learned_track_is_sim_nodes_stepping():
    """learned_track == LearnedSimulator stepped by hand (as sim_node does) for an LR model."""
    from littledog_mlsim.data.dataset import features_responses
    from littledog_mlsim.models.lr import LinearRegression
    from littledog_mlsim.models.onestep import OneStepModel
    from littledog_mlsim.rollout.simulate import prepare_test_move, rollout
    from littledog_mlsim.viewer.tracks import learned_track

    recs = [make_recording(f"F_{i:02d}", n=80, seed=i) for i in range(3)]
    X, Y, _ = features_responses(recs)
    model = OneStepModel.fit(LinearRegression(), X, Y)
    tr = learned_track(recs[0], model, "none")
    tm = prepare_test_move(recs[0])
    states = rollout(model, tm.s0, tm.actions)
    np.testing.assert_allclose(tr.q, states[:, 9:21], atol=1e-9)
    np.testing.assert_allclose(tr.position[:, 2], states[:, 0], atol=1e-9)
    assert tr.cov_xy is not None and np.all(np.diff(tr.cov_xy[:, 0, 0]) >= -1e-15)


def test_live_messages(monkeypatch):
    """Complete states need joint states and odometry of one stamp; bad messages are counted."""
    from littledog_mlsim.nodes.messages import joint_state_msg, odometry_msg
    from littledog_mlsim.viewer.live import SimSpec, _Robot

    r = _Robot(SimSpec("a", 0, ""))
    q = HOME_POSE.copy()
    cov = np.zeros(36)
    cov[0], cov[7], cov[1], cov[6] = 4e-4, 1e-4, 5e-5, 5e-5
    r.on_joint_states(joint_state_msg(10_000_000, q, q * 0))
    assert r.latest is None
    r.on_odom(odometry_msg(10_000_000, [1, 2, 0.15], [0, 0, 0, 1], [0] * 3, [0] * 3, cov))
    assert r.latest is not None and r.latest.t == pytest.approx(0.01)
    np.testing.assert_allclose(r.latest.cov_xy, [[4e-4, 5e-5], [5e-5, 1e-4]])
    bad = joint_state_msg(20_000_000, q)
    bad.position = [float("nan")] * 12
    r.on_joint_states(bad)
    worse = joint_state_msg(20_000_000, q)
    worse.name = ["x"] * 12
    r.on_joint_states(worse)
    r.on_odom(odometry_msg(20_000_000, [float("inf"), 0, 0], [0, 0, 0, 1], [0] * 3, [0] * 3))
    assert r.bad == 3 and r.latest.t == pytest.approx(0.01)
    r.on_odom(odometry_msg(30_000_000, [1.1, 2, 0.15], [0, 0, 0, 1], [0] * 3, [0] * 3))
    r.on_joint_states(joint_state_msg(30_000_000, q))
    assert r.latest.t == pytest.approx(0.03) and r.latest.cov_xy is None
    assert list(r.stamps) == [10_000_000, 30_000_000]


def test_live_received_counts_complete_states():
    """``received`` (behind ``LiveSource.received``/``ready``) counts complete states only: not a
    lone half, not a bad message, not a repeated stamp; a restart (stamps going back) clears
    the history but the count keeps growing."""
    from littledog_mlsim.nodes.messages import joint_state_msg, odometry_msg
    from littledog_mlsim.viewer.live import SimSpec, _Robot

    r = _Robot(SimSpec("a", 0, ""))
    q = HOME_POSE.copy()

    def odom(ns: int, x: float = 0.0):
        return odometry_msg(ns, [x, 0, 0.15], [0, 0, 0, 1], [0] * 3, [0] * 3)

    assert r.received == 0
    r.on_joint_states(joint_state_msg(10_000_000, q))
    assert r.received == 0                       # half a state
    r.on_odom(odom(10_000_000))
    assert r.received == 1
    r.on_odom(odom(20_000_000, float("nan")))    # bad: the state cannot complete
    r.on_joint_states(joint_state_msg(20_000_000, q))
    assert r.received == 1
    r.on_joint_states(joint_state_msg(10_000_000, q))
    r.on_odom(odom(10_000_000))                  # the same stamp again
    assert r.received == 1
    for ns in (0, 30_000_000):                   # back to 0: a restarted simulator
        r.on_joint_states(joint_state_msg(ns, q))
        r.on_odom(odom(ns))
    assert r.received == 3 and list(r.stamps) == [0, 30_000_000]


def _closed_and_outward(verts: np.ndarray, faces: np.ndarray) -> float:
    """Check a mesh is closed (after merging vertices at equal positions every edge has two
    faces, in opposite directions) and return its signed volume (> 0: outward faces)."""
    v = verts.astype(np.float64)
    _, ids = np.unique(np.round(v, 9), axis=0, return_inverse=True)
    f = ids.reshape(-1)[faces]
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    fwd = {tuple(e) for e in edges}
    assert len(fwd) == len(edges), "an edge is used twice in the same direction"
    assert all((b, a) in fwd for a, b in fwd), "an edge has only one face (a hole)"
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    assert np.all(np.linalg.norm(np.cross(b - a, c - a), axis=1) > 1e-12), "degenerate face"
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def test_primitive_meshes_are_closed_outward_and_on_their_shapes():
    from littledog_mlsim.viewer.meshes import shape_mesh

    r, L = 0.02, 0.09
    cases = {
        ("box", (0.33, 0.11, 0.14)): 0.33 * 0.11 * 0.14,
        ("sphere", (r,)): 4 / 3 * np.pi * r ** 3,
        ("capsule", (r, L)): np.pi * r ** 2 * L + 4 / 3 * np.pi * r ** 3,
        ("cylinder", (r, L)): np.pi * r ** 2 * L,
    }
    for (kind, size), volume in cases.items():
        verts, faces = shape_mesh(kind, size)
        assert verts.dtype == np.float32 and faces.dtype == np.uint32
        vol = _closed_and_outward(verts, faces)
        # inscribed polyhedra: a little smaller than the shape, never larger
        assert 0.9 * volume < vol <= volume * (1 + 1e-6), (kind, vol, volume)
        v = verts.astype(np.float64)
        if kind == "box":
            np.testing.assert_allclose(np.abs(v), np.broadcast_to(np.array(size) / 2, v.shape),
                                       rtol=1e-6)
        elif kind == "sphere":
            np.testing.assert_allclose(np.linalg.norm(v, axis=1), r, rtol=1e-6)
        elif kind == "capsule":      # distance to the axis segment is the radius
            z = np.clip(v[:, 2], -L / 2, L / 2)
            d = np.linalg.norm(v - np.column_stack([0 * z, 0 * z, z]), axis=1)
            np.testing.assert_allclose(d, r, rtol=1e-5)
        else:
            rho = np.linalg.norm(v[:, :2], axis=1)
            on_side = np.isclose(rho, r, rtol=1e-5)
            on_cap = np.isclose(np.abs(v[:, 2]), L / 2, rtol=1e-5) & (rho <= r * (1 + 1e-5))
            assert np.all(on_side | on_cap)
    with pytest.raises(ValueError, match="no mesh for shape 'cone'"):
        shape_mesh("cone", (1.0,))


def test_view_physics_takes_a_name_a_twin_file_or_a_robot_config_file(tmp_path, monkeypatch):
    """``view --physics`` resolves its robot as every other place that takes one
    (``robot_config_from``): a robot name, a twin file or a robot config file, the robot handed
    to the physics track; anything else is one ``--physics`` error before any replay."""
    import argparse
    from dataclasses import replace

    from littledog_mlsim.robot.baseline import save_robot_config
    from littledog_mlsim.robot.config import robot_config
    from littledog_mlsim.robot.twin import Twin, save_twin
    from littledog_mlsim.viewer import app, tracks

    class Rec:
        name = "F_01"

    seen = []
    monkeypatch.setattr(tracks, "load_recording", lambda bag, data, move: Rec())
    monkeypatch.setattr(tracks, "measured_track", lambda rec, label: label)
    monkeypatch.setattr(tracks, "physics_track", lambda rec, config, label: seen.append(config))
    heavier = replace(robot_config("nominal"), body_mass=2.5)
    twin = save_twin(Twin(heavier, {}), tmp_path / "twin.json")
    conf = tmp_path / "conf.json"
    save_robot_config(heavier, conf)

    def plan(physics):
        a = argparse.Namespace(model=None, data=tmp_path, move="F_01", projection=None,
                               alpha=None, radius=None, rollout=None, bag=None, physics=physics)
        labels, run = app._replay_plan(a)
        run()
        return labels

    assert plan("nominal") == ["measured", "physics (nominal)"]
    assert plan(str(twin)) == ["measured", "physics (twin)"]
    assert plan(str(conf)) == ["measured", "physics (conf)"]
    assert seen == [robot_config("nominal"), heavier, heavier]
    for bad in ("nomnal", str(tmp_path / "missing.json")):
        with pytest.raises(app.ViewError, match="--physics"):
            plan(bad)
    (tmp_path / "junk.json").write_text("{")
    with pytest.raises(app.ViewError, match="junk.json"):
        plan(str(tmp_path / "junk.json"))
