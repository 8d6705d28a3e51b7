"""A dataset of moves: the directory, its index ``dataset.yaml``, the split and loading.

Dataset directory
-----------------
A dataset is a directory of bags (``bags.write_bag``; one per move, named ``<TYPE>_<NN>``) plus
``dataset.yaml``, the index. Schema (format version 1)::

    format: littledog_mlsim.dataset     # fixed string
    format_version: 1                   # int; readers refuse versions they do not know
    info:                               # how it was recorded; plain YAML values, free-form.
      robot: measured                   #   Usual keys: robot, seed, storage, moves_per_type,
      seed: 0                           #   types, steps_per_move, control_dt_ns, created, ...
      storage: mcap                     #   No key anywhere in `info` may contain "effect":
      moves_per_type: 20                #   nothing in a dataset names the effects that were
    counts:                             #   active (docs/interface.md §3). Written by
      total: 220                        #   write_index from `bags`, checked by read_index.
      train: 154
      test: 66
    bags:                               # one entry per bag, in the order load_moves returns them
    - name: F_00                        #   bag directory name <TYPE>_<NN> (layout.bag_name)
      move_type: F                      #   must equal <TYPE>
      split: train                      #   train (TrainPool) or test (TestPool)

Split rule (``split_names`` gives it as move numbers, ``dataset_entries`` as index entries): for
each move type with n moves numbered 0..n-1 (bags ``<TYPE>_00``...), the first
``n_train(n) = floor(0.7 n + 1/2)`` (0.7 n rounded half up, exactly, without floating-point
error) are TrainPool and the rest TestPool: 14/6 of 20, 7/3 of 10, 4/1 of 5, 1/0 of 1.

Bad bags (``load_moves``): by default the first bag that fails to load raises its ``BagError``
(one line naming bag and topic). With ``on_error="skip"`` a bad bag is left out and a
``SkippedBagWarning`` naming it and the reason is issued (``warnings.warn``; collect them with
``warnings.catch_warnings(record=True)``); if nothing loads at all the call still raises.

The paper's state/feature extraction and normalisation (``states_from_recording``,
``features_responses``, ``integrate_path``, ``Normalizer``, ...) are :mod:`.states`; this module
re-exports them, so ``from littledog_mlsim.data.dataset import features_responses`` keeps
working.
"""
from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import yaml

from ..fileio import atomic_write_text, read_document, to_plain
from ..layout import DATASET_MOVE_TYPES, MOVE_TYPES, bag_name
from ..rotations import quat_to_matrix, quat_to_rpy, rpy_to_matrix, rpy_to_quat
from .bags import BagError, move_type_from_name, read_bag
from .recording import MoveRecording
from .states import (InitialPose, Normalizer, actions_from_recording, features_responses,
                     initial_pose, integrate_path, states_from_measurements,
                     states_from_recording)

__all__ = [
    "INDEX_FILE", "INDEX_FORMAT", "INDEX_FORMAT_VERSION", "SPLITS", "TRAIN_FRACTION",
    "BagEntry", "DatasetIndex", "DatasetError", "SkippedBagWarning",
    "n_train", "split_names", "dataset_entries", "write_index", "read_index", "load_moves",
    "quat_to_matrix", "quat_to_rpy", "rpy_to_quat", "rpy_to_matrix",
    "states_from_recording", "states_from_measurements", "actions_from_recording", "features_responses",
    "InitialPose", "initial_pose", "integrate_path", "Normalizer",
]

INDEX_FILE = "dataset.yaml"
INDEX_FORMAT = "littledog_mlsim.dataset"
INDEX_FORMAT_VERSION = 1
SPLITS: tuple[str, ...] = ("train", "test")
TRAIN_FRACTION = 0.7


class DatasetError(ValueError):
    """A dataset directory or its ``dataset.yaml`` is unusable (one-line message naming it)."""


class SkippedBagWarning(UserWarning):
    """``load_moves(on_error="skip")`` left a bag out; the message names the bag and why."""


# ---------------------------------------------------------------------------------------------
# index and splits


@dataclass(frozen=True)
class BagEntry:
    name: str        # bag directory name <TYPE>_<NN>
    move_type: str   # one of layout.DATASET_MOVE_TYPES (11 types or U), equal to <TYPE>
    split: str       # "train" (TrainPool) or "test" (TestPool)

    def check(self) -> None:
        """ValueError if the entry is not valid."""
        try:
            name_type = move_type_from_name(self.name)
        except ValueError as exc:
            raise ValueError(f"bag entry {self.name!r}: {exc}") from None
        if self.move_type != name_type:
            raise ValueError(f"bag entry {self.name!r}: move_type {self.move_type!r} does not "
                             f"match the name")
        if self.split not in SPLITS:
            raise ValueError(f"bag entry {self.name!r}: split {self.split!r} not in {SPLITS}")


