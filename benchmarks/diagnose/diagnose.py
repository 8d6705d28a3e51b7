"""Paper-scale runs of the residual diagnosis (``benchmarks/diagnose/diagnose.md``).

Runs ``littledog_mlsim.diagnose.diagnose`` on each dataset given (full-size: 20 moves per type,
recorded with ``littledog-mlsim record --effects ...``), each into ``OUT/NAME``, and appends a
summary (effects found with family, parameters, p, outputs; TestPool nMSE of the outputs and the
mean before/after; rollout final (x, y) error before/after) to ``OUT/summary.json``, printing it
as a Markdown table. Example (the commands of diagnose.md)::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose/diagnose.py --out /tmp/diag \\
        --data clean=bags/default --data delay2=/tmp/full/delay2 --method lgpr

``--baseline paper`` starts from the paper's 45 features (to find the measured robot's own
structure); the default starts from the default model's features.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

from littledog_mlsim.diagnose import SearchModel, diagnose


def summarise(name: str, report: dict) -> dict:
    effects = []
    for e in report["effects"]:
        cuts = [v for v in e["nmse_cut"].values() if v is not None]
        effects.append({
            "family": e["family"], "label": e["label"], "params": e["params"],
            "p_value": e["p_value"], "outputs": e["outputs"],
            "max_held_out_gain": e["evidence"]["max_gain"],
            "test_nmse_cut_mean_over_outputs": sum(cuts) / len(cuts) if cuts else None,
            "test_nmse_cut_max": max(cuts) if cuts else None,
        })
    roll = {lab: {"before": report["before"]["rollout"][lab]["final_xy_error_m"],
                  "after": report["after"]["rollout"][lab]["final_xy_error_m"]}
            for lab in report["before"]["rollout"]}
    last = report["rounds"][-1]
    before, after = report["before"]["nmse"], report["after"]["nmse"]
    joints = [n for n in before if n.startswith(("q_", "dq_"))
              and before[n] is not None and after[n] is not None and before[n] > 0]
    return {"name": name,
            # TestPool one-step nMSE cut of the 24 joint elements, first model -> final model
            "joint_nmse_cut_mean": (sum(1.0 - after[n] / before[n] for n in joints) / len(joints)
                                    if joints else None), "data": report.get("data"), "significant": report["significant"],
            "effects": effects, "nmse_mean_before": report["before"]["nmse_mean"],
            "nmse_mean_after": report["after"]["nmse_mean"], "final_xy_error_m": roll,
            "last_round": {"n_significant": last["n_significant"],
                           "best": [{k: c[k] for k in ("candidate", "max_gain", "p_value")}
                                    for c in last["best"][:3]]},
            "method": report.get("method"), "baseline": report.get("baseline"),
            "seconds": report.get("seconds")}


def markdown(rows: list[dict]) -> str:
    out = ["| data | found (family: parameters, p) | outputs | TestPool nMSE cut of outputs "
           "(mean / max) | nMSE mean before -> after | final (x, y) error before -> after [m] |",
           "|---|---|---|---|---|---|"]
    for r in rows:
        if r["effects"]:
            found = "; ".join(f"{e['family']}: `{e['label']}`, p = {e['p_value']:.2g}"
                              for e in r["effects"])
            outs = "; ".join(", ".join(e["outputs"][:4]) + (" ..." if len(e["outputs"]) > 4 else "")
                             for e in r["effects"])
            cut = "; ".join(f"{100 * (e['test_nmse_cut_mean_over_outputs'] or 0):.0f} % / "
                            f"{100 * (e['test_nmse_cut_max'] or 0):.0f} %" for e in r["effects"])
        else:
            found, outs, cut = "nothing (significant: false)", "", ""
        xy = ", ".join(f"{lab} {v['before']:.3f} -> {v['after']:.3f}"
                       for lab, v in r["final_xy_error_m"].items()
                       if v["before"] is not None and v["after"] is not None)
        nm = " -> ".join("n/a" if v is None else f"{v:.4f}"
                         for v in (r["nmse_mean_before"], r["nmse_mean_after"]))
        out.append(f"| {r['name']} | {found} | {outs} | {cut} | {nm} | {xy} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", action="append", required=True, metavar="NAME=DIR")
    p.add_argument("--out", required=True, type=Path)
    p.add_argument("--method", default="lgpr")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--baseline", default="measured", choices=["measured", "paper"])
    p.add_argument("--projections", default="alpha,none")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--gp-points", type=int, default=None,
                   help="search model's GP subset (default SearchModel's; the CI tests use 300)")
    p.add_argument("--gp-max-iter", type=int, default=None,
                   help="search model's GP optimiser iterations (the CI tests use 40)")
    a = p.parse_args(argv)
    search_opts = {k: v for k, v in (("n_gp_points", a.gp_points),
                                     ("gp_max_iter", a.gp_max_iter)) if v is not None}
    options = {k: json.loads(v) for k, v in (o.split("=", 1) for o in a.option)} or None
    a.out.mkdir(parents=True, exist_ok=True)
    summary_path = a.out / "summary.json"
    rows = json.loads(summary_path.read_text()) if summary_path.exists() else []
    for item in a.data:
        name, _, d = item.partition("=")
        t0 = time.perf_counter()
        report = diagnose(d, a.out / name, baseline=a.baseline, method=a.method, options=options,
                          projections=[x for x in a.projections.split(",") if x],
                          search=SearchModel(seed=a.seed, **search_opts), seed=a.seed, progress=True)
        row = summarise(name, report)
        row["wall_s"] = time.perf_counter() - t0
        rows = [r for r in rows if r["name"] != name] + [row]
        tmp = summary_path.with_suffix(".tmp")
        tmp.write_text(json.dumps(rows, indent=1) + "\n")
        os.replace(tmp, summary_path)
        print(markdown([row]), flush=True)
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
