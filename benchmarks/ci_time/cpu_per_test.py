"""A pytest plugin: each test's CPU seconds (setup, call and teardown), its own process's and
those of the children it reaped (worker pools, subprocesses, Dask processes), and its wall time.
Workers forked from Python's fork server (``littledog_mlsim.workers``) are the server's
children, not the test process's: their CPU is not counted here (only the wall time shows it).
Each pytest(-xdist) process writes ``cpu_per_test_<worker>.json`` into ``CPU_PER_TEST_DIR``
(default: the current directory) at the end of the session:

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=benchmarks/ci_time CPU_PER_TEST_DIR=OUT \
        .venv/bin/python -m pytest -q -p cpu_per_test -n 2 --dist loadfile test
"""
import json
import os
import resource
import time
from pathlib import Path

import pytest

_rows = []


def _cpu():
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime, b.ru_utime + b.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    s0, c0 = _cpu()
    t0 = time.perf_counter()
    yield
    s1, c1 = _cpu()
    _rows.append({"id": item.nodeid, "self": s1 - s0, "children": c1 - c0,
                  "wall": time.perf_counter() - t0})


def pytest_sessionfinish(session):
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    out = Path(os.environ.get("CPU_PER_TEST_DIR", ".")) / f"cpu_per_test_{worker}.json"
    out.write_text(json.dumps(_rows))
