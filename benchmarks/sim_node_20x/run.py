"""sim_node's step at 20x real time, and the batched learned simulator over N robots.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/run.py \
        --model MODEL --data bags/default --before /path/to/main/checkout \
        --out benchmarks/sim_node_20x/result

Four phases (``--phases``), one model (a paper-size LGPR), gated alpha-PROJ (the model's radius, or
``--radius``) and covariance on:

1. ``profile``: the core step sim_node runs (``LearnedSimulator.step``, built as sim_node's
   ``make_backend`` builds it: the model's projection, the standing TrainPool state, the model
   prepared, the search index built), driven by a TestPool F move's commands in a loop, in a
   child process (so that ``--before CODE_ROOT`` profiles another checkout's code, e.g. the
   main branch, with the same script). ``--profile-steps`` steps are timed one by one (thread
   CPU time) with the parts timed by wrappers around the calls (about 1 us each): the model's
   prediction (mean and std), the std's triangular solve alone, the nearest-neighbour search;
   then the same steps under cProfile (the functions with the most own time). The predicted
   states of both codes are compared bit for bit (the mean must not change).
2. ``batch``: the batched learned simulator (``rollout.vector_sim.VectorLearnedSimulator``)
   stepping N robots at once (``--batch-n``, default 1, 8, 64, 256), each driven by a TestPool
   move's commands (robot i: move i mod 66, from ``_common.BATCH_OFFSET`` x (i // 66) steps
   into it, so no two robots are alike): steps x robots per CPU second = real-time factor per
   core (one step is 10 ms of robot time), and the share of the model's ``predict`` in it. With the
   model's std off (the rollout's setting) and on.

3. ``timer`` (sim_node in its own process, ``real_time_factor`` ``--factor``, default 20, its
   ``covariance_precision`` as ``--std-dtype``): a controller here sends one command per step
   and counts the joint states it receives over ``--duration`` s; published rate and step CPU
   from the node's latency log (sim_node_10x's method).
4. ``lockstep``: command k+1 as soon as joint state k arrived: steps per second end to end.

The machine may be shared: ``uptime`` is recorded with every measurement; CPU time (not wall)
is what the figures use, but CPU time also grows when other jobs share caches and memory bus.
"""
from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


sys.path.insert(0, str(ROOT))
from benchmarks._common import batch_robots, pct, uptime  # noqa: E402


# ---------------------------------------------------------------------------------------------
# 1. profile (child process)


def build_backend(model_path: str, radius: float | None, std_dtype: str = "float64"):
    """The LearnedSimulator as sim_node's make_backend builds it (projection alpha 0.5,
    nn_method auto, covariance on), with APIs the main branch has too."""
    from littledog_mlsim.models.onestep import OneStepModel
    from littledog_mlsim.rollout.learned_sim import LearnedSimulator, standing_train_state

    model = OneStepModel.load(model_path)
    if radius is None:
        radius = model.gate_radius()[0]
    projection = model.projection("alpha", alpha=0.5, nn_method="auto", radius=radius)
    s0 = standing_train_state(model.train_states, projection)
    model.prepare(return_std=True,
                  **({} if std_dtype == "float64" else {"variance_dtype": std_dtype}))
    projection.nn.prepare()
    sim = LearnedSimulator(model, projection, s0, np.zeros(3), True, trust_radius=radius)
    return model, projection, sim


