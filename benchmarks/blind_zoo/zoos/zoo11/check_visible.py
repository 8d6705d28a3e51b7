"""Materiality and no-fall check of zoo11's effects, against clean data of the same seed.

Each effect dataset (recorded by ``harness/run.py --record-only`` with the gap robot, seed 61)
is compared move by move with the clean dataset of the same seed (same commands, same sensor
noise draws): RMS joint-angle difference, RMS body-attitude difference, mean final (x, y)
difference, mean final yaw difference. A null control (``null_control.yaml``: a plug-in with
every hook and no change) is recorded the same way and must show no difference. Every move of
every dataset (effects, clean seeds, reference, null control) must keep the body above 0.13 m.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo11/check_visible.py \\
        --work WORK

``--pilot N`` instead simulates the first N moves of each type in-process (a quick check
before recording). Writes check.md / check.json beside this file (or check_pilot.*).
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

from littledog_mlsim.layout import MOVE_TYPES, bag_name  # noqa: E402

SEED = 61
MIN_HEIGHT = 0.13
# an effect is "material" when at least one of these is exceeded (the null control shows 0)
THRESH = {"rms_q_rad": 0.005, "rms_att_rad": 0.003, "final_xy_m": 0.02, "final_yaw_rad": 0.03}


def yaw(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def att_angle(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    d = np.abs(np.sum(q1 * q2, axis=1)).clip(0, 1)
    return 2 * np.arccos(d)


def compare(a, b) -> dict:
    dyaw = np.angle(np.exp(1j * (yaw(a.orientation[-1:]) - yaw(b.orientation[-1:]))))[0]
    return {"rms_q_rad": float(np.sqrt(np.mean((a.q - b.q) ** 2))),
            "rms_att_rad": float(np.sqrt(np.mean(att_angle(a.orientation, b.orientation) ** 2))),
            "final_xy_m": float(np.hypot(*(a.position[-1, :2] - b.position[-1, :2]))),
            "final_yaw_rad": float(abs(dyaw))}


def summarise(rows: list[dict]) -> dict:
    return {k: float(np.mean([r[k] for r in rows])) for k in THRESH}


def min_height(rec) -> float:
    return float(np.min(rec.position[:, 2]))


def effect_files() -> list[tuple[str, Path]]:
    return ([(p.stem, p) for p in sorted((HERE / "effects").glob("z*.yaml"))]
            + [("null_control", HERE / "null_control.yaml")])


def pilot(n: int, only: set[str]) -> dict:
    from littledog_mlsim.apps.record import MoveJob
    from littledog_mlsim.control.moves import open_loop_commands
    from littledog_mlsim.robot.effects import load_effects
    from littledog_mlsim.robot.sim import simulate_move
    from littledog_mlsim.robot.twin import robot_config_from
    robot = robot_config_from(str(HERE / "gap_robot.json"))
    moves = []
    for t in MOVE_TYPES:
        for i in range(n):
            g, r = MoveJob(t, i, SEED).seeds()
            moves.append((bag_name(t, i), t, open_loop_commands("trot", t, np.random.default_rng(g)), r))
    clean = {m[0]: simulate_move(m[2], robot=robot, seed=m[3], name=m[0], move_type=m[1])
             for m in moves}
    out = {"clean": {"min_height_m": min(min_height(r) for r in clean.values())}}
    for name, f in effect_files():
        if only and name not in only:
            continue
        recs = {m[0]: simulate_move(m[2], robot=robot, effects=load_effects(f), seed=m[3],
                                    name=m[0], move_type=m[1]) for m in moves}
        out[name] = {**summarise([compare(recs[k], clean[k]) for k in clean]),
                     "min_height_m": min(min_height(r) for r in recs.values())}
        print(name, out[name], flush=True)
    return out


def recorded(work: Path) -> dict:
    from littledog_mlsim.data.bags import read_bag
    null_ds = work / "null_control"
    if not (null_ds / "dataset.yaml").is_file():
        subprocess.run([sys.executable, "-P", "-m", "littledog_mlsim.cli", "record", "--out",
                        str(null_ds), "--moves-per-type", "10", "--seed", str(SEED), "--jobs", "2",
                        "--quiet", "--effects", str(HERE / "null_control.yaml"), "--robot",
                        str(HERE / "gap_robot.json")], check=True,
                       env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})

    def bags(ds: Path) -> dict:
        doc = yaml.safe_load((ds / "dataset.yaml").read_text())
        names = sorted(p.name for p in ds.iterdir() if p.is_dir())
        return {n: read_bag(ds / n) for n in names}

    clean = bags(work / "clean" / f"s{SEED}_e0")
    out = {}
    for extra in ["clean/s62_e0", "clean/s63_e0", "reference"]:
        recs = bags(work / extra)
        out[extra] = {"min_height_m": min(min_height(r) for r in recs.values()),
                      "n_moves": len(recs)}
    out[f"clean/s{SEED}_e0"] = {"min_height_m": min(min_height(r) for r in clean.values()),
                                "n_moves": len(clean)}
    for name, _ in effect_files():
        ds = work / "effects" / name if name != "null_control" else work / "null_control"
        recs = bags(ds)
        assert set(recs) == set(clean), name
        out[name] = {**summarise([compare(recs[k], clean[k]) for k in clean]),
                     "min_height_m": min(min_height(r) for r in recs.values()),
                     "n_moves": len(recs)}
        print(name, out[name], flush=True)
    return out


def verdicts(res: dict) -> dict:
    for name, r in res.items():
        r["no_fall"] = r["min_height_m"] > MIN_HEIGHT
        if "rms_q_rad" in r:
            r["ratio_to_threshold"] = max(r[k] / v for k, v in THRESH.items())
            r["material"] = r["ratio_to_threshold"] > 1.0
    return res


def markdown(res: dict, mode: str) -> str:
    lines = [f"# zoo11 check_visible ({mode})", "",
             f"Against clean data of seed {SEED} (same commands and noise draws); means over "
             f"moves. Material: any column above its threshold {THRESH}. No fall: body height "
             f"> {MIN_HEIGHT} m in every move.", "",
             "| dataset | RMS q diff [rad] | RMS attitude diff [rad] | final xy diff [m] | "
             "final yaw diff [rad] | max ratio to threshold | material | min height [m] | "
             "no fall |", "|---|---|---|---|---|---|---|---|---|"]
    for name, r in res.items():
        if "rms_q_rad" in r:
            lines.append(f"| {name} | {r['rms_q_rad']:.4f} | {r['rms_att_rad']:.4f} | "
                         f"{r['final_xy_m']:.4f} | {r['final_yaw_rad']:.4f} | "
                         f"{r['ratio_to_threshold']:.1f} | {'yes' if r['material'] else 'no'} | "
                         f"{r['min_height_m']:.4f} | {'yes' if r['no_fall'] else 'NO'} |")
        else:
            lines.append(f"| {name} | - | - | - | - | - | - | {r['min_height_m']:.4f} | "
                         f"{'yes' if r['no_fall'] else 'NO'} |")
    eff = [r for n, r in res.items() if n.startswith("z")]
    null = res.get("null_control")
    lines += ["", f"Effects material: {sum(r['material'] for r in eff)} of {len(eff)}; "
              f"null control material: {null['material'] if null else '-'}; "
              f"every dataset without a fall: {all(r['no_fall'] for r in res.values())}."]
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True, help="the harness's WORK directory")
    ap.add_argument("--pilot", type=int, default=0)
    ap.add_argument("--only", default="")
    a = ap.parse_args()
    if a.pilot:
        res = verdicts(pilot(a.pilot, {s for s in a.only.split(",") if s}))
        stem = "check_pilot" + ("_" + a.only.replace(",", "_") if a.only else "")
        mode = f"pilot, first {a.pilot} move(s) of each type, simulated in-process"
    else:
        res = verdicts(recorded(Path(a.work)))
        stem, mode = "check", "the recorded datasets, 10 moves per type"
    (HERE / f"{stem}.json").write_text(json.dumps(res, indent=1) + "\n")
    (HERE / f"{stem}.md").write_text(markdown(res, mode))
    print(markdown(res, mode))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
