"""The controller pattern that hung ``make test``, against the package's ``Spinner``.

One iteration, as ``test/nodes/test_nodes.py``'s gated test did it: ``sim_node`` (lockstep) in a
child process; this process's controller node subscribes to its state, sends 20 commands one
after the other, then closes its node and stops ``sim_node`` with SIGINT, waiting for it with a
15 s timeout. Two ways to hold the controller's executor:

- ``naive``: ``executor.spin()`` on a daemon thread; the node is removed from the executor and
  destroyed from the main thread while the executor thread waits on it.
- ``spinner``: :class:`littledog_mlsim.nodes.spinner.Spinner` (bounded waits; the node is
  destroyed on the spin thread between two waits, and ``destroy`` returns when that is done).

A stuck iteration cannot be timed from inside (its main thread never gets the GIL back), so each
pattern runs in a child process of this script; the parent watches the child's progress lines
and, when none comes for ``--stall`` s, dumps every thread's native stack with ``py-spy`` (if it
is on PATH) and kills the child, counts a hang, and starts a fresh child for the iterations left.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/spin_thread_hang/spin_thread_hang.py \\
        --iterations 200 --hogs 2 --out benchmarks/spin_thread_hang/result.json

``--hogs K`` adds K busy-loop processes for the run (the hang needs a loaded machine).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
N_STEPS = 20
STOP_TIMEOUT_S = 15.0


# ---------------------------------------------------------------------------------------------
# the child: iterations of one pattern


def _model(work: Path) -> Path:
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import features_responses, load_moves
    from littledog_mlsim.models.lr import LinearRegression
    from littledog_mlsim.models.onestep import OneStepModel

    path = work / "lr_model"
    if not path.exists():
        data = work / "data"
        if not data.exists():
            record_dataset(data, moves_per_type=2, types=["F"], jobs=1, progress=False)
        X, Y, _ = features_responses(load_moves(data, split="train"))
        OneStepModel.fit(LinearRegression(), X, Y).save(path)
    return path


class Naive:
    """The old test harness: spin() on a daemon thread, destroy from the caller's thread."""

    def __init__(self, domain: int) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.thread = threading.Thread(target=self._spin, daemon=True, name="naive-spin")
        self.thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # noqa: BLE001  (shutdown)
            pass

    def node(self, name: str):
        from rclpy.node import Node

        n = Node(name, context=self.context)
        self.executor.add_node(n)
        return n

    def destroy(self, node) -> None:
        self.executor.remove_node(node)
        node.destroy_node()


def _spinner(domain: int):
    from littledog_mlsim.nodes.spinner import Spinner

    return Spinner(domain, name="spinner-spin")