def profile_main(a) -> dict:
    if os.environ.get("PROFILE_CODE_ROOT"):       # --before: that tree's package, not ours
        sys.path.insert(0, os.environ["PROFILE_CODE_ROOT"])
    import littledog_mlsim
    import littledog_mlsim.models.lgpr as lgpr_mod
    from littledog_mlsim.data.dataset import load_moves

    cmds = np.asarray(load_moves(a.data, split="test", types=["F"])[0].cmd)
    model, projection, sim = build_backend(a.model, a.radius, a.std_dtype)
    n = a.profile_steps

    def drive(k0: int, count: int, states=None, dist=None) -> None:
        for k in range(k0, k0 + count):
            sim.step(cmds[k % len(cmds)])
            if states is not None:
                states[k - k0] = sim.state
                dist[k - k0] = sim.nn_distance

    drive(0, 200)                                   # warm up
    sim.reset()
    spent = {"model predict (mean + std)": 0, "std triangular solve": 0, "nn search": 0}

    def timed(fn, key):
        def wrapper(*args, **kw):
            c = time.thread_time_ns()
            try:
                return fn(*args, **kw)
            finally:
                spent[key] += time.thread_time_ns() - c
        return wrapper
    predict, nv, query = model.predict, lgpr_mod.noisy_variance, projection.nn.query
    model.predict = timed(predict, "model predict (mean + std)")
    lgpr_mod.noisy_variance = timed(nv, "std triangular solve")
    projection.nn.query = timed(query, "nn search")
    cpu = np.empty(n)
    states = np.empty((n, 33))
    dist = np.empty(n)
    twist_var = np.empty((n, 6))
    load0 = uptime()
    for k in range(n):
        c0 = time.thread_time_ns()
        sim.step(cmds[k % len(cmds)])
        cpu[k] = time.thread_time_ns() - c0
        states[k] = sim.state
        dist[k] = sim.nn_distance
        twist_var[k] = sim.twist_covariance[::7]
    load1 = uptime()
    model.predict, lgpr_mod.noisy_variance, projection.nn.query = predict, nv, query
    parts = {key: v / 1e6 / n for key, v in spent.items()}
    parts["model mean (predict minus std solve)"] = (
        parts["model predict (mean + std)"] - parts["std triangular solve"])
    parts["rest (pose, covariance, projection arithmetic)"] = (
        cpu.sum() / 1e6 / n - parts["model predict (mean + std)"] - parts["nn search"])
    sim.reset()
    prof = cProfile.Profile()
    prof.enable()
    drive(0, n)
    prof.disable()
    st = pstats.Stats(prof)
    total = sum(v[2] for v in st.stats.values())
    top = sorted(((v[2], f"{Path(f).name}:{fn}") for (f, _, fn), v in st.stats.items()),
                 reverse=True)[:15]
    r = float(projection.radius)
    return {"code": str(Path(littledog_mlsim.__file__).resolve().parents[1]), "steps": n,
            "step_cpu_ms": pct(cpu / 1e6), "parts_ms_per_step": parts,
            "profiled_ms_per_step": 1e3 * total / n,
            "top_tottime_ms_per_step": [(name, 1e3 * t / n) for t, name in top],
            "radius": r, "inside_gate_share": float(np.mean(dist <= r)),
            "load_before": load0, "load_after": load1,
            "std_dtype": a.std_dtype, "states": states.tolist(), "nn_distance": dist.tolist(),
            "twist_var": twist_var.tolist()}


def run_profile(a, code_root: str | None, std_dtype: str = "float64") -> dict:
    env = dict(os.environ, PYTHONPATH=code_root or str(ROOT), PROFILE_CODE_ROOT=code_root or "")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "p.json"
        cmd = [sys.executable, __file__, "--profile-child", str(out), "--model", a.model,
               "--data", str(a.data), "--profile-steps", str(a.profile_steps),
               "--std-dtype", std_dtype]
        if a.radius is not None:
            cmd += ["--radius", repr(a.radius)]
        subprocess.run(cmd, env=env, check=True)
        return json.loads(out.read_text())


# ---------------------------------------------------------------------------------------------
# 2. batch


