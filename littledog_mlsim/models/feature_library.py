"""The library of augmentations: the feature classes a feature set can hold.

Lagged and filtered commands, lagged states, tracking saturation, joint-rate signs and
magnitudes, backlash play, heading and planar position, elapsed time, foot heights, commanded
lifts, the gait phase, and time times the tracking error (a servo stiffness drifting with time).
Each is a frozen dataclass registered under its ``name``
(:func:`.feature_base.register_augmentation`); its ``family`` names the kind of effect it models (the
diagnosis report groups candidates by it). ``JOINT_GROUPS``/``STATE_GROUPS`` are the named
scopes their ``joints``/``group`` parameters accept.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Mapping

import numpy as np

from ..layout import CONTROL_DT, HOME_POSE, JOINT_NAMES, LEGS, N_STATE, STATE_NAMES, S
from .feature_base import Augmentation, FeatureSetError, Window, register_augmentation

__all__ = [
    "CommandLag", "CommandIncrement", "StateLag", "CommandFilter", "TrackingSaturation",
    "JointRateSign", "JointRateMagnitude", "Play", "Heading", "PlanarPosition", "ElapsedTime",
    "FootHeight", "CommandedLift", "GaitPhase", "ElapsedTracking", "SwingRate", "STATE_GROUPS",
    "JOINT_GROUPS", "SWING_LIFT_M",
]


JOINT_GROUPS: dict[str, tuple[int, ...]] = {
    "all": tuple(range(12)),
    "hip_rolls": tuple(range(0, 12, 3)),
    "hip_pitches": tuple(range(1, 12, 3)),
    "knees": tuple(range(2, 12, 3)),
}
# the diagnosis' scopes (docs/diagnosis.md): legs, sides and single joints, by contract name
JOINT_GROUPS.update({leg: tuple(range(3 * i, 3 * i + 3)) for i, leg in enumerate(LEGS)})
JOINT_GROUPS.update({side: tuple(j for j, n in enumerate(JOINT_NAMES) if f"_{side}_" in n)
                     for side in ("left", "right")})
JOINT_GROUPS.update({n: (j,) for j, n in enumerate(JOINT_NAMES)})
STATE_GROUPS: dict[str, tuple[int, ...]] = {
    "all": tuple(range(N_STATE)),
    "body": tuple(range(0, 9)),
    "body_deltas": (1, 2, 3, 6, 7, 8),
    "joints": tuple(range(9, 33)),
    "q": tuple(range(9, 21)),
    "dq": tuple(range(21, 33)),
}


def _group(groups: Mapping[str, tuple[int, ...]], name: str, what: str) -> tuple[int, ...]:
    try:
        return groups[name]
    except KeyError:
        raise FeatureSetError(f"{what}: unknown group {name!r}; choose from "
                              f"{', '.join(groups)}") from None


def _check_lag(value: Any, what: str, least: int = 1) -> None:
    """FeatureSetError unless ``value`` is an integer >= ``least`` (a lag in control steps)."""
    if int(value) != value or value < least:
        rule = "a positive integer" if least == 1 else f"an integer >= {least}"
        raise FeatureSetError(f"{what} must be {rule}, got {value!r}")


@register_augmentation
@dataclass(frozen=True)
class CommandLag(Augmentation):
    """u_{t-lag} of the selected joints: the command the servo acts on if it arrives ``lag``
    control steps late (a pure delay: the model then has both u_t and u_{t-lag})."""

    lag: int = 1
    joints: str = "all"
    name: ClassVar[str] = "command_lag"
    family: ClassVar[str] = "command delay"

    def __post_init__(self) -> None:
        _check_lag(self.lag, "command_lag: lag")
        _group(JOINT_GROUPS, self.joints, "command_lag")

    @property
    def max_lag(self) -> int:
        return int(self.lag)

    def columns(self) -> tuple[str, ...]:
        return tuple(f"u_{JOINT_NAMES[j]}@t-{self.lag}" for j in JOINT_GROUPS[self.joints])

    def compute(self, w: Window) -> np.ndarray:
        return w.u(self.lag)[..., list(JOINT_GROUPS[self.joints])]


@register_augmentation
@dataclass(frozen=True)
class CommandIncrement(Augmentation):
    """u_{t-lag} - u_{t-lag-1}: the command's change ``lag`` steps ago (a late or rate-dependent
    servo). Screened in the command-delay family: next to u_t, the increment at lag 0 spans the
    same as u_{t-1}."""

    lag: int = 0
    joints: str = "all"
    name: ClassVar[str] = "command_increment"
    family: ClassVar[str] = "command delay"

    def __post_init__(self) -> None:
        _check_lag(self.lag, "command_increment: lag", least=0)
        _group(JOINT_GROUPS, self.joints, "command_increment")

    @property
    def max_lag(self) -> int:
        return int(self.lag) + 1

    def columns(self) -> tuple[str, ...]:
        return tuple(f"du_{JOINT_NAMES[j]}@t-{self.lag}" for j in JOINT_GROUPS[self.joints])

    def compute(self, w: Window) -> np.ndarray:
        idx = list(JOINT_GROUPS[self.joints])
        return w.u(self.lag)[..., idx] - w.u(self.lag + 1)[..., idx]


@register_augmentation
@dataclass(frozen=True)
class StateLag(Augmentation):
    """s_{t-lag} restricted to a group of state elements: a dynamics order the Markov state
    misses (filtered sensors, measurement noise that is shared by successive differences)."""

    lag: int = 1
    group: str = "all"
    name: ClassVar[str] = "state_lag"
    family: ClassVar[str] = "lagged state"

    def __post_init__(self) -> None:
        _check_lag(self.lag, "state_lag: lag")
        _group(STATE_GROUPS, self.group, "state_lag")

    @property
    def max_lag(self) -> int:
        return int(self.lag)

    def columns(self) -> tuple[str, ...]:
        return tuple(f"{STATE_NAMES[i]}@t-{self.lag}" for i in STATE_GROUPS[self.group])

    def compute(self, w: Window) -> np.ndarray:
        return w.s(self.lag)[..., list(STATE_GROUPS[self.group])]


@register_augmentation
@dataclass(frozen=True)
class TrackingSaturation(Augmentation):
    """clip(u_t - q_t, -limit, limit) per joint: the servo's tracking error through a
    saturation (torque limit; with a small limit, the sign of the error). The unclipped error is
    linear in the paper's features already."""

    limit: float = 0.1
    name: ClassVar[str] = "tracking_saturation"
    family: ClassVar[str] = "tracking error saturation"

    def __post_init__(self) -> None:
        if not self.limit > 0:
            raise FeatureSetError(f"tracking_saturation: limit must be > 0, got {self.limit!r}")

    def columns(self) -> tuple[str, ...]:
        return tuple(f"sat(u-q)_{j}" for j in JOINT_NAMES)

    def compute(self, w: Window) -> np.ndarray:
        e = w.u(0) - w.s(0)[..., S.q]
        return np.clip(e, -self.limit, self.limit)


