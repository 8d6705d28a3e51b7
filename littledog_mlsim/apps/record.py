"""Record a dataset: trot every move type on the pybullet LittleDog and write one bag per move.

Besides the paper's constant trots (``moves_per_type`` of each type, split 14 : 6 into TrainPool
and TestPool at 20), ``extra`` adds TrainPool moves of other kinds (``control.moves``): more
constant trots, trots with a transition, continuously varied trots (each so many per move type,
named after the plain moves of their type), and closed-loop runs of the velocity tracker and the
waypoint follower (so many in all, move type ``U``). The TestPool keeps the plain trots only, so
the paper's TestPool error stays comparable across datasets of one seed.

The dataset is built in a temporary sibling directory and renamed into place only when every bag
and ``dataset.yaml`` are written, so a failed or interrupted run leaves no partial bag behind and
never touches an existing dataset (which is only replaced when ``overwrite`` is set).
Moves run in parallel across processes (one pybullet world per process).
"""
from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np
from tqdm import tqdm

from .. import __version__
from ..fileio import atomic_directory
from ..control.moves import CLOSED_LOOP_KINDS, MOVE_KINDS
from ..data.recording import MoveRecording
from ..layout import (CONTROL_DT, CONTROL_DT_NS, DATASET_MOVE_TYPES, MOVE_TYPES, STEPS_PER_MOVE,
                      UNKNOWN_MOVE_TYPE, bag_name)

if TYPE_CHECKING:
    from ..robot.config import RobotConfig


@dataclass(frozen=True)
class MoveJob:
    """One move to record; seeds derive from (dataset seed, move type, seed index, kind) only
    (a constant trot's from the first three, as before kinds existed). An extra move's seed
    index is the one it would have if its kind were the only extra one (the plain moves'
    count plus its number within its kind; a closed-loop run's number within its kind), so
    the moves of one kind do not change with the count of another."""

    move_type: str
    index: int
    seed: int
    kind: str = "trot"
    seed_index: int | None = None   # the index its seeds use (default: ``index``)

    @property
    def name(self) -> str:
        return bag_name(self.move_type, self.index)

    def seeds(self) -> tuple[int, int]:
        """(gait seed, robot/sensor seed), independent streams for this move."""
        index = self.index if self.seed_index is None else self.seed_index
        key = [self.seed, DATASET_MOVE_TYPES.index(self.move_type), index]
        if self.kind != "trot":
            key.append(1 + MOVE_KINDS.index(self.kind))
        ss = np.random.SeedSequence(key)
        gait_ss, robot_ss = ss.spawn(2)
        return int(gait_ss.generate_state(1)[0]), int(robot_ss.generate_state(1)[0])


@dataclass
class RecordSummary:
    out: Path
    n_bags: int
    n_steps: int
    wall_s: float
    cpu_s: float                     # summed per-move CPU time (simulation + bag writing) in the workers
    jobs: int
    per_type: dict[str, int] = field(default_factory=dict)

    @property
    def realtime_factor_per_core(self) -> float:
        """Robot time per CPU second spent on moves (excludes process start-up)."""
        return self.n_steps * 0.01 / self.cpu_s if self.cpu_s > 0 else float("inf")


#: the largest ``start_spread`` [m] that ``record`` takes
MAX_START_SPREAD_M = 5.0
#: the longest warm-up [s] that ``record`` takes
MAX_WARMUP_S = 60.0


