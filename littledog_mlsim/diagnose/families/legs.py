"""Leg families: a property of one leg, or a force on one foot in one phase of its step."""
from __future__ import annotations

from typing import Any, ClassVar, Mapping

from .base import Family, FittedEffect, _cap, _magnitude, register_family

__all__ = ["LegDifference", "LowerLegMass", "FootSlip", "ContactPhase", "SwingDragFamily", "FootAdhesionFamily"]


def _leg(scope: str) -> str:
    return scope.split(":", 1)[1]


class _Leg(Family):
    kind: ClassVar[str] = "leg"


@register_family
class LegDifference(_Leg):
    """One leg's links weigh a multiple of the others'."""

    name: ClassVar[str] = "leg_difference"
    primary: ClassVar[str] = "scale"
    unit: ClassVar[str] = "1"
    probe: ClassVar[float] = 0.5
    bounds: ClassVar[tuple[float, float]] = (0.2, 4.0)
    neutral: ClassVar[float] = 1.0

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import LegMass
        return [LegMass(max(params[self.primary], 1e-3), _leg(scope))]

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        return {"scale": float(_magnitude(c)), "quantity": "leg link masses and inertias"}

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return f"{_cap(where)} differs: its links weigh about {params[self.primary]:.2f} times the others'"


@register_family
class LowerLegMass(LegDifference):
    """One leg weighs a multiple of the others', the difference all on its lower leg (a guard,
    a pad or a sensor on the shin): another form of the vocabulary's leg_difference, screened
    on its own because a load on the shin swings the foot unlike a heavier leg."""

    name: ClassVar[str] = "lower_leg_mass"
    reported_as: ClassVar[str] = "leg_difference"
    bounds: ClassVar[tuple[float, float]] = (0.5, 4.0)

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import LegMass
        return [LegMass(max(params[self.primary], 1e-3), _leg(scope), where="lower")]

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        return {"scale": float(_magnitude(c)),
                "quantity": "leg mass (links and inertias), the change on the lower leg"}

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)} differs: its lower leg carries the difference, the leg weighing "
                f"about {params[self.primary]:.2f} times the others'")


@register_family
class FootSlip(_Leg):
    """One foot's friction with the ground is a fraction of normal (a scaled property of one
    leg: the vocabulary's leg_difference)."""

    name: ClassVar[str] = "foot_slip"
    primary: ClassVar[str] = "friction_ratio"
    unit: ClassVar[str] = "1"
    probe: ClassVar[float] = -0.85
    bounds: ClassVar[tuple[float, float]] = (0.02, 1.5)
    neutral: ClassVar[float] = 1.0
    reported_as: ClassVar[str] = "leg_difference"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import FootFriction
        return [FootFriction(max(params[self.primary], 1e-3), _leg(scope))]

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        m = _magnitude(c)
        return {"scale": float(m), "quantity": "foot-ground friction coefficient",
                "friction_ratio": float(m), "friction_coefficient": float(m * foot_mu)}

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)}'s foot slips in stance: foot-ground friction coefficient about "
                f"{params['friction_coefficient']:.2f} ({100 * params['friction_ratio']:.0f} % "
                f"of normal)")


class ContactPhase(_Leg):
    """A force on one foot in one phase of its step (the vocabulary's contact_phase)."""

    primary: ClassVar[str] = "force_N"
    unit: ClassVar[str] = "N"
    probe: ClassVar[float] = 1.0
    bounds: ClassVar[tuple[float, float]] = (0.0, 10.0)
    reported_as: ClassVar[str] = "contact_phase"
    quantity: ClassVar[str]

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        m = _magnitude(c)
        return {"magnitude": float(m), "phase": self.phase, "quantity": self.quantity,
                "force_N": float(m)}


@register_family
class SwingDragFamily(ContactPhase):
    name: ClassVar[str] = "swing_drag"
    phase: ClassVar[str] = "swing"
    quantity: ClassVar[str] = "drag force on the swinging foot [N]"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import SwingDrag
        return [SwingDrag(max(params[self.primary], 0.0), _leg(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)}'s foot is dragged while it swings: about "
                f"{params['force_N']:.1f} N against its motion, none in stance")


@register_family
class FootAdhesionFamily(ContactPhase):
    name: ClassVar[str] = "foot_adhesion"
    phase: ClassVar[str] = "lift-off"
    quantity: ClassVar[str] = ("downward pull on the foot from touch-down until it has risen "
                               "1 cm [N]")

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import FootAdhesion
        return [FootAdhesion(max(params[self.primary], 0.0), _leg(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)}'s foot sticks to the ground: about {params['force_N']:.1f} N "
                f"pulling it down from touch-down until it has risen 1 cm")
