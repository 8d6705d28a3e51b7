"""The physical route's re-simulations on a Dask cluster (``diagnose --scheduler``): the same
outputs as in local processes, on a real scheduler and two worker processes."""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.diagnose.physical.channels import SEG_STARTS
from littledog_mlsim.diagnose.physical.resim import DaskRunner, Move, Runner
from littledog_mlsim.robot.sim import InitialState, simulate_move


def _moves() -> list[Move]:
    rng = np.random.default_rng(0)
    out = []
    for i in range(3):
        from littledog_mlsim.layout import HOME_POSE
        cmd = np.asarray(HOME_POSE) + 0.05 * np.sin(np.arange(400)[:, None] * 0.05 + i) \
            + 0.01 * rng.standard_normal((400, 12))
        rec = simulate_move(cmd, robot="measured", seed=i, name=f"F_0{i}", move_type="F")
        out.append(Move(rec.name, "F", cmd, {k: InitialState.from_recording(rec, k)
                                            for k in SEG_STARTS}))
    return out


def test_dask_runner_equals_the_local_runner():
    distributed = pytest.importorskip("distributed")
    moves = _moves()
    tasks = [(i, [], "short") for i in range(3)] + [
        (1, [("odom_force", "body", {"fx": 0.5, "fy": -1.0})], "full"),
        (2, [("command_delay", "all", {"delay_ms": 20.0})], "segs")]
    local = Runner("measured", moves, 1)
    try:
        want = local.map(tasks)
    finally:
        local.close()
    with distributed.LocalCluster(host="127.0.0.1", dashboard_address=None, n_workers=2,
                                  threads_per_worker=1, processes=True) as cluster:
        remote = DaskRunner("measured", moves, cluster.scheduler_address)
        try:
            got = remote.map(tasks)
            again = remote.map(tasks[:2])
        finally:
            remote.close()
    assert remote.n_sims == len(tasks) + 2
    for w, g in zip(want + want[:2], got + again):
        assert set(w) == set(g)
        for k in w:
            np.testing.assert_array_equal(w[k], g[k])


def test_unreachable_scheduler_is_one_line():
    with pytest.raises(ValueError, match="cannot connect to the Dask scheduler tcp://127.0.0.1:9"):
        DaskRunner("measured", [], "tcp://127.0.0.1:9")
