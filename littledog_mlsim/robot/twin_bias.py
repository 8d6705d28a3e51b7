"""The calibration's own bias, found by a parametric bootstrap and taken out (``--bootstrap N``).

A twin fitted to k-step residuals is biased even when its structure is the robot's: its
starting states are estimates (a smoothed pose, encoder rates a filter's time constant late,
quantised angles), and these errors in the variables pull the optimum by a few per cent,
more than the width of intervals from J^T J
(``benchmarks/blind_zoo/zoos/zoo32/runs/bootstrap_check/README.md``). The bias depends on the
robot smoothly, so the fitted twin shows it too:

1. **Synthetic recordings.** The fitted twin records every fitted move again with the move's
   recorded commands, from the move's start (the settled home stance where the recording
   starts there, else its smoothed first state), with the recording's own sensing
   (:func:`recording_sensing`: the motion-capture noise and the encoders' counts estimated from
   the recording), each iteration with its own noise seed. The noise read off a recording
   includes the motion a local polynomial cannot follow; :func:`matched_sensing` takes the
   twin's own share of it out (the twin records the moves with the noise so far and is read the
   same way), so that the synthetic recordings carry the recording's noise, not more.
2. **Refit.** The same parameters are fitted to the synthetic recording, from the twin's own
   values, with the same options (starting states, horizons, stride), in one stage weighted at
   the twin (module doc 2 of :mod:`.twin_fit`: the twin is the refit's truth, so its weights
   are those of the optimum but for the bias); the refit's optimum
   differs from the twin by the estimator's bias b (plus its noise). With a weighed mass
   (``weighed_mass``, module doc 13 of :mod:`.twin_fit`) each refit is weighed at the twin's
   own total mass, with the weighing's sd.
3. **Correction, iterated.** corrected = fit - b, inside the bounds. The bias is measured at the
   twin, not at the truth; where it varies with the parameters the two differ. With N > 1
   iterations the corrected twin records and is refitted again, and the bias measured there
   replaces the last (the fixed point x = fit - b(x), where the bias is measured at the
   answer itself). The corrected value carries the last bias's noise (the data's sd: the
   refit's noise is the data's) and, with N > 1, how much the bias moved between the last two
   points (a measured stand-in for how far it may still be off), added to the interval's
   variance (the consider analysis's included). A parameter at a bound or without an interval
   keeps its value, in the iterations' twins too (its bias is reported, not applied).
   **A threshold's bias from one point** (``TwinParameter.threshold``: the torque limits) is
   not applied either. A limit acts only on the steps where the joint reaches it, and how often
   the twin's own recordings reach it changes with the twin, so its bias changes with the point
   far more than the other parameters', and applied it can take the limit further from the
   truth (``benchmarks/blind_zoo/zoos/zoo35/runs/after_run1/README.md``). With one iteration the
   fit's value stands and the measured bias's square joins the interval's variance (with the
   bias's own noise): how far the one point says the fit may be off. With N > 1 the bias is
   measured at two points and is applied as any other's, with its change between them.
4. **Replicates** (``bootstrap_replicates`` R > 1). One refit's bias is one draw: refits of
   recordings that differ only in their noise seed scatter by more than the data's sd the
   intervals of :mod:`.twin_fit` report (``benchmarks/blind_zoo/zoos/zoo32/runs/secant_check/``,
   3). Each
   iteration then refits R recordings with their own noise seeds; the bias is their mean (its
   noise the estimator's variance over R), and where the R refits scatter more than the data's
   sd, their sample sd is taken as the estimator's: the fit's own error then is as large, and
   the interval's variance gains the difference too.
5. **Checked on the recording** (:func:`correction_check`). The correction is linear in the
   bias and trusts that the data's cost is as flat around the fit as around the twin; near a
   steep wall of the cost (a servo close to its stability limit) it is not. The corrected twin
   re-simulates the fitted moves of the recording once more, with the residuals weighted at the
   fit (:func:`cost_rise`). Each refit is costed the same way on its own synthetic
   recordings, from its optimum back to the twin, weighted at its optimum: what the bias is
   worth where the twin is the robot. Where the recording's cost rises by more than
   :data:`CHECK_SLACK` times their mean, plus half the 99 % chi-squared quantile of the number
   of parameters corrected, the recording refutes the correction: no bias is taken out, and
   every one widens its parameter's interval as a threshold's measured at one point does
   (a correction of a few per cent next to a steep wall of the cost can make the twin much
   worse: ``benchmarks/blind_zoo/zoos/zoo38/runs/after_run1/README.md``). A check that fails
   holds the biases too. The report's
   ``bootstrap.check`` has both costs, the rise, the refits' mean worth, the rise allowed and
   ``accepted`` (or ``error`` and ``accepted`` false; the whole entry null where nothing was
   to be taken out).

What it does not take out: a bias that varies with the parameters faster than the distance
between the fit and the truth, and one from a structure the twin lacks (the synthetic robot is
the twin). It costs N x R refits of the fitted parameters (each up to ``max_evals``
re-simulations, at least :data:`~.twin_fit.ROUND_EVALS_PER_COLUMN` Jacobians; a refit from the
twin's own values usually converges in a few) and N x R re-recordings.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import TYPE_CHECKING, Any, Callable, Sequence

import numpy as np

from ..data.recording import MoveRecording
from ..layout import HOME_POSE, N_JOINTS
from .config import RobotConfig

if TYPE_CHECKING:  # pragma: no cover
    from .twin_fit import Calibration, CalibrationOptions

__all__ = ["orientation_noise", "encoder_resolution", "recording_sensing", "matched_sensing",
           "cost_rise", "correction_check",
           "synthetic_recordings", "bias_corrected"]

#: a recording starts at the settled home stance when its first measurement is this close to it:
#: every joint within HOME_TOLERANCE_RAD of HOME_POSE and turning slower than HOME_RATE
HOME_TOLERANCE_RAD = 0.05
HOME_RATE = 0.05    # rad/s
#: joint kinds (hip roll, hip pitch, knee): the joints of kind j are j, j + 3, j + 6, j + 9
_KINDS = [list(range(j, N_JOINTS, 3)) for j in range(3)]


def orientation_noise(recs: Sequence[MoveRecording], half_window: int = 3, degree: int = 4,
                      every: int = 10) -> float:
    """The recordings' body-orientation noise [rad per axis]: the median over windows of
    2 w + 1 samples (every ``every``-th step of every move) of the RMS residual of a polynomial
    of ``degree`` fitted per axis to the rotation vectors relative to the window's middle
    orientation, scaled by sqrt(n / (n - degree - 1)). The body's attitude swings with the gait
    faster than its position moves, so a quadratic (as ``twin_fit.pose_noise`` fits the
    position) leaves its curvature, and a quartic far less of it
    (``benchmarks/blind_zoo/zoos/zoo32/runs/run3_bootstrap/README.md``)."""
    from ..rotations import quat_conjugate, quat_multiply, rotvec_from_quat

    n = 2 * half_window + 1
    if n < degree + 2:
        raise ValueError(f"a window of {n} samples cannot fit a degree-{degree} polynomial")
    t = np.arange(-half_window, half_window + 1, dtype=float)
    A = np.stack([t ** d for d in range(degree + 1)], axis=1)
    proj = np.eye(n) - A @ np.linalg.pinv(A)
    out = []
    for r in recs:
        orn = np.asarray(r.orientation, float)
        for k in range(half_window, orn.shape[0] - half_window, every):
            win = orn[k - half_window:k + half_window + 1]
            rel = rotvec_from_quat(quat_multiply(
                np.broadcast_to(quat_conjugate(orn[k]), win.shape), win))
            res = proj @ rel
            out.append(math.sqrt(float(np.mean(res ** 2)) * n / (n - degree - 1)))
    return float(np.median(out)) if out else 0.0


def encoder_resolution(recs: Sequence[MoveRecording]) -> tuple[float, float, float] | None:
    """The encoders' angle per count per joint kind, read off the recorded angles, or None if
    they are not quantised: per kind, the smallest step between distinct recorded angles,
    accepted when 99 % of the angles are whole counts from the joint's first recorded angle
    (within 1 % of a count; a joint's zero may sit anywhere between counts, as after homing).
    Where neighbouring counts were never both visited it reads a multiple of the count."""
    if not recs:
        return None
    q = np.concatenate([np.asarray(r.q, float) for r in recs], axis=0)
    out = []
    for joints in _KINDS:
        steps = []
        for j in joints:
            v = np.unique(q[:, j])
            d = np.diff(v)
            d = d[d > 1e-12]
            if d.size:
                steps.append(float(d.min()))
        if not steps:
            return None
        res = min(steps)
        counts = (q[:, joints] - q[:1, joints]) / res
        frac = np.abs(counts - np.rint(counts))
        if float(np.quantile(frac, 0.99)) > 0.01:
            return None
        out.append(res)
    return tuple(out)  # type: ignore[return-value]


def recording_sensing(recs: Sequence[MoveRecording]) -> dict[str, Any]:
    """What the recording's sensors did, as RobotConfig fields: the motion-capture noise (on
    where the body-position noise exceeds ``twin_fit.POSE_NOISE_FLOOR``) and the encoders'
    counts."""
    from .twin_fit import POSE_NOISE_FLOOR, pose_noise

    pos = pose_noise(recs)
    noisy = pos > POSE_NOISE_FLOOR
    res = encoder_resolution(recs)
    return {"sensor_noise": bool(noisy),
            "mocap_position_std": float(pos) if noisy else 0.0,
            "mocap_orientation_std": float(orientation_noise(recs)) if noisy else 0.0,
            "encoder_resolution": None if res is None else list(res)}


#: fixed-point iterations of :func:`matched_sensing`
SENSING_MATCH_ITERATIONS = 3
#: the matched noise is kept at least this fraction of the recording's own reading
SENSING_MATCH_FLOOR = 0.1


def matched_sensing(recs: Sequence[MoveRecording], twin: RobotConfig, sensing: dict[str, Any],
                    iterations: int = SENSING_MATCH_ITERATIONS) -> dict[str, Any]:
    """``sensing`` with the motion-capture noise at which the twin's own recordings of ``recs``
    read as ``recs`` do (step 1 of the module doc).

    The readings (:func:`~.twin_fit.pose_noise`, :func:`orientation_noise`) take what a local
    polynomial cannot follow for noise: on a robot whose attitude moves fast between samples
    the motion alone reads as noise, and the reading is well above the noise put in
    (``benchmarks/blind_zoo/zoos/zoo37/runs/after_run1/README.md``). Each iteration records
    the twin with
    the noise so far (its own seeds, not the bootstrap's) and reads it; the motion it shows
    (reading^2 - noise^2) is taken out of the recording's reading: noise^2 <- noise^2 +
    reading(recording)^2 - reading(twin)^2, kept at least ``SENSING_MATCH_FLOOR`` of the
    recording's reading. Without motion-capture noise, ``sensing`` as it is. The result has
    ``read_on_recording`` (the readings of ``recs``, which ``sensing`` held) and ``matched``
    (per iteration, the noise tried and the twin's readings)."""
    from .twin_fit import pose_noise

    if not sensing.get("sensor_noise"):
        return dict(sensing)
    readers = {"mocap_position_std": pose_noise, "mocap_orientation_std": orientation_noise}
    target = {key: float(sensing[key]) for key in readers}
    out = dict(sensing)
    history = []
    for i in range(int(iterations)):
        synth = synthetic_recordings(recs, _with_sensing(twin, out), 10_000 + i)
        step: dict[str, Any] = {}
        for key, read in readers.items():
            got = float(read(synth))
            var = out[key] ** 2 + target[key] ** 2 - got ** 2
            step[key] = {"tried": out[key], "read_on_twin": got}
            out[key] = math.sqrt(max(var, (SENSING_MATCH_FLOOR * target[key]) ** 2))
        history.append(step)
    out["read_on_recording"] = target
    out["matched"] = history
    return out


def _with_sensing(config: RobotConfig, sensing: dict[str, Any]) -> RobotConfig:
    res = sensing["encoder_resolution"]
    return replace(config, sensor_noise=sensing["sensor_noise"],
                   mocap_position_std=sensing["mocap_position_std"] or config.mocap_position_std,
                   mocap_orientation_std=(sensing["mocap_orientation_std"]
                                          or config.mocap_orientation_std),
                   encoder_resolution=None if res is None else tuple(res))


def _start(rec: MoveRecording):
    """The state a synthetic recording of ``rec`` starts from: None (the settled home stance,
    where ``record`` starts a move: joints at rest near HOME_POSE) or the recording's smoothed
    first state."""
    from .sim import InitialState

    at_home = (float(np.max(np.abs(np.asarray(rec.q[0], float) - HOME_POSE))) < HOME_TOLERANCE_RAD
               and float(np.max(np.abs(np.asarray(rec.dq[0], float)))) < HOME_RATE)
    return None if at_home else InitialState.smoothed(rec, 0)


def _seed(replicate: int, move: int) -> int:
    return int(np.random.SeedSequence([0xB0075, replicate, move]).generate_state(1)[0])


def synthetic_recordings(recs: Sequence[MoveRecording], config: RobotConfig,
                         replicate: int = 0) -> list[MoveRecording]:
    """``recs`` recorded again by ``config`` (step 1 of the module doc): the same commands, the
    same names and stamps, each move from its own start, noise seeded by (replicate, move)."""
    from .sim import simulate_move

    out = []
    for i, rec in enumerate(recs):
        out.append(simulate_move(rec.cmd, robot=config, seed=_seed(replicate, i), name=rec.name,
                                 move_type=rec.move_type, initial=_start(rec),
                                 start_ns=int(rec.stamps_ns[0])))
    return out


#: the correction may raise the recording's k-step cost by this many times what the bias is
#: worth on the twin's own recordings (the refits' optima against the twin), plus a shift within
#: the data's own 99 % confidence region (half the chi-squared quantile of the number corrected)
CHECK_SLACK = 3.0
CHECK_LEVEL = 0.99


def cost_rise(recs: Sequence[MoveRecording], at: RobotConfig, to: RobotConfig,
              options: "CalibrationOptions") -> tuple[float, float]:
    """(cost at ``at``, cost at ``to``) of the k-step residuals of ``recs``, each residual
    weighted by its RMS at ``at``: the cost at ``at`` is half the number of residuals, and the
    difference is what the data say a move from ``at`` to ``to`` costs, in units of the noise
    left at ``at``."""
    from . import baseline as bl
    from . import twin_fit as tf

    with bl.move_pool(recs, options.jobs, options.scheduler) as pool:
        raw = tf.twin_residuals(pool, replace(at, sensor_noise=False), options.stride,
                                options.horizons, options.initial_state)
        scale = tf._rms_scale(raw)
        w_at = tf._weighted(raw, scale)
        w_to = tf._weighted(tf.twin_residuals(pool, replace(to, sensor_noise=False),
                                              options.stride, options.horizons,
                                              options.initial_state), scale)
    return 0.5 * float(w_at @ w_at), 0.5 * float(w_to @ w_to)


def correction_check(rise: float, drops: Sequence[float], n_corrected: int) -> dict[str, Any]:
    """Whether the recording accepts the bias correction (module doc, step 5): ``rise``, what
    the move from the fit to the corrected twin costs on the recording (:func:`cost_rise`);
    ``drops``, what the move from each refit's optimum back to the twin costs on the twin's
    own recordings, the same way (the data's preference for the biased point where the twin is
    the robot). A right correction costs about as much as they do; accepted where it costs at
    most ``CHECK_SLACK`` times their mean plus half the ``CHECK_LEVEL`` chi-squared quantile of
    ``n_corrected`` degrees of freedom (a move inside the data's own confidence region)."""
    from scipy.stats import chi2

    drop = float(np.mean(drops)) if len(drops) else 0.0
    allowed = (CHECK_SLACK * max(drop, 0.0)
               + 0.5 * float(chi2.ppf(CHECK_LEVEL, max(int(n_corrected), 1))))
    return {"cost_rise": float(rise), "synthetic_drop": drop, "allowed_rise": allowed,
            "accepted": bool(np.isfinite(rise) and rise <= allowed)}


def bias_corrected(cal: "Calibration", train_recs: Sequence[MoveRecording],
                   options: "CalibrationOptions", say: Callable[[str], None]) -> "Calibration":
    """``cal`` with its estimator's bias taken out (module doc); ``options.bootstrap``
    iterations. The report gains ``bootstrap``; its ``params`` and the twin are the corrected
    ones."""
    from . import twin_fit as tf
    from .parameters import total_mass, twin_parameters

    t0 = time.perf_counter()
    n_it, n_rep = int(options.bootstrap), int(options.bootstrap_replicates)
    names = [e.name for e in cal.estimates]
    params = twin_parameters(names, cal.config)
    x_fit = np.array([p.to_x(p.get(cal.config)) for p in params])
    bounds = np.array([p.x_bounds() for p in params])
    sd_data = np.array([(cal.report.get("sd_coordinate_data") or {}).get(n, math.nan)
                        for n in names])
    sd_all = np.array([(cal.report.get("sd_coordinate") or {}).get(n, math.nan) for n in names])
    # a parameter at a bound or without an interval keeps its value: its bias is not applied
    apply = np.array([e.at_bound is None and e.ci95 != (None, None) and np.isfinite(sd_all[k])
                      for k, e in enumerate(cal.estimates)])
    sensing = matched_sensing(train_recs, cal.config, recording_sensing(train_recs))
    say(f"bootstrap: the twin records the {len(train_recs)} fitted moves again with the "
        "recording's sensing, its noise matched on the twin's own recordings (position noise "
        f"{1e3 * sensing['mocap_position_std']:.2f} mm, orientation "
        f"{1e3 * sensing['mocap_orientation_std']:.2f} mrad, encoder counts "
        f"{sensing['encoder_resolution'] or 'none'}) and is fitted again, {n_it} time(s)"
        + (f", {n_rep} noise seeds each" if n_rep > 1 else ""))
    inner = replace(options, params=tuple(names), servo="keep", add_asked=0, bootstrap=0,
                    bootstrap_continued=False,
                    bootstrap_replicates=1, test_missing=False, name=cal.config.name,
                    split_starts=0.0,
                    max_evals=max(options.max_evals,
                                  tf.ROUND_EVALS_PER_COLUMN * (2 * len(names) + 1)))

    def value(p, xi: float) -> float:
        """The parameter's value at coordinate ``xi``, inside its bounds in value space (the
        exponential of a log bound can fall a rounding error outside it)."""
        lo, hi = p.bounds
        return float(min(max(p.from_x(float(xi)), lo), hi))

    def config_at(x: np.ndarray) -> RobotConfig:
        c = cal.config
        for p, xi in zip(params, x):
            c = p.set(c, value(p, xi))
        return c

    x, points, biases, stops, spreads, error = x_fit.copy(), [], [], [], [], None
    check: dict[str, Any] | None = None
    drops: list[float] = []     # what the move from each refit back to the twin costs
    for i in range(n_it):
        twin = config_at(x)
        refits = []
        try:
            it_drops = []
            for j in range(n_rep):
                synth = synthetic_recordings(train_recs, _with_sensing(twin, sensing),
                                             i * n_rep + j)
                # the twin's own recordings come with its own mass on the scale
                rc = tf.calibrate_twin(synth, [], twin, inner if options.weighed_mass is None
                                       else replace(inner, weighed_mass=total_mass(twin)), say,
                                       weights="start")
                refits.append(np.array([p.to_x(p.get(rc.config)) for p in params]) - x)
                stops.append(rc.report.get("stop"))
                at_refit, at_twin = cost_rise(synth, rc.config, twin, inner)
                it_drops.append(at_twin - at_refit)
        except Exception as e:      # the fit (and any iteration before) stands; say why
            error = f"iteration {i + 1}: {type(e).__name__}: {e}"
            say(f"bootstrap: the refit failed ({error}); keeping "
                + ("the fit without its bias taken out" if not biases
                   else f"the correction of iteration {i} (a threshold's bias, measured at "
                   "one point, only widens its interval)"))
            break
        points.append(x.copy())
        drops = it_drops            # what the bias is worth, at the last point it was measured
        biases.append(np.mean(refits, axis=0))     # as measured, finite or not
        spreads.append(np.std(refits, axis=0, ddof=1) if n_rep > 1 else None)
        apply &= np.isfinite(biases[-1])            # a refit that went non-finite: not applied
        x = np.where(apply, np.clip(x_fit - biases[-1], bounds[:, 0], bounds[:, 1]), x_fit)
    def with_bootstrap(per: dict[str, Any]) -> dict[str, Any]:
        report = dict(cal.report)
        report["bootstrap"] = {"iterations": len(biases), "replicates": n_rep,
                               "sensing": sensing, "params": per, "refit_stops": stops,
                               "error": error, "check": check,
                               "wall_s": round(time.perf_counter() - t0, 1)}
        report["settings"] = {**report.get("settings", {}), "bootstrap": n_it,
                              "bootstrap_replicates": n_rep}
        return report

    if not biases:
        return tf.Calibration(cal.config, cal.estimates, cal.weak, with_bootstrap({}))
    n_done = len(biases)
    # a threshold's bias measured at one point only widens its interval (module doc, step 3)
    held = apply & np.array([p.threshold for p in params]) & (n_done == 1)
    apply &= ~held
    x = np.where(held, x_fit, x)
    refuted = np.zeros_like(apply)
    if apply.any():
        try:
            at_fit, at_corrected = cost_rise(train_recs, cal.config, config_at(x), options)
            check = {"cost_fit": at_fit, "cost_corrected": at_corrected,
                     **correction_check(at_corrected - at_fit, drops, int(apply.sum()))}
            if not check["accepted"]:
                say(f"bootstrap: the correction raises the k-step cost on the recording by "
                    f"{check['cost_rise']:.1f} (allowed {check['allowed_rise']:.1f}; the "
                    f"refits put the bias at {check['synthetic_drop']:.1f}): not taken out; "
                    "each bias widens its parameter's interval instead")
        except Exception as e:        # unchecked: say so, and hold the biases
            check = {"error": f"{type(e).__name__}: {e}", "accepted": False}
            say(f"bootstrap: the correction could not be checked on the recording ({e})")
        if not check["accepted"]:     # refuted by the recording, or not checked
            refuted = apply.copy()
            held = held | apply
            apply = np.zeros_like(apply)
            x = x_fit.copy()
    applied_b = [np.where(apply, b, 0.0) for b in biases]
    # the estimator's spread: the data's sd, or the replicates' where they scatter more (the
    # fit's own error then is as large as theirs, step 4 of the module doc)
    sd_e2 = np.nan_to_num(sd_data ** 2)
    extra = np.zeros_like(sd_e2)
    if spreads[-1] is not None:
        extra = np.nan_to_num(np.clip(spreads[-1] ** 2 - sd_e2, 0.0, None))
        sd_e2 = sd_e2 + extra
    # the last bias's own noise (a mean of n_rep refits), the fit's error beyond the data's sd,
    # and how much the bias moved between the last two points where it was measured: how far
    # it may still be off
    var_b = sd_e2 / n_rep + extra + (
        (applied_b[-1] - applied_b[-2]) ** 2 if n_done > 1 else 0.0)
    var_b = np.where(held, var_b + np.nan_to_num(biases[-1]) ** 2, var_b)
    config, estimates, per = cal.config, [], {}
    for k, (p, e) in enumerate(zip(params, cal.estimates)):
        if apply[k] or held[k]:
            sd_c = math.sqrt(sd_all[k] ** 2 + var_b[k])
            sd_cd = math.sqrt(sd_data[k] ** 2 + var_b[k])
            v = value(p, x[k])
            lo, hi = p.bounds
            config = p.set(config, v)
            e = replace(e, value=v, ci95=tf._interval(p, float(x[k]), sd_c),
                        ci95_data=(None if e.ci95_data is None
                                   else tf._interval(p, float(x[k]), sd_cd)),
                        at_bound="lower" if v <= lo else "upper" if v >= hi else None)
        estimates.append(e)
        per[p.name] = {"fitted": p.from_x(float(x_fit[k])),
                       "at": [p.from_x(float(pt[k])) for pt in points],
                       "bias_coordinate": [float(b[k]) if np.isfinite(b[k]) else None
                                           for b in biases],
                       "applied": bool(apply[k]),
                       "widened_only": bool(held[k]),
                       "refuted": bool(refuted[k]),
                       "corrected": value(p, x[k]) if apply[k] else p.from_x(float(x_fit[k])),
                       "sd_bias_coordinate": float(math.sqrt(var_b[k])),
                       "sd_refits_coordinate": (None if spreads[-1] is None
                                                else float(spreads[-1][k]))}
    report = with_bootstrap(per)
    report["params"] = [tf._estimate_dict(e) for e in estimates]
    # the largest biases in units of the parameter's own data sd (coordinates differ in units)
    size = np.abs(applied_b[-1]) / np.maximum(np.nan_to_num(sd_data), 1e-12)
    moved = [names[k] for k in np.argsort(-size, kind="stable") if apply[k]][:3]
    say("bootstrap: the largest biases taken out (against their data sd): " + ", ".join(
        f"{n} {per[n]['fitted']:.4g} -> {per[n]['corrected']:.4g}" for n in moved)
        if moved else "bootstrap: no bias taken out (every parameter at a bound, unbounded or "
        "a threshold measured at one point)")
    if (held & ~refuted).any():
        say("bootstrap: measured at one point"
            + (" (the second iteration failed)" if n_it > 1 else "")
            + ", a threshold's bias widens its interval and is not taken out: "
            + ", ".join(f"{names[k]} (bias {biases[-1][k]:+.3f} e-folds)"
                        for k in np.flatnonzero(held & ~refuted)))
    return tf.Calibration(config, estimates, cal.weak, report)
