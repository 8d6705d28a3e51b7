"""Fixtures shared across the test tree (which mirrors the package: ``test/<subpackage>/``).

``synthetic.py`` (hand-made recordings with known dynamics, synthetic states and points) and
``waiting.py`` (waiting on events in the multi-process ROS tests) sit beside this file; the test
directory is put on ``sys.path`` so every test module imports them as ``synthetic`` and
``waiting``.
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

# the hang guards and the leak check, shared with test/test_guards.py's inner runs
from guards import (leaves_no_threads_or_children, pytest_runtest_protocol,  # noqa: E402,F401
                    pytest_sessionfinish, pytest_sessionstart, sigint_as_from_a_terminal)

# a suite started as `make test &` from a script has SIGINT ignored, and so would every program
# the tests stop with SIGINT (guards.py)
sigint_as_from_a_terminal()


@pytest.fixture(scope="session")
def small_dataset(tmp_path_factory) -> Path:
    """A recorded contract dataset: move types F, BL and S, 2 moves each (1 TrainPool + 1
    TestPool per type), default seed. Shared read-only by every module that asks for it."""
    from littledog_mlsim.apps.record import record_dataset
    out = tmp_path_factory.mktemp("small") / "ds"
    record_dataset(out, moves_per_type=2, types=["F", "BL", "S"], jobs=2, progress=False)
    return out


@pytest.fixture(scope="session")
def tiny(tmp_path_factory) -> tuple[Path, Path]:
    """(dataset, model): two F moves recorded and an LR model trained on the TrainPool one, for
    the tests that run the demo end to end. Shared read-only."""
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import features_responses, load_moves
    from littledog_mlsim.models.lr import LinearRegression
    from littledog_mlsim.models.onestep import OneStepModel

    work = tmp_path_factory.mktemp("demo")
    data = work / "data"
    record_dataset(data, moves_per_type=2, types=["F"], jobs=1, progress=False)
    X, Y, _ = features_responses(load_moves(data, split="train"))
    model = work / "lr_model"
    OneStepModel.fit(LinearRegression(), X, Y).save(model)
    return data, model
