"""What the physical route's excess over the reference would name if the per-channel test
counted as the pooled one does (decision 047 names it only where the pooled test is significant).

Reads every committed report of the blind zoos whose ``physics.reference.unexplained`` is read
(``named``: decision 047 onwards; the arms with a twin and a reference), except the zoos given
in ``--skip``, and each zoo's
``truth.yaml``. For each report: whether the excess is named today; whether it would be under
"pooled or per-channel significant, and material" (the per-channel test is already the
smallest p of the 36 channels times 36); the clean runs that would then raise a false alarm;
the effects outside the vocabulary that would then be found at their scope.

    .venv/bin/python benchmarks/blind_zoo/left_by_channel/tally.py --skip zoo63 > OUT
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1] / "zoos"
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "harness"))
from run import score, significant  # noqa: E402


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
    ap.add_argument("--skip", default="", help="zoos not read, comma-separated")
    a = ap.parse_args()
    skip = {s for s in a.skip.split(",") if s}
    out = []
    for zoo, where, case, truth, r, left in rows(skip):
        comparable = left.get("comparable", True) or left.get("concentrated", False)
        by_channel = bool(left["channel_significant"] and left["material"] and comparable)
        named_now = bool(left.get("named"))
        named_new = named_now or by_channel
        row = {"zoo": zoo, "run": where, "case": case, "pooled_ratio": left["pooled_ratio"],
               "p": left["p_value"], "p_channel": left["channel_p_value"],
               "material": left["material"], "scope": left.get("scope"),
               "named_now": named_now, "named_new": named_new,
               "significant_now": significant(r)}
        if case.startswith("clean"):
            row["kind"] = "clean"
            row["false_alarm_now"] = significant(r)
            row["false_alarm_new"] = significant(r) or named_new
        elif truth is not None:
            s = score(truth, r)
            row["kind"] = "other" if truth["family"] == "other" else "vocabulary"
            row["truth"] = f"{truth['family']} @ {truth['scope']}"
            row["found_now"] = s["found"]
            row["found_new"] = s["found"] or (named_new and left.get("scope") == truth["scope"]
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
    print(f"clean runs: false alarms now {sum(x['false_alarm_now'] for x in clean)}, "
          f"with the per-channel test {sum(x['false_alarm_new'] for x in clean)}")
    print(f"outside the vocabulary: found now {sum(x['found_now'] for x in oth)}, "
          f"with the per-channel test {sum(x['found_new'] for x in oth)}")
    print(f"inside the vocabulary: excess named now {sum(x['named_now'] for x in voc)}, "
          f"with the per-channel test {sum(x['named_new'] for x in voc)}")
    print()
    print("Clean runs whose excess is significant by either test, or per channel p < 0.05:")
    print()
    print("| zoo | run | case | ratio | material | p | p per channel | named now | new |")
    print("|---|---|---|---|---|---|---|---|---|")
    for x in clean:
        if x["p"] < 0.05 or x["p_channel"] < 0.05:
            print(f"| {x['zoo']} | {x['run']} | {x['case']} | {x['pooled_ratio']:.2f} | "
                  f"{x['material']} | {x['p']:.2g} | {x['p_channel']:.2g} | {x['named_now']} | "
                  f"{x['named_new']} |")
    print()
    print("Every report of an effect outside the vocabulary, and every report whose naming changes:")
    print()
    print("| zoo | run | case | truth | ratio | p | p per channel | scope | named now | new | found/alarm now | new |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for x in out:
        if not (x["named_new"] != x["named_now"] or x["kind"] == "other"):
            continue
        fa = ("false_alarm_now", "false_alarm_new") if x["kind"] == "clean" else (
            ("found_now", "found_new") if "found_now" in x else (None, None))
        print(f"| {x['zoo']} | {x['run']} | {x['case']} | {x.get('truth', 'clean')} | "
              f"{x['pooled_ratio']:.2f} | {x['p']:.2g} | {x['p_channel']:.2g} | {x['scope']} | "
              f"{x['named_now']} | {x['named_new']} | "
              f"{x.get(fa[0]) if fa[0] else ''} | {x.get(fa[1]) if fa[1] else ''} |")


if __name__ == "__main__":
    main()
