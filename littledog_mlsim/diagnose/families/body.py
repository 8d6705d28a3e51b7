"""Body families: pushes, torques, slopes and loads on the body."""
from __future__ import annotations

import math
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from .base import (ALIKE, MORE_MOVES, TURNING_MOVES, Family, FittedEffect, ScreenProbe,
                   Separation, _degrees, _direction, _magnitude, register_family)

__all__ = ["OdomForce", "BodyWrenchFamily", "BodyTorque", "BodyRollTorque", "BodyPitchTorque",
           "GroundSlopeFamily", "GroundTiltFamily", "MassCom", "mass_com_of", "within_reach",
           "MASS_POSITIONS", "PAYLOAD_REACH_M", "TILT_DIRECTIONS", "tilt_direction"]


class _Push(Family):
    """A planar force on the body, fixed in odom (``push_frame`` ``odom``) or to the body.

    Two odom-fixed pushes (a force and a slope's pull) act alike on odometry level with the
    ground, and an odom-fixed and a body-fixed one differ only when the heading changes."""

    kind: ClassVar[str] = "body"
    components: ClassVar[tuple[str, ...]] = ("fx", "fy")
    push_frame: ClassVar[str] = "odom"

    def separation(self, other: Family) -> Separation | None:
        frame = getattr(other, "push_frame", None)
        if frame is None:
            return None
        if frame == self.push_frame == "odom":
            return Separation(
                1, "a slope tilts gravity (m g sin(slope) downhill, fixed in odom) and a "
                   "world-fixed push act alike on odometry that stays level with the ground; "
                   "the gravity direction in base_link (an IMU's accelerometer) separates them",
                "record the same moves with an IMU topic (sensor_msgs/Imu, linear "
                "acceleration); this project's recorder has none")
        return Separation(1, "a push fixed in odom and one fixed to the body differ only when "
                             "the heading changes; more turning moves separate them",
                          TURNING_MOVES)

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        m, d = _magnitude(c), _direction(c)
        return {"force_N": float(m), "direction_deg": _degrees(d),
                "force_xy_N": [float(m * d[0]), float(m * d[1])]}

    def augmentation(self, scope: str, params: Mapping[str, Any]) -> Any:
        if self.push_frame != "odom":
            return None
        from ...models.features import Heading   # a world-fixed push acts through the heading
        return Heading()


@register_family
class OdomForce(_Push):
    """A constant force fixed in the world (odom): wind, a tether."""

    name: ClassVar[str] = "odom_force"
    primary: ClassVar[str] = "force_N"
    unit: ClassVar[str] = "N"
    probe: ClassVar[float] = 1.0
    bounds: ClassVar[tuple[float, float]] = (0.0, 20.0)
    twin_family: ClassVar[str] = "ground_slope"

    @property
    def shortlist_class(self) -> str:
        return "push"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import ConstantWind
        return [ConstantWind([params["fx"], params["fy"]])]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"About {params[self.primary]:.2f} N pushing the body along "
                f"{params['direction_deg']:.0f} deg in odom (fixed in the world: its body-frame "
                f"effect turns with the heading)")

    def twin_magnitude(self, magnitude: float, weight_N: float) -> float:
        """The slope whose pull m g sin(slope) is this force."""
        return math.degrees(math.asin(min(magnitude / weight_N, 0.99)))


@register_family
class BodyWrenchFamily(_Push):
    """A constant force fixed to the body (base_link)."""

    name: ClassVar[str] = "body_wrench"
    primary: ClassVar[str] = "force_N"
    unit: ClassVar[str] = "N"
    probe: ClassVar[float] = 1.0
    bounds: ClassVar[tuple[float, float]] = (0.0, 20.0)
    push_frame: ClassVar[str] = "body"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import BodyWrench
        return [BodyWrench(force=[params["fx"], params["fy"], 0.0])]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"About {params[self.primary]:.2f} N pushing the body along "
                f"{params['direction_deg']:.0f} deg in base_link (fixed to the body)")


