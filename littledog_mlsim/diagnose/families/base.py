"""The effect family's contract and the registry of families.

A family is one kind of physical effect the physical route can name (a late set-point, extra
joint friction, a push on the body, a heavier leg). A subclass of :class:`Family` declares what
it is (name, kind, primary parameter and unit, screening probe, bounds, neutral value) and
says how it turns into effect plug-ins (:meth:`Family.build_effects`), reads in physical words
(:meth:`Family.physical_params`, :meth:`Family.statement`), maps to the learned model's online
feature (:meth:`Family.augmentation`), adjusts the start state of a re-simulation
(:meth:`Family.start_q`, :meth:`Family.start_dq`) and names what separates it from a rival
(:meth:`Family.separation`).
:func:`register_family` puts one instance under its name in :data:`FAMILIES`; the search only
reads these attributes and methods, never a family's name.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Mapping, Protocol, Sequence

import numpy as np

from ...layout import JOINT_NAMES, LEGS
from .scopes import joint_scopes, leg_scopes

__all__ = ["Family", "FAMILIES", "register_family", "ScreenProbe", "FittedEffect",
           "Separation", "vocabulary_family", "library_size", "KINDS"]

KINDS = ("joints", "body", "leg")

# What a newcomer records to separate two effects the held-out moves cannot tell apart.
MORE_MOVES = "littledog-mlsim record --out DIR --moves-per-type 20 [same options, a new seed]"
TURNING_MOVES = ("littledog-mlsim record --out DIR --moves-per-type 20 --types FL,FR,BL,BR "
                 "[same options, a new seed]")
EXCITED_MOVES = ("littledog-mlsim record --out DIR --moves-per-type 20 --excitation 0.03 "
                 "[same options, a new seed]")
ALIKE = "both explain the held-out moves about equally well"


class FittedEffect(Protocol):
    """What a family reads of a fitted hypothesis (the search's candidate)."""

    family: str
    scope: str
    magnitude: float
    fitted: float | None
    direction: np.ndarray | None

    def params(self, mag: float | None = None) -> dict[str, Any]: ...


@dataclass(frozen=True)
class ScreenProbe:
    """One sensitivity simulation of the screen: ``key`` (probe number, joint or leg index or
    None) names it, ``scope`` and ``params`` are the hypothesis simulated."""

    key: tuple[int, int | None]
    scope: str
    params: dict[str, Any]


@dataclass(frozen=True)
class Separation:
    """Why two families cannot be told apart and the recording that would separate them;
    of the two families' answers the higher ``priority`` is reported."""

    priority: int
    how: str
    recording: str


class Family:
    """One family of the vocabulary (module doc). Subclasses set the class attributes and
    implement :meth:`build_effects` and :meth:`statement`.

    ``kind``: ``joints`` (acts on a joint scope), ``body`` or ``leg`` (one foot);
    ``probe``: the deviation from ``neutral`` of a screening simulation; ``bounds``: the
    magnitude's range in the fit; ``components``: the parameters screened jointly (a planar
    force's ``fx``, ``fy``; one-parameter families have ``("value",)``); ``deep_probe``: a
    joint family's second screening probe, for a threshold effect that does nothing until it
    is strong; ``command_path``: acts on the set-points (identifiable with excitation);
    ``reported_as``: the vocabulary's family if the search splits one into several;
    ``other_forms``: families that are another physical form of the same effect (a gain drift
    and a supply sag), not screened themselves (``screened`` False): each is fitted at the
    scope this family's screen chose, and the held-out moves decide between the forms.
    """

    name: ClassVar[str]
    kind: ClassVar[str]
    primary: ClassVar[str]
    unit: ClassVar[str]
    probe: ClassVar[float]
    bounds: ClassVar[tuple[float, float]]
    components: ClassVar[tuple[str, ...]] = ("value",)
    neutral: ClassVar[float] = 0.0
    command_path: ClassVar[bool] = False
    reported_as: ClassVar[str] = ""
    phase: ClassVar[str] = ""
    deep_probe: ClassVar[float | None] = None
    timing_rival: ClassVar[bool] = False     # a set-point delay or lag: the other is its rival
    searches_position: ClassVar[bool] = False   # the fit also searches where it acts (a mass)
    twin_family: ClassVar[str] = ""          # the family that pushes alike, fitted beside it
    yields_to_twin: ClassVar[bool] = False   # its twin is the finding where both push alike
    screened: ClassVar[bool] = True          # the screen simulates it (False: a form only)
    other_forms: ClassVar[tuple[str, ...]] = ()   # unscreened families fitted at its scope

    # -- what it is
    @property
    def vocabulary(self) -> str:
        return self.reported_as or self.name

    @property
    def needs_excitation(self) -> bool:
        """Whether data without command excitation may fail to establish it."""
        return self.command_path

    @property
    def long_screen(self) -> bool:
        """Whether its screening simulations and fit include the 4 s replay."""
        return self.kind != "joints"

    @property
    def screen_style(self) -> str:
        """How the screen turns its probes into hypotheses: ``joints`` (every joint scope from
        one probe per joint), ``legs`` (one per leg), ``components`` (a vector fitted from one
        probe per component) or ``each`` (every probe a hypothesis of its own)."""
        return {"joints": "joints", "leg": "legs"}.get(self.kind, "components")

    @property
    def shortlist_class(self) -> str:
        """Families of one class take one place in the shortlist."""
        return self.name

    def scopes(self) -> list[str]:
        if self.kind == "joints":
            return joint_scopes()
        if self.kind == "leg":
            return leg_scopes()
        return ["body"]

    # -- the search's parameters
    def params_from(self, magnitude: float, direction: np.ndarray | None) -> dict[str, float]:
        """Plug-in parameters of a magnitude (and a unit direction for vector families)."""
        if len(self.components) > 1:
            d = np.zeros(len(self.components)) if direction is None else direction
            return {c: float(magnitude * d[i]) for i, c in enumerate(self.components)}
        return {self.primary: float(magnitude)}

    def screen_probes(self) -> list[ScreenProbe]:
        """The screen's sensitivity simulations (:attr:`screen_style`)."""
        if self.kind == "joints":
            return [ScreenProbe((k, j), f"joint:{JOINT_NAMES[j]}",
                                {self.primary: self.neutral + (self.deep_probe if k == 1
                                                               else self.probe)})
                    for k in range(1 if self.deep_probe is None else 2)
                    for j in range(len(JOINT_NAMES))]
        if self.kind == "leg":
            return [ScreenProbe((0, g), f"leg:{LEGS[g]}", {self.primary: self.neutral + self.probe})
                    for g in range(len(LEGS))]
        nc = len(self.components)
        if nc == 1:
            return [ScreenProbe((0, None), "body", {self.primary: self.neutral + self.probe})]
        return [ScreenProbe((c, None), "body", self.params_from(self.probe, np.eye(nc)[c]))
                for c in range(nc)]

    def probe_candidate(self, k: int, a: float
                        ) -> tuple[float, np.ndarray | None, dict[str, Any]]:
        """(magnitude, direction, fixed parameters) of the hypothesis probe ``k`` scaled by
        ``a`` gives (screen style ``each`` only)."""
        raise NotImplementedError(f"{self.name}: screen style {self.screen_style}")

    def twin_magnitude(self, magnitude: float, weight_N: float) -> float:
        """The magnitude of :attr:`twin_family` that pushes as ``magnitude`` of this one does
        (on a robot of weight ``weight_N``)."""
        raise NotImplementedError(f"{self.name} has no twin")

    # -- plug-ins, words, the learned model, the start state, rivals
    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        """The effect plug-ins (``robot/effects.py``) of one hypothesis."""
        raise NotImplementedError

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        """The vocabulary's parameters of a fitted hypothesis (primary first); ``foot_mu``:
        the transducer's normal foot-ground friction coefficient."""
        return {self.primary: float(_magnitude(c))}

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        """A roboticist's sentence for a finding on ``where`` (:func:`.scopes.scope_words`)."""
        return f"{self.name} on {where}: {dict(params)}"

    def augmentation(self, scope: str, params: Mapping[str, Any]) -> Any:
        """The online feature that lets a learned model carry the effect, or None if a model
        trained on the data carries it already (a constant change is a function of its
        inputs)."""
        return None

    def start_q(self, q: np.ndarray, scope: str, params: Mapping[str, Any]) -> np.ndarray:
        """The joint angles to start a re-simulation from, given the measured ones ``q``
        (returned unchanged, the same object, if the family does not change them)."""
        return q

    def start_dq(self, dq: np.ndarray, scope: str, params: Mapping[str, Any]) -> np.ndarray:
        """The joint rates to start a re-simulation from (and the encoders' rate filter's
        state), given the measured ones ``dq`` (returned unchanged, the same object, if the
        family does not change them)."""
        return dq

    def separation(self, other: "Family") -> Separation | None:
        """Why this family and ``other`` act alike, and what separates them (None: no view)."""
        return None


def _magnitude(c: FittedEffect) -> float:
    return c.fitted if c.fitted is not None else c.magnitude


def _direction(c: FittedEffect) -> np.ndarray:
    return c.direction if c.direction is not None else np.array([1.0, 0.0])


def _degrees(d: Sequence[float]) -> float:
    return float(math.degrees(math.atan2(d[1], d[0])))


def _cap(where: str) -> str:
    return where[0].upper() + where[1:]


FAMILIES: dict[str, Family] = {}


def register_family(cls: type[Family]) -> type[Family]:
    """Register one instance of ``cls`` under ``cls.name`` (usable as a decorator); the order
    of registration is the order the search screens in."""
    old = FAMILIES.get(cls.name)
    if old is not None and type(old) is not cls:
        raise ValueError(f"family {cls.name!r} is already registered to {type(old).__name__}")
    if cls.kind not in KINDS:
        raise ValueError(f"family {cls.name!r}: kind must be one of {', '.join(KINDS)}")
    FAMILIES[cls.name] = cls()
    return cls


def library_size() -> int:
    """Family x scope hypotheses of the registered families."""
    return sum(len(f.scopes()) for f in FAMILIES.values())


def vocabulary_family(family: str) -> str:
    """The vocabulary's family of a searched family (``swing_drag`` -> ``contact_phase``)."""
    return FAMILIES[family].vocabulary if family in FAMILIES else family
