"""The ``littledog-mlsim`` console script: one verb per job (``docs/interface.md`` §5).

Every verb prints ``--help``, shows progress on long work, and on bad input exits non-zero with a
one-line reason on stderr.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Sequence

from .layout import MOVE_TYPES
from .logs import setup_logging, teardown_logging

if TYPE_CHECKING:
    from .diagnose.options import DiagnoseOptions


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
    from .apps.record import record_dataset

    kinds = [k for k, _ in a.extra or []]
    twice = sorted({k for k in kinds if kinds.count(k) > 1})
    if twice:
        raise CliError(f"--extra gives {', '.join(twice)} more than once")
    s = record_dataset(a.out, moves_per_type=a.moves_per_type, types=a.types, seed=a.seed,
                       robot=a.robot, effects_file=a.effects, storage=a.storage, jobs=a.jobs,
                       overwrite=a.overwrite, progress=not a.quiet, excitation=a.excitation,
                       extra=dict(a.extra or []), start_spread=a.start_spread,
                       warmup=a.warmup)
    warm = f", each after {a.warmup:g} s of warm-up not kept" if a.warmup else ""
    print(f"recorded {s.n_bags} bags ({s.n_steps} steps, {s.n_steps * 0.01:.0f} s of robot time "
          f"simulated{warm}) into {s.out} in {s.wall_s:.1f} s wall with {s.jobs} process(es); "
          f"{s.realtime_factor_per_core:.1f}x real time per core (CPU time)")
    return 0


def cmd_info(a: argparse.Namespace) -> int:
    from .data.summary import format_summary, summarise_dataset

    print(format_summary(summarise_dataset(a.data, check_bags=not a.index_only)))
    return 0


def _extra_moves(text: str) -> tuple[str, int]:
    """``KIND=N`` of ``record --extra`` -> (kind, n)."""
    from .control.moves import MOVE_KINDS

    kind, sep, n = text.partition("=")
    if not sep or kind not in MOVE_KINDS or not (n.strip().isascii() and n.strip().isdigit()):
        raise argparse.ArgumentTypeError(f"expected KIND=N with KIND one of "
                                         f"{', '.join(MOVE_KINDS)} and N >= 0, got {text!r}")
    return kind, int(n)


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
    if a.dad < 0:
        raise CliError(f"--dad must be >= 0, got {a.dad}")
    if a.dad and a.features != "paper":
        raise CliError(f"--dad takes the paper's inputs only; drop --features {a.features}")
    if a.dad:
        extra_kw["dad_rounds"] = a.dad
    model = train_from_dataset(a.data, a.method, options=options, max_train_samples=a.n_train,
                               seed=a.seed, progress=not a.quiet, target=a.target, **extra_kw)
    model.save(a.out)
    extra = ""
    if a.method == "lgpr":
        extra = f", {model.estimator.n_clusters_} clusters"
    if a.dad:
        extra += f", {a.dad} DaD round(s) adding {sum(model.info['dad']['pairs_added'])} pairs"
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
    g.add_argument("--radius", type=_radius, default=None, metavar="R",
                   help="gated alpha-PROJ: leave states within R (normalised units) of their "
                        "nearest TrainPool state alone, pull only the excess (0: plain "
                        "alpha-PROJ; default: the model's own radius, the 0.9 quantile of its "
                        "TrainPool's leave-move-out distances, stored at training)")
    g.add_argument("--radius-quantile", type=_quantile, default=None, metavar="Q",
                   help="gated alpha-PROJ with R = the Q quantile of the distances of TrainPool "
                        "states to the nearest state of another TrainPool move (e.g. 0.9)")


def _add_scoring_options(p: argparse.ArgumentParser) -> None:
    """What ``evaluate`` and ``rollout`` share: model, data, output, alpha and the gate."""
    p.add_argument("--model", required=True, type=Path, help="model directory")
    p.add_argument("--data", required=True, type=Path, help="dataset directory")
    p.add_argument("--out", required=True, type=Path, help="output directory")
    p.add_argument("--alpha", type=_alpha, default=0.5, help="alpha of alpha-PROJ (default 0.5)")
    _add_radius_options(p)


def cmd_evaluate(a: argparse.Namespace) -> int:
    from .apps.evaluate import evaluate

    r = evaluate(a.model, a.data, a.out, projections=a.projections, alpha=a.alpha,
                 radius=a.radius, radius_quantile=a.radius_quantile)
    print(f"{r['method']}: mean one-step nMSE {r['nmse_mean']:.4f} over {r['n_samples']} TestPool samples")
    for label, v in r["rollout"].items():
        print(f"  rollout {label:<10} final (x,y) error {v['final_xy_error_m']} m "
              f"({v['realtime_factor']:.0f}x real time)")
    print(f"wrote {Path(a.out) / 'metrics.json'}")
    return 0


def cmd_rollout(a: argparse.Namespace) -> int:
    from .apps.evaluate import rollout_verb

    r = rollout_verb(a.model, a.data, a.out, kind=a.projection, alpha=a.alpha,
                     radius=a.radius, radius_quantile=a.radius_quantile)
    gate = f" (radius {r['radius']:.4g})" if "radius" in r else ""
    print(f"{r['method']} + {a.projection}{gate}: mean final (x,y) error "
          f"{r['final_xy_error_m']} m over "
          f"{len(r['per_move'])} TestPool moves; wrote {Path(a.out) / 'rollout.json'}")
    return 0


def cmd_reproduce(a: argparse.Namespace) -> int:
    from .apps.reproduce import reproduce

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


def diagnose_options(a: argparse.Namespace) -> DiagnoseOptions:
    """The diagnosis options of ``diagnose``'s parsed arguments (a CliError names bad ones)."""
    from .diagnose import DiagnoseOptions, LearnedRoute, PhysicalRoute, SearchModel
    from .diagnose.options import route_from_mode

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
                       "horizons_s": tuple(a.horizons), "initial_state": a.initial_state}
    if a.scheduler:
        physics_options["scheduler"] = a.scheduler
    route = route_from_mode(a.physics, PhysicalRoute(physics_options),
                            LearnedRoute(search=search, max_rounds=a.max_rounds,
                                         rollout=_rollout_options(a), scheduler=a.scheduler,
                                         jobs=a.jobs))
    twin = None
    if a.twin is not None:
        from .robot.twin import robot_config_from
        try:
            robot_config_from(a.twin)            # a bad twin fails here, in one line
        except ValueError as exc:
            raise CliError(f"--twin: {exc}") from None
        twin = a.twin
    if a.reference is not None and not (a.reference / "dataset.yaml").is_file():
        raise CliError(f"--reference {a.reference}: no dataset there (no dataset.yaml)")
    if twin is not None and a.physics == "off":
        raise CliError("--twin names effects by re-simulation; drop --physics off")
    if a.reference is not None and a.physics == "off" and not a.rollout_route:
        raise CliError("--reference with --physics off contrasts the rollout route's findings; "
                       "add --rollout-route")
    return DiagnoseOptions(
        route=route, twin=twin, reference=a.reference, model=a.model, baseline=a.baseline, method=a.method, options=options,
        alpha=a.significance, min_gain=a.min_gain, projections=a.projections,
        projection_alpha=a.alpha, seed=a.seed, figures=not a.no_figures, progress=not a.quiet)


