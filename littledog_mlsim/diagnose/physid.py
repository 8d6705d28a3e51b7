"""Physical identification: name an effect by family x scope x parameter, by re-simulation.

Why
---
A learned model trained on the data carries every effect that is a function of its inputs (a
softer knee, a payload, a constant body-frame push): its residual cannot show them. What names an
effect in physical terms is a *reference* model of the robot: the transducer. This module uses the
project's physics robot, pybullet with the robot configuration the dataset was recorded with
(``dataset.yaml`` ``info.robot``, e.g. ``measured``; sensor noise off), and asks which effect
plug-in (``robot/effects.py``), on which part of the robot, with which magnitude, makes that
robot reproduce the measured moves. This is output-error identification: the model is *run*
(simulated from measured states with the measured commands), not just stepped once, and the
residuals are the simulated-minus-measured outputs over horizons up to 4 s.

The limit (documented in docs/diagnosis.md): the reference is only as good as the physics robot.
On this project's data it is the robot the data came from, so any residual beyond sensor noise
and the measured initial state is the effect. On a real robot the reference's own model error
would be screened like an effect.

Method
------
1. **Output-error residuals.** Each selected move is re-simulated from measured states with its
   recorded commands: 1 s segments from the measured states at steps 0, 100, 200, 300 (short
   horizons 0.01-1 s) and, for the long horizon, the whole move (4 s) from step 0. The outputs
   compared with the measurement are the 12 joint angles, the body position (body frame of the
   measured heading for the short horizons; odom for the 4 s replay), height, roll, pitch and
   yaw: 18 channels x 2 horizon classes = 36 channels, each with its per-move SSE.
2. **Library = family x scope x parameter** (:data:`FAMILIES`, :func:`scopes_for`). Joint
   families act on any scope of the vocabulary (all, leg, joint type, side, joint); body
   families on the body (or one leg).
3. **Screening by sensitivities, hierarchically.** Each joint family is simulated once per
   joint at a probe magnitude; the change of the outputs it causes is that joint's sensitivity.
   The sensitivity of a scope is the sum of its joints' (first order), so every scope (all ->
   group -> joint) is scored from 12 simulations, by the weighted least-squares fit of the
   scope's sensitivity to the residual: the score is the summed relative SSE cut over the
   channels (each channel weighted by its baseline SSE). Vector body families (an odom force
   (fx, fy), a body-frame force, a slope (two tilt angles)) fit their components jointly.
4. **Parameter by re-simulation.** The best few (family, scope) pairs are fitted in 1-D (the
   magnitude along the fitted direction) by re-simulating a short grid around the first-order
   estimate, a parabola through the best three and two bisection steps (joint families on the
   1 s segments' channels only); vector families then search their direction around the
   first-order one and refit the magnitude (:func:`_refine_direction`).
   This is the transducer: the parameter is the plug-in's value that reproduces the data.
5. **Decision on held-out moves.** The fitted shortlist is re-simulated on other TrainPool moves
   (not used to screen or fit): the hypothesis with the largest mean per-move cut
   (:func:`move_cuts`, bounded per move and channel) is the finding (the 4 s replays are
   chaotic, so a fit on a few moves alone can prefer a hypothesis that only re-rolls the dice,
   and a cut summed relative to each channel's total lets a few moves' re-rolled replays
   decide); per-move SSE cuts, one-sided tests over moves: pooled over
   channels a t-test and a signed-rank max test over the shortlist (:func:`rank_max_p` of
   :func:`move_cuts`), per channel t-tests, Bonferroni over the three, the shortlist (the
   t-tests) and the 36 channels; it counts if significant
   (``p < alpha``) and material (some channel's held-out SSE cut >= ``min_gain`` with its own
   p < alpha). Before/after errors at horizons 0.1, 0.5, 1 and 4 s are reported.
6. **When the data cannot tell** (:func:`suspicions`): a command-path family that screens well
   but does not pass on data without command excitation is reported as suspected, with the
   recording that would settle it.
"""
from __future__ import annotations

import math
import multiprocessing as mp
import time
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..data.recording import MoveRecording
from ..layout import JOINT_NAMES, LEGS, N_JOINTS
from .families import (FAMILIES, TYPE_SCOPES, Family, joint_scopes,  # noqa: F401  (re-exported)
                       scope_joints, scope_words, vocabulary_family)
from .families.body import (MASS_POSITIONS, PAYLOAD_REACH_M,  # noqa: F401  (re-exported)
                            TILT_DIRECTIONS, mass_com_of, within_reach)
from .families.joints import NORMAL_TORQUE  # noqa: F401  (re-exported)
from . import stats as _stats
from .stats import (N_TESTS, RANK_FLIPS, Decision, move_cuts,  # noqa: F401  (re-exported)
                    rank_max_p)
from .stats import t_greater as _t_greater  # noqa: F401  (benchmarks/blind_zoo tools)

__all__ = ["FAMILIES", "FamilySpec", "scopes_for", "scope_joints", "build_effects",
           "identify", "PhysIdResult", "statement", "DEFAULT_HORIZONS_S"]

SEG_STARTS = (0, 100, 200, 300)
SEG_LEN = 100
SCREEN_SEGMENTS = (1, 3)          # the segments a joint family's sensitivity is simulated on
DEFAULT_HORIZONS_S = (0.1, 0.5, 1.0, 4.0)
BODY_CH = ("x", "y", "z", "roll", "pitch", "yaw")
CHANNELS = tuple([f"short:q_{j}" for j in JOINT_NAMES] + [f"short:{c}_b" if c in "xy" else
                                                          f"short:{c}" for c in BODY_CH]
                 + [f"long:q_{j}" for j in JOINT_NAMES] + [f"long:{c}_odom" if c in "xy"
                                                           else f"long:{c}" for c in BODY_CH])
N_CH = len(CHANNELS)
SHORT = np.arange(18)
LONG = np.arange(18, 36)

FamilySpec = Family   # the family's contract (families/base.py), by its former name


def scopes_for(family: str) -> list[str]:
    return FAMILIES[family].scopes()


def library_size() -> int:
    return sum(len(scopes_for(f)) for f in FAMILIES)


def build_effects(family: str, scope: str, params: Mapping[str, float]) -> list[Any]:
    """The effect plug-ins of one hypothesis (family, scope, params in the vocabulary's units
    and, for vector families, components)."""
    if family not in FAMILIES:
        raise ValueError(f"unknown family {family!r}")
    return FAMILIES[family].build_effects(scope, params)


def _params_from(family: str, mag: float, direction: np.ndarray | None) -> dict[str, float]:
    """Plug-in parameters of a hypothesis: a magnitude (and a unit direction for vectors)."""
    return FAMILIES[family].params_from(mag, direction)


# ---------------------------------------------------------------------------------------------
# re-simulation (runs in worker processes; each keeps its own pybullet client)

@dataclass
class _Move:
    """What a worker needs to re-simulate one move: commands and measured start states."""

    name: str
    move_type: str
    cmd: np.ndarray
    starts: dict[int, Any]


_WORKER: dict[str, Any] = {}


def _init_worker(robot: Any, moves: list[_Move], forked: bool = False) -> None:
    if forked:   # pybullet clients inherited from the parent are not this process's
        from ..robot import sim
        sim._SIMS.clear()
    _WORKER["robot"] = robot
    _WORKER["moves"] = moves


def _rpy(orient: np.ndarray) -> np.ndarray:
    from ..rotations import quat_to_rpy
    return np.asarray(quat_to_rpy(orient))


