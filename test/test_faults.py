"""Faults survived: each test makes a fault happen and checks that nothing is lost.

- a simulator (sim_node, pybullet_node) killed with SIGKILL mid-run: a controller that keeps
  publishing notices it within a bound and neither hangs nor crashes; a restarted node serves
  again, its ``/clock`` from its start;
- ``littledog-mlsim train`` killed with SIGKILL while it writes a model (at a chosen point, by a
  hook in the child process, not by a timer): the previous model is intact and loads, and no
  half-written directory is left (the next write removes the killed writer's staging);
- a recorder killed mid-bag (an MCAP file without its summary, cut mid-chunk; a sqlite3 bag
  without ``metadata.yaml``): ``import`` recovers what is readable and reports what it dropped
  and why, or refuses in one line naming the file;
- a controller flooding ``/littledog/cmd`` as fast as it can (aiming at 10 kHz) with NaN in
  every tenth message, sim_node in lockstep: every good command makes its step, in order; the
  node answers a service call during the flood; ``~/stats`` counts what it refused;
- a full disk (an injected write that fails with ENOSPC) while writing a model or a dataset:
  one line naming the path, nothing half-written, the old one kept.
"""
from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from rosharness import BIN, ENV, Probe, Proc, Ros  # noqa: I001  (first: it sets the test domain)
from littledog_mlsim import fileio
from littledog_mlsim.cli import main as cli_main
from littledog_mlsim.data.dataset import features_responses, load_moves, read_index
from littledog_mlsim.layout import CONTROL_DT_NS, HOME_POSE
from littledog_mlsim.models.lr import LinearRegression
from littledog_mlsim.models.onestep import OneStepModel
from waiting import TIMEOUT, wait_until

# ---------------------------------------------------------------------------------------------
# fixtures


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("faults")


@pytest.fixture(scope="module")
def dataset(work) -> Path:
    """Three F moves recorded with pybullet (2 TrainPool, 1 TestPool)."""
    from littledog_mlsim.apps.record import record_dataset

    out = work / "data"
    record_dataset(out, moves_per_type=3, types=["F"], jobs=1, progress=False)
    return out


@pytest.fixture(scope="module")
def model_path(work, dataset) -> Path:
    X, Y, _ = features_responses(load_moves(dataset, split="train"))
    path = work / "lr_model"
    OneStepModel.fit(LinearRegression(), X, Y).save(path)
    return path


def snapshot(directory: Path) -> dict[str, bytes]:
    """Every file under ``directory`` (relative name -> bytes)."""
    return {str(p.relative_to(directory)): p.read_bytes()
            for p in sorted(directory.rglob("*")) if p.is_file()}


def staging_of(path: Path) -> list[str]:
    """The hidden siblings a writer of ``path`` stages in (``.NAME.*``)."""
    return sorted(p.name for p in path.parent.iterdir() if p.name.startswith(f".{path.name}."))


def cli(capsys, *args: str) -> tuple[int, str, str]:
    """``littledog-mlsim ARGS`` in this process: (exit status, stdout, stderr)."""
    capsys.readouterr()
    rc = cli_main(list(args))
    out = capsys.readouterr()
    return rc, out.out, out.err


# ---------------------------------------------------------------------------------------------
# train killed (SIGKILL) while writing a model


# The child runs the real CLI verb after replacing one file-system step with a hook that marks
# the point and blocks; the test kills it there (no timer races the write).
KILL_HOOKS = {
    # the npz half written, model.json not yet
    "mid_file": """
        real = fileio.write_synced
        def hook(path, data):
            if Path(path).name == "arrays.npz":
                with open(path, "wb") as f:
                    f.write(data[: len(data) // 2]); f.flush(); os.fsync(f.fileno())
                block()
            real(path, data)
        fileio.write_synced = hook
    """,
    # both files whole in the staging directory, not yet renamed into place
    "before_rename": """
        real = fileio.replace_directory
        def hook(tmp, path):
            block()
            real(tmp, path)
        fileio.replace_directory = hook
    """,
}

CHILD = """
import os, sys, time
from pathlib import Path
from littledog_mlsim import fileio
MARK = Path(sys.argv[1])
def block():
    MARK.write_text(str(os.getpid()))
    time.sleep(600)
{hook}
from littledog_mlsim.cli import main
sys.exit(main(sys.argv[2:]))
"""


