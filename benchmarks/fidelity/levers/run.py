"""Model-input levers against the fidelity targets: each feature set's LGPR under the same
schedules and seeds.

For each lever (``--levers``) this trains an LGPR on the dataset's TrainPool with that feature
set (the paper's 45 inputs plus the lever's augmentations, ``models.feature_library``), then
runs ``fidelity.py open-loop --scenarios straight`` (the 60 s straight trot) and ``fidelity.py
closed-loop --controllers velocity`` (the PI velocity tracker) with the gated alpha-PROJ
(``lgpr-gated``) on ``--seeds``, and tabulates gap / path (median and worst seed), the final
yaw error and the learned path. The levers:

- ``paper``: the paper's 45 inputs (the baseline);
- ``measured``: ``train --features measured`` (the previous state as well);
- ``command_increment``: u_t - u_{t-1} of every joint (the set-points' rate, which carries the
  commanded turn of the feet);
- ``command_lag8``: u_{t-8} of every joint (the set-points about a quarter gait period ago).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/fidelity/levers/run.py \\
        --data bags/default --work WORK --out benchmarks/fidelity/levers/result
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from benchmarks._common import command_line, run_record, uptime, write_results  # noqa: E402

LEVERS = ("paper", "measured", "command_increment", "command_lag8")


def feature_set(lever: str):
    from littledog_mlsim.models.feature_library import CommandIncrement, CommandLag
    from littledog_mlsim.models.features import FeatureSet
    if lever == "paper":
        return None
    if lever == "measured":
        from littledog_mlsim.diagnose.candidates import measured_robot_features
        return measured_robot_features()
    if lever == "command_increment":
        return FeatureSet((CommandIncrement(lag=0, joints="all"),))
    if lever == "command_lag8":
        return FeatureSet((CommandLag(lag=8, joints="all"),))
    raise SystemExit(f"unknown lever {lever!r}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--work", type=Path, required=True,
                    help="models (reused when present) and each fidelity run's files")
    ap.add_argument("--levers", nargs="+", default=list(LEVERS), choices=LEVERS)
    ap.add_argument("--seeds", nargs="+", default=["0", "1", "2"])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--duration", default=None, help="s, both schedules (default: fidelity.py's)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from littledog_mlsim.models.train import train_from_dataset
    a.work.mkdir(parents=True, exist_ok=True)
    doc = run_record("fidelity/levers/run.py", argv)
    lr = a.work / "lr"
    if not lr.exists():
        train_from_dataset(a.data, "lr", progress=False).save(lr)
    rows = []
    for lever in a.levers:
        model = a.work / f"lgpr_{lever}"
        t0 = time.perf_counter()
        if not model.exists():
            train_from_dataset(a.data, "lgpr", progress=False,
                               feature_set=feature_set(lever)).save(model)
        train_s = time.perf_counter() - t0
        row = {"lever": lever, "train_s": round(train_s, 1), "load": uptime()}
        for what, extra, key in (
                ("open-loop", ["--scenarios", "straight"], "straight/lgpr-gated"),
                ("closed-loop", ["--controllers", "velocity"], "velocity/lgpr-gated")):
            out = a.work / f"{what}_{lever}"
            subprocess.run([sys.executable, str(ROOT / "benchmarks/fidelity/fidelity.py"), what,
                            "--data", str(a.data), "--lgpr", str(model), "--lr", str(lr),
                            "--configs", "lgpr-gated", "--seeds", *a.seeds,
                            "--workers", str(a.workers), "--out", str(out), *extra,
                            *(["--duration", a.duration] if a.duration else [])],
                           check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
            res = json.loads(out.with_suffix(".json").read_text())
            s = res["summary"][key]
            row[what] = {k: s.get(k) for k in ("err_per_m", "err_per_m_max", "final_err_m",
                                                "path_m", "path_learned_m",
                                                "final_yaw_err_rad", "rms_w", "rms_w_pybullet")}
            row[what]["per_seed_err_per_m"] = {str(r["seed"]): r["err_per_m"]
                                               for r in res["runs"]}
        rows.append(row)
        print(lever, json.dumps(row), flush=True)
    doc["rows"] = rows
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}; seeds "
             f"{' '.join(a.seeds)}", "",
             "| lever | straight 60 s: gap / path, median (worst) | final yaw error | learned / "
             "pybullet path | velocity tracker 40 s: gap / path, median (worst) | train [s] | "
             "load |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        o, c = r["open-loop"], r["closed-loop"]
        lines.append(f"| {r['lever']} | {100 * o['err_per_m']:.1f} % ({100 * o['err_per_m_max']:.1f} %)"
                     f" | {o['final_yaw_err_rad']:.3f} rad | {o['path_learned_m']:.2f} / "
                     f"{o['path_m']:.2f} m | {100 * c['err_per_m']:.1f} % "
                     f"({100 * c['err_per_m_max']:.1f} %) | {r['train_s']} | `{r['load']}` |")
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
