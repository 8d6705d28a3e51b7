"""bag_player: publish a bag's ``/littledog/cmd`` (or all its topics) with its timing.

    bag_player --ros-args -p bag:=bags/default/F_14 [-p rate:=2.0] [-p all_topics:=true]
    bag_player --ros-args -p bag:=bags/default/F_14 -p pace_topic:=/littledog/joint_states

``ros2 bag play`` for environments without rosbag2 (PyPI wheels). Reads the bag with
``rosbags`` (any rosbag2 bag, mcap or sqlite3) and publishes the stored serialized messages
unchanged (header stamps are the bag's), reliable keep-last 10 like every publisher of the
contract.

Timing: message i is published at ``start + (t_i - t_0) / rate`` on the steady clock (``rate``
2.0 = twice as fast). With ``pace_topic`` set, timing is replaced by lockstep pacing for a
``step_mode:=lockstep`` simulator: after each ``/littledog/cmd`` message the player waits for
one new message on ``pace_topic`` (the simulator's next state; a JointState topic, or
Odometry if its name ends in ``odom``) before publishing the next one (``pace_timeout`` s at
most, else it fails).

Start: with ``wait_for_subscribers`` N > 0 the player waits (at most ``wait_timeout`` s) until N
subscribers of ``/littledog/cmd`` (or of the first topic played) are matched, and, when pacing,
until a publisher of ``pace_topic`` is matched. ``publish_clock`` publishes the bag time of each
message on ``/clock`` (like ``ros2 bag play --clock``; off by default because the simulators
own ``/clock``). ``loop`` replays forever.

Exit status: 0 when the bag was played (or on SIGINT/SIGTERM), 1 when the bag cannot be read or
pacing timed out (one FATAL line), 2 for a bad parameter.
"""
from __future__ import annotations

import importlib
import sys
import time
from pathlib import Path
from typing import Any, Sequence

import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg

from ..layout import TOPIC_CLOCK, TOPIC_CMD
from . import messages as m
from ._run import ConfiguredNode, Param, StartupError, run_node
from .simulator import QOS

# The played topics: reliable with a deep writer queue, so a subscriber that falls behind for a
# moment (a busy machine) loses no message of the bag; it matches QOS and RECORD_QOS readers.
PLAY_QOS = QoSProfile(history=QOS.history, depth=1000, reliability=QOS.reliability,
                      durability=QOS.durability)

NODE_NAME = "bag_player"

PARAMS: tuple[Param, ...] = (
    Param("bag", "", "bag directory to play (required)"),
    Param("topics", Parameter.Type.STRING_ARRAY, "topics to play (unset: /littledog/cmd)"),
    Param("all_topics", False, "play every topic of the bag (overrides topics)"),
    Param("rate", 1.0, "playback speed factor (2.0: twice as fast)", "> 0"),
    Param("pace_topic", "", "lockstep pacing: after each /littledog/cmd wait for one message "
          "on this topic (e.g. /littledog/joint_states) instead of using the bag's timing"),
    Param("pace_timeout", 10.0, "seconds to wait for a pace message", "> 0"),
    Param("wait_for_subscribers", 0, "wait until this many subscribers are matched before "
          "playing", ">= 0"),
    Param("wait_timeout", 30.0, "seconds to wait for subscribers (and the pace publisher)",
          "> 0"),
    Param("publish_clock", False, "publish each message's bag time on /clock"),
    Param("loop", False, "play the bag again and again"),
)


class PlaybackError(Exception):
    """The bag cannot be played (one FATAL line, exit status 1)."""


def _message_class(msgtype: str) -> type:
    pkg, kind, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{pkg}.{kind}"), name)


