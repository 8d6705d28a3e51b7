"""The residual loop end to end: screen, add, retrain, score on the TestPool, report.

:func:`diagnose` is what ``littledog-mlsim diagnose`` runs:

1. the TrainPool picks the effects (:func:`.selection.select_effects`, cross-fitted residuals of
   the search model; the TestPool is not read for that);
2. for the starting feature set and after each accepted effect, the *report model* (the method
   of ``--model``, else ``method``) is fitted on the whole TrainPool with that feature set and
   scored on the TestPool: one-step nMSE per state element and rollouts from every TestPool
   move's measured s_1 (alpha-PROJ, and the other projections asked for), with the extra
   features computed online (:class:`..models.features.FeatureHistory`);
3. the last model is written to ``OUT/model`` (a model file like any other; it records its
   feature set, so ``evaluate``/``rollout``/``sim_node`` serve it like the baseline), and
   ``OUT/report.json`` / ``OUT/report.md`` (+ figures) are written by :mod:`.report`.
"""
from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np

from ..data.dataset import load_moves, read_index
from ..data.recording import MoveRecording
from ..models.features import FeatureSet
from .candidates import BASELINES, default_library
from .options import AutoRoute, DiagnoseOptions, LearnedRoute, PhysicalRoute
from .selection import SearchModel, select_effects

if TYPE_CHECKING:
    from .conditions import Conditions

__all__ = ["diagnose", "fit_report_model", "score_on_test", "DEFAULT_METHOD",
           "DEFAULT_OPTIONS"]

DEFAULT_METHOD = "lgpr"
DEFAULT_OPTIONS: dict[str, dict[str, Any]] = {
    "lgpr": {"cluster_size": 500},
}
ROLLOUT_KEYS = ("final_xy_error_m", "final_xy_error_m_median", "final_xy_error_m_p90",
                "n_nan_moves", "element_error_sum_mean", "nmse_at_horizon")


def fit_report_model(feature_set: FeatureSet, method: str, options: Mapping[str, Any] | None,
                     train: Sequence[MoveRecording], *, target: str = "delta", seed: int = 0,
                     info: Mapping[str, Any] | None = None):
    """A one-step model of ``method`` with ``feature_set`` fitted on the recordings ``train``
    (the pipeline's :func:`..models.train.fit_onestep`, on all samples; the diagnosis rolls
    out with the projections it is asked for, so no gate radius is computed here)."""
    from ..models.train import fit_onestep
    return fit_onestep(train, method, feature_set=feature_set, options=options,
                       random_state=seed, target=target, info=info, gate=False)


def score_on_test(model, test: Sequence[MoveRecording], projections: Sequence[str] = ("alpha",),
                  alpha: float = 0.5) -> dict[str, Any]:
    """One-step nMSE per state element and rollout errors of ``model`` on ``test``: the
    pipeline's :func:`..scoring.score_model`, kept in the report's stage schema (module doc)."""
    from ..scoring import RolloutSpec, score_model
    specs = [RolloutSpec(kind, alpha) for kind in projections]
    scores = score_model(model, test, specs)
    out: dict[str, Any] = {k: scores[k] for k in ("nmse", "nmse_mean", "n_samples")}
    out["rollout"] = {}
    for spec in specs:
        full = scores["rollout"][spec.label]
        block = {k: full.get(k) for k in ROLLOUT_KEYS}
        block["xy_error_vs_time_mean"] = full["xy_error_vs_time"]["mean"]
        block["rollout_wall_s"] = full.get("rollout_wall_s")
        out["rollout"][spec.label] = block
    return out


def _say(progress: bool) -> Callable[[str], None]:
    def say(text: str) -> None:
        if progress:
            print(f"diagnose: {text}", file=sys.stderr, flush=True)
    return say


