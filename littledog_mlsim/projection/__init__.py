"""Projection of predicted states back towards the TrainPool (paper Section VI).

A foundation below both the one-step model (which stores its TrainPool states as an alpha-PROJ
projection and computes the gate radius at training time) and the rollout (which projects every
predicted state): it depends on :mod:`littledog_mlsim.layout` only.

- :mod:`.kinds`: the projection kinds (none, BOUND, alpha-PROJ and its gated form), the limits
  every kind keeps, their array storage, the gate radius;
- :mod:`.neighbours`: the exact nearest-neighbour search alpha-PROJ uses.

Public API: :func:`make_projection`, :class:`Projection` and its kinds, :data:`PROJECTION_KINDS`,
:func:`enforce_limits`, :func:`leave_move_out_distances`, :func:`radius_from_quantile`,
:func:`gate_radius`, :class:`NearestNeighbour`, :class:`CandidateGroups` (the gate's
shortcut). ``littledog_mlsim.rollout.projection`` re-exports
the same names.
"""
from __future__ import annotations

from .kinds import (GATE_EVERY, GATE_QUANTILE, PROJECTION_FORMAT_VERSION, PROJECTION_KINDS,
                    AlphaProjection, BoundProjection, NoProjection, Projection, enforce_limits,
                    gate_radius, leave_move_out_distances, make_projection,
                    radius_from_quantile, train_scale)
from .neighbours import CandidateGroups, NearestNeighbour

__all__ = ["PROJECTION_KINDS", "PROJECTION_FORMAT_VERSION", "Projection", "NoProjection",
           "BoundProjection", "AlphaProjection", "NearestNeighbour", "make_projection",
           "enforce_limits", "leave_move_out_distances", "radius_from_quantile", "train_scale",
           "GATE_QUANTILE", "GATE_EVERY", "gate_radius", "CandidateGroups"]
