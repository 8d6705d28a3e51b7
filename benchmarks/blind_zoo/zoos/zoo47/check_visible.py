"""zoo47 (SEALED): does every effect change the recordings materially, and does no move fall?

Reads the datasets ``harness/run.py --record-only`` made in WORK (``WORK/effects/<id>``,
``WORK/clean/s<seed>_e<exc>``, ``WORK/reference``) and the zoo's ``truth.yaml`` (for each
effect's recording condition), and writes ``<prefix>.json`` and ``<prefix>.md``.

Two measures per effect, both against the clean dataset of the same seed and recording
condition (the same moves: the same commands, gait and sensor seeds):

1. **Paired differences.** Move by move, the effect's recording minus its clean counterpart:
   the RMS difference of each state group (``data.states``: body height, body displacement per
   step, roll/pitch, their rates, joint angles, joint rates) in units of that group's spread in
   the clean data, averaged over moves; and the difference of the final (x, y) position [m]
   and yaw [rad], averaged over moves.
2. **A clean one-step model's error.** A ridge-regularised linear one-step model (the paper's
   45 features, target s_{t+1} - s_t) is fitted to the clean dataset's TrainPool and scored on
   TestPools: the clean one of the same seed, the other clean seeds (the floor: what another
   seed alone changes) and the effect's. Per state element, nMSE(effect) / nMSE(clean, same
   seed), and the same ratio for each other clean seed.

An effect is **material** when its largest one-step ratio is at least ``RATIO_MIN`` and at least
``FLOOR_MARGIN`` times the largest ratio any other clean seed reaches, or when its mean final
(x, y) difference is at least ``XY_MIN_M`` (the path after 4 s visibly elsewhere). A move
**falls** when the body's height drops below ``FALL_Z_M`` or |roll| or |pitch| exceeds
``FALL_TILT_RAD``.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo47/check_visible.py --zoo benchmarks/blind_zoo/zoos/zoo47 \\
        --work WORK --out-prefix benchmarks/blind_zoo/zoos/zoo47/check
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.data.states import features_responses, states_from_recording
from littledog_mlsim.layout import N_STATE, STATE_NAMES, S
from littledog_mlsim.rotations import quat_to_rpy

RATIO_MIN = 1.25
FLOOR_MARGIN = 1.2
XY_MIN_M = 0.02
FALL_Z_M = 0.07
FALL_TILT_RAD = 0.7
RIDGE = 1e-3

GROUPS = {"z_w": [S.z_w], "d_b": list(range(1, 4)), "roll_pitch": [4, 5],
          "d_rpy": list(range(6, 9)), "q": list(range(9, 21)), "dq": list(range(21, 33))}


class OneStep:
    """Ridge linear model of s_{t+1} - s_t on standardised (s_t, u_t)."""

    def fit(self, X: np.ndarray, Y: np.ndarray) -> "OneStep":
        self.mu, self.sd = X.mean(0), X.std(0)
        self.sd[self.sd < 1e-12] = 1.0
        Z = np.hstack([(X - self.mu) / self.sd, np.ones((len(X), 1))])
        D = Y - X[:, :N_STATE]
        A = Z.T @ Z + RIDGE * len(Z) * np.diag([1.0] * (Z.shape[1] - 1) + [0.0])
        self.W = np.linalg.solve(A, Z.T @ D)
        return self

    def predict(self, X: np.ndarray) -> np.ndarray:
        Z = np.hstack([(X - self.mu) / self.sd, np.ones((len(X), 1))])
        return X[:, :N_STATE] + Z @ self.W


_LOADED: dict[str, tuple[list, list]] = {}


def moves(directory: Path, split: str) -> list:
    """The dataset's moves of ``split`` (train, test, all), each bag read once."""
    key = str(directory)
    if key not in _LOADED:
        _LOADED[key] = (load_moves(directory, "train"), load_moves(directory, "test"))
    train, test = _LOADED[key]
    return {"train": train, "test": test, "all": train + test}[split]


def falls(recs) -> list[str]:
    out = []
    for r in recs:
        rpy = quat_to_rpy(np.asarray(r.orientation))
        if (np.min(r.position[:, 2]) < FALL_Z_M
                or np.max(np.abs(rpy[:, :2])) > FALL_TILT_RAD):
            out.append(r.name)
    return out


