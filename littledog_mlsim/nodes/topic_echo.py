"""topic_echo: a small ``ros2 topic echo`` for installs without the ``ros2`` CLI (PyPI wheels).

    topic_echo /littledog/odom                      # every message, until Ctrl-C
    topic_echo /littledog/joint_states --once       # one message, then exit
    topic_echo /clock --count 5
    topic_echo /littledog/odom nav_msgs/msg/Odometry --timeout 10 --no-arr

Prints each message as ROS prints it: block-style YAML of the message's fields in definition
order, followed by a ``---`` line (``ros2 topic echo``'s format, which is PyYAML's dump of
``rosidl_runtime_py.message_to_ordereddict``; that package is not installed, so
:func:`message_to_yaml` is a small recursive re-implementation). Works for any message type
whose Python package is importable; the contract's are ``sensor_msgs/msg/JointState``,
``nav_msgs/msg/Odometry`` and ``rosgraph_msgs/msg/Clock``.

Type: the optional second argument, else the type the ROS graph reports for the topic (waiting
for a publisher to appear, as ``ros2 topic echo`` does). QoS: reliable/transient-local when every
publisher of the topic offers it, else best-effort/volatile (``ros2 topic echo``'s rule), so a
late ``topic_echo`` of a simulator's topic (transient-local, keep-last 10) first gets up to the
last 10 messages; ``--qos-reliability`` and ``--qos-durability`` override it.

Exit status: 0 after ``--once``/``--count`` messages or Ctrl-C/SIGTERM; 1 if ``--timeout``
passes first; 2 for bad arguments (an unknown message type, a topic of several types).
ROS arguments (``--ros-args ...``) are passed to rclpy; the domain is ``ROS_DOMAIN_ID``.
"""
from __future__ import annotations

import argparse
import array
import importlib
import os
import re
import sys
import time
from typing import Any, Sequence

import numpy as np
import yaml

__all__ = ["message_to_dict", "message_to_yaml", "message_class", "main"]

DEFAULT_TRUNCATE = 128   # ros2 topic echo's default --truncate-length


# ---------------------------------------------------------------------------------------------
# message -> YAML (no rclpy needed)


def _abbreviate(value: Any, type_str: str) -> str:
    """``--no-arr`` text for an array/sequence field, from its type string ('double[36]',
    'sequence<double>', 'sequence<double, 5>')."""
    m = re.fullmatch(r"sequence<([^,>]+)(?:,\s*(\d+))?>", type_str)
    if m:
        bound = f"[{m.group(2)}]" if m.group(2) else ""
        return f"<sequence type: {m.group(1)}{bound}, length: {len(value)}>"
    m = re.fullmatch(r"(.+)\[(\d+)\]", type_str)
    if m:
        return f"<array type: {m.group(1)}[{m.group(2)}]>"
    return f"<{type_str}, length: {len(value)}>"


def _value(v: Any, type_str: str | None, truncate: int | None, no_arr: bool) -> Any:
    """One field value as plain Python data (str, int, float, bool, list, dict)."""
    if isinstance(v, (bytes, bytearray)):            # byte / octet fields, as ROS prints them
        text = "".join(chr(c) for c in v)
        return text[:truncate] + "..." if truncate is not None and len(text) > truncate else text
    if isinstance(v, str):
        return v[:truncate] + "..." if truncate is not None and len(v) > truncate else v
    if isinstance(v, (list, tuple, array.array, np.ndarray)):
        if no_arr and type_str is not None:
            return _abbreviate(v, type_str)
        items = list(v)
        cut = truncate is not None and len(items) > truncate
        if cut:
            items = items[:truncate]
        out = [_value(x, None, truncate, no_arr) for x in items]
        return out + ["..."] if cut else out
    if isinstance(v, np.generic):                    # numpy scalars (float64 of an ndarray)
        return v.item()
    if isinstance(v, (bool, int, float)):
        return v
    return message_to_dict(v, truncate_length=truncate, no_arr=no_arr)   # a nested message


def message_to_dict(msg: Any, *, truncate_length: int | None = None,
                    no_arr: bool = False) -> dict[str, Any]:
    """A ROS message as a dict of its fields in definition order, recursively: nested
    messages become dicts, arrays lists, bytes strings; strings and arrays longer than
    ``truncate_length`` are cut (``'...'`` appended); ``no_arr`` replaces arrays by a
    ``<sequence type: ..., length: n>`` note."""
    fields = msg.get_fields_and_field_types()
    return {name: _value(getattr(msg, name), type_str, truncate_length, no_arr)
            for name, type_str in fields.items()}


class _Dumper(yaml.SafeDumper):
    """PyYAML's dumper, mappings in insertion order (ROS dumps an OrderedDict the same way)."""


def message_to_yaml(msg: Any, *, truncate_length: int | None = DEFAULT_TRUNCATE,
                    no_arr: bool = False, flow_style: bool = False) -> str:
    """The YAML ``ros2 topic echo`` prints for ``msg`` (without the ``---`` line)."""
    return yaml.dump(message_to_dict(msg, truncate_length=truncate_length, no_arr=no_arr),
                     Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=sys.maxsize,
                     default_flow_style=flow_style)


def message_class(type_name: str) -> type:
    """The Python class of ``pkg/msg/Name`` (or ``pkg/Name``); ValueError if unknown."""
    parts = type_name.strip().split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"{type_name!r} is not a message type (expected pkg/msg/Name)")
    try:
        cls = getattr(importlib.import_module(f"{parts[0]}.{parts[1]}"), parts[2])
    except (ImportError, AttributeError):
        raise ValueError(f"unknown message type {type_name!r} (no Python module "
                         f"{parts[0]}.{parts[1]} with {parts[2]})") from None
    if not hasattr(cls, "get_fields_and_field_types"):
        raise ValueError(f"{type_name!r} is not a ROS message type")
    return cls


