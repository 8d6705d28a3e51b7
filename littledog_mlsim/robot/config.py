"""Robot variants for the pybullet LittleDog: the "measured" stand-in and the "nominal" baseline.

Per-joint quantities are given per joint kind as ``(hip_roll, hip_pitch, knee)`` and expanded to
the 12 joints in contract order with :func:`per_joint`. Numbers come from design/LITTLEDOG.md.

``measured`` is the stand-in for the real robot (what the learned simulator is trained on):

- joint servo as on the robot: PD at 500 Hz in torque mode, torque held between updates,
  k = 7.5 / 7.5 / 6.7 N m/rad, b = 0.32 N m s/rad, torque limits 1.7 / 1.7 / 0.61 N m (the knee's
  default 0.6 A). The open-loop trot keeps all 11 move types upright with the default 0.61 N m
  (the knee torque saturates in ~5 % of servo ticks while trotting, a realistic nonlinearity);
  the configurable 1 A (1.0 N m) is available as ``torque_limit`` if a gait needs it. This soft
  servo tracks loosely (knee error ~0.1 rad RMS) and makes sideways/diagonal trots drift in yaw
  (up to ~1 rad in 4 s; the stiff nominal servo does not).
- the guide's mass, 3.0 kg: body with battery 2.24 kg, each leg 0.19 kg (the URDF's leg links
  are scaled by 0.19 / 0.2366; inertias scale with mass, geometry and COMs are unchanged).
- the gearbox's reflected rotor inertia ("armature") as added inertia about the joint axis on the
  child link: ``ROTOR_INERTIA * ratio**2`` with an assumed rotor (plus first gear stage) inertia of
  1.0e-7 kg m^2, ratio 84 (hips; the 0.4 differential is not modelled) and 126 (knee): 7.06e-4 and
  1.59e-3 kg m^2. Without it the 2 ms torque-mode PD is unstable on a swinging leg in pybullet (the
  lower leg's own inertia about the knee is only ~5e-5 kg m^2, so b*dt/I ~ 12). Approximation:
  pybullet has no armature, so this inertia also rotates with the child link's absolute angular
  velocity instead of acting only on the joint rate: the whole robot's inertia about its COM with
  the joints locked in the home pose grows from (0.0051, 0.0178, 0.0192) to (0.0079, 0.0269,
  0.0192) kg m^2 (roll +56 %, pitch +51 %, yaw unchanged). The rotor-only link inertias break the
  rigid-body triangle inequality, which pybullet's forward dynamics accepts but its inverse
  dynamics (calculateMassMatrix, calculateInverseDynamics) reject on the measured robot.
- sensing: encoders quantised (3.65e-5 rad/count hips, 2.43e-5 knee); joint rates are the encoder
  differences at the 500 Hz servo rate, low-passed at 50 Hz (first order) for reporting; the PD
  uses the unfiltered difference. Motion capture at 100 Hz with Gaussian noise of 0.3 mm per axis
  and 1.0 mrad per axis (small body-frame rotation), seeded, switched off by ``sensor_noise``
  (which leaves the deterministic encoder quantisation and rate filter on: they belong to the
  servo loop). Differentiated, this noise gives ~0.04 m/s and ~0.14 rad/s of twist noise.

``nominal`` is the "carefully tuned physics simulator" baseline: the URDF's nominal values
(2.746 kg), no armature, an idealised position servo (pybullet POSITION_CONTROL with explicit
``forces=``), exact joint readings and noise-free pose. Its free parameters (``position_gain``,
``velocity_gain``, ``torque_limit``, ``foot_friction``, ``ground_friction``, ``mass_scale``,
``solver_iterations``) are fields so that they can be tuned.

Both variants report the body twist in base_link as finite differences of the (measured) pose
over the last 10 ms, as the real robot's motion capture would give it.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Mapping

import numpy as np

from ..layout import CONTROL_DT, N_JOINTS

URDF_PATH = Path(__file__).with_name("littledog.urdf")

JointTriple = tuple[float, float, float]  # (hip_roll, hip_pitch, knee)

# URDF nominal masses [kg] (LITTLEDOG.md) and the guide's masses.
URDF_BODY_MASS = 1.800
URDF_LEG_MASS = 0.0623 + 0.1279 + 0.0464  # 0.2366
GUIDE_BODY_MASS = 2.24
GUIDE_LEG_MASS = 0.19

# Reflected rotor inertia: assumed rotor inertia times gear ratio squared.
ROTOR_INERTIA = 1.0e-7  # kg m^2 (assumption, 13-17 mm coreless DC motor class)
GEAR_RATIO: JointTriple = (84.0, 84.0, 126.0)
MEASURED_ARMATURE: JointTriple = tuple(ROTOR_INERTIA * n**2 for n in GEAR_RATIO)  # type: ignore

ENCODER_RESOLUTION: JointTriple = (3.65e-5, 3.65e-5, 2.43e-5)  # rad/count


def per_joint(values: JointTriple | float) -> np.ndarray:
    """Expand a per-joint-kind triple (or a scalar) to the 12 joints in contract order, shape (12,)."""
    v = np.broadcast_to(np.asarray(values, dtype=float), (3,))
    return np.tile(v, N_JOINTS // 3)


@dataclass(frozen=True)
class RobotConfig:
    """Everything that distinguishes one simulated LittleDog from another (hashable, immutable).

    Use ``dataclasses.replace(robot_config("measured"), sensor_noise=False)`` for variants.
    """

    name: str
    servo: Literal["pd_torque", "position"]
    physics_dt: float = 0.002               # s, must divide CONTROL_DT
    # Torque-mode PD servo (servo == "pd_torque"), run every physics step.
    kp: JointTriple = (7.5, 7.5, 6.7)       # N m/rad
    kd: JointTriple = (0.32, 0.32, 0.32)    # N m s/rad
    torque_limit: JointTriple = (1.7, 1.7, 0.61)  # N m, both servos
    # Set-points reach the servo this late (all joints; a fraction of a step interpolates the
    # two neighbouring commands, as effects.SetpointDelay). Both servos.
    command_delay_ms: float = 0.0
    armature: JointTriple = (0.0, 0.0, 0.0)  # kg m^2 added about the joint axis on the child link
    # Idealised position servo (servo == "position"): pybullet's POSITION_CONTROL gains.
    position_gain: float = 0.3
    velocity_gain: float = 1.0
    # Mass model: None keeps the URDF's value; mass_scale multiplies every link afterwards.
    body_mass: float | None = None          # kg
    leg_mass: float | None = None           # kg per leg (links scaled proportionally)
    mass_scale: float = 1.0
    # Contact.
    foot_friction: float = 0.9
    ground_friction: float = 0.9
    solver_iterations: int = 50             # pybullet's cap (the solver may stop earlier)
    # Sensing.
    encoder_resolution: JointTriple | None = None  # rad/count; None = exact angles
    rate_filter_hz: float | None = None     # first-order low-pass of the encoder rate; None = exact
    sensor_noise: bool = False              # motion-capture noise on/off
    mocap_position_std: float = 3.0e-4      # m per axis
    mocap_orientation_std: float = 1.0e-3   # rad per axis (body-frame rotation vector)
    # Standing up before a move.
    settle_time: float = 1.0                # s of holding HOME_POSE before recording starts

    def __post_init__(self) -> None:
        if self.servo not in ("pd_torque", "position"):
            raise ValueError(f"RobotConfig {self.name!r}: servo must be 'pd_torque' or 'position'")
        n = CONTROL_DT / self.physics_dt
        if self.physics_dt <= 0 or abs(n - round(n)) > 1e-9:
            raise ValueError(
                f"RobotConfig {self.name!r}: physics_dt {self.physics_dt} must divide {CONTROL_DT} s")

    @property
    def substeps(self) -> int:
        """Physics steps per 10 ms control step."""
        return int(round(CONTROL_DT / self.physics_dt))


def _measured() -> RobotConfig:
    return RobotConfig(
        name="measured",
        servo="pd_torque",
        armature=MEASURED_ARMATURE,
        body_mass=GUIDE_BODY_MASS,
        leg_mass=GUIDE_LEG_MASS,
        encoder_resolution=ENCODER_RESOLUTION,
        rate_filter_hz=50.0,
        sensor_noise=True,
    )


def _nominal() -> RobotConfig:
    return RobotConfig(name="nominal", servo="position", torque_limit=(1.7, 1.7, 1.0))


_FACTORIES = {"measured": _measured, "nominal": _nominal}
ROBOT_NAMES: tuple[str, ...] = tuple(_FACTORIES)


def robot_config(name: str) -> RobotConfig:
    """The named robot variant: ``"measured"`` or ``"nominal"``."""
    try:
        return _FACTORIES[name]()
    except KeyError:
        raise ValueError(f"unknown robot {name!r}; choose one of {', '.join(ROBOT_NAMES)}") from None


def as_config(robot: str | RobotConfig) -> RobotConfig:
    """Accept a variant name or a ready RobotConfig."""
    return robot if isinstance(robot, RobotConfig) else robot_config(robot)


_TUPLE_FIELDS = {f.name for f in dataclasses.fields(RobotConfig)
                 if "tuple" in str(f.type) or "JointTriple" in str(f.type)}


def config_to_dict(config: RobotConfig) -> dict[str, Any]:
    """A JSON-ready dict of every RobotConfig field (tuples as lists)."""
    return {k: (list(v) if isinstance(v, tuple) else v)
            for k, v in dataclasses.asdict(config).items()}


# fields that must be > 0 when set (every other number must be >= 0)
_POSITIVE_FIELDS = frozenset({"physics_dt", "body_mass", "leg_mass", "mass_scale",
                              "rate_filter_hz", "solver_iterations", "encoder_resolution"})


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _value_problem(field: dataclasses.Field, v: Any) -> str | None:
    """Why ``v`` cannot be the value of RobotConfig ``field`` (one phrase), or None."""
    kind = str(field.type)
    if v is None:
        return None if "None" in kind else "must not be null"
    if kind.startswith("Literal") or kind == "str":
        return None if isinstance(v, str) else "must be a string"
    if kind == "bool":
        return None if isinstance(v, bool) else "must be true or false"
    if "JointTriple" in kind or "tuple" in kind:
        if not (isinstance(v, (list, tuple)) and len(v) == 3 and all(map(_is_number, v))):
            return "must be 3 finite numbers (hip_roll, hip_pitch, knee)"
        values = list(v)
    elif kind == "int":
        if not (_is_number(v) and int(v) == v):
            return "must be an integer"
        values = [v]
    else:
        if not _is_number(v):
            return "must be a finite number"
        values = [v]
    if field.name in _POSITIVE_FIELDS:
        return None if min(values) > 0 else "must be > 0"
    return None if min(values) >= 0 else "must be >= 0"


def config_from_dict(d: Mapping[str, Any]) -> RobotConfig:
    """Inverse of :func:`config_to_dict`; ValueError (one line) naming an unknown or missing
    field or a value of the wrong kind (types follow the field annotations; numbers finite,
    non-negative, and positive where zero makes no robot)."""
    if not isinstance(d, Mapping):
        raise ValueError("a robot configuration must be a mapping of RobotConfig fields")
    fields = {f.name: f for f in dataclasses.fields(RobotConfig)}
    unknown = sorted(set(d) - set(fields))
    if unknown:
        raise ValueError(f"unknown RobotConfig field(s): {unknown}")
    missing = sorted(f.name for f in fields.values()
                     if f.name not in d and f.default is dataclasses.MISSING)
    if missing:
        raise ValueError(f"RobotConfig field(s) missing: {missing}")
    for k, v in d.items():
        problem = _value_problem(fields[k], v)
        if problem:
            raise ValueError(f"RobotConfig field {k!r} {problem}, got {v!r}")
    return RobotConfig(**{k: (tuple(float(x) for x in v)
                              if isinstance(v, (list, tuple)) and k in _TUPLE_FIELDS else v)
                          for k, v in d.items()})


__all__ = [
    "RobotConfig", "robot_config", "as_config", "per_joint", "ROBOT_NAMES", "URDF_PATH",
    "MEASURED_ARMATURE", "ENCODER_RESOLUTION", "config_to_dict", "config_from_dict",
]
