"""Where an effect acts: the vocabulary's scopes and their words.

A joint scope is ``all``, a leg (``leg:front_left``), a joint type (``type:knees``), a side
(``side:left``) or one joint (``joint:back_left_knee``); a body family acts on ``body``, a leg
family on one ``leg:...``.
"""
from __future__ import annotations

import numpy as np

from ...layout import JOINT_NAMES, LEGS, N_JOINTS

__all__ = ["TYPE_SCOPES", "scope_joints", "joint_scopes", "leg_scopes", "scope_words",
           "scope_group", "group_scope", "related_scopes"]

TYPE_SCOPES = {"hip_rolls": "hip_roll", "hip_pitches": "hip_pitch", "knees": "knee"}
_JOINT_WORDS = {"hip_roll": "hip roll", "hip_pitch": "hip pitch", "knee": "knee"}


def scope_joints(scope: str) -> np.ndarray:
    """Joint indices (contract order) of a vocabulary scope ('all', 'leg:front_left',
    'type:knees', 'side:left', 'joint:back_left_knee')."""
    names = np.array(JOINT_NAMES)
    if scope == "all":
        return np.arange(N_JOINTS)
    kind, _, what = scope.partition(":")
    if kind == "leg" and what in LEGS:
        return np.flatnonzero(np.char.startswith(names, what + "_"))
    if kind == "type" and what in TYPE_SCOPES:
        return np.flatnonzero(np.char.endswith(names, "_" + TYPE_SCOPES[what]))
    if kind == "side" and what in ("left", "right"):
        return np.flatnonzero([f"_{what}_" in n for n in names])
    if kind == "joint" and what in JOINT_NAMES:
        return np.array([JOINT_NAMES.index(what)])
    raise ValueError(f"unknown scope {scope!r}")


def joint_scopes() -> list[str]:
    """Every joint scope of the vocabulary, coarse to fine (all -> groups -> joints)."""
    return (["all"] + [f"leg:{g}" for g in LEGS] + [f"type:{t}" for t in TYPE_SCOPES]
            + ["side:left", "side:right"] + [f"joint:{j}" for j in JOINT_NAMES])


def leg_scopes() -> list[str]:
    return [f"leg:{g}" for g in LEGS]


def scope_group(scope: str) -> str:
    """The joint group a learned feature is restricted to: ``all`` for ``all`` and ``body``,
    else the scope's name after the colon (``leg:back_left`` -> ``back_left``)."""
    return "all" if scope in ("all", "body") else scope.split(":", 1)[1]


def group_scope(group: str) -> str:
    """The joint scope of a learned feature's joint group (:func:`scope_group`'s inverse):
    ``all``, a joint type (``knees`` -> ``type:knees``), a side (``left`` -> ``side:left``), a
    leg (``back_left`` -> ``leg:back_left``) or one joint (``joint:back_left_knee``)."""
    if group == "all":
        return "all"
    if group in TYPE_SCOPES:
        return f"type:{group}"
    if group in ("left", "right"):
        return f"side:{group}"
    if group.count("_") == 1:
        return f"leg:{group}"
    return f"joint:{group}"


def scope_words(scope: str) -> str:
    """'back-left knee', 'the front-left leg', 'all knees', 'the left side', 'all joints'."""
    if scope == "all":
        return "all joints"
    if scope == "body":
        return "the body"
    kind, _, what = scope.partition(":")
    if kind == "leg":
        return f"the {what.replace('_', '-')} leg"
    if kind == "type":
        return f"all {what.replace('_', ' ')}"
    if kind == "side":
        return f"the {what} side's joints"
    leg = next(g for g in LEGS if what.startswith(g + "_"))
    return f"{leg.replace('_', '-')} {_JOINT_WORDS[what[len(leg) + 1:]]}"


def related_scopes(scope: str, other_types: bool = True) -> list[str]:
    """The scopes a joint finding is compared with before it is named: for a single joint, the
    other joints of its leg (an offset or a fault on one joint of a leg moves the foot much as
    one on its neighbour does, and the linear screen can prefer the wrong one:
    docs/decisions/013-scope-check-and-signed-start.md) and the groups that hold it; for a
    joint type, the other joint types (the same in every leg at once: an encoder read long at
    the hip pitches was named short at the knees, decision 061; left out if not
    ``other_types``) and ``all``; for a leg, its side and ``all``; for a side, its legs and
    ``all``; for ``all``, the sides and the joint types."""
    if scope == "all":
        return ["side:left", "side:right"] + [f"type:{t}" for t in TYPE_SCOPES]
    kind, _, what = scope.partition(":")
    if kind == "joint":
        leg = next(g for g in LEGS if what.startswith(g + "_"))
        jt = what[len(leg) + 1:]
        typ = next(t for t, k in TYPE_SCOPES.items() if k == jt)
        side = "left" if leg.endswith("left") else "right"
        siblings = [f"joint:{leg}_{k}" for k in TYPE_SCOPES.values() if k != jt]
        return siblings + [f"leg:{leg}", f"type:{typ}", f"side:{side}", "all"]
    if kind == "leg":
        return [f"side:{'left' if what.endswith('left') else 'right'}", "all"]
    if kind == "side":
        return [f"leg:{g}" for g in LEGS if g.endswith(what)] + ["all"]
    if kind == "type" and other_types:
        return [f"type:{t}" for t in TYPE_SCOPES if t != what] + ["all"]
    return ["all"]