def paired(effect, clean) -> dict:
    by = {r.name: r for r in clean}
    allc = np.vstack([states_from_recording(r) for r in clean])
    spread = {g: float(np.sqrt(np.mean(np.var(allc[:, ix], axis=0)))) for g, ix in GROUPS.items()}
    groups = {g: [] for g in GROUPS}
    dxy, dyaw, same_cmd = [], [], True
    for e in effect:
        c = by[e.name]
        same_cmd &= bool(np.array_equal(e.cmd, c.cmd))
        se, sc = states_from_recording(e), states_from_recording(c)
        for g, ix in GROUPS.items():
            groups[g].append(float(np.sqrt(np.mean((se[:, ix] - sc[:, ix]) ** 2))) / spread[g])
        dxy.append(float(np.linalg.norm(e.position[-1, :2] - c.position[-1, :2])))
        ye, yc = quat_to_rpy(e.orientation[-1:])[0, 2], quat_to_rpy(c.orientation[-1:])[0, 2]
        dyaw.append(float(abs((ye - yc + np.pi) % (2 * np.pi) - np.pi)))
    return {"same_commands": same_cmd, "moves": len(effect),
            "rms_diff_over_spread": {g: float(np.mean(v)) for g, v in groups.items()},
            "final_xy_diff_m_mean": float(np.mean(dxy)),
            "final_xy_diff_m_median": float(np.median(dxy)),
            "final_yaw_diff_rad_mean": float(np.mean(dyaw))}