@dataclass(frozen=True)
class _Run:
    """One diagnosis run: the dataset, where it writes, the starting model and the options."""

    data: str | os.PathLike
    out: Path
    index: Any
    train: Sequence[MoveRecording]
    test: Sequence[MoveRecording]
    start: FeatureSet
    loaded: Any                  # the model file started from, or None
    method: str
    model_options: dict[str, Any]
    target: str
    baseline_desc: str
    o: DiagnoseOptions
    say: Callable[[str], None]
    t_start: float
    loaded_once: dict[str, Any] = field(default_factory=dict)   # e.g. the reference's moves
    # decisions 043 and 044: the TrainPool and TestPool as recorded, where held frames were
    # filled in or a late sensor stream was re-stamped (``train``/``test`` are then the
    # corrected ones), the re-stamp and the repair
    as_recorded: tuple[Sequence[MoveRecording], Sequence[MoveRecording]] | None = None
    correction: dict[str, Any] | None = None
    repair: dict[str, Any] | None = None


def diagnose(data: str | os.PathLike, out: str | os.PathLike,
             diagnose_options: DiagnoseOptions | None = None, /, **keywords: Any
             ) -> dict[str, Any]:
    """Run the residual loop on the dataset ``data``; write ``out/report.json``, ``report.md``,
    figures and ``out/model``. Returns the report (the JSON document).

    ``diagnose_options`` (positional): a :class:`.options.DiagnoseOptions` (its ``route``:
    physical, learned or auto); or, instead, its fields as keywords (``options`` is the report
    model's options) with the route given by ``physics`` (``"on"``,
    ``"off"``, ``"auto"``, default), ``physics_options`` (keyword arguments of
    :func:`.physical.identify`), ``search``, ``library`` and ``max_rounds`` (the learned
    route's), as :meth:`.options.DiagnoseOptions.from_keywords` maps them.

    The physical route names effects by family x scope x parameter by re-simulation with the
    dataset's robot (multi-step output errors), then adds each found effect's online feature to
    the learned model; the learned route runs the residual loop of :mod:`.selection` on the
    learned model alone; auto takes the physical route if the dataset names a known robot.
    """
    if diagnose_options is not None and keywords:
        raise ValueError("diagnose: give DiagnoseOptions or keywords, not both")
    o = (diagnose_options if diagnose_options is not None
         else DiagnoseOptions.from_keywords(**keywords))
    say = _say(o.progress)
    t_start = time.perf_counter()
    index = read_index(data)
    train = load_moves(data, "train")
    test = load_moves(data, "test")
    say(f"{len(train)} TrainPool and {len(test)} TestPool moves from {data}")
    start, loaded, method, model_options, target, baseline_desc = _starting_model(o)
    run = _sensor_corrected(_Run(data, Path(out), index, train, test, start, loaded, method,
                                 model_options, target, baseline_desc, o, say, t_start))
    route, robot, why = choose_route(o, index.info)
    run.say(f"{route.name} route: {why}")
    if isinstance(route, PhysicalRoute):
        return _diagnose_physical(run, route, robot, why)
    return _diagnose_learned(run, route, why)


