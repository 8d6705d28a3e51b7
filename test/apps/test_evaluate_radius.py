"""``rollout``/``evaluate`` with the gated alpha-PROJ (``--radius``, ``--radius-quantile``)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from littledog_mlsim.cli import main
from littledog_mlsim.data.dataset import features_responses, load_moves
from littledog_mlsim.apps.evaluate import projection_label, trainpool_radius
from littledog_mlsim.models.onestep import OneStepModel
from littledog_mlsim.models.train import train_from_dataset
from littledog_mlsim.projection import leave_move_out_distances


@pytest.fixture(scope="module")
def data(small_dataset: Path) -> Path:
    return small_dataset


@pytest.fixture(scope="module")
def lr_model(data: Path, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("m") / "lr"
    train_from_dataset(data, "lr", progress=False).save(path)
    return path


def _rollout(args: list[str], out: Path) -> dict:
    assert main(["rollout", *args, "--out", str(out)]) == 0
    return json.loads((out / "rollout.json").read_text())


def test_labels():
    assert projection_label("alpha", 0.5) == "alpha_0.5"
    assert projection_label("alpha", 0.5, 1.25) == "alpha_0.5_r1.25"
    assert projection_label("alpha", 0.5, 1.25, 0.9) == "alpha_0.5_q0.9"
    assert projection_label("bound", 0.5, 1.25, 0.9) == "bound"


def test_radius_options_in_rollout(lr_model: Path, data: Path, tmp_path: Path):
    base = ["--model", str(lr_model), "--data", str(data), "--projection", "alpha",
            "--alpha", "0.5"]
    plain = _rollout([*base, "--radius", "0"], tmp_path / "plain")
    zero = _rollout([*base, "--radius", "0.0"], tmp_path / "zero")
    assert "radius" not in plain and "radius" not in zero
    assert zero["final_xy_error_m"] == plain["final_xy_error_m"]
    # the default: the model's own radius, stored at training (quantile 0.9, every 4th state)
    default = _rollout(base, tmp_path / "default")
    gate = OneStepModel.load(lr_model).gate
    assert default["radius"] == gate["radius"] > 0 and default["radius_quantile"] == 0.9
    # a radius beyond every distance: the rollout of no projection, exactly
    none = _rollout([*base[:-4], "--projection", "none"], tmp_path / "none")
    huge = _rollout([*base, "--radius", "1e9"], tmp_path / "huge")
    assert huge["radius"] == 1e9
    assert [m["final_xy_error_m"] for m in huge["per_move"]] == \
        [m["final_xy_error_m"] for m in none["per_move"]]
    # the quantile: that of the TrainPool's leave-move-out distances
    q = _rollout([*base, "--radius-quantile", "0.9"], tmp_path / "q")
    _, Y, groups = features_responses(load_moves(data, split="train"))
    d = leave_move_out_distances(Y, groups, every=4)
    assert q["radius_quantile"] == 0.9
    assert q["radius"] == pytest.approx(float(np.quantile(d, 0.9)), rel=1e-12)
    assert q["radius"] == trainpool_radius(OneStepModel.load(lr_model), data, 0.9)
    assert q["radius"] == default["radius"]            # the stored radius is that quantile


def test_radius_options_in_evaluate_and_errors(lr_model: Path, data: Path, tmp_path: Path,
                                               capsys):
    assert main(["evaluate", "--model", str(lr_model), "--data", str(data), "--out",
                 str(tmp_path), "--projections", "none,alpha", "--radius", "0.7"]) == 0
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert set(m["rollout"]) == {"none", "alpha_0.5_r0.7"}
    assert m["rollout"]["alpha_0.5_r0.7"]["radius"] == 0.7
    assert "radius" not in m["rollout"]["none"]
    assert (tmp_path / "rollout_alpha_0.5_r0.7.json").is_file()
    with pytest.raises(SystemExit):                       # exclusive options
        main(["rollout", "--model", str(lr_model), "--data", str(data), "--radius", "1",
              "--radius-quantile", "0.5", "--out", str(tmp_path)])
    with pytest.raises(SystemExit):
        main(["rollout", "--model", str(lr_model), "--data", str(data), "--radius", "-1",
              "--out", str(tmp_path)])
    assert main(["rollout", "--model", str(lr_model), "--data", str(data), "--projection",
                 "bound", "--radius", "1", "--out", str(tmp_path)]) == 2
    assert "alpha only" in capsys.readouterr().err