def _rollout_options(a: argparse.Namespace) -> Any:
    """The rollout route's options (``--rollout-route``), or None."""
    if not a.rollout_route:
        return None
    from .diagnose.learned import LearnedOptions
    return LearnedOptions(seed=a.seed)


def cmd_diagnose(a: argparse.Namespace) -> int:
    from .diagnose import diagnose

    r = diagnose(a.data, a.out, diagnose_options(a))
    print_diagnosis(r, Path(a.out))
    return 0


def print_diagnosis(r: dict, out: Path) -> None:
    """The lines ``diagnose`` prints of its report: the effects, the suspects, the rollout
    route's verdict where it ran, a sensor-timing finding, and the one-step nMSE. Where the
    one-step loop's findings could not be compared with the reference (decision 031), the
    "nothing significant" line says so."""
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
    left = ((r.get("physics") or {}).get("reference") or {}).get("unexplained") or {}
    if left.get("named"):
        print(f"unexplained against the reference: other at {left['scope']}: "
              f"{left['statement']}")
    elif r["effects"]:
        pass
    elif not (r.get("rollout_route") or {}).get("significant"):
        nc, own = r.get("not_comparable") or [], r.get("shared") or []
        print("nothing significant: no candidate effect explains the residual" if not nc + own
              else "nothing significant against the reference: " + "; ".join(
                  ([f"{len(nc)} finding(s) of the joints' command response cannot be compared "
                    "with it (another command excitation; listed as suspected)"] if nc else [])
                  + ([f"{len(own)} finding(s) it shows as much (the robot's own: "
                      + ", ".join(e["label"] for e in own) + ")"] if own else [])))
    t = r.get("timing") or {}
    if t.get("significant"):
        print(f"timing: {t['statement']}")
    if r.get("rollout_route"):
        print(f"rollout route: {r['rollout_route'].get('verdict', '')}")
    b, f = r["before"]["nmse_mean"], r["after"]["nmse_mean"]
    nm = "n/a" if b is None or f is None else f"{b:.4f} -> {f:.4f}"
    print(f"one-step nMSE mean {nm}; wrote {out / 'report.md'}, report.json"
          f"{', model' if r.get('model') else ''}")


def cmd_calibrate(a: argparse.Namespace) -> int:
    from .robot.twin_fit import CalibrationOptions, calibrate_dataset

    if not a.data.is_dir():
        raise CliError(f"{a.data}: no such dataset directory")
    options = CalibrationOptions(params=tuple(a.params) if a.params else None, stride=a.stride,
                                 horizons=tuple(a.horizons), moves_per_type=a.moves_per_type,
                                 max_evals=a.max_evals, jobs=a.jobs, name=a.name,
                                 scheduler=a.scheduler, servo=a.servo,
                                 test_missing=not a.no_missing_test,
                                 initial_state=a.initial_state, add_asked=a.add_asked,
                                 threshold_round=not a.no_threshold_round,
                                 consider_spread=a.consider_spread, bootstrap=a.bootstrap,
                                 bootstrap_replicates=a.bootstrap_replicates,
                                 weighed_mass=a.weighed_mass, weighed_mass_sd=a.weighed_mass_sd,
                                 weigh_in_fit=a.weigh_in_fit, split_starts=a.split_starts,
                                 bootstrap_continued=a.bootstrap_continued,
                                 threshold_up=not a.no_threshold_up,
                                 jackknife=not a.no_jackknife)
    say = (lambda s: None) if a.quiet else (lambda s: print(s, file=sys.stderr, flush=True))
    cal = calibrate_dataset(a.data, a.robot, a.out, options, test_per_type=a.test_moves,
                            progress=say)
    print(format_calibration(cal.report))
    print(f"wrote {a.out} (robot {cal.config.name!r}) in {cal.report['wall_s']:.0f} s")
    return 0


