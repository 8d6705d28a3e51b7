"""One physical-route diagnosis against a reference, timed: `make test`'s reference case
(test/diagnose/test_reference.py: a shared 15 ms set-point delay, a 60 % front-left knee, the
`measured` twin, two families), on datasets it records once into WORK.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=CHECKOUT .venv/bin/python benchmarks/diagnose_speed/memo/knee.py \
        --work WORK --out OUT

writes OUT/report.json (the diagnosis's) and OUT/timing.json (wall and CPU seconds of the
diagnosis, this process and its worker processes, and the code it ran)."""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

TYPES = ["F", "L", "R", "S"]
DELAY = "- class: littledog_mlsim.robot.effects:SetpointDelay\n  params: {delay_ms: 15.0}\n"
SOFT_KNEE = ("- class: littledog_mlsim.robot.effects:ServoGain\n"
             "  params: {gain_ratio: 0.6, joints: front_left_knee}\n")
PHYS = dict(fit_per_type=1, validate_per_type=2, test_per_type=1, screen_moves=3, n_refine=2,
            families=["command_delay", "servo_gain"])


def _record(work: Path, name: str, seed: int, effects: str) -> Path:
    from littledog_mlsim.apps.record import record_dataset
    out = work / name
    if not (out / "dataset.yaml").is_file():
        (work / f"{name}.yaml").write_text(effects)
        record_dataset(out, moves_per_type=4, seed=seed, types=TYPES, jobs=2, progress=False,
                       effects_file=str(work / f"{name}.yaml"))
    return out


def _cpu() -> float:
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args()
    import littledog_mlsim
    from littledog_mlsim.diagnose import diagnose
    a.work.mkdir(parents=True, exist_ok=True)
    ref = _record(a.work, "reference", 411, DELAY)
    data = _record(a.work, "changed", 412, DELAY + SOFT_KNEE)
    c0, t0 = _cpu(), time.perf_counter()
    diagnose(data, a.out, method="lr", figures=False, progress=False, twin="measured",
             reference=ref, physics_options=PHYS)
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    src = Path(littledog_mlsim.__file__).resolve().parent.parent
    rev = subprocess.run(["git", "-C", str(src), "describe", "--always", "--dirty"],
                         capture_output=True, text=True).stdout.strip()
    (a.out / "timing.json").write_text(json.dumps(
        {"wall_s": round(wall, 1), "cpu_s": round(cpu, 1), "code": rev,
         "load_after": os.getloadavg()[0]}, indent=1) + "\n")
    print(json.dumps({"wall_s": round(wall, 1), "cpu_s": round(cpu, 1), "code": rev}))


if __name__ == "__main__":
    sys.exit(main())
