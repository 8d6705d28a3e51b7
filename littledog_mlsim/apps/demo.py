"""The main job end to end (``make run``): the learned simulator against pybullet over ROS 2.

    python -m littledog_mlsim.apps.demo [--data bags/demo] [--model bags/demo_lgpr] [--move F_02]

1. Data and model, built only if absent: ``littledog-mlsim record --out DATA --moves-per-type 3
   --quiet`` (33 bags, about 15 s on 2 cores) and ``littledog-mlsim train --data DATA --method
   lgpr --out MODEL`` (about 30 s).
2. Two simulators as separate processes, each alone in its own ROS domain (so both keep the
   contract's topic names, docs/interface.md §2, without remapping, and their outputs cannot
   mix), with localhost discovery: ``sim_node`` (the learned model, lockstep) in domain D and
   ``pybullet_node`` (measured robot, lockstep) in domain D + 1. D is derived from the process
   id unless ``--domain`` is given. sim_node runs with its own default projection, the gated
   alpha-PROJ (alpha 0.5, the radius stored in the model; docs/cli.md "Which projection"), unless
   ``--projection`` says otherwise.
3. One TestPool move's recorded commands go to both on ``/littledog/cmd``, one command per step,
   the next one only after both simulators published that step's ``/littledog/joint_states``,
   ``/littledog/odom`` and ``~/state`` (lockstep: deterministic whatever the CPU load).
   Alignment: pybullet_node starts from the settled stance at measurement 0 with the move's
   recording seed, so its replay reproduces the bag; the learned simulator, like the core's
   rollout (``rollout.simulate``), starts at measurement 1 from the recorded s_1 and pose
   (``initial_state``, ``initial_pose``, ``start_time`` 0.01 s) and gets u_1..u_{N-1}; u_0 goes
   to pybullet_node only. Both then stamp measurement k with k * 10 ms.
4. Report: the learned simulator's error against pybullet (final (x, y) error, mean joint-angle
   error, per-step RMS errors of the state groups), and the last step's ``/littledog/odom`` and
   ``/littledog/joint_states`` of the learned simulator as ``ros2 topic echo`` prints them.

Processes: the simulators get SIGINT, then ``STOP_TIMEOUT`` s, then SIGKILL, on success, error
or interrupt (and on Linux they get SIGTERM if this process dies). Problems are one line on
stderr (``demo: error: ...``) and exit status 1; Ctrl-C exits 130.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

__all__ = ["DemoError", "DemoResult", "ensure_dataset", "ensure_model", "run_demo",
           "format_report", "main"]

DEFAULT_DATA = Path("bags/demo")
DEFAULT_MODEL = Path("bags/demo_lgpr")
DEMO_MOVES_PER_TYPE = 3
DEMO_METHOD = "lgpr"
START_TIMEOUT = 60.0   # s, start-up (model loading) and discovery of both simulators
STEP_TIMEOUT = 15.0    # s, one lockstep step of both simulators
STOP_TIMEOUT = 10.0    # s, between SIGINT and SIGKILL
PING_RETRY_S = 1.0     # s, before the start-up service call is sent again (an answer can be lost)

Log = Callable[[str], None]


class DemoError(Exception):
    """A user-facing problem: printed as one line, exit status 1."""


def _print(text: str) -> None:
    print(text, flush=True)


def _cli(*args: str) -> list[str]:
    """The ``littledog-mlsim`` command line, run with this interpreter."""
    return [sys.executable, "-m", "littledog_mlsim.cli", *args]


def _run_step(what: str, argv: list[str], shown: str) -> float:
    t0 = time.perf_counter()
    rc = subprocess.run(argv).returncode       # its progress and errors go to the terminal
    if rc != 0:
        raise DemoError(f"{what} failed (exit status {rc}): {shown}")
    return time.perf_counter() - t0


def ensure_dataset(data: Path, moves_per_type: int = DEMO_MOVES_PER_TYPE,
                   log: Log = _print) -> float | None:
    """Record the demo dataset into ``data`` unless ``data/dataset.yaml`` exists.
    Returns the recording's wall time, or None if it was there already."""
    if (data / "dataset.yaml").is_file():
        return None
    args = ["record", "--out", str(data), "--moves-per-type", str(moves_per_type), "--quiet"]
    shown = "littledog-mlsim " + " ".join(args)
    log(f"no dataset at {data}: {shown}")
    return _run_step("recording the dataset", _cli(*args), shown)


