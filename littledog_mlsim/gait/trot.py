"""Open-loop trot: foot trajectories in the body frame, turned into joint commands by the IK.

Diagonal pairs (front_left + back_right, front_right + back_left) alternate with duty factor 0.5.
For a commanded body velocity v = (vx, vy) [m/s] in base_link and yaw rate w [rad/s], a foot in
stance moves through the body frame exactly as a ground-fixed point would (dp/dt = -v - w x p),
along the arc about the instantaneous centre of rotation whose midpoint is the home foot position;
so it touches down half a stance stride (v Ts / 2, w Ts / 2; Ts = duty * period) ahead of home:
Raibert's neutral point, the open-loop form of his foot placement rule. In swing the foot returns along a
cycloid (zero velocity at lift-off and touchdown) and lifts by h (1 - cos 2 pi s) / 2, s in [0, 1].
All of v, w and h ramp in smoothly (smoothstep over ``ramp_time``) from the home pose.

Command k (k = 0..n_steps-1) is the pose at the end of its step, t = (k + 1) * dt.

Move types (layout.MOVE_TYPES): F/B forward/backward, FL/BL with yaw increasing (turning left),
FR/BR yaw decreasing, L/R sideways, DL/DR diagonally forward at 45 degrees, S trotting in place.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layout import CONTROL_DT, HOME_POSE, JOINT_LOWER, JOINT_UPPER, MOVE_TYPES, STEPS_PER_MOVE
from .ik import forward_kinematics, inverse_kinematics

# Diagonal pairs in LEGS order (front_left, front_right, back_left, back_right).
LEG_PHASE_OFFSET = np.array([0.0, 0.5, 0.5, 0.0])

# Per move type: unit direction of the body velocity in base_link and the sign of the yaw rate.
MOVE_DIRECTION: dict[str, tuple[float, float, float]] = {
    "F": (1.0, 0.0, 0.0), "FL": (1.0, 0.0, 1.0), "FR": (1.0, 0.0, -1.0),
    "B": (-1.0, 0.0, 0.0), "BL": (-1.0, 0.0, 1.0), "BR": (-1.0, 0.0, -1.0),
    "L": (0.0, 1.0, 0.0), "R": (0.0, -1.0, 0.0),
    "DL": (np.sqrt(0.5), np.sqrt(0.5), 0.0), "DR": (np.sqrt(0.5), -np.sqrt(0.5), 0.0),
    "S": (0.0, 0.0, 0.0),
}


@dataclass(frozen=True)
class TrotRanges:
    """Uniform sampling ranges of :func:`sample_trot_params` (SI units)."""

    period: tuple[float, float] = (0.30, 0.40)            # s
    step_height: tuple[float, float] = (0.020, 0.030)     # m
    speed_forward: tuple[float, float] = (0.08, 0.16)     # m/s, F B FL FR BL BR
    speed_sideways: tuple[float, float] = (0.05, 0.10)    # m/s, L R
    speed_diagonal: tuple[float, float] = (0.07, 0.13)    # m/s, DL DR
    yaw_rate_turn: tuple[float, float] = (0.30, 0.60)     # rad/s, |w| of FL FR BL BR
    yaw_rate_jitter: float = 0.05                          # rad/s, |w| <= this for F B L R DL DR
    ramp_time: tuple[float, float] = (0.30, 0.50)         # s


DEFAULT_RANGES = TrotRanges()


@dataclass(frozen=True)
class TrotParams:
    """One open-loop trot (all that :func:`trot_commands` needs)."""

    move_type: str
    velocity: tuple[float, float]   # commanded body velocity (vx, vy) in base_link [m/s]
    yaw_rate: float                 # commanded yaw rate [rad/s]
    period: float                   # gait cycle [s]
    step_height: float              # swing foot lift [m]
    duty: float = 0.5               # stance fraction of the cycle
    ramp_time: float = 0.4          # s to ramp v, w, h in from zero
    phase: float = 0.0              # gait phase at t = 0 [cycles]; 0.5 swaps which pair steps first
    n_steps: int = STEPS_PER_MOVE   # commands
    dt: float = CONTROL_DT          # s between commands

    def __post_init__(self) -> None:
        if self.move_type not in MOVE_TYPES:
            raise ValueError(f"unknown move type {self.move_type!r}")
        if not (0.0 < self.duty < 1.0) or self.period <= 0 or self.n_steps < 1 or self.dt <= 0:
            raise ValueError(f"bad trot timing: period={self.period}, duty={self.duty}, "
                             f"n_steps={self.n_steps}, dt={self.dt}")
        if self.step_height < 0 or self.ramp_time < 0:
            raise ValueError("step_height and ramp_time must not be negative")


def sample_trot_params(move_type: str, rng: np.random.Generator,
                       ranges: TrotRanges = DEFAULT_RANGES) -> TrotParams:
    """Random trot parameters for one move of the given type."""
    if move_type not in MOVE_DIRECTION:
        raise ValueError(f"unknown move type {move_type!r}; expected one of {' '.join(MOVE_TYPES)}")
    dx, dy, yaw_sign = MOVE_DIRECTION[move_type]
    period = rng.uniform(*ranges.period)
    step_height = rng.uniform(*ranges.step_height)
    ramp = rng.uniform(*ranges.ramp_time)
    if move_type == "S":
        speed, yaw = 0.0, 0.0
    elif move_type in ("L", "R"):
        speed = rng.uniform(*ranges.speed_sideways)
        yaw = rng.uniform(-ranges.yaw_rate_jitter, ranges.yaw_rate_jitter)
    elif move_type in ("DL", "DR"):
        speed = rng.uniform(*ranges.speed_diagonal)
        yaw = rng.uniform(-ranges.yaw_rate_jitter, ranges.yaw_rate_jitter)
    else:
        speed = rng.uniform(*ranges.speed_forward)
        yaw = (yaw_sign * rng.uniform(*ranges.yaw_rate_turn) if yaw_sign
               else rng.uniform(-ranges.yaw_rate_jitter, ranges.yaw_rate_jitter))
    # Which diagonal pair steps first: the soft-servo robot's sideways trot yaws in a direction
    # set by this choice, so both are sampled to keep the data set free of that bias.
    phase = 0.5 * float(rng.integers(2))
    return TrotParams(move_type=move_type, velocity=(speed * dx, speed * dy), yaw_rate=float(yaw),
                      period=float(period), step_height=float(step_height), ramp_time=float(ramp),
                      phase=phase)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def foot_trajectories(params: TrotParams) -> np.ndarray:
    """Desired foot centres in the body frame at t = (k+1) dt, shape (n_steps, 4, 3)."""
    t = params.dt * np.arange(1, params.n_steps + 1)                      # (n,)
    ramp = _smoothstep(t / params.ramp_time) if params.ramp_time > 0 else np.ones_like(t)
    phase = np.mod(t[:, None] / params.period + params.phase + LEG_PHASE_OFFSET, 1.0)  # (n, 4)
    stance = phase < params.duty
    sigma_st = phase / params.duty
    sigma_sw = (phase - params.duty) / (1.0 - params.duty)
    cycloid = sigma_sw - np.sin(2 * np.pi * sigma_sw) / (2 * np.pi)
    # Position along the stride, +1/2 = touchdown (front), -1/2 = lift-off (rear).
    frac = np.where(stance, 0.5 - sigma_st, cycloid - 0.5)              # (n, 4)
    lift = np.where(stance, 0.0, 0.5 * (1.0 - np.cos(2 * np.pi * sigma_sw)))
    t_stance = params.duty * params.period
    home = forward_kinematics(HOME_POSE)                                   # (4, 3)
    # A ground-fixed point seen from a body moving with constant (v, w) turns about the
    # instantaneous centre c = (-vy, vx) / w: p = c + Rz(a) (p_home - c), a = w Ts frac.
    # Rz(a) p_home + (I - Rz(a)) c, written with sin(a)/a and (1 - cos a)/a so that w -> 0 is exact.
    vx = ramp[:, None] * params.velocity[0]
    vy = ramp[:, None] * params.velocity[1]
    a = (ramp * params.yaw_rate * t_stance)[:, None] * frac                # (n, 4)
    s1 = np.sinc(a / np.pi)                                                # sin(a) / a
    s2 = 0.5 * a * np.sinc(a / (2 * np.pi)) ** 2                           # (1 - cos a) / a
    ca, sa = np.cos(a), np.sin(a)
    arc = t_stance * frac
    feet = np.empty((params.n_steps, 4, 3))
    feet[..., 0] = ca * home[:, 0] - sa * home[:, 1] + arc * (vx * s1 - vy * s2)
    feet[..., 1] = sa * home[:, 0] + ca * home[:, 1] + arc * (vy * s1 + vx * s2)
    feet[..., 2] = home[:, 2] + (ramp * params.step_height)[:, None] * lift
    return feet


def trot_commands(params: TrotParams) -> np.ndarray:
    """Joint commands (n_steps, 12), contract order, inside the joint limits."""
    return inverse_kinematics(foot_trajectories(params), clip=True)


def excite_commands(commands: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Commands plus independent N(0, sigma^2) noise per joint and step [rad], kept in the limits.

    Persistent excitation for system identification: on a smooth open-loop trot the command at
    step t is almost a function of the state it produced, so effects that act through the command
    (a delay, say) barely show in one-step residuals; white noise on the command makes them
    identifiable. ``sigma = 0`` returns the commands unchanged and draws nothing from ``rng``.
    """
    if not np.isfinite(sigma) or sigma < 0:
        raise ValueError(f"command excitation must be a finite non-negative angle [rad], got {sigma!r}")
    if sigma == 0:
        return commands
    noisy = commands + rng.normal(0.0, sigma, size=commands.shape)
    return np.clip(noisy, JOINT_LOWER, JOINT_UPPER)