@dataclass
class DatasetIndex:
    entries: list[BagEntry]
    info: dict[str, Any] = field(default_factory=dict)
    format_version: int = INDEX_FORMAT_VERSION

    def names(self, split: str = "all", types: Iterable[str] | None = None) -> list[str]:
        """Bag names of ``split`` (``train``/``test``/``all``) and ``types`` (None: all)."""
        return [e.name for e in _select(self.entries, split, types)]


def n_train(n_moves_per_type: int, train_fraction: float = TRAIN_FRACTION) -> int:
    """Number of TrainPool moves of a type: ``train_fraction * n`` rounded half up (exact)."""
    if n_moves_per_type < 0:
        raise ValueError("n_moves_per_type must be >= 0")
    if not 0.0 <= train_fraction <= 1.0:
        raise ValueError("train_fraction must be in [0, 1]")
    return math.floor(Fraction(repr(float(train_fraction))) * n_moves_per_type + Fraction(1, 2))


def split_names(n_moves_per_type: int,
                train_fraction: float = TRAIN_FRACTION) -> tuple[list[int], list[int]]:
    """The split rule as move numbers: (train NNs, test NNs), the same for every move type.

    Moves ``0..n_train-1`` are TrainPool, the rest TestPool; the bag of move ``i`` of type ``T``
    is ``layout.bag_name(T, i)``. E.g. ``split_names(20) == ([0..13], [14..19])``. For complete
    index entries (names, types, splits) use ``dataset_entries``.
    """
    k = n_train(n_moves_per_type, train_fraction)
    return list(range(k)), list(range(k, n_moves_per_type))


def dataset_entries(n_moves_per_type: int, types: Sequence[str] = MOVE_TYPES,
                    train_fraction: float = TRAIN_FRACTION) -> list[BagEntry]:
    """Index entries of a dataset of ``n_moves_per_type`` moves of each type, type-major."""
    bad = [t for t in types if t not in MOVE_TYPES]
    if bad:
        raise ValueError(f"unknown move type(s) {bad}; known: {MOVE_TYPES}")
    train, _ = split_names(n_moves_per_type, train_fraction)
    return [BagEntry(bag_name(t, i), t, "train" if i in train else "test")
            for t in types for i in range(n_moves_per_type)]


def _effect_keys(obj: Any, where: str = "info") -> list[str]:
    found: list[str] = []
    if isinstance(obj, Mapping):
        for k, v in obj.items():
            if "effect" in str(k).lower():
                found.append(f"{where}.{k}")
            found += _effect_keys(v, f"{where}.{k}")
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            found += _effect_keys(v, f"{where}[{i}]")
    return found


_plain = to_plain   # the one converter (fileio)


def _counts(entries: Sequence[BagEntry]) -> dict[str, int]:
    return {"total": len(entries), **{s: sum(e.split == s for e in entries) for s in SPLITS}}


def _check_entries(entries: Sequence[BagEntry]) -> None:
    seen: set[str] = set()
    for e in entries:
        e.check()
        if e.name in seen:
            raise ValueError(f"bag {e.name!r} listed twice")
        seen.add(e.name)


def write_index(directory: str | os.PathLike, entries: Iterable[BagEntry | Mapping[str, str]],
                info: Mapping[str, Any] | None = None) -> Path:
    """Write ``directory/dataset.yaml`` atomically (temporary file, then rename); return its path.

    ``entries``: BagEntry or mappings with keys name, move_type, split. ``info``: recording
    information (plain YAML values). ValueError for invalid or duplicated entries, any ``info``
    key mentioning effects, or values YAML cannot represent. Does not check that the bags exist
    (``load_moves`` does). Replaces an existing index.
    """
    directory = Path(directory)
    ents: list[BagEntry] = []
    for e in entries:
        if isinstance(e, BagEntry):
            ents.append(e)
            continue
        if set(e) != {"name", "move_type", "split"}:
            raise ValueError(f"bag entry {dict(e)!r}: keys must be name, move_type, split")
        ents.append(BagEntry(str(e["name"]), str(e["move_type"]), str(e["split"])))
    _check_entries(ents)
    info = _plain(dict(info or {}))
    leaked = _effect_keys(info)
    if leaked:
        raise ValueError(f"dataset info must not name effects (docs/interface.md §3): {leaked}")
    doc = {
        "format": INDEX_FORMAT,
        "format_version": INDEX_FORMAT_VERSION,
        "info": info,
        "counts": _counts(ents),
        "bags": [{"name": e.name, "move_type": e.move_type, "split": e.split} for e in ents],
    }
    try:
        text = yaml.safe_dump(doc, sort_keys=False, default_flow_style=None)
    except yaml.YAMLError as exc:
        raise ValueError(f"dataset info holds a value YAML cannot store: {exc}") from None
    if not directory.is_dir():
        raise FileNotFoundError(f"{directory} is not a directory")
    return atomic_write_text(directory / INDEX_FILE, text)


