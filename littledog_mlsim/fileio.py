"""Atomic writes: a reader sees the old file or directory or the complete new one, never a part.

- :func:`atomic_write_text`: one text file, through a fsynced temporary sibling and a rename.
- :func:`read_document` / :func:`format_problem`: the one way to read a versioned JSON or
  YAML document (model files, dataset indexes, robot configs) and check its ``format`` and
  ``format_version``.
- :func:`to_plain`: NumPy values, tuples and paths as the plain values JSON and YAML write.
- :func:`atomic_directory`: a context manager that yields an empty temporary sibling directory;
  when the block succeeds the directory is fsynced and put in place of the target (replacing
  an existing one only if allowed), when it fails it is removed. Model files, recorded datasets
  and bags are all written through it, so there is one set of rules for partial output:
  - a failed write (``OSError``, e.g. ENOSPC: the disk is full) is re-raised as a
    :class:`WriteFailed` (an ``OSError`` of the same errno) whose one-line message names the
    target and says that nothing was written there, or that the previous one is kept;
  - the writer holds an ``flock`` on its staging directory while it writes; a staging directory
    whose writer was killed (SIGKILL, a power cut: nothing could remove it) is unlocked, and
    the next write of the same target removes it.
- :func:`write_synced`: one file's bytes, flushed and fsynced (the model writer's file write;
  tests replace it to make a write fail part-way).
"""
from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import fcntl
import logging
import os
import secrets
import shutil
import tempfile
from pathlib import Path
from typing import Any, Iterator, Mapping

__all__ = ["atomic_write_text", "atomic_directory", "fsync_path", "replace_directory", "to_plain",
           "format_problem", "read_document", "write_synced", "remove_stale_staging",
           "WriteFailed"]

log = logging.getLogger(__name__)


def format_problem(doc: Any, fmt: str, version: int, what: str) -> str | None:
    """Why ``doc`` is not a ``fmt`` document of ``version`` (one line), or None if it is.

    ``what`` names the document for the reader ("a dataset index")."""
    if not isinstance(doc, dict) or doc.get("format") != fmt:
        return f"not {what} (format is not {fmt!r})"
    got = doc.get("format_version")
    if got != version:
        return f"unsupported format_version {got!r} (this build reads {version})"
    return None


def read_document(path: str | os.PathLike, fmt: str, version: int, what: str,
                  syntax: str = "json") -> dict:
    """The document at ``path`` (``syntax`` "json" or "yaml"), checked to be a ``fmt`` document
    of ``version``; ValueError with a one-line reason (without the path) otherwise."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ValueError(f"unreadable: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"not text (truncated or corrupt?): {exc}") from None
    try:
        if syntax == "yaml":
            import yaml
            doc = yaml.safe_load(text)
        else:
            import json
            doc = json.loads(text)
    except Exception as exc:   # json.JSONDecodeError, yaml.YAMLError
        detail = " ".join(str(exc).split())
        raise ValueError(f"not valid {syntax.upper()} (truncated or corrupt?): {detail}") from None
    problem = format_problem(doc, fmt, version, what)
    if problem:
        raise ValueError(problem)
    return doc


def to_plain(obj: Any) -> Any:
    """``obj`` with NumPy scalars/arrays, tuples, mappings and paths turned into plain values
    (numbers, lists, dicts with string keys, strings); anything else is returned as it is, for
    the writer (json, yaml) to accept or refuse."""
    import numpy as np

    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Mapping):
        return {str(k): to_plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_plain(v) for v in obj]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    return obj


def atomic_write_text(path: str | os.PathLike, text: str, mode: int = 0o644) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a fsynced temporary sibling and a rename.

    The temporary file is removed if anything fails (also on KeyboardInterrupt), so an
    interrupted write leaves the previous file untouched and no debris. ``mode``: permissions
    of the new file (``mkstemp`` creates 0600). Returns the path.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)
    try:
        os.chmod(tmp, mode)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_synced(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to a new file ``path``, flushed and fsynced."""
    with open(path, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())


