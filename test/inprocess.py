"""The ``littledog-mlsim`` console script run in this process (imported as ``inprocess``, like
``synthetic`` and ``waiting``)."""
from __future__ import annotations

import subprocess


def cli(capsys, *args) -> subprocess.CompletedProcess:
    """``littledog-mlsim ARGS`` through ``cli.main`` (paths and numbers as their ``str``); its
    exit status and captured output."""
    from littledog_mlsim.cli import main

    capsys.readouterr()
    rc = main([str(a) for a in args])
    out = capsys.readouterr()
    return subprocess.CompletedProcess(args, rc, out.out, out.err)
