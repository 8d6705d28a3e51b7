"""Visibility and fall check of zoo43's datasets (SEALED: its output names per-effect numbers).

Every effect dataset is compared with the clean dataset of the same seed and excitation (moves
paired by name: the same commands and sensor-noise draws), beside a control (a negligible
perturbation, ``control.yaml``) recorded with the same seed and excitation; every dataset
recorded is checked for falls (body above 0.1 m, upright: body z axis within about 26 deg of
vertical, so that a stumble counts too).

    # small, self-recorded (3 moves per type) to tune magnitudes:
    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo43/check_visible.py --small SCRATCH
    # the harness's recordings (records the controls into WORK/control/ if missing):
    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo43/check_visible.py --work WORK

Measures, per effect: ``state``: per move, the RMS over its samples of the effect-minus-clean
difference of each of the 33 state elements divided by that element's std in the clean data,
averaged over the elements, then the median over moves; ``xy``: the median over moves of the
distance between the final (x, y) positions (the means are reported too). Medians, because a
single move of the control can take another gait branch (contact chaos) and dominate a mean.
Material: both measures at least 3x the control's of the same excitation, and
``state`` >= 0.05 or ``xy`` >= 0.02 m.
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

from littledog_mlsim.apps.record import record_dataset  # noqa: E402
from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.data.states import states_from_recording  # noqa: E402
from littledog_mlsim.rotations import quat_to_matrix  # noqa: E402

SEED = 341
ROBOT = HERE / "gap_robot.json"
RATIO = 3.0
MIN_STATE, MIN_XY = 0.05, 0.02
UPRIGHT = 0.9            # body z axis within about 26 deg of vertical


def truth() -> list[dict]:
    return yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]


def moves(path: Path) -> dict:
    return {m.name: m for m in load_moves(path, split="all")}


def compare(eff: dict, clean: dict) -> dict:
    names = sorted(set(eff) & set(clean))
    sc_all = np.vstack([states_from_recording(clean[n]) for n in names])
    std = sc_all.std(axis=0)
    std = np.where(std > 1e-12, std, 1.0)
    per_state, per_xy = [], []
    for n in names:
        se, sc = states_from_recording(eff[n]), states_from_recording(clean[n])
        per_state.append(float(np.mean(np.sqrt(np.mean((se - sc) ** 2, axis=0)) / std)))
        per_xy.append(float(np.hypot(*(eff[n].position[-1, :2] - clean[n].position[-1, :2]))))
    return {"state": float(np.median(per_state)), "xy_m": float(np.median(per_xy)),
            "state_mean": float(np.mean(per_state)), "xy_mean_m": float(np.mean(per_xy)),
            "moves": len(names)}


def falls(path: Path) -> dict:
    bad = []
    ms = load_moves(path, split="all")
    zmin, upmin = np.inf, np.inf
    for m in ms:
        z = float(np.min(m.position[:, 2]))
        up = float(np.min(quat_to_matrix(np.asarray(m.orientation))[:, 2, 2]))
        zmin, upmin = min(zmin, z), min(upmin, up)
        if not (z > 0.1 and up > UPRIGHT):
            bad.append(m.name)
    return {"moves": len(ms), "fell": bad, "min_z_m": zmin, "min_up_z": upmin}


def rec(out: Path, effects: Path | None, exc: float, n: int) -> Path:
    if not (out / "dataset.yaml").is_file():
        record_dataset(out, moves_per_type=n, seed=SEED, robot=str(ROBOT), jobs=2,
                       progress=False, excitation=exc,
                       effects_file=str(effects) if effects else None)
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--small", type=Path, help="record 3 moves per type here and check them")
    g.add_argument("--work", type=Path, help="the harness's WORK: check its recordings")
    ap.add_argument("--only", default="")
    a = ap.parse_args()
    t = truth()
    if a.only:
        t = [x for x in t if x["id"] in a.only.split(",")]
    excs = sorted({0.0} | {float(x["recording"]["excitation"]) for x in t})
    if a.small:
        base, n = a.small, 3
        clean = {e: rec(base / f"clean_e{e:g}", None, e, n) for e in excs}
        effs = {x["id"]: rec(base / x["id"], HERE / "effects" / x["file"],
                             float(x["recording"]["excitation"]), n) for x in t}
        others = []
    else:
        base, n = a.work, 10
        clean = {e: base / "clean" / f"s{SEED}_e{e:g}" for e in excs}
        effs = {x["id"]: base / "effects" / x["id"] for x in t}
        others = sorted(p for p in (base / "clean").iterdir() if (p / "dataset.yaml").is_file())
        others += [base / "reference"]
    control = {e: rec(base / "control" / f"s{SEED}_e{e:g}", HERE / "control.yaml", e, n)
               for e in excs}
    cm = {e: moves(p) for e, p in clean.items()}
    ctl = {e: compare(moves(control[e]), cm[e]) for e in excs}
    rows, ok_all = [], True
    for x in t:
        e = float(x["recording"]["excitation"])
        c = compare(moves(effs[x["id"]]), cm[e])
        c["state_vs_control"] = c["state"] / max(ctl[e]["state"], 1e-12)
        c["xy_vs_control"] = c["xy_m"] / max(ctl[e]["xy_m"], 1e-12)
        c["material"] = bool(c["state_vs_control"] >= RATIO and c["xy_vs_control"] >= RATIO
                             and (c["state"] >= MIN_STATE or c["xy_m"] >= MIN_XY))
        c["falls"] = falls(effs[x["id"]])
        c["excitation"] = e
        ok_all &= c["material"] and not c["falls"]["fell"]
        rows.append((x["id"], c))
    fall_rows = [(p.relative_to(base).as_posix(), falls(p))
                 for p in others + [control[e] for e in excs]]
    ok_all &= all(not f["fell"] for _, f in fall_rows)
    doc = {"mode": "small" if a.small else "full", "moves_per_type": n, "seed": SEED,
           "ratio_target": RATIO, "upright_min_up_z": UPRIGHT, "min_state": MIN_STATE, "min_xy_m": MIN_XY,
           "control": {f"{e:g}": v for e, v in ctl.items()},
           "effects": dict(rows), "other_datasets": dict(fall_rows), "all_passed": ok_all}
    lines = [f"# zoo43 visibility and fall check ({doc['mode']}, {n} moves per type, seed "
             f"{SEED})", "",
             "Effect vs clean of the same seed and excitation; control = a negligible "
             "perturbation (0.001 N) of the same seed and excitation.", "",
             "| dataset | exc. | state diff (median) | x control | final xy diff [m] (median) | "
             "x control | state / xy diff (means) | material | moves | fell | min z [m] | "
             "min up |", "|" + "---|" * 12]
    for e, v in ctl.items():
        lines.append(f"| control | {e:g} | {v['state']:.4f} | 1 | {v['xy_m']:.4f} | 1 | "
                     f"{v['state_mean']:.4f} / {v['xy_mean_m']:.4f} | - | {v['moves']} | "
                     f"- | - | - |")
    for i, c in rows:
        f = c["falls"]
        lines.append(f"| {i} | {c['excitation']:g} | {c['state']:.4f} | "
                     f"{c['state_vs_control']:.1f} | {c['xy_m']:.4f} | "
                     f"{c['xy_vs_control']:.1f} | {c['state_mean']:.4f} / "
                     f"{c['xy_mean_m']:.4f} | {'yes' if c['material'] else 'NO'} | "
                     f"{f['moves']} | {len(f['fell'])} | {f['min_z_m']:.3f} | "
                     f"{f['min_up_z']:.3f} |")
    lines += ["", "| other dataset | moves | fell | min z [m] | min body z-axis up |",
              "|---|---|---|---|---|"]
    for name, f in fall_rows:
        lines.append(f"| {name} | {f['moves']} | {len(f['fell'])} | {f['min_z_m']:.3f} | "
                     f"{f['min_up_z']:.3f} |")
    lines += ["", f"All passed: {'yes' if ok_all else 'NO'}"]
    text = "\n".join(lines) + "\n"
    print(text)
    if a.work:
        (HERE / "check.md").write_text(text)
        (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())
