"""The physical route's records: a fitted hypothesis, a finding with its evidence, the result."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..families import FAMILIES
from .channels import CHANNELS

if TYPE_CHECKING:
    from ..stats import Decision

__all__ = ["Hypothesis", "Candidate", "Finding", "PhysIdResult", "HeldOutDecision"]

class Hypothesis(NamedTuple):
    """What is simulated: an effect family on a scope with its plug-in parameters (immutable;
    a tuple, the form the transducer's tasks carry to the worker processes)."""

    family: str
    scope: str
    params: dict[str, Any]


@dataclass(frozen=True)
class Candidate:
    """A hypothesis (family, scope, magnitude, direction, fixed parameters) and its fit so
    far. Frozen: a fitting step returns a new candidate (``dataclasses.replace``)."""

    family: str
    scope: str
    score: float                     # screened summed relative SSE cut (first order)
    magnitude: float                 # first-order estimate (or the fit's starting point)
    direction: np.ndarray | None = None
    fitted: float | None = None      # after the 1-D re-simulation fit
    J: float | None = None           # weighted SSE on the fit moves after the fit
    J0: float | None = None
    profile: list[dict[str, Any]] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)   # fixed parameters (mass position)

    def params(self, mag: float | None = None) -> dict[str, Any]:
        return {**FAMILIES[self.family].params_from(self.fitted if mag is None else mag,
                                                    self.direction), **self.extra}

    def hyp(self, mag: float | None = None) -> Hypothesis:
        return Hypothesis(self.family, self.scope, self.params(mag))


@dataclass(frozen=True)
class HeldOutDecision:
    """What one round's held-out decision compared and chose (method, step 5): the fitted
    shortlist, then a push's twin if it was simulated for the decision (``hypotheses``, the
    first ``n_shortlist`` of them the shortlist); the per-move, per-channel held-out SSE
    (M, 36) of the base (``S0``) and with each hypothesis (``S1``); each one's decision and mean
    per-move cut; the index of the finding (``chosen``)."""

    hypotheses: tuple[Candidate, ...]
    n_shortlist: int
    S0: np.ndarray
    S1: tuple[np.ndarray, ...]
    decisions: tuple["Decision", ...]
    move_cut: tuple[float, ...]
    chosen: int


@dataclass(frozen=True)
class Finding:
    """One identified (or rejected) effect with its evidence."""

    family: str
    scope: str
    params: dict[str, Any]
    statement: str
    significant: bool
    material: bool
    p_value: float
    gain: np.ndarray                 # (36,) held-out SSE cut per channel
    p_channel: np.ndarray
    screening: list[dict[str, Any]]
    profile: list[dict[str, float]]
    horizons_before: dict[str, Any]
    horizons_after: dict[str, Any]
    hyp: Hypothesis
    alternatives: list[dict[str, Any]]
    reference_check: dict[str, Any] | None = None   # with a reference: its comparison
    remainder: dict[str, Any] | None = None   # with a reference: what it leaves (driver.remainder)

    @property
    def accepted(self) -> bool:
        return self.significant and self.material

    def evidence(self) -> dict[str, Any]:
        order = np.argsort(-np.nan_to_num(self.gain, nan=-np.inf))[:8]
        return {"method": "output-error re-simulation (physics transducer)",
                "p_value": self.p_value, "significant": self.significant,
                "material": self.material,
                "held_out_sse_cut": {CHANNELS[j]: _num(self.gain[j]) for j in order},
                "held_out_p": {CHANNELS[j]: _num(self.p_channel[j]) for j in order},
                "total_gain": _num(np.nansum(self.gain)),
                "magnitude_profile": self.profile, "screening_top": self.screening,
                "alternatives": self.alternatives,
                "horizon_errors_before": self.horizons_before,
                "horizon_errors_after": self.horizons_after,
                **({"reference_check": self.reference_check} if self.reference_check else {})}


def _num(x: Any) -> float | None:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


@dataclass
class PhysIdResult:
    findings: list[Finding]          # accepted effects, in the order found
    rejected: list[Finding]          # the best candidate of a round that did not pass
    suspected: list[dict[str, Any]]
    robot: str
    n_fit_moves: int
    n_validation_moves: int
    n_simulations: int
    seconds: float
    alpha: float
    min_gain: float
    library_size: int
    horizons_s: tuple[float, ...]
    baseline_horizons: dict[str, Any]
    notes: list[str] = field(default_factory=list)
    reference: dict[str, Any] | None = None    # with a reference: its moves and twin errors

    def describe(self) -> dict[str, Any]:
        return {"transducer": f"pybullet robot '{self.robot}' (sensor noise off), "
                              "re-simulated from measured states",
                "n_fit_moves": self.n_fit_moves, "n_validation_moves": self.n_validation_moves,
                "n_simulations": self.n_simulations, "seconds": self.seconds,
                "alpha": self.alpha, "min_gain": self.min_gain,
                "library_size": self.library_size, "families": list(FAMILIES),
                "horizons_s": list(self.horizons_s), "channels": list(CHANNELS),
                "baseline_horizon_errors": self.baseline_horizons,
                "rejected": [{"family": f.family, "scope": f.scope, "params": f.params,
                              "statement": f.statement, **f.evidence()} for f in self.rejected],
                "notes": list(self.notes),
                **({"reference": self.reference} if self.reference is not None else {})}
