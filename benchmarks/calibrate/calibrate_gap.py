"""Calibrate a twin on a robot whose parameters are known only to this script: coverage and time.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/calibrate_gap.py \
        [--work /tmp/calibrate_gap] [--moves-per-type 20] [--max-evals 80] [--jobs 2] \
        [--name calibrate_gap] [--no-sensor-noise] [--initial-state measured]

1. Writes ``gap_robot.json``: the ``measured`` robot (torque-mode PD, sensor noise) with five
   parameters moved by 7-20 % (body mass, hip-pitch and knee stiffness, knee damping, knee
   torque limit).
2. Records the reference with ``littledog-mlsim record --robot gap_robot.json`` (all 11 types).
3. Runs ``littledog-mlsim calibrate --robot measured`` on it, fitting those five parameters.
4. Writes ``NAME.json`` (the twin's provenance, truth, coverage, times) and ``NAME.md`` (the
   table), NAME ``calibrate_gap`` unless ``--name`` says otherwise.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import resource
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import ROOT, git_state  # noqa: E402

from littledog_mlsim.fileio import atomic_write_text  # noqa: E402
from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.parameters import TWIN_PARAMETERS  # noqa: E402
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin  # noqa: E402

HERE = Path(__file__).resolve().parent
PARAMS = ("body_mass", "kp_hip_pitch", "kp_knee", "kd_knee", "torque_limit_knee")


def gap_robot(sensor_noise: bool = True):
    m = robot_config("measured")
    return dataclasses.replace(m, name="gap", body_mass=2.45, kp=(7.5, 8.3, 5.8),
                               kd=(0.32, 0.32, 0.27), torque_limit=(1.7, 1.7, 0.55),
                               sensor_noise=sensor_noise and m.sensor_noise)


def run(cmd: list[str]) -> tuple[float, float, str]:
    """(wall s, child CPU s, stdout) of a littledog-mlsim command."""
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "littledog_mlsim.cli", *cmd], cwd=ROOT,
                       capture_output=True, text=True)
    wall = time.perf_counter() - t0
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed: {p.stderr.strip()}")
    return wall, (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime), p.stdout


def table(doc: dict) -> str:
    rows = ["| parameter | truth | start | calibrated | 95 % interval | truth inside | unit |",
            "|---|---|---|---|---|---|---|"]
    for name, c in doc["coverage"].items():
        lo, hi = c["ci95"]
        rows.append(f"| {name} | {c['truth']:.4g} | {c['start']:.4g} | {c['value']:.4g} | "
                    f"[{lo:.4g}, {hi:.4g}] | {'yes' if c['inside'] else 'no'} | {c['unit']} |")
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", type=Path, default=Path("/tmp/calibrate_gap"))
    ap.add_argument("--moves-per-type", type=int, default=20)
    ap.add_argument("--max-evals", type=int, default=80)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--name", default="calibrate_gap",
                    help="result files NAME.json and NAME.md in this folder")
    ap.add_argument("--no-sensor-noise", action="store_true",
                    help="record the gap robot without sensor noise (its robot file then "
                         "goes to WORK)")
    ap.add_argument("--initial-state", choices=("measured", "smoothed"), default="measured",
                    help="calibrate's --initial-state")
    a = ap.parse_args()
    a.work.mkdir(parents=True, exist_ok=True)
    gap = gap_robot(not a.no_sensor_noise)
    robot_file = a.work / "gap_robot.json" if a.no_sensor_noise else HERE / "gap_robot.json"
    save_twin(Twin(gap, {"note": "benchmarks/calibrate: the robot calibrate must recover"}),
              robot_file)
    data, out = a.work / "reference", a.work / "twin.json"
    rec_wall, rec_cpu, _ = run(["record", "--out", str(data), "--robot",
                                str(robot_file), "--moves-per-type",
                                str(a.moves_per_type), "--jobs", str(a.jobs), "--overwrite",
                                "--quiet"])
    cal_cmd = ["calibrate", "--data", str(data), "--robot", "measured", "--out", str(out),
               "--params", ",".join(PARAMS), "--max-evals", str(a.max_evals),
               "--jobs", str(a.jobs), "--initial-state", a.initial_state, "--quiet"]
    cal_wall, cal_cpu, stdout = run(cal_cmd)
    twin = load_twin(out)
    coverage = {}
    for name in PARAMS:
        e = twin.provenance["parameters"][name]
        truth = TWIN_PARAMETERS[name].get(gap)
        lo, hi = e["ci95"]
        coverage[name] = {**e, "truth": truth, "inside": lo is not None and hi is not None
                          and lo <= truth <= hi}
    doc = {"command": "OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/"
                      f"calibrate_gap.py --moves-per-type {a.moves_per_type} "
                      f"--max-evals {a.max_evals} --jobs {a.jobs}"
                      + ("" if a.name == "calibrate_gap" else f" --name {a.name}")
                      + (" --no-sensor-noise" if a.no_sensor_noise else "")
                      + (f" --initial-state {a.initial_state}"
                         if a.initial_state != "measured" else ""),
           "calibrate_command": "littledog-mlsim " + " ".join(cal_cmd),
           "code": git_state(), "when": datetime.now(timezone.utc).isoformat(timespec="seconds"),
           "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                       "load_average_at_end": os.getloadavg()},
           "record": {"wall_s": round(rec_wall, 1), "cpu_s": round(rec_cpu, 1)},
           "calibrate": {"wall_s": round(cal_wall, 1), "cpu_s": round(cal_cpu, 1)},
           "coverage": coverage,
           "n_inside": sum(c["inside"] for c in coverage.values()),
           "calibration": twin.provenance["calibration"], "stdout": stdout}
    atomic_write_text(HERE / f"{a.name}.json", json.dumps(doc, indent=2) + "\n")
    roll = doc["calibration"].get("rollout", {})
    md = [f"# calibrate on the gap robot", "", f"Command: `{doc['command']}`", "",
          f"Code: {doc['code']}; {doc['when']}; load average at the end "
          f"{', '.join(f'{v:.1f}' for v in doc['machine']['load_average_at_end'])} on "
          f"{doc['machine']['cpus']} CPUs.", "", table(doc), "",
          f"Truth inside its 95 % interval: {doc['n_inside']} of {len(PARAMS)}.", "",
          "Not identified: " + ("; ".join(w["describe"] for w in
                                          doc["calibration"]["weak_directions"]) or "none"),
          "", f"TestPool rollout final (x, y) error, {len(roll.get('test_moves', []))} moves: "
          f"{roll.get('before', {}).get('final_xy_error_m')} m (measured, uncalibrated) -> "
          f"{roll.get('after', {}).get('final_xy_error_m')} m (calibrated).", "",
          f"Residual variance at the optimum {doc['calibration']['residual_variance']:.3f}; "
          f"{doc['calibration']['n_evals']} re-simulations of "
          f"{len(doc['calibration']['train_moves'])} TrainPool moves.", "",
          f"Time: record {doc['record']['wall_s']} s wall ({doc['record']['cpu_s']} s CPU); "
          f"calibrate {doc['calibrate']['wall_s']} s wall ({doc['calibrate']['cpu_s']} s CPU), "
          f"{a.jobs} worker processes on a shared machine.", ""]
    atomic_write_text(HERE / f"{a.name}.md", "\n".join(md))
    print("\n".join(md))


if __name__ == "__main__":
    main()
