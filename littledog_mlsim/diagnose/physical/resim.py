"""Re-simulation: the transducer that runs hypotheses on measured moves.

A task is ``(move index, hypotheses, mode)`` with hypotheses as ``(family, scope, params)``
tuples (picklable for the worker processes); :class:`Runner` maps tasks to simulated outputs
(:func:`simulate`), in worker processes if ``jobs > 1``; :class:`DaskRunner` maps them on the
workers of a Dask cluster (``diagnose --scheduler``), with the same outputs: a re-simulation is
deterministic (seed 0), wherever it runs. Anything with the same ``map`` (and ``config``) can
stand in for either (:class:`Transducer`). :class:`Memo` wraps a transducer and serves a task it
has run before from memory: the search asks again for runs it has made (a held-out decision's
full runs of the finding are the next base's), and a re-simulation is a pure function of its
task, so the answer is the same.
"""
from __future__ import annotations

import math
import multiprocessing as mp
import threading
from collections import OrderedDict
from dataclasses import dataclass, replace
from typing import Any, Mapping, Protocol, Sequence

import numpy as np

from ..families import FAMILIES
from .channels import SCREEN_SEGMENTS, SEG_LEN, SEG_STARTS, rpy

__all__ = ["Move", "Task", "Transducer", "Runner", "DaskRunner", "Memo", "task_key", "simulate",
           "init_worker", "true_start", "build_effects"]

Task = tuple[int, list[tuple[str, str, dict]], str]


class Transducer(Protocol):
    """Maps re-simulation tasks to outputs (``segs``, ``seg_idx`` and in ``full`` mode
    ``full``, as :func:`simulate`)."""

    def map(self, tasks: list[Task]) -> list[dict[str, np.ndarray]]: ...


def build_effects(family: str, scope: str, params: Mapping[str, Any]) -> list[Any]:
    """The effect plug-ins of one hypothesis (family, scope, params in the vocabulary's units
    and, for vector families, components)."""
    if family not in FAMILIES:
        raise ValueError(f"unknown family {family!r}")
    return FAMILIES[family].build_effects(scope, params)


@dataclass
class Move:
    """What a worker needs to re-simulate one move: commands and measured start states."""

    name: str
    move_type: str
    cmd: np.ndarray
    starts: dict[int, Any]
    seg_starts: tuple[int, ...] = SEG_STARTS    # channels.seg_starts of its length


_WORKER: dict[str, Any] = {}


def init_worker(robot: Any, moves: list[Move], forked: bool = False) -> None:
    if forked:   # pybullet clients inherited from the parent are not this process's
        from ...robot import sim
        sim._SIMS.clear()
    _WORKER["robot"] = robot
    _WORKER["moves"] = moves


def simulate(task: Task) -> dict[str, np.ndarray]:
    """Re-simulate move ``i`` with the hypotheses' plug-ins: segments (4, 100, 18) of
    [q (12), position (3), roll, pitch, yaw]; ``full`` mode also the 4 s replay (400, 18),
    ``segs`` mode the four segments without it, ``short`` mode the segments SCREEN_SEGMENTS."""
    from ...robot.sim import simulate_move
    i, hyps, mode = task
    mv: Move = _WORKER["moves"][i]
    robot = _WORKER["robot"]
    out: dict[str, np.ndarray] = {}

    def run(k0: int, n: int) -> np.ndarray:
        effects = [e for (fam, sc, par) in hyps
                   for e in build_effects(fam, sc, {**par, "t0_s": k0 * 0.01,
                                                    "origin_xy": mv.starts[0].position[:2]})]
        rec = simulate_move(mv.cmd[k0:k0 + n], robot=robot, effects=effects, seed=0,
                            name=mv.name, move_type=mv.move_type,
                            initial=true_start(mv.starts[k0], hyps))
        return np.hstack([rec.q[1:], rec.position[1:], rpy(rec.orientation[1:])]
                         ).astype(np.float64)

    if mode == "full":
        full = run(0, mv.cmd.shape[0])
        out["full"] = full
        segs = [full[:SEG_LEN]] + [run(k0, SEG_LEN) for k0 in mv.seg_starts[1:]]
        out["seg_idx"] = np.arange(len(mv.seg_starts))
    elif mode == "segs":
        segs = [run(k0, SEG_LEN) for k0 in mv.seg_starts]
        out["seg_idx"] = np.arange(len(mv.seg_starts))
    else:   # "short": the 1 s segments SCREEN_SEGMENTS only
        segs = [run(mv.seg_starts[k], SEG_LEN) for k in SCREEN_SEGMENTS]
        out["seg_idx"] = np.array(SCREEN_SEGMENTS)
    out["segs"] = np.stack(segs)
    return out


