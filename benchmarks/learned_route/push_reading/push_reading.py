"""The learned route's push in newtons (``diagnose/push.py``) on the gap zoos' pushes, not blind.

For each case: record the effect on the zoo's gap robot (its seed) and a clean reference of the
same robot (another seed) with ``littledog-mlsim record`` (10 moves per type), unless WORK has
them; measure the drift of the effect's TrainPool against the reference's TrainPool; measure the
``nominal`` robot's push response walking the reference's commands; read the force. Clean cases
(no effect) must read a force whose interval holds 0 N or is small. The true values come from
the zoo's ``truth.yaml`` (zoos whose truth was read before this study).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/push_reading/push_reading.py \
        --work WORK --out benchmarks/learned_route/push_reading/result
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.diagnose.push import (PybulletPushes, drift_against_reference,  # noqa: E402
                                           push_mobility, push_reading)
from littledog_mlsim.diagnose.run import load_moves  # noqa: E402

ZOOS = ROOT / "benchmarks" / "blind_zoo" / "zoos"
#: (zoo, effect id or None for a clean seed, seed, reference seed)
CASES = [("zoo8", "g02", 31, 93), ("zoo9", "g17", 41, 94), ("zoo10", "z06", 51, 95),
         ("zoo11", "z03", 61, 96), ("zoo12", "z11", 71, 97),
         ("zoo8", None, 31, 93), ("zoo10", None, 51, 95), ("zoo12", None, 71, 97)]


def record(out: Path, zoo: str, seed: int, effect: str | None) -> None:
    if (out / "dataset.yaml").exists():
        return
    cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", "10", "--seed", str(seed), "--jobs", "2", "--quiet",
           "--robot", str(ZOOS / zoo / "gap_robot.json")]
    if effect:
        cmd += ["--effects", str(ZOOS / zoo / "effects" / f"{effect}.yaml")]
    subprocess.run(cmd, check=True, cwd=ROOT)


def recorded(work: Path, zoo: str, effect: str | None, seed: int, ref_seed: int
             ) -> tuple[list, list]:
    """(the case's TrainPool, the reference's TrainPool), recording either if WORK lacks it."""
    data = work / f"{zoo}_{effect or 'clean'}_s{seed}"
    ref = work / f"{zoo}_reference_s{ref_seed}"
    record(data, zoo, seed, effect)
    record(ref, zoo, ref_seed, None)
    return load_moves(data, "train"), load_moves(ref, "train")


def run_meta(**extra) -> dict:
    """The command, the date, the load and the commit of this run."""
    return {"command": " ".join(["OPENBLAS_NUM_THREADS=1", ".venv/bin/python"] + sys.argv),
            **extra, "load_after": os.getloadavg()[0],
            "date_utc": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
            "commit": subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                                     capture_output=True, text=True).stdout.strip()}


def truth(zoo: str, effect: str | None) -> dict:
    if effect is None:
        return {"force_N": 0.0, "direction_deg": None}
    doc = yaml.safe_load((ZOOS / zoo / "truth.yaml").read_text())
    for e in doc["effects"] if isinstance(doc, dict) else doc:
        if e["id"] == effect:
            return dict(e["params"])
    raise KeyError(effect)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--out", required=True, help="path stem: writes STEM.json and STEM.md")
    ap.add_argument("--robot", default="nominal",
                    help="the physics robot of the push response; 'gap': each zoo's own gap "
                         "robot (the exact twin, to separate the drift's error from the "
                         "response's)")
    a = ap.parse_args()
    work = Path(a.work)
    sims: dict[str, PybulletPushes] = {}
    rows = []
    for zoo, effect, seed, ref_seed in CASES:
        recs, ref_recs = recorded(work, zoo, effect, seed, ref_seed)
        t0 = time.perf_counter()
        drift = drift_against_reference(recs, ref_recs)
        robot = str(ZOOS / zoo / "gap_robot.json") if a.robot == "gap" else a.robot
        sim = sims.setdefault(robot, PybulletPushes(robot))
        M, n_sim = push_mobility(ref_recs, sim)
        reading = push_reading(drift, M)
        secs = time.perf_counter() - t0
        tr = truth(zoo, effect)
        err = (None if not tr["force_N"] else abs(reading["force_N"] / tr["force_N"] - 1))
        rows.append({"zoo": zoo, "effect": effect or "clean", "seed": seed,
                     "reference_seed": ref_seed, "truth": tr, "drift": drift.to_dict(),
                     "reading": reading, "param_error": err, "mobility_moves": n_sim,
                     "seconds": secs})
        print(f"{zoo} {effect or 'clean'}: {reading['force_N']:.2f} N "
              f"[{reading['force_interval_N'][0]:.2f}, {reading['force_interval_N'][1]:.2f}] "
              f"@ {reading['direction_deg']:.0f} deg; truth {tr}; {secs:.0f} s", flush=True)
    out = Path(a.out)
    meta = run_meta(robot=a.robot)
    out.with_suffix(".json").write_text(json.dumps({"meta": meta, "cases": rows}, indent=1))
    lines = [f"# The push in newtons against a reference, robot response from `{a.robot}`", "",
             f"Command: `{meta['command']}`", "",
             f"Code: {meta['commit']}; {meta['date_utc']} UTC; "
             f"load after {meta['load_after']:.1f}.",
             "", "| zoo | effect | truth | drift against the reference | read | "
             "95 % (drift's scatter) | error |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        t, d, g = r["truth"], r["drift"], r["reading"]
        tt = "none" if not t["force_N"] else f"{t['force_N']:g} N @ {t['direction_deg']:g} deg"
        lines.append(
            f"| {r['zoo']} | {r['effect']} | {tt} | {100 * d['speed_mps']:.2f} cm/s @ "
            f"{d['direction_deg']:.0f} deg | {g['force_N']:.2f} N @ {g['direction_deg']:.0f} deg | "
            f"{g['force_interval_N'][0]:.2f}-{g['force_interval_N'][1]:.2f} N | "
            + ("-" if r["param_error"] is None else f"{100 * r['param_error']:.0f} %") + " |")
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