def choose_route(o: DiagnoseOptions, info: Mapping[str, Any]
                 ) -> tuple[PhysicalRoute | LearnedRoute, Any, str]:
    """(route, the physical route's robot, why): the report's ``route`` says which and why."""
    from ..robot.config import ROBOT_NAMES
    named = info.get("robot")
    if isinstance(o.route, LearnedRoute) and o.reference is not None and o.twin is None:
        if o.route.rollout is None:
            raise ValueError("a reference without a twin contrasts the rollout route's findings; "
                             "add --rollout-route")
        return o.route, None, ("asked for (--physics off): the learned model's own residual, "
                               f"each finding contrasted with the reference {o.reference}")
    if o.twin is not None or o.reference is not None:
        if isinstance(o.route, LearnedRoute):
            raise ValueError("a twin needs the physical route; drop --physics off")
        route = o.route.physical if isinstance(o.route, AutoRoute) else o.route
        if o.twin is not None:
            robot, whose = o.twin, f"the twin {_twin_words(o.twin)}"
        elif named in ROBOT_NAMES:
            robot, whose = named, f"the dataset's robot '{named}'"
        else:
            robot, whose = "nominal", "the nominal robot (the dataset names no known robot)"
        why = f"re-simulation with {whose}" + (
            f", its own errors cancelled against the reference {o.reference}"
            if o.reference is not None else " (given)" + _no_reference_words(o.twin))
        return route, robot, why
    if isinstance(o.route, AutoRoute):
        route = o.route.resolve(named)
        if isinstance(route, PhysicalRoute):
            return route, named, f"the dataset names the robot '{named}', re-simulated as a twin"
        return route, None, ("the dataset names no known robot (" + (
            f"'{named}'" if named else "an imported recording") + ") and no twin or reference "
            "is given: the learned model's own residual")
    if isinstance(o.route, PhysicalRoute):
        robot = named if named in ROBOT_NAMES else "measured"
        return o.route, robot, f"asked for (--physics on), re-simulation with '{robot}'"
    return o.route, None, "asked for (--physics off): the learned model's own residual"


def _no_reference_words(twin: Any) -> str:
    """What a twin without a reference cannot tell: its own errors from the data's effects;
    the recording a calibrated twin file was fitted on is named as the reference to give."""
    from ..robot.config import RobotConfig
    text = ("; with no reference, what the twin gets wrong is found as an effect of the data "
            "(--reference RECORDING cancels it")
    if twin is not None and not isinstance(twin, RobotConfig) and str(twin).endswith(".json"):
        try:
            from ..robot.twin import load_twin
            source = load_twin(twin).provenance.get("calibrated_from")
        except (OSError, ValueError):
            source = None
        data = source.get("data") if isinstance(source, Mapping) else None
        if isinstance(data, str) and data:
            return text + f"; this twin was calibrated on {data})"
    return text + ")"


def _twin_words(twin: Any) -> str:
    from ..robot.config import RobotConfig
    if isinstance(twin, RobotConfig):
        return f"'{twin.name}'"
    return f"'{twin}'"


def _starting_model(o: DiagnoseOptions) -> tuple[FeatureSet, Any, str, dict[str, Any], str, str]:
    """(feature set, loaded model or None, method, its options, target, description) of the
    model the diagnosis starts from."""
    from ..models.onestep import OneStepModel
    if o.model is not None:
        loaded = OneStepModel.load(o.model, feature_names=None)
        return (loaded.feature_set, loaded, loaded.method,
                dict(loaded.estimator.get_params() or {}), loaded.target, f"model {o.model}")
    if o.baseline not in BASELINES:
        raise ValueError(f"baseline must be one of {', '.join(BASELINES)}, got {o.baseline!r}")
    method = o.method or DEFAULT_METHOD
    options = o.options if o.options is not None else DEFAULT_OPTIONS.get(method, {})
    return (BASELINES[o.baseline](), None, method, dict(options or {}), "delta",
            f"{o.baseline} feature set")


