"""A push fixed in odom, in newtons, without a twin of the robot (decision 025).

A robot standing or walking on its feet does not accelerate under a steady push: its feet hold
it, and it drifts. The learned route's heading feature carries the push's effect per step, but
the body's one-step acceleration is not the push over the mass (the feet take most of it), so a
force cannot be read off it. What the recordings do measure is the drift: how far each move ends
from where the same move type ends in a reference recording of the robot without the change
(:func:`drift_against_reference`). A push of F newtons makes a robot drift by M F, where M is
its push response, (m/s) per newton in odom (:func:`push_mobility`). M is a property of the
robot's servos, feet and gait that the recordings do not hold; it is measured on a physics
robot (``nominal``, the URDF-level LittleDog) walking the recordings' own commands from their
measured start states, with and without a probe push along x and along y. The force is then
M^-1 v (:func:`push_reading`), with an interval from the drift's scatter over moves only: the
nominal robot's response differs from the recorded robot's by an unknown amount, which the
interval does not hold and the report says.

The simulator is injected (:class:`PushSimulator`); :class:`PybulletPushes` is the physics one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Protocol, Sequence

import numpy as np

from ..layout import CONTROL_DT
from ..rotations import quat_to_rpy

__all__ = ["Drift", "PushSimulator", "PybulletPushes", "drift_against_reference",
           "first_per_type", "push_mobility", "push_reading", "PROBE_N",
           "MOBILITY_MOVES_PER_TYPE", "MIN_MOVES"]

#: the probe push [N] whose drift measures the physics robot's response
PROBE_N = 1.0
#: moves per type the physics robot walks to measure its response (three runs each)
MOBILITY_MOVES_PER_TYPE = 2
#: moves of the data with a reference move of their type below which no drift is measured
MIN_MOVES = 8


def _start_and_displacement(rec: Any) -> tuple[float, np.ndarray, float]:
    """(start heading [rad], displacement (x, y) in odom over the move [m], duration [s])."""
    P = np.asarray(rec.position, dtype=np.float64)
    yaw0 = float(quat_to_rpy(np.asarray(rec.orientation[0], dtype=np.float64))[2])
    return yaw0, P[-1, :2] - P[0, :2], (P.shape[0] - 1) * CONTROL_DT


def _rot(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True)
class Drift:
    """The data's mean drift against the reference in odom [m/s]: ``velocity_xy`` with its
    covariance ``cov`` (over moves, the reference's type means included), ``n_moves`` of the
    data used and ``n_skipped`` (a type the reference lacks, or a move too short)."""

    velocity_xy: np.ndarray
    cov: np.ndarray
    n_moves: int
    n_skipped: int

    @property
    def p_value(self) -> float:
        """Of no drift: v' cov^-1 v against chi-squared with 2 degrees of freedom."""
        v = self.velocity_xy
        try:
            q = float(v @ np.linalg.solve(self.cov, v))
        except np.linalg.LinAlgError:
            return float("nan")
        return float(math.exp(-0.5 * q))       # the chi-squared(2) survival function

    def to_dict(self) -> dict[str, Any]:
        v = self.velocity_xy
        return {"velocity_xy_mps": [float(v[0]), float(v[1])], "p_value": self.p_value,
                "speed_mps": float(math.hypot(*v)),
                "direction_deg": float(math.degrees(math.atan2(v[1], v[0])) % 360.0),
                "se_xy_mps": [float(math.sqrt(self.cov[0, 0])), float(math.sqrt(self.cov[1, 1]))],
                "n_moves": self.n_moves, "n_skipped": self.n_skipped}


def drift_against_reference(recs: Sequence[Any], reference: Sequence[Any]) -> Drift | None:
    """How far the moves of ``recs`` end from where the reference's moves of the same type end,
    per second, in odom.

    Each reference move's displacement is taken in its start frame (turned by minus its start
    heading) and averaged per type; a data move's drift is its displacement minus that mean
    turned to its own start heading, over its duration. A drift the same in every start frame
    (a gait change) cancels between types that walk opposite ways; one fixed in odom does not.
    None with fewer than :data:`MIN_MOVES` data moves whose type the reference has."""
    ref: dict[str, list[np.ndarray]] = {}
    for r in reference:
        yaw0, d, T = _start_and_displacement(r)
        if T > 0 and np.all(np.isfinite(d)):
            ref.setdefault(r.move_type, []).append(_rot(-yaw0) @ d / T)
    per_type = {t: np.array(v) for t, v in ref.items() if len(v) >= 2}
    rows, ref_cov, skipped = [], [], 0
    for r in recs:
        yaw0, d, T = _start_and_displacement(r)
        V = per_type.get(r.move_type)
        if V is None or T <= 0 or not np.all(np.isfinite(d)):
            skipped += 1
            continue
        R = _rot(yaw0)
        rows.append(d / T - R @ V.mean(axis=0))
        ref_cov.append(R @ np.cov(V.T) @ R.T / V.shape[0])
    if len(rows) < MIN_MOVES:
        return None
    E = np.array(rows)
    n = E.shape[0]
    # the data's scatter over its moves, plus the type means' own (shared by a type's moves)
    cov = np.cov(E.T) / n + np.mean(ref_cov, axis=0)
    return Drift(E.mean(axis=0), cov, n, skipped)


class PushSimulator(Protocol):
    """Walks a recorded move's commands from its measured start, with a push fixed in odom
    (``force_xy`` [N], or none), and returns the displacement (x, y) in odom [m]."""

    def displacement(self, rec: Any, force_xy: tuple[float, float] | None) -> np.ndarray: ...


class PybulletPushes:
    """:class:`PushSimulator` on the pybullet robot ``robot`` (a name, a twin file or a
    RobotConfig), without sensor noise."""

    def __init__(self, robot: Any = "nominal") -> None:
        from dataclasses import replace

        from ..robot.twin import robot_config_from
        self.config = replace(robot_config_from(robot), sensor_noise=False)

    def displacement(self, rec: Any, force_xy: tuple[float, float] | None) -> np.ndarray:
        from ..robot.effects import ConstantWind
        from ..robot.sim import InitialState, simulate_move
        effects = [] if force_xy is None else [ConstantWind(list(force_xy))]
        out = simulate_move(np.asarray(rec.cmd, dtype=np.float64), robot=self.config,
                            effects=effects, seed=0, name=rec.name, move_type=rec.move_type,
                            initial=InitialState.at(rec, 0))
        P = np.asarray(out.position, dtype=np.float64)
        return P[-1, :2] - P[0, :2]


def first_per_type(recs: Sequence[Any], per_type: int) -> list[Any]:
    """The first ``per_type`` moves of each move type of ``recs``, types in order of first
    appearance (the moves :func:`push_mobility` walks)."""
    chosen: dict[str, list[Any]] = {}
    for r in recs:
        if len(chosen.setdefault(r.move_type, [])) < per_type:
            chosen[r.move_type].append(r)
    return [r for rs in chosen.values() for r in rs]


def push_mobility(recs: Sequence[Any], sim: PushSimulator,
                  per_type: int = MOBILITY_MOVES_PER_TYPE, probe_N: float = PROBE_N
                  ) -> tuple[np.ndarray, int]:
    """(M, n_moves): the simulated robot's drift per newton of a push fixed in odom, (2, 2) in
    (m/s)/N, column k for a push along odom axis k, over the first ``per_type`` moves of each
    type of ``recs`` (each walked three times: no push, ``probe_N`` along x, along y)."""
    moves = first_per_type(recs, per_type)
    if not moves:
        raise ValueError("push_mobility: no moves to walk")
    cols = np.zeros((2, 2))
    for r in moves:
        T = (np.asarray(r.position).shape[0] - 1) * CONTROL_DT
        base = sim.displacement(r, None)
        for k, f in enumerate(((probe_N, 0.0), (0.0, probe_N))):
            cols[:, k] += (sim.displacement(r, f) - base) / (T * probe_N)
    return cols / len(moves), len(moves)


def push_reading(drift: Drift, mobility: np.ndarray, *, level: float = 0.95, draws: int = 4000,
                 seed: int = 0) -> dict[str, Any] | None:
    """The push M^-1 v that makes the drift, in odom: {force_N, direction_deg, force_xy_N,
    force_interval_N (``level``, from the drift's covariance only), mobility_mps_per_N};
    None where M is singular (a robot that does not drift under a push)."""
    M = np.asarray(mobility, dtype=np.float64)
    if not np.all(np.isfinite(M)) or abs(np.linalg.det(M)) < 1e-12 or np.linalg.cond(M) > 1e3:
        return None
    Minv = np.linalg.inv(M)
    F = Minv @ drift.velocity_xy
    cov = Minv @ drift.cov @ Minv.T
    rng = np.random.default_rng(seed)
    mags = np.hypot(*rng.multivariate_normal(F, cov, size=draws).T)
    lo, hi = np.quantile(mags, [(1 - level) / 2, (1 + level) / 2])
    return {"force_N": float(math.hypot(*F)),
            "direction_deg": float(math.degrees(math.atan2(F[1], F[0])) % 360.0),
            "force_xy_N": [float(F[0]), float(F[1])],
            "force_interval_N": [float(lo), float(hi)], "interval_level": level,
            "mobility_mps_per_N": [[float(x) for x in row] for row in M]}


def describe(reading: Mapping[str, Any], drift: Drift, robot_name: str) -> str:
    """One sentence for the report."""
    d = drift.to_dict()
    lo, hi = reading["force_interval_N"]
    return (f"a steady force fixed in odom of about {reading['force_N']:.2f} N toward "
            f"{reading['direction_deg']:.0f} deg "
            f"({100 * reading['interval_level']:.0f} % from the drift's scatter: {lo:.2f}-"
            f"{hi:.2f} N): the robot drifts {100 * d['speed_mps']:.1f} cm/s toward "
            f"{d['direction_deg']:.0f} deg against the reference ({d['n_moves']} moves), and the "
            f"'{robot_name}' robot walking the same commands drifts "
            f"{100 * reading['mobility_mps_per_N'][0][0]:.1f} cm/s per newton along x and "
            f"{100 * reading['mobility_mps_per_N'][1][1]:.1f} along y; this robot's own response "
            f"to a push is not measured, so the size is as good as the '{robot_name}' robot's"
            + (f"; the drift itself is not significant (p = {d['p_value']:.2g}): these "
               f"recordings do not size the push" if d["p_value"] > 0.05 else ""))
