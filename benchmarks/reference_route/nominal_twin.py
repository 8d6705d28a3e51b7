"""The nominal twin against a push, without and with a reference (decision 019).

Records (robot measured; 6 move types x 4 moves) a clean reference (seed 301), data with a
1.5 N push fixed in odom along +y (seed 302) and clean data (seed 303) into WORK, then
diagnoses each dataset named with the nominal twin, without and with the reference::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/reference_route/nominal_twin.py WORK wind clean
"""
import sys, time, json
from pathlib import Path
from littledog_mlsim.apps.record import record_dataset
from littledog_mlsim.diagnose import diagnose
root = Path(sys.argv[1])
TYPES = ["F", "B", "L", "R", "DL", "S"]
PHYS_FAMILIES = ["command_delay", "command_filter", "servo_gain", "joint_friction",
                 "odom_force", "body_wrench", "ground_slope"]
PHYS = dict(fit_per_type=1, validate_per_type=2, test_per_type=1, screen_moves=3, n_refine=4,
            families=PHYS_FAMILIES, max_rounds=1)
def rec(name, seed, effects=None, exc=0.0):
    out = root / name
    if (out / "dataset.yaml").exists():
        return out
    ef = None
    if effects:
        ef = root / f"{name}.yaml"; ef.write_text(effects)
    record_dataset(out, moves_per_type=4, seed=seed, types=TYPES, effects_file=None if ef is None else str(ef),
                   jobs=2, progress=False, excitation=exc)
    return out
ref = rec("ref", 301)
wind = rec("wind", 302, "- class: littledog_mlsim.robot.effects:ConstantWind\n  params: {force_xy: [0.0, 1.5]}\n")
clean = rec("clean", 303)
for data in sys.argv[2:]:
    for arm in (["nominal", None], ["nominal", ref]):
        t0 = time.time()
        tag = f"{data}_{'ref' if arm[1] else 'noref'}"
        r = diagnose(root / data, root / f"out_{tag}", method="lr", figures=False, progress=True,
                     physics="auto", physics_options=PHYS, twin=arm[0], reference=arm[1])
        print("RESULT", tag, f"{time.time()-t0:.0f}s", r["significant"],
              [e["physical"]["statement"] for e in r["effects"]],
              json.dumps(r["physics"].get("reference", {}).get("twin_errors", []), default=str)[:600], flush=True)
