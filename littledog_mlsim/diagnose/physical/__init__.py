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
2. **Library = family x scope x parameter** (:data:`..families.FAMILIES`, :meth:`..families.Family.scopes`). Joint
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
   magnitude along the fitted direction) on the screening moves by re-simulating a short grid
   around the first-order estimate and the vertex of a parabola through the best three (joint
   families on the 1 s segments' channels only); vector families then search their direction
   around the first-order one and refit the magnitude (:func:`.fit.refine_direction`). Every
   magnitude kept is then refitted on all fit moves (:func:`.fit.wide_magnitude`: body and
   leg families in :func:`.fit.refine_wide`, joint families once their scope is chosen), which
   is why the fits on the screening moves take no bisection steps (decision 057).
   This is the transducer: the parameter is the plug-in's value that reproduces the data.
   A family with other physical forms (a gain drift and a supply sag) has each form fitted at
   the scope its screen chose (:func:`.fit.form_variants`); step 5 chooses the form. The best
   joint hypothesis is refitted on its related scopes (:func:`.fit.scope_variants`). With a
   reference, where the fit moves' excess over it lives at one joint, leg or group
   (:func:`.driver.located_scopes`), every joint family and form is fitted there too
   (:func:`.fit.located_variants`, decision 051).
5. **Decision on held-out moves.** The fitted shortlist is re-simulated on other TrainPool moves
   (not used to screen or fit): the hypothesis with the largest mean per-move cut
   (:func:`..stats.move_cuts`, bounded per move and channel) is the finding (the 4 s replays are
   chaotic, so a fit on a few moves alone can prefer a hypothesis that only re-rolls the dice,
   and a cut summed relative to each channel's total lets a few moves' re-rolled replays
   decide); per-move SSE cuts, one-sided tests over moves: pooled over
   channels a t-test and a signed-rank max test over the shortlist (:func:`..stats.rank_max_p` of
   :func:`..stats.move_cuts`), per channel t-tests, Bonferroni over the three, the shortlist (the
   t-tests) and the 36 channels; it counts if significant
   (``p < alpha``) and material (some channel's held-out SSE cut >= ``min_gain`` with its own
   p < alpha). Before/after errors at horizons 0.1, 0.5, 1 and 4 s are reported.
6. **When the data cannot tell** (:func:`.advice.suspicions`): a command-path family that screens well
   but does not pass on data without command excitation is reported as suspected, with the
   recording that would settle it.
"""
from .advice import INSEPARABLE_SHARE, inseparable, physical_params, statement, suspicions
from .channels import CHANNELS, DEFAULT_HORIZONS_S, N_CH, horizon_errors
from .context import Objective, SearchContext
from .driver import PhysicalOptions, identify, pick_moves
from .fit import (fit, fit_magnitude, refine_direction, refine_position, refine_wide,
                  ridge_mass, scope_variants, form_variants, located_variants, start_side,
                  wide_magnitude)
from .records import Candidate, Finding, HeldOutDecision, Hypothesis, PhysIdResult
from .resim import Memo, Move, Runner, Transducer, build_effects, simulate, true_start
from .screen import screen, shortlist
from .validate import push_twin, validate

__all__ = ["identify", "PhysicalOptions", "PhysIdResult", "Finding", "Candidate", "Hypothesis",
           "SearchContext", "Objective", "Transducer", "Runner", "Memo", "Move", "simulate",
           "true_start", "build_effects", "screen", "shortlist", "fit", "fit_magnitude",
           "refine_direction", "refine_position", "refine_wide", "ridge_mass", "wide_magnitude",
           "start_side", "scope_variants", "form_variants", "located_variants", "validate",
           "push_twin", "physical_params",
           "statement", "inseparable", "suspicions", "INSEPARABLE_SHARE", "horizon_errors",
           "CHANNELS", "N_CH", "DEFAULT_HORIZONS_S", "pick_moves", "HeldOutDecision"]