def _diagnose_learned(run: _Run, route: LearnedRoute, why: str) -> dict[str, Any]:
    """The residual loop of :mod:`.selection` (and, with ``route.rollout``, the rollout route
    of :mod:`.learned` from where it ended), then the report model before/after."""
    from .report import write_report
    search = SearchModel(seed=run.o.seed) if route.search is None else route.search
    library = list(default_library() if route.library is None else route.library)
    sel = select_effects(run.train, run.start, library, search=search, alpha=run.o.alpha,
                         min_gain=run.o.min_gain, max_rounds=route.max_rounds, progress=run.say)
    feature_sets = [run.start]
    for picked in sel.accepted:
        feature_sets.append(feature_sets[-1].with_augmentation(picked.augmentation))
    conditions = _conditions(run)
    contrasts = _one_step_contrasts(run, sel, search, conditions)
    rollout = (None if route.rollout is None
               else _rollout_route(run, route, feature_sets[-1], conditions))
    for aug in ([] if rollout is None else _accepted(rollout, feature_sets[-1])):
        feature_sets.append(feature_sets[-1].with_augmentation(aug))
    stages, last_model = _stages(run, feature_sets, 1 if route.scheduler else route.jobs)
    keywords = _report_keywords(run, last_model)
    keywords["route"] = {"name": "learned", "why": why}
    from .families.learned import floor_plane
    keywords["floor_plane"] = floor_plane(run.train)
    if rollout is not None:
        keywords["rollout_route"] = rollout
    if conditions is not None:
        keywords["reference_conditions"] = conditions.to_dict()
    if contrasts is not None:
        keywords["one_step_contrasts"] = contrasts
    report = write_report(run.out, sel, stages, **keywords)
    change = (rollout or {}).get("unexplained_change") or {}
    carried = (rollout or {}).get("reference_change") or {}
    pushed = (rollout or {}).get("drift_change") or {}
    found = ", ".join([e["label"] for e in report["effects"]]
                      + [e["label"] + (" (a stand-in, not named)" if e.get("stand_in") else "")
                         for e in (rollout or {}).get("effects", [])]
                      + ([f"an unexplained change at {change['scope']}"]
                         if change.get("significant") else [])
                      + ([f"a push since the reference, about {_fmt_n(pushed['push'])} "
                          f"toward {pushed['push']['direction_deg']:.0f} deg (drift test)"]
                         if pushed.get("named") else [])
                      + ([f"a change since the reference: {carried['family']} at "
                          f"{carried['kept_scope']}"] if carried.get("named") else [])
                      + ([f"a late {run.correction['stream']} stream (re-stamped)"]
                         if run.correction else [])
                      + ([f"held {' and '.join(run.repair['streams'])} frames (filled in)"]
                         if run.repair and (_held_frames(run) or {}).get("significant")
                         else []))
    run.say(f"{'found ' + found if found else 'nothing significant'}; wrote "
            f"{run.out / 'report.md'} in {time.perf_counter() - run.t_start:.1f} s")
    return report


def _fmt_n(push: dict[str, Any]) -> str:
    """A named push's size for the closing line: "0.66 N", or "an unmeasured force"."""
    f = push.get("force_N")
    return "an unmeasured force" if f is None else f"{f:.2f} N"


def _rollout_route(run: _Run, route: LearnedRoute, start: FeatureSet,
                   conditions: "Conditions | None" = None) -> dict[str, Any]:
    """The rollout route's report, searched from ``start`` (what the one-step loop ended
    with)."""
    from .learned import diagnose_learned
    return diagnose_learned(run.train, run.test, start=start, options=route.rollout,
                            library=route.rollout_library, progress=run.say,
                            scheduler=route.scheduler, jobs=route.jobs,
                            reference=_reference_moves(run) if run.o.reference else None,
                            conditions=conditions)


def _one_step_contrasts(run: _Run, sel: Any, search: SearchModel,
                        conditions: "Conditions | None") -> list[dict[str, Any] | None] | None:
    """Decision 041: each effect the one-step loop accepted, contrasted with the reference
    (:mod:`.one_step_contrast`; aligned with ``sel.accepted``, None for one decision 031 does
    not contrast); None without a reference."""
    if run.o.reference is None:
        return None
    from .conditions import cannot_contrast
    from .one_step_contrast import contrast_findings
    found = contrast_findings(sel, _reference_moves(run), search,
                              skip=lambda aug: cannot_contrast(aug, conditions),
                              progress=run.say)
    return [None if c is None else c.to_dict() for c in found]


