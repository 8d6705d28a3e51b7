"""zoo62's visibility and no-fall check.

Short recordings (the gap robot, seed 531, 3 moves per type, in a scratch directory): for every
recording condition the zoo uses (plain, and the command excitation some effects are recorded
under), a clean dataset and a negligible perturbation's (a constant 0.02 N horizontal push);
then one dataset per effect under its condition. An effect passes when, in some state channel
(the 33 of docs/interface.md section 4), its recordings differ from the clean ones of the same
seed and moves by

- at least 10 % of that channel's spread (standard deviation over the clean moves), and
- at least twice what the push changes in the same channel,

the difference being the RMS over a move of (effect - clean), averaged over the moves. Nothing
may fall: in every move of every dataset the body stays above 0.07 m and |roll|, |pitch| stay
below 0.7 rad. Results: ``check.md`` and ``check.json`` beside this file.

``--recorded WORK`` runs the no-fall check on every dataset under WORK (the harness's
recordings: ``effects/*``, ``clean/*``, ``reference``), and each effect dataset's difference
from the clean dataset of its seed and condition (10 % of spread); results
``check_recorded.md`` / ``.json``.

    cd /work/main && OPENBLAS_NUM_THREADS=1 .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo62/check_visible.py [--work /tmp/z62check] [--only z01,z02]
    cd /work/main && OPENBLAS_NUM_THREADS=1 .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo62/check_visible.py --recorded /tmp/z62w

A scratch dataset is re-recorded when its effects file changed (a hash kept beside it).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))          # the repository root

from littledog_mlsim.layout import STATE_NAMES  # noqa: E402

SEED = 531
MOVES = 3
PUSH_N = 0.02
Z_MIN = 0.07
TILT_MAX = 0.7
SPREAD_FRACTION = 0.10
PUSH_FACTOR = 2.0


def _load(path: Path):
    from littledog_mlsim.data.dataset import load_moves
    return load_moves(path, split="all")


def states(moves) -> dict[str, np.ndarray]:
    from littledog_mlsim.data.states import states_from_recording
    return {m.name: states_from_recording(m) for m in moves}


def falls(moves) -> list[dict]:
    from littledog_mlsim.rotations import quat_to_rpy
    out = []
    for m in moves:
        rpy = quat_to_rpy(m.orientation)
        z = float(np.min(m.position[:, 2]))
        tilt = float(np.max(np.abs(rpy[:, :2])))
        if not (np.isfinite(z) and np.isfinite(tilt)) or z < Z_MIN or tilt > TILT_MAX:
            out.append({"move": m.name, "z_min": z, "tilt_max": tilt})
    return out


def extremes(moves) -> dict:
    from littledog_mlsim.rotations import quat_to_rpy
    z = min(float(np.min(m.position[:, 2])) for m in moves)
    tilt = max(float(np.max(np.abs(quat_to_rpy(m.orientation)[:, :2]))) for m in moves)
    return {"z_min": z, "tilt_max": tilt}


def difference(a: dict, b: dict) -> np.ndarray:
    """Per channel: the RMS over each move of (a - b), averaged over the moves both hold."""
    names = sorted(set(a) & set(b))
    rms = [np.sqrt(np.mean((a[n] - b[n]) ** 2, axis=0)) for n in names]
    return np.mean(rms, axis=0)


def spread(s: dict) -> np.ndarray:
    return np.std(np.concatenate(list(s.values())), axis=0)


def _hash(path: Path | None, extra: str) -> str:
    h = hashlib.sha1(extra.encode())
    if path is not None:
        h.update(path.read_bytes())
        for py in sorted(path.parent.glob("*.py")):     # the zoo's plug-ins
            h.update(py.read_bytes())
    return h.hexdigest()


def record(out: Path, effects: Path | None, excitation: float, robot: Path) -> Path:
    from littledog_mlsim.apps.record import record_dataset
    stamp = out.with_name(out.name + ".sha1")
    key = _hash(effects, f"{excitation}|{robot.read_text()}|{SEED}|{MOVES}")
    if (out / "dataset.yaml").is_file() and stamp.is_file() and stamp.read_text() == key:
        return out
    if out.exists():
        shutil.rmtree(out)
    t0 = time.perf_counter()
    record_dataset(out, moves_per_type=MOVES, seed=SEED, robot=str(robot),
                   effects_file=str(effects) if effects else None, excitation=excitation,
                   jobs=2, progress=False)
    stamp.write_text(key)
    print(f"recorded {out.name} in {time.perf_counter() - t0:.0f} s", flush=True)
    return out


def truth_entries() -> list[dict]:
    t = yaml.safe_load((HERE / "truth.yaml").read_text())
    return t.get("effects", t) if isinstance(t, dict) else t


def short_check(work: Path, only: set[str]) -> int:
    robot = HERE / "gap_robot.json"
    work.mkdir(parents=True, exist_ok=True)
    entries = [e for e in truth_entries() if not only or e["id"] in only]
    conds = sorted({0.0} | {float((e.get("recording") or {}).get("excitation", 0.0))
                            for e in entries})
    push_file = work / "push.yaml"
    push_file.write_text(yaml.safe_dump([{"class": "littledog_mlsim.robot.effects:ConstantWind",
                                          "params": {"force_xy": [PUSH_N, 0.0]}}]))
    base = {}
    for e in conds:
        clean = _load(record(work / f"clean_e{e:g}", None, e, robot))
        push = _load(record(work / f"push_e{e:g}", push_file, e, robot))
        sc, sp = states(clean), states(push)
        base[e] = {"clean": sc, "spread": spread(sc), "push": difference(sp, sc),
                   "falls": falls(clean) + falls(push), "extremes": extremes(clean)}
    rows = []
    for ent in entries:
        e = float((ent.get("recording") or {}).get("excitation", 0.0))
        path = HERE / "effects" / ent.get("file", f"{ent['id']}.yaml")
        moves = _load(record(work / ent["id"], path, e, robot))
        s = states(moves)
        d = difference(s, base[e]["clean"])
        rel = d / np.maximum(base[e]["spread"], 1e-12)
        vs_push = d / np.maximum(base[e]["push"], 1e-12)
        ok = (rel >= SPREAD_FRACTION) & (vs_push >= PUSH_FACTOR)
        best = int(np.argmax(np.where(ok, rel, -1.0))) if ok.any() else int(np.argmax(rel))
        fl = falls(moves)
        rows.append({"id": ent["id"], "excitation": e, "visible": bool(ok.any()),
                     "channels_passing": int(ok.sum()), "best_channel": STATE_NAMES[best],
                     "best_fraction_of_spread": float(rel[best]),
                     "best_times_push": float(vs_push[best]),
                     "falls": fl, "upright": not fl, **extremes(moves)})
        print(f"{ent['id']}: visible {rows[-1]['visible']} ({rows[-1]['channels_passing']} "
              f"channels), upright {not fl}", flush=True)
    clean_falls = sum(len(b["falls"]) for b in base.values())
    passed = all(r["visible"] and r["upright"] for r in rows) and clean_falls == 0
    doc = {"seed": SEED, "moves_per_type": MOVES, "push_N": PUSH_N, "rule": {
               "spread_fraction": SPREAD_FRACTION, "push_factor": PUSH_FACTOR,
               "z_min_m": Z_MIN, "tilt_max_rad": TILT_MAX},
           "conditions": {f"{e:g}": {"clean_and_push_falls": b["falls"], **b["extremes"]}
                          for e, b in base.items()},
           "effects": rows, "passed": passed,
           "counts": {"effects": len(rows), "visible": sum(r["visible"] for r in rows),
                      "upright": sum(r["upright"] for r in rows)}}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo62 visibility and no-fall check (short recordings)", "",
             f"Gap robot, seed {SEED}, {MOVES} moves per type; push {PUSH_N} N. An effect is "
             f"visible where some state channel differs from clean by >= "
             f"{SPREAD_FRACTION:.0%} of its spread and >= {PUSH_FACTOR:g}x the push's change "
             f"(RMS over the move, mean over moves). A fall: body below {Z_MIN} m or "
             f"|roll|, |pitch| above {TILT_MAX} rad.", "",
             "| condition | clean+push falls | clean z_min [m] | clean max tilt [rad] |",
             "|---|---|---|---|"]
    for e, b in base.items():
        lines.append(f"| excitation {e:g} | {len(b['falls'])} | {b['extremes']['z_min']:.3f} "
                     f"| {b['extremes']['tilt_max']:.3f} |")
    lines += ["", "| effect | excitation | visible | channels passing | best channel | "
              "x spread | x push | falls | z_min [m] | max tilt [rad] |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['id']} | {r['excitation']:g} | {'yes' if r['visible'] else 'NO'} | "
                     f"{r['channels_passing']} | {r['best_channel']} | "
                     f"{r['best_fraction_of_spread']:.2f} | {r['best_times_push']:.1f} | "
                     f"{len(r['falls'])} | {r['z_min']:.3f} | {r['tilt_max']:.3f} |")
    lines += ["", f"**{'PASSED' if passed else 'FAILED'}**: {doc['counts']['visible']} of "
              f"{len(rows)} visible, {doc['counts']['upright']} of {len(rows)} without a fall, "
              f"{clean_falls} falls in the clean and push recordings.", ""]
    (HERE / "check.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if passed else 1


def recorded_check(work: Path) -> int:
    sets = sorted(p.parent for p in work.glob("**/dataset.yaml")
                  if ".tmp" not in str(p) and "diag" not in p.parts[len(work.parts)])
    rows, clean_states = [], {}
    for d in sets:
        moves = _load(d)
        fl = falls(moves)
        rel = d.relative_to(work)
        rows.append({"dataset": str(rel), "moves": len(moves), "falls": fl, **extremes(moves)})
        if rel.parts[0] == "clean":
            clean_states[rel.parts[1]] = states(moves)
        print(f"{rel}: {len(moves)} moves, {len(fl)} falls", flush=True)
    # each effect dataset against the clean one of its seed and condition
    try:
        truth = {e["id"]: e for e in truth_entries()}
    except OSError:
        truth = {}
    seed = None
    for r in rows:
        parts = Path(r["dataset"]).parts
        if parts[0] != "effects" or parts[1] not in truth:
            continue
        e = float((truth[parts[1]].get("recording") or {}).get("excitation", 0.0))
        key = next((k for k in clean_states if k.endswith(f"_e{e:g}") and
                    k.startswith(f"s{SEED}_")), None)
        if key is None:
            continue
        sc = clean_states[key]
        s = states(_load(work / r["dataset"]))
        frac = difference(s, sc) / np.maximum(spread(sc), 1e-12)
        best = int(np.argmax(frac))
        r.update({"against": f"clean/{key}", "best_channel": STATE_NAMES[best],
                  "best_fraction_of_spread": float(frac[best]),
                  "visible_10pc": bool(frac[best] >= SPREAD_FRACTION)})
        seed = SEED
    n_falls = sum(len(r["falls"]) for r in rows)
    eff = [r for r in rows if "visible_10pc" in r]
    passed = n_falls == 0 and all(r["visible_10pc"] for r in eff)
    doc = {"work": str(work), "datasets": rows, "passed": passed,
           "counts": {"datasets": len(rows), "moves": sum(r["moves"] for r in rows),
                      "falls": n_falls, "effects_compared": len(eff),
                      "effects_visible_10pc": sum(r["visible_10pc"] for r in eff)},
           "rule": {"z_min_m": Z_MIN, "tilt_max_rad": TILT_MAX,
                    "spread_fraction": SPREAD_FRACTION, "effect_seed": seed}}
    (HERE / "check_recorded.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo62 no-fall check of the recorded datasets", "",
             f"Every dataset under `{work}` (the harness's recordings). A fall: body below "
             f"{Z_MIN} m or |roll|, |pitch| above {TILT_MAX} rad in any measurement of a move. "
             f"Effect datasets are also compared with the clean dataset of their seed and "
             f"condition (largest RMS difference over a state channel's spread).", "",
             "| dataset | moves | falls | z_min [m] | max tilt [rad] | x spread (vs clean) |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        vis = (f"{r['best_fraction_of_spread']:.2f}" if "best_fraction_of_spread" in r else "")
        lines.append(f"| {r['dataset']} | {r['moves']} | {len(r['falls'])} | {r['z_min']:.3f} "
                     f"| {r['tilt_max']:.3f} | {vis} |")
    c = doc["counts"]
    lines += ["", f"**{'PASSED' if passed else 'FAILED'}**: {c['datasets']} datasets, "
              f"{c['moves']} moves, {c['falls']} falls; {c['effects_visible_10pc']} of "
              f"{c['effects_compared']} effect datasets differ from clean by >= 10 % of a "
              f"channel's spread.", ""]
    (HERE / "check_recorded.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if passed else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", default="/tmp/z62check", help="scratch directory (short check)")
    ap.add_argument("--only", default="", help="comma-separated effect ids (short check)")
    ap.add_argument("--recorded", default=None, metavar="WORK",
                    help="no-fall check of every dataset the harness recorded under WORK")
    a = ap.parse_args()
    if a.recorded:
        return recorded_check(Path(a.recorded))
    return short_check(Path(a.work), {s for s in a.only.split(",") if s})


if __name__ == "__main__":
    raise SystemExit(main())
