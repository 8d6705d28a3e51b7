"""Decision 048's evidence: every committed report whose excess over the reference was named
(``physics.reference.unexplained.named``), with the kept scope's ratio, the body's, and the
scope decision 048 (``physical.driver.BODY_SHARE``) gives.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo43/runs/after_run1/body_share_retro.py \
        > benchmarks/blind_zoo/zoos/zoo43/runs/after_run1/body_share_retro.md
"""
import glob
import json
from pathlib import Path

from littledog_mlsim.diagnose.physical.driver import BODY_SHARE

ZOOS = Path(__file__).resolve().parents[3]


def main() -> None:
    print("| report | named | scope's ratio | body's | with 048 |")
    print("|---|---|---|---|---|")
    for f in sorted(glob.glob(str(ZOOS / "*/runs/**/report.json"), recursive=True)):
        u = (json.load(open(f)).get("physics") or {}).get("reference") or {}
        u = u.get("unexplained") or {}
        if not u.get("named"):
            continue
        ratios, scope = u["scope_ratios"], u["scope"]
        body = ratios["body"]
        new = "body" if scope != "body" and body >= BODY_SHARE * ratios[scope] else scope
        print(f"| {Path(f).relative_to(ZOOS).parent} | {scope} | {ratios[scope]:.2f} | "
              f"{body:.2f} | {new} |")


if __name__ == "__main__":
    main()
