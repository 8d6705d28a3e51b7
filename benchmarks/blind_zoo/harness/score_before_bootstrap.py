"""Score a calibrated twin's fit as it was before its bootstrap (``calibrate --bootstrap N``).

The twin's report keeps the fitted values (``bootstrap.params.*.fitted``) and the intervals'
sd before the bootstrap widened them (``sd_coordinate``); this rebuilds those intervals and
checks the gap robot's values against them, as ``score_twin.py`` does for the corrected twin.
The fitted friction coefficient is scored as the contact's product (foot x floor).

    .venv/bin/python benchmarks/blind_zoo/harness/score_before_bootstrap.py RUN_DIR

RUN_DIR holds ``calibrated_twin.json`` and ``score.json`` (``score_twin.py --json``), whose
truth and identifiability it uses.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path


def main(run: str) -> None:
    from littledog_mlsim.robot import twin_fit as tf
    from littledog_mlsim.robot.parameters import twin_parameters
    from littledog_mlsim.robot.twin import load_twin

    twin = load_twin(Path(run) / "calibrated_twin.json")
    cal = twin.provenance["calibration"]
    boot = cal["bootstrap"]["params"]
    rows = {r["name"]: r for r in json.loads((Path(run) / "score.json").read_text())["rows"]}
    n = inside = 0
    for p in twin_parameters(list(boot), twin.robot):
        row = rows.get(p.name)
        if row is None or not row.get("identifiable"):
            continue
        lo, hi = tf._interval(p, p.to_x(boot[p.name]["fitted"]), cal["sd_coordinate"][p.name])
        value = boot[p.name]["fitted"]
        if row.get("scored_as") == "contact_friction":
            f = twin.robot.foot_friction
            lo, hi, value = lo * f, hi * f, value * f
        ok = lo <= row["truth"] <= hi
        n, inside = n + 1, inside + ok
        print(f"{p.name:20s} fitted {value:.4g}  95 % [{lo:.4g}, {hi:.4g}]  truth {row['truth']:.4g}"
              f"  inside {ok}")
    print(f"before the bootstrap: {inside} of {n} identifiable inside their intervals")


if __name__ == "__main__":
    main(sys.argv[1])
