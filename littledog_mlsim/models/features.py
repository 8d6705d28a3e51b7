"""Feature sets: the paper's 45 features plus named augmentations, in batch and online.

The paper's one-step model maps x_t = (s_t, u_t) (45 features, ``layout.FEATURE_NAMES``) to
s_{t+1}. A model that carries an *effect* the paper's features miss (a command delay, friction,
a heading-dependent force, ...) needs more inputs, computed from what a simulator sees: the state
and command streams. An :class:`Augmentation` is one such named, parametrised transform; a
:class:`FeatureSet` is the paper's 45 features followed by the columns of its augmentations, in
order. The same object computes the features

- in batch, from recordings (:meth:`FeatureSet.features_responses`, aligned sample for sample
  with :func:`..data.dataset.features_responses`), and
- online, step by step and batched over B simulated moves (:meth:`FeatureSet.history` ->
  :class:`FeatureHistory`), for the rollout and the 100 Hz node,

and both give the same numbers (``test/test_diagnose.py`` checks that they are equal).

What an augmentation may look at (the :class:`Window` it is given), for the sample at step t:

- ``s(k)`` = s_{t-k}, ``u(k)`` = u_{t-k} for 0 <= k <= ``max_lag`` (the state the model is given
  and the commands sent);
- ``pose`` = (x_w, y_w, yaw) at t, the pose the state drops on purpose, integrated from the states
  as the contract says (``integrate_path``: yaw += dyaw, p += R(roll, pitch, yaw at t-1) d_b);
- ``elapsed`` = seconds since the history started.

History rule (the same in both modes): the history starts at the first sample of a move (batch:
s_1 with u_1, the first feature/response pair of ``features_responses``; online: the state the
simulator starts from and the first command it is given). Lags that reach before it repeat the
first state and the first command (the robot is taken to have been at rest holding its first
command), and elapsed time is 0 there. The pose starts from the pose given at the first sample
(batch: the recording's measured pose at measurement 1; the rollout uses the same).

Augmentations with a memory beyond a fixed window (the backlash "play" operator) are recursive:
they carry a state from step to step (``init_carry``/``advance``), run through the same code in
both modes (batch loops over time, batched over the moves).

Files: a model records ``FeatureSet.to_dict()`` in its metadata: the augmentations' registered
names and parameters (plain JSON; nothing executable), plus the column names. ``from_dict``
rebuilds it and fails with a one-line ``FeatureSetError`` for an augmentation this build does not
know. Registered augmentations are listed in :data:`AUGMENTATIONS`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from ..data.dataset import actions_from_recording, initial_pose, states_from_recording
from ..data.recording import MoveRecording
from ..layout import (
    CONTROL_DT, FEATURE_NAMES, HOME_POSE, JOINT_NAMES, LEGS, N_ACTION, N_FEATURE, N_STATE,
    STATE_NAMES, S,
)
from ..rotations import rpy_to_matrix

FEATURE_SET_FORMAT_VERSION = 1
BASE_FEATURES = "paper45"

__all__ = [
    "Augmentation", "AUGMENTATIONS", "register_augmentation", "FeatureSet", "FeatureSetError",
    "FeatureHistory", "Window", "batch_columns", "integrate_pose", "CommandLag",
    "CommandIncrement", "StateLag", "CommandFilter",
    "TrackingSaturation", "JointRateSign", "JointRateMagnitude", "Play", "Heading",
    "PlanarPosition", "ElapsedTime", "FootHeight", "CommandedLift", "GaitPhase",
    "STATE_GROUPS", "JOINT_GROUPS", "BASE_FEATURES", "FEATURE_SET_FORMAT_VERSION",
]


class FeatureSetError(ValueError):
    """A feature set cannot be built or read (one-line message)."""


# ---------------------------------------------------------------------------------------------
# what an augmentation sees


class Window:
    """The inputs of one step for a batch of samples, shapes (..., dim).

    Batch mode builds it over whole moves (leading shape (B, T)), online mode for one step
    (leading shape (B,)). ``s(k)``/``u(k)`` return s_{t-k}/u_{t-k}; ``pose`` is (..., 3) x_w,
    y_w, yaw (None if the feature set needs no pose); ``elapsed`` (...) seconds.
    """

    def __init__(self, states: Sequence[np.ndarray], actions: Sequence[np.ndarray],
                 pose: np.ndarray | None, elapsed: np.ndarray) -> None:
        self._s = states
        self._u = actions
        self.pose = pose
        self.elapsed = elapsed

    def s(self, k: int = 0) -> np.ndarray:
        return self._s[k]

    def u(self, k: int = 0) -> np.ndarray:
        return self._u[k]


# ---------------------------------------------------------------------------------------------
# augmentations

AUGMENTATIONS: dict[str, type["Augmentation"]] = {}


def register_augmentation(cls: type["Augmentation"]) -> type["Augmentation"]:
    """Register an augmentation class under ``cls.name`` (usable as a decorator)."""
    old = AUGMENTATIONS.get(cls.name)
    if old is not None and old is not cls:
        raise ValueError(f"augmentation {cls.name!r} is already registered to {old.__name__}")
    AUGMENTATIONS[cls.name] = cls
    return cls


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


@dataclass(frozen=True)
class Augmentation:
    """A named transform of the state/command history into extra feature columns.

    Subclasses set ``name`` (registry key, stored in model files), ``family`` (the kind of
    effect it models, used by the diagnosis report), are frozen dataclasses whose fields are the
    parameters (plain JSON values), and implement ``columns`` and ``compute`` (or, for
    recursive ones, ``init_carry`` and ``advance``).
    """

    name: ClassVar[str] = ""
    family: ClassVar[str] = ""
    recursive: ClassVar[bool] = False
    needs_pose: ClassVar[bool] = False

    @property
    def max_lag(self) -> int:
        """Largest k of s(k)/u(k) used."""
        return 0

    def params(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def label(self) -> str:
        """Short human-readable name with parameters, e.g. ``command_lag(lag=2)``."""
        args = ", ".join(f"{k}={v}" for k, v in self.params().items())
        return f"{self.name}({args})"

    def columns(self) -> tuple[str, ...]:
        raise NotImplementedError

    def compute(self, w: Window) -> np.ndarray:
        """(..., n_columns) for the samples of ``w``."""
        raise NotImplementedError

    # recursive augmentations
    def init_carry(self, w: Window) -> np.ndarray:
        raise NotImplementedError

    def advance(self, carry: np.ndarray, w: Window) -> tuple[np.ndarray, np.ndarray]:
        """(features (B, n_columns), new carry) for one step."""
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "family": self.family, "params": self.params(),
                "columns": list(self.columns())}


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
        if int(self.lag) != self.lag or self.lag < 1:
            raise FeatureSetError(f"command_lag: lag must be a positive integer, got {self.lag!r}")
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
        if int(self.lag) != self.lag or self.lag < 0:
            raise FeatureSetError(f"command_increment: lag must be an integer >= 0, "
                                  f"got {self.lag!r}")
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
        if int(self.lag) != self.lag or self.lag < 1:
            raise FeatureSetError(f"state_lag: lag must be a positive integer, got {self.lag!r}")
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
    input x (``source``: the measured angle q or the command u) with a dead band, starting
    centred (y = x at the first sample); the feature (x_t - y_t) / (width/2) in [-1, 1] is +1
    after moving up, -1 after moving down, and between them while a reversal takes up the play:
    the direction-reversal history that backlash and hysteresis depend on. Recursive.
    """

    width: float = 0.02
    source: str = "q"
    name: ClassVar[str] = "play"
    family: ClassVar[str] = "backlash/hysteresis"
    recursive: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if not self.width > 0:
            raise FeatureSetError(f"play: width must be > 0, got {self.width!r}")
        if self.source not in ("q", "u"):
            raise FeatureSetError(f"play: source must be q or u, got {self.source!r}")

    def columns(self) -> tuple[str, ...]:
        return tuple(f"play({self.source}_{j})" for j in JOINT_NAMES)

    def _x(self, w: Window) -> np.ndarray:
        return w.s(0)[..., S.q] if self.source == "q" else w.u(0)

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
        return _forward_kinematics(w.u(0))[..., 2] - _home_feet()[:, 2]


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
        if int(self.quarter_lag) != self.quarter_lag or self.quarter_lag < 1:
            raise FeatureSetError(f"gait_phase: quarter_lag must be a positive integer, got "
                                  f"{self.quarter_lag!r}")

    @property
    def max_lag(self) -> int:
        return int(self.quarter_lag)

    def columns(self) -> tuple[str, ...]:
        return ("gait_phase_sin", "gait_phase_cos")

    @staticmethod
    def _diag(u: np.ndarray) -> np.ndarray:
        lift = _forward_kinematics(u)[..., 2] - _home_feet()[:, 2]
        return lift[..., 0] + lift[..., 3] - lift[..., 1] - lift[..., 2]

    def compute(self, w: Window) -> np.ndarray:
        c0, ck = self._diag(w.u(0)), self._diag(w.u(self.quarter_lag))
        a, b = c0 + ck, c0 - ck
        n = np.hypot(a, b)
        scale = np.where(n > 1e-4, 1.0 / np.where(n > 1e-4, n, 1.0), 0.0)  # 0.1 mm: not lifting
        return np.stack([a * scale, b * scale], axis=-1)