def _conditions(run: _Run) -> "Conditions | None":
    """The data's and the reference's recording conditions (:mod:`.conditions`, decision
    031); None without a reference. Where they differ, the run says so."""
    if run.o.reference is None:
        return None
    from .conditions import conditions_of
    c = conditions_of(run.index.info, read_index(run.o.reference).info,
                      os.fspath(run.data), f"reference {run.o.reference}")
    if not c.comparable:
        run.say(f"reference: {c.statement}; {c.recording}")
    return c


def _accepted(rollout: Mapping[str, Any], fs: FeatureSet) -> list[Any]:
    """The rollout route's accepted augmentations that ``fs`` does not carry yet."""
    from ..models.features import augmentation_from_dict
    out, names = [], set(fs.names)
    ref = rollout.get("reference", {})
    for e in rollout.get("effects", []) + ref.get("shared", []) + ref.get("not_comparable", []):
        aug = augmentation_from_dict(e["augmentation"])
        if not set(aug.columns()) & names:
            out.append(aug)
            names |= set(aug.columns())
    return out


def _report_keywords(run: _Run, last_model: Any) -> dict[str, Any]:
    """Writes the last model (if asked and fitted) and returns the report writers' keywords."""
    run.out.mkdir(parents=True, exist_ok=True)
    model_path = None
    if run.o.save_model and last_model is not None:   # None if the last stage's fit failed
        model_path = last_model.save(run.out / "model")
    return dict(data=os.fspath(run.data), dataset_info=run.index.info, timing=_timing(run),
                sensor_correction=run.correction, held_frames=_held_frames(run),
                frame_repair=run.repair,
                baseline=run.baseline_desc, method=run.method, options=run.model_options,
                model_path=None if model_path is None else os.fspath(model_path),
                n_train=len(run.train), n_test=len(run.test), figures=run.o.figures,
                seconds=time.perf_counter() - run.t_start)


def _diagnose_physical(run: _Run, route: PhysicalRoute, robot: Any, why: str
                       ) -> dict[str, Any]:
    """Physical identification (:mod:`.physical`), then the learned model before/after."""
    from ..robot.twin import robot_config_from
    from .physical import identify
    from .report import write_physical_report
    from .conditions import excitation_of
    conditions = _conditions(run)       # decision 052: the excess over it is read accordingly
    excitation = excitation_of(run.index.info, os.fspath(run.data))
    config = robot_config_from(robot)
    reference = _reference_moves(run)
    popts = route.options(run.o.alpha, run.o.min_gain, config, excitation)
    if conditions is not None:
        popts = replace(popts, reference_excitation=conditions.reference_excitation_rad)
    pid = identify(run.train, run.test, popts, reference=reference, progress=run.say)
    fs = run.start
    feature_sets = [run.start]
    effect_augs, effect_stage = [], []
    for f in pid.findings:
        aug = augmentation_for(f.family, f.scope, f.params)
        if aug is not None and not (set(aug.columns()) & set(fs.names)):
            fs = fs.with_augmentation(aug)
            feature_sets.append(fs)
        else:
            aug = None
        effect_augs.append(aug)
        effect_stage.append(len(feature_sets) - 1 + (run.as_recorded is not None))
    stages, last_model = _stages(run, feature_sets, 1 if popts.scheduler else popts.jobs)
    keywords = _report_keywords(run, last_model)
    if conditions is not None:
        keywords["reference_conditions"] = conditions.to_dict()
    keywords["route"] = {"name": "physical", "why": why, "robot": config.name,
                         "twin": None if run.o.twin is None else _plain_twin(run.o.twin),
                         "reference": None if run.o.reference is None
                         else os.fspath(run.o.reference)}
    report = write_physical_report(run.out, pid, effect_augs, effect_stage, stages, **keywords)
    found = "; ".join([e["physical"]["statement"] for e in report["effects"]]
                      + [f"unexplained against the reference, other at {u['scope']}"
                         for u in [((report["physics"].get("reference") or {})
                                    .get("unexplained") or {})] if u.get("named")])
    run.say(f"{'found: ' + found if found else 'nothing significant'}"
            + (f"; suspected: {', '.join(s['family'] for s in report['suspected'])}"
               if report["suspected"] else "")
            + f"; wrote {run.out / 'report.md'} in {time.perf_counter() - run.t_start:.1f} s")
    return report


