"""The suite's own guards (test/guards.py), each made to fire in an inner pytest run.

The hard guard's case holds the GIL in C for good (a ctypes.PyDLL call that blocks on a mutex
it already holds), the way a C extension can: SIGALRM's Python handler cannot run then, and only
the GIL-free watchdog ends the run.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

HERE = Path(__file__).resolve().parent

CONFTEST = "from guards import (leaves_no_threads_or_children, pytest_runtest_protocol,\n" \
           "                    pytest_sessionfinish, pytest_sessionstart,\n" \
           "                    sigint_as_from_a_terminal)  # noqa: F401\n" \
           "sigint_as_from_a_terminal()\n"

STUCK = textwrap.dedent("""
    import ctypes, time
    import pytest

    @pytest.mark.timeout(1)
    def test_sleeps():
        time.sleep(30)

    def test_after():
        pass

    @pytest.mark.timeout(1)
    def test_holds_the_gil_in_c():
        libc = ctypes.PyDLL(None)          # PyDLL: the call keeps the GIL
        mutex = ctypes.create_string_buffer(64)
        libc.pthread_mutex_init(mutex, None)
        libc.pthread_mutex_lock(mutex)
        libc.pthread_mutex_lock(mutex)     # a default mutex locked twice: blocks for good

    def test_never_reached():
        pass
""")

LEAKS = textwrap.dedent("""
    import threading

    STOP = threading.Event()

    def test_leaves_a_thread():
        threading.Thread(target=STOP.wait, name="leaked-by-test", daemon=True).start()
""")


# a child that says it is up, then sleeps; SIGINT must end it at once
CTRL_C = textwrap.dedent("""
    import signal, subprocess, sys

    SLEEPER = "import time; print('up', flush=True); time.sleep(60)"

    def test_a_child_hears_sigint():
        p = subprocess.Popen([sys.executable, "-c", SLEEPER], stdout=subprocess.PIPE, text=True)
        assert p.stdout.readline() == "up\\n"
        p.send_signal(signal.SIGINT)
        assert p.wait(20) in (1, -signal.SIGINT)      # KeyboardInterrupt ended it
""")


def _ignore_sigint() -> None:
    """What a non-interactive shell does to a background job (`cmd &`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _inner(tmp_path: Path, source: str, timeout: float = 60,
           preexec=None) -> subprocess.CompletedProcess:
    (tmp_path / "conftest.py").write_text(CONFTEST)
    (tmp_path / "test_inner.py").write_text(source)
    # the inner run is no pytest-xdist worker, even when this one is
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_XDIST_")}
    env.update(PYTHONPATH=str(HERE), LITTLEDOG_HARD_MARGIN_S="2", LITTLEDOG_LEAK_WAIT_S="0.5")
    return subprocess.run([sys.executable, "-m", "pytest", "-v", "-p", "no:cacheprovider",
                           "-o", "timeout=0", "test_inner.py"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=timeout,
                          preexec_fn=preexec)


def test_soft_then_hard_timeout(tmp_path):
    r = _inner(tmp_path, STUCK)
    out = r.stdout
    # pytest-timeout fails the sleeping test and the run goes on
    assert "test_inner.py::test_sleeps FAILED" in out
    assert "test_inner.py::test_after PASSED" in out
    # the GIL held in C: only the watchdog ends the run, with the stuck test's stack
    assert r.returncode == 1 and "test_never_reached" not in out
    log = (tmp_path / ".pytest-hang.log").read_text()
    assert log.startswith("test_inner.py::test_holds_the_gil_in_c: still running after 3 s")
    assert "test_holds_the_gil_in_c" in log.split("\n", 1)[1]       # its frame, in the stack
    assert (tmp_path / ".pytest-running").read_text().strip() == \
        "test_inner.py::test_holds_the_gil_in_c"


def test_a_module_that_leaves_a_thread_errors_naming_it(tmp_path):
    r = _inner(tmp_path, LEAKS)
    assert r.returncode == 1
    assert "ERROR at teardown of test_leaves_a_thread" in r.stdout
    assert "left behind threads ['leaked-by-test']" in r.stdout
    assert not (tmp_path / ".pytest-running").exists()             # a finished run removes it


def test_an_interrupted_run_keeps_the_name_of_its_test_and_a_new_run_drops_it(tmp_path):
    """.ci/run's time-out interrupts the run with SIGINT: the file names the test it was in,
    and the next run removes what an earlier one left (one file per xdist worker)."""
    (tmp_path / ".pytest-running.gw7").write_text("test_old.py::test_from_an_earlier_run\n")
    r = _inner(tmp_path, "def test_interrupted():\n    raise KeyboardInterrupt\n")
    assert r.returncode == 2, r.stdout                       # pytest's "interrupted"
    assert (tmp_path / ".pytest-running").read_text().strip() == \
        "test_inner.py::test_interrupted"
    assert not (tmp_path / ".pytest-running.gw7").exists()


def test_a_suite_started_with_sigint_ignored_still_stops_its_programs_with_it(tmp_path):
    """`make test &` in a script starts pytest with SIGINT ignored, an inherited disposition:
    a program a test starts would ignore the test's Ctrl-C and the test would wait on it. The
    guard restores SIGINT in pytest, so its children start with the default again."""
    # the premise: a Python started with SIGINT ignored keeps ignoring it
    p = subprocess.Popen([sys.executable, "-c", "import signal; print(signal.getsignal(2) is signal.SIG_IGN)"],
                         stdout=subprocess.PIPE, text=True, preexec_fn=_ignore_sigint)
    assert p.communicate(timeout=30)[0].strip() == "True"
    r = _inner(tmp_path, CTRL_C, preexec=_ignore_sigint)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "test_inner.py::test_a_child_hears_sigint PASSED" in r.stdout
