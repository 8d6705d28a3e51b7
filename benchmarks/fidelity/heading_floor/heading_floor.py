"""Does more of its own data lower the straight trot's one-step heading floor?

The 60 s straight trot's open-loop gap is a heading error, and LGPR teacher-forced on
pybullet's own states already makes it (``../floor.py``: a d_yaw bias of 1-2 mrad/s on the
paper's model). This study asks how that floor falls with the amount of trot data of the same
kind, and whether the model reads the turn the set-points command.

Data: one dataset of forward trots only (``record --types F --moves-per-type N``), every move
of it (TrainPool and TestPool) a candidate training move. For each replicate r the moves are
shuffled (seed r) and LGPR with the paper's 45 inputs and the trainer's defaults is fitted on
the first k of them, for each k of ``--sizes`` (nested subsets). Each model is teacher-forced
on the measured pybullet robot's 60 s straight trot of each of ``--seeds`` (the schedules of
``../fidelity.py``), as ``../floor.py`` does: every step predicted from pybullet's measured
state, the predicted displacements and yaw changes integrated into a path.

Per model and seed: the final yaw gap, the gap over the path, the signed d_yaw bias (mean
predicted minus measured d_yaw per second; also over the first 4 s, a recorded move's length,
and over the rest), pybullet's own mean yaw rate and the model's. Per
size: the medians and worst over seeds and replicates, the RMS bias, and the slope of the
model's mean yaw rate against pybullet's over the seeds (1: the model reads each trot's turn;
0: it predicts one turn whatever the set-points say). ``--long N``: also models fitted on N
straight trots of the test's length that pybullet walks from other seeds (1000 on), per
replicate: data of the test's own kind and length. ``--settled N``: N forward trots of 4 s
each kept after ``--warmup`` s of the same trot (seeds 2000 on), per replicate: the recorded
moves' number and length, started from a settled trot. ``--warm DIR``: a forward-trot dataset
recorded with ``record --types F --warmup S`` (each move after S s of the same trot);
``--warm-sizes N``: models fitted on N of its moves, and ``--mixed N``: on N/2 moves of
``--data`` (from standing) and N/2 of ``--warm`` (settled), per replicate.

Writes ``--out``.json / .md. The pybullet runs are made once per seed and kept in
``--work`` (``ref_sSEED.npz``).
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parents[1]))
import fidelity as F  # noqa: E402
import floor as FL  # noqa: E402

from _common import command_line, run_record, uptime, write_results  # noqa: E402
from littledog_mlsim.apps.record import after_warmup  # noqa: E402
from littledog_mlsim.control.gait import StreamingTrot  # noqa: E402
from littledog_mlsim.control.schedule import straight_trot_schedule  # noqa: E402
from littledog_mlsim.data.dataset import (integrate_path, load_moves,  # noqa: E402
                                          states_from_recording)
from littledog_mlsim.layout import CONTROL_DT  # noqa: E402
from littledog_mlsim.rotations import quat_to_rpy  # noqa: E402

#: the bias a 60 s straight trot of about 2.5 m may carry for a gap of 2 % of its path
#: (theta L / 2 <= 0.02 L, so theta <= 0.04 rad over 60 s)
TARGET_BIAS = 0.04 / 60.0
#: a recorded move's length [s]: the bias is also split into the trot's first MOVE_S and the rest
MOVE_S = 4.0
#: the first seed of the long trots a model may be trained on (``--long``)
LONG_SEED = 1000
#: the first seed of the settled trots a model may be trained on (``--settled``)
SETTLED_SEED = 2000


def reference(args) -> str:
    """Run pybullet's straight trot of one seed and keep what teacher forcing needs."""
    seed, duration, work = args
    path = Path(work) / f"ref_s{seed}.npz"
    if path.exists():
        return str(path)
    rng = np.random.default_rng(seed)
    sched = straight_trot_schedule(duration, rng)
    U = StreamingTrot(phase=sched.phase).commands(sched.commands)
    ref = FL._pybullet_run(seed, U, None)
    np.savez(path.with_suffix(".tmp.npz"), U=U, states=states_from_recording(ref),
             position=ref.position, orientation=ref.orientation)
    os.replace(path.with_suffix(".tmp.npz"), path)
    return str(path)


def _unwrap_yaw(orientation: np.ndarray) -> np.ndarray:
    return np.unwrap(quat_to_rpy(orientation)[:, 2])


