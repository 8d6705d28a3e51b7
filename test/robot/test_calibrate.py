"""Physics diagnosis (littledog_mlsim.robot.calibrate) on data with a known missing effect.

Independent reference: the "measured" moves are recorded by the noise-free nominal robot with a
2-step :class:`CommandDelay` (the effect plug-in the recorder uses, not the command shift the
diagnosis replays with); the diagnosis starts from the same nominal robot without the delay and
must name the delay, estimate 2 steps, cut the TestPool error, and then find nothing more.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from littledog_mlsim.robot.baseline import physics_rollout
from littledog_mlsim.robot.calibrate import (PhysicsModel, diagnose_physics, evaluate_model,
                                             shifted_recording)
from littledog_mlsim.gait.trot import sample_trot_params, trot_commands
from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.effects import CommandDelay
from littledog_mlsim.robot.sim import simulate_move

DELAY = 2
N_STEPS = 200
TRAIN_TYPES = ("F", "B", "L", "R", "FL", "BR", "DL", "DR")
TEST_TYPES = ("F", "L", "BL", "DR")


def _moves(types, seed0: int):
    recs = []
    for i, t in enumerate(types):
        params = dataclasses.replace(sample_trot_params(t, np.random.default_rng(seed0 + i)),
                                     n_steps=N_STEPS)
        recs.append(simulate_move(trot_commands(params), robot=robot_config("nominal"),
                                  effects=[CommandDelay(DELAY)], move_type=t, name=f"{t}_00",
                                  seed=seed0 + i))
    return recs


@pytest.fixture(scope="module")
def delayed_data():
    return _moves(TRAIN_TYPES, 100), _moves(TEST_TYPES, 200)


def test_finds_and_calibrates_command_delay(delayed_data):
    train, test = delayed_data
    rep = diagnose_physics(train, test, robot_config("nominal"), stride=20, test_stride=20,
                           params=("command_delay", "coulomb_friction"), max_rounds=2,
                           n_folds=2, jobs=1)
    found = rep["found"]
    assert len(found) == 1 and found[0]["param"] == "command_delay"
    assert found[0]["screening_estimate"] == DELAY and found[0]["calibrated_value"] == DELAY
    assert found[0]["accepted"]
    # the delay shows in the joints it acts on
    assert any(e.startswith("q_") for e in found[0]["elements"])
    assert rep["final_model"]["command_delay"] == DELAY
    # with the delay calibrated nothing material is left (friction would only hurt here)
    assert rep["stopped"] == "no material candidate in round 2"
    assert rep["rounds"][1]["found"] is None
    before, after = rep["test"][0], rep["test"][1]
    q_before = np.mean([v for k, v in before["one_step_nmse"].items() if k.startswith("q_")])
    q_after = np.mean([v for k, v in after["one_step_nmse"].items() if k.startswith("q_")])
    assert q_after < 0.2 * q_before
    assert after["final_xy_error_m"] < before["final_xy_error_m"]


def test_delay_replay_matches_recorder_effect(delayed_data):
    """The command shift the diagnosis replays with is the recorder's CommandDelay."""
    train, _ = delayed_data
    rec = train[0]
    s_shift = physics_rollout(shifted_recording(rec, DELAY), robot_config("nominal"))
    s_plain = physics_rollout(rec, robot_config("nominal"))
    truth = evaluate_model([rec], PhysicsModel(robot_config("nominal"), command_delay=DELAY),
                           stride=50, jobs=1)
    from littledog_mlsim.rollout.metrics import rollout_metrics
    from littledog_mlsim.rollout.simulate import prepare_test_move
    states = prepare_test_move(rec).states
    err_shift = np.sqrt(np.mean((s_shift[:, 9:21] - states[:, 9:21]) ** 2))
    err_plain = np.sqrt(np.mean((s_plain[:, 9:21] - states[:, 9:21]) ** 2))
    assert err_shift < 0.1 * err_plain
    assert truth["final_xy_error_m"] == pytest.approx(
        rollout_metrics([prepare_test_move(rec)], [s_shift])["final_xy_error_m"])
    # joint friction rides along as an effect: same scorer, a different robot
    rubbing = evaluate_model([rec], PhysicsModel(robot_config("nominal"), command_delay=DELAY,
                                                 coulomb_friction=0.1), stride=50, jobs=1)
    assert np.isfinite(rubbing["final_xy_error_m"])
    assert rubbing["one_step_nmse"] != truth["one_step_nmse"]


def test_bad_input():
    cfg = robot_config("nominal")
    with pytest.raises(ValueError, match="unknown physics parameter 'servo_magic'"):
        diagnose_physics([], [], cfg, params=("command_delay", "servo_magic"))
    with pytest.raises(ValueError, match="TrainPool"):
        diagnose_physics([], [], cfg)
