"""The ROS shell both simulators share: topics, services and parameters wired to the core.

``sim_node`` (learned) and ``pybullet_node`` (pybullet) subclass :class:`SimulatorNode` and only
say which robot to step (a ``sim.backend.Backend``), so a controller sees the same topics,
message shapes and behaviour from either. The rules below (step modes, zero-order hold,
timeout, catch-up, pause, reset, divergence, counters, statistics) are implemented, without
rclpy, by ``sim.core.SimulatorCore`` and unit-tested there with a fake clock
(``docs/simulator.md``); this module only turns messages, timers and service calls into calls
of the core and its outputs into messages.

Topics (docs/interface.md §2; publishers reliable, keep-last 10, transient-local so that a
late-joining transient-local subscriber such as bag_recorder gets the last 10 messages):

- subscribes ``/littledog/cmd`` (JointState; reliable; timer mode keep-last ``cmd_queue_depth``,
  lockstep keep-all: see Step modes);
- publishes ``/littledog/joint_states`` (position + velocity, contract order),
  ``/littledog/odom`` (odom -> base_link, twist in base_link), ``/clock`` (if
  ``publish_clock``), and, under the node's name: ``~/state`` (the paper's 33-element state
  s_t, exact float64, as a stamped named vector: a JointState with ``name`` =
  ``layout.STATE_NAMES``, ``position`` = the values; ``messages.state_array``), ``~/cmd_applied``
  (JointState: the command actually applied for the step starting at its stamp, after the
  command rule, the zero-order hold and the timeout rule; always sent, so that its
  transient-local history, like that of the measurements, holds the last 10 for a recorder
  whose subscription the node matches only after the first steps; ``~/state`` is only built
  and sent while it has a subscriber) and ``~/stats`` (DiagnosticStatus, every ``stats_period`` s;
  key/value strings: ``step_mode``, ``paused``, ``sim_time``, the counters below, ``steps``,
  ``steps_skipped``, ``diverged``, ``resets``, and over the last period ``rate_hz``,
  ``real_time_factor`` (simulated seconds per wall second), ``step_ms_p50/p99/max`` (step
  start to last publish), ``step_cpu_ms_p50/p99`` (CPU time of the step, which excludes
  waiting for a CPU) and ``latency_ms_p50/p99`` (command received to published), then the
  backend's own keys (sim_node: the distance to the data, ``nodes/sim_node.py``); level WARN
  once any command was rejected or a step diverged);
- publishes ``/robot_description`` (std_msgs/String, reliable, transient-local, once): the
  robot's URDF with a ``base_link`` root joined fixed to its ``body`` link (the same frame),
  as robot_state_publisher publishes it;
- publishes ``odom -> base_link`` on ``/tf`` (tf2_msgs/TFMessage, each step, the odometry's
  pose) where ``tf2_msgs`` is importable (full ROS installs; the pip wheels lack it: then no
  ``/tf``, said once at start-up), unless ``publish_tf`` is false.

Every published message of step k carries the simulated time ``start_time + k * 10 ms`` (also
on ``/clock``); it never goes backwards, also not on reset. Measurement k = 0 (the initial
state) is published at start-up: volatile subscribers that are not matched yet miss it,
transient-local ones get it.

Step modes (``step_mode``):

- ``timer``: one step per tick of a 100 Hz timer on the steady clock (period
  ``0.01 / real_time_factor``), independent of ``/clock`` and ``use_sim_time``. Each step uses
  the newest valid command received before the tick (zero-order hold). The node keeps its own
  schedule: steps missed by late ticks (CPU contention) are run late, at most
  ``steps_per_tick`` (default 2) per tick, so, while the node has the time for it, the
  simulated time keeps up with the wall clock and the average rate stays 100 Hz, and at least
  every other step takes a new command (one burst of the whole backlog would hold one command
  for all of it); a backlog beyond ``MAX_CATCH_UP`` = 50 (0.5 s) is skipped (``steps_skipped``,
  warned): the simulated time then falls behind (in sustained overload, all the time). Until
  the first command arrives the robot is commanded ``stand_command`` (default
  ``layout.HOME_POSE``).
- ``lockstep``: exactly one step per accepted command, computed and published in the command's
  callback; no timer, no timeout. For deterministic replay a controller sends command k after it
  received state k. A controller may also send faster than the node steps: the command
  subscription then keeps all (reliable, keep-all history), so a burst waits in the node's
  queue, or, once DDS's resource limits are reached, in the controller's writer (it is not
  acknowledged until there is room), and every valid command makes its step, in order. The
  controller's own publisher must keep what it has not yet delivered: keep-all, or keep-last
  with a depth of at least its longest burst (a shallower one overwrites its own unsent
  commands).

Command rule: ``messages.check_command`` (names, lengths, NaN/inf rejected; out-of-limit angles
clipped). ``~/stats`` also says ``cmd_publishers``, the publishers of ``/littledog/cmd`` the node
has matched: a controller that sees itself counted there knows its commands reach the node
(discovery is two-sided, and its own matched count says only that it sees the node). Counted in
``~/stats``: ``cmd_received``, ``cmd_accepted``, ``cmd_clipped``,
``cmd_rejected_<names|length|nonfinite>``; each kind of problem is logged as a warning at most
once per ``log_throttle`` seconds (with the number suppressed since). A flood (commands faster
than the step rate) is not an error: in timer mode only the newest command before a tick is
used and the others are counted as ``cmd_superseded`` (a warning, throttled, says so); the
callback does no more than the command check, and timers go before subscriptions in rclpy's
executor, so the 100 Hz stepping is kept as long as the process gets the CPU: each received
message costs about 0.2 ms in rclpy, so a 1 kHz flood needs about a quarter of a core on top
of the stepping (``benchmarks/sim_node_latency/sim_node_latency.md``).

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
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger

from ..layout import CONTROL_DT, TOPIC_CLOCK, TOPIC_CMD, TOPIC_JOINT_STATES, TOPIC_ODOM
from ..sim.backend import Backend
from ..sim.core import STEP_MODES, TIMEOUT_ACTIONS, CoreConfig, Logs, SimulatorCore
from . import messages as m
from ._run import ConfiguredNode, Param, StartupError, run_node
from .simulation_services import SimulationServices, interface_types

__all__ = ["SimulatorNode", "Backend", "QOS", "SIM_QOS", "run_simulator", "COMMON_PARAMS",
           "TOPIC_ROBOT_DESCRIPTION", "TOPIC_TF"]

QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                 reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
# The simulators' publishers: also transient-local, so a late-joining transient-local subscriber
# (bag_recorder) still gets the last 10 messages, e.g. measurement 0; volatile subscribers match
# as usual.
SIM_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
# /robot_description as robot_state_publisher offers it: keep-last 1, transient-local
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
TOPIC_ROBOT_DESCRIPTION = "/robot_description"
TOPIC_TF = "/tf"

COMMON_PARAMS: tuple[Param, ...] = (
    Param("step_mode", "timer", "timer: one step per tick of a 100 Hz steady-clock timer, "
          "holding the newest valid command; lockstep: exactly one step per received command",
          "timer | lockstep"),
    Param("real_time_factor", 1.0, "timer mode: simulated seconds per wall second (tick period "
          "0.01 s / real_time_factor)", "> 0"),
    Param("steps_per_tick", 2, "timer mode: steps one tick runs at most when the node is "
          "behind its schedule; ticks on time drain the backlog by steps_per_tick - 1 each and "
          "take the commands received in between (50: the whole backlog at once, on one held "
          "command)", "2..50"),
    Param("publish_clock", True, "publish the simulated time on /clock (10 ms per step)"),
    Param("start_time", 0.0, "simulated time of the initial state [s]", ">= 0"),
    Param("cmd_timeout", 0.5, "timer mode: seconds without a valid command before "
          "cmd_timeout_action applies (0: never)", ">= 0"),
    Param("cmd_timeout_action", "hold", "after cmd_timeout: hold = keep the last command, "
          "stand = command stand_command", "hold | stand"),
    Param("stand_command", Parameter.Type.DOUBLE_ARRAY, "12 joint angles [rad], contract order, "
          "commanded before the first command, after a reset and by the stand timeout action "
          "(unset: layout.HOME_POSE)", "12 finite values"),
    Param("cmd_queue_depth", 100, "timer mode: depth of the /littledog/cmd subscription queue "
          "(lockstep keeps all commands)", ">= 1"),
    Param("stats_period", 1.0, "seconds between ~/stats messages (0: none)", ">= 0"),
    Param("log_throttle", 2.0, "seconds between two warnings about the same kind of bad "
          "command", ">= 0"),
    Param("latency_log", "", "if set, a CSV file written at shutdown with one row per step: "
          "cmd_received_ns, step_start_ns, published_ns (system clock; cmd_received_ns -1 if "
          "the step reused a held command), step_cpu_ns (the thread's CPU time of the step)"),
    Param("publish_tf", True, "publish odom -> base_link on /tf each step (only where tf2_msgs "
          "is installed) and the URDF on /robot_description (always)"),
    Param("executor", "single", "rclpy executor: single (SingleThreadedExecutor) or events "
          "(rclpy.experimental.EventsExecutor: faster in lockstep, slower in timer mode at "
          "real_time_factor 20 with a streaming controller; benchmarks/sim_node_20x)",
          "single | events"),
)

EXECUTORS = ("single", "events")


class SimulatorNode(ConfiguredNode):
    """Base of sim_node and pybullet_node; subclasses set ``CONFIG_FILE``, ``PARAMS`` and
    implement ``make_backend()`` (called after the parameters are declared)."""

    CONFIG_FILE = ""
    PARAMS: tuple[Param, ...] = ()

    def __init__(self, node_name: str) -> None:
        super().__init__(node_name, self.PARAMS + COMMON_PARAMS)
        self.step_mode = self._choice("step_mode", STEP_MODES)
        self._choice("cmd_timeout_action", TIMEOUT_ACTIONS)
        self.executor_kind = self._choice("executor", EXECUTORS)
        if self.executor_kind == "events":
            try:
                from rclpy.experimental import EventsExecutor  # noqa: F401
            except ImportError as e:
                raise StartupError(f"parameter executor: events needs rclpy.experimental."
                                   f"EventsExecutor, which this rclpy lacks ({e})") from None
        depth = self.param("cmd_queue_depth")
        self.stats_period = self.param("stats_period")
        start = self.param("start_time")
        stand = self.param("stand_command")
        bounds = ("real_time_factor must be > 0, cmd_queue_depth >= 1, and cmd_timeout, "
                  "start_time, stats_period, log_throttle >= 0")
        if depth < 1 or not self.stats_period >= 0 or not (start >= 0 and np.isfinite(start)):
            raise StartupError(bounds)
        try:
            config = CoreConfig(
                step_mode=self.step_mode, real_time_factor=self.param("real_time_factor"),
                start_ns=int(round(start * 1e9)), cmd_timeout=self.param("cmd_timeout"),
                cmd_timeout_action=self.param("cmd_timeout_action"),
                log_throttle=self.param("log_throttle"),
                steps_per_tick=self.param("steps_per_tick"),
                **({} if stand is None else {"stand_command": np.asarray(stand, dtype=float)}))
        except ValueError as e:
            raise StartupError(str(e) if "stand_command" in str(e) or "steps_per_tick" in str(e)
                               else bounds) from None
        self.stand_command = config.stand_command
        self._latency_log = self.param("latency_log")

        self.backend: Backend = self.make_backend()

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
        self.pub_description = self.create_publisher(String, TOPIC_ROBOT_DESCRIPTION,
                                                     LATCHED_QOS, event_callbacks=quiet)
        self.pub_description.publish(String(data=m.robot_description()))
        self.pub_tf = None
        if self.param("publish_tf"):
            tf_type = m.tf_message_type()
            if tf_type is None:
                self.get_logger().info("tf2_msgs is not installed: no odom -> base_link on /tf")
            else:
                self.pub_tf = self.create_publisher(tf_type, TOPIC_TF, QOS,
                                                    event_callbacks=quiet)
                self._tf = m.TfOdometry(tf_type)
        # lockstep: one step per command, so none may be dropped (module doc, Step modes)
        cmd_qos = (QoSProfile(history=HistoryPolicy.KEEP_ALL,
                              reliability=ReliabilityPolicy.RELIABLE,
                              durability=DurabilityPolicy.VOLATILE)
                   if self.step_mode == "lockstep" else
                   QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                              reliability=ReliabilityPolicy.RELIABLE,
                              durability=DurabilityPolicy.VOLATILE))
        log = self.get_logger()
        self.core = SimulatorCore(self.backend, config, self._publish,
                                  logs=Logs(info=log.info, warning=log.warning, error=log.error))
        self._js = m.JointStateWriter()
        self._odom = m.OdometryWriter()
        self.sub_cmd = self.create_subscription(JointState, TOPIC_CMD, self._on_cmd, cmd_qos)
        self.create_service(Trigger, "~/reset", self._on_reset)
        self.create_service(SetBool, "~/pause", self._on_pause)
        self.simulation_services = self._serve_simulation_interfaces()
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        if self.step_mode == "timer":
            self.create_timer(CONTROL_DT / config.real_time_factor, self.core.on_tick,
                              clock=steady)
        if self.stats_period > 0:
            self.create_timer(self.stats_period, self._publish_stats, clock=steady)

        self.core.start()   # measurement 0

    # -- parameters -------------------------------------------------------------------------

    def _choice(self, name: str, choices: Sequence[str]) -> str:
        v = self.param(name)
        if v not in choices:
            raise StartupError(f"parameter {name} must be one of {', '.join(choices)}, got {v!r}")
        return v

    def make_backend(self) -> Backend:
        raise NotImplementedError

    def extra_stats(self) -> dict[str, Any]:
        """The node's own ``~/stats`` entries (sim_node: ``model_swaps``)."""
        return {}

    @property
    def counters(self):
        return self.core.counters

    def sim_time_ns(self) -> int:
        return self.core.sim_time_ns

    # -- topics -------------------------------------------------------------------------------

    def _on_cmd(self, msg: JointState, info: Any = None) -> None:
        self.core.on_command(msg.name, msg.position, _received_ns(info))

    def _publish(self, ns: int, u: np.ndarray | None) -> None:
        """Send the backend's outputs stamped ``ns`` (the core's ``publish``)."""
        b = self.backend
        # ~/cmd_applied always (a small message): sent only while a subscriber was matched,
        # the commands of the steps before this node matched a recorder (which the recorder's
        # own process may have seen matched already) were never sent, nor kept in the
        # transient-local history, and the recording lost its first steps
        if u is not None:
            self.pub_applied.publish(m.joint_state_msg(ns - m.CONTROL_DT_NS, u))
        if self.pub_clock is not None:
            self.pub_clock.publish(m.clock_msg(ns))
        self.pub_js.publish(self._js(ns, b.q, b.dq))
        self.pub_odom.publish(self._odom(ns, b.position, b.orientation, b.linear_velocity,
                                         b.angular_velocity, b.pose_covariance,
                                         b.twist_covariance))
        if self.pub_tf is not None:
            self.pub_tf.publish(self._tf(ns, b.position, b.orientation))
        # ~/state is built only while someone subscribes (CPU per step)
        if b.state is not None and self.pub_state.get_subscription_count():
            self.pub_state.publish(m.state_msg(ns, b.state))

    def _publish_stats(self) -> None:
        values, level = self.core.stats()
        # this side's view of the match: a controller that sees its publisher counted here
        # knows its next command reaches the node (its own matched count says only that it
        # sees the node's subscription)
        values["cmd_publishers"] = self.sub_cmd.get_publisher_count()
        values.update(self.extra_stats())
        self.pub_stats.publish(m.status_msg(self.get_name(), values, level))

    # -- services -------------------------------------------------------------------------------

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response):
        response.message = self.core.reset()
        response.success = True
        return response

    def _on_pause(self, request: SetBool.Request, response: SetBool.Response):
        response.message = self.core.set_paused(request.data)
        response.success = True
        return response

    def _serve_simulation_interfaces(self) -> SimulationServices | None:
        """The standard simulation services where ``simulation_interfaces`` is importable
        (``nodes/simulation_services.py``); None, said once, where it is not."""
        types = interface_types()
        if types is None:
            self.get_logger().info("simulation_interfaces is not installed: no standard "
                                   "simulation services (~/reset and ~/pause are served)")
            return None
        services = SimulationServices(types, self.core, lambda: self.backend, self.get_name(),
                                      log=self.get_logger().error)
        for name, srv_type, handler in services.endpoints():
            self.create_service(srv_type, name, handler)
        return services

    def write_latency_log(self) -> None:
        if self._latency_log:
            self.core.write_latency_log(self._latency_log)


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

    The executor is the node's ``executor`` parameter: rclpy's SingleThreadedExecutor
    (``single``), or ``events``, rclpy.experimental.EventsExecutor, spun one event at a time
    with a 0.1 s timeout: its ``spin()`` never returns on SIGINT/SIGTERM in this rclpy (7.1.6),
    while the ``spin_once`` loop ends with KeyboardInterrupt (SIGINT) or
    ExternalShutdownException (SIGTERM), both an interruption for ``run_node``. The events
    executor runs ready callbacks in arrival order, not timers before subscriptions.
    """
    return run_node(name, factory, _spin, args, rclpy_signals=True)


def _spin(node: SimulatorNode) -> None:
    try:
        if node.executor_kind == "events":
            from rclpy.experimental import EventsExecutor

            executor = EventsExecutor(context=node.context)
            executor.add_node(node)
            try:
                while True:
                    executor.spin_once(timeout_sec=0.1)
            finally:
                executor.shutdown()
        else:
            rclpy.spin(node)
    finally:
        try:
            node.write_latency_log()
        except OSError as e:
            node.get_logger().error(f"cannot write the latency log: {e}")
