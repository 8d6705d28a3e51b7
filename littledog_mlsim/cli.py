"""The ``littledog-mlsim`` console script: one verb per job (CONTRACT.md section 5).

Every verb prints ``--help``, shows progress on long work, and on bad input exits non-zero with a
one-line reason on stderr.
"""
from __future__ import annotations

import argparse
import sys
import time
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


def _option(text: str) -> tuple[str, object]:
    """``KEY=VALUE`` -> (key, value), the value parsed as JSON when it is valid JSON."""
    import json

    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    try:
        return key.strip(), json.loads(value)
    except json.JSONDecodeError:
        return key.strip(), value


# train flag -> (constructor argument, methods that take it)
_TRAIN_FLAGS: dict[str, tuple[str, tuple[str, ...]]] = {
    "clusters": ("n_clusters", ("lgpr",)),
    "cluster_size": ("cluster_size", ("lgpr",)),
    "hyperparameters": ("hyperparameters", ("lgpr",)),
    "init": ("init", ("lgpr",)),
    "blend": ("blend", ("lgpr",)),
    "n_blend": ("n_blend", ("lgpr",)),
    "dask_scheduler": ("dask_scheduler", ("lgpr",)),
    "support_points": ("n_support", ("sor",)),
    "support": ("support", ("sor",)),
    "jobs": ("n_jobs", ("lgpr", "gpr")),
}


def cmd_train(a: argparse.Namespace) -> int:
    from .models.persistence import META_FILE
    from .models.train import train_from_dataset

    options: dict[str, object] = dict(a.option or [])
    for flag, (arg, methods) in _TRAIN_FLAGS.items():
        value = getattr(a, flag)
        if value is None or value is False:
            continue
        if a.method not in methods:
            raise CliError(f"--{flag.replace('_', '-')} applies to {'/'.join(methods)}, "
                           f"not {a.method}")
        options[arg] = value
    if a.out.exists() and not (a.out.is_dir() and (a.out / META_FILE).is_file()):
        raise CliError(f"refusing to replace {a.out}: it exists and is not a model directory")
    if not a.data.is_dir():
        raise CliError(f"{a.data}: no such dataset directory")
    t0 = time.perf_counter()
    model = train_from_dataset(a.data, a.method, options=options, max_train_samples=a.n_train,
                               seed=a.seed, progress=not a.quiet, target=a.target)
    model.save(a.out)
    extra = ""
    if a.method == "lgpr":
        extra = f", {model.estimator.n_clusters_} clusters"
    print(f"trained {a.method} (target {model.target}) on {model.info['n_train']} of "
          f"{model.info['n_train_pool']} TrainPool samples{extra} in "
          f"{time.perf_counter() - t0:.1f} s; wrote {a.out}")
    return 0


def _alpha(text: str) -> float:
    a = float(text)
    if not 0.0 <= a <= 1.0:
        raise argparse.ArgumentTypeError(f"alpha must be in [0, 1], got {text}")
    return a


def cmd_evaluate(a: argparse.Namespace) -> int:
    from .evaluate import evaluate

    r = evaluate(a.model, a.data, a.out, projections=a.projections, alpha=a.alpha)
    print(f"{r['method']}: mean one-step nMSE {r['nmse_mean']:.4f} over {r['n_samples']} TestPool samples")
    for label, v in r["rollout"].items():
        print(f"  rollout {label:<10} final (x,y) error {v['final_xy_error_m']} m "
              f"({v['realtime_factor']:.0f}x real time)")
    print(f"wrote {Path(a.out) / 'metrics.json'}")
    return 0


def cmd_rollout(a: argparse.Namespace) -> int:
    from .evaluate import rollout_verb

    r = rollout_verb(a.model, a.data, a.out, kind=a.projection, alpha=a.alpha)
    print(f"{r['method']} + {a.projection}: mean final (x,y) error {r['final_xy_error_m']} m over "
          f"{len(r['per_move'])} TestPool moves; wrote {Path(a.out) / 'rollout.json'}")
    return 0


