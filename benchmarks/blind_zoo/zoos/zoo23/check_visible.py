"""zoo23: check that every effect changes its recording materially against the clean recording
of the same seed and recording condition, and that no move (effects, clean, reference) falls.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo23/check_visible.py --work WORK \
        [--seed 141] [--out benchmarks/blind_zoo/zoos/zoo23]

Reads ``truth.yaml`` (the effect ids and their recording.excitation only) and the datasets the
harness recorded: ``WORK/effects/<id>``, ``WORK/clean/s<seed>_e<exc>``, ``WORK/reference``.
Writes ``check.json`` and ``check.md`` (no truth in them: ids and numbers only).

Per effect, the moves are paired by bag name with the clean dataset of the same seed and
excitation (same gait parameters, same commands, same sensor-noise seed), so every difference
is the effect's:

- ``xy_final``: |final (x, y) of the effect move - the clean move's| [m], mean and median;
- ``yaw_final``: |final yaw difference| [rad], mean;
- ``state_nrms``: per state element, RMS over time of the difference, divided by that element's
  standard deviation over the clean dataset; mean over moves; the largest element is reported
  and the mean over the 33 elements.

Also, where ``WORK/null`` exists (seed 141 recorded with a 1 g payload, ``WORK/null_effect.yaml``:
a change that should be invisible), its row against the same clean data is the floor of these
measures (numerical sensitivity of the paired comparison), printed for scale, not a condition.

Material: median xy_final >= 0.02 m, or mean yaw_final >= 0.05 rad, or the largest element's
state_nrms >= 0.15. A move falls when the body drops below 0.06 m or |roll| or |pitch| exceeds
0.8 rad at any time.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))
from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.layout import JOINT_NAMES  # noqa: E402

HERE = Path(__file__).resolve().parent
XY_MIN, YAW_MIN, NRMS_MIN = 0.02, 0.05, 0.15
FALL_Z, FALL_ANGLE = 0.06, 0.8


def rpy(quat: np.ndarray) -> np.ndarray:
    x, y, z, w = quat.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], 1)


def state(m) -> np.ndarray:
    """(T, 33): z, body-frame twist, roll, pitch, angular velocity, q, dq (the measured state)."""
    a = rpy(m.orientation)
    return np.column_stack([m.position[:, 2], m.linear_velocity, a[:, :2], m.angular_velocity,
                            m.q, m.dq])


NAMES = (["z", "vx_b", "vy_b", "vz_b", "roll", "pitch", "wx_b", "wy_b", "wz_b"]
         + [f"q_{j}" for j in JOINT_NAMES] + [f"dq_{j}" for j in JOINT_NAMES])


def moves(path: Path) -> dict:
    return {m.name: m for m in load_moves(path, split="all")}


def falls(ms: dict) -> list[str]:
    out = []
    for name, m in ms.items():
        a = rpy(m.orientation)
        if (m.position[:, 2].min() < FALL_Z or np.abs(a[:, 0]).max() > FALL_ANGLE
                or np.abs(a[:, 1]).max() > FALL_ANGLE or not np.all(np.isfinite(m.position))):
            out.append(name)
    return out


def compare(eff: dict, clean: dict) -> dict:
    names = sorted(set(eff) & set(clean))
    cs = np.concatenate([state(clean[n]) for n in names])
    sd = cs.std(0) + 1e-9
    xy, yaw, nrms = [], [], []
    for n in names:
        e, c = eff[n], clean[n]
        xy.append(float(np.hypot(*(e.position[-1, :2] - c.position[-1, :2]))))
        d = rpy(e.orientation)[-1, 2] - rpy(c.orientation)[-1, 2]
        yaw.append(float(abs((d + np.pi) % (2 * np.pi) - np.pi)))
        diff = state(e) - state(c)
        nrms.append(np.sqrt((diff ** 2).mean(0)) / sd)
    nrms = np.mean(nrms, 0)
    k = int(np.argmax(nrms))
    out = {"moves": len(names), "xy_final_mean_m": float(np.mean(xy)),
           "xy_final_median_m": float(np.median(xy)), "yaw_final_mean_rad": float(np.mean(yaw)),
           "state_nrms_max": float(nrms[k]), "state_nrms_max_element": NAMES[k],
           "state_nrms_mean": float(nrms.mean())}
    out["material"] = bool(out["xy_final_median_m"] >= XY_MIN or out["yaw_final_mean_rad"] >= YAW_MIN
                           or out["state_nrms_max"] >= NRMS_MIN)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--seed", type=int, default=141)
    ap.add_argument("--truth", default=str(HERE / "truth.yaml"))
    ap.add_argument("--out", default=str(HERE))
    a = ap.parse_args(argv)
    work, out = Path(a.work), Path(a.out)
    truth = yaml.safe_load(Path(a.truth).read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    t0 = time.time()
    rows, fall_rows = [], []
    cache: dict = {}

    def get(path: Path) -> dict:
        if path not in cache:
            cache[path] = moves(path)
            fall_rows.append({"dataset": str(path.relative_to(work)), "moves": len(cache[path]),
                              "falls": falls(cache[path])})
        return cache[path]

    for d in sorted((work / "clean").iterdir()):
        if (d / "dataset.yaml").is_file():
            get(d)
    if (work / "reference" / "dataset.yaml").is_file():
        get(work / "reference")
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        eff = get(work / "effects" / t["id"])
        clean = get(work / "clean" / f"s{a.seed}_e{exc:g}")
        rows.append({"id": t["id"], "excitation": exc, **compare(eff, clean)})
    floor = None
    if (work / "null" / "dataset.yaml").is_file():
        floor = {"id": "floor (1 g payload)", "excitation": 0.0,
                 **compare(get(work / "null"), get(work / "clean" / f"s{a.seed}_e0"))}
    n_fall = sum(len(f["falls"]) for f in fall_rows)
    summary = {"effects": len(rows), "material": sum(r["material"] for r in rows),
               "datasets checked for falls": len(fall_rows),
               "moves checked": sum(f["moves"] for f in fall_rows), "moves that fall": n_fall,
               "passed": bool(all(r["material"] for r in rows) and n_fall == 0)}
    doc = {"work": str(work), "seed": a.seed,
           "thresholds": {"xy_final_median_m": XY_MIN, "yaw_final_mean_rad": YAW_MIN,
                          "state_nrms_max": NRMS_MIN, "fall_z_m": FALL_Z,
                          "fall_angle_rad": FALL_ANGLE},
           "summary": summary, "effects": rows, "floor": floor, "falls": fall_rows,
           "seconds": round(time.time() - t0, 1)}
    out.mkdir(parents=True, exist_ok=True)
    (out / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    md = ["# zoo23 check_visible", "",
          f"WORK = `{work}`; effects seed {a.seed}; each effect against the clean recording of "
          "the same seed and excitation, moves paired by bag name.", "",
          f"Material if median final-(x,y) difference >= {XY_MIN} m, or mean final-yaw difference "
          f">= {YAW_MIN} rad, or the largest per-element state nRMS >= {NRMS_MIN}. A fall: body "
          f"below {FALL_Z} m or |roll|/|pitch| > {FALL_ANGLE} rad.", "",
          "| effect | exc. | moves | final xy diff mean / median [m] | final yaw diff mean [rad] "
          "| state nRMS max (element) | state nRMS mean | material |",
          "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        md.append(f"| {r['id']} | {r['excitation']:g} | {r['moves']} | {r['xy_final_mean_m']:.3f} / "
                  f"{r['xy_final_median_m']:.3f} | {r['yaw_final_mean_rad']:.3f} | "
                  f"{r['state_nrms_max']:.3f} ({r['state_nrms_max_element']}) | "
                  f"{r['state_nrms_mean']:.3f} | {'yes' if r['material'] else 'NO'} |")
    if floor is not None:
        r = floor
        md.append(f"| {r['id']} | 0 | {r['moves']} | {r['xy_final_mean_m']:.3f} / "
                  f"{r['xy_final_median_m']:.3f} | {r['yaw_final_mean_rad']:.3f} | "
                  f"{r['state_nrms_max']:.3f} ({r['state_nrms_max_element']}) | "
                  f"{r['state_nrms_mean']:.3f} | (floor, not a condition) |")
    md += ["", "| dataset | moves | moves that fall |", "|---|---|---|"]
    for f in fall_rows:
        md.append(f"| {f['dataset']} | {f['moves']} | {len(f['falls'])}"
                  f"{' (' + ', '.join(f['falls']) + ')' if f['falls'] else ''} |")
    md += ["", "Summary: " + "; ".join(f"{k} {v}" for k, v in summary.items()), ""]
    (out / "check.md").write_text("\n".join(md))
    print("\n".join(md))
    return 0 if summary["passed"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
