"""zoo64's visibility and no-fall check.

Short check (results ``check.md``, ``check.json`` beside this file)::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo64/check_visible.py

records, with the gap robot (``gap_robot.json``) and the rule's effect seed (551), 3 moves of
each of the 11 types: clean, with a negligible perturbation (a constant 0.02 N horizontal push
in odom, ``ConstantWind``), and with each effect, each under its truth's recording condition
(command excitation 0 or 0.05; clean and push recorded under each condition used). An effect
is visible when, in some state channel c of the 33 (``layout.STATE_NAMES``), the RMS over a
move of (effect - clean), averaged over the moves, is at least 10 % of the channel's standard
deviation in the clean recordings AND at least twice the same RMS of (push - clean). No move
may fall: body below 0.07 m (above the floor where the floor is tilted), or |roll| or |pitch|
beyond 0.7 rad. Recordings go to ``--scratch`` (default /tmp/z64_check) and are reused while
their effect file, plug-ins and the gap robot are unchanged.

No-fall check of every dataset the harness recorded (``check_recorded.md``,
``check_recorded.json``)::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo64/check_visible.py --recorded /tmp/z64w

reads WORK/effects/*, WORK/clean/* and WORK/reference, every move.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))   # the repository root

from littledog_mlsim.layout import STATE_NAMES, WRAPPED_STATE, wrap_angle  # noqa: E402

SEED = 551
MOVES = 3
RATIO_MIN = 0.10
PUSH_FACTOR = 2.0
PUSH_N = 0.02
Z_MIN, TILT_MAX = 0.07, 0.7
GAP = HERE / "gap_robot.json"
EFFECTS = HERE / "effects"


def _truth() -> list[dict]:
    t = yaml.safe_load((HERE / "truth.yaml").read_text())
    return t.get("effects", t) if isinstance(t, dict) else t


def _key(*paths: Path, extra: str = "") -> str:
    h = hashlib.sha256(extra.encode())
    for p in paths:
        h.update(p.read_bytes() if p is not None else b"-")
    return h.hexdigest()


def _record(out: Path, effects: Path | None, excitation: float, jobs: int) -> None:
    from littledog_mlsim.apps.record import record_dataset
    key = _key(GAP, effects, EFFECTS / "plugins.py",
               extra=f"{SEED} {MOVES} {excitation:g}")
    stamp = out.with_name(out.name + ".key")
    if (out / "dataset.yaml").is_file() and stamp.is_file() and stamp.read_text() == key:
        return
    t0 = time.perf_counter()
    record_dataset(out, moves_per_type=MOVES, seed=SEED, robot=str(GAP),
                   effects_file=None if effects is None else str(effects),
                   excitation=excitation, jobs=jobs, overwrite=True, progress=False)
    stamp.write_text(key)
    print(f"recorded {out.name} in {time.perf_counter() - t0:.0f} s", flush=True)


def _states(path: Path) -> dict[str, np.ndarray]:
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.data.states import states_from_recording
    return {rec.name: (states_from_recording(rec), np.asarray(rec.position)[1:])
            for rec in load_moves(path, split="all")}


def _floor(effects: Path | None):
    """The floor's height under (x, y) for an effect file that tilts the floor, else None."""
    if effects is None:
        return None
    for e in yaml.safe_load(effects.read_text()) or []:
        if str(e.get("class", "")).endswith(":GroundTilt"):
            pr = e.get("params") or {}
            s = np.radians(float(pr["slope_deg"]))
            phi = np.radians(float(pr.get("uphill_direction_deg", 0.0)))
            ox, oy = (pr.get("origin_xy") or (0.0, 0.0))
            return lambda xy: np.tan(s) * ((xy[:, 0] - ox) * np.cos(phi)
                                           + (xy[:, 1] - oy) * np.sin(phi))
    return None