def cmd_reproduce(a: argparse.Namespace) -> int:
    from .reproduce import reproduce

    s = reproduce(a.data, a.out, scale=a.scale, methods=a.methods, seed=a.seed, fig4=not a.no_fig4,
                  rollouts=not a.no_rollouts, jobs=a.jobs, progress=True)
    print(f"wrote Table I, Fig. 4{'' if a.no_rollouts else ' and Figs 5-7'} into {a.out} "
          f"in {s['wall_s']:.0f} s")
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

    t = sub.add_parser("train", help="fit a one-step model on a dataset's TrainPool",
                       description="Fit a one-step model (lr, lwpr, gpr, sor or lgpr) on the TrainPool "
                                   "of a dataset and write it atomically to MODEL.")
    t.add_argument("--data", required=True, type=Path, help="dataset directory")
    t.add_argument("--method", required=True, choices=["lr", "lwpr", "gpr", "sor", "lgpr"], help="regressor")
    t.add_argument("--out", required=True, type=Path, metavar="MODEL", help="model directory to write")
    t.add_argument("--n-train", type=int, default=None, metavar="N",
                   help="use a random subset of N TrainPool samples (default: all; gpr 2000, sor 10000)")
    t.add_argument("--target", choices=["delta", "next"], default="delta",
                   help="learn s_{t+1} - s_t (delta, default) or s_{t+1} (next)")
    t.add_argument("--seed", type=int, default=0, help="seed of the subset and the regressor")
    t.add_argument("--clusters", type=int, default=None, metavar="K", help="lgpr: number of k-means clusters")
    t.add_argument("--cluster-size", type=int, default=None, metavar="M",
                   help="lgpr: points per cluster when --clusters is not given (default 1000)")
    t.add_argument("--hyperparameters", choices=["shared", "per_output"], default=None,
                   help="lgpr: one kernel per cluster for all outputs (default) or one per output")
    t.add_argument("--init", choices=["warm", "cold"], default=None,
                   help="lgpr: start each cluster from a global GP (default) or the median heuristic")
    t.add_argument("--blend", action="store_true", help="lgpr: blend the nearest local models")
    t.add_argument("--n-blend", type=int, default=None, help="lgpr: local models in a blend (default 2)")
    t.add_argument("--support-points", type=int, default=None, metavar="M", help="sor: support points")
    t.add_argument("--support", choices=["cv", "random"], default=None, help="sor: support point selection")
    t.add_argument("--jobs", type=int, default=None, metavar="J",
                   help="lgpr: worker processes for the cluster fits; gpr: threads over outputs")
    t.add_argument("--dask-scheduler", default=None, metavar="ADDRESS",
                   help="lgpr: fit the clusters on this Dask cluster (tcp://host:port)")
    t.add_argument("--option", type=_option, action="append", metavar="KEY=VALUE",
                   help="any other constructor argument of the regressor (VALUE parsed as JSON); repeatable")
    t.add_argument("--quiet", action="store_true", help="no progress lines")
    t.set_defaults(func=cmd_train)

    e = sub.add_parser("evaluate", help="one-step nMSE and rollout errors of a model on the TestPool",
                       description="Score a model on a dataset's TestPool: metrics.json with nmse "
                                   "(state name -> one-step nMSE) and the rollout errors.")
    e.add_argument("--model", required=True, type=Path, help="model directory")
    e.add_argument("--data", required=True, type=Path, help="dataset directory")
    e.add_argument("--out", required=True, type=Path, help="output directory")
    e.add_argument("--projections", type=lambda t: [x for x in t.split(",") if x],
                   default=["none", "bound", "alpha"], help="comma-separated: none,bound,alpha")
    e.add_argument("--alpha", type=_alpha, default=0.5, help="alpha of alpha-PROJ (default 0.5)")
    e.set_defaults(func=cmd_evaluate)

    o = sub.add_parser("rollout", help="roll a model out over every TestPool move",
                       description="Roll every TestPool move out from its measured initial state "
                                   "with its recorded commands: rollout.json.")
    o.add_argument("--model", required=True, type=Path, help="model directory")
    o.add_argument("--data", required=True, type=Path, help="dataset directory")
    o.add_argument("--projection", choices=["none", "bound", "alpha"], default="alpha")
    o.add_argument("--alpha", type=_alpha, default=0.5, help="alpha of alpha-PROJ (default 0.5)")
    o.add_argument("--out", required=True, type=Path, help="output directory")
    o.set_defaults(func=cmd_rollout)

    rp = sub.add_parser("reproduce", help="the paper's Table I and Figs 4-7 on a dataset",
                       description="Train every method, write table1.csv/md, fig4.png and the "
                                   "rollout figures (Figs 5-7, animation).")
    rp.add_argument("--data", required=True, type=Path, help="dataset directory")
    rp.add_argument("--out", required=True, type=Path, help="output directory")
    rp.add_argument("--scale", choices=["small", "paper"], default="small")
    rp.add_argument("--methods", type=lambda t: [x for x in t.split(",") if x],
                   default=["lr", "lwpr", "gpr", "sor", "lgpr"], help="comma-separated subset")
    rp.add_argument("--seed", type=int, default=0)
    rp.add_argument("--jobs", type=int, default=2, help="processes for the Fig. 4 fits")
    rp.add_argument("--no-fig4", action="store_true", help="skip Fig. 4")
    rp.add_argument("--no-rollouts", action="store_true", help="skip Figs 5-7 and the animation")
    rp.set_defaults(func=cmd_reproduce)

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