def _iteration(ros, i: int, model: Path, work: Path, env: dict) -> str:
    from sensor_msgs.msg import JointState
    from diagnostic_msgs.msg import DiagnosticStatus
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    from littledog_mlsim.layout import CONTROL_DT_NS, HOME_POSE, JOINT_NAMES
    from littledog_mlsim.nodes import messages as m
    from littledog_mlsim.nodes.simulator import QOS

    exe = Path(sys.executable).parent / "sim_node"
    with open(work / "sim_node.err", "w") as err:
        proc = subprocess.Popen([str(exe), "--ros-args", "-p", f"model_path:={model}",
                                 "-p", "step_mode:=lockstep", "-p", "stats_period:=0.2"],
                                stdout=subprocess.DEVNULL, stderr=err, env=env)
    cond = threading.Condition()
    states: set[int] = set()
    heard = [0]

    def on_state(msg) -> None:
        with cond:
            states.add(m.stamp_ns(msg.header.stamp))
            cond.notify_all()

    def on_stats(msg) -> None:
        with cond:
            heard[0] = int(m.status_values(msg).get("cmd_publishers", 0))
            cond.notify_all()

    node = ros.node(f"controller_{i}_{os.getpid()}")
    node.create_subscription(JointState, "/sim_node/state", on_state, QOS)
    node.create_subscription(DiagnosticStatus, "/sim_node/stats", on_stats, QOS)
    pub = node.create_publisher(JointState, "/littledog/cmd", QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE))
    outcome = "ok"
    with cond:
        if not cond.wait_for(lambda: heard[0] >= 1 and pub.get_subscription_count() >= 1,
                             STOP_TIMEOUT_S):
            outcome = "no discovery"
    for k in range(N_STEPS if outcome == "ok" else 0):
        msg = JointState(name=list(JOINT_NAMES), position=[float(x) for x in HOME_POSE])
        pub.publish(msg)
        with cond:
            if not cond.wait_for(lambda k=k: (k + 1) * CONTROL_DT_NS in states, STOP_TIMEOUT_S):
                outcome = f"no state {k + 1}"
                break
    ros.destroy(node)                      # the pattern under study
    proc.send_signal(signal.SIGINT)        # ... and the simulator leaves right after
    try:
        proc.wait(STOP_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        outcome = "sim_node ignored SIGINT"
    return outcome


def child(args: argparse.Namespace) -> int:
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    domain = int(args.domain)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               PYTHONUNBUFFERED="1")
    os.environ.update(ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    model = _model(work)
    ros = Naive(domain) if args.pattern == "naive" else _spinner(domain)
    print("ready", flush=True)
    for i in range(args.first, args.first + args.iterations):
        t0 = time.monotonic()
        outcome = _iteration(ros, i, model, work, env)
        print(json.dumps({"i": i, "outcome": outcome, "s": round(time.monotonic() - t0, 2)}),
              flush=True)
    return 0


# ---------------------------------------------------------------------------------------------
# the parent: a child per pattern, watched for stalls


def _run_pattern(pattern: str, args: argparse.Namespace, log) -> dict:
    done, hangs, outcomes, dumps = 0, [], {}, []
    domain = 150 + os.getpid() % 50
    while done < args.iterations:
        cmd = [sys.executable, __file__, "--child", "--pattern", pattern, "--work", args.work,
               "--domain", str(domain), "--first", str(done),
               "--iterations", str(args.iterations - done)]
        p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        lines: list[str] = []
        reader = threading.Thread(target=lambda: [lines.append(x) for x in p.stdout], daemon=True)
        reader.start()
        seen, last = 0, time.monotonic()
        while p.poll() is None:
            time.sleep(1.0)
            if len(lines) != seen:
                seen, last = len(lines), time.monotonic()
            elif time.monotonic() - last > args.stall:
                hangs.append(done + max(0, seen - 1))
                dumps.append(_dump(p.pid, pattern, len(hangs)))
                p.kill()
                break
        p.wait()
        reader.join(5)
        for x in lines:
            if x.startswith("{"):
                r = json.loads(x)
                outcomes[r["outcome"]] = outcomes.get(r["outcome"], 0) + 1
                done = r["i"] + 1
        if hangs and hangs[-1] >= done:
            done = hangs[-1] + 1          # the stuck iteration counts as run
        log(f"{pattern}: {done}/{args.iterations} iterations, {len(hangs)} hangs")
    return {"iterations": args.iterations, "hangs": len(hangs), "hang_at": hangs,
            "outcomes": outcomes, "dumps": dumps}


def _dump(pid: int, pattern: str, n: int) -> str | None:
    spy = shutil.which("py-spy") or str(Path(sys.executable).parent / "py-spy")
    if not Path(spy).exists():
        return None
    out = HERE / f"dump_{pattern}_{n}.txt"
    with open(out, "w") as f:
        subprocess.run([spy, "dump", "--native", "--pid", str(pid)], stdout=f,
                       stderr=subprocess.STDOUT, timeout=60)
    return out.name


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--pattern", default="naive,spinner",
                    help="comma-separated patterns: naive, spinner (default both)")
    ap.add_argument("--iterations", type=int, default=200)
    ap.add_argument("--first", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--domain", default="0", help=argparse.SUPPRESS)
    ap.add_argument("--work", default="/tmp/spin_thread_hang")
    ap.add_argument("--stall", type=float, default=60.0,
                    help="s without a finished iteration that count as a hang (default 60)")
    ap.add_argument("--hogs", type=int, default=0, help="busy-loop processes beside the run")
    ap.add_argument("--out", default=None, help="result JSON (default: print only)")
    args = ap.parse_args()
    if args.child:
        return child(args)
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
            for _ in range(args.hogs)]
    t0 = time.time()
    try:
        result = {p: _run_pattern(p, args, print) for p in args.pattern.split(",")}
    finally:
        for h in hogs:
            h.kill()
            h.wait()
    result["_run"] = {"command": " ".join([Path(sys.executable).name] + sys.argv),
                      "hogs": args.hogs, "stall_s": args.stall, "cpus": os.cpu_count(),
                      "loadavg_at_end": os.getloadavg(), "wall_s": round(time.time() - t0)}
    print(json.dumps(result, indent=1))
    if args.out:
        Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
