"""The one progress set-up: library code logs, the command line decides what is shown.

Library modules log through ``logging.getLogger(__name__)`` (progress at INFO, problems at
WARNING) and never print. A program (the ``littledog-mlsim`` verbs, the benchmark scripts)
calls :func:`setup_logging` once; it shows the package's records on stderr as
``<module>: <message>`` (``train: ...``, ``lgpr: ...``, ``reproduce: ...``), the form the
progress lines had before. Progress bars over many items (recording) use tqdm on stderr.

Library functions with a ``progress`` argument (``train_from_dataset``, ``reproduce``) wrap
their work in :func:`progress_to_stderr`: when the program configured nothing, progress still
reaches the *current* ``sys.stderr`` in the same form, so a caller that redirects stderr
(trainer_node forwards it to the ROS log) or a script that configured nothing keeps seeing it.
"""
from __future__ import annotations

import contextlib
import logging
import sys
from typing import Iterator, TextIO

__all__ = ["setup_logging", "teardown_logging", "progress_to_stderr", "PACKAGE_LOGGER"]

PACKAGE_LOGGER = "littledog_mlsim"


class _ShortNameFormatter(logging.Formatter):
    """``<last component of the logger name>: <message>``."""

    def format(self, record: logging.LogRecord) -> str:
        record.short_name = record.name.rsplit(".", 1)[-1]
        return super().format(record)


def setup_logging(*, quiet: bool = False, verbose: bool = False,
                  stream: TextIO | None = None) -> logging.Handler:
    """Show the package's log records on ``stream`` (default stderr); returns the handler.

    Level INFO (progress), WARNING with ``quiet``, DEBUG with ``verbose``. Calling it again
    replaces the handler it installed before, so lines are never doubled."""
    logger = logging.getLogger(PACKAGE_LOGGER)
    for h in list(logger.handlers):
        if getattr(h, "_littledog_mlsim", False):
            logger.removeHandler(h)
    handler = logging.StreamHandler(stream if stream is not None else sys.stderr)
    handler._littledog_mlsim = True  # type: ignore[attr-defined]
    handler.setFormatter(_ShortNameFormatter("%(short_name)s: %(message)s"))
    level = logging.WARNING if quiet else logging.DEBUG if verbose else logging.INFO
    handler.setLevel(level)
    logger.addHandler(handler)
    logger.setLevel(min(level, logger.level) if logger.level else level)
    return handler


def teardown_logging(handler: logging.Handler) -> None:
    """Remove a handler :func:`setup_logging` installed (e.g. at the end of a CLI call)."""
    logging.getLogger(PACKAGE_LOGGER).removeHandler(handler)
    handler.flush()


class _CurrentStderr(logging.StreamHandler):
    """A handler writing to whatever ``sys.stderr`` is when a record is emitted."""

    def __init__(self) -> None:
        super().__init__()

    @property
    def stream(self) -> TextIO:  # type: ignore[override]
        return sys.stderr

    @stream.setter
    def stream(self, value: TextIO) -> None:
        pass


@contextlib.contextmanager
def progress_to_stderr(enabled: bool = True) -> Iterator[None]:
    """Show the package's INFO records on the current ``sys.stderr`` while the block runs, if
    ``enabled`` and no handler is configured on the package logger (else do nothing)."""
    logger = logging.getLogger(PACKAGE_LOGGER)
    if not enabled or logger.handlers:
        yield
        return
    handler = _CurrentStderr()
    handler.setFormatter(_ShortNameFormatter("%(short_name)s: %(message)s"))
    old_level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old_level)
