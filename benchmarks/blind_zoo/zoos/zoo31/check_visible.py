"""Check that every effect of zoo31 changes its recordings materially, and that no move falls.

Each effect dataset (WORK/effects/<id>, recorded by harness/run.py --record-only) is compared
move by move with the clean dataset of the same seed and excitation (WORK/clean/s<seed>_e<exc>):
the same seed gives the same commands and sensor-noise stream, so every difference is the
effect's, plus the divergence any perturbation of a walking robot grows into. That floor is
measured with control datasets recorded under a negligible perturbation (WORK/control/null_e<exc>,
a 1 mN pull on the body, made by this script with `record` if missing):

- final_xy_m: per move, |(x, y)_end - (x, y)_start| effect minus clean [m];
- final_yaw_rad: per move, |yaw_end effect - yaw_end clean| [rad];
- rms_body / rms_q / rms_dq: per move, the RMS over its samples of the state difference (the paper's 33
  states: 9 body states, 12 joint angles, 12 joint rates), each element divided by its standard
  deviation in the clean data (1.0 = as large as the state's own variation).

Each metric is reported as the mean over moves and the median over moves (a few moves, the
trots in place, diverge under any perturbation, which the mean of the control shows). An effect
is visible when, for the mean or for the median, one of the state metrics is at least 0.25 (a
quarter of the state's own spread) and at least 3x the control's same statistic, or final_xy_m
is at least 0.02 m and at least 3x the control's.

A move falls when the body drops below 0.115 m, tilts (roll or pitch) beyond 0.35 rad, or holds
a non-finite value (the clean gap robot stays above 0.13 m and within 0.14 rad; a move that
stumbles into a lasting crouched tilt counts as a fall). Every dataset under WORK/effects,
WORK/clean, WORK/reference and WORK/control is checked.

Run from the repository root (CPU-light; the control recording is not):
  nice -n 19 env OPENBLAS_NUM_THREADS=1 .venv/bin/python \
      benchmarks/blind_zoo/zoos/zoo31/check_visible.py --work WORK
Writes check.json and check.md beside this script.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[4]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.data.states import states_from_recording  # noqa: E402
from littledog_mlsim.rotations import quat_to_rpy  # noqa: E402

HERE = Path(__file__).resolve().parent
STATE_MIN = 0.25
XY_MIN = 0.02
RATIO_MIN = 3.0
FALL_Z = 0.115
FALL_TILT = 0.35
GROUPS = {"rms_body": slice(0, 9), "rms_q": slice(9, 21), "rms_dq": slice(21, 33)}


def moves(path: Path) -> dict:
    return {r.name: r for r in load_moves(path, "all")}


def compare(eff: dict, clean: dict) -> dict:
    names = sorted(set(eff) & set(clean))
    s_c = {n: states_from_recording(clean[n]) for n in names}
    std = np.vstack(list(s_c.values())).std(axis=0)
    std[std < 1e-9] = 1.0
    per = {k: [] for k in (*GROUPS, "final_xy_m", "final_yaw_rad")}
    by_type: dict = {}
    for n in names:
        d = (states_from_recording(eff[n]) - s_c[n]) / std
        for k, sl in GROUPS.items():
            per[k].append(float(np.sqrt(np.mean(d[:, sl] ** 2))))
        a, b = eff[n], clean[n]
        dxy = float(np.linalg.norm((a.position[-1, :2] - a.position[0, :2])
                                   - (b.position[-1, :2] - b.position[0, :2])))
        ya, yb = quat_to_rpy(a.orientation[-1:])[0, 2], quat_to_rpy(b.orientation[-1:])[0, 2]
        per["final_xy_m"].append(dxy)
        per["final_yaw_rad"].append(float(abs((ya - yb + np.pi) % (2 * np.pi) - np.pi)))
        by_type.setdefault(a.move_type, []).append(dxy)
    out = {k: float(np.mean(v)) for k, v in per.items()}
    out["median"] = {k: float(np.median(v)) for k, v in per.items()}
    out["final_xy_m_by_type"] = {t: float(np.mean(v)) for t, v in by_type.items()}
    out["moves"] = len(names)
    return out


def falls(path: Path) -> dict:
    bad = []
    zmin, tilt = np.inf, 0.0
    recs = load_moves(path, "all")
    for r in recs:
        arrays = (r.position, r.orientation, r.q, r.dq)
        if not all(np.all(np.isfinite(x)) for x in arrays):
            bad.append(r.name + " (non-finite)")
            continue
        rpy = quat_to_rpy(r.orientation)
        z, t = float(r.position[:, 2].min()), float(np.abs(rpy[:, :2]).max())
        zmin, tilt = min(zmin, z), max(tilt, t)
        if z < FALL_Z or t > FALL_TILT:
            bad.append(r.name)
    return {"moves": len(recs), "fallen": bad, "min_body_z_m": zmin, "max_tilt_rad": tilt}


def ensure_control(work: Path, seed: int, exc: float, robot: Path, moves_per_type: int) -> Path:
    out = work / "control" / f"null_e{exc:g}"
    if (out / "dataset.yaml").is_file():
        return out
    eff = work / "control" / "null.yaml"
    eff.parent.mkdir(parents=True, exist_ok=True)
    eff.write_text(f"- class: {HERE / 'plugins.py'}:TetherPull\n"
                   f"  params: {{force_N: 0.001, direction_deg: 0.0}}\n")
    cmd = [sys.executable, "-P", "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(moves_per_type), "--seed", str(seed), "--jobs", "1",
           "--quiet", "--robot", str(robot), "--effects", str(eff)]
    if exc:
        cmd += ["--excitation", f"{exc:g}"]
    subprocess.run(cmd, check=True, cwd=ROOT, env={**__import__("os").environ,
                                                  "PYTHONPATH": str(ROOT)})
    return out


def visible(m: dict, ctrl: dict) -> tuple[bool, str]:
    """Visible on the mean over moves, or on the median over moves (robust to the few moves
    that diverge under any perturbation), against the control's same statistic."""
    reasons = []
    for stat, get in (("mean", lambda d: d), ("median", lambda d: d["median"])):
        e, c = get(m), get(ctrl)
        for k in GROUPS:
            if e[k] >= STATE_MIN and e[k] >= RATIO_MIN * c[k]:
                reasons.append(f"{stat} {k} {e[k]:.2f} ({e[k] / max(c[k], 1e-12):.0f}x control)")
        if e["final_xy_m"] >= XY_MIN and e["final_xy_m"] >= RATIO_MIN * c["final_xy_m"]:
            reasons.append(f"{stat} final_xy {e['final_xy_m'] * 100:.1f} cm "
                           f"({e['final_xy_m'] / max(c['final_xy_m'], 1e-12):.0f}x control)")
    return bool(reasons), "; ".join(reasons)


