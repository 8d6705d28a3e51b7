"""zoo51's visibility check: every effect changes the recordings materially, and no move falls.

Default: records, with the gap robot and seed 421, ``--moves-per-type`` (3) moves of each
type clean, with each effect (under its recording condition from truth.yaml) and with a
negligible perturbation (a 0.02 N horizontal push, under 0.1 % of the robot's weight), and
compares each move's states (layout.STATE_NAMES, s_1..s_N) with the clean move of the same
name: per channel, the RMS difference over the move divided by the channel's spread (its
standard deviation over the clean moves), averaged over the moves. An effect passes when some
channel's fraction is at least MATERIAL and at least RATIO times the negligible
perturbation's fraction in the same channel, and none of its moves falls. Results: check.md, check.json.

``--recorded WORK``: checks only that no move of any dataset under WORK (the harness's
recordings) falls. Results: check_recorded.md, check_recorded.json.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo51/check_visible.py
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo51/check_visible.py \\
        --recorded /tmp/z51w
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.data.states import states_from_recording
from littledog_mlsim.layout import STATE_NAMES

HERE = Path(__file__).resolve().parent
MATERIAL = 0.10          # fraction of a channel's spread
RATIO = 2.0              # times the negligible perturbation's fraction
FALL_Z = 0.07            # m: body height below this is a fall (standing: ~0.145 m)
FALL_TILT = 0.7          # rad: |roll| or |pitch| above this is a fall
NEGLIGIBLE = [{"class": "littledog_mlsim.robot.effects:ConstantWind",
               "params": {"force_xy": [0.02, 0.0]}}]


def record(out: Path, seed: int, moves: int, effects: Path | None, excitation: float) -> None:
    if (out / "dataset.yaml").is_file():
        return
    cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(moves), "--seed", str(seed), "--jobs", "2", "--quiet",
           "--robot", str(HERE / "gap_robot.json")]
    if excitation:
        cmd += ["--excitation", f"{excitation:g}"]
    if effects is not None:
        cmd += ["--effects", str(effects)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def states(path: Path) -> dict[str, np.ndarray]:
    return {m.name: states_from_recording(m) for m in load_moves(path, split="all")}


def falls(st: dict[str, np.ndarray]) -> list[dict]:
    out = []
    for name, s in st.items():
        zmin = float(s[:, 0].min())
        tilt = float(np.abs(s[:, 4:6]).max())
        if zmin < FALL_Z or tilt > FALL_TILT or not np.all(np.isfinite(s)):
            out.append({"move": name, "z_min_m": zmin, "tilt_max_rad": tilt})
    return out


def fractions(st: dict[str, np.ndarray], clean: dict[str, np.ndarray],
              spread: np.ndarray) -> np.ndarray:
    """Per channel: RMS difference from the clean move over the move, / spread, mean over
    moves (33,)."""
    per = [np.sqrt(np.mean((st[n] - clean[n]) ** 2, axis=0)) / spread for n in clean]
    return np.mean(per, axis=0)


def summary(frac: np.ndarray) -> dict:
    k = int(np.argmax(frac))
    top = np.argsort(frac)[::-1][:3]
    return {"max_fraction": float(frac[k]), "channel": STATE_NAMES[k],
            "top3": {STATE_NAMES[i]: round(float(frac[i]), 3) for i in top}}


def check_effects(work: Path, seed: int, moves: int) -> int:
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    t0 = time.time()
    excitations = sorted({float((t.get("recording") or {}).get("excitation", 0.0))
                          for t in truth})
    neg_file = work / "negligible.yaml"
    work.mkdir(parents=True, exist_ok=True)
    neg_file.write_text(yaml.safe_dump(NEGLIGIBLE))
    base, neg = {}, {}
    for e in excitations:
        record(work / f"clean_e{e:g}", seed, moves, None, e)
        record(work / f"negligible_e{e:g}", seed, moves, neg_file, e)
        base[e] = states(work / f"clean_e{e:g}")
        spread = np.concatenate(list(base[e].values())).std(axis=0)
        neg[e] = (spread, fractions(states(work / f"negligible_e{e:g}"), base[e], spread))
    rows = []
    for t in truth:
        e = float((t.get("recording") or {}).get("excitation", 0.0))
        out = work / t["id"]
        record(out, seed, moves, HERE / "effects" / t.get("file", f"{t['id']}.yaml"), e)
        st = states(out)
        spread, nf = neg[e]
        frac = fractions(st, base[e], spread)
        s = summary(frac)
        ratio = s["max_fraction"] / max(float(nf.max()), 1e-12)
        # the same channel's: effect fraction over the negligible perturbation's
        per = frac / np.maximum(nf, 1e-12)
        ok = (frac >= MATERIAL) & (per >= RATIO)
        best = int(np.argmax(np.where(frac >= MATERIAL, per, 0.0)))
        fl = falls(st)
        rows.append({"id": t["id"], "excitation": e, **s,
                     "negligible_max_fraction": float(nf.max()),
                     "ratio_to_negligible": ratio,
                     "best_channel": STATE_NAMES[best], "best_fraction": float(frac[best]),
                     "best_ratio_same_channel": float(per[best]),
                     "channels_passing": int(ok.sum()), "falls": fl,
                     "passed": bool(ok.any() and not fl)})
    clean_falls = {f"clean_e{e:g}": falls(base[e]) for e in excitations}
    doc = {"seed": seed, "moves_per_type": moves, "robot": "gap_robot.json",
           "material": MATERIAL, "ratio": RATIO, "negligible": NEGLIGIBLE,
           "negligible_summary": {f"e{e:g}": summary(neg[e][1]) for e in excitations},
           "clean_falls": clean_falls, "rows": rows,
           "all_passed": all(r["passed"] for r in rows) and not any(clean_falls.values()),
           "wall_s": time.time() - t0}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo51 visibility check", "",
             f"Gap robot, seed {seed}, {moves} moves of each type; a channel's fraction is the "
             f"RMS difference from the clean move of the same name over its spread, mean over "
             f"moves. Pass: some channel's fraction >= {MATERIAL} and >= {RATIO}x the "
             f"negligible perturbation's (a 0.02 N push) in the same channel, and no move "
             f"falls (z < {FALL_Z} m or |roll|, |pitch| > {FALL_TILT} rad). Also shown: the "
             f"largest fraction over the negligible perturbation's largest.", "",
             "Negligible perturbation: " + "; ".join(
                 f"{k}: {v['max_fraction']:.3f} ({v['channel']})"
                 for k, v in doc["negligible_summary"].items()),
             f"Clean moves falling: {sum(len(v) for v in clean_falls.values())}", "",
             "| effect | exc. | largest fraction | channel | x negligible's largest | "
             "best channel | its fraction | x negligible (same channel) | channels passing | "
             "falls | passed |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['id']} | {r['excitation']:g} | {r['max_fraction']:.3f} | "
                     f"{r['channel']} | {r['ratio_to_negligible']:.1f} | {r['best_channel']} | "
                     f"{r['best_fraction']:.3f} | {r['best_ratio_same_channel']:.1f} | "
                     f"{r['channels_passing']} | {len(r['falls'])} | "
                     f"{'yes' if r['passed'] else 'NO'} |")
    lines += ["", f"All passed: {'yes' if doc['all_passed'] else 'NO'} "
              f"({doc['wall_s']:.0f} s)", ""]
    (HERE / "check.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if doc["all_passed"] else 1


def check_recorded(work: Path) -> int:
    rows = []
    for index in sorted(work.rglob("dataset.yaml")):
        st = states(index.parent)
        fl = falls(st)
        zmin = min(float(s[:, 0].min()) for s in st.values())
        tilt = max(float(np.abs(s[:, 4:6]).max()) for s in st.values())
        rows.append({"dataset": str(index.parent.relative_to(work)), "moves": len(st),
                     "z_min_m": zmin, "tilt_max_rad": tilt, "falls": fl})
    ok = bool(rows) and not any(r["falls"] for r in rows)
    doc = {"work": str(work), "fall_z_m": FALL_Z, "fall_tilt_rad": FALL_TILT, "rows": rows,
           "no_falls": ok}
    (HERE / "check_recorded.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo51: no recorded move falls", "",
             f"Every dataset under `{work}` (the harness's recordings); a fall: body height "
             f"below {FALL_Z} m or |roll|, |pitch| above {FALL_TILT} rad at any step.", "",
             "| dataset | moves | lowest body height [m] | largest tilt [rad] | falls |",
             "|---|---|---|---|---|"]
    lines += [f"| {r['dataset']} | {r['moves']} | {r['z_min_m']:.3f} | {r['tilt_max_rad']:.3f} "
              f"| {len(r['falls'])} |" for r in rows]
    lines += ["", f"No falls: {'yes' if ok else 'NO'} ({len(rows)} datasets)", ""]
    (HERE / "check_recorded.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if ok else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", default="/tmp/z51check", help="scratch directory")
    ap.add_argument("--seed", type=int, default=421)
    ap.add_argument("--moves-per-type", type=int, default=3)
    ap.add_argument("--recorded", default=None, metavar="WORK",
                    help="only check the harness's recordings under WORK for falls")
    a = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    if a.recorded:
        return check_recorded(Path(a.recorded))
    return check_effects(Path(a.work), a.seed, a.moves_per_type)


if __name__ == "__main__":
    raise SystemExit(main())
