"""What every node process shares: its parameters, its start-up, its exit status and shutdown.

Parameters (:class:`ConfiguredNode`): each is a :class:`Param`, declared read-only with its
description and constraints (``ros2 param describe`` shows them); defaults come from
``config/<CONFIG_FILE>`` (section ``<node name>: ros__parameters``, found in the package's share
directory or the source tree), and ``--ros-args -p name:=value`` / ``--params-file`` override
them. A parameter the config file names but the node does not declare, or an override of the
wrong type, is a :class:`StartupError`.

Process (:func:`run_node`): ``rclpy.init`` with the command line, build the node, do its work,
destroy the node and shut rclpy down, whatever happened. Exit status:

- 0: the work ended (or the status it returns), or a signal ended it (``interrupted`` may say
  otherwise, e.g. trainer_node's 130);
- 2: rclpy refuses the command line (one line on stderr) or the node cannot start
  (:class:`StartupError`: one FATAL log line);
- the status ``failures`` gives an expected failure of the work (one FATAL log line).

Signals: with ``rclpy_signals`` (nodes that spin) rclpy's handlers turn SIGINT/SIGTERM into a
shutdown request and ``rclpy.spin`` ends with ``ExternalShutdownException``; without (nodes that
work in the main thread: a fit, a paced playback, a recording loop) SIGINT and SIGTERM raise
``KeyboardInterrupt`` there, so they interrupt the work itself (also in a process started with
SIGINT ignored, e.g. in the background of a script, as rclpy's handlers would). The previous
handlers are back when ``run_node`` returns.
"""
from __future__ import annotations

import signal
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence, TypeVar

import rclpy
import yaml
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.exceptions import ParameterUninitializedException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

__all__ = ["StartupError", "Param", "ConfiguredNode", "load_config_defaults", "run_node",
           "one_line"]

PACKAGE = "littledog_mlsim"
N = TypeVar("N", bound=Node)


class StartupError(Exception):
    """A configuration or input problem: logged as one line, the node exits with status 2."""


def one_line(e: BaseException) -> str:
    """An exception's message on one line (its type name if it has none)."""
    text = " ".join(str(e).split())
    return text or type(e).__name__


# ---------------------------------------------------------------------------------------------
# parameters


@dataclass(frozen=True)
class Param:
    """A node parameter: ``default`` is a value or a ``Parameter.Type`` (no default: unset)."""

    name: str
    default: Any
    description: str
    constraints: str = ""


def _config_dirs() -> list[Path]:
    dirs = []
    try:
        from ament_index_python.packages import get_package_share_directory
        dirs.append(Path(get_package_share_directory(PACKAGE)) / "config")
    except Exception:  # not in an ament environment (pip/venv)
        pass
    dirs.append(Path(sys.prefix) / "share" / PACKAGE / "config")
    dirs.append(Path(__file__).resolve().parents[2] / "config")  # source tree / editable
    return dirs


def load_config_defaults(file_name: str, node_name: str) -> tuple[dict[str, Any], Path | None]:
    """The ``ros__parameters`` of ``node_name`` in the first ``config/<file_name>`` found."""
    for d in _config_dirs():
        path = d / file_name
        if path.is_file():
            try:
                doc = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
                section = doc.get(node_name, doc.get("/**", {})) or {}
                params = section.get("ros__parameters", {}) or {}
            except (OSError, yaml.YAMLError, AttributeError) as e:
                raise StartupError(f"{path}: unreadable parameter file: {one_line(e)}") from None
            if not isinstance(params, dict):
                raise StartupError(f"{path}: ros__parameters is not a mapping")
            return params, path
    return {}, None


class ConfiguredNode(Node):
    """A node that declares ``params`` at construction (defaults from ``config/CONFIG_FILE``
    if set; ``config_path`` is the file used, or None) and reads them with :meth:`param`."""

    CONFIG_FILE = ""

    def __init__(self, node_name: str, params: Sequence[Param]) -> None:
        super().__init__(node_name)
        defaults, path = (load_config_defaults(self.CONFIG_FILE, node_name)
                          if self.CONFIG_FILE else ({}, None))
        unknown = sorted(set(defaults) - {p.name for p in params})
        if unknown:
            raise StartupError(f"{path}: unknown parameter(s) {', '.join(unknown)}")
        for p in params:
            default = defaults.get(p.name, p.default)
            if isinstance(p.default, float) and isinstance(default, int) \
                    and not isinstance(default, bool):
                default = float(default)
            desc = ParameterDescriptor(description=p.description, read_only=True,
                                       additional_constraints=p.constraints)
            try:
                self.declare_parameter(p.name, default, desc)
            except Exception as e:  # a -p override of the wrong type, mostly
                raise StartupError(f"parameter {p.name}: {one_line(e)}") from None
        self.config_path = path

    def param(self, name: str) -> Any:
        """A parameter's value; None if it is declared without a default and not set."""
        try:
            return self.get_parameter(name).value
        except ParameterUninitializedException:
            return None


# ---------------------------------------------------------------------------------------------
# process


_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def run_node(name: str, make: Callable[[], N], work: Callable[[N], int | None],
             args: Sequence[str] | None = None, *, rclpy_signals: bool = False,
             failures: Mapping[type[Exception], tuple[int, str]] | None = None,
             interrupted: tuple[int, str] = (0, "")) -> int:
    """Run one node process; returns its exit status (module doc).

    Args:
        name: the node's name, for messages before the node exists.
        make: builds the node (after ``rclpy.init``); raises StartupError on bad parameters.
        work: what the node does, e.g. ``rclpy.spin`` or ``BagPlayer.play``; returns the exit
            status (None: 0).
        args: the command line (None: ``sys.argv``).
        rclpy_signals: keep rclpy's SIGINT/SIGTERM handlers (for ``work`` that spins).
        failures: exception class -> (exit status, FATAL message with ``{}`` for the error).
        interrupted: (exit status, message; logged as FATAL if the status is non-zero, else
            INFO; "" logs nothing) when a signal ends the work.
    """
    options = SignalHandlerOptions.ALL if rclpy_signals else SignalHandlerOptions.NO
    try:
        rclpy.init(args=args, signal_handler_options=options)
    except Exception as e:  # rcl refuses the command line (e.g. an unparsable -p override)
        print(f"{name}: error: {one_line(e)}", file=sys.stderr)
        return 2
    previous = {} if rclpy_signals else {s: signal.signal(s, _interrupt) for s in _SIGNALS}
    logger = rclpy.logging.get_logger(name)
    expected = tuple((failures or {}).items())
    node = None
    status = 0
    try:
        try:
            node = make()
            status = work(node) or 0
        except StartupError as e:
            logger.fatal(one_line(e))
            status = 2
        except (KeyboardInterrupt, ExternalShutdownException):
            status = _interrupted(logger, interrupted)
        except Exception as e:
            for cls, (code, text) in expected:
                if isinstance(e, cls):
                    logger.fatal(text.format(one_line(e)))
                    status = code
                    break
            else:
                # A signal that arrives while rclpy converts a message surfaces as a
                # RuntimeError from take_message; after a shutdown request that is a normal
                # end, otherwise a bug.
                if rclpy.ok():
                    raise
                status = _interrupted(logger, interrupted)
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
        for s, handler in previous.items():
            signal.signal(s, handler)
    return status


def _interrupted(logger: Any, interrupted: tuple[int, str]) -> int:
    status, text = interrupted
    if text:
        (logger.fatal if status else logger.info)(text)
    return status
