"""The physical parameters of a RobotConfig that ``calibrate`` can fit, as a registry.

Each :class:`TwinParameter` reads and sets one number of a :class:`RobotConfig`: a scalar field
(``mass_scale``), one joint kind of a per-joint-kind triple (``kp_knee`` is ``kp[2]``), or a mass
the config may leave at the URDF's value (``body_mass`` None reads as the URDF's 1.8 kg). It also
says its unit, its search bounds, whether the fit works on its logarithm (scale-like parameters:
gains, masses, limits) and which servo it belongs to (``kp``/``kd`` act only on the torque-mode PD,
``position_gain``/``velocity_gain`` only on pybullet's position servo); a parameter of the other
servo has no effect and is refused.

``threshold`` marks a parameter that acts only where the motion reaches it (a torque limit acts
only on the steps where the servo asks for more): how much the data say about it, and how the
fit's estimate of it is biased, depend on how often the recorded motion gets there
(``twin_bias``, step 3).

``same_as`` names the parameters that, fitted together, already have a parameter's whole effect:
``mass_scale`` multiplies the body's and the legs' masses, and Bullet multiplies the foot's and
the floor's friction coefficients into the contact's. With those fitted, the parameter is another
name for what they express, not an unknown of its own (``twin_fit``'s consider analysis leaves it
out).

Parameters a RobotConfig cannot hold (Coulomb joint friction, an effect plug-in in
``robot.effects``) are not here, because a twin file is a RobotConfig.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Sequence

from .config import URDF_BODY_MASS, URDF_LEG_MASS, RobotConfig

__all__ = ["TwinParameter", "TWIN_PARAMETERS", "twin_parameters", "DEFAULT_CALIBRATION_PARAMS",
           "total_mass"]

KINDS: tuple[str, ...] = ("hip_roll", "hip_pitch", "knee")
_URDF_DEFAULT = {"body_mass": URDF_BODY_MASS, "leg_mass": URDF_LEG_MASS}


@dataclass(frozen=True)
class TwinParameter:
    """One number of a RobotConfig (``field``, or element ``index`` of a triple field)."""

    name: str
    field: str
    unit: str
    bounds: tuple[float, float]
    log: bool = True
    index: int | None = None
    servo: str | None = None        # "pd_torque" | "position" | None (both)
    unset: float | None = None      # the value a None field stands for (e.g. unfiltered)
    typical: float = 1.0            # a linear parameter's scale (finite-difference step, x_scale)
    same_as: tuple[str, ...] = ()   # parameters that, fitted together, already span its effect
    threshold: bool = False         # acts only where the state reaches it (a torque limit)

    def renames(self, fitted: set[str]) -> bool:
        """Whether this parameter is only another name for the fitted ones (``same_as``)."""
        return bool(self.same_as) and set(self.same_as) <= fitted

    def get(self, config: RobotConfig) -> float:
        v = getattr(config, self.field)
        if v is None:
            v = _URDF_DEFAULT.get(self.field, self.unset)
            if v is None:
                raise ValueError(f"{self.name}: {config.name!r} leaves {self.field} unset")
            return float(v)
        return float(v[self.index]) if self.index is not None else float(v)

    def set(self, config: RobotConfig, value: float) -> RobotConfig:
        v = float(value)
        if self.index is not None:
            triple = list(getattr(config, self.field))
            triple[self.index] = v
            return dataclasses.replace(config, **{self.field: tuple(triple)})
        return dataclasses.replace(config, **{self.field: v})

    def to_x(self, value: float) -> float:
        """The fit's coordinate of ``value`` (its log for a scale-like parameter)."""
        return math.log(value) if self.log else float(value)

    def from_x(self, x: float) -> float:
        return math.exp(x) if self.log else float(x)

    @property
    def x_scale(self) -> float:
        """A unit change of the fit's coordinate: 1 (e-fold) for a log parameter, else
        ``typical``."""
        return 1.0 if self.log else self.typical

    def x_bounds(self) -> tuple[float, float]:
        return (self.to_x(self.bounds[0]), self.to_x(self.bounds[1]))


