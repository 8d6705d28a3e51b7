"""CPU the live view costs: the view process's share of one core, nobody watching and drawing
for one websocket client, with sim_node at 100 Hz as the source; A/B between two source trees.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/viewer/viewer_cpu.py \
        --model bags/default_lr --rounds 3 --trees .,/path/to/other/checkout \
        --out benchmarks/viewer

For each round and each tree (``--trees``, comma-separated; the tree's code is what
``littledog-mlsim view`` runs: PYTHONPATH and working directory), one sim_node (this
repository's, timer mode, no commands) runs in its own ROS domain and
``littledog-mlsim view --live sim=DOMAIN --no-plots`` is launched on it. After the view has
received states (``--settle`` s), the view process's CPU time (utime + stime from
/proc/PID/stat) is read over two windows of ``--seconds`` s each:

1. nobody watching (subscriptions only; the view draws only for a page);
2. one websocket client connected (``bench_viewer.wire_frames``: speaks viser's protocol like
   the page, in this process, so its decoding is not counted); also the distinct robot frames
   per second the client received.

CPU share = CPU seconds / wall seconds (1.0 = one core). sim_node's own share over the same
windows is recorded too. The load average is recorded beside every number.

``--startups N``: also N start-ups per tree, the trees alternating (so both see the same load):
wall time from launching ``littledog-mlsim view`` to the page served (HTTP 200 on /) and to
its "ready" line, for ``--live sim=DOMAIN``, for ``--bag BAG`` and for the replay of
``--startup-replay`` (``bench_viewer.startup``'s measure, with the tree's code).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))

from bench_viewer import (free_port, save, startup_cells, stop, wait_http,  # noqa: E402
                          wire_frames)

PY = sys.executable
TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK     # utime, stime


def env(domain: int, tree: Path) -> dict[str, str]:
    return dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1", PYTHONUNBUFFERED="1")


def window(pids: dict[str, int], seconds: float, during=None) -> dict:
    c0 = {k: cpu_seconds(p) for k, p in pids.items()}
    load0, t0 = os.getloadavg()[0], time.perf_counter()
    extra = during(seconds) if during is not None else time.sleep(seconds)
    wall = time.perf_counter() - t0
    out = {f"{k}_cpu_share": (cpu_seconds(p) - c0[k]) / wall for k, p in pids.items()}
    out.update(wall_s=wall, load_min=min(load0, os.getloadavg()[0]),
               load_max=max(load0, os.getloadavg()[0]))
    if extra:
        out.update(extra)
    return out


def one(tree: Path, model: str, domain: int, seconds: float, settle: float) -> dict:
    tmp = Path(tempfile.mkdtemp(prefix="viewer_cpu_"))
    sim = subprocess.Popen([PY, "-m", "littledog_mlsim.nodes.sim_node", "--ros-args", "-p",
                            f"model_path:={model}", "-p", "stats_period:=0.0"],
                           env=env(domain, ROOT), cwd=ROOT, stdout=subprocess.DEVNULL,
                           stderr=open(tmp / "sim.err", "w"))
    view = None
    try:
        port = free_port()
        view = subprocess.Popen([PY, "-m", "littledog_mlsim.cli", "view", "--live",
                                 f"sim={domain}", "--port", str(port), "--no-plots"],
                                env=env(domain, tree), cwd=tree, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
        url = f"http://127.0.0.1:{port}"
        wait_http(url)
        ready = threading.Event()

        def read() -> None:
            for line in view.stdout:
                if "ready in" in line:
                    ready.set()

        threading.Thread(target=read, daemon=True).start()
        if not ready.wait(60):
            raise RuntimeError("the view printed no ready line within 60 s")
        time.sleep(settle)          # discovery, then states flowing
        pids = {"view": view.pid, "sim_node": sim.pid}
        idle = window(pids, seconds)
        client = window(pids, seconds, lambda s: wire_frames(url, s))
    finally:
        if view is not None:
            stop(view)
        stop(sim)
    return {"tree": str(tree), "nobody_watching": idle, "one_client": client}


def startup(tree: Path, argv: list[str], domain: int) -> dict:
    port = free_port()
    t0 = time.perf_counter()
    p = subprocess.Popen([PY, "-m", "littledog_mlsim.cli", "view", *argv, "--port", str(port)],
                         env=env(domain, tree), cwd=tree, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    try:
        served = wait_http(f"http://127.0.0.1:{port}") - t0
        ready = None
        for line in p.stdout:
            if "ready in" in line:
                ready = time.perf_counter() - t0
                break
    finally:
        stop(p)
    mode = argv[0].lstrip("-") if argv[0] in ("--live", "--bag") else "replay " + " ".join(argv)
    return {"tree": str(tree), "mode": mode, "served_s": served,
            "ready_line_s": ready, "load": os.getloadavg()[0]}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", required=True)
    ap.add_argument("--trees", default=".", help="comma-separated source trees to compare")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--settle", type=float, default=5.0)
    ap.add_argument("--domain", type=int, default=176)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/viewer"))
    ap.add_argument("--name", default="viewer_cpu")
    ap.add_argument("--startups", type=int, default=0, help="start-ups per tree and mode")
    ap.add_argument("--bag", default=None, help="bag of the replay start-ups")
    ap.add_argument("--startup-replay", default=None, metavar="ARGS",
                    help="also time this replay's start-ups (view arguments in one string)")
    a = ap.parse_args()
    trees = [Path(t).resolve() for t in a.trees.split(",")]
    runs = []
    for r in range(a.rounds):
        for tree in trees:
            res = one(tree, a.model, a.domain, a.seconds, a.settle)
            res["round"] = r
            print(json.dumps(res), flush=True)
            runs.append(res)
    starts = []
    for _ in range(a.startups):
        for tree in trees:
            modes = [["--live", f"sim={a.domain}"], ["--bag", a.bag]]
            if a.startup_replay:
                modes.append(a.startup_replay.split())
            for argv in modes:
                if argv[1] is None:
                    continue
                res = startup(tree, argv, a.domain)
                print(json.dumps(res), flush=True)
                starts.append(res)
    return save(a.out, a.name, runs, starts, report)


def report(doc: dict) -> str:
    L = ["# Viewer CPU", "", f"{doc['date']}, made by:", "", f"    {doc['command']}", "",
         "CPU share of one core (CPU s / wall s) of the view process and of sim_node.", "",
         "| round | tree | view, nobody watching | view, one client | client frames/s | "
         "sim_node (nobody / client) | load avg |", "|---|---|---|---|---|---|---|"]
    for r in doc["runs"]:
        i, c = r["nobody_watching"], r["one_client"]
        L.append(f"| {r['round']} | {r['tree']} | {i['view_cpu_share']:.3f} | "
                 f"{c['view_cpu_share']:.3f} | {c.get('client_frames_per_s', 0):.1f} | "
                 f"{i['sim_node_cpu_share']:.3f} / {c['sim_node_cpu_share']:.3f} | "
                 f"{min(i['load_min'], c['load_min']):.1f}-"
                 f"{max(i['load_max'], c['load_max']):.1f} |")
    if doc.get("startup"):
        import numpy as np

        L += ["", "## Start-up (launch to page served; launch to the \"ready\" line), trees "
              "alternating", "", "| tree | mode | served s (runs) | median | ready line s "
              "(median) | load avg |", "|---|---|---|---|---|---|"]
        for tree in dict.fromkeys(x["tree"] for x in doc["startup"]):
            for mode in dict.fromkeys(x["mode"] for x in doc["startup"]):
                rs = [x for x in doc["startup"] if x["tree"] == tree and x["mode"] == mode]
                L.append(f"| {tree} | {mode} | {startup_cells(rs)} |")
    return "\n".join(L) + "\n"


if __name__ == "__main__":
    sys.exit(main())
