"""Decisions 041 and 042 on read zoos: the one-step loop's findings contrasted with the reference.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/one_step_contrast/one_step_contrast.py --zoo-dir WORK_zooNN \
        --truth benchmarks/blind_zoo/zoos/zooNN/truth.yaml --label zooNN --out OUT

``--zoo-dir`` is a blind zoo's harness work directory after its run: each diagnosis under
``diag_learned+reference/NAME/report.json``, with the recordings it read (the report's
``data``, and the reference its ``route.why`` names). For every effect the one-step loop
accepted there and contrasted against the reference (decision 031's ``not_comparable`` is not),
the data and the reference are screened again at the round's feature set
(:func:`littledog_mlsim.diagnose.one_step_contrast.screen_one`; the data with the length
scales of the starting feature set, as the loop reuses them) and contrasted
(``contrast_one_step``, as ``diagnose`` does since decision 041, with the rule the code has).
Each row gives the data's
and the reference's held-out gain, the p of the contrast, and whether the effect stays a
change; the truth of the dataset (an effect's, or clean) beside it. Writes OUT.md and
OUT.json (appending rows where OUT.json exists).
"""
from __future__ import annotations

import json
import os
import re
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

from _common import (appended_study, save_study, study_commands,  # noqa: E402
                     truth_with_params, zoo_effects, zoo_study_parser)

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.diagnose.families.learned import physical_reading  # noqa: E402
from littledog_mlsim.diagnose.one_step_contrast import (contrast_one_step,  # noqa: E402
                                                        screen_one)
from littledog_mlsim.diagnose.selection import SearchModel  # noqa: E402
from littledog_mlsim.models.features import FeatureSet  # noqa: E402
from littledog_mlsim.models.feature_base import augmentation_from_dict  # noqa: E402


def _search(report: dict) -> SearchModel:
    s = report["search"]
    return SearchModel(**{k: s[k] for k in ("n_random_features", "ridge", "length_scale_factor",
                                            "n_gp_points", "n_folds", "seed")})


def _reference(report: dict) -> Path:
    m = re.search(r"contrasted with the reference (\S+)$", report["route"]["why"])
    if m is None:
        raise ValueError(f"{report['data']}: the report names no reference")
    return Path(m.group(1))


def _truth(name: str, truth: dict) -> str:
    if name.startswith("clean"):
        return "clean"
    e = truth.get(name.split("_")[0])
    return "?" if e is None else truth_with_params(e)


def rows_of(report_path: Path, truth: dict, say) -> list[dict]:
    report = json.loads(report_path.read_text())
    name = report_path.parent.name
    picks = sorted(report.get("effects", []) + report.get("shared", []), key=lambda e: e["round"])
    if not picks:
        return []
    t0 = time.perf_counter()
    search = _search(report)
    data, ref_dir = Path(report["data"]), _reference(report)
    train, ref = load_moves(data, "train"), load_moves(ref_dir, "train")
    fs = FeatureSet.from_dict(report["before"]["feature_set"])
    rounds = sorted(report.get("effects", []) + report.get("shared", [])
                    + report.get("not_comparable", []), key=lambda e: e["round"])
    scales = None
    rows = []
    for e in rounds:
        aug = augmentation_from_dict({"name": e["name"], "params": e["params"]})
        if e in picks:
            on_data, ls = screen_one(train, fs, aug, search, 0.01, 0.05, scales)
            scales = ls if scales is None else scales
            on_ref, _ = screen_one(ref, fs, aug, search, 0.01, 0.05)
            c = contrast_one_step(aug, on_data.d, on_ref, len(picks))
            ph = physical_reading(aug)
            rows.append({"data": name, "truth": _truth(name, truth), "round": e["round"],
                         "label": aug.label(), "named": f"{ph['family']} @ {ph['scope']}",
                         **c.to_dict(), "seconds": round(time.perf_counter() - t0)})
            say(f"{name} {aug.label()}: gain {c.total_gain:.3f} / reference "
                f"{c.reference_total_gain:.3f}, p = {c.p_change:.2g}, excess "
                f"{c.max_excess:.3f}, changed {c.changed}")
        fs = fs.with_augmentation(aug)
    return rows


def write_md(doc: dict, path: Path) -> None:
    lines = ["# Decisions 041 and 042 on read zoos: the one-step loop's findings against the "
             "reference",
             ""] + study_commands(doc)
    lines += ["", "| zoo | data | truth | round | one-step finding (named) | gain | gain on "
              "the reference | p_change (x contrasts) | largest element excess | a change |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['round']} | "
                     f"`{r['label']}` ({r['named']}) | {r['total_gain']:.3f} | "
                     f"{r['reference_total_gain']:.3f} | {r['p_change']:.2g} "
                     f"(x{r['n_contrasts']}) | {r['max_excess']:.3f} | "
                     f"{'yes' if r['changed'] else 'no'} |")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    p = zoo_study_parser(__doc__.splitlines()[0])
    a = p.parse_args()
    truth = {e["id"]: e for e in zoo_effects(a.truth)}
    doc = appended_study(a.out.with_suffix(".json"))
    say = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    for rp in sorted((a.zoo_dir / "diag_learned+reference").glob("*/report.json")):
        for r in rows_of(rp, truth, say):
            doc["rows"].append({"zoo": a.label, **r})
        save_study(doc, a.out, write_md)
    save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
