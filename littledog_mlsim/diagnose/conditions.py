"""Whether a reference was recorded the way the data were (decision 031).

``diagnose --reference`` asks what changed since the reference by comparing the two
recordings: a finding must gain more on the data than on the reference, and the data's held-out
rollout error (decision 026) and the reference's model on the data (decision 027) are read
against the reference's own. Those comparisons hold only where both recordings probe the robot
alike. Command excitation (``record --excitation``, ``dataset.yaml``'s
``command_excitation_rad``) does not: it drives the joints' set-points through histories a gait
alone hardly gives. A recording with excitation then shows more of the joints' own response to
their commands (the families whose :attr:`.families.learned.LearnedFamily.excitation_shows` is
set) than one without, for any robot, and its rollouts are harder to predict. Where the two
excitations differ, :class:`Conditions` says so, and the learned route:

- reports a finding of such a family in either loop as one the reference cannot tell, with the
  recording that settles it (the reference recorded with the data's excitation); the model keeps
  its columns, as it keeps a finding the reference shows as much;
- keeps decision 026's and 027's readings in the report, but neither is significant nor named.

Findings of the other families (heading, position, time, phase, swing) are contrasted as
before: excitation does not make a recording depend more on where, when or in which phase the
robot is.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from ..models.feature_base import Augmentation

__all__ = ["Conditions", "conditions_of", "excitation_of", "cannot_contrast", "EXCITATION_KEY"]

#: ``dataset.yaml``'s key for the command excitation a recording was made with [rad]
EXCITATION_KEY = "command_excitation_rad"


@dataclass(frozen=True)
class Conditions:
    """The data's and the reference's command excitation [rad]."""

    data_excitation_rad: float
    reference_excitation_rad: float

    def __post_init__(self) -> None:
        for name in ("data_excitation_rad", "reference_excitation_rad"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")

    @property
    def comparable(self) -> bool:
        return self.data_excitation_rad == self.reference_excitation_rad

    @property
    def recording(self) -> str:
        """The recording that makes the comparisons hold."""
        e = self.data_excitation_rad
        return ("record the reference the way the data were recorded: "
                + (f"with command excitation (record --excitation {e:g})" if e > 0
                   else "without command excitation (record without --excitation)"))

    @property
    def recorded(self) -> str:
        """How the two recordings' excitations differ."""
        return (f"the reference was recorded with command excitation "
                f"{self.reference_excitation_rad:g} rad and the data with "
                f"{self.data_excitation_rad:g} rad")

    @property
    def statement(self) -> str:
        """What the differing conditions rule out."""
        return (self.recorded + ": the joints' command response and the rollout error cannot "
                "be compared against it")

    @property
    def why(self) -> str:
        """Why a finding of a family excitation shows cannot be contrasted."""
        return (self.recorded + "; a recording with more excitation gains more from the "
                "joints' own command response for any robot, so the reference cannot tell "
                "whether this robot had it before")

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"data_excitation_rad": self.data_excitation_rad,
                               "reference_excitation_rad": self.reference_excitation_rad,
                               "comparable": self.comparable}
        if not self.comparable:
            out["statement"] = self.statement
            out["recording"] = self.recording
        return out


def excitation_of(info: Mapping[str, Any], whose: str) -> float:
    """The command excitation [rad] a recording names in its ``dataset.yaml`` ``info`` (0 if
    none); a value that is not a finite number >= 0 is refused in one line naming ``whose``."""
    raw = info.get(EXCITATION_KEY, 0.0)
    try:
        v = float(0.0 if raw is None else raw)
    except (TypeError, ValueError):
        raise ValueError(f"{whose}: dataset.yaml's {EXCITATION_KEY} is not a number: "
                         f"{raw!r}") from None
    if not (math.isfinite(v) and v >= 0.0):
        raise ValueError(f"{whose}: dataset.yaml's {EXCITATION_KEY} must be a finite number "
                         f">= 0, got {raw!r}")
    return v


def conditions_of(data_info: Mapping[str, Any], reference_info: Mapping[str, Any],
                  data_name: str = "data", reference_name: str = "reference") -> Conditions:
    """The two recordings' conditions from their ``dataset.yaml`` infos (a recording that
    names no excitation was made without); a value that is not a finite number >= 0 is
    refused in one line naming the dataset."""
    return Conditions(excitation_of(data_info, data_name),
                      excitation_of(reference_info, reference_name))


def cannot_contrast(aug: Augmentation, conditions: "Conditions | None") -> bool:
    """Whether a finding of ``aug``'s family cannot be contrasted against a reference recorded
    under ``conditions`` (None: no reference, or the same conditions)."""
    from .families.learned import learned_family
    return (conditions is not None and not conditions.comparable
            and learned_family(aug.family).excitation_shows)
