"""The start method of the package's local process pools.

A *spawned* worker starts a new interpreter and imports numpy, scipy, pybullet and the package
again before its first task; a *forked* one inherits whatever its parent holds (pybullet
clients, ROS or Dask threads), which is unsafe. The pools use the fork server instead: one
clean, single-threaded process per parent, started on first use with the modules of
:data:`PRELOAD` imported, from which each worker is forked without importing them again.
"""
from __future__ import annotations

import multiprocessing as mp
from multiprocessing.context import BaseContext

#: imported once by the fork server (the re-simulation and model-fitting workers' modules)
PRELOAD = ["littledog_mlsim.robot.baseline", "littledog_mlsim.models.train"]


def worker_context() -> BaseContext:
    """The multiprocessing context for a local worker pool: the fork server, with
    :data:`PRELOAD` (which takes effect when this process starts its fork server)."""
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(PRELOAD)
    return ctx
