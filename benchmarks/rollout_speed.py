"""Rollout speed: all TestPool moves x 399 steps, batched, as a multiple of real time.

Usage (from the repo root, in the venv; models trained beforehand with ``littledog-mlsim train``):

    OPENBLAS_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/rollout_speed.py \\
        --data bags/default --lgpr /tmp/pstudy2/lgpr_delta --lr /tmp/pstudy2/lr_delta

What is timed: ``rollout.simulate.rollout_moves(model, moves, projection)`` over every TestPool
move (66 moves of 399 steps on ``bags/default``, one batch: one model call and one projection
per step), wall clock (``time.perf_counter``). Real time = sum of the moves' steps x 10 ms
(66 x 3.99 s = 263.34 s); the factor is real time / wall. Configurations: LGPR + alpha-PROJ
(``--alpha``), LGPR + none, LGPR + BOUND, LR + alpha-PROJ. Each configuration is warmed up once
(``model.prepare()``, ``projection.nn.prepare()`` and one untimed rollout: the one-time index
build and first-touch costs are left out), then timed ``--repeats`` times in rounds (one rollout
of each configuration per round, the order reversed every other round, so that load from other
jobs on the shared cores hits all alike). Reported: median and min wall, median factor, and the
1-min load average before and after each round.

``--profile``: also a cProfile of one LGPR + alpha-PROJ rollout (top functions by own time).

``--prototype-lgpr-fastpath``: also LGPR + alpha-PROJ and LGPR + none with a prototype of a
leaner per-cluster mean for rollout steps (``prototype_fast_local`` below, bound to a second copy
of the LGPR model only; ``littledog_mlsim/models`` is not changed): for a cluster with one shared
kernel and at most ``gp._FEW_QUERIES`` queries without variance, the same arithmetic as
``gp.cross_kernel`` + ``gp_predict`` in the same order, minus the per-call re-derivation of the
kernels (``_unique_kernels``, ``broadcast_to``, column lists, ``1 / l^2``). Its predictions are
checked to be bit-identical to the unpatched model's.

``--prototype-lgpr-gemm``: also the same two with a second prototype (``prototype_gemm_local``):
the kernel rows of a rollout step by one GEMM per cluster on the cluster's inputs centred and
scaled once (``|a|^2 + |b|^2 - 2 a.b``, as ``gp.kernel_cross`` does for large batches) instead of
the exact per-dimension differences. Not bit-identical: reported with the largest state
difference to the unpatched rollout and the change of the mean final (x, y) error.

Writes ``--out``.json and ``--out``.md (default ``benchmarks/rollout_speed``).
"""
from __future__ import annotations

import argparse
import cProfile
import io
import json
import os
import platform
import pstats
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.models.onestep import OneStepModel  # noqa: E402
from littledog_mlsim.rollout.metrics import rollout_metrics  # noqa: E402
from littledog_mlsim.rollout.simulate import prepare_test_moves, rollout_moves  # noqa: E402


def prototype_fast_local(est):
    """Bind the prototype per-cluster mean to the LGPR estimator ``est`` (instance only)."""
    import types

    from littledog_mlsim.models import gp as G
    orig = type(est)._local
    cache: dict[int, tuple | None] = {}

    def fast_local(self, c, Xq, want_var):
        ns = Xq.shape[0]
        if want_var or ns > G._FEW_QUERIES:
            return orig(self, c, Xq, want_var)
        if c not in cache:
            kernels, _ = self._kernels[c]
            sf2, ls, _ = G.unpack_log_params(kernels)
            cache[c] = (1.0 / ls**2, sf2) if kernels.shape[0] == 1 else None
        k = cache[c]
        if k is None:
            return orig(self, c, Xq, want_var)
        inv_l2, sf2 = k
        X, alpha = self._X[c], self._alpha[c]
        n, d = X.shape
        mean = np.empty((ns, alpha.shape[1]))
        for sl in G._blocks(ns, n * d):                  # as cross_kernel (q = 1)
            diff = Xq[sl, None, :] - X[None, :, :]
            np.square(diff, out=diff)
            E = diff.reshape(-1, d) @ inv_l2.T
            E *= -0.5
            np.exp(E, out=E)
            E *= sf2
            mean[sl] = E.reshape(-1, n) @ alpha          # as gp_predict: Ks[:, :, 0] @ alpha
        mean *= self.y_std_[c]
        mean += self.y_mean_[c]
        return mean, None

    est._local = types.MethodType(fast_local, est)
    return est


