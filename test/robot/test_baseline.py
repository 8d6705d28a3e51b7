"""Physics baseline (littledog_mlsim.robot.baseline) and the side-by-side animation (animate).

Independent references: the recording itself (a replay by the robot that recorded it, from its
own noise-free measurements, must reproduce it; a one-step shift must not pass the same
tolerance), the recorded odometry (the animated measured pose must be it), the objective
recomputed from ``rollout_metrics`` and the recorded joint angles, and a dataset whose TestPool
bags do not exist (tuning would fail if it read them).
"""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from PIL import Image

from littledog_mlsim.apps.animate import animate_move, panel_poses
from littledog_mlsim.robot.baseline import (
    config_from_dict, config_to_dict, evaluate_baseline, load_robot_config, physics_rollout,
    physics_rollouts, save_robot_config, tune_nominal, tuning_moves,
)
from littledog_mlsim.data.bags import write_bag
from littledog_mlsim.data.dataset import load_moves, write_index
from littledog_mlsim.data.recording import MoveRecording
from littledog_mlsim.gait.trot import sample_trot_params, trot_commands
from littledog_mlsim.layout import STATE_NAMES, S
from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.sim import simulate_move
from littledog_mlsim.rollout.metrics import rollout_metrics
from littledog_mlsim.rollout.simulate import prepare_test_move


def quiet(name: str) -> object:
    return dataclasses.replace(robot_config(name), sensor_noise=False)


def window(rec: MoveRecording, a: int, b: int, name: str | None = None) -> MoveRecording:
    """Measurements a..b and commands a..b-1 of a recording (a shorter move, already walking)."""
    return MoveRecording(name=name or rec.name, move_type=rec.move_type,
                         stamps_ns=rec.stamps_ns[a:b + 1] - rec.stamps_ns[a], cmd=rec.cmd[a:b],
                         q=rec.q[a:b + 1], dq=rec.dq[a:b + 1], position=rec.position[a:b + 1],
                         orientation=rec.orientation[a:b + 1],
                         linear_velocity=rec.linear_velocity[a:b + 1],
                         angular_velocity=rec.angular_velocity[a:b + 1])


def trot(move_type: str, seed: int, robot, n: int = 160, noise_seed: int = 0) -> MoveRecording:
    params = dataclasses.replace(sample_trot_params(move_type, np.random.default_rng(seed)),
                                 n_steps=n)
    return simulate_move(trot_commands(params), robot=robot, move_type=move_type,
                         name=f"{move_type}_00", seed=noise_seed)


@pytest.fixture(scope="module")
def quiet_fl() -> MoveRecording:
    """1 s of a noise-free measured-robot FL trot, cut from mid-move (t = 0.6..1.6 s)."""
    return window(trot("FL", 3, quiet("measured")), 60, 160, "FL_00")


# ----------------------------------------------------------------------------- alignment
def test_measured_replay_reproduces_noise_free_recording(quiet_fl):
    move = prepare_test_move(quiet_fl)
    pred = physics_rollout(quiet_fl, robot_config("measured"))   # noise is switched off inside
    assert pred.shape == move.states.shape == (99, 33)
    q_err = np.sqrt(np.mean((pred[:, S.q] - move.states[:, S.q]) ** 2))
    # Not exact: the start state holds the 50 Hz-filtered joint rates and the finite-difference
    # body twist, not the true ones (measured here: 6e-4 rad RMS). An off-by-one alignment is
    # > 20x worse on this move (0.014 rad).
    shifted = np.sqrt(np.mean((pred[1:, S.q] - move.states[:-1, S.q]) ** 2))
    assert q_err < 1.5e-3
    assert shifted > 8 * q_err and shifted > 5e-3
    np.testing.assert_allclose(pred[:, S.d_b], move.states[:, S.d_b], atol=2e-4)
    np.testing.assert_allclose(pred[:, S.roll_pitch], move.states[:, S.roll_pitch], atol=3e-3)
    m = rollout_metrics([move], [pred])
    assert m["final_xy_error_m"] < 1e-3 and m["n_nan_moves"] == 0
    # deterministic, and the same through worker processes
    np.testing.assert_array_equal(physics_rollouts([quiet_fl], robot_config("measured"), jobs=1)[0],
                                  pred)


