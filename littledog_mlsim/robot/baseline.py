"""The physics baseline: the pybullet ``nominal`` robot, tuned, scored exactly like the learned sim.

The paper (Section VII) compares its learned simulator with ODE "very carefully tuned to make its
motion look similar to the real LittleDog". Here the real robot is the ``measured`` pybullet robot
(soft torque-mode PD servo, 3.0 kg, rotor inertia, sensor noise) and the physics simulator is the
``nominal`` one (URDF masses, idealised position servo); this module replays TestPool moves on it
and tunes its few free parameters on TrainPool moves.

Alignment with the learned rollout (``rollout.simulate.prepare_test_move``): a recording has
measurements k = 0..N and commands u_0..u_{N-1}; the learned rollout starts from the recorded
s_1, applies u_1..u_{N-1} and predicts s_2..s_N. :func:`physics_rollout` puts the pybullet robot
in the state measured at k = 1 (``InitialState.from_recording(rec, 1)``: measured pose, joint
angles, filtered joint rates, finite-difference body twist), replays u_1..u_{N-1} and extracts
the states with ``states_from_recording`` from the simulated measurements k = 1..N (the first one
being the initial pose itself), so its rows are s_2..s_N, shape (N - 1, 33): the same array
``rollout_metrics(moves, predicted)`` gets from a learned model, integrated from the same pose
``initial_pose(rec, 1)``. Motion-capture noise is switched off in every replay (the baseline
predicts the noise-free state; encoder quantisation and the rate filter stay as configured).

Tuning (:func:`tune_nominal`) sees only the recordings it is given; :func:`tuning_moves` is the
one place that reads them from a dataset, and it asks ``load_moves`` for the ``train`` split
(TrainPool) only. The objective, on the tuning moves::

    J = mean_final_xy / D_ref + rms_q / Q_ref

- mean_final_xy [m]: mean over the moves of the (x, y) error at the end of the rollout (the
  contract's ``final_xy_error_m``);
- rms_q [rad]: RMS over moves, steps and the 12 joints of the joint-angle error;
- D_ref [m]: mean distance the tuning moves travel (|p_N - p_1| in the plane), so the first term
  is the final error as a fraction of the distance walked;
- Q_ref [rad]: RMS of (q_{t+1} - u_t) on the tuning moves, the error of assuming the servo tracks
  perfectly, so the second term below 1 means better joint prediction than that.

A move that turns non-finite scores J = 1e3. The tuned parameters are ``position_gain``,
``velocity_gain`` (pybullet POSITION_CONTROL gains, searched in log space), ``mass_scale`` and
``ground_friction`` (the foot's stays 0.9; Bullet multiplies the two). Bullet's joint motor
(btMultiBodyJointMotor) asks the constraint solver for the joint velocity
``kp (q_des - q) / dt + (1 - kd) v`` within the torque limit, so kp sets a first-order lag of
time constant dt / kp (6.7 ms at the default 0.3) and kd carries (kd < 1) or reverses (kd > 1)
part of the joint's velocity from one physics step to the next; the bounds keep kd below 2,
beyond which that term would grow without bound. The search is a coarse grid (the untuned
nominal first) and then bounded Nelder-Mead from the best grid point, stopping after ``budget``
distinct evaluations in all; every evaluated point is in the report's ``trail``.

Persistence: :func:`save_robot_config` / :func:`load_robot_config` write/read a RobotConfig as
JSON ``{"format": "littledog_mlsim.robot_config", "format_version": 1, "config": {field: value}}``
(tuples as lists), written atomically.
"""
from __future__ import annotations

import dataclasses
import itertools
import json
import math
import os
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..data.dataset import load_moves
from ..data.recording import MoveRecording
from ..data.states import features_responses, states_from_recording
from ..fileio import atomic_write_text, read_document
from ..layout import CONTROL_DT, MOVE_TYPES, S, STATE_NAMES
from .config import RobotConfig, config_from_dict, config_to_dict, robot_config
from .sim import INITIAL_STATES, OBS_FIELDS, InitialState, LittleDogSim
from ..rollout.metrics import nmse_array, rollout_metrics, xy_error
from ..rollout.simulate import prepare_test_moves, predicted_paths

