"""After zoo14 run1 (not blind): where the unexplained change of a report lives, joint by joint,
and which vocabulary scope a two-level fit of the joints' log ratios would pick.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/blind_zoo/zoos/zoo14/runs/run1/scope_fit/scope_fit.py REPORT.json ...

Each REPORT.json is a diagnosis's report with ``rollout_route.unexplained_change`` (decision
026); its ``scope_ratios`` hold each joint's ratio (its angle and rate against the reference's).
The fit: for each joint scope but ``all``, the sum of squared deviations of the log ratios from
their mean inside the scope and from their mean outside it; the smallest fits best. It is a
measurement for the run's account, not part of the diagnosis.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[7]
sys.path.insert(0, str(ROOT))
from littledog_mlsim.diagnose.families.scopes import joint_scopes, scope_joints  # noqa: E402
from littledog_mlsim.layout import JOINT_NAMES  # noqa: E402

print("Command: `OPENBLAS_NUM_THREADS=1 .venv/bin/python "
      "benchmarks/blind_zoo/zoos/zoo14/runs/run1/scope_fit/scope_fit.py "
      + " ".join(sys.argv[1:]) + "` (the report of run1's WORK)\n")
for path in sys.argv[1:]:
    u = json.loads(Path(path).read_text())["rollout_route"]["unexplained_change"]
    sr = u["scope_ratios"]
    r = np.log(np.array([sr[f"joint:{j}"] for j in JOINT_NAMES]))
    print(f"## {path}\n\nkept scope {u['scope']}, ratio {u['ratio']:.2f}, concentration "
          f"{u['concentration']:.2f}\n")
    print("| joint | ratio |\n|---|---|")
    for j, v in zip(JOINT_NAMES, np.exp(r)):
        print(f"| {j} | {v:.1f} |")
    fits = []
    for s in joint_scopes()[1:]:
        m = np.zeros(len(JOINT_NAMES), bool)
        m[scope_joints(s)] = True
        fits.append((((r[m] - r[m].mean()) ** 2).sum() + ((r[~m] - r[~m].mean()) ** 2).sum(), s))
    fits.sort()
    print("\nSides and joint types (a side's rest is the other side): " + ", ".join(
        f"{s} {sr[s]:.2f}" for s in ("side:left", "side:right", "type:hip_rolls",
                                     "type:hip_pitches", "type:knees"))
          + f"; side:left's concentration {sr['side:left'] / sr['side:right']:.2f}, "
          f"side:right's {sr['side:right'] / sr['side:left']:.2f}")
    print(f"\nTwo-level fit of the log ratios (one level: {((r - r.mean()) ** 2).sum():.2f}), "
          "the best five: " + ", ".join(f"{s} {v:.2f}" for v, s in fits[:5]) + "\n")
