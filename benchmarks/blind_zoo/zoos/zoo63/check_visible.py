"""zoo63's visibility and no-fall check (sealed, as the rest of the zoo but its README).

Two checks, from the repository root:

    # short recordings: every effect against the clean recordings of the same seed and moves
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo63/check_visible.py

    # every dataset the harness recorded into WORK (no fall; each effect against its clean)
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo63/check_visible.py \
        --recorded /tmp/z63w

**Short check** (``check.md`` / ``check.json``): with the gap robot (``gap_robot.json``), seed
541 and ``--moves-per-type`` moves of each of the 11 types (default 3), under the recording
condition truth.yaml gives each effect (command excitation 0 or 0.05), it records the clean
moves, the same moves with the effect, and the same moves with a negligible perturbation (a
constant 0.02 N horizontal push in odom, ``ConstantWind``). For each of the 33 state channels
(``data.states.states_from_recording``): the RMS over a move of the difference from the clean
move, averaged over the moves, over the channel's standard deviation in the clean moves. An
effect is **visible** when some channel changes by at least 10 % of its spread **and** by at
least twice what the push changes in that channel. A move **falls** when the body goes below
0.07 m or |roll| or |pitch| beyond 0.7 rad. Every effect must be visible with no move fallen.
Recordings are kept under ``--scratch`` (default /tmp/z63check), keyed by what they depend on,
and reused.

**Recorded check** (``check_recorded.md`` / ``check_recorded.json``): every dataset under WORK
(the effects, the clean seeds, the reference): the no-fall rule on every move; for each effect,
its largest channel change against the clean dataset of the same seed and excitation (the same
measure, no push there).
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
sys.path.insert(0, str(HERE.parents[3]))      # the repository root

from littledog_mlsim.apps.record import record_dataset  # noqa: E402
from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.data.states import states_from_recording  # noqa: E402
from littledog_mlsim.layout import STATE_NAMES  # noqa: E402
from littledog_mlsim.rotations import quat_to_rpy  # noqa: E402

ROBOT = HERE / "gap_robot.json"
TRUTH = HERE / "truth.yaml"
EFFECTS = HERE / "effects"
SEED = 541
VISIBLE = 0.10          # of the channel's spread
OVER_PUSH = 2.0         # times the negligible push's change
PUSH_N = 0.02           # the negligible push [N]
Z_MIN, ANGLE_MAX = 0.07, 0.7


def truth() -> list[dict]:
    doc = yaml.safe_load(TRUTH.read_text())
    return doc["effects"] if isinstance(doc, dict) else doc


def _key(*parts: str) -> str:
    h = hashlib.sha1()
    for x in parts:
        h.update(x.encode())
        h.update(b"\0")
    return h.hexdigest()[:12]


def record(scratch: Path, name: str, effects_file: Path | None, excitation: float,
           n: int) -> Path:
    """The short recording of ``name`` (reused when what it depends on is unchanged)."""
    parts = [ROBOT.read_text(), str(excitation), str(n), str(SEED)]
    if effects_file is not None:
        parts.append(effects_file.read_text())
        if (EFFECTS / "plugins.py").is_file():
            parts.append((EFFECTS / "plugins.py").read_text())
    out = scratch / f"{name}_e{excitation:g}_{_key(*parts)}"
    if not (out / "dataset.yaml").is_file():
        t0 = time.perf_counter()
        record_dataset(out, moves_per_type=n, seed=SEED, robot=str(ROBOT),
                       effects_file=None if effects_file is None else str(effects_file),
                       jobs=1, progress=False, excitation=excitation, overwrite=True)
        print(f"recorded {out.name} in {time.perf_counter() - t0:.0f} s", flush=True)
    return out


def moves(path: Path) -> dict:
    return {m.name: m for m in load_moves(path, split="all")}


def falls(recs: dict) -> list[dict]:
    """The moves that fall, with their lowest height and largest |roll|, |pitch|."""
    out = []
    for name, m in recs.items():
        rpy = quat_to_rpy(m.orientation)
        z = float(np.min(m.position[:, 2]))
        r, pch = float(np.max(np.abs(rpy[:, 0]))), float(np.max(np.abs(rpy[:, 1])))
        if not (np.isfinite(z) and np.isfinite(r) and np.isfinite(pch)) or z < Z_MIN \
                or r > ANGLE_MAX or pch > ANGLE_MAX:
            out.append({"move": name, "z_min": z, "roll_max": r, "pitch_max": pch})
    return out


def spread(clean: dict) -> np.ndarray:
    s = np.concatenate([states_from_recording(m) for m in clean.values()])
    return np.std(s, axis=0)


def change(other: dict, clean: dict, sd: np.ndarray) -> np.ndarray:
    """Per channel: RMS over a move of the difference, averaged over moves, / spread."""
    rms = []
    for name, c in clean.items():
        d = states_from_recording(other[name]) - states_from_recording(c)
        rms.append(np.sqrt(np.mean(d * d, axis=0)))
    return np.mean(rms, axis=0) / np.where(sd > 0, sd, np.inf)


def short_check(n: int, scratch: Path) -> dict:
    scratch.mkdir(parents=True, exist_ok=True)
    push = scratch / "push.yaml"
    push.write_text("- class: littledog_mlsim.robot.effects:ConstantWind\n"
                    f"  params: {{force_xy: [{PUSH_N}, 0.0]}}\n")
    base: dict[float, tuple] = {}
    rows = []
    for t in truth():
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        if exc not in base:
            clean = moves(record(scratch, "clean", None, exc, n))
            pushed = moves(record(scratch, "push", push, exc, n))
            sd = spread(clean)
            base[exc] = (clean, sd, change(pushed, clean, sd))
        clean, sd, push_v = base[exc]
        eff = moves(record(scratch, t["id"], EFFECTS / f"{t['id']}.yaml", exc, n))
        v = change(eff, clean, sd)
        ok = (v >= VISIBLE) & (v >= OVER_PUSH * push_v)
        score = np.where(ok, v, -np.inf)
        best = int(np.argmax(score)) if ok.any() else int(np.argmax(v / np.maximum(push_v, 1e-12)))
        fallen = falls(eff)
        rows.append({"id": t["id"], "excitation": exc, "moves": len(eff),
                     "visible": bool(ok.any()), "channels_visible": int(ok.sum()),
                     "best_channel": STATE_NAMES[best], "change": float(v[best]),
                     "push_change": float(push_v[best]),
                     "over_push": float(v[best] / push_v[best]) if push_v[best] > 0 else None,
                     "largest_change": float(v.max()),
                     "largest_channel": STATE_NAMES[int(np.argmax(v))],
                     "falls": fallen})
    clean_falls = {f"{exc:g}": falls(b[0]) for exc, b in base.items()}
    return {"seed": SEED, "moves_per_type": n, "rows": rows, "clean_falls": clean_falls,
            "push_largest_change": {f"{e:g}": float(b[2].max()) for e, b in base.items()},
            "all_visible": all(r["visible"] for r in rows),
            "no_falls": not any(r["falls"] for r in rows) and not any(clean_falls.values())}


def short_markdown(doc: dict) -> str:
    h = [f"# zoo63 short check: seed {doc['seed']}, {doc['moves_per_type']} moves per type", "",
         f"Visible: a channel changes >= {VISIBLE:.0%} of its clean spread and >= "
         f"{OVER_PUSH:g}x the change of a {PUSH_N} N push. Fall: z < {Z_MIN} m or |roll|, "
         f"|pitch| > {ANGLE_MAX} rad.", "",
         "| effect | exc. | moves | visible | channels visible | best channel | change / spread "
         "| push's | x push | largest (channel) | falls |", "|" + "---|" * 11]
    for r in doc["rows"]:
        h.append(f"| {r['id']} | {r['excitation']:g} | {r['moves']} | "
                 f"{'yes' if r['visible'] else 'NO'} | {r['channels_visible']} | "
                 f"{r['best_channel']} | {r['change']:.3f} | {r['push_change']:.3f} | "
                 f"{r['over_push']:.1f} | {r['largest_change']:.3f} ({r['largest_channel']}) | "
                 f"{len(r['falls'])} |")
    h += ["", f"Clean moves fallen: {json.dumps({k: len(v) for k, v in doc['clean_falls'].items()})}; "
          f"the push's largest change / spread: {json.dumps(doc['push_largest_change'])}.", "",
          f"**All visible: {'yes' if doc['all_visible'] else 'NO'}; no falls: "
          f"{'yes' if doc['no_falls'] else 'NO'}.**"]
    return "\n".join(h) + "\n"


def recorded_check(work: Path) -> dict:
    sets = sorted(p.parent for p in work.rglob("dataset.yaml"))
    exc_of = {t["id"]: float((t.get("recording") or {}).get("excitation", 0.0)) for t in truth()}
    loaded = {}
    rows = []
    for ds in sets:
        recs = moves(ds)
        loaded[ds] = recs
        rows.append({"dataset": str(ds.relative_to(work)), "moves": len(recs),
                     "falls": falls(recs)})
    effects = []
    for ds in sets:
        if ds.parent.name != "effects" or ds.name not in exc_of:
            continue
        cpath = work / "clean" / f"s{SEED}_e{exc_of[ds.name]:g}"
        if cpath not in loaded:
            continue
        clean = loaded[cpath]
        sd = spread(clean)
        v = change(loaded[ds], clean, sd)
        effects.append({"id": ds.name, "clean": str(cpath.relative_to(work)),
                        "largest_change": float(v.max()),
                        "largest_channel": STATE_NAMES[int(np.argmax(v))],
                        "channels_over_10pc": int((v >= VISIBLE).sum())})
    return {"work": str(work), "datasets": rows, "effects": effects,
            "n_datasets": len(rows), "n_moves": sum(r["moves"] for r in rows),
            "n_falls": sum(len(r["falls"]) for r in rows)}


def recorded_markdown(doc: dict) -> str:
    h = [f"# zoo63 recorded check: {doc['work']}", "",
         f"{doc['n_datasets']} datasets, {doc['n_moves']} moves, {doc['n_falls']} fallen "
         f"(z < {Z_MIN} m or |roll|, |pitch| > {ANGLE_MAX} rad).", "",
         "| dataset | moves | falls |", "|---|---|---|"]
    for r in doc["datasets"]:
        h.append(f"| {r['dataset']} | {r['moves']} | {len(r['falls'])} |")
    h += ["", "| effect | against | largest change / spread (channel) | channels >= 10 % |",
          "|---|---|---|---|"]
    for e in doc["effects"]:
        h.append(f"| {e['id']} | {e['clean']} | {e['largest_change']:.3f} "
                 f"({e['largest_channel']}) | {e['channels_over_10pc']} |")
    return "\n".join(h) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--moves-per-type", type=int, default=3)
    ap.add_argument("--scratch", default="/tmp/z63check")
    ap.add_argument("--recorded", metavar="WORK", default=None,
                    help="check every dataset the harness recorded into WORK instead")
    a = ap.parse_args(argv)
    if a.recorded:
        doc = recorded_check(Path(a.recorded))
        (HERE / "check_recorded.json").write_text(json.dumps(doc, indent=1) + "\n")
        (HERE / "check_recorded.md").write_text(recorded_markdown(doc))
        print(recorded_markdown(doc))
        return 0 if doc["n_falls"] == 0 else 1
    doc = short_check(a.moves_per_type, Path(a.scratch))
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    (HERE / "check.md").write_text(short_markdown(doc))
    print(short_markdown(doc))
    return 0 if doc["all_visible"] and doc["no_falls"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
