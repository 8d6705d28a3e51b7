"""The servo-structure choices in the committed calibration logs of the blind zoos: each distinct
line ``servo structure: S (k-step cost A against B)`` and the ratio B / A of the structure left
behind to the one chosen (decision 056).

    python benchmarks/diagnose_speed/calibrate_eval/structure_ratios.py
"""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
LINE = re.compile(r"servo structure: ([a-z_]+) \(k-step cost ([0-9.e-]+) against ([0-9.e-]+)\)")


def main() -> None:
    found = set()
    for path in (ROOT / "benchmarks/blind_zoo/zoos").rglob("*.log"):
        found.update(LINE.findall(path.read_text(errors="replace")))
    ratios = sorted((float(b) / float(a), s) for s, a, b in found)
    print(f"{len(ratios)} distinct choices; the one left behind over the one chosen: "
          f"{ratios[0][0]:.3g} to {ratios[-1][0]:.3g}")
    for r, s in ratios:
        print(f"  {s:10s} {r:6.2f}")


if __name__ == "__main__":
    main()
