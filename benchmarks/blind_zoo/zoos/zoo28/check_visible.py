"""Check zoo28's recordings (SEALED output: check.md, check.json, beside this file).

1. Materiality: each effect dataset against the clean dataset of the same seed and recording
   condition (same moves, same commands, same sensor noise: the recordings are a pure function
   of robot, seed and effects, so every difference is the effect). Per effect, means over the
   moves of
   - q_div: RMS of (q_effect - q_clean) over time and the 12 joints [rad];
   - track: RMS joint tracking error |q - cmd| relative to clean's (ratio);
   - track_late: the same over the last quarter of each move (a drift shows here);
   - xy_final: |(x, y)_effect - (x, y)_clean| at the end of the move [m];
   - yaw_final: |yaw_effect - yaw_clean| at the end [rad];
   - z_mean: |mean z_effect - mean z_clean| [m];
   - twist_n: RMS of the body-twist difference over the RMS of clean's twist (6 axes pooled);
   - attitude: RMS of the roll/pitch difference [rad].
   An effect is material when one of them clears its threshold (THRESHOLDS).
2. Falls: every move of every dataset (effects, clean, reference): fallen when the body drops
   more than 6 cm below its starting height, tilts more than 40 degrees, or a value is not
   finite.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo28/check_visible.py --work WORK
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves

HERE = Path(__file__).resolve().parent
THRESHOLDS = {"q_div": 0.02, "track_change": 0.10, "track_late_change": 0.10, "xy_final": 0.03,
              "yaw_final": 0.05, "z_mean": 0.003, "twist_n": 0.20, "attitude": 0.01}
FALL_DROP_M = 0.06
FALL_TILT_RAD = np.radians(40.0)


def _rpy(qxyzw: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    x, y, z, w = qxyzw.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    r22 = 1 - 2 * (x * x + y * y)               # body z axis . world z
    return roll, pitch, np.unwrap(yaw), np.arccos(np.clip(r22, -1, 1))


def _moves(path: Path) -> dict:
    return {m.name: m for m in load_moves(path, split="all")}


WORST: dict[int, dict] = {}


def fall_check(moves: dict) -> list[dict]:
    out = []
    worst = {"drop_m": 0.0, "tilt_deg": 0.0}
    for name, m in moves.items():
        arrays = [m.q, m.dq, m.position, m.orientation, m.linear_velocity, m.angular_velocity]
        finite = all(np.all(np.isfinite(a)) for a in arrays)
        if not finite:
            out.append({"move": name, "why": "non-finite"})
            continue
        z = m.position[:, 2]
        _, _, _, tilt = _rpy(m.orientation)
        drop = float(z[0] - z.min())
        worst["drop_m"] = max(worst["drop_m"], drop)
        worst["tilt_deg"] = max(worst["tilt_deg"], float(np.degrees(tilt.max())))
        if drop > FALL_DROP_M or tilt.max() > FALL_TILT_RAD:
            out.append({"move": name, "drop_m": drop, "tilt_deg": float(np.degrees(tilt.max()))})
    WORST[id(out)] = worst
    return out


def compare(eff: dict, clean: dict) -> dict:
    keys = sorted(set(eff) & set(clean))
    acc: dict[str, list[float]] = {k: [] for k in
                                   ("q_div", "track_e", "track_c", "late_e", "late_c",
                                    "xy_final", "yaw_final", "z_mean", "twist_d", "twist_c",
                                    "attitude")}
    for k in keys:
        e, c = eff[k], clean[k]
        n = min(len(e.q), len(c.q))
        n_cmd = min(n, len(e.cmd), len(c.cmd))
        acc["q_div"].append(float(np.sqrt(np.mean((e.q[:n] - c.q[:n]) ** 2))))
        te = e.q[1:n_cmd + 1] - e.cmd[:n_cmd] if len(e.q) > n_cmd else e.q[:n_cmd] - e.cmd[:n_cmd]
        tc = c.q[1:n_cmd + 1] - c.cmd[:n_cmd] if len(c.q) > n_cmd else c.q[:n_cmd] - c.cmd[:n_cmd]
        q4 = 3 * len(te) // 4
        acc["track_e"].append(float(np.sqrt(np.mean(te ** 2))))
        acc["track_c"].append(float(np.sqrt(np.mean(tc ** 2))))
        acc["late_e"].append(float(np.sqrt(np.mean(te[q4:] ** 2))))
        acc["late_c"].append(float(np.sqrt(np.mean(tc[q4:] ** 2))))
        acc["xy_final"].append(float(np.hypot(*(e.position[n - 1, :2] - c.position[n - 1, :2]))))
        re, pe, ye, _ = _rpy(e.orientation[:n])
        rc, pc, yc, _ = _rpy(c.orientation[:n])
        acc["yaw_final"].append(float(abs(ye[-1] - yc[-1])))
        acc["z_mean"].append(float(abs(e.position[:n, 2].mean() - c.position[:n, 2].mean())))
        tw_e = np.hstack([e.linear_velocity[:n], e.angular_velocity[:n]])
        tw_c = np.hstack([c.linear_velocity[:n], c.angular_velocity[:n]])
        acc["twist_d"].append(float(np.sqrt(np.mean((tw_e - tw_c) ** 2))))
        acc["twist_c"].append(float(np.sqrt(np.mean((tw_c - tw_c.mean(0)) ** 2))))
        acc["attitude"].append(float(np.sqrt(np.mean((re - rc) ** 2 + (pe - pc) ** 2))))
    m = {k: float(np.mean(v)) for k, v in acc.items()}
    res = {"moves": len(keys), "q_div": m["q_div"],
           "track_effect": m["track_e"], "track_clean": m["track_c"],
           "track_change": m["track_e"] / m["track_c"] - 1.0,
           "track_late_change": m["late_e"] / m["late_c"] - 1.0,
           "xy_final": m["xy_final"], "xy_final_max": float(np.max(acc["xy_final"])),
           "yaw_final": m["yaw_final"], "z_mean": m["z_mean"],
           "twist_n": m["twist_d"] / m["twist_c"], "attitude": m["attitude"]}
    res["cleared"] = [k for k, th in THRESHOLDS.items() if abs(res[k]) > th]
    res["material"] = bool(res["cleared"])
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True, help="the harness's work directory")
    ap.add_argument("--seed", type=int, default=191)
    a = ap.parse_args()
    t0 = time.perf_counter()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    clean_dirs = sorted((work / "clean").iterdir())
    clean_cache: dict[str, dict] = {}
    falls: dict[str, list] = {}
    for d in clean_dirs:
        if (d / "dataset.yaml").is_file():
            clean_cache[d.name] = _moves(d)
            falls[f"clean/{d.name}"] = fall_check(clean_cache[d.name])
    ref = work / "reference"
    falls["reference"] = fall_check(_moves(ref))
    rows = {}
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        eff = _moves(work / "effects" / t["id"])
        falls[f"effects/{t['id']}"] = fall_check(eff)
        cname = f"s{a.seed}_e{exc:g}"
        rows[t["id"]] = {"clean": cname, "excitation": exc,
                         **compare(eff, clean_cache[cname])}
    fell = sum(len(v) for v in falls.values())
    worst = {k: WORST[id(v)] for k, v in falls.items()}
    doc = {"worst": worst, "thresholds": THRESHOLDS, "fall_rule": {"drop_m": FALL_DROP_M,
                                                   "tilt_deg": float(np.degrees(FALL_TILT_RAD))},
           "effects": rows, "falls": falls, "moves_fallen": fell,
           "all_material": all(r["material"] for r in rows.values()),
           "seconds": time.perf_counter() - t0}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    cols = ["q_div", "track_change", "track_late_change", "xy_final", "yaw_final", "z_mean",
            "twist_n", "attitude"]
    lines = ["# zoo28: check of the recordings (SEALED)", "",
             f"Effect datasets (seed {a.seed}) against the clean dataset of the same seed and "
             "excitation; means over the moves. Thresholds: "
             + ", ".join(f"{k} {v:g}" for k, v in THRESHOLDS.items()) + ".", "",
             "| effect | clean | " + " | ".join(cols) + " | material (cleared) |",
             "|" + "---|" * (len(cols) + 3)]
    for k, r in rows.items():
        lines.append(f"| {k} | {r['clean']} | " + " | ".join(f"{r[c]:.4g}" for c in cols)
                     + f" | {'yes' if r['material'] else 'NO'} ({', '.join(r['cleared'])}) |")
    lines += ["", f"Falls (drop > {FALL_DROP_M} m below the start height, tilt > 40 deg, or "
              f"non-finite), over {len(falls)} datasets: {fell} moves fell."]
    for k, v in falls.items():
        lines.append(f"- {k}: {len(v)} fell" + (f" {v}" if v else "")
                     + f" (worst move: drop {worst[k]['drop_m'] * 100:.1f} cm, "
                     f"tilt {worst[k]['tilt_deg']:.1f} deg)")
    lines += ["", f"Check time: {doc['seconds']:.0f} s."]
    (HERE / "check.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 1 if fell or not doc["all_material"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
