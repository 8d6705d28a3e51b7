"""sim_node at 10x real time: where a step's time goes, and whether 1,000 steps/s hold.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_10x/run.py \
        --model MODEL --data bags/default --duration 60 --out benchmarks/sim_node_10x/result

Three phases, one model (the paper-scale LGPR), gated alpha-PROJ (the model's radius, or
``--radius``) and covariance on:

1. ``profile`` (in this process, no subscriber): a sim_node is built here and stepped
   ``--profile-steps`` times through its command callback (lockstep: command check, model,
   projection, pose, covariance, message construction and publish), once timed per step
   (thread CPU time, with the model's prediction, the nearest-neighbour search and the
   publish calls timed by wrappers: the split of the step's CPU), once under cProfile (the
   functions with the most own time). With ``--code-root`` another checkout's code is
   profiled instead (for the before/after comparison).
2. ``timer10x`` (sim_node in its own process, ``real_time_factor`` 10, ``latency_log`` on): a
   controller here streams a TestPool move's commands at ``--cmd-hz`` (1 kHz: one per step)
   and counts the joint states it receives, for ``--duration`` s after ``--warmup`` s. From
   the node's own log: published rate, step CPU and wall p50/p99; here: received rate.
3. ``lockstep`` (own process): the controller sends command k+1 as soon as joint state k
   arrived: steps per second end to end (controller -> node -> controller) over
   ``--lockstep-duration`` s.

The machine is shared: ``uptime``'s load average is recorded before and after each phase.
"""
from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", "151")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


sys.path.insert(0, str(ROOT))
from benchmarks._common import pct, uptime  # noqa: E402


def sim_params(model: str, radius: float | None, **extra) -> list[str]:
    params = {"model_path": model, "publish_covariance": "true", "stats_period": "0.0"}
    if radius is not None:
        params["radius"] = repr(radius)
    params.update(extra)           # sim_node_20x's --node-param may override the defaults
    return [a for k, v in params.items() for a in ("-p", f"{k}:={v}")]


# ---------------------------------------------------------------------------------------------
# 1. profile


def profile_main(a) -> dict:
    """Child process (so that ``--code-root`` can point at another checkout)."""
    import rclpy
    from sensor_msgs.msg import JointState

    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.layout import JOINT_NAMES
    from littledog_mlsim.nodes.sim_node import SimNode

    cmds = load_moves(a.data, split="test", types=["F"])[0].cmd
    rclpy.init(args=["--ros-args", *sim_params(a.model, a.radius, step_mode="lockstep")])
    node = SimNode()
    msgs = []
    for u in cmds:
        m = JointState()
        m.name = list(JOINT_NAMES)
        m.position = [float(x) for x in u]
        msgs.append(m)
    n = a.profile_steps
    for k in range(200):                           # warm up
        node._on_cmd(msgs[k % len(msgs)])
    # the parts, timed by wrappers around the calls (thread CPU time, about 1 us each):
    # the model's prediction (mean + std), the nearest-neighbour search, the publish calls
    spent = {"model predict (mean + std)": 0, "nn search": 0, "publish (serialise + DDS)": 0}

    def timed(fn, key):
        def wrapper(*args, **kw):
            c = time.thread_time_ns()
            try:
                return fn(*args, **kw)
            finally:
                spent[key] += time.thread_time_ns() - c
        return wrapper
    node.model.predict = timed(node.model.predict, "model predict (mean + std)")
    nn = node.backend.projection.nn
    nn.query = timed(nn.query, "nn search")
    for pub in (node.pub_js, node.pub_odom, node.pub_clock):
        if pub is not None:
            pub.publish = timed(pub.publish, "publish (serialise + DDS)")
    cpu = np.empty(n)
    for k in range(n):
        c0 = time.thread_time_ns()
        node._on_cmd(msgs[k % len(msgs)])
        cpu[k] = time.thread_time_ns() - c0
    parts = {key: v / 1e6 / n for key, v in spent.items()}
    parts["rest (command check, pose, covariance, messages, core)"] = (
        cpu.sum() / 1e6 / n - sum(parts.values()))
    prof = cProfile.Profile()
    prof.enable()
    for k in range(n):
        node._on_cmd(msgs[k % len(msgs)])
    prof.disable()
    st = pstats.Stats(prof)
    total = sum(v[2] for v in st.stats.values())   # tottime over all functions
    top = sorted(((v[2], f"{Path(f).name}:{fn}") for (f, _, fn), v in st.stats.items()),
                 reverse=True)[:15]
    out = {"code": a.code_root or str(ROOT), "steps": n, "step_cpu_ms": pct(cpu / 1e6),
           "profiled_ms_per_step": 1e3 * total / n, "parts_ms_per_step": parts,
           "top_tottime_ms_per_step": [(name, 1e3 * t / n) for t, name in top]}
    node.destroy_node()
    rclpy.shutdown()
    return out


