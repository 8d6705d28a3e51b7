"""Trace-and-calibrate loop for the physics baseline: its residual against the measured robot,
traced to a missing or wrong parameter, calibrated.

The learned-model diagnosis (:mod:`littledog_mlsim.diagnose.selection`) asks which feature a
regression lacks; here the same loop is pointed at the physics simulator (the ``nominal`` pybullet
robot, usually the tuned ``benchmarks/physics_baseline/nominal_tuned.json``), the hybrid route of
sim-to-real practice: find which physical parameter or effect the simulator lacks or has wrong,
calibrate it, check on held-out moves.

Method (and why)
----------------
1. **Residual.** One physics step of the robot from each measured TrainPool state
   (every ``stride``-th sample t = 1, 1 + stride, ... of ``features_responses``, as
   :func:`littledog_mlsim.robot.baseline.one_step_predictions`), r = s_{t+1}(measured) -
   s_{t+1}(physics), per state element; summed per move as SSE_mj (move m, element j).
2. **Trace by re-simulation (route (i) of the brief), not by regression on r.** Each candidate is
   a physical parameter the simulator lacks or may have wrong, with a few values
   (:data:`PARAMETERS`): a servo command delay (0..3 control steps), the joint-rate low-pass filter
   of the encoders (``rate_filter_hz``), the knee torque limit, Coulomb joint friction (the
   :class:`~littledog_mlsim.robot.effects.JointFriction` effect) and the mass scale. The one-step
   residual is recomputed with each value. Why this route rather than the learned diagnosis'
   feature candidates regressed on r: a feature that explains r (e.g. "lagged command") says what
   a regression could add, not which parameter of the simulator is wrong nor its value in the
   simulator's own units, and the physics residual is strongly nonlinear in the state (contacts,
   saturation), which a linear correction fits poorly; re-simulating answers "does this parameter
   at this value make the physics match" directly and yields the estimate the calibration needs.
   The price is one pass over the sampled states per candidate value (~10 ms per sample).
3. **Held-out test grouped by move.** The TrainPool moves are split into K folds stratified by
   move type (:func:`littledog_mlsim.diagnose.selection.move_folds`); for each fold the
   candidate's value is chosen on the other folds (largest summed relative SSE cut) and scored
   on the held-out fold, so choosing among values cannot by itself produce a gain. Per element j
   the held-out gain is ``gain_j = 1 - sum_m SSE1_mj / sum_m SSE0_mj`` (the cut of the
   element's one-step nMSE); the moves are the independent unit: per-move contributions
   d_mj = M (SSE0_mj - SSE1_mj) / SSE0_j are t-tested across moves (one-sided, M - 1 d.o.f.,
   :func:`littledog_mlsim.diagnose.selection.sse_decision`), per element and pooled over the 33
   elements, Bonferroni-adjusted over the two tests, the 33 elements and the number of
   candidates, exactly as the learned diagnosis decides (significant: adjusted p < ``alpha``;
   material: also some element with p < alpha and gain >= ``min_gain``).
4. **Calibrate (one-step residual, TrainPool only).** The material candidate with the largest
   summed held-out gain is taken; its parameter is set to the value minimising the summed
   relative one-step SSE on all TrainPool moves: the best grid value for the integer delay, the
   best grid value refined by a bounded scalar search (log space where the parameter is scale-like)
   for the others. The one-step residual is used, not the rollout objective J of
   :func:`~littledog_mlsim.robot.baseline.tune_nominal`, because it is what the screening measured and it
   isolates the parameter (J mixes the parameter with the drift of a 4 s rollout).
   **Acceptance on the rollout objective.** A one-step cut can come from a proxy (a parameter at
   an unphysical value absorbing another mismatch) that makes the 4 s rollouts worse, so the
   calibrated change is kept only if the rollout objective J of ``tune_nominal`` on the TrainPool
   moves (``baseline.tuning_objective``; TrainPool only) does not increase; otherwise it is
   rejected, reported as such. Each parameter is calibrated (or rejected) at most once: it is not
   screened in later rounds. The loop then screens again from the (possibly) calibrated robot, up
   to ``max_rounds`` rounds, stopping earlier when no candidate is material.
5. **Report on TestPool** (never used to choose or calibrate): before the first round and after
   each kept calibration, :func:`~littledog_mlsim.robot.baseline.evaluate_baseline` (rollout final (x, y) error and
   one-step nMSE per element). A command delay d is applied by replaying the recordings with the
   commands shifted by d steps (u'_k = u_{max(k - d, 0)}: the servo receives at step k the command
   sent d steps before; before the move, the first command), which is exact for a whole-step
   delay; joint friction rides along as an effect plug-in, so ``evaluate_baseline`` scores every
   candidate robot.

Limits. The trace can only name a family in :data:`PARAMETERS`; a mismatch of another kind (on the
stand-in robot chiefly the servo model itself: torque-mode PD with rotor armature against an
idealised position motor) is absorbed by whichever candidate best imitates it, at a value that
need not be physical (e.g. a heavy rate filter smoothing the position motor's joint rates, or a
mass scale standing in for the rotor inertia). The estimates are therefore calibrations of the
physics robot, not measurements of the real one; ``benchmarks/physics_diagnosis/physics_diagnosis.md`` compares them
with the stand-in's known values.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from . import baseline as _bl
from ..data.recording import MoveRecording
# the held-out move-grouped decision is the learned diagnosis' own (one home for the statistics)
from ..diagnose.selection import DEFAULT_ALPHA, DEFAULT_MIN_GAIN, move_folds, sse_decision
from ..layout import N_STATE, STATE_NAMES
from ..rollout.simulate import prepare_test_moves
from .config import RobotConfig
from .effects import JointFriction

__all__ = ["PhysicsModel", "Parameter", "PARAMETERS", "diagnose_physics", "shifted_recording",
           "one_step_sse", "screen_parameters", "evaluate_model"]


# ---------------------------------------------------------------------------------------------
# the physics robot being diagnosed: a RobotConfig plus what a RobotConfig cannot hold


@dataclass(frozen=True)
class PhysicsModel:
    """A physics robot: ``config`` plus a whole-step command delay and Coulomb joint friction.

    ``command_delay`` [control steps]: the servo receives the command sent that many steps
    earlier. ``coulomb_friction`` [N m]: :class:`JointFriction` on all 12 joints (0 = none).
    """

    config: RobotConfig
    command_delay: int = 0
    coulomb_friction: float = 0.0

    def effects(self) -> list[Any]:
        """Fresh effect plug-ins for one move (JointFriction keeps per-move state)."""
        return [JointFriction(coulomb=self.coulomb_friction)] if self.coulomb_friction > 0 else []

    def to_dict(self) -> dict[str, Any]:
        return {"config": _bl.config_to_dict(self.config), "command_delay": self.command_delay,
                "coulomb_friction": self.coulomb_friction}


def _knee(model: PhysicsModel) -> float:
    return float(model.config.torque_limit[2])


def _set_knee(model: PhysicsModel, v: float) -> PhysicsModel:
    h = model.config.torque_limit
    return dataclasses.replace(model, config=dataclasses.replace(
        model.config, torque_limit=(h[0], h[1], float(v))))


def _set_config(field: str) -> Callable[[PhysicsModel, float], PhysicsModel]:
    def setter(model: PhysicsModel, v: float) -> PhysicsModel:
        return dataclasses.replace(model, config=dataclasses.replace(model.config,
                                                                     **{field: float(v)}))
    return setter


@dataclass(frozen=True)
class Parameter:
    """One candidate physical parameter/effect: how to read it, set it, and what to try.

    ``values(model)`` gives the screening values (absolute), ``bounds`` the calibration range,
    ``log`` whether the calibration searches log(value), ``integer`` a grid-only parameter.
    """

    name: str
    family: str
    unit: str
    get: Callable[[PhysicsModel], float | None]
    set: Callable[[PhysicsModel, float], PhysicsModel]
    values: Callable[[PhysicsModel], tuple[float, ...]]
    bounds: tuple[float, float]
    log: bool = False
    integer: bool = False


PARAMETERS: dict[str, Parameter] = {p.name: p for p in (
    Parameter("command_delay", "command delay", "control steps (10 ms)",
              lambda m: float(m.command_delay),
              lambda m, v: dataclasses.replace(m, command_delay=int(round(v))),
              lambda m: (0.0, 1.0, 2.0, 3.0), (0.0, 3.0), integer=True),
    Parameter("rate_filter_hz", "joint-rate low-pass filter", "Hz (None = unfiltered)",
              lambda m: m.config.rate_filter_hz, _set_config("rate_filter_hz"),
              lambda m: (100.0, 50.0, 25.0), (10.0, 300.0), log=True),
    Parameter("knee_torque_limit", "knee torque limit", "N m", _knee, _set_knee,
              lambda m: (0.8, 0.61, 0.45), (0.3, 1.7)),
    Parameter("coulomb_friction", "Coulomb joint friction", "N m (all joints)",
              lambda m: m.coulomb_friction,
              lambda m, v: dataclasses.replace(m, coulomb_friction=float(v)),
              lambda m: (0.01, 0.03, 0.1), (0.002, 0.3), log=True),
    Parameter("mass_scale", "mass", "x URDF masses", lambda m: m.config.mass_scale,
              _set_config("mass_scale"),
              lambda m: tuple(round(m.config.mass_scale * f, 4) for f in (0.9, 1.1)),
              _bl.PARAM_BOUNDS["mass_scale"]),
)}


def _check_params(params: Sequence[str]) -> tuple[str, ...]:
    params = tuple(params)
    if not params:
        raise ValueError("params must name at least one physics parameter")
    for p in params:
        if p not in PARAMETERS:
            raise ValueError(f"unknown physics parameter {p!r}; choose from "
                             f"{', '.join(PARAMETERS)}")
    return params


# ---------------------------------------------------------------------------------------------
# replay with a PhysicsModel


def shifted_recording(rec: MoveRecording, delay: int) -> MoveRecording:
    """``rec`` with the commands delayed by ``delay`` steps: u'_k = u_{max(k - delay, 0)}."""
    if delay == 0:
        return rec
    idx = np.maximum(np.arange(rec.n_steps) - int(delay), 0)
    return dataclasses.replace(rec, cmd=np.asarray(rec.cmd)[idx].copy())


