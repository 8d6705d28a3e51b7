"""What the bootstrap's check on the recording (``twin_bias.correction_check``) says about
calibrations made before it existed.

For a twin file whose calibration ran ``--bootstrap``: the corrected twin against the fit's
optimum on the fitted moves of its reference (``twin_bias.cost_rise``: the rise), and, for
each replicate of the last iteration, the twin's own recordings made again with the stored
sensing and noise seeds, on which the move from the refit back to the twin is costed (the
drop). The refit's point is taken as the last point plus the mean bias the report stores (the
replicates' own optima are not stored; their scatter would make each drop larger, so this
retro errs towards refuting). Prints and writes one JSON row per twin.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo38/runs/after_run1/check_retro.py \
        OUT.json TWIN.json=DATA [TWIN.json=DATA ...]
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import replace

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import baseline as bl
from littledog_mlsim.robot import twin_bias as tb
from littledog_mlsim.robot import twin_fit as tf
from littledog_mlsim.robot.parameters import twin_parameters
from littledog_mlsim.robot.twin import load_twin


def one(twin_path: str, data: str) -> dict:
    twin = load_twin(twin_path)
    cal = twin.provenance["calibration"]
    settings, boot = cal["settings"], cal.get("bootstrap")
    if not boot or not boot.get("params"):
        print(json.dumps({"twin": twin_path, "skipped": "no bootstrap correction"}), flush=True)
        return {"twin": twin_path, "skipped": "no bootstrap correction"}
    final = replace(twin.robot, sensor_noise=False)
    names = list(twin.provenance["parameters"])
    params = twin_parameters(names, final)
    per = boot["params"]
    fit = last = refit = final
    for p in params:
        b = per.get(p.name)
        if b is None:
            continue
        fit = p.set(fit, b["fitted"])
        at = b["at"][-1]
        last = p.set(last, at)
        bias = b["bias_coordinate"][-1]
        refit = p.set(refit, min(max(p.from_x(p.to_x(at) + (bias or 0.0)), p.bounds[0]),
                                 p.bounds[1]))
    opts = tf.CalibrationOptions(params=tuple(names), jobs=2,
                                 horizons=tuple(settings["horizons"]), stride=settings["stride"],
                                 initial_state=settings["initial_state"])
    train = bl.first_per_type(load_moves(data, "train"), 2)
    t0 = time.perf_counter()
    c_fit, c_cor = tb.cost_rise(train, fit, final, opts)
    n_it, n_rep = int(boot["iterations"]), int(boot.get("replicates", 1))
    drops = []
    for j in range(n_rep):
        synth = tb.synthetic_recordings(train, tb._with_sensing(last, boot["sensing"]),
                                        (n_it - 1) * n_rep + j)
        at_refit, at_twin = tb.cost_rise(synth, refit, last, opts)
        drops.append(at_twin - at_refit)
    n_applied = sum(1 for b in per.values() if b.get("applied"))
    row = {"twin": twin_path, "cost_fit": c_fit, "cost_corrected": c_cor, "drops": drops,
           "n_applied": n_applied,
           **tb.correction_check(c_cor - c_fit, drops, n_applied),
           "seconds": round(time.perf_counter() - t0, 1)}
    print(json.dumps(row), flush=True)
    return row


def main() -> None:
    out = sys.argv[1]
    rows = [one(*pair.split("=", 1)) for pair in sys.argv[2:]]
    json.dump({"rows": rows, "check_slack": tb.CHECK_SLACK, "check_level": tb.CHECK_LEVEL},
              open(out, "w"), indent=1)


if __name__ == "__main__":
    main()