def run_batch(a) -> dict:
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.models.onestep import OneStepModel
    from littledog_mlsim.rollout.simulate import prepare_test_moves
    from littledog_mlsim.rollout.vector_sim import VectorLearnedSimulator

    model = OneStepModel.load(a.model)
    radius = model.gate_radius()[0] if a.radius is None else a.radius
    projection = model.projection("alpha", alpha=0.5, radius=radius)
    projection.nn.prepare()
    model.prepare(return_std=True)
    moves = prepare_test_moves(load_moves(a.data, split="test"))
    predict = model.predict
    spent = [0]

    def timed_predict(*args, **kw):
        c = time.thread_time_ns()
        try:
            return predict(*args, **kw)
        finally:
            spent[0] += time.thread_time_ns() - c
    out = []
    for use_var in (False, True):
        for N in a.batch_n:
            s0, u, pose0 = batch_robots(moves, N)   # (pose: not compared)
            T = u.shape[1]
            sim = VectorLearnedSimulator(model, projection, s0, pose0,
                                         use_variance=use_var, trust_radius=radius)
            steps = max(20, min(T, a.batch_robot_steps // N))
            for t in range(5):                       # warm up
                sim.step(u[:, t])
            sim.reset()
            load0 = uptime()
            cpu = np.empty(steps)
            spent[0] = 0
            model.predict = timed_predict
            w0 = time.perf_counter()
            for t in range(steps):
                c0 = time.thread_time_ns()
                sim.step(u[:, t % T])
                cpu[t] = time.thread_time_ns() - c0
            wall = time.perf_counter() - w0
            model.predict = predict
            robot_s = N * steps * 0.01
            out.append({"N": N, "std": use_var, "steps": steps, "cpu_s": float(cpu.sum() / 1e9),
                        "wall_s": wall, "rtf_per_core": robot_s / (cpu.sum() / 1e9),
                        "predict_share": spent[0] / cpu.sum(),
                        "step_cpu_ms": pct(cpu / 1e6), "load": load0})
            print(f"N={N:4d} std={use_var}: {out[-1]['rtf_per_core']:.0f}x real time per core "
                  f"(step CPU p50 {out[-1]['step_cpu_ms']['p50']:.3f} ms, model.predict "
                  f"{100 * out[-1]['predict_share']:.0f} %); {load0}", flush=True)
    return {"runs": out, "radius": radius}


# ---------------------------------------------------------------------------------------------
# 3./4. sim_node in its own process (the controller and node helpers of sim_node_10x/run.py)


def _study10x():
    import importlib.util
    spec = importlib.util.spec_from_file_location("sim_node_10x_run",
                                                  HERE.parent / "sim_node_10x" / "run.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def run_timer(a, ten, ctl, cmds: np.ndarray) -> dict:
    """sim_node at ``real_time_factor`` ``--factor`` with a command per step from this
    process: published and received rates, step CPU (sim_node_10x's ``run_timer`` with the
    factor as a parameter)."""
    import threading
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "lat.csv"
        proc = ten.start_node(a, log, step_mode="timer", real_time_factor=f"{a.factor:.1f}",
                              covariance_precision=a.std_dtype, stats_period="1.0")
        load0 = uptime()
        try:
            ctl.wait_connected()
            stop = threading.Event()
            hz = 100.0 * a.factor

            def stream() -> None:
                t = time.monotonic()
                while not stop.wait(max(0.0, t - time.monotonic())):
                    ctl.send(cmds[count[0] % len(cmds)])
                    count[0] += 1
                    t += 1.0 / hz
            count = [0]
            if a.controller == "reactive":
                # a controller that runs in the simulated time: one command per joint state
                # received, sent from the receiving thread (the node, stepping on its own
                # clock, still takes whichever command is newest at each step)

                def react() -> None:
                    if not stop.is_set():
                        count[0] += 1
                        ctl.send(cmds[count[0] % len(cmds)])
                ctl.on_state = react
                th = None
            else:
                th = threading.Thread(target=stream, daemon=True)
                th.start()
            time.sleep(a.warmup)
            w0_wall, w0_mono, c0 = time.time_ns(), time.monotonic_ns(), count[0]
            time.sleep(a.duration)
            w1_wall, w1_mono, c1 = time.time_ns(), time.monotonic_ns(), count[0]
            stop.set()
            if th is not None:
                th.join(5)
            ctl.on_state = None
        finally:
            err = ten.stop_node(proc)
        load1 = uptime()
        L = ten.read_log(log)
    with ctl.cond:
        rec = np.asarray(ctl.received)
        stats = [v for t, v in ctl.stats if w0_mono <= t < w1_mono]
        ctl.stats.clear()
    n_rec = int(((rec >= w0_mono) & (rec < w1_mono)).sum())
    # the node's own counters over the window (~/stats once a second): the share of steps
    # whose prediction left the gate (each needs the exact nearest-neighbour search)
    outside = skipped = None
    if len(stats) >= 2:
        d_steps = int(stats[-1]["steps"]) - int(stats[0]["steps"])
        d_skip = int(stats[-1]["steps_skipped"]) - int(stats[0]["steps_skipped"])
        skipped = d_skip / max(d_steps + d_skip, 1)       # of the steps due
        if "extrapolating_steps" in stats[0]:
            d_out = int(stats[-1]["extrapolating_steps"]) - int(stats[0]["extrapolating_steps"])
            outside = d_out / max(d_steps, 1)
    pub = L[:, 2]
    win = (pub >= w0_wall) & (pub < w1_wall)
    span = (w1_wall - w0_wall) / 1e9
    Lw = L[win]
    # steps that took a new command (the rest held the last one: the controller's stream and
    # the node's steps are not in step)
    fresh = float(np.mean(Lw[:, 0] >= 0)) if len(Lw) else float("nan")
    return {"factor": a.factor, "executor": a.executor, "controller": a.controller,
            "node_params": a.node_param, "duration_s": span,
            "commands_sent_rate_hz": (c1 - c0) / span,
            "published_rate_hz": int(win.sum()) / span, "received_rate_hz": n_rec / span,
            "fresh_command_share": fresh, "outside_gate_share": outside,
            "skipped_share": skipped,
            "step_cpu_ms": pct(Lw[:, 3] / 1e6), "step_wall_ms": pct((Lw[:, 2] - Lw[:, 1]) / 1e6),
            "load_before": load0, "load_after": load1,
            "node_errors": [ln for ln in err.splitlines() if "ERROR" in ln][:5]}


HOG = "import os\nparent = os.getppid()\nwhile os.getppid() == parent:\n    pass\n"


def run_node_phases(a, phases: list[str]) -> dict:
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_DOMAIN_ID", "152")
    ten = _study10x()
    from littledog_mlsim.data.dataset import load_moves
    cmds = np.asarray(load_moves(a.data, split="test", types=["F"])[0].cmd)
    ctl = ten.Controller()
    out = {}
    hogs: list[subprocess.Popen] = []
    try:
        for _ in range(a.hogs):        # a busy loop that ends with this process
            hogs.append(subprocess.Popen([sys.executable, "-c", HOG]))
        if "timer" in phases:
            out["timer"] = dict(run_timer(a, ten, ctl, cmds), hogs=a.hogs)
        if "lockstep" in phases:
            out["lockstep"] = dict(ten.run_lockstep(a, ctl, cmds), executor=a.executor,
                                   hogs=a.hogs, node_params=a.node_param)
    finally:
        for h in hogs:
            h.kill()
            h.wait()
        ctl.close()
    return out


# ---------------------------------------------------------------------------------------------


def _node_params(t: dict) -> list[str]:
    p = t.get("node_params") or {}
    return [f"sim_node parameters set here: {', '.join(f'`{k}:={v}`' for k, v in p.items())}.",
            ""] if p else []


def markdown(doc: dict) -> list[str]:
    r = doc["results"]
    lines = ["# sim_node's step at 20x and the batched learned simulator (paper-size LGPR, "
             "gated alpha-PROJ, covariance)", "",
             f"Command: `OPENBLAS_NUM_THREADS={doc['openblas_num_threads']} "
             f".venv/bin/python {doc['command']}`  ", f"Code: {doc['git']}; date {doc['date']}",
             ""]
    keys = ["model predict (mean + std)", "model mean (predict minus std solve)",
            "std triangular solve", "nn search",
            "rest (pose, covariance, projection arithmetic)"]
    if "profile" in r:
        lines += ["## 1. One step of sim_node's core (`LearnedSimulator.step`), thread CPU time",
                  "", "| code | step p50 [ms] | p99 [ms] | mean [ms] | "
                  + " | ".join(keys) + " | load |", "|---" * (5 + len(keys)) + "|"]
        names = {"profile_before": "before", "profile_float64": "after, std float64",
                 "profile": "after"}
        for key in ("profile_before", "profile_float64", "profile"):
            if key not in r:
                continue
            p = r[key]
            parts = p["parts_ms_per_step"]
            s = p["step_cpu_ms"]
            lines.append(f"| {names[key].split(',')[0]}, std {p.get('std_dtype', 'float64')} "
                         f"(`{p['code']}`) | {s['p50']:.3f} | {s['p99']:.3f} | {s['mean']:.3f} | "
                         + " | ".join(f"{parts.get(k, float('nan')):.3f}" for k in keys)
                         + f" | `{p['load_before']}` |")
        lines += ["", "(Parts: mean CPU ms per step, timed by wrappers; `rest` is the step "
                  "minus the model's predict and the search.)", ""]
        p = r["profile"]
        lines += [f"Steps inside the gate (nn_distance <= radius {p['radius']:.4f}): "
                  f"{100 * p['inside_gate_share']:.1f} %.", ""]
        if "std_rel_error_vs_float64" in r:
            e = r["std_rel_error_vs_float64"]
            lines += [f"The twist std (6 elements per step) with {p['std_dtype']} factors against "
                      f"float64 ones, relative error: median {e['median']:.2e}, p99 "
                      f"{e['p99']:.2e}, max {e['max']:.2e}.", ""]
        if "same_states" in r:
            lines += [f"Predicted states of before and after equal bit for bit over "
                      f"{p['steps']} steps: **{r['same_states']}**; nn_distance equal on "
                      f"{100 * r['same_distance_share']:.1f} % of the steps (the others: "
                      f"inside the gate, see README).", ""]
        for key in ("profile_before", "profile"):
            if key in r:
                lines += [f"Top functions by own time ({key}, ms per step under cProfile):", ""]
                lines += [f"- `{name}` {ms:.3f}" for name, ms in
                          r[key]["top_tottime_ms_per_step"][:10]]
                lines.append("")
    if "batch" in r:
        lines += ["## 2. Batched learned simulator: real-time factor per core over N", "",
                  "| N robots | std | steps | step CPU p50 [ms] | p99 [ms] | "
                  "x real time per core | model.predict share | load |",
                  "|---|---|---|---|---|---|---|---|"]
        for b in r["batch"]["runs"]:
            s = b["step_cpu_ms"]
            lines.append(f"| {b['N']} | {'on' if b['std'] else 'off'} | {b['steps']} | "
                         f"{s['p50']:.3f} | {s['p99']:.3f} | {b['rtf_per_core']:.0f} | "
                         f"{100 * b.get('predict_share', float('nan')):.0f} % | "
                         f"`{b['load']}` |")
        lines.append("")
    if "timer" in r:
        t = r["timer"]
        lines += [f"## 3. sim_node in its own process, timer mode, real_time_factor "
                  f"{t['factor']:g} ({100 * t['factor']:.0f} steps/s asked), executor "
                  f"{t.get('executor', 'single')}, {t.get('hogs', 0)} CPU hogs beside it, controller "
                  f"{t.get('controller', 'stream')}", "", *_node_params(t),
                  f"Over {t['duration_s']:.1f} s: published {t['published_rate_hz']:.1f} Hz, "
                  f"received {t['received_rate_hz']:.1f} Hz, commands sent "
                  f"{t.get('commands_sent_rate_hz', float('nan')):.1f} Hz; step CPU p50 "
                  f"{t['step_cpu_ms']['p50']:.3f} ms, p99 {t['step_cpu_ms']['p99']:.3f} ms.  ",
                  *([f"Steps with a new command: {100 * t['fresh_command_share']:.1f} %; "
                     f"predictions outside the gate (the node's extrapolating_steps): "
                     f"{100 * t['outside_gate_share']:.1f} %; steps skipped: "
                     f"{100 * (t.get('skipped_share') or 0):.1f} % of those due.  "]
                    if t.get("outside_gate_share") is not None else []),
                  f"Load: before `{t['load_before']}`, after `{t['load_after']}`.", ""]
    if "lockstep" in r:
        t = r["lockstep"]
        rt = t["round_trip_ms"] or {}
        lines += [f"## 4. Lockstep end to end (controller -> node -> controller), executor "
                  f"{t.get('executor', 'single')}, {t.get('hogs', 0)} CPU hogs beside it", "",
                  *_node_params(t),
                  f"{t['steps_per_s']:.1f} steps/s over {t['duration_s']:.1f} s; round trip "
                  f"p50 {rt.get('p50', float('nan')):.3f} ms, p99 "
                  f"{rt.get('p99', float('nan')):.3f} ms.  ",
                  f"Load: before `{t['load_before']}`, after `{t['load_after']}`.", ""]
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", required=True)
    p.add_argument("--data", type=Path, required=True, help="dataset (its TestPool)")
    p.add_argument("--radius", type=float, default=None,
                   help="gate radius (default: the model's own)")
    p.add_argument("--profile-steps", type=int, default=3000)
    p.add_argument("--std-dtype", default="float32", choices=("float64", "float32"),
                   help="LGPR's variance factors in the 'after' profile (sim_node's "
                        "std_precision; the 'before' code has float64 only)")
    p.add_argument("--batch-n", type=lambda s: [int(x) for x in s.split(",")],
                   default=[1, 8, 64, 256])
    p.add_argument("--batch-robot-steps", type=int, default=20000,
                   help="robot-steps per batch measurement (steps = this / N, 20..T)")
    p.add_argument("--phases", default="profile,batch",
                   help="any of profile, batch, timer, lockstep")
    p.add_argument("--factor", type=float, default=20.0, help="timer: real_time_factor")
    p.add_argument("--executor", default="single", choices=("single", "events"),
                   help="timer, lockstep: sim_node's executor parameter")
    p.add_argument("--controller", default="stream", choices=("stream", "reactive"),
                   help="timer: stream = one command per 1/(100 factor) s of wall time from "
                        "a thread, whatever the node's rate; reactive = one command per joint "
                        "state received (a controller in simulated time)")
    p.add_argument("--hogs", type=int, default=0,
                   help="timer, lockstep: this many CPU busy-loop processes run beside them")
    p.add_argument("--node-param", action="append", default=[], metavar="NAME=VALUE",
                   type=lambda s: tuple(s.split("=", 1)),
                   help="timer, lockstep: a sim_node parameter (repeatable), e.g. "
                        "--node-param steps_per_tick=50")
    p.add_argument("--duration", type=float, default=60.0, help="timer: seconds measured")
    p.add_argument("--lockstep-duration", type=float, default=20.0)
    p.add_argument("--warmup", type=float, default=3.0)
    p.add_argument("--before", default=None, metavar="CODE_ROOT",
                   help="also profile this checkout's code (e.g. the main branch) as 'before'")
    p.add_argument("--out", type=Path, default=None, help="write OUT.json and OUT.md")
    p.add_argument("--profile-child", type=Path, default=None, help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if any(len(kv) != 2 for kv in a.node_param):
        p.error("--node-param takes NAME=VALUE")
    a.node_param = dict(a.node_param)
    if a.profile_child is not None:
        a.profile_child.write_text(json.dumps(profile_main(a)))
        return 0
    sys.path.insert(0, str(ROOT))
    from benchmarks._common import run_record
    doc = run_record("sim_node_20x/run.py", argv)
    doc["results"] = results = {}
    phases = a.phases.split(",")
    if "profile" in phases:
        if a.before:
            results["profile_before"] = run_profile(a, a.before)
        if a.std_dtype != "float64":
            results["profile_float64"] = run_profile(a, None, "float64")
        results["profile"] = run_profile(a, None, a.std_dtype)
        if "profile_float64" in results:
            va = np.array(results["profile"]["twist_var"])
            vb = np.array(results["profile_float64"]["twist_var"])
            rel = np.abs(np.sqrt(va) - np.sqrt(vb)) / np.sqrt(vb)
            results["std_rel_error_vs_float64"] = {"median": float(np.median(rel)),
                                                   "p99": float(np.percentile(rel, 99)),
                                                   "max": float(rel.max())}
        if a.before:
            sa = np.array(results["profile"]["states"])
            sb = np.array(results["profile_before"]["states"])
            results["same_states"] = bool(np.array_equal(sa, sb))
            results["same_distance_share"] = float(np.mean(
                np.array(results["profile"]["nn_distance"])
                == np.array(results["profile_before"]["nn_distance"])))
        for key in ("profile_before", "profile_float64", "profile"):
            if key in results:
                for k in ("states", "nn_distance", "twist_var"):
                    results[key].pop(k)
    if "batch" in phases:
        results["batch"] = run_batch(a)
    if "timer" in phases or "lockstep" in phases:
        results.update(run_node_phases(a, phases))
    lines = markdown(doc)
    if a.out is not None:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.with_suffix(".json").write_text(json.dumps(doc, indent=1) + "\n")
        a.out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