def ensure_model(data: Path, model: Path, method: str = DEMO_METHOD,
                 log: Log = _print) -> float | None:
    """Train ``method`` on ``data`` into ``model`` unless a model is there already.
    Returns the training's wall time, or None."""
    from ..models.persistence import META_FILE

    if (model / META_FILE).is_file() or model.is_file():
        return None
    args = ["train", "--data", str(data), "--method", method, "--out", str(model)]
    shown = "littledog-mlsim " + " ".join(args)
    log(f"no model at {model}: {shown}")
    return _run_step("training the model", _cli(*args), shown)


# ---------------------------------------------------------------------------------------------
# the simulator processes


def parent_death_signal() -> Callable[[], None] | None:
    """preexec_fn: SIGTERM the child when this process dies (Linux prctl), else None (also
    a pool's initializer: ``record``'s workers)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        prctl = libc.prctl
    except (OSError, AttributeError):
        return None
    return lambda: prctl(1, signal.SIGTERM, 0, 0, 0)   # PR_SET_PDEATHSIG = 1


_LOG_LINE = re.compile(r"^\[(?:FATAL|ERROR|WARN)\] \[[\d.]+\] \[([^\]]+)\]: (.*)$")


class Child:
    """A node in its own process (``python -m littledog_mlsim.nodes.<name>``); stdout and
    stderr go to files (no pipe to fill up)."""

    def __init__(self, name: str, params_file: Path, env: dict[str, str], logdir: Path) -> None:
        self.name = name
        self.log = logdir / f"{name}.log"
        self.returncode: int | None = None
        argv = [sys.executable, "-m", f"littledog_mlsim.nodes.{name}", "--ros-args",
                "--params-file", str(params_file)]
        with open(self.log, "w") as f:
            self.p = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=f,
                                      stderr=subprocess.STDOUT, env=env,
                                      preexec_fn=parent_death_signal())
        self.pid = self.p.pid

    def alive(self) -> bool:
        return self.p.poll() is None

    def reason(self) -> str:
        """The node's last error line (its FATAL line, mostly), or its last line."""
        try:
            lines = [ln.strip() for ln in self.log.read_text(errors="replace").splitlines()
                     if ln.strip()]
        except OSError:
            lines = []
        bad = [ln for ln in lines if "[INFO]" not in ln and "[DEBUG]" not in ln]
        if not bad:
            return "no error message"
        fatal = [ln for ln in bad if ln.startswith(("[FATAL]", "[ERROR]"))]
        line = (fatal or bad)[-1]
        m = _LOG_LINE.match(line)
        return m.group(2) if m else line

    def check(self) -> None:
        if not self.alive():
            rc = self.p.returncode
            if rc < 0:     # killed by a signal: it could not say why itself
                try:
                    sig = signal.Signals(-rc).name
                except ValueError:
                    sig = f"signal {-rc}"
                last = self.reason()
                raise DemoError(f"{self.name} was killed by {sig} (exit status {rc})"
                                + ("" if last == "no error message" else
                                   f"; its last line: {last}"))
            raise DemoError(f"{self.name} exited with status {rc}: {self.reason()}")

    def stop(self) -> int:
        """SIGINT, wait up to STOP_TIMEOUT s, then SIGKILL; returns the exit status."""
        if self.alive():
            try:
                self.p.send_signal(signal.SIGINT)
                self.p.wait(STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
        self.returncode = self.p.returncode
        return self.returncode


# ---------------------------------------------------------------------------------------------
# the controller side: one rclpy context per domain


class _Link:
    """This process's view of one simulator: an rclpy context in the simulator's domain, a
    ``/littledog/cmd`` publisher and subscriptions to its outputs, messages kept by stamp."""

    def __init__(self, label: str, node_name: str, domain: int, cond: threading.Condition) -> None:
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import JointState

        from ..layout import TOPIC_CMD, TOPIC_JOINT_STATES, TOPIC_ODOM
        from ..nodes.simulator import QOS
        from ..nodes.spinner import Spinner

        self.label, self.domain, self.cond = label, domain, cond
        self.js: dict[int, Any] = {}
        self.odom: dict[int, Any] = {}
        self.state: dict[int, Any] = {}
        self.spinner = Spinner(domain, name=f"demo-{label}")
        self.node = self.spinner.node(f"demo_{label}_{os.getpid()}")
        n = self.node
        self.cmd = n.create_publisher(JointState, TOPIC_CMD, QOS)
        self.subs = [
            n.create_subscription(JointState, TOPIC_JOINT_STATES,
                                  lambda msg: self._add(self.js, msg), QOS),
            n.create_subscription(Odometry, TOPIC_ODOM, lambda msg: self._add(self.odom, msg),
                                  QOS),
            n.create_subscription(JointState, f"/{node_name}/state",
                                  lambda msg: self._add(self.state, msg), QOS),
        ]
        # one service round trip before the first command: our side matching the simulator's
        # subscription does not mean its side has matched our publisher yet (a command sent in
        # between is lost, and lockstep then waits for it forever)
        from rcl_interfaces.srv import GetParameters
        self._ping = n.create_client(GetParameters, f"/{node_name}/get_parameters")
        self._ping_future: Any = None
        self._ping_sent = 0.0
        self.pinged = False

    def _add(self, store: dict[int, Any], msg: Any) -> None:
        from ..nodes.messages import stamp_ns

        with self.cond:
            store[stamp_ns(msg.header.stamp)] = msg
            self.cond.notify_all()

    def connected(self) -> bool:
        """Both ways matched: topics seen from here and one service call answered."""
        if not (self.cmd.get_subscription_count() >= 1
                and all(s.get_publisher_count() >= 1 for s in self.subs)):
            return False
        if self.pinged or not self._ping.service_is_ready():
            return self.pinged
        # sent again every PING_RETRY_S: a client can see the service ready before the server
        # has matched its response reader, and that first answer is then lost for good
        if self._ping_future is not None and time.monotonic() - self._ping_sent > PING_RETRY_S:
            self._ping.remove_pending_request(self._ping_future)
            self._ping_future = None
        if self._ping_future is None:
            from rcl_interfaces.srv import GetParameters
            self._ping_sent = time.monotonic()
            self._ping_future = self._ping.call_async(GetParameters.Request(names=[]))
            self._ping_future.add_done_callback(self._answered)
        return self.pinged

    def _answered(self, future: Any) -> None:
        with self.cond:
            self.pinged = True
            self.cond.notify_all()

    def has(self, ns: int) -> bool:
        return ns in self.js and ns in self.odom and ns in self.state

    def send(self, u: np.ndarray) -> None:
        from ..nodes.messages import joint_state_msg

        self.cmd.publish(joint_state_msg(0, u))

    def close(self) -> None:
        self.spinner.close()


def _wait(cond: threading.Condition, pred: Callable[[], bool], timeout: float, what: str,
          children: Sequence[Child]) -> None:
    """Wait for ``pred`` (under ``cond``), checking every 0.2 s that the children still run."""
    end = time.monotonic() + timeout
    with cond:
        while not pred():
            for c in children:
                c.check()
            left = end - time.monotonic()
            if left <= 0:
                raise DemoError(f"timed out after {timeout:g} s waiting for {what}")
            cond.wait(min(left, 0.2))


# ---------------------------------------------------------------------------------------------
# the job


@dataclass
class DemoResult:
    """What ``run_demo`` measured. Arrays are over the compared measurements k = 2..N
    (T = N - 1 steps of the learned simulator), learned minus pybullet."""

    move: str
    split: str
    method: str
    projection: str                    # e.g. "alpha-PROJ (alpha 0.5)"
    n_steps: int                       # T
    domains: tuple[int, int]           # (learned, pybullet)
    final_xy_error_m: float
    mean_joint_error_rad: float
    rms: dict[str, float]              # per group: RMS over all steps of the per-step errors
    per_step: dict[str, np.ndarray]    # per group: (T,) per-step error (RMS within the group)
    t: np.ndarray                      # (T,) s since the start of the move
    learned_xy: np.ndarray             # (T, 2) odometry of the learned simulator
    pybullet_xy: np.ndarray            # (T, 2) odometry of pybullet_node
    learned_states: np.ndarray         # (T, 33) ~/state of sim_node
    pybullet_states: np.ndarray        # (T + 1, 33) ~/state of pybullet_node, k = 1..N
    bag_max_diff: float                # max |pybullet_node's states - the recorded bag's|
    example_odom: str                  # learned sim's last /littledog/odom, ros2 topic echo YAML
    example_joint_states: str
    example_stamp_s: float
    start_s: float                     # start-up and discovery wall time
    replay_s: float                    # lockstep replay wall time
    pids: list[int] = field(default_factory=list)
    exit_codes: dict[str, int | None] = field(default_factory=dict)
    seed: int = 0


def pick_domains(domain: int | None = None) -> tuple[int, int]:
    """(learned, pybullet) ROS domain ids: ``domain`` and ``domain + 1``; by default derived
    from the process id (2..98, so a parallel run or test picks another pair)."""
    if domain is None:
        domain = 2 + 2 * (os.getpid() % 49)
    if not 0 <= domain <= 231:       # ROS 2 domain ids end at 232 (Linux)
        raise DemoError(f"--domain must be in 0..231 (it and the next one are used), got {domain}")
    return domain, domain + 1


def _choose_move(data: Path, move: str | None):
    from ..data.dataset import read_index

    try:
        index = read_index(data)
    except ValueError as e:
        raise DemoError(str(e)) from None
    if move is None:
        tests = [e for e in index.entries if e.split == "test"]
        if not tests:
            raise DemoError(f"{data} has no TestPool moves; record more moves per type")
        fwd = [e for e in tests if e.move_type == "F"]
        return (fwd or tests)[0], index.info
    for e in index.entries:
        if e.name == move:
            return e, index.info
    raise DemoError(f"no move {move} in {data}/dataset.yaml")


def _recording_seed(entry, info: dict) -> int:
    """The sensor-noise seed ``littledog-mlsim record`` used for this move (record.MoveJob)."""
    from .record import MoveJob

    try:
        index = int(entry.name.rsplit("_", 1)[1])
        return MoveJob(entry.move_type, index, int(info.get("seed", 0))).seeds()[1]
    except (IndexError, ValueError):
        return 0


def run_demo(data: str | os.PathLike = DEFAULT_DATA, model: str | os.PathLike = DEFAULT_MODEL,
             *, move: str | None = None, max_steps: int | None = None,
             domain: int | None = None, robot: str = "measured",
             projection: str = "alpha", alpha: float = 0.5,
             log: Log = _print, watcher: Callable[[], bool] | None = None) -> DemoResult:
    """Replay one move's commands through sim_node and pybullet_node (each a process in its
    own ROS domain, lockstep) and compare what they publish (module doc). ``max_steps`` cuts
    the move to that many commands (at least 2); ``projection`` and ``alpha`` are sim_node's
    parameters (module doc). ``watcher``, if given, says whether an observer (the browser
    view, ``DemoView.ready``) has received state from both simulators (their initial states,
    which lockstep simulators publish at start-up; a transient-local subscription gets them);
    the first command waits for it up to ``START_TIMEOUT`` so that the observer sees the whole
    run. Stops every process it started."""
    import rclpy  # noqa: F401  (fail early and plainly if the ROS wheels are missing)

    from ..data.bags import read_bag
    from ..layout import CONTROL_DT, CONTROL_DT_NS, S
    from ..models.persistence import META_FILE
    from ..nodes import messages as m
    from ..nodes.topic_echo import message_to_yaml
    from ..rollout.simulate import prepare_test_move
    from ..rotations import quat_to_rpy

    data, model = Path(data), Path(model)
    if not (model.is_file() or (model / META_FILE).is_file()):
        raise DemoError(f"no model at {model} (train one: littledog-mlsim train --data {data} "
                        f"--method lgpr --out {model})")
    entry, info = _choose_move(data, move)
    try:
        rec = read_bag(data / entry.name, move_type=entry.move_type)
    except ValueError as e:
        raise DemoError(str(e)) from None
    n_cmd = rec.cmd.shape[0] if max_steps is None else min(rec.cmd.shape[0], int(max_steps))
    if n_cmd < 2:
        raise DemoError(f"need at least 2 steps, got {n_cmd}")
    cmds = np.asarray(rec.cmd[:n_cmd], dtype=np.float64)
    tm = prepare_test_move(rec)
    seed = _recording_seed(entry, info)
    d_learned, d_pyb = pick_domains(domain)
    method = _model_method(model)

    label = _projection_label(projection, alpha)
    log(f"ROS 2: sim_node ({method} model {model}, {label}) in domain {d_learned}, pybullet_node "
        f"({robot} robot) in domain {d_pyb}; localhost discovery; both lockstep")
    children: list[Child] = []
    links: list[_Link] = []
    cond = threading.Condition()
    saved = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE")
    with tempfile.TemporaryDirectory(prefix="littledog_demo_") as tmp:
        tmpdir = Path(tmp)
        try:
            t0 = time.perf_counter()
            base_env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                            PYTHONUNBUFFERED="1")
            base_env.setdefault("OPENBLAS_NUM_THREADS", "1")
            sim_params = {"model_path": str(model.resolve()), "step_mode": "lockstep",
                          "initial_state": [float(x) for x in tm.s0],
                          "initial_pose": [float(tm.pose0.x0), float(tm.pose0.y0),
                                           float(tm.pose0.yaw0)],
                          "start_time": CONTROL_DT, "stats_period": 0.0,
                          "projection": projection, "alpha": float(alpha)}
            pyb_params = {"robot": robot, "seed": seed, "step_mode": "lockstep",
                          "stats_period": 0.0}
            for name, params, dom in (("sim_node", sim_params, d_learned),
                                      ("pybullet_node", pyb_params, d_pyb)):
                f = tmpdir / f"{name}.yaml"
                f.write_text(json.dumps({name: {"ros__parameters": params}}))  # JSON is YAML
                children.append(Child(name, f, dict(base_env, ROS_DOMAIN_ID=str(dom)), tmpdir))
            os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"   # read by rclpy.init
            links.append(_Link("learned", "sim_node", d_learned, cond))
            links.append(_Link("pybullet", "pybullet_node", d_pyb, cond))
            learned, pyb = links
            _restore_env(saved)
            _wait(cond, lambda: learned.connected() and pyb.connected(), START_TIMEOUT,
                  "sim_node and pybullet_node to start and be discovered", children)
            if watcher is not None:
                end = time.monotonic() + START_TIMEOUT
                while not watcher() and time.monotonic() < end:
                    for c in children:
                        c.check()
                    time.sleep(0.1)
                if not watcher():
                    log(f"view: has not received state from both simulators after "
                        f"{START_TIMEOUT:g} s; it may miss part of the run")
            start_s = time.perf_counter() - t0
            log(f"both simulators up and discovered in {start_s:.1f} s; replaying "
                f"{entry.name} ({'TestPool' if entry.split == 'test' else 'TrainPool'}, "
                f"{n_cmd} commands, {n_cmd * CONTROL_DT:.2f} s) into both")

            t1 = time.perf_counter()
            for k in range(n_cmd):
                ns = (k + 1) * CONTROL_DT_NS
                pyb.send(cmds[k])
                if k >= 1:
                    learned.send(cmds[k])
                _wait(cond, (lambda ns=ns: pyb.has(ns) and learned.has(ns)) if k >= 1
                      else (lambda ns=ns: pyb.has(ns)), STEP_TIMEOUT,
                      f"step {k + 1} of {n_cmd}", children)
            replay_s = time.perf_counter() - t1
            log(f"replayed {n_cmd} lockstep steps in {replay_s:.1f} s "
                f"({n_cmd / replay_s:.0f} steps/s through both simulators)")

            stamps = [(k + 1) * CONTROL_DT_NS for k in range(1, n_cmd)]   # measurements 2..N
            with cond:
                l_odom = [m.odometry_arrays(learned.odom[t]) for t in stamps]
                p_odom = [m.odometry_arrays(pyb.odom[t]) for t in stamps]
                l_q = np.array([m.joint_state_arrays(learned.js[t])[0] for t in stamps])
                p_q = np.array([m.joint_state_arrays(pyb.js[t])[0] for t in stamps])
                l_s = np.array([m.state_array(learned.state[t]) for t in stamps])
                p_s = np.array([m.state_array(pyb.state[(k + 1) * CONTROL_DT_NS])
                                for k in range(n_cmd)])
                last_odom, last_js = learned.odom[stamps[-1]], learned.js[stamps[-1]]
        finally:
            _restore_env(saved)
            for link in links:
                try:
                    link.close()
                except Exception:
                    pass
            codes = {c.name: c.stop() for c in children}
        for c in children:
            if codes[c.name] not in (0, None):
                log(f"warning: {c.name} exited with status {codes[c.name]} on SIGINT: "
                    f"{c.reason()}")

    l_xy = np.array([o["position"][:2] for o in l_odom])
    p_xy = np.array([o["position"][:2] for o in p_odom])
    l_yaw = quat_to_rpy(np.array([o["orientation"] for o in l_odom]))[:, 2]
    p_yaw = quat_to_rpy(np.array([o["orientation"] for o in p_odom]))[:, 2]
    dyaw = np.angle(np.exp(1j * (l_yaw - p_yaw)))
    ps = p_s[1:]
    per_step = {
        "xy_m": np.linalg.norm(l_xy - p_xy, axis=1),
        "z_m": np.abs(l_s[:, S.z_w] - ps[:, S.z_w]),
        "roll_pitch_rad": _rms(l_s[:, S.roll_pitch] - ps[:, S.roll_pitch]),
        "yaw_rad": np.abs(dyaw),
        "q_rad": _rms(l_q - p_q),
        "dq_rad_s": _rms(l_s[:, S.dq] - ps[:, S.dq]),
    }
    ref = tm.states[: n_cmd - 1]
    bag_max_diff = float(np.max(np.abs(np.r_[tm.s0[None], ref] - p_s)))
    return DemoResult(
        move=entry.name, split=entry.split, method=method, projection=label,
        n_steps=n_cmd - 1,
        domains=(d_learned, d_pyb),
        final_xy_error_m=float(per_step["xy_m"][-1]),
        mean_joint_error_rad=float(np.mean(np.abs(l_q - p_q))),
        rms={k: float(np.sqrt(np.mean(v ** 2))) for k, v in per_step.items()},
        per_step=per_step, t=np.array(stamps) / 1e9, learned_xy=l_xy, pybullet_xy=p_xy,
        learned_states=l_s, pybullet_states=p_s, bag_max_diff=bag_max_diff,
        example_odom=message_to_yaml(last_odom), example_joint_states=message_to_yaml(last_js),
        example_stamp_s=stamps[-1] / 1e9, start_s=start_s, replay_s=replay_s,
        pids=[c.pid for c in children], exit_codes=codes, seed=seed)


