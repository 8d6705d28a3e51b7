"""The excess over the reference of one diagnosis that accepted nothing, measured again with
``significant_channels`` (decision 062), which reports written before it do not keep.

With no finding and no twin error, what the physical route leaves is the twin alone on the
held-out moves against the reference's moves (``driver.unexplained`` on the base of no
hypothesis), so only those moves are re-simulated (one process). The pooled ratio and p must
equal the report's (checked), which shows the moves and the twin are the diagnosis's.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/left_by_channel/recheck.py \\
        --data WORK/effects/ID --reference WORK/reference --twin TWIN.json --report REPORT.json
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.diagnose.physical.channels import errors, measured, seg_starts
from littledog_mlsim.diagnose.physical.context import SearchContext
from littledog_mlsim.diagnose.physical.driver import (PhysicalOptions, _long_enough, _split,
                                                      exceeds, name_left, unexplained)
from littledog_mlsim.diagnose.physical.resim import Move, Runner
from littledog_mlsim.robot.sim import InitialState
from littledog_mlsim.robot.twin import robot_config_from


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--reference", required=True)
    ap.add_argument("--twin", required=True)
    ap.add_argument("--report", required=True, help="the diagnosis's report.json")
    a = ap.parse_args()
    rep = json.load(open(a.report))
    phys = rep["physics"]
    if rep.get("effects") or phys["reference"]["twin_errors"]:
        sys.exit("recheck: the diagnosis accepted a finding or a twin error; this reads only "
                 "the twin alone")
    o = PhysicalOptions(alpha=float(phys["alpha"]))
    cfg = replace(robot_config_from(a.twin), sensor_noise=False)
    train, test, ref, _ = _long_enough(load_moves(a.data, "train"), load_moves(a.data, "test"),
                                       load_moves(a.reference, "train"))
    sp = _split(train, test, o, ref)
    want = sorted(sp.V + sp.R)
    moves = [Move(r.name, r.move_type, np.asarray(r.cmd, dtype=np.float64),
                  {k: InitialState.at(r, k, o.initial_state) for k in seg_starts(r.n_steps)},
                  seg_starts(r.n_steps)) for r in sp.recs]
    runner = Runner(cfg, moves, 1)
    try:
        sims = runner.map([(i, [], "full") for i in want])
    finally:
        runner.close()
    meas = [measured(r) for r in sp.recs]
    base_err: list = [None] * len(sp.recs)
    for i, s in zip(want, sims):
        base_err[i] = errors(s, meas[i])
    ctx = SearchContext(runner, (), base_err, meas)
    left = name_left(unexplained(ctx, sp.V, sp.R, o.alpha))
    was = phys["reference"]["unexplained"]
    same = (np.isclose(left["pooled_ratio"], was["pooled_ratio"], rtol=1e-9)
            and np.isclose(left["p_value"], was["p_value"], rtol=1e-9))
    print(json.dumps({"data": a.data, "same_as_report": bool(same),
                      "pooled_ratio": left["pooled_ratio"], "p_value": left["p_value"],
                      "channel_p_value": left["channel_p_value"],
                      "significant_channels": left["significant_channels"],
                      "material": left["material"], "scope": left["scope"],
                      "exceeds": exceeds(left), "named": left["named"],
                      "report_pooled_ratio": was["pooled_ratio"],
                      "report_p_value": was["p_value"]}, indent=1))
    if not same:
        sys.exit("recheck: the pooled ratio or p differs from the report's")


if __name__ == "__main__":
    main()
