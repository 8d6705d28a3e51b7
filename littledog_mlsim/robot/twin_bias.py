"""The calibration's own bias, found by a parametric bootstrap and taken out (``--bootstrap N``).

A twin fitted to k-step residuals is biased even when its structure is the robot's: its
starting states are estimates (a smoothed pose, encoder rates a filter's time constant late,
quantised angles), and these errors in the variables pull the optimum by a few per cent,
several times the width of intervals from J^T J (``benchmarks/blind_zoo``, zoo32: with every
parameter fitted, the masses and servo parameters ended 1-4 % off, outside intervals of
+-2 %). The bias depends on the robot smoothly, so the fitted twin shows it too:

1. **Synthetic recordings.** The fitted twin records every fitted move again with the move's
   recorded commands, from the move's start (the settled home stance where the recording
   starts there, else its smoothed first state), with the recording's own sensing
   (:func:`recording_sensing`: the motion-capture noise and the encoders' counts estimated from
   the recording), each replicate with its own noise seed.
2. **Refit.** The same parameters are fitted to each synthetic recording, from the twin's own
   values, with the same options (starting states, horizons, stride); the refit's optimum
   differs from the twin by the estimator's bias plus its noise.
3. **Correction.** The bias b = mean(refits) - fit, in the fit's coordinates, is subtracted:
   corrected = fit - b, inside the bounds. The corrected value carries the uncertainty of b
   as well: var(b) = max(sd_data^2, the refits' sample variance) / N, with sd_data the fit's
   data sd (the refits' noise is the data's), added to the interval's variance (the consider
   analysis's included). A parameter at a bound or without an interval keeps its value (its
   bias is reported, not applied).

What it does not take out: a bias that varies with the parameters faster than the distance
between the fit and the truth, and one from a structure the twin lacks (the synthetic robot is
the twin). It costs N refits of the fitted parameters (each up to ``max_evals`` re-simulations,
at least :data:`~.twin_fit.ROUND_EVALS_PER_COLUMN` Jacobians) and N re-recordings.
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

__all__ = ["orientation_noise", "encoder_resolution", "recording_sensing", "synthetic_recordings",
           "bias_corrected"]

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
    position) leaves its curvature: on a twin's recording with 0.76 mrad of noise it read 1.02
    mrad, a quartic 0.78 (``benchmarks/blind_zoo/zoos/zoo32/runs/run3_bootstrap``)."""
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
    accepted when 99 % of the angles are whole multiples of it (within 1 % of a count). Where
    neighbouring counts were never both visited it reads a multiple of the count."""
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
        counts = q[:, joints] / res
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


def bias_corrected(cal: "Calibration", train_recs: Sequence[MoveRecording],
                   options: "CalibrationOptions", say: Callable[[str], None]) -> "Calibration":
    """``cal`` with its estimator's bias taken out (module doc); ``options.bootstrap`` refits.
    The report gains ``bootstrap``; its ``params`` and the twin are the corrected ones."""
    from . import twin_fit as tf
    from .parameters import twin_parameters

    t0 = time.perf_counter()
    n_rep = int(options.bootstrap)
    names = [e.name for e in cal.estimates]
    params = twin_parameters(names, cal.config)
    x_fit = np.array([p.to_x(p.get(cal.config)) for p in params])
    sensing = recording_sensing(train_recs)
    synth_robot = _with_sensing(cal.config, sensing)
    say(f"bootstrap: the twin records the {len(train_recs)} fitted moves again with the "
        f"recording's sensing (position noise {1e3 * sensing['mocap_position_std']:.2f} mm, "
        f"orientation {1e3 * sensing['mocap_orientation_std']:.2f} mrad, encoder counts "
        f"{sensing['encoder_resolution'] or 'none'}) and is fitted again, {n_rep} time(s)")
    inner = replace(options, params=tuple(names), servo="keep", add_asked=0, bootstrap=0,
                    test_missing=False, name=cal.config.name,
                    max_evals=max(options.max_evals,
                                  tf.ROUND_EVALS_PER_COLUMN * (2 * len(names) + 1)))
    refits, stops = [], []
    for i in range(n_rep):
        synth = synthetic_recordings(train_recs, synth_robot, i)
        rc = tf.calibrate_twin(synth, [], cal.config, inner, say)
        refits.append([p.to_x(p.get(rc.config)) for p in params])
        stops.append(rc.report.get("stop"))
    refits_x = np.array(refits)
    bias = refits_x.mean(axis=0) - x_fit
    sd_data = np.array([(cal.report.get("sd_coordinate_data") or {}).get(n, math.nan)
                        for n in names])
    sd_all = np.array([(cal.report.get("sd_coordinate") or {}).get(n, math.nan) for n in names])
    spread = refits_x.var(axis=0, ddof=1) if n_rep > 1 else np.zeros(len(names))
    var_b = np.maximum(np.nan_to_num(sd_data ** 2), spread) / n_rep
    config, estimates, per = cal.config, [], {}
    for k, (p, e) in enumerate(zip(params, cal.estimates)):
        lo, hi = p.x_bounds()
        apply = (e.at_bound is None and e.ci95 != (None, None) and np.isfinite(sd_all[k])
                 and np.isfinite(bias[k]))
        x_c = float(np.clip(x_fit[k] - bias[k], lo, hi)) if apply else float(x_fit[k])
        if apply:
            sd_c = math.sqrt(sd_all[k] ** 2 + var_b[k])
            sd_cd = math.sqrt(sd_data[k] ** 2 + var_b[k])
            config = p.set(config, p.from_x(x_c))
            e = replace(e, value=p.from_x(x_c), ci95=tf._interval(p, x_c, sd_c),
                        ci95_data=(None if e.ci95_data is None
                                   else tf._interval(p, x_c, sd_cd)))
        estimates.append(e)
        per[p.name] = {"fitted": p.from_x(float(x_fit[k])),
                       "refits": [p.from_x(float(v)) for v in refits_x[:, k]],
                       "bias_coordinate": float(bias[k]), "applied": bool(apply),
                       "corrected": p.from_x(x_c),
                       "sd_bias_coordinate": float(math.sqrt(var_b[k]))}
    report = dict(cal.report)
    report["params"] = [tf._estimate_dict(e) for e in estimates]
    report["bootstrap"] = {"replicates": n_rep, "sensing": sensing, "params": per,
                           "refit_stops": stops, "wall_s": round(time.perf_counter() - t0, 1)}
    report["settings"] = {**report.get("settings", {}), "bootstrap": n_rep}
    moved = sorted(per, key=lambda n: -abs(per[n]["bias_coordinate"]))[:3]
    say("bootstrap: the largest biases taken out: " + ", ".join(
        f"{n} {per[n]['fitted']:.4g} -> {per[n]['corrected']:.4g}" for n in moved
        if per[n]["applied"]))
    return tf.Calibration(config, estimates, cal.weak, report)