class StartSpread:
    """A recording protocol, not an effect: at reset, carry the settled standing robot (at rest)
    by a uniform offset of up to ``half_span_m`` in x and y and turn it by a uniform yaw in
    [-pi, pi), drawn from ``seed`` alone (the effects' and the sensors' streams are unchanged).
    Each move then starts from its own place and heading, so that where the robot is on the
    floor, and which way it faces, no longer follow from the move's type and elapsed time."""

    changes_world = False     # it moves the robot only (LittleDogSim.reset)

    def __init__(self, half_span_m: float, seed: int) -> None:
        self.half_span_m = float(half_span_m)
        self.rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5E7A]))

    def reset(self, sim: Any) -> None:
        import pybullet as p
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        dx, dy = self.rng.uniform(-self.half_span_m, self.half_span_m, size=2)
        yaw = float(self.rng.uniform(-np.pi, np.pi))
        turn = p.getQuaternionFromEuler([0.0, 0.0, yaw])
        # turn about the world's vertical axis through the body's position (roll and pitch
        # kept), then shift
        orn_new = p.multiplyTransforms([0, 0, 0], turn, [0, 0, 0], orn)[1]
        p.resetBasePositionAndOrientation(sim.robot, [pos[0] + dx, pos[1] + dy, pos[2]],
                                          orn_new, physicsClientId=c)
        p.resetBaseVelocity(sim.robot, [0, 0, 0], [0, 0, 0], physicsClientId=c)


def after_warmup(rec: MoveRecording, k: int) -> MoveRecording:
    """The recording ``rec`` from its measurement ``k`` on, its stamps from zero (``k`` = 0:
    ``rec`` itself)."""
    if k == 0:
        return rec
    fields = ("q", "dq", "position", "orientation", "linear_velocity", "angular_velocity")
    return replace(rec, stamps_ns=rec.stamps_ns[k:] - rec.stamps_ns[k], cmd=rec.cmd[k:],
                   **{f: getattr(rec, f)[k:] for f in fields})


def check_warmup(warmup_s: float) -> float:
    """``warmup_s`` [s] as a float; ValueError (one line) outside [0, MAX_WARMUP_S] or not a
    whole number of control steps."""
    v = float(warmup_s)
    if not np.isfinite(v) or not 0.0 <= v <= MAX_WARMUP_S:
        raise ValueError(f"--warmup must be between 0 and {MAX_WARMUP_S:g} s, got {warmup_s}")
    if abs(v / CONTROL_DT - round(v / CONTROL_DT)) > 1e-6:
        raise ValueError(f"--warmup must be a whole number of {CONTROL_DT * 1e3:g} ms steps, got "
                         f"{warmup_s}")
    return v


def check_start_spread(start_spread: float) -> float:
    """``start_spread`` [m] as a float; ValueError (one line) outside [0, MAX_START_SPREAD_M]."""
    v = float(start_spread)
    if not np.isfinite(v) or not 0.0 <= v <= MAX_START_SPREAD_M:
        raise ValueError(f"--start-spread must be between 0 and {MAX_START_SPREAD_M:g} m, got "
                         f"{start_spread}")
    return v


def _record_one(job: MoveJob, bag_path: str, robot: "RobotConfig", effects_file: str | None,
                storage: str, excitation: float = 0.0, start_spread: float = 0.0,
                warmup_s: float = 0.0) -> tuple[str, int, float]:
    """Worker: simulate one move (after ``warmup_s`` of the same move, cut off) and write its
    bag. Returns (name, n_steps, CPU seconds)."""
    from ..control.moves import closed_loop_policy, open_loop_commands
    from ..data.bags import write_bag
    from ..gait.trot import excite_commands
    from ..robot.effects import load_effects
    from ..robot.sim import simulate_closed_loop, simulate_move

    t0 = time.process_time()
    gait_seed, robot_seed = job.seeds()
    gait_rng = np.random.default_rng(gait_seed)
    effects = list(load_effects(effects_file)) if effects_file else []
    if start_spread:           # first: the effects' reset hooks see the robot where it starts
        effects.insert(0, StartSpread(start_spread, robot_seed))
    warm = int(round(warmup_s / CONTROL_DT))
    n_steps = warm + STEPS_PER_MOVE
    if job.kind in CLOSED_LOOP_KINDS:
        policy = closed_loop_policy(job.kind, gait_rng, n_steps=n_steps)

        def excited(obs):
            return excite_commands(policy(obs)[None], excitation, gait_rng)[0]

        rec = simulate_closed_loop(excited, n_steps, robot=robot, effects=effects,
                                   seed=robot_seed, name=job.name, move_type=job.move_type)
    else:
        commands = open_loop_commands(job.kind, job.move_type, gait_rng, excitation,
                                      n_steps=n_steps)
        rec = simulate_move(commands, robot=robot, effects=effects, seed=robot_seed,
                            name=job.name, move_type=job.move_type)
    write_bag(bag_path, after_warmup(rec, warm), storage=storage)
    return job.name, rec.n_steps, time.process_time() - t0


