"""Calibrate a twin: fit RobotConfig parameters to an ordinary recording by re-simulation.

``littledog-mlsim calibrate --data REFERENCE --robot nominal --out twin.json`` runs
:func:`calibrate_dataset`. The recording is a dataset as ``record`` or ``import`` writes it; only
its TrainPool moves are fitted, its TestPool moves only scored.

Method
------
1. **Residuals.** From every ``stride``-th measured state t of the fitted moves the robot is
   re-simulated ``max(horizons)`` control steps with the recorded commands
   (:func:`~littledog_mlsim.robot.baseline.k_step_predictions`); at each horizon h the residual is
   s_{t+h}(simulated) - s_{t+h}(measured), per state element. One step isolates the parameters
   of a step; a few steps (0.1 s by default) let effects accumulate that one step hides
   (masses, friction). The state at t is taken as measured (``initial_state="measured"``) or
   :meth:`~littledog_mlsim.robot.sim.InitialState.smoothed` (``"smoothed"``: the body's pose
   and twist from a local quadratic fit of the poses around t, the joints as measured). As
   measured, the twist is a 10 ms difference of noisy poses, and the fit explains part of that
   starting error with the parameters (errors in the variables); on noise-free poses the fit's
   curvature error is the larger one (benchmarks/calibrate/README.md, "Converged, the fit is
   biased by its starting states"). ``"auto"`` (default) smooths
   where the recordings' body-position noise (:func:`pose_noise`) exceeds
   :data:`POSE_NOISE_FLOOR`.
2. **Weights.** Each (horizon, element) residual is divided by its RMS: first at the starting
   robot, then, after a first fit, at that fit's optimum, and the fit is run again from there
   (two-stage weighted least squares, so that every channel counts by its own noise level and
   the residual variance of the final fit estimates the noise, about 1). Two kinds of fit start
   where those weights are known already and run one stage (``weights`` of
   :func:`calibrate_twin`; the report's ``weights``): a second start across the masses' split
   (14) takes the weights of the fit it starts from at that fit's optimum (its residual RMS
   there: the noise left at the fit, where the fit's own second stage is weighted at the end
   of its first); a bootstrap refit (11) is weighted at its own start, the twin, which is its
   truth (a second stage would reweight at a point a bias away). Their evaluations
   then go to one stage's iterations, not two (a second stage took a share of those fits'
   Jacobians: benchmarks/calibrate/fit_progress/README.md, "What it shows").
3. **Fit.** ``scipy.optimize.least_squares`` (trust region, bounds) over the parameters'
   coordinates: the logarithm of scale-like parameters (gains, masses, limits), the value of the
   others (friction coefficients, armature). The Jacobian is central differences of step
   ``diff_step`` coordinates (5 %), two full re-simulations per column: the residual of a
   contact-rich re-simulation is rough at small steps and curved at large ones, and forward
   differences then overstate the slope, so that Gauss-Newton creeps (benchmarks/calibrate/
   README.md, "Central differences, not forward ones").
4. **Uncertainty.** At the optimum, cov = s^2 (J^T J)^-1 with s^2 = SSE / (n - p), the residual
   variance, and its sandwich forms clustered by sampled state (the residuals of one state, all
   elements and horizons, may be correlated) and by move (every state of a move may be: a
   systematic error of the twin repeats along a move); the 95 % interval is x +- 1.96 sd in the
   fit's coordinate with the widest of the three sd (so a log parameter's interval is a
   factor, and stays positive), cut to the parameter's bounds. With ``jackknife`` (on by
   default; ``--no-jackknife``) the leave-one-move-out jackknife (CR3, :func:`_jackknife`;
   report ``sd_coordinate_jackknife``) is a fourth among them: the per-move sandwich is too
   narrow when the moves are few against the parameters and a parameter is pinned by a few of
   them (as on the blind benchmark's references), and the jackknife less so: it is a little
   wider and brings some misses inside (benchmarks/calibrate/interval_honesty/README.md, "Too
   few moves for the per-move sandwich?"). Where leaving some move out leaves a direction
   without information (a
   parameter only that move informs), the jackknife cannot say how far it moves and is left
   out (``jackknife_skipped`` says so). It is not among the forms of the weak directions (5).
   The intervals
   hold for a twin of the right structure; a twin of the wrong structure (the nominal position
   servo against a torque-mode PD) has systematic residuals, and its intervals then measure the
   fit, not the robot; the parameters not fitted widen them (10). Nor do they cover what the
   optimiser left: a fit stopped by the evaluation budget (``converged`` false in the report)
   can end outside them (benchmarks/calibrate).
5. **Identifiability.** The singular values of J scaled to the coordinates (a unit is one e-fold
   of a log parameter, ``typical`` of a linear one) give the directions the data pins worst;
   a direction whose 95 % half-width s * 1.96 / sigma_k exceeds ``weak_halfwidth`` is reported
   as one the data cannot identify, named as its combination of parameters. Parameters that end
   at a bound are reported as stuck (their interval is then not a confidence interval).
6. **Rollouts.** The starting and the calibrated robot roll out every TestPool move
   (:func:`~littledog_mlsim.robot.baseline.evaluate_baseline`): the final (x, y) error before and
   after.
7. **What else the residual asks for** (``missing``). At the optimum, every parameter of the
   registry that was not fitted (and that the servo has) gets a score test: its Jacobian column
   (a one-sided difference of ``diff_step`` coordinates, towards the inside of its bounds),
   with the fitted columns projected out, against the residual. The statistic is the squared
   score over its per-sample robust variance (chi-squared with one degree of freedom where the
   parameter is not needed; clustered by sampled state as the intervals are, so the states of
   one move count as independent and the p-value is on the small side), and a Gauss-Newton step, kept inside the bounds, gives the value it
   points to and the share of the cost it would remove (none for a parameter at a bound that
   the residual pushes outwards). The test is local and one parameter at a time: it detects
   what is missing, but rivals that act alike (a joint-rate filter and a servo's gains) are each
   asked for, and the suggested value and share are a first-order guess, not an estimate (with
   two gains left out, one gain's step can even point the wrong way): refit with them. A parameter is reported as asked for when its p-value is below
   0.001 over the number tested and that share is at least ``ask_share``; ``calibrate`` then
   prints it with its value, to be added to ``--params``. It costs one re-simulation per
   candidate, outside ``max_evals`` (``test_missing=False``, ``--no-missing-test``: skipped,
   ``missing`` null); a candidate whose moved robot diverges is left out. A threshold
   (``TwinParameter.threshold``: a torque limit) is read by a secant, not a derivative: lowered
   by twice the consider spread (item 10; 0.3 e-folds by default). A limit above every torque
   the twin's motion asks for has a derivative of zero, however much lower the robot's own
   limit is: such a limit is never asked for, and the gains, dampings and masses take up its
   effect (benchmarks/blind_zoo/LOG.md, "A threshold's bias held, and a torque limit left
   unfitted: zoo36 run1 (blind)"); the secant sees a limit the motion would reach within the
   plausible range. With
   ``threshold_up`` (on by default; ``--no-threshold-up``) a limit is also raised by as much
   (:func:`raised_columns`, one more re-simulation each): a twin whose limit cuts torques
   the robot's does not shows it only there, since the secant down is dominated by the
   torques between its two points, which neither cuts; such a limit, left as assumed, biases
   the other parameters (benchmarks/calibrate/interval_honesty/hip_limits_probe/README.md).
   The raised column only reads a
   higher limit and the secant down then only a lower one (a side whose step leaves its side
   has no statistic); the limit's entry is the side that asks, else the one with the larger
   cost share (``side``, present only where both sides were read), and every column counts in
   the level. A limit that raising changes nothing is tested downwards only, as before, and
   there is no raised side without a consider spread (``consider_spread`` 0).
8. **Servo structure** (``servo``). A twin can have the wrong servo structure: the nominal
   robot's idealised position servo against a robot whose joints run a torque-mode PD. Its
   parameters then absorb what the structure cannot express, and the rollout can end further off
   than before the fit. ``servo="position"`` or ``"pd_torque"`` fits that structure (a position
   robot turned torque-mode keeps its config's ``kp``/``kd`` as the start, and gets the
   gearboxes' reflected rotor inertia as armature if it has none: without it the 2 ms
   torque-mode PD is unstable on a swinging leg, ``robot/config.py``); ``"auto"`` fits
   both and keeps the one whose k-step residual on the fitted moves is lower, measured by the
   first stage's objective with the starting robot's weights (the same residuals and the same
   weights for both, so their costs compare; the TestPool is not used to choose). Both fits
   are first run for :data:`STRUCTURE_SCREEN_EVALS` evaluations each (the screen); where one
   structure's best k-step cost there is at least :data:`STRUCTURE_SCREEN_RATIO` times the
   other's, only the other is fitted on (decision 056). A fit is deterministic, so the one
   fitted on passes the same points with the screen's evaluations served from memory, and
   ends where a fit without the screen ends. The report's ``structure`` gives both fits, a
   screened-out one with its screen (``screened``).
9. **Adding what the residual asks for** (``add_asked``, ``--add-asked N``). The fitted
   parameters absorb what a parameter left out would explain (a short set-point delay shows
   as stiffer gains), and a diagnosis against that twin then names the left-out parameter as
   an effect of clean data. With ``add_asked`` N > 0, the fit (in the structure ``servo``
   chooses) is followed by up to N rounds: the parameters the score test asks for are added,
   and so are those the intervals blame (:func:`blamed_by_intervals`: a parameter not fitted
   whose consider sd share, 10, exceeds the data's sd of some fitted parameter; the score test
   cannot see a parameter whose effect the fitted ones can take over, which is exactly the
   one that biases them), and all are fitted again from the optimum, each round with its own
   ``max_evals``, raised to at least ``ROUND_EVALS_PER_COLUMN`` Jacobians of the larger set,
   until nothing new is asked for. Every parameter asked for is added at once: rivals that act
   alike are then fitted together, and the refit's weak directions name what the data cannot
   tell apart. The report's ``added`` lists each round: what was added, the fit before it
   (convergence, evaluations, estimates) and the k-step cost before and after (the measure of
   8, with the weights of the first fit's starting robot, in the structure ``servo`` chose, so
   that rounds compare); ``n_evals_total`` counts the re-simulations of every fit that
   finished (both structures' with ``auto``), ``added_for_intervals`` the round's parameters
   that the intervals blamed, and
   ``settings`` records ``add_asked``, ``threshold_round`` and ``servo``. The top-level
   estimates, costs and ``stop`` are the last fit's; its estimates' ``start`` is the previous
   round's optimum, except for a torque limit the score test asked for (below). A refit that
   fails, for any reason, keeps the fit before it, and says why. **A torque limit asked for**
   starts its round at the value the score test suggests (its Gauss-Newton step, along the
   secant of 7), but no lower than the secant's own point, the lowest value the test
   re-simulated: where the limit was, no torque reaches it and a difference there has no slope;
   one asked for on its raised side (7) starts no higher than the raised secant's point, since
   above every torque it has no slope either.
   The round's ``started_at`` gives each such limit's value before, the suggestion and the
   start. If that refit ends above the k-step cost before the round, the round is fitted again
   from the previous optimum (``restarted`` gives the first refit's cost). A limit the
   intervals blame starts where it was. **A threshold round** (``threshold_round``, on by
   default; ``--no-threshold-round``): a torque limit that the score test asks for after the
   last of the N rounds gets one more round, with only the torque limits asked for added. A
   robot whose limit is below the twin's, but above every torque the twin's motion asks for,
   leaves no trace in the residual until a fit has moved the twin to where the limit binds
   (the secant of 7 reads it only then), so the earlier rounds could not have added it; its
   round is marked ``threshold_round`` in ``added``. Other parameters asked for after the last
   round are only named.
10. **What the parameters not fitted add to the intervals** (``consider_spread``, a consider
   analysis in the estimation sense). The intervals of 4 assume that every parameter left out
   of the fit is right. On a real robot none is known exactly, and where one acts along a
   direction the data pins weakly, its error moves the optimum further than the data's noise
   does: if every mass and every servo torque scale together, the motion stays the same but
   for what does not scale (the rotor inertia, the contact's stiffness), so an armature a few
   per cent off shifts the masses and gains together by as much
   (benchmarks/blind_zoo/zoos/zoo31/runs/run1/README.md). Each parameter not fitted (the score
   test's columns of 7: no extra re-simulation)
   gets an a-priori standard deviation, :func:`consider_sd`: ``consider_spread`` (default
   0.15) e-folds of a scale-like parameter, that fraction of the larger of its value and
   ``typical`` for the others; the optimum's shift per unit of it is S = (J^T J)^-1 J^T J_c,
   and S C S^T (C the a-priori variances) is added to the widest covariance of 4. A parameter
   whose ``same_as`` are all fitted (``mass_scale`` with both masses, one friction coefficient
   with the other) is another name for them and is left out. The default spread is the size
   of the gap between a calibrated twin and a real robot that the project's gap robots are
   built to (a few per cent to a few tens of per cent); a user with a datasheet sets it
   smaller. A torque limit with a raised column (7) acts by one column below its value and by
   the other above; its a-priori spread is symmetric, so each carries half its variance
   (``sides`` 2 in ``considered``). A limit that raising changes nothing keeps its full
   variance on the lowered column: wider than the half its upper side would carry, on purpose.
   The report's ``consider`` names the parameters considered and, per fitted parameter, its
   consider sd and the three that give most of it; ``ci95`` is the widened interval and
   ``ci95_data`` the data's alone. Weak directions (5) stay the data's. Without
   the score test (``test_missing=False``) there are no columns and the intervals are the
   data's.
11. **The fit's own bias** (``bootstrap``, ``--bootstrap N``; :mod:`.twin_bias`). Starting states
   that are estimates (a smoothed pose, late filtered rates, quantised angles) bias the optimum
   by a few per cent even where the twin's structure is the robot's, more than the intervals of
   4 allow (benchmarks/blind_zoo/zoos/zoo32/runs/bootstrap_check/README.md). With N > 0 the
   fitted twin records the fitted moves
   again with their commands and the recording's sensing and is fitted again from its own
   values (in one weighted stage, 2); the shift is subtracted, and with N > 1 measured again
   at the corrected twin (a
   fixed-point iteration); the intervals gain the shift's uncertainty. With
   ``bootstrap_replicates`` R > 1 each iteration refits R recordings with their own noise
   seeds: the bias is their mean, and their spread, where larger than the data's sd, is the
   estimator's: it can be well above the data's sd
   (benchmarks/blind_zoo/zoos/zoo32/runs/secant_check/README.md, 3).
   A correction stops at the parameter's bound (the estimate then says so); a refit that fails
   keeps the last good correction, or the fit, and the report says why. The report's
   ``bootstrap`` gives, per parameter, the fitted value, the biases, the refits' spread and
   the corrected value; ``params`` and the twin are the corrected ones, while ``sd_coordinate``,
   ``correlation``, ``consider``, ``residual_rms`` and the costs stay the fit's before it.
   **Only an optimum is corrected.** The refits start at the twin, which is their truth, and
   converge; their shift is the bias of a converged fit. A fit the evaluation budget stopped
   (``converged`` false) is not at its optimum, and its distance from it is not in that shift
   (a fit stopped on its budget and corrected by the refits' shift still costs more than the
   robot itself, and fitted on to convergence it covers more true values: benchmarks/calibrate/
   README.md, "A fit its budget stopped (zoo51's reference)"; decision 058). Such a fit is
   **continued** instead (:func:`_continued`): fitted again from where it
   stopped, with the evaluations the bootstrap would have spent (N x R refits of a round's
   budget, 9); the report's ``continued`` says from where, the cost before and after and
   whether it converged, and ``bootstrap.skipped`` why no bias was taken out. With
   ``bootstrap_continued`` (``--bootstrap-continued``; off by default) a continuation that
   converged is an optimum, and its bias is then taken out as above: ``continued`` stays, the
   report's ``bootstrap`` is the correction's; ``settings.bootstrap_continued`` records the
   option. It costs the bootstrap's refits on top of the continuation.

12. **The common scale** (``scale_symmetry``). A robot whose every mass, rotor inertia and
   servo torque (gains, dampings, limits) scale by one factor moves the same way under gravity
   and on an LCP contact: the re-simulation's residuals do not change, to rounding
   (benchmarks/blind_zoo/zoos/zoo34/runs/after_run1/README.md, 3). The finite-difference
   Jacobian does not show it: one parameter moved alone changes the contacts' course, and
   those responses do not add up, so J^T J is full rank along a direction the data do not
   constrain (|J v| far above the difference along v: the same README, 4). Where a mass and at
   least one other such parameter are fitted, the
   residuals are re-simulated along that common scale (two evaluations), and where its 95 %
   half-width (from that difference) exceeds ``weak_halfwidth``, it is reported first among
   the weak directions, and the parameters in it get no interval: only a weighed mass (a mass
   left out of the fit at its weighed value) or a parameter that breaks the symmetry and binds
   tells the scale. Where it is bounded, the intervals of its parameters gain the width that
   difference leaves along it. The report's ``scale_symmetry`` has the combination, the
   derivative along it measured and as the Jacobian gives it, the half-width and
   ``identified``.

13. **A weighed robot** (``weighed_mass``, ``--weighed-mass KG``; :func:`weigh`). The robot's
   total mass on a scale (:func:`~.parameters.total_mass`) tells the common scale of 12.
   **In the fit** (``weigh_in_fit``, ``--weigh-in-fit``; off by default): each
   stage starts on the weighed scale (the start moved along v, below, to the weighed total)
   and the weighing is one more residual of the least squares, (log M(x) - log M_w) /
   (sd_w / M_w), so that the parameters off the scale (the contact's friction, a delay, a
   filter) are fitted where the scale is, not where the unweighed fit wandered along it
   (moved only afterwards along the scale, the twin's cost rises and the friction, delay and
   filter stay where the unweighed fit put them: benchmarks/blind_zoo/zoos/zoo37/runs/
   after_run1/README.md, 3). It is off by default because it does not pay: on the gap robots
   where it was tried it covered as many or a few more true values and left the TestPool
   rollout worse, since the k-step optimum away from the weighed scale predicts better
   (benchmarks/blind_zoo/zoos/zoo37/runs/run3_weigh_in_fit/README.md,
   benchmarks/blind_zoo/zoos/zoo38/runs/run2_weigh_after_fit/README.md). The row is
   not in J, the intervals or the score test; the report's ``weighing_in_fit`` gives the
   total mass at the start and the end and the row's last value. **After the fit**, its
   fitted parameters move together along x + t v (v: d x / d t when each scales
   by e^t). The weighing puts t at t_w, where the fitted masses sum to the weighed mass, with
   sd (weighing sd / mass) / (d log M / d t); the data put it at 0 with the information
   |d r / d t|^2 / s^2 of the residuals re-simulated along v (12's two evaluations, not the
   Jacobian's columns), less what the parameters not fitted could move it by (a rotor inertia
   left at its assumed value ties the scale to itself: the square of its consider sd (item 10)
   times (d r/d t . J_c) / |d r/d t|^2 is added to the data's variance). Where re-simulating
   along v fails or diverges, the weighing alone sets t. Combined as independent
   measurements: t = t_w w / (w + i), sd
   1 / sqrt(w + i), w = 1 / sd_w^2, i the data's. The twin moves to t (cut at the bounds), each
   estimate's coordinate gains that sd times its v in quadrature (as a bounded scale's do in
   12), and the scale is weak only if that sd's 95 % half-width along the unit-norm combination
   exceeds ``weak_halfwidth``; once the weighing bounds it, a weak direction of the Jacobian
   along it (|overlap| > 0.9) is dropped. The report's
   ``scale_symmetry.weighed`` gives the weighing, both masses, the steps, the sds and the cost
   before and after the move (equal where the scale is an exact symmetry).

14. **Second starts across the masses' split** (``split_starts``, ``--split-starts F``; off by
   default). The k-step objective can have more than one minimum along the split of the mass
   between the body and the legs (the total is fixed by the weighing of 13, the split is not):
   the servo gains, dampings and rotor inertias take up a wrong split, and a fit from the
   nominal robot can end in the wrong basin, with the legs' mass well off, where a fit started
   across the split ends at a lower cost with the smaller mass error (benchmarks/calibrate/
   README.md, "Two basins along the masses' split"; decision 059). With F > 0 the fit (after
   its rounds, 9) is fitted again, with the same parameters,
   a round's budget and the fit's weights at its optimum (one stage, 2), from two more starts:
   its optimum with the legs x(1 - F) and x(1 + F),
   the body taking the difference so that the total stays (:func:`split_start`). The lowest
   k-step cost (the measure of 8, with the weights of the last round's starting robot) is
   kept. Each other minimum is then compared with it on the fitted moves
   (:func:`minima_compared`): both re-simulated, weighted at the kept one, the per-move cost
   differences summed over their standard error (the moves independent, the states of a move
   not, as the intervals' clustering by move). Where that z is below the two-sided 95 %
   quantile of Student's t (:data:`SPLIT_TIE_LEVEL`, n - 1 degrees of freedom for n moves) the
   data do not tell the two apart, and every interval becomes the hull of its own and that
   minimum's, with its value (after the bootstrap, which corrects the kept minimum only, or
   continues it, and with ``bootstrap_continued`` corrects it once it converged, 11). A
   comparison that fails counts as not told apart. The report's ``split_starts`` has each
   start (its masses (the fit's: its optimum), cost, convergence, evaluations, estimates and
   comparison), ``chosen``, ``tied`` and ``widened``; a fit without both masses is left alone
   and says so (``skipped``). A kept start that had not converged is continued by the
   bootstrap (11), and the others are compared again with where it ended
   (``compared_after``). It costs two fits of the last round's parameters (each up to a
   round's budget) and two re-simulations per comparison; a start that fails is reported and
   left out.

The twin file (:mod:`.twin`) is written atomically, only when the fit succeeded.
"""
from __future__ import annotations