def test_nominal_replay_differs(quiet_fl):
    move = prepare_test_move(quiet_fl)
    pred = physics_rollout(quiet_fl, robot_config("nominal"))
    good = physics_rollout(quiet_fl, robot_config("measured"))
    m_nom, m_meas = rollout_metrics([move], [pred]), rollout_metrics([move], [good])
    assert m_nom["final_xy_error_m"] > 10 * m_meas["final_xy_error_m"]
    assert np.sqrt(np.mean((pred[:, S.q] - move.states[:, S.q]) ** 2)) > 0.01


def test_one_step_of_the_recording_robot_is_nearly_exact(quiet_fl):
    res = evaluate_baseline([quiet_fl], quiet("measured"), one_step_stride=7, jobs=1)
    assert res["one_step"]["n_samples"] == len(range(1, 100, 7))
    assert set(res["one_step_nmse"]) == set(STATE_NAMES)
    q_names = [n for n in STATE_NAMES if n.startswith("q_")]
    # measured here: max 0.025 (dz_b), q <= 7e-4; the nominal's q nMSE is 0.2-1.1
    assert max(res["one_step_nmse"].values()) < 0.05
    nom = evaluate_baseline([quiet_fl], robot_config("nominal"), one_step_stride=7, jobs=1)
    assert np.mean([nom["one_step_nmse"][n] for n in q_names]) > 50 * max(
        res["one_step_nmse"][n] for n in q_names)
    assert nom["final_xy_error_m"] > res["final_xy_error_m"]
    json.dumps(nom, allow_nan=False)


# ----------------------------------------------------------------------------- tuning
@pytest.fixture(scope="module")
def train_only_dataset(tmp_path_factory):
    """Two short TrainPool bags (F, L) and TestPool entries whose bags do not exist."""
    d = tmp_path_factory.mktemp("ds")
    entries = []
    for mt, seed in (("F", 1), ("L", 2)):
        rec = window(trot(mt, seed, "measured", n=140, noise_seed=seed), 40, 140)
        write_bag(d / f"{mt}_00", rec)
        entries += [{"name": f"{mt}_00", "move_type": mt, "split": "train"},
                    {"name": f"{mt}_01", "move_type": mt, "split": "test"}]
    write_index(d, entries, {"robot": "measured"})
    return d


def test_tuning_improves_objective_and_never_reads_testpool(train_only_dataset):
    with pytest.raises(Exception):      # the trap is armed: TestPool cannot be loaded
        load_moves(train_only_dataset, "test")
    recs = tuning_moves(train_only_dataset, per_type=1)
    assert [r.name for r in recs] == ["F_00", "L_00"]
    base = robot_config("nominal")
    tuned, rep = tune_nominal(recs, base, grid={"position_gain": (0.05,)}, budget=3, jobs=2)
    trail = rep["trail"]
    assert rep["moves"] == ["F_00", "L_00"] and len(trail) == rep["n_evals"] <= 3
    assert trail[0]["phase"] == "base" and trail[0]["position_gain"] == base.position_gain
    assert rep["best"]["objective"] < rep["base"]["objective"]
    assert tuned.name == "nominal-tuned" and tuned != base
    assert {f.name for f in dataclasses.fields(tuned)
            if getattr(tuned, f.name) != getattr(base, f.name)} <= {"name", *rep["params"]}
    # the reported objective, recomputed from rollout_metrics and the recorded joint angles
    moves = [prepare_test_move(r) for r in recs]
    for cfg, row in ((base, rep["base"]), (tuned, rep["best"])):
        pred = [physics_rollout(r, cfg) for r in recs]
        final = rollout_metrics(moves, pred)["final_xy_error_m"]
        q_rms = np.sqrt(np.mean([(p[:, S.q] - m.states[:, S.q]) ** 2 for p, m in zip(pred, moves)]))
        assert row["final_xy_error_m"] == pytest.approx(final, rel=1e-9)
        assert row["objective"] == pytest.approx(final / rep["D_ref_m"] + q_rms / rep["Q_ref_rad"],
                                                 rel=1e-9)


