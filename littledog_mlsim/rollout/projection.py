"""The projections, under the name the rollout code used before they moved to
:mod:`littledog_mlsim.projection` (a layer below both the one-step model and the rollout).

Kept so that ``from littledog_mlsim.rollout.projection import ...`` keeps working; new code
imports :mod:`littledog_mlsim.projection`.
"""
from __future__ import annotations

from ..projection import *  # noqa: F401,F403  (the same public names)
from ..projection import __all__  # noqa: F401
