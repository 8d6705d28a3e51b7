"""What the physical route's excess over the reference would name if the per-channel test
counted as the pooled one does (decision 062; decision 047 named it only where the pooled test
was significant), and without the pooled ratio's condition (decision 063).

Reads every committed report of the blind zoos whose ``physics.reference.unexplained`` is read
(``named``: decision 047 onwards; the arms with a twin and a reference), except the zoos given
in ``--skip`` (``none`` to read every zoo), and each zoo's ``truth.yaml``. For each report:
whether the excess is named in it as written (``named``: the rule of the code that wrote it,
decision 052's reading included where it was in that code); whether it would be under decision
062 and under decisions 062 and 063 (:func:`named_by_channel`); the clean runs that would then
raise a false alarm; the effects outside the vocabulary that would then be found at their
scope.

    .venv/bin/python benchmarks/blind_zoo/left_by_channel/tally.py --skip none > OUT
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1] / "zoos"
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "harness"))
from run import score, significant  # noqa: E402

#: decision 062's material ratio (``physical.driver.UNEXPLAINED_RATIO``)
RATIO = 1.25


def named_by_channel(left: dict[str, Any], pooled_material: bool = True) -> tuple[bool, bool]:
    """(named under decision 062, whether that is exact); with ``pooled_material`` false,
    under decision 063 (a significant channel material, the pooled ratio whatever it is).
    Reports written before decision 062 do not keep which channels were significant: there the
    largest channel ratio stands in for the significant channels' (an upper bound, so the
    count can only be too high)."""
    if left.get("named"):
        return True, True
    comparable = left.get("comparable", True) or left.get("concentrated", False)
    if not ((left["material"] or not pooled_material) and comparable
            and left["channel_significant"]):
        return False, True
    if "significant_channels" in left:
        return any(c["ratio"] >= RATIO for c in left["significant_channels"]), True
    return max((c["ratio"] for c in left["channels"]), default=0.0) >= RATIO, False


def rows(skip: set[str]):
    for zoo in sorted(ROOT.iterdir(), key=lambda p: int(p.name[3:]) if p.name[3:].isdigit() else 0):
        if zoo.name in skip or not (zoo / "truth.yaml").exists():
            continue
        t = yaml.safe_load((zoo / "truth.yaml").read_text()) or {}
        truth = {e["id"]: e for e in (t.get("effects", []) if isinstance(t, dict) else t)}
        for rep in sorted(zoo.glob("runs/**/report.json")):
            case = rep.parent.name
            try:
                r = json.loads(rep.read_text())
            except (OSError, ValueError):
                continue
            left = ((r.get("physics") or {}).get("reference") or {}).get("unexplained")
            if not left or "channel_p_value" not in left or "named" not in left:
                continue     # before decision 047 the excess was not named
            yield zoo.name, str(rep.parent.relative_to(zoo)), case, truth.get(case), r, left


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--skip", required=True,
                    help="zoos not to read (a sealed zoo whose run is unread), comma-separated, "
                         "or none")
    a = ap.parse_args()
    skip = {s for s in a.skip.split(",") if s and s != "none"}
    out = []
    for zoo, where, case, truth, r, left in rows(skip):
        named_new, exact = named_by_channel(left)
        named_063, exact_063 = named_by_channel(left, pooled_material=False)
        row = {"zoo": zoo, "run": where, "case": case, "pooled_ratio": left["pooled_ratio"],
               "p": left["p_value"], "p_channel": left["channel_p_value"],
               "material": left["material"], "scope": left.get("scope"),
               "named_now": bool(left.get("named")), "named_new": named_new, "exact": exact,
               "named_063": named_063, "exact_063": exact_063}
        if case.startswith("clean"):
            row["kind"] = "clean"
            row["alarm_now"] = significant(r)
            row["alarm_new"] = significant(r) or named_new
            row["alarm_063"] = significant(r) or named_063
        elif truth is not None:
            s = score(truth, r)
            row["kind"] = "other" if truth["family"] == "other" else "vocabulary"
            row["truth"] = f"{truth['family']} @ {truth['scope']}"
            row["found_now"] = s["found"]
            row["found_new"] = s["found"] or (named_new and left.get("scope") == truth["scope"]
                                              and truth["family"] == "other")
            row["found_063"] = s["found"] or (named_063 and left.get("scope") == truth["scope"]
                                              and truth["family"] == "other")
        else:
            continue
        out.append(row)
    clean = [x for x in out if x["kind"] == "clean"]
    oth = [x for x in out if x["kind"] == "other"]
    voc = [x for x in out if x["kind"] == "vocabulary"]
    print(f"reports with an excess over the reference read: {len(out)} "
          f"(clean {len(clean)}, outside the vocabulary {len(oth)}, inside {len(voc)}); "
          f"skipped: {', '.join(sorted(skip)) or 'none'}")
    print(f"clean runs: false alarms as written {sum(x['alarm_now'] for x in clean)}, "
          f"under decision 062 {sum(x['alarm_new'] for x in clean)}, "
          f"under 062 and 063 {sum(x['alarm_063'] for x in clean)}")
    print(f"outside the vocabulary: found as written {sum(x['found_now'] for x in oth)}, "
          f"under decision 062 {sum(x['found_new'] for x in oth)}, "
          f"under 062 and 063 {sum(x['found_063'] for x in oth)}")
    print(f"inside the vocabulary: excess named as written {sum(x['named_now'] for x in voc)}, "
          f"under decision 062 {sum(x['named_new'] for x in voc)}, "
          f"under 062 and 063 {sum(x['named_063'] for x in voc)}")
    print(f"reports whose reading is an upper bound (no significant_channels kept, the "
          f"largest channel ratio standing in): under 062 {sum(not x['exact'] for x in out)}, "
          f"under 062 and 063 {sum(not x['exact_063'] for x in out)}")
    print()
    print("Clean reports with a pooled or per-channel p below 0.05:")
    print()
    print("| zoo | run | case | ratio | material | p | p per channel | named as written | 062 | "
          "062+063 |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for x in clean:
        if x["p"] < 0.05 or x["p_channel"] < 0.05:
            print(f"| {x['zoo']} | {x['run']} | {x['case']} | {x['pooled_ratio']:.2f} | "
                  f"{x['material']} | {x['p']:.2g} | {x['p_channel']:.2g} | {x['named_now']} | "
                  f"{x['named_new']} | {x['named_063']} |")
    print()
    print("Every report of an effect outside the vocabulary, and every report whose naming "
          "changes:")
    print()
    print("| zoo | run | case | truth | ratio | p | p per channel | scope | named as written | "
          "062 | 062+063 | exact | found/alarm as written | 062 | 062+063 |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for x in out:
        if not (x["named_063"] != x["named_now"] or x["kind"] == "other"):
            continue
        was, new, n63 = (("alarm_now", "alarm_new", "alarm_063") if x["kind"] == "clean"
                         else ("found_now", "found_new", "found_063"))
        print(f"| {x['zoo']} | {x['run']} | {x['case']} | {x.get('truth', 'clean')} | "
              f"{x['pooled_ratio']:.2f} | {x['p']:.2g} | {x['p_channel']:.2g} | {x['scope']} | "
              f"{x['named_now']} | {x['named_new']} | {x['named_063']} | "
              f"{x['exact'] and x['exact_063']} | {x[was]} | {x[new]} | {x[n63]} |")


if __name__ == "__main__":
    main()
