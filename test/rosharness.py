"""The ROS side of the multi-process tests (imported as ``rosharness``, like ``waiting``).

- :class:`Proc`: a node in its own process, output to files, stopped with SIGINT (SIGKILL and a
  failure if it does not stop within ``TIMEOUT``).
- :class:`Ros`: this process's rclpy context and executor thread (the package's ``Spinner``).
- :class:`Probe`: subscribes to a simulator's topics, records what arrives, sends commands and
  calls its services.

One ROS domain for every module of a process that imports it (``DOMAIN_ID``:
``LITTLEDOG_TEST_DOMAIN_ID``, or derived from the pid so that concurrent runs, and the workers
of one pytest-xdist run, do not meet), localhost discovery; set in the environment at import,
so the node processes inherit it. Modules run one after the other and
each leaves no node process behind (test/guards.py), so they can share the domain.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np


def _domain_id() -> int:
    """``LITTLEDOG_TEST_DOMAIN_ID`` (a fixed domain, e.g. one reserved for this checkout), else
    one from the process's pid. The N workers of one pytest-xdist run (``PYTEST_XDIST_WORKER``
    gw0 .. gwN-1, ``PYTEST_XDIST_WORKER_COUNT`` N) take N consecutive domains, from the fixed
    one or placed by their parent's pid, so two workers of a run never share one."""
    fixed = os.environ.get("LITTLEDOG_TEST_DOMAIN_ID")
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    k = int(worker[2:]) if worker else 0
    if fixed:
        return int(fixed) + k
    if not worker:
        return 1 + os.getpid() % 100
    n = max(1, int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")))
    return 1 + (os.getppid() % max(1, 100 // n)) * n + k % n


DOMAIN_ID = _domain_id()
os.environ["ROS_DOMAIN_ID"] = str(DOMAIN_ID)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from diagnostic_msgs.msg import DiagnosticStatus
from nav_msgs.msg import Odometry
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

from littledog_mlsim.layout import JOINT_NAMES
from littledog_mlsim.nodes import messages as m
from littledog_mlsim.nodes.simulator import QOS
from littledog_mlsim.nodes.spinner import Spinner
from waiting import TIMEOUT, wait_until

BIN = Path(sys.executable).parent
ENV = dict(os.environ, PYTHONUNBUFFERED="1")


# ---------------------------------------------------------------------------------------------
# processes


class Proc:
    """A node in its own process; output goes to files (no pipe to fill up)."""

    def __init__(self, exe: str, params: dict | None, tmp: Path, *extra: str) -> None:
        self.name = exe
        self.out = tmp / f"{exe}.{time.monotonic_ns()}.out"
        self.err = self.out.with_suffix(".err")
        args = [str(BIN / exe), "--ros-args"]
        for k, v in (params or {}).items():
            args += ["-p", f"{k}:={_param(v)}"]
        args += list(extra)
        with open(self.out, "w") as o, open(self.err, "w") as e:
            self.p = subprocess.Popen(args, stdout=o, stderr=e, env=ENV)

    def alive(self) -> bool:
        return self.p.poll() is None

    def stderr(self) -> str:
        return self.err.read_text()

    def wait(self, timeout: float = 120.0) -> int:
        return self.p.wait(timeout)

    def stop(self) -> int:
        if self.alive():
            self.p.send_signal(signal.SIGINT)
        try:
            return self.p.wait(TIMEOUT)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()
            raise AssertionError(f"{self.name} did not stop on SIGINT") from None


def _param(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ",".join(_param(x) for x in v) + "]"
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    return str(v)


def run(exe: str, params: dict, tmp: Path, timeout: float = 120.0) -> tuple[int, str]:
    p = Proc(exe, params, tmp)
    try:
        rc = p.wait(timeout)
    except subprocess.TimeoutExpired:
        p.stop()
        raise
    return rc, p.stderr()


def error_lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln.strip() and "[INFO]" not in ln]


# ---------------------------------------------------------------------------------------------
# the controller side: one rclpy context, an executor in a background thread


def call_service(client, request, what: str = "", attempt_s: float = 2.0,
                 timeout: float = TIMEOUT):
    """Call a service and return its answer, sending the request again every ``attempt_s``
    until ``timeout``: a client can see the service ready before the server has matched the
    client's response reader, and that first answer is then lost for good (the requests the
    tests send are idempotent: describe, get, reset, pause)."""
    what = what or f"service {client.srv_name}"
    deadline = time.monotonic() + timeout
    while True:
        fut = client.call_async(request)
        retry_at = min(deadline, time.monotonic() + attempt_s)
        while not fut.done() and time.monotonic() < retry_at:
            time.sleep(0.005)
        if fut.done():
            return fut.result()
        client.remove_pending_request(fut)
        if time.monotonic() >= deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")


class Ros(Spinner):
    """The controller side: one rclpy context in the test domain, spun on a thread
    (:class:`littledog_mlsim.nodes.spinner.Spinner`: ``node``, ``destroy``, ``close``)."""

    def __init__(self) -> None:
        super().__init__(DOMAIN_ID, name="test-ros-spin")


class Probe:
    """Subscribes to a simulator's topics and records what arrives (with receive times)."""

    def __init__(self, ros: Ros, sim: str = "sim_node", name: str = "probe",
                 light: bool = False, cmd_depth: int = 100) -> None:
        self.ros = ros
        self.node = ros.node(f"{name}_{time.monotonic_ns()}")
        self.cond = threading.Condition()
        # (source timestamp [system ns, the sim's publish time], stamp, q, dq)
        self.js: list[tuple[int, int, np.ndarray, np.ndarray]] = []
        self.odom: list[tuple[int, dict]] = []
        self.state: dict[int, np.ndarray] = {}
        self.applied: dict[int, np.ndarray] = {}
        self.clock: list[int] = []
        self.stats: list[dict[str, str]] = []
        n = self.node
        # light: fewer subscriptions, for a test process that must keep up with 100 Hz
        self.subs = [
            n.create_subscription(JointState, "/littledog/joint_states", self._js, QOS),
            n.create_subscription(Odometry, "/littledog/odom", self._odom, QOS),
            n.create_subscription(JointState, f"/{sim}/cmd_applied", self._applied, QOS),
            n.create_subscription(DiagnosticStatus, f"/{sim}/stats", self._stats, QOS),
        ]
        if not light:
            self.subs += [
                n.create_subscription(JointState, f"/{sim}/state", self._state, QOS),
                n.create_subscription(ClockMsg, "/clock", self._clock, QOS)]
        # cmd_depth: a burst of commands must not overwrite itself in the writer's history
        self.cmd = n.create_publisher(JointState, "/littledog/cmd", QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=cmd_depth,
            reliability=ReliabilityPolicy.RELIABLE))
        self.reset_client = n.create_client(Trigger, f"/{sim}/reset")
        self.pause_client = n.create_client(SetBool, f"/{sim}/pause")

    def _add(self, fn) -> None:
        with self.cond:
            fn()
            self.cond.notify_all()

    def _js(self, msg, info):
        q, dq = m.joint_state_arrays(msg)
        src = int(info["source_timestamp"])
        self._add(lambda: self.js.append((src, m.stamp_ns(msg.header.stamp), q, dq)))

    def _odom(self, msg):
        self._add(lambda: self.odom.append((m.stamp_ns(msg.header.stamp), m.odometry_arrays(msg))))

    def _state(self, msg):
        self._add(lambda: self.state.__setitem__(m.stamp_ns(msg.header.stamp), m.state_array(msg)))

    def _applied(self, msg):
        self._add(lambda: self.applied.__setitem__(m.stamp_ns(msg.header.stamp),
                                                   m.joint_state_arrays(msg)[0]))

    def _clock(self, msg):
        self._add(lambda: self.clock.append(m.stamp_ns(msg.clock)))

    def _stats(self, msg):
        self._add(lambda: self.stats.append(m.status_values(msg)))

    def wait(self, pred, timeout: float = TIMEOUT, what: str = "") -> None:
        with self.cond:
            if not self.cond.wait_for(pred, timeout):
                raise AssertionError(f"timed out after {timeout} s waiting for {what or pred}")

    def connect(self, proc: Proc | None = None) -> None:
        """Wait until the simulator's endpoints are matched both ways: here (our subscriptions
        and clients see it) and there (its ``~/stats`` counts our command publisher), so that
        the first command is not lost to one-sided discovery."""
        def ready() -> bool:
            if proc is not None and not proc.alive():
                raise AssertionError(f"{proc.name} exited: {proc.stderr()}")
            with self.cond:
                heard = bool(self.stats) and int(self.stats[-1].get("cmd_publishers", 0)) >= 1
            return (heard and self.cmd.get_subscription_count() >= 1
                    and all(s.get_publisher_count() >= 1 for s in self.subs)
                    and self.reset_client.service_is_ready()
                    and self.pause_client.service_is_ready())
        wait_until(ready, what="discovery of the simulator (both ways)")

    def counter(self, key: str) -> int:
        with self.cond:
            return int(self.stats[-1][key]) if self.stats else 0

    def wait_counter(self, key: str, at_least: int) -> dict[str, str]:
        """Wait until the simulator's ``~/stats`` counts ``key`` at least ``at_least``; on a
        timeout the message gives the last counts the node sent and the machine's load."""
        def seen() -> str:
            with self.cond:
                st = self.stats[-1] if self.stats else {}
            keys = dict.fromkeys((key, "cmd_received", "cmd_accepted", "steps_skipped"))
            return (f"stats {key} >= {at_least} (last stats: "
                    f"{', '.join(f'{k}={st.get(k)}' for k in keys)}; {len(self.stats)} "
                    f"received; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs)")
        try:
            self.wait(lambda: bool(self.stats) and int(self.stats[-1][key]) >= at_least,
                      what=f"stats {key} >= {at_least}")
        except AssertionError:
            raise AssertionError(f"timed out after {TIMEOUT} s waiting for {seen()}") from None
        with self.cond:
            return dict(self.stats[-1])

    def send(self, u: np.ndarray, names=JOINT_NAMES) -> None:
        msg = JointState()
        msg.name = list(names)
        msg.position = [float(x) for x in u]
        self.cmd.publish(msg)

    def call(self, client, request):
        return call_service(client, request)

    def close(self) -> None:
        self.ros.destroy(self.node)