def _simulate(task: tuple[int, list[tuple[str, str, dict]], str]) -> dict[str, np.ndarray]:
    """Re-simulate move ``i`` with the hypotheses' plug-ins: segments (4, 100, 18) of
    [q (12), position (3), roll, pitch, yaw]; ``full`` mode also the 4 s replay (400, 18),
    ``segs`` mode the four segments without it, ``short`` mode the segments SCREEN_SEGMENTS."""
    from ..robot.sim import simulate_move
    i, hyps, mode = task
    mv: _Move = _WORKER["moves"][i]
    robot = _WORKER["robot"]
    out: dict[str, np.ndarray] = {}

    def run(k0: int, n: int) -> np.ndarray:
        effects = [e for (fam, sc, par) in hyps
                   for e in build_effects(fam, sc, {**par, "t0_s": k0 * 0.01,
                                                    "origin_xy": mv.starts[0].position[:2]})]
        rec = simulate_move(mv.cmd[k0:k0 + n], robot=robot, effects=effects, seed=0,
                            name=mv.name, move_type=mv.move_type,
                            initial=true_start(mv.starts[k0], hyps))
        return np.hstack([rec.q[1:], rec.position[1:], _rpy(rec.orientation[1:])]
                         ).astype(np.float64)

    if mode == "full":
        full = run(0, mv.cmd.shape[0])
        out["full"] = full
        segs = [full[:SEG_LEN]] + [run(k0, SEG_LEN) for k0 in SEG_STARTS[1:]]
        out["seg_idx"] = np.arange(len(SEG_STARTS))
    elif mode == "segs":
        segs = [run(k0, SEG_LEN) for k0 in SEG_STARTS]
        out["seg_idx"] = np.arange(len(SEG_STARTS))
    else:   # "short": the 1 s segments SCREEN_SEGMENTS only
        segs = [run(SEG_STARTS[k], SEG_LEN) for k in SCREEN_SEGMENTS]
        out["seg_idx"] = np.array(SCREEN_SEGMENTS)
    out["segs"] = np.stack(segs)
    return out


def true_start(initial: Any, hyps: Sequence[tuple[str, str, Mapping[str, Any]]]) -> Any:
    """The state to start a re-simulation from, given the measured one and the hypotheses
    (each family's :meth:`~.families.Family.start_q`: an encoder offset starts the joints at
    the measured angle minus it)."""
    q0 = initial.q
    q = q0
    for fam, sc, par in hyps:
        q = FAMILIES[fam].start_q(q, sc, par)
    return initial if q is q0 else replace(initial, q=q)


