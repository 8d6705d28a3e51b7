"""A pytest plugin that counts the physics re-simulations of the diagnosis, by mode.

It wraps ``physid._Runner.map`` and prints, at the end of the session, the tasks of each mode
and the control steps they simulate (``full`` 700: the 4 s replay and three more 1 s segments;
``segs`` 400: the four 1 s segments; ``short`` 200: the two screening segments). This is how
LOG.md's step counts before and after the joint refit (the sixth zoo) were made:

    PYTHONPATH=benchmarks/blind_zoo/harness:$PWD OPENBLAS_NUM_THREADS=1 .venv/bin/python -m pytest -q \\
        -p sim_tally test/diagnose/test_diagnose.py -k "physical_one_leg_delay or \\
        physical_clean or heavy_leg or odom_fixed or scopes_and_shortlist or \\
        mass_com_position_and or torque_axes"
"""
from __future__ import annotations

import collections

from littledog_mlsim.diagnose import physid

STEPS = {"full": 700, "segs": 400, "short": 200}
_tally: collections.Counter = collections.Counter()
_map = physid._Runner.map


def _counting_map(self, tasks):
    for t in tasks:
        _tally[t[2]] += 1
    return _map(self, tasks)


physid._Runner.map = _counting_map


def pytest_terminal_summary(terminalreporter):
    steps = sum(STEPS[k] * v for k, v in _tally.items())
    terminalreporter.write_line(f"re-simulations by mode {dict(_tally)}; control steps {steps}")