def _projection_label(projection: str, alpha: float) -> str:
    if projection == "alpha":
        return f"alpha-PROJ (alpha {alpha:g}, gated by the model's radius)"
    return {"none": "no projection", "bound": "BOUND projection"}.get(projection, projection)


def _rms(a: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(a * a, axis=1))


def _restore_env(saved: str | None) -> None:
    if saved is None:
        os.environ.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
    else:
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = saved


def _model_method(model: Path) -> str:
    """The model's method from its metadata (for the report), without loading its arrays."""
    from ..models.persistence import META_FILE

    try:
        doc = json.loads((model / META_FILE).read_text())
    except (OSError, ValueError):
        return "learned"
    for where in (doc, doc.get("meta") or {}, doc.get("info") or {}):
        if isinstance(where, dict) and isinstance(where.get("method"), str):
            return where["method"]
    return "learned"


# ---------------------------------------------------------------------------------------------
# report


_GROUPS = (("xy_m", "(x,y) [m]", "{:.4f}"), ("z_m", "z [m]", "{:.4f}"),
           ("roll_pitch_rad", "roll,pitch [rad]", "{:.4f}"), ("yaw_rad", "yaw [rad]", "{:.4f}"),
           ("q_rad", "q [rad]", "{:.4f}"), ("dq_rad_s", "dq [rad/s]", "{:.3f}"))


