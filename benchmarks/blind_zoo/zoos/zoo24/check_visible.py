"""Check that every zoo24 effect changes the recordings materially, and that no move falls.

Each effect dataset (WORK/effects/<id>) is compared move by move with the clean dataset of the
same seed and recording condition (WORK/clean/s<seed>_e<excitation>): the same moves, the same
commands, the same gap robot and sensor-noise seed, so every difference is the effect's.
Usage (repository root):

    python benchmarks/blind_zoo/zoos/zoo24/check_visible.py --work WORK [--seed 151]

Writes check.md and check.json beside this script (sealed with the truth: they name the effects).

Material: the mean over moves of the final (x, y) difference >= 0.03 m, or the RMS difference of
the joint angles of the effect's scope (all joints for a body scope) >= 0.02 rad, or the RMS
difference of roll/pitch >= 0.01 rad. Fallen: a move whose body drops below 60 % of the clean
median height or tilts by more than 0.7 rad (roll or pitch).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot.effects import resolve_joints

HERE = Path(__file__).resolve().parent
XY_M, Q_RAD, ATT_RAD = 0.03, 0.02, 0.01


def rpy(quat: np.ndarray) -> np.ndarray:
    x, y, z, w = quat.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=1)


def scope_joints(scope: str) -> np.ndarray:
    kind, _, name = scope.partition(":")
    if kind in ("joint", "leg", "type", "side"):
        return resolve_joints(name)
    return resolve_joints("all")


def moves(path: Path) -> dict:
    return {m.name: m for m in load_moves(path, split="all")}


def fallen(m, z_ref: float) -> bool:
    a = rpy(m.orientation)
    return bool(m.position[:, 2].min() < 0.6 * z_ref or np.abs(a[:, :2]).max() > 0.7)


def compare(eff: dict, clean: dict, joints: np.ndarray, z_ref: float) -> dict:
    xy, yaw, q_rms, att_rms, z_rms, track_e, track_c, falls = [], [], [], [], [], [], [], []
    for name, c in clean.items():
        e = eff[name]
        xy.append(float(np.hypot(*(e.position[-1, :2] - c.position[-1, :2]))))
        ae, ac = rpy(e.orientation), rpy(c.orientation)
        yaw.append(float(abs((ae[-1, 2] - ac[-1, 2] + np.pi) % (2 * np.pi) - np.pi)))
        q_rms.append(float(np.sqrt(np.mean((e.q[:, joints] - c.q[:, joints]) ** 2))))
        att_rms.append(float(np.sqrt(np.mean((ae[:, :2] - ac[:, :2]) ** 2))))
        z_rms.append(float(np.sqrt(np.mean((e.position[:, 2] - c.position[:, 2]) ** 2))))
        track_e.append(float(np.sqrt(np.mean((e.cmd[:, joints] - e.q[1:, joints]) ** 2))))
        track_c.append(float(np.sqrt(np.mean((c.cmd[:, joints] - c.q[1:, joints]) ** 2))))
        if fallen(e, z_ref):
            falls.append(name)
    travel = [float(np.hypot(*(c.position[-1, :2] - c.position[0, :2]))) for c in clean.values()]
    out = {"moves": len(clean),
           "final_xy_diff_m_mean": float(np.mean(xy)), "final_xy_diff_m_max": float(np.max(xy)),
           "clean_travel_m_mean": float(np.mean(travel)),
           "final_yaw_diff_rad_mean": float(np.mean(yaw)),
           "q_rms_diff_rad_scope": float(np.mean(q_rms)),
           "roll_pitch_rms_diff_rad": float(np.mean(att_rms)),
           "z_rms_diff_m": float(np.mean(z_rms)),
           "tracking_rms_rad_scope": [float(np.mean(track_c)), float(np.mean(track_e))],
           "fallen_moves": falls}
    out["material"] = bool(out["final_xy_diff_m_mean"] >= XY_M or out["q_rms_diff_rad_scope"] >= Q_RAD
                           or out["roll_pitch_rms_diff_rad"] >= ATT_RAD)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=151)
    a = ap.parse_args(argv)
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    cache: dict = {}
    rows = {}
    clean_falls = {}
    for d in sorted((work / "clean").iterdir()):
        if (d / "dataset.yaml").is_file():
            ms = moves(d)
            cache[d.name] = ms
            z_ref = float(np.median([m.position[0, 2] for m in ms.values()]))
            clean_falls[d.name] = [n for n, m in ms.items() if fallen(m, z_ref)]
    ref = moves(work / "reference")
    z_ref = float(np.median([m.position[0, 2] for m in ref.values()]))
    clean_falls["reference"] = [n for n, m in ref.items() if fallen(m, z_ref)]
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        clean = cache[f"s{a.seed}_e{exc:g}"]
        z_ref = float(np.median([m.position[0, 2] for m in clean.values()]))
        r = compare(moves(work / "effects" / t["id"]), clean, scope_joints(t["scope"]), z_ref)
        r.update(family=t["family"], scope=t["scope"], excitation=exc)
        rows[t["id"]] = r
        print(t["id"], "material" if r["material"] else "NOT material",
              f"xy {r['final_xy_diff_m_mean']:.3f} q {r['q_rms_diff_rad_scope']:.4f} "
              f"att {r['roll_pitch_rms_diff_rad']:.4f} falls {len(r['fallen_moves'])}", flush=True)
    doc = {"work": str(work), "seed": a.seed,
           "thresholds": {"final_xy_diff_m_mean": XY_M, "q_rms_diff_rad_scope": Q_RAD,
                          "roll_pitch_rms_diff_rad": ATT_RAD},
           "effects": rows, "clean_fallen_moves": clean_falls,
           "all_material": all(r["material"] for r in rows.values()),
           "no_falls": not any(r["fallen_moves"] for r in rows.values())
           and not any(clean_falls.values())}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo24: is every effect material? (check_visible.py)", "",
             f"Recordings: `{work}`; each effect against the clean dataset of seed {a.seed} and "
             "the same excitation (same moves). Material: mean final (x, y) difference >= "
             f"{XY_M} m, or RMS joint-angle difference in the effect's scope >= {Q_RAD} rad, or "
             f"RMS roll/pitch difference >= {ATT_RAD} rad.", "",
             "| effect | family @ scope | exc. | final xy diff mean / max [m] (clean travel) | "
             "final yaw diff [rad] | q RMS diff, scope [rad] | roll/pitch RMS diff [rad] | "
             "z RMS diff [mm] | tracking RMS clean -> effect [rad] | fallen | material |",
             "|" + "---|" * 11]
    for i, r in rows.items():
        lines.append(
            f"| {i} | {r['family']} @ {r['scope']} | {r['excitation']:g} | "
            f"{r['final_xy_diff_m_mean']:.3f} / {r['final_xy_diff_m_max']:.3f} "
            f"({r['clean_travel_m_mean']:.3f}) | {r['final_yaw_diff_rad_mean']:.3f} | "
            f"{r['q_rms_diff_rad_scope']:.4f} | {r['roll_pitch_rms_diff_rad']:.4f} | "
            f"{1000 * r['z_rms_diff_m']:.1f} | {r['tracking_rms_rad_scope'][0]:.4f} -> "
            f"{r['tracking_rms_rad_scope'][1]:.4f} | {len(r['fallen_moves'])} | "
            f"{'yes' if r['material'] else 'NO'} |")
    lines += ["", "Fallen moves in the clean datasets and the reference: "
              + ", ".join(f"{k}: {len(v)}" for k, v in clean_falls.items()), "",
              f"All material: {'yes' if doc['all_material'] else 'NO'}; no move fallen: "
              f"{'yes' if doc['no_falls'] else 'NO'}."]
    (HERE / "check.md").write_text("\n".join(lines) + "\n")
    return 0 if doc["all_material"] and doc["no_falls"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