def teacher(model, ref: dict) -> dict:
    """One model teacher-forced on one reference run (``floor.floor_task``'s LGPR part)."""
    U, states = ref["U"], ref["states"]
    pos, ori = ref["position"], ref["orientation"]
    ref_xy, ref_yaw = pos[2:, :2], quat_to_rpy(ori[2:])[:, 2]
    path = F.path_length(ref_xy)
    rpy1 = quat_to_rpy(ori[1])
    pred = model.predict(np.hstack([states[:-1], U]))
    path_tf = integrate_path(pred, pos[1, 0], pos[1, 1], rpy1[2], rpy1[:2])
    out = FL._gap(path_tf[:, :2], path_tf[:, 2], ref_xy, ref_yaw, path)
    err = pred - states[1:]
    duration = U.shape[0] * CONTROL_DT
    yaw = _unwrap_yaw(ori[1:])
    out["path_m"] = path
    out["dyaw_bias_per_s"] = float(err[:, F.S.dyaw].mean() / CONTROL_DT)
    k = int(round(MOVE_S / CONTROL_DT))
    out["dyaw_bias_first_per_s"] = float(err[:k, F.S.dyaw].mean() / CONTROL_DT)
    out["dyaw_bias_after_per_s"] = float(err[k:, F.S.dyaw].mean() / CONTROL_DT)
    out["pybullet_yaw_rate"] = float((yaw[-1] - yaw[0]) / duration)
    out["model_yaw_rate"] = float(pred[:, F.S.dyaw].sum() / duration)
    return out


def _fit_and_force(chosen: list, kind: str, k: int, r: int, refs) -> dict:
    """Fit LGPR on the moves ``chosen``; teacher-force it on every seed's pybullet run."""
    from littledog_mlsim.models.train import fit_onestep
    t0 = time.perf_counter()
    model = fit_onestep(chosen, "lgpr", random_state=0, gate=False)
    fit_s = time.perf_counter() - t0
    runs = []
    for seed, p in refs:
        with np.load(p) as z:
            ref = {name: z[name] for name in z.files}
        runs.append({"seed": seed, **teacher(model, ref)})
    return {"kind": kind, "moves": k, "replicate": r,
            "samples": int(sum(m.n_steps - 1 for m in chosen)), "fit_s": round(fit_s, 1),
            "runs": runs}


def fit_and_force(args) -> dict:
    """Fit LGPR on the first ``k`` moves of replicate ``r``'s order; teacher-force every seed."""
    data, k, r, refs = args
    moves = load_moves(data, "all")
    order = np.random.default_rng(r).permutation(len(moves))
    return _fit_and_force([moves[i] for i in order[:k]], "4 s moves", k, r, refs)


