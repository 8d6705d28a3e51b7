"""zoo14 run2 (not blind): z02 recorded again with the TrainPool size its report asked for.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/blind_zoo/zoos/zoo14/runs/run2_more_moves/follow.py record WORK
    OPENBLAS_NUM_THREADS=1 .venv/bin/littledog-mlsim diagnose --data WORK/effects/z02_m15 \
        --out WORK/diag/z02_m15 --no-figures --jobs 2 --physics off --rollout-route \
        --reference ZOO14_WORK/reference
    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/blind_zoo/zoos/zoo14/runs/run2_more_moves/follow.py score WORK

``record``: the harness's own ``record`` (the gap robot, the effect's file, seed 91 as run1,
its identity removed) with 15 moves per type instead of 10. ``score``: the harness's ``score``
of the report against the truth.
"""
import json
import sys
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
ZOO = HERE.parents[1]
sys.path.insert(0, str(ZOO.parents[1] / "harness"))
from run import Dataset, record, score  # noqa: E402

verb, work = sys.argv[1], Path(sys.argv[2])
if verb == "record":
    ds = Dataset("z02_m15", work / "effects" / "z02_m15", 91, 0.0,
                 effects=ZOO / "effects" / "z02.yaml", robot=ZOO / "gap_robot.json")
    record(ds, 15, 2, work / "logs")
    print("recorded", ds.path)
else:
    truth = {t["id"]: t for t in yaml.safe_load((ZOO / "truth.yaml").read_text())["effects"]}
    report = json.loads((work / "diag" / "z02_m15" / "report.json").read_text())
    s = score(truth["z02"], report)
    u = report["rollout_route"].get("unexplained_change") or {}
    print(json.dumps({**{k: s[k] for k in ("found", "family_right", "scope_right", "param_error",
                                           "identified", "named")},
                      "unexplained_change": {k: u.get(k) for k in ("significant", "ratio",
                                                                   "p_value", "scope")}},
                     indent=1))
