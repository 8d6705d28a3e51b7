"""bag_recorder: record a simulator's live topics into one contract bag (docs/interface.md §3).

    bag_recorder --ros-args -p out:=/tmp/run/F_00 [-p max_steps:=400] [-p storage:=mcap]

Subscribes to ``/littledog/joint_states`` and ``/littledog/odom`` and to the command topic
``cmd_topic`` (default ``/sim_node/cmd_applied``: the command the simulator actually applied
for the step starting at its stamp, so commands and measurements are on one clock; use
``/pybullet_node/cmd_applied`` for the pybullet robot), all transient-local, so the last 10
messages before it joined (e.g. measurement 0) are recorded too. On SIGINT/SIGTERM, or once
``max_steps`` steps are recorded, it writes the bag with the core's ``write_bag`` (atomic;
``out`` must not exist; its directory name ``<TYPE>_<NN>`` is the bag's name) and exits.

Ready: once it has received a complete measurement (a joint state and an odometry message with
the same stamp, e.g. the simulator's initial state, measurement 0) and its ``cmd_topic``
subscription has a matched publisher, it logs one line (INFO) starting ``ready:``. A script
that starts the recorder, then the simulator, then a controller waits for that line before it
sends the first command: a subscription that the caller's own process sees in the ROS graph is
not yet one that the simulator has matched, nor one that has received anything. (The
simulator sends ``~/cmd_applied`` whether or not it has a subscriber, so its transient-local
history also holds the first commands for a recorder the simulator matched late.)

What goes in: the first contiguous run of the 100 Hz clock starting at the first stamp that has
a joint state, an odometry message and an applied command; it ends at the first stamp where any
of them is missing (a reset, a pause that dropped nothing is fine, a lost message), with the
last measurement's command left out (N commands, N + 1 measurements). Exit status 0 when the
bag is written, 1 when there is nothing to write (fewer than 2 measurements) or writing fails,
2 for a bad parameter, 130 when a signal comes before recording started or while writing.
"""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Sequence

import rclpy
from rclpy.qos import QoSProfile
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from ..layout import TOPIC_JOINT_STATES, TOPIC_ODOM
from ._run import ConfiguredNode, Param, StartupError, one_line, run_node
from .recording import TopicRecording, move_recording
from .simulator import SIM_QOS

# A recorder must not lose messages when it falls behind for a moment (a busy machine): the same
# QoS as the simulators' publishers (reliable, transient-local), with a deep reader queue.
RECORD_QOS = QoSProfile(history=SIM_QOS.history, depth=1000, reliability=SIM_QOS.reliability,
                        durability=SIM_QOS.durability)

NODE_NAME = "bag_recorder"

PARAMS: tuple[Param, ...] = (
    Param("out", "", "bag directory to create, named <TYPE>_<NN> (required, must not exist)"),
    Param("cmd_topic", "/sim_node/cmd_applied", "JointState topic of the applied commands, "
          "stamped at the start of their step"),
    Param("max_steps", 0, "stop after this many steps (0: record until SIGINT/SIGTERM)", ">= 0"),
    Param("storage", "mcap", "rosbag2 storage plugin", "mcap | sqlite3"),
)


class RecordError(Exception):
    """Nothing usable was recorded or writing failed (one FATAL line, exit status 1)."""


class BagRecorder(ConfiguredNode):
    def __init__(self) -> None:
        super().__init__(NODE_NAME, PARAMS)
        out = self.param("out")
        if not out:
            raise StartupError("set the parameter out (bag directory to create)")
        self.out = Path(out)
        if self.out.exists():
            raise StartupError(f"{self.out} exists already, not overwriting")
        from ..data.bags import STORAGES, move_type_from_name
        try:
            self.move_type = move_type_from_name(self.out.name)
        except ValueError as e:
            raise StartupError(str(e)) from None
        self.storage = self.param("storage")
        if self.storage not in STORAGES:
            raise StartupError(f"storage must be one of {', '.join(STORAGES)}")
        self.max_steps = self.param("max_steps")
        if self.max_steps < 0:
            raise StartupError("max_steps must be >= 0")
        self.rec = TopicRecording()
        self.cmd_topic = self.param("cmd_topic")
        # the command subscription first: it is announced to the simulator before the
        # measurement ones, whose first message then marks the recorder ready (module doc)
        self.cmd_sub = self.create_subscription(JointState, self.cmd_topic, self._on_cmd,
                                                RECORD_QOS)
        self.create_subscription(JointState, TOPIC_JOINT_STATES, self._on_js, RECORD_QOS)
        self.create_subscription(Odometry, TOPIC_ODOM, self._on_odom, RECORD_QOS)
        self.done = False
        self.ready = False

    def _on_js(self, msg: JointState) -> None:
        try:
            self.rec.add_joint_state(msg)
        except ValueError as e:
            self.get_logger().warning(f"ignored a joint state: {e}", throttle_duration_sec=2.0)
        self._check_done()

    def _on_odom(self, msg: Odometry) -> None:
        self.rec.add_odometry(msg)
        self._check_done()

    def _on_cmd(self, msg: JointState) -> None:
        try:
            self.rec.add_command(msg)
        except ValueError as e:
            self.get_logger().warning(f"ignored a command: {e}", throttle_duration_sec=2.0)
        self._check_done()

    def _check_ready(self) -> None:
        """Log the ``ready:`` line once a complete measurement is in and the command topic has a
        publisher (module doc)."""
        if self.ready:
            return
        complete = self.rec.js.keys() & self.rec.odom.keys()
        if complete and self.cmd_sub.get_publisher_count() >= 1:
            self.ready = True
            self.get_logger().info(
                f"ready: measurement at {min(complete) / 1e9:.3f} s received, "
                f"{self.cmd_sub.get_publisher_count()} publisher(s) of {self.cmd_topic}")

    def _stamps(self) -> list[int]:
        """The contiguous run of measurement stamps (module doc)."""
        return self.rec.first_run(self.max_steps)

    def _check_done(self) -> None:
        if self.max_steps and not self.done and len(self.rec.cmd) >= self.max_steps:
            if len(self._stamps()) >= self.max_steps + 1:
                self.done = True

    def record(self) -> int:
        """Record until ``max_steps`` steps are in (or SIGINT/SIGTERM), then write the bag."""
        log = self.get_logger()
        log.info(f"recording into {self.out}")
        try:
            while not self.done:
                rclpy.spin_once(self, timeout_sec=0.1)
                self._check_ready()
        except KeyboardInterrupt:
            pass
        n = self.write()
        log.info(f"wrote {self.out} ({n} steps)")
        return 0

    def write(self) -> int:
        """Write the bag; returns the number of steps written."""
        from ..data.bags import write_bag

        stamps = self._stamps()
        if len(stamps) < 2:
            raise RecordError(f"nothing to write: {self.rec.summary()}, no 2 consecutive "
                              f"steps with all three")
        rec = move_recording(self.rec, stamps, self.out.name, self.move_type)
        try:
            write_bag(self.out, rec, storage=self.storage)
        except (ValueError, OSError) as e:
            raise RecordError(f"cannot write {self.out}: {one_line(e)}") from None
        return len(stamps) - 1


def main(args: Sequence[str] | None = None) -> int:
    return run_node(NODE_NAME, BagRecorder, BagRecorder.record, args,
                    failures={RecordError: (1, "{}")},
                    interrupted=(130, "interrupted, no bag written"))


if __name__ == "__main__":
    sys.exit(main())
