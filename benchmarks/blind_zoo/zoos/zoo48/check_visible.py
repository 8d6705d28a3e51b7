"""Check zoo48's recordings: every effect changes them materially, and no move falls.

Reads the datasets ``harness/run.py --record-only`` wrote into WORK (``effects/<id>``,
``clean/s<seed>_e<exc>``, ``reference``) and ``truth.yaml`` (ids and recording conditions only).

- **Falls**: a move falls when its body height drops below ``FALL_Z`` m or its roll or pitch
  exceeds ``FALL_TILT`` rad at any measurement. Checked on every move of every dataset.
- **Material**: each effect dataset against the clean dataset of the same seed and excitation,
  move by move (the same bag names: the same commands and sensor-noise streams, so every
  difference is the effect's). For each of the 33 state elements (``docs/interface.md`` section
  4), the RMS difference over all samples divided by the clean element's standard deviation
  (nRMS); and the final (x, y) and yaw differences. Material when the largest nRMS is at least
  ``NRMS_MIN`` or the mean final (x, y) difference is at least ``XY_MIN`` m.

Writes ``check.json`` and ``check.md`` beside this file (or to --out) and exits 1 if a check
fails.

    PYTHONPATH=. .venv/bin/python benchmarks/blind_zoo/zoos/zoo48/check_visible.py --work WORK
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.data.states import integrate_path, initial_pose, states_from_recording
from littledog_mlsim.layout import STATE_NAMES, wrap_angle
from littledog_mlsim.rotations import quat_to_rpy

HERE = Path(__file__).resolve().parent
FALL_Z = 0.08        # m (standing: ~0.14)
FALL_TILT = 0.7      # rad
NRMS_MIN = 0.2
XY_MIN = 0.05        # m


def falls(directory: Path) -> dict:
    moves = load_moves(directory, split="all")
    fallen, min_z, max_tilt = [], np.inf, 0.0
    for m in moves:
        z = float(np.min(m.position[:, 2]))
        tilt = float(np.max(np.abs(quat_to_rpy(m.orientation)[:, :2])))
        min_z, max_tilt = min(min_z, z), max(max_tilt, tilt)
        if z < FALL_Z or tilt > FALL_TILT or not np.all(np.isfinite(m.position)):
            fallen.append(m.name)
    return {"moves": len(moves), "fallen": fallen, "min_z_m": min_z, "max_tilt_rad": max_tilt}


def difference(effect: Path, clean: Path) -> dict:
    eff = {m.name: m for m in load_moves(effect, split="all")}
    cln = {m.name: m for m in load_moves(clean, split="all")}
    names = sorted(set(eff) & set(cln))
    if len(names) != len(cln):
        raise SystemExit(f"{effect} and {clean} hold different moves")
    se = np.vstack([states_from_recording(eff[n]) for n in names])
    sc = np.vstack([states_from_recording(cln[n]) for n in names])
    d = se - sc
    wrapped = [STATE_NAMES.index(k) for k in ("droll", "dpitch", "dyaw")]
    d[:, wrapped] = wrap_angle(d[:, wrapped])
    std = sc.std(axis=0)
    nrms = np.sqrt(np.mean(d * d, axis=0)) / np.where(std > 1e-9, std, 1.0)
    xy, yaw = [], []
    for n in names:
        pe = integrate_path(states_from_recording(eff[n]), *initial_pose(eff[n]))[-1]
        pc = integrate_path(states_from_recording(cln[n]), *initial_pose(cln[n]))[-1]
        xy.append(float(np.hypot(*(pe[:2] - pc[:2]))))
        yaw.append(float(abs(wrap_angle(pe[2] - pc[2]))))
    order = np.argsort(nrms)[::-1][:3]
    top = {STATE_NAMES[i]: float(nrms[i]) for i in order}
    out = {"moves": len(names), "max_nrms": float(nrms.max()), "top_elements": top,
           "body_max_nrms": float(nrms[:9].max()), "joint_max_nrms": float(nrms[9:].max()),
           "final_xy_diff_m_mean": float(np.mean(xy)), "final_yaw_diff_rad_mean": float(np.mean(yaw))}
    out["material"] = bool(out["max_nrms"] >= NRMS_MIN or out["final_xy_diff_m_mean"] >= XY_MIN)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True, help="the harness's WORK directory")
    ap.add_argument("--zoo", default=str(HERE))
    ap.add_argument("--seed", type=int, default=391)
    ap.add_argument("--out", default=None, help="where check.md/json go (default: the zoo)")
    a = ap.parse_args(argv)
    work, zoo = Path(a.work), Path(a.zoo)
    out = Path(a.out) if a.out else zoo
    truth = yaml.safe_load((zoo / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    result = {"work": str(work), "thresholds": {"fall_z_m": FALL_Z, "fall_tilt_rad": FALL_TILT,
                                                  "nrms_min": NRMS_MIN, "xy_min_m": XY_MIN},
              "effects": {}, "falls": {}}
    datasets = sorted(p.parent for p in work.glob("*/*/dataset.yaml")) + (
        [work / "reference"] if (work / "reference" / "dataset.yaml").is_file() else [])
    for d in datasets:
        result["falls"][str(d.relative_to(work))] = falls(d)
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        eff = work / "effects" / t["id"]
        clean = work / "clean" / f"s{a.seed}_e{exc:g}"
        result["effects"][t["id"]] = {"excitation": exc, **difference(eff, clean)}
    n_material = sum(e["material"] for e in result["effects"].values())
    n_fallen = sum(len(f["fallen"]) for f in result["falls"].values())
    n_moves = sum(f["moves"] for f in result["falls"].values())
    ok = n_material == len(truth) and n_fallen == 0 and len(truth) == 12
    result["summary"] = {"effects": len(truth), "material": n_material, "datasets": len(datasets),
                         "moves": n_moves, "fallen": n_fallen, "pass": ok}
    (out / "check.json").write_text(json.dumps(result, indent=1) + "\n")
    lines = ["# zoo48 check (sealed)", "",
             f"Effects material: {n_material} of {len(truth)}; moves fallen: {n_fallen} of "
             f"{n_moves} in {len(datasets)} datasets; pass: {'yes' if ok else 'NO'}.", "",
             f"Material: max nRMS over the 33 state elements >= {NRMS_MIN} or mean final (x, y) "
             f"difference >= {XY_MIN} m, against the clean dataset of seed {a.seed} and the same "
             f"excitation. Fall: z < {FALL_Z} m or |roll|, |pitch| > {FALL_TILT} rad.", "",
             "Floor: a scratch probe (not kept) with a negligible effect, 0.005 N m of dry "
             "friction in the knees (2 moves per type, excited, the same gap robot and seed), "
             "gave max nRMS 0.05 against its clean twin: the threshold is 4x that.", "",
             "| effect | exc. | max nRMS | top elements | body max nRMS | joint max nRMS | "
             "final xy diff [m] | final yaw diff [rad] | material |", "|" + "---|" * 9]
    for k, e in result["effects"].items():
        top = ", ".join(f"{n} {v:.2f}" for n, v in e["top_elements"].items())
        lines.append(f"| {k} | {e['excitation']:g} | {e['max_nrms']:.2f} | {top} | "
                     f"{e['body_max_nrms']:.2f} | {e['joint_max_nrms']:.2f} | "
                     f"{e['final_xy_diff_m_mean']:.3f} | {e['final_yaw_diff_rad_mean']:.3f} | "
                     f"{'yes' if e['material'] else 'NO'} |")
    lines += ["", "| dataset | moves | fallen | min z [m] | max tilt [rad] |", "|---|---|---|---|---|"]
    for k, f in result["falls"].items():
        lines.append(f"| {k} | {f['moves']} | {len(f['fallen'])} {' '.join(f['fallen'])} | "
                     f"{f['min_z_m']:.3f} | {f['max_tilt_rad']:.3f} |")
    (out / "check.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
