"""Is every effect of this zoo visible in its recording, and does no effect move fall?

Compares each effect dataset with the clean dataset of the same seed and excitation, bag by bag
(same move name = same gait randomisation and sensor-noise seed), and checks every effect move
for a fall. Datasets are laid out as ``benchmarks/blind_zoo/harness/run.py`` makes them:
``WORK/effects/<id>`` and ``WORK/clean/s<seed>_e<excitation>``. With ``--record`` the missing
datasets are recorded first (``littledog-mlsim record``), with ``--moves-per-type`` moves per type.

A control recording (a 0.02 N steady push, far below anything in the zoo) is made and compared
the same way, to show how much two recordings of the same seed differ for a negligible change.

Per bag: final odometry (x, y) difference [m] and relative to the clean move's travel; final yaw
difference [rad]; RMS joint-angle difference over all joints [rad] and of the most changed joint;
mean body height difference [m]. An effect is visible when the median over its moves of at least
one of these passes its threshold (``THRESHOLDS``). A move falls when the body z axis tilts more
than 0.35 rad from its start, or the body drops more than 0.03 m below its start height (above
the floor plane: for an inclined floor the height is taken normal to gravity above the floor
under the body).

    PYTHONPATH=. python benchmarks/blind_zoo/zoos/zoo7/check_visible.py --work /work/data/blind8 \\
        --seed 21 --out benchmarks/blind_zoo/zoos/zoo7/check_full.md
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves, quat_to_matrix
from littledog_mlsim.layout import JOINT_NAMES, wrap_angle

HERE = Path(__file__).resolve().parent
THRESHOLDS = {"dxy_m": 0.03, "dxy_rel": 0.20, "dyaw_rad": 0.05, "q_rms_rad": 0.02,
              "q_rms_max_rad": 0.03, "dz_m": 0.004}
TILT_FALL = 0.35
DROP_FALL = 0.03
CONTROL = "control_tiny_push"


def _yaw(quat: np.ndarray) -> float:
    R = quat_to_matrix(quat)
    return math.atan2(R[1, 0], R[0, 0])


def _floor_height(pos: np.ndarray, p0: np.ndarray, slope: tuple[float, float] | None) -> np.ndarray:
    """Height of the body above the floor under it (the level floor: z)."""
    z = pos[:, 2].copy()
    if slope:
        s, u = math.radians(slope[0]), math.radians(slope[1])
        along = (pos[:, 0] - p0[0]) * math.cos(u) + (pos[:, 1] - p0[1]) * math.sin(u)
        z -= math.tan(s) * along
    return z


def fall(m, slope=None) -> tuple[bool, float, float]:
    """(fell, max tilt [rad], max drop [m]) of one move."""
    z0 = quat_to_matrix(m.orientation[0])[:, 2]
    tilt = max(float(np.arccos(np.clip(quat_to_matrix(q)[:, 2] @ z0, -1, 1)))
               for q in m.orientation)
    h = _floor_height(m.position, m.position[0], slope)
    drop = float(h[0] - h.min())
    return tilt > TILT_FALL or drop > DROP_FALL, tilt, drop


def compare(eff, cln) -> dict[str, float]:
    travel = float(np.hypot(*(cln.position[-1, :2] - cln.position[0, :2])))
    dxy = float(np.hypot(*(eff.position[-1, :2] - cln.position[-1, :2])))
    dq = eff.q - cln.q
    per_joint = np.sqrt(np.mean(dq ** 2, axis=0))
    return {
        "dxy_m": dxy,
        "dxy_rel": dxy / max(travel, 0.05),
        "dyaw_rad": abs(float(wrap_angle(_yaw(eff.orientation[-1]) - _yaw(cln.orientation[-1])))),
        "q_rms_rad": float(np.sqrt(np.mean(dq ** 2))),
        "q_rms_max_rad": float(per_joint.max()),
        "most_changed_joint": JOINT_NAMES[int(per_joint.argmax())],
        "dz_m": abs(float(np.mean(eff.position[:, 2] - cln.position[:, 2]))),
    }


def record(out: Path, seed: int, moves: int, excitation: float, effects: Path | None) -> None:
    if (out / "dataset.yaml").is_file():
        return
    cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(moves), "--seed", str(seed), "--jobs", "2", "--quiet"]
    if excitation:
        cmd += ["--excitation", f"{excitation:g}"]
    if effects is not None:
        cmd += ["--effects", str(effects)]
    subprocess.run(cmd, check=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--zoo", default=str(HERE))
    ap.add_argument("--work", required=True, help="effects/<id> and clean/s<seed>_e<exc> under it")
    ap.add_argument("--seed", type=int, default=21)
    ap.add_argument("--record", action="store_true", help="record missing datasets first")
    ap.add_argument("--moves-per-type", type=int, default=2)
    ap.add_argument("--out", required=True, help="markdown report")
    a = ap.parse_args(argv)
    t0 = time.time()
    zoo, work = Path(a.zoo), Path(a.work)
    truth = yaml.safe_load((zoo / "truth.yaml").read_text())["effects"]
    control_yaml = work / f"{CONTROL}.yaml"
    work.mkdir(parents=True, exist_ok=True)
    control_yaml.write_text(
        f"- class: {zoo / 'effects' / 'zoo7_effects.py'}:WorldPush\n  params: {{force: 0.02, direction_deg: 0.0}}\n")
    rows = [(t["id"], float((t.get("recording") or {}).get("excitation", 0.0)),
             zoo / "effects" / t.get("file", f"{t['id']}.yaml"), t) for t in truth]
    rows.append((CONTROL, 0.0, control_yaml, None))
    for ex in sorted({r[1] for r in rows}):
        d = work / "clean" / f"s{a.seed}_e{ex:g}"
        if a.record:
            record(d, a.seed, a.moves_per_type, ex, None)
    for rid, ex, f, _ in rows:
        if a.record or rid == CONTROL:
            record(work / ("effects" if rid != CONTROL else "control") / rid, a.seed,
                   a.moves_per_type, ex, f)

    lines = [f"# Visibility and fall check of zoo7 ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())})",
             "", f"Command: `{' '.join(sys.argv)}`", "",
             f"Data: {work} (seed {a.seed}). Each effect move is compared with the clean move of the same "
             "name, seed and excitation. Values are medians over the effect's moves.", "",
             "Visible when at least one median passes its threshold: " +
             ", ".join(f"{k} > {v:g}" for k, v in THRESHOLDS.items()) +
             f". A move falls when its body z axis tilts > {TILT_FALL} rad from its start or the body "
             f"drops > {DROP_FALL} m below its start height (above the floor under it).", "",
             "| id | exc. | moves | dxy [m] | dxy / travel | dyaw [rad] | q RMS [rad] | "
             "most changed joint RMS [rad] | dz [m] | passes | visible | falls | max tilt [rad] | max drop [m] |",
             "|" + "---|" * 14]
    clean_cache: dict[float, dict] = {}
    n_vis = n_fall = n_moves = 0
    fall_clean = 0
    for rid, ex, f, t in rows:
        if ex not in clean_cache:
            cm = load_moves(work / "clean" / f"s{a.seed}_e{ex:g}", split="all")
            clean_cache[ex] = {m.name: m for m in cm}
            fall_clean += sum(fall(m)[0] for m in cm)
        d = work / ("effects" if rid != CONTROL else "control") / rid
        em = load_moves(d, split="all")
        slope = None
        if t is not None and t["family"] == "ground_slope":
            slope = (t["params"]["slope_deg"], t["params"].get("uphill_direction_deg", 0.0))
        cmp = [compare(m, clean_cache[ex][m.name]) for m in em]
        falls = [fall(m, slope) for m in em]
        med = {k: float(np.median([c[k] for c in cmp])) for k in THRESHOLDS}
        joints = [c["most_changed_joint"] for c in cmp]
        passes = [k for k, v in THRESHOLDS.items() if med[k] > v]
        nf = sum(x[0] for x in falls)
        vis = bool(passes)
        if rid != CONTROL:
            n_vis += vis
            n_fall += nf
            n_moves += len(em)
        lines.append(
            f"| {rid} | {ex:g} | {len(em)} | {med['dxy_m']:.3f} | {med['dxy_rel']:.2f} | "
            f"{med['dyaw_rad']:.3f} | {med['q_rms_rad']:.4f} | {med['q_rms_max_rad']:.4f} | "
            f"{med['dz_m']:.4f} | {', '.join(passes) or '-'} | {'yes' if vis else 'NO'} | "
            f"{nf}/{len(em)} | {max(x[1] for x in falls):.3f} | {max(x[2] for x in falls):.4f} |")
    n_eff = len(rows) - 1
    lines += ["", f"Summary: {n_vis}/{n_eff} effects visible; {n_fall} of {n_moves} effect moves fall; "
              f"{fall_clean} clean moves fall. The control row ({CONTROL}, 0.02 N) shows the "
              f"difference two recordings of the same seed have for a negligible change "
              f"(not part of the zoo). Check took {time.time() - t0:.0f} s.", ""]
    Path(a.out).write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if (n_vis == n_eff and n_fall == 0) else 1


if __name__ == "__main__":
    raise SystemExit(main())
