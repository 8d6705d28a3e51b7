"""The middleware's floor under sim_node's lockstep: the same round trip with no step at all.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/echo_floor.py \
        --model MODEL --data DATA --out benchmarks/sim_node_20x/echo_floor

Lockstep (``run.py --phases lockstep``) measures command -> sim_node -> joint state -> next
command. Its round trip holds the learned step and everything around it: the controller's
publish, DDS, sim_node's executor and receive path, its publish, DDS back, the controller's
executor. This script runs the same controller (``sim_node_10x/run.py``'s) against an **echo
node**: a process that receives the command as sim_node does (``JointState`` on
``/littledog/cmd``, the same QoS, the executor named by ``--executor``) and publishes one
preallocated ``JointState`` on ``/littledog/joint_states`` at once, with no model, no step and
no message filling. Then, in the same run and with the same controller process, sim_node's
lockstep itself (skipped without ``--model``). Alternating them ``--rounds`` times lets the
machine's state at the time act on both alike.

The echo's round trip is what no change to the learned step can remove: the lockstep target
of issue 27 (1,500 steps/s, a round trip of 0.667 ms) needs echo + step + sim_node's own message
work below it.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT))
from benchmarks._common import git_state, uptime  # noqa: E402


def serve(executor: str) -> int:
    """The echo node: one JointState back for every command, until SIGINT."""
    import rclpy
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from littledog_mlsim.layout import JOINT_NAMES

    rclpy.init(args=[])
    node = rclpy.create_node("echo_floor")
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                     reliability=ReliabilityPolicy.RELIABLE)
    pub = node.create_publisher(JointState, "/littledog/joint_states", qos)
    out = JointState()
    out.name = list(JOINT_NAMES)
    out.position = [0.0] * len(JOINT_NAMES)
    out.velocity = [0.0] * len(JOINT_NAMES)
    out.effort = [0.0] * len(JOINT_NAMES)
    node.create_subscription(JointState, "/littledog/cmd", lambda msg: pub.publish(out), qos)
    stop = [False]
    signal.signal(signal.SIGINT, lambda *_: stop.__setitem__(0, True))
    if executor == "events":
        from rclpy.experimental import EventsExecutor
        ex = EventsExecutor(context=node.context)
    else:
        from rclpy.executors import SingleThreadedExecutor
        ex = SingleThreadedExecutor(context=node.context)
    ex.add_node(node)
    try:
        while not stop[0]:
            ex.spin_once(timeout_sec=0.1)
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def run_echo(a, ten, ctl, cmds: np.ndarray) -> dict:
    """sim_node_10x's lockstep loop against the echo node."""
    proc = subprocess.Popen([sys.executable, __file__, "--serve", "--executor", a.executor],
                            env=dict(os.environ, PYTHONPATH=str(ROOT)),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    load0 = uptime()
    try:
        t0, t_end = ten.drive_lockstep(a, ctl, cmds)
    finally:
        err = ten.stop_node(proc)
    return {**ten.lockstep_rate(a, ctl, t0, t_end), "load_before": load0,
            "load_after": uptime(),
            "errors": [ln for ln in err.splitlines() if "rror" in ln][:5]}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--executor", choices=("single", "events"), default="events",
                   help="the echo's and sim_node's executor (default events)")
    p.add_argument("--model", default=None, help="a trained model: also sim_node's lockstep")
    p.add_argument("--data", default=None,
                   help="a dataset: the commands are its first TestPool F move's (as run.py's "
                        "lockstep); default: small random moves around the home pose")
    p.add_argument("--radius", type=float, default=None)
    p.add_argument("--rounds", type=int, default=3, help="echo / sim_node alternations")
    p.add_argument("--lockstep-duration", type=float, default=20.0)
    p.add_argument("--warmup", type=float, default=2.0)
    p.add_argument("--out", default=None, help="write OUT.json and OUT.md")
    a = p.parse_args(argv)
    if a.serve:
        return serve(a.executor)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_DOMAIN_ID", str(60 + os.getpid() % 40))
    import importlib.util
    spec = importlib.util.spec_from_file_location("sim_node_10x_run",
                                                  HERE.parent / "sim_node_10x" / "run.py")
    ten = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ten)
    a.node_param = None
    if a.data:
        from littledog_mlsim.data.dataset import load_moves
        cmds = np.asarray(load_moves(a.data, split="test", types=["F"])[0].cmd)
    else:
        from littledog_mlsim.layout import HOME_POSE
        rng = np.random.default_rng(0)
        cmds = np.asarray(HOME_POSE, float)[None, :] + 0.01 * rng.standard_normal((400, 12))
    ctl = ten.Controller()
    rounds = []
    try:
        for i in range(a.rounds):
            r = {"echo": run_echo(a, ten, ctl, cmds)}
            print(f"round {i + 1}: echo {r['echo']['steps_per_s']:.0f} steps/s, round trip p50 "
                  f"{r['echo']['round_trip_ms']['p50']:.3f} ms", flush=True)
            if a.model:
                r["sim_node"] = ten.run_lockstep(a, ctl, cmds)
                print(f"round {i + 1}: sim_node {r['sim_node']['steps_per_s']:.0f} steps/s, "
                      f"round trip p50 {r['sim_node']['round_trip_ms']['p50']:.3f} ms",
                      flush=True)
            rounds.append(r)
    finally:
        ctl.close()
    doc = {"command": " ".join([Path(sys.argv[0]).as_posix()] + sys.argv[1:]),
           "git": git_state(),
           "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()), "executor": a.executor,
           "rounds": rounds}
    if a.out:
        Path(a.out + ".json").write_text(json.dumps(doc, indent=1) + "\n")
        Path(a.out + ".md").write_text("\n".join(markdown(doc)) + "\n")
    return 0


def markdown(doc: dict) -> list[str]:
    lines = ["# The lockstep round trip with no step (echo) and with sim_node", "",
             f"Command: `OPENBLAS_NUM_THREADS=1 .venv/bin/python {doc['command']}`  ",
             f"Code: {doc['git']}; date {doc['date']} UTC; executor {doc['executor']}", "",
             "| round | echo steps/s | echo round trip p50 / p99 [ms] | sim_node steps/s | "
             "sim_node round trip p50 / p99 [ms] | load (1 min) before, after |",
             "|---|---|---|---|---|---|"]
    for i, r in enumerate(doc["rounds"], 1):
        e, s = r["echo"], r.get("sim_node")
        loads = [x["load_before"].split("load average:")[-1].split(",")[0].strip()
                 for x in (e, s) if x] + [(s or e)["load_after"].split("load average:")[-1]
                                          .split(",")[0].strip()]
        lines.append(
            f"| {i} | {e['steps_per_s']:.0f} | {e['round_trip_ms']['p50']:.3f} / "
            f"{e['round_trip_ms']['p99']:.3f} | "
            + (f"{s['steps_per_s']:.0f} | {s['round_trip_ms']['p50']:.3f} / "
               f"{s['round_trip_ms']['p99']:.3f}" if s else "- | -")
            + f" | {', '.join(loads)} |")
    return lines


if __name__ == "__main__":
    sys.exit(main())
