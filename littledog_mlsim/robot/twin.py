"""Robot twin files: a RobotConfig with a format version and where its values came from.

A twin file (``twin.json``) is the robot a simulator runs, written once and read wherever a robot
name is accepted (``record --robot``, ``pybullet_node``'s ``robot`` parameter, ``import --robot``)::

    {"format": "littledog_mlsim.twin", "format_version": 1,
     "robot": {RobotConfig field: value, ...},          # every field, tuples as lists
     "provenance": {...}}                               # free-form, see below

``provenance`` says what the values rest on; ``calibrate`` writes ``created_by``, ``base_robot``
(the robot the fit started from), ``calibrated_from`` (dataset directory, its robot, the moves
used) and ``parameters`` ({name: {value, unit, start, ci95: [lo, hi], at_bound}}). A hand-made
twin may leave it empty.

:func:`robot_config_from` is the one loader: a robot name (``measured``, ``nominal``) or a path to
a twin file; a robot config file written by ``baseline.save_robot_config`` (the tuned nominal) is
accepted as well. Every failure is a ValueError with one line naming the file.
"""
from __future__ import annotations

import json
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from ..fileio import atomic_write_text, format_problem, read_document, to_plain
from .config import ROBOT_NAMES, RobotConfig, config_from_dict, config_to_dict, robot_config

__all__ = ["TWIN_FORMAT", "TWIN_FORMAT_VERSION", "Twin", "save_twin", "load_twin",
           "robot_config_from", "robot_source"]

log = logging.getLogger(__name__)

TWIN_FORMAT = "littledog_mlsim.twin"
TWIN_FORMAT_VERSION = 1
_CONFIG_FORMAT = "littledog_mlsim.robot_config"   # baseline.save_robot_config's files
_CONFIG_FORMAT_VERSION = 1


@dataclass(frozen=True)
class Twin:
    """A robot configuration and the provenance of its values."""

    robot: RobotConfig
    provenance: Mapping[str, Any] = field(default_factory=dict)

    def to_document(self) -> dict[str, Any]:
        return {"format": TWIN_FORMAT, "format_version": TWIN_FORMAT_VERSION,
                "robot": config_to_dict(self.robot), "provenance": to_plain(self.provenance)}


def save_twin(twin: Twin, path: str | os.PathLike) -> Path:
    """Write ``twin`` to ``path`` atomically (temporary sibling + rename): a reader sees the old
    file or the whole new one. Non-finite numbers are refused (ValueError) before writing."""
    text = json.dumps(twin.to_document(), indent=2, allow_nan=False) + "\n"
    path = atomic_write_text(Path(path), text)
    log.debug("wrote twin file %s (robot %r)", path, twin.robot.name)
    return path


def _read(path: Path) -> dict:
    """The twin (or robot config) document at ``path``; ValueError without the path."""
    if not path.exists():
        raise ValueError("no such file")
    if path.is_dir():
        raise ValueError("is a directory, not a twin file")
    try:
        doc = read_document(path, TWIN_FORMAT, TWIN_FORMAT_VERSION, "a robot twin file")
    except ValueError as exc:
        fallback = _read_config_document(path)
        if fallback is None:
            raise exc
        return fallback
    if not isinstance(doc.get("robot"), Mapping):
        raise ValueError("has no 'robot' mapping of RobotConfig fields")
    if not isinstance(doc.get("provenance", {}), Mapping):
        raise ValueError("'provenance' is not a mapping")
    return doc


def _read_config_document(path: Path) -> dict | None:
    """A ``baseline.save_robot_config`` file as a twin document, or None if it is not one."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    if format_problem(doc, _CONFIG_FORMAT, _CONFIG_FORMAT_VERSION, "a robot config") is not None:
        return None
    return {"robot": doc.get("config"), "provenance": {"robot_config_file": str(path)}}


def load_twin(path: str | os.PathLike) -> Twin:
    """Read a twin file; ValueError "PATH: reason" (one line) when it is missing, not JSON, of
    another format or version, or names an unknown or ill-typed RobotConfig field."""
    path = Path(path)
    try:
        doc = _read(path)
        return Twin(config_from_dict(doc["robot"]), dict(doc.get("provenance", {})))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"twin file {path}: {' '.join(str(exc).split())}") from None


def robot_config_from(name_or_path: str | os.PathLike | RobotConfig) -> RobotConfig:
    """The robot named (``measured``, ``nominal``) or stored in a twin file at this path.

    A ready RobotConfig is returned as it is. A string that is neither a robot name nor an
    existing path fails with one line saying both."""
    if isinstance(name_or_path, RobotConfig):
        return name_or_path
    text = os.fspath(name_or_path)
    if text in ROBOT_NAMES:
        return robot_config(text)
    if not text:
        raise ValueError(f"no robot given; name one of {', '.join(ROBOT_NAMES)} or a twin file")
    path = Path(text)
    if not path.exists() and not _looks_like_path(text):
        raise ValueError(f"unknown robot {text!r}: not one of {', '.join(ROBOT_NAMES)} and no "
                         f"such twin file")
    return load_twin(path).robot


def _looks_like_path(text: str) -> bool:
    return os.sep in text or text.endswith((".json", ".JSON"))


def robot_source(name_or_path: str | os.PathLike | RobotConfig) -> dict[str, Any]:
    """What a dataset records about the robot ``name_or_path`` names.

    ``robot``: the robot name; for a twin file the config's name, unless that is a stock name
    (``measured``, ``nominal``) whose stock robot differs from the twin, then ``NAME-twin`` (a
    reader that re-simulates the named stock robot must not take the twin for it). A twin file
    adds ``twin`` (its absolute path); a twin file or a RobotConfig that is not a stock robot
    adds ``robot_config`` (every field, so the dataset describes its robot even when the file is
    gone)."""
    config = robot_config_from(name_or_path)
    name = config.name
    if name in ROBOT_NAMES and robot_config(name) == config:
        return {"robot": name}
    if name in ROBOT_NAMES:
        name = f"{name}-twin"
    out: dict[str, Any] = {"robot": name}
    if not isinstance(name_or_path, RobotConfig):
        out["twin"] = str(Path(os.fspath(name_or_path)).resolve())
    out["robot_config"] = config_to_dict(config)
    return out
