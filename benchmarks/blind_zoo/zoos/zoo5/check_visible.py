"""Is each effect of this zoo visible in the recordings, and does the robot stay upright?

For every ``zNN`` of ``truth.yaml`` this compares the effect's dataset with the clean dataset of
the same seed and excitation, move by move (the same seed gives the same gait and noise, so the
difference is the effect's alone), and prints one table row per effect, without naming the
effect:

- final (x, y) difference [m]: mean over moves of |p_effect(4 s) - p_clean(4 s)| (odometry);
- relative: that difference over the clean moves' mean (x, y) travel;
- final yaw difference [rad] (mean absolute);
- joint angle RMS difference [rad] (measured q, all joints, all steps);
- body z change [m]: mean of (z(t) - z(0)) effect minus clean;
- fall check: the worst |roll| / |pitch| [rad] relative to the first sample and the lowest body
  height above its start; a move counts as fallen if the tilt exceeds 0.35 rad or the body drops
  more than 0.03 m below its start.

Two modes:

- ``--small``: records small datasets itself (``--moves-per-type``, default 2) into ``--work``;
- default: reads the datasets ``run.py --record-only`` wrote under ``--data``
  (``effects/<id>`` and ``clean/s<seed>_e<excitation>``).

The markdown table goes to ``--out`` with the command on its first line.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))
from littledog_mlsim.data.bags import read_bag  # noqa: E402

TILT_FALL = 0.35
DROP_FALL = 0.03


def _yaw(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q.T
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _roll_pitch(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y, z, w = q.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    return roll, pitch


def load(ds: Path) -> dict[str, object]:
    bags = sorted(d for d in ds.iterdir() if d.is_dir() and (d / "metadata.yaml").is_file())
    if not bags:
        raise SystemExit(f"check_visible: no bags in {ds}")
    return {b.name: read_bag(b) for b in bags}


def compare(eff: dict, clean: dict) -> dict[str, float]:
    names = sorted(set(eff) & set(clean))
    dxy, dyaw, qrms, dz, travel, tilt, drop, fallen = [], [], [], [], [], [], [], 0
    for n in names:
        e, c = eff[n], clean[n]
        dxy.append(float(np.linalg.norm(e.position[-1, :2] - c.position[-1, :2])))
        travel.append(float(np.linalg.norm(c.position[-1, :2] - c.position[0, :2])))
        dyaw.append(float(abs(np.angle(np.exp(1j * (_yaw(e.orientation[-1:]) -
                                                       _yaw(c.orientation[-1:]))))[0])))
        qrms.append(float(np.sqrt(np.mean((e.q - c.q) ** 2))))
        dz.append(float(np.mean(e.position[:, 2] - e.position[0, 2])
                        - np.mean(c.position[:, 2] - c.position[0, 2])))
        r, pch = _roll_pitch(e.orientation)
        t = float(max(np.max(np.abs(r - r[0])), np.max(np.abs(pch - pch[0]))))
        d = float(e.position[0, 2] - np.min(e.position[:, 2]))
        tilt.append(t)
        drop.append(d)
        fallen += int(t > TILT_FALL or d > DROP_FALL)
    return {"moves": len(names), "dxy": np.mean(dxy), "rel": np.mean(dxy) / np.mean(travel),
            "dyaw": np.mean(dyaw), "qrms": np.mean(qrms), "dz": np.mean(dz),
            "tilt": max(tilt), "drop": max(drop), "fallen": fallen}


def record(out: Path, seed: int, moves: int, exc: float, effects: Path | None) -> None:
    if (out / "dataset.yaml").is_file():
        return
    cmd = [sys.executable, "-m", "littledog_mlsim.cli", "record", "--out", str(out),
           "--moves-per-type", str(moves), "--seed", str(seed), "--jobs", "2", "--quiet",
           "--overwrite"]
    if exc:
        cmd += ["--excitation", f"{exc:g}"]
    if effects is not None:
        cmd += ["--effects", str(effects)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--zoo", default=str(HERE))
    ap.add_argument("--data", default="/work/data/blind6", help="run.py --work directory")
    ap.add_argument("--small", action="store_true", help="record small datasets into --work")
    ap.add_argument("--work", default="/tmp/zoo5_check")
    ap.add_argument("--moves-per-type", type=int, default=2)
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    zoo = Path(a.zoo)
    truth = yaml.safe_load((zoo / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    rows = []
    cleans: dict[float, dict] = {}
    for t in truth:
        exc = float((t.get("recording") or {}).get("excitation", 0.0))
        if a.small:
            base = Path(a.work)
            cpath = base / f"clean_e{exc:g}"
            record(cpath, a.seed, a.moves_per_type, exc, None)
            epath = base / t["id"]
            efile = zoo / "effects" / t.get("file", f"{t['id']}.yaml")
            record(epath, a.seed, a.moves_per_type, exc, efile)
        else:
            cpath = Path(a.data) / "clean" / f"s{a.seed}_e{exc:g}"
            epath = Path(a.data) / "effects" / t["id"]
        if exc not in cleans:
            cleans[exc] = load(cpath)
        r = compare(load(epath), cleans[exc])
        rows.append((t["id"], exc, r))
        print(t["id"], "done", file=sys.stderr, flush=True)
    lines = ["Command (from benchmarks/blind_zoo/zoos/zoo5, PYTHONPATH=<repository root>, "
             "OPENBLAS_NUM_THREADS=1): `" + " ".join(["python"] + [str(x) for x in sys.argv]) + "`",
             "", "Same seed, effect versus clean, move by move; see check_visible.py for the "
             "columns. A move counts as fallen above %.2f rad of tilt or %.2f m of drop." % (
                 TILT_FALL, DROP_FALL), "",
             "| effect | excitation | moves | final (x,y) diff [m] | relative to clean travel | "
             "final yaw diff [rad] | joint q RMS diff [rad] | mean z change [m] | "
             "worst tilt [rad] | worst drop [m] | fallen moves |",
             "|" + "---|" * 11]
    for i, exc, r in rows:
        lines.append(f"| {i} | {exc:g} | {r['moves']} | {r['dxy']:.3f} | {r['rel']:.2f} | "
                     f"{r['dyaw']:.3f} | {r['qrms']:.4f} | {r['dz']:+.4f} | {r['tilt']:.2f} | "
                     f"{r['drop']:.3f} | {r['fallen']} |")
    for exc, c in cleans.items():
        r = compare(c, c)
        lines.append(f"| clean (reference) | {exc:g} | {r['moves']} | 0 | 0 | 0 | 0 | 0 | "
                     f"{r['tilt']:.2f} | {r['drop']:.3f} | {r['fallen']} |")
    text = "\n".join(lines) + "\n"
    Path(a.out).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