def check_extra(extra: Mapping[str, int] | None) -> dict[str, int]:
    """``extra`` as {kind: count}, in MOVE_KINDS order; ValueError (one line) on an unknown kind
    or a count that is not a non-negative integer."""
    out: dict[str, int] = {}
    for kind, n in (extra or {}).items():
        if kind not in MOVE_KINDS:
            raise ValueError(f"unknown extra move kind {kind!r}; expected one of "
                             f"{' '.join(MOVE_KINDS)}")
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"extra {kind} moves must be a non-negative integer, got {n!r}")
    for kind in MOVE_KINDS:
        if (extra or {}).get(kind):
            out[kind] = int(extra[kind])
    return out


def plan_jobs(moves_per_type: int, types: Sequence[str], seed: int,
              extra: Mapping[str, int] | None = None) -> list[MoveJob]:
    """The plain trots (type-major), then the extra moves: per move type for the open-loop
    kinds (indices after the plain moves, kind by kind), in all for the closed-loop kinds (type
    U, numbered from 0 across kinds)."""
    for t in types:
        if t not in MOVE_TYPES:
            raise ValueError(f"unknown move type {t!r}; expected some of {' '.join(MOVE_TYPES)}")
    if moves_per_type < 1:
        raise ValueError(f"--moves-per-type must be at least 1, got {moves_per_type}")
    jobs = [MoveJob(t, i, seed) for t in types for i in range(moves_per_type)]
    extra = check_extra(extra)
    for t in types:
        i = moves_per_type
        for kind, n in extra.items():
            if kind not in CLOSED_LOOP_KINDS:
                jobs += [MoveJob(t, i + j, seed, kind, moves_per_type + j) for j in range(n)]
                i += n
    u = 0
    for kind, n in extra.items():
        if kind in CLOSED_LOOP_KINDS:
            jobs += [MoveJob(UNKNOWN_MOVE_TYPE, u + j, seed, kind, j) for j in range(n)]
            u += n
    return jobs


