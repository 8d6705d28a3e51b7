"""An unexplained change since the reference: the data's held-out rollout error against the reference's.

The learned route's search adds a family when a probe of the library cuts the held-out rollout
error. A change the library has no family for cuts nothing, and the search ends with "nothing
significant" although the model rolls out far worse than on the reference. With a reference
recording of the same robot, that excess is measured directly (decision 026):

- the same cross-fitted search model, with the route's final feature set, rolls out both
  datasets' TrainPool moves from measured states (the route's evidence); at the decision
  horizon each move's mean squared residual per state element is divided by the reference's
  mean over its moves, element by element, and averaged over the elements: one score per move;
- the change is **material** when the mean score of the data's moves is at least
  :data:`MIN_RATIO` times the reference's, and **significant** when a one-sided Mann-Whitney U
  test of the data's move scores above the reference's gives p below the route's ``alpha``;
- **where it lives**: the same ratio over the body's nine elements and over each joint scope's
  angles and rates. A scope is *concentrated* when its ratio is at least :data:`CONCENTRATION`
  times the ratio over the rest of the joints (the body's nine elements against all joints);
  among the concentrated scopes within :data:`CONCENTRATION_TOLERANCE` of the most
  concentrated, the widest is kept. With none, the change is spread: ``all`` where the joints'
  ratio is at least the body's, else ``body``. Also by the rollouts' start time in the move and
  by move type.

It names no mechanism: the vocabulary's family is ``other`` and the reading says which
recording would tell more. Nothing is added to the served model for it.
"""
from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np
from scipy import stats

from ..layout import CONTROL_DT, StateLayout
from .families.scopes import joint_scopes, scope_joints, scope_words
from .learned import _joint_elements

__all__ = ["MIN_RATIO", "CONCENTRATION", "CONCENTRATION_TOLERANCE", "RECORDINGS", "move_mse",
           "elements_of", "locate", "where_words", "unexplained_change"]

S = StateLayout()
#: the data's error at least this many times the reference's is material
MIN_RATIO = 1.5
#: a scope's ratio at least this many times the rest's makes the change concentrated there
CONCENTRATION = 2.0
#: concentrated scopes this close to the most concentrated (a fraction of its concentration)
#: are read as the same place, and the widest of them is kept
CONCENTRATION_TOLERANCE = 0.8
BODY = np.arange(S.z_w, S.d_rpy.stop)

#: what to record next, by where the change lives
RECORDINGS = {
    "body": "record the same move types started from several places on the floor and "
            "headings (record --start-spread 0.5), so where the robot is, which way it faces "
            "and how far into a move it is can be told apart",
    "joints": "record with command excitation (record --excitation 0.05), so the set-points of "
              "these joints take histories the gait alone does not give",
}


def move_mse(err: np.ndarray, move: np.ndarray, n_moves: int) -> np.ndarray:
    """(M, 33) each move's mean squared residual per element (rows of ``err`` by ``move``)."""
    out = np.zeros((n_moves, err.shape[1]))
    np.add.at(out, move, err ** 2)
    count = np.bincount(move, minlength=n_moves)
    return out / np.maximum(count, 1)[:, None]


def elements_of(scope: str) -> np.ndarray:
    """State elements of a vocabulary scope: the body's nine, or a joint scope's angles and
    rates."""
    return BODY if scope == "body" else np.array(_joint_elements(scope_joints(scope)))


def _ratio(A: np.ndarray, B: np.ndarray, cols: np.ndarray) -> float:
    a, b = A[:, cols].mean(axis=1).mean(), B[:, cols].mean(axis=1).mean()
    return float(a / b) if b > 0 else float("inf")


def _where(A: np.ndarray, B: np.ndarray) -> tuple[str, dict[str, float], float]:
    """(scope, ratio per scope, concentration of the kept scope) of normalized MSEs A, B."""
    return locate(lambda cols: _ratio(A, B, cols), elements_of)


def locate(ratio: Callable[[np.ndarray], float], elements: Callable[[str], np.ndarray]
           ) -> tuple[str, dict[str, float], float]:
    """Where an excess lives (module doc, "where it lives"): (scope, ratio per scope,
    concentration of the kept scope), given the data's error over the reference's on a set of
    elements or channels (``ratio``) and each vocabulary scope's elements (``elements``:
    ``"body"`` and the joint scopes)."""
    joints = elements("all")
    ratios = {s: ratio(elements(s)) for s in ["body"] + joint_scopes()}
    conc: dict[str, float] = {"body": ratios["body"] / ratios["all"] if ratios["all"] > 0
                              else float("nan")}
    for s in joint_scopes()[1:]:
        rest = ratio(np.setdiff1d(joints, elements(s)))
        conc[s] = ratios[s] / rest if rest > 0 else float("nan")
    best = max((c for c in conc.values() if np.isfinite(c)), default=0.0)
    if best >= CONCENTRATION:
        near = [s for s, c in conc.items() if c >= max(CONCENTRATION,
                                                       CONCENTRATION_TOLERANCE * best)]
        width = {s: (99 if s == "body" else len(scope_joints(s))) for s in near}
        scope = max(near, key=lambda s: (width[s], conc[s]))
        return scope, ratios, conc[scope]
    return ("all" if ratios["all"] >= ratios["body"] else "body"), ratios, 1.0


