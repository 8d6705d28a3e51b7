"""The ``littledog-mlsim`` console script: one verb per job (CONTRACT.md section 5).

Every verb prints ``--help``, shows progress on long work, and on bad input exits non-zero with a
one-line reason on stderr.
"""
from __future__ import annotations

import argparse
import os
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
                       overwrite=a.overwrite, progress=not a.quiet, excitation=a.excitation)
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
    if a.method == "lgpr" and "n_jobs" not in options:
        options["n_jobs"] = os.cpu_count() or 1
    if a.out.exists() and not (a.out.is_dir() and (a.out / META_FILE).is_file()):
        raise CliError(f"refusing to replace {a.out}: it exists and is not a model directory")
    if not a.data.is_dir():
        raise CliError(f"{a.data}: no such dataset directory")
    t0 = time.perf_counter()
    extra_kw = {}
    if a.features != "paper":  # the default model's features: diagnose.measured_robot_features
        from .diagnose.candidates import BASELINES
        extra_kw["feature_set"] = BASELINES[a.features]()
    model = train_from_dataset(a.data, a.method, options=options, max_train_samples=a.n_train,
                               seed=a.seed, progress=not a.quiet, target=a.target, **extra_kw)
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


def _radius(text: str) -> float:
    r = float(text)
    if not (r >= 0.0 and r < float("inf")):
        raise argparse.ArgumentTypeError(f"radius must be finite and >= 0, got {text}")
    return r


def _quantile(text: str) -> float:
    q = float(text)
    if not 0.0 <= q <= 1.0:
        raise argparse.ArgumentTypeError(f"quantile must be in [0, 1], got {text}")
    return q


def _add_radius_options(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--radius", type=_radius, default=0.0, metavar="R",
                   help="gated alpha-PROJ: leave states within R (normalised units) of their "
                        "nearest TrainPool state alone, pull only the excess (default 0: plain "
                        "alpha-PROJ)")
    g.add_argument("--radius-quantile", type=_quantile, default=None, metavar="Q",
                   help="gated alpha-PROJ with R = the Q quantile of the distances of TrainPool "
                        "states to the nearest state of another TrainPool move (e.g. 0.9)")


def cmd_evaluate(a: argparse.Namespace) -> int:
    from .evaluate import evaluate

    r = evaluate(a.model, a.data, a.out, projections=a.projections, alpha=a.alpha,
                 radius=a.radius, radius_quantile=a.radius_quantile)
    print(f"{r['method']}: mean one-step nMSE {r['nmse_mean']:.4f} over {r['n_samples']} TestPool samples")
    for label, v in r["rollout"].items():
        print(f"  rollout {label:<10} final (x,y) error {v['final_xy_error_m']} m "
              f"({v['realtime_factor']:.0f}x real time)")
    print(f"wrote {Path(a.out) / 'metrics.json'}")
    return 0


def cmd_rollout(a: argparse.Namespace) -> int:
    from .evaluate import rollout_verb

    r = rollout_verb(a.model, a.data, a.out, kind=a.projection, alpha=a.alpha,
                     radius=a.radius, radius_quantile=a.radius_quantile)
    gate = f" (radius {r['radius']:.4g})" if "radius" in r else ""
    print(f"{r['method']} + {a.projection}{gate}: mean final (x,y) error "
          f"{r['final_xy_error_m']} m over "
          f"{len(r['per_move'])} TestPool moves; wrote {Path(a.out) / 'rollout.json'}")
    return 0


def cmd_reproduce(a: argparse.Namespace) -> int:
    from .reproduce import reproduce

    s = reproduce(a.data, a.out, scale=a.scale, methods=a.methods, seed=a.seed, fig4=not a.no_fig4,
                  rollouts=not a.no_rollouts, jobs=a.jobs, physics_config=a.physics_config,
                  progress=True)
    print(f"wrote Table I, Fig. 4{'' if a.no_rollouts else ' and Figs 5-7'} into {a.out} "
          f"in {s['wall_s']:.0f} s")
    return 0