def _plain_twin(twin: Any) -> str:
    from ..robot.config import RobotConfig
    return twin.name if isinstance(twin, RobotConfig) else os.fspath(twin)


def _reference_moves(run: _Run) -> list[MoveRecording]:
    """The reference dataset's TrainPool moves (none without a reference); a reference of
    another control step, or without moves, is refused in one line naming it."""
    if run.o.reference is None:
        return []
    if "reference_moves" in run.loaded_once:
        return run.loaded_once["reference_moves"]
    ref = read_index(run.o.reference)
    for key in ("control_dt_ns",):
        a, b = ref.info.get(key), run.index.info.get(key)
        if a is not None and b is not None and a != b:
            raise ValueError(f"reference {run.o.reference}: {key} {a} differs from the data's {b}")
    moves = load_moves(run.o.reference, "train")
    if not moves:
        raise ValueError(f"reference {run.o.reference}: no TrainPool moves")
    run.say(f"reference: {len(moves)} TrainPool moves from {run.o.reference}")
    run.loaded_once["reference_as_recorded"] = moves
    from .held_frames import reference_streams, repair
    streams = reference_streams(moves)
    if streams:                          # decision 044: a reference with held frames is made whole
        moves, filled = repair(moves, streams)
        run.say(f"held frames: the reference's {' and '.join(streams)} held on {filled} rows, "
                "filled in")
        run.loaded_once["reference_repaired"] = streams
    run.loaded_once["reference_moves"] = moves
    return moves


def _held_frames(run: _Run) -> dict[str, Any]:
    """The held-frame check (:mod:`.held_frames`) of the TrainPool as recorded, against the
    reference's as recorded where given (run once, before the timing check)."""
    if "held_frames" in run.loaded_once:
        return run.loaded_once["held_frames"]
    from .held_frames import HELD_ALPHA, held_frames
    _reference_moves(run)                        # a bad reference is refused, not skipped
    reference = run.loaded_once.get("reference_as_recorded")
    train = run.train if run.as_recorded is None else run.as_recorded[0]
    h = held_frames(train, reference, alpha=HELD_ALPHA)
    if reference is not None:
        h["reference_repaired"] = list(run.loaded_once.get("reference_repaired", []))
    pose = next(r for r in h["streams"] if r["stream"] == "pose")
    run.say("held frames: " + (h["statement"] if h["significant"] else
                               f"none to speak of (the pose held on "
                               f"{100 * pose['held_fraction']:.2f} % of the moving rows)"))
    run.loaded_once["held_frames"] = h
    return h


def _timing(run: _Run, train: Sequence[MoveRecording] | None = None) -> dict[str, Any]:
    """The sensor-timing check (:mod:`.timing`) of the TrainPool (``train``: as recorded, or
    with its held frames filled in), against the reference's where given (run once, after the
    held-frame check); a
    recording it cannot read (a move too short) gives an ``error`` entry instead."""
    if "timing" in run.loaded_once:
        return run.loaded_once["timing"]
    from .timing import TIMING_ALPHA, sensor_timing
    reference = _reference_moves(run) or None    # a bad reference is refused, not skipped
    if train is None:
        train = run.train if run.as_recorded is None else run.as_recorded[0]
    try:
        t = sensor_timing(train, reference, alpha=TIMING_ALPHA)
    except ValueError as exc:
        run.say(f"timing: not checked: {exc}")
        t = {"error": str(exc), "significant": False}
    else:
        run.say("timing: " + (t["statement"] if t["significant"] else
                              "the joint states and the pose agree (shift "
                              f"{t['shift_ms']:+.1f} ms, p = {t['p_value']:.2g})"))
    run.loaded_once["timing"] = t
    return t