def test_tune_nominal_rejects_bad_arguments():
    with pytest.raises(ValueError, match="subset"):
        tune_nominal([object()], params=("kp",))
    with pytest.raises(ValueError, match="budget"):
        tune_nominal([object()], budget=0)
    with pytest.raises(ValueError, match="TrainPool"):
        tune_nominal([])


def test_robot_config_json_roundtrip(tmp_path):
    cfg = dataclasses.replace(robot_config("measured"), name="x", position_gain=0.123)
    assert config_from_dict(json.loads(json.dumps(config_to_dict(cfg)))) == cfg
    save_robot_config(cfg, tmp_path / "c.json", extra={"note": "hi"})
    assert load_robot_config(tmp_path / "c.json") == cfg
    (tmp_path / "bad.json").write_text('{"format": "littledog_mlsim.robot_config", '
                                       '"format_version": 1, "config": {"name": "n", "servo": '
                                       '"position", "colour": 1}}')
    with pytest.raises(ValueError, match="colour"):
        load_robot_config(tmp_path / "bad.json")
    (tmp_path / "other.json").write_text("{}")
    with pytest.raises(ValueError, match="not a robot config"):
        load_robot_config(tmp_path / "other.json")


# ----------------------------------------------------------------------------- animation
def test_measured_panel_pose_is_the_recorded_odometry(quiet_fl):
    poses = panel_poses(quiet_fl, prepare_test_move(quiet_fl).states)
    np.testing.assert_allclose(poses["position"], quiet_fl.position[2:], atol=1e-9)
    dots = np.abs(np.sum(poses["orientation"] * quiet_fl.orientation[2:], axis=1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-9)               # same rotation (q or -q)
    np.testing.assert_allclose(poses["q"], quiet_fl.q[2:])
    bad = prepare_test_move(quiet_fl).states.copy()
    bad[50:, S.z_w] = np.nan
    held = panel_poses(quiet_fl, bad)
    assert held["finite"].sum() == 50
    np.testing.assert_array_equal(held["position"][60], held["position"][49])


def test_animation_writes_gif_with_three_panels(quiet_fl, tmp_path):
    truth = prepare_test_move(quiet_fl).states
    physics = physics_rollout(quiet_fl, robot_config("nominal"))
    out = tmp_path / "move.gif"
    info = animate_move(quiet_fl, {"learned": truth, "physics": physics}, out, fps=25,
                        size=(96, 72))
    n_frames = len(range(0, truth.shape[0], 4))                  # 100 Hz states, 25 fps
    assert info["n_frames"] == n_frames and info["labels"] == ["measured", "learned", "physics"]
    with Image.open(out) as im:
        assert im.format == "GIF" and im.size == (3 * 96, 72) and im.n_frames == n_frames
        im.seek(n_frames // 2)
        frame = np.asarray(im.convert("RGB"))
    # every panel shows the robot: dark-blue leg pixels in each third of the image
    legs = (frame[..., 2] > 120) & (frame[..., 0] < 90) & (frame[..., 1] < 110)
    assert all(legs[:, i * 96:(i + 1) * 96].sum() > 10 for i in range(3))
    with pytest.raises(ValueError, match="shape"):
        animate_move(quiet_fl, {"bad": truth[:-1]}, tmp_path / "x.gif")
    with pytest.raises(ValueError, match="gif"):
        animate_move(quiet_fl, {}, tmp_path / "x.mp4")