@register_augmentation
@dataclass(frozen=True)
class JointRateSign(Augmentation):
    """Coulomb friction terms per selected joint: tanh(dq_t / smoothing), the sign of the joint
    rate now, and tanh((u_t - q_t) / error_smoothing), the sign of the servo's push, which is
    the direction the joint moves during the step when it starts or reverses (the soft,
    heavily damped servo makes the rate follow the push within a few ms). Coulomb friction
    -c sign(dq) over the step is a mix of the two; viscous friction -b dq is linear in dq, which
    the paper's features hold already."""

    smoothing: float = 0.05
    joints: str = "all"
    error_smoothing: float = 0.02
    name: ClassVar[str] = "joint_rate_sign"
    family: ClassVar[str] = "Coulomb friction"

    def __post_init__(self) -> None:
        if not (self.smoothing > 0 and self.error_smoothing > 0):
            raise FeatureSetError(f"joint_rate_sign: smoothing and error_smoothing must be > 0, "
                                  f"got {self.smoothing!r}, {self.error_smoothing!r}")
        _group(JOINT_GROUPS, self.joints, "joint_rate_sign")

    def columns(self) -> tuple[str, ...]:
        idx = JOINT_GROUPS[self.joints]
        return (tuple(f"sign(dq_{JOINT_NAMES[j]})" for j in idx)
                + tuple(f"sign(u-q)_{JOINT_NAMES[j]}" for j in idx))

    def compute(self, w: Window) -> np.ndarray:
        idx = list(JOINT_GROUPS[self.joints])
        s, u = w.s(0), w.u(0)
        dq = s[..., S.dq][..., idx]
        e = u[..., idx] - s[..., S.q][..., idx]
        return np.concatenate([np.tanh(dq / self.smoothing),
                               np.tanh(e / self.error_smoothing)], axis=-1)