def _sensor_corrected(run: _Run) -> _Run:
    """Decisions 044 and 043: where a sensor stream holds frames (:mod:`.held_frames`), they
    are filled in; then where the timing check (on those data) finds a late sensor stream, it
    is re-stamped (:mod:`.restamp`). Returns the run with its TrainPool and TestPool corrected
    (the data as recorded kept for the report's ``before``), or ``run`` itself."""
    from .held_frames import repair, repair_plan
    from .restamp import correction_from_timing, restamp
    train, test = run.train, run.test
    fixed = None
    plan = repair_plan(_held_frames(run))
    if plan is not None:
        train, f_tr = repair(run.train, plan["streams"], plan["velocity"])
        test, f_te = repair(run.test, plan["streams"], plan["velocity"])
        what = " and ".join("the pose" if s_ == "pose" else "the joint states"
                            for s_ in plan["streams"])
        fixed = {"streams": plan["streams"], "velocity": plan["velocity"],
                 "rows_filled": f_tr + f_te,
                 "reference_repaired": run.loaded_once.get("reference_repaired", []),
                 "statement": (f"{what}'s held frames filled in by interpolation before the "
                               f"search ({f_tr + f_te} rows); the search, the model after and "
                               "its TestPool scores use the repaired data")}
        run.say(f"held frames: {fixed['statement']}")
        h = run.loaded_once["held_frames"]
        if h.get("significant"):
            h["recording"] += ("; this diagnosis filled them in before its search "
                               "(frame_repair)")
    correction = correction_from_timing(_timing(run, train))
    if correction is not None:
        try:
            train, test = restamp(train, correction), restamp(test, correction)
        except ValueError as exc:
            run.say(f"timing: not re-stamped: {exc}")
            correction = None
        else:
            run.say(f"timing: {correction['statement']}")
            run.loaded_once["timing"]["recording"] += ("; this diagnosis re-stamped the data "
                                                       "before its search (sensor_correction)")
    if fixed is None and correction is None:
        return run
    return replace(run, train=train, test=test, as_recorded=(run.train, run.test),
                   correction=None if correction is None else {**correction,
                                                               "stage_as_recorded": 0},
                   repair=None if fixed is None else {**fixed, "stage_as_recorded": 0})


def _corrected_label(run: _Run) -> str:
    """A stage's ``data`` on the corrected data: "re-stamped" (decision 043), "held frames
    filled in" (decision 044) or both."""
    return " and ".join((["held frames filled in"] if run.repair else [])
                        + (["re-stamped"] if run.correction else []))


def _stages(run: _Run, feature_sets: Sequence[FeatureSet], jobs: int = 1
            ) -> tuple[list[dict[str, Any]], Any]:
    """Fit and score the report model for every feature set (the loop's stages); an LGPR's
    clusters fit in ``jobs`` local processes (:func:`fit_options`). Where a sensor stream was
    re-stamped (decision 043), a first stage fits the starting feature set on the data as
    recorded and scores it on the TestPool as recorded (the report's ``before``); every stage
    then has ``data``: "as recorded" or "re-stamped"."""
    o = run.o
    stages: list[dict[str, Any]] = []
    last_model = None
    plan = [(fs_k, run.train, run.test, k == 0 and run.loaded is not None)
            for k, fs_k in enumerate(feature_sets)]
    if run.as_recorded is not None:
        plan = [(feature_sets[0], *run.as_recorded, run.loaded is not None)] + [
            (fs_k, tr, te, False) for fs_k, tr, te, _ in plan]
    for k, (fs_k, train, test, use_loaded) in enumerate(plan):
        t0 = time.perf_counter()
        if use_loaded:
            m, note = run.loaded, None
        else:
            info = {"diagnosis_stage": k, "data_dir": os.fspath(run.data)}
            m, note = _fit_with_fallback(fs_k, run.method,
                                         fit_options(run.method, run.model_options, jobs),
                                         train, run.target, o.seed, info, run.say)
        if m is None:
            scores = _failed_stage(note, o.projections, o.projection_alpha)
        else:
            scores = score_on_test(m, test, o.projections, o.projection_alpha)
            if note:
                scores["note"] = note
        if run.as_recorded is not None:
            scores["data"] = "as recorded" if k == 0 else _corrected_label(run)
        scores["feature_set"] = fs_k.to_dict()
        scores["feature_set_description"] = fs_k.describe()
        scores["fit_and_score_seconds"] = time.perf_counter() - t0
        stages.append(scores)
        last_model = m
        if m is None:
            run.say(f"stage {k} ({fs_k.describe()}): {note}")
            continue
        run.say(f"stage {k} ({fs_k.describe()}): TestPool nMSE mean {scores['nmse_mean']:.4f}, "
                f"final xy error {_fmt(scores['rollout'])} in {time.perf_counter() - t0:.1f} s")
    return stages, last_model