def fsync_path(path: str | os.PathLike) -> None:
    """fsync a file or directory by path (a directory: its entries)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Atomically swap two paths with renameat2(RENAME_EXCHANGE); False if unsupported."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    if fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EPERM):
        return False
    raise OSError(err, f"renameat2 {a} <-> {b}: {os.strerror(err)}")


def sibling_dir(path: Path, tag: str) -> Path:
    """A new empty directory ``.NAME.<tag>-XXXXXXXX`` next to ``path`` (mode from the umask,
    unlike ``tempfile.mkdtemp``'s 0700)."""
    for _ in range(100):
        d = path.parent / f".{path.name}.{tag}-{secrets.token_hex(4)}"
        try:
            os.mkdir(d)
            return d
        except FileExistsError:
            continue
    raise OSError(f"cannot create a temporary directory next to {path}")


def replace_directory(tmp: Path, path: Path) -> None:
    """Put the finished directory ``tmp`` at ``path``, replacing what is there.

    ``renameat2(RENAME_EXCHANGE)`` where the kernel and file system offer it; otherwise the old
    directory is renamed aside first (a crash between the two renames leaves it in
    ``.NAME.old-*/old``), then the new one in."""
    if not path.exists():
        os.rename(tmp, path)
        return
    if _exchange(tmp, path):
        shutil.rmtree(tmp, ignore_errors=True)  # tmp now holds the old directory
        return
    old = sibling_dir(path, "old")
    os.rename(path, old / "old")
    os.rename(tmp, path)
    shutil.rmtree(old, ignore_errors=True)


def _lock(directory: Path) -> int:
    """An exclusive ``flock`` on ``directory`` (an open descriptor; closing it unlocks)."""
    fd = os.open(directory, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        raise
    return fd


def remove_stale_staging(path: str | os.PathLike, tag: str) -> list[Path]:
    """Remove the staging directories ``.NAME.<tag>-*`` next to ``path`` whose writer is gone
    (nobody holds their lock: the writer was killed); returns what was removed."""
    path = Path(path)
    removed = []
    try:
        candidates = sorted(path.parent.glob(f".{path.name}.{tag}-*"))
    except OSError:
        return removed
    for d in candidates:
        if not d.is_dir() or d.is_symlink():
            continue
        try:
            fd = _lock(d)
        except OSError:        # locked: a live writer; or gone meanwhile
            continue
        try:
            shutil.rmtree(d, ignore_errors=True)
            removed.append(d)
        finally:
            os.close(fd)
    if removed:
        log.info("removed %d staging director%s left by a killed writer of %s: %s",
                 len(removed), "y" if len(removed) == 1 else "ies", path,
                 ", ".join(d.name for d in removed))
    return removed


class WriteFailed(OSError):
    """A write of ``target`` failed (the OS error's errno kept); ``str()`` is one line naming
    the target, the reason and what is left at the target."""

    def __init__(self, err: int, target: Path, reason: str, existed: bool) -> None:
        kept = "the previous one is kept" if existed else "nothing was written there"
        super().__init__(err, f"writing {target} failed: {reason}; {kept}")
        self.target, self.reason, self.existed = target, reason, existed

    def __str__(self) -> str:
        return str(self.strerror)

    def __reduce__(self):  # picklable across process pools despite the 4-argument __init__
        return WriteFailed, (self.errno, self.target, self.reason, self.existed)


def _write_failed(path: Path, existed: bool, e: OSError) -> OSError:
    """``e`` as a :class:`WriteFailed` of ``path`` (a nested one keeps its first reason)."""
    if isinstance(e, WriteFailed):
        reason = f"{e.reason} (at {e.target})"
    else:
        where = f" ({e.filename})" if e.filename and str(e.filename) != str(path) else ""
        reason = f"{e.strerror or e}{where}"
    return WriteFailed(e.errno, path, reason, existed)


@contextlib.contextmanager
def atomic_directory(path: str | os.PathLike, *, replace: bool = False, tag: str = "partial",
                     create: bool = True) -> Iterator[Path]:
    """Build the directory ``path`` atomically: ``with atomic_directory(p) as tmp: write into tmp``.

    ``tmp`` is a new empty sibling ``.NAME.<tag>-XXXXXXXX`` (the parent directory must exist
    or is created). With ``create=False`` ``tmp`` does not exist yet, for writers that create
    their own directory (rosbags' Writer): it is ``.NAME.<tag>-XXXXXXXX/NAME``, so the files a
    writer names after its directory get the final name. On success ``tmp`` is fsynced and
    renamed to ``path``; an existing ``path`` is replaced if ``replace``, else FileExistsError
    (checked before and after the block). On any exception (also KeyboardInterrupt) the
    temporary directory is removed and ``path`` is untouched; an ``OSError`` with an errno
    (a full disk, ENOSPC) comes out as one line naming ``path`` (module doc). The staging
    directory is locked while the block runs; unlocked ones of the same target and tag (left
    by a killed writer) are removed first.
    """
    path = Path(path)
    if not replace and (path.exists() or path.is_symlink()):
        raise FileExistsError(f"{path} exists already, not overwriting")
    existed = path.exists()
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_staging(path, tag)
    staging = sibling_dir(path, tag)
    lock = _lock(staging)
    tmp = staging if create else staging / path.name
    try:
        try:
            yield tmp
            if not replace and (path.exists() or path.is_symlink()):
                raise FileExistsError(f"{path} appeared while writing, not overwriting")
            fsync_path(tmp)
            replace_directory(tmp, path)
        except OSError as e:
            if e.errno is None:
                raise
            raise _write_failed(path, existed, e) from e
        fsync_path(path.parent)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        os.close(lock)
