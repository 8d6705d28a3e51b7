"""The gated alpha-PROJ's default radius in the model file (``OneStepModel.gate``)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from littledog_mlsim.models.lr import LinearRegression
from littledog_mlsim.models.onestep import OneStepModel
from littledog_mlsim.models.persistence import ModelError
from littledog_mlsim.projection import gate_radius, leave_move_out_distances


def _model(n_moves: int = 4, per_move: int = 30, info: dict | None = None) -> OneStepModel:
    rng = np.random.default_rng(0)
    # each move a random walk of its own, so the leave-move-out distances are not trivial
    Y = np.cumsum(rng.normal(size=(n_moves * per_move, 33)) * 0.1, axis=0)
    Y[:, 3:5] = np.clip(Y[:, 3:5], -1, 1)
    Y[:, 9:21] = 0.0                                  # joint angles inside every limit
    X = np.hstack([Y, rng.normal(size=(Y.shape[0], 12)) * 0.01])
    return OneStepModel.fit(LinearRegression(), X, Y, info=info)


def test_gate_is_the_quantile_of_leave_move_out_distances():
    m = _model()
    groups = np.repeat(np.arange(4), 30)
    g = gate_radius(m.train_states, groups)
    d = leave_move_out_distances(m.train_states, groups, every=4)
    assert g["radius"] == float(np.quantile(d, 0.9)) and g["n_queries"] == d.size


def test_gate_round_trips_through_the_model_file(tmp_path):
    m = _model()
    m.gate = gate_radius(m.train_states, np.repeat(np.arange(4), 30))
    m.save(tmp_path / "m")
    meta = json.loads((tmp_path / "m" / "model.json").read_text())["meta"]
    assert meta["gate"]["radius"] == m.gate["radius"]
    back = OneStepModel.load(tmp_path / "m")
    assert back.gate == m.gate
    r, how = back.gate_radius()
    assert r == m.gate["radius"] and "stored in the model" in how


def test_model_without_gate_computes_it_on_load_or_turns_it_off(tmp_path):
    m = _model(info={"n_moves": 4, "n_train_pool": 120})
    m.save(tmp_path / "old")                           # no gate: a file written before the key
    assert "gate" not in json.loads((tmp_path / "old" / "model.json").read_text())["meta"]
    old = OneStepModel.load(tmp_path / "old")
    r, how = old.gate_radius(every_on_load=2)
    d = leave_move_out_distances(old.train_states, np.repeat(np.arange(4), 30), every=2)
    assert r == float(np.quantile(d, 0.9)) and "computed on load" in how
    r0, how0 = _model().gate_radius()                  # moves unknown: gate off
    assert r0 == 0.0 and "plain alpha-PROJ" in how0


def test_bad_gate_in_the_file_is_a_model_error(tmp_path):
    m = _model()
    m.gate = {"radius": 1.0, "quantile": 0.9}
    m.save(tmp_path / "m")
    path = tmp_path / "m" / "model.json"
    doc = json.loads(path.read_text())
    doc["meta"]["gate"]["radius"] = -1.0
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelError, match="gate radius"):
        OneStepModel.load(tmp_path / "m")
