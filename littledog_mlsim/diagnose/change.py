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
2. **Only a concentrated change at joints is screened**: a change with no scope at least
   :data:`.excess.CONCENTRATION` times the rest, or in the body's elements, is reported and
   not named.
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
   :class:`..models.feature_library.ElapsedTracking`). Decisions are the route's
   :func:`.stats.sse_decision` on per-move held-out one-step SSE of the scope's angles and
   rates:
   - the servo response against the same correction fitted on the reference's own held-out
     residual (what these columns do where nothing changed) must be significant and
     material, else nothing is named;
   - a family's column against the servo response must be significant, material and cut at
     least :data:`FAMILY_MIN_CUT` of the scope's elements' error on average; the largest such
     gain is kept, else the servo response. A delay and a low-pass mimic each other: where
     one scan's best sits at the edge the other's shape explains (a delay still gaining at
     the longest lag, a low-pass best at the shortest time constant) and the other's is
     inside its scan, the other is kept (:func:`_delay_or_low_pass`).
4. **Named** where the kept hypothesis removes at least :data:`EXPLAINED_SHARE` of the scope's
   one-step error of the reference's model above the data's own model's (``explained``);
   otherwise the change is reported at its scope without a family.
5. **Its size**, where the family has one (:func:`_size`): a servo gain ratio, the data's over
   the reference's slope of the rate's one-step change on ``u - q`` (:func:`servo_slope`,
   median over the scope's joints); a delay of ``k`` steps; a play band's width; a low-pass's
   time constant, on a finer grid around the scan's best (:data:`FINER_STEPS`;
   :func:`_finer_low_pass`); a drift rate from the ``t (u - q)`` coefficient over the
   reference's slope; a drag in newtons, the coefficient of its torque column over the
   reference's slope times the ``nominal`` robot's servo stiffness (the slope is that stiffness
   over the joint's inertia, the coefficient the drag over it; median over the scope's joints),
   so off by as much as the robot's stiffness is.