@register_augmentation
@dataclass(frozen=True)
class JointRateMagnitude(Augmentation):
    """|dq_t| (``kind="abs"``) or dq_t |dq_t| (``"quadratic"``) per joint: velocity-dependent
    friction beyond the linear (viscous) term."""

    kind: str = "abs"
    name: ClassVar[str] = "joint_rate_magnitude"
    family: ClassVar[str] = "velocity-dependent friction"

    def __post_init__(self) -> None:
        if self.kind not in ("abs", "quadratic"):
            raise FeatureSetError(f"joint_rate_magnitude: kind must be abs or quadratic, "
                                  f"got {self.kind!r}")

    def columns(self) -> tuple[str, ...]:
        f = "|dq_{}|" if self.kind == "abs" else "dq|dq|_{}"
        return tuple(f.format(j) for j in JOINT_NAMES)

    def compute(self, w: Window) -> np.ndarray:
        dq = w.s(0)[..., S.dq]
        return np.abs(dq) if self.kind == "abs" else dq * np.abs(dq)


@register_augmentation
@dataclass(frozen=True)
class Play(Augmentation):
    """Backlash / hysteresis: the position of each joint inside a play band of ``width``.

    The play (backlash) operator y_t = clip(y_{t-1}, x_t - width/2, x_t + width/2) follows the
    input x (``source``: the measured angle q or the command u) of each selected joint
    (``joints``, a joint group) with a dead band, starting centred (y = x at the first sample);
    the feature (x_t - y_t) / (width/2) in [-1, 1] is +1 after moving up, -1 after moving down,
    and between them while a reversal takes up the play: the direction-reversal history that
    backlash and hysteresis depend on. Recursive.
    """

    width: float = 0.02
    source: str = "q"
    joints: str = "all"
    name: ClassVar[str] = "play"
    family: ClassVar[str] = "backlash/hysteresis"
    recursive: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if not self.width > 0:
            raise FeatureSetError(f"play: width must be > 0, got {self.width!r}")
        if self.source not in ("q", "u"):
            raise FeatureSetError(f"play: source must be q or u, got {self.source!r}")
        _group(JOINT_GROUPS, self.joints, "play")

    def columns(self) -> tuple[str, ...]:
        return tuple(f"play({self.source}_{JOINT_NAMES[j]})" for j in JOINT_GROUPS[self.joints])

    def _x(self, w: Window) -> np.ndarray:
        x = w.s(0)[..., S.q] if self.source == "q" else w.u(0)
        return x[..., list(JOINT_GROUPS[self.joints])]

    def init_carry(self, w: Window) -> np.ndarray:
        return np.array(self._x(w), dtype=np.float64)

    def advance(self, carry: np.ndarray, w: Window) -> tuple[np.ndarray, np.ndarray]:
        x = self._x(w)
        half = 0.5 * self.width
        y = np.minimum(np.maximum(carry, x - half), x + half)
        return (x - y) / half, y


@register_augmentation
@dataclass(frozen=True)
class CommandFilter(Augmentation):
    """The selected joints' commands through a first-order low-pass of ``time_constant_ms``
    (y_t = y_{t-1} + a (u_t - y_{t-1}), a = 1 - exp(-10 ms / tau), y = u at the first sample):
    the set-point a servo acts on if set-points pass a lag. Recursive."""

    time_constant_ms: float = 20.0
    joints: str = "all"
    name: ClassVar[str] = "command_filter"
    family: ClassVar[str] = "command filter"
    recursive: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if not self.time_constant_ms > 0:
            raise FeatureSetError(f"command_filter: time_constant_ms must be > 0, "
                                  f"got {self.time_constant_ms!r}")
        _group(JOINT_GROUPS, self.joints, "command_filter")

    def columns(self) -> tuple[str, ...]:
        return tuple(f"lowpass{self.time_constant_ms:g}ms(u_{JOINT_NAMES[j]})"
                     for j in JOINT_GROUPS[self.joints])

    def init_carry(self, w: Window) -> np.ndarray:
        return np.array(w.u(0)[..., list(JOINT_GROUPS[self.joints])], dtype=np.float64)

    def advance(self, carry: np.ndarray, w: Window) -> tuple[np.ndarray, np.ndarray]:
        a = 1.0 - np.exp(-CONTROL_DT * 1000.0 / self.time_constant_ms)
        y = carry + a * (w.u(0)[..., list(JOINT_GROUPS[self.joints])] - carry)
        return y, y


