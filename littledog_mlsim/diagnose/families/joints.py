"""Joint families: effects on the servos and joints of a joint scope."""
from __future__ import annotations

from typing import Any, ClassVar, Mapping

import numpy as np

from ...layout import JOINT_NAMES, LEG_JOINTS
from ...robot.config import robot_config
from .base import (EXCITED_MOVES, Family, FittedEffect, Separation, _cap, _magnitude,
                   register_family)
from .scopes import scope_group, scope_joints

__all__ = ["CommandDelay", "CommandFilter", "ServoGainFamily", "JointFrictionFamily", "Backlash",
           "MotorBacklash", "SetpointBacklash", "TorqueSaturation", "EncoderOffsetFamily",
           "ReportOffset", "EncoderScaleFamily", "ReportScale", "TorqueSpeedFamily", "TimeDrift",
           "SupplySagDrift", "NORMAL_TORQUE", "TorqueRatio"]

_MEASURED = robot_config("measured")
# The servos' normal torque limits [N m] by joint type: the measured robot's (robot/config.py).
NORMAL_TORQUE: dict[str, float] = dict(zip(LEG_JOINTS, _MEASURED.torque_limit))
# The knee's normal torque limit [N m] and P gain [N m/rad]: their quotient is the tracking error
# at which the knee servo saturates, the scale of the learned TrackingSaturation feature.
_KNEE_TORQUE = _MEASURED.torque_limit[2]
_KNEE_KP = _MEASURED.kp[2]


def _joints(scope: str) -> list[str]:
    return [JOINT_NAMES[j] for j in scope_joints(scope)]


