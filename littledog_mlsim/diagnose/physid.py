"""The physical route under its former name: :mod:`.physical` re-exported.

The route lives in :mod:`littledog_mlsim.diagnose.physical` (method in its docstring) and the
families in :mod:`littledog_mlsim.diagnose.families`. This module keeps the names the tests and
the benchmark tools (``benchmarks/blind_zoo/harness/*.py``) import, including their former private
names; new code imports from :mod:`.physical`.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from . import stats as _stats
from .families import (FAMILIES, TYPE_SCOPES, Family, joint_scopes, library_size,
                       related_scopes, scope_joints, scope_words, vocabulary_family)
from .families.body import (MASS_POSITIONS, PAYLOAD_REACH_M, TILT_DIRECTIONS,
                            mass_com_of, within_reach)
from .families.joints import NORMAL_TORQUE
from .physical import (CHANNELS, DEFAULT_HORIZONS_S, INSEPARABLE_SHARE, N_CH,
                       Candidate, Finding, PhysicalOptions, PhysIdResult, build_effects,
                       horizon_errors, identify, inseparable, physical_params, push_twin,
                       statement, suspicions, true_start)
from .physical.channels import (LONG, SCREEN_SEGMENTS, SEG_LEN, SEG_STARTS,
                                SHORT)
from .physical.channels import Measured as _Measured
from .physical.channels import errors as _errors
from .physical.channels import measured as _measured
from .physical.channels import sse as _sse
from .physical.context import weighted_sse as _J
from .physical.driver import pick_moves as _pick_moves
from .physical.resim import Move as _Move
from .physical.resim import Runner as _Runner
from .physical.resim import init_worker as _init_worker
from .physical.resim import simulate as _simulate
from .stats import N_TESTS, RANK_FLIPS, Decision, move_cuts, rank_max_p
from .stats import t_greater as _t_greater

__all__ = ["FAMILIES", "FamilySpec", "scopes_for", "scope_joints", "build_effects",
           "identify", "PhysIdResult", "statement", "DEFAULT_HORIZONS_S",
           # the vocabulary and the records, as before
           "TYPE_SCOPES", "joint_scopes", "library_size", "related_scopes", "scope_words",
           "vocabulary_family", "MASS_POSITIONS", "PAYLOAD_REACH_M", "TILT_DIRECTIONS",
           "mass_com_of", "within_reach", "NORMAL_TORQUE", "CHANNELS", "INSEPARABLE_SHARE",
           "N_CH", "Candidate", "Finding", "PhysicalOptions", "horizon_errors", "inseparable",
           "physical_params", "push_twin", "suspicions", "true_start", "LONG",
           "SCREEN_SEGMENTS", "SEG_LEN", "SEG_STARTS", "SHORT", "N_TESTS", "RANK_FLIPS",
           "Decision", "move_cuts", "rank_max_p", "decide", "decide_all",
           # former private names the benchmarks/blind_zoo/harness tools use
           "_Measured", "_errors", "_measured", "_sse", "_J", "_pick_moves", "_Move", "_Runner",
           "_init_worker", "_simulate", "_t_greater", "_weights"]

FamilySpec = Family   # the family's contract, by its former name


def scopes_for(family: str) -> list[str]:
    return FAMILIES[family].scopes()


def _weights(base_err: Sequence[Mapping[str, np.ndarray]], F: Sequence[int]) -> np.ndarray:
    """Channel weights (36,): 1 / the base's SSE on the moves F."""
    S0 = np.array([_sse(base_err[i]) for i in F]).sum(axis=0)
    return 1.0 / np.where(S0 > 0, S0, 1.0)


def _as_tuple(d: Decision) -> tuple[np.ndarray, np.ndarray, float, bool, bool]:
    return d.gain, d.p_channel, d.p_value, d.significant, d.material


def decide(S0: np.ndarray, S1: np.ndarray, n_choice: int, alpha: float, min_gain: float,
           p_rank: float) -> tuple[np.ndarray, np.ndarray, float, bool, bool]:
    """(gain, p per channel, adjusted p, significant, material): :func:`.stats.decide` with a
    rank test, as a tuple (the benchmark tools' form)."""
    return _as_tuple(_stats.decide(S0, S1, n_choice, alpha, min_gain, p_rank))


def decide_all(S0: np.ndarray, S1s: Sequence[np.ndarray], alpha: float, min_gain: float
               ) -> list[tuple[np.ndarray, np.ndarray, float, bool, bool]]:
    """:func:`.stats.decide_all` as tuples (the benchmark tools' form)."""
    return [_as_tuple(d) for d in _stats.decide_all(S0, S1s, alpha, min_gain)]