def format_calibration(report: dict) -> str:
    """The calibration table ``calibrate`` prints: estimates, weak directions, rollouts."""
    import math

    def num(v: object) -> str:
        return "-" if v is None else f"{v:.4g}"

    lines = [f"{'parameter':<20} {'start':>9} {'value':>9}   95 % interval        unit"]
    for e in report["params"]:
        lo, hi = e["ci95"]
        stuck = f"  (at its {e['at_bound']} bound)" if e["at_bound"] else ""
        lines.append(f"{e['name']:<20} {num(e['start']):>9} {num(e['value']):>9}   "
                     f"[{num(lo)}, {num(hi)}]".ljust(64) + f" {e['unit']}{stuck}")
    boot = report.get("bootstrap") or {}
    if boot.get("params"):
        moved = [(n, b) for n, b in boot["params"].items() if b.get("applied")]
        refits = boot["iterations"] * boot.get("replicates", 1)
        lines.append(f"the fit's own bias, from {refits} refit(s) on the twin's own recordings "
                     "(--bootstrap), is taken out: "
                     + ", ".join(f"{n} {num(b['fitted'])} -> {num(b['corrected'])}"
                                 for n, b in moved) if moved else
                     "the fit's own bias (--bootstrap) is not taken out: every parameter is at "
                     "a bound, not bounded by the data, a threshold measured at one point or "
                     "refuted by the recording")
    check = boot.get("check") or {}
    if check and not check.get("accepted"):
        lines.append("the recording refutes the bias correction ("
                     + (f"it could not be checked: {check['error']}" if check.get("error") else
                        f"its k-step cost rises by {check['cost_rise']:.1f}, "
                        f"{check['allowed_rise']:.1f} allowed")
                     + "): the fit's values stand, each bias widens its interval")
    widened = [(n, b) for n, b in (boot.get("params") or {}).items()
               if b.get("widened_only") and not b.get("refuted")]
    if widened:
        again = ("(--bootstrap 2 measures it again)" if boot.get("iterations", 0) >= 1
                 and (report.get("settings") or {}).get("bootstrap", 1) == 1
                 else "(the second iteration did not finish)")
        lines.append("measured at one point, a threshold's bias widens its interval and is not "
                     f"taken out {again}: " + ", ".join(
                         f"{n} (bias {b['bias_coordinate'][-1]:+.3f} in the fit's coordinate)"
                         for n, b in widened))
    if boot.get("error"):
        lines.append(f"the bootstrap stopped: {boot['error']}")
    cont = report.get("continued")
    if cont:
        corrected = "skipped" not in boot and boot.get("iterations", 0) > 0
        failed = "skipped" not in boot and not corrected       # its correction's refit failed
        lines.append(("the fit stopped on its budget: fitted on from there"
                      if corrected or failed else
                      "the fit stopped on its budget, so no bias was taken out (--bootstrap "
                      "corrects an optimum only): fitted on from there")
                     + f" with the bootstrap's {cont['max_evals']} evaluations, "
                     + (f"which failed ({cont['error']})" if cont.get("error") else
                        f"k-step cost {num(cont['k_step_cost_before'])} -> "
                        f"{num(cont['k_step_cost_after'])}, "
                        + ("converged" if cont.get("converged") else "not converged either"))
                     + ("; the converged fit's bias then measured (--bootstrap-continued)"
                        if corrected else
                        "; measuring the converged fit's bias then failed (--bootstrap-continued)"
                        if failed else ""))
    split = report.get("split_starts") or {}
    if split.get("candidates"):
        others = [c for c in split["candidates"]
                  if c["start"] != split["chosen"] and not c.get("error")]
        failed = [c["start"] for c in others if (c.get("compared") or {}).get("error")]
        tied = [t for t in split.get("tied") or [] if t not in failed]
        kept = ("the fit's own" if split["chosen"] == "fit"
                else f"the {split['chosen']} start's")
        text = (f"second starts across the masses' split (--split-starts): kept {kept} "
                "minimum, k-step cost " + ", ".join(
                    f"{c['start']} " + (f"failed ({c['error']})" if c.get("error") else
                                        num(c["k_step_cost"]))
                    for c in split["candidates"]))
        if tied:
            text += f"; the data do not tell it from {', '.join(tied)}"
        elif others and not failed:
            text += "; the data tell it from the others"
        if failed:
            text += f"; not compared with {', '.join(failed)} (the comparison failed)"
        if split.get("widened"):
            text += f"; intervals widened over the tied minima: {', '.join(split['widened'])}"
        lines.append(text)
    elif split.get("skipped"):
        lines.append(f"no second starts (--split-starts): {split['skipped']}")
    consider = report.get("consider") or {}
    if consider.get("considered"):
        lines.append(f"the intervals include the {len(consider['considered'])} parameters not "
                     f"fitted, each uncertain by {100 * consider['spread']:.0f} % (1 sd; "
                     "--consider-spread)")
    for e in report["params"]:
        c = (consider.get("params") or {}).get(e["name"])
        data = e.get("ci95_data")
        sd_data = (report.get("sd_coordinate_data") or {}).get(e["name"])
        if c and data and sd_data is not None and c["sd_coordinate"] > sd_data:
            lines.append(f"{e['name']}: its interval is mostly what {', '.join(c['by'])} "
                         f"could be (the data alone: [{num(data[0])}, {num(data[1])}]); fit "
                         "them, or measure them")
    sym = report.get("scale_symmetry")
    w = (sym or {}).get("weighed")
    if w:
        lines.append(f"weighed {num(w['mass_kg'])} +- {num(w['sd_kg'])} kg: the fit's masses "
                     f"summed to {num(w['fitted_mass_kg'])} kg; the common scale of the masses "
                     f"and servo torques moved by {100 * math.expm1(w['scale_applied']):+.1f} % "
                     f"(95 % +- {196 * w['sd_scale']:.1f} %; the data alone "
                     + ("nothing" if w["sd_scale_data"] is None else
                        f"+- {196 * w['sd_scale_data']:.0f} %") + ")"
                     + (f"; stopped at the bounds of {', '.join(w['clipped'])}"
                        if w["clipped"] else ""))
        if w["cost_weighed"] > 1.05 * w["cost_fit"] and w.get("sd_scale_data_by"):
            lines.append(f"the weighing raised the fit's cost from {num(w['cost_fit'])} to "
                         f"{num(w['cost_weighed'])}: the data tie the scale to "
                         f"{', '.join(w['sd_scale_data_by'])} (not fitted); fit "
                         + ("it" if len(w["sd_scale_data_by"]) == 1 else "them"))
    if sym and not sym.get("identified") and not w:
        lines.append("the common scale of the masses and servo torques is not identified: "
                     "scaled together they leave the motion unchanged (derivative along it "
                     f"{num(sym['derivative'])}, the Jacobian's "
                     f"{num(sym['jacobian_derivative'])}); weigh the robot (--weighed-mass)")
    for w in report["weak_directions"]:
        lines.append(f"not identified: {w['describe']} (95 % half-width "
                     f"{num(w['halfwidth95'])} in log/typical units)")
    if not report["weak_directions"]:
        lines.append("every parameter direction identified (95 % half-width <= "
                     f"{report['settings']['weak_halfwidth']:g})")
    for k, rnd in enumerate(report.get("added") or [], 1):
        why = (f" ({', '.join(rnd['added_for_intervals'])} for the intervals)"
               if rnd.get("added_for_intervals") else "")
        late = " (a torque limit asked for after the last round)" if rnd.get(
            "threshold_round") else ""
        lines.append(f"round {k}{late}: added {', '.join(rnd['added'])}{why} to the fit; " + (
            f"the refit failed: {rnd['error']}" if "error" in rnd else
            f"k-step cost {num(rnd['k_step_cost_before'])} -> {num(rnd['k_step_cost_after'])}"))
    from .robot.parameters import TWIN_PARAMETERS

    settings = report.get("settings") or {}
    rounds = int(settings.get("add_asked") or 0)
    used_up = bool(rounds) and len(report.get("added") or []) >= rounds
    hint = (f"raise --add-asked above {rounds}, or add it to --params" if used_up else
            "add it to --params")
    held = used_up and settings.get("threshold_round") is False
    for m in report.get("missing") or []:
        par = TWIN_PARAMETERS.get(m.get("name"))
        limit_hint = ("drop --no-threshold-round, " + hint
                      if held and par is not None and par.threshold else hint)
        if "error" in m:
            lines.append(f"the test of the parameters not fitted failed: {m['error']}")
        elif m["asks"]:
            lines.append(f"the residual asks for {m['name']}: about {num(m['suggested'])} "
                         f"{m['unit']} (now {num(m['value'])}; p = {m['p']:.2g}, would remove "
                         f"{100 * m['cost_share']:.1f} % of the cost): {limit_hint}")
    if "structure" in report:
        st = report["structure"]
        costs = ", ".join(f"{c['servo']} {c['cost']:.4g}"
                          + (" (screened out after its first evaluations)"
                             if c.get("screened") else "") for c in st["candidates"])
        lines.append(f"servo structure: {st['chosen']} (k-step cost, lower is better: {costs})")
    if not report.get("converged", True):
        lines.append(f"not converged ({report['stop']}): the intervals leave out the distance "
                     f"to the optimum; raise --max-evals")
    if "rollout" in report:
        b, f = report["rollout"]["before"], report["rollout"]["after"]
        lines.append(f"TestPool rollout final (x, y) error: {num(b['final_xy_error_m'])} m -> "
                     f"{num(f['final_xy_error_m'])} m over "
                     f"{len(report['rollout']['test_moves'])} moves")
        if (b["final_xy_error_m"] is not None and f["final_xy_error_m"] is not None
                and f["final_xy_error_m"] > b["final_xy_error_m"]):
            lines.append("the calibrated twin ends its TestPool moves further off than the robot "
                         "it started from: its parameters absorb what its structure cannot "
                         "express, and its intervals then measure the fit, not the robot; "
                         + ("try --servo auto, and add the parameters the residual asks for"
                            if "structure" not in report else
                            "add the parameters the residual asks for, or fit more of them"))
    return "\n".join(lines)