__all__ = [
    "TUNED_PARAMS", "PARAM_BOUNDS", "LOG_PARAMS", "DEFAULT_GRID", "CONFIG_FORMAT",
    "physics_rollout", "physics_rollouts", "one_step_predictions", "k_step_predictions",
    "delayed_recording",
    "tuning_moves", "first_per_type",
    "tuning_objective", "tune_nominal", "evaluate_baseline", "save_robot_config",
    "load_robot_config", "config_to_dict", "config_from_dict",
]

# Tuned free parameters of the nominal robot, their search bounds, and which are searched in
# log space (gains act multiplicatively).
TUNED_PARAMS: tuple[str, ...] = ("position_gain", "velocity_gain", "mass_scale", "ground_friction")
PARAM_BOUNDS: dict[str, tuple[float, float]] = {
    "position_gain": (0.02, 1.0),
    "velocity_gain": (0.1, 1.9),
    "mass_scale": (0.8, 1.3),
    "ground_friction": (0.3, 1.5),
}
LOG_PARAMS: frozenset[str] = frozenset({"position_gain", "velocity_gain"})
# Initial Nelder-Mead simplex steps in search space (log units for the gains).
_SIMPLEX_STEP: dict[str, float] = {"position_gain": 0.5, "velocity_gain": 0.5,
                                   "mass_scale": 0.08, "ground_friction": 0.2}
# Coarse grid: every combination; parameters not named keep the base value.
DEFAULT_GRID: dict[str, tuple[float, ...]] = {
    "position_gain": (0.05, 0.15, 0.3, 0.6),
    "ground_friction": (0.5, 0.9),
    "mass_scale": (1.0, 1.1),
}
DIVERGED_OBJECTIVE = 1e3
CONFIG_FORMAT = "littledog_mlsim.robot_config"
CONFIG_FORMAT_VERSION = 1


# ---------------------------------------------------------------------------------------------
# replay on the pybullet robot

_SIM: LittleDogSim | None = None  # one robot per process, rebuilt when the config changes


def _sim_for(config: RobotConfig) -> LittleDogSim:
    """The process's replay robot for ``config``: its world built again in the same pybullet
    client when the config changes, and stood up only if a move starts at home (a replay
    starts from measured states; ``LittleDogSim(stand_up=False)``)."""
    global _SIM
    if _SIM is None or _SIM.client < 0:
        _SIM = LittleDogSim(config, stand_up=False)
    elif _SIM.config != config:
        _SIM.reconfigure(config, stand_up=False)
    return _SIM


def _replay_config(config: RobotConfig) -> RobotConfig:
    """The robot a replay steps: noise-free, and without its command delay, which
    :func:`delayed_recording` applies to the recorded commands instead (a replay starting
    mid-move must see the commands sent before its start)."""
    return dataclasses.replace(config, sensor_noise=False, command_delay_ms=0.0)


def delayed_recording(rec: MoveRecording, delay_ms: float) -> MoveRecording:
    """``rec`` with the commands as a servo ``delay_ms`` late receives them:
    u'_k = (1 - f) u_{k-n} + f u_{k-n-1} (n whole steps and a fraction f of a 10 ms step; before
    the move, the first command), exactly what ``effects.SetpointDelay`` feeds the servo."""
    if delay_ms <= 0:
        return rec
    steps = delay_ms / (CONTROL_DT * 1e3)
    n, f = int(np.floor(steps)), steps - np.floor(steps)
    k = np.arange(rec.n_steps)
    cmd = np.asarray(rec.cmd, dtype=float)
    out = (1.0 - f) * cmd[np.maximum(k - n, 0)] + f * cmd[np.maximum(k - n - 1, 0)]
    return dataclasses.replace(rec, cmd=out)


#: per recording (by identity) and kind, its starting states by step (:func:`_starts`)
_STARTS: dict[tuple[int, str], tuple[MoveRecording, dict[int, InitialState]]] = {}
_STARTS_KEPT = 512     # recordings whose starting states a process keeps


def _starts(rec: MoveRecording, ts: Sequence[int], kind: str) -> dict[int, InitialState]:
    """``InitialState.at(rec, t, kind)`` for each t of ``ts``, kept for the process's life:
    a calibration re-simulates the same moves from the same states with robot after robot, and
    the states (a local fit of the poses, for ``"smoothed"``) depend on the recording only.
    Their arrays are read-only (a replay only reads its start)."""
    key = (id(rec), kind)
    entry = _STARTS.get(key)
    if entry is None or entry[0] is not rec:
        if len(_STARTS) >= _STARTS_KEPT:
            _STARTS.clear()
        entry = _STARTS[key] = (rec, {})
    got = entry[1]
    for t in ts:
        t = int(t)
        if t not in got:
            state = InitialState.at(rec, t, kind)
            for a in vars(state).values():
                if isinstance(a, np.ndarray):
                    a.setflags(write=False)
            got[t] = state
    return got