def datasets_fit_and_force(args) -> dict:
    """Fit LGPR on the first ``k // len(datas)`` moves of replicate ``r``'s order of each
    dataset of ``datas``; teacher-force every seed."""
    datas, k, r, refs, kind = args
    chosen = []
    for data in datas:
        moves = load_moves(data, "all")
        order = np.random.default_rng(r).permutation(len(moves))
        chosen += [moves[i] for i in order[:k // len(datas)]]
    return _fit_and_force(chosen, kind, k, r, refs)


def long_fit_and_force(args) -> dict:
    """Fit LGPR on ``k`` straight trots of ``duration`` s walked by pybullet (seeds
    ``LONG_SEED + 100 r`` on, none of them a test seed); teacher-force every seed."""
    k, r, duration, refs = args
    chosen = []
    for i in range(k):
        seed = LONG_SEED + 100 * r + i
        sched = straight_trot_schedule(duration, np.random.default_rng(seed))
        chosen.append(FL._pybullet_run(seed, StreamingTrot(phase=sched.phase).commands(
            sched.commands), None))
    return _fit_and_force(chosen, f"{duration:g} s trots", k, r, refs)


def settled_fit_and_force(args) -> dict:
    """Fit LGPR on ``k`` forward trots of ``MOVE_S`` s, each kept after ``warmup`` s of the
    same trot (pybullet, seeds ``SETTLED_SEED + 100 r`` on): moves as many and as short as the
    recorded ones, but starting from a settled trot; teacher-force every seed."""
    k, r, warmup, refs = args
    chosen = []
    for i in range(k):
        seed = SETTLED_SEED + 100 * r + i
        sched = straight_trot_schedule(warmup + MOVE_S, np.random.default_rng(seed))
        rec = FL._pybullet_run(seed, StreamingTrot(phase=sched.phase).commands(
            sched.commands), None)
        chosen.append(after_warmup(rec, int(round(warmup / CONTROL_DT))))
    return _fit_and_force(chosen, f"{MOVE_S:g} s after {warmup:g} s", k, r, refs)


def _slope(x: list[float], y: list[float]) -> float:
    x, y = np.asarray(x), np.asarray(y)
    xc = x - x.mean()
    return float(xc @ (y - y.mean()) / (xc @ xc)) if xc @ xc > 0 else float("nan")


def summarise(fits: list[dict]) -> list[dict]:
    rows = []
    for kind, k in sorted({(f["kind"], f["moves"]) for f in fits}):
        group = [f for f in fits if f["kind"] == kind and f["moves"] == k]
        runs = [(f["replicate"], r) for f in group for r in f["runs"]]
        bias = np.array([r["dyaw_bias_per_s"] for _, r in runs])
        gap = np.array([r["err_per_m"] for _, r in runs])
        yaw = np.array([r["final_yaw_err_rad"] for _, r in runs])
        slopes = []
        for rep in sorted({rep for rep, _ in runs}):
            rr = [r for q, r in runs if q == rep]
            slopes.append(_slope([r["pybullet_yaw_rate"] for r in rr],
                                 [r["model_yaw_rate"] for r in rr]))
        rows.append({"kind": kind, "moves": k, "n_runs": len(runs),
                     "samples": int(np.median([f["samples"] for f in group])),
                     "fit_s": float(np.median([f["fit_s"] for f in group])),
                     "bias_rms_mrad_s": float(1e3 * math.sqrt(np.mean(bias ** 2))),
                     "bias_abs_median_mrad_s": float(1e3 * np.median(np.abs(bias))),
                     "gap_median": float(np.median(gap)), "gap_worst": float(gap.max()),
                     "yaw_median_rad": float(np.median(yaw)),
                     "slope_median": float(np.median(slopes)), "slopes": slopes,
                     "within_target": int(np.sum(np.abs(bias) <= TARGET_BIAS))})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="a forward-trot dataset")
    ap.add_argument("--work", type=Path, required=True, help="scratch for the pybullet runs")
    ap.add_argument("--sizes", nargs="+", type=int, default=[15, 30, 60, 120])
    ap.add_argument("--replicates", type=int, default=3)
    ap.add_argument("--seeds", nargs="+", type=int, default=list(range(8)))
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--long", nargs="*", type=int, default=[],
                    help="also fit on this many straight trots of --duration each (pybullet, "
                         "seeds from 1000), per replicate")
    ap.add_argument("--settled", nargs="*", type=int, default=[],
                    help="also fit on this many 4 s forward trots each cut after --warmup s of "
                         "the same trot (pybullet, seeds from 2000), per replicate")
    ap.add_argument("--warmup", type=float, default=10.0)
    ap.add_argument("--warm", type=Path, default=None,
                    help="a forward-trot dataset recorded with record --warmup")
    ap.add_argument("--warm-sizes", nargs="*", type=int, default=[],
                    help="also fit on this many moves of --warm, per replicate")
    ap.add_argument("--mixed", nargs="*", type=int, default=[],
                    help="also fit on half this many moves of --data and half of --warm")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=HERE / "heading_floor")
    a = ap.parse_args(argv)
    a.work.mkdir(parents=True, exist_ok=True)
    n_moves = len(load_moves(a.data, "all"))
    if max(a.sizes) > n_moves:
        print(f"error: --sizes asks for {max(a.sizes)} moves; {a.data} holds {n_moves}",
              file=sys.stderr)
        return 2
    if (a.warm_sizes or a.mixed) and a.warm is None:
        print("error: --warm-sizes and --mixed need --warm", file=sys.stderr)
        return 2
    if a.warm is not None:
        n_warm = len(load_moves(a.warm, "all"))
        need = max(a.warm_sizes + [k // 2 for k in a.mixed], default=0)
        if need > n_warm or max([k // 2 for k in a.mixed], default=0) > n_moves:
            print(f"error: --warm-sizes/--mixed ask for more moves than {a.warm} ({n_warm}) "
                  f"or {a.data} ({n_moves}) hold", file=sys.stderr)
            return 2
    load_before, t0 = uptime(), time.time()
    with ProcessPoolExecutor(max_workers=a.workers) as ex:
        paths = list(ex.map(reference, [(s, a.duration, str(a.work)) for s in a.seeds]))
        refs = list(zip(a.seeds, paths))
        jobs = [(str(a.data), k, r, refs) for k in sorted(a.sizes, reverse=True)
                for r in range(a.replicates)]
        fits = list(ex.map(fit_and_force, jobs))
        fits += list(ex.map(long_fit_and_force, [(k, r, a.duration, refs) for k in a.long
                                                 for r in range(a.replicates)]))
        fits += list(ex.map(settled_fit_and_force, [(k, r, a.warmup, refs) for k in a.settled
                                                    for r in range(a.replicates)]))
        fits += list(ex.map(datasets_fit_and_force, [
            ([str(a.warm)], k, r, refs, "4 s moves after record --warmup")
            for k in a.warm_sizes for r in range(a.replicates)] + [
            ([str(a.data), str(a.warm)], k, r, refs, "half from standing, half after --warmup")
            for k in a.mixed for r in range(a.replicates)]))
    wall = time.time() - t0
    rows = summarise(fits)
    doc = {**run_record("fidelity/heading_floor/heading_floor.py", sys.argv[1:]),
           "wall_s": round(wall, 1), "load_before": load_before, "load_after": uptime(),
           "dataset_moves": n_moves, "target_bias_rad_s": TARGET_BIAS,
           "summary": rows, "fits": fits}
    lines = [f"# The straight trot's one-step heading floor against the amount of trot data "
             f"({a.duration:g} s, seeds {a.seeds})", "", command_line(doc), "",
             f"Code: {doc['git']}; {doc['date']} UTC; wall {wall:.0f} s.  ",
             f"Load: before `{load_before}`, after `{doc['load_after']}`.", "",
             f"LGPR (the paper's 45 inputs) on the first k of {n_moves} forward trots, "
             f"{a.replicates} shuffles; teacher-forced on pybullet's straight trot of each "
             f"seed. The 2 % target needs |bias| <= {1e3 * TARGET_BIAS:.2f} mrad/s.", "",
             "| data | moves | samples | fit [s] | d_yaw bias RMS [mrad/s] | abs bias median | "
             "runs within the 2 % bias | gap / path, median (worst) | final yaw gap, median "
             "[rad] | slope of the model's yaw rate on pybullet's (median over shuffles) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['kind']} | {r['moves']} | {r['samples']} | {r['fit_s']:.0f} | "
            f"{r['bias_rms_mrad_s']:.2f} | "
            f"{r['bias_abs_median_mrad_s']:.2f} | {r['within_target']} of {r['n_runs']} | "
            f"{100 * r['gap_median']:.1f} % ({100 * r['gap_worst']:.1f} %) | "
            f"{r['yaw_median_rad']:.3f} | {r['slope_median']:.2f} "
            f"({', '.join(f'{s:.2f}' for s in r['slopes'])}) |")
    for kind in sorted({f["kind"] for f in fits}, reverse=True):
        k_max = max(f["moves"] for f in fits if f["kind"] == kind)
        lines += ["", f"Per seed, {kind}, {k_max} of them, median over the replicates [mrad/s]: "
                  f"the d_yaw bias (over the first {MOVE_S:g} s / after them).", "",
                  "| seed | bias | first | after | gap / path |", "|---|---|---|---|---|"]
        for seed in a.seeds:
            rr = [r for f in fits if f["kind"] == kind and f["moves"] == k_max
                  for r in f["runs"] if r["seed"] == seed]
            med = lambda key: float(np.median([r[key] for r in rr]))  # noqa: E731
            lines.append(f"| {seed} | {1e3 * med('dyaw_bias_per_s'):.1f} | "
                         f"{1e3 * med('dyaw_bias_first_per_s'):.1f} | "
                         f"{1e3 * med('dyaw_bias_after_per_s'):.1f} | "
                         f"{100 * med('err_per_m'):.1f} % |")
    pyb = {run["seed"]: run["pybullet_yaw_rate"] for run in fits[0]["runs"]}
    lines += ["", "Pybullet's mean yaw rate per seed [mrad/s]: "
              + ", ".join(f"{s}: {1e3 * v:.1f}" for s, v in sorted(pyb.items())) + "."]
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
