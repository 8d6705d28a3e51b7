"""One variant of ``test/diagnose/test_reference.py``'s change case, timed: record its reference
and changed datasets as the test does, diagnose with the physical route against the reference,
print the progress lines (each round's wall time), the twin errors, the finding and what is
left. Run from the repository root:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/ci_time/reference_case/variant.py \
        --twin-error delay --families command_delay,command_filter,servo_gain

``--twin-error``: the effect the reference shares (``delay``: set-points 15 ms late;
``tether``: the test module's 3 N force fixed in odom); the changed data add the module's soft
front-left knee. ``--types``: the move types recorded (default the module's five).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path[:0] = ["test/diagnose", "test"]
import test_reference as T  # noqa: E402

from littledog_mlsim.diagnose import diagnose  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--twin-error", choices=("delay", "tether"), default="delay")
    ap.add_argument("--families", default=",".join(T.FAMILIES))
    ap.add_argument("--types", default=",".join(T.TYPES))
    a = ap.parse_args()
    T.TYPES = a.types.split(",")
    shared = T.DELAY if a.twin_error == "delay" else T.TETHER
    root = Path(tempfile.mkdtemp(prefix="reference_case"))
    t = time.perf_counter()
    ref = T._record(root, "reference", 411, shared)
    changed = T._record(root, "changed", 412, shared + T.SOFT_KNEE)
    print(f"recorded in {time.perf_counter() - t:.1f} s", flush=True)
    t, c = time.perf_counter(), time.process_time()
    rep = diagnose(changed, root / "out", method="lr", figures=False, progress=True,
                   twin="measured", reference=ref,
                   physics_options={**T.PHYS, "families": a.families.split(",")})
    print(f"diagnosed in {time.perf_counter() - t:.1f} s (main process CPU "
          f"{time.process_time() - c:.1f} s)")
    r = rep["physics"]["reference"]
    print("twin errors:", [(e["family"], e["scope"], e["params"], e["changed"])
                           for e in r["twin_errors"]])
    print("effects:", [(e["physical"]["family"], e["physical"]["scope"], e["physical"]["params"])
                       for e in rep["effects"]])
    print("unexplained: significant", r["unexplained"]["significant"], "material",
          r["unexplained"]["material"])


if __name__ == "__main__":
    main()
