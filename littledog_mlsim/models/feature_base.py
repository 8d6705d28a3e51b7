"""What an augmentation is and sees: :class:`Augmentation`, :class:`Window`, the registry.

An :class:`Augmentation` is one named, parametrised transform of the state/command history
into extra feature columns; :class:`Window` is what it is given for one step (lagged states and
commands, the pose, the elapsed time). Concrete augmentations live in :mod:`.feature_library` and
register themselves in :data:`AUGMENTATIONS` (:func:`register_augmentation`), so that a model
file's feature set can name them (:func:`augmentation_from_dict`). The feature-set machinery
that combines them, in batch and online, is :mod:`.features`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

__all__ = ["FeatureSetError", "Window", "Augmentation", "AUGMENTATIONS",
           "register_augmentation", "augmentation_from_dict"]


class FeatureSetError(ValueError):
    """A feature set cannot be built or read (one-line message)."""


# ---------------------------------------------------------------------------------------------
# what an augmentation sees


class Window:
    """The inputs of one step for a batch of samples, shapes (..., dim).

    Batch mode builds it over whole moves (leading shape (B, T)), online mode for one step
    (leading shape (B,)). ``s(k)``/``u(k)`` return s_{t-k}/u_{t-k}; ``pose`` is (..., 3) x_w,
    y_w, yaw (None if the feature set needs no pose); ``elapsed`` (...) seconds.
    """

    def __init__(self, states: Sequence[np.ndarray], actions: Sequence[np.ndarray],
                 pose: np.ndarray | None, elapsed: np.ndarray) -> None:
        self._s = states
        self._u = actions
        self.pose = pose
        self.elapsed = elapsed

    def s(self, k: int = 0) -> np.ndarray:
        return self._s[k]

    def u(self, k: int = 0) -> np.ndarray:
        return self._u[k]


# ---------------------------------------------------------------------------------------------
# the registry

AUGMENTATIONS: dict[str, type["Augmentation"]] = {}


def register_augmentation(cls: type["Augmentation"]) -> type["Augmentation"]:
    """Register an augmentation class under ``cls.name`` (usable as a decorator)."""
    old = AUGMENTATIONS.get(cls.name)
    if old is not None and old is not cls:
        raise ValueError(f"augmentation {cls.name!r} is already registered to {old.__name__}")
    AUGMENTATIONS[cls.name] = cls
    return cls


@dataclass(frozen=True)
class Augmentation:
    """A named transform of the state/command history into extra feature columns.

    Subclasses set ``name`` (registry key, stored in model files), ``family`` (the kind of
    effect it models, used by the diagnosis report), are frozen dataclasses whose fields are the
    parameters (plain JSON values), and implement ``columns`` and ``compute`` (or, for
    recursive ones, ``init_carry`` and ``advance``).
    """

    name: ClassVar[str] = ""
    family: ClassVar[str] = ""
    recursive: ClassVar[bool] = False
    needs_pose: ClassVar[bool] = False

    @property
    def max_lag(self) -> int:
        """Largest k of s(k)/u(k) used."""
        return 0

    def params(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def label(self) -> str:
        """Short human-readable name with parameters, e.g. ``command_lag(lag=2)``."""
        args = ", ".join(f"{k}={v}" for k, v in self.params().items())
        return f"{self.name}({args})"

    def columns(self) -> tuple[str, ...]:
        raise NotImplementedError

    def compute(self, w: Window) -> np.ndarray:
        """(..., n_columns) for the samples of ``w``."""
        raise NotImplementedError

    # recursive augmentations
    def init_carry(self, w: Window) -> np.ndarray:
        raise NotImplementedError

    def advance(self, carry: np.ndarray, w: Window) -> tuple[np.ndarray, np.ndarray]:
        """(features (B, n_columns), new carry) for one step."""
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "family": self.family, "params": self.params(),
                "columns": list(self.columns())}


def augmentation_from_dict(d: Mapping[str, Any]) -> Augmentation:
    """Rebuild an augmentation from ``Augmentation.to_dict()`` (FeatureSetError if unknown)."""
    if not isinstance(d, Mapping) or "name" not in d:
        raise FeatureSetError("augmentation entry must be a mapping with a 'name'")
    cls = AUGMENTATIONS.get(str(d["name"]))
    if cls is None:
        raise FeatureSetError(f"unknown augmentation {d['name']!r} (this build knows "
                              f"{', '.join(sorted(AUGMENTATIONS))})")
    params = d.get("params") or {}
    if not isinstance(params, Mapping):
        raise FeatureSetError(f"augmentation {d['name']!r}: params must be a mapping")
    try:
        aug = cls(**params)
    except TypeError as e:
        raise FeatureSetError(f"augmentation {d['name']!r}: bad params {dict(params)}: "
                              f"{e}") from None
    cols = d.get("columns")
    if cols is not None and list(cols) != list(aug.columns()):
        raise FeatureSetError(f"augmentation {aug.label()}: stored columns differ from this "
                              f"build's")
    return aug
