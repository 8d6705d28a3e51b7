"""Waiting on events in the multi-process ROS tests (imported as ``waiting``, like ``synthetic``).

Discovery of a late joiner takes about 2.5 s, so every wait polls its condition with a generous
timeout instead of sleeping a fixed time.
"""
from __future__ import annotations

import time

TIMEOUT = 15.0          # s, any wait for an event


def wait_until(pred, timeout: float = TIMEOUT, what: str = "") -> None:
    """Poll ``pred()`` every 5 ms until it is true; AssertionError naming ``what`` (or the
    predicate) after ``timeout`` s."""
    end = time.monotonic() + timeout
    while not pred():
        if time.monotonic() > end:
            raise AssertionError(f"timed out after {timeout} s waiting for {what or pred}")
        time.sleep(0.005)