def augmentation_from_dict(d: Mapping[str, Any]) -> Augmentation:
    """Rebuild an augmentation from ``Augmentation.to_dict()`` (FeatureSetError if unknown)."""
    if not isinstance(d, Mapping) or "name" not in d:
        raise FeatureSetError("augmentation entry must be a mapping with a 'name'")
    cls = AUGMENTATIONS.get(str(d["name"]))
    if cls is None:
        raise FeatureSetError(f"unknown augmentation {d['name']!r} (this build knows "
                              f"{', '.join(sorted(AUGMENTATIONS))})")
    params = d.get("params") or {}
    if not isinstance(params, Mapping):
        raise FeatureSetError(f"augmentation {d['name']!r}: params must be a mapping")
    try:
        aug = cls(**params)
    except TypeError as e:
        raise FeatureSetError(f"augmentation {d['name']!r}: bad params {dict(params)}: "
                              f"{e}") from None
    cols = d.get("columns")
    if cols is not None and list(cols) != list(aug.columns()):
        raise FeatureSetError(f"augmentation {aug.label()}: stored columns differ from this "
                              f"build's")
    return aug


# ---------------------------------------------------------------------------------------------
# feature sets


@dataclass(frozen=True)
class FeatureSet:
    """The paper's 45 features followed by the columns of ``augmentations``, in order."""

    augmentations: tuple[Augmentation, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        object.__setattr__(self, "augmentations", tuple(self.augmentations))
        for a in self.augmentations:
            if not isinstance(a, Augmentation):
                raise FeatureSetError(f"not an augmentation: {a!r}")
        names = self.names
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise FeatureSetError(f"feature set has duplicate columns: {', '.join(dup[:5])}")

    # -- description

    @property
    def extra_names(self) -> tuple[str, ...]:
        return tuple(c for a in self.augmentations for c in a.columns())

    @property
    def names(self) -> tuple[str, ...]:
        return FEATURE_NAMES + self.extra_names

    @property
    def n_features(self) -> int:
        return N_FEATURE + len(self.extra_names)

    @property
    def n_extra(self) -> int:
        return len(self.extra_names)

    @property
    def is_base(self) -> bool:
        return not self.augmentations

    @property
    def max_lag(self) -> int:
        return max((a.max_lag for a in self.augmentations), default=0)

    @property
    def needs_pose(self) -> bool:
        return any(a.needs_pose for a in self.augmentations)

    def with_augmentation(self, aug: Augmentation) -> "FeatureSet":
        return FeatureSet(self.augmentations + (aug,))

    def column_slices(self) -> list[slice]:
        """Column range of each augmentation in the full feature vector."""
        out, start = [], N_FEATURE
        for a in self.augmentations:
            n = len(a.columns())
            out.append(slice(start, start + n))
            start += n
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"format_version": FEATURE_SET_FORMAT_VERSION, "base": BASE_FEATURES,
                "augmentations": [a.to_dict() for a in self.augmentations]}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | None) -> "FeatureSet":
        """Inverse of :meth:`to_dict`; None or {} is the paper's feature set."""
        if not d:
            return cls()
        if not isinstance(d, Mapping):
            raise FeatureSetError("feature_set must be a mapping")
        if d.get("format_version") != FEATURE_SET_FORMAT_VERSION:
            raise FeatureSetError(f"unsupported feature_set format_version "
                                  f"{d.get('format_version')!r} (this build reads "
                                  f"{FEATURE_SET_FORMAT_VERSION})")
        if d.get("base", BASE_FEATURES) != BASE_FEATURES:
            raise FeatureSetError(f"unknown base feature set {d.get('base')!r}")
        augs = d.get("augmentations") or []
        if not isinstance(augs, list):
            raise FeatureSetError("feature_set.augmentations must be a list")
        return cls(tuple(augmentation_from_dict(a) for a in augs))

    def describe(self) -> str:
        if self.is_base:
            return "paper (45 features)"
        return "paper (45) + " + " + ".join(a.label() for a in self.augmentations)

    # -- batch

    def _window_batch(self, S_: np.ndarray, U: np.ndarray, pose: np.ndarray | None
                      ) -> Window:
        """Window over (B, T, .) arrays: lags shifted along time, the first row repeated."""
        return _lag_window(S_, U, pose, self.max_lag)

    def _extra_batch(self, S_: np.ndarray, U: np.ndarray, pose: np.ndarray | None) -> np.ndarray:
        """Extra columns (B, T, n_extra) for moves of equal length, from the first sample on."""
        B, T = S_.shape[:2]
        if not self.augmentations:
            return np.empty((B, T, 0))
        w = self._window_batch(S_, U, pose)
        return np.concatenate([_compute_batch(a, w) for a in self.augmentations], axis=-1)

    def move_arrays(self, rec: MoveRecording) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                         np.ndarray | None]:
        """(S, U, Y, pose) of one recording: S = s_1..s_{N-1} (T, 33), U = u_1..u_{N-1},
        Y = s_2..s_N, pose (T, 3) at s_1..s_{N-1} integrated from the measured pose at
        measurement 1 (None if no augmentation needs it)."""
        s = states_from_recording(rec)
        u = actions_from_recording(rec)
        if s.shape[0] < 2:
            raise ValueError(f"{rec.name}: needs at least 2 steps for one feature/response pair")
        S_, U, Y = s[:-1], u[1:], s[1:]
        pose = None
        if self.needs_pose:
            p0 = initial_pose(rec, 1)
            pose = integrate_pose(S_[None], np.array([[p0.x0, p0.y0, p0.yaw0]]))[0]
        return S_, U, Y, pose

    def extra_features(self, recs: Sequence[MoveRecording]) -> np.ndarray:
        """Extra columns (n, n_extra), rows aligned with ``data.dataset.features_responses``."""
        return self.features_responses(recs)[0][:, N_FEATURE:]

    def features_responses(self, recs: Sequence[MoveRecording]
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """X (n, n_features), Y (n, 33), move_index (n,): ``dataset.features_responses`` with
        this set's extra columns appended (same rows, same order)."""
        if len(recs) == 0:
            raise ValueError("features_responses needs at least one recording")
        arrays = [self.move_arrays(r) for r in recs]
        by_len: dict[int, list[int]] = {}
        for i, (S_, _, _, _) in enumerate(arrays):
            by_len.setdefault(S_.shape[0], []).append(i)
        extra: list[np.ndarray | None] = [None] * len(recs)
        for T, idx in by_len.items():
            S_ = np.stack([arrays[i][0] for i in idx])
            U = np.stack([arrays[i][1] for i in idx])
            pose = np.stack([arrays[i][3] for i in idx]) if self.needs_pose else None
            E = self._extra_batch(S_, U, pose)
            for j, i in enumerate(idx):
                extra[i] = E[j]
        X = np.vstack([np.hstack([S_, U, e]) for (S_, U, _, _), e in zip(arrays, extra)])
        Y = np.vstack([a[2] for a in arrays])
        move_index = np.concatenate([np.full(a[0].shape[0], i, dtype=np.int64)
                                     for i, a in enumerate(arrays)])
        return X, Y, move_index

    # -- online

    def history(self, s0: np.ndarray, pose0: np.ndarray | Sequence[float] | None = None
                ) -> "FeatureHistory":
        """An online feature computer starting at state(s) ``s0`` ((33,) or (B, 33)) and pose(s)
        ``pose0`` ((3,) or (B, 3): x_w, y_w, yaw; needed only if ``needs_pose``)."""
        return FeatureHistory(self, s0, pose0)


def _compute_batch(a: Augmentation, w: Window) -> np.ndarray:
    """Columns (B, T, k) of ``a`` on a batch window over (B, T) samples."""
    if not a.recursive:
        return np.asarray(a.compute(w), dtype=np.float64)
    T = w.s(0).shape[1]
    cols = []
    carry = None
    for t in range(T):
        wt = Window([x[:, t] for x in w._s], [x[:, t] for x in w._u],
                    None if w.pose is None else w.pose[:, t], w.elapsed[:, t])
        if carry is None:
            carry = a.init_carry(wt)
        f, carry = a.advance(carry, wt)
        cols.append(f)
    return np.stack(cols, axis=1)


def batch_columns(recs: Sequence[MoveRecording], augmentations: Sequence[Augmentation]
                  ) -> list[np.ndarray]:
    """The columns (n, k_i) of each augmentation on ``recs`` (rows as ``features_responses``),
    sharing the state extraction: what :meth:`FeatureSet.extra_features` gives for each one
    alone, for many at once (the diagnosis screens a whole library)."""
    fs_all = FeatureSet()
    needs_pose = any(a.needs_pose for a in augmentations)
    max_lag = max((a.max_lag for a in augmentations), default=0)
    arrays = []
    for r in recs:
        S_, U, _, _ = fs_all.move_arrays(r)
        pose = None
        if needs_pose:
            p0 = initial_pose(r, 1)
            pose = integrate_pose(S_[None], np.array([[p0.x0, p0.y0, p0.yaw0]]))[0]
        arrays.append((S_, U, pose))
    by_len: dict[int, list[int]] = {}
    for i, (S_, _, _) in enumerate(arrays):
        by_len.setdefault(S_.shape[0], []).append(i)
    per_aug: list[list[np.ndarray | None]] = [[None] * len(recs) for _ in augmentations]
    for T, idx in by_len.items():
        S_ = np.stack([arrays[i][0] for i in idx])
        U = np.stack([arrays[i][1] for i in idx])
        pose = np.stack([arrays[i][2] for i in idx]) if needs_pose else None
        w = _lag_window(S_, U, pose, max_lag)
        for k, a in enumerate(augmentations):
            E = _compute_batch(a, w)
            for j, i in enumerate(idx):
                per_aug[k][i] = E[j]
    return [np.vstack(cols) for cols in per_aug]


def _lag_window(S_: np.ndarray, U: np.ndarray, pose: np.ndarray | None, max_lag: int) -> Window:
    T = S_.shape[1]
    states, actions = [S_], [U]
    for k in range(1, max_lag + 1):
        idx = np.maximum(np.arange(T) - k, 0)
        states.append(S_[:, idx])
        actions.append(U[:, idx])
    elapsed = np.broadcast_to(np.arange(T, dtype=np.float64) * CONTROL_DT, S_.shape[:2])
    return Window(states, actions, pose, elapsed)


def integrate_pose(states: np.ndarray, pose0: np.ndarray) -> np.ndarray:
    """(x_w, y_w, yaw) at each state of (B, T, 33) ``states`` given the pose (B, 3) at the
    first one: the contract's integration (yaw += dyaw, p += R(roll, pitch, yaw at t-1) d_b),
    summed left to right exactly as :class:`FeatureHistory` does step by step. yaw is not
    wrapped (features use sin/cos of it)."""
    s = np.asarray(states, dtype=np.float64)
    B, T = s.shape[:2]
    pose = np.empty((B, T, 3))
    pose[:, 0] = pose0
    for t in range(1, T):
        pose[:, t] = _pose_step(pose[:, t - 1], s[:, t - 1], s[:, t])
    return pose


def _pose_step(pose: np.ndarray, s_prev: np.ndarray, s_next: np.ndarray) -> np.ndarray:
    """One integration step: pose (B, 3) at s_prev -> pose at s_next (B, 3)."""
    rpy = np.stack([s_prev[:, S.roll], s_prev[:, S.pitch], pose[:, 2]], axis=-1)
    R = rpy_to_matrix(rpy)                                    # (B, 3, 3)
    d = s_next[:, S.d_b]
    dx = R[:, 0, 0] * d[:, 0] + R[:, 0, 1] * d[:, 1] + R[:, 0, 2] * d[:, 2]
    dy = R[:, 1, 0] * d[:, 0] + R[:, 1, 1] * d[:, 1] + R[:, 1, 2] * d[:, 2]
    return np.stack([pose[:, 0] + dx, pose[:, 1] + dy, pose[:, 2] + s_next[:, S.dyaw]], axis=-1)


class FeatureHistory:
    """Online features of a :class:`FeatureSet` for B moves advancing together.

    Per step: ``x = hist.features(u_t)`` gives the (B, n_features) feature rows of the current
    state s_t and the command u_t (remembering u_t), then ``hist.push(s_next)`` advances to
    s_{t+1}. Lagged values come from ring buffers of the last ``max_lag`` states and commands
    (at the first step filled with the first state and command); the pose is integrated from
    ``pose0``; recursive augmentations keep their carry here. A move whose state turned NaN
    keeps producing NaN rows (callers drop them).
    """

    def __init__(self, feature_set: FeatureSet, s0: np.ndarray,
                 pose0: np.ndarray | Sequence[float] | None = None) -> None:
        s0 = np.asarray(s0, dtype=np.float64)
        self.single = s0.ndim == 1
        s0 = np.atleast_2d(s0)
        if s0.ndim != 2 or s0.shape[1] != N_STATE:
            raise ValueError(f"s0 must be ({N_STATE},) or (B, {N_STATE}), got {s0.shape}")
        self.feature_set = feature_set
        self.B = s0.shape[0]
        self.L = feature_set.max_lag
        self._states = [s0.copy() for _ in range(self.L + 1)]   # [s_t, s_{t-1}, ...]
        self._actions: list[np.ndarray] | None = None            # [u_t, u_{t-1}, ...]
        self._pending_u = False
        self.steps = 0
        self.pose = None
        if feature_set.needs_pose:
            if pose0 is None:
                raise ValueError(f"feature set {feature_set.describe()} needs the initial pose "
                                 f"(x_w, y_w, yaw)")
            p = np.asarray(pose0, dtype=np.float64)
            self.pose = np.broadcast_to(p, (self.B, 3)).copy()
        self._carry: dict[int, np.ndarray] = {}          # recursive augmentations' state
        self._pending_carry: dict[int, np.ndarray] = {}  # ... after the current step

    def copy(self) -> "FeatureHistory":
        """An independent copy (to undo a step: keep one, restore it if the step is refused).
        Arrays are never modified in place here, so copying the containers is enough."""
        new = object.__new__(FeatureHistory)
        new.__dict__.update(self.__dict__)
        new._states = list(self._states)
        new._actions = None if self._actions is None else list(self._actions)
        new._carry = dict(self._carry)
        new._pending_carry = dict(self._pending_carry)
        return new

    @property
    def state(self) -> np.ndarray:
        """The current s_t, (B, 33) (or (33,) if started from one state)."""
        return self._states[0][0] if self.single else self._states[0]

    def _window(self) -> Window:
        elapsed = np.full(self.B, self.steps * CONTROL_DT)
        return Window(self._states, self._actions, self.pose, elapsed)

    def features(self, u: np.ndarray) -> np.ndarray:
        """Feature rows (B, n_features) (or (n_features,)) for the current state and command
        ``u`` ((12,) or (B, 12)). Calling it again before ``push`` replaces the command."""
        u = np.asarray(u, dtype=np.float64)
        u2 = np.broadcast_to(np.atleast_2d(u), (self.B, N_ACTION)).copy()
        if self._actions is None:
            self._actions = [u2.copy() for _ in range(self.L + 1)]
        elif self._pending_u:
            self._actions[0] = u2
        else:
            self._actions = [u2] + self._actions[:self.L]
        self._pending_u = True
        fs = self.feature_set
        out = np.empty((self.B, fs.n_features))
        out[:, :N_STATE] = self._states[0]
        out[:, N_STATE:N_FEATURE] = u2
        w = self._window()
        for i, (a, sl) in enumerate(zip(fs.augmentations, fs.column_slices())):
            if not a.recursive:
                out[:, sl] = a.compute(w)
                continue
            carry = self._carry.get(i)
            if carry is None:
                carry = a.init_carry(w)
            out[:, sl], self._pending_carry[i] = a.advance(carry, w)
        return out[0] if self.single else out

    def push(self, s_next: np.ndarray) -> None:
        """Advance to the next state ((33,) or (B, 33)) after ``features`` was called."""
        if not self._pending_u:
            raise RuntimeError("FeatureHistory.push before features(u) for this step")
        s_next = np.asarray(s_next, dtype=np.float64)
        s2 = np.atleast_2d(s_next)
        if s2.shape != (self.B, N_STATE):
            raise ValueError(f"s_next must be ({self.B}, {N_STATE}), got {s_next.shape}")
        if self.pose is not None:
            self.pose = _pose_step(self.pose, self._states[0], s2)
        self._states = [s2.copy()] + self._states[:self.L]
        self._carry.update(self._pending_carry)
        self._pending_carry = {}
        self._pending_u = False
        self.steps += 1