import logging
import math
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from . import baseline as _bl
from ..data.recording import MoveRecording
from ..layout import STATE_NAMES
from .config import MEASURED_ARMATURE as REFLECTED_ROTOR_INERTIA
from .config import RobotConfig
from .parameters import (DEFAULT_CALIBRATION_PARAMS, TWIN_PARAMETERS, TwinParameter, total_mass,
                         twin_parameters)

__all__ = ["SERVO_CHOICES", "with_servo", "missing_parameters", "unfitted_columns",
           "raised_columns", "consider_analysis", "consider_sd", "blamed_by_intervals",
           "CalibrationOptions",
           "Estimate", "WeakDirection", "Calibration", "calibrate_twin",
           "calibrate_dataset", "twin_residuals", "twin_residuals_many", "weak_directions",
           "scale_symmetry", "SCALES_WITH_MASS", "weigh", "split_start", "minima_compared"]

log = logging.getLogger(__name__)

Z95 = 1.959964
SERVO_CHOICES = ("keep", "position", "pd_torque", "auto")
DIVERGED_RESIDUAL = 1e3      # a weighted residual standing in for a non-finite one


@dataclass(frozen=True)
class CalibrationOptions:
    """Settings of :func:`calibrate_twin` (module doc)."""

    params: tuple[str, ...] | None = None   # None: DEFAULT_CALIBRATION_PARAMS of the servo
    stride: int = 20                        # steps between sampled states
    horizons: tuple[int, ...] = (1, 10)     # control steps re-simulated (residual at each)
    moves_per_type: int | None = 2          # TrainPool moves per type fitted (None: all)
    max_evals: int = 150                    # residual evaluations, Jacobian columns included
    diff_step: float = 0.05                 # central-difference step in fit coordinates
    weak_halfwidth: float = 0.25            # 95 % half-width beyond which a direction is weak
    jobs: int = 2
    name: str | None = None                 # the twin's name (default BASE-calibrated)
    scheduler: str | None = None            # fit's re-simulations on this Dask cluster
    servo: str = "keep"                     # keep | position | pd_torque | auto (module doc, 8)
    ask_share: float = 0.01                 # cost share a missing parameter must remove (doc, 7)
    test_missing: bool = True               # score-test the parameters not fitted (doc, 7)
    initial_state: str = "auto"             # auto | smoothed | measured starting states (doc, 1)
    add_asked: int = 0                      # rounds adding what the residual asks for (doc, 9)
    threshold_round: bool = True            # a torque limit asked for after them: a round (9)
    consider_spread: float = 0.15           # a-priori sd of the parameters not fitted (doc, 10)
    bootstrap: int = 0                      # refits on the twin's own recordings (doc, 11)
    bootstrap_replicates: int = 1           # noise seeds per bootstrap iteration (doc, 11)
    weighed_mass: float | None = None       # the robot's weighed mass [kg] (doc, 13)
    weighed_mass_sd: float = 0.01           # the weighing's standard deviation [kg]
    weigh_in_fit: bool = False              # the weighing a residual of the fit (doc, 13)
    split_starts: float = 0.0               # second starts across the masses' split (doc, 14)
    bootstrap_continued: bool = False       # a continued fit that converged: its bias too (11)
    threshold_up: bool = True               # a torque limit's secant upwards too (doc, 7)
    jackknife: bool = True                  # the per-move jackknife among the sd (doc, 4)

    def check(self) -> None:
        if self.servo not in SERVO_CHOICES:
            raise ValueError(f"servo must be one of {', '.join(SERVO_CHOICES)}, got "
                             f"{self.servo!r}")
        if int(self.stride) != self.stride or self.stride < 1:
            raise ValueError(f"stride must be a positive integer, got {self.stride!r}")
        if not self.horizons or any(int(h) != h or h < 1 or h > 100 for h in self.horizons):
            raise ValueError(f"horizons must be integers in 1..100 steps, got {self.horizons!r}")
        if self.moves_per_type is not None and self.moves_per_type < 1:
            raise ValueError(f"moves_per_type must be >= 1, got {self.moves_per_type}")
        if not 0 <= self.ask_share < 1:
            raise ValueError(f"ask_share must be in [0, 1), got {self.ask_share}")
        if self.max_evals < 4:
            raise ValueError(f"max_evals must be >= 4, got {self.max_evals}")
        if not 1e-4 <= self.diff_step <= 0.5:
            raise ValueError(f"diff_step must be in [1e-4, 0.5], got {self.diff_step}")
        if self.jobs < 1:
            raise ValueError(f"jobs must be >= 1, got {self.jobs}")
        if int(self.add_asked) != self.add_asked or not 0 <= self.add_asked <= 5:
            raise ValueError(f"add_asked must be an integer in 0..5, got {self.add_asked!r}")
        if not 0 <= self.consider_spread <= 1:
            raise ValueError(f"consider_spread must be in [0, 1], got {self.consider_spread}")
        if int(self.bootstrap) != self.bootstrap or not 0 <= self.bootstrap <= 10:
            raise ValueError(f"bootstrap must be an integer in 0..10, got {self.bootstrap!r}")
        if (int(self.bootstrap_replicates) != self.bootstrap_replicates
                or not 1 <= self.bootstrap_replicates <= 10):
            raise ValueError("bootstrap_replicates must be an integer in 1..10, got "
                             f"{self.bootstrap_replicates!r}")
        if self.bootstrap_replicates > 1 and not self.bootstrap:
            raise ValueError("bootstrap_replicates needs bootstrap (at least 1 iteration)")
        if self.bootstrap_continued and not self.bootstrap:
            raise ValueError("bootstrap_continued needs bootstrap (at least 1 iteration)")
        if self.weighed_mass is not None and not (
                math.isfinite(self.weighed_mass) and 0.5 <= self.weighed_mass <= 30.0):
            raise ValueError("weighed_mass must be the robot's mass in kg (0.5 to 30), got "
                             f"{self.weighed_mass!r}")
        if not (math.isfinite(self.weighed_mass_sd) and 0 < self.weighed_mass_sd <= 5.0):
            raise ValueError("weighed_mass_sd must be a positive number of kg (at most 5), got "
                             f"{self.weighed_mass_sd!r}")
        if self.add_asked and not self.test_missing:
            raise ValueError("add_asked needs the score test of the parameters not fitted "
                             "(test_missing)")
        if not (math.isfinite(self.split_starts) and 0 <= self.split_starts <= 0.5):
            raise ValueError("split_starts must be a fraction of the leg mass in [0, 0.5] "
                             f"(0: off), got {self.split_starts!r}")
        if self.initial_state not in ("auto",) + _bl.INITIAL_STATES:
            raise ValueError("initial_state must be one of auto, "
                             f"{', '.join(_bl.INITIAL_STATES)}, got {self.initial_state!r}")


@dataclass(frozen=True)
class Estimate:
    """One calibrated parameter: start and fitted value, 95 % interval, bound it is stuck at."""

    name: str
    unit: str
    start: float
    value: float
    ci95: tuple[float | None, float | None]   # None: not bounded by the data
    at_bound: str | None                      # "lower" | "upper" | None
    # the interval from the data alone, without what the parameters not fitted add (module
    # doc, 10); None where the consider analysis did not run
    ci95_data: tuple[float | None, float | None] | None = None

    def contains(self, v: float) -> bool:
        lo, hi = self.ci95
        return (lo is None or lo <= v) and (hi is None or v <= hi)


@dataclass(frozen=True)
class WeakDirection:
    """A parameter combination the data pins worst: its singular value and 95 % half-width in
    fit coordinates, and the combination (coefficients of the unit-norm direction)."""

    singular_value: float
    halfwidth95: float | None
    combination: dict[str, float]

    def describe(self) -> str:
        terms = sorted(self.combination.items(), key=lambda kv: -abs(kv[1]))
        text = " ".join(f"{'+' if c >= 0 else '-'} {abs(c):.2f} {n}" for n, c in terms
                        if abs(c) >= 0.05)
        return text.lstrip("+ ")


@dataclass
class Calibration:
    """The result of :func:`calibrate_twin`; ``report`` is its JSON-ready summary."""

    config: RobotConfig
    estimates: list[Estimate]
    weak: list[WeakDirection]
    report: dict[str, Any] = field(default_factory=dict)


# ---------------------------------------------------------------------------------------------
# residuals, evaluated in worker processes (one per move)


