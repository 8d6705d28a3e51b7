"""Helpers shared by the benchmark scripts (run as ``python benchmarks/<study>/<script>.py``;
a script puts ``benchmarks/`` on ``sys.path`` to import this module)."""
from __future__ import annotations

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def git_state() -> str:
    """HEAD commit, the modified tracked files and the untracked Python files: the code a
    benchmark measured."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                              capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "diff", "--name-only", "HEAD"], cwd=ROOT,
                               capture_output=True, text=True).stdout.split()
        new = subprocess.run(["git", "ls-files", "--others", "--exclude-standard", "--",
                              "*.py"], cwd=ROOT, capture_output=True, text=True).stdout.split()
    except OSError:
        return "unknown"
    return (head + (f" + uncommitted changes to {', '.join(dirty)}" if dirty else "")
            + (f" + untracked {', '.join(new)}" if new else ""))


def time_calls(fn, inputs, pace_s: float = 0.0):
    """Call ``fn(x)`` for each x in ``inputs``, one after another; returns (wall, cpu), two
    arrays of milliseconds per call (wall clock, and this thread's CPU time, which leaves out
    preemption by other jobs). ``pace_s`` > 0 starts calls that far apart (a node's tick)."""
    import time

    import numpy as np
    n = len(inputs)
    wall, cpu = np.empty(n), np.empty(n)
    for j, x in enumerate(inputs):
        c0 = time.thread_time_ns()
        t0 = time.perf_counter_ns()
        fn(x)
        wall[j] = time.perf_counter_ns() - t0
        cpu[j] = time.thread_time_ns() - c0
        if pace_s > 0:
            time.sleep(max(0.0, pace_s - (time.perf_counter_ns() - t0) / 1e9))
    return wall / 1e6, cpu / 1e6


def run_record(script: str, argv) -> dict:
    """The provenance a benchmark's JSON starts with: command line, code and date."""
    import os
    import sys
    import time
    return {"command": " ".join([f"benchmarks/{script}", *(argv or sys.argv[1:])]),
            "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
            "git": git_state(), "date": time.strftime("%Y-%m-%d %H:%M")}


def command_line(doc: dict) -> str:
    """The Markdown line naming the command (with the BLAS thread setting it ran under: the one
    ``run_record`` recorded, else this process's)."""
    import os
    threads = doc.get("openblas_num_threads", os.environ.get("OPENBLAS_NUM_THREADS"))
    return f"Command: `OPENBLAS_NUM_THREADS={threads} .venv/bin/python {doc['command']}`"


def write_results(out: Path | None, doc: dict, lines: list) -> None:
    """Write ``out``.json (``doc``) and ``out``.md (``lines``), unless ``out`` is None, and
    print the Markdown."""
    import json
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.with_suffix(".json").write_text(json.dumps(doc, indent=1) + "\n")
        out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def uptime() -> str:
    """The machine's ``uptime`` line (the load a measurement was taken at)."""
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def pct(x) -> dict:
    """n, mean, p50, p99 and max of the values ``x``."""
    import numpy as np
    x = np.asarray(x, dtype=float)
    return {"n": int(x.size), "mean": float(x.mean()), "p50": float(np.percentile(x, 50)),
            "p99": float(np.percentile(x, 99)), "max": float(x.max())}


#: steps between the starts of batch robots that share a TestPool move
BATCH_OFFSET = 50


def batch_robots(moves, n: int, offset: int = BATCH_OFFSET):
    """(s0 (n, 33), commands (n, T, 12), pose0 (n, 3)) of ``n`` robots for the batched
    simulator: robot i drives TestPool move i mod M (``rollout.simulate.prepare_test_moves``),
    started ``offset`` x (i // M) steps into it from the recorded state there, so that no two
    robots are the same; T is the shortest remaining command stream."""
    import numpy as np
    s0, u, pose0 = [], [], []
    for i in range(n):
        m = moves[i % len(moves)]
        o = (i // len(moves)) * offset
        s0.append(m.s0 if o == 0 else m.states[o - 1])
        u.append(m.actions[o:])
        pose0.append([m.pose0.x0, m.pose0.y0, m.pose0.yaw0])
    T = min(len(x) for x in u)
    return np.stack(s0), np.stack([x[:T] for x in u]), np.array(pose0)


def appended_study(out_json: Path) -> dict:
    """A study whose runs append rows to one table: the document in ``out_json`` where it
    exists, else a new one (``commands``, ``rows``), with this run's command line (relative to
    the repository), code and date appended to ``commands``."""
    import json
    import sys
    import time
    doc = (json.loads(out_json.read_text()) if out_json.exists()
           else {"commands": [], "rows": []})
    doc["commands"].append({"command": "OPENBLAS_NUM_THREADS=1 .venv/bin/python " + " ".join(
        [str(Path(sys.argv[0]).resolve().relative_to(ROOT))] + sys.argv[1:]),
        "code": git_state(), "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime())})
    return doc


def study_commands(doc: dict) -> list[str]:
    """The Markdown lines naming each of an appended study's commands, its code and date."""
    return [f"Command: `{c['command']}`  \nCode: {c['code']}; {c['date']} UTC  "
            for c in doc["commands"]]


def zoo_effects(path: Path) -> list[dict]:
    """A blind zoo's ``truth.yaml``: its effects' entries (after its run)."""
    import yaml
    doc = yaml.safe_load(Path(path).read_text())
    return doc["effects"] if isinstance(doc, dict) else doc


def truth_with_params(e: dict) -> str:
    """A truth entry as "family @ scope (params)", the params left out where it has none."""
    params = e.get("params") or {}
    return f"{e['family']} @ {e['scope']}" + (f" ({params})" if params else "")


def named_change(c: dict) -> str | None:
    """Decision 027's reading ``c`` (``reference_change``) as "family @ scope" where it names
    a change, else None."""
    return f"{c['vocabulary']['family']} @ {c['vocabulary']['scope']}" if c["named"] else None


def zoo_truth(path: Path) -> dict[str, str]:
    """A blind zoo's ``truth.yaml`` read as ``{effect id: "family @ scope"}`` (after its run)."""
    return {e["id"]: f"{e['family']} @ {e['scope']}" for e in zoo_effects(path)}


def zoo_study_parser(description: str):
    """The arguments the read-zoo studies share (``learned_route/reference_change``): a zoo's
    recordings (``--zoo-dir``), its ``--truth``, the rows' ``--label`` and the ``--out`` stem."""
    import argparse
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--zoo-dir", type=Path, required=True)
    p.add_argument("--truth", type=Path, required=True)
    p.add_argument("--label", required=True)
    p.add_argument("--out", type=Path, required=True)
    return p


def zoo_effect_routes(a):
    """The read-zoo studies' loop (``learned_route/reference_change``), for the arguments of
    :func:`zoo_study_parser` with ``--only``: the learned route's start features, the
    reference's route and its fit at them (``ref.fit(start, one_step=True)``), then per effect
    of ``--only`` ``(name, truth entry, its route, seconds since the effect's start)``; the
    last is a function, read after the effect's work. A name the truth lacks is read from the
    harness's ``clean/`` recordings, with the truth entry family ``clean``."""
    import time

    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.diagnose.candidates import measured_robot_features
    from littledog_mlsim.diagnose.learned import LearnedOptions, _Route
    opts, start, quiet = LearnedOptions(), measured_robot_features(), (lambda s: None)
    truth = {e["id"]: e for e in zoo_effects(a.truth)}
    ref = _Route(load_moves(a.zoo_dir / "reference", "train"), start, opts, quiet)
    ref_fit = ref.fit(start, one_step=True)

    def effects():
        for name in a.only.split(","):
            t = time.perf_counter()
            clean = name not in truth and (a.zoo_dir / "clean" / name).is_dir()
            where = a.zoo_dir / ("clean" if clean else "effects") / name
            r = _Route(load_moves(where, "train"), start, opts, quiet)
            entry = {"id": name, "family": "clean", "scope": "-"} if clean else truth[name]
            yield name, entry, r, lambda t=t: round(time.perf_counter() - t, 1)
    return start, ref, ref_fit, effects()


def zoo_effect_study(description: str):
    """A read-zoo study over ``--only``'s effects, set up: the arguments of
    :func:`zoo_study_parser` and ``--only`` parsed, :func:`zoo_effect_routes` of them, and the
    appended study document at ``--out``. Returns ``(args, start, ref, ref_fit, effects,
    doc)``."""
    p = zoo_study_parser(description)
    p.add_argument("--only", required=True,
                   help="comma-separated effect ids (zNN), or the harness's clean datasets "
                        "(sNNN_eX)")
    a = p.parse_args()
    start, ref, ref_fit, effects = zoo_effect_routes(a)
    return a, start, ref, ref_fit, effects, appended_study(a.out.with_suffix(".json"))


def save_study(doc: dict, out: Path, write_md) -> None:
    """Write an appended study's ``doc`` to ``out``.json and its table to ``out``.md
    (``write_md(doc, path)``)."""
    import json
    out.with_suffix(".json").write_text(json.dumps(doc, indent=1))
    write_md(doc, out.with_suffix(".md"))


def per_bag_modes(doc: dict, times: dict, n: int, title: str, repeats: int) -> list:
    """Store in ``doc["modes"]`` each mode's median milliseconds per bag (wall and CPU) over the
    repeats and its wall-time speed-up over the first mode (``times``: mode -> {"wall": [s],
    "cpu": [s]}, in order), and return the Markdown result's lines up to its table's rows
    (``bag_read``, ``bag_write``)."""
    import statistics
    first = next(iter(times.values()))
    base = statistics.median(first["wall"])
    doc["modes"] = {m: {"wall_ms_per_bag": 1e3 * statistics.median(t["wall"]) / n,
                        "cpu_ms_per_bag": 1e3 * statistics.median(t["cpu"]) / n,
                        "speed_up": base / statistics.median(t["wall"]),
                        "wall_s": t["wall"], "cpu_s": t["cpu"]} for m, t in times.items()}
    lines = [f"# {title}", "",
             command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}; "
             f"{n} bags; {repeats} repeats, medians", "",
             f"Load before: `{doc['load_before']}`  ", f"after: `{doc['load_after']}`", "",
             "| mode | wall [ms per bag] | CPU [ms per bag] | speed-up (wall) |",
             "|---|---|---|---|"]
    for m, r in doc["modes"].items():
        lines.append(f"| {m} | {r['wall_ms_per_bag']:.1f} | {r['cpu_ms_per_bag']:.1f} | "
                     f"{r['speed_up']:.2f}x |")
    return lines


def timed_modes(modes: tuple, repeats: int, run, same, name: str) -> dict:
    """Run ``run(mode)`` -> (wall s, CPU s, result) for every mode, ``repeats`` times, the order
    rotating by one mode each repeat; every result must satisfy ``same(first result, result)``
    (else exit naming the mode). Returns mode -> {"wall": [s], "cpu": [s]}, in ``modes``'
    order (``bag_read``, ``bag_write``)."""
    import sys
    ref = None
    times: dict[str, dict[str, list]] = {m: {"wall": [], "cpu": []} for m in modes}
    for r in range(repeats):
        for mode in modes[r % len(modes):] + modes[:r % len(modes)]:
            wall, cpu, result = run(mode)
            if ref is None:
                ref = result
            elif not same(ref, result):
                sys.exit(f"{name}: {mode} gave another result than the first mode")
            times[mode]["wall"].append(wall)
            times[mode]["cpu"].append(cpu)
    return times


def bag_benchmark_args(description: str, argv) -> "argparse.Namespace":
    """``--data``, ``--moves-per-type``, ``--repeats`` and ``--out`` of the bag benchmarks
    (``bag_read``, ``bag_write``)."""
    import argparse
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--moves-per-type", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", type=Path, default=None)
    return ap.parse_args(argv)


def bags_to_time(data: Path | None, moves_per_type: int, tmp: str, name: str) -> list:
    """Every bag directory under ``data`` (any depth), sorted; without ``data``,
    ``moves_per_type`` moves of every type recorded (``record``, seed 0) into ``tmp`` first.
    Exits naming the benchmark where there is none."""
    import sys
    if data is None:
        from littledog_mlsim.apps.record import record_dataset
        data = Path(tmp) / "data"
        record_dataset(data, moves_per_type=moves_per_type, seed=0, jobs=1, progress=False)
    bags = sorted(p.parent for p in data.rglob("metadata.yaml"))
    if not bags:
        sys.exit(f"{name}: no bags under {data}")
    return bags


class StepSimulationTimer:
    """While entered, every ``pybullet.stepSimulation`` call (the simulator calls it through
    the module) is timed into ``calls`` [s]."""

    def __init__(self) -> None:
        self.calls: list[float] = []

    def __enter__(self) -> "StepSimulationTimer":
        import time

        import pybullet as p
        self._step = step = p.stepSimulation

        def timed(**kw) -> None:
            t = time.perf_counter()
            step(**kw)
            self.calls.append(time.perf_counter() - t)

        p.stepSimulation = timed
        return self

    def __exit__(self, *exc: object) -> None:
        import pybullet as p
        p.stepSimulation = self._step

