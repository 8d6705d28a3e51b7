"""zoo20's check: every effect changes its recording materially against clean data of the same
seed and condition (beyond a null recording's chaos floor), and no move falls in any dataset.

Run from the repository root after the harness's --record-only run:
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo20/check_visible.py --work /tmp/s55/z20
Writes check.md and check.json beside this file. The null recordings (a 1 mN world force, the
chaos floor) are made here under WORK/null/ with the gap robot and the effects' seed.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[3]
sys.path.insert(0, str(ROOT))
from littledog_mlsim.data.dataset import load_moves  # noqa: E402

SEED = 111
MOVES = 10
RATIO = 3.0            # material: a metric at least this many times the null's
TILT_FALL_DEG = 45.0   # a move falls when roll or pitch exceeds this
Z_FALL_FRACTION = 0.5  # ... or the body drops below this fraction of its start height


def rpy(qxyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = qxyzw.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=1)


def signals(m) -> np.ndarray:
    """33 elements per step: q, dq, body z, roll, pitch, yaw-rate-free twist (lin, ang)."""
    e = rpy(m.orientation)
    return np.concatenate([m.q, m.dq, m.position[:, 2:3], e[:, :2], m.linear_velocity,
                           m.angular_velocity, np.unwrap(e[:, 2:3], axis=0)], axis=1)[:, :33]


def load(path: Path) -> dict:
    return {m.name: m for m in load_moves(path, split="all")}


def falls(moves: dict) -> list[str]:
    out = []
    for name, m in moves.items():
        e = np.degrees(rpy(m.orientation))
        z0 = m.position[0, 2]
        if np.any(np.abs(e[:, :2]) > TILT_FALL_DEG) or np.any(m.position[:, 2] < Z_FALL_FRACTION * z0):
            out.append(name)
    return out


def max_tilt(moves: dict) -> float:
    return float(max(np.abs(np.degrees(rpy(m.orientation))[:, :2]).max() for m in moves.values()))


def compare(a: dict, b: dict) -> dict:
    names = sorted(set(a) & set(b))
    xy, yaw, nr = [], [], []
    for n in names:
        ma, mb = a[n], b[n]
        xy.append(float(np.hypot(*(ma.position[-1, :2] - mb.position[-1, :2]))))
        ya = np.unwrap(rpy(ma.orientation)[:, 2])
        yb = np.unwrap(rpy(mb.orientation)[:, 2])
        yaw.append(abs(float(ya[-1] - yb[-1])))
        sa, sb = signals(ma), signals(mb)
        sd = np.std(sb, axis=0) + 1e-9
        nr.append(np.sqrt(np.mean((sa - sb) ** 2, axis=0)) / sd)
    nr = np.array(nr)
    return {"moves": len(names), "final_xy_m": float(np.mean(xy)), "final_yaw_rad": float(np.mean(yaw)),
            "nrms": float(np.mean(nr)), "nrms_q": float(np.mean(nr[:, :12])),
            "nrms_body": float(np.mean(nr[:, 24:]))}


def record_null(work: Path, robot: Path, exc: float) -> Path:
    out = work / "null" / f"s{SEED}_e{exc:g}"
    if (out / "dataset.yaml").is_file():
        return out
    eff = work / "null" / "null.yaml"
    eff.parent.mkdir(parents=True, exist_ok=True)
    eff.write_text(f"- class: {HERE / 'plugins.py'}:PZ\n  params: {{force_N: 0.001}}\n")
    cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(MOVES), "--seed", str(SEED), "--jobs", "2", "--quiet",
           "--robot", str(robot), "--effects", str(eff)]
    if exc:
        cmd += ["--excitation", f"{exc:g}"]
    subprocess.run(cmd, check=True, cwd=ROOT)
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    robot = HERE / "gap_robot.json"
    excs = sorted({0.0} | {float((t.get("recording") or {}).get("excitation", 0.0)) for t in truth})
    clean = {e: load(work / "clean" / f"s{SEED}_e{e:g}") for e in excs}
    null = {e: compare(load(record_null(work, robot, e)), clean[e]) for e in excs}
    fall_report, tilt = {}, {}
    for d in sorted((work / "clean").iterdir()):
        if (d / "dataset.yaml").is_file():
            ms = load(d)
            fall_report[f"clean/{d.name}"] = falls(ms)
            tilt[f"clean/{d.name}"] = max_tilt(ms)
    if (work / "reference" / "dataset.yaml").is_file():
        ms = load(work / "reference")
        fall_report["reference"] = falls(ms)
        tilt["reference"] = max_tilt(ms)
    rows = []
    for t in truth:
        e = float((t.get("recording") or {}).get("excitation", 0.0))
        moves = load(work / "effects" / t["id"])
        fall_report[f"effects/{t['id']}"] = falls(moves)
        tilt[f"effects/{t['id']}"] = max_tilt(moves)
        c = compare(moves, clean[e])
        n = null[e]
        r_xy = c["final_xy_m"] / max(n["final_xy_m"], 1e-9)
        r_nr = c["nrms"] / max(n["nrms"], 1e-9)
        rows.append({"id": t["id"], "excitation": e, **c, "ratio_xy_to_null": r_xy,
                     "ratio_nrms_to_null": r_nr, "material": bool(max(r_xy, r_nr) >= RATIO),
                     "falls": fall_report[f"effects/{t['id']}"]})
    n_fall = sum(len(v) for v in fall_report.values())
    doc = {"seed": SEED, "ratio_threshold": RATIO, "null": null, "rows": rows,
           "falls": fall_report, "max_tilt_deg": tilt, "n_material": sum(r["material"] for r in rows),
           "n_effects": len(rows), "n_falls": n_fall,
           "passed": bool(all(r["material"] for r in rows) and n_fall == 0)}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    md = ["# zoo20 check_visible", "",
          f"Material: a metric >= {RATIO:g}x the null recording's (1 mN world force, same seed and "
          "condition) against clean data of the same seed and condition. Metrics: mean final (x, y) "
          "difference [m]; mean over 33 signals of RMS difference / clean std (nrms).", "",
          "| null (chaos floor) | final xy [m] | final yaw [rad] | nrms |", "|---|---|---|---|"]
    for e, n in null.items():
        md.append(f"| excitation {e:g} | {n['final_xy_m']:.4f} | {n['final_yaw_rad']:.4f} | {n['nrms']:.4f} |")
    md += ["", "| effect | exc. | final xy [m] | final yaw [rad] | nrms (q / body) | xy / null | nrms / null | material | falls |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        md.append(f"| {r['id']} | {r['excitation']:g} | {r['final_xy_m']:.4f} | {r['final_yaw_rad']:.4f} | "
                  f"{r['nrms']:.3f} ({r['nrms_q']:.3f} / {r['nrms_body']:.3f}) | {r['ratio_xy_to_null']:.1f} | "
                  f"{r['ratio_nrms_to_null']:.1f} | {'yes' if r['material'] else 'NO'} | {len(r['falls'])} |")
    md += ["", "Falls (max |roll|, |pitch| over all moves, deg) per dataset: " + ", ".join(
        f"{k} {len(v)} ({tilt[k]:.0f})" for k, v in fall_report.items()), "",
           f"**{doc['n_material']} of {doc['n_effects']} material, {n_fall} falls: "
           f"{'PASSED' if doc['passed'] else 'FAILED'}**", ""]
    (HERE / "check.md").write_text("\n".join(md))
    print("\n".join(md))
    return 0 if doc["passed"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