class _NoProgress:
    """A progress bar that shows nothing (``record_dataset(progress=False)``)."""

    def update(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


def _end_with_parent(parent: int) -> None:
    """A recording worker ends when the recording process dies (Linux: SIGTERM on the parent's
    death, :func:`.demo.parent_death_signal`). A pool's worker otherwise outlives a parent
    killed outright (SIGKILL, the OOM killer), waiting for work that never comes."""
    from .demo import parent_death_signal
    set_signal = parent_death_signal()
    if set_signal is None:
        return
    set_signal()
    if os.getppid() != parent:     # the parent died before the line above: end now
        os._exit(1)


def record_dataset(out: str | os.PathLike, *, moves_per_type: int = 20,
                   types: Sequence[str] = MOVE_TYPES, seed: int = 0,
                   robot: str | os.PathLike | "RobotConfig" = "measured",
                   effects_file: str | None = None, storage: str = "mcap",
                   jobs: int | None = None, overwrite: bool = False,
                   progress: bool = True, excitation: float = 0.0,
                   extra: Mapping[str, int] | None = None,
                   start_spread: float = 0.0, warmup: float = 0.0) -> RecordSummary:
    """Record ``moves_per_type`` moves of each type into the dataset directory ``out``.

    ``extra``: {kind: count} of TrainPool moves of other kinds (``control.moves.MOVE_KINDS``):
    per move type for trot, switch and varied, in all for velocity and waypoints;
    ``dataset.yaml`` lists them under ``info.extra_moves`` (kind -> bag names).

    ``robot``: a robot name, a twin file (``robot.twin``) or a RobotConfig; the dataset's
    ``dataset.yaml`` records it (``robot.twin.robot_source``).
    ``excitation`` [rad]: standard deviation of white noise added to every joint command
    (:func:`~littledog_mlsim.gait.trot.excite_commands`); 0 records the plain trot.
    ``start_spread`` [m]: each move starts from its own place, up to this far from the origin
    in x and y, and its own heading (:class:`StartSpread`); 0 starts every move at the origin
    facing +x. ``dataset.yaml`` records it as ``info.start_spread_m``.
    ``warmup`` [s]: each move is walked for this long before its recorded part, the same move
    continued (the same trot, schedule or controller, over ``warmup`` more seconds), and the
    bag keeps the last ``STEPS_PER_MOVE`` steps, its stamps from zero: moves that start from a
    settled gait instead of standing, as a robot's logs cut from a long walk do. Effects see
    the whole walk (a drift with time has run for ``warmup`` s when the bag starts).
    ``dataset.yaml`` records it as ``info.warmup_s``.
    """
    from ..data.dataset import BagEntry, dataset_entries, write_index
    from ..robot.effects import load_effects
    from ..robot.twin import robot_config_from, robot_source

    out = Path(out)
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out} already exists; pass --overwrite to replace it")
    if not np.isfinite(excitation) or not 0.0 <= excitation <= 0.2:
        raise ValueError(f"--excitation must be between 0 and 0.2 rad, got {excitation}")
    start_spread = check_start_spread(start_spread)
    warmup = check_warmup(warmup)
    if storage not in ("mcap", "sqlite3"):
        raise ValueError(f"--storage must be mcap or sqlite3, got {storage!r}")
    config = robot_config_from(robot)        # fails early on an unknown robot or a bad twin
    source = robot_source(robot)
    if effects_file:
        load_effects(effects_file)           # fails early on a bad effects file
    plan = plan_jobs(moves_per_type, types, seed, extra)
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(plan)))

    t0 = time.perf_counter()
    with atomic_directory(out, replace=overwrite) as tmp:  # swapped in only after success
        results = []
        args = [(j, str(tmp / j.name), config, effects_file, storage, excitation, start_spread,
                 warmup) for j in plan]
        # no tqdm object at all without progress: even a disabled one starts tqdm's monitor
        # thread, which then outlives the call
        bar = (tqdm(total=len(plan), desc=f"record {out.name}", unit="move") if progress
               else _NoProgress())
        if jobs == 1:
            for a in args:
                results.append(_record_one(*a))
                bar.update()
        else:
            with ProcessPoolExecutor(max_workers=jobs, initializer=_end_with_parent,
                                     initargs=(os.getpid(),)) as pool:
                futures = [pool.submit(_record_one, *a) for a in args]
                for f in as_completed(futures):
                    results.append(f.result())
                    bar.update()
        bar.close()
        entries = dataset_entries(moves_per_type, types)
        extras = [j for j in plan if j.kind != "trot" or j.index >= moves_per_type]
        entries += [BagEntry(j.name, j.move_type, "train") for j in extras]
        info = {**source, "seed": seed, "storage": storage,
                "moves_per_type": moves_per_type, "types": list(types),
                "steps_per_move": STEPS_PER_MOVE, "control_dt_ns": CONTROL_DT_NS,
                "recorded_by": f"littledog_mlsim {__version__}"}
        if excitation:
            info["command_excitation_rad"] = float(excitation)
        if start_spread:
            info["start_spread_m"] = start_spread
        if warmup:
            info["warmup_s"] = warmup
        if extras:
            info["extra_moves"] = {k: [j.name for j in extras if j.kind == k]
                                   for k in dict.fromkeys(j.kind for j in extras)}
        write_index(tmp, entries, info)
    per_type = {t: sum(j.move_type == t for j in plan)
                for t in (*types, UNKNOWN_MOVE_TYPE) if any(j.move_type == t for j in plan)}
    return RecordSummary(out=out, n_bags=len(plan), n_steps=sum(r[1] for r in results),
                         wall_s=time.perf_counter() - t0, cpu_s=sum(r[2] for r in results),
                         jobs=jobs, per_type=per_type)
