"""Check zoo45 (SEALED): every effect changes the recordings materially, and nothing falls.

For every effect, its dataset is compared move by move with the clean dataset of the same seed
and excitation (the same gait commands and sensor-noise draws), and so is the control
(control.yaml, a negligible perturbation). Measures, averaged over the moves:

- ``state``: RMS over steps and the 33 state elements of the difference in states, each element
  divided by its standard deviation in the clean dataset;
- ``xy``: distance between the final (x, y) positions [m].

An effect is visible if its ``state`` is at least ``--ratio`` (3) times the control's and at
least ``--floor`` (0.05). A move falls if the body drops below 0.1 m above the floor or its z
axis leans more than 26 deg from vertical; every dataset is checked (clean, control, effects,
the reference where present).

    # small: records 3 moves per type itself into WORK (--jobs 2)
    PYTHONPATH=. .venv/bin/python benchmarks/blind_zoo/zoos/zoo45/check_visible.py --small \\
        --work WORK_SMALL
    # full: the datasets the harness recorded in WORK (records the control there too)
    PYTHONPATH=. .venv/bin/python benchmarks/blind_zoo/zoos/zoo45/check_visible.py --work WORK

Writes check_small.md/json (--small) or check.md/json beside this file.
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

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[3]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.data.states import states_from_recording  # noqa: E402

SEED = 361
ROBOT = HERE / "gap_robot.json"
MIN_HEIGHT = 0.1
MAX_TILT_DEG = 26.0


def record(out: Path, moves: int, seed: int, exc: float, effects: Path | None) -> float:
    if (out / "dataset.yaml").is_file():
        return 0.0
    cmd = [sys.executable, "-P", "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(moves), "--seed", str(seed), "--jobs", "2", "--quiet",
           "--robot", str(ROBOT)]
    if exc:
        cmd += ["--excitation", f"{exc:g}"]
    if effects is not None:
        cmd += ["--effects", str(effects)]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL)
    forget_robot(out)
    return time.perf_counter() - t0


def forget_robot(path: Path) -> None:
    """Remove the recording robot's identity from ``dataset.yaml``, as the harness does."""
    index = path / "dataset.yaml"
    doc = yaml.safe_load(index.read_text())
    for k in ("robot", "twin", "robot_config"):
        (doc.get("info") or {}).pop(k, None)
    index.write_text(yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))


def floor_normal(floor: dict | None) -> np.ndarray:
    if not floor:
        return np.array([0.0, 0.0, 1.0])
    s, phi = np.radians(floor["slope_deg"]), np.radians(floor["uphill_direction_deg"])
    # the plane's normal after turning about (sin phi, -cos phi, 0) by s
    return np.array([-np.sin(s) * np.cos(phi), -np.sin(s) * np.sin(phi), np.cos(s)])


def falls(moves: list, floor: dict | None = None) -> list[str]:
    n = floor_normal(floor)
    out = []
    for rec in moves:
        pos = np.asarray(rec.position)
        o = np.asarray(rec.orientation)
        zz = 1.0 - 2.0 * (o[:, 0] ** 2 + o[:, 1] ** 2)      # z of the body's z axis
        height = pos @ n
        if (not np.all(np.isfinite(pos)) or height.min() < MIN_HEIGHT
                or zz.min() < np.cos(np.radians(MAX_TILT_DEG))):
            out.append(rec.name)
    return out