def prototype_gemm_local(est):
    """Bind the GEMM-kernel-row prototype to the LGPR estimator ``est`` (instance only)."""
    import types

    from littledog_mlsim.models import gp as G
    orig = type(est)._local
    cache: dict[int, tuple | None] = {}

    def gemm_local(self, c, Xq, want_var):
        if want_var or Xq.shape[0] > G._FEW_QUERIES:
            return orig(self, c, Xq, want_var)
        if c not in cache:
            kernels, _ = self._kernels[c]
            if kernels.shape[0] != 1:
                cache[c] = None
            else:
                sf2, ls, _ = G.unpack_log_params(kernels)
                X = self._X[c]
                shift = X.mean(axis=0)
                Z = (X - shift) / ls[0]
                cache[c] = (shift, ls[0], np.ascontiguousarray(Z.T),
                            np.einsum("ij,ij->i", Z, Z), float(sf2[0]))
        k = cache[c]
        if k is None:
            return orig(self, c, Xq, want_var)
        shift, ls, ZT, zz, sf2 = k
        A = (Xq - shift) / ls
        D = A @ ZT
        D *= -2.0
        D += np.einsum("ij,ij->i", A, A)[:, None]
        D += zz
        np.maximum(D, 0.0, out=D)
        D *= -0.5
        np.exp(D, out=D)
        D *= sf2
        mean = D @ self._alpha[c]
        mean *= self.y_std_[c]
        mean += self.y_mean_[c]
        return mean, None

    est._local = types.MethodType(gemm_local, est)
    return est


def git_state() -> str:
    """HEAD commit and the modified tracked files (the code measured)."""
    import subprocess
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                              capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "diff", "--name-only", "HEAD"], cwd=ROOT,
                               capture_output=True, text=True).stdout.split()
    except OSError:
        return "unknown"
    return head + (f" + uncommitted changes to {', '.join(dirty)}" if dirty else "")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, type=Path)
    ap.add_argument("--lgpr", required=True, help="LGPR model directory")
    ap.add_argument("--lr", required=True, help="LR model directory")
    ap.add_argument("--alpha", type=float, default=0.5)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--prototype-lgpr-fastpath", action="store_true")
    ap.add_argument("--prototype-lgpr-gemm", action="store_true")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "rollout_speed")
    a = ap.parse_args(argv)

    moves = prepare_test_moves(load_moves(a.data, split="test"))
    robot_s = sum(m.n_steps for m in moves) * 0.01
    lgpr, lr = OneStepModel.load(a.lgpr), OneStepModel.load(a.lr)
    configs = {
        f"LGPR + alpha {a.alpha:g}": (lgpr, lgpr.projection("alpha", alpha=a.alpha)),
        "LGPR + none": (lgpr, lgpr.projection("none")),
        "LGPR + bound": (lgpr, lgpr.projection("bound")),
        f"LR + alpha {a.alpha:g}": (lr, lr.projection("alpha", alpha=a.alpha)),
    }
    protos = []
    if a.prototype_lgpr_fastpath:
        protos.append(("prototype fast path", prototype_fast_local))
    if a.prototype_lgpr_gemm:
        protos.append(("prototype GEMM rows", prototype_gemm_local))
    for label, bind in protos:
        pm = OneStepModel.load(a.lgpr)
        bind(pm.estimator)
        configs[f"LGPR + alpha {a.alpha:g}, {label}"] = (pm, pm.projection("alpha", alpha=a.alpha))
        configs[f"LGPR + none, {label}"] = (pm, pm.projection("none"))
    first: dict[str, np.ndarray] = {}
    for name, (model, proj) in configs.items():
        model.prepare()
        if hasattr(proj, "nn"):
            proj.nn.prepare()
        first[name] = np.array(rollout_moves(model, moves, proj))     # warm-up, untimed
    prototypes = {}
    for label, _ in protos:
        entry = {}
        for base in (f"LGPR + alpha {a.alpha:g}", "LGPR + none"):
            p, b = first[f"{base}, {label}"], first[base]
            e_p = rollout_metrics(moves, list(p))["final_xy_error_m"]
            e_b = rollout_metrics(moves, list(b))["final_xy_error_m"]
            entry[base] = {"bit_identical": bool(np.array_equal(p, b)),
                           "max_abs_state_diff": float(np.nanmax(np.abs(p - b))),
                           "final_xy_error_m": e_p, "final_xy_error_m_unpatched": e_b}
        prototypes[label] = entry
        print(f"{label}: {entry}", flush=True)
    walls: dict[str, list[float]] = {name: [] for name in configs}
    loads = []
    same = {name: True for name in configs}
    names = list(configs)
    for r in range(a.repeats):
        before = os.getloadavg()[0]
        for name in (names if r % 2 == 0 else names[::-1]):
            model, proj = configs[name]
            t0 = time.perf_counter()
            pred = rollout_moves(model, moves, proj)
            walls[name].append(time.perf_counter() - t0)
            same[name] &= bool(np.array_equal(np.array(pred), first[name]))
        loads.append((before, os.getloadavg()[0]))
        print(f"round {r + 1}: " + ", ".join(f"{n} {walls[n][-1]:.3f} s" for n in names)
              + f" (load {loads[-1][0]:.2f} -> {loads[-1][1]:.2f})", flush=True)
    res = {
        "command": " ".join(["benchmarks/rollout_speed.py", *(argv or sys.argv[1:])]),
        "git": git_state(),
        "python": platform.python_version(), "numpy": np.__version__,
        "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
        "date": time.strftime("%Y-%m-%d %H:%M"), "n_moves": len(moves),
        "n_steps": [int(m.n_steps) for m in moves][:1], "robot_time_s": robot_s,
        "load_avg_1min_per_round": loads,
        "prototypes": prototypes,
        "configs": {n: {"walls_s": w, "median_wall_s": float(np.median(w)),
                        "min_wall_s": float(np.min(w)),
                        "realtime_factor_median": robot_s / float(np.median(w)),
                        "realtime_factor_best": robot_s / float(np.min(w)),
                        "identical_predictions_every_repeat": same[n]}
                    for n, w in walls.items()},
    }
    if a.profile:
        model, proj = configs[names[0]]
        pr = cProfile.Profile()
        pr.enable()
        rollout_moves(model, moves, proj)
        pr.disable()
        buf = io.StringIO()
        pstats.Stats(pr, stream=buf).sort_stats("tottime").print_stats(18)
        res["profile"] = buf.getvalue()
    a.out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{a.out}.json").write_text(json.dumps(res, indent=1) + "\n")
    Path(f"{a.out}.md").write_text(report(res))
    for n, c in res["configs"].items():
        print(f"{n:<18} median {c['median_wall_s']:.3f} s = {c['realtime_factor_median']:.0f}x "
              f"real time (best {c['realtime_factor_best']:.0f}x)")
    print(f"wrote {a.out}.json and .md")
    return 0


