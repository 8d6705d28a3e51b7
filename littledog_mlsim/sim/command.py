"""The command rule both simulators apply to every ``/littledog/cmd`` (no ROS types here).

- ``name`` must hold each of the 12 contract joint names exactly once (any order). Anything else
  (unknown, missing or duplicated names) rejects the command (reason ``names``).
- ``position`` must have one value per name (reason ``length``). ``velocity``/``effort`` are
  ignored (the contract leaves them empty).
- every position must be finite (reason ``nonfinite``): NaN or +-inf rejects the command.
- positions outside ``layout.JOINT_LOWER``/``JOINT_UPPER`` are clipped to the limits and the
  command is used (reason ``clipped``; the pybullet servo clips the same way).

A rejected command is not used at all: the simulator keeps holding the previous valid command.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..layout import JOINT_LOWER, JOINT_NAMES, JOINT_UPPER, N_JOINTS

__all__ = ["REJECT_REASONS", "CommandCheck", "check_command", "joint_permutation"]

REJECT_REASONS: tuple[str, ...] = ("names", "length", "nonfinite")
_INDEX = {n: i for i, n in enumerate(JOINT_NAMES)}


@dataclass(frozen=True)
class CommandCheck:
    """Outcome of ``check_command``: ``u`` (12,) in contract order, or None if rejected.

    ``reason``: None (used as sent), ``"clipped"`` (used after clipping to the joint limits) or
    one of ``REJECT_REASONS``; ``detail`` is a short human-readable explanation.
    """

    u: np.ndarray | None
    reason: str | None = None
    detail: str = ""

    @property
    def accepted(self) -> bool:
        return self.u is not None


@lru_cache(maxsize=64)
def joint_permutation(names: tuple[str, ...]) -> np.ndarray | str:
    """Index into ``names`` of each contract joint, or why ``names`` is not usable."""
    unknown = [n for n in names if n not in _INDEX]
    if unknown:
        return f"unknown joint name(s) {', '.join(repr(n) for n in unknown[:3])}"
    if len(set(names)) != len(names):
        return "duplicated joint names"
    if len(names) != N_JOINTS:
        missing = [n for n in JOINT_NAMES if n not in names]
        return f"{len(names)} joint names, missing {', '.join(missing[:3])}"
    where = {n: i for i, n in enumerate(names)}
    return np.array([where[n] for n in JOINT_NAMES])


def check_command(names, positions) -> CommandCheck:
    """Apply the command rule (module doc) to a JointState's ``name`` and ``position``."""
    perm = joint_permutation(tuple(names))
    if isinstance(perm, str):
        return CommandCheck(None, "names", perm)
    pos = np.asarray(positions, dtype=np.float64)
    if pos.shape != (N_JOINTS,):
        return CommandCheck(None, "length", f"{pos.size} positions for {N_JOINTS} names")
    u = pos[perm]
    if not np.all(np.isfinite(u)):
        bad = [JOINT_NAMES[i] for i in np.flatnonzero(~np.isfinite(u))]
        return CommandCheck(None, "nonfinite", f"NaN/inf for {', '.join(bad[:3])}")
    clipped = np.clip(u, JOINT_LOWER, JOINT_UPPER)
    if np.any(clipped != u):
        bad = [JOINT_NAMES[i] for i in np.flatnonzero(clipped != u)]
        return CommandCheck(clipped, "clipped", f"outside the joint limits: {', '.join(bad[:3])}")
    return CommandCheck(u)
