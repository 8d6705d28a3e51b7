"""zoo68's visibility and no-fall check (sealed, the zoo author's).

Short mode (default): records, with the gap robot (``gap_robot.json``), seed 591 and 3 moves
of each of the 11 types, one dataset per effect (under the recording condition ``truth.yaml``
gives it), clean datasets of the same seed and moves under every condition the zoo uses, and
the same with a negligible perturbation (a constant 0.02 N horizontal push in odom). An effect
is **visible** when, in some state channel (the 33 of ``docs/interface.md`` section 4), its
recordings differ from the clean ones of the same condition by

- at least 10 % of the channel's spread: the RMS over a move of the difference, averaged over
  the moves, against the channel's standard deviation in the clean recordings, **and**
- at least twice what the 0.02 N push changes in that channel (the same measure).

No move may fall: body below 0.07 m, or |roll| or |pitch| beyond 0.7 rad (measured pose).
Results: ``check.md``, ``check.json`` beside this file; recordings under ``--scratch``
(default ``/tmp/z68_author/short``; a dataset whose effect file, plug-ins and robot are
unchanged is reused).

``--recorded WORK``: the no-fall check on every dataset the harness recorded under WORK
(``WORK/effects/*``, ``WORK/clean/*``, ``WORK/reference``), every move; results
``check_recorded.md``, ``check_recorded.json``.

Commands, from the repository root::

    OPENBLAS_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/blind_zoo/zoos/zoo68/check_visible.py
    OPENBLAS_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/blind_zoo/zoos/zoo68/check_visible.py --recorded /tmp/z68w
"""
from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))     # the repository root

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.data.states import states_from_recording  # noqa: E402
from littledog_mlsim.layout import STATE_NAMES  # noqa: E402
from littledog_mlsim.rotations import quat_to_rpy  # noqa: E402

SEED, MOVES = 591, 3
PUSH_N = 0.02
SPREAD_FRACTION, PUSH_MULTIPLE = 0.10, 2.0
FALL_Z, FALL_ANGLE = 0.07, 0.7
ROBOT = HERE / "gap_robot.json"


def falls(moves) -> list[dict]:
    """Per move: name, lowest body height, largest |roll| or |pitch|, fell."""
    out = []
    for m in moves:
        rpy = quat_to_rpy(m.orientation)
        z = float(np.min(m.position[:, 2]))
        a = float(np.max(np.abs(rpy[:, :2])))
        out.append({"move": m.name, "min_z": z, "max_tilt": a,
                    "fell": bool(z < FALL_Z or a > FALL_ANGLE or not np.isfinite([z, a]).all())})
    return out


def _digest(*paths: Path) -> str:
    h = hashlib.sha1()
    for p in paths:
        h.update(p.read_bytes() if p.is_file() else b"-")
    return h.hexdigest()


def record(name: str, effects: Path | None, excitation: float, scratch: Path,
           extra_files: tuple[Path, ...] = ()) -> Path:
    from littledog_mlsim.apps.record import record_dataset
    out = scratch / name
    key = _digest(*(([effects] if effects else []) + list(extra_files) + [ROBOT])) + \
        f" e{excitation:g} s{SEED} m{MOVES}"
    stamp = scratch / f"{name}.key"
    if (out / "dataset.yaml").is_file() and stamp.is_file() and stamp.read_text() == key:
        return out
    if out.exists():
        shutil.rmtree(out)
    print(f"record {name}", flush=True)
    record_dataset(out, moves_per_type=MOVES, seed=SEED, robot=str(ROBOT),
                   effects_file=str(effects) if effects else None, jobs=2, progress=False,
                   excitation=excitation)
    stamp.write_text(key)
    return out


def states(path: Path):
    moves = load_moves(path, split="all")
    return moves, {m.name: states_from_recording(m) for m in moves}


def change(a: dict, b: dict) -> np.ndarray:
    """Per channel: the RMS over a move of a - b, averaged over the moves (33,)."""
    return np.mean([np.sqrt(np.mean((a[k] - b[k]) ** 2, axis=0)) for k in sorted(b)], axis=0)