def _replay(sim: LittleDogSim, rec: MoveRecording, k: int, n: int,
            effects: Sequence[Any] = (), initial: str = "measured",
            start: InitialState | None = None) -> np.ndarray:
    """States s_{k+1}..s_{k+n} of the robot started in measurement k and fed u_k..u_{k+n-1}
    (with the effect plug-ins ``effects`` switched on, reset at the start); ``initial``: the
    starting state as measured (:meth:`InitialState.from_recording`) or estimated from the
    measurements around k (:meth:`InitialState.smoothed`); ``start``: that state, taken
    already."""
    obs = [sim.reset(initial=InitialState.at(rec, k, initial) if start is None else start,
                     effects=effects)]
    for u in rec.cmd[k:k + n]:
        obs.append(sim.step(u))
    arrays = {f: np.array([o[f] for o in obs], dtype=float) for f in OBS_FIELDS}
    sim_rec = MoveRecording(name=rec.name, move_type=rec.move_type,
                            stamps_ns=rec.stamps_ns[k:k + n + 1], cmd=rec.cmd[k:k + n], **arrays)
    return states_from_recording(sim_rec)


def physics_rollout(rec: MoveRecording, config: RobotConfig,
                    effects: Sequence[Any] = ()) -> np.ndarray:
    """Predicted s_2..s_N (N - 1, 33) of the pybullet robot ``config`` replaying ``rec``.

    Aligned with ``prepare_test_move(rec)`` (module doc): starts in the state measured at k = 1,
    replays the recorded u_1..u_{N-1}. Motion-capture noise is off; the rollout is deterministic.
    ``effects``: plug-ins (``robot.effects``) the physics robot carries, e.g. joint friction.
    """
    if rec.n_steps < 2:
        raise ValueError(f"{rec.name}: a rollout needs at least 2 commands, got {rec.n_steps}")
    return _replay(_sim_for(_replay_config(config)),
                   delayed_recording(rec, config.command_delay_ms), 1, rec.n_steps - 1, effects)


def one_step_predictions(rec: MoveRecording, config: RobotConfig, stride: int = 1,
                         effects: Sequence[Any] = ()) -> tuple[np.ndarray, np.ndarray]:
    """One physics step from each measured state: (Y_true, Y_pred), each (n, 33).

    For t = 1, 1 + stride, ... <= N - 1 (the samples of ``features_responses``): the robot is put
    in the state measured at t, applies u_t, and its s_{t+1} is compared with the recorded one.
    Each sample starts a move in the pybullet world as built (``LittleDogSim.reset``), hence
    ``stride``.
    """
    sim = _sim_for(_replay_config(config))
    s = states_from_recording(rec)              # row j = s_{j+1}
    rec = delayed_recording(rec, config.command_delay_ms)
    ts = np.arange(1, rec.n_steps, stride)
    pred = np.stack([_replay(sim, rec, int(t), 1, effects)[0] for t in ts])
    return s[ts], pred


