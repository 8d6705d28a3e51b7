"""Check that every effect of the sixth zoo is visible and that no move falls (sealed zoo file).

Each effect's recording is compared with the clean recording of the same seed and excitation,
move by move (bags of the same name): final (x, y) odometry difference (absolute, and relative
to the clean move's travel), final yaw difference, joint-angle RMS difference, mean body-height
change, and a fall check on the effect's move (worst tilt from the start orientation > 0.35 rad,
or the body more than 0.03 m below its start height above the floor under it).

    # small check: records 2 moves per type, seed 16, into /work/data/zoo6_small/ itself
    python benchmarks/blind_zoo/zoos/zoo6/check_visible.py --small \\
        --out benchmarks/blind_zoo/zoos/zoo6/check_small.md
    # full check on the datasets run.py --record-only wrote
    python benchmarks/blind_zoo/zoos/zoo6/check_visible.py --work /work/data/blind7 --seed 18 \\
        --out benchmarks/blind_zoo/zoos/zoo6/check_full.md
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from littledog_mlsim.data.bags import read_bag
from littledog_mlsim.data.dataset import read_index

ZOO = Path(__file__).resolve().parent
TILT_FALL = 0.35   # rad
DROP_FALL = 0.03   # m
# An effect counts as visible when the median move passes one of these.
VIS = {"dxy_m": 0.05, "dxy_rel": 0.10, "dyaw_rad": 0.10, "q_rms_rad": 0.02, "dz_m": 0.005}


def load_truth() -> list[dict]:
    t = yaml.safe_load((ZOO / "truth.yaml").read_text())
    return t["effects"] if isinstance(t, dict) else t


def yaw_of(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q.T
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def up_vector(q: np.ndarray) -> np.ndarray:
    """The body's z axis in the world for quaternions (..., 4) xyzw."""
    x, y, z, w = np.moveaxis(q, -1, 0)
    return np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], -1)


def tilt_from_start(q: np.ndarray) -> np.ndarray:
    """Angle between the body's z axis at the start and at each sample (yaw excluded)."""
    u = up_vector(q)
    return np.arccos(np.clip(u @ u[0], -1.0, 1.0))


def floor_height(effect_file: Path):
    """The floor height under (x, y) for a tilted-floor effect file, else None."""
    spec = yaml.safe_load(effect_file.read_text())
    for e in spec:
        if e["class"].endswith(":TiltedFloor"):
            s = np.radians(e["params"]["slope_deg"])
            d = np.radians(e["params"]["uphill_deg"])
            return lambda xy: np.tan(s) * (xy[..., 0] * np.cos(d) + xy[..., 1] * np.sin(d))
    return None


def compare(eff_dir: Path, clean_dir: Path, effect_file: Path) -> list[dict]:
    idx = read_index(clean_dir)
    test = set(idx.names("test"))
    floor = floor_height(effect_file)
    rows = []
    for name in idx.names("all"):
        a, b = read_bag(clean_dir / name), read_bag(eff_dir / name)
        travel = np.linalg.norm(a.position[-1, :2] - a.position[0, :2])
        dxy = np.linalg.norm(b.position[-1, :2] - a.position[-1, :2])
        dyaw = np.angle(np.exp(1j * (yaw_of(b.orientation[-1:]) - yaw_of(a.orientation[-1:]))))[0]
        h = b.position[:, 2] - (floor(b.position[:, :2]) if floor else 0.0)
        ha = a.position[:, 2]
        rows.append({
            "move": name, "test": name in test, "travel_m": travel, "dxy_m": dxy,
            "dxy_rel": dxy / max(travel, 0.05), "dyaw_rad": abs(dyaw),
            "q_rms_rad": float(np.sqrt(np.mean((b.q - a.q) ** 2))),
            "dz_m": float(abs(np.mean(h) - np.mean(ha))),
            "tilt_rad": float(tilt_from_start(b.orientation).max()),
            "drop_m": float(h[0] - h.min()),
        })
        r = rows[-1]
        r["fallen"] = r["tilt_rad"] > TILT_FALL or r["drop_m"] > DROP_FALL
    return rows