def _residual_task(config: RobotConfig, stride: int, horizons: tuple[int, ...], initial: str,
                   i: int) -> np.ndarray:
    """Raw residuals (n_t, len(horizons), 33) of move i (``baseline._RECS``)."""
    _, true, pred = _bl.k_step_predictions(_bl._RECS[i], config, max(horizons), stride,
                                           initial=initial)
    with np.errstate(invalid="ignore", over="ignore"):
        r = pred[:, [h - 1 for h in horizons]] - true[:, [h - 1 for h in horizons]]
    return np.where(np.isfinite(r), r, np.inf)


def twin_residuals(pool: Any, config: RobotConfig, stride: int,
                   horizons: tuple[int, ...], initial: str = "measured") -> list[np.ndarray]:
    """Per move, the raw residuals (n_t, len(horizons), 33) of ``config`` (module doc, 1),
    re-simulated from the ``initial`` starting states (``baseline.INITIAL_STATES``)."""
    return pool.map(_residual_task, config, int(stride), tuple(int(h) for h in horizons),
                    str(initial))


def twin_residuals_many(pool: Any, configs: Sequence[RobotConfig], stride: int,
                        horizons: tuple[int, ...], initial: str = "measured"
                        ) -> list[list[np.ndarray]]:
    """:func:`twin_residuals` of each robot of ``configs``, the same arrays, as one batch of
    the pool's work (``map_many``: a finite-difference Jacobian's robots side by side); one
    robot after another where the pool has no ``map_many``."""
    head = (int(stride), tuple(int(h) for h in horizons), str(initial))
    if not hasattr(pool, "map_many"):
        return [twin_residuals(pool, c, stride, horizons, initial) for c in configs]
    return pool.map_many(_residual_task, [(c, *head) for c in configs])


def _weighted(raw: Sequence[np.ndarray], scale: np.ndarray) -> np.ndarray:
    """Residuals divided by their (horizon, element) scale, flattened; non-finite -> large."""
    r = np.concatenate([(m / scale).reshape(-1) for m in raw])
    return np.where(np.isfinite(r), r, DIVERGED_RESIDUAL)


def _rms_scale(raw: Sequence[np.ndarray]) -> np.ndarray:
    """RMS per (horizon, element) of the residuals; a zero RMS (an element nothing moves)
    counts as 1 so that it neither divides by zero nor weighs."""
    all_r = np.concatenate(raw, axis=0)
    with np.errstate(invalid="ignore", over="ignore"):
        rms = np.sqrt(np.mean(all_r ** 2, axis=0))
    if not np.all(np.isfinite(rms)):
        raise ValueError("the starting robot's re-simulation is not finite on the recording")
    return np.where(rms > 0, rms, 1.0)


# ---------------------------------------------------------------------------------------------
# the fit


class _Problem:
    """Residual function and finite-difference Jacobian over fit coordinates, memoised, with
    an evaluation budget."""

    def __init__(self, pool: Any, base: RobotConfig, params: Sequence[TwinParameter],
                 options: CalibrationOptions, progress: Callable[[str], None],
                 cache: dict[tuple[float, ...], list[np.ndarray]] | None = None) -> None:
        self.pool, self.base, self.params, self.o, self.say = pool, base, params, options, progress
        self.cache: dict[tuple[float, ...], list[np.ndarray]] = {} if cache is None else cache
        self.screen: float = math.inf   # distinct robots simulated before _ScreenDone
        self.scale: np.ndarray | None = None
        self.limit: float = options.max_evals   # distinct robots simulated before _BudgetSpent
        self.lo = np.array([p.x_bounds()[0] for p in params])
        self.hi = np.array([p.x_bounds()[1] for p in params])

    def config(self, x: np.ndarray) -> RobotConfig:
        cfg = self.base
        for p, xi in zip(self.params, x):
            lo, hi = p.bounds
            cfg = p.set(cfg, float(min(max(p.from_x(float(xi)), lo), hi)))
        return cfg

    @staticmethod
    def key(x: np.ndarray) -> tuple[float, ...]:
        return tuple(np.round(np.asarray(x, float), 12))

    def raw(self, x: np.ndarray) -> list[np.ndarray]:
        self.raw_many([x])
        return self.cache[self.key(x)]

    def raw_many(self, xs: Sequence[np.ndarray]) -> None:
        """Into the cache: the residuals at each point of ``xs`` not there yet, simulated as
        one batch (:func:`twin_residuals_many`). Where the budget runs out, the points it still
        allows are simulated and kept, in order, and then :class:`_BudgetSpent` is raised: the
        cache ends as evaluating the points one by one leaves it."""
        new: dict[tuple[float, ...], np.ndarray] = {}
        for x in xs:
            k = self.key(x)
            if k not in self.cache and k not in new:
                new[k] = np.asarray(x, float)
        cap = min(self.limit, self.screen)
        room = max(0, min(len(new), cap - len(self.cache)))   # the limit may be inf
        spent = len(new) > room
        todo = list(new.items())[:int(room)]
        if todo:
            t0 = time.perf_counter()
            raws = twin_residuals_many(self.pool, [self.config(x) for _, x in todo],
                                       self.o.stride, self.o.horizons, self.o.initial_state)
            dt = time.perf_counter() - t0
            for (k, x), raw in zip(todo, raws):
                self.cache[k] = raw
                cost = None if self.scale is None else 0.5 * float(np.sum(self.fun(x) ** 2))
                self.say(f"  [{len(self.cache)}/{self.o.max_evals}] "
                         + " ".join(f"{p.name}={p.from_x(float(v)):.4g}"
                                    for p, v in zip(self.params, x))
                         + ("" if cost is None else f" cost {cost:.1f}")
                         + (f" ({dt:.1f} s)" if len(todo) == 1
                            else f" ({dt / len(todo):.1f} s: one of {len(todo)} in {dt:.1f} s)"))
        if spent:
            raise _ScreenDone if self.screen < self.limit else _BudgetSpent

    def fun(self, x: np.ndarray) -> np.ndarray:
        return _weighted(self.raw(x), self.scale)

    def jac(self, x: np.ndarray) -> np.ndarray:
        """Central differences of step ``diff_step`` coordinates (one-sided at a bound); the
        points simulated as one batch (:meth:`raw_many`)."""
        pairs = []
        for k, p in enumerate(self.params):
            h = self.o.diff_step * p.x_scale
            up, down = np.array(x, float), np.array(x, float)
            up[k], down[k] = min(x[k] + h, self.hi[k]), max(x[k] - h, self.lo[k])
            if up[k] == x[k] or down[k] == x[k]:
                up[k] = x[k] if up[k] == x[k] else up[k]
                down[k] = x[k] if down[k] == x[k] else down[k]
            pairs.append((up, down))
        self.raw_many([v for pair in pairs for v in pair])
        cols = [(self.fun(up) - self.fun(down)) / (up[k] - down[k])
                for k, (up, down) in enumerate(pairs)]
        return np.stack(cols, axis=1)


class _BudgetSpent(Exception):
    pass


class _ScreenDone(Exception):
    """A structure's screen (:func:`_screen_structure`) has used its evaluations."""


_STOPS = {0: "iteration limit", 1: "converged (gradient)", 2: "converged (cost)",
          3: "converged (step)", 4: "converged (cost and step)"}


def _least_squares(prob: _Problem, x0: np.ndarray, max_nfev: int,
                   weighing: "_WeighingRow | None" = None) -> tuple[np.ndarray, str]:
    """One weighted least-squares stage from x0: (optimum, why it stopped); the best point
    seen if the evaluation budget runs out. ``weighing``: the weighed mass as one more
    residual (module doc, 13)."""
    from scipy.optimize import least_squares

    def fun(x: np.ndarray) -> np.ndarray:
        r = prob.fun(x)
        return r if weighing is None else np.concatenate([r, weighing.fun(x)])

    def jac(x: np.ndarray) -> np.ndarray:
        J = prob.jac(x)
        return J if weighing is None else np.vstack([J, weighing.jac(x)])

    x_scale = np.array([p.x_scale for p in prob.params])
    try:
        res = least_squares(fun, x0, jac=jac, bounds=(prob.lo, prob.hi),
                            x_scale=x_scale, method="trf", max_nfev=max_nfev,
                            xtol=1e-3, ftol=1e-4, gtol=1e-6)
        return np.asarray(res.x, float), _STOPS.get(res.status, f"status {res.status}")
    except _BudgetSpent:
        prob.say("  evaluation budget spent; keeping the best point so far")
        best = min(prob.cache, key=lambda k: float(np.sum(fun(np.array(k)) ** 2)))
        return np.array(best), "evaluation budget spent"


class _WeighingRow:
    """The weighed mass as a residual of the fit (module doc, 13): (log M(x) - log M_w) /
    (sd_w / M_w), M(x) the total mass of the robot at coordinates x; its derivative by central
    differences of the masses alone (no re-simulation)."""

    def __init__(self, prob: _Problem) -> None:
        self.prob = prob
        self.target = math.log(prob.o.weighed_mass)
        self.sd = prob.o.weighed_mass_sd / prob.o.weighed_mass

    def log_mass(self, x: np.ndarray) -> float:
        return math.log(total_mass(self.prob.config(x)))

    def fun(self, x: np.ndarray) -> np.ndarray:
        return np.array([(self.log_mass(x) - self.target) / self.sd])

    def jac(self, x: np.ndarray) -> np.ndarray:
        row = np.zeros((1, len(x)))
        for k, p in enumerate(self.prob.params):
            if p.name not in _MASSES:
                continue
            h = 1e-6 * p.x_scale
            up, down = np.array(x, float), np.array(x, float)
            up[k], down[k] = x[k] + h, x[k] - h
            row[0, k] = (self.log_mass(up) - self.log_mass(down)) / (2 * h * self.sd)
        return row

    def start(self, x: np.ndarray) -> np.ndarray:
        """x moved along the common scale (:func:`_to_weighing`) to the weighed mass, cut at
        the bounds; x itself where the bounds cannot reach it (:func:`weigh` then says so)."""
        v, _, t = _to_weighing(self.prob, x)
        if t is None:
            return np.asarray(x, float)
        return np.clip(x + t * v, self.prob.lo, self.prob.hi)


def _sandwich(J: np.ndarray, r: np.ndarray, bread: np.ndarray, sizes: Sequence[int]
              ) -> np.ndarray:
    """(J^T J)^-1 [sum_c J_c^T r_c r_c^T J_c] (J^T J)^-1 C / (C - 1) over C clusters of
    ``sizes`` consecutive residuals each."""
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    g = np.add.reduceat(J * r[:, None], starts, axis=0)          # (C, p)
    c = len(sizes)
    return bread @ (g.T @ g) @ bread * (c / max(c - 1, 1))


def _jackknife(J: np.ndarray, r: np.ndarray, sizes: Sequence[int]) -> np.ndarray | None:
    """The leave-one-cluster-out jackknife covariance of the fit coordinates (CR3): with each
    cluster g of ``sizes`` consecutive residuals left out in turn, the Gauss-Newton step of the
    fit without it from here, delta_g = (J^T J - J_g^T J_g)^-1 (J^T r - J_g^T r_g), and the
    covariance (G - 1) / G sum_g (delta_g - mean)(delta_g - mean)^T (module doc, 4). None
    where leaving some cluster out leaves a direction without information (a parameter only
    that cluster informs): the jackknife cannot say how far it moves."""
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    A = J.T @ J
    g = np.add.reduceat(J * r[:, None], starts, axis=0)          # (G, p)
    total = g.sum(axis=0)
    diag = np.diag(A)
    unit = 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0))
    scaled = unit[:, None] * unit[None, :]     # ranks of the correlation-scaled matrices:
    rank = np.linalg.matrix_rank(A * scaled)   # the coordinates' units do not count
    d = []
    for k, (s, n) in enumerate(zip(starts, sizes)):
        A_k = A - J[s:s + n].T @ J[s:s + n]
        if np.linalg.matrix_rank(A_k * scaled) < rank:
            return None
        d.append(np.linalg.pinv(A_k) @ (total - g[k]))
    d = np.array(d)
    d -= d.mean(axis=0)
    c = len(sizes)
    return (c - 1) / c * (d.T @ d)


def _covariances(J: np.ndarray, r: np.ndarray, cluster: int,
                 move_sizes: Sequence[int] | None = None, jackknife: bool = False
                 ) -> tuple[np.ndarray, np.ndarray, float, int, np.ndarray | None,
                            np.ndarray | None]:
    """(plain, per-state robust) covariance of the fit coordinates, s^2, the d.o.f., the
    per-move robust covariance and, with ``jackknife``, the per-move jackknife (None without
    ``move_sizes``).

    plain = s^2 (J^T J)^-1, s^2 = SSE / (n - p). The robust ones are sandwiches clustered by
    sampled state (``cluster`` consecutive residuals each: every horizon and element of one
    state), which lets the residuals of one state be correlated, and by move (``move_sizes``:
    the residuals of each move, in order), which lets every state of a move be (module doc,
    4); :func:`_jackknife` over the moves as well."""
    n, p = J.shape
    dof = max(n - p, 1)
    s2 = float(np.sum(r ** 2)) / dof
    bread = np.linalg.pinv(J.T @ J)
    c = n // cluster
    robust = _sandwich(J[:c * cluster], r[:c * cluster], bread, [cluster] * c)
    by_move = jack = None
    if move_sizes is not None and len(move_sizes) > 1 and sum(move_sizes) == n:
        by_move = _sandwich(J, r, bread, list(move_sizes))
        if jackknife:
            jack = _jackknife(J, r, list(move_sizes))
    return s2 * bread, robust, s2, dof, by_move, jack


def _estimates(prob: _Problem, x: np.ndarray, J: np.ndarray, r: np.ndarray,
               start: np.ndarray, consider: np.ndarray | None = None
               ) -> tuple[list[Estimate], dict[str, Any], list[np.ndarray]]:
    """Estimates with 95 % intervals (module doc, 4): the widest of the plain, the per-state and
    the per-move robust interval, widened by the ``consider`` covariance of the parameters not
    fitted (module doc, 10) where given."""
    sizes = [m.size for m in prob.raw(x)]
    plain, robust, s2, dof, by_move, jack = _covariances(
        J, r, len(prob.o.horizons) * len(STATE_NAMES), sizes, prob.o.jackknife)
    sd_plain = np.sqrt(np.clip(np.diag(plain), 0, None))
    sd = np.maximum(sd_plain, np.sqrt(np.clip(np.diag(robust), 0, None)))
    sd_move = None if by_move is None else np.sqrt(np.clip(np.diag(by_move), 0, None))
    if sd_move is not None:
        sd = np.maximum(sd, sd_move)
    sd_jack = None if jack is None else np.sqrt(np.clip(np.diag(jack), 0, None))
    if sd_jack is not None:
        sd = np.maximum(sd, sd_jack)
    sd_data = sd
    if consider is not None:
        sd = np.sqrt(sd ** 2 + np.clip(np.diag(consider), 0, None))
    out = []
    for k, par in enumerate(prob.params):
        span = prob.hi[k] - prob.lo[k]
        at = ("lower" if x[k] - prob.lo[k] <= 1e-3 * span else
              "upper" if prob.hi[k] - x[k] <= 1e-3 * span else None)
        ci: tuple[float | None, float | None] = (None, None)
        ci_data: tuple[float | None, float | None] | None = None if consider is None else ci
        if np.isfinite(sd[k]) and sd[k] > 0 and np.any(J[:, k] != 0):
            ci = _interval(par, x[k], sd[k])
            if consider is not None:
                ci_data = _interval(par, x[k], sd_data[k])
        out.append(Estimate(par.name, par.unit, par.from_x(start[k]), par.from_x(x[k]), ci, at,
                            ci_data))
    stats = {"residual_variance": s2, "dof": dof,
             "sd_coordinate_plain": {p.name: float(v) for p, v in zip(prob.params, sd_plain)},
             "sd_coordinate": {p.name: float(v) for p, v in zip(prob.params, sd)},
             "sd_coordinate_data": {p.name: float(v) for p, v in zip(prob.params, sd_data)}}
    if sd_move is not None:
        stats["sd_coordinate_by_move"] = {p.name: float(v) for p, v in zip(prob.params, sd_move)}
    if sd_jack is not None:
        stats["sd_coordinate_jackknife"] = {p.name: float(v)
                                            for p, v in zip(prob.params, sd_jack)}
    elif prob.o.jackknife and by_move is not None:
        stats["jackknife_skipped"] = ("leaving a move out leaves a direction without "
                                      "information: a parameter only that move informs")
    # the weak directions (5) are the plain and sandwich forms' (the jackknife is not among
    # them: one move that pins a direction would make it weak)
    return out, stats, [plain, robust] + ([] if by_move is None else [by_move])


