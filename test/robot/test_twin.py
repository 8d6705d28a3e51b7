"""Twin files (littledog_mlsim.robot.twin): round trip, one-line errors, and every place that
takes a robot name taking a twin file instead (record, import, pybullet_node's parameter).

Independent reference for "the twin was used": the recorded move is compared with
``simulate_move`` of the same commands on the RobotConfig the test built by hand, and with the
stock robot it was derived from (which must differ).
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from inprocess import cli

from littledog_mlsim.apps.record import MoveJob, record_dataset
from littledog_mlsim.data.dataset import load_moves, read_index
from littledog_mlsim.robot.baseline import save_robot_config
from littledog_mlsim.robot.config import config_to_dict, robot_config
from littledog_mlsim.robot.sim import simulate_move
from littledog_mlsim.robot.twin import (Twin, load_twin, robot_config_from, robot_source,
                                        save_twin)

HEAVY = dataclasses.replace(robot_config("nominal"), name="heavy-nominal", mass_scale=1.15,
                            torque_limit=(1.7, 1.7, 0.8))


@pytest.fixture(scope="module")
def twin_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("twin") / "twin.json"
    save_twin(Twin(HEAVY, {"note": "hand-made for the tests"}), path)
    return path


def test_round_trip_names_and_robot_config_files(twin_file, tmp_path):
    twin = load_twin(twin_file)
    assert twin.robot == HEAVY and twin.provenance == {"note": "hand-made for the tests"}
    assert robot_config_from(twin_file) == HEAVY
    assert robot_config_from(str(twin_file)) == HEAVY
    assert robot_config_from("measured") == robot_config("measured")
    assert robot_config_from(HEAVY) is HEAVY
    # a baseline robot config file (the tuned nominal's format) is a twin as well
    save_robot_config(HEAVY, tmp_path / "cfg.json", extra={"tuning": {}})
    assert robot_config_from(tmp_path / "cfg.json") == HEAVY
    doc = json.loads(twin_file.read_text())
    assert doc["format"] == "littledog_mlsim.twin" and doc["format_version"] == 1
    assert doc["robot"] == json.loads(json.dumps(config_to_dict(HEAVY)))


def _write(path: Path, doc) -> Path:
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return path


@pytest.mark.parametrize("case, fragment", [
    ("missing", "no such file"),
    ("truncated", "not valid JSON"),
    ("version", "unsupported format_version 2"),
    ("other", "not a robot twin file"),
    ("unknown", "unknown RobotConfig field(s): ['warp_drive']"),
    ("typed", "RobotConfig field 'torque_limit' must be 3 finite numbers"),
    ("negative", "RobotConfig field 'mass_scale' must be > 0"),
    ("directory", "is a directory"),
])
def test_bad_twin_files_are_one_line_naming_the_file(twin_file, tmp_path, case, fragment):
    good = json.loads(twin_file.read_text())
    path = tmp_path / f"{case}.json"
    if case == "truncated":
        _write(path, twin_file.read_text()[:200])
    elif case == "version":
        _write(path, {**good, "format_version": 2})
    elif case == "other":
        _write(path, {"format": "littledog_mlsim.model", "format_version": 1})
    elif case == "unknown":
        _write(path, {**good, "robot": {**good["robot"], "warp_drive": 9}})
    elif case == "typed":
        _write(path, {**good, "robot": {**good["robot"], "torque_limit": [1.7, "x", 1]}})
    elif case == "negative":
        _write(path, {**good, "robot": {**good["robot"], "mass_scale": -1.0}})
    elif case == "directory":
        path.mkdir()
    with pytest.raises(ValueError) as e:
        robot_config_from(path)
    msg = str(e.value)
    assert "\n" not in msg and fragment in msg and str(path) in msg, msg


def test_unknown_name_and_failed_save_keeps_the_good_file(twin_file, tmp_path):
    with pytest.raises(ValueError, match="unknown robot 'measurd': not one of measured, nominal"):
        robot_config_from("measurd")
    target = tmp_path / "t.json"
    save_twin(Twin(HEAVY), target)
    before = target.read_bytes()
    with pytest.raises(ValueError):   # NaN is not JSON: refused before anything is written
        save_twin(Twin(HEAVY, {"ci95": [float("nan"), 1.0]}), target)
    assert target.read_bytes() == before and sorted(tmp_path.iterdir()) == [target]


def test_robot_source_never_passes_a_twin_off_as_a_stock_robot(twin_file, tmp_path):
    assert robot_source("nominal") == {"robot": "nominal"}
    src = robot_source(twin_file)
    assert src["robot"] == "heavy-nominal" and src["twin"] == str(twin_file.resolve())
    assert src["robot_config"]["mass_scale"] == 1.15
    renamed = tmp_path / "n.json"
    save_twin(Twin(dataclasses.replace(HEAVY, name="nominal")), renamed)
    assert robot_source(renamed)["robot"] == "nominal-twin"


@pytest.fixture(scope="module")
def twin_dataset(tmp_path_factory, twin_file) -> Path:
    out = tmp_path_factory.mktemp("rec") / "ds"
    record_dataset(out, moves_per_type=1, types=["F"], robot=str(twin_file), jobs=1,
                   progress=False)
    return out


def test_record_runs_the_twin(twin_dataset, twin_file):
    info = read_index(twin_dataset).info
    assert info["robot"] == "heavy-nominal" and info["twin"] == str(twin_file.resolve())
    rec = load_moves(twin_dataset, "train")[0]
    seed = MoveJob("F", 0, 0).seeds()[1]
    same = simulate_move(rec.cmd, robot=HEAVY, seed=seed, name="F_00", move_type="F")
    stock = simulate_move(rec.cmd, robot="nominal", seed=seed, name="F_00", move_type="F")
    np.testing.assert_allclose(rec.q, same.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.position, same.position, rtol=0, atol=1e-9)
    assert np.abs(rec.q - stock.q).max() > 1e-3


def test_cli_record_and_import_take_a_twin(twin_dataset, twin_file, tmp_path, capsys):
    p = cli(capsys, "record", "--out", str(tmp_path / "bad"), "--moves-per-type", "1",
            "--types", "F", "--robot", str(tmp_path / "nope.json"), "--quiet")
    assert p.returncode == 2 and "no such file" in p.stderr and len(p.stderr.splitlines()) == 1
    assert not (tmp_path / "bad").exists()
    out = tmp_path / "imported"
    p = cli(capsys, "import", str(twin_dataset / "F_00"), "--out", str(out), "--twin",
            str(twin_file), "--move-type", "F", "--test-fraction", "0", "--no-figure")
    assert p.returncode == 0, p.stderr
    info = read_index(out).info
    assert info["robot"] == "heavy-nominal" and info["robot_config"]["mass_scale"] == 1.15
    p = cli(capsys, "import", str(twin_dataset / "F_00"), "--out", str(tmp_path / "i2"),
            "--robot", "nominal", "--move-type", "F", "--test-fraction", "0", "--no-figure")
    assert p.returncode == 0 and read_index(tmp_path / "i2").info["robot"] == "nominal"
    p = cli(capsys, "import", str(twin_dataset / "F_00"), "--out", str(tmp_path / "i3"),
            "--twin", "nominal", "--move-type", "F", "--no-figure")
    assert p.returncode == 2 and "twin file nominal: no such file" in p.stderr
    assert not (tmp_path / "i3").exists()


def test_pybullet_node_robot_parameter_takes_a_twin(twin_file, tmp_path):
    pytest.importorskip("rclpy")
    from littledog_mlsim.nodes._run import StartupError
    from littledog_mlsim.nodes.pybullet_node import robot_from_parameter

    assert robot_from_parameter(str(twin_file)) == HEAVY
    assert robot_from_parameter("measured") == robot_config("measured")
    with pytest.raises(StartupError, match=r"parameter robot: twin file .*nope.json: no such"):
        robot_from_parameter(str(tmp_path / "nope.json"))
    with pytest.raises(StartupError, match="parameter robot: unknown robot 'x'"):
        robot_from_parameter("x")


def test_a_twin_with_a_command_delay_records_and_replays_it(tmp_path):
    """``command_delay_ms`` is part of the robot: the recorder applies it as the SetpointDelay
    plug-in would, and a replay (from measured states, with the recorded commands) applies it
    to the commands sent before its start, so the twin re-simulates its own recording and the
    same twin without the delay does not."""
    from littledog_mlsim.gait.trot import sample_trot_params, trot_commands
    from littledog_mlsim.robot.baseline import k_step_predictions, physics_rollout
    from littledog_mlsim.robot.effects import SetpointDelay
    from littledog_mlsim.rollout.simulate import prepare_test_move

    late = dataclasses.replace(robot_config("nominal"), name="late", command_delay_ms=15.0)
    save_twin(Twin(late), tmp_path / "late.json")
    assert robot_config_from(tmp_path / "late.json") == late
    params = dataclasses.replace(sample_trot_params("L", np.random.default_rng(3)), n_steps=150)
    cmd = trot_commands(params)
    rec = simulate_move(cmd, robot=late, seed=1, name="L_00", move_type="L")
    plugin = simulate_move(cmd, robot="nominal", effects=[SetpointDelay(15.0)], seed=1,
                           name="L_00", move_type="L")
    np.testing.assert_array_equal(rec.q, plugin.q)
    np.testing.assert_array_equal(rec.cmd, cmd)          # the commands as sent
    states = prepare_test_move(rec).states
    q = slice(9, 21)
    err = {d: np.sqrt(np.mean((physics_rollout(rec, dataclasses.replace(late, command_delay_ms=d))
                               [:, q] - states[:, q]) ** 2)) for d in (15.0, 0.0)}
    assert err[15.0] < 0.1 * err[0.0], err
    _, true, pred = k_step_predictions(rec, late, 1, stride=7)
    _, _, pred0 = k_step_predictions(rec, dataclasses.replace(late, command_delay_ms=0.0), 1,
                                     stride=7)
    one = {"late": np.abs(pred - true)[..., q].mean(), "none": np.abs(pred0 - true)[..., q].mean()}
    assert one["late"] < 0.2 * one["none"], one
