"""Diagnosis: find what a model of the robot lacks, name it, add it, report before/after.

Two routes share one statistics module and one report:

- :mod:`.physical` (the default when the dataset names a known robot): effects named by
  family x scope x parameter by re-simulating the dataset's robot (the transducer), decided on
  held-out moves; each family is a class in :mod:`.families` (``docs/families.md``);
- :mod:`.selection` (the learned route): cross-fitted residuals of a fast model, held-out
  screening of candidate features (:mod:`.candidates`), forward selection; with a reference,
  its findings contrasted with the reference's (:mod:`.one_step_contrast`);
- :mod:`.stats`: the move-grouped t-tests, the rank test and the decision both routes use;
- :mod:`.run`: :func:`diagnose`, the loop end to end (the ``diagnose`` verb), with
  :class:`.options.DiagnoseOptions`;
- :mod:`.report`: ``report.json`` (schema: ``docs/report.md``) and ``report.md`` with figures;
- :mod:`.physid`: the physical route under its former name (re-exports for tools).
"""
from .candidates import BASELINES, default_library, measured_robot_features, paper_features
from .options import AutoRoute, DiagnoseOptions, LearnedRoute, PhysicalRoute
from .run import diagnose
from .selection import (DEFAULT_ALPHA, DEFAULT_MIN_GAIN, CandidateScore, SearchModel,
                        SelectionResult, select_effects)

__all__ = ["diagnose", "DiagnoseOptions", "PhysicalRoute", "LearnedRoute", "AutoRoute", "select_effects", "SearchModel", "SelectionResult", "CandidateScore",
           "default_library", "measured_robot_features", "paper_features", "BASELINES",
           "DEFAULT_ALPHA", "DEFAULT_MIN_GAIN"]
