"""End to end on a small recorded dataset: train -> evaluate / rollout -> reproduce --scale small."""
from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from littledog_mlsim.cli import main
from littledog_mlsim.layout import STATE_NAMES

CLI = [sys.executable, "-m", "littledog_mlsim.cli"]


@pytest.fixture(scope="module")
def data(small_dataset: Path) -> Path:
    return small_dataset


@pytest.fixture(scope="module")
def lr_model(data: Path, tmp_path_factory) -> Path:
    model = tmp_path_factory.mktemp("m") / "lr"
    proc = subprocess.run([*CLI, "train", "--data", str(data), "--method", "lr", "--out", str(model)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return model


def test_evaluate_writes_metrics_per_state_and_rollouts(lr_model: Path, data: Path, tmp_path: Path):
    assert main(["evaluate", "--model", str(lr_model), "--data", str(data), "--out", str(tmp_path)]) == 0
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert list(m["nmse"]) == list(STATE_NAMES)
    assert all(v is None or v >= 0 for v in m["nmse"].values())
    assert m["n_samples"] == 3 * 399                    # one TestPool move per type
    # the default alpha-PROJ is gated with the model's own radius (its 0.9 quantile)
    assert set(m["rollout"]) == {"none", "bound", "alpha_0.5_q0.9"}
    for v in m["rollout"].values():
        assert v["final_xy_error_m"] is not None and v["final_xy_error_m"] >= 0


def test_rollout_json_has_the_contract_keys(lr_model: Path, data: Path, tmp_path: Path):
    assert main(["rollout", "--model", str(lr_model), "--data", str(data), "--projection", "alpha",
                 "--alpha", "0.25", "--out", str(tmp_path)]) == 0
    r = json.loads((tmp_path / "rollout.json").read_text())
    assert {"final_xy_error_m", "xy_error_vs_time", "per_move"} <= set(r)
    assert len(r["per_move"]) == 3
    finals = [p["final_xy_error_m"] for p in r["per_move"]]
    assert r["final_xy_error_m"] == pytest.approx(sum(finals) / 3)


def test_bad_alpha_and_missing_model_are_one_line(lr_model: Path, data: Path, tmp_path: Path, capsys):
    with pytest.raises(SystemExit):
        main(["rollout", "--model", str(lr_model), "--data", str(data), "--alpha", "1.5", "--out", str(tmp_path)])
    assert main(["evaluate", "--model", str(tmp_path / "nope"), "--data", str(data), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "nope" in err[-1]


def test_reproduce_small_writes_table1_and_figures(data: Path, tmp_path: Path):
    out = tmp_path / "rep"
    proc = subprocess.run([*CLI, "reproduce", "--data", str(data), "--out", str(out), "--scale", "small"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with open(out / "table1.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["method"] for r in rows] == ["lr", "lwpr", "gpr", "sor", "lgpr"]
    assert list(rows[0])[:1 + len(STATE_NAMES)] == ["method", *STATE_NAMES]
    for r in rows:
        assert 0 <= float(r["nmse_mean"]) < 2 and float(r["fit_s"]) >= 0 and float(r["peak_rss_mb"]) > 0
    for name in ("table1.md", "fig4.png", "fig5.png", "fig6.png", "fig5_6_mean.png", "fig7.png",
                 "fig5_6_mean_by_method.png", "fig_projection_by_method.png", "rollouts.md",
                 "rollouts.json"):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "rollouts.json").read_text())
    assert summary["method"] == "lgpr"
    assert summary["projections"]["none"]["n_nan_moves"] == 0
    # every trained model is rolled out with every projection, with its drift from the TrainPool
    labels = ["none", "BOUND", "alpha-PROJ 0.25", "alpha-PROJ 0.5", "alpha-PROJ 0.75",
              "alpha-PROJ 1"]
    assert list(summary["by_method"]) == ["lgpr", "sor", "gpr", "lwpr", "lr"]
    for method, rollouts in summary["by_method"].items():
        assert list(rollouts) == labels, method
        for label, r in rollouts.items():
            assert r["final_xy_error_m"] >= 0 and r["n_nan_moves"] == 0, (method, label)
            d = r["drift_nn_distance_median"]["step399"]
            assert d >= 0, (method, label)
        # alpha-PROJ 1 replaces each state by a TrainPool state: no distance left
        assert rollouts["alpha-PROJ 1"]["drift_nn_distance_median"]["step399"] == 0.0
    assert summary["by_method"]["lgpr"] == summary["projections"]
    report = (out / "rollouts.md").read_text()
    assert all(f"| {m.upper()} |" in report for m in summary["by_method"])