@register_family
class CommandDelay(Family):
    """Set-points arrive late (a pure delay on the command path)."""

    name: ClassVar[str] = "command_delay"
    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "delay_ms"
    unit: ClassVar[str] = "ms"
    probe: ClassVar[float] = 10.0
    bounds: ClassVar[tuple[float, float]] = (0.0, 120.0)
    command_path: ClassVar[bool] = True
    timing_rival: ClassVar[bool] = True

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import SetpointDelay
        return [SetpointDelay(max(params[self.primary], 0.0), _joints(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return f"{_cap(where)}: set-points arrive about {params[self.primary]:.0f} ms late"

    def augmentation(self, scope: str, params: Mapping[str, Any]) -> Any:
        from ...models.features import CommandLag
        lag = int(round(float(params["delay_ms"]) / 10.0))
        return CommandLag(lag=lag, joints=scope_group(scope)) if lag >= 1 else None


@register_family
class CommandFilter(Family):
    """Set-points pass a first-order low-pass (a lag on the command path)."""

    name: ClassVar[str] = "command_filter"
    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "time_constant_ms"
    unit: ClassVar[str] = "ms"
    probe: ClassVar[float] = 20.0
    bounds: ClassVar[tuple[float, float]] = (0.0, 300.0)
    command_path: ClassVar[bool] = True
    timing_rival: ClassVar[bool] = True

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import SetpointFilter
        return [SetpointFilter(max(params[self.primary], 0.0), _joints(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)}: set-points pass a first-order lag of about "
                f"{params[self.primary]:.0f} ms (time constant)")

    def augmentation(self, scope: str, params: Mapping[str, Any]) -> Any:
        from ...models.features import CommandFilter as Lowpass
        tau = float(params["time_constant_ms"])
        return Lowpass(time_constant_ms=round(tau, 1), joints=scope_group(scope)) \
            if tau > 1 else None


@register_family
class ServoGainFamily(Family):
    """The servo's P gain differs from nominal (a ratio)."""

    name: ClassVar[str] = "servo_gain"
    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "gain_ratio"
    unit: ClassVar[str] = "1"
    probe: ClassVar[float] = -0.25
    bounds: ClassVar[tuple[float, float]] = (0.05, 3.0)
    neutral: ClassVar[float] = 1.0

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import ServoGain
        return [ServoGain(max(params[self.primary], 0.0), _joints(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)} tracks about {100 * params[self.primary]:.0f} % of each "
                f"set-point change (servo P gain ratio)")


@register_family
class JointFrictionFamily(Family):
    """Extra Coulomb friction in the joints."""

    name: ClassVar[str] = "joint_friction"
    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "coulomb_Nm"
    unit: ClassVar[str] = "N m"
    probe: ClassVar[float] = 0.05
    bounds: ClassVar[tuple[float, float]] = (0.0, 0.6)

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import JointFriction
        return [JointFriction(coulomb=max(params[self.primary], 0.0), joints=_joints(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return f"{_cap(where)}: about {params[self.primary]:.3f} N m of extra Coulomb friction"

    def augmentation(self, scope: str, params: Mapping[str, Any]) -> Any:
        from ...models.features import JointRateSign
        return JointRateSign(smoothing=0.05, joints=scope_group(scope), error_smoothing=0.02)


class _Play(Family):
    """Backlash's two forms share the parameter, the feature and the excitation advice."""

    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "width_rad"
    unit: ClassVar[str] = "rad"
    form: ClassVar[str] = ""

    @property
    def needs_excitation(self) -> bool:
        return True

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        return {"width_rad": float(_magnitude(c)), "form": self.form}

    def augmentation(self, scope: str, params: Mapping[str, Any]) -> Any:
        from ...models.features import Play
        w = float(params["width_rad"])
        return (Play(width=round(w, 4), source="u", joints=scope_group(scope)) if w > 1e-4
                else None)


@register_family
class Backlash(_Play):
    """Play in the joint: the servo drives no torque within half the width of its set-point."""

    name: ClassVar[str] = "backlash"
    probe: ClassVar[float] = 0.03
    bounds: ClassVar[tuple[float, float]] = (0.0, 0.3)
    form: ClassVar[str] = "play in the joint (servo dead zone)"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import ServoDeadband
        return [ServoDeadband(max(params[self.primary], 0.0), _joints(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        v = params[self.primary]
        return (f"{_cap(where)}: about {v:.3f} rad of play (backlash): the servo drives no "
                f"torque while the joint is within {v / 2:.3f} rad of its set-point")


@register_family
class MotorBacklash(_Play):
    """Play in the gears with the encoder on the motor side: the servo drives no torque within
    half the width of its set-point, and the encoder, on the motor that runs to the set-point
    within the play, reads the set-point there (the joint angles hide the play; the body's
    motion shows it)."""

    name: ClassVar[str] = "motor_backlash"
    probe: ClassVar[float] = 0.03
    bounds: ClassVar[tuple[float, float]] = (0.0, 0.3)
    reported_as: ClassVar[str] = "backlash"
    form: ClassVar[str] = "play in the gears, the encoder on the motor side"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import ServoDeadband
        return [ServoDeadband(max(params[self.primary], 0.0), _joints(scope), encoder="motor")]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        v = params[self.primary]
        return (f"{_cap(where)}: about {v:.3f} rad of play (backlash) in the gears, the encoder "
                f"on the motor side: the servo drives no torque while the joint is within "
                f"{v / 2:.3f} rad of its set-point, and the encoder then reads the set-point")


@register_family
class SetpointBacklash(_Play):
    """Play on the set-point path: the set-point holds until the command has moved past it."""

    name: ClassVar[str] = "setpoint_backlash"
    probe: ClassVar[float] = 0.04
    bounds: ClassVar[tuple[float, float]] = (0.0, 0.4)
    command_path: ClassVar[bool] = True
    reported_as: ClassVar[str] = "backlash"
    form: ClassVar[str] = "play on the set-point path"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import SetpointBacklash as Operator
        return [Operator(max(params[self.primary], 0.0), _joints(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        v = params[self.primary]
        return (f"{_cap(where)}: about {v:.3f} rad of play (backlash) on the set-point path: "
                f"the servo's set-point holds until the command has moved {v / 2:.3f} rad "
                f"past it")


class TorqueRatio:
    """TorqueLimit with the limit given relative to each joint's normal one."""

    changes_world = False     # it keeps its own state only (LittleDogSim.reset)

    def __init__(self, ratio: float, joints: list[str] | None) -> None:
        from ...robot.effects import TorqueLimit
        self.ratio = ratio
        self._inner = [TorqueLimit(1.0, [j]) for j in (joints or JOINT_NAMES)]

    def reset(self, sim: Any) -> None:
        for e in self._inner:
            e.reset(sim)
            e.torque_limit_Nm = float(self.ratio * e._lim0[0])

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        for e in self._inner:
            e.command(u, t)
        return u

    def substep(self, sim: Any, t: float) -> None:
        for e in self._inner:
            e.substep(sim, t)


@register_family
class TorqueSaturation(Family):
    """The servo's torque saturates below its normal limit (a threshold effect: screened at a
    second, deeper probe too)."""

    name: ClassVar[str] = "torque_saturation"
    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "torque_limit_ratio"
    unit: ClassVar[str] = "1"
    probe: ClassVar[float] = -0.5
    bounds: ClassVar[tuple[float, float]] = (0.05, 1.0)
    neutral: ClassVar[float] = 1.0
    deep_probe: ClassVar[float | None] = -0.8

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        return [TorqueRatio(max(params["torque_limit_ratio"], 0.0), _joints(scope))]

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        m = _magnitude(c)
        kinds = {JOINT_NAMES[j].rsplit("_", 1)[-1] for j in scope_joints(c.scope)}
        kinds = {("hip_roll" if k == "roll" else "hip_pitch" if k == "pitch" else k)
                 for k in kinds}
        lim = {k: float(m * NORMAL_TORQUE[k]) for k in sorted(kinds)}
        primary = lim.get("knee", next(iter(lim.values())))
        return {"torque_limit_Nm": primary, "torque_limit_ratio": float(m),
                "torque_limit_Nm_by_joint_type": lim}

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)}: servo torque saturates at about "
                f"{100 * params['torque_limit_ratio']:.0f} % of the normal limit "
                f"({params['torque_limit_Nm']:.2f} N m)")

    def augmentation(self, scope: str, params: Mapping[str, Any]) -> Any:
        from ...models.features import TrackingSaturation
        lim = float(params["torque_limit_ratio"]) * _KNEE_TORQUE / _KNEE_KP
        return TrackingSaturation(limit=round(max(lim, 1e-3), 4))


@register_family
class EncoderOffsetFamily(Family):
    """The encoder reads off the true angle; the servo holds the joint that far away."""

    name: ClassVar[str] = "encoder_offset"
    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "offset_rad"
    unit: ClassVar[str] = "rad"
    probe: ClassVar[float] = 0.03
    bounds: ClassVar[tuple[float, float]] = (-0.3, 0.3)
    form: ClassVar[str] = "the servo closes its loop on the reading"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import EncoderOffset
        return [EncoderOffset(params[self.primary], _joints(scope), servo_loop=True)]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)}: the encoder reads about {params[self.primary]:+.3f} rad off "
                f"the true angle (the servo holds the joint that far from the set-point while "
                f"the report shows it on it)")

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        return {self.primary: float(_magnitude(c)), "form": self.form}

    def start_q(self, q: np.ndarray, scope: str, params: Mapping[str, Any]) -> np.ndarray:
        """The measured angle is the true one plus the offset: the joints start at the
        measured angle minus it (else the legs, and so the body, start in a pose the robot
        was not in)."""
        out = np.array(q, dtype=float)
        out[scope_joints(scope)] -= float(params["offset_rad"])
        return out


@register_family
class ReportOffset(EncoderOffsetFamily):
    """The joint states are published a constant off the true angle (a zero set wrong in the
    report only, decision 055): the servo reads the true angle, and the reported angle is the
    true one plus the offset; the joints start at the measured angle minus it, as for the
    servo-loop form."""

    name: ClassVar[str] = "report_offset"
    reported_as: ClassVar[str] = "encoder_offset"
    form: ClassVar[str] = "the report only (the servo reads the true angle)"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import EncoderOffset
        return [EncoderOffset(params[self.primary], _joints(scope), servo_loop=False)]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)}: the joint states report about {params[self.primary]:+.3f} rad "
                f"off the true angle (the servo reads the true angle; a zero set wrong in the "
                f"report only)")


@register_family
class EncoderScaleFamily(Family):
    """The encoder reads every angle and rate a ratio off the true one (its counts per radian,
    or the gear ratio it is read through, set wrong); the servo closes its loop on it."""

    name: ClassVar[str] = "encoder_scale"
    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "scale"
    unit: ClassVar[str] = "1"
    probe: ClassVar[float] = -0.03
    bounds: ClassVar[tuple[float, float]] = (0.7, 1.3)
    neutral: ClassVar[float] = 1.0
    form: ClassVar[str] = "the servo closes its loop on the reading"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import EncoderScale
        return [EncoderScale(float(params[self.primary]), _joints(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        s = float(params[self.primary])
        off = (f"{100 * abs(1 - s):.1f} % {'short' if s < 1 else 'over'}" if round(s, 3) != 1
                 else "within 0.1 %")
        return (f"{_cap(where)}: the encoder reads about {s:.3f} times the true angle "
                f"({off}; the servo holds the joint at the set-point / {s:.3f} while the "
                f"report shows it on it)")

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        return {self.primary: float(_magnitude(c)), "form": self.form}

    def start_q(self, q: np.ndarray, scope: str, params: Mapping[str, Any]) -> np.ndarray:
        """The measured angle is the true one times the scale: the joints start at the
        measured angle divided by it."""
        return _divided(q, scope, params["scale"])

    def start_dq(self, dq: np.ndarray, scope: str, params: Mapping[str, Any]) -> np.ndarray:
        """The measured rate is the true one times the scale: the joints (and the encoders'
        rate filter) start at the measured rate divided by it."""
        return _divided(dq, scope, params["scale"])


def _divided(x: np.ndarray, scope: str, scale: float) -> np.ndarray:
    """A copy of ``x`` with the scope's joints divided by ``scale``."""
    out = np.array(x, dtype=float)
    out[scope_joints(scope)] /= float(scale)
    return out


@register_family
class ReportScale(EncoderScaleFamily):
    """The encoder's counts are converted to radians with a wrong ratio for the report only
    (a joint-state publisher's counts per radian): the servo reads the true angle, and the
    reported angle and rate are the ratio times the true ones."""

    name: ClassVar[str] = "report_scale"
    reported_as: ClassVar[str] = "encoder_scale"
    form: ClassVar[str] = "the report only (the servo reads the true angle)"

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import ReadingScale
        return [ReadingScale(float(params[self.primary]), _joints(scope))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        s = float(params[self.primary])
        return (f"{_cap(where)}: the joint states report about {s:.3f} times the true angle "
                f"and rate (the servo reads the true angle; a wrong counts per radian in the "
                f"report only)")


@register_family
class TorqueSpeedFamily(Family):
    """The motors' torque-speed line: while the servo drives a joint the way it moves, the
    torque it can give falls with the joint's speed (back-EMF), reaching zero at the no-load
    speed; braking keeps the normal limit. Fitted as the share of the normal limit lost per
    rad/s, 1 / no-load speed (0: no loss); a threshold effect (it bites only where a servo
    pushes hard while the joint moves fast): screened at a second, deeper probe too."""

    name: ClassVar[str] = "torque_speed"
    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "torque_drop_s_per_rad"
    unit: ClassVar[str] = "s/rad"
    probe: ClassVar[float] = 0.25
    bounds: ClassVar[tuple[float, float]] = (0.0, 1.0)
    deep_probe: ClassVar[float | None] = 0.5

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import TorqueSpeed
        drop = float(params[self.primary])
        return [TorqueSpeed(1.0 / drop, _joints(scope))] if drop > 1e-9 else []

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        drop = float(_magnitude(c))
        return {"no_load_speed_rad_s": (1.0 / drop) if drop > 1e-9 else None,
                self.primary: drop}

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        w0 = params.get("no_load_speed_rad_s")
        if w0 is None:
            return f"{_cap(where)}: no loss of servo torque with joint speed"
        return (f"{_cap(where)}: the servo's torque falls with joint speed while it drives the "
                f"joint the way it moves, by about {100 * params[self.primary]:.0f} % of the "
                f"normal limit per rad/s ({params[self.primary]:.3f} s/rad), to zero at about "
                f"{w0:.1f} rad/s (a motor's no-load speed; braking torque unchanged)")

    def separation(self, other: Family) -> Separation | None:
        if other.name != "torque_saturation":
            return None
        return Separation(2, "a torque-speed line takes torque only where a joint moves fast "
                             "while its servo drives it, a lower limit wherever the servo pushes "
                             "hard: they differ in fast swings against slow pushes",
                          EXCITED_MOVES)


class _Drift(Family):
    """A drift's two forms share the parameter, the range, the feature and the reading."""

    kind: ClassVar[str] = "joints"
    primary: ClassVar[str] = "rate_per_s"
    unit: ClassVar[str] = "1/s"
    probe: ClassVar[float] = -0.08
    bounds: ClassVar[tuple[float, float]] = (-0.24, 0.24)
    long_screen: ClassVar[bool] = True   # type: ignore[assignment]
    form: ClassVar[str] = ""

    @property
    def shortlist_class(self) -> str:
        return "time_drift"

    def physical_params(self, c: FittedEffect, foot_mu: float) -> dict[str, Any]:
        return {self.primary: float(_magnitude(c)), "form": self.form}

    def augmentation(self, scope: str, params: Mapping[str, Any]) -> Any:
        from ...models.features import ElapsedTime
        return ElapsedTime()

    def separation(self, other: Family) -> Separation | None:
        if not isinstance(other, _Drift) or other.name == self.name:
            return None
        return Separation(2, "a drifting P gain leaves the servo's damping and torque limit as "
                             "they were, a sagging supply shrinks them too: they differ where "
                             "a servo moves fast or saturates", EXCITED_MOVES)


@register_family
class TimeDrift(_Drift):
    """The servo's P gain drifts over a move (grows over 4 s: screened on the replay too)."""

    name: ClassVar[str] = "time_drift"
    form: ClassVar[str] = "servo P gain"
    other_forms: ClassVar[tuple[str, ...]] = ("supply_sag",)

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import ServoGain
        return [ServoGain(1.0, _joints(scope), drift_per_s=params[self.primary],
                          time_offset_s=params.get("t0_s", 0.0))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)}: servo gain drifts by about {100 * params[self.primary]:+.1f} % "
                f"per second since the start of a move")


@register_family
class SupplySagDrift(_Drift):
    """The servo's whole output (P and D torque and its limit) drifts over a move: the supply
    voltage sags. Not screened: fitted where the gain drift's screen points."""

    name: ClassVar[str] = "supply_sag"
    bounds: ClassVar[tuple[float, float]] = (-0.24, 0.0)   # a supply only sags
    reported_as: ClassVar[str] = "time_drift"
    form: ClassVar[str] = "servo output (P, D and torque limit)"
    screened: ClassVar[bool] = False

    def build_effects(self, scope: str, params: Mapping[str, Any]) -> list[Any]:
        from ...robot.effects import SupplySag
        return [SupplySag(params[self.primary], _joints(scope),
                          time_offset_s=params.get("t0_s", 0.0))]

    def statement(self, where: str, params: Mapping[str, Any]) -> str:
        return (f"{_cap(where)}: servo output (torque and its limit) drifts by about "
                f"{100 * params[self.primary]:+.1f} % per second since the start of a move "
                f"(a sagging supply)")