def compare(moves: list, clean: dict, std: np.ndarray) -> dict:
    st, xy = [], []
    for rec in moves:
        c = clean[rec.name]
        d = (states_from_recording(rec) - states_from_recording(c)) / std
        st.append(float(np.sqrt(np.mean(d ** 2))))
        xy.append(float(np.linalg.norm(np.asarray(rec.position)[-1, :2]
                                       - np.asarray(c.position)[-1, :2])))
    return {"state": float(np.mean(st)), "xy": float(np.mean(xy))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--small", action="store_true", help="record 3 moves per type here")
    ap.add_argument("--ratio", type=float, default=3.0)
    ap.add_argument("--floor", type=float, default=0.05)
    ap.add_argument("--only", default="")
    a = ap.parse_args(argv)
    work = Path(a.work)
    sys.path.insert(0, str(HERE))
    from effect_specs import specs
    only = {s for s in a.only.split(",") if s}
    sp = [s for s in specs() if not only or s["id"] in only]
    excs = sorted({0.0} | {s["excitation"] for s in sp})
    moves = 3 if a.small else 10
    secs = 0.0
    clean_dir = {e: work / "clean" / f"s{SEED}_e{e:g}" for e in excs}
    control_dir = {e: work / "control" / f"s{SEED}_e{e:g}" for e in excs}
    eff_dir = {s["id"]: work / "effects" / s["id"] for s in sp}
    for e in excs:
        if a.small:
            secs += record(clean_dir[e], moves, SEED, e, None)
        secs += record(control_dir[e], moves, SEED, e, HERE / "control.yaml")
    if a.small:
        for s in sp:
            secs += record(eff_dir[s["id"]], moves, SEED, s["excitation"],
                           HERE / "effects" / f"{s['id']}.yaml")
    result = {"mode": "small" if a.small else "full", "moves_per_type": moves,
              "record_seconds": round(secs, 1), "effects": [], "falls": {}}
    base = {}
    for e in excs:
        cm = load_moves(clean_dir[e], "all")
        clean = {r.name: r for r in cm}
        std = np.concatenate([states_from_recording(r) for r in cm]).std(axis=0)
        std = np.where(std < 1e-9, 1.0, std)
        ctrl = load_moves(control_dir[e], "all")
        base[e] = (clean, std, compare(ctrl, clean, std))
        result["falls"][f"clean_e{e:g}"] = falls(cm)
        result["falls"][f"control_e{e:g}"] = falls(ctrl)
    if not a.small:
        for d in sorted((work / "clean").iterdir()):
            if (d / "dataset.yaml").is_file() and f"clean_{d.name}" not in result["falls"]:
                result["falls"][f"clean_{d.name}"] = falls(load_moves(d, "all"))
        if (work / "reference" / "dataset.yaml").is_file():
            result["falls"]["reference"] = falls(load_moves(work / "reference", "all"))
    for s in sp:
        clean, std, ctrl = base[s["excitation"]]
        em = load_moves(eff_dir[s["id"]], "all")
        m = compare(em, clean, std)
        fell = falls(em, s.get("floor"))
        result["falls"][s["id"]] = fell
        visible = m["state"] >= a.ratio * ctrl["state"] and m["state"] >= a.floor
        result["effects"].append({"id": s["id"], "excitation": s["excitation"], **m,
                                  "control_state": ctrl["state"], "control_xy": ctrl["xy"],
                                  "ratio": m["state"] / ctrl["state"], "visible": visible,
                                  "falls": len(fell)})
    n_vis = sum(r["visible"] for r in result["effects"])
    n_fall = sum(len(v) for v in result["falls"].values())
    result["summary"] = {"effects": len(result["effects"]), "visible": n_vis,
                         "datasets checked for falls": len(result["falls"]),
                         "moves that fell": n_fall,
                         "passed": n_vis == len(result["effects"]) and n_fall == 0}
    lines = [f"# zoo45 check ({result['mode']}, {moves} moves per type, seed {SEED})", "",
             "| effect | exc. | state diff (x std) | control | ratio | final xy diff [m] "
             "| control xy [m] | visible | falls |", "|---|---|---|---|---|---|---|---|---|"]
    for r in result["effects"]:
        lines.append(f"| {r['id']} | {r['excitation']:g} | {r['state']:.3f} | "
                     f"{r['control_state']:.3f} | {r['ratio']:.1f} | {r['xy']:.3f} | "
                     f"{r['control_xy']:.3f} | {'yes' if r['visible'] else 'NO'} | "
                     f"{r['falls']} |")
    lines += ["", "Falls per dataset: " + ", ".join(f"{k} {len(v)}"
                                                    for k, v in result["falls"].items()), "",
              "Summary: " + "; ".join(f"{k} {v}" for k, v in result["summary"].items()), ""]
    stem = "check_small" if a.small else "check"
    (HERE / f"{stem}.md").write_text("\n".join(lines))
    (HERE / f"{stem}.json").write_text(json.dumps(result, indent=1) + "\n")
    print("\n".join(lines))
    return 0 if result["summary"]["passed"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
