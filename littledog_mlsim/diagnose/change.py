"""A change since the reference that the data's own model carries: the reference's model on the data.

The learned route's search (:mod:`.learned`) and the unexplained-change test (:mod:`.excess`,
decision 026) both judge the model *trained on the data*. An effect that is a function of that
model's inputs is learned from the data and leaves it no excess: a weaker servo, a worn foot, a
drag on a swinging foot, and, with the start features' lagged states, even a leg whose
set-points arrive a few steps late. Such a change is still a change of the robot, and with a
reference recording of the same robot it is measured directly (decision 027):

1. **Is there a change, and where** (:func:`_where_one_step`). The route's search model is
   fitted on every TrainPool move of the reference, with the route's final feature set, and
   predicts the data's next step. Each move's one-step mean squared residual per element,
   divided by the reference's own held-out mean, gives the scope by decision 026's
   concentration rule (:func:`.excess._where`); the change is material where that scope's
   ratio is at least :data:`.excess.MIN_RATIO` and significant where a one-sided Mann-Whitney
   U test over moves gives p < ``alpha``. The same model's 1 s rollouts of the data against
   the reference's own are reported beside it (``rollout_ratio``). One step, not rollouts,
   locates it: a joint that behaves differently drives the reference's model into states its
   data never held, and its rollouts then go wrong everywhere.
2. **Only a change at joints is screened**: one concentrated at a joint scope, or spread over
   all joints (decision 035, :data:`SCREEN_SPREAD`). A change in the body's elements is
   reported and not named, unless it lives in one leg's swing (decision 029,
   :func:`_where_in_swing`):
   the same ratio per leg on the rows where the leg swings and where it stands; the leg whose
   swing ratio is the largest, material (:data:`SWING_MIN_RATIO`), significant and at least
   :data:`SWING_CONCENTRATION` times the other legs' (each on the rows where it swings apart
   from that leg; a trot's diagonal partner left out: decision 067) is screened on its swing rows
   (:func:`_screen_in_swing`) where the change over all rows is not material, or where the
   joint scope located over all rows lies in that leg and was not named. There a force on the
   swinging foot (``contact_phase``, ``phase: swing``) is named where the leg's stance ratio
   is not material and the force's columns are significant and material on those rows (one
   test at the route's ``scope_alpha``); it is sized by :func:`_drag_newtons`, and named only
   where that size opposes the foot's motion (a positive drag; so also a drag kept over all
   rows).
3. **What it is like.** A hypothesis corrects the reference's model by a per-joint linear
   function of each scope joint's one-step change in angle and rate, fitted on the data's
   residual of the reference's model and cross-fitted by the route's folds
   (:class:`ChangeModel`): the servo's tracking error ``u - q``, the joint's rate and a
   constant (the servo's response: ``servo_gain``), plus a family's column: the set-point
   ``k`` steps back minus the current one (``command_delay``, ``k`` = 1..:data:`MAX_LAG`), the
   set-point through a first-order low-pass minus the current one (``command_filter``, the time
   constants :data:`FILTER_MS`), the set-point's place in a play band of the widths
   :data:`PLAY_WIDTHS` (``backlash``, :class:`..models.feature_library.Play` of the set-point), the
   rate while the foot swings and the joint's torque per newton of a drag opposing the
   swinging foot's horizontal motion (``contact_phase``, :func:`swing_drag_torque`; named at
   the leg), the elapsed time times the tracking error (``time_drift``,
   :class:`..models.feature_library.ElapsedTracking`; under decision 068,
   :data:`DRIFT_WHOLE_OUTPUT`, also times the rate: a supply's sag scales the servo's damping
   with its stiffness; under decision 069, :data:`DRIFT_COUPLED`, the screen's drift carries
   both columns of every scope joint at each: a sag at many joints moves each joint by the
   others' torques through the body; decision 070, :data:`COUPLED_CHECKED`, fits and judges
   that drift on a servo response coupled the same way). Decisions are the route's
   :func:`.stats.sse_decision` on per-move held-out one-step SSE of the scope's angles and
   rates:
   - the servo response against the same correction fitted on the reference's own held-out
     residual (what these columns do where nothing changed) must be significant and
     material, else nothing is named;
   - a family's column against the servo response must be significant and material, and the
     family must stand alone (decision 030, :func:`_stands_alone`): the best of its scan, its
     column and a constant without the servo's columns, leaves no more held-out one-step
     error at the scope than the servo response alone. Of the families that qualify, the one
     whose best alone leaves the least error is kept, at its scan's largest gain on top of
     the servo response; else the servo response. A delay and a low-pass mimic each other on
     top of the servo's columns (a delay's gain still rising at the longest lag, a low-pass's
     at the shortest time constant), not alone.
   - **An angle offset** (decision 039, :func:`_offset`): where no family qualifies, a
     constant alone (``encoder_offset``) is kept in place of the servo response where it is
     significant and material against the same constant fitted on the reference and gains
     more than the servo response's other columns gain on top of it: an angle sensor mounted
     off shows at the recorded angle as a near-constant in the rate's change with the servo's
     slope unchanged (:func:`_offset`).
   - **Replayed** (decision 036, :func:`_replay`): where the kept hypothesis is a change of
     the set-point's path (a delay, a low-pass, a play), the reference's model predicts the
     data's next step from the data's state and the set-point each hypothesis of that
     family says the servo acts on (delays of 5-60 ms in quarter steps, low-passes of
     10-80 ms, plays of 0.01-0.1 rad), with nothing fitted. The replay that leaves the least
     one-step error sizes the family where it removes at least :data:`REPLAY_MIN_SHARE` of
     the excess over the data's own model: a free column can trade its scale for its
     delay, a replay cannot. The family stays the screen's: across families the replay
     depends on how well the reference's commands taught its model the answer to a
     set-point apart from the state, and a one-leg delay's replay is beaten by a low-pass's.
4. **Named** where the kept hypothesis removes at least :data:`EXPLAINED_SHARE` of the scope's
   one-step error of the reference's model above the data's own model's (``explained``);
   otherwise the change is reported at its scope without a family. A change spread over all
   joints where a time drift is kept and not named is screened again at each joint type, side
   and leg where it is material, and named at the scope where the drift explains the most,
   where that is enough (decision 040, :func:`_screen_narrower`, ``narrower``). A change
   located over all rows that no screen names (decision 071, :data:`COUPLED_FALLBACK`) is
   screened once more at its located scope with the drift coupled and checked (decisions 069
   and 070), and named a drift with time where that screen names one
   (:func:`_fall_back_coupled`, ``coupled_fallback``): each joint's own drift columns name a
   drift of some joints at their scope, and a sag of many servos, which moves each joint by
   the others' torques as well, only through the coupled columns. Decision 072's candidate
   (:data:`NARROW_FALLBACK`, off, not adopted) names such a drift found at all joints at the
   joint type, side or leg whose joints' coupled drift, acting on every joint, explains the
   whole change as well (:func:`_narrow_source`, ``coupled_fallback.narrower``).
5. **Its size**, where the family has one (:func:`_size`): a servo gain ratio, the data's over
   the reference's slope of the rate's one-step change on ``u - q`` (:func:`servo_slope`,
   median over the scope's joints); an angle offset, none (the constant's size depends on
   where the servo reads its angle and on the loads at the joint; ``per_joint`` gives each
   joint's constant); a delay, a low-pass's time constant or a play band's
   width, the replay's where it explains enough (3), else a delay of ``k`` steps, a play
   band's width and a low-pass's time constant on a finer grid around the scan's best
   (:data:`FINER_STEPS`; :func:`_finer_low_pass`); a drift rate from each scope joint's own
   stiffness slope on the data minus on the reference (:func:`_drift_rate`, decision 038; the
   ``t (u - q)`` coefficient over the reference's slope is kept as ``model_rate_per_s``); a
   drag in newtons, the coefficient of its torque column over the reference's slope times the
   ``nominal`` robot's servo stiffness (the slope is that stiffness over the joint's inertia,
   the coefficient the drag over it; median over the scope's joints), so off by as much as the
   robot's stiffness is.

Nothing is added to the served model for it; the statement says whether the data's own model
carries the change (decision 026's ratio below :data:`.excess.MIN_RATIO`) or not. It runs also
where the route's search accepted changes (``search``): a search led by the data's own model
can take a rival family or scope first (a delay at the hip pitches for a low-pass on one side),
and the reference's model, which holds neither, still shows where the robot changed;
``agrees`` says whether the named change is one the search accepted.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ..layout import CONTROL_DT, N_FEATURE, N_STATE, S
from ..models.feature_base import Augmentation
from ..models.feature_library import (JOINT_GROUPS, SWING_LIFT_M, CommandFilter, CommandLag,
                                      ElapsedTime, ElapsedTracking, Play, SwingRate,
                                      _commanded_lift, _forward_kinematics)
from ..models.features import FeatureSet
from .excess import CONCENTRATION, MIN_RATIO, unexplained_change
from .families.scopes import (TYPE_SCOPES, group_scope, joint_scopes, leg_scopes, scope_group,
                              scope_joints, scope_words)

if TYPE_CHECKING:                    # pragma: no cover
    from .learned import CrossFitModel, _Route

__all__ = ["MAX_LAG", "EXPLAINED_SHARE", "Hypothesis", "ChangeModel", "wider_scopes",
           "reference_change", "drift_through_reference"]

#: the longest set-point delay screened, in control steps
MAX_LAG = 5
#: the set-point low-pass time constants screened [ms]
FILTER_MS = (15.0, 25.0, 35.0, 50.0, 80.0)
#: a hypothesis explains the change when it removes at least this share of the scope's one-step
#: error of the reference's model above the data's own model's: each hypothesis is linear in its
#: own columns, so the change it stands for leaves little of the excess (decision 027)
EXPLAINED_SHARE = 0.75
#: the play band widths screened for a set-point backlash [rad]
PLAY_WIDTHS = (0.01, 0.02, 0.035, 0.05, 0.08)
#: the kept low-pass's time constant is sized on this finer grid, as ratios to the scan's best
FINER_STEPS = (0.7, 0.8, 0.9, 1.1, 1.2, 1.35)
#: foot speed [m/s] below which a swing drag's direction is softened (its size v / sqrt(v^2 +
#: scale^2))
FOOT_SPEED_SCALE = 0.05
#: the robot whose servo stiffness turns a drag's joint response into newtons
NOMINAL_ROBOT = "nominal"
#: ridge on the standardised correction columns, per row
RIDGE = 1e-3
#: a leg's swing-phase one-step ratio at least this many times the other legs' (in their swing)
#: locates a change there where no scope of all rows is concentrated (decisions 029, 034)
SWING_CONCENTRATION = 1.4
#: a leg's swing-phase one-step ratio at least this is material there (decision 034; decision
#: 029 took decision 026's 1.5)
SWING_MIN_RATIO = 1.25
#: the concentration compares the leg's swing with the other legs' swing *apart from its own*
#: (decision 067): each other leg's ratio on the rows where it swings and the located leg
#: stands; a leg that swings with it (a trot's diagonal partner: the same rows) is left out
SWING_APART = True
#: another leg swings apart from the located one where at least this share of its swing rows
#: (in the data and in the reference) has the located leg standing
SWING_APART_SHARE = 0.25
#: a change spread over all joints (scope ``all``) is screened as a concentrated one is
#: (decision 035)
SCREEN_SPREAD = True
#: where no family stands beside the servo response, a constant alone is screened against it:
#: an angle sensor's offset (decision 039, :func:`_offset`)
SCREEN_OFFSET = True
#: a change spread over all joints whose kept family (one of :data:`NARROWER_FAMILIES`) is not
#: named there is screened again at each joint type, side and leg where the change is
#: material, and named at the one where the same family explains the most, if it explains
#: enough there (decision 040, :func:`_screen_narrower`)
SCREEN_NARROWER = True
#: a drift with time is the servo's whole output scaled with time (decision 068): beside
#: ``t (u - q)`` its hypothesis carries ``t dq`` at each scope joint, as a supply that sags
#: scales the servo's damping with its stiffness (a gain that drifts leaves ``t dq`` near zero)
DRIFT_WHOLE_OUTPUT = False
#: the screen's drift with time is coupled over its scope's joints (decision 069): each scope
#: joint's correction carries ``t (u - q)`` and ``t dq`` of every scope joint (its own first),
#: as a joint's acceleration answers every joint's torque through the body's mass matrix and
#: the feet's contacts, so a sag of many servos moves each joint by the others' torques too.
#: Decision 028's confirmation of a drift the search accepted keeps the joint's own columns:
#: it is a guard against a search's stand-in, and the coupled columns would confirm a one-leg
#: delay as a drift of that leg
DRIFT_COUPLED = False
#: a coupled drift (decision 069) is checked (decision 070): it is fitted on top of a servo
#: response coupled over the scope's joints (each joint's correction also carries every other
#: scope joint's ``u - q`` and ``dq``) and judged against that response, so that the other
#: joints' drift columns cannot stand in for a constant change of some servos; and a coupled
#: drift named at all joints is screened again at the narrower scopes (decision 040's), where
#: the one that explains the most is named instead if it explains at least the share at all
#: joints less :data:`NARROWER_CLOSE`
COUPLED_CHECKED = False
#: decision 070: a narrower scope is preferred to all joints where its share is this close
NARROWER_CLOSE = 0.05
#: a change located where the screen (with decisions 029 and 040) names nothing is screened
#: again at the located scope with the drift coupled and checked (decisions 069 and 070), and
#: named where that screen names a drift with time (decision 071): the screen's own drift,
#: per joint, names a drift of some joints at their scope; a sag of many servos moves each
#: joint by the others' torques too, and only the coupled drift carries that share
COUPLED_FALLBACK = True
#: decision 072's candidate, not adopted (off): a drift decision 071 names at all joints is
#: named at the narrower scope (:data:`NARROWER_SCOPES`) whose joints' coupled drift, acting on
#: every joint, explains the whole change within :data:`NARROWER_CLOSE` of all joints' drift.
#: Its study (``benchmarks/learned_route/reference_change/narrow_fallback/``) named sags of
#: every servo at a side: every scope's share comes close to all joints'
NARROW_FALLBACK = False
#: the families decision 040 screens again: a drift's excess grows from nothing along each move
#: and spreads through the body, so a drift of some joints reads as spread
NARROWER_FAMILIES = ("time_drift",)
#: the scopes decision 040 screens under ``all``
NARROWER_SCOPES = (tuple(f"type:{t}" for t in TYPE_SCOPES) + ("side:left", "side:right")
                   + tuple(leg_scopes()))
#: the families of the set-point's path: a change the reference's model can replay, given the
#: set-point the servo would then act on
SETPOINT_FAMILIES = ("command_delay", "command_filter", "backlash")
#: a kept change of the set-point's path is named and sized by replaying the reference's model
#: with each hypothesised set-point (decision 036, :func:`_replay`)
REPLAY_SETPOINT = True
#: delays replayed [control steps]; a fractional one interpolates between whole steps
REPLAY_DELAYS = tuple(float(d) for d in np.arange(0.5, MAX_LAG + 1.0 + 1e-9, 0.25))
#: low-pass time constants replayed [ms]
REPLAY_FILTER_MS = (10.0, 12.5, 15.0, 17.5, 20.0, 22.5, 25.0, 30.0, 35.0, 40.0, 50.0, 65.0, 80.0)
#: play band widths replayed [rad]
REPLAY_PLAY_WIDTHS = (0.01, 0.015, 0.02, 0.025, 0.035, 0.05, 0.065, 0.08, 0.1)
#: the kept family's best replay sizes it where it removes at least this share of the scope's
#: one-step error of the reference's model above the data's own model's
REPLAY_MIN_SHARE = 0.5
#: a leg swings on a row where its swing weight (commanded lift over ``SWING_LIFT_M``) is above
#: this, and stands where it is zero
SWING_ROW = 0.5


@dataclass(frozen=True)
class Hypothesis:
    """A change at ``scope``: the servo's response, plus ``aug``'s column for ``family``."""

    family: str       # servo_gain, encoder_offset, command_delay, command_filter, backlash,
    #                   contact_phase, time_drift
    scope: str
    aug: Augmentation | None = None
    alone: bool = False   # the family's column(s) and a constant, without the servo response
    coupled: bool = False  # a drift's columns of every scope joint at each (decision 069)
    checked: bool = False  # a coupled drift on a coupled servo response (decision 070)
    source: str | None = None  # a coupled drift's own joints, narrower than ``scope``'s, on
    #                            each of which it acts (decision 072); None: ``scope``'s

    def label(self) -> str:
        what = {"servo_gain": "servo response", "encoder_offset": "angle offset",
                "command_delay": "set-point delay",
                "command_filter": "set-point low-pass", "backlash": "set-point play",
                "contact_phase": "rate in swing", "time_drift": "drift with time"}[self.family]
        if self.coupled:
            what += " (coupled)"
        if isinstance(self.aug, CommandLag):
            what += f" {self.aug.lag} step(s)"
        elif isinstance(self.aug, CommandFilter):
            what += f" {self.aug.time_constant_ms:g} ms"
        elif isinstance(self.aug, Play):
            what += f" {self.aug.width:g} rad"
        if self.source is not None:
            return f"{what} @ {self.source}, acting at {self.scope}"
        return f"{what} @ {self.scope}"


def _family_aug(family: str, scope: str, lag: int = 1, tau_ms: float = 20.0,
                width: float = 0.05) -> Augmentation:
    group = scope_group(scope)
    if family == "backlash":
        return Play(width=width, source="u", joints=group)
    if family == "command_delay":
        return CommandLag(lag=lag, joints=group)
    if family == "command_filter":
        return CommandFilter(time_constant_ms=tau_ms, joints=group)
    if family == "contact_phase":
        return SwingRate(joints=group)
    if family == "time_drift":
        return ElapsedTracking(joints=group)
    raise ValueError(f"change: no column for family {family!r}")


def _whole_output(hyp: Hypothesis) -> bool:
    """Whether ``hyp`` is a drift with time carrying the servo's whole output (decision 068,
    :data:`DRIFT_WHOLE_OUTPUT`; a coupled drift, decision 069, carries it too)."""
    return bool((DRIFT_WHOLE_OUTPUT or hyp.coupled) and hyp.family == "time_drift"
                and isinstance(hyp.aug, ElapsedTracking))


def _coupled(hyp: Hypothesis) -> bool:
    """Whether ``hyp`` is a drift with time coupled over its scope's joints (decision 069: the
    screen's drift under :data:`DRIFT_COUPLED`, :func:`_families`)."""
    return bool(hyp.coupled and _whole_output(hyp))


