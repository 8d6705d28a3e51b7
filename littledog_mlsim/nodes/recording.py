"""What a recorder keeps of a simulator's live topics, and the moves it makes of them.

Shared by ``bag_recorder`` (one bag per process) and ``trainer_node``'s live recording
(``~/record``): joint states, odometry and applied commands are kept by stamp
(:class:`TopicRecording`); a *run* is a stretch of consecutive 10 ms stamps that each have a
joint state and an odometry message, every one but the last also an applied command (the
command of the step starting there); :meth:`TopicRecording.runs` finds them and
:func:`move_recording` turns one into a ``MoveRecording`` (N commands, N + 1 measurements), the
record ``data.bags.write_bag`` writes.
"""
from __future__ import annotations

from typing import Iterator

import numpy as np
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from ..data.recording import MoveRecording
from ..layout import CONTROL_DT_NS
from . import messages as m

__all__ = ["TopicRecording", "move_recording"]


class TopicRecording:
    """Messages by stamp (ns). ``add_*`` raise ValueError for a joint state or command whose
    names are not the 12 joints (the caller warns and goes on)."""

    def __init__(self) -> None:
        self.js: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.odom: dict[int, dict[str, np.ndarray]] = {}
        self.cmd: dict[int, np.ndarray] = {}

    def add_joint_state(self, msg: JointState) -> None:
        self.js[m.stamp_ns(msg.header.stamp)] = m.joint_state_arrays(msg)

    def add_odometry(self, msg: Odometry) -> None:
        self.odom[m.stamp_ns(msg.header.stamp)] = m.odometry_arrays(msg)

    def add_command(self, msg: JointState) -> None:
        self.cmd[m.stamp_ns(msg.header.stamp)] = m.joint_state_arrays(msg)[0]

    def clear(self) -> None:
        self.js.clear()
        self.odom.clear()
        self.cmd.clear()

    def complete(self, t: int) -> bool:
        """Stamp ``t`` has a joint state and an odometry message."""
        return t in self.js and t in self.odom

    def runs(self, max_steps: int = 0) -> Iterator[list[int]]:
        """Every run (module doc) of at least 2 measurements, in time order; a run stops at
        ``max_steps`` steps if that is > 0 (the next one starts where it stopped)."""
        done: set[int] = set()
        for t0 in sorted(t for t in self.cmd if self.complete(t)):
            if t0 in done:
                continue
            run = [t0]
            while run[-1] in self.cmd and self.complete(run[-1] + CONTROL_DT_NS):
                run.append(run[-1] + CONTROL_DT_NS)
                if max_steps and len(run) == max_steps + 1:
                    break
            done.update(run[:-1])
            if len(run) >= 2:
                yield run

    def first_run(self, max_steps: int = 0) -> list[int]:
        """The first run (bag_recorder's rule), or [] if there is none."""
        return next(self.runs(max_steps), [])

    def summary(self) -> str:
        return (f"{len(self.js)} joint states, {len(self.odom)} odometry messages, "
                f"{len(self.cmd)} commands")


def move_recording(rec: TopicRecording, stamps: list[int], name: str,
                   move_type: str) -> MoveRecording:
    """The move of one run ``stamps`` (module doc), named ``name``."""
    o = [rec.odom[t] for t in stamps]
    return MoveRecording(
        name=name, move_type=move_type,
        stamps_ns=np.asarray(stamps, dtype=np.int64),
        cmd=np.array([rec.cmd[t] for t in stamps[:-1]]),
        q=np.array([rec.js[t][0] for t in stamps]),
        dq=np.array([rec.js[t][1] for t in stamps]),
        position=np.array([x["position"] for x in o]),
        orientation=np.array([x["orientation"] for x in o]),
        linear_velocity=np.array([x["linear_velocity"] for x in o]),
        angular_velocity=np.array([x["angular_velocity"] for x in o]))