def read_index(directory: str | os.PathLike) -> DatasetIndex:
    """Read and check ``directory/dataset.yaml``; DatasetError (one line naming it) if invalid."""
    path = Path(directory) / INDEX_FILE

    def fail(reason: str) -> DatasetError:
        return DatasetError(f"{path}: {' '.join(reason.split())}")

    if not path.is_file():
        raise fail("no dataset index (not a dataset directory?)")
    try:
        doc = read_document(path, INDEX_FORMAT, INDEX_FORMAT_VERSION, "a dataset index", "yaml")
    except ValueError as exc:
        raise fail(str(exc)) from None
    info = doc.get("info") or {}
    if not isinstance(info, dict):
        raise fail("info is not a mapping")
    leaked = _effect_keys(info) + _effect_keys({k: v for k, v in doc.items() if k != "info"}, "")
    if leaked:
        raise fail(f"names effects, which a dataset must not (docs/interface.md §3): {leaked}")
    bags = doc.get("bags")
    if not isinstance(bags, list) or not bags:
        raise fail("bags is missing or empty")
    entries: list[BagEntry] = []
    for i, b in enumerate(bags):
        if not isinstance(b, dict) or set(b) != {"name", "move_type", "split"}:
            raise fail(f"bags[{i}] must have exactly the keys name, move_type, split")
        entries.append(BagEntry(str(b["name"]), str(b["move_type"]), str(b["split"])))
    try:
        _check_entries(entries)
    except ValueError as exc:
        raise fail(str(exc)) from None
    counts = doc.get("counts")
    if counts is not None and counts != _counts(entries):
        raise fail(f"counts {counts} do not match the bags listed {_counts(entries)}")
    return DatasetIndex(entries=entries, info=info, format_version=INDEX_FORMAT_VERSION)


def _select(entries: Iterable[BagEntry], split: str, types: Iterable[str] | None) -> list[BagEntry]:
    if split not in (*SPLITS, "all"):
        raise ValueError(f"split must be one of {SPLITS + ('all',)}, got {split!r}")
    if types is not None:
        types = list(types)
        bad = [t for t in types if t not in DATASET_MOVE_TYPES]
        if bad:
            raise ValueError(f"unknown move type(s) {bad}; known: {DATASET_MOVE_TYPES}")
    return [e for e in entries
            if (split == "all" or e.split == split) and (types is None or e.move_type in types)]


def load_moves(directory: str | os.PathLike, split: str = "train",
               types: Iterable[str] | None = None, on_error: str = "raise") -> list[MoveRecording]:
    """Read the bags of ``split`` (``train``/``test``/``all``) and ``types`` in index order.

    ``on_error="raise"`` (default): the first bad bag raises its ``BagError`` (naming bag and
    topic). ``on_error="skip"``: bad bags are left out, each with a ``SkippedBagWarning``; a
    DatasetError is still raised if no bag loads. DatasetError if the index is invalid or the
    selection is empty.
    """
    if on_error not in ("raise", "skip"):
        raise ValueError(f"on_error must be 'raise' or 'skip', got {on_error!r}")
    directory = Path(directory)
    index = read_index(directory)
    selected = _select(index.entries, split, types)
    if not selected:
        raise DatasetError(f"{directory}: no bags with split {split!r} and types "
                           f"{list(types) if types is not None else 'all'}")
    moves: list[MoveRecording] = []
    skipped: list[str] = []
    for e in selected:
        try:
            moves.append(read_bag(directory / e.name, move_type=e.move_type))
        except BagError as exc:
            if on_error == "raise":
                raise
            skipped.append(e.name)
            warnings.warn(SkippedBagWarning(f"skipped {exc}"), stacklevel=2)
    if not moves:
        raise DatasetError(f"{directory}: all {len(selected)} selected bags are bad "
                           f"(skipped {', '.join(skipped)})")
    return moves
