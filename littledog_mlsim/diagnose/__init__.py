"""Diagnosis: find what the one-step model lacks in its residual, add it, report before/after.

- :mod:`.candidates`: the library of candidate effects (feature transforms a simulator can
  compute online, :mod:`..models.features`) and the default model's feature set;
- :mod:`.selection`: cross-fitted residuals, held-out screening with a grouped significance
  test, forward selection;
- :mod:`.run`: :func:`diagnose`, the loop end to end (the ``diagnose`` verb);
- :mod:`.report`: ``report.json`` (schema in its docstring) and ``report.md`` with figures;
- :mod:`.physics`: the same loop pointed at the physics baseline (``diagnose_physics``: its
  residual traced to a missing parameter by re-simulation, calibrated; imported on its own, it
  needs pybullet: ``benchmarks/physics_diagnosis/physics_diagnosis.py``).
"""
from .candidates import BASELINES, default_library, measured_robot_features, paper_features
from .run import diagnose
from .selection import (DEFAULT_ALPHA, DEFAULT_MIN_GAIN, CandidateScore, SearchModel,
                        SelectionResult, select_effects)

__all__ = ["diagnose", "select_effects", "SearchModel", "SelectionResult", "CandidateScore",
           "default_library", "measured_robot_features", "paper_features", "BASELINES",
           "DEFAULT_ALPHA", "DEFAULT_MIN_GAIN"]
