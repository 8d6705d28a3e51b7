"""Screening candidate effects against cross-fitted one-step residuals; forward selection.

Method (and why)
----------------
1. **Search model, cross-fitted by move.** The residual the candidates are screened against is
   that of a fast flexible model of the one-step change r = s_{t+1} - s_t, fitted K times with
   the moves split into K folds (stratified by move type; default K = 5) and evaluated on the
   held-out fold only, so an overfitting model cannot hide structure and the residual of a move
   never comes from a model that saw it. The search model (:class:`SearchModel`) is ridge
   regression on random Fourier features of the 45 paper features with ARD length scales taken
   from a GP (shared kernel) fitted on a random subset: a GP approximation whose cross-fitting is
   closed-form (the Gram matrix of every fold is the total minus the fold's), about as accurate
   as LGPR with 500-point clusters on this data and 10-50x cheaper to cross-fit. Effects already
   accepted enter it as linear terms; LR (the paper's baseline) is not used: its residual is full
   of the nonlinearity of (s_t, u_t) itself, which every nonlinear candidate then "explains"
   (on clean data LR made x_w, y_w and clipped tracking errors look like 10-25 % effects).
2. **Screening: held-out explained residual variance.** Each candidate's columns are added to the
   search model as an additive linear term (a structured correction ``Z beta`` next to the
   flexible base) and the cross-fit is repeated (exactly, by a Schur complement on the fold Gram
   matrices: the held-out residual becomes r0 - (Z - B G^-1 B'Z) beta). The score of candidate c
   for state element j is the relative cut of the held-out MSE,
   ``gain_j = 1 - SSE_j(with c) / SSE_j(without)``, i.e. the held-out nMSE cut of that element.
3. **Significance, grouped by move.** A move is the independent unit (samples within a move are
   strongly autocorrelated; treating them as independent inflates significance by ~100x). Per
   move m the contribution d_mj = M (SSE0_mj - SSE1_mj) / SSE0_j has mean gain_j; one-sided
   t-tests across the M moves (M - 1 degrees of freedom) test the pooled gain (sum over the 33
   elements: an effect spread over many elements, like a delay on all joints) and each
   element's gain. The candidate's ``p_value`` is Bonferroni-adjusted over the two tests, the 33
   elements and the library size, so ``p_value < alpha`` (default 0.01) bounds the chance of
   any false alarm in a round.
4. **Materiality.** Significant is not enough (with enough data everything is): an effect counts
   only if it also cuts the held-out nMSE of at least one element by ``min_gain`` (default 5 %,
   see ``benchmarks/diagnose/diagnose.md`` for why not 10 %) with that element's own p < alpha. Its
   ``outputs`` are the elements with p < alpha and gain >= ``min_gain / 2``.
5. **Forward selection.** The family of the significant and material candidate with the largest
   total held-out gain (summed over the 33 elements) is detected; its parameters are estimated
   within the family: the delay's scope where its gain lands (each side's and leg's joints
   against the others, :func:`.families.learned.delay_scope`), then the delay in steps by
   refitting the search model with u_t of that scope's joints *replaced* by u_{t-d} for every
   d on the grid and taking the d after which the fit falls off
   (:func:`delay_scan`, :func:`delay_from_scan`; as an added column every lag up to the delay
   helps about equally, so the augmentation profile cannot tell d apart), other families by
   parsimony among the near-best members (:func:`estimate_member`); a family whose columns are
   per joint (the play band) is screened at all joints only and then scoped by the subsets of
   the detected member's columns (:func:`scope_by_columns`, decision 065). The scan is also a
   cross-check: command columns that help while the scan puts the fall-off at d = 0 are not a
   delay, and the family is not accepted (the next detected family is considered instead).
   The accepted member joins the model and the next round screens the rest against the new
   residual, until none is significant and material.

Residual-input cross-correlation (Ljung's whiteness test) is reported as evidence for command
families (:func:`residual_input_ccf`), not used to select: on open-loop trot data the commands
are smooth and periodic, so the raw cross-correlation of a residual with u is broad and peaks
for every lag. Sparse regression over the whole library (lasso) was not used either: the
candidates are near-collinear by construction (u_{t-1}, u_{t-2}, ... of the same smooth
signal), where the lasso picks among them arbitrarily; explicit held-out comparison within a
family estimates the parameter instead.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Sequence

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..data.recording import MoveRecording
from ..layout import MOVE_TYPES, N_FEATURE, N_STATE, STATE_NAMES
from ..models.feature_library import JOINT_GROUPS
from ..models.features import Augmentation, CommandLag, FeatureSet
from .families.learned import DELAY_TOLERANCE, learned_family
from .stats import SSEDecision, sse_decision  # re-exported (physics.py imports them here)

__all__ = ["SearchModel", "CandidateScore", "Round", "SelectionResult", "move_folds",
           "screen", "select_effects", "candidate_columns", "residual_input_ccf",
           "DEFAULT_ALPHA", "DEFAULT_MIN_GAIN", "sse_decision", "SSEDecision"]

DEFAULT_ALPHA = 0.01
DEFAULT_MIN_GAIN = 0.05


def move_folds(move_types: Sequence[str], n_folds: int, seed: int = 0) -> np.ndarray:
    """Fold number (M,) of each move: shuffled within each move type, then dealt round-robin
    (continuing across types), so every fold holds about the same mix of types."""
    rng = np.random.default_rng(seed)
    folds = np.empty(len(move_types), dtype=np.int64)
    k = 0
    types = sorted(set(move_types), key=lambda t: MOVE_TYPES.index(t) if t in MOVE_TYPES else 99)
    for t in types:
        idx = np.flatnonzero(np.asarray(move_types) == t)
        for i in rng.permutation(idx):
            folds[i] = k % n_folds
            k += 1
    return folds


def _standardise(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    mean = A.mean(axis=0)
    std = A.std(axis=0)
    std = np.where(std < 1e-12, 1.0, std)
    return (A - mean) / std, mean, std


class SearchModel:
    """Cross-fitted RFF ridge model of the normalised one-step change (see module doc).

    Args:
        n_random_features: random Fourier features M of the 45 paper features.
        ridge: ridge penalty (on standardised columns and targets).
        length_scale_factor: the GP's length scales are multiplied by this for the features
            (slightly shorter than the GP optimum fits the whole pool better).
        n_gp_points, gp_max_iter: the GP fitted for the length scales.
        n_folds: cross-fitting folds (by move, stratified by type).
        seed: all randomness (subset, features, folds).

    After :meth:`fit`: ``residual_`` (n, 33) held-out residuals in units of the standardised
    change, ``sse_`` (M, 33) per-move held-out SSE, ``fold_of_move_`` (M,), ``length_scales_``.
    """

    def __init__(self, n_random_features: int = 1000, ridge: float = 0.05,
                 length_scale_factor: float = 0.7, n_gp_points: int = 600, gp_max_iter: int = 50,
                 n_folds: int = 5, seed: int = 0) -> None:
        self.n_random_features = n_random_features
        self.ridge = ridge
        self.length_scale_factor = length_scale_factor
        self.n_gp_points = n_gp_points
        self.gp_max_iter = gp_max_iter
        self.n_folds = n_folds
        self.seed = seed

    def describe(self) -> dict[str, Any]:
        return {"kind": "rff_ridge_ard", "n_random_features": self.n_random_features,
                "ridge": self.ridge, "length_scale_factor": self.length_scale_factor,
                "n_gp_points": self.n_gp_points, "n_folds": self.n_folds, "seed": self.seed}

    def fit_length_scales(self, Xb_n: np.ndarray, Dn: np.ndarray) -> np.ndarray:
        from ..models.gp import fit_gp_hyperparameters, unpack_log_params
        rng = np.random.default_rng(self.seed)
        m = min(self.n_gp_points, Xb_n.shape[0])
        sub = np.sort(rng.choice(Xb_n.shape[0], size=m, replace=False))
        fit = fit_gp_hyperparameters(Xb_n[sub], Dn[sub], shared=True, max_iter=self.gp_max_iter)
        return np.asarray(unpack_log_params(fit.log_params[0])[1], dtype=np.float64).ravel()

    def fit(self, X: np.ndarray, D: np.ndarray, move_index: np.ndarray,
            move_types: Sequence[str], length_scales: np.ndarray | None = None
            ) -> "SearchModel":
        """X (n, 45 + k) features (the first 45 the paper's), D (n, 33) one-step changes,
        move_index (n,) into ``move_types`` (M,). ``length_scales`` (45,) reuses a GP fit."""
        X = np.asarray(X, dtype=np.float64)
        D = np.asarray(D, dtype=np.float64)
        self.n_moves_ = len(move_types)
        self.move_index_ = np.asarray(move_index, dtype=np.int64)
        Dn, self.d_mean_, self.d_std_ = _standardise(D)
        Xn, _, _ = _standardise(X)
        Xb = Xn[:, :N_FEATURE]
        self.length_scales_ = (self.fit_length_scales(Xb, Dn) if length_scales is None
                               else np.asarray(length_scales, dtype=np.float64))
        rng = np.random.default_rng(self.seed + 1)
        M = self.n_random_features
        W = rng.standard_normal((N_FEATURE, M)) / (self.length_scale_factor
                                                    * self.length_scales_[:, None])
        b = rng.uniform(0.0, 2.0 * np.pi, M)
        B = np.empty((X.shape[0], M + X.shape[1] + 1))
        B[:, :M] = np.sqrt(2.0 / M) * np.cos(Xb @ W + b)
        B[:, M:M + X.shape[1]] = Xn
        B[:, -1] = 1.0
        self.Dn_ = Dn
        self.fold_of_move_ = move_folds(move_types, self.n_folds, self.seed)
        self.fold_ = self.fold_of_move_[self.move_index_]
        K = self.n_folds
        self.rows_ = [np.flatnonzero(self.fold_ == f) for f in range(K)]
        # each fold's rows of the design, copied once: every candidate's fit reads them (the
        # whole design is dropped, so it is held once)
        self.B_f_ = [B[r] for r in self.rows_]
        del B
        # a fold's rows times a copy of them, two operands: the general product (one array
        # times its own transpose takes the symmetric one, whose sums differ in the last bits)
        G_f = [Bf.T @ Bf.copy() for Bf in self.B_f_]
        b_f = [Bf.T @ Dn[r] for Bf, r in zip(self.B_f_, self.rows_)]
        G_all, b_all = sum(G_f), sum(b_f)
        eye = self.ridge * np.eye(G_all.shape[0])
        self.chol_, self.W0_ = [], []
        res = np.empty_like(Dn)
        for f in range(K):
            c = cho_factor(G_all - G_f[f] + eye)
            W0 = cho_solve(c, b_all - b_f[f])
            self.chol_.append(c)
            self.W0_.append(W0)
            r = self.rows_[f]
            res[r] = Dn[r] - self.B_f_[f] @ W0
        self.residual_ = res
        self.sse_ = self._per_move_sse(res)
        return self

    @property
    def B_(self) -> np.ndarray:
        """The design (n, M + 46): random features, the standardised inputs and a constant."""
        out = np.empty((len(self.fold_), self.B_f_[0].shape[1]))
        for r, Bf in zip(self.rows_, self.B_f_):
            out[r] = Bf
        return out

    def _per_move_sse(self, res: np.ndarray) -> np.ndarray:
        out = np.zeros((self.n_moves_, res.shape[1]))
        np.add.at(out, self.move_index_, res ** 2)
        return out

    def candidate_fit(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cross-fit with the columns Z (n, q) added linearly: (held-out residual (n, 33),
        held-out correction Z~ beta (n, 33), i.e. residual = residual_ - correction)."""
        Zs, _, _ = _standardise(np.asarray(Z, dtype=np.float64))
        Dn = self.Dn_
        q = Zs.shape[1]
        # fold pieces of B'Z, Z'Z, Z'D
        BZ_f = [Bf.T @ Zs[r] for Bf, r in zip(self.B_f_, self.rows_)]
        ZZ_f = [Zs[r].T @ Zs[r] for r in self.rows_]
        ZD_f = [Zs[r].T @ Dn[r] for r in self.rows_]
        BZ, ZZ, ZD = sum(BZ_f), sum(ZZ_f), sum(ZD_f)
        corr = np.empty_like(Dn)
        for f, r in enumerate(self.rows_):
            BZt = BZ - BZ_f[f]
            GiBZ = cho_solve(self.chol_[f], BZt)
            Szz = ZZ - ZZ_f[f] - BZt.T @ GiBZ + self.ridge * np.eye(q)
            Szd = ZD - ZD_f[f] - BZt.T @ self.W0_[f]
            beta = np.linalg.solve(Szz, Szd)
            corr[r] = (Zs[r] - self.B_f_[f] @ GiBZ) @ beta
        return self.residual_ - corr, corr

    def score(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(per-move held-out SSE (M, 33) with Z added, held-out correction (n, 33))."""
        res, corr = self.candidate_fit(Z)
        return self._per_move_sse(res), corr


@dataclass
class CandidateScore:
    """One candidate screened in one round."""

    augmentation: Augmentation
    gain: np.ndarray          # (33,) held-out nMSE cut per element (1 - SSE1 / SSE0)
    p_element: np.ndarray     # (33,) one-sided t-test p per element (unadjusted)
    p_adjusted: np.ndarray    # (33,) Bonferroni over elements and library
    n_moves_better: np.ndarray  # (33,) moves whose held-out SSE went down
    significant: bool
    material: bool
    outputs: list[str]
    total_gain: float         # sum of gain over all 33 elements (the pooled statistic's mean)
    p_value: float            # adjusted over the tests and the library: significant iff < alpha
    p_pooled: float           # unadjusted p of the pooled (all-element) test
    d: np.ndarray | None = field(default=None, repr=False)  # (M, 33) per-move contributions

    @property
    def label(self) -> str:
        return self.augmentation.label()

    @property
    def max_gain(self) -> float:
        return float(np.nanmax(self.gain))

    def to_dict(self) -> dict[str, Any]:
        order = np.argsort(-self.gain)[:5]
        return {"candidate": self.label, "family": self.augmentation.family,
                "params": self.augmentation.params(), "p_value": self.p_value,
                "p_pooled": self.p_pooled,
                "significant": self.significant, "material": self.material,
                "max_gain": self.max_gain, "total_gain": self.total_gain,
                "outputs": self.outputs,
                "top_gains": {STATE_NAMES[j]: float(self.gain[j]) for j in order}}


def _score_from_sse(aug: Augmentation, S0: np.ndarray, S1: np.ndarray, n_library: int,
                    alpha: float, min_gain: float) -> CandidateScore:
    """Gains, tests and the decision for one candidate from per-move held-out SSEs (M, 33)."""
    r = sse_decision(S0, S1, n_library, alpha, min_gain)
    p_adj = np.minimum(1.0, r.p_element * n_library * 2.0 * N_STATE)
    return CandidateScore(aug, r.gain, r.p_element, p_adj, (r.d > 0).sum(axis=0), r.significant,
                          r.material, r.outputs, float(r.gain.sum()), r.p_value, r.p_pooled, r.d)


def candidate_columns(recs: Sequence[MoveRecording], library: Sequence[Augmentation]
                      ) -> dict[str, np.ndarray]:
    """Extra columns of every candidate on ``recs`` (rows as ``features_responses``)."""
    from ..models.features import batch_columns
    return {a.label(): c for a, c in zip(library, batch_columns(recs, library))}


def screen(model: SearchModel, columns: dict[str, np.ndarray],
           library: Sequence[Augmentation], *, alpha: float = DEFAULT_ALPHA,
           min_gain: float = DEFAULT_MIN_GAIN, n_library: int | None = None
           ) -> list[CandidateScore]:
    """Score every candidate of ``library`` (columns precomputed) against ``model``."""
    n_lib = n_library if n_library is not None else len(library)
    out = []
    for a in library:
        S1, _ = model.score(columns[a.label()])
        out.append(_score_from_sse(a, model.sse_, S1, n_lib, alpha, min_gain))
    return out


def estimate_member(family: str, scores: Sequence[CandidateScore],
                    delay_tolerance: float = DELAY_TOLERANCE) -> CandidateScore:
    """The member of a detected feature family that states its parameters (see module doc,
    step 5): the family's own rule (:meth:`.families.learned.LearnedFamily.estimate_member`),
    the largest lag near the best for a command delay, parsimony for the others."""
    return learned_family(family).estimate_member(scores, delay_tolerance)


@dataclass
class Round:
    """One round of forward selection: the feature set screened and what was found."""

    index: int
    feature_set: FeatureSet           # before this round's pick
    scores: list[CandidateScore]
    picked: CandidateScore | None     # the member added (its family was detected)
    residual: np.ndarray              # (n, 33) held-out residual before the pick (std units)
    correction: np.ndarray | None     # (n, 33) held-out correction of the picked candidate
    search_nmse: np.ndarray           # (33,) held-out nMSE of the search model (TrainPool)
    seconds: float
    delay_profile: list[dict[str, Any]] | None = None  # command delay: the replacement scan
    notes: list[str] = field(default_factory=list)     # e.g. a family the cross-check rejected
    ccf: dict[str, Any] | None = None  # command delay: residual-input cross-correlation (evidence)


@dataclass
class SelectionResult:
    rounds: list[Round]
    feature_set: FeatureSet           # start + every accepted effect
    start: FeatureSet
    move_types: list[str]
    move_index: np.ndarray
    search_model: dict[str, Any] = field(default_factory=dict)
    alpha: float = DEFAULT_ALPHA
    min_gain: float = DEFAULT_MIN_GAIN
    library: list[Augmentation] = field(default_factory=list)

    @property
    def accepted(self) -> list[CandidateScore]:
        return [r.picked for r in self.rounds if r.picked is not None]

    @property
    def significant(self) -> bool:
        return bool(self.accepted)


def _fresh(search: SearchModel) -> SearchModel:
    """An unfitted search model with the settings of ``search``."""
    return SearchModel(**{k: getattr(search, k) for k in (
        "n_random_features", "ridge", "length_scale_factor", "n_gp_points", "gp_max_iter",
        "n_folds", "seed")})


def _already_in(aug: Augmentation, fs: FeatureSet) -> bool:
    """True if ``aug`` is in ``fs`` or shares a column with it (it could not be added)."""
    return bool(set(aug.columns()) & set(fs.extra_names))


def select_effects(train: Sequence[MoveRecording], start: FeatureSet | None = None,
                   library: Sequence[Augmentation] | None = None, *,
                   search: SearchModel | None = None, alpha: float = DEFAULT_ALPHA,
                   min_gain: float = DEFAULT_MIN_GAIN, max_rounds: int = 4,
                   progress: Callable[[str], None] | None = None,
                   scope_by_columns: bool = True) -> SelectionResult:
    """Forward selection of effects on the TrainPool recordings ``train`` (see module doc;
    ``scope_by_columns`` False leaves a detected member of a family whose columns are per
    joint at the library's scope: decision 065's comparison)."""
    from .candidates import default_library
    start = FeatureSet() if start is None else start
    library = list(default_library() if library is None else library)
    search = SearchModel() if search is None else search
    say = progress or (lambda s: None)
    move_types = [r.move_type for r in train]
    t0 = time.perf_counter()
    columns = candidate_columns(train, library)
    say(f"computed {len(library)} candidate feature sets in {time.perf_counter() - t0:.1f} s")
    fs = start
    rounds: list[Round] = []
    length_scales = None
    move_index = None
    for k in range(max_rounds + 1):
        t1 = time.perf_counter()
        X, Y, move_index = fs.features_responses(train)
        D = Y - X[:, :N_STATE]
        m = _fresh(search).fit(X, D, move_index, move_types, length_scales)
        length_scales = m.length_scales_
        var = Y.var(axis=0) / m.d_std_ ** 2
        search_nmse = np.where(var > 1e-24, (m.residual_ ** 2).mean(axis=0)
                               / np.where(var > 1e-24, var, 1.0), np.nan)
        todo = [a for a in library if not _already_in(a, fs)]
        scores = screen(m, columns, todo, alpha=alpha, min_gain=min_gain,
                        n_library=len(library))
        ok = [s for s in scores if s.significant and s.material]
        picked, delay_profile, ccf, notes = (
            _pick(m, X, D, move_index, move_types, columns, scores, ok, say,
                  (len(library), alpha, min_gain) if scope_by_columns else None)
            if k < max_rounds else (None, None, None, []))
        corr = m.candidate_fit(columns[picked.label])[1] if picked is not None else None
        rounds.append(Round(k, fs, scores, picked, m.residual_, corr, search_nmse,
                            time.perf_counter() - t1, delay_profile, notes, ccf))
        if picked is None:
            say(f"round {k}: no effect accepted "
                f"({sum(s.significant for s in scores)} significant, best gain "
                f"{max(s.max_gain for s in scores):.3f}) in {time.perf_counter() - t1:.1f} s")
            break
        say(f"round {k}: {picked.label} ({picked.augmentation.family}), p = "
            f"{picked.p_value:.2g}, max gain {picked.max_gain:.3f} on "
            f"{', '.join(picked.outputs[:4])}{' ...' if len(picked.outputs) > 4 else ''} "
            f"in {time.perf_counter() - t1:.1f} s")
        fs = fs.with_augmentation(picked.augmentation)
    return SelectionResult(rounds=rounds, feature_set=fs, start=start, move_types=move_types,
                           move_index=move_index, search_model=search.describe(), alpha=alpha,
                           min_gain=min_gain, library=library)


def _pick(m: SearchModel, X: np.ndarray, D: np.ndarray, move_index: np.ndarray,
          move_types: Sequence[str], columns: dict[str, np.ndarray],
          scores: Sequence[CandidateScore], ok: Sequence[CandidateScore],
          say: Callable[[str], None],
          scoping: tuple[int, float, float] | None = None
          ) -> tuple[CandidateScore | None, list[dict[str, Any]] | None, dict[str, Any] | None,
                     list[str]]:
    """The member picked among the significant and material candidates ``ok`` (module doc,
    step 5): (picked or None, delay profile, residual-input ccf, notes). ``scoping`` (the
    library's size, alpha, min_gain): a family whose columns are per joint is scoped by
    :func:`scope_by_columns`."""
    picked = None
    delay_profile = None
    ccf = None
    notes: list[str] = []
    families = sorted({s.augmentation.family for s in ok},
                      key=lambda f: -max(c.total_gain for c in ok
                                         if c.augmentation.family == f))
    for family in families:
        members = [s for s in scores if s.augmentation.family == family]
        picked = estimate_member(family, members)
        if not learned_family(family).scans_delay:
            if scoping is not None and learned_family(family).scoped_by_columns:
                picked, note = scope_by_columns(m, columns, picked, *scoping)
                if note:
                    notes.append(note)
                    say(note)
            break
        # the scan replaces the commands of the joints the picked lag is scoped to; a scope
        # whose own lag at the scan's delay does not pass is tried again at all joints
        scoped = picked.augmentation.joints if picked.augmentation.name == "command_lag" \
            else "all"
        accepted = False
        for joints in dict.fromkeys((scoped, "all")):
            by_lag = {s.augmentation.lag: s for s in members if s.augmentation.name ==
                      "command_lag" and s.augmentation.joints == joints}
            delay_profile = delay_scan(m, X, D, move_index, move_types, columns,
                                       sorted(by_lag), joints)
            d_hat = delay_from_scan(delay_profile)
            where = "" if joints == "all" else f" of the {joints} joints"
            say(f"delay scan (u_t{where} replaced by u_t-d): " + ", ".join(
                f"d={r['delay']}: {r['total_gain']:+.3f}" for r in delay_profile)
                + f" -> delay {d_hat}")
            if d_hat in by_lag and any(s is by_lag[d_hat] for s in ok):
                picked = by_lag[d_hat]
                ccf = _command_ccf(m.residual_, X, move_index, picked)
                accepted = True
                break
            # the replacement scan sees no delay, or a delay whose own column is not
            # significant and material (e.g. already in the model): not a delay here
            scan = ", ".join(f"d={r['delay']}: {r['total_gain']:+.2f}" for r in delay_profile)
            why = ("puts the fall-off at d = 0 (no delay)" if d_hat not in by_lag else
                   f"puts the fall-off at d = {d_hat}, whose u_(t-{d_hat}){where} column is "
                   "not significant and material by itself")
            notes.append("command-delay candidates were significant and material, but the "
                         f"delay scan{where} {why}: not accepted; scan " + scan)
            say(notes[-1])
        if accepted:
            break
        picked, delay_profile = None, None
    return picked, delay_profile, ccf, notes


def narrower_members(aug: Augmentation) -> list[Augmentation]:
    """``aug`` at every joint group strictly inside its own (joint types, legs, sides, single
    joints; ``JOINT_GROUPS``), none for a family without a joint scope."""
    if "joints" not in aug.params():
        return []
    inside = set(JOINT_GROUPS[aug.joints])
    return [replace(aug, joints=g) for g, js in JOINT_GROUPS.items()
            if set(js) < inside]


def scope_by_columns(model: SearchModel, columns: dict[str, np.ndarray],
                     picked: CandidateScore, n_library: int, alpha: float, min_gain: float,
                     tolerance: float = DELAY_TOLERANCE) -> tuple[CandidateScore, str]:
    """Decision 065: the scope of a detected member whose columns are per joint (a play band's
    position: ``LearnedFamily.scoped_by_columns``). The library screens such a family at all
    joints only; each narrower joint group's member has a subset of the detected member's
    columns (taken from them, not computed again), is scored against the same model, at the
    library's Bonferroni factor, and counts where it is significant and material. Of the
    detected member and those, parsimony as within a family (the fewest columns among the
    members within ``tolerance`` of the best total gain): a play band at one knee is named
    there, not at all joints. Returns (the member, a note for the log; empty where no
    narrower member was scored)."""
    aug = picked.augmentation
    names = list(aug.columns())
    full = columns[picked.label]
    narrower = narrower_members(aug)
    if not narrower:
        return picked, ""
    for a in narrower:
        if a.label() not in columns:
            columns[a.label()] = full[:, [names.index(c) for c in a.columns()]]
    scored = screen(model, columns, narrower, alpha=alpha, min_gain=min_gain,
                    n_library=n_library)
    ok = [picked] + [s for s in scored if s.significant and s.material]
    best = max(s.total_gain for s in ok)
    near = [s for s in ok if s.total_gain >= (1.0 - tolerance) * best]
    chosen = min(near, key=lambda s: (len(s.augmentation.columns()), -s.total_gain))
    top = sorted(scored, key=lambda s: -s.total_gain)[:3]
    note = (f"{aug.family} scoped by its columns: {chosen.label} (total gain "
            f"{chosen.total_gain:+.3f}; detected {picked.label} {picked.total_gain:+.3f}; "
            f"{len(ok) - 1} of {len(narrower)} narrower significant and material; best "
            + ", ".join(f"{s.augmentation.params()['joints']} {s.total_gain:+.3f}"
                        for s in top) + ")")
    return chosen, note


def delay_scan(model: SearchModel, X: np.ndarray, D: np.ndarray, move_index: np.ndarray,
               move_types: Sequence[str], columns: dict[str, np.ndarray],
               lags: Sequence[int], joints: str = "all") -> list[dict[str, Any]]:
    """The command-delay estimate: refit the search model with u_t replaced by u_{t-d} (of the
    ``joints`` group only; the other joints keep u_t).

    A delay of d steps means the servo acts on u_{t-d}; the search model that is given that
    command instead of u_t (in its nonlinear map as well as linearly) fits the held-out data
    best at the true d (system identification's delay estimate by comparing model fits over
    candidate delays). Returns, for d = 0 (the current model) and each lag, the total held-out
    gain over the 33 elements relative to d = 0 and the per-element gains.
    """
    out = [{"delay": 0, "total_gain": 0.0, "gain": [0.0] * N_STATE}]
    tot0 = model.sse_.sum(axis=0)
    tot0 = np.where(tot0 > 0, tot0, 1.0)
    for d in lags:
        Xd = np.array(X, copy=True)
        Xd[:, [N_STATE + j for j in JOINT_GROUPS[joints]]] = \
            columns[CommandLag(lag=d, joints=joints).label()]
        md = _fresh(model).fit(Xd, D, move_index, move_types, model.length_scales_)
        gain = 1.0 - md.sse_.sum(axis=0) / tot0
        out.append({"delay": int(d), "total_gain": float(gain.sum()),
                    "gain": [float(g) for g in gain]})
    return out


def delay_from_scan(profile: Sequence[dict[str, Any]]) -> int:
    """The delay estimate from :func:`delay_scan`: the d after which the fit falls off.

    Given u_{t-d} with d up to the true delay, the model still sees the command being applied
    (or a newer one, from which, with the state, it infers it), so its fit changes little; one
    step older and the applied command is gone, so the held-out gain drops sharply (measured on
    clean and delayed data, ``benchmarks/diagnose/diagnose.md``; the best single d is less reliable: a
    command a step newer than the applied one often fits as well or better). The estimate is the
    d before the largest one-step drop of the total gain; 0 means no delay.
    """
    prof = sorted(profile, key=lambda r: r["delay"])
    drops = [(prof[i]["total_gain"] - prof[i + 1]["total_gain"], prof[i]["delay"])
             for i in range(len(prof) - 1)]
    return int(max(drops)[1]) if drops else 0


CCF_LAGS = tuple(range(-3, 9))


def _command_ccf(residual: np.ndarray, X: np.ndarray, move_index: np.ndarray,
                 picked: CandidateScore) -> dict[str, Any]:
    """Cross-correlation of the held-out residual of the most improved joint elements with the
    increments of that joint's command, u_{t-k} - u_{t-k-1}, at lags k (Ljung's residual-input
    test, as evidence for a command delay)."""
    U = X[:, N_STATE:N_FEATURE]
    dU = np.zeros_like(U)
    for mv in np.unique(move_index):
        idx = np.flatnonzero(move_index == mv)
        dU[idx[1:]] = np.diff(U[idx], axis=0)
    joint_el = [j for j in np.argsort(-picked.gain) if STATE_NAMES[j].startswith(("q_", "dq_"))]
    out: dict[str, Any] = {"lags": list(CCF_LAGS), "ccf": {}}
    for j in joint_el[:3]:
        name = STATE_NAMES[j]
        joint = name.split("_", 1)[1]
        i = [n.split("_", 1)[1] for n in STATE_NAMES[9:21]].index(joint)
        out["ccf"][name] = [float(v) for v in
                            residual_input_ccf(residual[:, j], dU[:, i], move_index, CCF_LAGS)]
    n_eff = len(np.unique(move_index)) * 20  # ~20 independent samples per 4 s move (trot period)
    out["band_95"] = 1.96 / math.sqrt(n_eff)
    return out


def residual_input_ccf(residual: np.ndarray, inputs: np.ndarray, move_index: np.ndarray,
                       lags: Sequence[int]) -> np.ndarray:
    """Cross-correlation of a residual r_t (n,) with an input x_{t-k} (n,) at each lag k, within
    moves (pairs never straddle two moves), per lag: (len(lags),)."""
    out = []
    for k in lags:
        a, b = [], []
        for m in np.unique(move_index):
            idx = np.flatnonzero(move_index == m)
            r, x = residual[idx], inputs[idx]
            if k >= 0:
                a.append(r[k:])
                b.append(x[:len(x) - k])
            else:
                a.append(r[:k])
                b.append(x[-k:])
        a, b = np.concatenate(a), np.concatenate(b)
        a = a - a.mean()
        b = b - b.mean()
        den = math.sqrt(float(a @ a) * float(b @ b))
        out.append(float(a @ b) / den if den > 0 else 0.0)
    return np.array(out)


def _stderr(text: str) -> None:
    print(f"diagnose: {text}", file=sys.stderr, flush=True)