def format_report(r: DemoResult) -> str:
    lines = []
    if r.bag_max_diff == 0.0:
        lines.append(f"pybullet_node reproduced the recorded bag {r.move} exactly "
                     f"(recording seed {r.seed}).")
    else:
        lines.append(f"note: pybullet_node's states differ from the recorded bag {r.move} by up "
                     f"to {r.bag_max_diff:.3g} (another robot or undeclared effects?); the "
                     f"comparison below is against pybullet_node.")
    moved_p = float(np.linalg.norm(r.pybullet_xy[-1] - r.pybullet_xy[0]))
    moved_l = float(np.linalg.norm(r.learned_xy[-1] - r.learned_xy[0]))
    lines += [
        "",
        f"Learned simulator ({r.method}, {r.projection}) vs pybullet, {r.move}, {r.n_steps} steps "
        f"({r.n_steps * 0.01:.2f} s) from the same state:",
        f"  final (x,y) error        {r.final_xy_error_m:.4f} m   (pybullet moved "
        f"{moved_p:.3f} m, the learned simulator {moved_l:.3f} m)",
        f"  mean joint-angle error   {r.mean_joint_error_rad:.4f} rad "
        f"({np.degrees(r.mean_joint_error_rad):.2f} deg) over 12 joints x {r.n_steps} steps",
        "  per-step error (learned - pybullet; RMS over each group's elements):",
        "    " + f"{'t [s]':>8}" + "".join(f"{label:>18}" for _, label, _ in _GROUPS),
    ]
    T = r.n_steps
    rows = sorted({min(T - 1, max(0, int(round(t / 0.01)) - 2)) for t in (0.5, 1, 2, 3, 4)}
                  | {T - 1})
    for i in rows:
        lines.append("    " + f"{r.t[i]:>8.2f}" + "".join(
            f"{fmt.format(r.per_step[key][i]):>18}" for key, _, fmt in _GROUPS))
    lines.append("    " + f"{'RMS all':>8}" + "".join(
        f"{fmt.format(r.rms[key]):>18}" for key, _, fmt in _GROUPS))
    lines += [
        "",
        f"The learned simulator's last messages (t = {r.example_stamp_s:.2f} s), as "
        f"`ros2 topic echo` (here: topic_echo) prints them:",
        "/littledog/odom:",
        r.example_odom + "---",
        "/littledog/joint_states:",
        r.example_joint_states + "---",
    ]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# command line


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m littledog_mlsim.apps.demo",
        description="The main job end to end: build the demo dataset and LGPR model if absent, "
                    "then run sim_node and pybullet_node as ROS 2 processes, replay a TestPool "
                    "move's commands into both and report the learned simulator's error.")
    p.add_argument("--data", type=Path, default=DEFAULT_DATA,
                   help=f"dataset directory (recorded if absent; default {DEFAULT_DATA})")
    p.add_argument("--model", type=Path, default=DEFAULT_MODEL,
                   help=f"model directory (trained with {DEMO_METHOD} if absent; default "
                        f"{DEFAULT_MODEL})")
    p.add_argument("--move", default=None,
                   help="bag to replay, e.g. F_02 (default: the first TestPool F move)")
    p.add_argument("--steps", type=int, default=None, help="replay only the first N commands")
    p.add_argument("--projection", choices=["none", "bound", "alpha"], default="alpha",
                   help="sim_node's projection (default alpha: sim_node's default, the gated "
                        "alpha-PROJ with the model's own radius)")
    p.add_argument("--alpha", type=float, default=0.5, help="alpha of alpha-PROJ (default 0.5)")
    p.add_argument("--domain", type=int, default=None, metavar="D",
                   help="ROS domain of sim_node (pybullet_node uses D + 1; default from the pid)")
    p.add_argument("--view", action="store_true",
                   help="also serve the browser view (docs/viewer.md): live during the replay, "
                        "then a replay of the run, until Ctrl-C")
    p.add_argument("--view-port", type=int, default=8080, help="port of the view (default 8080)")
    a = p.parse_args(argv)
    previous = signal.signal(signal.SIGTERM, _interrupt)
    t0 = time.perf_counter()
    view = None
    try:
        rec_s = ensure_dataset(a.data)
        if rec_s is not None:
            _print(f"recorded {a.data} in {rec_s:.0f} s")
        _choose_move(a.data, a.move)          # a bad --move fails before any training
        train_s = ensure_model(a.data, a.model)
        if train_s is not None:
            _print(f"trained {a.model} in {train_s:.0f} s")
        if a.view:
            from ..viewer.demo_view import DemoView

            a.domain = pick_domains(a.domain)[0]
            view = DemoView(a.domain, a.domain + 1, port=a.view_port, log=_print)
        r = run_demo(a.data, a.model, move=a.move, max_steps=a.steps, domain=a.domain,
                     projection=a.projection, alpha=a.alpha,
                     watcher=None if view is None else view.ready)
        _print(format_report(r))
        _print(f"\ndone in {time.perf_counter() - t0:.0f} s; to run the nodes yourself see "
               f"README.md, 'Using it from ROS 2'.")
        if view is not None:
            view.serve_replay()           # until Ctrl-C
        return 0
    except KeyboardInterrupt:
        print("demo: interrupted", file=sys.stderr)
        return 130
    except DemoError as e:
        print(f"demo: error: {' '.join(str(e).split())}", file=sys.stderr)
        return 1
    finally:
        if view is not None:
            view.close()
        signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
