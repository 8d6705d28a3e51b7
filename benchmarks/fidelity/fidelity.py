"""Fidelity beyond the paper's 4 s: long open-loop horizons, a 10-minute soak and closed loop.

The learned simulator is stepped exactly as ``sim_node`` steps it (``rollout.learned_sim.
LearnedSimulator.step``: model prediction, projection, pose integration) and compared with the
``measured`` pybullet robot (the robot the data was recorded from) fed the same commands (open
loop) or driven by the same controller (closed loop, ``littledog_mlsim.control``).

Start: the pybullet robot stands settled at home (``LittleDogSim.reset(seed=seed)``; the seed is
that of the sensor noise) and holds HOME_POSE for one step; the learned simulator starts from the
state s_1 those two measurements define (``states_from_recording``) and from the measured pose.
From there both get the same commands.

Sub-commands (each writes ``<name>.json``, ``<name>.md`` and figures in this directory):

- ``open-loop``: per seed, a gait-switching trot (a new move type every 4 s, every parameter
  blended over 0.5 s by smoothstep, ``control.schedule.gait_switch_schedule``) and a straight
  forward trot (``straight_trot_schedule``), ``--duration`` s each.
- ``soak``: one gait-switching schedule of ``--duration`` s (600 = 10 minutes).
- ``closed-loop``: per seed, a waypoint follower and a PI body-velocity tracker
  (``control.controllers``), ``--duration`` s each, in every simulator; ``--controllers
  trajectory`` adds the trajectory tracker (a timed curved reference with sideways motion,
  ``trajectory_reference``), written after the levers' first table and not tuned on.

Configurations (``--configs``): ``lgpr-none``, ``lgpr-alpha`` (plain alpha-PROJ 0.5),
``lgpr-gated`` (alpha 0.5, radius = the ``--quantile`` of the TrainPool's leave-move-out
nearest-neighbour distances, ``evaluate.trainpool_radius``), ``lgpr-bound``, ``lr-none``,
``lr-gated``.

Metrics:
- (x, y) error: distance between the learned and the pybullet body position at the same step.
- path: length of the pybullet robot's (x, y) path sampled every 0.5 s (sampling coarser than
  the mocap noise and the stride's sway, which would otherwise add length that is not travel).
- error per metre: final (x, y) error / path; the targets are 2 % (0.02 m per m).
- first implausible state of the learned robot: the first step with a non-finite value, body
  height outside [min, max] of the TrainPool's z_w, or |roll| or |pitch| > 0.5 rad (the same
  test is applied to the pybullet robot's measured states as a reference).
- distance from the data: alpha-PROJ's normalised distance of a state to its nearest TrainPool
  state (every 5th step), against the gate radius.

Run from the repo root (see README.md in this directory for the exact commands).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from _common import command_line, run_record, write_results  # noqa: E402
from littledog_mlsim.control.controllers import (  # noqa: E402
    Observation, TrajectoryTracker, VelocityTracker, WaypointFollower, reference_trajectory)
from littledog_mlsim.control.gait import StreamingTrot  # noqa: E402
from littledog_mlsim.control.schedule import (  # noqa: E402
    blend, gait_switch_schedule, straight_trot_schedule)
from littledog_mlsim.control.gait import TrotCommand  # noqa: E402
from littledog_mlsim.data.dataset import states_from_recording  # noqa: E402
from littledog_mlsim.data.recording import MoveRecording  # noqa: E402
from littledog_mlsim.layout import CONTROL_DT, CONTROL_DT_NS, HOME_POSE, N_STATE, S  # noqa: E402
from littledog_mlsim.rotations import quat_to_rpy  # noqa: E402

CONFIGS = ("lgpr-none", "lgpr-alpha", "lgpr-gated", "lgpr-bound", "lr-none", "lr-gated")
LABEL = {"lgpr-none": "LGPR none", "lgpr-alpha": "LGPR alpha 0.5 (plain)",
         "lgpr-gated": "LGPR gated alpha 0.5", "lgpr-bound": "LGPR BOUND",
         "lr-none": "LR none", "lr-gated": "LR gated alpha 0.5", "pybullet": "pybullet"}
PATH_SAMPLE = 50          # steps between the path samples (0.5 s)
DIST_EVERY = 5            # steps between the nearest-neighbour distances
TILT_LIMIT = 0.5          # rad
STATE_GROUPS = {"z_w": S.z_w, "d_b": S.d_b, "roll,pitch": S.roll_pitch, "d_rpy": S.d_rpy,
                "q": S.q, "dq": S.dq}


# ---------------------------------------------------------------------------------------------
# worker-side model cache (each process loads the models once)

_MODELS: dict = {}


def _setup(models: dict, radius: float) -> None:
    _MODELS.clear()
    _MODELS["paths"], _MODELS["radius"] = models, radius


def _model(name: str):
    if name not in _MODELS:
        from littledog_mlsim.models.onestep import OneStepModel
        _MODELS[name] = OneStepModel.load(_MODELS["paths"][name])
    return _MODELS[name]


def _config(cfg: str):
    """(model, projection) of a configuration name."""
    method, kind = cfg.split("-")
    model = _model(method)
    if kind == "none":
        return model, model.projection("none")
    if kind == "bound":
        return model, model.projection("bound")
    if kind == "alpha":
        return model, model.projection("alpha", alpha=0.5)
    if kind == "gated":
        return model, model.projection("alpha", alpha=0.5, radius=_MODELS["radius"])
    raise ValueError(f"unknown configuration {cfg!r}")


def _distance_model():
    """An alpha projection over the TrainPool states, for distances from the data."""
    if "dist" not in _MODELS:
        _MODELS["dist"] = _model("lgpr").projection("alpha", alpha=0.5)
    return _MODELS["dist"]


# ---------------------------------------------------------------------------------------------
# the two robots


def _pybullet():
    if "pyb" not in _MODELS:
        from littledog_mlsim.robot.sim import LittleDogSim
        _MODELS["pyb"] = LittleDogSim("measured")
    return _MODELS["pyb"]


def _recording(obs: list[dict], cmd: np.ndarray) -> MoveRecording:
    n = len(obs)
    fields = ("q", "dq", "position", "orientation", "linear_velocity", "angular_velocity")
    return MoveRecording(name="F_00", move_type="F",
                         stamps_ns=CONTROL_DT_NS * np.arange(n, dtype=np.int64),
                         cmd=np.asarray(cmd, dtype=np.float64),
                         **{f: np.array([o[f] for o in obs]) for f in fields})


def start(seed: int) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """Reset the pybullet robot (sensor seed), hold HOME_POSE one step; the learned simulator's
    s_0 (33,) and pose (x, y, yaw) from those two measurements, and the measurements."""
    sim = _pybullet()
    obs = [sim.reset(seed=seed)]
    obs.append(sim.step(HOME_POSE))
    s0 = states_from_recording(_recording(obs, HOME_POSE[None]))[0]
    rpy = quat_to_rpy(obs[1]["orientation"])
    return s0, np.array([obs[1]["position"][0], obs[1]["position"][1], rpy[2]]), obs


class _Trace:
    """Per-step record of one robot: position, orientation, state."""

    def __init__(self, n: int) -> None:
        self.position = np.full((n, 3), np.nan)
        self.orientation = np.full((n, 4), np.nan)
        self.state = np.full((n, N_STATE), np.nan)
        self.n = 0

    def arrays(self) -> dict:
        return {"position": self.position, "yaw": quat_to_rpy(self.orientation)[:, 2],
                "state": self.state, "steps_done": self.n}


def _learned_sim(cfg: str, s0: np.ndarray, pose0: np.ndarray):
    from littledog_mlsim.rollout.learned_sim import LearnedSimulator
    model, proj = _config(cfg)
    return LearnedSimulator(model, proj, s0, pose0, use_variance=False)


def run_open_loop(cfg: str, seed: int, commands: np.ndarray) -> dict:
    """One robot (``cfg`` or ``"pybullet"``) under open-loop joint commands (n, 12)."""
    t0 = time.process_time()
    n = commands.shape[0]
    tr = _Trace(n)
    s0, pose0, obs = start(seed)
    if cfg == "pybullet":
        sim = _pybullet()
        for u in commands:
            obs.append(sim.step(u))
        rec = _recording(obs, np.vstack([HOME_POSE[None], commands]))
        tr.position = rec.position[2:]
        tr.orientation = rec.orientation[2:]
        tr.state = states_from_recording(rec)[1:]
        tr.n = n
    else:
        sim = _learned_sim(cfg, s0, pose0)
        with np.errstate(all="ignore"):
            for k, u in enumerate(commands):
                if not sim.step(u):
                    break
                tr.position[k], tr.orientation[k], tr.state[k] = (sim.position, sim.orientation,
                                                                  sim.state)
                tr.n = k + 1
    out = tr.arrays()
    out["cpu_s"] = time.process_time() - t0
    return out


def _controller(kind: str, seed: int, n: int):
    rng = np.random.default_rng(1000 + seed)
    if kind == "waypoints":
        heading, p, pts = 0.0, np.zeros(2), []
        for i in range(4):
            heading += 0.0 if i == 0 else rng.uniform(-0.9, 0.9)
            p = p + 0.4 * np.array([np.cos(heading), np.sin(heading)])
            pts.append(p.copy())
        return WaypointFollower(np.array(pts))
    if kind == "velocity":
        choices = np.array([[0.045, 0.0, 0.0], [0.04, 0.0, 0.2], [0.04, 0.0, -0.2],
                            [0.0, 0.025, 0.0], [0.0, -0.025, 0.0], [-0.04, 0.0, 0.0],
                            [0.03, 0.02, 0.0]])
        seg = 500
        rows, prev = [], np.zeros(3)
        for i in range(int(np.ceil(n / seg))):
            nxt = choices[rng.integers(len(choices))]
            b = blend(TrotCommand(*prev), TrotCommand(*nxt), 50)[:, :3]
            rows += [b, np.tile(nxt, (seg - 50, 1))]
            prev = nxt
        return VelocityTracker(np.vstack(rows)[:n])
    if kind == "trajectory":
        return TrajectoryTracker(*trajectory_reference(np.random.default_rng(3000 + seed), n))
    raise ValueError(kind)


def trajectory_reference(rng: np.random.Generator, n: int, segment: int = 800,
                         join: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """(poses (n, 3), body velocity (n, 3)) of the trajectory tracker's reference: 8 s
    segments, each with a forward speed from 0.03-0.05 m/s, a sideways speed within +-0.015 m/s
    and a yaw rate within +-0.15 rad/s, joined by smoothstep over 1 s, from rest. The speeds
    are those the soft-servo robot reaches (about 40 % of a trot's commanded speed)."""
    rows, prev = [], np.zeros(3)
    for _ in range(int(np.ceil(n / segment))):
        nxt = np.array([rng.uniform(0.03, 0.05), rng.uniform(-0.015, 0.015),
                        rng.uniform(-0.15, 0.15)])
        b = blend(TrotCommand(*prev), TrotCommand(*nxt), join)[:, :3]
        rows += [b, np.tile(nxt, (segment - join, 1))]
        prev = nxt
    v = np.vstack(rows)[:n]
    return reference_trajectory(v), v


def run_closed_loop(cfg: str, seed: int, kind: str, n: int) -> dict:
    """One robot (``cfg`` or ``"pybullet"``) driven by controller ``kind`` for n steps."""
    t0 = time.process_time()
    ctrl = _controller(kind, seed, n)
    gait = StreamingTrot(smoothing_time=0.3)
    tr = _Trace(n)
    cmds = np.full((n, 5), np.nan)
    est = np.full((n, 3), np.nan)
    s0, pose0, obs = start(seed)
    if cfg == "pybullet":
        sim = _pybullet()
        o = Observation.from_mapping(obs[-1])
        us = []
        for k in range(n):
            c = ctrl.command(o)
            u = gait.step(c)
            us.append(u)
            obs.append(sim.step(u))
            o = Observation.from_mapping(obs[-1])
            cmds[k] = c.as_array()
            if kind == "velocity":
                est[k] = ctrl.estimate
        rec = _recording(obs, np.vstack([HOME_POSE[None], us]))
        tr.position, tr.orientation = rec.position[2:], rec.orientation[2:]
        tr.state, tr.n = states_from_recording(rec)[1:], n
    else:
        sim = _learned_sim(cfg, s0, pose0)
        o = Observation.from_learned(sim)
        with np.errstate(all="ignore"):
            for k in range(n):
                c = ctrl.command(o)
                if not sim.step(gait.step(c)) or not sim.outputs_finite():
                    break
                o = Observation.from_learned(sim)
                tr.position[k], tr.orientation[k], tr.state[k] = (sim.position, sim.orientation,
                                                                  sim.state)
                tr.n = k + 1
                cmds[k] = c.as_array()
                if kind == "velocity":
                    est[k] = ctrl.estimate
    out = tr.arrays()
    out.update(commands=cmds, estimate=est, cpu_s=time.process_time() - t0)
    if kind == "waypoints":
        out["reached_steps"] = list(ctrl.reached_steps)
        out["n_waypoints"] = int(ctrl.waypoints.shape[0])
        out["waypoints"] = ctrl.waypoints.tolist()
    elif kind == "trajectory":
        out["reference_path"] = ctrl.poses
    else:
        out["reference"] = ctrl.reference
    return out


def nn_distances(states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every DIST_EVERY-th row's normalised distance to the TrainPool (NaN where not finite) and
    the per-element squared normalised offsets (m, 33) from the nearest TrainPool state."""
    proj = _distance_model()
    s = states[DIST_EVERY - 1::DIST_EVERY]
    d = np.full(s.shape[0], np.nan)
    off = np.full(s.shape, np.nan)
    ok = np.isfinite(s).all(axis=1)
    if ok.any():
        i = proj.nearest(s[ok])
        d[ok] = proj.distance(s[ok], i)
        off[ok] = ((s[ok] - proj.train_states[i]) / proj.scale) ** 2
    return d, off


def _task(args):
    what, cfg, seed, payload = args
    if what == "open":
        out = run_open_loop(cfg, seed, payload)
    else:
        out = run_closed_loop(cfg, seed, payload[0], payload[1])
    out["dist"], out["offset"] = nn_distances(out["state"])
    return out


# ---------------------------------------------------------------------------------------------
# metrics


def path_length(xy: np.ndarray) -> float:
    """Length of the (x, y) path sampled every PATH_SAMPLE steps (finite part)."""
    p = xy[::PATH_SAMPLE]
    p = p[np.isfinite(p).all(axis=1)]
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if len(p) > 1 else 0.0


def first_implausible(state: np.ndarray, n_done: int, n: int, z_range) -> dict:
    """Seconds until the first implausible state, per reason (None = never within the run)."""
    s = state[:n_done]
    def first(mask) -> float | None:
        i = np.flatnonzero(mask)
        return None if i.size == 0 else round(float((i[0] + 1) * CONTROL_DT), 2)
    with np.errstate(invalid="ignore"):
        height = (s[:, S.z_w] < z_range[0]) | (s[:, S.z_w] > z_range[1])
        tilt = (np.abs(s[:, S.roll]) > TILT_LIMIT) | (np.abs(s[:, S.pitch]) > TILT_LIMIT)
    nonfinite = None if n_done >= n else round(float((n_done + 1) * CONTROL_DT), 2)
    out = {"nonfinite_s": nonfinite, "height_s": first(height), "tilt_s": first(tilt)}
    times = [v for v in out.values() if v is not None]
    out["first_s"] = min(times) if times else None
    return out


def compare(learned: dict, ref: dict, n: int, z_range) -> dict:
    """Error metrics of one learned run against the pybullet run with the same inputs."""
    err = np.linalg.norm(learned["position"][:, :2] - ref["position"][:, :2], axis=1)
    path = path_length(ref["position"][:, :2])
    path_l = path_length(learned["position"][:, :2])
    done = learned["steps_done"]
    per_s = err[99::100]               # error at 1 s, 2 s, ...
    final = float(err[n - 1]) if done >= n else float("nan")
    dyaw = np.abs(np.angle(np.exp(1j * (learned["yaw"] - ref["yaw"]))))
    d = learned["dist"]
    return {
        "final_err_m": final, "path_m": path, "path_learned_m": path_l,
        "err_per_m": final / path if path > 0 else float("nan"),
        "max_err_m": float(np.nanmax(err)) if np.isfinite(err).any() else float("nan"),
        "final_yaw_err_rad": float(dyaw[n - 1]) if done >= n else float("nan"),
        "err_per_s": [None if not np.isfinite(e) else round(float(e), 4) for e in per_s],
        "implausible": first_implausible(learned["state"], done, n, z_range),
        "dist_median": float(np.nanmedian(d)) if np.isfinite(d).any() else float("nan"),
        "dist_p90": float(np.nanquantile(d, 0.9)) if np.isfinite(d).any() else float("nan"),
        "cpu_s": round(learned["cpu_s"], 1),
    }


def windows(learned: dict, ref: dict, n: int, win: int = 100) -> dict:
    """Per ``win``-step window: the relative displacement error |dp_l - dp_r| / |dp_r| and the
    learned robot's mean distance from the data (the mechanism tables)."""
    pl, pr = learned["position"][:, :2], ref["position"][:, :2]
    k = np.arange(win, n, win)
    dl = pl[k] - pl[k - win]
    dr = pr[k] - pr[k - win]
    rel = np.linalg.norm(dl - dr, axis=1) / np.maximum(np.linalg.norm(dr, axis=1), 1e-3)
    d = learned["dist"]
    per = win // DIST_EVERY
    dist = np.array([np.nanmean(d[(j - win) // DIST_EVERY:(j) // DIST_EVERY])
                     if np.isfinite(d[(j - win) // DIST_EVERY:j // DIST_EVERY]).any() else np.nan
                     for j in k])
    return {"rel": rel, "dist": dist, "end_step": k, "abs": np.linalg.norm(dl - dr, axis=1),
            "per": per}


# ---------------------------------------------------------------------------------------------
# driver


def _common_setup(a) -> tuple[dict, float, tuple[float, float]]:
    from littledog_mlsim.apps.evaluate import trainpool_radius
    from littledog_mlsim.models.onestep import OneStepModel
    lgpr = OneStepModel.load(a.lgpr)
    radius = float(trainpool_radius(lgpr, a.data, a.quantile)) if a.radius is None else a.radius
    z = lgpr.train_states[:, S.z_w]
    return {"lgpr": str(a.lgpr), "lr": str(a.lr)}, radius, (float(z.min()), float(z.max()))


def _pool(a, models, radius):
    return ProcessPoolExecutor(max_workers=a.workers, initializer=_setup,
                               initargs=(models, radius))


def _fmt(x, nd=3) -> str:
    if x is None:
        return "never"
    if isinstance(x, float) and not np.isfinite(x):
        return "n/a"
    return f"{x:.{nd}f}" if isinstance(x, float) else str(x)


def _implausible(rs: list[dict]) -> tuple[int, float | None]:
    """How many of the runs ``rs`` turned implausible, and the earliest time one did (None if
    none did)."""
    imp = [r["implausible"]["first_s"] for r in rs if r["implausible"]["first_s"] is not None]
    return len(imp), (min(imp) if imp else None)


def _med(vals) -> float:
    v = np.array([np.nan if x is None else x for x in vals], dtype=float)
    return float(np.nanmedian(v)) if np.isfinite(v).any() else float("nan")


def cmd_open_loop(a, soak: bool = False) -> int:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    models, radius, z_range = _common_setup(a)
    n = int(round(a.duration / CONTROL_DT))
    scenarios = ["soak"] if soak else a.scenarios
    jobs, meta = [], []
    schedules = {}
    for sc in scenarios:
        for seed in a.seeds:
            rng = np.random.default_rng(seed)
            sched = (straight_trot_schedule(a.duration, rng) if sc == "straight"
                     else gait_switch_schedule(a.duration, rng))
            U = StreamingTrot(phase=sched.phase).commands(sched.commands)
            schedules[(sc, seed)] = sched
            for cfg in ["pybullet", *a.configs]:
                jobs.append(("open", cfg, seed, U))
                meta.append((sc, seed, cfg))
    t0 = time.time()
    with _pool(a, models, radius) as ex:
        results = dict(zip(meta, ex.map(_task, jobs)))
    wall = time.time() - t0
    doc = {**run_record("fidelity/fidelity.py", [("soak" if soak else "open-loop"), *sys.argv[2:]]),
           "radius": radius, "quantile": a.quantile, "z_range": z_range,
           "duration_s": a.duration, "seeds": a.seeds, "wall_s": round(wall, 1),
           "load_after": os.getloadavg()[0], "runs": []}
    win_pool: dict = {}
    for (sc, seed, cfg), res in results.items():
        if cfg == "pybullet":
            continue
        ref = results[(sc, seed, "pybullet")]
        m = compare(res, ref, n, z_range)
        m.update(scenario=sc, seed=seed, config=cfg,
                 pybullet_implausible=first_implausible(ref["state"], n, n, z_range),
                 pybullet_dist_median=float(np.nanmedian(ref["dist"])),
                 segments=[s.move_type for s in schedules[(sc, seed)].segments])
        doc["runs"].append(m)
        w = windows(res, ref, n)
        seg_starts = np.array([s.start_step for s in schedules[(sc, seed)].segments[1:]])
        near = np.array([np.any((seg_starts <= e) & (e - 100 < seg_starts + 100)) for e in
                         w["end_step"]]) if seg_starts.size else np.zeros(len(w["rel"]), bool)
        win_pool.setdefault((sc, cfg), []).append((w, near))
        # which elements are far from the data: share of the squared distance per group
        off = res["offset"][np.isfinite(res["offset"]).all(axis=1)]
        far = off[np.sqrt(off.sum(axis=1)) > radius]
        m["far_fraction"] = float(len(far) / max(1, len(off)))
        m["far_share"] = ({g: round(float(far[:, sl].sum() / far.sum()), 3)
                           for g, sl in STATE_GROUPS.items()} if len(far) else {})
    # summary tables
    lines = [f"# Fidelity, open loop: {', '.join(scenarios)} ({a.duration:g} s, seeds "
             f"{a.seeds})", "", command_line(doc), "",
             f"Code: {doc['git']}; {doc['date']} UTC; wall {wall:.0f} s on {a.workers} "
             f"processes, load after {doc['load_after']:.1f}. Gate radius {radius:.3f} "
             f"(quantile {a.quantile} of the TrainPool's leave-move-out distances). "
             f"TrainPool body height {z_range[0]:.4f}..{z_range[1]:.4f} m.", ""]
    doc["summary"] = {}
    for sc in scenarios:
        lines += [f"## {sc}", "",
                  "| simulator | path (pybullet) m | learned path m | final (x,y) error m | "
                  "error / path | max error m | final yaw error rad | first implausible s "
                  "(runs with one) | median dist. from data | states beyond radius |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for cfg in a.configs:
            rs = [r for r in doc["runs"] if r["scenario"] == sc and r["config"] == cfg]
            k_imp, first = _implausible(rs)
            summ = {"path_m": _med([r["path_m"] for r in rs]),
                    "path_learned_m": _med([r["path_learned_m"] for r in rs]),
                    "final_err_m": _med([r["final_err_m"] for r in rs]),
                    "err_per_m": _med([r["err_per_m"] for r in rs]),
                    "err_per_m_max": float(np.nanmax([r["err_per_m"] for r in rs])),
                    "max_err_m": _med([r["max_err_m"] for r in rs]),
                    "final_yaw_err_rad": _med([r["final_yaw_err_rad"] for r in rs]),
                    "first_implausible_s": first,
                    "runs_implausible": k_imp, "runs": len(rs),
                    "dist_median": _med([r["dist_median"] for r in rs]),
                    "far_fraction": _med([r["far_fraction"] for r in rs])}
            doc["summary"][f"{sc}/{cfg}"] = summ
            lines.append(
                f"| {LABEL[cfg]} | {summ['path_m']:.2f} | {summ['path_learned_m']:.2f} | "
                f"{summ['final_err_m']:.3f} | {100 * summ['err_per_m']:.1f} % (worst "
                f"{100 * summ['err_per_m_max']:.1f} %) | {summ['max_err_m']:.3f} | "
                f"{summ['final_yaw_err_rad']:.3f} | {_fmt(summ['first_implausible_s'], 2)} "
                f"({k_imp}/{len(rs)}) | {summ['dist_median']:.2f} | "
                f"{100 * summ['far_fraction']:.0f} % |")
        pimp = [r["pybullet_implausible"]["first_s"] for r in doc["runs"]
                if r["scenario"] == sc and r["config"] == a.configs[0]]
        lines += ["", f"Medians over {len(a.seeds)} seeds. Pybullet's own measured states: "
                  f"first implausible {[_fmt(x, 2) for x in pimp]} s; median distance from the "
                  f"data {_med([r['pybullet_dist_median'] for r in doc['runs'] if r['scenario'] == sc]):.2f}.",
                  ""]
        # implausible reasons
        lines += ["First implausible state per run (s; height / tilt / non-finite):", ""]
        for cfg in a.configs:
            rs = [r for r in doc["runs"] if r["scenario"] == sc and r["config"] == cfg]
            lines.append(f"- {LABEL[cfg]}: " + "; ".join(
                f"seed {r['seed']}: {_fmt(r['implausible']['height_s'], 2)} / "
                f"{_fmt(r['implausible']['tilt_s'], 2)} / "
                f"{_fmt(r['implausible']['nonfinite_s'], 2)}" for r in rs))
        lines.append("")
        # mechanism: relative displacement error per 1 s window vs distance from the data
        bins = [0.0, 1.0, radius, 2.5, 4.0, np.inf]
        lines += [f"Mechanism ({sc}): per 1 s window, |learned displacement - pybullet "
                  f"displacement| / |pybullet displacement|, median (windows) by the learned "
                  f"state's mean distance from the data; and windows within 1 s of a move-type "
                  f"switch vs the rest.", "",
                  "| simulator | " + " | ".join(
                      f"dist {bins[i]:.2f}-{bins[i + 1]:.2f}" for i in range(len(bins) - 1))
                  + " | at switches | steady |",
                  "|---|" + "---|" * (len(bins) + 1)]
        doc.setdefault("mechanism", {})
        for cfg in a.configs:
            ws = win_pool.get((sc, cfg), [])
            rel = np.concatenate([w["rel"] for w, _ in ws])
            dist = np.concatenate([w["dist"] for w, _ in ws])
            near = np.concatenate([nr for _, nr in ws])
            cells, mech = [], {}
            for i in range(len(bins) - 1):
                sel = (dist >= bins[i]) & (dist < bins[i + 1]) & np.isfinite(rel)
                v = float(np.median(rel[sel])) if sel.any() else float("nan")
                mech[f"{bins[i]:.2f}-{bins[i + 1]:.2f}"] = {"median_rel": v, "windows": int(sel.sum())}
                cells.append(f"{_fmt(v, 2)} (n={sel.sum()})")
            sw = rel[near & np.isfinite(rel)]
            st = rel[~near & np.isfinite(rel)]
            mech["switch"] = float(np.median(sw)) if sw.size else float("nan")
            mech["steady"] = float(np.median(st)) if st.size else float("nan")
            doc["mechanism"][f"{sc}/{cfg}"] = mech
            lines.append(f"| {LABEL[cfg]} | " + " | ".join(cells) +
                         f" | {_fmt(mech['switch'], 2)} | {_fmt(mech['steady'], 2)} |")
        lines += ["", "Where the learned states are far from the data (share of the squared "
                  "normalised distance, states beyond the radius, median run):", "",
                  "| simulator | " + " | ".join(STATE_GROUPS) + " |",
                  "|---|" + "---|" * len(STATE_GROUPS)]
        for cfg in a.configs:
            rs = [r for r in doc["runs"] if r["scenario"] == sc and r["config"] == cfg
                  and r["far_share"]]
            if rs:
                lines.append(f"| {LABEL[cfg]} | " + " | ".join(
                    f"{_med([r['far_share'][g] for r in rs]):.2f}" for g in STATE_GROUPS) + " |")
        lines.append("")
        # figure: error vs time
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        for cfg in a.configs:
            E = np.array([[np.nan if e is None else e for e in r["err_per_s"]]
                          for r in doc["runs"] if r["scenario"] == sc and r["config"] == cfg])
            t = np.arange(1, E.shape[1] + 1)
            ax[0].plot(t, np.nanmedian(E, axis=0), label=LABEL[cfg])
            ws = win_pool.get((sc, cfg), [])
            ax[1].scatter(np.concatenate([w["dist"] for w, _ in ws]),
                          np.concatenate([w["rel"] for w, _ in ws]), s=4, label=LABEL[cfg])
        ax[0].set(xlabel="time [s]", ylabel="(x, y) error vs pybullet [m], median of seeds",
                  yscale="log", title=f"{sc}: error against time")
        ax[1].axvline(radius, color="k", lw=0.8, ls="--")
        ax[1].set(xlabel="learned state's distance from the data (1 s mean)",
                  ylabel="relative displacement error per 1 s", yscale="log",
                  title="error vs distance from the data")
        ax[0].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(a.out.parent / f"{a.out.name}_{sc}.png", dpi=90)
        plt.close(fig)
    write_results(a.out, doc, lines)
    return 0


def path_tracking(res: dict) -> dict:
    """RMS distance [m] of the robot's (x, y) from the reference trajectory's at the same step,
    over the steps done."""
    k = int(res["steps_done"])
    if k == 0:
        return {"rms_ref_m": float("nan")}
    d = res["position"][:k, :2] - np.asarray(res["reference_path"])[:k, :2]
    return {"rms_ref_m": float(np.sqrt(np.mean(np.sum(d ** 2, axis=1))))}


def cmd_closed_loop(a) -> int:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    models, radius, z_range = _common_setup(a)
    n = int(round(a.duration / CONTROL_DT))
    jobs, meta = [], []
    for kind in a.controllers:
        for seed in a.seeds:
            for cfg in ["pybullet", *a.configs]:
                jobs.append(("closed", cfg, seed, (kind, n)))
                meta.append((kind, seed, cfg))
    t0 = time.time()
    with _pool(a, models, radius) as ex:
        results = dict(zip(meta, ex.map(_task, jobs)))
    wall = time.time() - t0
    doc = {**run_record("fidelity/fidelity.py", ["closed-loop", *sys.argv[2:]]),
           "radius": radius, "quantile": a.quantile, "z_range": z_range,
           "duration_s": a.duration, "seeds": a.seeds, "wall_s": round(wall, 1),
           "load_after": os.getloadavg()[0], "runs": []}

    def tracking(res) -> dict:
        """RMS of the body velocity (pose over one gait period, in the yaw frame) minus the
        reference, after the first 2 s."""
        W = 35
        p, yaw = res["position"][:, :2], np.unwrap(np.nan_to_num(res["yaw"]))
        k = np.arange(max(W, 200), res["steps_done"])
        if k.size == 0:
            return {"rms_v": float("nan"), "rms_w": float("nan")}
        dp = (p[k] - p[k - W]) / (W * CONTROL_DT)
        ym = yaw[k - W // 2]
        v = np.stack([np.cos(ym) * dp[:, 0] + np.sin(ym) * dp[:, 1],
                      -np.sin(ym) * dp[:, 0] + np.cos(ym) * dp[:, 1]], axis=1)
        w = (yaw[k] - yaw[k - W]) / (W * CONTROL_DT)
        ref = res["reference"][k - W // 2]
        return {"rms_v": float(np.sqrt(np.mean(np.sum((v - ref[:, :2]) ** 2, axis=1)))),
                "rms_w": float(np.sqrt(np.mean((w - ref[:, 2]) ** 2)))}

    for (kind, seed, cfg), res in results.items():
        if cfg == "pybullet":
            continue
        ref = results[(kind, seed, "pybullet")]
        m = compare(res, ref, n, z_range)
        m.update(controller=kind, seed=seed, config=cfg)
        if kind == "trajectory":
            m["tracking"] = path_tracking(res)
            m["tracking_pybullet"] = path_tracking(ref)
        elif kind == "waypoints":
            m["reached"] = len(res["reached_steps"])
            m["reached_pybullet"] = len(ref["reached_steps"])
            m["n_waypoints"] = res["n_waypoints"]
            m["reach_s"] = [s * CONTROL_DT for s in res["reached_steps"]]
            m["reach_s_pybullet"] = [s * CONTROL_DT for s in ref["reached_steps"]]
        else:
            m["tracking"] = tracking(res)
            m["tracking_pybullet"] = tracking(ref)
        doc["runs"].append(m)
    lines = [f"# Fidelity, closed loop ({a.duration:g} s, seeds {a.seeds})", "",
             command_line(doc), "",
             f"Code: {doc['git']}; {doc['date']} UTC; wall {wall:.0f} s on {a.workers} "
             f"processes, load after {doc['load_after']:.1f}. Gate radius {radius:.3f} "
             f"(quantile {a.quantile}).", ""]
    doc["summary"] = {}
    for kind in a.controllers:
        if kind == "trajectory":
            lines += ["## Trajectory tracker (timed curved reference, feedforward + pose "
                      "feedback)", "",
                      "| simulator | path (pybullet) m | final gap m | gap / path | max gap m | "
                      "RMS distance from the reference, learned m | pybullet m | first "
                      "implausible s |", "|---|---|---|---|---|---|---|---|"]
        elif kind == "waypoints":
            lines += ["## Waypoint follower (4 waypoints 0.4 m apart)", "",
                      "| simulator | path (pybullet) m | final gap m | gap / path | max gap m | "
                      "waypoints reached (learned / pybullet, sum of seeds) | median time to "
                      "last common waypoint, learned - pybullet s | first implausible s |",
                      "|---|---|---|---|---|---|---|---|"]
        else:
            lines += ["## Body-velocity tracker (PI, leg odometry)", "",
                      "| simulator | path (pybullet) m | final gap m | gap / path | max gap m | "
                      "RMS speed error learned m/s | pybullet m/s | RMS yaw-rate error learned "
                      "rad/s | pybullet rad/s | first implausible s |",
                      "|---|---|---|---|---|---|---|---|---|---|"]
        for cfg in a.configs:
            rs = [r for r in doc["runs"] if r["controller"] == kind and r["config"] == cfg]
            k_imp, first = _implausible(rs)
            summ = {"path_m": _med([r["path_m"] for r in rs]),
                    "final_err_m": _med([r["final_err_m"] for r in rs]),
                    "err_per_m": _med([r["err_per_m"] for r in rs]),
                    "err_per_m_max": float(np.nanmax([r["err_per_m"] for r in rs])),
                    "max_err_m": _med([r["max_err_m"] for r in rs]),
                    "first_implausible_s": first, "runs_implausible": k_imp}
            if kind == "trajectory":
                summ["rms_ref_m"] = _med([r["tracking"]["rms_ref_m"] for r in rs])
                summ["rms_ref_m_pybullet"] = _med([r["tracking_pybullet"]["rms_ref_m"]
                                                   for r in rs])
                lines.append(
                    f"| {LABEL[cfg]} | {summ['path_m']:.2f} | {summ['final_err_m']:.3f} | "
                    f"{100 * summ['err_per_m']:.1f} % (worst {100 * summ['err_per_m_max']:.1f} %)"
                    f" | {summ['max_err_m']:.3f} | {summ['rms_ref_m']:.3f} | "
                    f"{summ['rms_ref_m_pybullet']:.3f} | {_fmt(first, 2)} ({k_imp}/{len(rs)}) |")
            elif kind == "waypoints":
                summ["reached"] = sum(r["reached"] for r in rs)
                summ["reached_pybullet"] = sum(r["reached_pybullet"] for r in rs)
                dts = []
                for r in rs:
                    c = min(len(r["reach_s"]), len(r["reach_s_pybullet"]))
                    if c:
                        dts.append(r["reach_s"][c - 1] - r["reach_s_pybullet"][c - 1])
                summ["reach_dt_s"] = _med(dts) if dts else float("nan")
                lines.append(
                    f"| {LABEL[cfg]} | {summ['path_m']:.2f} | {summ['final_err_m']:.3f} | "
                    f"{100 * summ['err_per_m']:.1f} % (worst {100 * summ['err_per_m_max']:.1f} %)"
                    f" | {summ['max_err_m']:.3f} | {summ['reached']} / {summ['reached_pybullet']}"
                    f" of {sum(r['n_waypoints'] for r in rs)} | {_fmt(summ['reach_dt_s'], 1)} | "
                    f"{_fmt(first, 2)} ({k_imp}/{len(rs)}) |")
            else:
                for key in ("rms_v", "rms_w"):
                    summ[key] = _med([r["tracking"][key] for r in rs])
                    summ[key + "_pybullet"] = _med([r["tracking_pybullet"][key] for r in rs])
                lines.append(
                    f"| {LABEL[cfg]} | {summ['path_m']:.2f} | {summ['final_err_m']:.3f} | "
                    f"{100 * summ['err_per_m']:.1f} % (worst {100 * summ['err_per_m_max']:.1f} %)"
                    f" | {summ['max_err_m']:.3f} | {summ['rms_v']:.3f} | "
                    f"{summ['rms_v_pybullet']:.3f} | {summ['rms_w']:.3f} | "
                    f"{summ['rms_w_pybullet']:.3f} | {_fmt(first, 2)} ({k_imp}/{len(rs)}) |")
            doc["summary"][f"{kind}/{cfg}"] = summ
        lines += ["", f"Medians over {len(a.seeds)} seeds (sums where stated).", ""]
        # figure: paths of the first seed
        seed = a.seeds[0]
        fig, ax = plt.subplots(figsize=(6, 5))
        ref = results[(kind, seed, "pybullet")]
        ax.plot(*ref["position"][:, :2].T, "k", lw=2, label="pybullet")
        for cfg in a.configs:
            ax.plot(*results[(kind, seed, cfg)]["position"][:, :2].T, lw=1, label=LABEL[cfg])
        if kind == "waypoints":
            wp = np.array(ref["waypoints"])
            ax.plot(*wp.T, "rx", ms=10, label="waypoints")
        if kind == "trajectory":
            ax.plot(*np.asarray(ref["reference_path"])[:, :2].T, "r:", lw=1, label="reference")
        ax.set(xlabel="x [m]", ylabel="y [m]", title=f"{kind}, seed {seed}", aspect="equal")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(a.out.parent / f"{a.out.name}_{kind}.png", dpi=90)
        plt.close(fig)
    write_results(a.out, doc, lines)
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("open-loop", "soak", "closed-loop"))
    ap.add_argument("--data", type=Path, default=Path("bags/default"),
                    help="the dataset the models were trained on (its TrainPool gives the radius)")
    ap.add_argument("--lgpr", type=Path, default=Path("bags/default_lgpr"))
    ap.add_argument("--lr", type=Path, default=Path("bags/default_lr"))
    ap.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=CONFIGS)
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    ap.add_argument("--duration", type=float, default=None, help="s (default 60, soak 600, "
                    "closed loop 40)")
    ap.add_argument("--scenarios", nargs="+", default=["switch", "straight"],
                    choices=("switch", "straight"))
    ap.add_argument("--controllers", nargs="+", default=["waypoints", "velocity"],
                    choices=("waypoints", "velocity", "trajectory"))
    ap.add_argument("--quantile", type=float, default=0.9)
    ap.add_argument("--radius", type=float, default=None, help="gate radius (default: from "
                    "--quantile)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    name = a.what.replace("-", "_")
    a.out = a.out or HERE / name
    a.out.parent.mkdir(parents=True, exist_ok=True)      # the figures are written first
    if a.duration is None:
        a.duration = {"open-loop": 60.0, "soak": 600.0, "closed-loop": 40.0}[a.what]
    if a.what == "soak" and a.seeds == [0, 1, 2, 3, 4]:
        a.seeds = [0]
    if a.what == "closed-loop":
        return cmd_closed_loop(a)
    return cmd_open_loop(a, soak=a.what == "soak")


if __name__ == "__main__":
    raise SystemExit(main())