class ChangeModel:
    """The reference's model (its fit on every move, ``fold=-1``) plus a per-joint linear
    correction of each scope joint's one-step change in angle and rate, fitted per fold on the
    data's one-step residual of the reference's model. Predicts as :class:`.learned.CrossFitModel`
    does (raw one-step change), on rows of ``fs``'s columns followed by the hypothesis's
    augmentation's own."""

    def __init__(self, ref: "CrossFitModel", fs: FeatureSet, hyp: Hypothesis) -> None:
        self.ref, self.hyp = ref, hyp
        self.design = ref.design              # the rollout clips to the reference's box
        self.n_ref = fs.n_features
        self.joints = [int(j) for j in scope_joints(hyp.scope)]
        self.extra: dict[int, int] = {}
        self.elapsed: int | None = None       # the seconds' column of a whole-output drift
        self.coupled = _coupled(hyp)          # every scope joint's drift columns (decision 069)
        # every scope joint's servo columns too (decision 070): a coupled servo response, or a
        # checked coupled drift on top of it
        self.coupled_servo = bool(hyp.coupled and not hyp.alone and (
            (hyp.family == "servo_gain" and hyp.aug is None)
            or (self.coupled and (COUPLED_CHECKED or hyp.checked))))
        if hyp.aug is not None:        # its columns follow fs's (:meth:`_Residuals.of`)
            cols = JOINT_GROUPS[hyp.aug.joints]
            self.extra = {int(j): self.n_ref + i for i, j in enumerate(cols)}
            if _whole_output(hyp):
                self.elapsed = self.n_ref + len(cols)

    def _drag(self, X: np.ndarray) -> np.ndarray | None:
        """:func:`swing_drag_torque` of X's rows for a swing hypothesis, else None."""
        return swing_drag_torque(X) if isinstance(self.hyp.aug, SwingRate) else None

    @property
    def const(self) -> int:
        """The constant's place among a joint's correction columns (:meth:`_z`)."""
        return 0 if self.hyp.alone else 2

    @property
    def own_joints(self) -> list[int]:
        """The joints whose column 3 is their own family column: the scope's, or a drift's
        ``source`` joints (decision 072)."""
        if self.hyp.source is None:
            return self.joints
        return [j for j in self.joints if j in self.extra]

    def _z(self, X: np.ndarray, j: int, drag: np.ndarray | None = None) -> np.ndarray:
        """(n, k) correction columns of joint j: u - q, dq, 1 and the family's column(s)
        (a swing hypothesis: the rate in swing and ``drag``'s column j; a whole-output drift,
        decision 068: ``t (u - q)`` and ``t dq``; a coupled drift, decision 069: then the same
        two of every other scope joint); last, under decision 070, every other scope joint's
        ``u - q`` and ``dq`` (a coupled servo response, or a checked coupled drift); a
        hypothesis ``alone``: 1 and the family's column(s), without the servo's."""
        u, q, dq = X[:, N_STATE + j], X[:, S.q.start + j], X[:, S.dq.start + j]
        cols = [np.ones_like(u)] if self.hyp.alone else [u - q, dq, np.ones_like(u)]
        if j in self.extra:
            e = X[:, self.extra[j]]
            cols.append(e - u if isinstance(self.hyp.aug, (CommandLag, CommandFilter)) else e)
            if drag is not None:
                cols.append(drag[:, j])
            if self.elapsed is not None:
                cols.append(X[:, self.elapsed] * dq)
            if self.coupled:
                for k, c in self.extra.items():
                    if k != j:
                        cols += [X[:, c], X[:, self.elapsed] * X[:, S.dq.start + k]]
        elif self.coupled and self.hyp.source is not None:
            # decision 072: a joint outside the drift's own, moved by the drifting joints
            for k, c in self.extra.items():
                cols += [X[:, c], X[:, self.elapsed] * X[:, S.dq.start + k]]
        if self.coupled_servo:         # decision 070: last, every other scope joint's servo
            for k in self.joints:
                if k != j:
                    cols += [X[:, N_STATE + k] - X[:, S.q.start + k], X[:, S.dq.start + k]]
        return np.stack(cols, axis=1)

    @staticmethod
    def outputs(j: int) -> list[int]:
        return [S.q.start + j, S.dq.start + j]

    def fit(self, X: np.ndarray, R: np.ndarray, fold_of_row: np.ndarray, n_folds: int
            ) -> "ChangeModel":
        """Fit the correction on residuals ``R`` (n, 33) of the reference's model at rows X:
        per fold (all rows but the fold's) and on all rows (``fold=-1``)."""
        self.coef_: dict[int, dict[int, np.ndarray]] = {f: {} for f in [-1] + list(range(n_folds))}
        self.scale_: dict[int, np.ndarray] = {}
        drag = self._drag(X)
        for j in self.joints:
            Z = self._z(X, j, drag)
            sd = Z.std(axis=0)
            sd[self.const] = 1.0
            sd = np.where(sd < 1e-12, 1.0, sd)
            self.scale_[j] = sd
            Zs, r = Z / sd, R[:, self.outputs(j)]
            G_f = [Zs[fold_of_row == f].T @ Zs[fold_of_row == f] for f in range(n_folds)]
            b_f = [Zs[fold_of_row == f].T @ r[fold_of_row == f] for f in range(n_folds)]
            G, b = sum(G_f), sum(b_f)
            for f in [-1] + list(range(n_folds)):
                A = G if f < 0 else G - G_f[f]
                bb = b if f < 0 else b - b_f[f]
                n = max(1.0, float(A[self.const, self.const]))
                self.coef_[f][j] = np.linalg.solve(A + RIDGE * n * np.eye(len(sd)), bb)
        return self

    def correction(self, X: np.ndarray, fold: int) -> np.ndarray:
        """(n, 33) the correction alone (zero outside the scope's angles and rates)."""
        out = np.zeros((len(X), N_STATE))
        drag = self._drag(X)
        for j in self.joints:
            out[:, self.outputs(j)] = ((self._z(X, j, drag) / self.scale_[j])
                                       @ self.coef_[fold][j])
        return out

    def predict(self, X: np.ndarray, fold: int) -> np.ndarray:
        return self.ref.predict(X[:, :self.n_ref], -1) + self.correction(X, fold)

    def raw_coef(self, j: int, column: int, output: int = 1, fold: int = -1) -> float:
        """Raw-unit coefficient of correction column ``column`` (0: u - q, or the constant of a
        hypothesis ``alone``; 3: the family's, at :attr:`own_joints` only; 4: a swing
        hypothesis's drag, a whole-output drift's ``t dq``) on output ``output`` (0: the
        angle's one-step change, 1: the rate's)."""
        return float(self.coef_[fold][j][column, output] / self.scale_[j][column])


