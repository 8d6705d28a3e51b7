"""A pytest plugin that counts the bags ``read_bag`` reads in the pytest process, and how often.

It wraps ``data.bags._read_topic`` (``read_bag`` calls it once per topic, three times per bag)
and prints, at the end of the session, the reads, the distinct bags and how many bags were read
how many times. Reads in worker processes (``--jobs``) are not counted. README.md's counts for
99aea18 were made this way:

    PYTHONPATH=benchmarks/ci_time:$PWD OPENBLAS_NUM_THREADS=1 .venv/bin/python -m pytest -q \\
        -p no:cacheprovider -p bag_tally test/diagnose/test_learned.py
"""
from __future__ import annotations

import collections

from littledog_mlsim.data import bags
from littledog_mlsim.layout import TOPIC_JOINT_STATES

_reads: collections.Counter = collections.Counter()
_read_topic = bags._read_topic


def _counting_read_topic(reader, bag, topic):
    if topic == TOPIC_JOINT_STATES:      # once per bag
        _reads[bag] += 1
    return _read_topic(reader, bag, topic)


bags._read_topic = _counting_read_topic


def pytest_terminal_summary(terminalreporter):
    times = collections.Counter(_reads.values())
    terminalreporter.write_line(
        f"bags read: {sum(_reads.values())} reads of {len(_reads)} distinct bags; "
        + ", ".join(f"{n} read {k} times" for k, n in sorted(times.items())))
