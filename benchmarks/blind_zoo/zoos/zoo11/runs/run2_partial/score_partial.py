"""Score run2's partial diagnoses with the harness's own ``score`` (its run stopped at scoring:
the clean dataset of the effects' seed, 61, was not part of this run). Usage, from a checkout:

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo11/runs/run2_partial/score_partial.py WORK
"""
import json
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[6]
sys.path.insert(0, str(ROOT / "benchmarks/blind_zoo/harness"))
import run as harness  # noqa: E402

work = Path(sys.argv[1])
truth = {e["id"]: e for e in yaml.safe_load(
    (ROOT / "benchmarks/blind_zoo/zoos/zoo11/truth.yaml").read_text())["effects"]}
for name in ["z03", "z07", "z13", "clean_s63_e0"]:
    rep = json.loads((work / "diag_learned+reference" / name / "report.json").read_text())
    if name.startswith("clean"):
        print(f"{name}: significant {harness.significant(rep)}, {rep['seconds']:.0f} s")
        continue
    s = harness.score(truth[name], rep)
    named = [(n["family"], n["scope"], n["params"]) for n in s["named"]]
    print(f"{name}: found {s['found']}, named {named}, param error {s['param_error']}, "
          f"angle error {s['angle_error_deg']}, {rep['seconds']:.0f} s")
    if name == "z07":              # the delay's narrower scopes: the leg the truth names
        for rd in rep["rollout_route"]["rounds"]:
            for p in rd.get("scoped", []):
                if p["label"].startswith("command_lag"):
                    print(f"  round {rd['round']} {p['label']}: gain {p['total_gain']:.2f}, "
                          f"p {p['p_value']:.2g}")