class _Torque(Family):
    """A pure torque fixed to the body about one of base_link's axes (x roll, y pitch, z yaw)."""

    kind: ClassVar[str] = "body"
    primary: ClassVar[str] = "torque_Nm"
    unit: ClassVar[str] = "N m"
    probe: ClassVar[float] = 0.1
    bounds: ClassVar[tuple[float, float]] = (-1.0, 1.0)
    reported_as: ClassVar[str] = "body_wrench"
    axis: ClassVar[int]
    axis_words: ClassVar[str]
    # (what it does, its sense when > 0, when < 0)
    words: ClassVar[tuple[str, str, str]]

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import BodyWrench
        torque = [0.0, 0.0, 0.0]
        torque[self.axis] = params[self.primary]
        return [BodyWrench(torque=torque)]

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        return {"torque_Nm": float(_magnitude(c)), "force_N": 0.0, "torque_axis": self.axis_words}

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        v = params[self.primary]
        what, positive, negative = self.words
        return (f"About {abs(v):.3f} N m {what} ({positive if v >= 0 else negative}; a torque "
                f"fixed to the body, no net force)")

    def separation(self, other: Family) -> Separation | None:
        return Separation(
            2, "a torque about the vertical axis and a push or a leg effect that turns the trot "
               "both bend its path; moves with other headings and speeds separate them (a "
               "torque turns the body the same way at any speed)", TURNING_MOVES)


@register_family
class BodyTorque(_Torque):
    name: ClassVar[str] = "body_torque"
    probe: ClassVar[float] = 0.05
    axis: ClassVar[int] = 2
    axis_words: ClassVar[str] = "z (base_link)"
    words: ClassVar[tuple[str, str, str]] = (
        "twisting the body about its vertical axis", "counter-clockwise seen from above",
        "clockwise seen from above")


@register_family
class BodyRollTorque(_Torque):
    name: ClassVar[str] = "body_roll_torque"
    axis: ClassVar[int] = 0
    axis_words: ClassVar[str] = "x (base_link, roll)"
    words: ClassVar[tuple[str, str, str]] = (
        "rolling the body about its forward axis", "its left side pushed up",
        "its right side pushed up")


@register_family
class BodyPitchTorque(_Torque):
    name: ClassVar[str] = "body_pitch_torque"
    axis: ClassVar[int] = 1
    axis_words: ClassVar[str] = "y (base_link, pitch)"
    words: ClassVar[tuple[str, str, str]] = (
        "pitching the body about its lateral axis", "nose down", "nose up")


class _Slope(Family):
    kind: ClassVar[str] = "body"
    primary: ClassVar[str] = "slope_deg"
    unit: ClassVar[str] = "deg"
    probe: ClassVar[float] = 2.0
    bounds: ClassVar[tuple[float, float]] = (0.0, 20.0)
    components: ClassVar[tuple[str, ...]] = ("sx", "sy")
    odom_words: ClassVar[str]

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        return {"slope_deg": float(_magnitude(c)), "uphill_direction_deg": _degrees(_direction(c)),
                "odom": self.odom_words}

    def augmentation(self, scope: str, params: Mapping[str, Any]) -> Any:
        from ...models.features import Heading   # a world-fixed push acts through the heading
        return Heading()


@register_family
class GroundSlopeFamily(_Slope, _Push):
    """Gravity tilted: the ground inclined under odometry that stays level with it."""

    name: ClassVar[str] = "ground_slope"
    odom_words: ClassVar[str] = "level with the ground (gravity tilted)"
    twin_family: ClassVar[str] = "odom_force"
    yields_to_twin: ClassVar[bool] = True   # odometry level in the world: the push is the finding

    @property
    def shortlist_class(self) -> str:
        return "push"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import GroundSlope
        sx, sy = params["sx"], params["sy"]
        return [GroundSlope(math.hypot(sx, sy), math.degrees(math.atan2(sy, sx)))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"Ground inclined by about {params[self.primary]:.1f} deg, uphill towards "
                f"{params['uphill_direction_deg']:.0f} deg in odom")

    def twin_magnitude(self, magnitude: float, weight_N: float) -> float:
        """The force m g sin(slope) this slope pulls with."""
        return weight_N * math.sin(math.radians(magnitude))


# ground_tilt is screened as a tilt of the floor towards each of these many directions (uphill
# every 45 deg): a floor tilted the wrong way puts the measured stance into or above it, so the
# response is far from linear in the two tilt components and a first-order fit of them fails.
TILT_DIRECTIONS = 8


def tilt_direction(k: int) -> np.ndarray:
    a = 2.0 * math.pi * k / TILT_DIRECTIONS
    return np.array([math.cos(a), math.sin(a)])