@register_augmentation
@dataclass(frozen=True)
class Heading(Augmentation):
    """sin(yaw), cos(yaw): the heading the state drops on purpose. A force fixed in the world
    (wind, a slope) acts in the body frame through these."""

    name: ClassVar[str] = "heading"
    family: ClassVar[str] = "pose (heading)"
    needs_pose: ClassVar[bool] = True

    def columns(self) -> tuple[str, ...]:
        return ("sin_yaw", "cos_yaw")

    def compute(self, w: Window) -> np.ndarray:
        yaw = w.pose[..., 2]
        return np.stack([np.sin(yaw), np.cos(yaw)], axis=-1)


@register_augmentation
@dataclass(frozen=True)
class PlanarPosition(Augmentation):
    """x_w, y_w: where the robot is in odom (terrain that varies over the floor)."""

    name: ClassVar[str] = "planar_position"
    family: ClassVar[str] = "pose (position)"
    needs_pose: ClassVar[bool] = True

    def columns(self) -> tuple[str, ...]:
        return ("x_w", "y_w")

    def compute(self, w: Window) -> np.ndarray:
        return w.pose[..., :2].copy()


@register_augmentation
@dataclass(frozen=True)
class ElapsedTime(Augmentation):
    """Seconds since the move (the simulation) started: drift, warm-up, battery sag."""

    name: ClassVar[str] = "elapsed_time"
    family: ClassVar[str] = "elapsed time"

    def columns(self) -> tuple[str, ...]:
        return ("elapsed_s",)

    def compute(self, w: Window) -> np.ndarray:
        return np.asarray(w.elapsed, dtype=np.float64)[..., None]


def _forward_kinematics(q: np.ndarray) -> np.ndarray:
    from ..gait.ik import forward_kinematics  # pure NumPy leg geometry (no robot/ import)
    return forward_kinematics(q)


_HOME_FEET = None


def _home_feet() -> np.ndarray:
    global _HOME_FEET
    if _HOME_FEET is None:
        _HOME_FEET = _forward_kinematics(HOME_POSE)
    return _HOME_FEET


def _commanded_lift(u: np.ndarray) -> np.ndarray:
    """(..., 4) how high the commands ``u`` (..., 12) lift each foot above its home position."""
    return _forward_kinematics(u)[..., 2] - _home_feet()[:, 2]


@register_augmentation
@dataclass(frozen=True)
class FootHeight(Augmentation):
    """Height of each foot centre above the floor plane of odom, from the measured joint angles,
    z_w, roll and pitch (forward kinematics): a foot-contact proxy (a foot in contact sits at
    about its radius, 0.01 m)."""

    name: ClassVar[str] = "foot_height"
    family: ClassVar[str] = "foot contact"

    def columns(self) -> tuple[str, ...]:
        return tuple(f"foot_z_{leg}" for leg in LEGS)

    def compute(self, w: Window) -> np.ndarray:
        s = w.s(0)
        feet = _forward_kinematics(s[..., S.q])                     # (..., 4, 3) body frame
        r, p = s[..., S.roll], s[..., S.pitch]
        # z row of Ry(pitch) Rx(roll): (-sin p, cos p sin r, cos p cos r)
        z = (-np.sin(p)[..., None] * feet[..., 0] + (np.cos(p) * np.sin(r))[..., None]
             * feet[..., 1] + (np.cos(p) * np.cos(r))[..., None] * feet[..., 2])
        return s[..., S.z_w][..., None] + z


@register_augmentation
@dataclass(frozen=True)
class CommandedLift(Augmentation):
    """How high the command lifts each foot above its home position (body frame, forward
    kinematics of u_t): which legs the gait means to swing (contact intent)."""

    name: ClassVar[str] = "commanded_lift"
    family: ClassVar[str] = "foot contact"

    def columns(self) -> tuple[str, ...]:
        return tuple(f"lift_cmd_{leg}" for leg in LEGS)

    def compute(self, w: Window) -> np.ndarray:
        return _commanded_lift(w.u(0))


