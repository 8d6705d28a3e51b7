"""Decision 031 on read zoos: a reference recorded under another command excitation.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/excitation_mismatch/run.py \\
        --zoo zoo18=WORK18 --out OUT --table benchmarks/learned_route/excitation_mismatch/zoo18

WORKnn holds a blind zoo's recordings as the harness writes them (``reference``,
``effects/zNN``, ``clean/sNNN_eE``). Every recording whose ``dataset.yaml`` names a command
excitation other than the reference's is diagnosed as the harness's ``learned+reference`` arm
does (``diagnose --no-figures --jobs 2 --physics off --rollout-route --reference
WORKnn/reference``, into OUT/<zoo>_<name>, skipped where its report.json exists), and scored
with the harness's own ``significant`` and ``score`` against the zoo's ``truth.yaml`` (these
zoos' truth has been read). The table gives beside it the zoo's blind run1 (its committed
``results.json``); seconds are each report's own. Writes TABLE.md and TABLE.json (appending
rows where TABLE.json exists).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks"), str(ROOT / "benchmarks/blind_zoo/harness")]

import yaml  # noqa: E402
from _common import appended_study, study_commands  # noqa: E402
from run import named_effects, score, significant  # noqa: E402  (the harness's)

ZOOS = ROOT / "benchmarks" / "blind_zoo" / "zoos"


def excitation(dataset: Path) -> float:
    info = yaml.safe_load((dataset / "dataset.yaml").read_text())["info"]
    return float(info.get("command_excitation_rad") or 0.0)


def recordings(work: Path) -> list[tuple[str, Path]]:
    """(name as the harness names it, path) of every recording under another excitation than
    the reference's."""
    ref = excitation(work / "reference")
    out = []
    for d in sorted((work / "effects").iterdir()) + sorted((work / "clean").iterdir()):
        if (d / "dataset.yaml").exists() and excitation(d) != ref:
            out.append((d.name if d.parent.name == "effects" else f"clean_{d.name}", d))
    return out


def diagnose(data: Path, out: Path, reference: Path) -> None:
    """One diagnosis, unless its report is there already."""
    if (out / "report.json").exists():
        return
    cmd = [str(ROOT / ".venv/bin/littledog-mlsim"), "diagnose", "--data", str(data), "--out",
           str(out), "--no-figures", "--jobs", "2", "--physics", "off", "--rollout-route",
           "--reference", str(reference)]
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out.with_suffix(".log"), "w") as log:
        subprocess.run(cmd, check=True, stdout=log, stderr=subprocess.STDOUT, cwd=ROOT)


def blind_run1(zoo: str) -> dict[str, dict]:
    """The zoo's blind run1 by dataset name: ``{found, named, significant}``."""
    path = ZOOS / zoo / "runs" / "run1" / "learned+reference" / "results.json"
    doc = json.loads(path.read_text())
    out = {r["id"]: {"found": r["score"]["found"],
                     "named": [f"{n['family']} @ {n['scope']}" for n in r["score"]["named"]]}
           for r in doc["rows"]}
    for c in doc["clean"]:
        out[c["name"]] = {"significant": c["significant"], "named": c["named"]}
    return out


def row(zoo: str, name: str, report: dict, truth: dict | None) -> dict:
    rr = report.get("rollout_route") or {}
    ref = rr.get("reference") or {}
    uc, rc = rr.get("unexplained_change") or {}, rr.get("reference_change") or {}
    out = {"zoo": zoo, "data": name, "seconds": report.get("seconds"),
           "truth": None if truth is None else f"{truth['family']} @ {truth['scope']}",
           "learned_inputs": None if truth is None else truth.get("learned_inputs"),
           "significant": significant(report),
           "named": [f"{n.get('family')} @ {n.get('scope')}" for n in named_effects(report)],
           "one_step_effects": [e["label"] for e in report.get("effects", [])],
           "one_step_not_comparable": [e["label"] for e in report.get("not_comparable", [])],
           "rollout_effects": [e["label"] for e in rr.get("effects", [])],
           "rollout_not_comparable": [e["label"] for e in ref.get("not_comparable", [])],
           "rollout_shared": [e["label"] for e in ref.get("shared", [])],
           "unexplained_ratio": uc.get("ratio"), "reference_change_ratio": rc.get("ratio"),
           "conditions": report.get("reference_conditions")}
    if truth is not None:
        s = score(truth, report)
        out["found"] = s["found"]
    return out


def write_md(doc: dict, path: Path) -> None:
    lines = ["# Decision 031 on read zoos: a reference recorded under another excitation", ""]
    lines += study_commands(doc)
    lines += ["", "Every recording of the zoo made under another command excitation than its "
              "reference, diagnosed as the blind harness's `learned+reference` arm does, beside "
              "the zoo's blind run1. `significant` is the harness's (either loop); a clean "
              "recording's true `significant` is a false alarm.", "",
              "| zoo | data | truth | run1: named | run1: found / alarm | now: named | now: found "
              "/ alarm | one-step not comparable | rollout not comparable | 026 ratio | 027 "
              "ratio | s |", "|---" * 12 + "|"]
    for r in doc["rows"]:
        b = r["run1"]
        was = (b.get("found") if "found" in b else b.get("significant"))
        now = r.get("found") if r["truth"] else r["significant"]
        lines.append(
            f"| {r['zoo']} | {r['data']} | {r['truth'] or 'clean'} | "
            f"{'; '.join(b['named']) if isinstance(b['named'], list) else b['named']} | {was} | "
            f"{'; '.join(r['named']) or 'nothing'} | {now} | "
            f"{', '.join(r['one_step_not_comparable']) or '-'} | "
            f"{', '.join(r['rollout_not_comparable']) or '-'} | "
            f"{'' if r['unexplained_ratio'] is None else format(r['unexplained_ratio'], '.2f')} | "
            f"{'' if r['reference_change_ratio'] is None else format(r['reference_change_ratio'], '.1f')} | "
            f"{'' if r['seconds'] is None else format(r['seconds'], '.0f')} |")
    path.with_suffix(".md").write_text("\n".join(lines) + "\n")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--zoo", action="append", required=True, metavar="ZOO=WORK",
                    help="a blind zoo's name and its recordings' directory (repeatable)")
    ap.add_argument("--out", type=Path, required=True, help="where the diagnoses go")
    ap.add_argument("--table", type=Path, required=True, help="TABLE.md/.json to write")
    a = ap.parse_args(argv)
    doc = appended_study(a.table.with_suffix(".json"))
    for spec in a.zoo:
        zoo, work = spec.split("=", 1)
        work = Path(work)
        truth_doc = yaml.safe_load((ZOOS / zoo / "truth.yaml").read_text())
        items = truth_doc["effects"] if isinstance(truth_doc, dict) else truth_doc
        truth = {e["id"]: e for e in items}
        run1 = blind_run1(zoo)
        for name, data in recordings(work):
            out = a.out / f"{zoo}_{name}"
            diagnose(data, out, work / "reference")
            report = json.loads((out / "report.json").read_text())
            r = row(zoo, name, report, truth.get(name))
            r["run1"] = run1.get(name, {"named": []})
            doc["rows"].append(r)
            print(json.dumps({k: r[k] for k in ("zoo", "data", "significant", "named")}))
    a.table.parent.mkdir(parents=True, exist_ok=True)
    a.table.with_suffix(".json").write_text(json.dumps(doc, indent=1) + "\n")
    write_md(doc, a.table)


if __name__ == "__main__":
    main()
