"""CPU per timer tick of rclpy's two executors, without the model: a node with a 2 kHz timer
that publishes a JointState and an Odometry per tick (sim_node's per-step traffic, without the
step), spun until it has ticked ``--ticks`` times, by rclpy's SingleThreadedExecutor
(``spin_until_future_complete``; ``rclpy.spin`` uses the same executor) or by rclpy.experimental.EventsExecutor spun as sim_node's ``executor:
events`` spins it (``spin_once`` with a 0.1 s timeout, in a loop). Each executor runs in its own
process, alternately, ``--repeats`` times; printed and written: process CPU time per tick, ticks
per wall second, and the load average.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/executor_tick.py \\
        --out benchmarks/sim_node_20x/executor_tick
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import git_state, uptime  # noqa: E402


def child(kind: str, ticks: int, domain: int) -> None:
    import rclpy
    from nav_msgs.msg import Odometry
    from rclpy.node import Node
    from rclpy.task import Future
    from sensor_msgs.msg import JointState

    rclpy.init(domain_id=domain)
    node = Node("executor_tick")
    pub_js = node.create_publisher(JointState, "/executor_tick/js", 10)
    pub_odom = node.create_publisher(Odometry, "/executor_tick/odom", 10)
    js = JointState(name=[f"j{i}" for i in range(12)], position=[0.0] * 12, velocity=[0.0] * 12)
    odom = Odometry()
    done = Future()
    count = [0]

    def tick() -> None:
        count[0] += 1
        js.position[0] = float(count[0])
        pub_js.publish(js)
        pub_odom.publish(odom)
        if count[0] == ticks:
            done.set_result(True)

    node.create_timer(0.0005, tick)
    t0, c0 = time.perf_counter(), time.process_time()
    if kind == "events":
        from rclpy.experimental import EventsExecutor
        ex = EventsExecutor()
        ex.add_node(node)
        while not done.done():
            ex.spin_once(timeout_sec=0.1)
    else:
        from rclpy.executors import SingleThreadedExecutor
        ex = SingleThreadedExecutor()
        ex.add_node(node)
        ex.spin_until_future_complete(done)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(json.dumps({"executor": kind, "ticks": count[0], "wall_s": wall,
                      "cpu_ms_per_tick": 1e3 * cpu / count[0], "ticks_per_s": count[0] / wall}),
          flush=True)
    os._exit(0)          # the EventsExecutor's teardown is not what is measured


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--ticks", type=int, default=10000)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--domain", type=int, default=153)
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--child", default=None, help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        child(a.child, a.ticks, a.domain)
        return 0
    runs = []
    load0 = uptime()
    for _ in range(a.repeats):
        for kind in ("single", "events"):
            r = subprocess.run([sys.executable, __file__, "--child", kind, "--ticks",
                                str(a.ticks), "--domain", str(a.domain)],
                               capture_output=True, text=True, timeout=300,
                               env=dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"))
            if r.returncode != 0:
                raise SystemExit(f"{kind}: exit {r.returncode}: {r.stderr.strip()[-500:]}")
            runs.append(json.loads(r.stdout.strip().splitlines()[-1]))
            print(runs[-1], flush=True)
    load1 = uptime()

    def median(kind: str, key: str) -> float:
        v = sorted(r[key] for r in runs if r["executor"] == kind)
        return v[len(v) // 2]

    summary = {k: {"cpu_ms_per_tick_median": median(k, "cpu_ms_per_tick"),
                   "ticks_per_s_median": median(k, "ticks_per_s")} for k in ("single", "events")}
    summary["cpu_ratio_events_to_single"] = (summary["events"]["cpu_ms_per_tick_median"]
                                             / summary["single"]["cpu_ms_per_tick_median"])
    doc = {"command": "OPENBLAS_NUM_THREADS=%s .venv/bin/python %s" % (
               os.environ.get("OPENBLAS_NUM_THREADS"), " ".join(sys.argv)),
           "git": git_state(), "load_before": load0, "load_after": load1, "runs": runs,
           "summary": summary}
    print(json.dumps(summary, indent=1))
    if a.out:
        a.out.with_suffix(".json").write_text(json.dumps(doc, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