def swing_drag_torque(X: np.ndarray) -> np.ndarray:
    """(n, 12) each joint's torque per newton of a horizontal force of constant size opposing
    its foot's horizontal velocity while the foot is meant to swing: ``w J_j^T (-v / |v|)``,
    ``J_j`` the foot position's derivative by the joint's angle (forward kinematics, body
    frame, x and y), ``v = sum_j J_j dq_j`` the foot's velocity (its size softened below
    :data:`FOOT_SPEED_SCALE`), ``w`` the leg's swing weight (commanded lift over
    ``SWING_LIFT_M``, clipped to [0, 1], as :class:`..models.feature_library.SwingRate`). In
    metres: a drag of F newtons adds ``F`` times it to the joint's torque."""
    q, dq = X[:, S.q], X[:, S.dq]
    n = len(X)
    p = _forward_kinematics(q)                                   # (n, 4, 3)
    p0 = p[..., :2]
    J = np.empty((n, 12, 2))
    eps = 1e-5
    for j in range(12):
        qq = q.copy()
        qq[:, j] += eps
        J[:, j] = (_forward_kinematics(qq)[:, j // 3, :2] - p0[:, j // 3]) / eps
    legs = np.arange(12) // 3
    v = np.zeros((n, 4, 2))
    np.add.at(v, (slice(None), legs), J * dq[:, :, None])
    # the body's own motion at the foot: its velocity plus its rates across the foot's place
    vb, wb = X[:, S.d_b][:, None, :], X[:, S.d_rpy][:, None, :]
    v[..., 0] += vb[..., 0] + wb[..., 1] * p[..., 2] - wb[..., 2] * p[..., 1]
    v[..., 1] += vb[..., 1] + wb[..., 2] * p[..., 0] - wb[..., 0] * p[..., 2]
    v_hat = v / np.sqrt((v ** 2).sum(axis=2, keepdims=True) + FOOT_SPEED_SCALE ** 2)
    return swing_weight(X)[:, legs] * -(J * v_hat[:, legs]).sum(axis=2)


def swing_weight(X: np.ndarray) -> np.ndarray:
    """(n, 4) each leg's swing weight on rows X: its commanded lift over ``SWING_LIFT_M``,
    clipped to [0, 1] (as :class:`..models.feature_library.SwingRate`)."""
    return np.clip(_commanded_lift(X[:, N_STATE:N_STATE + 12]) / SWING_LIFT_M, 0.0, 1.0)


def wider_scopes(scope: str) -> list[str]:
    """``scope`` and every joint scope of the vocabulary that holds all its joints, narrow
    to wide."""
    mine = set(scope_joints(scope).tolist())
    out = [s for s in joint_scopes() if mine <= set(scope_joints(s).tolist())]
    return sorted(out, key=lambda s: (len(scope_joints(s)), s != scope))


def servo_slope(X: np.ndarray, D: np.ndarray, j: int) -> float:
    """The slope of joint j's one-step rate change on its tracking error u - q, by least
    squares on u - q, its rate and a constant: the servo's stiffness over the joint's inertia,
    times the step (a weaker servo: a smaller slope)."""
    u, q, dq = X[:, N_STATE + j], X[:, S.q.start + j], X[:, S.dq.start + j]
    Z = np.stack([u - q, dq, np.ones_like(u)], axis=1)
    coef, *_ = np.linalg.lstsq(Z, D[:, S.dq.start + j], rcond=None)
    return float(coef[0])


def elapsed_s(mi: np.ndarray) -> np.ndarray:
    """Each row's seconds since its move's first row, for rows of whole moves in time order
    (``mi``: each row's move index, as :meth:`..models.features.FeatureSet.features_responses`
    gives them)."""
    mi = np.asarray(mi)
    starts = np.r_[0, np.flatnonzero(np.diff(mi)) + 1]
    lengths = np.diff(np.r_[starts, len(mi)])
    return (np.arange(len(mi)) - np.repeat(starts, lengths)) * CONTROL_DT


def stiffness_rate(X: np.ndarray, D: np.ndarray, mi: np.ndarray, j: int,
                   t_dq: bool = False) -> float:
    """Joint j's relative stiffness change per second on one recording's rows: the
    least-squares coefficient of t (u - q) over that of u - q in the rate's one-step change,
    beside a constant, the rate and the angle, and ``t dq`` where ``t_dq`` (t:
    :func:`elapsed_s`; a servo gain k (1 + r t) gives r)."""
    u, q, dq = X[:, N_STATE + j], X[:, S.q.start + j], X[:, S.dq.start + j]
    e, t = u - q, elapsed_s(mi)
    Z = np.stack([np.ones_like(u), e, t * e, dq, q] + ([t * dq] if t_dq else []), axis=1)
    c, *_ = np.linalg.lstsq(Z, D[:, S.dq.start + j], rcond=None)
    return float(c[2] / c[1]) if abs(c[1]) > 1e-12 else float("nan")


def _drift_rate(X: np.ndarray, D: np.ndarray, mi: np.ndarray, Xr: np.ndarray, Dr: np.ndarray,
                mir: np.ndarray, joints: Sequence[int]) -> dict[str, Any]:
    """Decision 038: a time drift's rate, each joint's :func:`stiffness_rate` on the data
    minus on the reference, the median over ``joints``."""
    r = {j: stiffness_rate(X, D, mi, j) - stiffness_rate(Xr, Dr, mir, j) for j in joints}
    ok = [v for v in r.values() if np.isfinite(v)]
    return {"rate_per_s": round(float(np.median(ok)), 4) if ok else None,
            "per_joint": {str(j): round(v, 4) for j, v in r.items() if np.isfinite(v)}}


def _size(model: ChangeModel, X: np.ndarray, D: np.ndarray, Xr: np.ndarray, Dr: np.ndarray,
          mi: np.ndarray | None = None, mir: np.ndarray | None = None) -> dict[str, Any]:
    """The kept hypothesis's size in its family's unit (module doc, 3): X, D the data's
    features and one-step changes, Xr, Dr the reference's; ``mi``, ``mir`` their rows' move
    indices where the rows are whole moves (a time drift is then sized by
    :func:`_drift_rate`, decision 038, and the correction's own figure is kept as
    ``model_rate_per_s``)."""
    hyp = model.hyp
    if hyp.family == "encoder_offset":
        # no angle without a twin (decision 039): each joint's constant in its rate's one-step
        # change [rad/s], as measured
        return {"offset_rad": None,
                "per_joint": {str(j): round(model.raw_coef(j, 0), 5) for j in model.joints}}
    if hyp.family == "command_delay":
        return {"delay_ms": round(hyp.aug.lag * CONTROL_DT * 1000.0, 1)}
    if hyp.family == "command_filter":
        return {"time_constant_ms": float(hyp.aug.time_constant_ms)}
    if hyp.family == "backlash":
        return {"width_rad": float(hyp.aug.width)}
    # the rest are read against the reference's servo slope
    k = {j: servo_slope(Xr, Dr, j) for j in model.joints}
    if hyp.family == "servo_gain":
        r = {j: servo_slope(X, D, j) / k[j] for j in model.joints if abs(k[j]) > 1e-12}
        return {"gain_ratio": round(float(np.median(list(r.values()))), 3) if r else None,
                "per_joint": {str(j): round(float(v), 3) for j, v in r.items()}}
    if hyp.family == "time_drift":
        r = [model.raw_coef(j, 3) / k[j] for j in model.own_joints if abs(k[j]) > 1e-12]
        own = round(float(np.median(r)), 4) if r else None
        if mi is None or mir is None:
            return {"rate_per_s": own}
        return {**_drift_rate(X, D, mi, Xr, Dr, mir, model.own_joints),
                "model_rate_per_s": own}
    if hyp.family == "contact_phase":
        from ..robot.config import per_joint, robot_config
        kp = per_joint(robot_config(NOMINAL_ROBOT).kp)
        f = [model.raw_coef(j, 4) / k[j] * kp[j] for j in model.joints if abs(k[j]) > 1e-12]
        return {"magnitude": round(float(np.median(f)), 3) if f else None,
                "per_joint": {str(j): round(float(v), 3) for j, v in zip(model.joints, f)}}
    return {"magnitude": None}


#: the joint elements (q and dq of the 12 joints) the change screen judges
JOINT_ELEMENTS = np.r_[S.q.start:S.q.stop, S.dq.start:S.dq.stop]


@dataclass
class _Judged:
    """A hypothesis's held-out one-step evidence (per move and joint element, (M, 24)):
    ``sse`` the data's residual with the correction fitted on the data (each move by the fit
    without its fold), ``base`` with the correction fitted on the reference (what the same
    columns do where nothing changed), ``ref_sse`` the reference's own held-out residual with
    its correction; and the decision of ``sse`` against ``base``."""

    hyp: Hypothesis
    model: ChangeModel
    sse: np.ndarray
    base: np.ndarray
    ref_sse: np.ndarray
    decision: Any = None

    @property
    def total(self) -> float:
        return float(np.sum(self.decision.gain)) if self.decision is not None else 0.0

    @property
    def ok(self) -> bool:
        d = self.decision
        return bool(d is not None and d.significant and d.material and self.total > 0)


def _explained(j: _Judged, own: float, cols: Sequence[int]) -> float:
    """The share of the excess over the data's own model (``own``, its held-out SSE at
    ``cols``) that ``j``'s correction removes: its SSE against the same columns fitted on the
    reference (``j.base``)."""
    before, after = j.base[:, cols].sum(), j.sse[:, cols].sum()
    return float((before - after) / (before - own)) if before > own else 0.0


def _columns_of(joints: Sequence[int]) -> list[int]:
    """Columns of JOINT_ELEMENTS that are the joints' angles and rates."""
    js = set(int(j) for j in joints)
    return [i for i in range(len(JOINT_ELEMENTS)) if i % 12 in js]


def _move_sse(R: np.ndarray, mi: np.ndarray, n_moves: int) -> np.ndarray:
    out = np.zeros((n_moves, len(JOINT_ELEMENTS)))
    np.add.at(out, mi, R[:, JOINT_ELEMENTS] ** 2)
    return out


@dataclass
class _Residuals:
    """One side's one-step residuals of the reference's model at the route's feature set ``fs``:
    rows X (``fs``'s columns, then a hypothesis's own: :meth:`of`), the residual R (the data:
    of the fit on every reference move; the reference: held out), move index and fold of each
    row."""

    route: "_Route"
    ref_model: "CrossFitModel"
    fs: FeatureSet
    held_out: np.ndarray | None = None           # the reference's own held-out residual
    rows: tuple | None = None                    # fs.features_responses(route.train), if made
    cache: dict = None

    def __post_init__(self) -> None:
        X, Y, mi = self.rows or self.fs.features_responses(self.route.train)
        R = (Y - X[:, :N_STATE] - self.ref_model.predict(X, -1)
             if self.held_out is None else self.held_out)
        self.base = (X, R, mi, self.route.fold_of_move[mi])
        self.cache = {}

    def of(self, hyp: Hypothesis) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The rows with ``hyp``'s columns appended, computed in a feature set of their own
        (the route's may hold the same augmentation: a shared finding)."""
        X, R, mi, fold = self.base
        if hyp.aug is None:
            return self.base
        augs = (hyp.aug, ElapsedTime()) if _whole_output(hyp) else (hyp.aug,)
        if augs not in self.cache:
            Xa, _, mia = FeatureSet(augs).features_responses(self.route.train)
            if not np.array_equal(mia, mi):          # the same rows, in the same order
                raise ValueError("change: a hypothesis's rows differ from the route's")
            self.cache[augs] = np.hstack([X, Xa[:, N_FEATURE:]])
        return self.cache[augs], R, mi, fold


def _held_out(model: ChangeModel, X: np.ndarray, R: np.ndarray, fold: np.ndarray,
              n_folds: int) -> np.ndarray:
    out = np.empty_like(R)
    for f in range(n_folds):
        r = fold == f
        out[r] = R[r] - model.correction(X[r], f)
    return out


def _fit(data: _Residuals, ref: _Residuals, fs: FeatureSet, hyp: Hypothesis,
         rows: tuple[np.ndarray, np.ndarray] | None = None) -> _Judged:
    """The hypothesis's correction fitted on the data and on the reference, cross-fitted by
    each side's folds, and the per-move SSE of :class:`_Judged`; ``rows``: each side's row
    mask (the rows where one leg swings: decision 029), else every row."""
    n_folds = data.route.opts.n_folds
    X, R, mi, fold = data.of(hyp)
    Xr, Rr, mir, fold_r = ref.of(hyp)
    if rows is not None:
        m, m_r = rows
        X, R, mi, fold = X[m], R[m], mi[m], fold[m]
        Xr, Rr, mir, fold_r = Xr[m_r], Rr[m_r], mir[m_r], fold_r[m_r]
    model = ChangeModel(data.ref_model, fs, hyp).fit(X, R, fold, n_folds)
    model_r = ChangeModel(data.ref_model, fs, hyp).fit(Xr, Rr, fold_r, n_folds)
    n, n_r = data.route.mv.n, ref.route.mv.n
    return _Judged(hyp, model,
                   _move_sse(_held_out(model, X, R, fold, n_folds), mi, n),
                   _move_sse(R - model_r.correction(X, -1), mi, n),
                   _move_sse(_held_out(model_r, Xr, Rr, fold_r, n_folds), mir, n_r))


def _judge(j: _Judged, base: np.ndarray, n_candidates: int, opts: Any,
           cols: Sequence[int], alpha: float | None = None) -> _Judged:
    """``j``'s decision against the per-move SSE ``base`` (:func:`.stats.sse_decision` over
    the scope's joint elements ``cols``, columns of JOINT_ELEMENTS) at ``alpha`` (default the
    route's)."""
    from ..layout import STATE_NAMES
    from .stats import sse_decision
    cols = list(cols)
    j.decision = sse_decision(base[:, cols], j.sse[:, cols], n_candidates,
                              opts.alpha if alpha is None else alpha,
                              opts.min_gain, names=[STATE_NAMES[JOINT_ELEMENTS[c]]
                                                    for c in cols])
    return j


def _ratio(sse: np.ndarray, sse_ref: np.ndarray, joints: Sequence[int], n: int, n_ref: int
           ) -> float:
    """Mean over the joints' angles and rates of the data's one-step MSE over the
    reference's own (held-out)."""
    cols = _columns_of(joints)
    a = sse[:, cols].sum(axis=0) / n
    b = sse_ref[:, cols].sum(axis=0) / n_ref
    return float(np.mean(a / np.where(b > 0, b, 1.0)))


def _where_one_step(R: np.ndarray, mi: np.ndarray, n: int, R_ref: np.ndarray,
                    mir: np.ndarray, n_ref: int, alpha: float) -> dict[str, Any]:
    """Where the reference's one-step error on the data exceeds its own held-out error:
    decision 026's per-move normalisation and scope rule (:func:`.excess._where`) on one-step
    residuals; ``ratio`` and ``p_value`` (one-sided Mann-Whitney over moves) of the scope."""
    from scipy import stats as st
    from .excess import _where, elements_of, move_mse
    A, B = move_mse(R, mi, n), move_mse(R_ref, mir, n_ref)
    scale = B.mean(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    A, B = A / scale, B / scale
    scope, ratios, conc = _where(A, B)
    cols = elements_of(scope)
    a, b = A[:, cols].mean(axis=1), B[:, cols].mean(axis=1)
    p = float(st.mannwhitneyu(a, b, alternative="greater").pvalue)
    ratio = float(a.mean() / b.mean())
    return {"scope": scope, "concentration": conc, "scope_ratios": ratios, "ratio": ratio,
            "p_value": p, "significant": bool(ratio >= MIN_RATIO and p < alpha)}


def _phase_mse(R: np.ndarray, mi: np.ndarray, n: int, rows: np.ndarray, cols: Sequence[int]
               ) -> np.ndarray:
    """(m, len(cols)) the mean squared residual per element of each move with rows in
    ``rows`` (a boolean mask), over those rows only."""
    from .excess import move_mse
    has = np.bincount(mi[rows], minlength=n) > 0
    return move_mse(R[rows][:, cols], mi[rows], n)[has]


def _screened_scope(u: dict[str, Any]) -> bool:
    """Whether the change over all rows lies where decision 027 screens it: a joint scope
    concentrated by :data:`.excess.CONCENTRATION`, or spread over all joints (``all``, decision
    035, where :data:`SCREEN_SPREAD`); never the body's elements."""
    return bool(u["scope"] != "body" and (u["concentration"] >= CONCENTRATION
                                          or (SCREEN_SPREAD and u["scope"] == "all")))


def _where_in_swing(R: np.ndarray, X: np.ndarray, mi: np.ndarray, n: int, R_ref: np.ndarray,
                    X_ref: np.ndarray, mir: np.ndarray, n_ref: int, alpha: float
                    ) -> dict[str, Any]:
    """Where the reference's one-step error on the data exceeds its own in one leg's swing
    (decision 029): per leg and phase (rows where the leg swings, :data:`SWING_ROW`, or
    stands), each move's mean squared residual of the leg's angles and rates over those rows,
    divided element by element by the reference's held-out mean there, averaged over the six
    elements; a cell's ratio is the data's mean score over the reference's. The leg with the
    largest swing ratio is ``located`` where that ratio is material (:data:`SWING_MIN_RATIO`),
    significant (one-sided Mann-Whitney U over moves, p below ``alpha`` over the four legs) and
    at least :data:`SWING_CONCENTRATION` times the mean of the other legs' swing ratios: each
    on the rows where it swings apart from that leg (:func:`_swing_apart`, decision 067, where
    :data:`SWING_APART`; ``apart``), the legs that swing with it left out (``against`` names
    the legs compared), or on all its swing rows where every other leg swings with it."""
    from scipy import stats as st
    from ..layout import LEGS
    w, w_ref = swing_weight(X), swing_weight(X_ref)
    cells: dict[str, dict[str, float]] = {}
    scores: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for leg, name in enumerate(LEGS):
        cols = _columns_of(range(3 * leg, 3 * leg + 3))
        elements = JOINT_ELEMENTS[cols]
        cells[name] = {}
        for phase, m, m_ref in (("swing", w[:, leg] > SWING_ROW, w_ref[:, leg] > SWING_ROW),
                                ("stance", w[:, leg] == 0, w_ref[:, leg] == 0)):
            if not m.any() or not m_ref.any():
                cells[name][phase] = float("nan")
                continue
            a, b = _cell_scores(R, mi, n, m, R_ref, mir, n_ref, m_ref, elements)
            cells[name][phase] = float(a.mean() / b.mean())
            if phase == "swing":
                scores[name] = (a, b)
    swing = {k: v["swing"] for k, v in cells.items() if np.isfinite(v["swing"])}
    out: dict[str, Any] = {"cells": cells, "located": False, "leg": None}
    if len(swing) < 2:
        return out
    leg = max(swing, key=swing.get)
    others = {k: v for k, v in swing.items() if k != leg}
    if SWING_APART:
        apart = _swing_apart(R, w, mi, n, R_ref, w_ref, mir, n_ref, LEGS.index(leg))
        out["apart"] = apart
        others = {k: v for k, v in apart.items() if np.isfinite(v)} or others
    out["against"] = sorted(others)
    rest = float(np.mean(list(others.values())))
    a, b = scores[leg]
    p = float(st.mannwhitneyu(a, b, alternative="greater").pvalue)
    conc = swing[leg] / rest if rest > 0 else float("inf")
    out.update(leg=leg, scope=f"leg:{leg}", ratio=swing[leg], concentration=conc, p_value=p,
               located=bool(swing[leg] >= SWING_MIN_RATIO and p < alpha / len(swing)
                            and conc >= SWING_CONCENTRATION))
    return out


def _swing_apart(R: np.ndarray, w: np.ndarray, mi: np.ndarray, n: int, R_ref: np.ndarray,
                 w_ref: np.ndarray, mir: np.ndarray, n_ref: int, located: int
                 ) -> dict[str, float]:
    """Each other leg's swing ratio on the rows where it swings and leg ``located`` stands
    (decision 067), in the data and the reference, as :func:`_where_in_swing` reads a cell;
    nan for a leg that swings with the located one (fewer than :data:`SWING_APART_SHARE` of
    its swing rows, on either side, have the located leg standing): in a trot the diagonal
    partner's swing rows are the located leg's own, and a force on one swinging foot moves
    the body, and so the partner, on exactly those rows."""
    from ..layout import LEGS
    out: dict[str, float] = {}
    for leg, name in enumerate(LEGS):
        if leg == located:
            continue
        cols = JOINT_ELEMENTS[_columns_of(range(3 * leg, 3 * leg + 3))]
        s, s_ref = w[:, leg] > SWING_ROW, w_ref[:, leg] > SWING_ROW
        m, m_ref = s & (w[:, located] == 0), s_ref & (w_ref[:, located] == 0)
        if (m.sum() < SWING_APART_SHARE * max(s.sum(), 1)
                or m_ref.sum() < SWING_APART_SHARE * max(s_ref.sum(), 1)):
            out[name] = float("nan")
            continue
        a, b = _cell_scores(R, mi, n, m, R_ref, mir, n_ref, m_ref, cols)
        out[name] = float(a.mean() / b.mean())
    return out


def _cell_scores(R: np.ndarray, mi: np.ndarray, n: int, m: np.ndarray, R_ref: np.ndarray,
                 mir: np.ndarray, n_ref: int, m_ref: np.ndarray, elements: Sequence[int]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Each move's score on the rows ``m`` (the data) and ``m_ref`` (the reference): its mean
    squared residual per element, divided by the reference's mean there, averaged over the
    elements; a cell's ratio is the data's mean score over the reference's."""
    A = _phase_mse(R, mi, n, m, elements)
    B = _phase_mse(R_ref, mir, n_ref, m_ref, elements)
    scale = B.mean(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    return (A / scale).mean(axis=1), (B / scale).mean(axis=1)


def _finite(v: Any) -> bool:
    """Whether a report's number is a finite one (not nan, not null)."""
    return v is not None and bool(np.isfinite(v))


def _apart_words(swing: dict[str, Any]) -> str:
    """The statement's words for the legs decision 067 left out of the concentration's
    comparison, " apart from its own (back-left swinging with it left out)", or "" where none
    was: a leg with swing rows of its own (a finite swing cell) and no ratio apart (nan, or
    null in a report read back)."""
    apart, cells = swing.get("apart") or {}, swing.get("cells") or {}
    left = sorted(k for k, v in apart.items()
                  if not _finite(v) and _finite((cells.get(k) or {}).get("swing")))
    if not left or not swing.get("against") or set(swing["against"]) & set(left):
        return ""
    return (" apart from its own (" + ", ".join(k.replace("_", "-") for k in left)
            + " swinging with it left out)")


def _scope_for(family: str, scope: str) -> str:
    """The vocabulary's scope for a family found at ``scope``: a leg for ``contact_phase``
    (a force on a foot acts on its leg), else ``scope``."""
    if family == "contact_phase" and scope.startswith("joint:"):
        leg = next(s for s in wider_scopes(scope) if s.startswith("leg:"))
        return leg
    return scope


def reference_change(route: "_Route", ref_route: "_Route", fs: FeatureSet,
                     own_ratio: float | None = None,
                     own_one_step: np.ndarray | None = None,
                     ref_fit: tuple | None = None,
                     accepted: Sequence[Augmentation] = ()) -> dict[str, Any]:
    """The change since the reference read through the reference's model (module doc).

    ``route``/``ref_route``: the learned route's data and reference; ``fs``: its final feature
    set; ``own_ratio``: decision 026's ratio (the data's own held-out rollout error against the
    reference's), quoted as how well the data's model carries the change; ``own_one_step``:
    the data's own held-out one-step residual at ``fs`` (rows of ``fs.features_responses``;
    made here where not given), the floor a correction is measured against; ``ref_fit``:
    ``ref_route.fit(fs)`` (its one-step residuals included) where the caller made it;
    ``accepted``: the changes the route's search accepted (already in ``fs``), which the
    statement compares with what this reading names (``search``, ``agrees``)."""
    from .families.learned import physical_reading
    from .learned import rollout_evidence
    opts = route.opts
    ref_model, ev_ref = ref_fit if ref_fit is not None else ref_route.fit(fs, one_step=True)
    X, Y, mi = fs.features_responses(route.train)
    D = Y - X[:, :N_STATE]
    ev0 = rollout_evidence(ref_model, fs, route.mv, None, opts, X, D, mi, one_step=False)
    h = route.h_dec if route.h_dec in ev_ref.err else max(k for k in ev_ref.err if k in ev0.err)
    roll = unexplained_change(ev0.err[h], ev0.move[h], ev0.t0[h], route.mv.types,
                              ev_ref.err[h], ev_ref.move[h], ev_ref.t0[h], ref_route.mv.types,
                              h * CONTROL_DT, opts.alpha)
    Xr, Yr, mir = fs.features_responses(ref_route.train)
    R = D - ref_model.predict(X, -1)
    one = _where_one_step(R, mi, route.mv.n, ev_ref.one_step, mir, ref_route.mv.n, opts.alpha)
    out: dict[str, Any] = {
        "significant": one["significant"], "named": False, "ratio": one["ratio"],
        "p_value": one["p_value"], "scope": one["scope"],
        "concentration": one["concentration"], "scope_ratios": one["scope_ratios"],
        "rollout_ratio": roll["ratio"], "rollout_p_value": roll["p_value"],
        "own_ratio": own_ratio, "horizon_s": h * CONTROL_DT, "hypotheses": [],
        "located_by": None,
        "search": [{"label": a.label(), "family": r["family"], "scope": r["scope"]}
                   for a in accepted for r in [physical_reading(a)]]}
    out["swing"] = sw = _where_in_swing(R, X, mi, route.mv.n, ev_ref.one_step, Xr, mir,
                                        ref_route.mv.n, opts.alpha)
    located = bool(one["significant"] and _screened_scope(one))
    # decision 029: a leg's swing where the change over all rows is not material, or where
    # the scope of all rows lies in that leg
    in_swing = sw["located"] and (
        (not located and one["ratio"] < MIN_RATIO)
        or (located and set(scope_joints(one["scope"]).tolist())
            <= set(scope_joints(sw["scope"]).tolist())))
    if not located and not in_swing:
        out["statement"] = _statement(out)     # none, or spread over the robot: not named
        return out
    data, ref = _sides(route, ref_route, ref_model, ev_ref, fs, (X, Y, mi), (Xr, Yr, mir))
    if own_one_step is None:
        _, ev_own = route.fit(fs, one_step=True)
        own_one_step = ev_own.one_step
    Dr = Yr - Xr[:, :N_STATE]
    if located:
        out["located_by"] = "all_rows"
        out.update(_screen(data, ref, fs, one["scope"], own_one_step, X, D, mi, Xr, Dr, opts,
                           out["hypotheses"], mir))
        if _screens_narrower(one, out):
            nr = _screen_narrower(data, ref, fs, out["family"], one["scope_ratios"],
                                  own_one_step, X, D, mi, Xr, Dr, opts, mir)
            kept = nr.pop("kept")
            out["narrower"] = {**nr, "all": {"label": out["label"],
                                             "explained": out["explained"]}}
            if _narrower_named(out, kept, nr["named"]):
                out.update(kept)
    if not out["named"] and in_swing:
        sw["screen"] = sc = _screen_in_swing(data, ref, fs, sw["leg"],
                                             sw["cells"][sw["leg"]]["stance"], own_one_step,
                                             X, D, mi, Xr, Dr, opts)
        if sc["named"] or not located:
            out.update(located_by="swing", named=sc["named"], family=sc["family"],
                       kept_scope=None if sc["family"] is None else sc["scope"],
                       **{k: sc[k] for k in ("label", "explained", "size") if k in sc})
    if _falls_back(located, out):
        _fall_back_coupled(out, data, ref, fs, one["scope"], own_one_step, X, D, mi, Xr, Dr,
                           opts, mir)
    if out["named"]:
        out["agrees"] = any(r["family"] == out["family"] and r["scope"] == out["kept_scope"]
                            for r in out["search"])
        params = {k: v for k, v in out["size"].items()
                  if k not in ("per_joint", "model_rate_per_s")}
        if out["located_by"] == "swing" and out["family"] == "contact_phase":
            params["phase"] = "swing"
        out["vocabulary"] = {"family": out["family"], "scope": out["kept_scope"],
                             "params": params, "statement": _statement(out)}
    else:
        out["agrees"] = None
    out["statement"] = _statement(out)
    return out


def _screen(data: "_Residuals", ref: "_Residuals", fs: FeatureSet, scope: str,
            own_one_step: np.ndarray, X: np.ndarray, D: np.ndarray, mi: np.ndarray,
            Xr: np.ndarray, Dr: np.ndarray, opts: Any, rows: list[dict[str, Any]],
            mir: np.ndarray | None = None, checked: bool = False) -> dict[str, Any]:
    """Decision 027's screen at a scope located over all rows (module doc, 3-5): the servo
    response, then every family's column against it; the hypotheses' rows are appended to
    ``rows``. ``checked``: the drift coupled and checked (decisions 069 and 070) whatever
    the flags (decision 071, :data:`COUPLED_FALLBACK`). Returns ``named`` and, where the
    servo response differs, ``family``, ``kept_scope``, ``label``, ``explained`` and
    ``size``."""
    cols = _columns_of(scope_joints(scope))
    # the servo's response at the scope, against the reference's own correction
    servo = _servo_response(data, ref, fs, scope, opts, cols)
    rows.append(_row(servo, "servo"))
    if not servo.ok:
        return {"named": False}
    kept = servo
    # the family: a column that adds to the servo response at that scope, and alone explains
    # as much as the servo response alone (decision 030)
    fams = _families(scope, checked)
    judged = []
    coupled_servo = None
    for hyp in fams:
        base = servo.sse
        if (COUPLED_CHECKED or hyp.checked) and _coupled(hyp):
            # decision 070: against a coupled servo response
            if coupled_servo is None:
                coupled_servo = _fit(data, ref, fs, Hypothesis("servo_gain", scope,
                                                               coupled=True))
                rows.append(_row(_judge(coupled_servo, coupled_servo.base, 1, opts, cols),
                                 "coupled servo"))
            base = coupled_servo.sse
        j = _judge(_fit(data, ref, fs, hyp), base, len(fams), opts, cols)
        rows.append(_row(j, "family"))
        judged.append(j)
    alone = _stands_alone(servo, fams, data, fs, cols, rows)
    ok = {j.hyp.family for j in judged if j.ok and j.hyp.family in alone}
    if ok:       # the family that stands best alone; its scan's largest gain on the servo's
        family = min(ok, key=alone.__getitem__)
        kept = max((j for j in judged if j.ok and j.hyp.family == family),
                   key=lambda j: j.total)
    elif SCREEN_OFFSET:      # decision 039: the servo response's gain, or an offset alone
        offset = _offset(servo, data, ref, fs, scope, opts, cols, rows)
        if offset is not None:
            kept = offset
    own = _move_sse(own_one_step, mi, data.route.mv.n)[:, cols].sum()
    share = _explained(kept, own, cols)
    replay = None
    if REPLAY_SETPOINT and kept.hyp.family in SETPOINT_FAMILIES:
        rp = _replay(data, fs, scope, cols, rows)
        replay = {**rp["best"][kept.hyp.family], "unchanged": rp["unchanged"]}
        replay["explained"] = (float((rp["unchanged"] - replay["sse"]) / (rp["unchanged"] - own))
                               if rp["unchanged"] > own else 0.0)
        # decision 036: the replay sizes the family where it explains at least half the
        # excess with nothing fitted
        replay["kept"] = bool(replay["explained"] >= REPLAY_MIN_SHARE)
    if replay is not None and replay["kept"]:
        family, label, size = kept.hyp.family, replay["label"], replay["size"]
    else:
        sized = (_finer_low_pass(kept, data, ref, fs, cols, rows)
                 if kept.hyp.family == "command_filter" else kept)   # between the scan's taus
        family, label, size = kept.hyp.family, sized.hyp.label(), _size(sized.model, X, D,
                                                                         Xr, Dr, mi, mir)
    return {"family": family, "kept_scope": _scope_for(family, scope),
            "label": label, "explained": share, "size": size, "replay": replay,
            "named": bool(share >= EXPLAINED_SHARE
                          and (family != "contact_phase" or _opposes(size)))}


def _falls_back(located: bool, out: dict[str, Any]) -> bool:
    """Whether decision 071 (:data:`COUPLED_FALLBACK`) screens the change again with a
    coupled, checked drift: located over all rows (``located``; a swing reading is the
    swing screen's), named by no screen (``out``), and the screen's drift not coupled
    already (:data:`DRIFT_COUPLED`)."""
    return bool(COUPLED_FALLBACK and located and not out.get("named")
                and out.get("located_by") == "all_rows" and not DRIFT_COUPLED)


def _fall_back_coupled(out: dict[str, Any], data: "_Residuals", ref: "_Residuals",
                       fs: FeatureSet, scope: str, own_one_step: np.ndarray, X: np.ndarray,
                       D: np.ndarray, mi: np.ndarray, Xr: np.ndarray, Dr: np.ndarray,
                       opts: Any, mir: np.ndarray) -> None:
    """Decision 071 (:data:`COUPLED_FALLBACK`): the change located at ``scope`` that every
    screen left unnamed (``out``) is screened there again with the drift coupled and checked
    (:func:`_screen`, ``checked``). Its reading goes to ``out["coupled_fallback"]`` (the
    screen's result and its ``hypotheses``); where it names a drift with time, ``out`` takes
    it (``located_by`` stays ``all_rows``; ``first`` keeps the first screen's label and
    share). Any other family it keeps is not taken: the first screen's reading of those
    stands. Under decision 072 (:data:`NARROW_FALLBACK`) a drift it names at all joints is
    named at a narrower scope where :func:`_narrow_source` finds one (``narrower``)."""
    rows: list[dict[str, Any]] = []
    s = _screen(data, ref, fs, scope, own_one_step, X, D, mi, Xr, Dr, opts, rows, mir,
                checked=True)
    out["coupled_fallback"] = fb = {
        **{k: s.get(k) for k in ("named", "family", "kept_scope", "label", "explained")},
        "scope": scope, "hypotheses": rows,
        "first": {k: out.get(k) for k in ("label", "explained")}}
    if s["named"] and s["family"] == "time_drift":
        if NARROW_FALLBACK and scope == "all":
            nr = _narrow_source(s, data, ref, fs, own_one_step, X, D, mi, Xr, Dr, opts, mir)
            kept = nr.pop("kept")
            fb["narrower"] = nr
            if kept is not None:
                s = {**s, **kept}
        out.update(s, located_by="all_rows")


def _narrow_source(s: dict[str, Any], data: "_Residuals", ref: "_Residuals", fs: FeatureSet,
                   own_one_step: np.ndarray, X: np.ndarray, D: np.ndarray, mi: np.ndarray,
                   Xr: np.ndarray, Dr: np.ndarray, opts: Any, mir: np.ndarray
                   ) -> dict[str, Any]:
    """Decision 072 (:data:`NARROW_FALLBACK`): for a drift the coupled screen named at all
    joints (``s``), the coupled, checked drift of each of :data:`NARROWER_SCOPES`' joints
    acting on every joint (each joint's correction carries the scope joints' ``t (u - q)``
    and ``t dq``), judged against the coupled servo response at all joints and measured by
    the share of the whole excess it removes, as ``s["explained"]`` is. A drift of those
    joints alone needs no other joint's columns: the scope with the largest share among
    those significant and material, within :data:`NARROWER_CLOSE` of all joints' and at
    least :data:`EXPLAINED_SHARE` (what naming asks of any reading) is
    ``kept`` (its reading, to replace ``s``'s; None where there is none). ``scopes``: each
    scope's row (:func:`_row`'s, with its ``source`` and ``explained``), ``scope`` the kept
    one, ``all`` the share at all joints."""
    cols = _columns_of(scope_joints("all"))
    own = _move_sse(own_one_step, mi, data.route.mv.n)[:, cols].sum()
    servo = _fit(data, ref, fs, Hypothesis("servo_gain", "all", coupled=True))
    scopes, best = [], None
    for source in NARROWER_SCOPES:
        hyp = Hypothesis("time_drift", "all", _family_aug("time_drift", source), coupled=True,
                         checked=True, source=source)
        j = _judge(_fit(data, ref, fs, hyp), servo.sse, len(NARROWER_SCOPES), opts, cols)
        share = _explained(j, own, cols)
        scopes.append({**_row(j, "source"), "source": source, "explained": share})
        if (j.ok and share >= max(EXPLAINED_SHARE, s["explained"] - NARROWER_CLOSE)
                and (best is None or share > best[2])):
            best = (source, j, share)
    kept = None
    if best is not None:
        source, j, share = best
        kept = {"family": "time_drift", "kept_scope": source, "label": j.hyp.label(),
                "explained": share, "size": _size(j.model, X, D, Xr, Dr, mi, mir),
                "replay": None, "named": True}
    return {"scopes": scopes, "scope": None if best is None else best[0], "kept": kept,
            "all": s["explained"]}


def _screens_narrower(one: dict[str, Any], out: dict[str, Any]) -> bool:
    """Whether decision 040 screens the change again at narrower scopes: located over all
    joints (``one``, the located reading), screened there and not named, the family kept one
    of :data:`NARROWER_FAMILIES` (``out``, the screen's result); under decision 070
    (:data:`COUPLED_CHECKED`) also a coupled drift named there."""
    checked = bool(COUPLED_CHECKED and DRIFT_COUPLED and out.get("family") == "time_drift")
    return bool(SCREEN_NARROWER and one["scope"] == "all"
                and (not out.get("named") or checked)
                and out.get("family") in NARROWER_FAMILIES)


def _narrower_named(out: dict[str, Any], kept: dict[str, Any] | None, named: bool) -> bool:
    """Whether decision 040's narrower reading (``kept``, ``named``) replaces the screen's at
    all joints (``out``): where all joints are not named; under decision 070, also where its
    share is at least all joints' less :data:`NARROWER_CLOSE`."""
    if not named or kept is None:
        return False
    return (not out.get("named")
            or kept["explained"] >= out["explained"] - NARROWER_CLOSE)


def _screen_narrower(data: "_Residuals", ref: "_Residuals", fs: FeatureSet, family: str,
                     ratios: dict[str, float], own_one_step: np.ndarray, X: np.ndarray,
                     D: np.ndarray, mi: np.ndarray, Xr: np.ndarray, Dr: np.ndarray, opts: Any,
                     mir: np.ndarray) -> dict[str, Any]:
    """Decision 040: a change spread over all joints whose kept ``family`` (a time drift,
    :data:`NARROWER_FAMILIES`) explains too little there to be named, screened again
    (:func:`_screen`) at each of :data:`NARROWER_SCOPES` whose one-step ratio (``ratios``,
    the located reading's per scope) is material (:data:`.excess.MIN_RATIO`). A drift of
    some joints grows from nothing along each move and moves the others through the body, so
    it reads as spread, and over all joints its column leaves the others' excess, which at
    its own joints weighs less. Of the scopes where the screen keeps the same family, the one
    where it explains the most is ``kept`` (the screen's result, with ``scope``; the first in
    :data:`NARROWER_SCOPES` of equals), and ``named`` where the screen names it there.
    ``scopes``: every scope of :data:`NARROWER_SCOPES`, its ratio and, where screened, the
    family kept (None where it is not material or the screen kept nothing), its label, the
    share it explains, whether the screen names it, and the screen's ``hypotheses``."""
    scopes, best = [], None
    for scope in NARROWER_SCOPES:
        row: dict[str, Any] = {"scope": scope, "ratio": float(ratios[scope]),
                               "family": None, "label": None, "explained": None,
                               "named": False, "hypotheses": []}
        scopes.append(row)
        if not ratios[scope] >= MIN_RATIO:          # NaN too
            continue
        s = _screen(data, ref, fs, scope, own_one_step, X, D, mi, Xr, Dr, opts,
                    row["hypotheses"], mir)
        if s.get("family") is None:
            continue
        row.update(family=s["family"], label=s["label"], explained=s["explained"],
                   named=s["named"])
        if s["family"] == family and (best is None or s["explained"] > best[1]["explained"]):
            best = (scope, s)
    return {"scopes": scopes, "scope": None if best is None else best[0],
            "kept": None if best is None else best[1],
            "named": bool(best is not None and best[1]["named"])}


def _replay(data: "_Residuals", fs: FeatureSet, scope: str, cols: Sequence[int],
            rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Decision 036: a change of the set-point's path sized by replay. The reference's model
    predicts the data's next step from the data's state and, at the scope's joints, the
    set-point each hypothesis says the servo acts on: the set-point :data:`REPLAY_DELAYS`
    steps back (a fractional delay interpolates between whole steps), through a first-order
    low-pass of :data:`REPLAY_FILTER_MS`, or held in a play band of
    :data:`REPLAY_PLAY_WIDTHS`. Nothing is fitted: if the robot now acts on that set-point,
    the reference's model, which learned how the robot answers a set-point, predicts the data
    as it predicts the reference, as far as the reference's commands taught it the answer to
    a set-point apart from the state. Returns ``unchanged``, the one-step SSE over the scope's
    elements ``cols`` at the recorded set-point, and ``best``: per family, the hypothesis
    whose replay leaves the least (``family``, ``label``, ``size``, ``sse``). Each hypothesis
    is a row of ``rows`` (``stage`` "replay", ``sse``; the recorded set-point's label is
    "unchanged")."""
    X, R, mi, _ = data.base
    n_ref, n = fs.n_features, data.route.mv.n
    group = scope_group(scope)
    joints = list(JOINT_GROUPS[group])
    at = N_STATE + np.asarray(joints)
    U = X[:, at]
    key = ("replay", n_ref)
    if key not in data.cache:       # the reference's model at the recorded set-points
        data.cache[key] = data.ref_model.predict(X[:, :n_ref], -1)
    p0 = data.cache[key]

    def sse(e: np.ndarray) -> float:
        X2 = X[:, :n_ref].copy()
        X2[:, at] = e
        return float(_move_sse(R + p0 - data.ref_model.predict(X2, -1), mi, n)[:, cols].sum())

    def column(aug: Augmentation) -> np.ndarray:
        return data.of(Hypothesis("replay", scope, aug))[0][:, n_ref:n_ref + len(joints)]

    lags = {0: U}
    for k in range(1, int(np.ceil(max(REPLAY_DELAYS))) + 1):
        lags[k] = column(CommandLag(lag=k, joints=group))
    cand: list[tuple[float, str, str, dict[str, Any]]] = []
    for d in REPLAY_DELAYS:
        k, f = int(np.floor(d)), d - np.floor(d)
        e = lags[k] if f == 0 else (1.0 - f) * lags[k] + f * lags[k + 1]
        ms = round(d * CONTROL_DT * 1000.0, 1)
        cand.append((sse(e), "command_delay", f"set-point delay {ms:g} ms", {"delay_ms": ms}))
    for tau in REPLAY_FILTER_MS:
        cand.append((sse(column(CommandFilter(time_constant_ms=tau, joints=group))),
                     "command_filter", f"set-point low-pass {tau:g} ms",
                     {"time_constant_ms": tau}))
    for w in REPLAY_PLAY_WIDTHS:
        e = U - 0.5 * w * column(Play(width=w, source="u", joints=group))
        cand.append((sse(e), "backlash", f"set-point play {w:g} rad", {"width_rad": w}))
    unchanged = sse(U)
    rows.append({"label": f"unchanged @ {scope}", "family": None, "scope": scope,
                 "stage": "replay", "sse": unchanged})
    for v, family, what, _ in cand:
        rows.append({"label": f"{what} @ {scope}", "family": family, "scope": scope,
                     "stage": "replay", "sse": v})
    best: dict[str, dict[str, Any]] = {}
    for v, family, what, size in cand:
        if family not in best or v < best[family]["sse"]:
            best[family] = {"family": family, "label": f"{what} @ {scope} (replayed)",
                            "size": size, "sse": v}
    return {"unchanged": unchanged, "best": best}


def _stands_alone(servo: _Judged, fams: Sequence[Hypothesis], data: "_Residuals",
                  fs: FeatureSet, cols: Sequence[int], rows: list[dict[str, Any]]
                  ) -> dict[str, float]:
    """The families that stand alone, each with the held-out one-step SSE its best leaves at
    the scope's elements ``cols`` (decision 030): the best of its scan, its column alone (with
    a constant, without the servo's columns), leaves no more than the servo response alone.
    A change of the set-point's path (a delay, a low-pass) is its column's shape, and the
    servo's columns only mimic it; a change of the servo is the servo's columns, and a
    family's column only adds to them. Each family's best is appended to ``rows`` (``stage``
    "alone", ``sse``, ``stands``; the servo's row gets its own ``sse``). Only the data's side
    is fitted: nothing here is judged against the reference."""
    servo_sse = float(servo.sse[:, cols].sum())
    for r in rows:
        if r["stage"] == "servo" and r["scope"] == servo.hyp.scope:
            r["sse"] = servo_sse
    best: dict[str, tuple[float, Hypothesis]] = {}
    n_folds = data.route.opts.n_folds
    for hyp in fams:
        alone = replace(hyp, alone=True)
        X, R, mi, fold = data.of(alone)
        model = ChangeModel(data.ref_model, fs, alone).fit(X, R, fold, n_folds)
        sse = float(_move_sse(_held_out(model, X, R, fold, n_folds), mi,
                              data.route.mv.n)[:, cols].sum())
        if hyp.family not in best or sse < best[hyp.family][0]:
            best[hyp.family] = (sse, hyp)
    for family, (sse, hyp) in best.items():
        rows.append({"label": hyp.label(), "family": family, "scope": hyp.scope,
                     "stage": "alone", "sse": sse, "stands": bool(sse <= servo_sse)})
    return {family: sse for family, (sse, _) in best.items() if sse <= servo_sse}


def _screen_in_swing(data: "_Residuals", ref: "_Residuals", fs: FeatureSet, leg: str,
                     stance_ratio: float, own_one_step: np.ndarray, X: np.ndarray,
                     D: np.ndarray, mi: np.ndarray, Xr: np.ndarray, Dr: np.ndarray, opts: Any
                     ) -> dict[str, Any]:
    """Decision 029's screen of a change located in one leg's swing, on the rows where that
    leg swings, each side's own: the servo response at the leg (against the same correction
    fitted on the reference), and every family's column of :func:`_families` against it.

    A force on the swinging foot (``contact_phase``: the rate in swing and the drag's torque
    column) is named where the change is a change of the swing alone (the leg's stance ratio
    ``stance_ratio`` below :data:`.excess.MIN_RATIO`), its column is significant and
    material there, and its size opposes the foot's motion (:func:`_opposes`): a family of
    the set-points (a delay, a low-pass, a play) or of time acts in stance as well, and a
    force on a foot in the air reads on swing rows like a set-point that lags. That force is
    one test, of the hypothesis the location points to, at the route's level for a choice
    within a finding (``scope_alpha``; row ``stage`` "force").
    Nothing else is named from the swing's rows (a family of all phases is read on all rows,
    by :func:`_screen`); where the force is not named, the family with the largest gain
    among the significant and material ones is reported as the best hypothesis.
    ``explained``: the share of the leg's swing-row one-step error of the reference's model
    above the data's own model's that the kept hypothesis removes."""
    from ..layout import LEGS
    i = LEGS.index(leg)
    scope = f"leg:{leg}"
    cols = _columns_of(scope_joints(scope))
    m, m_r = swing_weight(X)[:, i] > SWING_ROW, swing_weight(Xr)[:, i] > SWING_ROW
    servo = _fit(data, ref, fs, Hypothesis("servo_gain", scope), rows=(m, m_r))
    _judge(servo, servo.base, 1, opts, cols)
    rows = [_row(servo, "servo")]
    fams = _families(scope)
    kept = fitted_force = None
    for hyp in fams:
        fitted = _fit(data, ref, fs, hyp, rows=(m, m_r))
        if hyp.family == "contact_phase":
            fitted_force = replace(fitted)           # judged again below, on its own
        j = _judge(fitted, servo.sse, len(fams), opts, cols)
        rows.append(_row(j, "family"))
        if j.ok and (kept is None or j.total > kept.total):
            kept = j
    # the force the swing's location points to: one test, at the route's level for a choice
    # within a finding (``scope_alpha``)
    force = _judge(fitted_force, servo.sse, 1, opts, cols, alpha=opts.scope_alpha)
    rows.append({**_row(force, "force"), "alpha": opts.scope_alpha})
    swing_only = bool(stance_ratio < MIN_RATIO)
    by_phase = bool(swing_only and force.ok)
    if by_phase:
        kept = force
    out: dict[str, Any] = {"scope": scope, "hypotheses": rows, "named": False,
                           "stance_ratio": stance_ratio, "swing_only": swing_only,
                           "family": None if kept is None else kept.hyp.family}
    if kept is None:
        return out
    own = _move_sse(own_one_step[m], mi[m], data.route.mv.n)[:, cols].sum()
    share = _explained(kept, own, cols)
    size = (_drag_newtons(X[m], data.base[1][m], i, Xr[m_r], Dr[m_r])
            if kept.hyp.family == "contact_phase"
            else _size(kept.model, X[m], D[m], Xr[m_r], Dr[m_r]))
    out.update(label=kept.hyp.label(), explained=share, size=size,
               named=by_phase and _opposes(size))
    return out


def _opposes(size: dict[str, Any]) -> bool:
    """Whether a drag's size (:func:`_drag_newtons`, or :func:`_size` of ``contact_phase``)
    opposes the foot's motion: a positive magnitude. A negative one would push the foot along
    its motion, which is no drag; the force's columns then stand in for a change of another
    kind."""
    return size.get("magnitude") is not None and size["magnitude"] > 0


def _drag_newtons(X: np.ndarray, R: np.ndarray, leg: int, Xr: np.ndarray, Dr: np.ndarray
                  ) -> dict[str, Any]:
    """A drag on leg ``leg``'s swinging foot in newtons: per joint of the leg, on the rows
    where the leg swings (``X``, and ``R`` the data's one-step residual of the reference's
    model there), the least-squares coefficient of the drag's torque column
    (:func:`swing_drag_torque`) in the rate's residual, beside a constant, over the
    reference's servo slope there (``Xr``, ``Dr``: the reference's swing rows and one-step
    changes) times the ``nominal`` robot's servo stiffness; the median over the leg's joints
    (module doc, 5). The rate, the rate in swing and the tracking error are left out of this
    fit: a drag and a damping in swing share most of their shape, and a rate's column would
    take the drag's share."""
    from ..robot.config import per_joint, robot_config
    T = swing_drag_torque(X)
    kp = per_joint(robot_config(NOMINAL_ROBOT).kp)
    f = {}
    for j in range(3 * leg, 3 * leg + 3):
        Z = np.stack([np.ones(len(X)), T[:, j]], axis=1)
        c, *_ = np.linalg.lstsq(Z, R[:, S.dq.start + j], rcond=None)
        k = servo_slope(Xr, Dr, j)
        if abs(k) > 1e-12:
            f[j] = float(c[1] / k * kp[j])
    return {"magnitude": round(float(np.median(list(f.values()))), 3) if f else None,
            "per_joint": {str(j): round(v, 3) for j, v in f.items()}}


def _families(scope: str, checked: bool = False) -> list[Hypothesis]:
    """Every family hypothesis decision 027 screens at ``scope``: the set-point delays, the
    low-passes, the play widths, the rate in swing with the drag's column, the drift (coupled
    over the scope's joints under decision 069, :data:`DRIFT_COUPLED`; ``checked``: coupled
    and checked whatever the flags, decision 071's screen)."""
    return ([Hypothesis("command_delay", scope, _family_aug("command_delay", scope, k))
             for k in range(1, MAX_LAG + 1)]
            + [Hypothesis("command_filter", scope, _family_aug("command_filter", scope,
                                                               tau_ms=t)) for t in FILTER_MS]
            + [Hypothesis("backlash", scope, _family_aug("backlash", scope, width=w))
               for w in PLAY_WIDTHS]
            + [Hypothesis("contact_phase", scope, _family_aug("contact_phase", scope)),
               Hypothesis("time_drift", scope, _family_aug("time_drift", scope),
                          coupled=DRIFT_COUPLED or checked, checked=checked)])


def _sides(route: "_Route", ref_route: "_Route", ref_model: "CrossFitModel", ev_ref: Any,
           fs: FeatureSet, rows: tuple | None = None, ref_rows: tuple | None = None
           ) -> tuple["_Residuals", "_Residuals"]:
    """The data's and the reference's one-step residuals of the reference's model at ``fs``
    (the reference's held out: ``ev_ref.one_step``); ``rows``/``ref_rows``: each side's
    ``fs.features_responses`` where the caller made them."""
    return (_Residuals(route, ref_model, fs, rows=rows),
            _Residuals(ref_route, ref_model, fs, held_out=ev_ref.one_step, rows=ref_rows))


def _servo_response(data: "_Residuals", ref: "_Residuals", fs: FeatureSet, scope: str,
                    opts: Any, cols: Sequence[int]) -> _Judged:
    """The servo response's correction at ``scope``, judged against the same correction
    fitted on the reference (what its columns do where nothing changed)."""
    servo = _fit(data, ref, fs, Hypothesis("servo_gain", scope))
    return _judge(servo, servo.base, 1, opts, cols)


def _offset(servo: _Judged, data: "_Residuals", ref: "_Residuals", fs: FeatureSet,
            scope: str, opts: Any, cols: Sequence[int], rows: list[dict[str, Any]]
            ) -> _Judged | None:
    """Decision 039: a change the servo response reads where no family's column stands beside
    it, read as an angle sensor's offset. An encoder mounted ``c`` off shows at the recorded
    angle ``q`` as a near-constant in the rate's one-step change, with the servo's slope
    unchanged: where the servo reads another sensor than the one recorded, it acts on
    ``u - q + c``; where it closes its loop on the offset encoder, it acts on ``u - q`` and
    every load that depends on the true angle (gravity, the leg's geometry) is shifted by
    ``c``. The constant's size depends on which, and on those loads, so no angle is given
    without a twin (:func:`_size`). The constant alone (``encoder_offset``: a constant per
    joint, no servo column) must be significant and material against the same constant
    fitted on the reference, and gain more over it than the servo response's other columns
    (``u - q`` and the rate) gain on top of the constant; then the offset is kept. Rows
    ``stage`` "offset" and "gain over offset". Returns the offset's judged fit, or None."""
    off = _fit(data, ref, fs, Hypothesis("encoder_offset", scope, alone=True))
    _judge(off, off.base, 1, opts, cols)
    rows.append(_row(off, "offset"))
    gain = _judge(replace(servo), off.sse, 1, opts, cols)
    rows.append(_row(gain, "gain over offset"))
    return off if off.ok and off.total > gain.total else None


def _finer_low_pass(kept: _Judged, data: "_Residuals", ref: "_Residuals", fs: FeatureSet,
                    cols: Sequence[int], rows: list[dict[str, Any]]) -> _Judged:
    """The kept low-pass's time constant on a finer grid (:data:`FINER_STEPS` times the scan's
    best): the one with the least held-out one-step SSE over the scope's elements ``cols``.
    The scan decided the family; this sizes it (each row ``stage`` "size")."""
    best, best_sse = kept, float(kept.sse[:, cols].sum())
    tau0 = kept.hyp.aug.time_constant_ms
    for r in FINER_STEPS:
        hyp = Hypothesis("command_filter", kept.hyp.scope,
                         _family_aug("command_filter", kept.hyp.scope, tau_ms=round(tau0 * r, 1)))
        j = _fit(data, ref, fs, hyp)
        sse = float(j.sse[:, cols].sum())
        rows.append({"label": hyp.label(), "family": hyp.family, "scope": hyp.scope,
                     "stage": "size", "sse": sse})
        if sse < best_sse:
            best, best_sse = j, sse
    return best


def drift_through_reference(route: "_Route", ref_route: "_Route", fs: FeatureSet,
                            aug: ElapsedTracking, ref_fit: tuple) -> dict[str, Any]:
    """Whether a drift of the servos with time that the route's search accepted (``aug``) is
    one through the reference's model (decision 028): at ``aug``'s joints, the time-drift
    hypothesis's column ``t (u - q)`` (with ``t dq`` under decision 068,
    :data:`DRIFT_WHOLE_OUTPUT`) on top of the servo response, both fitted on the data's
    one-step residual of the reference's model (``ref_fit``: ``ref_route.fit(fs)``, with its
    held-out one-step residuals), judged against the servo response by the route's
    ``sse_decision`` (one candidate; no test of the family alone). ``confirmed``: significant
    and material; else the search's drift stands in for a change of another kind that grows
    along the move."""
    ref_model, ev_ref = ref_fit
    opts = route.opts
    data, ref = _sides(route, ref_route, ref_model, ev_ref, fs)
    scope = group_scope(aug.joints)
    cols = _columns_of(scope_joints(scope))
    servo = _servo_response(data, ref, fs, scope, opts, cols)
    drift = _judge(_fit(data, ref, fs, Hypothesis("time_drift", scope,
                                                  _family_aug("time_drift", scope))),
                   servo.sse, 1, opts, cols)
    d = drift.decision
    return {"confirmed": drift.ok, "scope": scope, "total_gain": drift.total,
            "p_value": float(d.p_value), "significant": bool(d.significant),
            "material": bool(d.material), "servo_total_gain": servo.total}


def _row(j: _Judged, stage: str) -> dict[str, Any]:
    return {"label": j.hyp.label(), "family": j.hyp.family, "scope": j.hyp.scope,
            "stage": stage, "p_value": float(j.decision.p_value), "total_gain": j.total,
            "significant": bool(j.decision.significant), "material": bool(j.decision.material)}


def _statement(u: dict[str, Any]) -> str:
    head = (f"the reference's model predicts this data's next step {u['ratio']:.2f} times as "
            f"far off as its own held-out moves at {scope_words(u['scope'])} (p = "
            f"{u['p_value']:.2g}; 1 s rollouts {u['rollout_ratio']:.2f} times)")
    swing = u.get("swing") or {}
    by_swing = u.get("located_by") == "swing"
    if by_swing:
        head += (f"; the leg's angles and rates while its foot swings {swing['ratio']:.2f} "
                 f"times (p = {swing['p_value']:.2g}), {swing['concentration']:.2f} times the "
                 "other legs' in their swing" + _apart_words(swing))
    where = swing["scope"] if by_swing else u["scope"]
    if not u["significant"] and not by_swing:
        return head + ": no material and significant change since the reference"
    own = u.get("own_ratio")
    carried = ("" if own is None else
               f"; a model trained on this data carries it (its own rollout error is "
               f"{own:.2f} times the reference's), so nothing is added to the model"
               if own < MIN_RATIO else
               f"; a model trained on this data does not carry it (its own rollout error is "
               f"{own:.2f} times the reference's), and nothing is added to the model")
    if not by_swing and not _screened_scope(u):
        return (f"a change since the reference, spread over the robot: {head}; it is not "
                "named" + carried)
    if u.get("family") is None:
        return (f"a change since the reference at {scope_words(where)}: {head}; " + (
                "no family's column reads it on the rows where the foot swings"
                if by_swing else "the joints' servo response does not differ from the "
                "reference's") + ", so it is not named" + carried)
    screen = swing.get("screen") or {}
    if not u.get("named") and by_swing:
        why = (f"in stance the leg's ratio is {screen['stance_ratio']:.2f}, so the change is "
               "not one of the swing alone" if not screen["swing_only"] else
               "a force on the swinging foot is not significant and material there")
        return (f"a change since the reference at {scope_words(where)}: {head}; on the rows "
                f"where the foot swings the best hypothesis ({u['label']}) removes "
                f"{100 * u['explained']:.0f} % of the excess over the data's own model, but "
                f"{why}, so it is not named" + carried)
    if not u.get("named"):
        nr = u.get("narrower") or {}
        same = [r for r in nr.get("scopes", ()) if r["scope"] == nr.get("scope")]
        narrower = ("" if not nr else
                    "; at no narrower scope where the change is material does the screen keep "
                    "the same family" if not same else
                    f"; of the narrower scopes, the same family explains the most at "
                    f"{scope_words(same[0]['scope'])}, {100 * same[0]['explained']:.0f} % of "
                    "the excess there")
        fb = u.get("coupled_fallback") or {}
        coupled = ("" if fb.get("family") != "time_drift" or fb.get("explained") is None else
                   f"; with a drift coupled over the scope's joints the best hypothesis "
                   f"({fb['label']}) removes {100 * fb['explained']:.0f} %")
        return (f"a change since the reference at {scope_words(where)}: {head}; the best "
                f"hypothesis ({u['label']}) removes {100 * u['explained']:.0f} % of the excess "
                f"over the data's own model{narrower}{coupled}, so it is not named" + carried)
    size = ", ".join(f"{k} {v}" for k, v in u["size"].items()
                     if k != "per_joint" and v is not None) or "no size without a twin"
    search = ", ".join(r["label"] for r in u.get("search") or [])
    mine = set(scope_joints(u["kept_scope"]).tolist())
    rival = any(r["scope"] != "body" and mine & set(scope_joints(r["scope"]).tolist())
                for r in u.get("search") or [])
    beside = ("" if not search else
              f"; the search's finding ({search}) reads the same" if u.get("agrees") else
              f"; the search accepted {search} first, a rival reading of the same joints"
              if rival else f"; beside the search's {search}")
    if by_swing and u["family"] == "contact_phase":
        size += ", phase swing"
        how = (f"; in stance the leg's ratio is {screen['stance_ratio']:.2f}, so the change "
               "is one of the swing alone, and on the rows where the foot swings a force on it "
               "(the rate in swing and a drag's torque) is significant and material against "
               f"the servo response; it removes {100 * u['explained']:.0f} % of the excess "
               "over the data's own model there")
    else:
        how = (f"; it removes {100 * u['explained']:.0f} % of the excess over the data's own "
               "model")
        nr, fb = u.get("narrower") or {}, u.get("coupled_fallback") or {}
        if fb.get("named") and fb.get("family") == "time_drift" and fb["first"]["label"]:
            nf = fb.get("narrower") or {}
            coupled = (f"removes {100 * u['explained']:.0f} %" if not nf.get("scope") else
                       f"removes {100 * nf['all']:.0f} %, and the drift of "
                       f"{scope_words(nf['scope'])} alone, acting on every joint, "
                       f"{100 * u['explained']:.0f} %")
            how = (f"; the best hypothesis with each joint's own columns "
                   f"({fb['first']['label']}) removes {100 * fb['first']['explained']:.0f} % "
                   "of the excess over the data's own model, and a drift coupled over the "
                   "scope's joints (each joint's correction also carries the others' drifting "
                   f"torques) " + coupled)
        elif nr.get("named"):
            how = (f"; over all joints the best hypothesis ({nr['all']['label']}) removes "
                   f"{100 * nr['all']['explained']:.0f} % of the excess over the data's own "
                   f"model, and at {scope_words(nr['scope'])}, the narrower scope where the "
                   f"same family explains the most, it removes {100 * u['explained']:.0f} % "
                   "of the excess there")
    return (f"a change since the reference at {scope_words(u['kept_scope'])}, {u['family']} "
            f"({size}): {head}" + how + carried + beside)
