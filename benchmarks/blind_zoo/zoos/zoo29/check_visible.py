"""Check that every effect of zoo29 changes the recordings materially, and that no move falls.

Each effect dataset (WORK/effects/<id>) is compared move by move with the clean dataset of the
same seed and the same command excitation (WORK/clean/s<seed>_e<exc>): same commands, same
sensor-noise seed, so every difference is the effect's. Per move type: mean final (x, y)
difference, mean |final yaw difference|, RMS joint-angle difference, and over the whole dataset
the RMS difference of the 33 state elements (body: z, roll, pitch, base_link twist; joints: q,
dq) relative to each element's spread in the clean data (mean over elements), and the share of
motion-capture frames that repeat the previous pose exactly. Material: mean final (x, y)
difference >= 2 cm, or mean |yaw difference| >= 0.05 rad, or mean normalised state RMS
difference >= 0.2 (over the 33 elements, or over the 9 body elements alone). A move "falls" when its body drops below 6 cm or tilts beyond 1 rad.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo29/check_visible.py --work /tmp/s64/z29 \
        [--null /tmp/s64/z29/check_null]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.layout import MOVE_TYPES

XY_MIN, YAW_MIN, STATE_MIN = 0.02, 0.05, 0.2


def euler(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], 1)


def states(m) -> np.ndarray:
    e = euler(m.orientation)
    return np.column_stack([m.position[:, 2], m.linear_velocity, e[:, :2], m.angular_velocity,
                            m.q, m.dq])


def falls(m) -> bool:
    e = euler(m.orientation)
    return bool(m.position[:, 2].min() < 0.06 or np.abs(e[:, :2]).max() > 1.0)


def repeats(m) -> float:
    d = np.abs(np.diff(m.position, axis=0)).max(1)
    return float(np.mean(d == 0.0))


def compare(eff_dir: Path, clean_dir: Path) -> dict:
    eff = {m.name: m for m in load_moves(eff_dir, split="all")}
    clean = {m.name: m for m in load_moves(clean_dir, split="all")}
    names = [n for n in eff if n in clean]
    spread = np.concatenate([states(clean[n]) for n in names]).std(0) + 1e-9
    per_type: dict[str, dict] = {}
    rows = []
    for n in names:
        a, b = eff[n], clean[n]
        dxy = float(np.hypot(*(a.position[-1, :2] - b.position[-1, :2])))
        dyaw = float(abs((euler(a.orientation)[-1, 2] - euler(b.orientation)[-1, 2] + np.pi)
                         % (2 * np.pi) - np.pi))
        dq = float(np.sqrt(np.mean((a.q - b.q) ** 2)))
        ds = np.sqrt(np.mean((states(a) - states(b)) ** 2, 0)) / spread
        rows.append({"move": n, "type": a.move_type, "dxy": dxy, "dyaw": dyaw, "dq_rms": dq,
                     "state_nrms": float(ds.mean()), "body_nrms": float(ds[:9].mean()), "fell": falls(a), "clean_fell": falls(b),
                     "repeat_share": repeats(a), "clean_repeat_share": repeats(b)})
    for t in MOVE_TYPES:
        r = [x for x in rows if x["type"] == t]
        if r:
            per_type[t] = {k: float(np.mean([x[k] for x in r]))
                           for k in ("dxy", "dyaw", "dq_rms", "state_nrms")}
    summ = {k: float(np.mean([x[k] for x in rows]))
            for k in ("dxy", "dyaw", "dq_rms", "state_nrms", "body_nrms", "repeat_share",
                      "clean_repeat_share")}
    summ["falls"] = sum(x["fell"] for x in rows)
    summ["clean_falls"] = sum(x["clean_fell"] for x in rows)
    summ["moves"] = len(rows)
    summ["material"] = bool(summ["dxy"] >= XY_MIN or summ["dyaw"] >= YAW_MIN
                            or summ["state_nrms"] >= STATE_MIN
                            or summ["body_nrms"] >= STATE_MIN)
    return {"summary": summ, "per_type": per_type}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    ap.add_argument("--zoo", default=str(Path(__file__).parent))
    ap.add_argument("--seed", type=int, default=201)
    ap.add_argument("--null", default=None,
                    help="a control dataset of the same seed with a negligible effect (0.01 N "
                         "horizontal force), recorded outside the harness, shown as the floor")
    ap.add_argument("--out", default=None, help="directory for check.md/json (default: the zoo)")
    a = ap.parse_args()
    zoo, work = Path(a.zoo), Path(a.work)
    truth = yaml.safe_load((zoo / "truth.yaml").read_text())["effects"]
    out = Path(a.out) if a.out else zoo
    res = {}
    control = (compare(Path(a.null), work / "clean" / f"s{a.seed}_e0") if a.null else None)
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        res[t["id"]] = {"excitation": exc,
                        **compare(work / "effects" / t["id"], work / "clean" / f"s{a.seed}_e{exc:g}")}
    lines = ["# zoo29: is every effect material? (check_visible.py)", "",
             f"Each effect dataset against the clean dataset of seed {a.seed} and the same "
             "excitation, move by move. Material: mean final (x, y) difference >= "
             f"{XY_MIN} m, or mean |final yaw difference| >= {YAW_MIN} rad, or mean normalised "
             f"state RMS difference >= {STATE_MIN} (over the 33 state elements, or over the 9 body "
             "elements alone).", "",
             "| effect | exc. | final dxy [m] | final dyaw [rad] | q RMS diff [rad] | state nRMS diff | "
             "body nRMS diff | repeated mocap frames (clean) | falls (clean) | material |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for k, r in res.items():
        s = r["summary"]
        lines.append(f"| {k} | {r['excitation']:g} | {s['dxy']:.3f} | {s['dyaw']:.3f} | "
                     f"{s['dq_rms']:.4f} | {s['state_nrms']:.3f} | {s['body_nrms']:.3f} | "
                     f"{s['repeat_share']:.1%} "
                     f"({s['clean_repeat_share']:.1%}) | {s['falls']} ({s['clean_falls']}) | "
                     f"{'yes' if s['material'] else 'NO'} |")
    if control is not None:
        s = control["summary"]
        lines.append(f"| control: 0.01 N force (floor) | 0 | {s['dxy']:.3f} | {s['dyaw']:.3f} | "
                     f"{s['dq_rms']:.4f} | {s['state_nrms']:.3f} | {s['body_nrms']:.3f} | "
                     f"{s['repeat_share']:.1%} ({s['clean_repeat_share']:.1%}) | "
                     f"{s['falls']} ({s['clean_falls']}) | {'yes' if s['material'] else 'no'} |")
    lines += ["", "Per move type, mean final (x, y) difference [m] / |yaw difference| [rad]:", "",
              "| effect | " + " | ".join(MOVE_TYPES) + " |", "|---|" + "---|" * len(MOVE_TYPES)]
    for k, r in res.items():
        pt = r["per_type"]
        lines.append(f"| {k} | " + " | ".join(
            f"{pt[t]['dxy']:.3f} / {pt[t]['dyaw']:.2f}" if t in pt else "-" for t in MOVE_TYPES)
            + " |")
    if control is not None:
        lines += ["", "The control row is a dataset of the same seed with a 0.01 N horizontal force "
                  "(recorded outside the harness, with the same robot, only for this check): the "
                  "floor of these differences."]
    n = sum(r["summary"]["material"] for r in res.values())
    lines += ["", f"Material: {n} of {len(res)}; moves that fell: "
              f"{sum(r['summary']['falls'] for r in res.values())}."]
    out.mkdir(parents=True, exist_ok=True)
    (out / "check.md").write_text("\n".join(lines) + "\n")
    doc = {"effects": res, "control_null": control,
           "criteria": {"final_xy_m": XY_MIN, "final_yaw_rad": YAW_MIN, "state_nrms": STATE_MIN}}
    (out / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
