"""Model files (``docs/interface.md`` §7) and the registry of regression methods.

A model is a directory holding two files, nothing executable::

    MODEL/
      arrays.npz   the estimator's learned arrays (NumPy .npz, read with allow_pickle=False)
      model.json   {"format": "littledog_mlsim-model", "format_version": 1, "method": "gpr",
                    "params": {constructor arguments}, "state": {estimator meta},
                    "meta": {caller meta: feature names, normalisation, data fingerprint, ...},
                    "arrays": {name: {"shape": [...], "dtype": "<f8"}},
                    "arrays_sha256": "...", "created_utc": "...", "versions": {...}}

Writing is atomic (:func:`..fileio.atomic_directory`): both files are written and fsynced in
a temporary sibling directory, which then replaces MODEL in one step (``renameat2
(RENAME_EXCHANGE)`` where the kernel and file system offer it, otherwise rename-old-aside then
rename-new-in, where a crash between the two renames leaves the old model in
``.MODEL.old-*/old``); a failed or interrupted save leaves an existing model untouched. A directory that is not a model is never replaced. Directory and file modes
follow the umask.

Every failure to read a model raises :class:`ModelError` (a ValueError) with a one-line reason:
unknown format version or method, truncated/corrupt files (the npz is checked against its
SHA-256), missing arrays or wrong shapes, or a feature set the caller cannot supply.

Callers may store their own arrays next to the estimator's (``save_model(..., extra_arrays=)``,
e.g. the TrainPool states a rollout projects onto); they live in the same ``arrays.npz`` under the
prefix ``extra.``, are covered by the same checksum and shape checks, and come back from
:func:`read_model`.

Methods: :data:`METHODS` maps method names to estimator classes. ``lr``, ``gpr`` and ``sor``
are registered here; other estimators call :func:`register` (usable as a class decorator) in
their module. A method named ``X`` that is not registered yet is looked up by importing
``littledog_mlsim.models.X``; a Regressor subclass there whose ``method`` is ``X`` is registered.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import importlib
import io
import json
import os
import re
import zipfile
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from .. import fileio
from ..fileio import atomic_directory, read_document, to_plain
from .base import Regressor
from .gp import GPR
from .lr import LinearRegression
from .sor import SoR

FORMAT = "littledog_mlsim-model"
FORMAT_VERSION = 1
ARRAYS_FILE = "arrays.npz"
META_FILE = "model.json"
EXTRA_PREFIX = "extra."  # npz names of caller arrays (save_model's extra_arrays)

METHODS: dict[str, type[Regressor]] = {}
_METHOD_NAME = re.compile(r"^[a-z][a-z0-9_]*$")


class ModelError(ValueError):
    """A model file cannot be read or written; the message is one line naming the cause."""


def register(cls: type[Regressor]) -> type[Regressor]:
    """Register an estimator class under ``cls.method`` (returns cls: usable as a decorator).

    The class must implement get_params/get_state/from_state (see models/base.py).
    Re-registering the same class is a no-op; another class under a taken name is an error.
    """
    name = getattr(cls, "method", "")
    if not isinstance(name, str) or not _METHOD_NAME.match(name):
        raise ValueError(f"{cls.__name__}.method must be a lower-case identifier; got {name!r}")
    old = METHODS.get(name)
    if old is not None and old is not cls and old.__qualname__ != cls.__qualname__:
        raise ValueError(f"method {name!r} is already registered to {old.__qualname__}")
    METHODS[name] = cls
    return cls


for _cls in (LinearRegression, GPR, SoR):
    register(_cls)


def get_method(name: str) -> type[Regressor]:
    """The estimator class registered as ``name``; ModelError if there is none."""
    if name not in METHODS and isinstance(name, str) and _METHOD_NAME.match(name):
        module = f"{__package__}.{name}"
        try:
            mod = importlib.import_module(module)
        except ModuleNotFoundError as e:
            if e.name != module:  # the module exists but one of its imports is missing
                raise ModelError(f"method {name!r}: cannot import {module}: {e}") from e
        else:  # a module that defines the estimator but does not register it
            for obj in vars(mod).values():
                if (isinstance(obj, type) and issubclass(obj, Regressor)
                        and getattr(obj, "method", None) == name and name not in METHODS):
                    register(obj)
    if name not in METHODS:
        raise ModelError(f"unknown model method {name!r} (known: {', '.join(sorted(METHODS))})")
    return METHODS[name]


# ----------------------------------------------------------------------------- writing

def fingerprint_arrays(*arrays: np.ndarray) -> str:
    """SHA-256 hex digest of arrays' dtypes, shapes and bytes (a training-data fingerprint)."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape};".encode())
        h.update(a.tobytes())
    return h.hexdigest()