def run_profile(a, code_root: str | None) -> dict:
    env = dict(os.environ, PYTHONPATH=code_root or str(ROOT))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "p.json"
        cmd = [sys.executable, __file__, "--profile-child", str(out), "--model", a.model,
               "--data", str(a.data), "--profile-steps", str(a.profile_steps)]
        if a.radius is not None:
            cmd += ["--radius", repr(a.radius)]
        if code_root:
            cmd += ["--code-root", code_root]
        subprocess.run(cmd, env=env, check=True)
        return json.loads(out.read_text())


# ---------------------------------------------------------------------------------------------
# 2./3. sim_node in its own process


class Controller:
    """This process's end: publishes commands, counts joint states (with receive times)."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState

        from littledog_mlsim.layout import JOINT_NAMES

        rclpy.init(args=[])
        self.node = rclpy.create_node(f"bench_{os.getpid()}")
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                         reliability=ReliabilityPolicy.RELIABLE)
        self.pub = self.node.create_publisher(JointState, "/littledog/cmd", qos)
        self.node.create_subscription(JointState, "/littledog/joint_states", self._on_js, qos)
        from diagnostic_msgs.msg import DiagnosticStatus
        self.stats: list[tuple[int, dict]] = []     # (monotonic ns, ~/stats values) received
        self.node.create_subscription(DiagnosticStatus, "/sim_node/stats", self._on_stats, qos)
        self.msg = JointState()
        self.msg.name = list(JOINT_NAMES)
        self.cond = threading.Condition()
        self.received: list[int] = []       # monotonic ns
        self.on_state = None
        self.ex = SingleThreadedExecutor()
        self.ex.add_node(self.node)
        self.thread = threading.Thread(target=self.ex.spin, daemon=True)
        self.thread.start()

    def _on_js(self, msg) -> None:
        with self.cond:
            self.received.append(time.monotonic_ns())
            self.cond.notify_all()
        cb = self.on_state                   # read once: another thread may clear it
        if cb is not None:
            cb()

    def _on_stats(self, msg) -> None:
        with self.cond:
            self.stats.append((time.monotonic_ns(), {v.key: v.value for v in msg.values}))

    def send(self, u: np.ndarray) -> None:
        self.msg.position = u.tolist()
        self.pub.publish(self.msg)

    def wait_connected(self, timeout: float = 30.0) -> None:
        t1 = time.monotonic() + timeout
        while time.monotonic() < t1:
            if self.pub.get_subscription_count() >= 1 and \
                    self.node.count_publishers("/littledog/joint_states") >= 1:
                return
            time.sleep(0.05)
        raise RuntimeError("sim_node not discovered")

    def close(self) -> None:
        import rclpy
        self.ex.shutdown()
        self.thread.join(5)              # the spin has returned before the node goes
        if self.thread.is_alive():       # never destroy what a running spin waits on
            print("controller: the spin thread did not stop; its node is left to the exit",
                  file=sys.stderr)
        else:
            self.node.destroy_node()
        rclpy.try_shutdown()


def start_node(a, log: Path, **params) -> subprocess.Popen:
    if getattr(a, "executor", None):           # sim_node_20x's --executor
        params.setdefault("executor", a.executor)
    params.update(getattr(a, "node_param", None) or {})     # sim_node_20x's --node-param
    return subprocess.Popen([sys.executable, "-m", "littledog_mlsim.nodes.sim_node",
                             "--ros-args", *sim_params(a.model, a.radius, latency_log=str(log),
                                                       **params)],
                            env=dict(os.environ, PYTHONPATH=str(ROOT)),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def stop_node(proc: subprocess.Popen) -> str:
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    return err


def read_log(log: Path) -> np.ndarray:
    return np.loadtxt(log, delimiter=",", skiprows=1, dtype=np.int64, ndmin=2)


def run_timer(a, ctl: Controller, cmds: np.ndarray) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "lat.csv"
        proc = start_node(a, log, step_mode="timer", real_time_factor="10.0")
        load0 = uptime()
        try:
            ctl.wait_connected()
            stop = threading.Event()

            def stream() -> None:
                t, k = time.monotonic(), 0
                while not stop.wait(max(0.0, t - time.monotonic())):
                    ctl.send(cmds[k % len(cmds)])
                    k += 1
                    t += 1.0 / a.cmd_hz
            th = threading.Thread(target=stream, daemon=True)
            th.start()
            time.sleep(a.warmup)
            w0_wall, w0_mono = time.time_ns(), time.monotonic_ns()
            time.sleep(a.duration)
            w1_wall, w1_mono = time.time_ns(), time.monotonic_ns()
            stop.set()
            th.join(5)
        finally:
            err = stop_node(proc)
        load1 = uptime()
        L = read_log(log)
    with ctl.cond:
        rec = np.asarray(ctl.received)
    n_rec = int(((rec >= w0_mono) & (rec < w1_mono)).sum())
    pub = L[:, 2]
    win = (pub >= w0_wall) & (pub < w1_wall)
    span = (w1_wall - w0_wall) / 1e9
    Lw = L[win]
    return {"duration_s": span, "published_rate_hz": int(win.sum()) / span,
            "received_rate_hz": n_rec / span,
            "step_cpu_ms": pct(Lw[:, 3] / 1e6), "step_wall_ms": pct((Lw[:, 2] - Lw[:, 1]) / 1e6),
            "load_before": load0, "load_after": load1,
            "node_errors": [ln for ln in err.splitlines() if "ERROR" in ln or "WARN" in ln][:5]}


def drive_lockstep(a, ctl: Controller, cmds: np.ndarray) -> tuple[int, int]:
    """Command k+1 as soon as joint state k arrives, for ``a.warmup + a.lockstep_duration`` s,
    against whatever answers on the topics (sim_node, or sim_node_20x's echo node): (start,
    end) in monotonic ns."""
    ctl.wait_connected()
    with ctl.cond:
        ctl.received.clear()
    k = [0]
    t_end = [0]

    def next_cmd() -> None:
        if time.monotonic_ns() < t_end[0]:
            k[0] += 1
            ctl.send(cmds[k[0] % len(cmds)])
    ctl.on_state = next_cmd
    t0 = time.monotonic_ns()
    t_end[0] = t0 + int((a.warmup + a.lockstep_duration) * 1e9)
    ctl.send(cmds[0])
    time.sleep(a.warmup + a.lockstep_duration + 1.0)
    ctl.on_state = None
    return t0, t_end[0]


def lockstep_rate(a, ctl: Controller, t0: int, t_end: int) -> dict:
    """Steps per second and round trip over the window after the warm-up."""
    with ctl.cond:
        rec = np.asarray(ctl.received)
    w0 = t0 + int(a.warmup * 1e9)
    inwin = rec[(rec >= w0) & (rec < t_end)]
    span = (t_end - w0) / 1e9
    gaps = np.diff(inwin) / 1e6
    return {"duration_s": span, "steps_per_s": inwin.size / span,
            "round_trip_ms": pct(gaps) if gaps.size else None}


def run_lockstep(a, ctl: Controller, cmds: np.ndarray) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "lat.csv"
        proc = start_node(a, log, step_mode="lockstep")
        load0 = uptime()
        try:
            t0, t_end = drive_lockstep(a, ctl, cmds)
        finally:
            err = stop_node(proc)
        load1 = uptime()
    return {**lockstep_rate(a, ctl, t0, t_end), "load_before": load0, "load_after": load1,
            "node_errors": [ln for ln in err.splitlines() if "ERROR" in ln][:5]}


# ---------------------------------------------------------------------------------------------


def markdown(doc: dict) -> list[str]:
    r = doc["results"]
    lines = ["# sim_node at 10x real time (paper-scale LGPR, gated alpha-PROJ, covariance)", "",
             f"Command: `OPENBLAS_NUM_THREADS={doc['openblas_num_threads']} "
             f".venv/bin/python {doc['command']}`  ", f"Code: {doc['git']}; date {doc['date']}",
             ""]
    keys = ["model predict (mean + std)", "nn search", "publish (serialise + DDS)",
            "rest (command check, pose, covariance, messages, core)"]
    lines += ["## 1. Where a step's CPU goes (in-process node, lockstep callback, no subscriber)",
              "", "| code | step CPU p50 [ms] | p99 [ms] | mean [ms] | " + " | ".join(keys) +
              " |", "|---" * (4 + len(keys)) + "|"]
    for key in ("profile_before", "profile"):
        if key not in r:
            continue
        p = r[key]
        parts = p["parts_ms_per_step"]
        lines.append(f"| {'before (' + p['code'] + ')' if key == 'profile_before' else 'this'} "
                     f"| {p['step_cpu_ms']['p50']:.3f} | {p['step_cpu_ms']['p99']:.3f} | "
                     f"{p['step_cpu_ms']['mean']:.3f} | "
                     + " | ".join(f"{parts.get(k, float('nan')):.3f}" for k in keys) + " |")
    lines += ["", "(Parts: mean CPU ms per step; load: "
              + "; ".join(f"`{r[k]['load']}`" for k in ("profile_before", "profile") if k in r)
              + ")", ""]
    if "profile" in r:
        lines += ["Top functions by own time (this code, ms per step under cProfile):", ""]
        lines += [f"- `{name}` {ms:.3f}" for name, ms in r["profile"]["top_tottime_ms_per_step"]]
        lines.append("")
    if "timer10x" in r:
        t = r["timer10x"]
        lines += ["## 2. Timer mode, real_time_factor 10 (1,000 steps/s)", "",
                  f"Over {t['duration_s']:.1f} s: published {t['published_rate_hz']:.1f} Hz, "
                  f"received {t['received_rate_hz']:.1f} Hz; step CPU p50 "
                  f"{t['step_cpu_ms']['p50']:.3f} ms, p99 {t['step_cpu_ms']['p99']:.3f} ms; step "
                  f"wall p50 {t['step_wall_ms']['p50']:.3f} ms, p99 "
                  f"{t['step_wall_ms']['p99']:.3f} ms.  ",
                  f"Load: before `{t['load_before']}`, after `{t['load_after']}`.", ""]
    if "lockstep" in r:
        t = r["lockstep"]
        rt = t["round_trip_ms"] or {}
        lines += ["## 3. Lockstep end to end (controller -> node -> controller)", "",
                  f"{t['steps_per_s']:.1f} steps/s over {t['duration_s']:.1f} s; round trip "
                  f"p50 {rt.get('p50', float('nan')):.3f} ms, p99 {rt.get('p99', float('nan')):.3f}"
                  f" ms.  ", f"Load: before `{t['load_before']}`, after `{t['load_after']}`.", ""]
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", required=True)
    p.add_argument("--data", type=Path, required=True, help="dataset (a TestPool F move)")
    p.add_argument("--radius", type=float, default=None,
                   help="gate radius (default: sim_node's default, the model's own)")
    p.add_argument("--duration", type=float, default=60.0)
    p.add_argument("--lockstep-duration", type=float, default=20.0)
    p.add_argument("--warmup", type=float, default=3.0)
    p.add_argument("--cmd-hz", type=float, default=1000.0)
    p.add_argument("--profile-steps", type=int, default=3000)
    p.add_argument("--phases", default="profile,timer10x,lockstep")
    p.add_argument("--before", default=None, metavar="CODE_ROOT",
                   help="also profile this checkout's code (e.g. the main branch) as 'before'")
    p.add_argument("--before-model", default=None,
                   help="model for the 'before' profile (older code may not read newer keys)")
    p.add_argument("--out", type=Path, default=None, help="write OUT.json and OUT.md")
    p.add_argument("--profile-child", type=Path, default=None, help=argparse.SUPPRESS)
    p.add_argument("--code-root", default=None, help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.profile_child is not None:
        a.profile_child.write_text(json.dumps(profile_main(a)))
        return 0
    sys.path.insert(0, str(ROOT))
    from benchmarks._common import run_record
    doc = run_record("sim_node_10x/run.py", argv)
    doc["results"] = results = {}
    phases = a.phases.split(",")
    if "profile" in phases:
        if a.before:
            b = argparse.Namespace(**vars(a))
            b.model = a.before_model or a.model
            results["profile_before"] = run_profile(b, a.before)
            results["profile_before"]["load"] = uptime()
        results["profile"] = run_profile(a, None)
        results["profile"]["load"] = uptime()
    if "timer10x" in phases or "lockstep" in phases:
        from littledog_mlsim.data.dataset import load_moves
        cmds = np.asarray(load_moves(a.data, split="test", types=["F"])[0].cmd)
        ctl = Controller()
        try:
            if "timer10x" in phases:
                results["timer10x"] = run_timer(a, ctl, cmds)
            if "lockstep" in phases:
                results["lockstep"] = run_lockstep(a, ctl, cmds)
        finally:
            ctl.close()
    lines = markdown(doc)
    if a.out is not None:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.with_suffix(".json").write_text(json.dumps(doc, indent=1) + "\n")
        a.out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
