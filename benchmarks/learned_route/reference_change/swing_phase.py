"""Where a swing drag shows: the reference's one-step model on the data, split by gait phase.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/swing_phase.py --reference WORK/reference \
        --data WORK/effects/z08 WORK/clean/s101_e0 --label zoo16 --out OUT

A lead, not a decision: decision 027 locates a change by each move's one-step error of the
reference's model per joint element, over all rows, and no swing drag of zoo14-16 concentrated
enough to be screened. Here the search model fitted on the whole reference (measured robot's
start features) predicts each dataset's next step; for each leg, the mean squared residual of its
three joints' angles and rates is divided by the reference's own held-out one, separately on
rows where the leg is commanded to swing (commanded lift over ``SWING_LIFT_M`` above 0.5) and
where it stands (no commanded lift); the ratio is the mean over the six elements. Writes
OUT.md and OUT.json (appending rows where OUT.json exists).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

from _common import appended_study, study_commands  # noqa: E402

import numpy as np  # noqa: E402

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.diagnose.candidates import measured_robot_features  # noqa: E402
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route  # noqa: E402
from littledog_mlsim.layout import N_STATE, S  # noqa: E402
from littledog_mlsim.models.feature_library import SWING_LIFT_M, _commanded_lift  # noqa: E402

LEGS = ("front_left", "front_right", "back_left", "back_right")


def _swing(X: np.ndarray) -> np.ndarray:
    return np.clip(_commanded_lift(X[:, N_STATE:N_STATE + 12]) / SWING_LIFT_M, 0.0, 1.0)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--reference", type=Path, required=True)
    p.add_argument("--data", type=Path, nargs="+", required=True)
    p.add_argument("--label", required=True)
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args()
    opts, start = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    ref = _Route(load_moves(a.reference, "train"), start, opts, quiet)
    ref_model, ev_ref = ref.fit(start, one_step=True)
    Xr, _, _ = start.features_responses(ref.train)
    wr = _swing(Xr)
    out_json = a.out.with_suffix(".json")
    doc = appended_study(out_json)
    for d in a.data:
        r = _Route(load_moves(d, "train"), start, opts, quiet)
        X, Y, _ = start.features_responses(r.train)
        R = (Y - X[:, :N_STATE]) - ref_model.predict(X, -1)
        w = _swing(X)
        row = {"zoo": a.label, "data": d.name}
        for leg, name in enumerate(LEGS):
            js = [3 * leg + k for k in range(3)]
            cols = [S.q.start + j for j in js] + [S.dq.start + j for j in js]
            for phase, m, mr in (("swing", w[:, leg] > 0.5, wr[:, leg] > 0.5),
                                 ("stance", w[:, leg] == 0, wr[:, leg] == 0)):
                num = (R[m][:, cols] ** 2).mean(axis=0)
                den = (ev_ref.one_step[mr][:, cols] ** 2).mean(axis=0)
                row[f"{name} {phase}"] = round(float(np.mean(num / den)), 2)
        doc["rows"].append(row)
        print(row, flush=True)
    out_json.write_text(json.dumps(doc, indent=1))
    keys = [f"{n} {ph}" for n in LEGS for ph in ("swing", "stance")]
    lines = ["# The reference's one-step model on the data, by leg and gait phase", ""]
    lines += study_commands(doc)
    lines += ["", "| zoo | data | " + " | ".join(keys) + " |", "|---|---|" + "---|" * len(keys)]
    lines += [f"| {r['zoo']} | {r['data']} | " + " | ".join(f"{r[k]:.2f}" for k in keys) + " |"
              for r in doc["rows"]]
    a.out.with_suffix(".md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
