"""How far a budget-capped fit would have ended from where `calibrate` ended it, read off logs.

Every fit in a `calibrate` log prints each re-simulated robot as ``[n/M] name=value ...``. A
trust-region iteration re-simulates a central-difference Jacobian (2p robots, printed as one
batch: ``one of K in T s``) around the iterate, then one or more trial steps (single lines).
So the centres of the Jacobian batches are the iterates, in order, and the last centre is where
the fit ended (the final Jacobian at the optimum, or at the best point when the budget ran
out). For each fit (the structure's fit, the rounds, the split starts, the bootstrap's refits)
this prints, per Jacobian k, the largest distance over the parameters between the iterate
after k Jacobians and the end, in units of the parameter's reported sd (the final interval's
half-width over 1.96, from the twin file beside the log): what a fit capped at k Jacobians
would have left undone.

    .venv/bin/python benchmarks/calibrate/fit_progress/fit_progress.py RUN_DIR [RUN_DIR ...]

RUN_DIR holds ``logs/calibrate.log`` and ``calibrated_twin.json`` (a blind zoo's run).
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np

EVAL = re.compile(r"^  \[(\d+)/(\d+)\] (.*?)(?: cost ([-\d.e+]+))? \((.*)\)$")


def parse_fits(log: Path) -> list[dict]:
    """The fits of a log: each a label, its parameter names and its evaluations."""
    fits: list[dict] = []
    context = "fit"
    for line in log.read_text().splitlines():
        if line.startswith("a second start across"):
            context = "split " + line.split(": ")[1].split(" (")[0]
        elif line.startswith("bootstrap: the twin records"):
            context = "bootstrap"
        elif line.startswith("the residual asks for") or line.startswith("round "):
            context = "round"
        if line.startswith("fitting "):
            label = context
            if context == "bootstrap":
                n = sum(f["label"].startswith("bootstrap") for f in fits)
                label = f"bootstrap refit {n + 1}"
            fits.append({"label": label, "evals": []})
            continue
        m = EVAL.match(line)
        if m and fits:
            pairs = [kv.split("=", 1) for kv in m.group(3).split()]
            fits[-1]["evals"].append({"names": [k for k, _ in pairs],
                                      "x": np.array([float(v) for _, v in pairs]),
                                      "cost": None if m.group(4) is None else float(m.group(4)),
                                      "batch": "one of" in m.group(5)})
    return [f for f in fits if f["evals"]]


def second_stage_jacobians(evals: list[dict]) -> int:
    """Jacobians after the first trial step whose cost is more than 10 above the last one's:
    the reweighting between the stages (module doc 2) raises the cost of the same robots."""
    singles = [(i, e["cost"]) for i, e in enumerate(evals)
               if not e["batch"] and e["cost"] is not None]
    jumps = [i for (i, c), (_, c0) in zip(singles[1:], singles[:-1]) if c - c0 > 10]
    if not jumps:
        return 0
    starts = [i for i, e in enumerate(evals)
              if e["batch"] and (i == 0 or not evals[i - 1]["batch"])]
    return sum(1 for i in starts if i > jumps[0])


def centres(evals: list[dict]) -> list[np.ndarray]:
    """The centre of each Jacobian batch (the coordinate-wise median of its robots)."""
    out, batch = [], []
    for e in evals + [{"batch": False, "x": None}]:
        if e["batch"]:
            batch.append(e["x"])
            continue
        if len(batch) >= 4:
            out.append(np.median(np.array(batch), axis=0))
        batch = []
    return out


def sds(twin: Path) -> dict[str, float]:
    """Each parameter's sd from its final 95 % interval (half-width / 1.96)."""
    params = json.loads(twin.read_text())["provenance"]["parameters"]
    out = {}
    for name, p in params.items():
        lo, hi = p.get("ci95") or (None, None)
        if lo is not None and hi is not None and hi > lo:
            out[name] = (hi - lo) / (2 * 1.96)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    args = ap.parse_args(argv)
    print("| run | fit | Jacobians to the end | of them in the second stage | largest distance "
          "from the end after k Jacobians (sd), k = 1, 2, ... |")
    print("|---|---|---|---|---|")
    for run in args.runs:
        sd = sds(run / "calibrated_twin.json")
        for f in parse_fits(run / "logs" / "calibrate.log"):
            cs = centres(f["evals"])
            names = f["evals"][0]["names"]
            if len(cs) < 2:
                continue
            scale = np.array([sd.get(n, np.nan) for n in names])
            d = [float(np.nanmax(np.abs(c - cs[-1]) / scale)) for c in cs]
            print(f"| {run.parent.parent.name}/{run.name} | {f['label']} | {len(cs)} | "
                  f"{second_stage_jacobians(f['evals'])} | "
                  + " ".join(f"{v:.2f}" for v in d) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
