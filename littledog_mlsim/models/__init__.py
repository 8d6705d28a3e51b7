"""One-step regressors (LR, LWPR, GPR, SoR, LGPR), the one-step model and their files.

Public API:

- the estimator contract (:mod:`.base`): :class:`Regressor`, :class:`NotFittedError`,
  :class:`StdNotSupportedError`;
- the registry of methods: :data:`METHODS` (name -> estimator class, every built-in one
  registered on import), :data:`METHOD_NAMES` (the paper's five, in the paper's order),
  :func:`get_method`, :func:`register`, :func:`make_estimator`;
- :class:`OneStepModel` (what training produces and everything else consumes) and
  :func:`fit_onestep` (the one recipe that fits it);
- model files: :func:`save_model`, :func:`load_model`, :func:`read_model`,
  :class:`ModelError`;
- :class:`FeatureSet` (the paper's 45 inputs plus named augmentations).
"""
from __future__ import annotations

from .base import NotFittedError, Regressor, StdNotSupportedError
from .features import FeatureSet
from .gp import GPR
from .lgpr import LGPR
from .lr import LinearRegression
from .lwpr import LWPR
from .onestep import TARGETS, OneStepModel
from .persistence import (METHODS, ModelError, fingerprint_arrays, get_method, load_model,
                          read_model, register, save_model)
from .sor import SoR
from .train import DEFAULT_MAX_TRAIN, METHOD_NAMES, fit_onestep, make_estimator

__all__ = ["Regressor", "NotFittedError", "StdNotSupportedError", "METHODS", "METHOD_NAMES",
           "get_method", "register", "make_estimator", "OneStepModel", "TARGETS", "fit_onestep",
           "DEFAULT_MAX_TRAIN", "save_model", "load_model", "read_model", "ModelError",
           "fingerprint_arrays", "FeatureSet", "LinearRegression", "LWPR", "GPR", "SoR", "LGPR"]