def augmentation_for(family: str, scope: str, params: Mapping[str, Any]):
    """The online feature (an :class:`..models.features.Augmentation`) that lets a learned model
    carry a physically identified effect, or None if the model trained on the data carries it
    already (a constant change of the robot is a function of the model's inputs): the family's
    :meth:`.families.Family.augmentation`."""
    from .families import FAMILIES
    return FAMILIES[family].augmentation(scope, params)


def fit_options(method: str, options: Mapping[str, Any], jobs: int) -> dict[str, Any]:
    """The report model's fit options: an LGPR's per-cluster fits run in ``jobs`` local
    processes unless its options name ``n_jobs`` (each cluster's fit depends only on its data
    and seed: LGPR's module doc)."""
    out = dict(options)
    if method == "lgpr" and jobs > 1 and "n_jobs" not in out:
        out["n_jobs"] = int(jobs)
    return out


def _fit_with_fallback(fs, method, options, train, target, seed, info, say):
    """(model, note): the report model, or (None, reason) if it cannot be fitted.

    LGPR's warm start fails on a cluster where an added column is constant up to rounding (a
    saturated tanh); it is then refitted from the median heuristic (init=cold), which does not
    always help either (reported to the LGPR owner).
    """
    try:
        return fit_report_model(fs, method, options, train, target=target, seed=seed,
                                info=info), None
    except (ValueError, np.linalg.LinAlgError) as e:
        first = f"{method} fit failed: {str(e).splitlines()[0]}"
        if method != "lgpr" or options.get("init") == "cold":
            return None, first
    say(f"{first}; refitting with init=cold")
    try:
        return (fit_report_model(fs, method, {**options, "init": "cold"}, train, target=target,
                                 seed=seed, info=info),
                f"{first}; refitted with init=cold")
    except (ValueError, np.linalg.LinAlgError) as e:
        return None, f"{first}; with init=cold too: {str(e).splitlines()[0]}"


def _failed_stage(note: str, projections: Sequence[str], alpha: float) -> dict[str, Any]:
    from ..layout import STATE_NAMES
    labels = [f"alpha_{alpha:g}" if k == "alpha" else k for k in projections]
    empty = {k: None for k in ROLLOUT_KEYS}
    empty["xy_error_vs_time_mean"] = []
    return {"error": note, "nmse": {n: None for n in STATE_NAMES}, "nmse_mean": None,
            "n_samples": 0, "rollout": {lab: dict(empty) for lab in labels}}


def _fmt(rollout: Mapping[str, Any]) -> str:
    parts = []
    for label, block in rollout.items():
        v = block.get("final_xy_error_m")
        parts.append(f"{label} {v:.3f} m" if v is not None else f"{label} diverged")
    return ", ".join(parts)
