"""Data as Demonstrator (``models.dad``, ``train --dad``): the pairs, the refit, the refusals."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from littledog_mlsim.cli import main
from littledog_mlsim.data.dataset import features_responses, load_moves
from littledog_mlsim.models.dad import dad_pairs
from littledog_mlsim.models.feature_library import CommandIncrement
from littledog_mlsim.models.features import FeatureSet
from littledog_mlsim.models.onestep import OneStepModel
from littledog_mlsim.models.train import train_from_dataset
from littledog_mlsim.rollout.simulate import prepare_test_moves, rollout_moves


def test_pairs_are_the_models_own_states_with_the_recorded_commands_and_next_states(
        small_dataset: Path):
    moves = load_moves(small_dataset, split="train")
    model = train_from_dataset(small_dataset, "lr", progress=False)
    X, Y, g = dad_pairs(model, moves)
    tm = prepare_test_moves(moves)
    preds = rollout_moves(model, tm, model.projection("alpha", alpha=0.5,
                                                      radius=model.gate_radius()[0]))
    i = 1
    rows = g == i
    np.testing.assert_array_equal(X[rows, :33], preds[i][:-1])          # s^_2 .. s^_{N-1}
    np.testing.assert_array_equal(X[rows, 33:], tm[i].actions[1:])      # u_2 .. u_{N-1}
    np.testing.assert_array_equal(Y[rows], tm[i].states[1:])            # s_3 .. s_N
    assert not np.array_equal(X[rows, :33], tm[i].states[:-1])          # predictions, not data


def test_a_dad_round_refits_on_both_and_keeps_the_recorded_states_for_the_projection(
        small_dataset: Path):
    base = train_from_dataset(small_dataset, "lr", progress=False)
    dad = train_from_dataset(small_dataset, "lr", progress=False, dad_rounds=1)
    _, Y, _ = features_responses(load_moves(small_dataset, split="train"))
    np.testing.assert_array_equal(dad.train_states, Y)
    assert dad.gate == base.gate
    info = dad.info["dad"]
    assert info["rounds"] == 1 and info["n_recorded"] == Y.shape[0]
    assert dad.info["n_train"] == Y.shape[0] + info["pairs_added"][0]
    x = np.hstack([Y[:3], np.zeros((3, 12))])
    assert not np.allclose(dad.predict(x), base.predict(x))


def test_dad_refuses_inputs_with_a_history_and_bad_rounds(small_dataset: Path, tmp_path, capsys):
    fs = FeatureSet((CommandIncrement(lag=0, joints="all"),))
    with pytest.raises(ValueError, match="paper's inputs only"):
        train_from_dataset(small_dataset, "lr", progress=False, feature_set=fs, dad_rounds=1)
    with pytest.raises(ValueError, match="dad_rounds"):
        train_from_dataset(small_dataset, "lr", progress=False, dad_rounds=-1)
    assert main(["train", "--data", str(small_dataset), "--method", "lr", "--out",
                 str(tmp_path / "m"), "--dad", "-1"]) == 2
    assert "--dad" in capsys.readouterr().err and not (tmp_path / "m").exists()
    assert main(["train", "--data", str(small_dataset), "--method", "lr", "--out",
                 str(tmp_path / "m"), "--dad", "1", "--features", "measured"]) == 2
    assert "drop --features measured" in capsys.readouterr().err


def test_train_dad_on_the_command_line(small_dataset: Path, tmp_path, capsys):
    out = tmp_path / "m"
    assert main(["train", "--data", str(small_dataset), "--method", "lr", "--out", str(out),
                 "--dad", "1", "--quiet"]) == 0
    assert "1 DaD round(s) adding" in capsys.readouterr().out
    assert OneStepModel.load(out).info["dad"]["rounds"] == 1


def test_moves_too_short_for_a_pair_are_left_out(small_dataset: Path):
    from dataclasses import fields, replace
    moves = load_moves(small_dataset, split="train")
    model = train_from_dataset(small_dataset, "lr", progress=False)
    per_step = {f.name for f in fields(moves[0])} - {"name", "move_type"}
    short = replace(moves[0], **{k: getattr(moves[0], k)[:3] for k in per_step
                                 if k != "cmd"}, cmd=moves[0].cmd[:2])   # 2 steps
    X, _, g = dad_pairs(model, [short, *moves[1:]])
    X2, _, _ = dad_pairs(model, moves[1:])
    np.testing.assert_array_equal(X, X2)
    with pytest.raises(ValueError, match="at least 3 steps"):
        dad_pairs(model, [short])