def _one_step_model(rec: MoveRecording, model: PhysicsModel,
                    stride: int) -> tuple[np.ndarray, np.ndarray]:
    """(Y_true, Y_pred) of one step of ``model`` from each measured state (t = 1, 1 + stride...)."""
    return _bl.one_step_predictions(shifted_recording(rec, model.command_delay), model.config,
                                    stride, model.effects())


def _rollout_model(rec: MoveRecording, model: PhysicsModel) -> np.ndarray:
    return _bl.physics_rollout(shifted_recording(rec, model.command_delay), model.config,
                               model.effects())


def _train_objective(pool: Any, moves: Sequence[Any], model: PhysicsModel, d_ref: float,
                     q_ref: float) -> dict[str, float]:
    """The rollout objective J of ``tune_nominal`` of ``model`` on the pool's (TrainPool) moves."""
    return _bl.tuning_objective(moves, pool.map(_rollout_task, model), d_ref, q_ref)


def _sse_task(model: PhysicsModel, stride: int, i: int) -> np.ndarray:
    y, yp = _one_step_model(_bl._RECS[i], model, stride)
    with np.errstate(over="ignore", invalid="ignore"):
        sse = ((yp - y) ** 2).sum(axis=0)
    return np.where(np.isfinite(sse), sse, np.inf)