@pytest.mark.parametrize("point", list(KILL_HOOKS))
def test_train_killed_while_writing_keeps_the_old_model(work, dataset, model_path, point, capsys):
    out = work / f"model_{point}"
    assert cli(capsys, "train", "--data", str(dataset), "--method", "lr", "--out", str(out),
               "--quiet")[0] == 0
    before = snapshot(out)
    old = OneStepModel.load(out)
    X, _, _ = features_responses(load_moves(dataset, split="test"))
    mark = work / f"mark_{point}"
    mark.unlink(missing_ok=True)
    code = CHILD.format(hook=textwrap.dedent(KILL_HOOKS[point]))
    # a different model (next-state target), so a swapped-in new one would show
    p = subprocess.Popen([sys.executable, "-c", code, str(mark), "train", "--data", str(dataset),
                          "--method", "lr", "--target", "next", "--out", str(out), "--quiet"],
                         env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        wait_until(lambda: mark.exists() or p.poll() is not None, timeout=120,
                   what=f"train to reach {point}")
        assert p.poll() is None, p.stderr.read().decode()
        p.send_signal(signal.SIGKILL)
    finally:
        if p.poll() is None:
            p.kill()
        p.wait(TIMEOUT)
        p.stderr.close()
    assert p.returncode == -signal.SIGKILL
    # the model at the path is the old one, whole, and loads and predicts as before
    assert snapshot(out) == before
    again = OneStepModel.load(out)
    assert again.target == old.target == "delta"
    np.testing.assert_array_equal(again.predict(X), old.predict(X))
    # the killed writer's staging directory is the only debris, beside (not at) the path
    debris = staging_of(out)
    assert len(debris) == 1 and debris[0].startswith(f".{out.name}.tmp-"), debris
    if point == "before_rename":     # it held the new model, whole
        assert (out.parent / debris[0] / "model.json").is_file()
    # the next write removes it and replaces the model
    assert cli(capsys, "train", "--data", str(dataset), "--method", "lr", "--target", "next",
               "--out", str(out), "--quiet")[0] == 0
    assert staging_of(out) == []
    assert OneStepModel.load(out).target == "next"


# ---------------------------------------------------------------------------------------------
# disk full (a write that fails with ENOSPC) while writing a model or a dataset


def _enospc(*_args, **_kw):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_disk_full_writing_a_model_keeps_the_old_one(work, dataset, model_path, capsys,
                                                    monkeypatch):
    out = work / "model_full"
    assert cli(capsys, "train", "--data", str(dataset), "--method", "lr", "--out", str(out),
               "--quiet")[0] == 0
    before = snapshot(out)
    real = fileio.write_synced
    written = []

    def half_then_full(path, data):      # the disk fills up part-way through the first file
        written.append(Path(path).name)
        with open(path, "wb") as f:
            f.write(data[: len(data) // 3])
        _enospc()
    monkeypatch.setattr(fileio, "write_synced", half_then_full)
    rc, stdout, err = cli(capsys, "train", "--data", str(dataset), "--method", "lr",
                          "--target", "next", "--out", str(out), "--quiet")
    monkeypatch.setattr(fileio, "write_synced", real)
    assert written == ["arrays.npz"]
    assert rc == 2 and stdout == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(out) in lines[0] and "No space left on device" in lines[0], lines[0]
    assert "previous one is kept" in lines[0]
    assert snapshot(out) == before and staging_of(out) == []
    assert OneStepModel.load(out).target == "delta"
    # a new path: nothing at all is left
    new = work / "model_full_new"
    monkeypatch.setattr(fileio, "write_synced", half_then_full)
    rc, _, err = cli(capsys, "train", "--data", str(dataset), "--method", "lr", "--out",
                     str(new), "--quiet")
    assert rc == 2 and len(err.strip().splitlines()) == 1 and str(new) in err
    assert "nothing was written there" in err
    assert not new.exists() and staging_of(new) == []


def test_disk_full_writing_a_dataset_keeps_the_old_one(work, dataset, capsys, monkeypatch):
    out = work / "data_full"
    assert cli(capsys, "record", "--out", str(out), "--moves-per-type", "1", "--types", "S",
               "--jobs", "1", "--quiet")[0] == 0
    before = snapshot(out)
    # the first fsync of the new dataset fails: its first bag's storage file did not fit
    calls = []

    def full(path):
        calls.append(str(path))
        _enospc()
    monkeypatch.setattr(fileio, "fsync_path", full)
    rc, stdout, err = cli(capsys, "record", "--out", str(out), "--moves-per-type", "1",
                          "--types", "F", "--jobs", "1", "--overwrite", "--quiet")
    monkeypatch.undo()
    assert calls, "the injected failure was never reached"
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(out) in lines[0] and "No space left on device" in lines[0], lines[0]
    assert snapshot(out) == before and staging_of(out) == []
    assert [e.name for e in read_index(out).entries] == ["S_00"]
    assert len(load_moves(out, "all")) == 1
