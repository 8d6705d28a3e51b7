"""sim_node step latency and achieved rate, with and without a 1 kHz command flood.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_latency/sim_node_latency.py \
        --model /tmp/lgpr_model --data bags/default --duration 60 \
        --md benchmarks/sim_node_latency/sim_node_latency.md --json /tmp/sim_node_latency.json

Runs ``sim_node`` (a separate process, ``latency_log`` on) against a controller in this process
that streams a TestPool move's commands (looped) at 100 Hz from a steady-clock thread, for
``--duration`` seconds after ``--warmup`` seconds, in these scenarios:

- ``timer``: step_mode timer (100 Hz steady-clock timer, zero-order hold).
- ``timer+flood``: the same plus a second process publishing valid commands at 1 kHz.
- ``lockstep``: one step per command, computed in the command's callback.
- ``lockstep+bad-flood``: lockstep plus a 1 kHz flood of rejected (NaN) commands (a flood of
  valid commands would make a lockstep node step at 1 kHz by definition).

Numbers, all from timestamps on one machine:

- rate: steps the node published per second of wall time (its own log) and joint-state
  messages received here per second;
- step: node-internal, from the start of the step (timer tick or command callback) to the last
  publish call returning (prediction, projection, pose, covariance, messages);
- cmd->state: node-internal, from the DDS receive timestamp of the command a step used to the
  end of that step's publishing. In timer mode only steps that used a fresh command count, and
  this includes waiting for the next tick (0-10 ms, the zero-order hold); in lockstep it is the
  step latency plus the executor's queueing.
- e2e (lockstep): controller publish -> joint state received back here (two DDS hops).
- step CPU: the node thread's CPU time per step (excludes waiting for a CPU), and node CPU %:
  the whole sim_node process (all threads, DDS included) over the window.

The machine is shared: the load average during each run is recorded next to the numbers.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(150 + os.getpid() % 50))

import numpy as np  # noqa: E402

BIN = Path(sys.executable).parent
SCENARIOS = ("timer", "timer+flood", "lockstep", "lockstep+bad-flood")


def flood_main(hz: float, bad: bool) -> None:
    """Child process: publish commands at ``hz`` until SIGTERM/SIGINT."""
    import rclpy
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from littledog_mlsim.layout import HOME_POSE, JOINT_NAMES

    rclpy.init(args=[])
    node = rclpy.create_node("flood")
    pub = node.create_publisher(JointState, "/littledog/cmd", QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE))
    msg = JointState()
    msg.name = list(JOINT_NAMES)
    u = HOME_POSE.copy()
    if bad:
        u[0] = np.nan
    msg.position = u.tolist()
    t, k = time.monotonic(), 0
    try:
        while rclpy.ok():
            pub.publish(msg)
            k += 1
            t += 1.0 / hz
            d = t - time.monotonic()
            if d > 0:
                time.sleep(d)
    except Exception:
        pass
    print(f"flood sent {k}", flush=True)


def process_cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process so far (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def percentiles(x: np.ndarray) -> dict[str, float]:
    if x.size == 0:
        return {"n": 0}
    return {"n": int(x.size), "p50_ms": round(float(np.percentile(x, 50)), 3),
            "p99_ms": round(float(np.percentile(x, 99)), 3),
            "max_ms": round(float(x.max()), 3)}


class Controller:
    """rclpy in a background thread: streams commands, records joint states."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState

        from littledog_mlsim.nodes import messages as m

        self.rclpy, self.JointState, self.m = rclpy, JointState, m
        rclpy.init(args=[])
        self.node = rclpy.create_node("latency_controller")
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE)
        self.pub = self.node.create_publisher(JointState, "/littledog/cmd", qos)
        self.lock = threading.Lock()
        self.received: list[tuple[int, int]] = []    # (receive ns, stamp ns)
        self.node.create_subscription(JointState, "/littledog/joint_states", self._on_js, qos)
        self.sent: list[int] = []
        self.ex = SingleThreadedExecutor()
        self.ex.add_node(self.node)
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        try:
            self.ex.spin()
        except Exception:
            pass

    def _on_js(self, msg) -> None:
        now = time.time_ns()
        with self.lock:
            self.received.append((now, self.m.stamp_ns(msg.header.stamp)))

    def wait_connected(self, timeout: float = 30.0) -> None:
        end = time.monotonic() + timeout
        while self.pub.get_subscription_count() < 1 or \
                self.node.count_publishers("/littledog/joint_states") < 1:
            if time.monotonic() > end:
                raise RuntimeError("sim_node not discovered")
            time.sleep(0.02)
        time.sleep(0.5)   # let the reverse direction (sim -> here) match as well

    def stream(self, commands: np.ndarray, seconds: float) -> None:
        from littledog_mlsim.layout import JOINT_NAMES

        msg = self.JointState()
        msg.name = list(JOINT_NAMES)
        t = time.monotonic()
        end = t + seconds
        k = 0
        while t < end:
            msg.position = commands[k % len(commands)].tolist()
            self.sent.append(time.time_ns())
            self.pub.publish(msg)
            k += 1
            t += 0.01
            d = t - time.monotonic()
            if d > 0:
                time.sleep(d)

    def close(self) -> None:
        self.node.destroy_node()
        self.rclpy.try_shutdown()
        self.thread.join(5)


