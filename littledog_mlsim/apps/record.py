"""Record a dataset: trot every move type on the pybullet LittleDog and write one bag per move.

The dataset is built in a temporary sibling directory and renamed into place only when every bag
and ``dataset.yaml`` are written, so a failed or interrupted run leaves no partial bag behind and
never touches an existing dataset (which is only replaced when ``overwrite`` is set).
Moves run in parallel across processes (one pybullet world per process).
"""
from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np
from tqdm import tqdm

from .. import __version__
from ..fileio import atomic_directory
from ..layout import CONTROL_DT_NS, MOVE_TYPES, STEPS_PER_MOVE, bag_name

if TYPE_CHECKING:
    from ..robot.config import RobotConfig


@dataclass(frozen=True)
class MoveJob:
    """One move to record; seeds derive from (dataset seed, move type, index) only."""

    move_type: str
    index: int
    seed: int

    @property
    def name(self) -> str:
        return bag_name(self.move_type, self.index)

    def seeds(self) -> tuple[int, int]:
        """(gait seed, robot/sensor seed), independent streams for this move."""
        ss = np.random.SeedSequence([self.seed, MOVE_TYPES.index(self.move_type), self.index])
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


def _record_one(job: MoveJob, bag_path: str, robot: "RobotConfig", effects_file: str | None,
                storage: str, excitation: float = 0.0) -> tuple[str, int, float]:
    """Worker: simulate one move and write its bag. Returns (name, n_steps, CPU seconds)."""
    from ..data.bags import write_bag
    from ..gait.trot import excite_commands, sample_trot_params, trot_commands
    from ..robot.effects import load_effects
    from ..robot.sim import simulate_move

    t0 = time.process_time()
    gait_seed, robot_seed = job.seeds()
    gait_rng = np.random.default_rng(gait_seed)
    params = sample_trot_params(job.move_type, gait_rng)
    commands = excite_commands(trot_commands(params), excitation, gait_rng)
    effects = load_effects(effects_file) if effects_file else ()
    rec = simulate_move(commands, robot=robot, effects=effects, seed=robot_seed,
                        name=job.name, move_type=job.move_type)
    write_bag(bag_path, rec, storage=storage)
    return job.name, rec.n_steps, time.process_time() - t0


def plan_jobs(moves_per_type: int, types: Sequence[str], seed: int) -> list[MoveJob]:
    for t in types:
        if t not in MOVE_TYPES:
            raise ValueError(f"unknown move type {t!r}; expected some of {' '.join(MOVE_TYPES)}")
    if moves_per_type < 1:
        raise ValueError(f"--moves-per-type must be at least 1, got {moves_per_type}")
    return [MoveJob(t, i, seed) for t in types for i in range(moves_per_type)]


class _NoProgress:
    """A progress bar that shows nothing (``record_dataset(progress=False)``)."""

    def update(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


def record_dataset(out: str | os.PathLike, *, moves_per_type: int = 20,
                   types: Sequence[str] = MOVE_TYPES, seed: int = 0,
                   robot: str | os.PathLike | "RobotConfig" = "measured",
                   effects_file: str | None = None, storage: str = "mcap",
                   jobs: int | None = None, overwrite: bool = False,
                   progress: bool = True, excitation: float = 0.0) -> RecordSummary:
    """Record ``moves_per_type`` moves of each type into the dataset directory ``out``.

    ``robot``: a robot name, a twin file (``robot.twin``) or a RobotConfig; the dataset's
    ``dataset.yaml`` records it (``robot.twin.robot_source``).
    ``excitation`` [rad]: standard deviation of white noise added to every joint command
    (:func:`~littledog_mlsim.gait.trot.excite_commands`); 0 records the plain trot.
    """
    from ..data.dataset import dataset_entries, write_index
    from ..robot.effects import load_effects
    from ..robot.twin import robot_config_from, robot_source

    out = Path(out)
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out} already exists; pass --overwrite to replace it")
    if not np.isfinite(excitation) or not 0.0 <= excitation <= 0.2:
        raise ValueError(f"--excitation must be between 0 and 0.2 rad, got {excitation}")
    if storage not in ("mcap", "sqlite3"):
        raise ValueError(f"--storage must be mcap or sqlite3, got {storage!r}")
    config = robot_config_from(robot)        # fails early on an unknown robot or a bad twin
    source = robot_source(robot)
    if effects_file:
        load_effects(effects_file)           # fails early on a bad effects file
    plan = plan_jobs(moves_per_type, types, seed)
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(plan)))

    t0 = time.perf_counter()
    with atomic_directory(out, replace=overwrite) as tmp:  # swapped in only after success
        results = []
        args = [(j, str(tmp / j.name), config, effects_file, storage, excitation) for j in plan]
        # no tqdm object at all without progress: even a disabled one starts tqdm's monitor
        # thread, which then outlives the call
        bar = (tqdm(total=len(plan), desc=f"record {out.name}", unit="move") if progress
               else _NoProgress())
        if jobs == 1:
            for a in args:
                results.append(_record_one(*a))
                bar.update()
        else:
            with ProcessPoolExecutor(max_workers=jobs) as pool:
                futures = [pool.submit(_record_one, *a) for a in args]
                for f in as_completed(futures):
                    results.append(f.result())
                    bar.update()
        bar.close()
        entries = dataset_entries(moves_per_type, types)
        info = {**source, "seed": seed, "storage": storage,
                "moves_per_type": moves_per_type, "types": list(types),
                "steps_per_move": STEPS_PER_MOVE, "control_dt_ns": CONTROL_DT_NS,
                "recorded_by": f"littledog_mlsim {__version__}"}
        if excitation:
            info["command_excitation_rad"] = float(excitation)
        write_index(tmp, entries, info)
    per_type = {t: moves_per_type for t in types}
    return RecordSummary(out=out, n_bags=len(plan), n_steps=sum(r[1] for r in results),
                         wall_s=time.perf_counter() - t0, cpu_s=sum(r[2] for r in results),
                         jobs=jobs, per_type=per_type)
