"""Recording datasets end to end: the record/info verbs, bags read by plain rosbags, atomicity.

Moves are checked on what was written to disk (read back from the bags), not on the simulator's
in-memory output.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.highlevel import AnyReader

from littledog_mlsim.cli import main
from littledog_mlsim.data.dataset import load_moves, read_index
from littledog_mlsim.data.summary import move_problems, summarise_dataset
from littledog_mlsim.layout import MOVE_TYPES, STEPS_PER_MOVE, TOPIC_CMD, TOPIC_JOINT_STATES, TOPIC_ODOM
from littledog_mlsim.apps.record import MoveJob, record_dataset

CONTRACT_TYPES = {TOPIC_CMD: "sensor_msgs/msg/JointState",
                  TOPIC_JOINT_STATES: "sensor_msgs/msg/JointState",
                  TOPIC_ODOM: "nav_msgs/msg/Odometry"}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    """Two moves of every type on the measured robot through the CLI, as a user would."""
    out = tmp_path_factory.mktemp("rec") / "ds"
    proc = subprocess.run([sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
                           "--moves-per-type", "2", "--quiet"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "recorded 22 bags" in proc.stdout
    return out


def test_cli_records_22_bags_that_rosbags_reads(dataset: Path):
    bags = sorted(p for p in dataset.iterdir() if p.is_dir())
    assert len(bags) == 22
    assert {b.name for b in bags} == {f"{t}_{i:02d}" for t in MOVE_TYPES for i in range(2)}
    for bag in bags:
        with AnyReader([bag]) as reader:
            types = {c.topic: c.msgtype for c in reader.connections}
            assert {t: types.get(t) for t in CONTRACT_TYPES} == CONTRACT_TYPES
            counts = {c.topic: c.msgcount for c in reader.connections}
            assert counts[TOPIC_JOINT_STATES] == counts[TOPIC_ODOM] == STEPS_PER_MOVE + 1
            assert counts[TOPIC_CMD] == STEPS_PER_MOVE
    assert not list(dataset.parent.glob(".*partial*"))


def test_dataset_yaml_split_and_no_effects(dataset: Path):
    index = read_index(dataset)
    splits = {(e.move_type, e.split) for e in index.entries}
    assert splits == {(t, s) for t in MOVE_TYPES for s in ("train", "test")}
    assert "effect" not in (dataset / "dataset.yaml").read_text().lower()


def test_every_recorded_move_is_upright_and_goes_where_named(dataset: Path):
    moves = load_moves(dataset, split="all")
    assert len(moves) == 22
    for rec in moves:
        assert move_problems(rec) == [], rec.name
    summary = summarise_dataset(dataset)
    assert summary.n_samples == 22 * (STEPS_PER_MOVE - 1)


def test_moves_of_a_type_differ_and_seeds_are_stable():
    a, b = MoveJob("F", 0, 0).seeds(), MoveJob("F", 1, 0).seeds()
    assert a != b and MoveJob("F", 0, 0).seeds() == a and MoveJob("F", 0, 1).seeds() != a


def test_same_seed_same_bags_and_sqlite3(tmp_path: Path, dataset: Path):
    record_dataset(tmp_path / "sq", moves_per_type=1, types=["FL"], storage="sqlite3", jobs=1,
                   progress=False)
    assert list((tmp_path / "sq" / "FL_00").glob("*.db3"))
    again = load_moves(tmp_path / "sq", split="all")[0]
    first = [m for m in load_moves(dataset, split="all") if m.name == "FL_00"][0]
    # same seed -> same move, any storage, however many moves per type are recorded (the
    # diagnosis tests record only the TrainPool moves they read)
    np.testing.assert_array_equal(again.q, first.q)
    np.testing.assert_array_equal(again.position, first.position)


def test_refuses_to_overwrite_and_overwrites_on_request(tmp_path: Path, capsys):
    out = tmp_path / "ds"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    assert main(["record", "--out", str(out), "--moves-per-type", "1", "--types", "S", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "already exists" in err and len(err.strip().splitlines()) == 1
    assert (out / "keep.txt").read_text() == "precious"
    assert main(["record", "--out", str(out), "--moves-per-type", "1", "--types", "S", "--quiet",
                 "--overwrite", "--jobs", "1"]) == 0
    assert not (out / "keep.txt").exists() and (out / "S_00").is_dir()


def test_failed_run_leaves_nothing_behind(tmp_path: Path, capsys):
    """An effect that raises in the middle of a move: no partial bag, no dataset, one-line error."""
    (tmp_path / "bad.py").write_text(
        "class Boom:\n"
        "    def command(self, u, t):\n"
        "        if t > 1.0:\n"
        "            raise RuntimeError('actuator exploded')\n"
        "        return u\n")
    (tmp_path / "fx.yaml").write_text(yaml.safe_dump([{"class": "bad.py:Boom", "params": {}}]))
    out = tmp_path / "ds"
    with pytest.raises(RuntimeError, match="actuator exploded"):
        record_dataset(out, moves_per_type=1, types=["F", "S"], effects_file=str(tmp_path / "fx.yaml"),
                       jobs=2, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.py", "fx.yaml"]


def test_bad_move_type_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["record", "--out", "X", "--types", "F,Q"])
    assert exc.value.code == 2
    assert "unknown move type(s) Q" in capsys.readouterr().err


@pytest.mark.parametrize("argv, fragment", [
    (["record", "--out", "X", "--moves-per-type", "0"], "at least 1"),
    (["record", "--out", "X", "--effects", "missing.yaml"], "missing.yaml"),
    (["record", "--out", "X", "--excitation", "0.5"], "--excitation"),
    (["record", "--out", "X", "--start-spread", "nan"], "--start-spread"),
    (["record", "--out", "X", "--start-spread", "-1"], "--start-spread"),
    (["record", "--out", "X", "--warmup", "-1"], "--warmup"),
    (["record", "--out", "X", "--warmup", "0.005"], "--warmup"),
    (["record", "--out", "X", "--warmup", "nan"], "--warmup"),
    (["info", "--data", "/nonexistent/ds"], "/nonexistent/ds"),
])
def test_bad_input_gives_one_line_and_writes_nothing(tmp_path: Path, argv, fragment, capsys,
                                                    monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert fragment in err and len(err.splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("effects", sorted((Path(__file__).parents[2] / "config" / "effects").glob("*.yaml")),
                         ids=lambda p: p.stem)
def test_shipped_effect_files_change_the_data_but_leave_no_trace(tmp_path: Path, dataset: Path, effects):
    out = tmp_path / "fx"
    record_dataset(out, moves_per_type=1, types=["F"], effects_file=str(effects), jobs=1, progress=False)
    with_fx = load_moves(out, split="all")[0]
    clean = [m for m in load_moves(dataset, split="all") if m.name == "F_00"][0]
    np.testing.assert_array_equal(with_fx.cmd, clean.cmd)            # same commands sent
    assert np.abs(with_fx.q - clean.q).max() > 1e-3                 # the robot answered differently
    text = (out / "dataset.yaml").read_text().lower()
    assert "effect" not in text and effects.stem not in text


def test_integrating_recorded_states_reproduces_odometry_of_a_noise_free_bag(tmp_path: Path):
    """pybullet move without motion-capture noise -> bag -> states -> integrated path == odometry."""
    import dataclasses

    from littledog_mlsim.data.bags import read_bag, write_bag
    from littledog_mlsim.data.dataset import initial_pose, integrate_path, quat_to_rpy, states_from_recording
    from littledog_mlsim.gait.trot import sample_trot_params, trot_commands
    from littledog_mlsim.robot.sim import robot_config, simulate_move

    quiet = dataclasses.replace(robot_config("measured"), sensor_noise=False)
    cmd = trot_commands(sample_trot_params("BL", np.random.default_rng(5)))
    write_bag(tmp_path / "BL_00", simulate_move(cmd, robot=quiet, seed=5, name="BL_00", move_type="BL"))
    rec = read_bag(tmp_path / "BL_00")
    path = integrate_path(states_from_recording(rec), *initial_pose(rec, 0))
    np.testing.assert_allclose(path[:, :2], rec.position[1:, :2], rtol=0, atol=1e-9)
    yaw_err = np.angle(np.exp(1j * (path[:, 2] - quat_to_rpy(rec.orientation[1:])[:, 2])))
    assert np.abs(yaw_err).max() < 1e-9


def test_excitation_changes_the_recorded_commands_and_is_noted(tmp_path: Path, dataset: Path):
    out = tmp_path / "exc"
    assert main(["record", "--out", str(out), "--moves-per-type", "1", "--types", "F",
                 "--excitation", "0.03", "--jobs", "1", "--quiet"]) == 0
    excited = load_moves(out, split="all")[0]
    plain = [m for m in load_moves(dataset, split="all") if m.name == "F_00"][0]
    noise = excited.cmd - plain.cmd                   # same gait parameters, plus the noise
    assert 0.02 < noise.std() < 0.035
    assert move_problems(excited) == []               # still a trot that goes forward
    assert read_index(out).info["command_excitation_rad"] == 0.03
    assert "command_excitation_rad" not in read_index(dataset).info


def test_start_spread_starts_each_move_at_its_own_place_and_heading(tmp_path: Path,
                                                                    dataset: Path):
    """``--start-spread``: the same commands, each move from its own place (within the spread in
    x and y) and heading; the move still goes where its type says in its own frame, and
    dataset.yaml notes the spread."""
    from littledog_mlsim.data.dataset import quat_to_rpy
    out = tmp_path / "spread"
    assert main(["record", "--out", str(out), "--moves-per-type", "2", "--types", "F,L",
                 "--start-spread", "0.5", "--jobs", "1", "--quiet"]) == 0
    spread = load_moves(out, split="all")
    plain = {m.name: m for m in load_moves(dataset, split="all")}
    starts = np.array([m.position[0, :2] for m in spread])
    yaws = np.array([quat_to_rpy(m.orientation[:1])[0, 2] for m in spread])
    home = plain["F_00"].position[0, :2]
    assert np.all(np.abs(starts - home) <= 0.5 + 0.01), starts
    assert np.ptp(starts[:, 0]) > 0.1 and np.ptp(starts[:, 1]) > 0.1, starts
    assert np.ptp(np.unwrap(yaws)) > 0.5, yaws
    for m in spread:
        np.testing.assert_array_equal(m.cmd, plain[m.name].cmd)
        assert move_problems(m) == [], m.name       # upright, and goes where its type says
    assert read_index(out).info["start_spread_m"] == 0.5
    assert "start_spread_m" not in read_index(dataset).info


def test_warmup_starts_each_move_from_a_settled_gait(tmp_path: Path, dataset: Path):
    """``--warmup``: each move walked 2 s before the 4 s its bag keeps (stamps from zero): it
    starts walking, away from where the plain move starts standing, still goes where its type
    says, and dataset.yaml notes the warm-up."""
    out = tmp_path / "warm"
    assert main(["record", "--out", str(out), "--moves-per-type", "2", "--types", "F",
                 "--warmup", "2", "--jobs", "1", "--quiet"]) == 0
    warm = load_moves(out, split="all")
    plain = {m.name: m for m in load_moves(dataset, split="all")}
    for m in warm:
        p = plain[m.name]
        assert m.n_steps == STEPS_PER_MOVE and m.stamps_ns[0] == 0
        moving, standing = np.abs(m.dq[:20]).mean(), np.abs(p.dq[:20]).mean()
        assert moving > 3 * standing, (moving, standing)
        assert m.position[0, 0] - p.position[0, 0] > 0.05          # walked forward 2 s
        assert move_problems(m) == [], m.name
    assert read_index(out).info["warmup_s"] == 2.0
    assert "warmup_s" not in read_index(dataset).info


def test_start_spread_on_a_tilted_floor_stands_on_the_floor_where_it_starts(tmp_path: Path,
                                                                             dataset: Path):
    """``--start-spread`` with a floor tilted about the origin (``GroundTilt``): each move
    starts at its own place as high above the floor under it as the plain move at the origin
    (it neither starts inside the floor nor drops onto it)."""
    from littledog_mlsim.robot.effects import GroundTilt
    tilt = tmp_path / "tilt.yaml"
    tilt.write_text("- class: littledog_mlsim.robot.effects:GroundTilt\n"
                    "  params: {slope_deg: 8.0, uphill_direction_deg: 0.0}\n")
    out = tmp_path / "tilt_spread"
    record_dataset(out, moves_per_type=3, types=["F"], seed=4, effects_file=str(tilt),
                   start_spread=0.5, jobs=1, progress=False)
    plain = [m for m in load_moves(dataset, split="all") if m.name == "F_00"][0]
    clearance = plain.position[0, 2]
    xs = []
    for m in load_moves(out, split="all"):
        x0, z = m.position[0, 0], m.position[:, 2]
        floor = x0 * np.tan(np.radians(8.0))              # uphill toward +x, through the origin
        xs.append(x0)
        assert abs(z[0] - floor - clearance) < 0.01, (m.name, x0, z[0], floor)
        assert z[:50].min() - floor > clearance - 0.03, (m.name, z[:50].min(), floor)
    assert np.ptp(xs) > 0.1, xs
    assert GroundTilt(8.0).origin_xy.tolist() == [0.0, 0.0]


def test_extra_moves_go_to_the_trainpool_and_leave_the_plain_moves_alone(tmp_path: Path,
                                                                        dataset: Path):
    out = tmp_path / "extra"
    assert main(["record", "--out", str(out), "--moves-per-type", "2", "--types", "F,L",
                 "--extra", "switch=1", "--extra", "velocity=1", "--extra", "trot=1",
                 "--jobs", "2", "--quiet"]) == 0
    index = read_index(out)
    assert index.info["extra_moves"] == {"trot": ["F_02", "L_02"], "switch": ["F_03", "L_03"],
                                         "velocity": ["U_00"]}
    split = {e.name: e.split for e in index.entries}
    assert [n for n, s in split.items() if s == "test"] == ["F_01", "L_01"]
    moves = {m.name: m for m in load_moves(out, split="all")}
    plain = {m.name: m for m in load_moves(dataset, split="all")}
    for name in ("F_00", "F_01", "L_00", "L_01"):                   # the plain moves: unchanged
        np.testing.assert_array_equal(moves[name].q, plain[name].q)
    assert moves["U_00"].move_type == "U"
    assert min(moves[n].position[:, 2].min() for n in ("F_03", "L_03", "U_00")) > 0.1  # upright
    assert not np.array_equal(moves["F_03"].cmd, moves["F_02"].cmd)
    assert MoveJob("F", 3, 0, "switch").seeds() != MoveJob("F", 3, 0).seeds()


def test_the_moves_of_one_extra_kind_do_not_depend_on_another_kinds_count():
    from littledog_mlsim.apps.record import plan_jobs
    alone = {(j.kind, j.move_type): j.seeds() for j in plan_jobs(2, ["F"], 0, {"switch": 1,
                                                                              "waypoints": 1})
             if j.kind != "trot"}
    more = {(j.kind, j.move_type): j.seeds() for j in plan_jobs(2, ["F"], 0, {
        "trot": 3, "switch": 1, "velocity": 2, "waypoints": 1}) if j.kind in ("switch",
                                                                            "waypoints")}
    assert more == alone


@pytest.mark.parametrize("arg", ["bogus=1", "switch=-1", "switch", "velocity=x", "switch=\u00b2"])
def test_a_bad_extra_is_a_usage_error(arg, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["record", "--out", "X", "--extra", arg])
    assert exc.value.code == 2
    assert "expected KIND=N" in capsys.readouterr().err


def test_an_extra_kind_given_twice_is_one_line(tmp_path: Path, capsys):
    assert main(["record", "--out", str(tmp_path / "x"), "--extra", "switch=1",
                 "--extra", "switch=2"]) == 2
    err = capsys.readouterr().err.strip()
    assert "switch more than once" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "x").exists()


def test_the_workers_end_with_a_killed_recording(tmp_path: Path):
    """A record killed outright (SIGKILL: a test runner's clean-up, the OOM killer) takes its
    worker processes with it: none is left waiting on a parent that is gone."""
    import os
    import signal
    import time
    out = tmp_path / "ds"
    p = subprocess.Popen([sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
                          "--moves-per-type", "20", "--jobs", "2", "--quiet"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while not any(tmp_path.glob("*/*/*.mcap")):
            assert p.poll() is None and time.monotonic() < deadline, "no move was recorded"
            time.sleep(0.05)
        p.kill()                                  # the parent only
        p.wait()
        deadline = time.monotonic() + 20
        while True:
            try:
                os.killpg(p.pid, 0)               # a worker is still in the group
            except ProcessLookupError:
                break
            assert time.monotonic() < deadline, "a recording worker outlived its killed parent"
            time.sleep(0.05)
    finally:
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
