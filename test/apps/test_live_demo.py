"""The live record -> train -> swap loop end to end (``apps/live_demo.py``): pybullet_node,
trainer_node (live) and sim_node as processes, this process the controller. Checks the
recorded data against the commands sent, the model against the recorded moves, and the swap
against the time line and pose of the robot it keeps."""
from __future__ import annotations

import numpy as np

from littledog_mlsim.apps.live_demo import _trot, run_live_demo
from littledog_mlsim.data.bags import read_bag
from littledog_mlsim.data.dataset import read_index
from littledog_mlsim.layout import CONTROL_DT_NS
from littledog_mlsim.models.onestep import OneStepModel


def test_record_train_swap(tmp_path):
    lines: list[str] = []
    r = run_live_demo(tmp_path, steps=100, log=lines.append)
    # the robot stepped until the trainer heard it (its commands come only with a step)
    assert r.warmup_steps >= 1
    # two sessions recorded as moves U_00, U_01; what was recorded is what was sent
    index = read_index(tmp_path / "live_data")
    assert index.names("train") == ["U_00", "U_01"]
    for name, (kind, seed) in zip(index.names(), [("F", 0), ("FL", 2)]):
        rec = read_bag(tmp_path / "live_data" / name)
        sent = _trot(kind, 100, seed)
        # measurement 0 (and its command) went out before the recording began
        np.testing.assert_allclose(rec.cmd, sent[-rec.cmd.shape[0]:], atol=1e-9)
        assert rec.cmd.shape[0] >= 98
        assert np.all(np.diff(rec.stamps_ns) == CONTROL_DT_NS)
    # the model trained on both, written where sim_node loads it
    model = OneStepModel.load(tmp_path / "live_model")
    assert model.method == "lr" and model.info["n_moves"] == 2
    assert "from 1 moves" in r.trainings[0] and "from 2 moves" in r.trainings[1]
    # the swap: the same time line, the pose kept: the step across it is one step of a trot,
    # the new model's first (a model fitted on two 100-step moves takes up to about 3x the old
    # model's median step there), not the way back to where the robot started (a reset)
    assert r.swap.startswith("swapped at t = ")
    assert r.stamp_after_ns == r.stamp_before_ns + CONTROL_DT_NS
    assert r.steps_after_swap == r.steps_before_swap >= 20
    assert r.jump_m < 5 * r.median_step_m + 1e-3