class BagPlayer(ConfiguredNode):
    def __init__(self) -> None:
        super().__init__(NODE_NAME, PARAMS)
        self.bag = Path(self.param("bag"))
        if not self.param("bag"):
            raise StartupError("set the parameter bag (a bag directory)")
        self.rate = self.param("rate")
        if not self.rate > 0 or not self.param("pace_timeout") > 0 \
                or not self.param("wait_timeout") > 0 or self.param("wait_for_subscribers") < 0:
            raise StartupError("rate, pace_timeout and wait_timeout must be > 0, "
                               "wait_for_subscribers >= 0")
        self.topics = self.param("topics") or [TOPIC_CMD]
        self.pace_topic = self.param("pace_topic")
        self._paced = 0
        self.clock_pub = (self.create_publisher(ClockMsg, TOPIC_CLOCK, QOS)
                          if self.param("publish_clock") else None)

    def _spin_until(self, done, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while not done():
            left = end - time.monotonic()
            if left <= 0:
                return False
            rclpy.spin_once(self, timeout_sec=min(left, 0.05))
        return True

    def play(self) -> int:
        from rosbags.rosbag2 import Reader

        log = self.get_logger()
        try:
            reader = Reader(self.bag)
            reader.open()
        except Exception as e:
            raise PlaybackError(f"cannot open bag {self.bag}: {type(e).__name__}: "
                                f"{' '.join(str(e).split())}") from None
        try:
            conns = [c for c in reader.connections
                     if self.param("all_topics") or c.topic in self.topics]
            missing = set() if self.param("all_topics") else \
                set(self.topics) - {c.topic for c in conns}
            if missing or not conns:
                raise PlaybackError(f"bag {self.bag} has no topic {', '.join(sorted(missing))}"
                                    if missing else f"bag {self.bag} has no messages to play")
            pubs = {}
            for c in conns:
                if c.topic not in pubs:
                    try:
                        cls = _message_class(c.msgtype)
                    except (ImportError, AttributeError, ValueError):
                        raise PlaybackError(f"no Python message type {c.msgtype} for topic "
                                            f"{c.topic}") from None
                    pubs[c.topic] = self.create_publisher(cls, c.topic, PLAY_QOS)
            if self.pace_topic:
                self.create_subscription(self._pace_class(), self.pace_topic, self._on_pace,
                                         QOS)
            self._wait_for_peers(pubs)
            n_loops = 0
            while True:
                n = self._play_once(reader, conns, pubs)
                n_loops += 1
                log.info(f"played {n} messages of {self.bag}"
                         + (f" (loop {n_loops})" if self.param("loop") else ""))
                if not self.param("loop"):
                    return 0
        finally:
            reader.close()

    def _pace_class(self) -> type:
        """Odometry for a topic named ``*odom``, else JointState (e.g. joint_states)."""
        from sensor_msgs.msg import JointState

        if self.pace_topic.endswith("odom"):
            from nav_msgs.msg import Odometry
            return Odometry
        return JointState

    def _on_pace(self, msg: Any) -> None:
        self._paced += 1

    def _wait_for_peers(self, pubs: dict) -> None:
        n = self.param("wait_for_subscribers")
        timeout = self.param("wait_timeout")
        first = pubs.get(TOPIC_CMD) or next(iter(pubs.values()))
        if n > 0 and not self._spin_until(lambda: first.get_subscription_count() >= n, timeout):
            raise PlaybackError(f"{first.topic_name}: fewer than {n} subscriber(s) after "
                                f"{timeout:g} s")
        if self.pace_topic:
            sub = next(s for s in self.subscriptions if s.topic_name == self.pace_topic)
            if not self._spin_until(lambda: sub.get_publisher_count() >= 1, timeout):
                raise PlaybackError(f"no publisher of {self.pace_topic} after {timeout:g} s")

    def _play_once(self, reader, conns, pubs) -> int:
        n = 0
        t0_bag = None
        t0 = time.monotonic()
        pace_timeout = self.param("pace_timeout")
        try:
            for conn, t_bag, raw in reader.messages(connections=conns):
                if t0_bag is None:
                    t0_bag = t_bag
                if not self.pace_topic:
                    delay = t0 + (t_bag - t0_bag) / 1e9 / self.rate - time.monotonic()
                    if delay > 0:
                        time.sleep(delay)
                if self.clock_pub is not None:
                    self.clock_pub.publish(m.clock_msg(t_bag))
                before = self._paced
                pubs[conn.topic].publish(bytes(raw))
                n += 1
                if self.pace_topic and conn.topic == TOPIC_CMD:
                    if not self._spin_until(lambda b=before: self._paced > b, pace_timeout):
                        raise PlaybackError(f"no message on {self.pace_topic} within "
                                            f"{pace_timeout:g} s of command {n}")
        except PlaybackError:
            raise
        except Exception as e:   # rosbags: truncated/corrupt storage
            raise PlaybackError(f"bag {self.bag}: corrupt or truncated after {n} messages: "
                                f"{type(e).__name__}: {' '.join(str(e).split())}") from None
        return n


def main(args: Sequence[str] | None = None) -> int:
    return run_node(NODE_NAME, BagPlayer, BagPlayer.play, args,
                    failures={PlaybackError: (1, "{}")}, interrupted=(0, "stopped"))


if __name__ == "__main__":
    sys.exit(main())
