"""zoo50's visibility check: every effect changes the recordings materially, and no move falls.

For each effect file (effects/zNN.yaml) this records MOVES moves of each of the 11 types with
the gap robot (gap_robot.json), the zoo's seed and the effect's recording condition, and the
same moves clean; it compares the 33 states (docs/interface.md section 4) of the two, channel by
channel (RMS of the difference over the RMS spread of the clean channel), and the moves' final
(x, y). Material: the largest channel difference at least FLOOR of that channel's spread
and at least MATERIAL times a negligible perturbation's. A negligible perturbation (a 0.01 N push) gives the floor of differences that the
trot's own sensitivity makes. No move may fall (|roll| or |pitch| above 0.7 rad, or the body
below 5 cm).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo50/check_visible.py

Writes check.json and check.md beside this script. With ``--recorded WORK`` it instead checks
the datasets the harness recorded in WORK (``--record-only``) for falls, every move of every
dataset, and writes check_recorded.json / check_recorded.md.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[3]
sys.path.insert(0, str(ROOT))
from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.data.states import states_from_recording  # noqa: E402
from littledog_mlsim.layout import STATE_NAMES  # noqa: E402

SEED = 411
MOVES = 3
ROBOT = HERE / "gap_robot.json"
NULL = "- class: littledog_mlsim.robot.effects:ConstantWind\n  params: {force_xy: [0.01, 0.0]}\n"
MATERIAL = 2.0      # the largest channel difference at least this many times the null's
FLOOR = 0.25        # ... and at least this fraction of the clean channel's spread


def record(out: Path, excitation: float, effects: Path | None) -> list:
    cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(MOVES), "--seed", str(SEED), "--jobs", "2", "--quiet",
           "--robot", str(ROBOT)]
    if excitation:
        cmd += ["--excitation", f"{excitation:g}"]
    if effects is not None:
        cmd += ["--effects", str(effects)]
    if not (out / "dataset.yaml").is_file():
        subprocess.run(cmd, check=True, cwd=ROOT)
    return sorted(load_moves(out, split="all"), key=lambda r: r.name)


def compare(clean: list, moved: list) -> dict:
    S0 = np.concatenate([states_from_recording(r) for r in clean])
    S1 = np.concatenate([states_from_recording(r) for r in moved])
    spread = S0.std(axis=0) + 1e-9
    ratio = np.sqrt(np.mean((S1 - S0) ** 2, axis=0)) / spread
    fxy = [float(np.hypot(*(a.position[-1, :2] - b.position[-1, :2])))
           for a, b in zip(clean, moved)]
    top = np.argsort(ratio)[::-1][:3]
    return {"max_channel_ratio": float(ratio.max()), "mean_channel_ratio": float(ratio.mean()),
            "top_channels": [STATE_NAMES[i] for i in top],
            "final_xy_diff_m_mean": float(np.mean(fxy))}


def falls(moves: list) -> list[str]:
    out = []
    for r in moves:
        rpy = states_from_recording(r)[:, 4:6]
        if np.abs(rpy).max() > 0.7 or r.position[:, 2].min() < 0.05:
            out.append(r.name)
    return out


def check_recorded(work: Path) -> int:
    rows = []
    for index in sorted(work.glob("*/*/dataset.yaml")) + sorted(work.glob("*/dataset.yaml")):
        d = index.parent
        moves = load_moves(d, split="all")
        rows.append({"dataset": str(d.relative_to(work)), "moves": len(moves),
                     "fell": falls(moves)})
    doc = {"work": str(work), "datasets": len(rows), "moves": sum(r["moves"] for r in rows),
           "fell": sum(len(r["fell"]) for r in rows), "rows": rows}
    (HERE / "check_recorded.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# zoo50: falls in the recorded datasets", "",
             f"{doc['datasets']} datasets, {doc['moves']} moves, {doc['fell']} fell "
             "(|roll| or |pitch| above 0.7 rad, or the body below 5 cm)", "",
             "| dataset | moves | fell |", "|---|---|---|"]
    lines += [f"| {r['dataset']} | {r['moves']} | {len(r['fell'])} |" for r in rows]
    (HERE / "check_recorded.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0 if doc["fell"] == 0 else 1


def main() -> int:
    if len(sys.argv) == 3 and sys.argv[1] == "--recorded":
        return check_recorded(Path(sys.argv[2]))
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    tmp = Path(tempfile.mkdtemp(prefix="zoo50_check_"))
    clean: dict[float, list] = {}
    null: dict[float, dict] = {}
    rows = []
    all_ok = True
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        if exc not in clean:
            clean[exc] = record(tmp / f"clean_e{exc:g}", exc, None)
            nf = tmp / "null.yaml"
            nf.write_text(NULL)
            null[exc] = compare(clean[exc], record(tmp / f"null_e{exc:g}", exc, nf))
            fell = falls(clean[exc])
            rows.append({"id": f"clean (excitation {exc:g})", "fell": fell})
            all_ok &= not fell
        moved = record(tmp / t["id"], exc, HERE / "effects" / f"{t['id']}.yaml")
        c = compare(clean[exc], moved)
        c["ratio_to_null"] = c["max_channel_ratio"] / null[exc]["max_channel_ratio"]
        c["fell"] = falls(moved)
        c["material"] = bool(c["ratio_to_null"] >= MATERIAL and c["max_channel_ratio"] >= FLOOR)
        c["ok"] = c["material"] and not c["fell"]
        all_ok &= c["ok"]
        rows.append({"id": t["id"], **c})
        print(t["id"], json.dumps(c), flush=True)
    doc = {"seed": SEED, "moves_per_type": MOVES, "robot": "gap_robot.json",
           "null": null, "rows": rows, "all_ok": bool(all_ok),
           "passed": sum(bool(r.get("ok")) for r in rows if "ok" in r),
           "effects": sum("ok" in r for r in rows)}
    (HERE / "check.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = [f"# zoo50 visibility check (seed {SEED}, {MOVES} moves per type, gap robot)", "",
             f"null perturbation's largest channel ratio: " + ", ".join(
                 f"excitation {k:g}: {v['max_channel_ratio']:.3f}" for k, v in null.items()), "",
             "| id | largest channel ratio | x null | mean ratio | final xy diff [m] | fell | ok |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        if "ok" not in r:
            lines.append(f"| {r['id']} | | | | | {len(r['fell'])} | |")
            continue
        lines.append(f"| {r['id']} | {r['max_channel_ratio']:.3f} | {r['ratio_to_null']:.1f} | "
                     f"{r['mean_channel_ratio']:.3f} | {r['final_xy_diff_m_mean']:.3f} | "
                     f"{len(r['fell'])} | {'yes' if r['ok'] else 'NO'} |")
    lines += ["", f"passed: {doc['passed']} of {doc['effects']}; all ok: {doc['all_ok']}", ""]
    (HERE / "check.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0 if all_ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
