"""What the motion-capture noise readings take for noise on zoo37's gap robot (not blind).

The gap robot records 2 moves per type (seed 287) twice, with ``littledog-mlsim record``: with
its own sensing, and with ``sensor_noise`` off (a copy of its twin file). The readings the
bootstrap starts from (``twin_bias.orientation_noise``, ``twin_fit.pose_noise``) read both;
on the noise-free recording all they read is motion. Recordings go to a temporary directory.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo37/runs/after_run1/noise_reading.py \
        benchmarks/blind_zoo/zoos/zoo37/runs/after_run1/noise_reading.json
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot.twin_bias import orientation_noise
from littledog_mlsim.robot.twin_fit import pose_noise

GAP = Path(__file__).resolve().parents[2] / "gap_robot.json"


def main(out: str) -> None:
    doc = json.loads(GAP.read_text())
    result = {"gap_robot": {k: doc["robot"][k]
                            for k in ("mocap_position_std", "mocap_orientation_std")},
              "command": "littledog-mlsim record --robot ROBOT --out DIR --moves-per-type 2 "
                         "--jobs 2 --seed 287"}
    with tempfile.TemporaryDirectory() as tmp:
        quiet = Path(tmp) / "quiet.json"
        doc["robot"]["sensor_noise"] = False
        quiet.write_text(json.dumps(doc))
        for label, robot in (("with_noise", GAP), ("noise_free", quiet)):
            data = Path(tmp) / label
            subprocess.run([sys.executable, "-m", "littledog_mlsim.cli", "record", "--robot",
                            str(robot), "--out", str(data), "--moves-per-type", "2", "--jobs",
                            "2", "--seed", "287"], check=True, capture_output=True)
            recs = load_moves(data, "train")
            result[label] = {"moves": len(recs), "orientation_noise_rad": orientation_noise(recs),
                             "pose_noise_m": pose_noise(recs)}
            print(label, json.dumps(result[label]), flush=True)
    json.dump(result, open(out, "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1])