@register_augmentation
@dataclass(frozen=True)
class GaitPhase(Augmentation):
    """sin/cos of the trot phase, from the commands alone.

    c_t = lift(front_left) + lift(back_right) - lift(front_right) - lift(back_left) (commanded
    lifts, :class:`CommandedLift`) oscillates once per gait cycle. With ``quarter_lag`` k close
    to a quarter period, (c_t + c_{t-k}, c_t - c_{t-k}) is c in quadrature, so its direction is
    the phase; it is normalised to unit length (both 0 when the feet are not lifted, e.g.
    standing).
    """

    quarter_lag: int = 9
    name: ClassVar[str] = "gait_phase"
    family: ClassVar[str] = "gait phase"

    def __post_init__(self) -> None:
        _check_lag(self.quarter_lag, "gait_phase: quarter_lag")

    @property
    def max_lag(self) -> int:
        return int(self.quarter_lag)

    def columns(self) -> tuple[str, ...]:
        return ("gait_phase_sin", "gait_phase_cos")

    @staticmethod
    def _diag(u: np.ndarray) -> np.ndarray:
        lift = _commanded_lift(u)
        return lift[..., 0] + lift[..., 3] - lift[..., 1] - lift[..., 2]

    def compute(self, w: Window) -> np.ndarray:
        c0, ck = self._diag(w.u(0)), self._diag(w.u(self.quarter_lag))
        a, b = c0 + ck, c0 - ck
        n = np.hypot(a, b)
        scale = np.where(n > 1e-4, 1.0 / np.where(n > 1e-4, n, 1.0), 0.0)  # 0.1 mm: not lifting
        return np.stack([a * scale, b * scale], axis=-1)


@register_augmentation
@dataclass(frozen=True)
class ElapsedTracking(Augmentation):
    """t * (u_j - q_j) of the selected joints, t the seconds since the move started: a servo
    stiffness that drifts with time (battery sag, warming), which an elapsed-time column alone
    cannot carry (the servo's push is the product of its gain and its tracking error)."""

    joints: str = "all"
    name: ClassVar[str] = "elapsed_tracking"
    family: ClassVar[str] = "elapsed time"

    def __post_init__(self) -> None:
        _group(JOINT_GROUPS, self.joints, "elapsed_tracking")

    def columns(self) -> tuple[str, ...]:
        return tuple(f"t*(u-q)_{JOINT_NAMES[j]}" for j in JOINT_GROUPS[self.joints])

    def compute(self, w: Window) -> np.ndarray:
        idx = list(JOINT_GROUPS[self.joints])
        err = w.u(0)[..., idx] - w.s(0)[..., S.q][..., idx]
        return np.asarray(w.elapsed, dtype=np.float64)[..., None] * err


#: the commanded lift [m] at which a swing-rate column counts its joint's rate fully
SWING_LIFT_M = 0.01


@register_augmentation
@dataclass(frozen=True)
class SwingRate(Augmentation):
    """w * dq_j of the selected joints, w = clip(lift / SWING_LIFT_M, 0, 1) of the joint's leg
    (its commanded lift, :class:`CommandedLift`): the joint's rate while its foot is meant to
    swing. A force on a swinging foot (a snagging cable, drag) or a joint damping that acts
    only off the ground is a product of the contact phase and the rate, which the state and
    command carry only as separate inputs."""

    joints: str = "all"
    name: ClassVar[str] = "swing_rate"
    family: ClassVar[str] = "swing"

    def __post_init__(self) -> None:
        _group(JOINT_GROUPS, self.joints, "swing_rate")

    def columns(self) -> tuple[str, ...]:
        return tuple(f"swing*dq_{JOINT_NAMES[j]}" for j in JOINT_GROUPS[self.joints])

    def compute(self, w: Window) -> np.ndarray:
        idx = list(JOINT_GROUPS[self.joints])
        lift = _commanded_lift(w.u(0))                                   # (..., 4) legs
        weight = np.clip(lift / SWING_LIFT_M, 0.0, 1.0)[..., [j // 3 for j in idx]]
        return weight * w.s(0)[..., S.dq][..., idx]