Nothing is added to the served model for it; the statement says whether the data's own model
carries the change (decision 026's ratio below :data:`.excess.MIN_RATIO`) or not. It runs also
where the route's search accepted changes (``search``): a search led by the data's own model
can take a rival family or scope first (a delay at the hip pitches for a low-pass on one side),
and the reference's model, which holds neither, still shows where the robot changed;
``agrees`` says whether the named change is one the search accepted.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ..layout import CONTROL_DT, N_FEATURE, N_STATE, S
from ..models.feature_base import Augmentation
from ..models.feature_library import (JOINT_GROUPS, SWING_LIFT_M, CommandFilter, CommandLag,
                                      ElapsedTracking, Play, SwingRate, _commanded_lift,
                                      _forward_kinematics)
from ..models.features import FeatureSet
from .excess import CONCENTRATION, MIN_RATIO, unexplained_change
from .families.scopes import group_scope, joint_scopes, scope_group, scope_joints, scope_words

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
#: a family's column adds to the servo response when it cuts at least this share of the
#: servo-corrected one-step error of the scope's angles and rates, on average
FAMILY_MIN_CUT = 0.2
#: foot speed [m/s] below which a swing drag's direction is softened (its size v / sqrt(v^2 +
#: scale^2))
FOOT_SPEED_SCALE = 0.05
#: the robot whose servo stiffness turns a drag's joint response into newtons
NOMINAL_ROBOT = "nominal"
#: ridge on the standardised correction columns, per row
RIDGE = 1e-3


@dataclass(frozen=True)
class Hypothesis:
    """A change at ``scope``: the servo's response, plus ``aug``'s column for ``family``."""

    family: str       # servo_gain, command_delay, command_filter, backlash, contact_phase,
    #                   time_drift
    scope: str
    aug: Augmentation | None = None

    def label(self) -> str:
        what = {"servo_gain": "servo response", "command_delay": "set-point delay",
                "command_filter": "set-point low-pass", "backlash": "set-point play",
                "contact_phase": "rate in swing", "time_drift": "drift with time"}[self.family]
        if isinstance(self.aug, CommandLag):
            what += f" {self.aug.lag} step(s)"
        elif isinstance(self.aug, CommandFilter):
            what += f" {self.aug.time_constant_ms:g} ms"
        elif isinstance(self.aug, Play):
            what += f" {self.aug.width:g} rad"
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
        if hyp.aug is not None:        # its columns follow fs's (:meth:`_Residuals.of`)
            cols = JOINT_GROUPS[hyp.aug.joints]
            self.extra = {int(j): self.n_ref + i for i, j in enumerate(cols)}

    def _drag(self, X: np.ndarray) -> np.ndarray | None:
        """:func:`swing_drag_torque` of X's rows for a swing hypothesis, else None."""
        return swing_drag_torque(X) if isinstance(self.hyp.aug, SwingRate) else None

    def _z(self, X: np.ndarray, j: int, drag: np.ndarray | None = None) -> np.ndarray:
        """(n, k) correction columns of joint j: u - q, dq, 1 and the family's column(s)
        (a swing hypothesis: the rate in swing and ``drag``'s column j)."""
        u, q, dq = X[:, N_STATE + j], X[:, S.q.start + j], X[:, S.dq.start + j]
        cols = [u - q, dq, np.ones_like(u)]
        if j in self.extra:
            e = X[:, self.extra[j]]
            cols.append(e - u if isinstance(self.hyp.aug, (CommandLag, CommandFilter)) else e)
            if drag is not None:
                cols.append(drag[:, j])
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
            sd[2] = 1.0
            sd = np.where(sd < 1e-12, 1.0, sd)
            self.scale_[j] = sd
            Zs, r = Z / sd, R[:, self.outputs(j)]
            G_f = [Zs[fold_of_row == f].T @ Zs[fold_of_row == f] for f in range(n_folds)]
            b_f = [Zs[fold_of_row == f].T @ r[fold_of_row == f] for f in range(n_folds)]
            G, b = sum(G_f), sum(b_f)
            for f in [-1] + list(range(n_folds)):
                A = G if f < 0 else G - G_f[f]
                bb = b if f < 0 else b - b_f[f]
                n = max(1.0, float(A[2, 2]))
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
        """Raw-unit coefficient of correction column ``column`` (0: u - q, 3: the family's) on
        output ``output`` (0: the angle's one-step change, 1: the rate's)."""
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
    p0 = _forward_kinematics(q)[..., :2]                         # (n, 4, 2)
    J = np.empty((n, 12, 2))
    eps = 1e-5
    for j in range(12):
        qq = q.copy()
        qq[:, j] += eps
        J[:, j] = (_forward_kinematics(qq)[:, j // 3, :2] - p0[:, j // 3]) / eps
    legs = np.arange(12) // 3
    v = np.zeros((n, 4, 2))
    np.add.at(v, (slice(None), legs), J * dq[:, :, None])
    v_hat = v / np.sqrt((v ** 2).sum(axis=2, keepdims=True) + FOOT_SPEED_SCALE ** 2)
    w = np.clip(_commanded_lift(X[:, N_STATE:N_STATE + 12]) / SWING_LIFT_M, 0.0, 1.0)
    return w[:, legs] * -(J * v_hat[:, legs]).sum(axis=2)


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


def _size(model: ChangeModel, X: np.ndarray, D: np.ndarray, Xr: np.ndarray, Dr: np.ndarray
          ) -> dict[str, Any]:
    """The kept hypothesis's size in its family's unit (module doc, 3): X, D the data's
    features and one-step changes, Xr, Dr the reference's."""
    hyp = model.hyp
    k = {j: servo_slope(Xr, Dr, j) for j in model.joints}
    if hyp.family == "servo_gain":
        r = {j: servo_slope(X, D, j) / k[j] for j in model.joints if abs(k[j]) > 1e-12}
        return {"gain_ratio": round(float(np.median(list(r.values()))), 3) if r else None,
                "per_joint": {str(j): round(float(v), 3) for j, v in r.items()}}
    if hyp.family == "command_delay":
        return {"delay_ms": round(hyp.aug.lag * CONTROL_DT * 1000.0, 1)}
    if hyp.family == "command_filter":
        return {"time_constant_ms": float(hyp.aug.time_constant_ms)}
    if hyp.family == "backlash":
        return {"width_rad": float(hyp.aug.width)}
    if hyp.family == "time_drift":
        r = [model.raw_coef(j, 3) / k[j] for j in model.joints if abs(k[j]) > 1e-12]
        return {"rate_per_s": round(float(np.median(r)), 4) if r else None}
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
        if hyp.aug not in self.cache:
            Xa, _, mia = FeatureSet((hyp.aug,)).features_responses(self.route.train)
            if not np.array_equal(mia, mi):          # the same rows, in the same order
                raise ValueError("change: a hypothesis's rows differ from the route's")
            self.cache[hyp.aug] = np.hstack([X, Xa[:, N_FEATURE:]])
        return self.cache[hyp.aug], R, mi, fold


def _held_out(model: ChangeModel, X: np.ndarray, R: np.ndarray, fold: np.ndarray,
              n_folds: int) -> np.ndarray:
    out = np.empty_like(R)
    for f in range(n_folds):
        r = fold == f
        out[r] = R[r] - model.correction(X[r], f)
    return out


def _fit(data: _Residuals, ref: _Residuals, fs: FeatureSet, hyp: Hypothesis) -> _Judged:
    """The hypothesis's correction fitted on the data and on the reference, cross-fitted by
    each side's folds, and the per-move SSE of :class:`_Judged`."""
    n_folds = data.route.opts.n_folds
    X, R, mi, fold = data.of(hyp)
    Xr, Rr, mir, fold_r = ref.of(hyp)
    model = ChangeModel(data.ref_model, fs, hyp).fit(X, R, fold, n_folds)
    model_r = ChangeModel(data.ref_model, fs, hyp).fit(Xr, Rr, fold_r, n_folds)
    n, n_r = data.route.mv.n, ref.route.mv.n
    return _Judged(hyp, model,
                   _move_sse(_held_out(model, X, R, fold, n_folds), mi, n),
                   _move_sse(R - model_r.correction(X, -1), mi, n),
                   _move_sse(_held_out(model_r, Xr, Rr, fold_r, n_folds), mir, n_r))


def _judge(j: _Judged, base: np.ndarray, n_candidates: int, opts: Any,
           cols: Sequence[int]) -> _Judged:
    """``j``'s decision against the per-move SSE ``base`` (:func:`.stats.sse_decision` over
    the scope's joint elements ``cols``, columns of JOINT_ELEMENTS)."""
    from ..layout import STATE_NAMES
    from .stats import sse_decision
    cols = list(cols)
    j.decision = sse_decision(base[:, cols], j.sse[:, cols], n_candidates, opts.alpha,
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
        "search": [{"label": a.label(), "family": r["family"], "scope": r["scope"]}
                   for a in accepted for r in [physical_reading(a)]]}
    if not one["significant"] or one["concentration"] < CONCENTRATION:
        out["statement"] = _statement(out)     # none, or spread over the robot: not named
        return out
    scope = one["scope"]
    if scope == "body":
        out["statement"] = _statement(out)
        return out
    data, ref = _sides(route, ref_route, ref_model, ev_ref, fs, (X, Y, mi), (Xr, Yr, mir))
    cols = _columns_of(scope_joints(scope))
    # the servo's response at the scope, against the reference's own correction
    servo = _servo_response(data, ref, fs, scope, opts, cols)
    out["hypotheses"].append(_row(servo, "servo"))
    if not servo.ok:
        out["statement"] = _statement(out)
        return out
    kept, kept_gain = servo, 0.0
    # the family: a column that adds to the servo response at that scope
    fams = ([Hypothesis("command_delay", scope, _family_aug("command_delay", scope, k))
             for k in range(1, MAX_LAG + 1)]
            + [Hypothesis("command_filter", scope, _family_aug("command_filter", scope,
                                                               tau_ms=t)) for t in FILTER_MS]
            + [Hypothesis("backlash", scope, _family_aug("backlash", scope, width=w))
               for w in PLAY_WIDTHS]
            + [Hypothesis(f, scope, _family_aug(f, scope)) for f in ("contact_phase",
                                                                     "time_drift")])
    judged = []
    for hyp in fams:
        j = _judge(_fit(data, ref, fs, hyp), servo.sse, len(fams), opts, cols)
        out["hypotheses"].append(_row(j, "family"))
        judged.append(j)
    for j in _delay_or_low_pass(judged):
        if j.ok and j.total >= FAMILY_MIN_CUT * len(cols) and j.total > kept_gain:
            kept, kept_gain = j, j.total
    sized = (_finer_low_pass(kept, data, ref, fs, cols, out["hypotheses"])
             if kept.hyp.family == "command_filter" else kept)   # between the scan's taus
    if own_one_step is None:
        _, ev_own = route.fit(fs, one_step=True)
        own_one_step = ev_own.one_step
    own = _move_sse(own_one_step, mi, route.mv.n)[:, cols].sum()
    before, after = kept.base[:, cols].sum(), kept.sse[:, cols].sum()
    share = float((before - after) / (before - own)) if before > own else 0.0
    family = kept.hyp.family
    out.update(family=family, kept_scope=_scope_for(family, scope), label=sized.hyp.label(),
               explained=share)
    out["size"] = _size(sized.model, X, D, Xr, Yr - Xr[:, :N_STATE])
    out["named"] = bool(share >= EXPLAINED_SHARE)
    out["agrees"] = any(r["family"] == family and r["scope"] == out["kept_scope"]
                        for r in out["search"]) if out["named"] else None
    if out["named"]:
        params = {k: v for k, v in out["size"].items() if k != "per_joint"}
        out["vocabulary"] = {"family": family, "scope": out["kept_scope"], "params": params,
                             "statement": _statement(out)}
    out["statement"] = _statement(out)
    return out


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
    hypothesis's column ``t (u - q)`` on top of the servo response, both fitted on the data's
    one-step residual of the reference's model (``ref_fit``: ``ref_route.fit(fs)``, with its
    held-out one-step residuals), judged against the servo response by the route's
    ``sse_decision`` (one candidate; no :data:`FAMILY_MIN_CUT`). ``confirmed``: significant
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


def _delay_or_low_pass(judged: Sequence[_Judged]) -> list[_Judged]:
    """The family hypotheses without the set-point delays or without the low-passes, where
    one scan's best sits at the edge the other's shape explains: a delay whose gain is still
    rising at :data:`MAX_LAG` is a low-pass's long tail, a low-pass best at the shortest time
    constant a delay's sharp step; the other family keeps the field where its own best is
    inside its scan."""
    def best(family: str) -> _Judged | None:
        js = [j for j in judged if j.hyp.family == family]
        return max(js, key=lambda j: j.total) if js else None
    d, f = best("command_delay"), best("command_filter")
    if d is None or f is None:
        return list(judged)
    d_edge = d.hyp.aug.lag == MAX_LAG
    f_edge = f.hyp.aug.time_constant_ms == min(FILTER_MS)
    if d_edge and not f_edge:
        return [j for j in judged if j.hyp.family != "command_delay"]
    if f_edge and not d_edge:
        return [j for j in judged if j.hyp.family != "command_filter"]
    return list(judged)


def _row(j: _Judged, stage: str) -> dict[str, Any]:
    return {"label": j.hyp.label(), "family": j.hyp.family, "scope": j.hyp.scope,
            "stage": stage, "p_value": float(j.decision.p_value), "total_gain": j.total,
            "significant": bool(j.decision.significant), "material": bool(j.decision.material)}


def _statement(u: dict[str, Any]) -> str:
    head = (f"the reference's model predicts this data's next step {u['ratio']:.2f} times as "
            f"far off as its own held-out moves at {scope_words(u['scope'])} (p = "
            f"{u['p_value']:.2g}; 1 s rollouts {u['rollout_ratio']:.2f} times)")
    if not u["significant"]:
        return head + ": no material and significant change since the reference"
    own = u.get("own_ratio")
    carried = ("" if own is None else
               f"; a model trained on this data carries it (its own rollout error is "
               f"{own:.2f} times the reference's), so nothing is added to the model"
               if own < MIN_RATIO else
               f"; a model trained on this data does not carry it (its own rollout error is "
               f"{own:.2f} times the reference's), and nothing is added to the model")
    if u["concentration"] < CONCENTRATION or u["scope"] == "body":
        return (f"a change since the reference, spread over the robot: {head}; it is not "
                "named" + carried)
    if u.get("family") is None:
        return (f"a change since the reference at {scope_words(u['scope'])}: {head}; the "
                "joints' servo response does not differ from the reference's, so it is not "
                "named" + carried)
    if not u.get("named"):
        return (f"a change since the reference at {scope_words(u['scope'])}: {head}; the best "
                f"hypothesis ({u['label']}) removes {100 * u['explained']:.0f} % of the excess "
                "over the data's own model, so it is not named" + carried)
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
    return (f"a change since the reference at {scope_words(u['kept_scope'])}, {u['family']} "
            f"({size}): {head}; it removes {100 * u['explained']:.0f} % of the excess over the "
            "data's own model" + carried + beside)
