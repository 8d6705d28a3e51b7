"""The learned route of the diagnosis (no twin): what the learned model lacks, from its rollouts.

Why not the one-step screen alone
---------------------------------
The one-step screen (:mod:`.selection`) judges a candidate by the held-out one-step nMSE it cuts.
An effect whose cause is not among the model's inputs (a push fixed in the world, a drifting
servo) is small at one step against the measurement noise of the per-step body displacements,
yet it acts on every step in the same direction, so a rollout accumulates it: for a push in
odom the heading columns cut the held-out one-step nMSE of dx_b, dy_b by less than the
materiality minimum (the push's a dt^2 per step is small against the one-step residual),
while they cut the held-out odom error of the rollouts (0.1 to 4 s) by far more
(``benchmarks/learned_route/README.md``, "Why the one-step screen finds nothing"). This
route therefore judges candidates by held-out *k-step rollouts* of the learned
model from measured states.

Method
------
1. **Learned model, cross-fitted by move.** Ridge regression of the one-step change on random
   Fourier features of the paper's 45 features (ARD length scales from a GP, as
   :class:`.selection.SearchModel`) plus every extra column of the feature set as a linear term,
   fitted K times with the moves split into folds (:func:`.selection.move_folds`); a move is only
   ever predicted by the fit that did not see it.
2. **Evidence: k-step rollouts from measured states.** Every TrainPool move is rolled out by its
   held-out fit from the measured state every ``start_every`` steps, over the horizons
   ``horizons_s`` (0.1, 0.5, 1 s, and the whole move from its start: 4 s). The online features
   are warm-started by replaying the measured states up to the start, so lags, the pose and the
   elapsed time are those of the recording. Residuals are kept per state element (the body
   elements are body-frame already), in odom (x_w, y_w of the integrated path) and in the body
   frame at the start (the odom error turned by the start heading).
3. **Held-out decision, moves as the unit.** A candidate augmentation is added to the model, the
   cross-fit and the rollouts are repeated, and the per-move rollout SSE at ``decision_horizon_s``
   with and without it go to :func:`.selection.sse_decision` (one-sided t-tests over moves of
   the per-move SSE cut; Bonferroni over the elements, the two tests and the family probes;
   a probe of a family with a joint scope adds a rank test of its joints' q and dq cut,
   :func:`.stats.focus_p`, as a third, ``scope_test``; a probe of all joints does too, over
   every joint's q and dq, with ``focus_all`` (off by default:
   ``benchmarks/blind_zoo/zoos/zoo11/runs/run11_focus_all/README.md``), or wherever a reference
   is given with ``focus_all_with_reference`` (on by default:
   ``benchmarks/blind_zoo/zoos/zoo11/runs/run13_both_with_reference/README.md``);
   material = an element's held-out rollout SSE cut by ``min_gain``), and the path channels
   (odom x, y at every horizon) by a per-move rank test (:func:`.stats.path_test`). The moves of a
   fold share one fit, so moves are not fully independent units and these tests are liberal:
   at ``alpha`` = 0.01 clean datasets raise alarms, so the route's default ``alpha`` is 1e-4
   (``benchmarks/learned_route/README.md``, "Level: why alpha is 1e-4").
4. **Families whose cause is not among the model's inputs**, probed at full scope first
   (:func:`family_probes`): command history (delay, low-pass, play), heading (a world-fixed
   force or slope acts in the body frame through sin/cos of yaw), position (terrain over the
   floor), time (elapsed time; a servo stiffness drifting with time), gait phase, a joint's
   rate while its foot swings (a force or drag on a foot off the ground). The family with
   the largest significant and material rollout gain (the fewest columns among those within
   10 % of it: :func:`_pick`) is scoped (all joints, a leg, a joint type, a side, then one
   joint of the leg, type or side kept: :func:`_joint_members`) and its
   parameter estimated by the same held-out rollout SSE (parsimony among
   members within 10 % of the best; the scope widened while a wider one gains more move by
   move, in total or, with ``widen_focus`` (off; on wherever a reference is given with
   ``widen_focus_with_reference``), on the joints it adds, :func:`_widen`), then
   added; the next round screens the rest. A round whose
   full-scope screen accepts nothing screens the narrower scopes of every family with a joint
   scope whose full-scope probe gained (:func:`screen_narrower`): an effect on one leg or
   joint type is diluted at full scope. The narrower screen spends a quarter of alpha and the
   full-scope one the rest, each Bonferroni over every member it could test
   (:func:`screen_sizes`).
5. **Physical names** where the family allows (:func:`physical_statement`): a heading effect's
   direction is read off the fitted sin/cos columns' effect on the predicted body acceleration,
   turned into odom, and with a reference its size in newtons from the drift against the
   reference over the ``nominal`` robot's push response (:mod:`.push`, decision 025; without
   one it has no size); a delay in ms; a low-pass time constant; a stiffness drift in % per
   second (the t*(u-q) coefficient over the model's own d(ddq)/du, or with a reference each
   joint's stiffness per time bin against the reference's, :mod:`.servo_drift`). A position
   effect is an inclined floor where a plane through the TrainPool's body heights explains
   them (:func:`.families.learned.slope_reading`), else it is named by where it acts; a phase
   effect by when it acts.
6. **Residual structure** (:func:`residual_structure`): after the last accepted effect, the
   rollout residual is regressed (cross-fitted by move) on position, heading, time in the move
   and gait phase; its size is compared with the model's one-step predictive std. A material
   unexplained structure is reported with its channels, moves and the recording that would
   settle it, never as "nothing significant".

Report (:func:`diagnose_learned`'s dict)
---------------------------------------
``route``: "learned"; ``significant``: bool (an effect was accepted, or with a reference an
unexplained change); ``effects``: list of
``{family, label, augmentation (to_dict), p_value, gain (1 s rollout SSE cut, total over
elements), max_gain, outputs, scope, statement (physical sentence), physical (numbers; with
``scope_cannot_tell`` where a wider scope within the tolerance does not gain more move by move,
:func:`_scope_rivals`), scan (the scope/parameter candidates: label, total_gain, p_value,
stage "scope" or "parameter", ``p_wider`` for a scope wider than the one kept, ``kept_scope``
on that one), vocabulary (the physical route's form; null for a stand-in), and with a reference
on a drift with time ``stand_in`` (decision 028: the reference's model does not confirm the
drift, :func:`.change.drift_through_reference`, ``physical.through_reference``)}``;
``rounds``: per round the
probes ``{label, family, p_value, total_gain, max_gain, significant, material}``, and
``scoped``, the narrower screen's probes in the same form, where the round made one;
``evidence``: before/after TrainPool held-out rollout errors per horizon
(``{horizon_s: {rms_state (33 names), rms_odom_xy_m, rms_body_xy_m, n_rollouts}}``);
``test``: TestPool before/after ``{one_step_nmse_mean, one_step_nmse (33), final_xy_error_m,
xy_error_at (horizon -> mean m)}`` of the model fitted on the whole TrainPool;
``residual``: :func:`residual_structure`'s dict (``groups``, ``verdict``, ``unexplained``,
``channels``, ``moves``, ``z_ratio``, ``recording``); ``suspected``: families significant but
not material, or not significant with p within 10 alpha (on this route material implies
significant), each with the recording that would settle it and its ``vocabulary`` reading
(report.json's top-level ``suspected`` lists them in that form); one that is not significant
also has ``settle_moves_per_type`` (:func:`moves_to_settle`: the TrainPool moves per type of
the same kinds at which it would be significant with 80 % probability if its effect is what
the data show; None beyond 8 times the data's, or where nothing it cuts reaches the
materiality minimum), and its ``recording`` names that size (``record --moves-per-type``) as a
second way to settle it;
``verdict``: one sentence; ``options``: the options used; ``seconds``.

With a reference (a recording of the same robot before the change), each accepted effect also
has ``reference`` (:func:`contrast`: ``reference_total_gain``, ``reference_p_value``,
``reference_significant``, ``p_state``, ``p_path``, ``p_focus`` and ``focus_choices`` for a
candidate of a family with a joint scope, ``p_change``, ``changed``), and the report
has ``reference``: ``{n_moves, shared}``, where ``shared`` lists, in the form of ``effects``,
what the search accepted but the reference shows as much (not a change; the model carries it,
and ``significant`` does not count it), and ``unexplained_change``
(:func:`.excess.unexplained_change` at the final feature set, decision 026): the data's held-out
rollout error against the reference's; where it is material and significant, ``significant`` is
true and its ``vocabulary`` names family ``other`` at the scope where the excess concentrates;
``reference_change``
(:func:`.change.reference_change`, decision 027): the reference's model on the data, one step
and 1 s rollouts, against its own held-out moves; where the excess concentrates at a joint
scope and a hypothesis of the change screen explains it, ``named`` is true, ``significant``
is too, and its ``vocabulary`` names the family (``servo_gain``, ``command_delay``,
``command_filter``, ``backlash``, ``contact_phase``, ``time_drift``) at that scope, ``search``
lists what the search accepted (stand-ins left out) and ``agrees`` whether the named change is
one of them; ``narrower`` (decision 040): where a time drift kept over all joints is not named
there, the same screen at each joint type, side and leg, and the drift named where it explains
the most; ``coupled_fallback`` (decision 071): where no screen names a located change, the
screen again at the located scope with a drift coupled over its joints, named where it names a
drift; ``swing`` and ``located_by`` (decision 029): the same ratio per leg in swing and
stance, and where a change lives in one leg's swing alone, a force on that foot
(``contact_phase``, ``phase: swing``) named at the leg; nothing is added to the model, and its
statement says whether the data's own model carries the change. ``reference.conditions``
(where the caller gives them, :mod:`.conditions`, decision 031): the data's and the reference's
command excitation, ``comparable``, and where they differ a ``statement`` and the
``recording`` that makes them comparable; ``reference.not_comparable`` lists, in the form of
``effects`` with ``why`` and ``recording``, what the search accepted of a family excitation
shows while they differ (carried by the model; ``significant`` does not count it), and
``unexplained_change`` and ``reference_change`` are then kept as measured with
``comparable: false``, neither ``significant`` nor ``named``, except an ``unexplained_change``
that concentrates at one joint, leg or side (:func:`concentrated_at_joints`, decisions 033 and
064): it is read as measured, with ``comparable: false`` and ``concentrated: true``.
``drift_change`` (:func:`drift_change`, decisions 037 and 066): where the search suspected a
heading effect it did not accept, or probed one within 10 times alpha in any round, the drift
against the reference as a second test; where it holds,
``named``, the route's ``significant`` and a ``vocabulary`` naming ``odom_force @ body`` in
newtons.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..data.recording import MoveRecording
from ..data.states import initial_pose
from ..layout import (CONTROL_DT, JOINT_NAMES, LEGS, N_FEATURE, N_STATE, STATE_NAMES,
                      UNKNOWN_MOVE_TYPE, S)
from ..models.features import (Augmentation, CommandFilter, CommandLag, ElapsedTime, FeatureSet,
                               GaitPhase, Heading, PlanarPosition, Play, integrate_pose)
from ..models.feature_library import JOINT_GROUPS, ElapsedTracking, SwingRate
from .conditions import Conditions
from .selection import SearchModel, move_folds
from .stats import PathTest, contrast_combined, path_test, sse_decision

__all__ = ["LearnedOptions", "CrossFitModel", "Evidence", "diagnose_learned", "family_probes",
           "rollout_evidence", "residual_structure", "physical_statement", "contrast", "SCOPES",
           "screen_sizes", "screen_narrower", "decision_tests", "moves_to_settle",
           "record_moves_per_type", "train_per_type"]

log = logging.getLogger(__name__)

#: joint scopes a history/time family is tried at, after "all" (legs, joint types, sides)
SCOPES: tuple[str, ...] = ("front_left", "front_right", "back_left", "back_right",
                           "hip_rolls", "hip_pitches", "knees", "left", "right")


@dataclass(frozen=True)
class LearnedOptions:
    """Knobs of the learned route (defaults: the study in ``benchmarks/learned_route``)."""

    n_random_features: int = 600
    ridge: float = 0.05
    length_scale_factor: float = 0.7
    n_gp_points: int = 400
    gp_max_iter: int = 40
    n_folds: int = 5
    horizons_s: tuple[float, ...] = (0.1, 0.5, 1.0, 4.0)
    start_every: int = 50
    decision_horizon_s: float = 1.0
    alpha: float = 1e-4
    min_gain: float = 0.05
    max_rounds: int = 2
    max_shared: int = 2      # with a reference: findings it shows as much, besides max_rounds
    tolerance: float = 0.1
    scope_alpha: float = 0.01
    scoped_screen: bool = True   # a round with no full-scope finding screens narrower scopes
    narrow_p: float = 1.0        # ... of the families that gained with full-scope p <= this
    scoped_share: float = 0.25   # the share of alpha the narrower screen spends
    contrast_alpha: float = 0.01  # with a reference: changed if p x the round's contrasts < it
    joint_scopes: bool = True    # a kept leg, joint type or side also tries its single joints
    scope_test: bool = True      # a scoped probe's state test also ranks its joints' elements
    focus_all: bool = False      # ... and so does a probe of all joints (every joint's q, dq)
    focus_all_with_reference: bool = True  # focus_all on wherever a reference is given
    widen_focus: bool = False    # widening also tests the added joints' q, dq move by move
    widen_focus_with_reference: bool = True  # widen_focus on wherever a reference is given
    widen_within_tolerance: bool = True  # a wider scope's total need only be within tolerance
    push_robot: str | None = "nominal"  # with a reference: whose push response sizes a push
    push_moves_per_type: int = 2  # ... walking this many of the reference's moves per type
    drift_confirms: bool = True   # with a reference: a suspected heading confirmed by the
    #                               drift against it is named a push (decision 037)
    seed: int = 0


# --------------------------------------------------------------------------------- the model


@dataclass
class _Design:
    """Random features of the 45 and the scales shared by every fit of one route run."""

    x_mean: np.ndarray  # (45,) of the paper's features (the random features' input)
    x_std: np.ndarray
    d_mean: np.ndarray  # (33,) of the one-step change
    d_std: np.ndarray
    W: np.ndarray
    b: np.ndarray
    lo: np.ndarray      # state bounds a rollout is clipped to (training range +- 25 %)
    hi: np.ndarray
    # the TrainPool's rows of the paper's 45 (``remember``) and their random features, made
    # on first use in each process (not pickled: a worker makes its own)
    _key: np.ndarray | None = field(default=None, repr=False, compare=False)
    _block: np.ndarray | None = field(default=None, repr=False, compare=False)

    def remember(self, X: np.ndarray) -> None:
        """Keep the random features of these rows (the TrainPool's: every candidate's fit has
        the same paper's 45 there, only its own columns differ) once made: ``basis`` of rows
        equal to them copies them instead of making them again, the same numbers."""
        self._key = np.array(X[:, :N_FEATURE])
        self._block = None

    def _random(self, X: np.ndarray) -> np.ndarray:
        Xb = (X[:, :N_FEATURE] - self.x_mean) / self.x_std
        return math.sqrt(2.0 / self.W.shape[1]) * np.cos(Xb @ self.W + self.b)

    def basis(self, X: np.ndarray, mean: np.ndarray, std: np.ndarray) -> np.ndarray:
        """(n, M + F + 1): random features of the 45, every feature linear, a constant."""
        M = self.W.shape[1]
        B = np.empty((X.shape[0], M + X.shape[1] + 1))
        key = self._key
        if (key is not None and X.shape[0] == key.shape[0]
                and np.array_equal(X[:, :N_FEATURE], key)):
            if self._block is None:
                self._block = self._random(X)
            B[:, :M] = self._block
        else:
            B[:, :M] = self._random(X)
        B[:, M:-1] = (X - mean) / std
        B[:, -1] = 1.0
        return B

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_block"] = None
        return state


class CrossFitModel:
    """Ridge on :class:`_Design`'s basis, fitted once per fold (all moves but the fold's) and
    once on all moves (``fold=-1``); predicts the one-step change in raw units."""

    def __init__(self, design: _Design, ridge: float) -> None:
        self.design = design
        self.ridge = ridge

    def fit(self, X: np.ndarray, D: np.ndarray, fold_of_row: np.ndarray, n_folds: int
            ) -> "CrossFitModel":
        self.x_mean_ = X.mean(axis=0)
        sd = X.std(axis=0)
        self.x_std_ = np.where(sd < 1e-12, 1.0, sd)
        B = self._basis(X)
        Dn = (D - self.design.d_mean) / self.design.d_std
        G_f = [B[fold_of_row == f].T @ B[fold_of_row == f] for f in range(n_folds)]
        b_f = [B[fold_of_row == f].T @ Dn[fold_of_row == f] for f in range(n_folds)]
        G, bb = sum(G_f), sum(b_f)
        eye = self.ridge * np.eye(B.shape[1])
        self.coef_ = {}
        self.chol_ = {}
        for f in [-1] + list(range(n_folds)):
            A = G + eye if f < 0 else G - G_f[f] + eye
            c = cho_factor(A)
            self.chol_[f] = c
            self.coef_[f] = cho_solve(c, bb if f < 0 else bb - b_f[f])
        res = np.empty_like(Dn)
        for f in range(n_folds):
            r = fold_of_row == f
            res[r] = Dn[r] - B[r] @ self.coef_[f]
        self.sigma_ = res.std(axis=0)          # held-out one-step residual std (standardised)
        self.n_features_ = X.shape[1]
        return self

    def _basis(self, X: np.ndarray) -> np.ndarray:
        return self.design.basis(X, self.x_mean_, self.x_std_)

    def predict(self, X: np.ndarray, fold: int) -> np.ndarray:
        return (self._basis(X) @ self.coef_[fold]) * self.design.d_std + self.design.d_mean

    def predictive_std(self, X: np.ndarray, fold: int) -> np.ndarray:
        """One-step predictive std (n, 33), raw units: sigma * sqrt(1 + b' A^-1 b)."""
        B = self._basis(X)
        lev = np.einsum("ij,ij->i", B, cho_solve(self.chol_[fold], B.T).T)
        return np.sqrt(1.0 + lev)[:, None] * self.sigma_ * self.design.d_std

    def linear_coef(self, cols: slice, fold: int = -1) -> np.ndarray:
        """Raw-unit coefficients (k, 33) of the feature columns ``cols`` (the linear part)."""
        M = self.design.W.shape[1]
        idx = np.arange(self.n_features_)[cols]
        return (self.coef_[fold][M + idx] / self.x_std_[idx, None]) * self.design.d_std


def _make_design(X: np.ndarray, D: np.ndarray, S_all: np.ndarray, opts: LearnedOptions,
                 length_scales: np.ndarray) -> _Design:
    Xb = X[:, :N_FEATURE]
    x_std = Xb.std(axis=0)
    d_std = D.std(axis=0)
    rng = np.random.default_rng(opts.seed + 1)
    W = rng.standard_normal((N_FEATURE, opts.n_random_features)) / (
        opts.length_scale_factor * length_scales[:, None])
    span = S_all.max(axis=0) - S_all.min(axis=0)
    return _Design(Xb.mean(axis=0), np.where(x_std < 1e-12, 1.0, x_std), D.mean(axis=0),
                   np.where(d_std < 1e-12, 1.0, d_std), W,
                   rng.uniform(0.0, 2.0 * np.pi, opts.n_random_features),
                   S_all.min(axis=0) - 0.25 * span, S_all.max(axis=0) + 0.25 * span)


def _length_scales(X: np.ndarray, D: np.ndarray, opts: LearnedOptions) -> np.ndarray:
    sm = SearchModel(n_gp_points=opts.n_gp_points, gp_max_iter=opts.gp_max_iter, seed=opts.seed)
    Xn = (X - X.mean(axis=0)) / np.where(X.std(axis=0) < 1e-12, 1.0, X.std(axis=0))
    Dn = (D - D.mean(axis=0)) / np.where(D.std(axis=0) < 1e-12, 1.0, D.std(axis=0))
    return sm.fit_length_scales(Xn[:, :N_FEATURE], Dn)


# ------------------------------------------------------------------------------ the evidence


@dataclass
class _Moves:
    """The recordings as arrays: per move S = s_1..s_T, U = u_1..u_T, Y = s_2..s_{T+1} and the
    measured pose (x_w, y_w, yaw) at each row of S (the contract's integration)."""

    names: list[str]
    types: list[str]
    S: list[np.ndarray]
    U: list[np.ndarray]
    Y: list[np.ndarray]
    pose: list[np.ndarray]

    @property
    def n(self) -> int:
        return len(self.S)


def _moves(recs: Sequence[MoveRecording]) -> _Moves:
    fs = FeatureSet()
    out = _Moves([], [], [], [], [], [])
    for r in recs:
        S_, U, Y, _ = fs.move_arrays(r)
        p0 = initial_pose(r, 1)
        out.names.append(r.name)
        out.types.append(r.move_type)
        out.S.append(S_)
        out.U.append(U)
        out.Y.append(Y)
        out.pose.append(integrate_pose(S_[None], np.array([[p0.x0, p0.y0, p0.yaw0]]))[0])
    return out


@dataclass
class Evidence:
    """Held-out k-step rollout residuals (measured minus predicted) of one feature set.

    Per horizon h (steps): ``err[h]`` (R, 33) state residual h steps after the start,
    ``odom[h]`` (R, 2) residual of the integrated (x_w, y_w), ``body[h]`` (R, 2) the same turned
    into the body frame of the start, ``move[h]`` (R,) move index, ``t0[h]`` (R,) start step.
    ``one_step`` (n, 33) held-out one-step residual and ``one_step_std`` (n, 33) the model's
    predictive std there (raw units); both None where not made (a candidate's probe).
    """

    horizons: tuple[int, ...]
    err: dict[int, np.ndarray]
    odom: dict[int, np.ndarray]
    body: dict[int, np.ndarray]
    move: dict[int, np.ndarray]
    t0: dict[int, np.ndarray]
    one_step: np.ndarray | None
    one_step_std: np.ndarray | None
    one_step_move: np.ndarray

    def sse(self, h: int, n_moves: int) -> np.ndarray:
        """(M, 33) per-move SSE of the state residual at horizon h."""
        out = np.zeros((n_moves, N_STATE))
        np.add.at(out, self.move[h], self.err[h] ** 2)
        return out

    def summary(self) -> dict[str, Any]:
        out = {}
        for h in self.horizons:
            out[f"{h * CONTROL_DT:g}"] = {
                "rms_state": {n: float(v) for n, v in
                              zip(STATE_NAMES, np.sqrt((self.err[h] ** 2).mean(axis=0)))},
                "rms_odom_xy_m": float(np.sqrt((self.odom[h] ** 2).sum(axis=1).mean())),
                "rms_body_xy_m": [float(v) for v in np.sqrt((self.body[h] ** 2).mean(axis=0))],
                "n_rollouts": int(self.err[h].shape[0])}
        return out


def _horizon_steps(opts: LearnedOptions, T: int) -> tuple[tuple[int, ...], int]:
    """(horizons in steps, the longest that starts anywhere); horizons past T become T."""
    hs = sorted({min(T, max(1, int(round(h / CONTROL_DT)))) for h in opts.horizons_s})
    short = [h for h in hs if h < T]
    return tuple(hs), (max(short) if short else T)


def _rows(T: int, opts: LearnedOptions) -> list[tuple[int, int]]:
    """(start, length) of every rollout of a move of T steps."""
    hs, short = _horizon_steps(opts, T)
    rows = [(t0, short) for t0 in range(0, T - short + 1, opts.start_every)] if short < T else []
    return rows + [(0, T)]


def _roll(model: CrossFitModel, fold: int, fs: FeatureSet, mv: _Moves, idx: Sequence[int],
          opts: LearnedOptions) -> tuple[list[tuple[int, int, int]], np.ndarray]:
    """Roll moves ``idx`` (equal length) with fit ``fold`` from every start; (rows as
    (move, t0, H), predicted Y (R, T, 33), NaN outside each row's window)."""
    T = mv.S[idx[0]].shape[0]
    rows = [(m, t0, H) for m in idx for (t0, H) in _rows(T, opts)]
    R = len(rows)
    rm = np.array([r[0] for r in rows])
    t0 = np.array([r[1] for r in rows])
    end = t0 + np.array([r[2] for r in rows])
    U = np.stack([mv.U[m] for m in rm])
    Y = np.stack([mv.Y[m] for m in rm])
    S0 = np.stack([mv.S[m][0] for m in rm])
    pose0 = np.stack([mv.pose[m][0] for m in rm])
    hist = fs.history(S0, pose0 if fs.needs_pose else None)
    pred = np.full((R, T, N_STATE), np.nan)
    lo, hi = model.design.lo, model.design.hi
    for t in range(T):
        X = hist.features(U[:, t])
        act = (t >= t0) & (t < end)
        nxt = Y[:, t].copy()
        if act.any():
            p = X[act, :N_STATE] + model.predict(X[act], fold)
            p = np.clip(np.where(np.isfinite(p), p, 0.0), lo, hi)
            nxt[act] = p
            pred[act, t] = p
        hist.push(nxt)
    return rows, pred




def rollout_evidence(model: CrossFitModel, fs: FeatureSet, mv: _Moves,
                     fold_of_move: np.ndarray | None, opts: LearnedOptions,
                     X: np.ndarray, D: np.ndarray, move_index: np.ndarray,
                     one_step: bool = True) -> Evidence:
    """k-step rollouts of every move by the fit that did not see it (``fold_of_move``; None:
    the fit on all moves, for held-out TestPool moves), and the one-step residuals of X, D
    (``one_step`` False: not made, ``one_step`` and ``one_step_std`` None; a candidate's
    decision uses the rollouts only)."""
    folds = np.full(mv.n, -1) if fold_of_move is None else np.asarray(fold_of_move)
    groups: dict[tuple[int, int], list[int]] = {}
    for m in range(mv.n):
        groups.setdefault((int(folds[m]), mv.S[m].shape[0]), []).append(m)
    rows: list[tuple[int, int, int]] = []
    preds: list[np.ndarray] = []
    for (f, _), idx in sorted(groups.items()):
        r, p = _roll(model, f, fs, mv, idx, opts)
        rows += r
        preds += list(p)
    per_move = [_horizon_steps(opts, mv.S[m].shape[0])[0] for m in range(mv.n)]
    hs = sorted({h for v in per_move for h in v})
    ev = Evidence(tuple(hs), {}, {}, {}, {}, {}, None, None, move_index)
    for h in hs:
        sel = [i for i, (m, t0, H) in enumerate(rows) if H >= h and h in per_move[m]]
        _horizon_residuals(ev, h, [rows[i] for i in sel], [preds[i] for i in sel], mv)
    if not one_step:
        return ev
    fr = folds[move_index]
    pred = np.empty_like(D)
    std = np.empty_like(D)
    for f in np.unique(fr):
        r = fr == f
        pred[r] = model.predict(X[r], int(f))
        std[r] = model.predictive_std(X[r], int(f))
    ev.one_step, ev.one_step_std = D - pred, std
    return ev


def _horizon_residuals(ev: Evidence, h: int, rows: list[tuple[int, int, int]],
                       preds: list[np.ndarray], mv: _Moves) -> None:
    """Fill ``ev``'s horizon-h residuals from the rollouts ``rows`` (move, t0, H)."""
    ev.move[h] = np.array([m for m, _, _ in rows], dtype=np.int64)
    ev.t0[h] = np.array([t0 for _, t0, _ in rows], dtype=np.int64)
    true = np.stack([np.concatenate([mv.S[m][t0][None], mv.Y[m][t0:t0 + h]])
                     for m, t0, _ in rows])
    est = np.stack([np.concatenate([mv.S[m][t0][None], p[t0:t0 + h]])
                    for (m, t0, _), p in zip(rows, preds)])
    ev.err[h] = true[:, -1] - est[:, -1]
    p0 = np.stack([mv.pose[m][t0] for m, t0, _ in rows])
    d = integrate_pose(true, p0)[:, -1, :2] - integrate_pose(est, p0)[:, -1, :2]
    c, s = np.cos(p0[:, 2]), np.sin(p0[:, 2])
    ev.odom[h] = d
    ev.body[h] = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


# ------------------------------------------------------------------------------ the search


def family_probes() -> list[Augmentation]:
    """One member per family whose cause is not among the model's inputs, at full scope."""
    return [CommandLag(lag=2), CommandFilter(time_constant_ms=30.0), Play(width=0.03, source="u"),
            Heading(), PlanarPosition(), ElapsedTime(), ElapsedTracking(),
            GaitPhase(quarter_lag=9), SwingRate()]


def _scope_members(aug: Augmentation) -> list[Augmentation]:
    """``aug`` at every other joint scope, all joints and the narrower ones (none for a family
    without one)."""
    if "joints" not in aug.params():
        return []
    return [replace(aug, joints=s) for s in ("all",) + SCOPES if s != aug.joints]


def _joint_members(aug: Augmentation) -> list[Augmentation]:
    """``aug`` at each single joint of its joint group, where that is a leg, a joint type or a
    side (none for all joints, one joint, a family without a joint scope, or one that acts on
    whole legs: :attr:`.families.learned.LearnedFamily.single_joints`)."""
    from .families.learned import learned_family
    j = aug.params().get("joints")
    if j is None or j == "all" or j not in SCOPES or not learned_family(aug.family).single_joints:
        return []
    return [replace(aug, joints=JOINT_NAMES[k]) for k in JOINT_GROUPS[j]]


def screen_sizes(lib: Sequence[Augmentation], scoped: bool, share: float = 0.25
                 ) -> tuple[float, float]:
    """The Bonferroni factors of a round's two screens: the full-scope members of ``lib``, and
    (``scoped``) every narrower scope of its families that have one. With the scoped screen,
    the narrower one spends ``share`` of alpha and the full-scope one the rest (a weighted
    Bonferroni over every member either could test, so a screen that tests only some of them
    keeps the level)."""
    n_scoped = sum(len(SCOPES) for a in lib if "joints" in a.params())
    if not (scoped and n_scoped):
        return float(len(lib)), 0.0
    if not 0.0 < share < 1.0:
        raise ValueError(f"scoped_share must be in (0, 1), got {share!r}")
    return len(lib) / (1.0 - share), n_scoped / share


def _param_members(aug: Augmentation) -> list[Augmentation]:
    """``aug`` at the other values of its family's parameter grid."""
    if isinstance(aug, CommandLag):
        return [replace(aug, lag=d) for d in range(1, 6) if d != aug.lag]
    if isinstance(aug, CommandFilter):
        return [replace(aug, time_constant_ms=v) for v in (10.0, 20.0, 45.0, 70.0)
                if v != aug.time_constant_ms]
    if isinstance(aug, Play):
        return [replace(aug, width=w) for w in (0.01, 0.06) if w != aug.width]
    if isinstance(aug, GaitPhase):
        return [replace(aug, quarter_lag=k) for k in (8, 10) if k != aug.quarter_lag]
    return []


#: the path channels of the decision: odom x, y of the integrated path at every horizon
def _path_names(horizons: Sequence[int]) -> list[str]:
    return [f"odom_{a}@{h * CONTROL_DT:g}s" for h in horizons for a in "xy"]


def _path_sse(ev: Evidence, n_moves: int) -> np.ndarray:
    """(M, 2 * H) per-move SSE of the odom x, y residual at every horizon."""
    out = np.zeros((n_moves, 2 * len(ev.horizons)))
    for i, h in enumerate(ev.horizons):
        np.add.at(out[:, 2 * i:2 * i + 2], ev.move[h], ev.odom[h] ** 2)
    return out


@dataclass
class _Decision:
    """Held-out rollout decision on two channel sets: the 33 state elements at the decision
    horizon (:func:`.selection.sse_decision`, Bonferroni over its tests, the elements and the
    candidates) and the odom path at every horizon (:func:`.stats.path_test`, Bonferroni over the
    candidates); ``p_value`` = 2 min(p_state, p_path)."""

    state: Any          # selection.SSEDecision of the state elements
    path: PathTest
    path_names: list[str]
    n_candidates: int
    alpha: float
    min_gain: float

    @property
    def p_path(self) -> float:
        return min(1.0, self.n_candidates * self.path.p)

    @property
    def p_value(self) -> float:
        return min(1.0, 2.0 * min(self.state.p_value, self.p_path))

    @property
    def significant(self) -> bool:
        return bool(self.p_value < self.alpha)

    @property
    def material(self) -> bool:
        path_ok = 2.0 * self.p_path < self.alpha and self.path.total_gain >= self.min_gain
        state_ok = 2.0 * self.state.p_value < self.alpha and self.state.material
        return bool(path_ok or state_ok)

    @property
    def gain(self) -> np.ndarray:
        return np.concatenate([self.state.gain, self.path.gain])

    @property
    def outputs(self) -> list[str]:
        path = ([n for n, g in zip(self.path_names, self.path.gain) if g >= 0.5 * self.min_gain]
                if 2.0 * self.p_path < self.alpha else [])
        return list(self.state.outputs) + path


def scope_elements(aug: Augmentation, all_joints: bool = False) -> list[int] | None:
    """The state elements (q and dq) of the joints a scoped candidate acts on: the focus of
    :func:`.stats.decide`'s third test; None for a family without a joint scope, and for all
    joints unless ``all_joints`` (``LearnedOptions.focus_all``: then every joint's q and dq)."""
    j = aug.params().get("joints")
    if j is None or (j == "all" and not all_joints):
        return None
    return _joint_elements(JOINT_GROUPS[j])


def _joint_elements(joints: Sequence[int]) -> list[int]:
    """The state elements of these joints (indices into JOINT_NAMES): their q, then their dq."""
    idx = list(joints)
    return [S.q.start + k for k in idx] + [S.dq.start + k for k in idx]


def decide(ev0: Evidence, ev1: Evidence, h: int, n_moves: int, n_candidates: int,
           alpha: float, min_gain: float, focus: Sequence[int] | None = None) -> _Decision:
    """The held-out decision on one candidate: ``ev1`` (with it) against ``ev0`` (without);
    ``focus``: the state elements of its scope (:func:`scope_elements`), rank-tested too."""
    st = sse_decision(ev0.sse(h, n_moves), ev1.sse(h, n_moves), n_candidates, alpha, min_gain,
                      focus=focus)
    pa = path_test(_path_sse(ev0, n_moves), _path_sse(ev1, n_moves))
    return _Decision(st, pa, _path_names(ev0.horizons), n_candidates, alpha, min_gain)


@dataclass
class _Probe:
    """One candidate's held-out rollout decision against the current model."""

    aug: Augmentation
    total_gain: float   # state SSE cuts summed over the 33 elements + the path's total cut
    decision: _Decision

    def to_dict(self) -> dict[str, Any]:
        d = self.decision
        return {"label": self.aug.label(), "family": self.aug.family,
                "p_value": float(d.p_value), "p_state": float(d.state.p_value),
                "p_path": float(d.p_path), "total_gain": self.total_gain,
                "state_gain": float(np.sum(d.state.gain)), "path_gain_total": d.path.total_gain,
                "path_gain": {n: float(g) for n, g in zip(d.path_names, d.path.gain)},
                "max_gain": float(np.max(d.gain)), "significant": bool(d.significant),
                "material": bool(d.material), "outputs": d.outputs}


class _Route:
    """The TrainPool, its folds and the shared design; fits and rolls out feature sets."""

    def __init__(self, train: Sequence[MoveRecording], start: FeatureSet, opts: LearnedOptions,
                 say: Callable[[str], None]) -> None:
        self.train, self.opts, self.say = list(train), opts, say
        self.client = None        # a distributed.Client: probes run on its workers (``remote``)
        self._remote = None       # the future of this route on every worker
        self.pool = None          # local worker processes: probes run there (``local``)
        self.mv = _moves(self.train)
        self.fold_of_move = move_folds(self.mv.types, opts.n_folds, opts.seed)
        X, Y, mi = start.features_responses(self.train)
        D = Y - X[:, :N_STATE]
        ls = _length_scales(X, D, opts)
        self.design = _make_design(X, D, np.vstack(self.mv.S), opts, ls)
        self.design.remember(X)
        self.h = _horizon_steps(opts, min(s.shape[0] for s in self.mv.S))[0]
        self.h_dec = min(self.h, key=lambda h: abs(h - opts.decision_horizon_s / CONTROL_DT))

    def fit(self, fs: FeatureSet, one_step: bool = True) -> tuple[CrossFitModel, Evidence]:
        """The cross-fit of ``fs`` and its evidence (``one_step``: :func:`rollout_evidence`)."""
        X, Y, mi = fs.features_responses(self.train)
        D = Y - X[:, :N_STATE]
        model = CrossFitModel(self.design, self.opts.ridge).fit(
            X, D, self.fold_of_move[mi], self.opts.n_folds)
        return model, rollout_evidence(model, fs, self.mv, self.fold_of_move, self.opts, X, D,
                                       mi, one_step)

    def probe(self, fs: FeatureSet, ev0: Evidence, aug: Augmentation, n_candidates: int
              ) -> _Probe:
        _, ev1 = self.fit(fs.with_augmentation(aug), one_step=False)
        dec = decide(ev0, ev1, self.h_dec, self.mv.n, n_candidates, self.opts.alpha,
                     self.opts.min_gain,
                     scope_elements(aug, self.opts.focus_all) if self.opts.scope_test else None)
        return _Probe(aug, float(np.sum(dec.state.gain) + dec.path.total_gain), dec)

    def probes(self, fs: FeatureSet, ev0: Evidence, augs: Sequence[Augmentation],
               n_candidates: int) -> list[_Probe]:
        """``probe`` of every candidate, in order: here, or on the Dask workers (``remote``),
        one task per candidate; the same results either way."""
        if self.pool is not None and augs:
            light = replace(ev0, one_step=None, one_step_std=None)   # what a probe reads
            n = len(augs)
            return list(self.pool.map(_probe_local, [fs] * n, [light] * n, augs,
                                      [n_candidates] * n))
        if self.client is None or not augs:
            return [self.probe(fs, ev0, a, n_candidates) for a in augs]
        ev = self.client.scatter([ev0], broadcast=True, hash=False)[0]
        futures = [self.client.submit(_probe_remote, self._remote, fs, ev, a, n_candidates,
                                      pure=False) for a in augs]
        return self.client.gather(futures)

    def remote(self, client: Any) -> None:
        """Run the probes on the workers of ``client`` (a ``distributed.Client``, closed by
        ``close``): the route (TrainPool, folds, design) goes to every worker once."""
        self.client = client
        try:
            client.wait_for_workers(1, timeout=60)
            self._remote = client.scatter([self], broadcast=True, hash=False)[0]
        except Exception:
            self.close()
            raise

    def local(self, jobs: int) -> None:
        """Run the probes in ``jobs`` local worker processes (forked from the fork server,
        ``workers.worker_context``; one BLAS thread each; closed by ``close``): the route goes
        to each once, the current evidence with each probe. The same results as here when this
        process runs one BLAS thread too."""
        from concurrent.futures import ProcessPoolExecutor

        from ..workers import worker_context
        self.pool = ProcessPoolExecutor(int(jobs), worker_context(),
                                        initializer=_start_worker, initargs=(self,))

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
        self.client, self._remote, self.pool = None, None, None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()       # a worker's copy: no client, no progress callback
        state.update(client=None, _remote=None, say=None, pool=None)
        return state


_WORKER: dict[str, Any] = {}      # a local worker process's route (``_Route.local``)


def _one_blas_thread(on: bool):
    """A context of one BLAS thread (``on``), else of the BLAS threads as they are."""
    if not on:
        from contextlib import nullcontext
        return nullcontext()
    from threadpoolctl import threadpool_limits
    return threadpool_limits(1)


def _start_worker(route: _Route) -> None:
    from threadpoolctl import threadpool_limits
    threadpool_limits(1)            # one BLAS thread per process, as Dask's workers
    _WORKER["route"] = route


def _probe_local(fs: FeatureSet, ev0: Evidence, aug: Augmentation, n_candidates: int
                 ) -> _Probe:
    return _WORKER["route"].probe(fs, ev0, aug, n_candidates)


def _probe_remote(route: _Route, fs: FeatureSet, ev0: Evidence, aug: Augmentation,
                  n_candidates: int) -> _Probe:
    return route.probe(fs, ev0, aug, n_candidates)


def _pick(probes: Sequence[_Probe], tolerance: float, prefer_large_lag: bool) -> _Probe:
    """Parsimony among members within ``tolerance`` of the best total gain: fewest columns
    (then the larger gain); for a delay the largest lag (the knee of the lag profile)."""
    best = max(p.total_gain for p in probes)
    ok = [p for p in probes if p.total_gain >= best - tolerance * abs(best)]
    if prefer_large_lag:
        return max(ok, key=lambda p: (p.aug.lag, p.total_gain))
    return min(ok, key=lambda p: (len(p.aug.columns()), -p.total_gain))


def _move_gains(p: _Probe, elements: Sequence[int] | None = None) -> np.ndarray:
    """(M,) each move's share of a probe's held-out state gain (its contributions summed over
    the elements, or over ``elements`` only; the mean over moves is the summed gain)."""
    d = np.asarray(p.decision.state.d)
    return (d if elements is None else d[:, list(elements)]).sum(axis=1)


def _wider_p(cur: _Probe, tried: Sequence[_Probe], added: bool = False) -> dict[str, float]:
    """For each tried scope whose joints strictly contain ``cur``'s: the one-sided Wilcoxon
    signed-rank p that it gains more move by move (per move, its held-out state gain minus
    ``cur``'s), times the number of such scopes (capped at 1). ``added``
    (``LearnedOptions.widen_focus``): also the same test on the q and dq of the joints the wider
    scope adds, where their own columns act and the rest of the state adds only noise; the p
    is then 2 min of the two."""
    from scipy.stats import wilcoxon

    def greater(diff: np.ndarray) -> float:
        return float(wilcoxon(diff, alternative="greater").pvalue) if np.any(diff != 0) else 1.0
    if "joints" not in cur.aug.params():
        return {}
    inner = set(JOINT_GROUPS[cur.aug.joints])
    wider = [p for p in tried if "joints" in p.aug.params()
             and set(JOINT_GROUPS[p.aug.joints]) > inner]
    out = {}
    for p in wider:
        pv = greater(_move_gains(p) - _move_gains(cur))
        if added:
            el = _joint_elements(sorted(set(JOINT_GROUPS[p.aug.joints]) - inner))
            pv = min(1.0, 2.0 * min(pv, greater(_move_gains(p, el) - _move_gains(cur, el))))
        out[p.aug.label()] = min(1.0, pv * len(wider))
    return out


def _widen(chosen: _Probe, tried: Sequence[_Probe], alpha: float, added: bool = False,
           tolerance: float | None = None) -> tuple[_Probe, dict[str, float]]:
    """The parsimonious scope, widened while a tried scope whose joints strictly contain it
    gains more move by move (:func:`_wider_p` below ``alpha``, ``added`` as there) and at
    least as much in total (of those that pass, the one with the larger total gain); and the
    wider scopes' p against the scope kept. A drift on every joint that matters most in the
    knees keeps the knees within the parsimony tolerance of all joints; where the hips' share
    shows on most moves, all joints are taken, and where it does not, the report says the data
    cannot tell the two apart. With ``tolerance`` (``LearnedOptions.widen_within_tolerance``),
    a wider scope's total need only be within ``tolerance`` of the best tried, as parsimony's:
    where the totals cannot tell two scopes apart, the move-by-move test decides (a drift on
    every joint whose right side alone gains a little more in total:
    ``benchmarks/blind_zoo/zoos/zoo12/runs/run2_delay_scope_widen/README.md``, z08)."""
    cur = chosen
    best = max(p.total_gain for p in tried)
    while True:
        ps = _wider_p(cur, tried, added)
        floor = (cur.total_gain if tolerance is None
                 else min(cur.total_gain, best - tolerance * abs(best)))
        passed = [p for p in tried if ps.get(p.aug.label(), 1.0) < alpha
                  and p.total_gain >= floor]
        if not passed:
            return cur, ps
        cur = max(passed, key=lambda p: p.total_gain)


def screen_narrower(route: "_Route", fs: FeatureSet, ev0: Evidence, full: Sequence[_Probe],
                    n_scoped: float) -> list[_Probe]:
    """The narrower screen of a round: every narrower joint scope of each full-scope probe in
    ``full`` that gained (``total_gain`` > 0) with a p at most ``narrow_p`` (a hint, not a
    finding; below 1 it saves the probes of families that show little), probed at the
    Bonferroni factor ``n_scoped`` (:func:`screen_sizes`)."""
    narrow = [m for p in full if p.total_gain > 0 and p.decision.p_value <= route.opts.narrow_p
              for m in _scope_members(p.aug) if m.joints != "all"]
    return route.probes(fs, ev0, narrow, n_scoped)


def _refine(route: _Route, fs: FeatureSet, ev0: Evidence, first: _Probe, n_candidates: float,
            known: Sequence[_Probe] = ()) -> tuple[_Probe, list[dict[str, Any]]]:
    """Scope, then parameter, of a detected family by the same held-out rollout SSE. ``known``:
    probes this round already made at ``fs`` (the screens'), reused instead of made again."""
    have = {p.aug.label(): p for p in known}
    members = _new_columns(fs, _scope_members(first.aug))
    new = route.probes(fs, ev0, [a for a in members if a.label() not in have], n_candidates)
    made = {p.aug.label(): p for p in new}
    tried = [first] + [have.get(a.label()) or made[a.label()] for a in members]
    within = route.opts.tolerance if route.opts.widen_within_tolerance else None
    scoped, wider = _widen(_pick(tried, route.opts.tolerance, False), tried,
                           route.opts.scope_alpha, route.opts.widen_focus, within)
    joints = _new_columns(fs, _joint_members(scoped.aug)) if route.opts.joint_scopes else []
    if joints:     # one joint of the leg, type or side kept, if it carries the gain
        tried += route.probes(fs, ev0, joints, n_candidates)
        scoped, wider = _widen(_pick(tried, route.opts.tolerance, False), tried,
                               route.opts.scope_alpha, route.opts.widen_focus, within)
    params = [scoped] + route.probes(fs, ev0, _new_columns(fs, _param_members(scoped.aug)),
                                     n_candidates)
    best = _pick(params, route.opts.tolerance, isinstance(scoped.aug, CommandLag))
    scan = [{"label": p.aug.label(), "total_gain": p.total_gain,
             "p_value": float(p.decision.p_value), "stage": stage,
             **({"p_wider": wider[p.aug.label()]} if p.aug.label() in wider else {}),
             **({"kept_scope": True} if p is scoped else {})}
            for stage, group in (("scope", tried), ("parameter", params[1:])) for p in group]
    return best, scan


def _new_columns(fs: FeatureSet, augs: Sequence[Augmentation]) -> list[Augmentation]:
    """The augmentations of ``augs`` none of whose columns ``fs`` already holds: a scope's or
    parameter's neighbour can be a column an earlier round accepted (the one-step loop's
    ``command_lag(lag=1)`` beside the scan of a ``command_lag(lag=2)``), and ``fs`` with it
    again would hold a column twice."""
    have = set(fs.names)
    return [a for a in augs if not have & set(a.columns())]


def _scope_rivals(scan: Sequence[dict[str, Any]], tolerance: float, alpha: float
                  ) -> list[dict[str, Any]]:
    """The wider scopes the data cannot tell from the one kept (``kept_scope``), at the
    round's first parameter: within ``tolerance`` of the best total gain of the scope stage,
    and not gaining more move by move (``p_wider`` >= alpha). Each with the kept scope's
    label and gain for comparison."""
    scopes = [s for s in scan if s.get("stage", "scope") == "scope"]
    kept = [s for s in scopes if s.get("kept_scope")]
    if not scopes or not kept:
        return []
    best = max(s["total_gain"] for s in scopes)
    return [{"label": s["label"], "total_gain": s["total_gain"], "p_wider": s["p_wider"],
             "kept": kept[0]["label"], "kept_total_gain": kept[0]["total_gain"]}
            for s in scopes if "p_wider" in s and s["p_wider"] >= alpha
            and s["total_gain"] >= best - tolerance * abs(best)]


# ------------------------------------------------------------------------------ physical names


def _scope_words(aug: Augmentation) -> str:
    j = aug.params().get("joints", "all")
    if j == "all":
        return "all joints"
    if j in ("hip_rolls", "hip_pitches", "knees"):
        return f"the {j.replace('_', '-')}"
    if j in ("left", "right"):
        return f"the {j} side's joints"
    return f"the {j.replace('_', '-')} leg" if j in SCOPES else f"joint {j}"


def physical_statement(aug: Augmentation, model: CrossFitModel, fs: FeatureSet,
                       X: np.ndarray, mass_kg: float, elapsed_mean_s: float,
                       floor: Mapping[str, Any] | None = None) -> tuple[str, dict[str, Any]]:
    """(sentence, numbers) naming the effect ``aug`` of the fitted ``model`` (features X;
    ``elapsed_mean_s``: the mean time since the move's start over X's rows; ``floor``: the
    recordings' floor plane, :func:`.families.learned.floor_plane`, which names a position
    effect an inclined floor where a plane explains the body heights)."""
    from .families.learned import slope_reading
    slope = slope_reading(floor) if aug.family == "pose (position)" else None
    if slope is not None:                # the plane itself: report.json's floor_plane
        return slope["statement"], dict(slope["params"])
    sl = fs.column_slices()[list(fs.augmentations).index(aug)]
    if isinstance(aug, Heading):
        return _heading_statement(model.linear_coef(sl), mass_kg)
    if isinstance(aug, CommandLag):
        ms = aug.lag * CONTROL_DT * 1000.0
        return (f"{_scope_words(aug)}: set-points act about {ms:.0f} ms late "
                f"(u_t-{aug.lag})", {"delay_ms": ms})
    if isinstance(aug, CommandFilter):
        return (f"{_scope_words(aug)}: set-points pass a lag of about "
                f"{aug.time_constant_ms:.0f} ms", {"time_constant_ms": aug.time_constant_ms})
    if isinstance(aug, Play):
        return (f"{_scope_words(aug)}: command reversals matter: play of about "
                f"{aug.width:.2f} rad in the set-points", {"width_rad": aug.width})
    if isinstance(aug, ElapsedTracking):
        return _drift_statement(aug, model, sl, X, elapsed_mean_s)
    where = _strongest(model.linear_coef(sl), X[:, sl])
    kind = {"pose (position)": "where the robot is on the floor (terrain that varies over it)",
            "elapsed time": "the time since the move started (drift)",
            "gait phase": "the gait phase (a phase-locked effect)",
            "swing": (f"the joint rates of {_scope_words(aug)} while their foot swings (a "
                      "force or drag on a foot off the ground)")}.get(aug.family, aug.family)
    return (f"the dynamics depend on {kind}; strongest on {', '.join(where)}; the learned "
            f"model alone cannot put this family in physical units",
            {"strongest_on": where})


def vocabulary_reading(aug: Augmentation, numbers: dict[str, Any], text: str,
                       floor: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The effect in the diagnosis vocabulary (``{family, scope, params, statement}``, the
    physical route's form): the learned family's reading (:mod:`.families.learned`; ``floor``
    as for :func:`physical_statement`) with the physical numbers this route measured where the
    family's parameters name them."""
    from .families.learned import physical_reading
    out = physical_reading(aug, floor)
    params = dict(out["params"])
    for k in list(params) + ["direction_deg"]:
        if isinstance(numbers.get(k), (int, float)):
            params[k] = float(numbers[k])
    return {**out, "params": params, "statement": text}


def _strongest(coef: np.ndarray, Z: np.ndarray, n: int = 3) -> list[str]:
    """State elements whose one-step change the columns move most (in units of its spread)."""
    eff = np.abs(coef * Z.std(axis=0)[:, None]).sum(axis=0)
    return [STATE_NAMES[j] for j in np.argsort(-eff)[:n]]


def _heading_statement(coef: np.ndarray, mass_kg: float) -> tuple[str, dict[str, Any]]:
    """A world-fixed push's direction from the sin/cos(yaw) columns' effect on dx_b, dy_b per
    step, and the one-step free-body figure.

    The change of the per-step body displacement is a_b dt^2; a_b(yaw) from the fitted
    coefficients, turned into odom and averaged over the heading, is the constant
    acceleration a world-fixed force would give a free body (the part that turns with the body
    is reported as ``inconsistency``). A robot on its feet is no free body: they hold most of
    the push, so the mass times this acceleration is no force (``one_step_free_body_N``; on
    the gap zoos it was many times the push, ``benchmarks/learned_route/push_reading``).
    The force in newtons comes from the drift against a reference (:func:`_push_in_newtons`);
    without one ``force_N`` is None."""
    (sx, sy), (cx, cy) = coef[0, 1:3], coef[1, 1:3]
    dt2 = CONTROL_DT ** 2
    ax, ay = 0.5 * (cx - sy) / dt2, 0.5 * (sx + cy) / dt2
    rest = 0.5 * math.hypot(cx + sy, sx - cy) / dt2
    deg = math.degrees(math.atan2(ay, ax)) % 360.0
    return (f"a steady force fixed in odom toward {deg:.0f} deg ({_axis_words(deg)}); its size "
            f"in newtons needs a reference recording of the robot without it (the drift "
            f"against it)",
            {"force_N": None, "direction_deg": deg, "force_xy_N": None,
             "equivalent_slope_deg": None,
             "one_step_free_body_N": mass_kg * math.hypot(ax, ay),
             "one_step_direction_deg": deg, "inconsistency_N": mass_kg * rest,
             "mass_kg": mass_kg})


def _push_in_newtons(numbers: dict[str, Any], train: Sequence[MoveRecording],
                     reference: Sequence[MoveRecording] | None, opts: LearnedOptions,
                     say: Callable[[str], None], fitted: bool = True,
                     drift: "Drift | None" = None) -> tuple[str, dict[str, Any]]:
    """A heading effect's push in newtons (:mod:`.push`): the TrainPool's drift against the
    reference's, over the push response of the physics robot ``opts.push_robot`` walking the
    reference's commands. Without a reference, a push robot, pybullet, or a drift, the
    statement says which was missing and ``force_N`` stays None. ``fitted``: the statement
    ends with the direction of a fitted heading effect (``numbers['direction_deg']``);
    ``drift``: the drift against the reference where the caller measured it."""
    from .push import PybulletPushes, describe, drift_against_reference, push_mobility, \
        push_reading
    deg = numbers["direction_deg"]
    head = f"a steady force fixed in odom toward {deg:.0f} deg ({_axis_words(deg)})"
    if reference is None or not opts.push_robot:
        why = ("a reference recording of the robot without it (the drift against it)"
               if reference is None else "a robot's push response (push_robot is off)")
        return f"{head}; its size in newtons needs {why}", numbers
    if drift is None:
        drift = drift_against_reference(train, reference)
    if drift is None:
        return (f"{head}; too few moves of the reference's types to measure the drift against "
                f"it, so no size in newtons", numbers)
    out = {**numbers, "drift": drift.to_dict()}
    try:
        sim = PybulletPushes(opts.push_robot)
        t0 = time.perf_counter()
        M, n = push_mobility(reference, sim, per_type=opts.push_moves_per_type)
    except ImportError as exc:
        speed = 100 * drift.to_dict()["speed_mps"]
        return (f"{head}; the drift against the reference is {speed:.1f} cm/s, but no physics "
                f"robot to size the push with ({exc})", out)
    say(f"push: '{opts.push_robot}' walked {n} of the reference's moves three times in "
        f"{time.perf_counter() - t0:.0f} s")
    reading = push_reading(drift, M)
    if reading is None:
        return (f"{head}; the '{opts.push_robot}' robot does not drift under a push, so no size "
                f"in newtons", out)
    weight = numbers["mass_kg"] * 9.81
    out.update({k: reading[k] for k in ("force_N", "direction_deg", "force_xy_N")},
               equivalent_slope_deg=math.degrees(math.asin(min(1.0, reading["force_N"] / weight))),
               push={**reading, "robot": opts.push_robot, "mobility_moves": n})
    return (describe(reading, drift, opts.push_robot) + (
        f"; the fitted heading effect points toward {deg:.0f} deg" if fitted else ""), out)


#: the vocabulary families a heading probe reads as (a force fixed in odom, a slope)
HEADING_FAMILIES = ("odom_force", "ground_slope")


NEAR_ALPHA = 10.0   # a probe within this many times alpha is near (as ``suspected``'s rule)


def heading_near_misses(report: Mapping[str, Any], opts: LearnedOptions) -> list[dict[str, Any]]:
    """Decision 066: the full-scope heading probes of every round of the rollout route
    (``report["rounds"]``) whose p is below :data:`NEAR_ALPHA` times ``alpha``, smallest p
    first, each with its ``round``. A later round's model may carry what a shared or
    stand-in finding took up, so the last round's ``suspected`` list alone can lose them."""
    out = [{**p, "round": r.get("round")} for r in report.get("rounds", [])
           for p in r.get("probes", []) if p.get("family") == Heading.family
           and float(p.get("p_value", 1.0)) < NEAR_ALPHA * opts.alpha]
    return sorted(out, key=lambda p: float(p["p_value"]))


def _pose_effects_held(report: Mapping[str, Any]) -> list[str]:
    """The labels of the heading and position effects in the route's final feature set
    (``report["feature_set"]``), the one-step loop's included: a floor slope the one-step
    loop accepted as position columns drifts the robot as a push would."""
    from ..models.features import augmentation_from_dict
    augs = [augmentation_from_dict(a)
            for a in (report.get("feature_set") or {}).get("augmentations", [])]
    return [a.label() for a in augs if a.family in (Heading.family, PlanarPosition.family)]


def drift_change(report: dict[str, Any], train: Sequence[MoveRecording],
                 reference: Sequence[MoveRecording], opts: LearnedOptions, mass_kg: float,
                 say: Callable[[str], None]) -> dict[str, Any]:
    """Decision 037: a push fixed in odom that the search suspected but did not accept,
    confirmed by the drift against the reference.

    Where the search accepted no heading effect and suspects one as significant and material
    but raising the total held-out rollout error (a heading column also moves the body's own
    elements, and can cost there what it gains in odom), or, failing that, one of its rounds
    probed a heading with p within 10 times alpha (:func:`heading_near_misses`, decision
    066), the TrainPool's drift against the
    reference's (:func:`.push.drift_against_reference`, no model) is the second test, at the
    level of a choice within a finding (``scope_alpha``). Where it holds, the push is named
    ``odom_force @ body`` in newtons from the drift over the physics robot's push response
    (:func:`_push_in_newtons`, decision 025), toward the drift's direction. Nothing is added
    to the model. Returns ``{tested, named, why, suspected, drift, alpha, statement}`` and,
    where named, ``push`` (the force's numbers) and ``vocabulary``."""
    from .push import drift_against_reference
    out: dict[str, Any] = {"tested": False, "named": False, "suspected": None, "drift": None,
                           "alpha": opts.scope_alpha}
    accepted = [e for e in report.get("effects", []) + report.get("reference", {}).get(
        "shared", []) if (e.get("vocabulary") or {}).get("family") in HEADING_FAMILIES]
    if accepted:
        return {**out, "why": "the search accepted a heading effect",
                "statement": "no drift test: the search accepted a heading effect"}
    suspects = [s for s in report.get("suspected", [])
                if (s.get("vocabulary") or {}).get("family") in HEADING_FAMILIES
                and s.get("why") == NO_TOTAL_GAIN]
    how = "significant and material but raising the total held-out rollout error"
    if not suspects:           # decision 066: a heading probe near alpha in any round
        near = heading_near_misses(report, opts)
        held = _pose_effects_held(report)
        if near and held:
            return {**out, "why": "the model holds a pose effect",
                    "statement": f"no drift test: {near[0]['label']} was near alpha, but the "
                                 f"model already holds {held[0]}"}
        if near:
            suspects = near[:1]
            how = (f"its p {near[0]['p_value']:.2g} in round {near[0]['round']} within "
                   f"{NEAR_ALPHA:g} times alpha ({opts.alpha:g})")
    if not suspects:
        return {**out, "why": "no heading effect suspected",
                "statement": "no drift test: no heading effect suspected"}
    out["suspected"] = suspects[0]["label"]
    drift = drift_against_reference(train, reference)
    if drift is None:
        return {**out, "why": "too few moves of the reference's types",
                "statement": "no drift test: too few moves of the reference's types"}
    d = drift.to_dict()
    out.update(tested=True, drift=d)
    if not d["p_value"] < opts.scope_alpha:
        out["why"] = "the drift against the reference is not significant"
        out["statement"] = (f"{suspects[0]['label']} was suspected, but the drift against the "
                            f"reference, {100 * d['speed_mps']:.2f} cm/s toward "
                            f"{d['direction_deg']:.0f} deg, is not significant "
                            f"(p = {d['p_value']:.2g}, alpha {opts.scope_alpha:g})")
        return out
    numbers = {"force_N": None, "direction_deg": d["direction_deg"], "force_xy_N": None,
               "mass_kg": mass_kg}
    text, numbers = _push_in_newtons(numbers, train, reference, opts, say, fitted=False,
                                     drift=drift)
    params = {"force_N": numbers.get("force_N"), "direction_deg": numbers["direction_deg"]}
    statement = (f"a push since the reference: {text} ({suspects[0]['label']} was suspected, "
                 f"{how}; the drift against the reference confirms it, p = "
                 f"{d['p_value']:.2g} < {opts.scope_alpha:g}; nothing is added to the model)")
    return {**out, "named": True, "why": "the drift against the reference confirms it",
            "push": numbers, "statement": statement,
            "vocabulary": {"family": "odom_force", "scope": "body", "params": params,
                           "statement": statement}}


def _with_drift(text: str, numbers: dict[str, Any], ev0: Evidence, h: int
                ) -> tuple[str, dict[str, Any]]:
    """Add the drift the push leaves unmodelled, measured: the mean odom residual of the
    starting model's horizon-h rollouts over h (the robot's feet resist the push, so the
    free-body force read off one step is an upper figure; the drift is what it does)."""
    v = ev0.odom[h].mean(axis=0) / (h * CONTROL_DT)
    u = np.array([math.cos(math.radians(numbers["direction_deg"])),
                  math.sin(math.radians(numbers["direction_deg"]))])
    numbers = {**numbers, "drift_velocity_xy_mps": [float(v[0]), float(v[1])],
               "drift_along_force_mps": float(v @ u),
               "drift_direction_deg": float(math.degrees(math.atan2(v[1], v[0])) % 360.0)}
    return (f"{text}; unmodelled drift {100 * float(v @ u):.1f} cm/s along it "
            f"(measured, {h * CONTROL_DT:g} s rollouts)", numbers)


def _axis_words(deg: float) -> str:
    names = {0: "+x", 90: "+y", 180: "-x", 270: "-y", 360: "+x"}
    near = min(names, key=lambda a: abs(a - deg))
    return f"along {names[near]} in odom" if abs(near - deg) <= 20 else "in odom"


def _drift_statement(aug: ElapsedTracking, model: CrossFitModel, sl: slice, X: np.ndarray,
                     t_bar: float) -> tuple[str, dict[str, Any]]:
    """Servo stiffness drift: the t*(u-q) coefficient on ddq over the model's d(ddq)/du.

    With a push G(t) c (u - q), G(t) = G0 (1 + r t), the model's u column carries G0 c and
    the t*(u-q) column G0 r c, so their ratio is r, the rate relative to the start value
    (``t_bar``, the data's mean time, is reported for reference). On the gap zoos it reads
    about half the true rate (``benchmarks/learned_route/drift_reading/README.md``; decision
    025); with a reference, :func:`_drift_against_reference` measures the rate instead."""
    joints = [JOINT_NAMES.index(c.split("_", 1)[1]) for c in aug.columns()]
    beta = model.linear_coef(sl)
    rng = np.random.default_rng(0)
    sub = X[rng.choice(X.shape[0], size=min(2000, X.shape[0]), replace=False)]
    rates = []
    base = model.predict(sub, -1)
    for i, j in enumerate(joints):
        Xp = sub.copy()
        Xp[:, N_STATE + j] += 1e-3
        g = float(np.mean((model.predict(Xp, -1) - base)[:, S.dq.start + j]) / 1e-3)
        if abs(g) > 1e-9:
            rates.append(beta[i, S.dq.start + j] / g)
    r = float(np.median(rates)) if rates else float("nan")
    return (f"{_scope_words(aug)}: the servos' stiffness changes by about {100 * r:+.0f} % of "
            f"its starting value per second of the move (the model's own reading, 42-56 % "
            f"below the true rate on three gap zoos; a reference recording measures it)",
            {"rate_per_s": r, "mean_time_s": t_bar})


def _drift_against_reference(aug: ElapsedTracking, numbers: dict[str, Any], mv: "_Moves",
                             reference: "_Moves") -> tuple[str, dict[str, Any]]:
    """A stiffness drift's rate measured straight from the recordings against the reference
    (:mod:`.servo_drift`: each joint's stiffness regressed per time bin, its relative slope,
    minus the reference's), replacing the model-coefficient reading, which is kept as
    ``model_rate_per_s`` (``benchmarks/learned_route/drift_reading``)."""
    from .servo_drift import rate_against_reference
    joints = [JOINT_NAMES.index(c.split("_", 1)[1]) for c in aug.columns()]
    got = rate_against_reference(mv, reference, joints)
    r = got["rate_per_s"]
    out = {**numbers, "model_rate_per_s": numbers.get("rate_per_s"), "rate_per_s": r,
           "stiffness_drift": got}
    return (f"{_scope_words(aug)}: the servos' stiffness changes by about {100 * r:+.1f} % of "
            f"its starting value per second of the move, against the reference (measured: "
            f"each joint's stiffness per time bin, {100 * got['data_rate_per_s']:+.1f} %/s here "
            f"and {100 * got['reference_rate_per_s']:+.1f} %/s in the reference)", out)


# ------------------------------------------------------------------------------ what is left

#: the recording that would settle structure left in the residual, per group
RECORDINGS: dict[str, str] = {
    "bias": "record more moves of the types with the largest residual (the model is off on "
            "average there): 20 or more per type",
    "position": "record the same move types started from several places on the floor (a grid "
                "about 1 m apart) and headings, so where the robot is and how far into which "
                "move it is are not confounded (record --start-spread 0.5)",
    "heading": "record every move type from at least four start headings 90 deg apart (record "
               "--start-spread 0.5 starts each move at its own heading)",
    "time": "record longer moves (8 s or more), or the same moves at different times since "
            "power-up",
    "phase": "record with command excitation (record --excitation 0.05) and at a second gait "
             "period",
}


def _structure_columns(ev: Evidence, h: int, mv: _Moves, phase: list[np.ndarray]
                       ) -> dict[str, np.ndarray]:
    """Regressors of each horizon-h rollout from the measured data at its start."""
    m, t0 = ev.move[h], ev.t0[h]
    pose = np.stack([mv.pose[i][t] for i, t in zip(m, t0)])
    t = t0 * CONTROL_DT
    return {"position": pose[:, :2], "heading": np.stack([np.sin(pose[:, 2]),
                                                          np.cos(pose[:, 2])], axis=1),
            "time": np.stack([t, t ** 2], axis=1),
            "phase": np.stack([phase[i][t] for i, t in zip(m, t0)])}


def _crossfit_sse(E: np.ndarray, Z: np.ndarray | None, move: np.ndarray, fold: np.ndarray,
                  n_moves: int, ridge: float = 1e-6) -> np.ndarray:
    """(M, 33) per-move SSE of E minus its held-out least-squares fit on [1, Z] (Z None: on
    nothing, the residual itself), folds by move."""
    if Z is None:
        R = E
    else:
        A = np.hstack([np.ones((E.shape[0], 1)), (Z - Z.mean(axis=0)) / np.where(
            Z.std(axis=0) > 0, Z.std(axis=0), 1.0)])
        R = np.empty_like(E)
        f_row = fold[move]
        for f in np.unique(f_row):
            tr, te = f_row != f, f_row == f
            G = A[tr].T @ A[tr] + ridge * np.eye(A.shape[1])
            R[te] = E[te] - A[te] @ np.linalg.solve(G, A[tr].T @ E[tr])
    out = np.zeros((n_moves, E.shape[1]))
    np.add.at(out, move, R ** 2)
    return out


def residual_structure(ev: Evidence, mv: _Moves, fold_of_move: np.ndarray,
                       phase: list[np.ndarray], h: int, opts: LearnedOptions) -> dict[str, Any]:
    """Is the held-out horizon-h rollout residual structured? (module doc, 6)."""
    E = ev.err[h]
    cols = _structure_columns(ev, h, mv, phase)
    n_tests = 1 + len(cols)
    S_zero = _crossfit_sse(E, None, ev.move[h], fold_of_move, mv.n)
    S_const = _crossfit_sse(E, np.empty((E.shape[0], 0)), ev.move[h], fold_of_move, mv.n)
    groups = {"bias": sse_decision(S_zero, S_const, n_tests, opts.alpha, opts.min_gain)}
    for name, Z in cols.items():
        S1 = _crossfit_sse(E, Z, ev.move[h], fold_of_move, mv.n)
        groups[name] = sse_decision(S_const, S1, n_tests, opts.alpha, opts.min_gain)
    found = [g for g, d in groups.items() if d.significant and d.material]
    share = (S_zero / np.where(S_zero.sum(axis=0) > 0, S_zero.sum(axis=0), 1.0)).mean(axis=1)
    worst = np.argsort(-share)[:5]
    d_std = np.sqrt((ev.one_step_std[:, S.d_b][:, :2] ** 2).sum(axis=1).mean())
    odom_rms = float(np.sqrt((ev.odom[h] ** 2).sum(axis=1).mean()))
    out = {"horizon_s": h * CONTROL_DT,
           "groups": {g: {"p_value": float(d.p_value), "total_gain": float(np.sum(d.gain)),
                          "max_gain": float(np.max(d.gain)), "significant": bool(d.significant),
                          "material": bool(d.material), "outputs": list(d.outputs)}
                      for g, d in groups.items()},
           "smallest_p": float(min(d.p_value for d in groups.values())),
           "unexplained": found,
           "channels": sorted({o for g in found for o in groups[g].outputs}),
           "moves": [{"move": mv.names[i], "share": float(share[i])} for i in worst],
           "odom_rms_m": odom_rms,
           "coherence_ratio": odom_rms / (math.sqrt(h) * d_std) if d_std > 0 else None,
           "recording": {g: RECORDINGS[g] for g in found}}
    return out


# ------------------------------------------------------------------------------ the route


def _phase_columns(recs: Sequence[MoveRecording]) -> list[np.ndarray]:
    fs = FeatureSet((GaitPhase(quarter_lag=9),))
    X, _, mi = fs.features_responses(recs)
    return [X[mi == i, N_FEATURE:] for i in range(len(recs))]


def _test_scores(model: CrossFitModel, fs: FeatureSet, test: Sequence[MoveRecording],
                 mv: _Moves, opts: LearnedOptions) -> dict[str, Any]:
    """TestPool one-step nMSE and rollout errors of the fit on the whole TrainPool."""
    X, Y, mi = fs.features_responses(test)
    D = Y - X[:, :N_STATE]
    ev = rollout_evidence(model, fs, mv, None, opts, X, D, mi)
    var = Y.var(axis=0)
    nmse = np.where(var > 1e-24, (ev.one_step ** 2).mean(axis=0) / np.where(var > 1e-24, var,
                                                                             1.0), np.nan)
    xy = {f"{h * CONTROL_DT:g}": float(np.linalg.norm(ev.odom[h], axis=1).mean())
          for h in ev.horizons}
    return {"one_step_nmse_mean": float(np.nanmean(nmse)),
            "one_step_nmse": {n: float(v) for n, v in zip(STATE_NAMES, nmse)},
            "final_xy_error_m": xy[f"{max(ev.horizons) * CONTROL_DT:g}"], "xy_error_at": xy,
            "n_moves": mv.n}


def _check_input(train: Sequence[MoveRecording], test: Sequence[MoveRecording],
                 opts: LearnedOptions) -> None:
    if len(train) < 2 * opts.n_folds:
        raise ValueError(f"diagnose_learned: needs at least {2 * opts.n_folds} TrainPool moves "
                         f"for {opts.n_folds} folds, got {len(train)}")
    if len(test) == 0:
        raise ValueError("diagnose_learned: needs at least one TestPool move")


def _default_mass() -> float:
    from ..robot.config import GUIDE_BODY_MASS, GUIDE_LEG_MASS
    return GUIDE_BODY_MASS + 4 * GUIDE_LEG_MASS


def diagnose_learned(train_recs: Sequence[MoveRecording], test_recs: Sequence[MoveRecording],
                     *, start: FeatureSet | None = None, options: LearnedOptions | None = None,
                     library: Sequence[Augmentation] | None = None,
                     mass_kg: float | None = None,
                     progress: Callable[[str], None] | None = None,
                     scheduler: str | None = None,
                     reference: Sequence[MoveRecording] | None = None,
                     jobs: int = 1, conditions: "Conditions | None" = None) -> dict[str, Any]:
    """The learned route on TrainPool ``train_recs``, scored on TestPool ``test_recs``; returns
    the report dict of the module doc. ``start``: the model's feature set before the search
    (default :func:`.candidates.measured_robot_features`); ``library``: the family probes
    (default :func:`family_probes`); ``mass_kg``: the robot's total mass (default the
    guide's, from :mod:`..robot.config`); ``scheduler``: the address of a Dask scheduler
    whose workers run the probes (each a cross-fit and its held-out rollouts), with the same
    report (``seconds`` aside) as here; else ``jobs`` > 1 local worker processes run them
    (:meth:`_Route.local`; the whole search then runs one BLAS thread in this process too, as
    in the workers, and the report is the same as with one job at one BLAS thread, e.g.
    ``OPENBLAS_NUM_THREADS=1``). ``reference``: the TrainPool of a recording of the same
    robot before the change; an effect is then reported only if it cuts the data's held-out
    rollout error more than the reference's (:func:`contrast`), and one that does not is the
    robot's own: carried by the model, listed under ``reference.shared``. ``conditions``: the
    data's and the reference's command excitation (:mod:`.conditions`, decision 031); where
    they differ, a finding of a family excitation shows is listed under
    ``reference.not_comparable`` (carried by the model, not a change), and decisions 026 and
    027 are read but neither significant nor named."""
    from .candidates import measured_robot_features
    opts = options or LearnedOptions()
    if reference is not None:
        opts = replace(opts, focus_all=opts.focus_all or opts.focus_all_with_reference,
                       widen_focus=opts.widen_focus or opts.widen_focus_with_reference)
    _check_input(train_recs, test_recs, opts)
    if reference is not None and len(reference) < 2 * opts.n_folds:
        raise ValueError(f"diagnose_learned: the reference needs at least {2 * opts.n_folds} "
                         f"TrainPool moves for {opts.n_folds} folds, got {len(reference)}")
    say = progress or (lambda s: log.info(s))
    t_start = time.perf_counter()
    start = measured_robot_features() if start is None else start
    lib = list(family_probes() if library is None else library)
    if int(jobs) < 1:
        raise ValueError(f"diagnose_learned: jobs must be >= 1, got {jobs}")
    client = None
    if scheduler:              # an unreachable scheduler: a ValueError of one line, at once
        from ..models.parallel import connect_client
        client = connect_client(scheduler)
    local = client is None and int(jobs) > 1
    route = None
    try:
        with _one_blas_thread(local):    # the whole search, as the workers run it
            route = _Route(train_recs, start, opts, say)
            ref_route = None if reference is None else _Route(reference, start, opts, say)
            if client is not None:
                route.remote(client)
            elif local:
                route.local(int(jobs))
            return _search(route, train_recs, test_recs, start, lib, opts, mass_kg, t_start,
                           ref_route, None if reference is None else conditions)
    finally:
        if route is not None:
            route.close()
        elif client is not None:
            client.close()


def _search(route: _Route, train_recs: Sequence[MoveRecording],
            test_recs: Sequence[MoveRecording], start: FeatureSet, lib: list[Augmentation],
            opts: LearnedOptions, mass_kg: float | None, t_start: float,
            ref_route: "_Route | None" = None,
            conditions: "Conditions | None" = None) -> dict[str, Any]:
    from .conditions import cannot_contrast
    from .families.learned import floor_plane, slope_reading, start_spread
    say = route.say
    model0, ev0 = route.fit(start)
    fs, model, ev = start, model0, ev0
    rounds: list[dict[str, Any]] = []
    found: list[tuple[_Probe, list[dict[str, Any]]]] = []
    shared: list[tuple[_Probe, list[dict[str, Any]]]] = []   # in the reference as well
    uncontrasted: list[tuple[_Probe, list[dict[str, Any]]]] = []   # decision 031
    contrasts: dict[str, dict[str, Any]] = {}
    last: list[_Probe] = []
    spread = start_spread(train_recs)
    position_unsupported = spread["confounded"] and slope_reading(floor_plane(train_recs)) is None
    confounded: list[_Probe] = []
    k = -1
    n_full, n_scoped = screen_sizes(lib, opts.scoped_screen, opts.scoped_share)
    while len(found) < opts.max_rounds and len(shared) + len(uncontrasted) <= opts.max_shared:
        k += 1
        taken = ({p.aug.family for p, _ in found + shared + uncontrasted}
                 | {p.aug.family for p in confounded})
        todo = [a for a in lib if a.family not in taken and not set(a.columns()) & set(fs.names)]
        last = route.probes(fs, ev, todo, n_full)
        rounds.append({"round": k, "probes": [p.to_dict() for p in last]})
        ok = [p for p in last if _accepted(p)]
        if position_unsupported:       # position stands for the move's type and progress
            confounded += [p for p in ok if isinstance(p.aug, PlanarPosition)]
            ok = [p for p in ok if not isinstance(p.aug, PlanarPosition)]
        say(f"round {k}: " + ", ".join(f"{p.aug.label()} gain {p.total_gain:+.2f} "
                                       f"p {p.decision.p_value:.2g}" for p in last))
        if not ok and n_scoped:        # an effect on a few joints, diluted at full scope
            scoped = screen_narrower(route, fs, ev, last, n_scoped)
            rounds[-1]["scoped"] = [p.to_dict() for p in scoped]
            ok = [p for p in scoped if _accepted(p)]
            last = last + scoped
            if scoped:
                say(f"round {k}, narrower scopes: " + ", ".join(
                    f"{p.aug.label()} gain {p.total_gain:+.2f} p {p.decision.p_value:.2g}"
                    for p in sorted(scoped, key=lambda p: p.decision.p_value)[:4]))
        if not ok:
            break
        first = _pick(ok, opts.tolerance, False)   # parsimony among near-equal families
        if ref_route is not None:      # a change goes first: the robot's own does not lead
            _, ev_ref = ref_route.fit(fs, one_step=False)
            pre = {p.aug.label(): contrast(route, ref_route, fs, p, ev_ref, len(ok),
                                           _focus_choices(p.aug))
                   for p in ok}
            changed = [p for p in ok if pre[p.aug.label()]["changed"]
                       and not cannot_contrast(p.aug, conditions)]
            if not changed and len(shared) + len(uncontrasted) == opts.max_shared:
                break
            first = _pick(changed or ok, opts.tolerance, False)
            say(f"round {k}: against the reference: " + ", ".join(
                f"{lab} p(change) {c['p_change']:.2g}" for lab, c in pre.items()))
        best, scan = _refine(route, fs, ev, first, n_full, last)
        if not _accepted(best):
            best = first
            scan = [{k: v for k, v in e.items() if k not in ("p_wider", "kept_scope")}
                    for e in scan]   # the scope compared was not kept
        if ref_route is not None:
            choices = len(SCOPES) + sum(e.get("stage") == "scope" for e in scan)
            c = pre.get(best.aug.label())
            c = (contrast(route, ref_route, fs, best, ev_ref, len(ok), choices) if c is None
                 else _chosen_among(c, choices, route.opts.contrast_alpha))
            if cannot_contrast(best.aug, conditions):
                c = {**c, "changed": False, "comparable": False}
            contrasts[best.aug.label()] = c
            say(f"round {k}: {best.aug.label()} gain {best.total_gain:+.2f} here, "
                f"{c['reference_total_gain']:+.2f} on the reference: p(change) {c['p_change']:.2g}")
        into = (found if ref_route is None or contrasts[best.aug.label()]["changed"]
                else uncontrasted if cannot_contrast(best.aug, conditions) else shared)
        into.append((best, scan))
        fs = fs.with_augmentation(best.aug)
        model, ev = route.fit(fs)
        say(f"round {k}: accepted {best.aug.label()}" + (
            "" if into is found else " (in the reference as well)" if into is shared
            else " (the reference, recorded under another excitation, cannot tell)"))
    report = _report(route, train_recs, test_recs, start, fs, model0, model, ev0, ev, found,
                     rounds, [p for p in last if all(p is not c for c in confounded)], opts,
                     mass_kg or _default_mass(), t_start, shared,
                     None if ref_route is None else contrasts,
                     None if ref_route is None else ref_route.mv.n, ref_route,
                     uncontrasted, conditions)
    report["start_spread"] = spread
    if ref_route is not None:          # what the library left unexplained (decision 026)
        # the reference at fs, fitted once with its one-step residuals for decisions 026, 027
        ref_at_fs = ref_route.fit(fs)
        report["unexplained_change"] = _unexplained_change(route, ref_route, fs, ev,
                                                           ref_at_fs[1])
        if conditions is not None and not conditions.comparable:
            uc = report["unexplained_change"]
            report["unexplained_change"] = (_compared_where_concentrated(uc, conditions)
                                            if concentrated_at_joints(uc)
                                            else _not_compared(uc, conditions))
        if report["unexplained_change"]["significant"]:
            report["significant"] = True
            say("unexplained change: " + report["unexplained_change"]["statement"])
        # what the change is like, through the reference's model (decision 027); also where
        # the search accepted a change, which may have taken a rival family or scope first
        from .change import reference_change
        stand_ins = {e["label"] for e in report["effects"] if e.get("stand_in")}
        report["reference_change"] = rc = reference_change(
            route, ref_route, fs, report["unexplained_change"]["ratio"], ev.one_step,
            ref_at_fs, [p.aug for p, _ in found if p.aug.label() not in stand_ins])
        if conditions is not None and not conditions.comparable:
            report["reference_change"] = rc = _not_compared(rc, conditions)
        if rc["named"]:
            report["significant"] = True
        if rc["significant"]:
            say("change since the reference: " + rc["statement"])
        # a push the search suspected but did not accept, confirmed by the drift (decision 037)
        if opts.drift_confirms:
            report["drift_change"] = dc = drift_change(report, train_recs, ref_route.train,
                                                       opts, mass_kg or _default_mass(), say)
            if dc["named"]:
                report["significant"] = True
                say(dc["statement"])
    from .families.learned import physical_reading
    report["suspected"] += [{**p.to_dict(), "why": _confounded_why(spread),
                             "recording": RECORDINGS["position"],
                             "vocabulary": physical_reading(p.aug)} for p in confounded]
    report["verdict"] = _verdict(report)
    return report


def _not_compared(reading: dict[str, Any], conditions: "Conditions") -> dict[str, Any]:
    """Decision 026's or 027's ``reading`` against a reference recorded under other
    ``conditions`` (decision 031): kept as measured, but neither significant nor named; its
    statement says why and its recording what settles it."""
    out = {**reading, "significant": False, "comparable": False,
           "statement": (f"not compared: {conditions.statement} (as measured: "
                         f"{reading.get('statement', '')})"),
           "recording": conditions.recording}
    if "named" in out:
        out["named"] = False
    return out


def concentrated_at_joints(reading: Mapping[str, Any]) -> bool:
    """Whether decision 026's ``reading`` concentrates at one joint, one leg or one side
    (:data:`.excess.CONCENTRATION`, its own rule): a change a difference of command
    excitation alone does not give, since the excitation drives every joint's set-points
    alike (decision 033) and the legs and sides are copies of one another. A joint type
    (``type:``) does not count: the types answer an excitation differently, and a twin's
    parameters are per type, so its own error under excitation gathers at one; for the same
    reason one joint counts only where it also stands out of the other joints of its type by
    that factor (``scope_ratios``; decision 064)."""
    from .excess import CONCENTRATION
    kind, _, what = str(reading.get("scope")).partition(":")
    if kind not in ("joint", "leg", "side"):
        return False
    if not float(reading.get("concentration") or 0.0) >= CONCENTRATION:
        return False
    return kind != "joint" or over_type_mates(reading, what) >= CONCENTRATION


def over_type_mates(reading: Mapping[str, Any], joint: str) -> float:
    """The ratio of ``joint`` in ``reading``'s ``scope_ratios`` over the mean of the other
    joints of its type (the same joint in the other legs; decision 064); nan where the
    reading does not give them."""
    ratios = reading.get("scope_ratios") or {}
    leg = next((g for g in LEGS if joint.startswith(g + "_")), None)
    if leg is None:
        return float("nan")
    kind = joint[len(leg) + 1:]
    mates = [ratios.get(f"joint:{g}_{kind}") for g in LEGS if g != leg]
    own = ratios.get(f"joint:{joint}")
    if own is None or any(m is None for m in mates):
        return float("nan")
    mean = float(np.mean([float(m) for m in mates]))
    return float(own) / mean if mean > 0 else float("nan")


def _compared_where_concentrated(reading: dict[str, Any], conditions: "Conditions"
                                 ) -> dict[str, Any]:
    """Decision 026's ``reading`` against a reference recorded under other ``conditions``
    where it concentrates at one joint, leg or side (decisions 033 and 064): read as measured,
    significant where it is, with ``comparable`` false and ``concentrated`` true; the statement
    says why it was compared all the same."""
    from .families.scopes import scope_words
    return {**reading, "comparable": False, "concentrated": True,
            "statement": (f"{conditions.recorded}, but the change concentrates at "
                          f"{scope_words(reading['scope'])} "
                          f"({reading['concentration']:.2f} times the other joints' ratio), "
                          f"which a difference of excitation over all joints does not give, "
                          f"so it is compared all the same: {reading.get('statement', '')}")}


def _unexplained_change(route: _Route, ref_route: _Route, fs: FeatureSet, ev: Evidence,
                        ev_ref: Evidence | None = None) -> dict[str, Any]:
    """:func:`.excess.unexplained_change` of the route's final feature set: the data's
    held-out rollout residual at the decision horizon against the reference's, both rolled out
    with ``fs`` (``ev_ref``: the reference's evidence at ``fs`` where the last round made it;
    else the reference is fitted with ``fs`` here)."""
    from .excess import unexplained_change
    if ev_ref is None:
        _, ev_ref = ref_route.fit(fs, one_step=False)
    h = route.h_dec
    if h not in ev_ref.err:            # the reference's moves are shorter than the horizon
        h = max(k for k in ev_ref.err if k in ev.err)
    return unexplained_change(ev.err[h], ev.move[h], ev.t0[h], route.mv.types,
                              ev_ref.err[h], ev_ref.move[h], ev_ref.t0[h], ref_route.mv.types,
                              h * CONTROL_DT, route.opts.alpha)


def _accepted(p: _Probe) -> bool:
    """A probe a round may take: significant, material, and cutting the held-out rollout error
    in total (a rank test can pass on most moves, and one element be cut by the minimum,
    while the few moves that carry most of the error get worse)."""
    return bool(p.decision.significant and p.decision.material and p.total_gain > 0)


#: a suspect's ``why`` where it is significant and material but raises the total error
NO_TOTAL_GAIN = ("significant and material, but it raises the total held-out rollout error "
                 "(total gain <= 0)")


def _chosen_among(c: dict[str, Any], focus_choices: int, contrast_alpha: float
                  ) -> dict[str, Any]:
    """A screen's contrast ``c`` of the probe the scope stage kept, its focus test now
    Bonferroni over the ``focus_choices`` scopes it was kept among (never fewer than the
    screen's own); ``p_change`` and ``changed`` again from the same tests."""
    if "p_focus" not in c:
        return c
    choices = max(int(focus_choices), int(c["focus_choices"]))
    p = contrast_combined(c["p_state"], c["p_path"], c["p_focus"], choices)
    return {**c, "p_change": p, "focus_choices": choices,
            "changed": bool(min(1.0, p * c["n_contrasts"]) < contrast_alpha)}


def _confounded_why(spread: Mapping[str, Any]) -> str:
    return (f"significant and material, but every move starts within {spread['xy_sd_m']:.3f} m "
            f"(SD) and {spread['heading_sd_rad']:.2f} rad of the others, so where a move is "
            "follows from its type and elapsed time: the data cannot tell the floor from the "
            "move's progress, and no plane through the body heights backs an inclined floor")


def _focus_choices(aug: Augmentation) -> int:
    """The scopes a screened probe's focus was chosen among on the data: one at full scope
    (screened before any scope), the narrower screen's nine otherwise."""
    return 1 if aug.params().get("joints") == "all" else len(SCOPES)


def contrast(route: _Route, ref_route: _Route, fs: FeatureSet, probe: _Probe,
             ev_ref: Evidence | None = None, n_contrasts: int = 1,
             focus_choices: int = len(SCOPES)) -> dict[str, Any]:
    """Does ``probe``'s candidate gain more on the data than on the reference? The candidate
    is added to ``fs`` on the reference's TrainPool too (the same cross-fit and held-out
    rollouts); each move's state cut and path log ratio of the two datasets are compared by
    :func:`.stats.contrast_test`, and, for a candidate of a family with a joint scope (with
    ``scope_test``; at full scope with ``focus_all``), its cut over its joints' elements too
    (``p_focus``, unadjusted; a one-joint change is otherwise diluted in the sum over 33
    elements), Bonferroni over the ``focus_choices`` scopes it was chosen among on the data
    (default the narrower screen's nine; :func:`_focus_choices` for a screened probe,
    :func:`_chosen_among` once the scope stage has kept it among more). ``changed``:
    p_change x ``n_contrasts`` (the candidates the round contrasts) < ``contrast_alpha``;
    otherwise the reference shows it as much: the robot's own, not a change since the
    reference. The candidate itself has already passed
    the screen at ``alpha``; the contrast asks only whether it is new, one test per candidate
    the round contrasts."""
    from .stats import contrast_focus_p, contrast_test
    if ev_ref is None:                 # the reference's evidence without it, at ``fs``
        _, ev_ref = ref_route.fit(fs, one_step=False)
    on_ref = ref_route.probe(fs, ev_ref, probe.aug, 1)
    focus = scope_elements(probe.aug, route.opts.focus_all) if route.opts.scope_test else None
    cuts = ((_move_gains(probe, focus), _move_gains(on_ref, focus)) if focus
            else (None, None))
    p_state, p_path, p = contrast_test(
        _move_gains(probe), _move_gains(on_ref), probe.decision.path.log_ratios,
        on_ref.decision.path.log_ratios, *cuts, focus_choices=focus_choices)
    out = {"reference_total_gain": on_ref.total_gain,
           "reference_p_value": float(on_ref.decision.p_value),
           "reference_significant": bool(on_ref.decision.significant),
           "p_state": p_state, "p_path": p_path, "p_change": p, "n_contrasts": n_contrasts,
           "changed": bool(min(1.0, p * n_contrasts) < route.opts.contrast_alpha)}
    if focus:
        out["p_focus"] = contrast_focus_p(*cuts)
        out["focus_choices"] = int(focus_choices)
    return out


def _report(route, train, test, start, fs, model0, model, ev0, ev, found, rounds, last, opts,
            mass_kg, t_start, shared=(), contrasts=None, n_reference=None,
            ref_route=None, uncontrasted=(), conditions=None) -> dict[str, Any]:
    from .families.learned import floor_plane
    X, _, mi = fs.features_responses(route.train)
    t_bar = float(np.mean(np.concatenate([np.arange(s.shape[0]) for s in route.mv.S]))
                  * CONTROL_DT)
    floor = floor_plane(train)
    effects, carried, not_comparable = [], [], []
    ref_start: list[tuple] = []        # the reference at ``start``, fitted where a drift asks
    for (p, scan), into in ([(f, effects) for f in found] + [(f, carried) for f in shared]
                            + [(f, not_comparable) for f in uncontrasted]):
        text, numbers = physical_statement(p.aug, model, fs, X, mass_kg, t_bar, floor)
        if isinstance(p.aug, Heading):
            text, numbers = _push_in_newtons(numbers, route.train,
                                             None if ref_route is None else ref_route.train,
                                             opts, route.say)
            text, numbers = _with_drift(text, numbers, ev0, route.h_dec)
        stand_in = None
        if isinstance(p.aug, ElapsedTracking) and ref_route is not None:
            text, numbers = _drift_against_reference(p.aug, numbers, route.mv, ref_route.mv)
            from .change import drift_through_reference
            if not ref_start:
                ref_start.append(ref_route.fit(start))
            check = drift_through_reference(route, ref_route, start, p.aug, ref_start[0])
            numbers = {**numbers, "through_reference": check}
            stand_in = not check["confirmed"]
            if stand_in:               # decision 028
                text = ("a stand-in for a change that grows along the move, not a drift of the "
                        f"servos: the column t (u - q) at {_scope_words(p.aug)} cuts the "
                        f"data's rollout error (read as a drift, {text}), but through the "
                        "reference's model the servo response there does not drift with time "
                        f"(gain {check['total_gain']:+.2f}, p = {check['p_value']:.2g}); the "
                        "model keeps the column and the family is not named")
        rivals = _scope_rivals(scan, opts.tolerance, opts.scope_alpha)
        if rivals:
            numbers = {**numbers, "scope_cannot_tell": rivals}
            text += "; the data cannot tell this scope from " + ", ".join(
                f"{r['label']} (gain {r['total_gain']:.2f} against {r['kept_total_gain']:.2f} "
                f"for {r['kept']}, not larger move by move: p = {r['p_wider']:.2g})"
                for r in rivals)
        entry = {**p.to_dict(), "augmentation": p.aug.to_dict(), "gain": p.total_gain,
                 "scope": p.aug.params().get("joints", "body"), "statement": text,
                 "physical": numbers,
                 "vocabulary": None if stand_in else vocabulary_reading(p.aug, numbers, text,
                                                                        floor),
                 "scan": scan}
        if stand_in is not None:
            entry["stand_in"] = stand_in
        if contrasts is not None:
            entry["reference"] = contrasts[p.aug.label()]
        if into is not_comparable:
            entry["why"], entry["recording"] = conditions.why, conditions.recording
        into.append(entry)
    mv_test = _moves(test)
    before = _test_scores(model0, start, test, mv_test, opts)
    after = (_test_scores(model, fs, test, mv_test, opts) if found or shared or uncontrasted
             else before)
    residual = residual_structure(ev, route.mv, route.fold_of_move, _phase_columns(route.train),
                                  route.h_dec, opts)
    per_type = train_per_type(route.mv)
    suspected = [_suspect(p, per_type, n_reference is not None)
                 for p in last if not _accepted(p)
                 and (p.decision.significant or (p.decision.material or
                                                 p.decision.p_value < 10 * opts.alpha))]
    report = {"route": "learned", "significant": bool(found), "effects": effects,
              "rounds": rounds, "evidence": {"before": ev0.summary(), "after": ev.summary()},
              "test": {"before": before, "after": after}, "residual": residual,
              "suspected": suspected, "feature_set": fs.to_dict(),
              "options": asdict(opts), "seconds": time.perf_counter() - t_start}
    if n_reference is not None:
        report["reference"] = {"n_moves": n_reference, "shared": carried}
        if conditions is not None:
            report["reference"]["conditions"] = conditions.to_dict()
            report["reference"]["not_comparable"] = not_comparable
    report["verdict"] = _verdict(report)
    return report


#: the most moves :func:`moves_to_settle` asks for, as a multiple of those the data have
SETTLE_MAX_FACTOR = 8.0
#: the probability of significance at the moves :func:`moves_to_settle` asks for
SETTLE_POWER = 0.8


def decision_tests(d: _Decision) -> list[tuple[str, float, float]]:
    """The (name, Bonferroni factor, unadjusted p) of each test behind ``d.p_value``: the
    state's ``pooled``, ``element`` (the best of the C elements) and, with a focus, ``focus``
    tests, and the ``path`` test, each times the candidates and the route's two channel sets;
    ``d.p_value`` is min(1, min of factor x p)."""
    st, n = d.state, float(d.n_candidates)
    T = 3.0 if st.p_focus is not None else 2.0
    out = [("pooled", 2.0 * n * T, float(st.p_pooled)),
           ("element", 2.0 * n * T * len(st.p_element), float(np.min(st.p_element))),
           ("path", 2.0 * n, float(d.path.p))]
    if st.p_focus is not None:
        out.append(("focus", 2.0 * n * T, float(st.p_focus)))
    return out


def moves_to_settle(d: _Decision, per_type: float, power: float = SETTLE_POWER,
                    max_factor: float = SETTLE_MAX_FACTOR) -> int | None:
    """TrainPool moves per type (the same kinds as the data's ``per_type``) at which a
    candidate would be significant at ``alpha`` with probability ``power`` if its effect per
    move is what the held-out evidence shows: a test's z-score grows with the square root of the
    moves (a one-sided test of a mean or a rank sum over moves) and keeps its Bonferroni factor
    f, so test i needs k_i = ((z_(alpha/f_i) + z_power) / z_i)^2 times the moves; the smallest
    k_i of the pooled, focus and path tests is taken (not the best element's: the largest of C
    z-scores overstates its element's effect). None where no such test has evidence for the
    candidate (p >= 0.5), where it takes more than ``max_factor`` times the moves (a different
    recording, not more of the same, would settle it), or where no element and not the path
    is cut by the materiality minimum (more moves make it significant, not material). The
    effect as measured is a noisy estimate, so the probability is nominal."""
    from scipy.stats import norm
    if not (np.any(d.state.gain >= d.min_gain) or d.path.total_gain >= d.min_gain):
        return None
    z_power = float(norm.isf(1.0 - power))
    k = [((norm.isf(d.alpha / f) + z_power) / norm.isf(p)) ** 2
         for name, f, p in decision_tests(d)
         if name != "element" and 0.0 < p < 0.5 and d.alpha / f < 0.5]
    if not k or per_type <= 0 or min(k) > max_factor:
        return None
    return int(math.ceil(max(1.0, min(k)) * per_type - 1e-9))


def record_moves_per_type(n_train_moves: int) -> int:
    """The smallest ``record --moves-per-type`` whose TrainPool holds ``n_train_moves`` moves
    of each type (``data.dataset.n_train``: 7 of 10, 14 of 20)."""
    from ..data.dataset import n_train
    n = max(1, int(n_train_moves))
    while n_train(n) < n_train_moves:
        n += 1
    return n


def train_per_type(mv: _Moves) -> float:
    """The median number of TrainPool moves per move type (the plain types; not type U)."""
    from collections import Counter
    counts = Counter(t for t in mv.types if t != UNKNOWN_MOVE_TYPE)
    return float(np.median(list(counts.values()))) if counts else 0.0


def _suspect(p: _Probe, per_type: float, reference: bool) -> dict[str, Any]:
    """A suspected family's entry: why, the recording that would settle it, its vocabulary
    reading; where only significance is missing, also ``settle_moves_per_type``
    (:func:`moves_to_settle`: TrainPool moves per type) and, as a second way to settle it,
    the same kinds of moves, more of them (the ``record --moves-per-type`` that gives them)."""
    from .families.learned import physical_reading
    entry = {**p.to_dict(), "why": (NO_TOTAL_GAIN if p.decision.material else
                                    "significant but below the materiality minimum"
                                    if p.decision.significant else
                                    "not significant at alpha (p within 10 alpha)"),
             "recording": _family_recording(p.aug, reference),
             "vocabulary": physical_reading(p.aug)}
    if not p.decision.significant:
        m = moves_to_settle(p.decision, per_type)
        entry["settle_moves_per_type"] = m
        if m is not None:
            entry["recording"] += (f"; or the same kinds of moves, about {m} TrainPool moves per "
                                   f"type instead of {per_type:.3g} (record --moves-per-type "
                                   f"{record_moves_per_type(m)})")
    return entry


def _family_recording(aug: Augmentation, reference: bool = False) -> str:
    """The recording that would settle a suspected family; with a ``reference``, a recording
    with command excitation asks for the reference to be recorded the same way (the contrast
    compares gains, and an excited recording gains more from a command-history column than an
    unexcited reference for any robot)."""
    fam = aug.family
    if fam in ("command delay", "command filter", "backlash/hysteresis"):
        return ("record with command excitation (record --excitation 0.05)"
                + (", and the reference the same way" if reference else ""))
    key = {"pose (heading)": "heading", "pose (position)": "position",
           "elapsed time": "time", "gait phase": "phase", "swing": "phase"}.get(fam, "bias")
    return RECORDINGS[key]


def _verdict(report: dict[str, Any]) -> str:
    parts = [e["statement"] for e in report["effects"]]
    res = report["residual"]
    if res["unexplained"]:
        parts.append("unexplained structure left in the 1 s rollout residual, by "
                     + ", ".join(res["unexplained"]) + " (on " + ", ".join(res["channels"][:6])
                     + "); " + "; ".join(res["recording"].values()))
    carried = report.get("reference", {}).get("shared", [])
    if carried:
        parts.append("in the reference as well (the robot's own, carried by the model; not a "
                     "change since it): " + "; ".join(e["statement"] for e in carried))
    uncontrasted = report.get("reference", {}).get("not_comparable", [])
    if uncontrasted:
        parts.append("the reference cannot tell whether these are changes (carried by the "
                     "model): " + "; ".join(e["label"] for e in uncontrasted) + " ("
                     + uncontrasted[0]["why"] + "; " + uncontrasted[0]["recording"] + ")")
    change = report.get("unexplained_change") or {}
    if change.get("significant"):
        parts.append(change["statement"] + "; " + change["recording"])
    carried_change = report.get("reference_change") or {}
    if carried_change.get("significant"):
        parts.append(carried_change["statement"])
    drift = report.get("drift_change") or {}
    if drift.get("named"):
        parts.append(drift["statement"])
    if report["suspected"]:
        parts.append("the data cannot tell: " + ", ".join(
            f"{s['label']} ({s['why']})" for s in report["suspected"]))
    if not parts:
        return ("nothing significant: no probe cuts the held-out rollout error and the residual "
                f"shows no structure (smallest p {res['smallest_p']:.2g})")
    return "found: " + "; ".join(parts) if report["effects"] else "; ".join(parts)
