"""Faults survived: each test makes a fault happen and checks that nothing is lost.

- a simulator (sim_node, pybullet_node) killed with SIGKILL mid-run: a controller that keeps
  publishing notices it within a bound and neither hangs nor crashes; a restarted node serves
  again, its ``/clock`` from its start;
- ``littledog-mlsim train`` killed with SIGKILL while it writes a model (at a chosen point, by a
  hook in the child process, not by a timer): the previous model is intact and loads, and no
  half-written directory is left (the next write removes the killed writer's staging);
- a recorder killed mid-bag (an MCAP file without its summary, cut mid-chunk; a sqlite3 bag
  without ``metadata.yaml``): ``import`` recovers what is readable and reports what it dropped
  and why, or refuses in one line naming the file;
- a controller flooding ``/littledog/cmd`` as fast as it can (aiming at 10 kHz) with NaN in
  every tenth message, sim_node in lockstep: every good command makes its step, in order; the
  node answers a service call during the flood; ``~/stats`` counts what it refused;
- a full disk (an injected write that fails with ENOSPC) while writing a model or a dataset:
  one line naming the path, nothing half-written, the old one kept.
"""
from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from rosharness import ENV, Probe, Proc, Ros  # noqa: I001  (first: it sets the test domain)
from littledog_mlsim import fileio
from littledog_mlsim.cli import main as cli_main
from littledog_mlsim.data.dataset import features_responses, load_moves, read_index
from littledog_mlsim.layout import CONTROL_DT_NS
from littledog_mlsim.models.lr import LinearRegression
from littledog_mlsim.models.onestep import OneStepModel
from waiting import TIMEOUT, wait_until

# ---------------------------------------------------------------------------------------------
# fixtures


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("faults")


@pytest.fixture(scope="module")
def dataset(work) -> Path:
    """Three F moves recorded with pybullet (2 TrainPool, 1 TestPool)."""
    from littledog_mlsim.apps.record import record_dataset

    out = work / "data"
    record_dataset(out, moves_per_type=3, types=["F"], jobs=1, progress=False)
    return out


@pytest.fixture(scope="module")
def model_path(work, dataset) -> Path:
    X, Y, _ = features_responses(load_moves(dataset, split="train"))
    path = work / "lr_model"
    OneStepModel.fit(LinearRegression(), X, Y).save(path)
    return path


def snapshot(directory: Path) -> dict[str, bytes]:
    """Every file under ``directory`` (relative name -> bytes)."""
    return {str(p.relative_to(directory)): p.read_bytes()
            for p in sorted(directory.rglob("*")) if p.is_file()}


def staging_of(path: Path) -> list[str]:
    """The hidden siblings a writer of ``path`` stages in (``.NAME.*``)."""
    return sorted(p.name for p in path.parent.iterdir() if p.name.startswith(f".{path.name}."))


def cli(capsys, *args: str) -> tuple[int, str, str]:
    """``littledog-mlsim ARGS`` in this process: (exit status, stdout, stderr)."""
    capsys.readouterr()
    rc = cli_main(list(args))
    out = capsys.readouterr()
    return rc, out.out, out.err


# ---------------------------------------------------------------------------------------------
# train killed (SIGKILL) while writing a model


# The child runs the real CLI verb after replacing one file-system step with a hook that marks
# the point and blocks; the test kills it there (no timer races the write).
KILL_HOOKS = {
    # the npz half written, model.json not yet
    "mid_file": """
        real = fileio.write_synced
        def hook(path, data):
            if Path(path).name == "arrays.npz":
                with open(path, "wb") as f:
                    f.write(data[: len(data) // 2]); f.flush(); os.fsync(f.fileno())
                block()
            real(path, data)
        fileio.write_synced = hook
    """,
    # both files whole in the staging directory, not yet renamed into place
    "before_rename": """
        real = fileio.replace_directory
        def hook(tmp, path):
            block()
            real(tmp, path)
        fileio.replace_directory = hook
    """,
}