def k_step_predictions(rec: MoveRecording, config: RobotConfig, horizon: int, stride: int = 1,
                       effects: Sequence[Any] = (), initial: str = "measured"
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``horizon`` physics steps from each measured state: (t, Y_true, Y_pred).

    For t = 1, 1 + stride, ... with t + horizon <= N: the robot is put in the state measured at
    t and fed the recorded u_t..u_{t+horizon-1}; ``Y_pred[i, h]`` is its s_{t+h+1} and
    ``Y_true[i, h]`` the recorded one, each (n, horizon, 33). ``horizon`` 1 gives the samples
    of :func:`one_step_predictions` that leave room for the horizon. ``initial``: the starting
    state as measured (default) or smoothed (:data:`INITIAL_STATES`, :func:`_replay`).
    """
    if initial not in INITIAL_STATES:
        raise ValueError(f"initial state must be one of {', '.join(INITIAL_STATES)}, "
                         f"got {initial!r}")
    if int(horizon) != horizon or horizon < 1:
        raise ValueError(f"horizon must be a positive integer, got {horizon!r}")
    sim = _sim_for(_replay_config(config))
    s = states_from_recording(rec)              # row j = s_{j+1}
    ts = np.arange(1, rec.n_steps - horizon + 1, stride)
    if ts.size == 0:
        raise ValueError(f"{rec.name}: {rec.n_steps} commands leave no {horizon}-step sample")
    starts = _starts(rec, ts, initial)
    rec = delayed_recording(rec, config.command_delay_ms)
    pred = np.stack([_replay(sim, rec, int(t), int(horizon), effects, initial, starts[int(t)])
                     for t in ts])
    true = np.stack([s[t:t + horizon] for t in ts])
    return ts, true, pred


# ----- parallel over moves: worker processes hold the recordings, tasks name them by index

_RECS: Sequence[MoveRecording] = ()


def _init_worker(recs: Sequence[MoveRecording]) -> None:
    global _RECS
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    _RECS = recs


def _rollout_task(config: RobotConfig, effects: Sequence[Any], i: int) -> np.ndarray:
    return physics_rollout(_RECS[i], config, effects)


def _one_step_task(config: RobotConfig, effects: Sequence[Any], stride: int,
                   i: int) -> tuple[np.ndarray, np.ndarray]:
    return one_step_predictions(_RECS[i], config, stride, effects)


class _MovePool:
    """Runs per-move work in ``jobs`` processes (or in this one for jobs == 1), in move order."""

    def __init__(self, recs: Sequence[MoveRecording], jobs: int = 2) -> None:
        self.recs = list(recs)
        self.jobs = max(1, min(int(jobs), len(self.recs)))
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> "_MovePool":
        if self.jobs > 1:
            from ..workers import worker_context
            self._pool = ProcessPoolExecutor(self.jobs, mp_context=worker_context(),
                                             initializer=_init_worker, initargs=(self.recs,))
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def map(self, fn: Callable, *head: Any) -> list:
        idx = range(len(self.recs))
        if self._pool is None:
            _init_worker(self.recs)
            return [fn(*head, i) for i in idx]
        n = len(self.recs)
        return list(self._pool.map(fn, *[[h] * n for h in head], idx))

    def map_many(self, fn: Callable, heads: Sequence[tuple]) -> list[list]:
        """``[self.map(fn, *head) for head in heads]`` as one batch of work: each head's moves
        in :func:`move_chunks` (a worker builds the robot of a head once per chunk, as
        :meth:`map` has each worker do once per head), every chunk of every head queued at
        once, so no worker waits at the end of one head for the other's last move."""
        if self._pool is None:
            return [self.map(fn, *head) for head in heads]
        chunks = move_chunks(len(self.recs), self.jobs)
        futures = [[self._pool.submit(_chunk_task, fn, tuple(head), idx) for idx in chunks]
                   for head in heads]
        try:
            return [[r for f in fs for r in f.result()] for fs in futures]
        except BaseException:            # a failed or interrupted batch leaves nothing queued
            for fs in futures:
                for f in fs:
                    f.cancel()
            raise


def move_chunks(n: int, jobs: int) -> list[list[int]]:
    """Moves 0..n-1 in ``jobs`` contiguous chunks of nearly equal size (none empty)."""
    k = max(1, min(int(jobs), n))
    return [list(range(n * j // k, n * (j + 1) // k)) for j in range(k)]


def _chunk_task(fn: Callable, head: tuple, idx: Sequence[int]) -> list:
    """``fn(*head, i)`` for each move i of ``idx``, in order, in one worker."""
    return [fn(*head, i) for i in idx]


def _remote_task(fn: Callable, recs: Sequence[MoveRecording], *args: Any) -> Any:
    """``fn(*args)`` on a Dask worker, its recordings (scattered once, the same object for each
    task) set up first; a worker's threads take turns (one pybullet client per process)."""
    with _REMOTE_LOCK:
        if _RECS is not recs:
            _init_worker(recs)
        return fn(*args)


_REMOTE_LOCK = threading.Lock()


class _DaskMovePool:
    """:class:`_MovePool` on the workers of the Dask cluster at ``scheduler``: the recordings
    are sent to every worker once; results in move order, the same as in local processes."""

    def __init__(self, recs: Sequence[MoveRecording], scheduler: str) -> None:
        self.recs = list(recs)
        self.scheduler = scheduler
        self.client = None

    def __enter__(self) -> "_DaskMovePool":
        from ..models.parallel import connect_client
        self.client = connect_client(self.scheduler)
        try:
            self.client.wait_for_workers(1, timeout=60)
            # one future for the whole list (scatter sends a list's items one by one)
            self._recs = self.client.scatter([self.recs], broadcast=True, hash=False)[0]
        except Exception:
            self.client.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None

    def map(self, fn: Callable, *head: Any) -> list:
        n = len(self.recs)
        futures = self.client.map(_remote_task, [fn] * n, [self._recs] * n,
                                  *[[h] * n for h in head], list(range(n)), pure=False)
        return self.client.gather(futures)

    def map_many(self, fn: Callable, heads: Sequence[tuple]) -> list[list]:
        """:meth:`_MovePool.map_many` on the cluster: one task per move of each head."""
        if not heads:
            return []
        n = len(self.recs)
        args = [(*head, i) for head in heads for i in range(n)]   # one task per row
        futures = self.client.map(_remote_task, [fn] * len(args), [self._recs] * len(args),
                                  *map(list, zip(*args)), pure=False)
        out = self.client.gather(futures)
        return [out[k * n:(k + 1) * n] for k in range(len(heads))]


def move_pool(recs: Sequence[MoveRecording], jobs: int = 2, scheduler: str | None = None):
    """A pool of per-move work: ``jobs`` local processes, or the Dask cluster at ``scheduler``."""
    return _DaskMovePool(recs, scheduler) if scheduler else _MovePool(recs, jobs)


def physics_rollouts(recs: Sequence[MoveRecording], config: RobotConfig,
                     jobs: int = 2, effects: Sequence[Any] = ()) -> list[np.ndarray]:
    """``physics_rollout`` of each recording, in order, over ``jobs`` processes."""
    with _MovePool(recs, jobs) as pool:
        return pool.map(_rollout_task, config, tuple(effects))


# ---------------------------------------------------------------------------------------------
# tuning


def tuning_moves(data_dir: str | os.PathLike, per_type: int | None = 2,
                 types: Sequence[str] = MOVE_TYPES) -> list[MoveRecording]:
    """TrainPool moves to tune on: the first ``per_type`` TrainPool moves of each type (all: None).

    Reads only the ``train`` split of the dataset (never TestPool).
    """
    return first_per_type(load_moves(data_dir, "train", types=types), per_type)


def first_per_type(recs: Sequence[MoveRecording], per_type: int | None) -> list[MoveRecording]:
    """The first ``per_type`` of ``recs`` of each move type, in order (all: None)."""
    if per_type is None:
        return list(recs)
    taken: dict[str, int] = {}
    out = []
    for r in recs:
        if taken.get(r.move_type, 0) < per_type:
            taken[r.move_type] = taken.get(r.move_type, 0) + 1
            out.append(r)
    return out


def _references(recs: Sequence[MoveRecording]) -> tuple[float, float]:
    """(D_ref [m], Q_ref [rad]) of the objective (module doc)."""
    d = np.mean([np.hypot(*(r.position[-1, :2] - r.position[1, :2])) for r in recs])
    q_err = np.concatenate([(r.q[2:] - r.cmd[1:]).ravel() for r in recs])
    return float(d), float(np.sqrt(np.mean(q_err ** 2)))


def tuning_objective(moves, predicted: Sequence[np.ndarray], d_ref: float,
                     q_ref: float) -> dict[str, float]:
    """J and its parts for predicted states of prepared moves (``TestMove`` list)."""
    paths = predicted_paths(moves, predicted)
    final = np.array([xy_error(p, m.xy)[-1] for m, p in zip(moves, paths)])
    q_sq = np.concatenate([((p[:, S.q] - m.states[:, S.q]) ** 2).ravel()
                           for m, p in zip(moves, predicted)])
    mean_final = float(np.mean(final))
    rms_q = float(np.sqrt(np.mean(q_sq)))
    j = mean_final / d_ref + rms_q / q_ref
    if not np.isfinite(j):
        j = DIVERGED_OBJECTIVE
    return {"objective": float(j), "final_xy_error_m": mean_final, "q_rms_rad": rms_q}


def _to_x(config: RobotConfig, params: Sequence[str]) -> np.ndarray:
    return np.array([math.log(getattr(config, p)) if p in LOG_PARAMS else getattr(config, p)
                     for p in params])


def _from_x(base: RobotConfig, params: Sequence[str], x: np.ndarray) -> RobotConfig:
    values = {}
    for p, v in zip(params, x):
        v = math.exp(v) if p in LOG_PARAMS else float(v)
        lo, hi = PARAM_BOUNDS[p]
        values[p] = float(round(min(max(v, lo), hi), 6))  # 6 digits: stable cache keys and JSON
    return dataclasses.replace(base, **values)


class _BudgetExhausted(Exception):
    pass


def tune_nominal(train_recs: Sequence[MoveRecording], base: RobotConfig | None = None, *,
                 params: Sequence[str] = TUNED_PARAMS,
                 grid: Mapping[str, Sequence[float]] | None = None,
                 budget: int = 40, jobs: int = 2, name: str = "nominal-tuned",
                 progress: Callable[[str], None] | None = None) -> tuple[RobotConfig, dict]:
    """Tune ``params`` of the nominal robot on TrainPool recordings (see the module doc).

    Args:
        train_recs: TrainPool recordings only (e.g. ``tuning_moves(data_dir)``); nothing else
            is read.
        base: starting robot (default ``robot_config("nominal")``); evaluated first.
        params: which of ``TUNED_PARAMS`` to tune (a subset is fine).
        grid: coarse grid {param: values}, every combination (default ``DEFAULT_GRID``
            restricted to ``params``), evaluated in order after the base.
        budget: maximum number of distinct configurations simulated (grid + Nelder-Mead).
        jobs: worker processes (moves are simulated in parallel).
        name: ``name`` of the returned config.
        progress: called with a one-line message after each evaluation.
    Returns:
        (best RobotConfig, report) with the objective's references, the moves used, the base
        and best results and the ``trail`` of every evaluated point in order.
    """
    from scipy.optimize import minimize

    t_start = time.perf_counter()
    base = robot_config("nominal") if base is None else base
    params = tuple(params)
    unknown = [p for p in params if p not in TUNED_PARAMS]
    if unknown or not params:
        raise ValueError(f"params must be a non-empty subset of {TUNED_PARAMS}, got {params}")
    if budget < 1:
        raise ValueError(f"budget must be >= 1, got {budget}")
    if not train_recs:
        raise ValueError("tune_nominal needs at least one TrainPool recording")
    if grid is None:
        grid = {p: v for p, v in DEFAULT_GRID.items() if p in params}
    bad = [p for p in grid if p not in params]
    if bad:
        raise ValueError(f"grid names parameters that are not tuned: {bad}")
    base = _from_x(base, params, _to_x(base, params))   # clip to bounds, round like every point
    moves = prepare_test_moves(train_recs)
    d_ref, q_ref = _references(train_recs)
    trail: list[dict] = []
    cache: dict[tuple, dict] = {}

    with _MovePool(train_recs, jobs) as pool:
        def evaluate(config: RobotConfig, phase: str) -> float:
            key = tuple(getattr(config, p) for p in params)
            if key in cache:
                return cache[key]["objective"]
            if len(cache) >= budget:
                raise _BudgetExhausted
            t0 = time.perf_counter()
            pred = pool.map(_rollout_task, config, ())
            row = {"eval": len(trail) + 1, "phase": phase,
                   **{p: getattr(config, p) for p in params},
                   **tuning_objective(moves, pred, d_ref, q_ref),
                   "wall_s": round(time.perf_counter() - t0, 3)}
            cache[key] = row
            trail.append(row)
            if progress is not None:
                progress(f"[{row['eval']}/{budget}] {phase}: "
                         + " ".join(f"{p}={getattr(config, p):.4g}" for p in params)
                         + f" -> J={row['objective']:.4f} (final xy "
                         f"{row['final_xy_error_m']:.4f} m, q rms {row['q_rms_rad']:.4f} rad)")
            return row["objective"]

        try:
            evaluate(base, "base")
            names = list(grid)
            for combo in itertools.product(*(grid[p] for p in names)):
                evaluate(dataclasses.replace(base, **{p: float(v) for p, v in zip(names, combo)}),
                         "grid")
            best = min(cache.values(), key=lambda r: r["objective"])
            x0 = _to_x(dataclasses.replace(base, **{p: best[p] for p in params}), params)
            simplex = [x0] + [x0 + _SIMPLEX_STEP[p] * np.eye(len(params))[i]
                              for i, p in enumerate(params)]
            bounds = [tuple(math.log(b) if p in LOG_PARAMS else b for b in PARAM_BOUNDS[p])
                      for p in params]
            minimize(lambda x: evaluate(_from_x(base, params, x), "nelder-mead"), x0,
                     method="Nelder-Mead", bounds=bounds,
                     options={"initial_simplex": np.clip(simplex, *np.array(bounds).T),
                              "maxfev": 10 * budget, "xatol": 1e-3, "fatol": 1e-4})
        except _BudgetExhausted:
            pass

    best = min(trail, key=lambda r: r["objective"])
    tuned = dataclasses.replace(base, name=name, **{p: best[p] for p in params})
    report = {
        "objective": "J = mean_final_xy / D_ref + rms_q / Q_ref (littledog_mlsim.robot.baseline)",
        "D_ref_m": d_ref, "Q_ref_rad": q_ref,
        "params": list(params), "bounds": {p: list(PARAM_BOUNDS[p]) for p in params},
        "log_params": sorted(LOG_PARAMS & set(params)),
        "grid": {p: list(v) for p, v in grid.items()},
        "budget": budget, "n_evals": len(trail),
        "moves": [r.name for r in train_recs], "n_moves": len(train_recs),
        "base": trail[0], "best": best,
        "improvement": 1.0 - best["objective"] / trail[0]["objective"],
        "trail": trail, "wall_s": round(time.perf_counter() - t_start, 2), "jobs": jobs,
    }
    return tuned, report


# ---------------------------------------------------------------------------------------------
# scoring


def evaluate_baseline(test_recs: Sequence[MoveRecording], config: RobotConfig, *,
                      one_step: bool = True, one_step_stride: int = 1,
                      jobs: int = 2, effects: Sequence[Any] = ()) -> dict[str, Any]:
    """Score the physics robot ``config`` on TestPool moves like the learned simulator.

    Returns ``rollout_metrics`` of the physics rollouts (the contract's ``final_xy_error_m`` etc.)
    plus ``config`` and, with ``one_step``, ``one_step_nmse`` {state name: nMSE} of one physics
    step from each measured state (every ``one_step_stride``-th sample of ``features_responses``;
    variance: all TestPool responses, as the learned models' one-step nMSE) and ``one_step`` info.
    """
    t0 = time.perf_counter()
    moves = prepare_test_moves(test_recs)
    with _MovePool(test_recs, jobs) as pool:
        predicted = pool.map(_rollout_task, config, tuple(effects))
        t_roll = time.perf_counter() - t0
        out = rollout_metrics(moves, predicted)
        out["config"] = config_to_dict(config)
        out["rollout_wall_s"] = round(t_roll, 2)
        if one_step:
            t1 = time.perf_counter()
            pairs = pool.map(_one_step_task, config, tuple(effects), one_step_stride)
            Y_true = np.concatenate([a for a, _ in pairs])
            Y_pred = np.concatenate([b for _, b in pairs])
            var = features_responses(list(test_recs))[1].var(axis=0)
            values = nmse_array(Y_true, Y_pred, var)
            out["one_step_nmse"] = {n: (float(v) if np.isfinite(v) else None)
                                    for n, v in zip(STATE_NAMES, values)}
            out["one_step"] = {"stride": one_step_stride, "n_samples": int(Y_true.shape[0]),
                               "variance": "all TestPool responses s_{t+1}, t = 1..N-1",
                               "wall_s": round(time.perf_counter() - t1, 2)}
    return out


# ---------------------------------------------------------------------------------------------
# persistence

def save_robot_config(config: RobotConfig, path: str | os.PathLike,
                      extra: Mapping[str, Any] | None = None) -> None:
    """Write ``config`` as JSON (format in the module doc) atomically; ``extra`` adds keys."""
    path = Path(path)
    doc = {"format": CONFIG_FORMAT, "format_version": CONFIG_FORMAT_VERSION,
           "config": config_to_dict(config), **(dict(extra) if extra else {})}
    atomic_write_text(path, json.dumps(doc, indent=2, allow_nan=False) + "\n")


def load_robot_config(path: str | os.PathLike) -> RobotConfig:
    """Read a RobotConfig written by :func:`save_robot_config`; ValueError if it is not one."""
    path = Path(path)
    try:
        doc = read_document(path, CONFIG_FORMAT, CONFIG_FORMAT_VERSION, "a robot config")
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    try:
        return config_from_dict(doc["config"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{path}: {exc}") from None
