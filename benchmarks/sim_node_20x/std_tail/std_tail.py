"""Where the core step's p99 comes from when the covariance is on, and what the std options do to
it (issue 27: step CPU p99 <= 0.4 ms with LGPR, gated alpha-PROJ and covariance).

The learned simulator as sim_node builds it (``../run.py``'s ``build_backend``) steps through the
TestPool moves' commands, one command per step, for ``--steps`` steps, in each configuration:

- ``off``: no std (``use_variance`` False): the floor without the covariance;
- ``float32``: the std from float32 factors (sim_node's default ``covariance_precision``);
- ``float64``: from float64 factors;
- ``every K``: float32, but the std computed only on every K-th step (timing only: the steps
  between publish no covariance, so this measures what holding the std for K steps would save);
- ``held K`` (``--held``): sim_node's ``covariance_every`` K, the option itself: the std on every
  K-th step, held in between. Its published covariances are compared with the ``float32`` run's
  (the same states, checked bit for bit): the per-step std (the twist's 6 diagonal entries and
  the pose's z, roll, pitch) as sqrt(held / exact) - 1, and the summed x, y and yaw variances as
  held / exact - 1, over every step.

Per step: thread CPU time, whether the prediction left the gate, and whether the LGPR cluster
the step used differs from the previous step's (the step then reads another cluster's training
rows and, with the std, its Cholesky factor). Then, on the float32 run's queries: the std from
the m training points with the largest kernel values (a conservative bound: fewer points never
lower the posterior variance), its error against the exact std and its cost; and a memory probe
(single-thread read bandwidth over a 256 MB array, against the bytes of the clusters' factors).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/std_tail/std_tail.py \
        --model MODEL --data DATA --out benchmarks/sim_node_20x/std_tail/result
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sla

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
import run as R  # noqa: E402  (benchmarks/sim_node_20x/run.py: build_backend, ROOT on the path)
from benchmarks._common import uptime  # noqa: E402


def commands(data: str, steps: int) -> np.ndarray:
    from littledog_mlsim.data.dataset import load_moves
    cmds = np.concatenate([np.asarray(m.cmd) for m in load_moves(data, split="test")])
    return cmds[np.arange(steps) % len(cmds)]


def run_config(model_path: str, cmds: np.ndarray, dtype: str, every: int | None,
               use_std: bool, held: int | None = None, keep: bool = False) -> dict:
    model, projection, sim = R.build_backend(model_path, None, dtype)
    if held is not None:
        sim.covariance_every = held
    est = model.estimator
    labels: list[int] = []
    queries: list[tuple[int, np.ndarray]] = []
    orig = est._shared_kernel_predict

    def spy(c, Xq, want_var):
        labels.append(int(c))
        if want_var:
            queries.append((int(c), Xq.copy()))
        return orig(c, Xq, want_var)

    for k in range(200):                        # warm up, then start again
        sim.step(cmds[k])
    sim.reset()
    est._shared_kernel_predict = spy
    n = len(cmds)
    cpu = np.empty(n)
    out = np.zeros(n, bool)
    lab = np.full(n, -1)
    r = float(projection.radius)
    published = np.full((n, 2, 36), np.nan) if keep else None
    states = np.full((n, 33), np.nan) if keep else None
    load0 = uptime()
    for k in range(n):
        sim.use_variance = use_std and (every is None or k % every == 0)
        before = len(labels)
        c0 = time.thread_time_ns()
        sim.step(cmds[k])
        cpu[k] = (time.thread_time_ns() - c0) / 1e6
        out[k] = sim.nn_distance > r
        lab[k] = labels[-1] if len(labels) > before else -1
        if keep:
            published[k, 0], published[k, 1] = sim.pose_covariance, sim.twist_covariance
            states[k] = sim.state
    load1 = uptime()
    est._shared_kernel_predict = orig
    change = np.r_[False, lab[1:] != lab[:-1]]
    slow = cpu >= np.quantile(cpu, 0.99)
    doc = {"step_cpu_ms": {"p50": float(np.median(cpu)), "p99": float(np.quantile(cpu, 0.99)),
                           "mean": float(cpu.mean())},
           "outside_gate_share": float(out.mean()), "cluster_change_share": float(change.mean()),
           "slowest_1pct": {"outside_gate_share": float(out[slow].mean()),
                            "cluster_change_share": float(change[slow].mean())},
           "p99_inside_gate_same_cluster_ms": float(np.quantile(cpu[~out & ~change], 0.99)),
           "p99_inside_gate_cluster_changed_ms": float(np.quantile(cpu[~out & change], 0.99)),
           "load_before": load0, "load_after": load1}
    if keep:
        doc["_published"], doc["_states"] = published, states
    return doc, model, queries


#: the per-step std entries of the published covariances: (pose or twist, index in the 6 x 6)
STEP_STD = [(1, 7 * i) for i in range(6)] + [(0, 14), (0, 21), (0, 28)]
SUMMED = {"x": (0, 0), "y": (0, 7), "yaw": (0, 35)}


def held_error(held: dict, exact: dict) -> dict:
    """The held std's published covariances against every step's (module doc)."""
    if not np.array_equal(held["_states"], exact["_states"]):
        raise SystemExit("held std: the states differ from the exact run's (they must not)")
    ph, pe = held["_published"], exact["_published"]
    ratio = np.stack([ph[:, a, i] / pe[:, a, i] for a, i in STEP_STD], axis=1)
    step = np.abs(np.sqrt(ratio) - 1.0)
    doc = {"states_identical": True,
           "step_std_rel_error": {"median": float(np.median(step)),
                                  "p99": float(np.quantile(step, 0.99)),
                                  "max": float(step.max())}}
    for name, (a, i) in SUMMED.items():
        e = np.abs(ph[:, a, i] / pe[:, a, i] - 1.0)[100:]     # after the first second
        doc[f"summed_{name}_var_rel_error"] = {"median": float(np.median(e)),
                                               "max": float(e.max()),
                                               "last": float(e[-1])}
    return doc


def local_std(model, queries, ms: list[int], every: int = 3) -> list[dict]:
    """The exact std (the model's float64 factor) against the std from the m points of largest
    kernel value, on every ``every``-th query; thread CPU of each."""
    if not ms:
        return []
    est = model.estimator
    est.prepare_variance("float64")
    from littledog_mlsim.models.gp import noisy_variance
    rows = []
    for m in ms:
        err, t_exact, t_local = [], [], []
        for c, Xq in queries[::every]:
            _, _, ZT, zz, _, _ = est._rows[c]
            K, sf2, sn2 = est.kernel_rows(c, Xq)
            t0 = time.thread_time_ns()
            exact = noisy_variance(est._factors(c)[0], K, sf2, sn2)[0]
            t1 = time.thread_time_ns()
            k = K[0]
            idx = np.argpartition(k, -m)[-m:]
            Zm = ZT.T[idx]
            D = np.maximum(zz[idx][:, None] + zz[idx][None, :] - 2.0 * (Zm @ Zm.T), 0.0)
            Kmm = sf2 * np.exp(-0.5 * D)
            Kmm.flat[::m + 1] += sn2 + float(est.jitter_[c])
            v = sla.solve_triangular(np.linalg.cholesky(Kmm), k[idx], lower=True,
                                     check_finite=False)
            loc = max(sf2 + sn2 - float(v @ v), 0.0)
            t2 = time.thread_time_ns()
            err.append(np.sqrt(loc / exact) - 1.0)
            t_exact.append((t1 - t0) / 1e3)
            t_local.append((t2 - t1) / 1e3)
        err = np.array(err)
        rows.append({"m": m, "queries": len(err),
                     "std_rel_error": {"median": float(np.median(err)),
                                       "p99": float(np.quantile(err, 0.99)),
                                       "max": float(err.max()), "min": float(err.min())},
                     "exact_us": {"p50": float(np.median(t_exact)),
                                  "p99": float(np.quantile(t_exact, 0.99))},
                     "local_us": {"p50": float(np.median(t_local)),
                                  "p99": float(np.quantile(t_local, 0.99))}})
    return rows


def bandwidth_gbs(mb: int = 256, reps: int = 5) -> float:
    """Single-thread read bandwidth: the best of ``reps`` sums over an array of ``mb`` MB."""
    a = np.ones(mb * 1_000_000 // 4, dtype=np.float32)
    best = np.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        a.sum(dtype=np.float64)
        best = min(best, time.perf_counter() - t0)
    return a.nbytes / best / 1e9


def markdown(doc: dict) -> str:
    L = [f"# Where the step's p99 comes from with the covariance on",
         "", f"Command: `{doc['command']}`  ", f"Code: {doc['code']}; {doc['date']}", "",
         f"{doc['steps']} steps over the TestPool moves' commands (one per step); thread CPU "
         "per step.", "",
         "| std | step p50 [ms] | p99 | mean | outside the gate | cluster changed | slowest 1 %: "
         "outside / changed | p99 inside the gate, same cluster / changed | load |",
         "|---|---|---|---|---|---|---|---|---|"]
    for name, r in doc["configs"].items():
        s = r["step_cpu_ms"]
        L.append(f"| {name} | {s['p50']:.3f} | {s['p99']:.3f} | {s['mean']:.3f} | "
                 f"{100 * r['outside_gate_share']:.1f} % | {100 * r['cluster_change_share']:.1f} % | "
                 f"{100 * r['slowest_1pct']['outside_gate_share']:.0f} % / "
                 f"{100 * r['slowest_1pct']['cluster_change_share']:.0f} % | "
                 f"{r['p99_inside_gate_same_cluster_ms']:.3f} / "
                 f"{r['p99_inside_gate_cluster_changed_ms']:.3f} | `{r['load_before']}` |")
    held = {k: v for k, v in doc["configs"].items() if "held_error" in v}
    if held:
        L += ["", "`covariance_every` K (the std on every K-th step, held in between) against "
              "every step's std (float32), over the same steps (the states bit for bit the "
              "same):", "",
              "| K | per-step std: abs. relative error median / p99 / max | summed x variance: "
              "median / max | summed y | summed yaw |", "|---|---|---|---|---|"]
        for name, v in held.items():
            e = v["held_error"]
            st = e["step_std_rel_error"]
            L.append(f"| {name.split()[-1]} | {100 * st['median']:.1f} / {100 * st['p99']:.1f} / "
                     f"{100 * st['max']:.1f} % | " + " | ".join(
                         f"{100 * e[f'summed_{c}_var_rel_error']['median']:.2f} / "
                         f"{100 * e[f'summed_{c}_var_rel_error']['max']:.2f} %"
                         for c in ("x", "y", "yaw")) + " |")
    if not doc["local_std"]:
        return "\n".join(L + [""])
    L += ["", "The std from the m training points of largest kernel value (a conservative bound) "
          "against the exact one (float64 factor), on every third query of the float32 run:", "",
          "| m | std relative error: median | p99 | max | exact std p50 / p99 [us] | "
          "m-point std p50 / p99 [us] |", "|---|---|---|---|---|---|"]
    for r in doc["local_std"]:
        e = r["std_rel_error"]
        L.append(f"| {r['m']} | {e['median']:+.3f} | {e['p99']:+.3f} | {e['max']:+.3f} | "
                 f"{r['exact_us']['p50']:.0f} / {r['exact_us']['p99']:.0f} | "
                 f"{r['local_us']['p50']:.0f} / {r['local_us']['p99']:.0f} |")
    f = doc["factors"]
    L += ["", f"Memory: the model's {f['clusters']} clusters hold {f['rows_median']} training "
          f"rows (median; largest {f['rows_max']}); a packed float32 factor takes "
          f"{f['packed_mb_median']:.2f} MB (median; largest {f['packed_mb_max']:.2f} MB), "
          f"{f['packed_mb_total']:.0f} MB in all (float64 squares: {f['square64_mb_total']:.0f} MB). "
          f"Single-thread read bandwidth (best of 5 sums over 256 MB): "
          f"{doc['bandwidth_gbs']:.1f} GB/s, so reading the median factor from memory takes "
          f"{1e3 * f['packed_mb_median'] / 1e3 / doc['bandwidth_gbs']:.3f} ms and the largest "
          f"{1e3 * f['packed_mb_max'] / 1e3 / doc['bandwidth_gbs']:.3f} ms.", ""]
    return "\n".join(L)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--model", required=True)
    ap.add_argument("--data", required=True)
    ap.add_argument("--steps", type=int, default=6000)
    ap.add_argument("--every", default="2,4,8,16")
    ap.add_argument("--held", default="", help="also covariance_every K for these K (e.g. 2,4,8)")
    ap.add_argument("--local-m", default="32,64,128", help="'' skips the m-point std")
    ap.add_argument("--out", required=True)
    ap.add_argument("--code-root", default=None,
                    help="import littledog_mlsim from this checkout (an A/B against older code)")
    ap.add_argument("--only", default=None, metavar="CONFIG",
                    help="run this one configuration (e.g. float32) and write its figures only")
    a = ap.parse_args(argv)
    import subprocess
    if a.code_root:
        sys.path.insert(0, a.code_root)
    cmds = commands(a.data, a.steps)
    if a.only:
        dtype = "float64" if a.only == "float64" else "float32"
        doc, _, _ = run_config(a.model, cmds, dtype, None, a.only != "off")
        import littledog_mlsim
        doc.update(config=a.only, code=str(Path(littledog_mlsim.__file__).parents[1]))
        Path(a.out + ".json").write_text(json.dumps(doc, indent=1))
        print(json.dumps(doc))
        return 0
    configs, model32, queries = {}, None, None
    helds = [int(k) for k in a.held.split(",") if k]
    for name, dtype, every, use, held in [("off", "float32", None, False, None),
                                          ("float32", "float32", None, True, None),
                                          ("float64", "float64", None, True, None)] + [
            (f"every {k}", "float32", int(k), True, None) for k in a.every.split(",") if k] + [
            (f"held {k}", "float32", None, True, k) for k in helds]:
        doc, model, q = run_config(a.model, cmds, dtype, every, use, held,
                                   keep=bool(helds) and (held is not None or name == "float32"))
        configs[name] = doc
        if name == "float32":
            model32, queries = model, q
        elif held is not None:
            doc["held_error"] = held_error(doc, configs["float32"])
        print(name, doc["step_cpu_ms"], doc.get("held_error", ""), flush=True)
    for doc in configs.values():
        doc.pop("_published", None)
        doc.pop("_states", None)
    est = model32.estimator
    sizes = np.diff(est.offsets_)
    packed = sizes * (sizes + 1) / 2 * 4 / 1e6
    doc = {"command": " ".join([".venv/bin/python", "benchmarks/sim_node_20x/std_tail/std_tail.py"]
                               + sys.argv[1:]),
           "code": subprocess.run(["git", "-C", str(R.ROOT), "describe", "--always", "--dirty"],
                                  capture_output=True, text=True).stdout.strip(),
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "steps": a.steps,
           "configs": configs,
           "local_std": local_std(model32, queries, [int(m) for m in a.local_m.split(",") if m]),
           "factors": {"clusters": int(len(sizes)), "rows_median": int(np.median(sizes)),
                       "rows_max": int(sizes.max()),
                       "packed_mb_median": float(np.median(packed)),
                       "packed_mb_max": float(packed.max()),
                       "packed_mb_total": float(packed.sum()),
                       "square64_mb_total": float((sizes.astype(float) ** 2 * 8).sum() / 1e6)},
           "bandwidth_gbs": bandwidth_gbs()}
    Path(a.out + ".json").write_text(json.dumps(doc, indent=1))
    Path(a.out + ".md").write_text(markdown(doc))
    print(markdown(doc))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