def run_scenario(name: str, model: str, commands: np.ndarray, duration: float, warmup: float,
                 work: Path, sim_params: list[str]) -> dict:
    mode = "lockstep" if name.startswith("lockstep") else "timer"
    log = work / f"{name}.csv"
    err = open(work / f"{name}.err", "w")
    sim = subprocess.Popen([str(BIN / "sim_node"), "--ros-args", "-p", f"model_path:={model}",
                            "-p", f"step_mode:={mode}", "-p", f"latency_log:={log}",
                            "-p", "cmd_timeout:=0.0"]
                           + [a for kv in sim_params for a in ("-p", kv)],
                           stderr=err, stdout=err)
    ctl = Controller()
    flood = None
    load = []
    try:
        ctl.wait_connected()
        if "flood" in name:
            flood = subprocess.Popen([sys.executable, __file__, "--flood-child"]
                                     + (["--bad"] if "bad" in name else []),
                                     stdout=err, stderr=err)
        sampler_stop = threading.Event()

        def sample_load() -> None:
            while not sampler_stop.wait(5.0):
                load.append(os.getloadavg()[0])
        ctl.stream(commands, warmup)
        cpu_a, t0 = process_cpu_s(sim.pid), time.time_ns()
        threading.Thread(target=sample_load, daemon=True).start()
        ctl.stream(commands, duration)
        cpu_s, t_end = process_cpu_s(sim.pid) - cpu_a, time.time_ns()
        sampler_stop.set()
    finally:
        if flood is not None:
            flood.send_signal(signal.SIGINT)
            flood.wait(30)
        time.sleep(0.2)
        sim.send_signal(signal.SIGINT)
        rc = sim.wait(30)
        ctl.close()
        err.close()
    if rc != 0:
        raise RuntimeError(f"sim_node exited with {rc}; see {work / (name + '.err')}")
    a = np.loadtxt(log, delimiter=",", skiprows=1, dtype=np.int64, ndmin=2)
    sel = (a[:, 1] >= t0) & (a[:, 1] < t_end)
    w = a[sel]
    span = span_all = (t_end - t0) / 1e9
    step_ms = (w[:, 2] - w[:, 1]) / 1e6
    cpu_ms = w[:, 3] / 1e6
    fresh = w[:, 0] >= 0
    cmd_ms = (w[fresh, 2] - w[fresh, 0]) / 1e6
    rec = np.array(ctl.received, dtype=np.int64).reshape(-1, 2)
    rec_w = rec[(rec[:, 0] >= t0) & (rec[:, 0] < t_end)]
    out = {
        "scenario": name, "step_mode": mode, "window_s": round(span, 2),
        "rate_published_hz": round(w.shape[0] / span, 2),
        "rate_received_hz": round(rec_w.shape[0] / span, 2),
        "step": percentiles(step_ms), "step_cpu": percentiles(cpu_ms),
        "cmd_to_state": percentiles(cmd_ms),
        "process_cpu_percent": round(100 * cpu_s / span_all, 1),
        "load_average": [round(x, 2) for x in load],
    }
    if mode == "lockstep" and a.shape[0] != len(ctl.sent):
        # commands were lost on the way (queues overflowed): no step <-> command pairing
        out["e2e"] = {"n": 0, "note": f"{len(ctl.sent) - a.shape[0]} of {len(ctl.sent)} "
                                      f"commands never stepped"}
    elif mode == "lockstep":
        # step k (stamp (k+1) * 10 ms) answers the k-th command sent
        sent = np.array(ctl.sent, dtype=np.int64)
        k = rec[:, 1] // 10_000_000 - 1
        ok = (k >= 0) & (k < sent.size)
        e2e = (rec[ok, 0] - sent[k[ok]]) / 1e6
        in_win = sent[k[ok]] >= t0
        out["e2e"] = percentiles(e2e[in_win])
    err_text = (work / f"{name}.err").read_text()
    out["stats_line"] = next((ln for ln in reversed(err_text.splitlines())
                              if "skipped" in ln), "")
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--model", help="model directory (LGPR if available, else LR)")
    p.add_argument("--data", type=Path, default=Path("bags/default"),
                   help="dataset whose first TestPool F move gives the commands")
    p.add_argument("--duration", type=float, default=60.0)
    p.add_argument("--warmup", type=float, default=3.0)
    p.add_argument("--scenarios", default=",".join(SCENARIOS))
    p.add_argument("--sim-param", action="append", default=[], metavar="NAME:=VALUE",
                   help="extra sim_node parameter (repeatable), e.g. publish_covariance:=false")
    p.add_argument("--json", type=Path)
    p.add_argument("--md", type=Path)
    p.add_argument("--flood-child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--bad", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.flood_child:
        flood_main(1000.0, a.bad)
        return 0
    if not a.model:
        p.error("--model is required")

    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.models.onestep import OneStepModel

    model = OneStepModel.load(a.model)
    commands = load_moves(a.data, split="test", types=["F"])[0].cmd
    results = []
    with tempfile.TemporaryDirectory(prefix="sim_node_latency.") as tmp:
        for name in a.scenarios.split(","):
            print(f"{name}: {a.warmup + a.duration:.0f} s ...", file=sys.stderr, flush=True)
            r = run_scenario(name, a.model, commands, a.duration, a.warmup, Path(tmp),
                             a.sim_param)
            print(json.dumps(r), file=sys.stderr, flush=True)
            results.append(r)
    doc = {"model": str(a.model), "method": model.method,
           "n_train": model.info.get("n_train"),
           "n_train_states": None if model.train_states is None
           else int(model.train_states.shape[0]),
           "duration_s": a.duration, "cpus": os.cpu_count(), "sim_params": a.sim_param,
           "results": results,
           "command": " ".join(["OPENBLAS_NUM_THREADS=1", ".venv/bin/python"] + sys.argv)}
    if a.json:
        a.json.write_text(json.dumps(doc, indent=1) + "\n")
    if a.md:
        a.md.write_text(markdown(doc))
    print(markdown(doc))
    return 0


def markdown(doc: dict) -> str:
    head = [
        "# sim_node: step latency and rate, with and without a 1 kHz command flood", "",
        "Generated by `benchmarks/sim_node_latency/sim_node_latency.py` (its docstring defines every column):", "",
        f"    {doc['command']}", "",
        f"Model: `{doc['model']}`, method **{doc['method']}**, {doc['n_train']} training "
        f"samples, {doc['n_train_states']} TrainPool states for alpha-PROJ (sim_node "
        f"defaults: alpha 0.5, nn_method auto). sim_node parameters beyond the defaults: "
        f"{', '.join(doc['sim_params']) or 'none'}. {doc['duration_s']:.0f} s per scenario "
        f"after a warm-up; controller streaming a TestPool F move at 100 Hz; "
        f"{doc['cpus']} CPUs shared with other jobs (load average in the last column).", "",
    ]
    rows = ["| scenario | published Hz | received Hz | step p50 / p99 / max ms | "
            "step CPU p50 / p99 ms | cmd->state p50 / p99 ms | e2e p50 / p99 ms | "
            "node CPU % | load avg (min-max) |",
            "|---|---|---|---|---|---|---|---|---|"]
    for r in doc["results"]:
        s, c, e, u = r["step"], r["cmd_to_state"], r.get("e2e"), r["step_cpu"]
        la = r["load_average"]
        e2e = ("-" if not e else f"{e['p50_ms']} / {e['p99_ms']}" if e["n"]
               else "n/a: " + e["note"])
        load = f"{min(la):.1f}-{max(la):.1f}" if la else "-"
        rows.append(
            f"| {r['scenario']} | {r['rate_published_hz']:.2f} | {r['rate_received_hz']:.2f} | "
            f"{s.get('p50_ms')} / {s.get('p99_ms')} / {s.get('max_ms')} | "
            f"{u.get('p50_ms')} / {u.get('p99_ms')} | "
            f"{c.get('p50_ms')} / {c.get('p99_ms')} | {e2e} | {r['process_cpu_percent']} | "
            f"{load} |")
    return "\n".join(head + rows) + "\n"


if __name__ == "__main__":
    sys.exit(main())