def _interval(par: TwinParameter, x: float, sd: float) -> tuple[float, float]:
    """x +- 1.96 sd in the fit's coordinate, as values, inside the parameter's bounds (a delay
    is not negative, a mass not below its bound)."""
    lo, hi = par.bounds
    return (max(par.from_x(x - Z95 * sd), lo), min(par.from_x(x + Z95 * sd), hi))


def weak_directions(J: np.ndarray, params: Sequence[TwinParameter],
                    covs: Sequence[np.ndarray], s2: float,
                    limit: float) -> tuple[list[WeakDirection], list[float]]:
    """The parameter combinations the data cannot identify (module doc, 5).

    ``J``: the residuals' Jacobian (n, p) in fit coordinates; ``covs``: covariances of those
    coordinates; ``s2``: the residual variance. The singular directions of J scaled to units of
    ``x_scale`` are taken weakest first; a direction's 95 % half-width (in those units) is the
    widest of the covariances and of s / sigma_k (what a singular J^T J hides from its
    pseudo-inverse); directions wider than ``limit`` are returned, a zero singular value with
    half-width None. Returns (weak directions, all singular values)."""
    scale = np.array([p.x_scale for p in params])
    _, sv, vt = np.linalg.svd(J * scale[None, :], full_matrices=False)
    scaled = [c / np.outer(scale, scale) for c in covs]
    weak = []
    for s, v in zip(sv[::-1], vt[::-1]):
        half = None
        if s > 0:
            var = max([float(v @ c @ v) for c in scaled] + [s2 / s ** 2])
            half = Z95 * math.sqrt(var)
        if half is not None and half <= limit:
            continue
        v = v if v[np.argmax(np.abs(v))] > 0 else -v
        weak.append(WeakDirection(float(s), None if half is None else float(half),
                                  {p.name: float(c) for p, c in zip(params, v)}))
    return weak, [float(s) for s in sv]


#: the parameters that scale with the robot's mass: every mass and every servo torque (gain,
#: damping, limit) and rotor inertia; scaled together they leave the motion under gravity
#: unchanged (module doc, 12)
SCALES_WITH_MASS = ("body_mass", "leg_mass", "mass_scale", "kp_", "kd_", "torque_limit_",
                    "armature_")
_MASSES = ("body_mass", "leg_mass", "mass_scale")


def _scale_direction(prob: "_Problem", x: np.ndarray) -> np.ndarray:
    """The common scale in fit coordinates: d x / d t for every fitted parameter that scales
    with the mass multiplied by e^t (1 for a log coordinate, the value for a linear one)."""
    config = prob.config(x)
    return np.array([(1.0 if p.log else p.get(config)) if p.name.startswith(SCALES_WITH_MASS)
                     else 0.0 for p in prob.params])


