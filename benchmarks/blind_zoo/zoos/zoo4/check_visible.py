"""Is each recorded effect dataset materially different from the clean one of the same seed?

    python check_visible.py --clean DIR --set NAME=DIR [--set NAME=DIR ...] [--out table.md]

Moves are paired by bag name (same seed: same gait and noise draws). Per effect dataset, over its
moves: mean |end (x, y) shift - clean's| [m], mean |final yaw change - clean's| [rad], joint
tracking RMS (measured angle one step after the set-point minus the recorded set-point) [rad]
beside the clean one, max |roll| and |pitch| [rad] and min body height [m] (clean beside).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from littledog_mlsim.data.bags import read_bag


def yaw_roll_pitch(qxyzw: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x, y, z, w = qxyzw.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return yaw, roll, pitch


def summarise(ds: Path) -> dict[str, dict[str, float]]:
    out = {}
    for bag in sorted(d for d in ds.iterdir() if d.is_dir()):
        r = read_bag(bag)
        yaw, roll, pitch = yaw_roll_pitch(np.asarray(r.orientation))
        pos = np.asarray(r.position)
        n = len(r.cmd)
        out[bag.name] = {
            "end_xy": pos[-1, :2] - pos[0, :2],
            "dyaw": float(np.angle(np.exp(1j * (yaw[-1] - yaw[0])))),
            "track": float(np.sqrt(np.mean((np.asarray(r.q)[1:n + 1] - np.asarray(r.cmd)) ** 2))),
            "roll": float(np.max(np.abs(roll))), "pitch": float(np.max(np.abs(pitch))),
            "zmin": float(np.min(pos[:, 2])),
        }
    return out


def compare(clean: dict, eff: dict) -> dict[str, float]:
    names = sorted(set(clean) & set(eff))
    c, e = [clean[n] for n in names], [eff[n] for n in names]
    return {
        "moves": len(names),
        "xy_shift": float(np.mean([np.linalg.norm(a["end_xy"] - b["end_xy"]) for a, b in zip(c, e)])),
        "yaw_change": float(np.mean([abs(np.angle(np.exp(1j * (a["dyaw"] - b["dyaw"]))))
                                     for a, b in zip(c, e)])),
        "track": float(np.mean([b["track"] for b in e])),
        "track_clean": float(np.mean([a["track"] for a in c])),
        "max_roll": max(b["roll"] for b in e), "max_roll_clean": max(a["roll"] for a in c),
        "max_pitch": max(b["pitch"] for b in e), "max_pitch_clean": max(a["pitch"] for a in c),
        "zmin": min(b["zmin"] for b in e), "zmin_clean": min(a["zmin"] for a in c),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clean", action="append", required=True,
                    help="clean dataset; repeat as EXC=DIR to pair by excitation")
    ap.add_argument("--set", action="append", default=[],
                    help="NAME=DIR or NAME@EXC=DIR (EXC names the clean to compare with)")
    ap.add_argument("--out", help="also write the table here")
    a = ap.parse_args()
    cleans = {}
    for c in a.clean:
        key, _, path = c.rpartition("=") if "=" in c else ("0", "", c)
        cleans[key or "0"] = summarise(Path(path))
    rows = ["| set | moves | mean end xy shift [m] | mean final yaw change [rad] | tracking RMS "
            "[rad] (clean) | max roll [rad] (clean) | max pitch [rad] (clean) | min height [m] "
            "(clean) |", "|---|---|---|---|---|---|---|---|"]
    for s in a.set:
        name, path = s.split("=", 1)
        name, _, exc = name.partition("@")
        r = compare(cleans[exc or "0"], summarise(Path(path)))
        rows.append(f"| {name} | {r['moves']} | {r['xy_shift']:.3f} | {r['yaw_change']:.3f} | "
                    f"{r['track']:.4f} ({r['track_clean']:.4f}) | {r['max_roll']:.3f} "
                    f"({r['max_roll_clean']:.3f}) | {r['max_pitch']:.3f} ({r['max_pitch_clean']:.3f})"
                    f" | {r['zmin']:.3f} ({r['zmin_clean']:.3f}) |")
    text = "\n".join(rows)
    print(text)
    if a.out:
        Path(a.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
