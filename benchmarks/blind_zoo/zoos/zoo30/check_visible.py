"""Visibility / materiality check of zoo30: every effect dataset against the clean dataset of the
same seed and excitation (recorded by harness/run.py --record-only into WORK), and a fall check
of every dataset (effects, clean, reference).

    OPENBLAS_NUM_THREADS=1 /work/main/.venv/bin/python check_visible.py --work /tmp/s65/z30

Per effect (TestPool and TrainPool moves, paired by name with the clean dataset):
- final (x, y) difference [m] per move: mean and max;
- RMS difference of the body (x, y) path over the move [m], mean over moves;
- RMS difference of the joint angles (all 12, over the move) [rad] and the change of the
  joints' RMS tracking error |u - q| [rad];
- a quick learned one-step model: ridge regression of s_{t+1} - s_t on (s_t, u_t) trained on
  the clean TrainPool of the same seed and excitation; nMSE (mean over the 33 state elements,
  normalised by the clean TestPool's variance of the increment) on the effect's TestPool
  divided by that on the clean TestPool. The noise floor of that ratio is the same model on the
  other clean seeds' TestPools (212, 213: other gaits, other sensor noise).
Fall check: every move keeps the body above 0.07 m (home ~0.14 m) and |roll|, |pitch| < 0.6 rad.
Material: ratio above max(1.25, 1.2 x the clean seeds' worst) OR mean final (x, y) difference
> 0.02 m (50x the motion-capture noise) OR joint RMS difference > 0.02 rad.
Writes check.json and check.md beside this script.
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
from littledog_mlsim.data.dataset import load_moves          # noqa: E402
from littledog_mlsim.data.states import features_responses   # noqa: E402

Z_MIN, TILT_MAX = 0.07, 0.6
RATIO_MIN, FINAL_MIN, JOINT_MIN = 1.25, 0.02, 0.02


def roll_pitch(orn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y, z, w = orn.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    return roll, pitch


def falls(moves) -> list[str]:
    out = []
    for m in moves:
        r, pch = roll_pitch(m.orientation)
        if m.position[:, 2].min() < Z_MIN or np.abs(r).max() > TILT_MAX or np.abs(pch).max() > TILT_MAX:
            out.append(m.name)
    return out


class Ridge:
    def __init__(self, train, lam: float = 1e-3) -> None:
        X, Y, _ = features_responses(train)
        D = Y - X[:, :33]
        self.mu, self.sd = X.mean(0), X.std(0) + 1e-9
        Z = np.hstack([(X - self.mu) / self.sd, np.ones((len(X), 1))])
        self.W = np.linalg.solve(Z.T @ Z + lam * len(X) * np.eye(Z.shape[1]), Z.T @ D)

    def residual(self, moves) -> np.ndarray:
        X, Y, _ = features_responses(moves)
        Z = np.hstack([(X - self.mu) / self.sd, np.ones((len(X), 1))])
        return (Y - X[:, :33]) - Z @ self.W


def nmse(res: np.ndarray, var: np.ndarray) -> float:
    return float(np.mean(np.mean(res ** 2, 0) / var))


def compare(eff, clean) -> dict:
    by = {m.name: m for m in clean}
    fin, path, jq, jtrack = [], [], [], []
    for m in eff:
        c = by[m.name]
        fin.append(float(np.linalg.norm(m.position[-1, :2] - c.position[-1, :2])))
        path.append(float(np.sqrt(np.mean(np.sum((m.position[:, :2] - c.position[:, :2]) ** 2, 1)))))
        jq.append(float(np.sqrt(np.mean((m.q - c.q) ** 2))))
        te = np.sqrt(np.mean((m.cmd - m.q[1:]) ** 2))
        tc = np.sqrt(np.mean((c.cmd - c.q[1:]) ** 2))
        jtrack.append(float(te - tc))
    return {"final_xy_diff_mean_m": float(np.mean(fin)), "final_xy_diff_max_m": float(np.max(fin)),
            "path_xy_rms_diff_m": float(np.mean(path)), "joint_rms_diff_rad": float(np.mean(jq)),
            "tracking_rms_change_rad": float(np.mean(jtrack))}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", default="/tmp/s65/z30")
    ap.add_argument("--only", default="", help="comma-separated ids: print these, write nothing")
    a = ap.parse_args()
    work = Path(a.work)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    only = {x for x in a.only.split(",") if x}
    seed = 211
    cache: dict = {}

    def moves(path: Path, split: str = "all"):
        key = (str(path), split)
        if key not in cache:
            cache[key] = load_moves(path, split)
        return cache[key]

    fall_report = {}
    for d in [] if only else sorted((work / "clean").iterdir()) + [work / "reference"]:
        if (d / "dataset.yaml").is_file():
            fall_report[f"clean/{d.name}" if d.parent.name == "clean" else d.name] = falls(moves(d))
    models, floors = {}, {}
    for exc in sorted({float((t.get("recording") or {}).get("excitation", 0.0)) for t in truth}):
        cpath = work / "clean" / f"s{seed}_e{exc:g}"
        model = Ridge(moves(cpath, "train"))
        res_c = model.residual(moves(cpath, "test"))
        var = np.var(features_responses(moves(cpath, "test"))[1]
                     - features_responses(moves(cpath, "test"))[0][:, :33], 0) + 1e-12
        base = nmse(res_c, var)
        others = {}
        if exc == 0.0 and not only:
            for s in (212, 213):
                op = work / "clean" / f"s{s}_e0"
                others[s] = nmse(model.residual(moves(op, "test")), var) / base
        models[exc] = (model, var, base)
        floors[exc] = others
    floor = max([1.0] + [v for o in floors.values() for v in o.values()])
    ratio_min = max(RATIO_MIN, 1.2 * floor)

    rows = []
    for t in truth:
        if only and t["id"] not in only:
            continue
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        epath = work / "effects" / t["id"]
        cpath = work / "clean" / f"s{seed}_e{exc:g}"
        eff, cl = moves(epath), moves(cpath)
        r = {"id": t["id"], "excitation": exc, **compare(eff, cl)}
        model, var, base = models[exc]
        r["onestep_nmse_ratio"] = nmse(model.residual(moves(epath, "test")), var) / base
        r["falls"] = falls(eff)
        r["material"] = bool(r["onestep_nmse_ratio"] > ratio_min
                             or r["final_xy_diff_mean_m"] > FINAL_MIN
                             or r["joint_rms_diff_rad"] > JOINT_MIN)
        r["pass"] = bool(r["material"] and not r["falls"])
        rows.append(r)
    doc = {"work": str(work), "seed": seed, "clean_seed_nmse_ratio_floor": floors,
           "ratio_threshold": ratio_min, "final_xy_threshold_m": FINAL_MIN,
           "joint_rms_threshold_rad": JOINT_MIN, "falls_clean_reference": fall_report,
           "effects": rows, "all_pass": all(r["pass"] for r in rows)
           and not any(fall_report.values())}
    if only:
        print(json.dumps(rows, indent=1))
        return 0
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo30 visibility / materiality check", "",
             f"WORK `{work}`, seed {seed}, 10 moves per type (110 moves per dataset). "
             "Each effect against the clean dataset of the same seed and excitation.", "",
             f"Quick one-step model (ridge on (s_t, u_t), trained on the clean TrainPool): the "
             f"clean seeds 212 / 213 give ratios {', '.join(f'{v:.3f}' for o in floors.values() for v in o.values())} "
             f"(noise floor); threshold {ratio_min:.3f}. Other thresholds: mean final (x, y) "
             f"difference > {FINAL_MIN} m, joint RMS difference > {JOINT_MIN} rad (any one).", "",
             "| id | exc. | final xy diff mean / max [m] | path xy RMS diff [m] | joint RMS diff [rad] | tracking RMS change [rad] | one-step nMSE ratio | falls | pass |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['id']} | {r['excitation']:g} | {r['final_xy_diff_mean_m']:.4f} / "
                     f"{r['final_xy_diff_max_m']:.4f} | {r['path_xy_rms_diff_m']:.4f} | "
                     f"{r['joint_rms_diff_rad']:.4f} | {r['tracking_rms_change_rad']:+.4f} | "
                     f"{r['onestep_nmse_ratio']:.3f} | {len(r['falls'])} | "
                     f"{'yes' if r['pass'] else 'NO'} |")
    lines += ["", "Falls in the clean datasets and the reference: " + ", ".join(
        f"{k}: {len(v)}" for k, v in fall_report.items()), "",
        f"**All pass: {'yes' if doc['all_pass'] else 'NO'}**", ""]
    (HERE / "check.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if doc["all_pass"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
