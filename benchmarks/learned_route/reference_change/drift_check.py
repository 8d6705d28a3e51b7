"""A time drift read through the reference's model: confirmed, or a stand-in (decision 028).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/drift_check.py --reference WORK/reference \
        --check WORK/effects/z07=all WORK/effects/z05=type:hip_pitches --label zoo16 --out OUT

For each DATA=SCOPE, ``littledog_mlsim.diagnose.change.drift_through_reference`` at the
measured robot's start features (the route's start feature set): the search model fitted on the
whole reference predicts the data's next step; at the scope's joints the column t (u - q) on top
of the servo response is judged against it (significant and material, one candidate). Writes
OUT.md and OUT.json (appending rows where OUT.json exists, so several zoos share one table).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

from _common import appended_study, study_commands  # noqa: E402

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.diagnose.candidates import measured_robot_features  # noqa: E402
from littledog_mlsim.diagnose.change import drift_through_reference  # noqa: E402
from littledog_mlsim.diagnose.families.scopes import scope_group  # noqa: E402
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route  # noqa: E402
from littledog_mlsim.models.feature_library import ElapsedTracking  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--reference", type=Path, required=True)
    p.add_argument("--check", nargs="+", required=True, metavar="DATA=SCOPE")
    p.add_argument("--label", required=True, help="a name for the zoo in the table")
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args()
    opts, start = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    ref = _Route(load_moves(a.reference, "train"), start, opts, quiet)
    ref_fit = ref.fit(start)
    out_json = a.out.with_suffix(".json")
    doc = appended_study(out_json)
    for item in a.check:
        data, scope = item.split("=")
        t = time.perf_counter()
        r = _Route(load_moves(Path(data), "train"), start, opts, quiet)
        c = drift_through_reference(r, ref, start, ElapsedTracking(joints=scope_group(scope)),
                                    ref_fit)
        row = {"zoo": a.label, "data": Path(data).name, **c,
               "seconds": round(time.perf_counter() - t, 1)}
        doc["rows"].append(row)
        print(f"{a.label} {row['data']} @ {scope}: gain {c['total_gain']:+.2f} "
              f"p {c['p_value']:.2g} confirmed {c['confirmed']}", flush=True)
    out_json.write_text(json.dumps(doc, indent=1))
    lines = ["# A time drift read through the reference's model (decision 028)", ""]
    lines += study_commands(doc)
    lines += ["", "| zoo | data | scope | t (u - q) on the servo response: gain | p | "
              "significant | material | confirmed | servo response gain | seconds |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        lines.append(f"| {r['zoo']} | {r['data']} | {r['scope']} | {r['total_gain']:+.2f} | "
                     f"{r['p_value']:.2g} | {r['significant']} | {r['material']} | "
                     f"**{r['confirmed']}** | {r['servo_total_gain']:+.2f} | {r['seconds']} |")
    a.out.with_suffix(".md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
