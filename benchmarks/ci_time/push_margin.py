"""The learned route's push case of `make test` (test/diagnose/test_learned.py) with the push
recorded at PER moves per type (the test records 5): prints the report's numbers the test
checks (significant, family, direction, force and its interval, the TestPool rollout before and
after, the p-value). Run from the repository root:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/ci_time/push_margin.py 4
"""
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, "test/diagnose")
sys.path.insert(0, "test")
import test_learned as T  # noqa: E402

from littledog_mlsim.diagnose import DiagnoseOptions, LearnedRoute, diagnose  # noqa: E402

PUSH = "- class: littledog_mlsim.robot.effects:ConstantWind\n  params: {force_xy: [0.0, 1.5]}\n"


def main() -> None:
    root = Path(tempfile.mkdtemp())
    for per in (int(x) for x in sys.argv[1:] or ["4"]):
        push = T._record(root, f"push{per}", PUSH, per)
        clean = root / "clean" if (root / "clean").exists() else T._record(root, "clean", None, 4)
        route = LearnedRoute(max_rounds=0, rollout=T.SMALL, rollout_library=T.LIBRARY)
        rep = diagnose(push, root / f"out{per}", DiagnoseOptions(
            route=route, reference=clean, method="lr", figures=False,
            progress=False))["rollout_route"]
        e = rep["effects"][0]
        ph = e["physical"]
        print(per, rep["significant"], e["family"], "dir", ph["direction_deg"], "force",
              ph["force_N"], ph["push"]["force_interval_N"], "test",
              rep["test"]["before"]["final_xy_error_m"], rep["test"]["after"]["final_xy_error_m"],
              "p", e.get("p_value"))


if __name__ == "__main__":
    main()
