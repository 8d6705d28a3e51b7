"""zoo12's visibility and no-fall check: every effect dataset against the clean dataset of the
same seed (both recorded by harness/run.py --record-only on the gap robot, same commands and
sensor-noise streams, so any difference is the effect's).

Per effect, over the 110 moves (10 per type), per step:
- rms_q: RMS change of the 12 reported joint angles [rad];
- rms_pos: RMS change of the motion-capture body position [m];
- rms_tilt: RMS change of body roll and pitch [rad];
- final_xy: mean distance between the effect's and the clean move's final (x, y) [m].
Visible: rms_q >= 0.005 rad (~140 encoder counts) or rms_pos >= 0.005 m (~17x the motion
capture's per-axis noise). No fall: in every move |roll| and |pitch| stay below 0.35 rad and
the body height stays above 0.11 m (the stance is ~0.135 m).

    PYTHONPATH=/tmp/s46/frozen12 /tmp/s46/frozen12/.venv/bin/python check_visible.py [WORK]

Writes check.md and check.json beside this file. WORK defaults to /tmp/s46/z12.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from littledog_mlsim.data.bags import read_bag

HERE = Path(__file__).resolve().parent
Q_MIN, POS_MIN = 0.005, 0.005          # visibility thresholds
TILT_MAX, Z_MIN = 0.35, 0.11           # no-fall thresholds


def load(ds: Path) -> dict:
    doc = yaml.safe_load((ds / "dataset.yaml").read_text())
    return {b["name"]: read_bag(ds / b["name"], b["move_type"]) for b in doc["bags"]}


def tilt(rec) -> np.ndarray:
    return Rotation.from_quat(rec.orientation).as_euler("xyz")[:, :2]


def falls(recs: dict) -> dict:
    worst_tilt = max(float(np.abs(tilt(r)).max()) for r in recs.values())
    min_z = min(float(r.position[:, 2].min()) for r in recs.values())
    fallen = [n for n, r in recs.items()
              if np.abs(tilt(r)).max() > TILT_MAX or r.position[:, 2].min() < Z_MIN]
    return {"max_abs_roll_pitch_rad": worst_tilt, "min_height_m": min_z, "fallen_moves": fallen}


def compare(a: dict, b: dict) -> dict:
    dq, dp, dt, fxy = [], [], [], []
    for n, ra in a.items():
        rb = b[n]
        dq.append(np.mean((ra.q - rb.q) ** 2))
        dp.append(np.mean(np.sum((ra.position - rb.position) ** 2, axis=1)))
        dt.append(np.mean((tilt(ra) - tilt(rb)) ** 2))
        fxy.append(float(np.hypot(*(ra.position[-1, :2] - rb.position[-1, :2]))))
    return {"rms_q_rad": float(np.sqrt(np.mean(dq))), "rms_pos_m": float(np.sqrt(np.mean(dp))),
            "rms_tilt_rad": float(np.sqrt(np.mean(dt))), "final_xy_m": float(np.mean(fxy))}


def main() -> int:
    work = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("/tmp/s46/z12")
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    clean = load(work / "clean" / "s71_e0")
    rows = []
    controls = [("clean_s72_e0", work / "clean" / "s72_e0"), ("clean_s73_e0", work / "clean" / "s73_e0"),
                ("reference", work / "reference"), ("null_control", work / "null_control")]
    out = {"clean_s71_e0": falls(clean), "controls": {}, "effects": []}
    for name, path in controls:
        if (path / "dataset.yaml").is_file():
            recs = load(path)
            c = falls(recs)
            if name == "null_control":
                c.update(compare(clean, recs))
            out["controls"][name] = c
    for t in truth:
        recs = load(work / "effects" / t["id"])
        r = {"id": t["id"], **compare(clean, recs), **falls(recs)}
        r["visible"] = bool(r["rms_q_rad"] >= Q_MIN or r["rms_pos_m"] >= POS_MIN)
        r["no_fall"] = not r["fallen_moves"]
        rows.append(r)
    out["effects"] = rows
    out["thresholds"] = {"rms_q_rad": Q_MIN, "rms_pos_m": POS_MIN, "tilt_max_rad": TILT_MAX,
                         "height_min_m": Z_MIN}
    out["summary"] = {"visible": sum(r["visible"] for r in rows),
                      "no_fall": sum(r["no_fall"] for r in rows), "effects": len(rows)}
    (HERE / "check.json").write_text(json.dumps(out, indent=1) + "\n")
    md = ["# zoo12 check_visible: each effect dataset against clean/s71_e0 (seed 71, gap robot)",
          "", f"Visible: rms_q >= {Q_MIN} rad or rms_pos >= {POS_MIN} m. No fall: |roll|, |pitch| "
          f"< {TILT_MAX} rad and height > {Z_MIN} m in every move.", "",
          "| effect | rms q [rad] | rms pos [m] | rms roll/pitch [rad] | final xy [m] | "
          "max roll/pitch [rad] | min height [m] | visible | no fall |",
          "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        md.append(f"| {r['id']} | {r['rms_q_rad']:.4f} | {r['rms_pos_m']:.4f} | "
                  f"{r['rms_tilt_rad']:.4f} | {r['final_xy_m']:.3f} | "
                  f"{r['max_abs_roll_pitch_rad']:.3f} | {r['min_height_m']:.3f} | "
                  f"{'yes' if r['visible'] else 'NO'} | {'yes' if r['no_fall'] else 'NO'} |")
    md += ["", "| control dataset | max roll/pitch [rad] | min height [m] | fallen moves | "
           "rms q / rms pos vs clean_s71_e0 |", "|---|---|---|---|---|"]
    for name, c in [("clean_s71_e0", out["clean_s71_e0"])] + list(out["controls"].items()):
        vs = (f"{c['rms_q_rad']:.2e} / {c['rms_pos_m']:.2e}" if "rms_q_rad" in c else "-")
        md.append(f"| {name} | {c['max_abs_roll_pitch_rad']:.3f} | {c['min_height_m']:.3f} | "
                  f"{len(c['fallen_moves'])} | {vs} |")
    s = out["summary"]
    md += ["", f"Summary: {s['visible']} of {s['effects']} visible, {s['no_fall']} of "
           f"{s['effects']} without a fallen move."]
    (HERE / "check.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
