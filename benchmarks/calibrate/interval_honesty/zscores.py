"""How honest are calibrate's 95 % intervals, parameter by parameter, over the gap robots?

    .venv/bin/python benchmarks/calibrate/interval_honesty/zscores.py RUN [RUN ...]

Each RUN is a run directory under ``benchmarks/blind_zoo/zoos/`` with a ``score.json``
(``harness/score_twin.py``). For every identifiable parameter with an interval, z is the
error in the fit's coordinate (the logarithm of a log parameter, the value of the others) over
the interval's half-width on the truth's side, times 1.96: z = +-1.96 at the interval's ends.
For an honest 95 % interval z is about standard normal, so its RMS over runs is about 1; an
RMS of 2 means the intervals are about half as wide as the errors.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.robot.parameters import TWIN_PARAMETERS  # noqa: E402

Z95 = 1.959964


def zscores(run: str) -> dict[str, float]:
    doc = json.loads((ROOT / "benchmarks/blind_zoo/zoos" / run / "score.json").read_text())
    out = {}
    for row in doc["rows"]:
        if not row.get("identifiable") or row["ci95"][0] is None:
            continue
        log = TWIN_PARAMETERS[row["name"]].log
        f = math.log if log else (lambda v: v)
        v, t = f(row["value"]), f(row["truth"])
        lo, hi = f(row["ci95"][0]), f(row["ci95"][1])
        half = (hi - v) if t > v else (v - lo)
        if half > 0:
            out[row["scored_as"]] = Z95 * (t - v) / half
    return out


def main(runs: list[str]) -> int:
    per: dict[str, list[float]] = {}
    for run in runs:
        for name, z in zscores(run).items():
            per.setdefault(name, []).append(z)
    print("runs: " + ", ".join(runs))
    print("| parameter | n | RMS z | max abs z | mean z | z per run |")
    print("|---|---|---|---|---|---|")
    for name, zs in sorted(per.items(), key=lambda kv: -sum(z * z for z in kv[1]) / len(kv[1])):
        rms = math.sqrt(sum(z * z for z in zs) / len(zs))
        print(f"| {name} | {len(zs)} | {rms:.2f} | {max(abs(z) for z in zs):.2f} | "
              f"{sum(zs) / len(zs):+.2f} | " + " ".join(f"{z:+.1f}" for z in zs) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
