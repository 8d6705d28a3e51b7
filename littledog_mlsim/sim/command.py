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

import numpy as np

from ..layout import JOINT_LOWER, JOINT_NAMES, JOINT_UPPER, N_JOINTS, joint_permutation

__all__ = ["REJECT_REASONS", "CommandCheck", "check_command", "joint_permutation"]

REJECT_REASONS: tuple[str, ...] = ("names", "length", "nonfinite")


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
