"""How often the gated alpha-PROJ needs its exact search when the commands do not follow the
steps one to one.

sim_node in timer mode steps on its own clock and holds the newest command; a controller that
streams commands at the asked rate while the node steps slower makes the node skip commands.
This drives sim_node's core (``run.build_backend``: the model's gate radius, covariance on,
float32 factors) with a TestPool F move's commands in a loop, first one command per step, then
skipping commands as a node at ``--node-hz`` does under a ``--cmd-hz`` stream (step k takes
command ``floor(k * cmd_hz / node_hz)``), and reports the CPU per step, the share of steps
inside the gate and the exact searches per step. The exact searches of the second run are kept
and timed again with each search method of ``NearestNeighbour`` (``"pca"``, the default here,
in compiled code and in its NumPy form, and SciPy's ``"kdtree"``), alternately ``--repeats``
times; the medians and whether all return the same indices.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/gate_share.py \\
        --model MODEL --data DATA --out benchmarks/sim_node_20x/quiet/gate_share.json
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

from benchmarks._common import command_line, run_record, uptime, write_results  # noqa: E402
from run import build_backend  # noqa: E402


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", required=True)
    p.add_argument("--data", required=True)
    p.add_argument("--steps", type=int, default=15000)
    p.add_argument("--cmd-hz", type=float, default=2000.0)
    p.add_argument("--node-hz", type=float, default=1569.0,
                   help="default: sim_node's published rate in the quiet timer run")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    from littledog_mlsim.data.dataset import load_moves
    cmds = np.asarray(load_moves(a.data, split="test", types=["F"])[0].cmd)
    model, projection, sim = build_backend(a.model, None, "float32")
    radius = float(model.gate_radius()[0])
    query = projection.nn.query
    calls = [0]
    kept: list = []

    def counted(X, method=None, upper=None):
        calls[0] += 1
        kept.append((np.array(X), None if upper is None else np.array(upper)))
        return query(X, method, upper)
    projection.nn.query = counted
    doc = run_record("sim_node_20x/gate_share.py", argv)
    rows = []
    for name, ratio in (("one command per step", 1.0),
                        (f"commands skipped ({a.cmd_hz:g} Hz stream, node at {a.node_hz:g} Hz)",
                         a.cmd_hz / a.node_hz)):
        sim.reset()
        calls[0] = 0
        kept.clear()
        dist = np.empty(a.steps)
        load = uptime()
        t0 = time.thread_time_ns()
        for k in range(a.steps):
            sim.step(cmds[int(k * ratio) % len(cmds)])
            dist[k] = sim.nn_distance
        cpu = (time.thread_time_ns() - t0) / 1e6 / a.steps
        rows.append({"commands": name, "steps": a.steps, "cpu_ms_per_step": cpu,
                     "inside_gate_share": float(np.mean(dist <= radius)),
                     "exact_searches_per_step": calls[0] / a.steps, "load": load})
    projection.nn.query = query
    projection.nn.build_tree()
    compiled = projection.nn.compiled
    # (label, method, compiled): the pca search in compiled code and in NumPy, SciPy's k-d tree
    variants = (("pca", "pca", True), ("pca_numpy", "pca", False), ("kdtree", "kdtree", True))
    times: dict = {label: [] for label, _, _ in variants}
    answers: dict = {}
    for _ in range(a.repeats):
        for label, method, comp in variants:
            projection.nn.compiled = comp
            t0 = time.thread_time_ns()
            answers[label] = [query(X, method, up if method == "pca" else None)
                              for X, up in kept]
            times[label].append((time.thread_time_ns() - t0) / 1e3 / len(kept))
    projection.nn.compiled = compiled
    search = {"queries": len(kept), "load": uptime(),
              "us_per_query_median": {m: float(np.median(v)) for m, v in times.items()},
              "same_indices": all(all(np.array_equal(x, y) for x, y in
                                      zip(answers["pca"], answers[other]))
                                  for other in ("pca_numpy", "kdtree"))}
    doc["radius"] = radius
    doc["rows"] = rows
    doc["search_methods"] = search
    lines = ["| commands | steps | CPU per step [ms] | inside the gate | exact searches per step "
             "| load |", "|---|---|---|---|---|---|"]
    lines += [f"| {r['commands']} | {r['steps']} | {r['cpu_ms_per_step']:.3f} | "
              f"{100 * r['inside_gate_share']:.1f} % | {r['exact_searches_per_step']:.3f} | "
              f"`{r['load']}` |" for r in rows]
    med = search["us_per_query_median"]
    lines += ["", f"The second run's {search['queries']} exact searches, timed again (median of "
              f"{a.repeats}, CPU per query): pca (compiled, the default) {med['pca']:.0f} us, pca "
              f"in NumPy {med['pca_numpy']:.0f} us, kdtree {med['kdtree']:.0f} us; same indices: "
              f"{search['same_indices']}. Load `{search['load']}`."]
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}; gate radius "
             f"{radius:.4f}", ""] + lines
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