def _along(prob: "_Problem", x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """d r / d t along x + t v, from a central difference of ``diff_step`` (two evaluations,
    outside the fit's budget; memoised, so the common-scale check and the weighing share
    them)."""
    h = prob.o.diff_step
    prob.limit = max(prob.limit, len(prob.cache) + 2)
    return (prob.fun(x + h * v) - prob.fun(x - h * v)) / (2 * h)


def scale_symmetry(prob: "_Problem", x: np.ndarray, J: np.ndarray, s2: float,
                   limit: float) -> dict[str, Any] | None:
    """The data's hold on the common scale of the fitted mass and servo parameters (module
    doc, 12), measured by re-simulating along it (two evaluations), against what the
    Jacobian's columns say. None where no mass is fitted (a weighed mass pins the scale) or
    fewer than two such parameters are."""
    v = _scale_direction(prob, x)
    if np.count_nonzero(v) < 2 or not any(p.name in _MASSES for p in prob.params):
        return None
    scale = np.array([p.x_scale for p in prob.params])
    length = float(np.linalg.norm(v / scale))
    try:
        slope = float(np.linalg.norm(_along(prob, x, v))) / length
    except Exception as e:            # the fit stands; the check says it did not run
        log.warning("the common-scale check failed: %s", e)
        return None
    half = None if slope <= 0 else Z95 * math.sqrt(s2) / slope
    u = v / scale / length
    return {"combination": {p.name: float(c) for p, c in zip(prob.params, u) if c != 0},
            "derivative": slope, "jacobian_derivative": float(np.linalg.norm(J @ v)) / length,
            "halfwidth95": half, "identified": half is not None and half <= limit}


def _to_weighing(prob: "_Problem", x: np.ndarray
                 ) -> tuple[np.ndarray, Callable[[float], float], float | None]:
    """Along the common scale from x (x + t v, cut at the bounds): v, log M(t), and the step
    t_w at which the masses sum to the weighed mass (None where t in [-3, 3] cannot reach
    it)."""
    from scipy.optimize import brentq

    v = _scale_direction(prob, x)
    target = math.log(prob.o.weighed_mass)

    def log_mass(t: float) -> float:
        return math.log(total_mass(prob.config(np.clip(x + t * v, prob.lo, prob.hi))))

    if not log_mass(-3.0) <= target <= log_mass(3.0):
        return v, log_mass, None
    return v, log_mass, brentq(lambda t: log_mass(t) - target, -3.0, 3.0, xtol=1e-10)


def weigh(prob: "_Problem", x: np.ndarray, s2: float,
          columns: Sequence[tuple[TwinParameter, float, np.ndarray]] = ()
          ) -> tuple[np.ndarray, dict[str, Any]]:
    """The fit moved along the common scale of its mass and servo parameters to the weighed
    mass (module doc, 13): (the new coordinates, the report's ``scale_symmetry.weighed``).

    Along x + t v (v: :func:`_scale_direction`) the weighing says t = t_w, where the fitted
    masses give the weighed total, with sd (weighing sd / mass) / (d log M / d t); the data say
    t = 0 with the information |d r / d t|^2 / s^2 of the residuals measured along v (the
    Jacobian's is not: module doc, 12), less what the parameters not fitted (``columns``, the
    score test's) could move it: where one of them does not scale with the rest (a rotor
    inertia left at its assumed value), the residuals pin the scale to it, and its a-priori sd
    (:func:`consider_sd`) shifts that pin by (d r/d t . J_c) / |d r/d t|^2 per unit. The two
    combine as independent measurements of t. ValueError (one line) where no mass is fitted or
    the bounds cannot reach the weighing."""
    o = prob.o
    if not any(p.name in _MASSES for p in prob.params):
        raise ValueError("--weighed-mass needs a mass among the fitted parameters (body_mass, "
                         "leg_mass or mass_scale)")
    fitted = total_mass(prob.config(x))
    v, log_mass, t_w = _to_weighing(prob, x)
    if t_w is None:
        raise ValueError(f"the weighed mass {o.weighed_mass:g} kg is out of reach of the fitted "
                         f"masses' bounds (fitted total {fitted:.4g} kg)")
    d = 1e-4
    dlogm = (log_mass(t_w + d) - log_mass(t_w - d)) / (2 * d)
    if not dlogm > 0:
        raise ValueError("the weighed mass cannot move the fitted masses (each at a bound)")
    sd_w = o.weighed_mass_sd / o.weighed_mass / dlogm
    try:
        prob.limit = max(prob.limit, len(prob.cache) + 3)
        d = _along(prob, x, v)
        h = prob.o.diff_step
        ends = [prob.fun(x + h * v), prob.fun(x - h * v)]         # memoised by _along
        r0 = prob.fun(x)
        if any(np.any((e == DIVERGED_RESIDUAL) & (r0 != DIVERGED_RESIDUAL)) for e in ends):
            log.warning("the robot diverges along the common scale: the weighing alone sets it")
            d = np.zeros_like(r0)
    except Exception as e:            # the fit stands; the weighing alone sets the scale
        log.warning("re-simulating along the common scale failed (%s): the weighing alone sets "
                    "it", e)
        d = np.zeros(0)
    dd = float(d @ d)
    by: dict[str, float] = {}
    if dd > 0:
        for par, value, col in columns:
            if not par.renames({p.name for p in prob.params}):
                by[par.name] = float(d @ col) / dd * consider_sd(par, value, o.consider_spread)
    var_noise = s2 / dd if dd > 0 and s2 > 0 else math.inf
    var_d = var_noise + sum(b * b for b in by.values())
    info_d = 0.0 if not math.isfinite(var_d) or var_d <= 0 else 1.0 / var_d
    info = 1.0 / sd_w ** 2 + info_d
    t = t_w / sd_w ** 2 / info
    x_w = np.clip(x + t * v, prob.lo, prob.hi)
    prob.limit = max(prob.limit, len(prob.cache) + 1)
    cost_fit, cost_w = (0.5 * float(np.sum(prob.fun(xi) ** 2)) for xi in (x, x_w))
    clipped = [p.name for p, a, b in zip(prob.params, x + t * v, x_w) if a != b]
    return x_w, {"mass_kg": o.weighed_mass, "sd_kg": o.weighed_mass_sd,
                 "fitted_mass_kg": fitted, "twin_mass_kg": total_mass(prob.config(x_w)),
                 "scale_to_weighing": t_w, "scale_applied": t,
                 "sd_scale": 1.0 / math.sqrt(info), "sd_scale_weighing": sd_w,
                 "sd_scale_data": None if info_d <= 0 else 1.0 / math.sqrt(info_d),
                 "sd_scale_data_noise": (None if not math.isfinite(var_noise)
                                         else math.sqrt(var_noise)),
                 "sd_scale_data_by": {n: abs(b) for n, b in sorted(
                     by.items(), key=lambda kv: -abs(kv[1]))[:3] if b != 0},
                 "cost_fit": cost_fit, "cost_weighed": cost_w, "clipped": clipped,
                 "direction": v}


def _weighed_estimates(estimates: list[Estimate], stats: dict[str, Any],
                       params: Sequence[TwinParameter], x_w: np.ndarray, weighing: dict[str, Any],
                       limit: float) -> tuple[list[Estimate], dict[str, Any]]:
    """Estimates at the weighed coordinates ``x_w``, their intervals including the scale's sd
    after the weighing along its direction (as :func:`_widened` does for the data's), and the
    report's entry for the common scale."""
    v = weighing.pop("direction")
    scale = np.array([p.x_scale for p in params])
    length = float(np.linalg.norm(v / scale))
    combination = {p.name: float(c) for p, c in zip(params, v / scale / length) if c != 0}
    # the scale's sd is in t (x + t v); along the unit-norm combination a step t is t * length
    half = Z95 * weighing["sd_scale"] * length
    moved = []
    for k, (p, e) in enumerate(zip(params, estimates)):
        if v[k] == 0:
            moved.append(e)
            continue
        span = p.x_bounds()[1] - p.x_bounds()[0]
        lo, hi = p.x_bounds()
        at = ("lower" if x_w[k] - lo <= 1e-3 * span else
              "upper" if hi - x_w[k] <= 1e-3 * span else None)
        moved.append(replace(e, value=p.from_x(float(x_w[k])), at_bound=at))
    out = _widened(moved, stats, params, x_w, {"combination": combination, "halfwidth95": half})
    entry = {"combination": combination, "halfwidth95": half,
             "identified": half <= limit, "weighed": weighing}
    return out, entry


def _overlap(a: dict[str, float], b: dict[str, float]) -> float:
    """The dot product of two unit-norm parameter combinations."""
    return float(sum(c * b.get(n, 0.0) for n, c in a.items()))


def _widened(estimates: list[Estimate], stats: dict[str, Any], params: Sequence[TwinParameter],
             x: np.ndarray, symmetry: dict[str, Any]) -> list[Estimate]:
    """Estimates whose intervals (and ``stats``' sds) include the width the data leave along the
    common scale, measured along it (module doc, 12), which the Jacobian does not see."""
    sd_dir = symmetry["halfwidth95"] / Z95
    out = []
    for k, (p, e) in enumerate(zip(params, estimates)):
        c = symmetry["combination"].get(p.name, 0.0)
        if c == 0.0 or e.ci95 == (None, None):
            out.append(e)
            continue
        add = sd_dir * c * p.x_scale
        for key in ("sd_coordinate", "sd_coordinate_data"):
            stats[key][p.name] = math.sqrt(stats[key][p.name] ** 2 + add ** 2)
        out.append(replace(e, ci95=_interval(p, float(x[k]), stats["sd_coordinate"][p.name]),
                           ci95_data=None if e.ci95_data is None else
                           _interval(p, float(x[k]), stats["sd_coordinate_data"][p.name])))
    return out


def _opened(estimates: list[Estimate], combination: dict[str, float]) -> list[Estimate]:
    """Estimates of the parameters in ``combination`` (|coefficient| >= 0.1) without an
    interval: the Jacobian's intervals say nothing along a direction it does not see."""
    free = {n for n, c in combination.items() if abs(c) >= 0.1}
    return _without_interval(estimates, free)


def _without_interval(estimates: list[Estimate], free: set[str]) -> list[Estimate]:
    """``estimates`` with those named in ``free`` left without an interval."""
    return [replace(e, ci95=(None, None),
                    ci95_data=None if e.ci95_data is None else (None, None))
            if e.name in free else e for e in estimates]


def _unbounded(estimates: list[Estimate], weak: Sequence[WeakDirection],
               limit: float) -> list[Estimate]:
    """Estimates whose parameter takes part (|coefficient| >= 0.1) in a direction the data does
    not bound at all (half-width None or over 100 ``limit``) get no interval."""
    free = {n for w in weak if w.halfwidth95 is None or w.halfwidth95 > 100 * limit
            for n, c in w.combination.items() if abs(c) >= 0.1}
    return _without_interval(estimates, free)


def _fit(prob: _Problem, x0: np.ndarray, weights: dict[str, Any] | str | None = None
         ) -> tuple[np.ndarray, dict[str, Any]]:
    """Two weighted stages (module doc, 2-3); returns the optimum and the stages' costs.
    ``weights``: one stage only, weighted at the start (``"start"``) or by a residual RMS
    table (:func:`_rms_table`, the weights of a fit this one belongs to; module doc 2)."""
    p = len(prob.params)
    prob.limit = prob.o.max_evals - 2 * p      # keep 2p evaluations for the final Jacobian
    weighing = (_WeighingRow(prob) if prob.o.weighed_mass is not None and prob.o.weigh_in_fit
                and any(q.name in _MASSES for q in prob.params) else None)
    if weighing is not None:                   # start on the weighed scale (module doc, 13)
        x0 = weighing.start(x0)
    prob.scale = (_rms_scale(prob.raw(x0)) if weights is None or weights == "start"
                  else _scale_from_table(weights, prob.o.horizons))
    n = prob.fun(x0).size
    stages: dict[str, Any] = {"n_residuals": int(n), "cost_start_stage1": (
        0.5 * n if weights is None or weights == "start"
        else 0.5 * float(np.sum(prob.fun(x0) ** 2)))}
    if weights is not None:
        stages["weights"] = "start" if weights == "start" else "given"
        x2, stop = _least_squares(prob, x0, max_nfev=max(2, prob.o.max_evals // (2 * p + 1)),
                                  weighing=weighing)
        stages.update({"stop_stage1": stop, "cost_end_stage1": 0.5 * float(np.sum(
            prob.fun(x2) ** 2)), "cost_start_stage2": None})     # the one stage is the first
    else:
        x1, stages["stop_stage1"] = _least_squares(
            prob, x0, max_nfev=max(2, (2 * prob.o.max_evals) // (3 * (2 * p + 1))),
            weighing=weighing)
        stages["cost_end_stage1"] = 0.5 * float(np.sum(prob.fun(x1) ** 2))
        prob.scale = _rms_scale(prob.raw(x1))      # reweight by the noise left at the first fit
        stages["cost_start_stage2"] = 0.5 * float(np.sum(prob.fun(x1) ** 2))
        x2, stop = _least_squares(prob, x1, max_nfev=max(2, prob.o.max_evals // (2 * p + 1)),
                                  weighing=weighing)
    stages["cost_end"] = 0.5 * float(np.sum(prob.fun(x2) ** 2))
    stages["stop"], stages["converged"] = stop, stop.startswith("converged")
    if weighing is not None:
        stages["weighing_in_fit"] = {"mass_kg_start": total_mass(prob.config(x0)),
                                     "mass_kg_end": total_mass(prob.config(x2)),
                                     "residual_end": float(weighing.fun(x2)[0])}
    prob.limit = math.inf
    return x2, stages


def _scale_from_table(table: dict[str, Any], horizons: Sequence[int]) -> np.ndarray:
    """The (horizon, element) weights of a residual RMS table (:func:`_rms_table`), as
    :func:`_rms_scale` gives them (an element at 0 or missing counts as 1)."""
    out = np.ones((len(horizons), len(STATE_NAMES)))
    for k, h in enumerate(horizons):
        row = table.get(f"h{h}")
        if row is None:
            raise ValueError(f"the weights have no horizon {h}")
        for j, name in enumerate(STATE_NAMES):
            v = row.get(name)
            if v is not None and math.isfinite(v) and v > 0:
                out[k, j] = v
    return out


def _rollouts(test_recs: Sequence[MoveRecording], before: RobotConfig, after: RobotConfig,
              jobs: int) -> dict[str, Any]:
    """The report's ``rollout``: the TestPool rolled out with ``before`` and ``after``."""
    return {"test_moves": [r.name for r in test_recs],
            "before": _rollout_summary(_bl.evaluate_baseline(test_recs, before, one_step=False,
                                                              jobs=jobs)),
            "after": _rollout_summary(_bl.evaluate_baseline(test_recs, after, one_step=False,
                                                             jobs=jobs))}


def _rollout_summary(ev: dict[str, Any]) -> dict[str, Any]:
    return {"final_xy_error_m": ev["final_xy_error_m"],
            "final_xy_error_m_median": ev.get("final_xy_error_m_median"),
            "n_nan_moves": ev.get("n_nan_moves"),
            "per_move": {m["name"]: m.get("final_xy_error_m") for m in ev.get("per_move", [])}}


#: the body-position noise [m] above which ``initial_state="auto"`` smooths the starting states
#: and the bootstrap's synthetic recordings carry motion-capture noise: above what a
#: noise-free trot reads (its curvature), under half the least a gap robot's recording has
#: read (benchmarks/blind_zoo/zoos/zoo40/runs/run2_noise_floor/README.md). Smoothing costs
#: little without noise and gains much with it (benchmarks/calibrate/README.md, "Converged,
#: the fit is biased by its starting states"); a floor just above a gap robot's noise left
#: it calibrated from measured starts and bootstrapped without noise
#: (benchmarks/blind_zoo/zoos/zoo40/runs/run1/README.md)
POSE_NOISE_FLOOR = 8e-5


def pose_noise(recs: Sequence[MoveRecording], half_window: int = 3, every: int = 10) -> float:
    """The recordings' body-position noise [m]: the median over windows of 2 w + 1 samples
    (every ``every``-th step of every move) of the RMS residual of a quadratic fitted per axis,
    scaled by sqrt(n / (n - 3)) for the three fitted coefficients. A noise-free trot leaves
    its curvature's share, tens of micrometres; motion capture leaves its noise."""
    n = 2 * half_window + 1
    t = np.arange(-half_window, half_window + 1, dtype=float)
    A = np.stack([np.ones(n), t, t * t], axis=1)
    proj = np.eye(n) - A @ np.linalg.pinv(A)          # residual maker of the quadratic fit
    out = []
    for r in recs:
        pos = np.asarray(r.position, float)
        for k in range(half_window, pos.shape[0] - half_window, every):
            res = proj @ pos[k - half_window:k + half_window + 1]
            out.append(math.sqrt(float(np.mean(res ** 2)) * n / (n - 3)))
    return float(np.median(out)) if out else 0.0


def _resolve_initial_state(options: "CalibrationOptions", recs: Sequence[MoveRecording],
                           say: Callable[[str], None]) -> "CalibrationOptions":
    """``options`` with ``initial_state="auto"`` made ``smoothed`` where the recordings' pose
    noise (:func:`pose_noise`) exceeds :data:`POSE_NOISE_FLOOR`, else ``measured``."""
    if options.initial_state != "auto":
        return options
    noise = pose_noise(recs)
    chosen = "smoothed" if noise > POSE_NOISE_FLOOR else "measured"
    say(f"starting states: {chosen} (body-position noise about {noise * 1e3:.2f} mm, "
        f"{'above' if chosen == 'smoothed' else 'below'} {POSE_NOISE_FLOOR * 1e3:.2f} mm)")
    return replace(options, initial_state=chosen)


def _fit_inputs(train_recs: Sequence[MoveRecording], base: RobotConfig,
                options: CalibrationOptions) -> list[TwinParameter]:
    """The parameters a fit of ``base`` (its servo structure set) fits; ValueError (one line)
    for parameters it does not have, a weighing without a mass among them, no TrainPool move,
    or moves too short for the horizon."""
    params = twin_parameters(options.params or DEFAULT_CALIBRATION_PARAMS[base.servo], base)
    if options.weighed_mass is not None and not any(p.name in _MASSES for p in params):
        raise ValueError("--weighed-mass needs a mass among the fitted parameters (body_mass, "
                         "leg_mass or mass_scale)")
    if not train_recs:
        raise ValueError("calibration needs at least one TrainPool move")
    short = [r.name for r in train_recs if r.n_steps <= max(options.horizons)]
    if short:
        raise ValueError(f"moves too short for horizon {max(options.horizons)}: {short}")
    return params


def _fit_start(train_recs: Sequence[MoveRecording], base: RobotConfig,
               options: CalibrationOptions
               ) -> tuple[RobotConfig, RobotConfig, list[TwinParameter], np.ndarray]:
    """(the starting robot in ``options.servo``'s structure, the same without sensor noise,
    which re-simulation predicts, the parameters fitted, their starting coordinates):
    what :func:`calibrate_twin` and a structure's screen start a fit from."""
    start_robot = with_servo(base, options.servo)
    params = _fit_inputs(train_recs, start_robot, options)
    base = replace(start_robot, sensor_noise=False)
    return start_robot, base, params, np.array([p.to_x(p.get(base)) for p in params])


def calibrate_twin(train_recs: Sequence[MoveRecording], test_recs: Sequence[MoveRecording],
                   base: RobotConfig, options: CalibrationOptions = CalibrationOptions(),
                   progress: Callable[[str], None] | None = None, *,
                   cache: dict[tuple[float, ...], list[np.ndarray]] | None = None,
                   weights: dict[str, Any] | str | None = None) -> Calibration:
    """Fit ``options.params`` of ``base`` to ``train_recs`` (module doc); score on ``test_recs``.
    ``cache``: the evaluations this very fit made already (a structure's screen, module doc 8).
    ``weights``: one weighted stage, not two (module doc 2): weighted at the start
    (``"start"``, the bootstrap's refits) or by a residual RMS table (a split start, by its
    fit's weights at the optimum).

    Returns the calibrated robot (named ``options.name`` or BASE-calibrated), the estimates
    with their 95 % intervals and bounds, the weak directions and a JSON-ready report.
    Raises ValueError (one line) for bad options, parameters or recordings, or a starting
    robot whose re-simulation diverges.
    """
    t0 = time.perf_counter()
    options.check()
    if weights is not None and (options.bootstrap or options.split_starts or options.add_asked
                                or options.servo == "auto"):
        raise ValueError("weights apply to one fit: not with bootstrap, split_starts, "
                         "add_asked or servo auto")
    say = progress or (lambda s: None)
    options = _resolve_initial_state(options, train_recs, say)
    if options.bootstrap:
        from .twin_bias import bias_corrected
        cal = calibrate_twin(train_recs, [], base,
                             replace(options, bootstrap=0, bootstrap_replicates=1,
                                     bootstrap_continued=False), say)
        if cal.report.get("converged") is False:      # only an optimum is corrected (11)
            cal = _continued(cal, train_recs, options, say)
            ended = (cal.report.get("continued") or {}).get("converged")
            if ended is not None:
                cal = _split_recompared(cal, train_recs, options)   # it moved (14)
            if ended and options.bootstrap_continued:   # an optimum now: corrected as one
                say("the continued fit converged: taking out its bias as an optimum's "
                    "(--bootstrap-continued)")
                cal = bias_corrected(cal, train_recs, options, say)
        else:
            cal = bias_corrected(cal, train_recs, options, say)
        cal.report["settings"] = {**cal.report.get("settings", {}),
                                  "bootstrap_continued": bool(options.bootstrap_continued)}
        cal = _hull_over_tied(cal)                   # after the correction's intervals (14)
        _finish(cal.report, test_recs, replace(base, sensor_noise=False), cal.config, options,
                say, t0)
        return cal
    if options.split_starts:
        cal = calibrate_twin(train_recs, [], base, replace(options, split_starts=0.0), say)
        cal = _hull_over_tied(_split_started(cal, train_recs, options, say))
        _finish(cal.report, test_recs, replace(base, sensor_noise=False), cal.config, options,
                say, t0)
        return cal
    if options.add_asked:
        return _calibrate_adding_asked(train_recs, test_recs, base, options, say, t0)
    if options.servo == "auto":
        for servo in ("position", "pd_torque"):   # both refused before any fit or screen
            _fit_inputs(train_recs, with_servo(base, servo), options)
        return _calibrate_structures(train_recs, test_recs, base, options, say, t0)
    original = replace(base, sensor_noise=False)     # "before" is the robot as given
    start_robot, base, params, x0 = _fit_start(train_recs, base, options)
    with _bl.move_pool(train_recs, options.jobs, options.scheduler) as pool:
        prob = _Problem(pool, base, params, options, say, cache)
        say(f"fitting {', '.join(p.name for p in params)} on {len(train_recs)} TrainPool moves")
        x, stages = _fit(prob, x0, weights)
        J, r = prob.jac(x), prob.fun(x)
        n_evals = len(prob.cache)
        missing = consider = consider_cov = None
        columns: list[tuple[TwinParameter, float, np.ndarray]] = []
        if options.test_missing:
            say("testing the parameters not fitted")
            try:
                columns = unfitted_columns(prob, x, r)
                raised = raised_columns(prob, x, r) if options.threshold_up else []
                missing = missing_parameters(prob, x, J, r, options.ask_share, columns,
                                             raised)
                consider_cov, consider = consider_analysis(J, params, columns,
                                                           options.consider_spread, raised)
            except Exception as e:       # the fit is done; its twin is not lost to the test
                log.warning("the test of the parameters not fitted failed: %s", e)
                missing = [{"error": f"{type(e).__name__}: {e}"}]
        # in the pool: the common-scale check and the weighing re-simulate
        estimates, stats, covs = _estimates(prob, x, J, r, x0, consider_cov)
        weak, sv = weak_directions(J, params, covs, stats["residual_variance"],
                                   options.weak_halfwidth)
        symmetry = scale_symmetry(prob, x, J, stats["residual_variance"], options.weak_halfwidth)
        if options.weighed_mass is not None:
            x, weighing = weigh(prob, x, stats["residual_variance"], columns)
            estimates, entry = _weighed_estimates(estimates, stats, params, x, weighing,
                                                  options.weak_halfwidth)
            symmetry = {**(symmetry or {}), **entry}
            say(f"weighed {options.weighed_mass:g} +- {options.weighed_mass_sd:g} kg: the fitted "
                f"masses sum to {weighing['fitted_mass_kg']:.4g} kg; the common scale moved by "
                f"{100 * math.expm1(weighing['scale_applied']):+.1f} % (cost "
                f"{weighing['cost_fit']:.1f} -> {weighing['cost_weighed']:.1f})")
            if symmetry["identified"]:
                # the weighing bounds the scale: a weak direction of the Jacobian along it (where
                # the Jacobian does see the symmetry) no longer takes its parameters' intervals
                weak = [w for w in weak if abs(_overlap(w.combination,
                                                        symmetry["combination"])) <= 0.9]
            else:
                sv_scale = Z95 * math.sqrt(stats["residual_variance"]) / symmetry["halfwidth95"]
                weak = [WeakDirection(sv_scale, symmetry["halfwidth95"], symmetry["combination"])
                        ] + weak
                estimates = _opened(estimates, symmetry["combination"])
        elif symmetry is not None and not symmetry["identified"]:
            weak = [WeakDirection(symmetry["derivative"], symmetry["halfwidth95"],
                                  symmetry["combination"])] + weak
            estimates = _opened(estimates, symmetry["combination"])
        elif symmetry is not None:
            estimates = _widened(estimates, stats, params, x, symmetry)
    estimates = _unbounded(estimates, weak, options.weak_halfwidth)
    calibrated = replace(prob.config(x), name=options.name or f"{base.name}-calibrated",
                         sensor_noise=start_robot.sensor_noise)
    report = {"params": [_estimate_dict(e) for e in estimates],
              "weak_directions": [{"combination": w.combination, "describe": w.describe(),
                                   "singular_value": w.singular_value,
                                   "halfwidth95": w.halfwidth95} for w in weak],
              "singular_values": sv, **stats,
              "correlation": _correlation(covs[1], params), **stages,
              "n_evals": n_evals, "train_moves": [r.name for r in train_recs],
              "settings": {"stride": options.stride, "horizons": list(options.horizons),
                           "max_evals": options.max_evals, "diff_step": options.diff_step,
                           "weak_halfwidth": options.weak_halfwidth,
                           "initial_state": options.initial_state,
                           "consider_spread": options.consider_spread,
                           "threshold_up": options.threshold_up,
                           "jackknife": options.jackknife,
                           "weighed_mass": options.weighed_mass,
                           "weighed_mass_sd": options.weighed_mass_sd,
                           "weigh_in_fit": options.weigh_in_fit,
                           "pose_noise_m": pose_noise(train_recs)},
              "residual_rms": _rms_report(prob, x0, x), "missing": missing,
              "consider": consider, "scale_symmetry": symmetry}
    _finish(report, test_recs, original, calibrated, options, say, t0)
    return Calibration(calibrated, estimates, weak, report)


def _finish(report: dict[str, Any], test_recs: Sequence[MoveRecording], before: RobotConfig,
            after: RobotConfig, options: CalibrationOptions, say: Callable[[str], None],
            t0: float) -> None:
    """Into ``report``: the TestPool rollouts of ``before`` and ``after`` (if there is a
    TestPool) and the wall time since ``t0``."""
    if test_recs:
        say(f"rolling out {len(test_recs)} TestPool moves before and after")
        report["rollout"] = _rollouts(test_recs, before, after, options.jobs)
    report["wall_s"] = round(time.perf_counter() - t0, 1)


def with_servo(config: RobotConfig, servo: str) -> RobotConfig:
    """``config`` with the servo structure ``servo`` ("keep": as it is); the other servo's
    fields (``kp``/``kd``, ``position_gain``/``velocity_gain``) are kept as the start, and a
    torque-mode robot without armature gets the gearboxes' reflected rotor inertia."""
    if servo in ("keep", config.servo):
        return config
    if servo not in ("position", "pd_torque"):
        raise ValueError(f"servo must be position or pd_torque, got {servo!r}")
    if servo == "pd_torque" and not any(config.armature):
        # the torque-mode PD needs the rotor inertia the gearboxes reflect (config.py)
        return replace(config, servo=servo, armature=REFLECTED_ROTOR_INERTIA)
    return replace(config, servo=servo)


def _structure_cost(cal: Calibration, reference: dict[str, Any]) -> float:
    """The first stage's objective at ``cal``'s optimum with the weights of the starting robot
    ``reference`` (``residual_rms['start']`` of the keep-structure fit): the mean over
    (horizon, element) of (RMS / starting RMS)^2, elements the start leaves at 0 left out."""
    return _rms_cost(cal.report["residual_rms"]["calibrated"], reference)


def _rms_cost(got: dict[str, Any], reference: dict[str, Any]) -> float:
    """:func:`_structure_cost` of the residual RMS table ``got`` (:func:`_rms_table`)."""
    terms = []
    for h, row in reference.items():
        for name, ref in row.items():
            v = got.get(h, {}).get(name)
            if ref is None or ref <= 0:
                continue
            terms.append(math.inf if v is None else (v / ref) ** 2)
    return float(np.mean(terms)) if terms else math.inf


#: decision 056: ``servo="auto"`` first fits each structure for this many evaluations ...
STRUCTURE_SCREEN_EVALS = 40
#: ... and fits on only the better one where the other's best k-step cost there is at least
#: this many times its own
STRUCTURE_SCREEN_RATIO = 5.0


@dataclass
class _Screen:
    """A structure's screen: the evaluations its fit made first (the fit's own cache), the
    residual RMS table at the start, and the lowest k-step cost among the points evaluated
    (against ``reference``, set by the caller)."""

    cache: dict[tuple[float, ...], list[np.ndarray]]
    start_rms: dict[str, Any]
    tables: list[dict[str, Any]]
    wall_s: float

    def cost(self, reference: dict[str, Any]) -> float:
        return min(_rms_cost(t, reference) for t in self.tables)


def _rms_table(raw: Sequence[np.ndarray], horizons: Sequence[int]) -> dict[str, Any]:
    """RMS of the raw residual per horizon and element (:func:`_rms_report`'s tables)."""
    all_r = np.concatenate(raw, axis=0)
    with np.errstate(invalid="ignore", over="ignore"):
        rms = np.sqrt(np.mean(all_r ** 2, axis=0))
    return {f"h{h}": {n: (float(v) if np.isfinite(v) else None)
                      for n, v in zip(STATE_NAMES, rms[k])} for k, h in enumerate(horizons)}


def _screen_structure(train_recs: Sequence[MoveRecording], base: RobotConfig,
                      options: CalibrationOptions, say: Callable[[str], None]) -> _Screen:
    """The first :data:`STRUCTURE_SCREEN_EVALS` evaluations of the fit :func:`calibrate_twin`
    makes with ``options`` (a structure's servo): the same problem, the same start, stopped
    when they are spent. Its cache holds only the fit's own points, in its order, so the fit
    run after it with that cache passes the same points and ends where it would have."""
    t0 = time.perf_counter()
    options = _resolve_initial_state(options, train_recs, lambda s: None)
    _, start, params, x0 = _fit_start(train_recs, base, options)
    with _bl.move_pool(train_recs, options.jobs, options.scheduler) as pool:
        prob = _Problem(pool, start, params, options, say)
        prob.screen = STRUCTURE_SCREEN_EVALS
        say(f"screening {', '.join(p.name for p in params)} on {len(train_recs)} TrainPool "
            f"moves ({STRUCTURE_SCREEN_EVALS} evaluations)")
        try:
            _fit(prob, x0)
        except _ScreenDone:
            pass
        key = prob.key(x0)
        raw0 = (prob.cache[key] if key in prob.cache else   # not added: the fit's cache only
                twin_residuals(pool, prob.config(x0), options.stride, options.horizons,
                               options.initial_state))
    tables = [_rms_table(r, options.horizons) for r in prob.cache.values()]
    return _Screen(prob.cache, _rms_table(raw0, options.horizons), tables,
                   round(time.perf_counter() - t0, 1))


def _calibrate_structures(train_recs: Sequence[MoveRecording],
                          test_recs: Sequence[MoveRecording], base: RobotConfig,
                          options: CalibrationOptions, say: Callable[[str], None],
                          t0: float) -> Calibration:
    """``servo="auto"`` (module doc, 8): screen the starting servo and the other one, fit on
    the one the screen leaves or both, keep the structure with the lower k-step cost, roll out
    the TestPool before and after once."""
    other = "pd_torque" if base.servo == "position" else "position"
    screens: dict[str, _Screen] = {}
    for servo in (base.servo, other):
        say(f"servo structure {servo}:")
        screens[servo] = _screen_structure(train_recs, base, replace(options, servo=servo), say)
    reference = screens[base.servo].start_rms
    screened = {s: sc.cost(reference) for s, sc in screens.items()}
    lead = min(screened, key=lambda s: (screened[s], s != base.servo))
    behind = other if lead == base.servo else base.servo
    out = screened[behind] >= STRUCTURE_SCREEN_RATIO * screened[lead]
    say(f"servo structures screened: k-step cost {lead} {screened[lead]:.4g}, {behind} "
        f"{screened[behind]:.4g}: " + (f"fitting {lead} only" if out else "fitting both"))
    fits: dict[str, Calibration] = {}
    for servo in ((lead,) if out else (base.servo, other)):
        say(f"servo structure {servo}:")
        fits[servo] = calibrate_twin(train_recs, [], base, replace(options, servo=servo), say,
                                     cache=screens[servo].cache)
    costs = {s: _structure_cost(c, reference) for s, c in fits.items()}
    chosen = min(costs, key=lambda s: (costs[s], s != base.servo))   # a tie keeps the start's
    cal = fits[chosen]
    if out:
        say(f"servo structure: {chosen} (k-step cost {costs[chosen]:.4g}; {behind} screened "
            f"out at {screened[behind]:.4g})")
    else:
        say(f"servo structure: {chosen} (k-step cost {costs[chosen]:.4g} against "
            f"{costs[other if chosen == base.servo else base.servo]:.4g})")
    report = dict(cal.report)
    candidates = [{"servo": s, "cost": costs[s], "converged": c.report.get("converged"),
                   "n_evals": c.report.get("n_evals"), "wall_s": c.report.get("wall_s"),
                   "params": [_estimate_dict(e) for e in c.estimates]}
                  for s, c in fits.items()]
    if out:
        candidates.append({"servo": behind, "cost": screened[behind], "converged": False,
                           "n_evals": len(screens[behind].cache),
                           "wall_s": screens[behind].wall_s, "params": [],
                           "screened": True})
    report["structure"] = {
        "chosen": chosen, "start": base.servo,
        "criterion": "mean over horizon and element of (residual RMS / the starting robot's)^2 "
                     "on the fitted moves",
        "screen": {"evals": STRUCTURE_SCREEN_EVALS, "ratio": STRUCTURE_SCREEN_RATIO,
                   "costs": screened, "fitted": [lead] if out else [base.servo, other]},
        "candidates": candidates}
    _finish(report, test_recs, replace(base, sensor_noise=False), cal.config, options, say, t0)
    return Calibration(cal.config, cal.estimates, cal.weak, report)


def asked_for(report: dict[str, Any]) -> list[str]:
    """The parameters a calibration's score test asks for (module doc, 7), most asked first."""
    return [m["name"] for m in report.get("missing") or [] if m.get("asks")]


#: a refit round's evaluation budget is at least this many Jacobians (2 p + 1 each)
ROUND_EVALS_PER_COLUMN = 8


def blamed_by_intervals(report: dict[str, Any]) -> list[str]:
    """The parameters not fitted that the consider analysis (module doc, 10) blames: each
    widens some fitted parameter's interval by more than the data does (its consider sd share
    above that parameter's data sd), most blamed first."""
    consider = report.get("consider") or {}
    sd_data = report.get("sd_coordinate_data") or {}
    ratio: dict[str, float] = {}
    for name, c in (consider.get("params") or {}).items():
        base = sd_data.get(name)
        if not base or base <= 0:
            continue
        for other, sd in c.get("by", {}).items():
            if sd > base:
                ratio[other] = max(ratio.get(other, 0.0), sd / base)
    return sorted(ratio, key=lambda n: -ratio[n])


def _calibrate_adding_asked(train_recs: Sequence[MoveRecording],
                            test_recs: Sequence[MoveRecording], base: RobotConfig,
                            options: CalibrationOptions, say: Callable[[str], None],
                            t0: float) -> Calibration:
    """``add_asked`` (module doc, 9): fit as asked, then, up to ``add_asked`` times, add the
    parameters the score test asks for and fit all again from the optimum, in the structure
    chosen; roll out the TestPool before (the robot as given) and after (the last fit) once."""
    name = options.name or f"{base.name}-calibrated"
    inner = replace(options, add_asked=0, name=name)
    cal = calibrate_twin(train_recs, [], base, inner, say)
    structure = cal.report.get("structure")        # servo="auto": the choice, made once
    weights = cal.report["residual_rms"]["start"]  # one yardstick for every round
    total_evals = (sum(c.get("n_evals") or 0 for c in structure["candidates"]) if structure
                   else cal.report.get("n_evals") or 0)
    rounds = []
    for k in range(options.add_asked + 1):
        fitted = tuple(e.name for e in cal.estimates)
        asked = [n for n in asked_for(cal.report) if n not in fitted]
        late = k == options.add_asked          # the rounds are used up: only a threshold round
        if late:
            asked = [n for n in asked if TWIN_PARAMETERS[n].threshold]
            if not options.threshold_round or not asked:
                break
        blamed = [] if late else [n for n in blamed_by_intervals(cal.report)
                                  if n not in fitted + tuple(asked)]
        if not asked and not blamed:
            break
        params = fitted + tuple(asked) + tuple(blamed)
        moved = _limit_starts(cal.report, asked, options)
        say((f"the residual asks for {', '.join(asked)}" if asked else "")
            + (" (a torque limit, asked for after the last round: one round of its own)"
               if late else "")
            + ("; " if asked and blamed else "")
            + (f"the intervals ask for {', '.join(blamed)} (not fitted, they widen them more "
               "than the data do)" if blamed else "")
            + f": fitting {len(params)} parameters again from the optimum"
            + (" (" + ", ".join(f"{n} from {v['start']:.4g}, where the score test points"
                                for n, v in moved.items()) + ")" if moved else ""))
        rnd = {"added": asked + blamed, "added_for_intervals": blamed,
               "threshold_round": late, "started_at": moved,
               "k_step_cost_before": _structure_cost(cal, weights),
               "converged": cal.report.get("converged"), "n_evals": cal.report.get("n_evals"),
               "wall_s": cal.report.get("wall_s"),
               "params": [_estimate_dict(e) for e in cal.estimates]}
        round_options = replace(inner, params=params, servo="keep",
                                max_evals=max(inner.max_evals,
                                              ROUND_EVALS_PER_COLUMN * (2 * len(params) + 1)))
        start = cal.config
        for n, v in moved.items():
            start = TWIN_PARAMETERS[n].set(start, v["start"])
        try:
            refit = calibrate_twin(train_recs, [], start, round_options, say)
            after = _structure_cost(refit, weights)
            if moved and after > rnd["k_step_cost_before"]:
                # the limits' start led somewhere worse than the fit before the round: the
                # round again from that fit, as for any other parameter
                say("the refit from the limits' suggested values ends above the cost before it; "
                    "fitting again from the optimum")
                rnd["restarted"] = {"k_step_cost": after}
                total_evals += refit.report.get("n_evals") or 0
                refit = calibrate_twin(train_recs, [], cal.config, round_options, say)
        except Exception as e:        # the fit before it stands; say why the refit did not
            rnd["error"] = f"{type(e).__name__}: {e}"
            rounds.append(rnd)
            say(f"the refit with {', '.join(asked + blamed)} failed ({e}); keeping the fit "
                "before it")
            break
        cal = refit
        rnd["k_step_cost_after"] = _structure_cost(cal, weights)
        total_evals += cal.report.get("n_evals") or 0
        rounds.append(rnd)
    report = dict(cal.report)
    report["added"] = rounds
    report["n_evals_total"] = total_evals
    report["settings"] = {**report.get("settings", {}), "add_asked": options.add_asked,
                          "threshold_round": options.threshold_round, "servo": options.servo}
    if structure is not None:
        report["structure"] = structure
    _finish(report, test_recs, replace(base, sensor_noise=False), cal.config, options, say, t0)
    return Calibration(cal.config, cal.estimates, cal.weak, report)


def _evals_so_far(report: dict[str, Any]) -> int:
    """The re-simulations of every fit a calibration's ``report`` has finished: its
    ``n_evals_total`` where the rounds counted them, else both servo structures' fits (a
    screened-out one's screen) with ``servo="auto"``, else its own fit's."""
    if report.get("n_evals_total") is not None:
        return int(report["n_evals_total"])
    structure = report.get("structure")
    if structure:
        return int(sum(c.get("n_evals") or 0 for c in structure["candidates"]))
    return int(report.get("n_evals") or 0)


def _carried(report: dict[str, Any], earlier: dict[str, Any]) -> dict[str, Any]:
    """``report`` of a fit made from the calibration ``earlier`` reports, with that
    calibration's history: its structure choice, rounds and second starts, and its settings
    of them (the later fit's own are those of one inner fit)."""
    report = dict(report)
    for key in ("structure", "added", "split_starts"):
        if key in earlier:
            report[key] = earlier[key]
    kept = {k: v for k, v in earlier.get("settings", {}).items()
            if k in ("add_asked", "threshold_round", "servo", "split_starts")}
    report["settings"] = {**report.get("settings", {}), **kept}
    return report


def _continued(cal: Calibration, train_recs: Sequence[MoveRecording],
               options: CalibrationOptions, say: Callable[[str], None]) -> Calibration:
    """A fit the evaluation budget stopped, fitted on from where it stopped with the
    evaluations its bootstrap would have spent (module doc, 11); the report keeps the fit's
    structure and rounds, and gains ``continued`` and ``bootstrap.skipped``."""
    t0 = time.perf_counter()
    names = tuple(e.name for e in cal.estimates)
    budget = (int(options.bootstrap) * int(options.bootstrap_replicates)
              * ROUND_EVALS_PER_COLUMN * (2 * len(names) + 1))
    weights = cal.report["residual_rms"]["start"]
    entry: dict[str, Any] = {"from": {e.name: e.value for e in cal.estimates},
                             "stop_before": cal.report.get("stop"),
                             "k_step_cost_before": _structure_cost(cal, weights),
                             "max_evals": budget}
    reason = ("the fit stopped on its evaluation budget (not converged): its distance from the "
              "optimum is not a bias the refits measure, and their evaluations went to "
              "fitting on (continued)")
    say(f"the fit stopped on its budget: fitting on from there with the bootstrap's {budget} "
        "evaluations instead of measuring a bias at a point that is not an optimum")
    inner = replace(options, params=names, servo="keep", add_asked=0, bootstrap=0,
                    bootstrap_continued=False,
                    bootstrap_replicates=1, name=cal.config.name, split_starts=0.0,
                    max_evals=max(options.max_evals, budget))
    try:
        refit = calibrate_twin(train_recs, [], cal.config, inner, say)
    except Exception as e:          # the fit stands; say why it was not continued
        entry["error"] = f"{type(e).__name__}: {e}"
        say(f"continuing the fit failed ({e}); keeping it where its budget stopped it")
        refit = None
    if refit is None:
        result, report = cal, dict(cal.report)
    else:
        entry.update({"k_step_cost_after": _structure_cost(refit, weights),
                      "converged": refit.report.get("converged"),
                      "stop": refit.report.get("stop"), "n_evals": refit.report.get("n_evals"),
                      "wall_s": round(time.perf_counter() - t0, 1)})
        result, report = refit, _carried(refit.report, cal.report)
        report["n_evals_total"] = (_evals_so_far(cal.report)
                                   + (refit.report.get("n_evals") or 0))
        report["settings"] = {**report["settings"], "bootstrap": options.bootstrap,
                              "bootstrap_replicates": options.bootstrap_replicates}
    report["continued"] = entry
    report["bootstrap"] = {"skipped": reason, "iterations": 0}
    return Calibration(result.config, result.estimates, result.weak, report)


#: module doc 14: a second minimum whose per-move cost difference from the kept one is below
#: the two-sided quantile of Student's t at this level (n - 1 degrees of freedom for n moves),
#: in standard errors, is not told apart from it by the data
SPLIT_TIE_LEVEL = 0.95


def split_start(config: RobotConfig, factor: float) -> RobotConfig:
    """``config`` with its legs ``factor`` times as heavy and its body heavier by what the four
    legs give up, so that the total mass stays (module doc, 14); both inside their bounds."""
    body, leg = TWIN_PARAMETERS["body_mass"], TWIN_PARAMETERS["leg_mass"]
    b, m = body.get(config), leg.get(config)
    new_m = min(max(m * factor, leg.bounds[0]), leg.bounds[1])
    new_b = min(max(b + 4.0 * (m - new_m), body.bounds[0]), body.bounds[1])
    new_m = min(max(m + (b - new_b) / 4.0, leg.bounds[0]), leg.bounds[1])   # the body's bound
    return body.set(leg.set(config, new_m), new_b)


def minima_compared(train_recs: Sequence[MoveRecording], kept: RobotConfig,
                    other: RobotConfig, options: CalibrationOptions) -> dict[str, Any]:
    """Whether the fitted moves tell two minima apart (module doc, 14): both re-simulate the
    moves, every residual weighted by its (horizon, element) RMS at ``kept``; per move, d is
    the other's cost minus the kept one's (half the sum of squares), and z is their sum over
    its standard error, sqrt(n) times the moves' sample sd (the moves independent, the states
    of one move not: the intervals' clustering by move). Told apart where z exceeds the
    two-sided :data:`SPLIT_TIE_LEVEL` quantile of Student's t with n - 1 degrees of freedom
    (``threshold``); never with fewer than two moves."""
    with _bl.move_pool(train_recs, options.jobs, options.scheduler) as pool:
        raw_k, raw_o = twin_residuals_many(pool, [replace(kept, sensor_noise=False),
                                                  replace(other, sensor_noise=False)],
                                           options.stride, options.horizons,
                                           options.initial_state)
    return _paired(raw_k, raw_o)


def _paired(raw_k: Sequence[np.ndarray], raw_o: Sequence[np.ndarray]) -> dict[str, Any]:
    """:func:`minima_compared` of the kept minimum's and the other's raw residuals per move."""
    from scipy.stats import t as student_t

    scale = _rms_scale(raw_k)

    def cost(raw: np.ndarray) -> float:
        w = _weighted([raw], scale)
        return 0.5 * float(w @ w)

    d = np.array([cost(o) - cost(k) for k, o in zip(raw_k, raw_o)])
    n = len(d)
    se = float(np.std(d, ddof=1) * math.sqrt(n)) if n > 1 else math.nan
    total = float(d.sum())
    z = total / se if n > 1 and se > 0 else (math.inf if n > 1 and total > 0 else math.nan)
    threshold = (float(student_t.ppf(0.5 + SPLIT_TIE_LEVEL / 2, n - 1)) if n > 1
                 else math.inf)
    return {"cost_difference": total, "se": se, "z": z, "moves": n, "threshold": threshold,
            "told_apart": bool(n > 1 and z > threshold)}


def _split_started(cal: Calibration, train_recs: Sequence[MoveRecording],
                   options: CalibrationOptions, say: Callable[[str], None]) -> Calibration:
    """The fit ``cal`` and two more of its parameters, started across the masses' split (legs
    x(1 - step) and x(1 + step), the body taking the difference), the lowest k-step cost kept
    (module doc, 14); the report gains ``split_starts``. A fit without both masses is kept as
    it is, and says so."""
    t0 = time.perf_counter()
    names = tuple(e.name for e in cal.estimates)
    step = float(options.split_starts)
    if not {"body_mass", "leg_mass"} <= set(names):
        report = dict(cal.report)
        report["split_starts"] = {"step": step, "skipped": "the body and leg masses are not "
                                  "both fitted: there is no split to start across"}
        return Calibration(cal.config, cal.estimates, cal.weak, report)
    weights = cal.report["residual_rms"]["start"]
    inner = replace(options, params=names, servo="keep", add_asked=0, bootstrap=0,
                    bootstrap_continued=False,
                    bootstrap_replicates=1, split_starts=0.0, name=cal.config.name,
                    max_evals=max(options.max_evals,
                                  ROUND_EVALS_PER_COLUMN * (2 * len(names) + 1)))
    body, leg = TWIN_PARAMETERS["body_mass"], TWIN_PARAMETERS["leg_mass"]

    def entry(label: str, c: Calibration, start: RobotConfig) -> dict[str, Any]:
        return {"start": label, "from": {"body_mass": body.get(start), "leg_mass": leg.get(start)},
                "k_step_cost": _structure_cost(c, weights), "converged": c.report.get("converged"),
                "n_evals": c.report.get("n_evals"), "wall_s": c.report.get("wall_s"),
                "params": [_estimate_dict(e) for e in c.estimates]}

    fits = {"fit": cal}
    entries = [entry("fit", cal, cal.config)]
    for factor in (1.0 - step, 1.0 + step):
        label = f"legs x{factor:g}"
        start = split_start(cal.config, factor)
        say(f"a second start across the masses' split: {label} (body {body.get(start):.4g} kg, "
            f"legs {leg.get(start):.4g} kg, the total kept), fitting {len(names)} parameters")
        try:
            fits[label] = calibrate_twin(train_recs, [], start, inner, say,
                                         weights=cal.report["residual_rms"]["calibrated"])
            entries.append(entry(label, fits[label], start))
        except Exception as e:      # the other starts stand; say why this one did not
            say(f"the start {label} failed ({e})")
            entries.append({"start": label, "from": {"body_mass": body.get(start),
                                                     "leg_mass": leg.get(start)},
                            "error": f"{type(e).__name__}: {e}"})
    done = [e for e in entries if "error" not in e]
    chosen = min(done, key=lambda e: (e["k_step_cost"], e["start"] != "fit"))["start"]
    kept = fits[chosen]
    tied = _compare_minima(entries, chosen, kept.config, train_recs, options)
    say(f"masses' split: kept {chosen} (k-step cost {_structure_cost(kept, weights):.4g}; "
        + ", ".join(f"{e['start']} {e['k_step_cost']:.4g}" for e in done if e["start"] != chosen)
        + ")" + (f"; the data do not tell it from {', '.join(tied)}: the intervals cover "
                 + ("both" if len(tied) == 1 else "all") if tied else ""))
    report = _carried(kept.report, cal.report)
    report["n_evals_total"] = (_evals_so_far(cal.report)
                               + sum(fits[e["start"]].report.get("n_evals") or 0
                                     for e in done if e["start"] != "fit"))
    report["settings"] = {**report.get("settings", {}), "split_starts": step}
    report["split_starts"] = {
        "step": step, "chosen": chosen, "tied": tied, "tie_level": SPLIT_TIE_LEVEL,
        "criterion": "mean over horizon and element of (residual RMS / the last round's "
                     "starting robot's)^2 on the fitted moves; told apart by the per-move cost "
                     "difference weighted at the kept minimum (z over its standard error)",
        "candidates": entries, "wall_s": round(time.perf_counter() - t0, 1)}
    return Calibration(kept.config, kept.estimates, kept.weak, report)


def _candidate_config(config: RobotConfig, entry: dict[str, Any]) -> RobotConfig:
    """``config`` with the estimates of a split start's ``entry`` (its ``params``)."""
    for p in entry["params"]:
        par = TWIN_PARAMETERS[p["name"]]
        config = par.set(config, min(max(p["value"], par.bounds[0]), par.bounds[1]))
    return config


def _compare_minima(entries: list[dict[str, Any]], chosen: str, kept: RobotConfig,
                    train_recs: Sequence[MoveRecording], options: CalibrationOptions
                    ) -> list[str]:
    """Each split start's ``compared`` (:func:`minima_compared`, against ``kept``, null for
    the ``chosen`` one) set in ``entries``; returns the starts not told apart from it. A
    comparison that fails counts as not told apart, with its ``error``."""
    tied = []
    others = [e for e in entries if "error" not in e and e["start"] != chosen]
    for e in entries:
        if e["start"] == chosen:
            e["compared"] = None
    if not others:
        return tied
    try:
        with _bl.move_pool(train_recs, options.jobs, options.scheduler) as pool:
            def residuals(config: RobotConfig) -> list[np.ndarray]:
                return twin_residuals(pool, replace(config, sensor_noise=False),
                                      options.stride, options.horizons, options.initial_state)

            raw_k = residuals(kept)      # once, for every comparison
            for e in others:
                try:
                    e["compared"] = _paired(raw_k, residuals(_candidate_config(kept, e)))
                except Exception as err:    # not compared: not counted as told apart either
                    e["compared"] = {"error": f"{type(err).__name__}: {err}",
                                     "told_apart": False}
    except Exception as err:                # the kept minimum itself did not re-simulate
        for e in others:
            e.setdefault("compared", {"error": f"{type(err).__name__}: {err}",
                                      "told_apart": False})
    for e in others:
        if not e["compared"]["told_apart"]:
            tied.append(e["start"])
    return tied


def _split_recompared(cal: Calibration, train_recs: Sequence[MoveRecording],
                      options: CalibrationOptions) -> Calibration:
    """After the kept start was fitted on (:func:`_continued`), the other minima compared
    again with where it ended (module doc, 14); ``split_starts.compared_after`` says so. The
    continued fit's intervals are its own, so ``widened`` starts empty again: the hull over
    the minima tied now (:func:`_hull_over_tied`) names what it widens."""
    split = cal.report.get("split_starts") or {}
    if not split.get("candidates"):
        return cal
    entries = [dict(e) for e in split["candidates"]]
    tied = _compare_minima(entries, split["chosen"], cal.config, train_recs, options)
    report = dict(cal.report)
    report["split_starts"] = {**split, "candidates": entries, "tied": tied, "widened": [],
                              "compared_after": "continued"}
    return Calibration(cal.config, cal.estimates, cal.weak, report)


def _hull(a: Sequence[float | None], b: Sequence[float | None], v: float
          ) -> tuple[float | None, float | None]:
    """The smallest interval holding the intervals ``a`` and ``b`` and the value ``v``; an open
    end (None) stays open."""
    lo = None if a[0] is None or b[0] is None else min(a[0], b[0], v)
    hi = None if a[1] is None or b[1] is None else max(a[1], b[1], v)
    return lo, hi


def _hull_over_tied(cal: Calibration) -> Calibration:
    """``cal`` with every interval covering the minima the data do not tell from it (module
    doc, 14: ``split_starts.tied``): each the hull of its own and theirs, with their values;
    ``split_starts.widened`` names the intervals that grew."""
    split = cal.report.get("split_starts") or {}
    others = [c for c in split.get("candidates", []) if c["start"] in (split.get("tied") or [])]
    if not others:
        return cal
    estimates, widened = [], []
    for e in cal.estimates:
        ci, ci_data = e.ci95, e.ci95_data
        for c in others:
            o = next((p for p in c["params"] if p["name"] == e.name), None)
            if o is None:
                continue
            ci = _hull(ci, o["ci95"], o["value"])
            if ci_data is not None:
                ci_data = _hull(ci_data, o.get("ci95_data") or o["ci95"], o["value"])
        if tuple(ci) != tuple(e.ci95):
            widened.append(e.name)
        estimates.append(replace(e, ci95=tuple(ci),
                                 ci95_data=None if ci_data is None else tuple(ci_data)))
    report = dict(cal.report)
    report["params"] = [_estimate_dict(e) for e in estimates]
    # an interval hulled before the bootstrap and not recomputed by it stays in the list
    report["split_starts"] = {**split, "widened": sorted(set(split.get("widened") or [])
                                                         | set(widened))}
    return Calibration(cal.config, estimates, cal.weak, report)


def secant_step(par: TwinParameter, value: float, options: CalibrationOptions) -> float:
    """The score test's step in ``par``'s fit coordinate from ``value`` (module doc, 7): for a
    threshold with a consider spread, a secant down by twice its a-priori sd (at least
    ``diff_step``), kept inside the bounds; otherwise ``diff_step`` towards the inside."""
    xc = par.to_x(value)
    h = options.diff_step * par.x_scale
    lo_x, hi_x = par.x_bounds()
    step = h if xc + h <= hi_x else -h
    if par.threshold and options.consider_spread > 0:
        step = -max(2.0 * consider_sd(par, value, options.consider_spread), h)
        if xc + step < lo_x:
            step = lo_x - xc
    return step


def _limit_starts(report: dict[str, Any], asked: Sequence[str], options: CalibrationOptions
                  ) -> dict[str, dict[str, float]]:
    """Where a round starts the torque limits the score test asks for (module doc, 9): at its
    suggested value, but no lower than the secant's point, the lowest value it re-simulated;
    {name: {"value": now, "suggested", "start"}}."""
    out = {}
    for m in report.get("missing") or []:
        name = m.get("name")
        if name not in asked or not TWIN_PARAMETERS[name].threshold or "suggested" not in m:
            continue
        par, value = TWIN_PARAMETERS[name], float(m["value"])
        xc, down = par.to_x(value), secant_step(par, value, options)
        floor = par.from_x(xc + min(down, 0.0))
        start = max(float(m["suggested"]), floor)
        if m.get("side") == "raised":   # no higher than the raised secant's point either
            start = min(start, par.from_x(xc + min(-down, par.x_bounds()[1] - xc)))
        out[name] = {"value": value, "suggested": float(m["suggested"]), "start": start}
    return out


def _not_fitted(prob: "_Problem", config: RobotConfig) -> list[tuple[TwinParameter, float]]:
    """The registry's parameters ``prob`` did not fit, that the servo of ``config`` has, that
    are not another name for fitted ones (parameters.py) and whose value there is inside their
    bounds, with that value."""
    fitted = {p.name for p in prob.params}
    out = []
    for par in TWIN_PARAMETERS.values():
        if (par.name in fitted or (par.servo is not None and par.servo != config.servo)
                or par.renames(fitted)):
            continue
        try:
            value = par.get(config)
        except ValueError:
            continue
        lo, hi = par.bounds
        if lo <= value <= hi:
            out.append((par, value))
    return out


def _secant_columns(prob: "_Problem", config: RobotConfig, r: np.ndarray,
                    steps: Sequence[tuple[TwinParameter, float, float]]
                    ) -> list[tuple[TwinParameter, float, np.ndarray]]:
    """(parameter, value, column) for each (parameter, value, step) of ``steps``: the
    weighted residual of ``config`` with the parameter moved by ``step`` in its coordinate,
    less ``r``, over ``step``; the moved robots re-simulated as one batch. A moved robot that
    diverges where ``r``'s did not has no slope to read and is left out."""
    raws = twin_residuals_many(
        prob.pool, [par.set(config, par.from_x(par.to_x(value) + step))
                    for par, value, step in steps],
        prob.o.stride, prob.o.horizons, prob.o.initial_state)
    out = []
    for (par, value, step), raw in zip(steps, raws):
        w = _weighted(raw, prob.scale)
        if np.any((w == DIVERGED_RESIDUAL) & (r != DIVERGED_RESIDUAL)):
            continue
        out.append((par, value, (w - r) / step))
    return out


def unfitted_columns(prob: "_Problem", x: np.ndarray, r: np.ndarray
                     ) -> list[tuple[TwinParameter, float, np.ndarray]]:
    """The registry's parameters ``prob`` did not fit (and that the servo has) with their value
    and Jacobian column at ``x`` (module doc, 7): a one-sided difference of ``diff_step``
    coordinates towards the inside of the bounds, one re-simulation each. A parameter whose
    moved robot diverges where the fitted one did not is left out, and so is one whose
    ``same_as`` are all fitted: another name for them (``mass_scale`` with both masses), which a
    finite-difference column shows as a small effect of its own that the score test would
    ask for, and a refit would then hold a direction the data cannot tell."""
    config = prob.config(x)
    steps = []
    for par, value in _not_fitted(prob, config):
        xc = par.to_x(value)
        lo_x, hi_x = par.x_bounds()
        # a threshold: a secant down by the plausible range (a limit not reached has no slope)
        step = secant_step(par, value, prob.o)
        if lo_x <= xc + step <= hi_x and step != 0:
            steps.append((par, value, step))
    return _secant_columns(prob, config, r, steps)


def raised_columns(prob: "_Problem", x: np.ndarray, r: np.ndarray
                   ) -> list[tuple[TwinParameter, float, np.ndarray]]:
    """The thresholds ``prob`` did not fit with their secant *upwards* at ``x`` (module doc,
    7): raised by as much as :func:`secant_step` lowers them, kept inside the bounds, one
    re-simulation each. A limit that binds in the twin where the robot's does not leaves the
    residual a trace that only raising it reads. A limit no torque reaches changes nothing
    raised (a zero column) and is left out, as is a diverging or bound-blocked one."""
    if prob.o.consider_spread <= 0:
        return []
    config = prob.config(x)
    steps = []
    for par, value in _not_fitted(prob, config):
        if par.threshold:
            step = min(-secant_step(par, value, prob.o), par.x_bounds()[1] - par.to_x(value))
            if step > 0:
                steps.append((par, value, step))
    return [c for c in _secant_columns(prob, config, r, steps) if np.any(c[2] != 0)]


def missing_parameters(prob: "_Problem", x: np.ndarray, J: np.ndarray, r: np.ndarray,
                       ask_share: float = 0.01,
                       columns: Sequence[tuple[TwinParameter, float, np.ndarray]] | None = None,
                       raised: Sequence[tuple[TwinParameter, float, np.ndarray]] = ()
                       ) -> list[dict[str, Any]]:
    """Score tests of the registry's parameters ``prob`` did not fit (module doc, 7), most
    asked for first: name, unit, value now, suggested value, statistic, p-value, the cost
    share a step would remove, and ``asks``. ``columns``: :func:`unfitted_columns` at ``x``
    if already computed. ``raised``: :func:`raised_columns`; a threshold with one is tested
    both ways, each side only for its own direction (a side whose step leaves it has no
    statistic), and its entry is the side that asks, else the one with the larger cost share
    (``side``: "lowered" or "raised"); every column counts in the level."""
    from scipy.stats import chi2

    if columns is None:
        columns = unfitted_columns(prob, x, r)
    up = {par.name for par, _, _ in raised}
    columns = ([(par, value, col, "lowered" if par.name in up else None)
                for par, value, col in columns]
               + [(par, value, col, "raised") for par, value, col in raised])
    if not columns:
        return []
    u, sv, _ = np.linalg.svd(J, full_matrices=False)     # the fitted columns' span (a column
    q = u[:, sv > 1e-10 * sv.max()] if sv.size and sv.max() > 0 else u[:, :0]   # without effect: none)
    cluster = len(prob.o.horizons) * len(STATE_NAMES)
    n_c = r.size // cluster
    sse = float(r @ r)
    out = []
    for par, value, col, side in columns:
        xc = par.to_x(value)
        lo_x, hi_x = par.x_bounds()
        if side == "raised":          # a secant upwards reads only a higher limit,
            lo_x = xc
        elif side == "lowered":       # and where there is one, the secant down a lower one
            hi_x = xc
        perp = col - q @ (q.T @ col)
        norm2 = float(perp @ perp)
        if not np.isfinite(norm2) or norm2 <= 1e-12 * max(float(col @ col), 1e-300):
            continue                  # no effect, or one the fitted parameters already have
        score = float(perp @ r)
        per_state = (perp[:n_c * cluster] * r[:n_c * cluster]).reshape(n_c, cluster).sum(axis=1)
        var = float(per_state @ per_state) * n_c / max(n_c - 1, 1)
        stat = score ** 2 / var if var > 0 else 0.0
        # the Gauss-Newton step, kept inside the bounds: at a bound, a residual that asks to go
        # beyond it asks for nothing this parameter can give
        x_new = float(min(max(xc - score / norm2, lo_x), hi_x))
        if side and x_new == xc:
            stat = 0.0                # the side's step leaves its side: it asks for nothing
        delta = x_new - xc
        share = max(0.0, -(2 * delta * score + delta ** 2 * norm2)) / sse if sse > 0 else 0.0
        suggested = par.from_x(x_new)
        out.append({"name": par.name, "unit": par.unit, "value": value, "suggested": suggested,
                    "statistic": stat, "p": float(chi2.sf(stat, 1)), "cost_share": share,
                    **({"side": side} if side else {})})
    level = 1e-3 / max(len(out), 1)
    best: dict[str, dict[str, Any]] = {}
    for m in out:
        m["asks"] = bool(m["p"] < level and m["cost_share"] >= ask_share)
        kept = best.get(m["name"])
        if kept is None or ((m["asks"], m["cost_share"], m["statistic"])
                            > (kept["asks"], kept["cost_share"], kept["statistic"])):
            best[m["name"]] = m
    return sorted(best.values(), key=lambda m: (not m["asks"], -m["cost_share"]))


def consider_sd(par: TwinParameter, value: float, spread: float) -> float:
    """The a-priori standard deviation, in the fit's coordinate, of a parameter not fitted
    (module doc, 10): ``spread`` e-folds of a scale-like parameter, ``spread`` times the larger
    of its value and ``typical`` for the others."""
    return spread if par.log else spread * max(abs(value), par.typical)


def consider_analysis(J: np.ndarray, params: Sequence[TwinParameter],
                      columns: Sequence[tuple[TwinParameter, float, np.ndarray]],
                      spread: float,
                      raised: Sequence[tuple[TwinParameter, float, np.ndarray]] = ()
                      ) -> tuple[np.ndarray, dict[str, Any]]:
    """The covariance the parameters not fitted add to the fitted ones' (module doc, 10):
    S C S^T with S = (J^T J)^-1 J^T J_c, the shift of the optimum per unit of each unfitted
    parameter, and C its a-priori variance (:func:`consider_sd`). A parameter whose
    ``same_as`` are all fitted is another name for them and left out. A threshold with a
    ``raised`` column (:func:`raised_columns`) acts by one column below its value and by the
    other above; its a-priori spread is symmetric, so each side carries half its variance.

    Returns (covariance in fit coordinates, report): the report has ``spread``, ``considered``
    (name, value, a-priori sd in the fit coordinate) and, per fitted parameter, its consider
    sd and the unfitted parameters that give most of it (``by``: name -> sd share, the
    largest first)."""
    fitted = {p.name for p in params}
    up = {par.name for par, _, _ in raised if not par.renames(fitted)}
    kept = [(par, value, col, math.sqrt(0.5) if par.name in up else 1.0)
            for par, value, col in list(columns) + list(raised) if not par.renames(fitted)]
    report: dict[str, Any] = {"spread": spread, "considered": [], "params": {}}
    p = len(params)
    if not kept or spread <= 0:
        return np.zeros((p, p)), report
    Jc = np.stack([col for _, _, col, _ in kept], axis=1)
    sd_c = np.array([consider_sd(par, value, spread) for par, value, _, _ in kept])
    half = np.array([f for _, _, _, f in kept])
    S = np.linalg.pinv(J.T @ J) @ (J.T @ Jc)                   # (p, m)
    contrib = S * (sd_c * half)[None, :]                          # (p, m): sd of each source
    cov = contrib @ contrib.T
    names = list(dict.fromkeys(par.name for par, _, _, _ in kept))
    report["considered"] = []
    for name in names:
        par, value = next((c[0], c[1]) for c in kept if c[0].name == name)
        report["considered"].append({"name": name, "value": value,
                                     "sd_coordinate": consider_sd(par, value, spread),
                                     **({"sides": 2} if name in up else {})})
    idx = {name: [j for j, c in enumerate(kept) if c[0].name == name] for name in names}
    for k, par in enumerate(params):
        by = {name: float(np.sqrt(np.sum(contrib[k, js] ** 2))) for name, js in idx.items()}
        top = sorted(by, key=lambda n: -by[n])[:3]
        report["params"][par.name] = {
            "sd_coordinate": float(math.sqrt(max(cov[k, k], 0.0))),
            "by": {n: by[n] for n in top if by[n] > 0}}
    return cov, report


def _estimate_dict(e: Estimate) -> dict[str, Any]:
    out = {"name": e.name, "unit": e.unit, "start": e.start, "value": e.value,
           "ci95": list(e.ci95), "at_bound": e.at_bound}
    if e.ci95_data is not None:
        out["ci95_data"] = list(e.ci95_data)
    return out


def _correlation(cov: np.ndarray, params: Sequence[TwinParameter]) -> dict[str, dict[str, float]]:
    d = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    c = cov / np.outer(d, d)
    return {a.name: {b.name: float(round(c[i, j], 4)) for j, b in enumerate(params)}
            for i, a in enumerate(params)}


def _rms_report(prob: _Problem, x0: np.ndarray, x: np.ndarray) -> dict[str, Any]:
    """RMS of the raw residual per horizon and element, at the start and at the optimum."""
    return {label: _rms_table(prob.raw(xi), prob.o.horizons)
            for label, xi in (("start", x0), ("calibrated", x))}


# ---------------------------------------------------------------------------------------------
# from a dataset to a twin file


def _check_out(out: Path) -> None:
    """Refuse an output that is not (and would replace something that is not) a twin file."""
    from .twin import load_twin

    if out.is_dir():
        raise ValueError(f"{out} is a directory; --out names the twin file to write")
    if not out.parent.is_dir():
        raise ValueError(f"{out.parent}: no such directory for the twin file")
    if out.exists():
        try:
            load_twin(out)
        except ValueError:
            raise ValueError(f"refusing to replace {out}: it exists and is not a twin file") \
                from None


def calibrate_dataset(data: str | os.PathLike, robot: str | os.PathLike | RobotConfig,
                      out: str | os.PathLike, options: CalibrationOptions = CalibrationOptions(),
                      test_per_type: int | None = None,
                      progress: Callable[[str], None] | None = None) -> Calibration:
    """``calibrate``: fit the twin of ``robot`` (a name or a twin file) to the dataset ``data``
    and write it to ``out`` (module doc). The file is written atomically after a successful fit
    only; an existing twin file is replaced then, anything else there is refused up front.

    ``test_per_type``: TestPool moves per type rolled out before and after (None: all).
    """
    from .. import __version__
    from ..data.dataset import DatasetError, load_moves, read_index
    from .twin import Twin, robot_config_from, robot_source, save_twin

    out = Path(out)
    options.check()
    _check_out(out)
    base = robot_config_from(robot)
    index = read_index(data)
    train = _bl.first_per_type(load_moves(data, "train"), options.moves_per_type)
    try:
        test = _bl.first_per_type(load_moves(data, "test"), test_per_type)
    except DatasetError:
        test = []
    cal = calibrate_twin(train, test, base, options, progress)
    provenance = {
        "created_by": f"littledog_mlsim {__version__} calibrate",
        "base_robot": robot_source(robot),
        "calibrated_from": {"data": str(Path(data).resolve()),
                            "dataset_robot": index.info.get("robot"),
                            "train_moves": cal.report["train_moves"],
                            "test_moves": [r.name for r in test]},
        "parameters": {e.name: {k: v for k, v in _estimate_dict(e).items() if k != "name"}
                       for e in cal.estimates},
        "calibration": {k: v for k, v in cal.report.items() if k != "params"},
    }
    save_twin(Twin(cal.config, provenance), out)
    log.info("wrote the twin %r to %s", cal.config.name, out)
    return cal
