"""The one-step loop's findings contrasted with a reference (decisions 041 and 042).

With a reference (a recording of the same robot before the change), the rollout route
(:func:`.learned.contrast`) keeps a finding only if it gains more on the data than on the
reference; what gains as much is the robot's own, carried by the model and not a change. The
one-step loop (:mod:`.selection`) asks the same here: each effect it accepted, at the feature
set of its round, is screened again on the reference's TrainPool moves (the same cross-fitted
search model, fitted there), and each move's held-out contribution (``SSEDecision.d``: the
mean over moves is the held-out gain) is compared between the two datasets:

- ``p_state``: Welch's one-sided t-test that the contribution summed over the 33 elements is
  larger on the data's moves than on the reference's;
- ``p_focus`` (a candidate scoped to some joints, not all): the same on those joints' q and dq
  alone (a one-leg change is diluted in the sum over 33 elements), times ``focus_choices``, the
  scopes it was chosen among on the data (:data:`.learned.SCOPES`, as the rollout route counts);
- ``p_change``: ``p_state``, or with a focus test 2 min(``p_state``, ``focus_choices`` x
  ``p_focus``), capped at 1;
- ``max_excess``: the largest difference over the 33 elements between the data's held-out
  gain and the reference's (reported);
- ``changed``: ``p_change`` x ``n_contrasts`` (the loop's effects contrasted) < ``alpha``, and
  the reference's total gain less than ``NEW_SHARE`` (one half) of the data's: at least half of
  what the effect gains on the data is new (decision 042). Significant is not enough, since
  with 77 moves a side a structure both recordings share differs significantly between two
  recordings of the same robot (the data's gain is also the largest of a library's, the
  reference's is not). A share, not an element's excess (decision 041's first rule), since a
  change spread thinly over the elements (a push's heading columns) exceeds the reference on
  no element by much, and an excited recording's totals are 20 times an unexcited one's.

Each dataset's contribution is relative to its own held-out error without the effect, so a
robot's own structure, which cuts both datasets' error alike, reads as not changed whatever the
two recordings' sizes. The report (:func:`.report.build_report`) moves an effect that is not
changed from ``effects`` to ``shared``: the model keeps its columns (its before/after stays as
measured), and ``significant`` does not count it. A family command excitation shows is not
contrasted where the two recordings' excitations differ (decision 031: ``not_comparable``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Sequence

import numpy as np

from ..data.recording import MoveRecording
from ..layout import N_STATE
from ..models.features import Augmentation, FeatureSet

if TYPE_CHECKING:
    from .selection import SearchModel, SelectionResult

__all__ = ["OneStepContrast", "contrast_one_step", "contrast_findings", "screen_one",
           "CONTRAST_ALPHA", "NEW_SHARE"]

CONTRAST_ALPHA = 0.01   # as the rollout route's ``LearnedOptions.contrast_alpha``
NEW_SHARE = 0.5   # changed only if the reference gains less than this share of the data's


@dataclass(frozen=True)
class OneStepContrast:
    """One accepted effect of the one-step loop read against the reference."""

    label: str
    total_gain: float                 # held-out gain on the data (sum over the 33 elements)
    reference_total_gain: float       # the same on the reference
    reference_p_value: float          # the reference's screen of it alone (no library factor)
    reference_significant: bool
    p_state: float
    p_focus: float | None
    focus_choices: int | None
    p_change: float
    n_contrasts: int
    max_excess: float                 # max over elements of (data's gain - reference's)
    changed: bool

    def to_dict(self) -> dict[str, Any]:
        out = {"total_gain": self.total_gain, "reference_total_gain": self.reference_total_gain,
               "reference_p_value": self.reference_p_value,
               "reference_significant": self.reference_significant,
               "p_state": self.p_state, "p_change": self.p_change,
               "n_contrasts": self.n_contrasts, "max_excess": self.max_excess,
               "changed": self.changed}
        if self.p_focus is not None:
            out["p_focus"] = self.p_focus
            out["focus_choices"] = self.focus_choices
        return out


def screen_one(recs: Sequence[MoveRecording], fs: FeatureSet, aug: Augmentation,
               search: "SearchModel", alpha: float, min_gain: float,
               length_scales: np.ndarray | None = None) -> tuple[Any, np.ndarray]:
    """The screen of ``aug`` alone on the moves ``recs`` at the feature set ``fs``: a fresh
    search model of ``search``'s settings fitted there (its own GP length scales, or
    ``length_scales``), the candidate's columns added. Returns (the
    :class:`.stats.SSEDecision` of that one candidate, the length scales used)."""
    from .selection import _fresh, candidate_columns
    from .stats import sse_decision
    if not recs:
        raise ValueError("no TrainPool moves to screen the effect on")
    X, Y, move_index = fs.features_responses(recs)
    m = _fresh(search).fit(X, Y - X[:, :N_STATE], move_index, [r.move_type for r in recs],
                           length_scales)
    S1, _ = m.score(candidate_columns(recs, [aug])[aug.label()])
    return sse_decision(m.sse_, S1, 1, alpha, min_gain), m.length_scales_


def contrast_one_step(aug: Augmentation, d: np.ndarray, on_ref: Any, n_contrasts: int,
                      alpha: float = CONTRAST_ALPHA, new_share: float = NEW_SHARE
                      ) -> OneStepContrast:
    """The contrast of one effect from the data's per-move contributions (M, 33) ``d`` (from
    the round that accepted it) and the reference's screen ``on_ref`` (:func:`screen_one`,
    its ``d`` and ``gain``); see the module doc."""
    from .families.learned import learned_family
    from .learned import SCOPES, scope_elements
    from .stats import welch_greater
    d, d_ref = np.asarray(d, float), np.asarray(on_ref.d, float)
    p_state = welch_greater(d.sum(axis=1), d_ref.sum(axis=1))
    focus = scope_elements(aug)
    p_focus = choices = None
    p = p_state
    if focus:
        choices = len(SCOPES)
        if learned_family(aug.family).scoped_by_columns:   # chosen among 21 (decision 065)
            from dataclasses import replace

            from .selection import narrower_members
            choices = len(narrower_members(replace(aug, joints="all")))
        p_focus = welch_greater(d[:, focus].sum(axis=1), d_ref[:, focus].sum(axis=1))
        p = min(1.0, 2.0 * min(p_state, min(1.0, choices * p_focus)))
    n = max(1, int(n_contrasts))
    per_element = d.mean(axis=0)
    gain, gain_ref = float(per_element.sum()), float(np.sum(on_ref.gain))
    excess = float(np.max(per_element - np.asarray(on_ref.gain, float)))
    new = gain > 0 and gain_ref < new_share * gain
    return OneStepContrast(aug.label(), gain, gain_ref, float(on_ref.p_value),
                           bool(on_ref.significant), float(p_state),
                           None if p_focus is None else float(p_focus), choices, float(p), n,
                           excess, bool(min(1.0, p * n) < alpha and new))


def contrast_findings(sel: "SelectionResult", reference: Sequence[MoveRecording],
                      search: "SearchModel", *, skip: Callable[[Augmentation], bool] | None = None,
                      alpha: float = CONTRAST_ALPHA,
                      progress: Callable[[str], None] | None = None
                      ) -> list[OneStepContrast | None]:
    """The contrast of every effect ``sel`` accepted (aligned with ``sel.accepted``; None for an
    effect ``skip`` says is not contrasted: decision 031's ``not_comparable``)."""
    say = progress or (lambda s: None)
    rounds = [r for r in sel.rounds if r.picked is not None]
    todo = [not (skip and skip(r.picked.augmentation)) for r in rounds]
    out: list[OneStepContrast | None] = []
    for r, contrasted in zip(rounds, todo):
        if not contrasted:
            out.append(None)
            continue
        s = r.picked
        if s.d is None:
            raise ValueError(f"{s.label}: the round kept no per-move contributions")
        on_ref, _ = screen_one(reference, r.feature_set, s.augmentation, search,
                               sel.alpha, sel.min_gain)
        c = contrast_one_step(s.augmentation, s.d, on_ref, sum(todo), alpha)
        say(f"one-step {s.label} against the reference: gain {c.total_gain:.3f} on the data, "
            f"{c.reference_total_gain:.3f} on the reference, p = {c.p_change:.2g}: "
            + ("a change" if c.changed else "the robot's own (in the reference as well)"))
        out.append(c)
    return out
