"""Typed options of :func:`.run.diagnose`: :class:`DiagnoseOptions` and its route.

The route says how effects are found:

- :class:`PhysicalRoute`: named by re-simulation with the dataset's robot (:mod:`.physical`),
  then each found effect's online feature is added to the learned model;
- :class:`LearnedRoute`: the residual loop of :mod:`.selection` on the learned model alone;
- :class:`AutoRoute` (the default): the physical route if the dataset names a known robot,
  else the learned one.

:meth:`DiagnoseOptions.from_keywords` maps :func:`.run.diagnose`'s keywords (and the CLI's
``--physics auto|on|off``, :func:`route_from_mode`) onto these.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field, fields, replace
from typing import Any, Mapping, Sequence

from .physical.driver import PhysicalOptions
from .selection import DEFAULT_ALPHA, DEFAULT_MIN_GAIN, SearchModel

__all__ = ["DiagnoseOptions", "PhysicalRoute", "LearnedRoute", "AutoRoute", "Route",
           "route_from_mode", "PHYSICS_MODES"]

PHYSICS_MODES = ("auto", "on", "off")


@dataclass(frozen=True)
class PhysicalRoute:
    """Physical identification; ``overrides``: :class:`.physical.PhysicalOptions` fields
    (over the run's ``alpha``, ``min_gain``, the dataset's robot and command excitation)."""

    overrides: Mapping[str, Any] = field(default_factory=dict)
    name = "physical"

    def __post_init__(self) -> None:
        PhysicalOptions.from_keywords(None, **self.overrides)   # an unknown option fails here

    def options(self, alpha: float, min_gain: float, robot: str, excitation: float
                ) -> PhysicalOptions:
        run = {"alpha": alpha, "min_gain": min_gain, "robot": robot, "excitation": excitation}
        return PhysicalOptions.from_keywords(None, **{**run, **self.overrides})


@dataclass(frozen=True)
class LearnedRoute:
    """The learned residual loop: ``search`` model (default seeded with the run's seed),
    candidate ``library`` (default :func:`.candidates.default_library`), ``max_rounds``.
    ``rollout``: a :class:`.learned.LearnedOptions` to also search, after the one-step loop, by
    held-out k-step rollouts (:func:`.learned.diagnose_learned`, probing ``rollout_library``,
    default its family probes) and add what it accepts to the report model; None: not. Opt-in: on
    clean data recorded with command excitation it still takes the robot's own command response
    for an effect (``benchmarks/learned_route/README.md``). ``scheduler``: the address of a Dask
    scheduler whose workers run the rollout search's probes (the same report); else ``jobs``
    local processes run them (1: this process)."""

    search: SearchModel | None = None
    library: Sequence[Any] | None = None
    max_rounds: int = 4
    rollout: Any = None
    rollout_library: Sequence[Any] | None = None
    scheduler: str | None = None
    jobs: int = 1
    name = "learned"


@dataclass(frozen=True)
class AutoRoute:
    """The physical route if the dataset names a known robot, else the learned one."""

    physical: PhysicalRoute = field(default_factory=PhysicalRoute)
    learned: LearnedRoute = field(default_factory=LearnedRoute)
    name = "auto"

    def resolve(self, robot: str | None) -> "PhysicalRoute | LearnedRoute":
        from ..robot.config import ROBOT_NAMES
        return self.physical if robot in ROBOT_NAMES else self.learned


Route = PhysicalRoute | LearnedRoute | AutoRoute


def route_from_mode(mode: str, physical: PhysicalRoute, learned: LearnedRoute) -> Route:
    """The route of ``physics="on" | "off" | "auto"``."""
    if mode not in PHYSICS_MODES:
        raise ValueError(f"physics must be on, off or auto, got {mode!r}")
    return {"on": physical, "off": learned, "auto": AutoRoute(physical, learned)}[mode]


@dataclass(frozen=True)
class DiagnoseOptions:
    """Everything :func:`.run.diagnose` takes besides the dataset and the output directory.

    ``twin``: the robot the physical route re-simulates (a robot name, a twin file or a
    RobotConfig) instead of the dataset's; ``reference``: a dataset of clean moves of the same
    robot to cancel the twin's own errors against ("what changed since that recording?"). Either
    one takes the physical route (the twin without ``twin``: the dataset's robot, else
    ``nominal``).

    ``model``: start from this model file (its feature set, method, options and target).
    Otherwise the starting feature set is ``baseline`` (``measured`` or ``paper``) and the
    report model is ``method`` with ``options``. ``projections``/``projection_alpha``: the
    rollouts scored; ``save_model``, ``figures``, ``progress``: what is written and said.
    """

    route: Route = field(default_factory=AutoRoute)
    twin: Any = None
    reference: str | os.PathLike | None = None
    model: str | os.PathLike | None = None
    baseline: str = "measured"
    method: str | None = None
    options: Mapping[str, Any] | None = None
    alpha: float = DEFAULT_ALPHA
    min_gain: float = DEFAULT_MIN_GAIN
    projections: Sequence[str] = ("alpha",)
    projection_alpha: float = 0.5
    seed: int = 0
    save_model: bool = True
    figures: bool = True
    progress: bool = True

    @classmethod
    def from_keywords(cls, physics: str = "auto",
                      physics_options: Mapping[str, Any] | None = None,
                      search: SearchModel | None = None, library: Sequence[Any] | None = None,
                      max_rounds: int = 4, **kw: Any) -> "DiagnoseOptions":
        """Options from :func:`.run.diagnose`'s keywords: ``physics`` (on, off, auto) with
        ``physics_options`` choose the route, ``search``, ``library`` and ``max_rounds`` set
        the learned route; the rest are fields of this class (a ValueError names an unknown
        keyword)."""
        known = {f.name for f in fields(cls)} - {"route"}
        bad = sorted(set(kw) - known)
        if bad:
            raise ValueError(f"diagnose: unknown option {bad[0]!r}")
        route = route_from_mode(physics, PhysicalRoute(dict(physics_options or {})),
                                LearnedRoute(search, library, max_rounds))
        return cls(route=route, **kw)

    def with_route(self, route: Route) -> "DiagnoseOptions":
        return replace(self, route=route)
