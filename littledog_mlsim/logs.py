"""The one progress set-up: library code logs, the command line decides what is shown.

Library modules log through ``logging.getLogger(__name__)`` (progress at INFO, problems at
WARNING) and never print. A program (the ``littledog-mlsim`` verbs, the benchmark scripts)
calls :func:`setup_logging` once; it shows the package's records on stderr as
``<module>: <message>`` (``train: ...``, ``lgpr: ...``, ``reproduce: ...``), the form the
progress lines had before. Progress bars over many items (recording) use tqdm on stderr.
"""
from __future__ import annotations

import logging
import sys
from typing import TextIO

__all__ = ["setup_logging", "teardown_logging", "PACKAGE_LOGGER"]

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
