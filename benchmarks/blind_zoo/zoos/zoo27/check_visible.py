"""Check zoo27's recorded datasets: is each effect dataset materially different from the clean
dataset of the same seed and recording condition (same commands, same sensor noise), and does
any move of any dataset (effects, clean, reference) fall?

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo27/check_visible.py --work WORK

Writes check.md and check.json beside this file. Per move (effect vs clean, matched by bag name):
the final (x, y) difference, the final yaw difference, the RMS over time of the joint-angle
difference (mean over the 12 joints) and of the body-velocity difference. A dataset is material if
any of: mean final (x, y) difference >= 2 cm, mean |final yaw difference| >= 0.05 rad, mean
joint-angle RMS difference >= 0.02 rad, mean body-velocity RMS difference >= 0.02 m/s. A move
falls if |roll| or |pitch| exceeds 0.6 rad or the body drops below 60 % of its start height.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))
from littledog_mlsim.data.dataset import load_moves  # noqa: E402

TH = {"final_xy_m": 0.02, "final_yaw_rad": 0.05, "q_rms_rad": 0.02, "v_rms_m_s": 0.02}


def euler(qxyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = qxyzw.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=1)


def falls(moves) -> list[str]:
    out = []
    for m in moves:
        e = euler(m.orientation)
        z = m.position[:, 2]
        if (np.abs(e[:, :2]).max() > 0.6 or z.min() < 0.6 * z[0]
                or not np.all(np.isfinite(m.position))):
            out.append(m.name)
    return out


def compare(eff, clean) -> dict:
    by = {m.name: m for m in clean}
    rows = []
    for m in eff:
        c = by[m.name]
        ye = np.unwrap(euler(m.orientation)[:, 2])
        yc = np.unwrap(euler(c.orientation)[:, 2])
        rows.append({
            "move": m.name,
            "final_xy_m": float(np.hypot(*(m.position[-1, :2] - c.position[-1, :2]))),
            "final_yaw_rad": float(abs(ye[-1] - yc[-1])),
            "q_rms_rad": float(np.sqrt(np.mean((m.q - c.q) ** 2))),
            "v_rms_m_s": float(np.sqrt(np.mean((m.linear_velocity - c.linear_velocity) ** 2))),
        })
    mean = {k: float(np.mean([r[k] for r in rows])) for k in TH}
    changed = sum(any(r[k] >= TH[k] for k in TH) for r in rows)
    return {"mean": mean, "moves": len(rows), "moves_over_threshold": changed,
            "material": any(mean[k] >= TH[k] for k in TH), "per_move": rows}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    cache: dict[str, list] = {}

    def moves(path: Path):
        if str(path) not in cache:
            cache[str(path)] = load_moves(path, "all")
        return cache[str(path)]

    doc: dict = {"thresholds": TH, "effects": {}, "falls": {}}
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        eff = moves(work / "effects" / t["id"])
        clean = moves(work / "clean" / f"s181_e{exc:g}")
        r = compare(eff, clean)
        r["excitation"] = exc
        doc["effects"][t["id"]] = r
    for d in sorted((work / "clean").iterdir()) + sorted((work / "effects").iterdir()) + [
            work / "reference"]:
        if d.is_dir() and (d / "dataset.yaml").is_file():
            f = falls(moves(d))
            doc["falls"][f"{d.parent.name}/{d.name}" if d.name != "reference" else "reference"] = {
                "moves": len(moves(d)), "fallen": f}
    doc["all_material"] = all(r["material"] for r in doc["effects"].values())
    doc["no_falls"] = all(not v["fallen"] for v in doc["falls"].values())
    lines = ["# zoo27: check_visible", "",
             "Each effect dataset against the clean dataset of the same seed (181) and recording "
             "condition (same commands and sensor noise), means over its 110 moves. Thresholds "
             "(material if any is reached): " + ", ".join(f"{k} >= {v:g}" for k, v in TH.items()),
             "", "| id | excitation | final xy [m] | final yaw [rad] | q RMS [rad] | "
             "v RMS [m/s] | moves over a threshold | material |", "|---|---|---|---|---|---|---|---|"]
    for i, r in doc["effects"].items():
        m = r["mean"]
        lines.append(f"| {i} | {r['excitation']:g} | {m['final_xy_m']:.4f} | "
                     f"{m['final_yaw_rad']:.4f} | {m['q_rms_rad']:.4f} | {m['v_rms_m_s']:.4f} | "
                     f"{r['moves_over_threshold']}/{r['moves']} | "
                     f"{'yes' if r['material'] else 'NO'} |")
    lines += ["", "Falls (|roll| or |pitch| > 0.6 rad, or body below 60 % of its start height):",
              "", "| dataset | moves | fallen |", "|---|---|---|"]
    for k, v in doc["falls"].items():
        lines.append(f"| {k} | {v['moves']} | {', '.join(v['fallen']) or 'none'} |")
    lines += ["", f"All effects material: {'yes' if doc['all_material'] else 'NO'}. "
              f"No move falls: {'yes' if doc['no_falls'] else 'NO'}.", ""]
    (HERE / "check.md").write_text("\n".join(lines))
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    print("\n".join(lines))
    return 0 if doc["all_material"] and doc["no_falls"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
