"""The ``littledog-mlsim`` console script: one verb per job (CONTRACT.md section 5).

Every verb prints ``--help``, shows progress on long work, and on bad input exits non-zero with a
one-line reason on stderr.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable, Sequence

from .layout import MOVE_TYPES


class CliError(Exception):
    """A user-facing error: printed as one line, exit status 2."""


def _types(text: str) -> list[str]:
    types = [t.strip().upper() for t in text.split(",") if t.strip()]
    bad = [t for t in types if t not in MOVE_TYPES]
    if not types:
        raise argparse.ArgumentTypeError("no move types given")
    if bad:
        raise argparse.ArgumentTypeError(
            f"unknown move type(s) {','.join(bad)}; choose from {','.join(MOVE_TYPES)}")
    return types


def cmd_record(a: argparse.Namespace) -> int:
    from .record import record_dataset

    s = record_dataset(a.out, moves_per_type=a.moves_per_type, types=a.types, seed=a.seed,
                       robot=a.robot, effects_file=a.effects, storage=a.storage, jobs=a.jobs,
                       overwrite=a.overwrite, progress=not a.quiet)
    print(f"recorded {s.n_bags} bags ({s.n_steps} steps, {s.n_steps * 0.01:.0f} s of robot time) "
          f"into {s.out} in {s.wall_s:.1f} s wall with {s.jobs} process(es); "
          f"{s.realtime_factor_per_core:.1f}x real time per core (CPU time)")
    return 0


def cmd_info(a: argparse.Namespace) -> int:
    from .data.summary import format_summary, summarise_dataset

    print(format_summary(summarise_dataset(a.data, check_bags=not a.index_only)))
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="littledog-mlsim",
                                description="Learned rigid-body simulator of the LittleDog quadruped.")
    sub = p.add_subparsers(dest="verb", required=True, metavar="VERB")

    r = sub.add_parser("record", help="trot the pybullet LittleDog and write one rosbag2 bag per move",
                       description="Record a dataset of trot moves (one bag per move) and dataset.yaml.")
    r.add_argument("--out", required=True, type=Path, help="dataset directory to create")
    r.add_argument("--moves-per-type", type=int, default=20, help="moves per type (default 20: 14 train / 6 test)")
    r.add_argument("--types", type=_types, default=list(MOVE_TYPES), help="comma-separated move types (default all 11)")
    r.add_argument("--seed", type=int, default=0, help="dataset seed (gait randomisation and sensor noise)")
    r.add_argument("--robot", choices=["measured", "nominal"], default="measured", help="robot configuration")
    r.add_argument("--effects", type=str, default=None, metavar="FILE.yaml",
                   help="effects to switch on while recording (never written into the dataset)")
    r.add_argument("--storage", choices=["mcap", "sqlite3"], default="mcap", help="rosbag2 storage plugin")
    r.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    r.add_argument("--overwrite", action="store_true", help="replace an existing dataset directory")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=cmd_record)

    for name in ("info", "dataset"):
        i = sub.add_parser(name, help="summarise a recorded dataset" + (" (alias of info)" if name == "dataset" else ""),
                           description="Summarise a dataset: bags per type and split, samples, motion per move type.")
        i.add_argument("--data", required=True, type=Path, help="dataset directory")
        i.add_argument("--index-only", action="store_true", help="read dataset.yaml only, do not open the bags")
        i.set_defaults(func=cmd_info)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except KeyboardInterrupt:
        print(f"littledog-mlsim {args.verb}: interrupted", file=sys.stderr)
        return 130
    except (CliError, ValueError, OSError, KeyError) as e:
        print(f"littledog-mlsim {args.verb}: error: {_one_line(e)}", file=sys.stderr)
        return 2
    except Exception as e:  # e.g. a user's effect plug-in failing inside a worker
        print(f"littledog-mlsim {args.verb}: error: {type(e).__name__}: {_one_line(e)}", file=sys.stderr)
        return 1


def _one_line(e: BaseException) -> str:
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__


if __name__ == "__main__":
    sys.exit(main())