class _Runner:
    """Runs re-simulation tasks, in worker processes if ``jobs > 1``."""

    def __init__(self, robot: Any, moves: list[_Move], jobs: int) -> None:
        self.jobs = max(1, int(jobs))
        self.n_sims = 0
        self.config = robot
        if self.jobs > 1:
            ctx = mp.get_context("fork")
            self.pool = ctx.Pool(self.jobs, initializer=_init_worker,
                                 initargs=(robot, moves, True))
        else:
            self.pool = None
            _init_worker(robot, moves)

    def map(self, tasks: list) -> list[dict[str, np.ndarray]]:
        self.n_sims += len(tasks)
        if self.pool is None:
            return [_simulate(t) for t in tasks]
        return self.pool.map(_simulate, tasks, chunksize=max(1, len(tasks) // (4 * self.jobs)))

    def close(self) -> None:
        if self.pool is not None:
            self.pool.close()
            self.pool.join()
            self.pool = None


# ---------------------------------------------------------------------------------------------
# residuals

@dataclass
class _Measured:
    """Measured outputs aligned with :func:`_simulate`'s."""

    segs: np.ndarray      # (4, 100, 18)
    full: np.ndarray      # (400, 18)


def _measured(rec: MoveRecording) -> _Measured:
    y = np.hstack([rec.q, rec.position, _rpy(rec.orientation)])
    segs = np.stack([y[k0 + 1:k0 + 1 + SEG_LEN] for k0 in SEG_STARTS])
    return _Measured(segs, y[1:])


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def _errors(sim: Mapping[str, np.ndarray], meas: _Measured) -> dict[str, np.ndarray]:
    """Simulated minus measured outputs per channel: ``short`` (4, 100, 18) with the position
    error in the body frame of the measured heading, ``long`` (400, 18) in odom."""
    ms = meas.segs[sim["seg_idx"]]
    e = sim["segs"] - ms
    e[..., 17] = _wrap(e[..., 17])
    yaw = ms[..., 17]
    c, s = np.cos(yaw), np.sin(yaw)
    ex, ey = e[..., 12].copy(), e[..., 13].copy()
    e[..., 12] = c * ex + s * ey
    e[..., 13] = -s * ex + c * ey
    out = {"short": e}
    if "full" in sim:
        f = sim["full"] - meas.full
        f[..., 17] = _wrap(f[..., 17])
        out["long"] = f
    return out


def _sse(err: Mapping[str, np.ndarray]) -> np.ndarray:
    """Per-channel SSE (36,) of one move's errors (NaN for a missing horizon class)."""
    out = np.full(N_CH, np.nan)
    out[SHORT] = (err["short"] ** 2).sum(axis=(0, 1))
    if "long" in err:
        out[LONG] = (err["long"] ** 2).sum(axis=0)
    return out


def _flat(err: Mapping[str, np.ndarray], w: np.ndarray, long: bool) -> np.ndarray:
    """One move's errors as one weighted vector (sqrt of the channel weights)."""
    parts = [(err["short"] * np.sqrt(w[SHORT])).ravel()]
    if long:
        parts.append((err["long"] * np.sqrt(w[LONG])).ravel())
    return np.concatenate(parts)


def horizon_errors(errs: Sequence[Mapping[str, np.ndarray]],
                   horizons_s: Sequence[float] = DEFAULT_HORIZONS_S) -> dict[str, Any]:
    """Mean errors at each horizon: joint-angle RMS [rad], body-frame and odom (x, y) error
    [m], |yaw| error [rad]. Horizons up to 1 s come from the 1 s segments, longer ones from the
    4 s replay (the segment start 0)."""
    out = {}
    for h in horizons_s:
        k = int(round(h / 0.01)) - 1
        if k < SEG_LEN:
            e = np.stack([x["short"][:, k] for x in errs])          # (M, 4, 18)
            xy_b = np.hypot(e[..., 12], e[..., 13])
            out[f"{h:g}s"] = {"q_rms_rad": float(np.sqrt(np.mean(e[..., :12] ** 2))),
                              "xy_body_m": float(np.mean(xy_b)),
                              "yaw_rad": float(np.mean(np.abs(e[..., 17]))), "steps": k + 1,
                              "from": "1 s segments (starts 0, 1, 2, 3 s)"}
        elif all("long" in x for x in errs):
            kk = min(k, errs[0]["long"].shape[0] - 1)
            e = np.stack([x["long"][kk] for x in errs])             # (M, 18)
            out[f"{h:g}s"] = {"q_rms_rad": float(np.sqrt(np.mean(e[:, :12] ** 2))),
                              "xy_odom_m": float(np.mean(np.hypot(e[:, 12], e[:, 13]))),
                              "yaw_rad": float(np.mean(np.abs(e[:, 17]))), "steps": kk + 1,
                              "from": "4 s replay from the measured state at step 0"}
    return out


# ---------------------------------------------------------------------------------------------
# the search

@dataclass
class Candidate:
    family: str
    scope: str
    score: float                     # screened summed relative SSE cut (first order)
    magnitude: float                 # first-order estimate
    direction: np.ndarray | None = None
    fitted: float | None = None      # after the 1-D re-simulation fit
    J: float | None = None           # weighted SSE on the fit moves after the fit
    J0: float | None = None
    profile: list[dict[str, float]] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)   # fixed parameters (mass position)

    def params(self, mag: float | None = None) -> dict[str, Any]:
        return {**_params_from(self.family, self.fitted if mag is None else mag,
                               self.direction), **self.extra}

    def hyp(self, mag: float | None = None) -> tuple[str, str, dict]:
        return (self.family, self.scope, self.params(mag))


@dataclass
class Finding:
    """One identified (or rejected) effect with its evidence."""

    family: str
    scope: str
    params: dict[str, Any]
    statement: str
    significant: bool
    material: bool
    p_value: float
    gain: np.ndarray                 # (36,) held-out SSE cut per channel
    p_channel: np.ndarray
    screening: list[dict[str, Any]]
    profile: list[dict[str, float]]
    horizons_before: dict[str, Any]
    horizons_after: dict[str, Any]
    hyp: tuple[str, str, dict]
    alternatives: list[dict[str, Any]]

    @property
    def accepted(self) -> bool:
        return self.significant and self.material

    def evidence(self) -> dict[str, Any]:
        order = np.argsort(-np.nan_to_num(self.gain, nan=-np.inf))[:8]
        return {"method": "output-error re-simulation (physics transducer)",
                "p_value": self.p_value, "significant": self.significant,
                "material": self.material,
                "held_out_sse_cut": {CHANNELS[j]: _num(self.gain[j]) for j in order},
                "held_out_p": {CHANNELS[j]: _num(self.p_channel[j]) for j in order},
                "total_gain": _num(np.nansum(self.gain)),
                "magnitude_profile": self.profile, "screening_top": self.screening,
                "alternatives": self.alternatives,
                "horizon_errors_before": self.horizons_before,
                "horizon_errors_after": self.horizons_after}


def _num(x: Any) -> float | None:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


@dataclass
class PhysIdResult:
    findings: list[Finding]          # accepted effects, in the order found
    rejected: list[Finding]          # the best candidate of a round that did not pass
    suspected: list[dict[str, Any]]
    robot: str
    n_fit_moves: int
    n_validation_moves: int
    n_simulations: int
    seconds: float
    alpha: float
    min_gain: float
    library_size: int
    horizons_s: tuple[float, ...]
    baseline_horizons: dict[str, Any]
    notes: list[str] = field(default_factory=list)

    def describe(self) -> dict[str, Any]:
        return {"transducer": f"pybullet robot '{self.robot}' (the dataset's robot config, "
                              "sensor noise off), re-simulated from measured states",
                "n_fit_moves": self.n_fit_moves, "n_validation_moves": self.n_validation_moves,
                "n_simulations": self.n_simulations, "seconds": self.seconds,
                "alpha": self.alpha, "min_gain": self.min_gain,
                "library_size": self.library_size, "families": list(FAMILIES),
                "horizons_s": list(self.horizons_s), "channels": list(CHANNELS),
                "baseline_horizon_errors": self.baseline_horizons,
                "rejected": [{"family": f.family, "scope": f.scope, "params": f.params,
                              "statement": f.statement, **f.evidence()} for f in self.rejected],
                "notes": list(self.notes)}


def _pick_moves(recs: Sequence[MoveRecording], per_type: int, skip: int = 0) -> list[int]:
    """Indices of ``per_type`` moves of each type (after skipping ``skip`` of each)."""
    by: dict[str, list[int]] = {}
    for i, r in enumerate(recs):
        by.setdefault(r.move_type, []).append(i)
    out = []
    for t in sorted(by):
        out += by[t][skip:skip + per_type]
    return sorted(out)


def _as_tuple(d: Decision) -> tuple[np.ndarray, np.ndarray, float, bool, bool]:
    return d.gain, d.p_channel, d.p_value, d.significant, d.material


def decide(S0: np.ndarray, S1: np.ndarray, n_choice: int, alpha: float, min_gain: float,
           p_rank: float) -> tuple[np.ndarray, np.ndarray, float, bool, bool]:
    """(gain, p per channel, adjusted p, significant, material): :func:`.stats.decide` with a
    rank test, as a tuple (the benchmark tools' form)."""
    return _as_tuple(_stats.decide(S0, S1, n_choice, alpha, min_gain, p_rank))


def decide_all(S0: np.ndarray, S1s: Sequence[np.ndarray], alpha: float, min_gain: float
               ) -> list[tuple[np.ndarray, np.ndarray, float, bool, bool]]:
    """:func:`.stats.decide_all` as tuples (the benchmark tools' form)."""
    return [_as_tuple(d) for d in _stats.decide_all(S0, S1s, alpha, min_gain)]


def identify(train: Sequence[MoveRecording], test: Sequence[MoveRecording] = (), *,
             robot: Any = "measured", fit_per_type: int = 1, validate_per_type: int = 2,
             test_per_type: int = 2, alpha: float = 0.01, min_gain: float = 0.05,
             max_rounds: int = 1, n_refine: int = 8, jobs: int = 2, screen_moves: int = 4,
             excitation: float = 0.0, families: Sequence[str] | None = None,
             horizons_s: Sequence[float] = DEFAULT_HORIZONS_S,
             progress: Callable[[str], None] | None = None) -> PhysIdResult:
    """Identify effects on ``train`` (the TrainPool); report before/after on ``test``.

    ``robot``: the transducer's robot (name or RobotConfig; sensor noise is switched off).
    ``fit_per_type`` moves of each type choose and fit the effect, the next
    ``validate_per_type`` of each type decide on it; ``test_per_type`` TestPool moves of each
    type give the before/after. ``excitation``: the dataset's command excitation [rad] (for the
    "cannot tell" advice).
    """
    from ..robot.config import as_config
    from ..robot.sim import InitialState
    say = progress or (lambda s: None)
    t_start = time.perf_counter()
    fams = list(FAMILIES if families is None else families)
    cfg = replace(as_config(robot), sensor_noise=False)
    fit_idx = _pick_moves(train, fit_per_type)
    val_idx = _pick_moves(train, validate_per_type, skip=fit_per_type)
    if len(val_idx) < 3:
        val_idx = fit_idx
    test_idx = _pick_moves(test, test_per_type) if len(test) else []
    recs = ([train[i] for i in fit_idx] + [train[i] for i in val_idx]
            + [test[i] for i in test_idx])
    n_fit, n_val = len(fit_idx), len(val_idx)
    moves = [_Move(r.name, r.move_type, np.asarray(r.cmd, dtype=np.float64),
                   {k: InitialState.from_recording(r, k) for k in SEG_STARTS}) for r in recs]
    meas = [_measured(r) for r in recs]
    F = list(range(n_fit))
    V = list(range(n_fit, n_fit + n_val))
    T = list(range(n_fit + n_val, len(recs)))
    n_lib = library_size()
    runner = _Runner(cfg, moves, jobs)
    from ..robot.sim import get_sim
    robot_mass = get_sim(cfg).total_mass()
    try:
        base: list[tuple[str, str, dict]] = []
        findings: list[Finding] = []
        rejected: list[Finding] = []
        notes: list[str] = []
        base_err = [_errors(s, m) for s, m in zip(
            runner.map([(i, base, "full") for i in range(len(recs))]), meas)]
        baseline_h = horizon_errors([base_err[i] for i in T or V], horizons_s)
        say(f"physics: baseline re-simulation of {len(recs)} moves ({n_fit} fit, {n_val} "
            f"held out, {len(T)} TestPool) with robot '{cfg.name}' in "
            f"{time.perf_counter() - t_start:.1f} s")
        for rnd in range(max_rounds):
            t1 = time.perf_counter()
            FS = F[::max(1, len(F) // screen_moves)][:screen_moves]  # screening and fit moves
            cands = _screen(runner, base, base_err, meas, FS, fams, say)
            top = _shortlist(cands, n_refine)
            for c in top:
                _fit(runner, base, c, base_err, FS, F, meas)
            # the push class's other form, fitted on its own: the held-out moves then compare
            # a push and a slope each at its best magnitude (the shortlist holds one of them)
            for c in [c for c in top if FAMILIES[c.family].twin_family]:
                twin = push_twin(c, robot_mass)
                twin.magnitude, twin.fitted = float(twin.fitted), None
                _fit(runner, base, twin, base_err, FS, F, meas)
                top.append(twin)
            top += _scope_variants(runner, base, top, cands, base_err, FS, meas)
            for c in top:   # joint magnitudes too on every fit move, once the scope is chosen
                if FAMILIES[c.family].kind == "joints":
                    _wide_magnitude(runner, base, c, base_err, F, meas, (0.7, 1.0, 1.4))
            top.sort(key=lambda c: c.J / c.J0)
            say(f"physics round {rnd + 1}: fitted " + "; ".join(
                f"{c.family} {c.scope} {_fmt_params(c)} J {c.J / c.J0:.3f}" for c in top))
            fin = _validate(runner, base, top, base_err, V, T, meas, alpha, min_gain,
                            horizons_s, cands, robot_mass)
            say(f"physics round {rnd + 1}: {fin.statement}: p = {fin.p_value:.2g}, max held-out "
                f"cut {np.nanmax(fin.gain):.3f} -> "
                f"{'accepted' if fin.accepted else 'not accepted'} "
                f"({time.perf_counter() - t1:.1f} s)")
            if not fin.accepted:
                rejected.append(fin)
                break
            findings.append(fin)
            base = base + [fin.hyp]
            if rnd + 1 >= max_rounds:
                break
            base_err = [_errors(s, m) for s, m in zip(
                runner.map([(i, base, "full") for i in range(len(recs))]), meas)]
        n_sims = runner.n_sims
    finally:
        runner.close()
    sus = suspicions(findings, rejected, excitation, alpha, min_gain)
    return PhysIdResult(findings, rejected, sus, cfg.name, n_fit, n_val, n_sims,
                        time.perf_counter() - t_start, alpha, min_gain, n_lib,
                        tuple(horizons_s), baseline_h, notes)


def _fmt_params(c: Candidate) -> str:
    return ", ".join(f"{k}={v:.3g}" if isinstance(v, (int, float)) else
                     f"{k}=({', '.join(f'{x:.3g}' for x in v)})" for k, v in c.params().items())


def _screen(runner: _Runner, base: list, base_err: list, meas: list, F: list[int],
            fams: Sequence[str], say: Callable[[str], None]) -> list[Candidate]:
    """First-order scores of every family x scope (module doc, step 3)."""
    t0 = time.perf_counter()
    S0 = np.array([_sse(base_err[i]) for i in F]).sum(axis=0)
    w = 1.0 / np.where(S0 > 0, S0, 1.0)
    # (family, probe key) -> sensitivity simulations, one per screening move
    jobs = [(fam, p) for fam in fams for p in FAMILIES[fam].screen_probes()]
    tasks = [(i, base + [(fam, p.scope, p.params)],
              "full" if FAMILIES[fam].long_screen else "short") for fam, p in jobs for i in F]
    sims = runner.map(tasks)
    sens: dict[tuple[str, tuple], dict[int, np.ndarray]] = {}
    k = 0
    for fam, p in jobs:
        long = FAMILIES[fam].long_screen
        sens[(fam, p.key)] = {}
        for i in F:
            e = _errors(sims[k], meas[i])
            d = {"short": e["short"] - base_err[i]["short"][sims[k]["seg_idx"]]}
            k += 1
            if long:
                d["long"] = e["long"] - base_err[i]["long"]
            sens[(fam, p.key)][i] = _flat(d, w, long)
    res = _Residual(
        {i: _flat({"short": -base_err[i]["short"][list(SCREEN_SEGMENTS)]}, w, False)
         for i in F},  # meas - sim0 on the screening segments
        {i: _flat({"short": -base_err[i]["short"], "long": -base_err[i]["long"]}, w, True)
         for i in F}, F)
    cands: list[Candidate] = []
    for fam in fams:
        spec = FAMILIES[fam]
        found = _SCREEN_STYLES[spec.screen_style](spec, {key[1]: v for key, v in sens.items()
                                                         if key[0] == fam}, res)
        for c in found:   # first-order magnitude in the family's units
            if c.direction is None:
                c.magnitude = spec.neutral + c.magnitude * spec.probe
        cands += found
    cands.sort(key=lambda c: -c.score)
    say(f"physics screening: {len(cands)} family x scope hypotheses from {len(tasks)} "
        f"sensitivity simulations in {time.perf_counter() - t0:.1f} s; best " + ", ".join(
            f"{c.family} {c.scope} {c.score:.2f}" for c in cands[:5]))
    return cands


@dataclass(frozen=True)
class _Residual:
    """The screen's residuals (measured minus simulated, weighted, flat per move): on the
    screening segments (``short``) and on the whole move (``full``), and the moves ``F``."""

    short: Mapping[int, np.ndarray]
    full: Mapping[int, np.ndarray]
    F: Sequence[int]

    def fit_1d(self, sens: Mapping[int, np.ndarray]) -> tuple[float, float]:
        """(score, scale a) of one sensitivity fitted to the whole-move residual by least
        squares, summed over the screening moves."""
        gg = sum(float(sens[i] @ sens[i]) for i in self.F)
        bb = sum(float(sens[i] @ self.full[i]) for i in self.F)
        a = bb / gg if gg > 0 else 0.0
        return bb * a, a


def _screen_joints(spec: Family, sens: Mapping[tuple, Mapping[int, np.ndarray]],
                   res: _Residual) -> list[Candidate]:
    """Every joint scope from one probe per joint (first order: a scope's sensitivity is the
    sum of its joints'), per scope the probe that explains more; a family screened on the whole
    move (a drift that grows over 4 s) against the whole-move residual."""
    best: dict[str, Candidate] = {}
    for k in range(1 if spec.deep_probe is None else 2):
        G = np.zeros((N_JOINTS, N_JOINTS))
        b = np.zeros(N_JOINTS)
        for i in res.F:
            D = np.stack([sens[(k, j)][i] for j in range(N_JOINTS)])
            r = res.full[i] if spec.long_screen else res.short[i]
            G += D @ D.T
            b += D @ r
        for c in _scope_scores(spec.name, G, b):
            if k == 1:   # in units of the first probe (converted by the caller)
                c.magnitude *= spec.deep_probe / spec.probe
            if c.scope not in best or c.score > best[c.scope].score:
                best[c.scope] = c
    return list(best.values())


def _screen_legs(spec: Family, sens: Mapping[tuple, Mapping[int, np.ndarray]],
                 res: _Residual) -> list[Candidate]:
    out = []
    for p in spec.screen_probes():
        score, a = res.fit_1d(sens[p.key])
        out.append(Candidate(spec.name, p.scope, score, a))
    return out


def _screen_each(spec: Family, sens: Mapping[tuple, Mapping[int, np.ndarray]],
                 res: _Residual) -> list[Candidate]:
    """Every probe a hypothesis of its own (a tilt towards one direction, a mass at one
    position), scaled in 1-D; only a positive scale counts."""
    out = []
    for k, p in enumerate(spec.screen_probes()):
        score, a = res.fit_1d(sens[p.key])
        mag, direction, extra = spec.probe_candidate(k, a)
        out.append(Candidate(spec.name, p.scope, score if a > 0 else 0.0, mag, direction,
                             extra=extra))
    return out


def _screen_components(spec: Family, sens: Mapping[tuple, Mapping[int, np.ndarray]],
                       res: _Residual) -> list[Candidate]:
    """A vector family's components fitted jointly (one probe per component)."""
    keys = [p.key for p in spec.screen_probes()]
    nc = len(keys)
    G = np.zeros((nc, nc))
    b = np.zeros(nc)
    for i in res.F:
        D = np.stack([sens[key][i] for key in keys])
        G += D @ D.T
        b += D @ res.full[i]
    a = np.linalg.lstsq(G + 1e-12 * np.eye(nc), b, rcond=None)[0]
    score = float(b @ a)
    if nc > 1:
        mag = float(np.linalg.norm(a)) * spec.probe
        direction = a / np.linalg.norm(a) if np.linalg.norm(a) > 0 else np.eye(nc)[0]
        return [Candidate(spec.name, "body", score, mag, direction)]
    return [Candidate(spec.name, "body", score, float(a[0]))]


_SCREEN_STYLES: dict[str, Callable[..., list[Candidate]]] = {
    "joints": _screen_joints, "legs": _screen_legs, "each": _screen_each,
    "components": _screen_components}


def _scope_scores(fam: str, G: np.ndarray, b: np.ndarray) -> list[Candidate]:
    out = []
    for scope in scopes_for(fam):
        idx = scope_joints(scope)
        gg = float(G[np.ix_(idx, idx)].sum())
        bb = float(b[idx].sum())
        a = bb / gg if gg > 0 else 0.0
        out.append(Candidate(fam, scope, bb * a, a))
    return out


def _shortlist(cands: list[Candidate], n: int) -> list[Candidate]:
    """The hypotheses to fit: the best scope of the best joint families (half, at most three), of
    the best body families (all but one of the rest) and of the best leg family, then the next
    best overall. With the default 8 that is 3 joint, 4 body and 1 leg family: the body classes
    number seven, and with two body places a body-fixed force or a tilted floor was screened
    but never fitted (benchmarks/blind_zoo/README.md, zoo4). Joint
    families are screened on the 1 s segments, body and leg families also on the 4 s replay, so
    their scores are not compared directly: the held-out decision compares them after the fit.
    A push fixed in odom and a slope count as one class here (they act alike; the rival is
    reported by :func:`_inseparable`)."""
    pos = [c for c in cands if c.score > 0]

    def cls(c: Candidate) -> str:
        return FAMILIES[c.family].shortlist_class

    n_joint = min((n + 1) // 2, 3)
    n_body = max(1, n - n_joint - 1)
    groups = [([c for c in pos if FAMILIES[c.family].kind == "joints"], n_joint),
              ([c for c in pos if FAMILIES[c.family].kind == "body"], n_body),
              ([c for c in pos if FAMILIES[c.family].kind == "leg"], max(1, n - n_joint - n_body))]
    out: list[Candidate] = []
    for group, k in groups:
        seen: set[str] = set()
        for c in group:
            if len(seen) >= k:
                break
            if cls(c) not in seen:
                out.append(c)
                seen.add(cls(c))
    for c in pos:
        if len(out) >= n:
            break
        if c not in out and cls(c) not in {cls(o) for o in out}:
            out.append(c)
    return out[:max(n, 1)] or cands[:1]


def related_scopes(scope: str) -> list[str]:
    """The scopes a joint finding is compared with before it is named: for a single joint, the
    other joints of its leg (an offset or a fault on one joint of a leg moves the foot much as
    one on its neighbour does, and the linear screen can prefer the wrong one:
    benchmarks/blind_zoo/README.md, after zoo4) and the groups that hold it; the coarser groups
    of a group; the finer groups of ``all``."""
    if scope == "all":
        return ["side:left", "side:right"] + [f"type:{t}" for t in TYPE_SCOPES]
    kind, _, what = scope.partition(":")
    if kind == "joint":
        leg = next(g for g in LEGS if what.startswith(g + "_"))
        jt = what[len(leg) + 1:]
        typ = next(t for t, k in TYPE_SCOPES.items() if k == jt)
        side = "left" if leg.endswith("left") else "right"
        siblings = [f"joint:{leg}_{k}" for k in TYPE_SCOPES.values() if k != jt]
        return siblings + [f"leg:{leg}", f"type:{typ}", f"side:{side}", "all"]
    if kind == "leg":
        return [f"side:{'left' if what.endswith('left') else 'right'}", "all"]
    if kind == "side":
        return [f"leg:{g}" for g in LEGS if g.endswith(what)] + ["all"]
    return ["all"]


def _weights(base_err: list, F: list[int]) -> np.ndarray:
    S0 = np.array([_sse(base_err[i]) for i in F]).sum(axis=0)
    return 1.0 / np.where(S0 > 0, S0, 1.0)


def _J(errs: list, w: np.ndarray) -> float:
    return float(sum(np.nansum(_sse(e) * w) for e in errs))


def _J_hyp(runner: _Runner, base: list, hyp: tuple[str, str, dict], F: list[int], meas: list,
           w: np.ndarray) -> float:
    """J (weighted output-error SSE on the moves F) of one hypothesis added to ``base``."""
    sims = runner.map([(i, base + [hyp], "full") for i in F])
    return _J([_errors(s_, meas[i]) for s_, i in zip(sims, F)], w)


def _evaluate(runner: _Runner, base: list, c: Candidate, mags: list[float], F: list[int],
              meas: list, w: np.ndarray, evals: dict[float, float]) -> None:
    """J (weighted output-error SSE on the moves F) of ``c`` at each magnitude, into ``evals``.
    A joint family's J leaves out the 4 s replays (:func:`_fit_weights`), so they are not
    simulated for it."""
    if not mags:
        return
    mode = "segs" if FAMILIES[c.family].kind == "joints" else "full"
    sims = runner.map([(i, base + [(c.family, c.scope, c.params(m))], mode)
                       for m in mags for i in F])
    for k, m in enumerate(mags):
        evals[m] = _J([_errors(sims[k * len(F) + n], meas[i]) for n, i in enumerate(F)], w)


def _fit_weights(family: str, base_err: list, F: list[int]) -> np.ndarray:
    """The channel weights a family's magnitude is fitted with on the moves F: a joint family's
    from the 1 s segments only (the 4 s replays of a few moves flip between gaits, a foot
    landing a step earlier, at some magnitudes and not at neighbouring ones, which makes their
    error jump about the true value), a body or leg family's on all channels."""
    w = _weights(base_err, F)
    if FAMILIES[family].kind == "joints":
        w[LONG] = 0.0
    return w


def _refine(runner: _Runner, base: list, c: Candidate, base_err: list, F: list[int],
            meas: list, known: Mapping[float, float] | None = None) -> None:
    """1-D fit of the magnitude by re-simulation (module doc, step 4): a grid around the
    first-order estimate, then a parabola through the best point and its neighbours, then the
    midpoints between the best point and its neighbours, twice. Joint families are fitted on the
    1 s segments' channels, body and leg families on all (:func:`_fit_weights`). ``known``: J
    already evaluated on these moves with these weights, by magnitude; a grid point found there
    is not simulated again."""
    spec = FAMILIES[c.family]
    lo, hi = spec.bounds
    w = _fit_weights(c.family, base_err, F)
    J0 = _J([base_err[i] for i in F], w)
    m0 = float(np.clip(c.magnitude, lo, hi))
    dev = m0 - spec.neutral
    if abs(dev) < 1e-9:
        dev = spec.probe
    # a first-order estimate beyond the family's range (a strongly nonlinear effect such as a
    # foot that only slips below the friction its stance needs): a finer grid up to the bound
    fractions = (0.6, 1.0, 1.5) if m0 == c.magnitude else (0.2, 0.4, 0.6, 0.8, 0.95)
    grid = sorted({float(np.clip(spec.neutral + dev * f, lo, hi)) for f in fractions})
    evals = {m: j for m, j in (known or {}).items() if m in grid}

    def run(mags: list[float]) -> None:
        _evaluate(runner, base, c, [m for m in mags if m not in evals], F, meas, w, evals)

    run(grid)
    for _ in range(2):      # the minimum at the grid's edge: extend once or twice that way
        ms = sorted(evals, key=lambda m: abs(m - spec.neutral))
        best_m = min(evals, key=evals.get)
        if best_m == ms[-1]:
            new = float(np.clip(spec.neutral + (best_m - spec.neutral) * 1.6, lo, hi))
        elif best_m == ms[0] and len(ms) > 1:
            new = float(np.clip(spec.neutral + (best_m - spec.neutral) * 0.4, lo, hi))
        else:
            break
        if new in evals or abs(new - best_m) < 1e-9:
            break
        run([new])
    ms = sorted(evals)
    k = int(np.argmin([evals[m] for m in ms]))
    if 0 < k < len(ms) - 1:      # a parabola through the best point and its neighbours
        x = np.array(ms[k - 1:k + 2])
        y = np.array([evals[m] for m in x])
        A = np.vstack([x ** 2, x, np.ones(3)]).T
        try:
            a2, a1, _ = np.linalg.solve(A, y)
            if a2 > 0:
                xm = float(np.clip(-a1 / (2 * a2), x[0], x[2]))
                if all(abs(xm - m) > 1e-6 for m in evals):
                    run([xm])
        except np.linalg.LinAlgError:
            pass
    for _ in range(2):      # halve the bracket around the best point, twice
        ms = sorted(evals)
        k = int(np.argmin([evals[m] for m in ms]))
        run([0.5 * (ms[k] + ms[j]) for j in (k - 1, k + 1) if 0 <= j < len(ms)])
    best = min(evals, key=evals.get)
    c.fitted = best
    c.J = evals[best]
    c.J0 = J0
    c.profile = [{"magnitude": m, "J_relative": evals[m] / J0} for m in sorted(evals)]


def _refine_wide(runner: _Runner, base: list, c: Candidate, base_err: list, F: list[int],
                 meas: list, fractions: Sequence[float] = (0.7, 1.0, 1.4)) -> None:
    """The magnitude of a body or leg family refitted on every fit move (one of each type), at
    0.7, 1 and 1.4 times its fitted deviation from neutral and at the vertex of the parabola
    through those three; the best of the four is kept. Body and leg families are fitted on the
    4 s replays too, which flip between gait patterns at some magnitudes and not at
    neighbouring ones: over a few moves this makes the error profile jagged about the true
    value, over one move of each type it is smoother (benchmarks/blind_zoo/README.md).

    A planar force or slope is then turned by +-12 and +-6 deg on every fit move too (its
    direction from the screening moves alone can be off by more than the magnitude's tolerance
    allows), and if that helps its magnitude is refitted once more."""
    if c.fitted is None or len(F) == 0:
        return
    _wide_magnitude(runner, base, c, base_err, F, meas, fractions)
    if c.direction is not None and len(c.direction) == 2 and c.J is not None and \
            _turn(runner, base, c, F, meas, _weights(base_err, F), (12.0, 6.0)):
        # the turned direction's J at the fitted magnitude is known: not simulated again
        _wide_magnitude(runner, base, c, base_err, F, meas, fractions, {float(c.fitted): c.J})


def _wide_magnitude(runner: _Runner, base: list, c: Candidate, base_err: list, F: list[int],
                    meas: list, fractions: Sequence[float],
                    known: Mapping[float, float] | None = None) -> None:
    """The magnitude step of :func:`_refine_wide` (its docstring); ``known``: J already
    evaluated on these moves along the current direction, by magnitude. A joint family's
    magnitude is refitted so too, with its own weights (:func:`_fit_weights`), once its scope
    is chosen: over the few screening moves a weak joint effect's profile is flat and its
    minimum wanders (benchmarks/blind_zoo/README.md, the fifth zoo)."""
    spec = FAMILIES[c.family]
    lo, hi = spec.bounds
    w = _fit_weights(c.family, base_err, F)
    J0 = _J([base_err[i] for i in F], w)
    dev = float(c.fitted) - spec.neutral
    if abs(dev) < 1e-9:
        return
    evals: dict[float, float] = dict(known or {})

    def run(mags: list[float]) -> None:
        _evaluate(runner, base, c, [m for m in mags if m not in evals], F, meas, w, evals)

    x = [float(np.clip(spec.neutral + dev * f, lo, hi)) for f in fractions]
    run(x)
    xs = np.array(sorted(evals))
    if len(xs) == 3:
        try:
            a2, a1, _ = np.polyfit(xs, [evals[m] for m in xs], 2)
            if a2 > 0:
                v = np.clip(-a1 / (2 * a2), min(x[0], x[-1]) - 0.2 * abs(dev),
                            max(x[0], x[-1]) + 0.2 * abs(dev))
                run([float(np.clip(v, lo, hi))])
        except (np.linalg.LinAlgError, ValueError):
            pass
    best = min(evals, key=evals.get)
    c.fitted, c.J, c.J0 = best, evals[best], J0
    c.profile = [{"magnitude": m, "J_relative": evals[m] / J0, "moves": len(F)}
                 for m in sorted(evals)]


def _refine_direction(runner: _Runner, base: list, c: Candidate, base_err: list, F: list[int],
                      meas: list, steps_deg: Sequence[float] = (30.0, 12.0)) -> None:
    """The direction of a vector family's first-order fit, searched around it (the first-order
    direction is biased where the response is not linear in the components): a planar force or
    slope turned by +-30 deg, then +-12 deg around the best so far, at the fitted magnitude.
    Then the magnitude is refitted along the best direction."""
    if c.direction is None or c.fitted is None or len(c.direction) != 2:
        return
    if _turn(runner, base, c, F, meas, _weights(base_err, F), steps_deg):
        c.magnitude = float(c.fitted)
        _refine(runner, base, c, base_err, F, meas)


def _turn(runner: _Runner, base: list, c: Candidate, F: list[int], meas: list,
          w: np.ndarray, steps_deg: Sequence[float]) -> bool:
    """A planar hypothesis turned by -+step around its best direction so far, for each step, at
    its fitted magnitude on the moves ``F`` (weights ``w``, against ``c.J`` on the same moves).
    Keeps the best direction (and its J) in ``c``; True if it turned."""

    def J_of(vec: np.ndarray) -> float:
        par = _params_from(c.family, float(np.linalg.norm(vec)), vec / np.linalg.norm(vec))
        return _J_hyp(runner, base, (c.family, c.scope, par), F, meas, w)

    best = float(c.fitted) * np.asarray(c.direction, dtype=float)
    best_J = float(c.J)
    r = float(np.linalg.norm(best))
    for step in steps_deg:
        a0 = math.atan2(best[1], best[0])
        tries = [r * np.array([math.cos(a0 + s * math.radians(step)),
                               math.sin(a0 + s * math.radians(step))]) for s in (-1, 1)]
        for v in tries:
            j = J_of(v)
            if j < best_J:
                best, best_J = v, j
    if best_J < c.J:
        c.direction = best / np.linalg.norm(best)
        c.J = best_J
        return True
    return False


def _refine_position(runner: _Runner, base: list, c: Candidate, base_err: list, F: list[int],
                     meas: list, steps_m: Sequence[tuple[float, float]] = ((0.04, 0.03),
                                                                           (0.02, 0.015)),
                     step_up_m: float = 0.03,
                     valley_steps: Sequence[float] = (1.5, 1.2)) -> None:
    """mass_com's position searched around the best screening position at the fitted mass:
    +-4 cm ahead and +-3 cm to the side, then +-2 and +-1.5 cm around the best so far, then
    3 cm higher or lower, within the body's reach (:data:`PAYLOAD_REACH_M`). Then along the
    valley of a constant first moment: a lighter mass
    further out tilts the body as a heavier one nearer in does, so a search at a fixed mass
    stops on the first mass it fitted (benchmarks/blind_zoo/README.md, before the fifth
    zoo); the mass is scaled by each step in ``valley_steps`` and its offset divided by it, up
    or down while the fit improves. The mass is refitted at the best position."""
    if not FAMILIES[c.family].searches_position or c.fitted is None or c.J is None:
        return
    w = _weights(base_err, F)

    def J_at(pos: tuple[float, float, float], mass: float | None = None) -> float:
        return _J_hyp(runner, base, (c.family, c.scope, {**c.params(mass), "com_offset_m": pos}),
                      F, meas, w)

    best = tuple(float(x) for x in c.extra.get("com_offset_m", (0.0, 0.0, 0.0)))
    best_J = float(c.J)
    moves = [[(s * dx, 0.0, 0.0) for s in (-1, 1)] + [(0.0, s * dy, 0.0) for s in (-1, 1)]
             for dx, dy in steps_m] + [[(0.0, 0.0, s * step_up_m) for s in (1, -1)]]
    for tries in moves:
        start = best
        for d in tries:
            pos = tuple(round(a + b, 4) for a, b in zip(start, d))
            if not within_reach(pos):
                continue
            j = J_at(pos)
            if j < best_J:
                best, best_J = pos, j
    mass = float(c.fitted)
    lo, hi = FAMILIES[c.family].bounds
    for step in valley_steps:
        for f in (step, 1.0 / step):
            moved = False
            while lo <= mass * f <= hi:
                pos = tuple(round(a / f, 4) for a in best)
                if not within_reach(pos):
                    break
                j = J_at(pos, mass * f)
                if j >= best_J:
                    break
                best, best_J, mass, moved = pos, j, mass * f, True
            if moved:
                break
    if best_J < c.J:
        c.extra = {**c.extra, "com_offset_m": best}
        c.magnitude = mass
        _refine(runner, base, c, base_err, F, meas)


def _fit(runner: _Runner, base: list, c: Candidate, base_err: list, FS: list[int],
         F: list[int], meas: list) -> None:
    """Steps 4 of the method for one hypothesis: magnitude, direction and position on the
    screening moves ``FS``, then body and leg magnitudes on all fit moves ``F``."""
    _refine(runner, base, c, base_err, FS, meas)
    _refine_direction(runner, base, c, base_err, FS, meas)
    _refine_position(runner, base, c, base_err, FS, meas)
    if FAMILIES[c.family].kind != "joints":
        _refine_wide(runner, base, c, base_err, F, meas)


def _scope_variants(runner: _Runner, base: list, top: list[Candidate], cands: list[Candidate],
                    base_err: list, F: list[int], meas: list) -> list[Candidate]:
    """The best joint hypothesis refitted on its related scopes (:func:`related_scopes`); the
    best of those by the fit moves' error joins the shortlist if it fits about as well
    (within 10 %), so that the held-out decision also chooses the scope. A family whose
    parameter may lie either side of neutral (an encoder offset, a servo gain) starts each
    scope's fit on the side that fits it better: the neighbouring joint's offset that best
    imitates the true one can have the other sign (benchmarks/blind_zoo/README.md, before the
    fifth zoo)."""
    joint = [c for c in top if FAMILIES[c.family].kind == "joints" and c.J is not None]
    if not joint:
        return []
    c0 = min(joint, key=lambda c: c.J)
    have = {(c.family, c.scope) for c in top}
    variants = []
    for scope in related_scopes(c0.scope):
        if (c0.family, scope) in have:
            continue
        v = Candidate(c0.family, scope, 0.0, float(c0.fitted))
        side = _start_side(runner, base, v, base_err, F, meas)
        _refine(runner, base, v, base_err, F, meas, known=side)
        variants.append(v)
    if not variants:
        return []
    best = min(variants, key=lambda c: c.J)
    return [best] if best.J <= 1.1 * c0.J else []


def _start_side(runner: _Runner, base: list, c: Candidate, base_err: list, F: list[int],
                meas: list) -> dict[float, float]:
    """For a family signed about its neutral value, ``c.magnitude`` mirrored about neutral if
    the mirror image fits the moves ``F`` better (with :func:`_fit_weights`). Returns the J of
    the magnitude kept, for :func:`_refine` (empty if nothing was evaluated)."""
    spec = FAMILIES[c.family]
    lo, hi = spec.bounds
    dev = float(c.magnitude) - spec.neutral
    if not lo < spec.neutral < hi or abs(dev) < 1e-9:
        return {}
    mags = [float(np.clip(spec.neutral + s * dev, lo, hi)) for s in (1, -1)]
    evals: dict[float, float] = {}
    _evaluate(runner, base, c, mags, F, meas, _fit_weights(c.family, base_err, F), evals)
    c.magnitude = min(evals, key=evals.get)
    return {c.magnitude: evals[c.magnitude]}


def push_twin(c: Candidate, robot_mass: float) -> Candidate:
    """The hypothesis of the family that pushes alike (:attr:`~.families.Family.twin_family`:
    a slope of theta adds m g sin(theta) downhill, fixed in odom, like a force), opposite in
    direction (uphill against the push)."""
    from ..robot.sim import GRAVITY
    d = c.direction if c.direction is not None else np.array([1.0, 0.0])
    m = c.fitted if c.fitted is not None else c.magnitude
    fam = FAMILIES[c.family]
    mag = fam.twin_magnitude(m, robot_mass * GRAVITY)
    return Candidate(fam.twin_family, "body", 0.0, mag, -d, fitted=mag)


def _validate(runner: _Runner, base: list, top: list[Candidate], base_err: list, V: list[int],
              T: list[int], meas: list, alpha: float, min_gain: float,
              horizons_s: Sequence[float], cands: list[Candidate],
              robot_mass: float) -> Finding:
    """Held-out decision and TestPool before/after (module doc, step 5).

    Every fitted hypothesis of the shortlist is re-simulated on the held-out moves V; the one
    with the largest mean per-move cut (:func:`move_cuts`: each move's and channel's cut
    relative to that move's own error, bounded) is the finding, and its tests are adjusted for
    that choice (:func:`decide_all`: the rank test's max over the shortlist, the t-tests x the
    shortlist's size). The library's size does not
    enter: the held-out moves took no part in screening or fitting.
    """
    tasks = [(i, base + [c.hyp()], "full") for c in top for i in V]
    sims = runner.map(tasks)
    S0 = np.array([_sse(base_err[i]) for i in V])
    results = []
    for k, c in enumerate(top):
        err = {i: _errors(sims[k * len(V) + n], meas[i]) for n, i in enumerate(V)}
        results.append((c, err, np.array([_sse(err[i]) for i in V])))
    results = [r + (dec,) for r, dec in zip(results, decide_all(S0, [r[2] for r in results],
                                                                alpha, min_gain))]
    held = [float(np.nansum(r[3][0])) for r in results]
    score = [float(np.mean(move_cuts(S0, r[2]))) for r in results]
    kb = int(np.argmax(score))
    best = results[kb][0]
    if FAMILIES[best.family].twin_family:
        twins = [k for k, r in enumerate(results)
                 if r[0].family == FAMILIES[best.family].twin_family]
        if not twins:   # its physical twin, for the "cannot tell" statement
            twin = push_twin(best, robot_mass)
            sims_w = runner.map([(i, base + [twin.hyp()], "full") for i in V])
            err_w = {i: _errors(s_, meas[i]) for i, s_ in zip(V, sims_w)}
            S1w = np.array([_sse(err_w[i]) for i in V])
            top = top + [twin]
            results.append((twin, err_w, S1w))
            results = [r[:3] + (dec,) for r, dec in
                       zip(results, decide_all(S0, [r[2] for r in results], alpha, min_gain))]
            held.append(float(np.nansum(results[-1][3][0])))
            score.append(float(np.mean(move_cuts(S0, S1w))))
            twins = [len(results) - 1]
        # A recording's odometry is taken as level in the world (motion capture, or an estimate
        # aided by an IMU), where a slope is a tilted floor (ground_tilt) and a turned gravity is
        # not physical; the gravity form stays the named rival for odometry that tilts with
        # the ground. So where the two push alike, the push is the finding.
        k = twins[0]
        if FAMILIES[best.family].yields_to_twin and results[k][3][3] and \
                score[k] >= INSEPARABLE_SHARE * score[kb]:
            kb = k
    best, err1, S1, (gain, p_ch, p_adj, sig, mat) = results[kb]
    if T:
        sims_t = runner.map([(i, base + [best.hyp()], "full") for i in T])
        err1.update({i: _errors(s_, meas[i]) for i, s_ in zip(T, sims_t)})
    H = T or V
    mu = runner.config.foot_friction * runner.config.ground_friction
    params = physical_params(best, mu)
    alts = [{"family": vocabulary_family(c.family), "searched_family": c.family,
             "scope": c.scope, "params": physical_params(c, mu),
             "J_relative": None if c.J is None else c.J / c.J0,
             "held_out_total_gain": h, "held_out_move_cut": m, "held_out_p": r[3][2]}
            for c, h, m, r in zip(top, held, score, results)]
    screening = [{"family": c.family, "scope": c.scope, "score": c.score,
                  "first_order_magnitude": c.magnitude} for c in cands[:10]]
    return Finding(best.family, best.scope, params, statement(best.family, best.scope, params),
                   sig, mat, p_adj, gain, p_ch, screening, best.profile,
                   horizon_errors([base_err[i] for i in H], horizons_s),
                   horizon_errors([err1[i] for i in H], horizons_s), best.hyp(), alts)


def physical_params(c: Candidate, foot_mu: float = 0.81) -> dict[str, Any]:
    """The vocabulary's parameters of a fitted candidate (primary first); ``foot_mu``: the
    transducer's normal foot-ground friction coefficient (pybullet multiplies foot and ground)."""
    return FAMILIES[c.family].physical_params(c, foot_mu)


def statement(family: str, scope: str, params: Mapping[str, Any]) -> str:
    """A roboticist's sentence for a finding."""
    where = scope_words(scope)
    if family not in FAMILIES:
        return f"{family} on {where}: {dict(params)}"
    return FAMILIES[family].statement(where, params)


INSEPARABLE_SHARE = 0.8   # a rival with this share of the finding's held-out cut: data can't tell


def inseparable(f: Finding, alpha: float) -> list[dict[str, Any]]:
    """Rivals of another family that the held-out moves cannot tell from an accepted finding:
    significant on their own (adjusted p < alpha) with at least INSEPARABLE_SHARE of its summed
    held-out SSE cut. Each names what would separate them."""
    mine = vocabulary_family(f.family)
    own = [a for a in f.alternatives
           if a.get("searched_family", a["family"]) == f.family and a["scope"] == f.scope]
    if not own or not own[0]["held_out_total_gain"] or own[0]["held_out_total_gain"] <= 0:
        return []
    g0 = own[0]["held_out_total_gain"]
    out, seen = [], {f.family}
    for a in sorted(f.alternatives, key=lambda a: -(a["held_out_total_gain"] or -np.inf)):
        g = a["held_out_total_gain"]
        searched = a.get("searched_family", a["family"])
        if searched in seen or g is None or g < INSEPARABLE_SHARE * g0 or \
                not a["held_out_p"] < alpha:
            continue
        seen.add(searched)
        how, rec = _separation(f.family, searched)
        out.append({"family": a["family"], "scope": a["scope"], "params": a["params"],
                    "why": (f"cannot be told from the accepted {mine} on these data: held-out "
                            f"cut {g:.3g} against {g0:.3g}; {how}"),
                    "recording": rec, "kind": "inseparable"})
    return out


def _separation(a: str, b: str) -> tuple[str, str]:
    """Why families ``a`` and ``b`` act alike and the recording that separates them: the
    stronger of the two families' views (:meth:`~.families.Family.separation`), else more
    moves with command excitation."""
    fa, fb = FAMILIES[a], FAMILIES[b]
    views = [v for v in (fa.separation(fb), fb.separation(fa)) if v is not None]
    if not views:
        return ("both explain the held-out moves about equally well",
                "littledog-mlsim record --out DIR --moves-per-type 20 --excitation 0.03 "
                "[same options, a new seed]")
    best = max(views, key=lambda v: v.priority)
    return best.how, best.recording


def _timing(alt: Mapping[str, Any]) -> bool:
    fam = FAMILIES.get(alt.get("searched_family", alt["family"]))
    return fam is not None and fam.timing_rival


def suspicions(findings: Sequence[Finding], rejected: Sequence[Finding], excitation: float,
               alpha: float, min_gain: float) -> list[dict[str, Any]]:
    """Effects the data suggests but cannot establish, and the recording that would settle it.

    - a command-path family (delay, filter, backlash on the set-points) as the best candidate
      that was not accepted, on data without command excitation: a smooth open-loop trot
      hardly tells a late or filtered set-point from the robot's own dynamics;
    - any best candidate that is significant but below the materiality bar: more moves would
      settle it;
    - an accepted command delay or filter whose rival (filter or delay) fitted nearly as well:
      excitation separates a pure delay from a lag.
    """
    out = []
    cmd = ("littledog-mlsim record --out DIR --moves-per-type 20 --excitation 0.03 "
           "[--effects ... as before]")
    more = "littledog-mlsim record --out DIR --moves-per-type 20 [same options, a new seed]"
    for f in rejected:
        fit_cut = None
        if f.profile:
            fit_cut = 1.0 - min(p["J_relative"] for p in f.profile)
        path = FAMILIES[f.family].needs_excitation
        held = bool(np.nanmin(f.p_channel) < alpha) and float(np.nansum(f.gain)) > 0
        if path and excitation <= 0 and (fit_cut or 0) >= 2 * min_gain and held:
            out.append({"family": f.family, "scope": f.scope, "params": f.params,
                        "why": (f"{f.statement} explains {fit_cut:.0%} of the fit moves' "
                                "output error but is not established on the held-out moves; "
                                "on a smooth trot without command excitation a set-point "
                                "effect is hard to tell from the robot's own dynamics"),
                        "recording": cmd})
        elif f.significant and not f.material:
            out.append({"family": f.family, "scope": f.scope, "params": f.params,
                        "why": f"{f.statement} is significant on held-out moves (p = "
                               f"{f.p_value:.2g}) but cuts no output error by {min_gain:.0%}",
                        "recording": more})
    for f in findings:
        out += inseparable(f, alpha)
    for f in findings:
        if FAMILIES[f.family].timing_rival and excitation <= 0:
            rival = [a for a in f.alternatives if _timing(a) and a["family"] != f.family
                     and a["J_relative"] is not None]
            mine = [a for a in f.alternatives if a["family"] == f.family
                    and a["scope"] == f.scope and a["J_relative"] is not None]
            if rival and mine and rival[0]["J_relative"] <= mine[0]["J_relative"] * 1.05:
                out.append({"family": rival[0]["family"], "scope": rival[0]["scope"],
                            "params": rival[0]["params"],
                            "why": f"fits almost as well as the accepted {f.family}; a delay "
                                   "and a lag differ in how they pass fast set-point changes, "
                                   "which this data hardly has",
                            "recording": cmd})
    return out