def short(scratch: Path) -> int:
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    scratch.mkdir(parents=True, exist_ok=True)
    push = scratch / "push.yaml"
    push.write_text(yaml.safe_dump([{"class": "littledog_mlsim.robot.effects:ConstantWind",
                                     "params": {"force_xy": [PUSH_N, 0.0]}}]))
    plugins = HERE / "effects" / "plugins.py"
    conds = sorted({float((t.get("recording") or {}).get("excitation", 0.0)) for t in truth} | {0.0})
    clean, pushed, spread, floor, fall_rows = {}, {}, {}, {}, []
    for e in conds:
        mv, clean[e] = states(record(f"clean_e{e:g}", None, e, scratch))
        fall_rows += [dict(r, dataset=f"clean_e{e:g}") for r in falls(mv)]
        mv, pushed[e] = states(record(f"push_e{e:g}", push, e, scratch))
        fall_rows += [dict(r, dataset=f"push_e{e:g}") for r in falls(mv)]
        spread[e] = np.std(np.concatenate([clean[e][k] for k in sorted(clean[e])]), axis=0)
        floor[e] = change(pushed[e], clean[e])
    rows = []
    for t in truth:
        e = float((t.get("recording") or {}).get("excitation", 0.0))
        f = HERE / "effects" / t.get("file", f"{t['id']}.yaml")
        mv, st = states(record(t["id"], f, e, scratch, (plugins,)))
        fr = falls(mv)
        fall_rows += [dict(r, dataset=t["id"]) for r in fr]
        d = change(st, clean[e])
        rel = d / np.maximum(spread[e], 1e-12)
        mult = d / np.maximum(floor[e], 1e-12)
        ok = (rel >= SPREAD_FRACTION) & (mult >= PUSH_MULTIPLE)
        best = int(np.argmax(np.where(ok, rel, -1.0))) if ok.any() else int(np.argmax(rel))
        rows.append({"id": t["id"], "excitation": e, "visible": bool(ok.any()),
                     "channels_passing": int(ok.sum()), "best_channel": STATE_NAMES[best],
                     "best_fraction_of_spread": float(rel[best]),
                     "best_multiple_of_push": float(mult[best]),
                     "largest_fraction_of_spread": float(rel.max()),
                     "falls": int(sum(r["fell"] for r in fr)),
                     "max_tilt": float(max(r["max_tilt"] for r in fr)),
                     "min_z": float(min(r["min_z"] for r in fr))})
    n_fell = sum(r["fell"] for r in fall_rows)
    doc = {"seed": SEED, "moves_per_type": MOVES, "push_N": PUSH_N, "robot": ROBOT.name,
           "criteria": {"fraction_of_spread": SPREAD_FRACTION, "multiple_of_push": PUSH_MULTIPLE,
                        "fall_z_m": FALL_Z, "fall_angle_rad": FALL_ANGLE},
           "effects": rows, "visible": sum(r["visible"] for r in rows), "n_effects": len(rows),
           "moves_checked": len(fall_rows), "moves_fallen": n_fell}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    md = [f"# zoo68 short check (seed {SEED}, {MOVES} moves per type, gap robot)", "",
          "| effect | exc. | visible | channels passing | best channel | of spread | x push | "
          "largest of spread | falls | max tilt [rad] | min z [m] |", "|" + "---|" * 11]
    for r in rows:
        md.append(f"| {r['id']} | {r['excitation']:g} | {'yes' if r['visible'] else 'NO'} | "
                  f"{r['channels_passing']} | {r['best_channel']} | "
                  f"{r['best_fraction_of_spread']:.2f} | {r['best_multiple_of_push']:.1f} | "
                  f"{r['largest_fraction_of_spread']:.2f} | {r['falls']} | {r['max_tilt']:.3f} | "
                  f"{r['min_z']:.3f} |")
    md += ["", f"{doc['visible']} of {len(rows)} visible; {n_fell} of {len(fall_rows)} moves "
               f"fallen (effects, clean and pushed recordings)."]
    (HERE / "check.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    return 0 if doc["visible"] == len(rows) and n_fell == 0 else 1


def recorded(work: Path) -> int:
    sets = sorted((work / "effects").glob("*/dataset.yaml")) + \
        sorted((work / "clean").glob("*/dataset.yaml")) + \
        sorted(work.glob("reference/dataset.yaml"))
    rows = []
    for idx in sets:
        fr = falls(load_moves(idx.parent, split="all"))
        rows.append({"dataset": str(idx.parent.relative_to(work)), "moves": len(fr),
                     "fallen": int(sum(r["fell"] for r in fr)),
                     "max_tilt": float(max(r["max_tilt"] for r in fr)),
                     "min_z": float(min(r["min_z"] for r in fr))})
    n_moves = sum(r["moves"] for r in rows)
    n_fell = sum(r["fallen"] for r in rows)
    doc = {"work": str(work), "datasets": rows, "n_datasets": len(rows), "moves": n_moves,
           "fallen": n_fell, "criteria": {"fall_z_m": FALL_Z, "fall_angle_rad": FALL_ANGLE}}
    (HERE / "check_recorded.json").write_text(json.dumps(doc, indent=1) + "\n")
    md = [f"# zoo68 no-fall check of the harness's recordings ({work})", "",
          "| dataset | moves | fallen | max tilt [rad] | min z [m] |", "|---|---|---|---|---|"]
    md += [f"| {r['dataset']} | {r['moves']} | {r['fallen']} | {r['max_tilt']:.3f} | "
           f"{r['min_z']:.3f} |" for r in rows]
    md += ["", f"{len(rows)} datasets, {n_moves} moves, {n_fell} fallen."]
    (HERE / "check_recorded.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    return 0 if n_fell == 0 and rows else 1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scratch", default="/tmp/z68_author/short")
    ap.add_argument("--recorded", metavar="WORK", default=None)
    a = ap.parse_args(argv)
    return recorded(Path(a.recorded)) if a.recorded else short(Path(a.scratch))


if __name__ == "__main__":
    raise SystemExit(main())