def _import_options(a: argparse.Namespace):
    """ImportOptions from the ``import`` options (shared with trainer_node's import_options)."""
    from .data.importer import ImportOptions

    move_types = tuple(("U" if t.strip().lower() in ("u", "unknown") else t.strip().upper())
                       if t.strip() else None for t in (a.move_type or []))
    order = tuple(x.strip() for x in a.cmd_joint_order.split(",")) if a.cmd_joint_order \
        else ImportOptions().cmd_joint_order
    return ImportOptions(
        cmd_topic=a.cmd_topic, joint_states_topic=a.joint_states_topic, pose_topic=a.pose_topic,
        cmd_joint_order=order, time_source=a.time_source, clock_tolerance_s=a.clock_tolerance,
        gap_s=a.gap, reset_jump_m=a.reset_jump_m, reset_jump_rad=a.reset_jump_rad,
        joint_jump_rad=a.joint_jump_rad, min_segment_s=a.min_segment, max_move_s=a.max_move,
        cmd_cutoff_s=a.cmd_cutoff, twist=a.twist, dejitter=not a.no_dejitter,
        move_types=move_types,
        infer_types=not a.no_infer, test_fraction=a.test_fraction, storage=a.storage,
        skip_bad_bags=a.skip_bad, command_excitation_rad=a.excitation)