def true_start(initial: Any, hyps: Sequence[tuple[str, str, Mapping[str, Any]]]) -> Any:
    """The state to start a re-simulation from, given the measured one and the hypotheses
    (each family's :meth:`~.families.Family.start_q` and :meth:`~.families.Family.start_dq`:
    an encoder offset starts the joints at the measured angle minus it, an encoder scale at the
    measured angle and rate divided by it). The readings pass the hypotheses' plug-ins in their
    order, so their inverses are taken in the reverse order."""
    q0, dq0, rep0 = initial.q, initial.dq, initial.reported_dq
    q, dq, rep = q0, dq0, rep0
    for fam, sc, par in reversed(list(hyps)):
        f = FAMILIES[fam]
        q = f.start_q(q, sc, par)
        dq = f.start_dq(dq, sc, par)
        if rep is not None:
            rep = f.start_dq(rep, sc, par)
    if q is q0 and dq is dq0 and rep is rep0:
        return initial
    return replace(initial, q=q, dq=dq, reported_dq=rep)


class Runner:
    """Runs re-simulation tasks, in worker processes if ``jobs > 1``."""

    def __init__(self, robot: Any, moves: list[Move], jobs: int) -> None:
        self.jobs = max(1, int(jobs))
        self.n_sims = 0
        self.config = robot
        if self.jobs > 1:
            ctx = mp.get_context("fork")
            self.pool = ctx.Pool(self.jobs, initializer=init_worker,
                                 initargs=(robot, moves, True))
        else:
            self.pool = None
            init_worker(robot, moves)

    def map(self, tasks: list[Task]) -> list[dict[str, np.ndarray]]:
        self.n_sims += len(tasks)
        if self.pool is None:
            return [simulate(t) for t in tasks]
        return self.pool.map(simulate, tasks, chunksize=max(1, len(tasks) // (4 * self.jobs)))

    def close(self) -> None:
        if self.pool is not None:
            self.pool.close()
            self.pool.join()
            self.pool = None


_REMOTE_LOCK = threading.Lock()   # one pybullet client per process: a worker's threads take turns


def _simulate_remote(task: Task, state: tuple[Any, list[Move]]) -> dict[str, np.ndarray]:
    """:func:`simulate` on a Dask worker: ``state`` (robot, moves) was scattered to every worker
    once and is the same object for each of its tasks, so the worker is set up once."""
    with _REMOTE_LOCK:
        if _WORKER.get("state") is not state:
            init_worker(*state)
            _WORKER["state"] = state
        return simulate(task)


class DaskRunner:
    """Runs re-simulation tasks on the workers of the Dask cluster at ``scheduler`` (an address
    such as ``tcp://host:8786``; ``dask scheduler`` and ``dask worker ADDRESS``). The robot and
    the moves are sent to every worker once; results come back in task order. An unreachable
    scheduler is a ValueError of one line."""

    def __init__(self, robot: Any, moves: list[Move], scheduler: str) -> None:
        from ...models.parallel import connect_client
        self.config = robot
        self.n_sims = 0
        self.client = connect_client(scheduler)
        try:
            self.client.wait_for_workers(1, timeout=60)
            # one future for the pair (scatter sends a sequence's items one by one)
            self.state = self.client.scatter([(robot, moves)], broadcast=True, hash=False)[0]
        except Exception:
            self.client.close()
            raise

    def map(self, tasks: list[Task]) -> list[dict[str, np.ndarray]]:
        self.n_sims += len(tasks)
        if not tasks:
            return []
        futures = self.client.map(_simulate_remote, tasks, state=self.state, pure=False)
        return self.client.gather(futures)

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None


def _frozen(v: Any) -> Any:
    """A hashable, exact stand-in for a hypothesis parameter: numbers keep their type (an int
    and a float of one value stay apart; numpy's float64 is a float, with the same arithmetic, a
    float32 is not), a float its sign too (0.0 and -0.0 stay apart), lists, tuples and arrays
    become one kind of tuple (the families build the same effects from any of them)."""
    if isinstance(v, np.ndarray) and v.ndim == 0:
        v = v[()]
    if isinstance(v, (float, np.floating)):
        x = float(v)
        return ("float" if isinstance(v, float) else type(v).__name__, x, math.copysign(1.0, x))
    if isinstance(v, np.generic):
        return (type(v).__name__, v.item())
    if isinstance(v, np.ndarray) and v.dtype != np.float64:
        return ("array", str(v.dtype), v.shape) + tuple(_frozen(x) for x in v.ravel())
    if isinstance(v, Mapping):
        return ("map",) + tuple(sorted((str(k), _frozen(x)) for k, x in v.items()))
    if isinstance(v, (list, tuple, np.ndarray)):
        return ("seq",) + tuple(_frozen(x) for x in v)
    if isinstance(v, (bool, int, str)) or v is None:
        return (type(v).__name__, v)
    raise TypeError(f"a hypothesis parameter of type {type(v).__name__} cannot be a task key")


def task_key(task: Task) -> tuple:
    """The task's identity: move index, mode and each hypothesis's (family, scope, params)
    exactly (:func:`_frozen`)."""
    i, hyps, mode = task
    return (int(i), str(mode), tuple((str(f), str(sc), _frozen(par)) for f, sc, par in hyps))


class Memo:
    """A transducer that runs each distinct task once (:func:`task_key`) and serves repeats
    from memory, least recently used first out past ``max_bytes`` (default 256 MiB).
    ``n_sims`` counts the re-simulations the wrapped transducer ran; ``n_served`` the tasks
    answered from memory. Outputs are read-only arrays, shared by every caller that asks for
    the same task."""

    def __init__(self, inner: Any, max_bytes: int = 256 << 20) -> None:
        self.inner = inner
        self.config = getattr(inner, "config", None)
        self.max_bytes = int(max_bytes)
        self.n_served = 0
        self._store: OrderedDict[tuple, dict[str, np.ndarray]] = OrderedDict()
        self._bytes = 0

    @property
    def n_sims(self) -> int:
        return self.inner.n_sims

    def map(self, tasks: list[Task]) -> list[dict[str, np.ndarray]]:
        keys = [task_key(t) for t in tasks]
        todo: dict[tuple, Task] = {}
        for k, t in zip(keys, tasks):
            if k not in self._store and k not in todo:
                todo[k] = t
        fresh = dict(zip(todo, self.inner.map(list(todo.values())), strict=True)) if todo else {}
        self.n_served += len(tasks) - len(todo)
        out = []
        for k in keys:
            if k in fresh:
                r = fresh[k]
            else:
                r = self._store[k]
                self._store.move_to_end(k)
            out.append(r)
        for k, r in fresh.items():
            for a in r.values():
                a.setflags(write=False)
            self._store[k] = r
            self._bytes += sum(a.nbytes for a in r.values())
        while self._bytes > self.max_bytes and self._store:
            _, old = self._store.popitem(last=False)
            self._bytes -= sum(a.nbytes for a in old.values())
        return out

    def close(self) -> None:
        self._store.clear()
        self._bytes = 0
        self.inner.close()
