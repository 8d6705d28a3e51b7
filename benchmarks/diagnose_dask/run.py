"""The diagnosis on a Dask cluster: wall time with 1, 2 and 4 worker processes, and the time
projected at 64 workers from the measured per-task cost.

The tasks are the physical route's re-simulations, or with ``--arg=--physics --arg=off
--arg=--rollout-route`` the learned route's rollout probes (each a cross-fit and its held-out
rollouts), counted from the report (``n_simulations`` and ``per_simulation_s`` in the JSON
then count and cost probes; ``tasks`` says which).

For each worker count N this script starts a real ``dask scheduler`` and N ``dask worker
--nthreads 1`` processes on this machine (the CLI pair a cluster runs), runs ``littledog-mlsim
diagnose --scheduler`` on a dataset, checks that its report equals the local run's (wall times
aside), and records the wall time and the number of re-simulations. The times are fitted as
``T(N) = a + b / N`` (a: the part that does not fan out, the report model's fit and scoring and
the driver; b: the re-simulations' work); the projection at 64 workers is ``a + b / 64``, which
assumes the re-simulations keep fanning out as measured up to N = 4 (on this 2-core machine, N
= 4 oversubscribes, so b is read from N = 1 and 2 if N = 4 is slower than N = 2).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose_dask/run.py \\
        --data DATASET --out benchmarks/diagnose_dask/result [--workers 1,2,4] [--arg=--twin ...]
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import git_state  # noqa: E402

PY = sys.executable
BIN = Path(PY).parent


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _untimed(x):
    if isinstance(x, dict):
        return {k: _untimed(v) for k, v in x.items()
                if not (k.endswith("seconds") or k.endswith("_wall_s") or k in ("model", "data"))}
    if isinstance(x, list):
        return [_untimed(v) for v in x]
    return x


def _diagnose(data: str, out: Path, extra: list[str]) -> float:
    cmd = [PY, "-m", "littledog_mlsim.cli", "diagnose", "--data", data, "--out", str(out),
           "--no-figures", "--quiet"] + extra
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"diagnose failed: {r.stderr.strip().splitlines()[-1:]}")
    return time.perf_counter() - t0


def _tasks(report: dict) -> tuple[int, str]:
    """How many tasks the cluster ran for this report, and what they were."""
    if "physics" in report:
        return report["physics"]["n_simulations"], "re-simulations"
    rr = report.get("rollout_route") or {}
    n = sum(len(r["probes"]) for r in rr.get("rounds", []))
    n += sum(len(e.get("scan", [])) - 1 for e in rr.get("effects", []))
    return n, "rollout probes"


def _with_cluster(n: int, fn):
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    procs = [subprocess.Popen([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port",
                               str(port), "--no-dashboard"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(n):
            procs.append(subprocess.Popen([str(BIN / "dask"), "worker", addr, "--nthreads", "1",
                                           "--nworkers", "1", "--no-dashboard"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client
        with Client(addr, timeout="30s", set_as_default=False) as c:
            c.wait_for_workers(n, timeout=120)
        return fn(addr)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(30)
            except subprocess.TimeoutExpired:
                p.kill()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--workers", default="1,2,4")
    ap.add_argument("--arg", action="append", default=[], help="extra diagnose argument")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="diagnose_dask_"))
    rows = []
    try:
        t_local = _diagnose(a.data, work / "local", a.arg + ["--jobs", "1"])
        local = json.loads((work / "local" / "report.json").read_text())
        n_sims, what = _tasks(local)
        rows.append({"workers": "local, 1 process", "wall_s": t_local, "same_as_local": True,
                     "load_average": os.getloadavg()})
        for n in [int(x) for x in a.workers.split(",")]:
            def run(addr, n=n):
                t = _diagnose(a.data, work / f"dask{n}", a.arg + ["--scheduler", addr])
                rep = json.loads((work / f"dask{n}" / "report.json").read_text())
                return t, _untimed(rep) == _untimed(local)
            t, same = _with_cluster(n, run)
            rows.append({"workers": n, "wall_s": t, "same_as_local": same,
                         "load_average": os.getloadavg()})
            print(f"{n} workers: {t:.1f} s, same as local: {same}", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    pts = [(r["workers"], r["wall_s"]) for r in rows if isinstance(r["workers"], int)]
    fit = [p for p in pts if p[0] <= 2] if (len(pts) > 2 and pts[2][1] > pts[1][1]) else pts
    import numpy as np
    A = np.array([[1.0, 1.0 / n] for n, _ in fit])
    (a0, b0), *_ = np.linalg.lstsq(A, np.array([t for _, t in fit]), rcond=None)
    doc = {"command": "OPENBLAS_NUM_THREADS=%s %s %s" % (os.environ.get("OPENBLAS_NUM_THREADS"),
                                                       ".venv/bin/python", " ".join(sys.argv)),
           "code": git_state(), "cpus": os.cpu_count(), "n_simulations": n_sims, "tasks": what,
           "rows": rows, "fit": {"points": fit, "a_s": a0, "b_s": b0,
                                 "per_simulation_s": b0 / n_sims if n_sims else None},
           "projected_64_workers_s": a0 + b0 / 64}
    (out / "result.json").write_text(json.dumps(doc, indent=1, default=str) + "\n")
    lines = ["| workers | wall [s] | report = local | load average |", "|---|---|---|---|"]
    lines += [f"| {r['workers']} | {r['wall_s']:.1f} | {'yes' if r['same_as_local'] else 'NO'} "
              f"| {', '.join(f'{x:.1f}' for x in r['load_average'])} |" for r in rows]
    lines += ["", f"Fit T(N) = a + b/N over {[p[0] for p in fit]}: a = {a0:.1f} s, b = {b0:.1f} s "
              f"({n_sims} {what}, {b0 / max(n_sims, 1) * 1000:.1f} ms each of worker "
              f"time); projected at 64 workers: {a0 + b0 / 64:.1f} s."]
    (out / "result.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
