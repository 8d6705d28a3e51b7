"""The robot's names and the paper's state/action/feature layout, defined once.

Everything in the project imports joint names, state names and index ranges from here
(``docs/interface.md`` §1 and §4). Arrays of 12 joint values are
always in ``JOINT_NAMES`` order; :func:`joint_permutation` maps a message's or a bag's joint
order onto it.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

LEGS: tuple[str, ...] = ("front_left", "front_right", "back_left", "back_right")
LEG_JOINTS: tuple[str, ...] = ("hip_roll", "hip_pitch", "knee")
JOINT_NAMES: tuple[str, ...] = tuple(f"{leg}_{j}" for leg in LEGS for j in LEG_JOINTS)
N_JOINTS = len(JOINT_NAMES)  # 12
_JOINT_INDEX = {n: i for i, n in enumerate(JOINT_NAMES)}


@lru_cache(maxsize=64)
def joint_permutation(names: tuple[str, ...]) -> np.ndarray | str:
    """Index into ``names`` of each joint of ``JOINT_NAMES`` (``values[perm]`` reorders a
    JointState's arrays to the project's order), or a one-line reason why ``names`` is not
    usable: unknown names, duplicates, or not all 12. Cached: the order rarely changes."""
    unknown = [n for n in names if n not in _JOINT_INDEX]
    if unknown:
        return f"unknown joint name(s) {', '.join(repr(n) for n in unknown[:3])}"
    if len(set(names)) != len(names):
        return "duplicated joint names"
    if len(names) != N_JOINTS:
        missing = [n for n in JOINT_NAMES if n not in names]
        return f"{len(names)} joint names, missing {', '.join(missing[:3])}"
    where = {n: i for i, n in enumerate(names)}
    perm = np.array([where[n] for n in JOINT_NAMES])
    perm.flags.writeable = False   # shared by the cache
    return perm

MOVE_TYPES: tuple[str, ...] = ("F", "FL", "FR", "B", "BL", "BR", "L", "R", "DL", "DR", "S")
# A move whose type is not known (an imported recording whose motion fits none of the 11 types,
# ``littledog-mlsim import``): bags ``U_<NN>``, usable for training and scoring like any other.
UNKNOWN_MOVE_TYPE = "U"
DATASET_MOVE_TYPES: tuple[str, ...] = MOVE_TYPES + (UNKNOWN_MOVE_TYPE,)

CONTROL_DT = 0.01  # s, one step of the learned simulator and of the command stream
CONTROL_RATE_HZ = 100
CONTROL_DT_NS = 10_000_000
MOVE_DURATION_S = 4.0
STEPS_PER_MOVE = 400  # commands per move; a bag holds STEPS_PER_MOVE + 1 measurements

TOPIC_CMD = "/littledog/cmd"
TOPIC_JOINT_STATES = "/littledog/joint_states"
TOPIC_ODOM = "/littledog/odom"
TOPIC_CLOCK = "/clock"
ODOM_FRAME = "odom"
BASE_FRAME = "base_link"

BODY_STATE_NAMES: tuple[str, ...] = (
    "z_w", "dx_b", "dy_b", "dz_b", "roll", "pitch", "droll", "dpitch", "dyaw",
)
STATE_NAMES: tuple[str, ...] = (
    BODY_STATE_NAMES
    + tuple(f"q_{j}" for j in JOINT_NAMES)
    + tuple(f"dq_{j}" for j in JOINT_NAMES)
)
ACTION_NAMES: tuple[str, ...] = tuple(f"u_{j}" for j in JOINT_NAMES)
FEATURE_NAMES: tuple[str, ...] = STATE_NAMES + ACTION_NAMES
N_STATE = len(STATE_NAMES)  # 33
N_ACTION = len(ACTION_NAMES)  # 12
N_FEATURE = len(FEATURE_NAMES)  # 45


class StateLayout:
    """Index ranges into the 33-element state vector (docs/interface.md §4)."""

    z_w = 0
    d_b = slice(1, 4)         # dx_b, dy_b, dz_b
    roll = 4
    pitch = 5
    roll_pitch = slice(4, 6)
    d_rpy = slice(6, 9)       # droll, dpitch, dyaw
    dyaw = 8
    q = slice(9, 21)
    dq = slice(21, 33)


S = StateLayout()
STATE_INDEX: dict[str, int] = {n: i for i, n in enumerate(STATE_NAMES)}
# Elements that are angle differences and must be wrapped to (-pi, pi].
WRAPPED_STATE = np.array([STATE_INDEX[n] for n in ("droll", "dpitch", "dyaw")])

# Joint limits [rad] in JOINT_NAMES order (LITTLEDOG.md).
_LEG_LIMITS = {
    "front": ((-0.6, 0.6), (-3.5, 2.4), (-3.1, 1.0)),
    "back": ((-0.6, 0.6), (-2.4, 3.5), (-1.0, 3.1)),
}
JOINT_LOWER = np.array([_LEG_LIMITS[leg.split("_")[0]][j][0] for leg in LEGS for j in range(3)])
JOINT_UPPER = np.array([_LEG_LIMITS[leg.split("_")[0]][j][1] for leg in LEGS for j in range(3)])

# Home (standing) pose in JOINT_NAMES order (LITTLEDOG.md).
HOME_POSE = np.array([
    0.1, 1.0, -1.55,    # front_left
    -0.1, 1.0, -1.55,   # front_right
    0.1, -1.0, 1.55,    # back_left
    -0.1, -1.0, 1.55,   # back_right
])
HOME_BODY_HEIGHT = 0.146


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles to (-pi, pi]."""
    a = np.asarray(a, dtype=float)
    w = np.mod(a + np.pi, 2.0 * np.pi) - np.pi  # [-pi, pi)
    return np.where(w == -np.pi, np.pi, w)


def bag_name(move_type: str, index: int) -> str:
    """Directory name of a move's bag, e.g. ``FL_07``."""
    return f"{move_type}_{index:02d}"