def _cells(m: dict) -> str:
    med = m["median"]
    return " | ".join([f"{m[k]:.3f} / {med[k]:.3f}" for k in GROUPS]
                      + [f"{m['final_xy_m'] * 100:.2f} / {med['final_xy_m'] * 100:.2f}",
                         f"{m['final_yaw_rad']:.3f} / {med['final_yaw_rad']:.3f}"])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True, type=Path)
    ap.add_argument("--only", default="")
    ap.add_argument("--out-stem", default="check")
    ap.add_argument("--out-dir", type=Path, default=HERE, help="where check.json/.md go")
    a = ap.parse_args()
    work = a.work
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    only = {s for s in a.only.split(",") if s}
    truth = [t for t in truth if not only or t["id"] in only]
    robot = HERE / "gap_robot.json"
    rows, controls = [], {}
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        ds = work / "effects" / t["id"]
        info = yaml.safe_load((ds / "dataset.yaml").read_text())["info"]
        seed, mpt = int(info["seed"]), int(info["moves_per_type"])
        clean_path = work / "clean" / f"s{seed}_e{exc:g}"
        clean = moves(clean_path)
        if exc not in controls:
            cpath = ensure_control(work, seed, exc, robot, mpt)
            controls[exc] = compare(moves(cpath), clean)
        m = compare(moves(ds), clean)
        ok, why = visible(m, controls[exc])
        rows.append({"id": t["id"], "excitation": exc, "seed": seed,
                     "clean": str(clean_path), "metrics": m, "visible": ok, "why": why})
        print(t["id"], "visible" if ok else "NOT visible", why, flush=True)
    fall = {}
    for group in ("effects", "clean", "control"):
        for d in sorted((work / group).glob("*")) if (work / group).is_dir() else []:
            if (d / "dataset.yaml").is_file():
                fall[f"{group}/{d.name}"] = falls(d)
    if (work / "reference" / "dataset.yaml").is_file():
        fall["reference"] = falls(work / "reference")
    doc = {"work": str(work), "thresholds": {"state_min": STATE_MIN, "xy_min_m": XY_MIN,
                                              "ratio_to_control": RATIO_MIN,
                                              "fall_z_m": FALL_Z, "fall_tilt_rad": FALL_TILT},
           "controls": {f"{k:g}": v for k, v in controls.items()}, "effects": rows,
           "falls": fall,
           "all_visible": all(r["visible"] for r in rows),
           "no_falls": all(not f["fallen"] for f in fall.values())}
    (a.out_dir / f"{a.out_stem}.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo31: visibility and fall check", "",
             f"WORK: `{work}`. Each effect dataset against the clean dataset of the same seed "
             "and excitation, move by move (see check_visible.py for the metrics and "
             "thresholds). Controls: the same comparison for a negligible (1 mN) perturbation.",
             "", "Columns: mean over moves / median over moves.", "",
             "| dataset | exc. | rms_body | rms_q | rms_dq | final xy [cm] | final yaw "
             "[rad] | visible | why |", "|---|---|---|---|---|---|---|---|---|"]
    for k, c in controls.items():
        lines.append(f"| control (exc. {k:g}) | {k:g} | {_cells(c)} | - | - |")
    for r in rows:
        m = r["metrics"]
        lines.append(f"| {r['id']} | {r['excitation']:g} | {_cells(m)} | "
                     f"{'yes' if r['visible'] else 'NO'} | {r['why']} |")
    lines += ["", "## Falls", "", "| dataset | moves | fallen | min body z [m] | max tilt [rad] |",
              "|---|---|---|---|---|"]
    for k, f in fall.items():
        lines.append(f"| {k} | {f['moves']} | {', '.join(f['fallen']) or 'none'} | "
                     f"{f['min_body_z_m']:.3f} | {f['max_tilt_rad']:.3f} |")
    lines += ["", f"All effects visible: {'yes' if doc['all_visible'] else 'NO'}. "
              f"No move falls: {'yes' if doc['no_falls'] else 'NO'}."]
    (a.out_dir / f"{a.out_stem}.md").write_text("\n".join(lines) + "\n")
    return 0 if doc["all_visible"] and doc["no_falls"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