def cmd_import(a: argparse.Namespace) -> int:
    from .data.importer import import_bags

    # warnings (a skipped or salvaged bag) come through main's package log handler, once
    opts = _import_options(a)
    if a.twin is not None:
        from .robot.twin import load_twin
        load_twin(a.twin)                  # a file, not a robot name
    robot = a.twin if a.twin is not None else a.robot
    r = import_bags(a.bags, a.out, opts, overwrite=a.overwrite, figure=not a.no_figure,
                    robot=robot)
    types = ", ".join(f"{t} {n}" for t, n in _type_counts(r.report).items())
    rate = r.report.get("messages_per_s") or 0.0
    print(f"imported {r.n_moves} moves ({r.n_train} TrainPool / {r.n_test} TestPool; {types}) "
          f"from {len(r.report['bags'])} bag(s), {r.n_messages} messages ({rate:,.0f} messages/s) into "
          f"{r.out} in {r.wall_s:.1f} s; see {Path(r.out) / 'import_report.md'}")
    return 0


def _type_counts(report: dict) -> dict[str, int]:
    counts: dict[str, int] = {}
    for b in report.get("bags", []):
        for s in b.get("segments", []):
            counts[s["move_type"]] = counts.get(s["move_type"], 0) + 1
    return counts


def add_import_arguments(im: argparse.ArgumentParser) -> None:
    """The import options (also parsed by trainer_node from its import_options parameter)."""
    from .data.importer import ImportOptions, TIME_SOURCES, TWIST_SOURCES

    d = ImportOptions()
    im.add_argument("--cmd-topic", default=d.cmd_topic,
                    help="command topic: sensor_msgs/JointState, std_msgs/Float64MultiArray or "
                         "trajectory_msgs/JointTrajectory (default %(default)s)")
    im.add_argument("--joint-states-topic", default=d.joint_states_topic,
                    help="sensor_msgs/JointState topic (default %(default)s)")
    im.add_argument("--pose-topic", default=d.pose_topic,
                    help="nav_msgs/Odometry or geometry_msgs/PoseStamped topic (default %(default)s)")
    im.add_argument("--cmd-joint-order", default="", metavar="J1,J2,...",
                    help="joint names of a Float64MultiArray command's data, in order (default: "
                         "the contract order)")
    im.add_argument("--time-source", choices=TIME_SOURCES, default=d.time_source,
                    help="per topic: header stamps or receive (bag) time; auto (default) uses "
                         "stamps on the bag clock, shifts stamps of another clock onto it and "
                         "falls back to receive time for zero or missing stamps")
    im.add_argument("--clock-tolerance", type=float, default=d.clock_tolerance_s, metavar="S",
                    help="stamps within this of receive time count as the bag clock (default %(default)s)")
    im.add_argument("--gap", type=float, default=d.gap_s, metavar="S",
                    help="a longer gap in joint states or pose splits a segment (default %(default)s)")
    im.add_argument("--reset-jump-m", type=float, default=d.reset_jump_m, metavar="M",
                    help="a pose jump this much beyond 2 m/s splits a segment (default %(default)s)")
    im.add_argument("--reset-jump-rad", type=float, default=d.reset_jump_rad, metavar="RAD",
                    help="an orientation jump this much beyond 10 rad/s splits a segment "
                         "(default %(default)s)")
    im.add_argument("--joint-jump-rad", type=float, default=d.joint_jump_rad, metavar="RAD",
                    help="a joint jump this much beyond 30 rad/s splits a segment (default %(default)s)")
    im.add_argument("--min-segment", type=float, default=d.min_segment_s, metavar="S",
                    help="drop shorter segments (default %(default)s)")
    im.add_argument("--max-move", type=float, default=d.max_move_s, metavar="S",
                    help="split longer segments into equal moves (default 0: never)")
    im.add_argument("--cmd-cutoff", type=float, default=d.cmd_cutoff_s, metavar="S",
                    help="the command of step k->k+1 is the newest received this long before "
                         "measurement k+1 (default %(default)s)")
    im.add_argument("--twist", choices=TWIST_SOURCES, default=d.twist,
                    help="body twist from the message or from the poses (default auto: the "
                         "message's if it has one)")
    im.add_argument("--no-dejitter", action="store_true",
                    help="joint states and pose on receive time: keep the receive times (default: "
                         "fit the sender's regular clock through the least-delayed messages)")
    im.add_argument("--move-type", action="append", metavar="TYPE",
                    help="move type of the bag's segments (F, FL, ..., S or U/unknown); give it "
                         "once for all bags or once per bag in order; empty: infer")
    im.add_argument("--no-infer", action="store_true",
                    help="do not infer move types from the motion: unlabelled segments are U")
    im.add_argument("--test-fraction", type=float, default=d.test_fraction, metavar="F",
                    help="TestPool share per move type, the last moves in recording order "
                         "(default %(default)s; 0: all TrainPool)")
    im.add_argument("--storage", choices=["mcap", "sqlite3"], default=d.storage,
                    help="storage of the written bags")
    im.add_argument("--skip-bad", action="store_true",
                    help="leave out a bag that cannot be imported (reported) instead of failing")
    im.add_argument("--excitation", type=float, default=d.command_excitation_rad, metavar="RAD",
                    help="std of the white noise the recorded commands carried for system "
                         "identification, written to dataset.yaml as record --excitation writes "
                         "it (default 0: none; at most 0.2); diagnose --reference compares it")