def _triple(field: str, unit: str, bounds: tuple[float, float], servo: str | None = None,
            log: bool = True, typical: float = 1.0, threshold: bool = False
            ) -> list[TwinParameter]:
    return [TwinParameter(f"{field}_{k}", field, unit, bounds, log, i, servo, typical=typical,
                          threshold=threshold)
            for i, k in enumerate(KINDS)]


TWIN_PARAMETERS: dict[str, TwinParameter] = {p.name: p for p in (
    TwinParameter("body_mass", "body_mass", "kg (body with battery)", (0.9, 4.5)),
    TwinParameter("leg_mass", "leg_mass", "kg per leg", (0.08, 0.6)),
    TwinParameter("mass_scale", "mass_scale", "x every link mass", (0.5, 2.0),
                  same_as=("body_mass", "leg_mass")),
    *_triple("kp", "N m/rad", (0.5, 60.0), "pd_torque"),
    *_triple("kd", "N m s/rad", (0.01, 3.0), "pd_torque"),
    *_triple("torque_limit", "N m", (0.1, 5.0), threshold=True),
    *_triple("armature", "kg m^2 (reflected rotor inertia)", (0.0, 0.01), log=False,
             typical=1e-3),
    TwinParameter("position_gain", "position_gain", "pybullet position gain", (0.02, 1.0),
                  servo="position"),
    TwinParameter("velocity_gain", "velocity_gain", "pybullet velocity gain", (0.1, 1.9),
                  servo="position"),
    TwinParameter("foot_friction", "foot_friction", "Coulomb coefficient", (0.1, 2.0), log=False,
                  same_as=("ground_friction",)),
    TwinParameter("ground_friction", "ground_friction", "Coulomb coefficient", (0.1, 2.0),
                  log=False, same_as=("foot_friction",)),
    TwinParameter("command_delay_ms", "command_delay_ms", "ms (set-points arrive late)",
                  (0.0, 40.0), log=False, typical=10.0),
    TwinParameter("rate_filter_hz", "rate_filter_hz", "Hz (joint-rate low-pass; unset = 300)",
                  (5.0, 300.0), unset=300.0),
)}

# What ``calibrate`` fits when not told: the servo's gains and limits and the masses (the
# parameters a one-step residual of a trot identifies; the full list is TWIN_PARAMETERS).
DEFAULT_CALIBRATION_PARAMS: dict[str, tuple[str, ...]] = {
    "position": ("body_mass", "leg_mass", "position_gain", "velocity_gain",
                 "torque_limit_knee", "ground_friction"),
    "pd_torque": ("body_mass", "leg_mass", "kp_hip_roll", "kp_hip_pitch", "kp_knee", "kd_knee",
                  "torque_limit_knee", "ground_friction"),
}


def twin_parameters(names: Sequence[str], config: RobotConfig) -> tuple[TwinParameter, ...]:
    """The parameters ``names`` of ``config``; ValueError (one line) for an unknown name, a
    repeated one, one of the other servo, or a value outside its bounds."""
    names = tuple(names)
    if not names:
        raise ValueError("name at least one parameter to calibrate")
    out = []
    for n in names:
        par = TWIN_PARAMETERS.get(n)
        if par is None:
            raise ValueError(f"unknown parameter {n!r}; choose from {', '.join(TWIN_PARAMETERS)}")
        if names.count(n) > 1:
            raise ValueError(f"parameter {n!r} named twice")
        if par.servo is not None and par.servo != config.servo:
            raise ValueError(f"parameter {n!r} acts on the {par.servo} servo; robot "
                             f"{config.name!r} has the {config.servo} servo")
        lo, hi = par.bounds
        v = par.get(config)
        if not lo <= v <= hi:
            raise ValueError(f"parameter {n!r} of {config.name!r} is {v:g}, outside its bounds "
                             f"[{lo:g}, {hi:g}]")
        out.append(par)
    return tuple(out)


def total_mass(config: RobotConfig) -> float:
    """The robot's mass on a scale [kg]: the body and four legs (the feet are massless), times
    ``mass_scale``, as the simulator builds it (``robot/sim.py``)."""
    body = TWIN_PARAMETERS["body_mass"].get(config)
    leg = TWIN_PARAMETERS["leg_mass"].get(config)
    return float(config.mass_scale * (body + 4.0 * leg))
