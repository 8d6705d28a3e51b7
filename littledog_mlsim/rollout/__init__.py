"""Sequential prediction: projections (none, BOUND, alpha-PROJ), rollouts and their metrics.

Public API: :func:`make_projection` and the :class:`Projection` kinds (defined in
:mod:`littledog_mlsim.projection`, a layer below the one-step model and the rollout); :class:`TestMove`,
:func:`prepare_test_moves`, :func:`rollout`, :func:`step`, :func:`rollout_moves`,
:func:`predicted_paths`; :func:`nmse`, :func:`rollout_metrics` and the other error measures.
The learned simulator's stepping object (``learned_sim.LearnedSimulator``) is imported from its
module. Scoring a model (one-step plus rollouts, one schema): :mod:`littledog_mlsim.scoring`.
"""
from __future__ import annotations

from .metrics import (HORIZONS_S, element_error_sum, nmse, nmse_array, nmse_at_horizons,
                      rollout_metrics, xy_error)
from ..projection import (PROJECTION_KINDS, AlphaProjection, BoundProjection, NoProjection,
                          Projection, make_projection, radius_from_quantile)
from .simulate import (TestMove, predicted_paths, prepare_test_move, prepare_test_moves,
                       rollout, rollout_moves, step)

__all__ = ["make_projection", "Projection", "NoProjection", "BoundProjection", "AlphaProjection",
           "PROJECTION_KINDS", "radius_from_quantile", "TestMove", "prepare_test_move",
           "prepare_test_moves", "rollout", "step", "rollout_moves", "predicted_paths", "nmse",
           "nmse_array", "nmse_at_horizons", "rollout_metrics", "xy_error", "element_error_sum",
           "HORIZONS_S"]
