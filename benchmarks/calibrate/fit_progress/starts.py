"""The second starts' costs, Jacobian by Jacobian, against the fit they start from, read off logs.

A second start across the masses' split (module doc 14 of ``robot/twin_fit.py``) is fitted in
one stage weighted by the residual RMS of the fit it starts from, at that fit's optimum (module
doc 2). In those weights the fit's own optimum costs half the number of residuals, so each
trial step's printed cost can be read against it directly. Per run this prints, for each start,
the cost of each trial step (the log's single lines), its Jacobians, its k-step cost, whether it
converged, and how the minima's comparison ended (z, told apart or tied).

    .venv/bin/python benchmarks/calibrate/fit_progress/starts.py RUN_DIR [RUN_DIR ...]

RUN_DIR holds ``logs/calibrate.log`` and ``calibrated_twin.json`` (a blind zoo's run made with
one-stage second starts, bc8c658b or later).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fit_progress import parse_fits  # noqa: E402


def starts(run: Path) -> dict:
    report = json.loads((run / "calibrated_twin.json").read_text())["provenance"]["calibration"]
    split = report.get("split_starts") or {}
    candidates = {c["start"]: c for c in split.get("candidates", [])}
    fit_minimum = report["n_residuals"] / 2
    out = {"run": str(run), "step": split.get("step"), "chosen": split.get("chosen"),
           "tied": split.get("tied"), "fit_k_step_cost": candidates["fit"]["k_step_cost"],
           "fit_minimum_in_its_weights": fit_minimum, "starts": []}
    seen = set()
    for fit in parse_fits(run / "logs" / "calibrate.log"):
        label = fit["label"]
        if not label.startswith("split ") or label in seen:
            continue                  # a later fit under the same label is the continuation
        seen.add(label)
        evals = fit["evals"]
        c = candidates[label[len("split "):]]
        compared = c.get("compared") or {}
        out["starts"].append({
            "start": label[len("split "):],
            "trial_costs": [round(e["cost"]) for e in evals
                            if not e["batch"] and e["cost"] is not None],
            "jacobians": sum(1 for i, e in enumerate(evals)
                             if e["batch"] and (i == 0 or not evals[i - 1]["batch"])),
            "n_evals": c.get("n_evals"), "converged": c.get("converged"),
            "k_step_cost": c.get("k_step_cost"), "z": compared.get("z"),
            "told_apart": compared.get("told_apart")})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    args = ap.parse_args()
    for run in args.runs:
        r = starts(run)
        print(f"{r['run']}: step {r['step']}, kept {r['chosen']}, tied {r['tied']}; "
              f"the fit's k-step cost {r['fit_k_step_cost']:.4f}, "
              f"its optimum {r['fit_minimum_in_its_weights']:.0f} in its own weights")
        for s in r["starts"]:
            z = "kept" if s["z"] is None and s["start"] == r["chosen"] else (
                f"z {s['z']:.2f}, {'told apart' if s['told_apart'] else 'tied'}")
            print(f"  {s['start']}: k-step {s['k_step_cost']:.4f}, {s['jacobians']} Jacobians, "
                  f"{s['n_evals']} evaluations, converged {s['converged']}, {z}")
            print(f"    trial costs: {' '.join(str(c) for c in s['trial_costs'])}")


if __name__ == "__main__":
    main()