def nmse(model: OneStep, recs, var: np.ndarray) -> np.ndarray:
    X, Y, _ = features_responses(recs)
    return np.mean((model.predict(X) - Y) ** 2, axis=0) / var


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--zoo", required=True, help="the zoo directory (truth.yaml)")
    ap.add_argument("--work", required=True, help="the harness's work directory")
    ap.add_argument("--out-prefix", required=True, help="writes PREFIX.json and PREFIX.md")
    ap.add_argument("--seed", type=int, default=381, help="the effects' seed")
    ap.add_argument("--only", default="", help="comma-separated effect ids")
    a = ap.parse_args(argv)
    t0 = time.time()
    zoo, work = Path(a.zoo), Path(a.work)
    truth = yaml.safe_load((zoo / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    only = {s for s in a.only.split(",") if s}
    truth = [t for t in truth if not only or t["id"] in only]

    clean_dirs = sorted(d for d in (work / "clean").iterdir() if (d / "dataset.yaml").is_file())
    fall = {}
    for d in clean_dirs + ([work / "reference"] if (work / "reference").is_dir() else []):
        fall[f"clean/{d.name}" if d.parent.name == "clean" else d.name] = falls(
            moves(d, "all"))

    cache: dict[str, tuple] = {}

    def clean_model(exc: float):
        key = f"s{a.seed}_e{exc:g}"
        if key not in cache:
            train = moves(work / "clean" / key, "train")
            X, Y, _ = features_responses(train)
            model = OneStep().fit(X, Y)
            test = moves(work / "clean" / key, "test")
            Xt, Yt, _ = features_responses(test)
            var = np.var(Yt, axis=0)
            var[var < 1e-18] = 1.0
            base = nmse(model, test, var)
            floors = {}
            for d in clean_dirs:
                if d.name != key and d.name.endswith(f"_e{exc:g}"):
                    floors[d.name] = nmse(model, moves(d, "test"), var) / base
            if not floors:           # no other seed under this condition: the plain ones
                for d in clean_dirs:
                    if d.name.endswith("_e0") and d.name != key:
                        floors[d.name] = None
            cache[key] = (model, var, base, floors, moves(work / "clean" / key, "all"))
        return cache[key]

    rows = []
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        model, var, base, floors, clean_all = clean_model(exc)
        eff_all = moves(work / "effects" / t["id"], "all")
        eff_test = moves(work / "effects" / t["id"], "test")
        ratio = nmse(model, eff_test, var) / base
        floor_max = max((float(np.max(v)) for v in floors.values() if v is not None),
                        default=None)
        if floor_max is None:       # an excited condition with one clean seed: the plain floor
            _, _, _, f0, _ = clean_model(0.0)
            floor_max = max(float(np.max(v)) for v in f0.values() if v is not None)
        pr = paired(eff_all, clean_all)
        top = np.argsort(ratio)[::-1][:3]
        by_ratio = bool(ratio.max() >= RATIO_MIN and ratio.max() >= FLOOR_MARGIN * floor_max)
        by_path = bool(pr["final_xy_diff_m_mean"] >= XY_MIN_M)
        fell = falls(eff_all)
        rows.append({"id": t["id"], "excitation": exc,
                     "onestep_ratio_max": float(ratio.max()),
                     "onestep_ratio_top": {STATE_NAMES[i]: float(ratio[i]) for i in top},
                     "onestep_ratio_mean": float(np.mean(ratio)),
                     "clean_floor_ratio_max": floor_max,
                     "paired": pr, "material_by_onestep": by_ratio,
                     "material_by_path": by_path, "material": by_ratio or by_path,
                     "falls": fell})
    floors_doc = {k: {n: (None if v is None else {"max": float(np.max(v)),
                                                   "mean": float(np.mean(v))})
                      for n, v in c[3].items()} for k, c in cache.items()}
    doc = {"seed": a.seed, "thresholds": {"ratio_min": RATIO_MIN, "floor_margin": FLOOR_MARGIN,
                                          "xy_min_m": XY_MIN_M, "fall_z_m": FALL_Z_M,
                                          "fall_tilt_rad": FALL_TILT_RAD},
           "clean_floors": floors_doc, "falls_clean_and_reference": fall, "effects": rows,
           "all_material": all(r["material"] for r in rows),
           "no_falls": all(not r["falls"] for r in rows) and not any(fall.values()),
           "seconds": time.time() - t0}
    out = Path(a.out_prefix)
    out.with_suffix(".json").write_text(json.dumps(doc, indent=1) + "\n")
    md = ["# zoo47 visibility check (SEALED)", "",
          f"Seed {a.seed}; work directory given as an argument. Material: largest one-step "
          f"nMSE ratio >= {RATIO_MIN} and >= {FLOOR_MARGIN} x the clean seeds' largest, or "
          f"mean final (x, y) difference >= {XY_MIN_M} m. Falls: z < {FALL_Z_M} m or "
          f"|roll|, |pitch| > {FALL_TILT_RAD} rad.", "",
          "| id | exc. | one-step ratio max (top states) | clean floor max | mean ratio | "
          "paired RMS/spread: z, d_b, rp, d_rpy, q, dq | final xy diff mean [m] | "
          "final yaw diff [rad] | material | falls |", "|" + "---|" * 10]
    for r in rows:
        pr = r["paired"]
        g = pr["rms_diff_over_spread"]
        top = ", ".join(f"{k} {v:.2f}" for k, v in r["onestep_ratio_top"].items())
        md.append(f"| {r['id']} | {r['excitation']:g} | {r['onestep_ratio_max']:.2f} ({top}) | "
                  f"{r['clean_floor_ratio_max']:.2f} | {r['onestep_ratio_mean']:.3f} | "
                  + ", ".join(f"{g[k]:.3f}" for k in GROUPS)
                  + f" | {pr['final_xy_diff_m_mean']:.3f} | {pr['final_yaw_diff_rad_mean']:.3f} | "
                  f"{'yes' if r['material'] else 'NO'} | {len(r['falls'])} |")
    md += ["", "Clean floors (one-step ratio of another clean seed, same model): "
           + "; ".join(f"{k}: " + (", ".join(f"{n} max {v['max']:.2f}" for n, v in f.items()
                                              if v) or "no other seed recorded so, the plain "
                                   "floor is used") for k, f in floors_doc.items()),
           "", "Falls in clean datasets and the reference: "
           + ", ".join(f"{k} {len(v)}" for k, v in fall.items()),
           "", f"All material: {'yes' if doc['all_material'] else 'NO'}; no falls: "
           f"{'yes' if doc['no_falls'] else 'NO'}; {doc['seconds']:.0f} s."]
    out.with_suffix(".md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    return 0 if doc["all_material"] and doc["no_falls"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