CHILD = """
import os, sys, time
from pathlib import Path
from littledog_mlsim import fileio
MARK = Path(sys.argv[1])
def block():
    MARK.write_text(str(os.getpid()))
    time.sleep(600)
{hook}
from {module} import main
sys.exit(main(sys.argv[2:]))
"""


def writer_args(writer: str, dataset: Path, out: Path) -> tuple[str, list[str]]:
    """(module with ``main``, its arguments) to train a next-state LR model on ``dataset``."""
    if writer == "train":
        return "littledog_mlsim.cli", ["train", "--data", str(dataset), "--method", "lr",
                                       "--target", "next", "--out", str(out), "--quiet"]
    return "littledog_mlsim.nodes.trainer_node", [
        "--ros-args", "-p", f"data:={dataset}", "-p", f"out:={out}", "-p", "method:=lr",
        "-p", "target:=next"]


@pytest.mark.parametrize("point,writer", [(p, "train") for p in KILL_HOOKS] + [
    pytest.param("mid_file", "trainer_node", marks=pytest.mark.slow)])
def test_train_killed_while_writing_keeps_the_old_model(work, dataset, model_path, point, writer,
                                                        capsys):
    out = work / f"model_{point}_{writer}"
    assert cli(capsys, "train", "--data", str(dataset), "--method", "lr", "--out", str(out),
               "--quiet")[0] == 0
    before = snapshot(out)
    old = OneStepModel.load(out)
    X, _, _ = features_responses(load_moves(dataset, split="test"))
    mark = work / f"mark_{point}_{writer}"
    mark.unlink(missing_ok=True)
    # a different model (next-state target), so a swapped-in new one would show
    module, args = writer_args(writer, dataset, out)
    code = CHILD.format(hook=textwrap.dedent(KILL_HOOKS[point]), module=module)
    p = subprocess.Popen([sys.executable, "-c", code, str(mark), *args],
                         env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        wait_until(lambda: mark.exists() or p.poll() is not None, timeout=120,
                   what=f"train to reach {point}")
        assert p.poll() is None, p.stderr.read().decode()
        p.send_signal(signal.SIGKILL)
    finally:
        if p.poll() is None:
            p.kill()
        p.wait(TIMEOUT)
        p.stderr.close()
    assert p.returncode == -signal.SIGKILL
    # the model at the path is the old one, whole, and loads and predicts as before
    assert snapshot(out) == before
    again = OneStepModel.load(out)
    assert again.target == old.target == "delta"
    np.testing.assert_array_equal(again.predict(X), old.predict(X))
    # the killed writer's staging directory is the only debris, beside (not at) the path
    debris = staging_of(out)
    assert len(debris) == 1 and debris[0].startswith(f".{out.name}.tmp-"), debris
    if point == "before_rename":     # it held the new model, whole
        assert (out.parent / debris[0] / "model.json").is_file()
    # the next write removes it and replaces the model
    assert cli(capsys, "train", "--data", str(dataset), "--method", "lr", "--target", "next",
               "--out", str(out), "--quiet")[0] == 0
    assert staging_of(out) == []
    assert OneStepModel.load(out).target == "next"


def test_a_live_writers_staging_is_never_removed(work):
    """Only a killed writer's staging directory is removed: one whose writer still runs (it
    holds its lock) is left alone, also by a concurrent writer of the same target."""
    target = work / "shared_target"
    with fileio.atomic_directory(target, replace=True, tag="partial") as tmp:
        (tmp / "a").write_text("x")
        assert fileio.remove_stale_staging(target, "partial") == []
        assert (tmp / "a").is_file()
        with fileio.atomic_directory(target, replace=True, tag="partial") as other:
            (other / "b").write_text("y")
            assert (tmp / "a").is_file()
    assert sorted(p.name for p in target.iterdir()) == ["a"]   # the last one to finish wins
    assert staging_of(target) == []


# ---------------------------------------------------------------------------------------------
# disk full (a write that fails with ENOSPC) while writing a model or a dataset


def _enospc(*_args, **_kw):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_disk_full_writing_a_model_keeps_the_old_one(work, dataset, model_path, capsys,
                                                    monkeypatch):
    out = work / "model_full"
    assert cli(capsys, "train", "--data", str(dataset), "--method", "lr", "--out", str(out),
               "--quiet")[0] == 0
    before = snapshot(out)
    real = fileio.write_synced
    written = []

    def half_then_full(path, data):      # the disk fills up part-way through the first file
        written.append(Path(path).name)
        with open(path, "wb") as f:
            f.write(data[: len(data) // 3])
        _enospc()
    monkeypatch.setattr(fileio, "write_synced", half_then_full)
    rc, stdout, err = cli(capsys, "train", "--data", str(dataset), "--method", "lr",
                          "--target", "next", "--out", str(out), "--quiet")
    monkeypatch.setattr(fileio, "write_synced", real)
    assert written == ["arrays.npz"]
    assert rc == 2 and stdout == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(out) in lines[0] and "No space left on device" in lines[0], lines[0]
    assert "previous one is kept" in lines[0]
    assert snapshot(out) == before and staging_of(out) == []
    assert OneStepModel.load(out).target == "delta"
    # a new path: nothing at all is left
    new = work / "model_full_new"
    monkeypatch.setattr(fileio, "write_synced", half_then_full)
    rc, _, err = cli(capsys, "train", "--data", str(dataset), "--method", "lr", "--out",
                     str(new), "--quiet")
    assert rc == 2 and len(err.strip().splitlines()) == 1 and str(new) in err
    assert "nothing was written there" in err
    assert not new.exists() and staging_of(new) == []


def test_write_failed_is_one_line_and_survives_a_process_pool():
    import pickle

    e = fileio.WriteFailed(errno.ENOSPC, Path("/d/m"), "No space left on device", True)
    back = pickle.loads(pickle.dumps(e))
    assert isinstance(back, OSError) and back.errno == errno.ENOSPC
    assert str(back) == str(e) == ("writing /d/m failed: No space left on device; the previous "
                                   "one is kept")


def test_disk_full_writing_a_dataset_keeps_the_old_one(work, dataset, capsys, monkeypatch):
    out = work / "data_full"
    assert cli(capsys, "record", "--out", str(out), "--moves-per-type", "1", "--types", "S",
               "--jobs", "1", "--quiet")[0] == 0
    before = snapshot(out)
    # the first fsync of the new dataset fails: its first bag's storage file did not fit
    calls = []

    def full(path):
        calls.append(str(path))
        _enospc()
    monkeypatch.setattr(fileio, "fsync_path", full)
    rc, stdout, err = cli(capsys, "record", "--out", str(out), "--moves-per-type", "1",
                          "--types", "F", "--jobs", "1", "--overwrite", "--quiet")
    monkeypatch.undo()
    assert calls, "the injected failure was never reached"
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(out) in lines[0] and "No space left on device" in lines[0], lines[0]
    assert snapshot(out) == before and staging_of(out) == []
    assert [e.name for e in read_index(out).entries] == ["S_00"]
    assert len(load_moves(out, "all")) == 1


# ---------------------------------------------------------------------------------------------
# the ROS side: one executor thread for the module, simulators one at a time


@pytest.fixture(scope="module")
def ros():
    r = Ros()
    yield r
    r.close()


@pytest.fixture(scope="module")
def test_move(dataset):
    from littledog_mlsim.rollout.simulate import prepare_test_move

    return prepare_test_move(load_moves(dataset, split="test")[0])


def children_of(pid: int) -> dict[int, str]:
    """The live child processes of ``pid`` (Linux /proc): pid -> command line."""
    out = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            kids = (task / "children").read_text().split()
        except OSError:
            continue
        for k in map(int, kids):
            try:
                out[k] = (Path(f"/proc/{k}/cmdline").read_bytes().replace(b"\0", b" ")
                          .decode(errors="replace"))
            except OSError:
                continue
    return out


def gone(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return True
    return state in ("Z", "X")


def lockstep_params(work: Path, name: str, node: str, extra: dict) -> Path:
    """A params file for ``node`` in lockstep (a file: arrays through -p are clumsy)."""
    f = work / f"{name}.yaml"
    f.write_text(json.dumps({node: {"ros__parameters": {
        "step_mode": "lockstep", "stats_period": 0.2, **extra}}}))
    return f


class Controller:
    """A controller in its own thread that publishes a command every 10 ms whatever happens,
    and a watchdog on the simulator's output: ``silent_for()`` is how long no joint state came."""

    def __init__(self, probe: Probe, commands: np.ndarray) -> None:
        self.probe, self.commands = probe, commands
        self.sent = 0
        self.errors: list[BaseException] = []
        self.hold = threading.Event()          # set: publish nothing (a controller's own pause)
        self.stop_ev = threading.Event()
        self.thread = threading.Thread(target=self._run, name="fault-controller", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        t = time.monotonic()
        while not self.stop_ev.wait(max(0.0, t - time.monotonic())):
            t += 0.01
            if self.hold.is_set():
                continue
            try:
                self.probe.send(self.commands[self.sent % len(self.commands)])
                self.sent += 1
            except BaseException as e:         # a controller that crashes would show here
                self.errors.append(e)
                return

    def last_js(self) -> float:
        """Receive time (monotonic) of the newest joint state, or -inf."""
        with self.probe.cond:
            return self.probe.js_received[-1] if self.probe.js_received else -np.inf

    def stop(self) -> None:
        self.stop_ev.set()
        self.thread.join(5)
        assert not self.thread.is_alive(), "the controller thread did not stop"


class WatchedProbe(Probe):
    """A :class:`Probe` that also notes when each joint state arrived (monotonic) and keeps a
    transient-local ``/clock`` subscription (a restarted node's history reaches it)."""

    def __init__(self, ros: Ros, sim: str) -> None:
        super().__init__(ros, sim=sim, light=True)
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock as ClockMsg

        self.js_received: list[float] = []
        latched = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                             reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.subs.append(self.node.create_subscription(ClockMsg, "/clock", self._clock, latched))

    def _js(self, msg, info):
        super()._js(msg, info)
        with self.cond:
            self.js_received.append(time.monotonic())


# s: how long without a joint state the controller calls the simulator silent (10 steps)
SILENT_S = 0.1
# s: the bound on noticing a killed simulator (generous for a loaded 2-core machine; it takes
# about SILENT_S + 5 ms on a quiet one)
NOTICE_BOUND_S = 2.0


@pytest.mark.parametrize("node,graph", [
    ("sim_node", False),
    # also waits for DDS to drop the killed node from the graph: Fast DDS's participant lease,
    # about 20 s
    pytest.param("pybullet_node", True, marks=pytest.mark.slow)])
def test_simulator_killed_mid_run(ros, work, model_path, dataset, node, graph):
    extra = {"model_path": str(model_path)} if node == "sim_node" else {"seed": 3}
    params = lockstep_params(work, f"killed_{node}", node, extra)
    commands = load_moves(dataset, split="train")[0].cmd
    proc = Proc(node, None, work, "--params-file", str(params))
    probe = WatchedProbe(ros, node)
    ctl = None
    try:
        probe.connect(proc)
        ctl = Controller(probe, commands)
        probe.wait(lambda: len(probe.js) >= 50, what="50 steps")
        clock_before = list(probe.clock)
        proc.p.send_signal(signal.SIGKILL)
        t_kill = time.monotonic()
        assert proc.p.wait(TIMEOUT) == -signal.SIGKILL
        # the controller notices: no joint state for SILENT_S, within NOTICE_BOUND_S
        wait_until(lambda: time.monotonic() - ctl.last_js() > SILENT_S,
                   timeout=NOTICE_BOUND_S + SILENT_S, what="the controller to notice")
        noticed = time.monotonic() - t_kill
        assert noticed <= NOTICE_BOUND_S + SILENT_S
        # ... and goes on publishing, neither hung nor crashed
        sent = ctl.sent
        wait_until(lambda: ctl.sent >= sent + 20, what="the controller to keep publishing")
        assert not ctl.errors and ctl.thread.is_alive()
        gone = float("nan")
        if graph:   # the simulator's graph entries go away too (DDS liveliness; slower)
            t0 = time.monotonic()
            wait_until(lambda: probe.cmd.get_subscription_count() == 0, timeout=40,
                       what=f"the killed {node}'s subscription to leave the graph")
            gone = time.monotonic() - t0 + noticed
        # restarted: serves again, /clock from its start (0 s) on
        ctl.hold.set()
        with probe.cond:
            n_clock = len(probe.clock)
        proc = Proc(node, None, work, "--params-file", str(params))
        probe.wait(lambda: len(probe.clock) > n_clock, timeout=30,
                   what=f"/clock from the restarted {node}")
        with probe.cond:
            assert probe.clock[n_clock] == 0, probe.clock[n_clock:]
        probe.connect(proc)
        ctl.hold.clear()
        probe.wait(lambda: len(probe.clock) >= n_clock + 21, what="20 steps after the restart")
        with probe.cond:
            after = probe.clock[n_clock:n_clock + 21]
        assert after == [k * CONTROL_DT_NS for k in range(21)], after
        # the killed node was well past its start (so 0 above is a start, not a late message)
        assert clock_before[-1] >= 40 * CONTROL_DT_NS and np.all(np.diff(clock_before) > 0)
        assert not ctl.errors
        print(f"{node} killed: the controller noticed after {noticed:.3f} s"
              + (f"; the graph dropped its subscription after {gone:.2f} s" if graph else ""))
    finally:
        if ctl is not None:
            ctl.stop()
        probe.close()
        if proc.alive():
            assert proc.stop() == 0


# ---------------------------------------------------------------------------------------------
# a command flood with NaN in every tenth message, sim_node in lockstep


FLOOD_HZ = 10_000.0        # what the flood aims at; a flood is one the node cannot keep pace
                           # with (asserted), whatever rate a loaded machine lets it reach
ANSWER_BOUND_S = 2.0       # a service call during the flood answers within this (10-200 ms)


def flood_messages(good: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """``good`` with a NaN command in every tenth message; (messages, is_bad)."""
    msgs, bad = [], []
    it = iter(good)
    k = 0
    while True:
        if k % 10 == 9:
            u = good[0].copy()
            u[k % 12] = np.nan
            msgs.append(u)
            bad.append(True)
        else:
            u = next(it, None)
            if u is None:
                break
            msgs.append(u)
            bad.append(False)
        k += 1
    return msgs, np.array(bad)


@pytest.mark.parametrize("repeat", [1, pytest.param(4, marks=pytest.mark.slow)])
def test_lockstep_flood_with_nan_loses_no_good_command(ros, work, dataset, model_path,
                                                       test_move, repeat):
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_srvs.srv import SetBool

    from littledog_mlsim.layout import JOINT_NAMES
    from littledog_mlsim.rollout.simulate import rollout

    good = np.concatenate([m.cmd for m in load_moves(dataset, split="all")] * repeat)
    msgs, is_bad = flood_messages(good)
    n_good, n_bad = int((~is_bad).sum()), int(is_bad.sum())
    assert n_good == len(good) and np.all(is_bad[9::10]) and is_bad.sum() == len(msgs) // 10
    params = lockstep_params(work, "flood", "sim_node", {
        "model_path": str(model_path),
        "initial_state": [float(x) for x in test_move.s0],
        "initial_pose": [float(test_move.pose0.x0), float(test_move.pose0.y0),
                         float(test_move.pose0.yaw0)]})
    proc = Proc("sim_node", {"projection": "alpha", "alpha": 0.5, "radius": 0.0}, work,
                "--params-file", str(params))
    probe = Probe(ros)
    # the flood's own publisher: deep enough that its history never drops an unsent message
    pub = probe.node.create_publisher(JointState, "/littledog/cmd", QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=len(msgs),
        reliability=ReliabilityPolicy.RELIABLE))
    try:
        probe.connect(proc)
        wait_until(lambda: pub.get_subscription_count() >= 1, what="the flood's match")
        out = []
        for u in msgs:                        # built before, so the loop only publishes
            msg = JointState()
            msg.name = list(JOINT_NAMES)
            msg.position = [float(x) for x in u]
            out.append(msg)
        answered: list[tuple[float, int]] = []   # (when, the newest step's stamp then)

        def on_answer(_fut) -> None:
            with probe.cond:
                answered.append((time.monotonic(), max(probe.state, default=0)))
        call_at = len(out) // 2
        period = 1.0 / FLOOD_HZ
        t0 = time.perf_counter()
        for k, msg in enumerate(out):
            while time.perf_counter() < t0 + k * period:   # pace (never ahead of 10 kHz)
                pass
            pub.publish(msg)
            if k == call_at:    # mid-flood: the node must still answer a service call
                t_call = time.monotonic()
                fut = probe.pause_client.call_async(SetBool.Request(data=False))
                fut.add_done_callback(on_answer)
        rate = (len(out) - 1) / (time.perf_counter() - t0)
        with probe.cond:
            stepped_when_sent = max(probe.state, default=0)
        t_end = n_good * CONTROL_DT_NS
        probe.wait(lambda: bool(answered), timeout=ANSWER_BOUND_S, what="the service answer")
        latency = answered[0][0] - t_call
        probe.wait(lambda: t_end in probe.state, timeout=60, what=f"step {n_good}")
        st = probe.wait_counter("cmd_received", len(msgs))
        print(f"flood: {len(msgs)} commands ({n_bad} NaN) at {rate:.0f} Hz; service answered "
              f"in {latency * 1e3:.1f} ms; stats {st}")
        assert stepped_when_sent < t_end, (
            f"the node kept pace with the flood ({rate:.0f} Hz): nothing was queued")
        assert fut.result().success and latency <= ANSWER_BOUND_S
        assert answered[0][1] < t_end, "answered only after the flood was stepped"
        # ~/stats counts every message, each good one as one step, each NaN one as refused
        assert int(st["cmd_received"]) == len(msgs)
        assert int(st["cmd_rejected_nonfinite"]) == n_bad
        assert int(st["cmd_accepted"]) == n_good and int(st["steps"]) == n_good
        assert int(st["diverged"]) == 0 and proc.alive()
        # in order: the last state is the core's rollout of the good commands, in order; each
        # applied command that reached this process is the good command of its step
        pose0 = np.array([test_move.pose0.x0, test_move.pose0.y0, test_move.pose0.yaw0])
        model = OneStepModel.load(model_path)
        ref = rollout(model, test_move.s0, good, model.projection("alpha", 0.5), pose0=pose0)
        np.testing.assert_allclose(probe.state[t_end], ref[-1], rtol=0, atol=1e-12)
        with probe.cond:
            applied = dict(probe.applied)
        assert applied and all(np.array_equal(u, good[t // CONTROL_DT_NS])
                               for t, u in applied.items())
    finally:
        probe.node.destroy_publisher(pub)
        probe.close()
        if proc.alive():
            assert proc.stop() == 0


# ---------------------------------------------------------------------------------------------
# a recorder killed mid-bag


def killed_recorder_mcap(dataset: Path, out: Path, fraction: float) -> Path:
    """What a recorder killed mid-bag leaves: a bag directory without ``metadata.yaml`` whose
    MCAP file is cut at ``fraction`` of its bytes (inside its chunk: no summary, no footer)."""
    src = next((dataset / "F_00").glob("*.mcap"))
    raw = src.read_bytes()
    out.mkdir()
    (out / f"{out.name}.mcap").write_bytes(raw[: int(len(raw) * fraction)])
    return out


def test_import_recovers_a_cut_short_mcap(work, dataset, capsys):
    from littledog_mlsim.data.bags import read_bag

    bag = killed_recorder_mcap(dataset, work / "killed_mcap", 0.55)
    out = work / "imported_cut"
    rc, stdout, err = cli(capsys, "import", str(bag), "--out", str(out), "--test-fraction", "0",
                          "--no-figure")
    assert rc == 0, err
    # one warning naming the file, what was dropped and why
    warn = [ln for ln in err.splitlines() if ln.strip()]
    assert len(warn) == 1 and str(bag / "killed_mcap.mcap") in warn[0], err
    assert "no summary section" in warn[0] and "dropped" in warn[0], warn[0]
    report = json.loads((out / "import_report.json").read_text())
    assert report["bags"][0]["recovered"] in warn[0]
    assert "Recovered (cut short)" in (out / "import_report.md").read_text()
    # what was recovered is the source move's beginning, exactly
    src = read_bag(dataset / "F_00")
    (move,) = load_moves(out, "all")
    n = move.n_steps
    assert 0.4 * src.n_steps <= n < 0.6 * src.n_steps, (n, src.n_steps)
    np.testing.assert_array_equal(move.stamps_ns, src.stamps_ns[: n + 1])
    np.testing.assert_allclose(move.cmd, src.cmd[:n], rtol=0, atol=1e-12)
    np.testing.assert_allclose(move.q, src.q[: n + 1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(move.position, src.position[: n + 1], rtol=0, atol=1e-12)


def test_import_refuses_an_unreadable_cut_in_one_line(work, dataset, capsys):
    bag = killed_recorder_mcap(dataset, work / "killed_early", 0.0001)   # inside the header
    out = work / "imported_early"
    rc, stdout, err = cli(capsys, "import", str(bag), "--out", str(out), "--no-figure")
    assert rc == 2 and stdout == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and str(bag / "killed_early.mcap") in lines[0], err
    assert "nothing to salvage" in lines[0]
    assert not out.exists() and staging_of(out) == []


def test_import_reads_a_sqlite3_bag_without_metadata(work, dataset, capsys):
    from littledog_mlsim.data.bags import read_bag, write_bag

    src = read_bag(dataset / "F_00")
    bag = work / "sq" / "F_00"
    bag.parent.mkdir()
    write_bag(bag, src, storage="sqlite3")
    (bag / "metadata.yaml").unlink()
    out = work / "imported_sqlite"
    rc, stdout, err = cli(capsys, "import", str(bag), "--out", str(out), "--test-fraction", "0",
                          "--no-figure")
    assert rc == 0, err
    (move,) = load_moves(out, "all")
    assert move.n_steps == src.n_steps
    np.testing.assert_allclose(move.cmd, src.cmd, rtol=0, atol=1e-12)
    np.testing.assert_allclose(move.q, src.q, rtol=0, atol=1e-12)


def test_demo_controller_reports_a_killed_simulator(work, dataset, model_path):
    """The package's own controller (the demo: both simulators in lockstep) when sim_node is
    killed mid-replay: it ends within a bound with one line naming the node and the signal,
    and stops the other simulator."""
    from rosharness import DOMAIN_ID

    from littledog_mlsim.apps.demo import STOP_TIMEOUT

    log = work / "demo.log"
    err = work / "demo.err"
    domain = (DOMAIN_ID + 50) % 100 + 1       # its own pair of domains, not the module's
    with open(log, "w") as o, open(err, "w") as e:
        p = subprocess.Popen([sys.executable, "-m", "littledog_mlsim.apps.demo", "--data",
                              str(dataset), "--model", str(model_path), "--projection", "none",
                              "--domain", str(domain)], stdout=o, stderr=e, env=ENV)
    try:
        wait_until(lambda: "replaying" in log.read_text() or p.poll() is not None, timeout=120,
                   what="the demo's replay to start")
        assert p.poll() is None, err.read_text()
        kids = children_of(p.pid)
        sim = [k for k, cmd in kids.items() if "littledog_mlsim.nodes.sim_node" in cmd]
        assert len(sim) == 1 and len(kids) == 2, kids
        os.kill(sim[0], signal.SIGKILL)
        t_kill = time.monotonic()
        rc = p.wait(STOP_TIMEOUT + 10.0)
        ended = time.monotonic() - t_kill
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    # it notices within 0.2 s, then stops pybullet_node (SIGINT, SIGKILL after STOP_TIMEOUT)
    print(f"the demo ended {ended:.2f} s after sim_node was killed")
    assert rc == 1 and ended < STOP_TIMEOUT + 5.0, (rc, ended)
    lines = [ln for ln in err.read_text().splitlines() if ln.strip()]
    assert len(lines) == 1 and "sim_node was killed by SIGKILL" in lines[0], lines
    assert "replayed" not in log.read_text()        # killed mid-replay, not after it
    assert all(gone(k) for k in kids), "a simulator survived the demo"


def _zstd_copy(src: Path, out_dir: Path) -> Path:
    """``src`` (an MCAP file) rewritten with zstd-compressed chunks; returns the new file."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

    writer = Writer(out_dir, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)   # before open
    with AnyReader([src]) as reader, writer:
        conns = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=reader.typestore)
                 for c in reader.connections}
        for c, t, data in reader.messages():
            writer.write(conns[c.id], t, data)
    return next(out_dir.glob("*.mcap"))


@pytest.mark.parametrize("compressed", [False, True])
def test_salvage_keeps_the_whole_records_before_the_cut(work, dataset, compressed):
    """An MCAP file of several chunks cut inside its second chunk: the salvaged file holds the
    bag's first messages, exactly; an uncompressed chunk's whole records before the cut are
    kept, a compressed chunk cut short is dropped (said)."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2.storage_mcap import McapReader

    from littledog_mlsim.data.bags import read_bag
    from littledog_mlsim.data.realstyle import write_realstyle_bag
    from littledog_mlsim.data.salvage import salvage_mcap

    src = work / "multi.mcap"
    if not src.exists():
        write_realstyle_bag(src, [read_bag(dataset / f"F_0{i}") for i in range(3)])
    if compressed:
        src = _zstd_copy(src, work / "multi_zstd")
    storage = McapReader(src)
    storage.open()
    chunks = sorted(storage.chunks, key=lambda c: c.chunk_start_offset)
    storage.close()
    assert len(chunks) >= 2 and {c.compression for c in chunks} == {"zstd" if compressed else ""}
    with AnyReader([src]) as reader:
        full = [(c.topic, t, bytes(d)) for c, t, d in reader.messages()]
    first = sum(chunks[0].channel_count.values())
    second = chunks[1]
    cut = work / f"cut_{compressed}.mcap"
    cut.write_bytes(src.read_bytes()[: second.chunk_start_offset + second.chunk_length // 2])
    s = salvage_mcap(cut, work / f"salvaged_{compressed}.mcap")
    with AnyReader([s.out]) as reader:
        got = [(c.topic, t, bytes(d)) for c, t, d in reader.messages()]
    assert got == full[: len(got)] and s.messages == len(got)
    assert s.chunks_whole == 1
    if compressed:
        assert len(got) == first
        assert "zstd-compressed chunk cut short" in s.dropped
    else:
        assert first < len(got) < first + sum(second.channel_count.values())
        assert "after the cut inside its last chunk" in s.dropped