# ---------------------------------------------------------------------------------------------
# the command


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="topic_echo",
        description="Print a topic's messages as YAML, like `ros2 topic echo` (this install has "
                    "no ros2 CLI). The domain is ROS_DOMAIN_ID.")
    p.add_argument("topic", help="topic name, e.g. /littledog/odom")
    p.add_argument("message_type", nargs="?", default=None,
                   help="e.g. nav_msgs/msg/Odometry (default: the type the graph reports, "
                        "waiting for a publisher)")
    p.add_argument("--once", action="store_true", help="print one message and exit")
    p.add_argument("--count", type=int, default=None, metavar="N",
                   help="print N messages and exit")
    p.add_argument("--timeout", type=float, default=None, metavar="S",
                   help="exit with status 1 if the messages asked for have not arrived after S "
                        "seconds (default: wait forever)")
    p.add_argument("--truncate-length", type=int, default=DEFAULT_TRUNCATE, metavar="N",
                   help=f"cut strings and arrays longer than N (default {DEFAULT_TRUNCATE})")
    p.add_argument("--full-length", action="store_true", help="never cut (overrides "
                   "--truncate-length)")
    p.add_argument("--no-arr", action="store_true", help="print arrays as their type and length")
    p.add_argument("--flow-style", action="store_true", help="flow-style YAML")
    p.add_argument("--qos-reliability", choices=["reliable", "best_effort"], default=None,
                   help="default: reliable if every publisher is, else best_effort")
    p.add_argument("--qos-durability", choices=["transient_local", "volatile"], default=None,
                   help="default: transient_local if every publisher is, else volatile")
    p.add_argument("--qos-depth", type=int, default=10, help="history depth (default 10)")
    return p


def _qos(node: Any, topic: str, reliability: str | None, durability: str | None, depth: int):
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    infos = node.get_publishers_info_by_topic(topic)
    if reliability is None:
        reliability = "reliable" if infos and all(
            i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos) \
            else "best_effort"
    if durability is None:
        durability = "transient_local" if infos and all(
            i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos) \
            else "volatile"
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=(ReliabilityPolicy.RELIABLE if reliability == "reliable"
                                   else ReliabilityPolicy.BEST_EFFORT),
                      durability=(DurabilityPolicy.TRANSIENT_LOCAL
                                  if durability == "transient_local"
                                  else DurabilityPolicy.VOLATILE))


def main(args: Sequence[str] | None = None) -> int:
    from rclpy.node import Node
    from rclpy.utilities import remove_ros_args

    from ._run import run_node

    argv = list(sys.argv if args is None else ["topic_echo", *args])
    parser = _parser()
    a = parser.parse_args(remove_ros_args(argv)[1:])
    if a.once:
        a.count = 1
    if a.count is not None and a.count < 1:
        parser.error("--count must be >= 1")
    if a.qos_depth < 1:
        parser.error("--qos-depth must be >= 1")
    cls = None
    if a.message_type:
        try:
            cls = message_class(a.message_type)
        except ValueError as e:
            print(f"topic_echo: error: {e}", file=sys.stderr)
            return 2
    return run_node("topic_echo", lambda: Node(f"topic_echo_{time.monotonic_ns() % 10**9}"),
                    lambda node: _echo(node, a, cls), argv)


def _echo(node: Any, a: argparse.Namespace, cls: type | None) -> int:
    """Print the messages of ``a.topic`` (type ``cls``, or from the graph); the exit status."""
    import rclpy

    want = a.count
    truncate = None if a.full_length else a.truncate_length
    deadline = None if a.timeout is None else time.monotonic() + a.timeout
    printed = 0
    topic = node.resolve_topic_name(a.topic)
    warned = False
    try:
        # the type (if not given) and the publishers' QoS both come from the graph
        while True:
            types = dict(node.get_topic_names_and_types()).get(topic)
            if types:
                break
            if cls is not None and a.qos_reliability and a.qos_durability:
                break                      # nothing to learn from the graph
            if not warned:
                print(f"WARNING: topic [{topic}] does not appear to be published yet",
                      file=sys.stderr)
                warned = True
            if deadline is not None and time.monotonic() > deadline:
                print(f"topic_echo: error: no publisher of {topic} after {a.timeout:g} s",
                      file=sys.stderr)
                return 1
            rclpy.spin_once(node, timeout_sec=0.1)
        if cls is None:
            if len(types) != 1:
                print(f"topic_echo: error: {topic} has several types ({', '.join(types)}); "
                      f"give one", file=sys.stderr)
                return 2
            try:
                cls = message_class(types[0])
            except ValueError as e:
                print(f"topic_echo: error: {e}", file=sys.stderr)
                return 2

        def on_msg(msg: Any) -> None:
            nonlocal printed
            if want is not None and printed >= want:
                return
            sys.stdout.write(message_to_yaml(msg, truncate_length=truncate, no_arr=a.no_arr,
                                             flow_style=a.flow_style) + "---\n")
            sys.stdout.flush()
            printed += 1

        node.create_subscription(cls, topic, on_msg, _qos(node, topic, a.qos_reliability,
                                                          a.qos_durability, a.qos_depth))
        while want is None or printed < want:
            if deadline is not None and time.monotonic() > deadline:
                print(f"topic_echo: error: {printed} of {want or 'the'} message(s) on {topic} "
                      f"after {a.timeout:g} s", file=sys.stderr)
                return 1
            rclpy.spin_once(node, timeout_sec=0.1)
        return 0
    except BrokenPipeError:           # `topic_echo ... | head`: quiet, also at exit
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
