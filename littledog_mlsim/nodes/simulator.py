"""The ROS shell both simulators share: topics, step modes, commands, services, statistics.

``sim_node`` (learned) and ``pybullet_node`` (pybullet) subclass :class:`SimulatorNode` and only
say how to reset, step and read their robot (:class:`Backend`), so a controller sees the same
topics, message shapes and behaviour from either.

Topics (docs/interface.md §2; publishers reliable, keep-last 10, transient-local so that a
late-joining transient-local subscriber such as bag_recorder gets the last 10 messages):

- subscribes ``/littledog/cmd`` (JointState; reliable, keep-last ``cmd_queue_depth``);
- publishes ``/littledog/joint_states`` (position + velocity, contract order),
  ``/littledog/odom`` (odom -> base_link, twist in base_link), ``/clock`` (if
  ``publish_clock``), and, under the node's name: ``~/state`` (the paper's 33-element state
  s_t, exact float64, as a stamped named vector: a JointState with ``name`` =
  ``layout.STATE_NAMES``, ``position`` = the values; ``messages.state_array``), ``~/cmd_applied``
  (JointState: the command actually applied for the step starting at its stamp, after the
  command rule, the zero-order hold and the timeout rule; these two are only built and sent
  while they have a subscriber) and ``~/stats`` (DiagnosticStatus, every ``stats_period`` s;
  key/value strings: ``step_mode``, ``paused``, ``sim_time``, the counters below, ``steps``,
  ``steps_skipped``, ``diverged``, ``resets``, and over the last period ``rate_hz``,
  ``step_ms_p50/p99/max`` (step start to last publish), ``step_cpu_ms_p50`` (CPU time of
  the step, which excludes waiting for a CPU) and ``latency_ms_p50/p99`` (command
  received to published); level WARN once any command was rejected or a step diverged).

Every published message of step k carries the simulated time ``start_time + k * 10 ms`` (also
on ``/clock``); it never goes backwards, also not on reset. Measurement k = 0 (the initial
state) is published at start-up: volatile subscribers that are not matched yet miss it,
transient-local ones get it.

Step modes (``step_mode``):

- ``timer``: one step per tick of a 100 Hz timer on the steady clock (period
  ``0.01 / real_time_factor``), independent of ``/clock`` and ``use_sim_time``. Each step uses
  the newest valid command received before the tick (zero-order hold). The node keeps its own
  schedule: a tick that comes late (CPU contention) also runs the steps missed since, up to
  ``MAX_CATCH_UP`` = 50 (0.5 s), so the simulated time keeps up with the wall clock and the
  average rate stays 100 Hz (the late steps go out in a burst); a longer stall skips the rest
  (``steps_skipped``, warned): the simulated time then falls behind. Until the first command
  arrives the robot is commanded ``stand_command`` (default ``layout.HOME_POSE``).
- ``lockstep``: exactly one step per accepted command, computed and published in the command's
  callback; no timer, no timeout. For deterministic replay a controller sends command k after it
  received state k (a controller that sends faster than the node steps can lose commands to the
  queue depths).

Command rule: ``messages.check_command`` (names, lengths, NaN/inf rejected; out-of-limit angles
clipped). Counted in ``~/stats``: ``cmd_received``, ``cmd_accepted``, ``cmd_clipped``,
``cmd_rejected_<names|length|nonfinite>``; each kind of problem is logged as a warning at most
once per ``log_throttle`` seconds (with the number suppressed since). A flood (commands faster
than the step rate) is not an error: in timer mode only the newest command before a tick is
used and the others are counted as ``cmd_superseded`` (a warning, throttled, says so); the
callback does no more than the command check, and timers go before subscriptions in rclpy's
executor, so the 100 Hz stepping is kept as long as the process gets the CPU: each received
message costs about 0.2 ms in rclpy, so a 1 kHz flood needs about a quarter of a core on top
of the stepping (``benchmarks/sim_node_latency.md``).

Timeout (timer mode): when no valid command arrived for ``cmd_timeout`` s (0 = never), the node
applies ``cmd_timeout_action``: ``hold`` keeps the last command (the contract's zero-order hold)
or ``stand`` commands ``stand_command``; it logs this once per timeout and once when commands
resume (``cmd_timeouts`` counts them).

Divergence: if the backend cannot produce a finite step (a learned model predicting NaN/inf or a
non-finite pose), nothing non-finite is published: the step is discarded, the robot is reset to
its initial state (time still advances one step) and ``diverged`` is counted.

Services: ``~/reset`` (std_srvs/Trigger): back to the initial state and pose now; the simulated
time advances one step (the initial state is published at the next stamp), the held command
returns to ``stand_command`` until a new command arrives. ``~/pause`` (std_srvs/SetBool): true
stops stepping and publishing (the time stops); lockstep commands received while paused are
dropped (``cmd_dropped_paused``); timer-mode commands still update the held command.

Parameters are declared read-only with descriptions; defaults come from ``config/<node>.yaml``
(section ``<node name>: ros__parameters``) found in the package's share directory or source
tree, and ``--ros-args -p name:=value`` / ``--params-file`` override them
(``_run.ConfiguredNode``, shared with the other nodes). Process start-up, exit status and
shutdown: ``_run.run_node`` (:func:`run_simulator`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticStatus
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

from ..fileio import atomic_write_text
from ..layout import (
    CONTROL_DT,
    CONTROL_DT_NS,
    HOME_POSE,
    JOINT_NAMES,
    N_JOINTS,
    TOPIC_CLOCK,
    TOPIC_CMD,
    TOPIC_JOINT_STATES,
    TOPIC_ODOM,
)
from . import messages as m
from ._run import ConfiguredNode, Param, StartupError, run_node

__all__ = ["SimulatorNode", "Backend", "QOS", "SIM_QOS", "run_simulator", "COMMON_PARAMS"]

QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                 reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
# The simulators' publishers: also transient-local, so a late-joining transient-local subscriber
# (bag_recorder) still gets the last 10 messages, e.g. measurement 0; volatile subscribers match
# as usual.
SIM_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
STEP_MODES = ("timer", "lockstep")
MAX_CATCH_UP = 50   # timer mode: at most this many missed steps (0.5 s) are run late
TIMEOUT_ACTIONS = ("hold", "stand")

COMMON_PARAMS: tuple[Param, ...] = (
    Param("step_mode", "timer", "timer: one step per tick of a 100 Hz steady-clock timer, "
          "holding the newest valid command; lockstep: exactly one step per received command",
          "timer | lockstep"),
    Param("real_time_factor", 1.0, "timer mode: simulated seconds per wall second (tick period "
          "0.01 s / real_time_factor)", "> 0"),
    Param("publish_clock", True, "publish the simulated time on /clock (10 ms per step)"),
    Param("start_time", 0.0, "simulated time of the initial state [s]", ">= 0"),
    Param("cmd_timeout", 0.5, "timer mode: seconds without a valid command before "
          "cmd_timeout_action applies (0: never)", ">= 0"),
    Param("cmd_timeout_action", "hold", "after cmd_timeout: hold = keep the last command, "
          "stand = command stand_command", "hold | stand"),
    Param("stand_command", Parameter.Type.DOUBLE_ARRAY, "12 joint angles [rad], contract order, "
          "commanded before the first command, after a reset and by the stand timeout action "
          "(unset: layout.HOME_POSE)", "12 finite values"),
    Param("cmd_queue_depth", 100, "depth of the /littledog/cmd subscription queue", ">= 1"),
    Param("stats_period", 1.0, "seconds between ~/stats messages (0: none)", ">= 0"),
    Param("log_throttle", 2.0, "seconds between two warnings about the same kind of bad "
          "command", ">= 0"),
    Param("latency_log", "", "if set, a CSV file written at shutdown with one row per step: "
          "cmd_received_ns, step_start_ns, published_ns (system clock; cmd_received_ns -1 if "
          "the step reused a held command), step_cpu_ns (the thread's CPU time of the step)"),
)


class Throttle:
    """At most one log line per key and ``period`` seconds, counting the suppressed ones."""

    def __init__(self, log: Callable[[str], None], period: float) -> None:
        self.log, self.period = log, period
        self._last: dict[str, float] = {}
        self._suppressed: dict[str, int] = {}

    def __call__(self, key: str, text: str) -> None:
        now = time.monotonic()
        last = self._last.get(key)
        if last is not None and now - last < self.period:
            self._suppressed[key] = self._suppressed.get(key, 0) + 1
            return
        n = self._suppressed.pop(key, 0)
        self._last[key] = now
        self.log(text + (f" ({n} more since the last such message)" if n else ""))


class Backend:
    """What a simulator node steps. After ``reset``/``step`` the attributes hold the outputs:
    ``q``, ``dq`` (12,), ``position`` (3,), ``orientation`` (4,) xyzw, ``linear_velocity``,
    ``angular_velocity`` (3,) in base_link, ``state`` (33,) or None, ``pose_covariance``,
    ``twist_covariance`` (36,) or None (unknown)."""

    def reset(self) -> None:
        raise NotImplementedError

    def step(self, u: np.ndarray) -> bool:
        """One 10 ms step; False if it produced nothing finite (the node resets then)."""
        raise NotImplementedError

    def outputs_finite(self) -> bool:
        raise NotImplementedError


@dataclass
class Counters:
    steps: int = 0
    cmd_received: int = 0
    cmd_accepted: int = 0
    cmd_clipped: int = 0
    cmd_rejected_names: int = 0
    cmd_rejected_length: int = 0
    cmd_rejected_nonfinite: int = 0
    cmd_superseded: int = 0
    cmd_dropped_paused: int = 0
    cmd_timeouts: int = 0
    steps_skipped: int = 0
    diverged: int = 0
    resets: int = 0

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)


@dataclass
class _StepTimes:
    received: list[int] = field(default_factory=list)   # system ns, -1 = held command
    start: list[int] = field(default_factory=list)
    published: list[int] = field(default_factory=list)
    cpu: list[int] = field(default_factory=list)         # thread CPU ns of the step
    max_len: int = 1_000_000

    def add(self, received: int, start: int, published: int, cpu: int) -> None:
        if len(self.start) < self.max_len:
            self.received.append(received)
            self.start.append(start)
            self.published.append(published)
            self.cpu.append(cpu)


class SimulatorNode(ConfiguredNode):
    """Base of sim_node and pybullet_node; subclasses set ``CONFIG_FILE``, ``PARAMS`` and
    implement ``make_backend()`` (called after the parameters are declared)."""

    CONFIG_FILE = ""
    PARAMS: tuple[Param, ...] = ()

    def __init__(self, node_name: str) -> None:
        super().__init__(node_name, self.PARAMS + COMMON_PARAMS)
        self.step_mode = self._choice("step_mode", STEP_MODES)
        self.timeout_action = self._choice("cmd_timeout_action", TIMEOUT_ACTIONS)
        rtf = self.param("real_time_factor")
        self.cmd_timeout = self.param("cmd_timeout")
        start = self.param("start_time")
        depth = self.param("cmd_queue_depth")
        self.stats_period = self.param("stats_period")
        if not rtf > 0 or not self.cmd_timeout >= 0 or not start >= 0 or depth < 1 \
                or not self.stats_period >= 0 or not self.param("log_throttle") >= 0:
            raise StartupError("real_time_factor must be > 0, cmd_queue_depth >= 1, and "
                               "cmd_timeout, start_time, stats_period, log_throttle >= 0")
        stand = self.param("stand_command")
        self.stand_command = (HOME_POSE.copy() if stand is None
                              else np.asarray(stand, dtype=np.float64))
        if self.stand_command.shape != (N_JOINTS,) or not np.all(np.isfinite(self.stand_command)):
            raise StartupError(f"stand_command must be {N_JOINTS} finite joint angles")
        chk = m.check_command(JOINT_NAMES, self.stand_command)
        self.stand_command = chk.u

        self.backend: Backend = self.make_backend()

        self.counters = Counters()
        self._throttle = Throttle(self.get_logger().warning, self.param("log_throttle"))
        self._start_ns = int(round(start * 1e9))
        self._k = 0                      # step index of the published state
        self._paused = False
        self._held = self.stand_command.copy()
        self._fresh: tuple[np.ndarray, int] | None = None   # (u, received ns) not used yet
        self._last_cmd_time: float | None = None            # monotonic s of the last accepted
        self._timed_out = False
        self._times = _StepTimes()
        self._stats_index = 0
        self._stats_time = time.monotonic()
        self._latency_log = self.param("latency_log")

        self.pub_js = self.create_publisher(JointState, TOPIC_JOINT_STATES, SIM_QOS)
        self.pub_odom = self.create_publisher(Odometry, TOPIC_ODOM, SIM_QOS)
        self.pub_clock = (self.create_publisher(ClockMsg, TOPIC_CLOCK, SIM_QOS)
                          if self.param("publish_clock") else None)
        # the node's own topics without rclpy's default QoS-event handlers: fewer entities in
        # the executor's wait set, which it rebuilds on every wake-up
        quiet = PublisherEventCallbacks(use_default_callbacks=False)
        self.pub_state = self.create_publisher(JointState, "~/state", SIM_QOS,
                                               event_callbacks=quiet)
        self.pub_applied = self.create_publisher(JointState, "~/cmd_applied", SIM_QOS,
                                                 event_callbacks=quiet)
        self.pub_stats = self.create_publisher(DiagnosticStatus, "~/stats", SIM_QOS,
                                               event_callbacks=quiet)
        cmd_qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                             reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.VOLATILE)
        self.create_subscription(JointState, TOPIC_CMD, self._on_cmd, cmd_qos)
        self.create_service(Trigger, "~/reset", self._on_reset)
        self.create_service(SetBool, "~/pause", self._on_pause)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        if self.step_mode == "timer":
            self._period_ns = int(round(CONTROL_DT_NS / rtf))
            self._tick0: int | None = None    # schedule origin, set by the first tick
            self._ticks_done = 0
            self.create_timer(CONTROL_DT / rtf, self._on_tick, clock=steady)
        if self.stats_period > 0:
            self.create_timer(self.stats_period, self._publish_stats, clock=steady)

        self._publish(None)   # measurement 0

    # -- parameters -------------------------------------------------------------------------

    def _choice(self, name: str, choices: Sequence[str]) -> str:
        v = self.param(name)
        if v not in choices:
            raise StartupError(f"parameter {name} must be one of {', '.join(choices)}, got {v!r}")
        return v

    def make_backend(self) -> Backend:
        raise NotImplementedError

    # -- commands -----------------------------------------------------------------------------

    def _on_cmd(self, msg: JointState, info: Any = None) -> None:
        received = _received_ns(info)
        c = self.counters
        c.cmd_received += 1
        chk = m.check_command(msg.name, msg.position)
        if not chk.accepted:
            setattr(c, f"cmd_rejected_{chk.reason}", getattr(c, f"cmd_rejected_{chk.reason}") + 1)
            self._throttle(chk.reason, f"rejected a command ({chk.reason}): {chk.detail}; "
                                       f"holding the previous command")
            return
        c.cmd_accepted += 1
        if chk.reason == "clipped":
            c.cmd_clipped += 1
            self._throttle("clipped", f"clipped a command to the joint limits: {chk.detail}")
        if self.step_mode == "lockstep":
            if self._paused:
                c.cmd_dropped_paused += 1
                self._throttle("paused", "paused: dropped a lockstep command")
                return
            self._held = chk.u
            self._advance(chk.u, received, time.time_ns())
            return
        if self._fresh is not None:
            c.cmd_superseded += 1
            self._throttle("flood", "commands arrive faster than the 100 Hz step rate: only the "
                                    "newest one before each step is used")
        self._fresh = (chk.u, received)
        self._last_cmd_time = time.monotonic()
        if self._timed_out:
            self._timed_out = False
            self.get_logger().info("commands resumed")

    def _on_tick(self) -> None:
        """Run the steps due by now on the node's own 100 Hz schedule: one normally; after a
        late tick (CPU contention) the missed ones too, up to MAX_CATCH_UP, so the average rate
        stays 100 Hz (rcl drops missed timer periods); beyond that they are skipped."""
        now = time.monotonic_ns()
        if self._tick0 is None:
            self._tick0 = now - self._period_ns
        due = (now - self._tick0 + self._period_ns // 2) // self._period_ns
        behind = due - self._ticks_done
        if behind <= 0:
            return
        if behind > MAX_CATCH_UP:
            skipped = behind - MAX_CATCH_UP
            self.counters.steps_skipped += skipped
            self._throttle("skipped", f"fell {behind * self._period_ns / 1e6:.0f} ms behind the "
                                      f"100 Hz schedule: skipped {skipped} step(s)")
            behind = MAX_CATCH_UP
        self._ticks_done = due
        if self._paused:
            return
        for _ in range(behind):
            self._timer_step()

    def _timer_step(self) -> None:
        start = time.time_ns()
        if self._fresh is not None:
            u, received = self._fresh
            self._fresh = None
            self._held = u
        else:
            received = -1
            if self._last_cmd_time is not None and self.cmd_timeout > 0 and not self._timed_out \
                    and time.monotonic() - self._last_cmd_time > self.cmd_timeout:
                self._timed_out = True
                self.counters.cmd_timeouts += 1
                if self.timeout_action == "stand":
                    self._held = self.stand_command.copy()
                    what = "commanding stand_command"
                else:
                    what = "holding the last command"
                self.get_logger().warning(f"no valid command for {self.cmd_timeout:g} s: {what}")
        self._advance(self._held, received, start)

    def _advance(self, u: np.ndarray, received: int, start: int) -> None:
        """Step the backend with u and publish the new measurement (or reset on divergence)."""
        cpu0 = time.thread_time_ns()
        ok = self.backend.step(u) and self.backend.outputs_finite()
        if not ok:
            self.counters.diverged += 1
            self.get_logger().error("the simulator produced a non-finite state: discarded the "
                                    "step and reset to the initial state",
                                    throttle_duration_sec=2.0)
            self.backend.reset()
        self._k += 1
        self.counters.steps += 1
        self._publish(u)
        self._times.add(received, start, time.time_ns(), time.thread_time_ns() - cpu0)

    def _publish(self, u: np.ndarray | None) -> None:
        b = self.backend
        ns = self._start_ns + self._k * CONTROL_DT_NS
        # ~/cmd_applied and ~/state are built only while someone subscribes (CPU per step)
        if u is not None and self.pub_applied.get_subscription_count():
            self.pub_applied.publish(m.joint_state_msg(ns - CONTROL_DT_NS, u))
        if self.pub_clock is not None:
            self.pub_clock.publish(m.clock_msg(ns))
        self.pub_js.publish(m.joint_state_msg(ns, b.q, b.dq))
        self.pub_odom.publish(m.odometry_msg(ns, b.position, b.orientation, b.linear_velocity,
                                             b.angular_velocity, b.pose_covariance,
                                             b.twist_covariance))
        if b.state is not None and self.pub_state.get_subscription_count():
            self.pub_state.publish(m.state_msg(ns, b.state))

    # -- services -------------------------------------------------------------------------------

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response):
        self.backend.reset()
        self.counters.resets += 1
        self._held = self.stand_command.copy()
        self._fresh = None
        self._last_cmd_time = None
        self._timed_out = False
        self._k += 1
        self._publish(None)
        response.success = True
        response.message = f"reset to the initial state at t = {self.sim_time_ns() / 1e9:.2f} s"
        self.get_logger().info(response.message)
        return response

    def _on_pause(self, request: SetBool.Request, response: SetBool.Response):
        was = self._paused
        self._paused = bool(request.data)
        response.success = True
        state = "paused" if self._paused else "running"
        response.message = state if was != self._paused else f"already {state}"
        if was != self._paused:
            self.get_logger().info(state)
        return response

    def sim_time_ns(self) -> int:
        return self._start_ns + self._k * CONTROL_DT_NS

    # -- statistics -----------------------------------------------------------------------------

    def _window(self) -> dict[str, Any]:
        t = self._times
        i0, i1 = self._stats_index, len(t.start)
        now = time.monotonic()
        span = max(now - self._stats_time, 1e-9)
        self._stats_index, self._stats_time = i1, now
        out: dict[str, Any] = {"rate_hz": f"{(i1 - i0) / span:.2f}"}
        if i1 > i0:
            start = np.asarray(t.start[i0:i1])
            pub = np.asarray(t.published[i0:i1])
            rec = np.asarray(t.received[i0:i1])
            step_ms = (pub - start) / 1e6
            cpu_ms = np.asarray(t.cpu[i0:i1]) / 1e6
            out.update(step_ms_p50=f"{np.percentile(step_ms, 50):.3f}",
                       step_ms_p99=f"{np.percentile(step_ms, 99):.3f}",
                       step_ms_max=f"{step_ms.max():.3f}",
                       step_cpu_ms_p50=f"{np.percentile(cpu_ms, 50):.3f}")
            have = rec >= 0
            if have.any():
                lat = (pub[have] - rec[have]) / 1e6
                out.update(latency_ms_p50=f"{np.percentile(lat, 50):.3f}",
                           latency_ms_p99=f"{np.percentile(lat, 99):.3f}")
        return out

    def _publish_stats(self) -> None:
        values: dict[str, Any] = {"step_mode": self.step_mode, "paused": self._paused,
                                  "sim_time": f"{self.sim_time_ns() / 1e9:.2f}"}
        values.update(self.counters.as_dict())
        values.update(self._window())
        bad = (self.counters.cmd_rejected_names + self.counters.cmd_rejected_length
               + self.counters.cmd_rejected_nonfinite + self.counters.diverged)
        self.pub_stats.publish(m.status_msg(self.get_name(), values, 1 if bad else 0))

    def write_latency_log(self) -> None:
        if not self._latency_log:
            return
        t = self._times
        rows = "".join(f"{r},{s},{p},{c}\n"
                       for r, s, p, c in zip(t.received, t.start, t.published, t.cpu, strict=True))
        atomic_write_text(self._latency_log,
                          "cmd_received_ns,step_start_ns,published_ns,step_cpu_ns\n" + rows)


def _received_ns(info: Any) -> int:
    """The DDS receive time (system clock ns) of a message, or now if the rmw gives none."""
    if isinstance(info, dict):
        ns = info.get("received_timestamp", 0)
        if ns:
            return int(ns)
    return time.time_ns()


def run_simulator(factory: Callable[[], SimulatorNode], name: str,
                  args: Sequence[str] | None = None) -> int:
    """``_run.run_node`` for a simulator: spin until SIGINT/SIGTERM (rclpy's handlers turn them
    into ExternalShutdownException; exit status 0), then write the latency log.

    The executor is rclpy's SingleThreadedExecutor. (rclpy.experimental.EventsExecutor needs
    about 40 % less CPU per step here but never notices SIGINT/SIGTERM in this rclpy, 7.1.6.)
    """
    return run_node(name, factory, _spin, args, rclpy_signals=True)


def _spin(node: SimulatorNode) -> None:
    try:
        rclpy.spin(node)
    finally:
        try:
            node.write_latency_log()
        except OSError as e:
            node.get_logger().error(f"cannot write the latency log: {e}")
