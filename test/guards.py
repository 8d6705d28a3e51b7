"""Guards every test run here has: a stuck test cannot hang the run, and no module leaks.

- ``pytest-timeout`` (setup.cfg: ``timeout``, SIGALRM) fails a test that runs too long with a
  traceback, and the run goes on.
- The hard guard: :func:`faulthandler.dump_traceback_later` is armed for each test at the
  pytest-timeout bound plus ``HARD_MARGIN_S``. Its watchdog is a C thread that needs no GIL, so
  it fires even when a thread holds the GIL in C code and SIGALRM's Python handler never runs: it
  writes every thread's stack to ``.pytest-hang.log`` in the rootdir and ends the process.
- ``.pytest-running`` (rootdir) names the test running now; ``.ci/run`` prints it when the
  whole suite runs out of time. Under pytest-xdist (``make test`` runs two workers) each worker
  has its own files, ``.pytest-running.gw0`` and ``.pytest-hang.gw0.log``.
- :func:`leaves_no_threads_or_children`: every test module leaves the process as it found it
  (no new thread, no child process), or its last test errors naming what it left.
- :func:`sigint_as_from_a_terminal`: the run, and every process a test starts, turns SIGINT into
  KeyboardInterrupt even when the suite was started as a background job of a non-interactive
  shell (`cmd &`), which starts it with SIGINT ignored. Ignored signals are inherited across
  ``exec``, and Python installs its SIGINT handler only where SIGINT is at its default; the
  tests that stop a program with SIGINT (Ctrl-C) would otherwise wait on a program that cannot
  hear it, and ``.ci/run``'s time-out, which interrupts pytest with SIGINT, would not reach it.
"""
from __future__ import annotations

import faulthandler
import os
import signal
import threading
import time
from pathlib import Path

import pytest

# pytest-xdist's worker name (gw0, gw1, ...) in a worker process, "" in a run without workers:
# each worker keeps its own two files below
_WORKER = os.environ.get("PYTEST_XDIST_WORKER", "")
# the test running now (one line, rewritten at each test's start): `.ci/run` prints it when the
# whole suite runs out of time
RUNNING = ".pytest-running" + (f".{_WORKER}" if _WORKER else "")
# where the hard guard writes every thread's stack before it ends a stuck run
HANG_LOG = ".pytest-hang" + (f".{_WORKER}" if _WORKER else "") + ".log"
# s added to pytest-timeout's bound for the hard guard (faulthandler's watchdog, a C thread that
# needs no GIL: it fires even when a thread holds the GIL in C code and pytest-timeout cannot)
HARD_MARGIN_S = float(os.environ.get("LITTLEDOG_HARD_MARGIN_S", "120"))


def sigint_as_from_a_terminal() -> bool:
    """Give SIGINT back its default meaning (KeyboardInterrupt here, and SIG_DFL in every child
    after ``exec``) if this process was started with it ignored; returns whether it was."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        return True
    return False


def _timeout_s(item: pytest.Item) -> float:
    marker = item.get_closest_marker("timeout")
    if marker is not None and marker.args:
        return float(marker.args[0])
    return float(item.config.getini("timeout") or 0)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    """Write the test's id to ``RUNNING`` and arm the hard guard for its duration."""
    root = item.config.rootpath
    (root / RUNNING).write_text(item.nodeid + "\n")
    bound = _timeout_s(item)
    log = None
    if bound > 0:
        log = open(root / HANG_LOG, "w")
        log.write(f"{item.nodeid}: still running after {bound + HARD_MARGIN_S:g} s; "
                  "every thread's stack follows, then the run ends\n")
        log.flush()
        faulthandler.dump_traceback_later(bound + HARD_MARGIN_S, exit=True, file=log)
    try:
        yield
    finally:
        if log is not None:
            faulthandler.cancel_dump_traceback_later()
            log.close()
            (root / HANG_LOG).unlink(missing_ok=True)


def pytest_sessionstart(session: pytest.Session) -> None:
    """The run (the xdist controller, or the one process without workers) removes the
    ``RUNNING`` files an interrupted run left, so that only this run's are read."""
    if not _WORKER:
        for f in session.config.rootpath.glob(".pytest-running*"):
            f.unlink(missing_ok=True)


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """A finished run removes ``RUNNING``; an interrupted one (``.ci/run``'s time-out sends
    SIGINT to every process of the run, xdist's workers too) keeps it, naming the test it was
    in."""
    if exitstatus != pytest.ExitCode.INTERRUPTED:
        (session.config.rootpath / RUNNING).unlink(missing_ok=True)


# ---------------------------------------------------------------------------------------------
# every test module leaves the process as it found it: no new threads, no child processes


# s a module's threads and children get to end after its last test
LEAK_WAIT_S = float(os.environ.get("LITTLEDOG_LEAK_WAIT_S", "10"))


def _children() -> dict[int, str]:
    """This process's live children (Linux /proc), zombies included: pid -> command line."""
    out: dict[int, str] = {}
    for task in Path(f"/proc/{os.getpid()}/task").iterdir():
        try:
            pids = (task / "children").read_text().split()
        except OSError:
            continue
        for pid in pids:
            try:
                cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
            except OSError:
                cmd = "?"
            out[int(pid)] = cmd.strip()[:160]
    return out


def _threads() -> dict[int, str]:
    return {t.ident: t.name for t in threading.enumerate() if t.ident is not None}


# What a library keeps for the life of the process by design, with no public way to end it;
# not a leak of the module that happened to start it first:
# - distributed's module-level offload executor (one idle thread, "Dask-Offload_0");
# - multiprocessing's resource tracker (one process per parent, started by the first spawn).
LIFETIME_THREADS = ("Dask-Offload_",)
LIFETIME_CHILDREN = ("multiprocessing.resource_tracker", "loky.backend.resource_tracker",
                     "multiprocessing.forkserver")


def _release_idle_pools() -> None:
    """Shut down the worker pool joblib keeps for reuse (loky's reusable executor: idle worker
    processes and two threads), if this process made one."""
    import sys

    if "joblib.externals.loky" in sys.modules:
        from joblib.externals.loky import get_reusable_executor

        get_reusable_executor().shutdown(wait=True)


@pytest.fixture(scope="module", autouse=True)
def leaves_no_threads_or_children(request):
    """Fail the module's last test if it left a thread or a child process behind (after
    joblib's reusable pool is shut down: the module's own cache, released)."""
    threads, children = _threads(), _children()
    yield
    _release_idle_pools()
    wait_s = LEAK_WAIT_S
    deadline = time.monotonic() + wait_s
    while True:
        new_threads = sorted(n for i, n in _threads().items()
                             if i not in threads and not n.startswith(LIFETIME_THREADS))
        new_children = {p: c for p, c in _children().items()
                        if p not in children and not any(k in c for k in LIFETIME_CHILDREN)}
        if not (new_threads or new_children) or time.monotonic() > deadline:
            break
        time.sleep(0.05)
    assert not new_threads and not new_children, (
        f"{request.module.__name__} left behind threads {new_threads} and child processes "
        f"{new_children} (still there after {wait_s:g} s)")