def cmd_view(a: argparse.Namespace) -> int:
    import logging

    from .viewer.app import ViewError, run

    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        return run(a)
    except ViewError as e:
        raise CliError(str(e)) from None


def build_parser() -> argparse.ArgumentParser:
    from .models.train import METHOD_NAMES   # the registry's methods, in the paper's order

    methods = list(METHOD_NAMES)
    p = argparse.ArgumentParser(prog="littledog-mlsim",
                                description="Learned rigid-body simulator of the LittleDog quadruped.")
    sub = p.add_subparsers(dest="verb", required=True, metavar="VERB")

    r = sub.add_parser("record", help="trot the pybullet LittleDog and write one rosbag2 bag per move",
                       description="Record a dataset of trot moves (one bag per move) and dataset.yaml.")
    r.add_argument("--out", required=True, type=Path, help="dataset directory to create")
    r.add_argument("--moves-per-type", type=int, default=20, help="moves per type (default 20: 14 train / 6 test)")
    r.add_argument("--types", type=_types, default=list(MOVE_TYPES), help="comma-separated move types (default all 11)")
    r.add_argument("--seed", type=int, default=0, help="dataset seed (gait randomisation and sensor noise)")
    r.add_argument("--robot", default="measured", metavar="NAME|TWIN.json",
                   help="robot: measured (default), nominal, or a twin file (`calibrate --out`)")
    r.add_argument("--effects", type=str, default=None, metavar="FILE.yaml",
                   help="effects to switch on while recording (never written into the dataset)")
    r.add_argument("--excitation", type=float, default=0.0, metavar="RAD",
                   help="std of white noise added to every joint command, for system identification "
                        "(default 0: the plain trot; at most 0.2)")
    r.add_argument("--start-spread", type=float, default=0.0, metavar="M",
                   help="start each move from its own place, up to M metres from the origin in x "
                        "and y, and its own heading (default 0: every move at the origin facing "
                        "+x; at most 5)")
    r.add_argument("--warmup", type=float, default=0.0, metavar="S",
                   help="walk each move for S seconds more before its recorded 4 s (the same "
                        "move continued), so that it starts from a settled gait instead of "
                        "standing (default 0; at most 60, whole 10 ms steps)")
    r.add_argument("--extra", type=_extra_moves, action="append", metavar="KIND=N",
                   help="N more TrainPool moves of KIND: trot (constant trots), switch (a "
                        "transition to another type within the move), varied (continuously "
                        "varied commands), each N per move type; velocity or waypoints "
                        "(closed-loop runs of that controller), N in all; repeatable")
    r.add_argument("--storage", choices=["mcap", "sqlite3"], default="mcap", help="rosbag2 storage plugin")
    r.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    r.add_argument("--overwrite", action="store_true", help="replace an existing dataset directory")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=cmd_record)

    t = sub.add_parser("train", help="fit a one-step model on a dataset's TrainPool",
                       description=f"Fit a one-step model ({', '.join(methods)}) on the TrainPool "
                                   "of a dataset and write it atomically to MODEL.")
    t.add_argument("--data", required=True, type=Path, help="dataset directory")
    t.add_argument("--method", required=True, choices=methods, help="regressor")
    t.add_argument("--out", required=True, type=Path, metavar="MODEL", help="model directory to write")
    t.add_argument("--n-train", type=int, default=None, metavar="N",
                   help="use a random subset of N TrainPool samples (default: all; gpr 2000, sor 10000)")
    t.add_argument("--target", choices=["delta", "next"], default="delta",
                   help="learn s_{t+1} - s_t (delta, default) or s_{t+1} (next)")
    t.add_argument("--seed", type=int, default=0, help="seed of the subset and the regressor")
    t.add_argument("--features", choices=["paper", "measured"], default="paper",
                   help="inputs: the paper's 45 (default) or those plus the measured robot's own "
                        "structure, the previous state (found by `diagnose`; see "
                        "benchmarks/diagnose/diagnose.md)")
    t.add_argument("--dad", type=int, default=0, metavar="N",
                   help="N rounds of Data as Demonstrator: the model's own rollouts over the "
                        "TrainPool (gated alpha-PROJ) added as inputs, the recorded next states "
                        "as targets, and the model fitted again (default 0; paper inputs only)")
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
    _add_scoring_options(e)
    e.add_argument("--projections", type=lambda t: [x for x in t.split(",") if x],
                   default=["none", "bound", "alpha"], help="comma-separated: none,bound,alpha")
    e.set_defaults(func=cmd_evaluate)

    o = sub.add_parser("rollout", help="roll a model out over every TestPool move",
                       description="Roll every TestPool move out from its measured initial state "
                                   "with its recorded commands: rollout.json.")
    _add_scoring_options(o)
    o.add_argument("--projection", choices=["none", "bound", "alpha"], default="alpha")
    o.set_defaults(func=cmd_rollout)

    rp = sub.add_parser("reproduce", help="the paper's Table I and Figs 4-7 on a dataset",
                       description="Train every method, write table1.csv/md, fig4.png and the "
                                   "rollout figures (Figs 5-7, animation).")
    rp.add_argument("--data", required=True, type=Path, help="dataset directory")
    rp.add_argument("--out", required=True, type=Path, help="output directory")
    rp.add_argument("--scale", choices=["small", "paper"], default="small")
    rp.add_argument("--methods", type=lambda t: [x for x in t.split(",") if x],
                   default=methods, help=f"comma-separated subset of {','.join(methods)}")
    rp.add_argument("--seed", type=int, default=0)
    rp.add_argument("--jobs", type=int, default=2, help="processes for the Fig. 4 fits")
    rp.add_argument("--no-fig4", action="store_true", help="skip Fig. 4")
    rp.add_argument("--no-rollouts", action="store_true", help="skip Figs 5-7 and the animation")
    rp.add_argument("--physics-config", type=Path, default=None, metavar="FILE.json",
                    help="tuned nominal robot (e.g. "
                         "benchmarks/physics_baseline/nominal_tuned.json) for the physics "
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
    dg.add_argument("--method", choices=methods, default=None,
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
    dg.add_argument("--twin", default=None, metavar="NAME|TWIN.json",
                    help="re-simulate with this robot (a robot name or a twin file, e.g. from "
                         "`calibrate`) instead of the dataset's; takes the physical route")
    dg.add_argument("--reference", type=Path, default=None, metavar="DATASET",
                    help="a clean recording of the same robot: report what changed since it, "
                         "cancelling the twin's own errors against it (twin: --twin, else the "
                         "dataset's robot, else nominal); takes the physical route, except with "
                         "--physics off --rollout-route, where each rollout-route finding must "
                         "gain more here than on the reference (no twin)")
    dg.add_argument("--rollout-route", action="store_true",
                    help="learned route: after the one-step loop, also search by held-out k-step "
                         "rollouts (world-fixed forces, time drift, ...: effects too small at one "
                         "step); report key rollout_route (docs/diagnosis.md). Opt-in: it still "
                         "alarms on clean data recorded with command excitation")
    dg.add_argument("--initial-state", choices=("measured", "smoothed"), default="measured",
                    help="physics: re-simulated segments start from the measured state "
                         "(default) or from a local fit of the body's pose around it")
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
                    help="worker processes: the physical route's re-simulations, the "
                         "rollout route's probes (--rollout-route) (default 2)")
    dg.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="re-simulate (physics) and roll out the rollout route's probes "
                         "(--rollout-route) on the workers of the Dask cluster at ADDRESS "
                         "(tcp://host:8786; `dask scheduler`, `dask worker ADDRESS`) instead of "
                         "here; the same result")
    dg.set_defaults(func=cmd_diagnose)

    im = sub.add_parser("import", help="turn recorded bags (ros2 bag record, ROS 1) into a dataset",
                        description="Import rosbag2 bags (directories, .mcap or .db3 files) or "
                                    "ROS 1 .bag files: resample commands, joint states and pose "
                                    "onto the 10 ms grid, cut them into moves at gaps, pauses and "
                                    "resets, label and split them, and write a dataset (bags + "
                                    "dataset.yaml) with import_report.md/.json/.png, atomically "
                                    "(docs/import.md).")
    im.add_argument("bags", nargs="+", type=Path, metavar="BAG", help="bags to import")
    im.add_argument("--out", required=True, type=Path, metavar="DATASET",
                    help="dataset directory to create")
    add_import_arguments(im)
    what = im.add_mutually_exclusive_group()
    what.add_argument("--robot", default=None, metavar="NAME|TWIN.json",
                      help="the robot the bags come from (measured, nominal or a twin file), "
                           "recorded in dataset.yaml; default: not recorded")
    what.add_argument("--twin", type=Path, default=None, metavar="TWIN.json",
                      help="the twin file of the robot the bags come from (as --robot, a file "
                           "only)")
    im.add_argument("--overwrite", action="store_true", help="replace an existing dataset directory")
    im.add_argument("--no-figure", action="store_true", help="skip import_report.png")
    im.set_defaults(func=cmd_import)

    cb = sub.add_parser("calibrate", help="fit a twin's physical parameters to a recording",
                        description="Fit physical parameters of a pybullet robot (masses, servo "
                                    "gains and limits, friction, armature, command delay, rate "
                                    "filter) to the "
                                    "TrainPool of a dataset by re-simulation (weighted least "
                                    "squares on one- and few-step residuals), report 95 % "
                                    "intervals, parameters stuck at a bound, directions the data "
                                    "cannot identify and the TestPool rollout error before and "
                                    "after, and write the twin file atomically.")
    cb.add_argument("--data", required=True, type=Path, help="dataset directory (the reference)")
    cb.add_argument("--robot", default="nominal", metavar="NAME|TWIN.json",
                    help="robot to start from: nominal (default), measured or a twin file")
    cb.add_argument("--out", required=True, type=Path, metavar="TWIN.json",
                    help="twin file to write (an existing twin file is replaced on success)")
    cb.add_argument("--params", type=lambda t: [x.strip() for x in t.split(",") if x.strip()],
                    default=None, metavar="P1,P2,...",
                    help="parameters to fit (default: the servo's gains and limits, masses, "
                         "ground friction); names in robot/parameters.py")
    cb.add_argument("--moves-per-type", type=int, default=2, metavar="N",
                    help="TrainPool moves per type fitted (default 2)")
    cb.add_argument("--test-moves", type=int, default=None, metavar="N",
                    help="TestPool moves per type rolled out before/after (default all)")
    cb.add_argument("--stride", type=int, default=20, help="steps between sampled states")
    cb.add_argument("--horizons", type=lambda t: [int(x) for x in t.split(",") if x],
                    default=[1, 10], metavar="H1,H2",
                    help="re-simulated control steps with a residual (default 1,10)")
    cb.add_argument("--max-evals", type=int, default=150,
                    help="most re-simulations of the fitted moves (default 150; a Jacobian "
                         "costs two per parameter)")
    cb.add_argument("--servo", choices=("keep", "position", "pd_torque", "auto"), default="keep",
                    help="servo structure fitted: the starting robot's (keep, default), the "
                         "position servo, the torque-mode PD, or auto: screen both (40 "
                         "evaluations each), fit the one far ahead or both, and keep the one "
                         "with the lower k-step residual")
    cb.add_argument("--no-missing-test", action="store_true",
                    help="skip the score test of the parameters not fitted (one re-simulation "
                         "each) that names what else the residual asks for")
    cb.add_argument("--add-asked", type=int, default=0, metavar="N",
                    help="after the fit, up to N times: add the parameters the score test asks "
                         "for and fit all again from the optimum (default 0; each round costs "
                         "up to --max-evals more re-simulations)")
    cb.add_argument("--no-jackknife", action="store_true",
                    help="leave the leave-one-move-out jackknife out of the intervals' standard "
                         "deviations (by default it is among them, and the widest is used: the "
                         "per-move sandwich is too narrow for a parameter that few moves pin)")
    cb.add_argument("--no-threshold-up", action="store_true",
                    help="score-test a torque limit not fitted by lowering it only (by default "
                         "it is raised too: a limit that binds in the twin and not in the robot "
                         "shows only raised)")
    cb.add_argument("--no-threshold-round", action="store_true",
                    help="with --add-asked N: do not give a torque limit the score test asks "
                         "for after the N rounds one more round of its own (by default it gets "
                         "one: a limit the twin's motion does not reach shows only once a fit "
                         "has moved the twin to where it binds)")
    cb.add_argument("--consider-spread", type=float, default=0.15, metavar="SD",
                    help="a-priori standard deviation of every parameter not fitted, as a "
                         "fraction (default 0.15): the intervals include the shift of the "
                         "optimum it could cause; 0 gives the data's intervals alone")
    cb.add_argument("--bootstrap", type=int, default=0, metavar="N",
                    help="take out the fit's own bias: the calibrated twin records the fitted "
                         "moves again (their commands, the recording's sensing) and is fitted "
                         "again; the shift is subtracted, N times over from the corrected twin "
                         "(default 0: off; 2 measures how much the bias moves, and the "
                         "intervals carry it; each refit costs about an --add-asked round)")
    cb.add_argument("--bootstrap-replicates", type=int, default=1, metavar="R",
                    help="with --bootstrap: R noise seeds per iteration (default 1); the bias "
                         "is their mean, and where they scatter more than the data's interval "
                         "says, the intervals take their spread (R refits per iteration)")
    cb.add_argument("--bootstrap-continued", action="store_true",
                    help="with --bootstrap: a fit that stopped on its budget is fitted on from "
                         "there (always), and where that converges its bias is then taken out "
                         "as well (off by default: the bootstrap's refits come on top of the "
                         "continuation's time)")
    cb.add_argument("--weighed-mass", type=float, default=None, metavar="KG",
                    help="the robot's mass on a scale: motion under gravity cannot tell the "
                         "common scale of every mass and servo torque, so the fitted twin is "
                         "moved along it to this total (weighted against what the data say) "
                         "and its parameters get their intervals from the weighing")
    cb.add_argument("--weigh-in-fit", action="store_true",
                    help="with --weighed-mass: start the fit at the weighed total and hold it as "
                         "one more residual, so that the parameters off the common scale are "
                         "fitted where the scale is (off by default: measured, the rollouts "
                         "were worse)")
    cb.add_argument("--split-starts", type=float, default=0.0, metavar="F",
                    help="after the fit (and its --add-asked rounds), fit its parameters again "
                         "from the legs x(1-F) and x(1+F), the body taking the difference, and "
                         "keep the lowest k-step cost; intervals cover the minima the data do "
                         "not tell apart (default 0: off; 0.15 costs two more fits)")
    cb.add_argument("--weighed-mass-sd", type=float, default=0.01, metavar="KG",
                    help="the weighing's standard deviation (default 0.01 kg)")
    cb.add_argument("--initial-state", choices=("auto", "smoothed", "measured"), default="auto",
                    help="the re-simulations' starting states: smoothed (a local quadratic fit "
                         "of the body's pose, without the motion-capture noise of a 10 ms "
                         "difference in its twist), as measured, or auto (default): smoothed "
                         "where the recording's body-position noise exceeds 0.08 mm")
    cb.add_argument("--name", default=None, help="the twin's robot name (default ROBOT-calibrated)")
    cb.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    cb.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="run the fit's re-simulations on the workers of the Dask cluster at "
                         "ADDRESS instead of --jobs local processes (the TestPool rollouts stay "
                         "local)")
    cb.add_argument("--quiet", action="store_true", help="no progress lines")
    cb.set_defaults(func=cmd_calibrate)

    for name in ("info", "dataset"):
        i = sub.add_parser(name, help="summarise a recorded dataset" + (" (alias of info)" if name == "dataset" else ""),
                           description="Summarise a dataset: bags per type and split, samples, motion per move type.")
        i.add_argument("--data", required=True, type=Path, help="dataset directory")
        i.add_argument("--index-only", action="store_true", help="read dataset.yaml only, do not open the bags")
        i.set_defaults(func=cmd_info)

    from .viewer.app import add_arguments as _view_arguments

    vw = sub.add_parser("view", help="watch simulators live, or replay a move, in the browser",
                        description="A local web page with the LittleDog(s): live from ROS 2 "
                                    "topics (--live) or a replay with a timeline (--bag, --data "
                                    "--move, --rollout; docs/viewer.md).")
    _view_arguments(vw)
    vw.set_defaults(func=cmd_view)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    handler = setup_logging(quiet=bool(getattr(args, "quiet", False)))
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
    finally:
        teardown_logging(handler)


def _one_line(e: BaseException) -> str:
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__


if __name__ == "__main__":
    sys.exit(main())