def save_model(path: str | os.PathLike, model: Regressor,
               extra_meta: Mapping[str, Any] | None = None,
               extra_arrays: Mapping[str, np.ndarray] | None = None) -> Path:
    """Write a fitted ``model`` to the directory ``path`` atomically; returns the path.

    ``extra_meta``: JSON-serialisable caller metadata stored as ``meta``; NumPy arrays/scalars
    are converted to lists/numbers. Suggested keys: ``feature_names`` (checked by
    :func:`load_model`), ``normalisation``, ``data_fingerprint`` (:func:`fingerprint_arrays`).
    ``extra_arrays``: caller arrays (numeric, or 0-d unicode strings such as a projection's
    ``kind``) stored in the same npz under the prefix :data:`EXTRA_PREFIX` and covered by the
    same checksum; :func:`read_model` returns them (without the prefix).
    Raises ModelError if the method is not registered, ``path`` exists but is not a model, the
    model is not fitted, or the state cannot be serialised; nothing at ``path`` changes then.
    """
    path = Path(path)
    cls = METHODS.get(getattr(model, "method", ""))
    if cls is None or not isinstance(model, cls):
        raise ModelError(f"cannot save {type(model).__name__}: method "
                         f"{getattr(model, 'method', '')!r} is not registered")
    if path.exists() and not (path.is_dir() and (path / META_FILE).is_file()):
        raise ModelError(f"refusing to replace {path}: it exists and is not a model directory")
    try:
        arrays, state = model.get_state()
        params = model.get_params()
    except AttributeError as e:
        raise ModelError(f"cannot save {type(model).__name__}: not fitted ({e})") from e
    arrays = {k: np.asarray(v) for k, v in arrays.items()}
    for k, v in arrays.items():
        if v.dtype.kind not in "biuf":
            raise ModelError(f"cannot save array {k!r}: dtype {v.dtype} is not numeric")
        if k.startswith(EXTRA_PREFIX):
            raise ModelError(f"cannot save array {k!r}: the prefix {EXTRA_PREFIX!r} is reserved")
    for k, v in (extra_arrays or {}).items():
        v = np.asarray(v)
        if not (v.dtype.kind in "biuf" or (v.dtype.kind == "U" and v.shape == ())):
            raise ModelError(f"cannot save extra array {k!r}: dtype {v.dtype} is neither "
                             f"numeric nor a 0-d string")
        arrays[EXTRA_PREFIX + str(k)] = v

    buf = io.BytesIO()
    np.savez(buf, **arrays)
    blob = buf.getvalue()
    doc = {
        "format": FORMAT, "format_version": FORMAT_VERSION, "method": model.method,
        "params": params, "state": state, "meta": dict(extra_meta or {}),
        "arrays": {k: {"shape": list(v.shape), "dtype": v.dtype.str} for k, v in arrays.items()},
        "arrays_sha256": hashlib.sha256(blob).hexdigest(),
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "versions": {"numpy": np.__version__},
    }
    try:
        text = json.dumps(to_plain(doc), indent=1, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ModelError(f"cannot save model metadata as JSON: {e}") from e
    with atomic_directory(path, replace=True, tag="tmp") as tmp:
        for name, data in ((ARRAYS_FILE, blob), (META_FILE, (text + "\n").encode("utf-8"))):
            fileio.write_synced(tmp / name, data)
    return path


# ----------------------------------------------------------------------------- reading

def read_model_json(path: str | os.PathLike) -> dict[str, Any]:
    """The checked ``model.json`` of the model at ``path`` (format and version only)."""
    path = Path(path)
    meta_path = path / META_FILE
    if not path.exists():
        raise ModelError(f"{path}: no such model")
    if not meta_path.is_file():
        raise ModelError(f"{path} is not a model: no {META_FILE}")
    try:
        doc = read_document(meta_path, FORMAT, FORMAT_VERSION, "a model file")
    except ValueError as e:
        raise ModelError(f"{meta_path}: {e}") from None
    for key, typ in (("method", str), ("params", dict), ("state", dict), ("meta", dict),
                     ("arrays", dict), ("arrays_sha256", str)):
        if not isinstance(doc.get(key), typ):
            raise ModelError(f"{meta_path}: field {key!r} missing or not a {typ.__name__}")
    return doc


def load_model(path: str | os.PathLike, *, feature_names: Sequence[str] | None = None
               ) -> tuple[Regressor, dict[str, Any]]:
    """Read the model at ``path``; returns (fitted estimator, caller meta as saved).

    ``feature_names``: the features the caller can supply, in order; if the model's meta holds
    ``feature_names`` they must match exactly, otherwise the count must equal the estimator's
    ``n_features_in``. Raises ModelError (one line) on any problem.
    """
    model, meta, _ = read_model(path, feature_names=feature_names)
    return model, meta


def read_model(path: str | os.PathLike, *, feature_names: Sequence[str] | None = None
               ) -> tuple[Regressor, dict[str, Any], dict[str, np.ndarray]]:
    """:func:`load_model` plus the caller arrays saved as ``extra_arrays`` (names unprefixed)."""
    path = Path(path)
    doc = read_model_json(path)
    cls = get_method(doc["method"])
    npz_path = path / ARRAYS_FILE
    try:
        blob = npz_path.read_bytes()
    except OSError as e:
        raise ModelError(f"{npz_path}: cannot read ({e.strerror})") from e
    if hashlib.sha256(blob).hexdigest() != doc["arrays_sha256"]:
        raise ModelError(f"{npz_path}: checksum mismatch (truncated or corrupt)")
    arrays: dict[str, np.ndarray] = {}
    try:
        with np.load(io.BytesIO(blob), allow_pickle=False) as z:
            for name in z.files:
                arrays[name] = z[name]
    except (ValueError, OSError, zipfile.BadZipFile, EOFError) as e:
        raise ModelError(f"{npz_path}: unreadable ({e})") from e
    for name, spec in doc["arrays"].items():
        if name not in arrays:
            raise ModelError(f"{npz_path}: missing array {name!r}")
        a = arrays[name]
        if list(a.shape) != spec.get("shape") or a.dtype.str != spec.get("dtype"):
            raise ModelError(f"{npz_path}: array {name!r} is {a.dtype.str}{list(a.shape)}, "
                             f"model.json says {spec.get('dtype')}{spec.get('shape')}")
    extra = {k[len(EXTRA_PREFIX):]: arrays.pop(k) for k in list(arrays)
             if k.startswith(EXTRA_PREFIX)}
    try:
        model = cls.from_state(doc["params"], arrays, doc["state"])
    except (ValueError, KeyError, TypeError) as e:
        raise ModelError(f"{path}: bad {doc['method']} state: {e}") from e
    meta = doc["meta"]
    if feature_names is not None:
        names = list(feature_names)
        saved = meta.get("feature_names")
        if saved is not None and list(saved) != names:
            missing = [f for f in saved if f not in names]
            if missing:
                raise ModelError(f"{path}: model needs features the caller cannot supply: "
                                 f"{', '.join(map(str, missing))}")
            raise ModelError(f"{path}: model's {len(saved)} features differ in number or "
                             f"order from the caller's {len(names)}")
        n_in = doc["state"].get("n_features_in")
        if saved is None and n_in is not None and n_in != len(names):
            raise ModelError(f"{path}: model takes {n_in} features, caller supplies {len(names)}")
    return model, meta, extra
