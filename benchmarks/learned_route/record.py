"""Record the planted-effect and clean datasets of the learned-route study.

    .venv/bin/python benchmarks/learned_route/record.py --work /tmp/learned_route_data

One dataset per effects file in ``effects/`` (seed 1) and clean datasets of seeds 1 and 2, plain
and (for the command-history effect, recorded with 0.05 rad command excitation) excited.
Existing datasets are kept (delete one to record it again).
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
# effect name -> command excitation [rad] it is recorded with
EFFECTS = {"wind": 0.0, "wind2": 0.0, "delay_leg": 0.05, "tilt": 0.0, "drift": 0.0}
CLEAN = {"clean_s1": (1, 0.0), "clean_s2": (2, 0.0), "clean_s1_excited": (1, 0.05),
         "clean_s2_excited": (2, 0.05)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", required=True, help="directory for the datasets")
    ap.add_argument("--moves-per-type", type=int, default=8)
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args(argv)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from littledog_mlsim.apps.record import record_dataset
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    plan = [(n, 1, x, HERE / "effects" / f"{n}.yaml") for n, x in EFFECTS.items()]
    plan += [(n, s, x, None) for n, (s, x) in CLEAN.items()]
    for name, seed, excitation, eff in plan:
        if (work / name).exists():
            print(f"{name}: exists, kept", file=sys.stderr)
            continue
        summary = record_dataset(work / name, moves_per_type=args.moves_per_type, seed=seed,
                                 effects_file=None if eff is None else str(eff),
                                 jobs=args.jobs, progress=False, excitation=excitation)
        print(f"{name}: recorded ({summary})", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