def _rollout_task(model: PhysicsModel, i: int) -> np.ndarray:
    return _rollout_model(_bl._RECS[i], model)


def one_step_sse(pool: Any, model: PhysicsModel, stride: int) -> np.ndarray:
    """Per-move one-step SSE (M, 33) of ``model`` on the pool's recordings."""
    return np.stack(pool.map(_sse_task, model, stride))


# ---------------------------------------------------------------------------------------------
# screening


def _relative_cut(S0: np.ndarray, S1: np.ndarray, rows: np.ndarray) -> float:
    """Summed over elements, relative SSE cut of S1 vs S0 on the moves ``rows``."""
    tot0 = S0[rows].sum(axis=0)
    tot0 = np.where(tot0 > 0, tot0, 1.0)
    with np.errstate(invalid="ignore"):
        v = float(np.sum(1.0 - S1[rows].sum(axis=0) / tot0))
    return v if np.isfinite(v) else -np.inf


def _num(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def _score(S0: np.ndarray, S1: np.ndarray, n_cand: int, alpha: float,
           min_gain: float) -> dict[str, Any]:
    """Held-out gains, move-grouped t-tests and the decision (``selection.sse_decision``); a
    candidate whose re-simulation diverged on some move gains nothing and is not significant."""
    if np.all(np.isfinite(S1)):
        r = sse_decision(S0, S1, n_cand, alpha, min_gain)
        gain, p_el, gain_sum = r.gain, r.p_element, float(r.gain.sum())
        p_cand, p_pool, significant, material, outputs = (r.p_value, r.p_pooled, r.significant,
                                                          r.material, r.outputs)
    else:
        gain, p_el, gain_sum = np.full(N_STATE, -np.inf), np.ones(N_STATE), None
        p_cand, p_pool, significant, material, outputs = 1.0, 1.0, False, False, []
    return {"gain": {n: (float(g) if np.isfinite(g) else None) for n, g in zip(STATE_NAMES, gain)},
            "p": {n: float(v) for n, v in zip(STATE_NAMES, p_el)},
            "gain_sum": gain_sum, "p_value": p_cand, "p_pooled": p_pool,
            "significant": significant, "material": material, "outputs": outputs}


def screen_parameters(pool: Any, model: PhysicsModel, params: Sequence[str], S0: np.ndarray,
                      folds: np.ndarray, stride: int, *, alpha: float = DEFAULT_ALPHA,
                      min_gain: float = DEFAULT_MIN_GAIN,
                      progress: Callable[[str], None] | None = None,
                      sse: Callable[[PhysicsModel], np.ndarray] | None = None
                      ) -> tuple[list[dict[str, Any]], dict[tuple[str, float], np.ndarray]]:
    """Score each parameter of ``params`` by the held-out one-step SSE cut (module doc, 3).

    ``sse(model)``: per-move one-step SSE of a robot (default :func:`one_step_sse` on ``pool``;
    the loop passes a memoised one, so a robot is never simulated twice).
    Returns (one row per parameter, {(param, value): per-move SSE (M, 33)}).
    """
    sse = sse or (lambda m: one_step_sse(pool, m, stride))
    rows, cache = [], {}
    for name in params:
        par = PARAMETERS[name]
        current = par.get(model)
        values = [v for v in par.values(model) if current is None or abs(v - current) > 1e-9]
        if not values:
            continue
        by_value = {}
        for v in values:
            t0 = time.perf_counter()
            by_value[v] = cache[(name, v)] = sse(par.set(model, v))
            if progress is not None:
                progress(f"  {name}={v:g}: summed SSE cut on TrainPool "
                         f"{_relative_cut(S0, by_value[v], np.arange(len(S0))):+.3f} "
                         f"({time.perf_counter() - t0:.1f} s)")
        S1 = np.empty_like(S0)
        chosen = []
        for f in np.unique(folds):
            fit, held = folds != f, folds == f
            best = max(values, key=lambda v: _relative_cut(S0, by_value[v], fit))
            S1[held] = by_value[best][held]
            chosen.append(best)
        row = {"param": name, "family": par.family, "unit": par.unit, "current": current,
               "values": values, "fold_choices": chosen,
               "estimate": max(values, key=lambda v: _relative_cut(S0, by_value[v],
                                                                   np.arange(len(S0)))),
               "train_cut": {str(v): _num(_relative_cut(S0, by_value[v], np.arange(len(S0))))
                             for v in values}}
        row.update(_score(S0, S1, len(params), alpha, min_gain))
        rows.append(row)
    return rows, cache


# ---------------------------------------------------------------------------------------------
# calibration


def _calibrate(sse: Callable[[PhysicsModel], np.ndarray], model: PhysicsModel, name: str,
               S0: np.ndarray, grid: Mapping[float, np.ndarray], max_evals: int,
               progress: Callable[[str], None] | None) -> tuple[PhysicsModel, dict[str, Any]]:
    """Set ``name`` to its TrainPool one-step optimum (module doc, 4)."""
    from scipy.optimize import minimize_scalar

    par = PARAMETERS[name]
    allrows = np.arange(len(S0))
    trail = [{"value": v, "train_cut": _num(_relative_cut(S0, s, allrows))}
             for v, s in grid.items()]
    best_v = max(grid, key=lambda v: _relative_cut(S0, grid[v], allrows))
    if not par.integer and max_evals > 0:
        lo, hi = par.bounds
        to_x = (lambda v: math.log(v)) if par.log else (lambda v: v)
        from_x = (lambda x: math.exp(x)) if par.log else (lambda x: x)
        pts = sorted(v for v in grid if lo <= v <= hi)   # 'off' (e.g. 0 N m) is not searched
        if best_v not in pts:
            return par.set(model, best_v), {"param": name, "value": best_v, "trail": trail,
                                            "objective": "best screening value (outside the "
                                                         "calibration bounds)"}
        i = pts.index(best_v)
        a = to_x(pts[i - 1]) if i > 0 else to_x(lo)
        b = to_x(pts[i + 1]) if i + 1 < len(pts) else to_x(hi)

        def cost(x: float) -> float:
            v = float(round(min(max(from_x(x), lo), hi), 6))
            t0 = time.perf_counter()
            cut = _relative_cut(S0, sse(par.set(model, v)), allrows)
            trail.append({"value": v, "train_cut": _num(cut)})
            if progress is not None:
                progress(f"  calibrate {name}={v:.4g}: summed SSE cut {cut:+.4f} "
                         f"({time.perf_counter() - t0:.1f} s)")
            return -cut if np.isfinite(cut) else 1e9

        minimize_scalar(cost, bounds=(min(a, b), max(a, b)), method="bounded",
                        options={"maxiter": max_evals, "xatol": 0.02})
        best_v = max(trail, key=lambda r: -np.inf if r["train_cut"] is None
                     else r["train_cut"])["value"]
    calibrated = par.set(model, best_v)
    return calibrated, {"param": name, "value": par.get(calibrated),
                        "objective": "summed relative one-step SSE cut on TrainPool "
                                     "(module doc, 4)",
                        "trail": trail}


# ---------------------------------------------------------------------------------------------
# TestPool scoring


def evaluate_model(test_recs: Sequence[MoveRecording], model: PhysicsModel, *, stride: int = 1,
                   jobs: int = 2) -> dict[str, Any]:
    """TestPool rollout metrics and one-step nMSE of ``model``: ``evaluate_baseline`` on the
    delay-shifted recordings, with the model's effects."""
    recs = [shifted_recording(r, model.command_delay) for r in test_recs]
    return _bl.evaluate_baseline(recs, model.config, one_step=True, one_step_stride=stride,
                                 jobs=jobs, effects=model.effects())


def _test_summary(label: str, model: PhysicsModel, ev: Mapping[str, Any]) -> dict[str, Any]:
    return {"label": label, "model": {"command_delay": model.command_delay,
                                      "coulomb_friction": model.coulomb_friction,
                                      **{k: _bl.config_to_dict(model.config)[k] for k in (
                                          "rate_filter_hz", "torque_limit", "mass_scale",
                                          "position_gain", "velocity_gain",
                                          "ground_friction")}},
            "final_xy_error_m": ev["final_xy_error_m"],
            "final_xy_error_m_median": ev.get("final_xy_error_m_median"),
            "n_nan_moves": ev.get("n_nan_moves"),
            "one_step_nmse": ev["one_step_nmse"], "one_step": ev["one_step"],
            "by_move_type": {t: v.get("final_xy_error_m")
                             for t, v in ev.get("by_move_type", {}).items()}}


# ---------------------------------------------------------------------------------------------
# the loop


def diagnose_physics(train_recs: Sequence[MoveRecording], test_recs: Sequence[MoveRecording],
                     config: RobotConfig | PhysicsModel, *, stride: int = 8,
                     test_stride: int | None = None, params: Sequence[str] = tuple(PARAMETERS),
                     max_rounds: int = 3, n_folds: int = 3, alpha: float = DEFAULT_ALPHA,
                     min_gain: float = DEFAULT_MIN_GAIN, calibration_evals: int = 6,
                     jobs: int = 2, seed: int = 0,
                     progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Trace the physics robot's one-step residual to a missing parameter, calibrate, repeat.

    Args:
        train_recs: TrainPool recordings (screening and calibration see only these).
        test_recs: TestPool recordings (only scored, before and after every round).
        config: the starting physics robot (a RobotConfig, e.g. the tuned nominal, or a
            PhysicsModel with a delay/friction already set).
        stride: one-step samples every ``stride`` steps on TrainPool; ``test_stride`` on
            TestPool (default ``stride``).
        params: candidate parameters, names of :data:`PARAMETERS`.
        max_rounds: round limit (each round: screen, calibrate the best material one, score).
        n_folds: move folds of the held-out screening (stratified by type).
        alpha, min_gain: significance level and materiality minimum (module doc, 3).
        calibration_evals: bounded scalar-search evaluations of a continuous parameter.
        jobs: worker processes (moves in parallel).
        seed: fold assignment.
        progress: called with one-line messages.
    Returns:
        A JSON-ready report: ``rounds`` (screening table, found family/elements/estimate,
        calibration trail), ``test`` (TestPool metrics before and after each round),
        ``final_model``, ``stopped`` (why the loop ended) and settings.
    Raises:
        ValueError: empty recordings, an unknown parameter, or a bad setting (one line).
    """
    t_start = time.perf_counter()
    params = _check_params(params)
    if not train_recs:
        raise ValueError("diagnose_physics needs at least one TrainPool recording")
    if not test_recs:
        raise ValueError("diagnose_physics needs at least one TestPool recording")
    if int(stride) != stride or stride < 1:
        raise ValueError(f"stride must be a positive integer, got {stride!r}")
    test_stride = stride if test_stride is None else test_stride
    if int(test_stride) != test_stride or test_stride < 1:
        raise ValueError(f"test_stride must be a positive integer, got {test_stride!r}")
    if max_rounds < 1:
        raise ValueError(f"max_rounds must be >= 1, got {max_rounds}")
    if not 2 <= n_folds <= len(train_recs):
        raise ValueError(f"n_folds must be between 2 and the number of TrainPool moves "
                         f"({len(train_recs)}), got {n_folds}")
    model = config if isinstance(config, PhysicsModel) else PhysicsModel(config)
    say = progress or (lambda s: None)
    folds = move_folds([r.move_type for r in train_recs], n_folds, seed)

    test = []
    say("TestPool before: scoring the starting robot")
    test.append(_test_summary("start", model, evaluate_model(test_recs, model,
                                                             stride=test_stride, jobs=jobs)))
    say(f"  final xy {test[-1]['final_xy_error_m']:.4f} m")
    rounds: list[dict[str, Any]] = []
    stopped = f"round limit ({max_rounds}) reached"
    active = list(params)
    train_moves = prepare_test_moves(train_recs)
    d_ref, q_ref = _bl._references(train_recs)
    with _bl._MovePool(train_recs, jobs) as pool:
        memo: dict[PhysicsModel, np.ndarray] = {}   # a robot rejected in a round is not re-run

        def sse(m: PhysicsModel) -> np.ndarray:
            if m not in memo:
                memo[m] = one_step_sse(pool, m, stride)
            return memo[m]

        J = _train_objective(pool, train_moves, model, d_ref, q_ref)
        say(f"TrainPool rollout objective J of the starting robot: {J['objective']:.4f}")
        for r in range(1, max_rounds + 1):
            if not active:
                stopped = f"every candidate calibrated or rejected before round {r}"
                break
            t_round = time.perf_counter()
            say(f"round {r}: residual of the current robot on TrainPool (stride {stride})")
            S0 = sse(model)
            if not np.all(np.isfinite(S0)):
                raise ValueError("the starting physics robot's one-step prediction is not finite")
            screen, cache = screen_parameters(pool, model, active, S0, folds, stride,
                                              alpha=alpha, min_gain=min_gain, progress=say,
                                              sse=sse)
            material = [row for row in screen if row["material"]]
            entry: dict[str, Any] = {"round": r, "model": model.to_dict(), "screen": screen,
                                     "residual_sse_train": {n: float(v) for n, v in
                                                            zip(STATE_NAMES, S0.sum(axis=0))}}
            if not material:
                entry["found"] = None
                entry["wall_s"] = round(time.perf_counter() - t_round, 1)
                rounds.append(entry)
                stopped = f"no material candidate in round {r}"
                say(f"round {r}: nothing material left")
                break
            best = max(material, key=lambda row: row["gain_sum"])
            name = best["param"]
            say(f"round {r}: found {best['family']} ({name}), screening estimate "
                f"{best['estimate']:g}, elements {', '.join(best['outputs'][:6])}"
                f"{' ...' if len(best['outputs']) > 6 else ''}")
            grid = {v: s for (p, v), s in cache.items() if p == name}
            current = PARAMETERS[name].get(model)
            if current is not None:
                grid[current] = S0
            candidate, calib = _calibrate(sse, model, name, S0, grid, calibration_evals, say)
            J_new = _train_objective(pool, train_moves, candidate, d_ref, q_ref)
            accepted = bool(np.isfinite(J_new["objective"])
                            and J_new["objective"] <= J["objective"] + 1e-12)
            say(f"round {r}: calibrated {name} = {calib['value']:.4g}; TrainPool rollout J "
                f"{J['objective']:.4f} -> {J_new['objective']:.4f}: "
                f"{'accepted' if accepted else 'rejected'}")
            entry["found"] = {"param": name, "family": best["family"], "unit": best["unit"],
                              "elements": best["outputs"], "screening_estimate": best["estimate"],
                              "gain_sum": best["gain_sum"], "p_value": best["p_value"],
                              "calibrated_value": calib["value"], "calibration": calib,
                              "train_J_before": J, "train_J_after": J_new,
                              "accepted": accepted}
            entry["wall_s"] = round(time.perf_counter() - t_round, 1)
            rounds.append(entry)
            active.remove(name)
            if not accepted:
                continue
            model, J = candidate, J_new
            test.append(_test_summary(f"after round {r} ({name} = {calib['value']:.4g})", model,
                                      evaluate_model(test_recs, model, stride=test_stride,
                                                     jobs=jobs)))
            say(f"  TestPool final xy {test[-1]['final_xy_error_m']:.4f} m")
    return {
        "method": "one-step residual of the physics robot, traced by re-simulating candidate "
                  "parameters (held-out by move folds, move-grouped t-tests), calibrated on the "
                  "TrainPool one-step residual (littledog_mlsim.robot.calibrate)",
        "start_model": (config if isinstance(config, PhysicsModel)
                        else PhysicsModel(config)).to_dict(),
        "params": {p: {"family": PARAMETERS[p].family, "unit": PARAMETERS[p].unit,
                       "bounds": list(PARAMETERS[p].bounds)} for p in params},
        "stride": stride, "test_stride": test_stride, "n_folds": n_folds, "alpha": alpha,
        "min_gain": min_gain, "max_rounds": max_rounds, "seed": seed, "jobs": jobs,
        "train_moves": [r.name for r in train_recs], "test_moves": [r.name for r in test_recs],
        "rounds": rounds, "test": test, "final_model": model.to_dict(), "stopped": stopped,
        "found": [{"round": e["round"], **{k: e["found"][k] for k in (
            "param", "family", "elements", "screening_estimate", "calibrated_value",
            "accepted")}}
                  for e in rounds if e["found"]],
        "wall_s": round(time.perf_counter() - t_start, 1),
    }