def _fraction(text: str) -> float:
    v = float(text)
    if not 0.0 < v < 1.0:
        raise argparse.ArgumentTypeError(f"must be in (0, 1), got {text}")
    return v


def cmd_diagnose(a: argparse.Namespace) -> int:
    from .diagnose import SearchModel, diagnose

    if not a.data.is_dir():
        raise CliError(f"{a.data}: no such dataset directory")
    if a.model is not None and not a.model.exists():
        raise CliError(f"{a.model}: no such model")
    if a.model is not None and (a.method is not None or a.option):
        raise CliError("--method/--option set the report model; with --model it is the model's")
    if a.max_rounds < 0 or a.folds < 2 or a.random_features < 10:
        raise CliError("--max-rounds must be >= 0, --folds >= 2, --random-features >= 10")
    options = dict(a.option) if a.option else None
    search = SearchModel(n_random_features=a.random_features, n_folds=a.folds, seed=a.seed)
    if a.fit_moves < 1 or a.validate_moves < 1 or a.physics_rounds < 1 or a.jobs < 1:
        raise CliError("--fit-moves, --validate-moves, --physics-rounds and --jobs must be >= 1")
    if not a.horizons or any(h <= 0 or h > 4 for h in a.horizons):
        raise CliError("--horizons: comma-separated seconds in (0, 4]")
    physics_options = {"fit_per_type": a.fit_moves, "validate_per_type": a.validate_moves,
                       "max_rounds": a.physics_rounds, "jobs": a.jobs,
                       "horizons_s": tuple(a.horizons)}
    r = diagnose(a.data, a.out, model=a.model, baseline=a.baseline, method=a.method,
                 options=options, alpha=a.significance, min_gain=a.min_gain,
                 max_rounds=a.max_rounds, projections=a.projections, projection_alpha=a.alpha,
                 search=search, seed=a.seed, figures=not a.no_figures, progress=not a.quiet,
                 physics=a.physics, physics_options=physics_options)
    for e in r.get("effects", []):
        if "physical" in e:
            print(f"effect {e['round']}: {e['physical']['family']} on {e['physical']['scope']} "
                  f"{e['physical']['params']} (p = {e['p_value']:.2g}): "
                  f"{e['physical']['statement']}")
    for s in r.get("suspected", []):
        print(f"suspected: {s['family']} on {s['scope']}: {s['why']}; settle with: "
              f"{s['recording']}")
    if r["effects"] and "physics" in r:
        pass
    elif r["effects"]:
        for e in r["effects"]:
            cut = [v for v in e["nmse_cut"].values() if v is not None]
            print(f"effect {e['round']}: {e['family']} {e['label']} (p = {e['p_value']:.2g}) on "
                  f"{', '.join(e['outputs'][:6])}{' ...' if len(e['outputs']) > 6 else ''}; "
                  f"TestPool nMSE of those {100 * sum(cut) / max(len(cut), 1):.1f} % lower")
    else:
        print("nothing significant: no candidate effect explains the residual")
    b, f = r["before"]["nmse_mean"], r["after"]["nmse_mean"]
    nm = "n/a" if b is None or f is None else f"{b:.4f} -> {f:.4f}"
    print(f"one-step nMSE mean {nm}; wrote {Path(a.out) / 'report.md'}, report.json"
          f"{', model' if r.get('model') else ''}")
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
    r.add_argument("--excitation", type=float, default=0.0, metavar="RAD",
                   help="std of white noise added to every joint command, for system identification "
                        "(default 0: the plain trot; at most 0.2)")
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
    t.add_argument("--features", choices=["paper", "measured"], default="paper",
                   help="inputs: the paper's 45 (default) or those plus the measured robot's own "
                        "structure, the previous state (found by `diagnose`; see "
                        "benchmarks/diagnose.md)")
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
                   help="lgpr: worker processes for the cluster fits (default: all cores); "
                        "gpr: threads over outputs")
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
    _add_radius_options(e)
    e.set_defaults(func=cmd_evaluate)

    o = sub.add_parser("rollout", help="roll a model out over every TestPool move",
                       description="Roll every TestPool move out from its measured initial state "
                                   "with its recorded commands: rollout.json.")
    o.add_argument("--model", required=True, type=Path, help="model directory")
    o.add_argument("--data", required=True, type=Path, help="dataset directory")
    o.add_argument("--projection", choices=["none", "bound", "alpha"], default="alpha")
    o.add_argument("--alpha", type=_alpha, default=0.5, help="alpha of alpha-PROJ (default 0.5)")
    _add_radius_options(o)
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
    rp.add_argument("--physics-config", type=Path, default=None, metavar="FILE.json",
                    help="tuned nominal robot (e.g. benchmarks/nominal_tuned.json) for the physics "
                         "baseline curves")
    rp.set_defaults(func=cmd_reproduce)

    dg = sub.add_parser("diagnose", help="find what the model lacks in its residual, add it, report",
                        description="Screen a library of candidate effects (command delay, lagged "
                                    "states, friction, backlash, pose, time, contact, gait phase) "
                                    "against cross-fitted one-step residuals on the TrainPool, add "
                                    "the significant and material ones to the model, and report "
                                    "TestPool one-step nMSE and rollout errors before and after: "
                                    "report.md, report.json and the improved model in OUT/model.")
    dg.add_argument("--data", required=True, type=Path, help="dataset directory")
    dg.add_argument("--out", required=True, type=Path, help="output directory")
    dg.add_argument("--model", type=Path, default=None, metavar="MODEL",
                    help="start from this model (its features, method and options)")
    dg.add_argument("--baseline", choices=["measured", "paper"], default="measured",
                    help="without --model: start from the default model's features (measured, "
                         "the paper's 45 plus the measured robot's own structure) or the paper's 45")
    dg.add_argument("--method", choices=["lr", "lwpr", "gpr", "sor", "lgpr"], default=None,
                    help="report model fitted before/after each effect (default lgpr)")
    dg.add_argument("--option", type=_option, action="append", metavar="KEY=VALUE",
                    help="report model constructor argument (VALUE parsed as JSON); repeatable")
    dg.add_argument("--significance", type=_fraction, default=0.01,
                    help="family-wise significance level (default 0.01)")
    dg.add_argument("--min-gain", type=_fraction, default=0.05,
                    help="materiality: held-out nMSE cut of one element (default 0.05)")
    dg.add_argument("--max-rounds", type=int, default=4, help="most effects to add (default 4)")
    dg.add_argument("--projections", type=lambda t: [x for x in t.split(",") if x],
                    default=["alpha"], help="rollout projections to score (default alpha)")
    dg.add_argument("--alpha", type=_alpha, default=0.5, help="alpha of alpha-PROJ (default 0.5)")
    dg.add_argument("--random-features", type=int, default=1000,
                    help="search model: random Fourier features (default 1000)")
    dg.add_argument("--folds", type=int, default=5, help="search model: cross-fitting folds")
    dg.add_argument("--seed", type=int, default=0, help="seed of the search model and report model")
    dg.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    dg.add_argument("--quiet", action="store_true", help="no progress lines")
    dg.add_argument("--physics", choices=["auto", "on", "off"], default="auto",
                    help="name effects by physical identification (family x scope x parameter "
                         "by re-simulating the dataset's robot; docs/diagnosis.md); auto = on "
                         "when the dataset names a known robot; off = the learned residual loop "
                         "only (default auto)")
    dg.add_argument("--fit-moves", type=int, default=1,
                    help="physics: TrainPool moves per type that choose and fit (default 1)")
    dg.add_argument("--validate-moves", type=int, default=2,
                    help="physics: other TrainPool moves per type that decide (default 2)")
    dg.add_argument("--physics-rounds", type=int, default=1,
                    help="physics: most effects to identify (default 1)")
    dg.add_argument("--horizons", type=lambda t: [float(x) for x in t.split(",") if x],
                    default=[0.1, 0.5, 1.0, 4.0],
                    help="physics: reported error horizons [s] (default 0.1,0.5,1,4)")
    dg.add_argument("--jobs", type=int, default=2,
                    help="physics: re-simulation worker processes (default 2)")
    dg.set_defaults(func=cmd_diagnose)

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