def summary_line(tid: str, exc: float, rows: list[dict]) -> tuple[str, bool, int]:
    med = {k: float(np.median([r[k] for r in rows])) for k in VIS}
    med_test = {k: float(np.median([r[k] for r in rows if r["test"]])) for k in VIS}
    visible = any(med[k] > v for k, v in VIS.items()) and any(
        med_test[k] > v for k, v in VIS.items())
    fallen = sum(r["fallen"] for r in rows)
    worst_tilt = max(r["tilt_rad"] for r in rows)
    worst_drop = max(r["drop_m"] for r in rows)
    line = (f"| {tid} | {exc:g} | {len(rows)} | {med['dxy_m']:.3f} | {max(r['dxy_m'] for r in rows):.3f} | "
            f"{med['dxy_rel']:.2f} | {med['dyaw_rad']:.3f} | {med['q_rms_rad']:.4f} | "
            f"{med['dz_m'] * 1000:.1f} | {med_test['dxy_m']:.3f} / {med_test['q_rms_rad']:.4f} | "
            f"{worst_tilt:.3f} | {worst_drop * 1000:.1f} | {fallen} | {'yes' if visible else 'NO'} |")
    return line, visible, fallen


def record(out: Path, seed: int, moves: int, exc: float, effects: Path | None) -> None:
    if (out / "dataset.yaml").is_file():
        return
    cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(moves), "--seed", str(seed), "--jobs", "2", "--quiet"]
    if exc:
        cmd += ["--excitation", f"{exc:g}"]
    if effects is not None:
        cmd += ["--effects", str(effects)]
    subprocess.run(cmd, check=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--small", action="store_true",
                    help="record 2 moves per type (seed 16) into --work first")
    ap.add_argument("--work", default=None, help="datasets: <work>/effects/zNN, <work>/clean/s<seed>_e<exc>")
    ap.add_argument("--seed", type=int, default=16)
    ap.add_argument("--only", default="", help="comma-separated effect ids")
    ap.add_argument("--out", required=True, help="markdown report")
    a = ap.parse_args(argv)
    work = Path(a.work or ("/work/data/zoo6_small" if a.small else "/work/data/blind7"))
    truth = [t for t in load_truth() if not a.only or t["id"] in a.only.split(",")]
    t0 = time.time()
    if a.small:
        for t in truth:
            exc = float((t.get("recording") or {}).get("excitation", 0.0))
            record(work / "clean" / f"s{a.seed}_e{exc:g}", a.seed, 2, exc, None)
            record(work / "effects" / t["id"], a.seed, 2, exc, ZOO / "effects" / f"{t['id']}.yaml")
    lines = [
        "OPENBLAS_NUM_THREADS=%s python %s" % (os.environ.get("OPENBLAS_NUM_THREADS"),
                                                " ".join(sys.argv)),
        "",
        f"Data: {work} (seed {a.seed}); each effect vs the clean recording of the same seed and "
        f"excitation, move by move. Medians over all moves; 'test' = TestPool medians. Fallen: "
        f"tilt from start > {TILT_FALL} rad or body > {DROP_FALL * 1000:.0f} mm below its start "
        f"height above the floor. Visible: a median (all moves and TestPool) above one of "
        f"{VIS}.",
        "",
        "| effect | exc. | moves | final dxy [m] | max dxy [m] | dxy / clean travel | final dyaw [rad] | "
        "q RMS diff [rad] | height change [mm] | test dxy [m] / q RMS | worst tilt [rad] | "
        "worst drop [mm] | fallen moves | visible |",
        "|" + "---|" * 14,
    ]
    all_ok = True
    per_move = ["", "Moves with the smallest final dxy per effect (name: dxy m, q RMS rad):", ""]
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        rows = compare(work / "effects" / t["id"], work / "clean" / f"s{a.seed}_e{exc:g}",
                       ZOO / "effects" / f"{t['id']}.yaml")
        line, vis, fallen = summary_line(t["id"], exc, rows)
        lines.append(line)
        all_ok &= vis and fallen == 0
        low = sorted(rows, key=lambda r: r["dxy_m"])[:3]
        per_move.append(f"- {t['id']}: " + ", ".join(
            f"{r['move']}: {r['dxy_m']:.3f}, {r['q_rms_rad']:.4f}" for r in low)
            + ("; fallen: " + ", ".join(r["move"] for r in rows if r["fallen"])
               if fallen else ""))
    lines += per_move
    lines += ["", f"All visible and none fallen: {'yes' if all_ok else 'NO'}. "
                  f"({time.time() - t0:.0f} s wall, load {os.getloadavg()[0]:.2f})"]
    Path(a.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0 if all_ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
