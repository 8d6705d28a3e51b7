"""The physical route's effect families: one class each, registered in :data:`FAMILIES`.

:mod:`.base` holds the contract (:class:`Family`) and the registry, :mod:`.scopes` the
vocabulary of where an effect acts; :mod:`.joints`, :mod:`.body` and :mod:`.legs` the families
by kind, registered in the order the search screens them (``docs/families.md``: adding one);
:mod:`.learned` the learned route's feature families and the physical family each reads as.
"""
from .base import (FAMILIES, KINDS, Family, FittedEffect, ScreenProbe, Separation,
                   library_size, register_family, vocabulary_family)
from . import joints, body, legs  # noqa: F401,E402  (registers the families, in this order)
from .learned import LEARNED_FAMILIES, LearnedFamily, learned_family, register_learned
from .scopes import (TYPE_SCOPES, group_scope, joint_scopes, leg_scopes, related_scopes,
                     scope_group, scope_joints, scope_words)

__all__ = ["FAMILIES", "KINDS", "Family", "FittedEffect", "ScreenProbe", "Separation",
           "register_family", "vocabulary_family", "library_size", "TYPE_SCOPES", "joint_scopes",
           "leg_scopes", "related_scopes", "scope_group", "group_scope", "scope_joints",
           "scope_words", "LEARNED_FAMILIES", "LearnedFamily", "learned_family",
           "register_learned"]