def _by(keys: np.ndarray, A: np.ndarray, B: np.ndarray, keys_ref: np.ndarray
        ) -> dict[Any, float]:
    out = {}
    for k in sorted(set(keys.tolist()) & set(keys_ref.tolist())):
        a, b = A[keys == k].mean(), B[keys_ref == k].mean()
        out[k] = float(a / b) if b > 0 else float("inf")
    return out


def unexplained_change(err: np.ndarray, move: np.ndarray, t0: np.ndarray, types: Sequence[str],
                       err_ref: np.ndarray, move_ref: np.ndarray, t0_ref: np.ndarray,
                       types_ref: Sequence[str], horizon_s: float, alpha: float
                       ) -> dict[str, Any]:
    """The excess of the data's held-out rollout residual over the reference's (module doc).

    ``err`` (R, 33) the data's residuals at the horizon, ``move`` (R,) their move index,
    ``t0`` (R,) their start step, ``types`` each move's type; the same for the reference.
    """
    n, n_ref = len(types), len(types_ref)
    A = move_mse(err, move, n)
    B = move_mse(err_ref, move_ref, n_ref)
    scale = B.mean(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    A, B = A / scale, B / scale
    score, score_ref = A.mean(axis=1), B.mean(axis=1)
    ratio = float(score.mean() / score_ref.mean())
    p = float(stats.mannwhitneyu(score, score_ref, alternative="greater").pvalue)
    material = ratio >= MIN_RATIO
    significant = bool(material and p < alpha)
    scope, ratios, conc = _where(A, B)
    row = (err ** 2 / scale).mean(axis=1)
    row_ref = (err_ref ** 2 / scale).mean(axis=1)
    start_s = np.floor(t0 * CONTROL_DT).astype(int)
    start_ref = np.floor(t0_ref * CONTROL_DT).astype(int)
    by_start = _by(start_s, row, row_ref, start_ref)
    by_type = _by(np.array(types), score, score_ref, np.array(types_ref))
    out = {"significant": significant, "material": bool(material), "ratio": ratio,
           "p_value": p, "alpha": alpha, "min_ratio": MIN_RATIO, "horizon_s": horizon_s,
           "n_moves": n, "n_reference_moves": n_ref, "scope": scope,
           "concentration": conc, "scope_ratios": ratios,
           "by_start_s": [{"start_s": int(k), "ratio": v} for k, v in by_start.items()],
           "by_type": by_type}
    out["statement"] = _statement(out)
    out["recording"] = RECORDINGS["body" if scope == "body" else "joints"]
    out["vocabulary"] = {"family": "other", "scope": scope,
                         "params": {"error_ratio": round(ratio, 3)},
                         "statement": out["statement"]}
    return out


def where_words(u: dict[str, Any]) -> str:
    """Where an excess lives, in words, from :func:`locate`'s ``scope``, ``concentration`` and
    ``scope_ratios`` in ``u``."""
    where = ("the body's motion" if u["scope"] == "body" else scope_words(u["scope"]))
    if u["concentration"] > 1.0:
        return where + (f" ({u['scope_ratios'][u['scope']]:.1f} times the reference's there, "
                        f"{u['concentration']:.1f} times the rest's ratio)")
    return where + (f" (spread: body {u['scope_ratios']['body']:.1f}x, joints "
                    f"{u['scope_ratios']['all']:.1f}x)")


def _statement(u: dict[str, Any]) -> str:
    where = where_words(u)
    worst_t = sorted(u["by_type"].items(), key=lambda kv: -kv[1])[:3]
    starts = ", ".join(f"{e['start_s']} s {e['ratio']:.1f}x" for e in u["by_start_s"])
    head = (f"an unexplained change since the reference: the held-out {u['horizon_s']:g} s "
            f"rollout error is {u['ratio']:.2f} times the reference's "
            f"(p = {u['p_value']:.2g}, {u['n_moves']} against {u['n_reference_moves']} moves)")
    if not u["significant"]:
        return head + "; not a material and significant change"
    return (head + f"; it lives in {where}; by move type "
            + ", ".join(f"{t} {r:.1f}x" for t, r in worst_t)
            + f"; by the rollout's start in the move {starts}. No family of the library "
            "explains it, so nothing was added to the model for it")