@register_family
class GroundTiltFamily(_Slope):
    """The floor inclined under odometry level in the world (attitude and height follow it)."""

    name: ClassVar[str] = "ground_tilt"
    reported_as: ClassVar[str] = "ground_slope"
    odom_words: ClassVar[str] = "level in the world (the floor tilted under it)"
    screen_style: ClassVar[str] = "each"   # type: ignore[assignment]

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import GroundTilt
        sx, sy = params["sx"], params["sy"]
        return [GroundTilt(math.hypot(sx, sy), math.degrees(math.atan2(sy, sx)),
                           params.get("origin_xy", (0.0, 0.0)))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"Floor inclined by about {params[self.primary]:.1f} deg, uphill towards "
                f"{params['uphill_direction_deg']:.0f} deg in a level odom (the body's attitude "
                f"and height follow the floor)")

    def screen_probes(self) -> list[ScreenProbe]:
        return [ScreenProbe((k, None), "body", self.params_from(self.probe, tilt_direction(k)))
                for k in range(TILT_DIRECTIONS)]

    def probe_candidate(self, k: int, a: float
                        ) -> tuple[float, np.ndarray | None, dict[str, Any]]:
        return max(a, 0.0) * self.probe, tilt_direction(k), {}

    def separation(self, other: Family) -> Separation | None:
        return Separation(3, ALIKE, MORE_MOVES)


# mass_com is screened as a point mass at each of these positions on the body (base_link [m]:
# the centre, 8 cm ahead and behind, 4 cm to each side, 2 cm up, where a payload is strapped).
# A payload's signature is mostly the moment its weight makes about the body's centre of mass,
# which is far from linear in the mass and position over a 4 s replay, so the position is
# searched directly rather than solved from first-order components.
MASS_POSITIONS: tuple[tuple[float, float, float], ...] = (
    (0.0, 0.0, 0.02), (0.08, 0.0, 0.02), (-0.08, 0.0, 0.02), (0.0, 0.04, 0.02),
    (0.0, -0.04, 0.02))

# Where a carried load's centre of mass can be (base_link [m]): within the body's box
# (0.33 x 0.11 x 0.14 m, centred 4.5 cm above the origin; littledog.urdf) or a load strapped to
# its sides or top. The position search stays inside: a gram at 70 cm is not a payload.
PAYLOAD_REACH_M: tuple[tuple[float, float], ...] = ((-0.165, 0.165), (-0.08, 0.08),
                                                    (-0.03, 0.2))


def within_reach(pos: Sequence[float]) -> bool:
    """Whether a payload position lies within :data:`PAYLOAD_REACH_M`."""
    return all(lo <= float(x) <= hi for x, (lo, hi) in zip(pos, PAYLOAD_REACH_M))


def mass_com_of(params: Mapping[str, Any]) -> tuple[float, tuple[float, float, float]]:
    """(added mass [kg], its position in base_link [m]) of a mass_com hypothesis
    (``added_mass_kg``, ``com_offset_m``; a mass below 1 g is taken as 1 g)."""
    off = tuple(float(x) for x in params.get("com_offset_m", (0.0, 0.0, 0.0)))
    return max(float(params["added_mass_kg"]), 1e-3), off   # type: ignore[return-value]


@register_family
class MassCom(Family):
    """A carried load: added mass at a position on the body (the fit searches the position)."""

    name: ClassVar[str] = "mass_com"
    kind: ClassVar[str] = "body"
    primary: ClassVar[str] = "added_mass_kg"
    unit: ClassVar[str] = "kg"
    probe: ClassVar[float] = 0.3
    bounds: ClassVar[tuple[float, float]] = (0.01, 3.0)
    searches_position: ClassVar[bool] = True
    screen_style: ClassVar[str] = "each"   # type: ignore[assignment]

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import Payload
        m, off = mass_com_of(params)
        return [Payload(m, off)]

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        mass, off = mass_com_of(c.params(_magnitude(c)))
        return {"added_mass_kg": float(mass), "com_offset_m": [float(x) for x in off]}

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        off = params.get("com_offset_m", (0.0, 0.0, 0.0))
        return (f"About {params[self.primary]:.2f} kg of extra mass carried on the body, its "
                f"centre about {100 * off[0]:+.0f} cm ahead and {100 * off[1]:+.0f} cm to the "
                f"left of the body origin")

    def screen_probes(self) -> list[ScreenProbe]:
        return [ScreenProbe((k, None), "body", {self.primary: self.neutral + self.probe,
                                                "com_offset_m": pos})
                for k, pos in enumerate(MASS_POSITIONS)]

    def probe_candidate(self, k: int, a: float
                        ) -> tuple[float, np.ndarray | None, dict[str, Any]]:
        return a, None, {"com_offset_m": MASS_POSITIONS[k]}