def falls(moves: dict[str, tuple[np.ndarray, np.ndarray]], floor=None) -> list[dict]:
    """The moves that fall: body below Z_MIN over the floor, or |roll| or |pitch| > TILT_MAX."""
    out = []
    for name, (s, pos) in moves.items():
        h = s[:, 0] - (floor(pos[:, :2]) if floor is not None else 0.0)
        z, r, p_ = float(h.min()), float(np.abs(s[:, 4]).max()), float(np.abs(s[:, 5]).max())
        if z < Z_MIN or r > TILT_MAX or p_ > TILT_MAX:
            out.append({"move": name, "min_height_m": z, "max_abs_roll": r,
                        "max_abs_pitch": p_})
    return out


def change(a: dict, b: dict) -> np.ndarray:
    """Per channel (33,): the mean over moves of the RMS over a move of a - b."""
    rms = []
    for name in sorted(b):
        d = a[name][0] - b[name][0]
        d[:, WRAPPED_STATE] = wrap_angle(d[:, WRAPPED_STATE])
        rms.append(np.sqrt(np.mean(d * d, axis=0)))
    return np.mean(rms, axis=0)


def short_check(scratch: Path, jobs: int, only: set[str]) -> int:
    truth = [t for t in _truth() if not only or t["id"] in only]
    scratch.mkdir(parents=True, exist_ok=True)
    push_file = scratch / "push.yaml"
    push_file.write_text(yaml.safe_dump([{"class": "littledog_mlsim.robot.effects:ConstantWind",
                                          "params": {"force_xy": [PUSH_N, 0.0]}}]))
    excitations = sorted({float((t.get("recording") or {}).get("excitation", 0.0))
                          for t in truth})
    base = {}
    for e in excitations:
        _record(scratch / f"clean_e{e:g}", None, e, jobs)
        _record(scratch / f"push_e{e:g}", push_file, e, jobs)
        clean = _states(scratch / f"clean_e{e:g}")
        push = _states(scratch / f"push_e{e:g}")
        std = np.std(np.concatenate([s for s, _ in clean.values()]), axis=0)
        base[e] = (clean, std, change(push, clean) / std,
                   falls(clean), falls(push))
    rows = []
    for t in truth:
        e = float((t.get("recording") or {}).get("excitation", 0.0))
        f = EFFECTS / t.get("file", f"{t['id']}.yaml")
        _record(scratch / t["id"], f, e, jobs)
        moves = _states(scratch / t["id"])
        clean, std, push_r, _, _ = base[e]
        r = change(moves, clean) / std
        ok = (r >= RATIO_MIN) & (r >= PUSH_FACTOR * push_r)
        order = np.argsort(-np.where(ok, r, -np.inf))
        best = int(order[0]) if ok.any() else int(np.argmax(r / np.maximum(push_r, 1e-12)))
        fl = falls(moves, _floor(f))
        rows.append({"id": t["id"], "excitation": e, "visible": bool(ok.any()),
                     "channels_passing": int(ok.sum()),
                     "best_channel": STATE_NAMES[best], "ratio": float(r[best]),
                     "push_ratio": float(push_r[best]),
                     "top": [{"channel": STATE_NAMES[i], "ratio": float(r[i]),
                              "push_ratio": float(push_r[i])} for i in order[:5] if ok[i]],
                     "falls": fl, "moves": len(moves)})
    doc = {"seed": SEED, "moves_per_type": MOVES, "robot": GAP.name,
           "rule": {"ratio_min": RATIO_MIN, "push_factor": PUSH_FACTOR, "push_N": PUSH_N,
                    "z_min_m": Z_MIN, "tilt_max_rad": TILT_MAX},
           "baselines": {f"{e:g}": {"clean_falls": b[3], "push_falls": b[4],
                                    "push_ratio_max": float(np.max(b[2])),
                                    "push_ratio_max_channel": STATE_NAMES[int(np.argmax(b[2]))]}
                         for e, b in base.items()},
           "effects": rows,
           "summary": {"effects": len(rows), "visible": sum(r["visible"] for r in rows),
                       "moves_fallen": sum(len(r["falls"]) for r in rows)
                       + sum(len(b[3]) + len(b[4]) for b in base.values())}}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo64: visibility and no-fall check on short recordings", "",
             f"Seed {SEED}, {MOVES} moves of each type, the gap robot. Visible: some channel's "
             f"mean per-move RMS change >= {RATIO_MIN:.0%} of its clean std and >= "
             f"{PUSH_FACTOR:g}x the change a {PUSH_N} N push makes. Fall: body below {Z_MIN} m "
             f"(over the floor), or |roll| or |pitch| > {TILT_MAX} rad.", "",
             "| effect | exc. | visible | channels passing | best channel | change / std | "
             "push change / std | falls |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['id']} | {r['excitation']:g} | {'yes' if r['visible'] else 'NO'} | "
                     f"{r['channels_passing']} | {r['best_channel']} | {r['ratio']:.3f} | "
                     f"{r['push_ratio']:.3f} | {len(r['falls'])} |")
    lines += ["", "Baselines: " + "; ".join(
        f"excitation {e}: clean falls {len(b['clean_falls'])}, push falls "
        f"{len(b['push_falls'])}, push's largest change / std {b['push_ratio_max']:.3f} "
        f"({b['push_ratio_max_channel']})" for e, b in doc["baselines"].items()),
        "", f"Summary: {doc['summary']['visible']} of {doc['summary']['effects']} effects "
        f"visible; {doc['summary']['moves_fallen']} moves fallen."]
    (HERE / "check.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    ok = doc["summary"]["visible"] == len(rows) and doc["summary"]["moves_fallen"] == 0
    return 0 if ok else 1


def recorded_check(work: Path) -> int:
    truth = {t["id"]: t for t in _truth()}
    sets = sorted((work / "effects").glob("*/dataset.yaml")) + sorted(
        (work / "clean").glob("*/dataset.yaml")) + sorted(work.glob("reference/dataset.yaml"))
    rows = []
    for index in sets:
        d = index.parent
        t = truth.get(d.name) if d.parent.name == "effects" else None
        f = EFFECTS / t.get("file", f"{t['id']}.yaml") if t else None
        moves = _states(d)
        fl = falls(moves, _floor(f))
        rows.append({"dataset": str(d.relative_to(work)), "moves": len(moves), "falls": fl})
        print(f"{rows[-1]['dataset']}: {len(moves)} moves, {len(fl)} fallen", flush=True)
    summary = {"datasets": len(rows), "moves": sum(r["moves"] for r in rows),
               "moves_fallen": sum(len(r["falls"]) for r in rows)}
    doc = {"work": str(work), "rule": {"z_min_m": Z_MIN, "tilt_max_rad": TILT_MAX},
           "datasets": rows, "summary": summary}
    (HERE / "check_recorded.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo64: no-fall check of every dataset the harness recorded", "",
             f"Work directory {work}. Fall: body below {Z_MIN} m (over the floor), or |roll| or "
             f"|pitch| > {TILT_MAX} rad.", "", "| dataset | moves | fallen |", "|---|---|---|"]
    lines += [f"| {r['dataset']} | {r['moves']} | {len(r['falls'])} |" for r in rows]
    lines += ["", f"Summary: {summary['datasets']} datasets, {summary['moves']} moves, "
                  f"{summary['moves_fallen']} fallen."]
    (HERE / "check_recorded.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines[-1:]))
    return 0 if summary["moves_fallen"] == 0 else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--recorded", metavar="WORK", default=None,
                    help="no-fall check of every dataset the harness recorded in WORK")
    ap.add_argument("--scratch", default="/tmp/z64_check", help="where short recordings go")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="", help="comma-separated effect ids (default: all)")
    a = ap.parse_args()
    if a.recorded:
        return recorded_check(Path(a.recorded))
    return short_check(Path(a.scratch), a.jobs, {s for s in a.only.split(",") if s})


if __name__ == "__main__":
    raise SystemExit(main())
