"""The one experiment pipeline: fit_onestep (models/train.py) and score_model (scoring.py).

Checked against what they replace or rely on, computed independently here: the model fitted by
hand (OneStepModel.fit on the same rows), the one-step nMSE from the raw predictions, a rollout
with the same projection through rollout_metrics, and the diagnosis' own recipe
(diagnose.run.fit_report_model / score_on_test), which the pipeline is meant to serve as well.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from synthetic import make_recording

from littledog_mlsim.diagnose import measured_robot_features
from littledog_mlsim.diagnose.run import fit_report_model, score_on_test
from littledog_mlsim.layout import STATE_NAMES
from littledog_mlsim.models import OneStepModel, fit_onestep, make_estimator
from littledog_mlsim.models.features import FeatureSet
from littledog_mlsim.models.train import subset_rows, training_arrays
from littledog_mlsim.rollout.metrics import rollout_metrics
from littledog_mlsim.rollout.simulate import prepare_test_moves, rollout_moves
from littledog_mlsim.scoring import RolloutSpec, one_step_scores, rollout_scores, score_model


@pytest.fixture(scope="module")
def moves():
    train = [make_recording(f"{t}_0{i}", n=90, yaw0=2.9 - i, yaw_rate=0.6 + 0.3 * i, seed=i)
             for i, t in enumerate(["F", "FL", "BL", "S"])]
    test = [make_recording(f"{t}_1{i}", n=60, yaw0=1.0 + i, yaw_rate=0.5, seed=10 + i)
            for i, t in enumerate(["F", "BL"])]
    return train, test


def test_fit_onestep_is_the_hand_recipe(moves):
    train, _ = moves
    X, Y = training_arrays(train)
    rows = subset_rows(X.shape[0], 200, 3)
    assert rows.size == 200 and np.all(np.diff(rows) > 0)
    model = fit_onestep(train, "lwpr", options={"init_D": 0.5}, random_state=3, n_train=200,
                        info={"tag": "x"})
    ref = OneStepModel.fit(make_estimator("lwpr", {"init_D": 0.5}, random_state=3),
                           X[rows], Y[rows], train_states=Y)
    np.testing.assert_array_equal(model.predict(X[:50]), ref.predict(X[:50]))
    np.testing.assert_array_equal(model.train_states, Y)          # projection data: all rows
    assert model.info["tag"] == "x" and model.info["n_train"] == 200
    assert model.info["n_train_pool"] == X.shape[0] and model.info["seed"] == 3
    # arrays in, the same model out
    again = fit_onestep((X, Y), "lwpr", options={"init_D": 0.5}, random_state=3, n_train=200)
    np.testing.assert_array_equal(again.predict(X[:50]), model.predict(X[:50]))
    with pytest.raises(ValueError, match="target"):
        fit_onestep(train, "lr", target="sideways")


def test_score_model_against_its_parts(moves):
    train, test = moves
    model = fit_onestep(train, "lr")
    specs = [RolloutSpec("none"), RolloutSpec("alpha", 0.25)]
    res = score_model(model, test, specs)
    json.dumps(res, allow_nan=False)                                # JSON-ready as it is
    X, Y = training_arrays(test)
    err = ((model.predict(X) - Y) ** 2).mean(axis=0) / Y.var(axis=0)
    assert list(res["nmse"]) == list(STATE_NAMES) and res["n_samples"] == X.shape[0]
    for name, e in zip(STATE_NAMES, err):
        assert res["nmse"][name] == pytest.approx(e, rel=1e-12)
    assert res["nmse_mean"] == pytest.approx(np.mean(err), rel=1e-12)
    assert set(res["rollout"]) == {"none", "alpha_0.25"}
    tm = prepare_test_moves(test)
    proj = model.projection("alpha", alpha=0.25)
    ref = rollout_metrics(tm, rollout_moves(model, tm, proj), projection=proj)
    got = res["rollout"]["alpha_0.25"]
    assert got["final_xy_error_m"] == ref["final_xy_error_m"]
    assert got["per_move"] == ref["per_move"]
    assert got["projection"] == "alpha" and got["alpha"] == 0.25 and got["method"] == "lr"
    assert res["rollout"]["none"]["alpha"] is None
    # the parts alone give the same numbers
    assert one_step_scores(model, (X, Y))["nmse"] == res["nmse"]
    full, preds = rollout_scores(model, tm, specs[1:], keep_predictions=True)
    assert full["alpha_0.25"]["final_xy_error_m"] == got["final_xy_error_m"]
    assert len(preds["alpha_0.25"]) == len(tm)


def test_pipeline_serves_the_diagnosis(moves):
    """fit_onestep + score_model give the diagnosis' numbers for a model with added features."""
    train, test = moves
    fs: FeatureSet = measured_robot_features()
    ours = fit_onestep(train, "lr", feature_set=fs, random_state=0)
    theirs = fit_report_model(fs, "lr", None, train, seed=0)
    X, _ = training_arrays(test, fs)
    np.testing.assert_array_equal(ours.predict(X), theirs.predict(X))
    a = score_model(ours, test, [RolloutSpec("alpha", 0.5)])
    b = score_on_test(theirs, test, ("alpha",), 0.5)
    assert a["nmse"] == b["nmse"] and a["nmse_mean"] == b["nmse_mean"]
    for key in ("final_xy_error_m", "final_xy_error_m_median", "n_nan_moves",
                "element_error_sum_mean", "nmse_at_horizon"):
        assert a["rollout"]["alpha_0.5"][key] == b["rollout"]["alpha_0.5"][key], key
    assert (a["rollout"]["alpha_0.5"]["xy_error_vs_time"]["mean"]
            == b["rollout"]["alpha_0.5"]["xy_error_vs_time_mean"])