def report(res: dict) -> str:
    lines = ["# Rollout speed (generated by benchmarks/rollout_speed.py)", "",
             f"Command: `OPENBLAS_NUM_THREADS={res['openblas_num_threads']} nice -n 19 "
             f".venv/bin/python {res['command']}`", "",
             f"Code: {res['git']}. Python {res['python']}, NumPy {res['numpy']}, {res['date']}, "
             "2 shared cores. "
             f"{res['n_moves']} TestPool moves x {res['n_steps'][0]} steps in one batch "
             f"= {res['robot_time_s']:.2f} s of robot time; factor = robot time / wall. "
             "Warmed up (index built, one untimed rollout), then "
             f"{len(res['load_avg_1min_per_round'])} rounds; 1-min load average before -> "
             "after each round: "
             + ", ".join(f"{b:.2f} -> {e:.2f}" for b, e in res["load_avg_1min_per_round"]) + ".",
             "", "| configuration | median wall [s] | min wall [s] | x real time (median) | "
             "x real time (best) | same predictions every repeat |", "|---|---|---|---|---|---|"]
    for n, c in res["configs"].items():
        lines.append(f"| {n} | {c['median_wall_s']:.3f} | {c['min_wall_s']:.3f} | "
                     f"{c['realtime_factor_median']:.0f} | {c['realtime_factor_best']:.0f} | "
                     f"{c['identical_predictions_every_repeat']} |")
    for label, entry in res.get("prototypes", {}).items():
        lines += ["", f"{label} (a prototype bound in the script, not in the package) vs the "
                  "unpatched LGPR:", ""]
        for base, e in entry.items():
            lines.append(f"- {base}: bit-identical states {e['bit_identical']}, largest state "
                         f"difference {e['max_abs_state_diff']:.3g}, mean final (x,y) error "
                         f"{e['final_xy_error_m']!r} m (unpatched "
                         f"{e['final_xy_error_m_unpatched']!r})")
    if "profile" in res:
        lines += ["", "cProfile of one LGPR + alpha rollout (own time):", "", "```",
                  res["profile"].strip(), "```"]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    raise SystemExit(main())
