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
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..data.dataset import load_moves, read_index
from ..data.recording import MoveRecording
from ..models.features import FeatureSet
from .candidates import BASELINES, default_library
from .selection import (DEFAULT_ALPHA, DEFAULT_MIN_GAIN, SearchModel, select_effects)

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


def diagnose(data: str | os.PathLike, out: str | os.PathLike, *,
             model: str | os.PathLike | None = None, baseline: str = "measured",
             method: str | None = None, options: Mapping[str, Any] | None = None,
             alpha: float = DEFAULT_ALPHA, min_gain: float = DEFAULT_MIN_GAIN, max_rounds: int = 4,
             projections: Sequence[str] = ("alpha",), projection_alpha: float = 0.5,
             search: SearchModel | None = None, library: Sequence | None = None,
             seed: int = 0, save_model: bool = True, figures: bool = True,
             progress: bool = True, physics: str = "auto",
             physics_options: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Run the residual loop on the dataset ``data``; write ``out/report.json``, ``report.md``,
    figures and ``out/model``. Returns the report (the JSON document).

    ``physics``: ``"on"``/``"auto"`` (default): name effects by physical identification
    (:mod:`.physical`: family x scope x parameter by re-simulation with the dataset's robot,
    multi-step output errors), then add each found effect's online feature to the learned
    model; ``"auto"`` falls back to ``"off"`` if the dataset names no known robot.
    ``"off"``: the residual loop of :mod:`.selection` on the learned model alone.
    ``physics_options``: keyword arguments of :func:`.physical.identify`.

    ``model``: start from this model file (its feature set, method, options and target; its
    "before" scores are its own). Otherwise the starting feature set is ``baseline``
    (``"measured"``: the default model's, :func:`.candidates.measured_robot_features`;
    ``"paper"``: the 45 features) and the report model is ``method`` (default
    :data:`DEFAULT_METHOD`) with ``options``.
    """
    from ..models.onestep import OneStepModel
    from .report import write_report
    say = _say(progress)
    t_start = time.perf_counter()
    out = Path(out)
    index = read_index(data)
    train = load_moves(data, "train")
    test = load_moves(data, "test")
    say(f"{len(train)} TrainPool and {len(test)} TestPool moves from {data}")
    loaded = None
    target = "delta"
    if model is not None:
        loaded = OneStepModel.load(model, feature_names=None)
        start = loaded.feature_set
        method = loaded.method
        options = loaded.estimator.get_params()
        target = loaded.target
        baseline_desc = f"model {model}"
    else:
        if baseline not in BASELINES:
            raise ValueError(f"baseline must be one of {', '.join(BASELINES)}, got {baseline!r}")
        start = BASELINES[baseline]()
        method = method or DEFAULT_METHOD
        if options is None:
            options = DEFAULT_OPTIONS.get(method, {})
        baseline_desc = f"{baseline} feature set"
    options = dict(options or {})
    robot = index.info.get("robot")
    if physics not in ("on", "off", "auto"):
        raise ValueError(f"physics must be on, off or auto, got {physics!r}")
    if physics == "auto":
        from ..robot.config import ROBOT_NAMES
        physics = "on" if robot in ROBOT_NAMES else "off"
    if physics == "on":
        return _diagnose_physical(data, out, index, train, test, start, loaded, method, options,
                                  target, seed, baseline_desc, projections, projection_alpha,
                                  save_model, figures, say, t_start, robot or "measured",
                                  alpha, min_gain, physics_options or {})
    search = SearchModel(seed=seed) if search is None else search
    library = list(default_library() if library is None else library)

    sel = select_effects(train, start, library, search=search, alpha=alpha, min_gain=min_gain,
                         max_rounds=max_rounds, progress=say)

    # report model before and after every accepted effect
    fs = start
    feature_sets = [start] + [start for _ in sel.accepted]
    for k, picked in enumerate(sel.accepted):
        fs = fs.with_augmentation(picked.augmentation)
        feature_sets[k + 1] = fs
    stages, last_model = _stages(feature_sets, loaded, method, options, train, test, target,
                                 seed, data, projections, projection_alpha, say)
    out.mkdir(parents=True, exist_ok=True)
    model_path = None
    if save_model and last_model is not None:   # None if the last stage's fit failed
        model_path = last_model.save(out / "model")
    report = write_report(out, sel, stages, data=os.fspath(data), dataset_info=index.info,
                          baseline=baseline_desc, method=method, options=options,
                          model_path=None if model_path is None else os.fspath(model_path),
                          n_train=len(train), n_test=len(test), figures=figures,
                          seconds=time.perf_counter() - t_start)
    found = ", ".join(e["label"] for e in report["effects"])
    say(f"{'found ' + found if found else 'nothing significant'}; wrote {out / 'report.md'} in "
        f"{time.perf_counter() - t_start:.1f} s")
    return report


def _diagnose_physical(data, out, index, train, test, start, loaded, method, options, target,
                       seed, baseline_desc, projections, projection_alpha, save_model, figures,
                       say, t_start, robot, alpha, min_gain, physics_options):
    """Physical identification (:mod:`.physical`), then the learned model before/after."""
    from .physical import identify
    from .report import write_physical_report
    opts = {"alpha": alpha, "min_gain": min_gain, **dict(physics_options)}
    excitation = float(index.info.get("command_excitation_rad", 0.0) or 0.0)
    pid = identify(train, test, robot=robot, excitation=excitation, progress=say, **opts)
    fs = start
    feature_sets = [start]
    effect_augs, effect_stage = [], []
    for f in pid.findings:
        aug = augmentation_for(f.family, f.scope, f.params)
        if aug is not None and not (set(aug.columns()) & set(fs.names)):
            fs = fs.with_augmentation(aug)
            feature_sets.append(fs)
        else:
            aug = None
        effect_augs.append(aug)
        effect_stage.append(len(feature_sets) - 1)
    stages, last_model = _stages(feature_sets, loaded, method, options, train, test, target,
                                 seed, data, projections, projection_alpha, say)
    out.mkdir(parents=True, exist_ok=True)
    model_path = None
    if save_model and last_model is not None:
        model_path = last_model.save(out / "model")
    report = write_physical_report(
        out, pid, effect_augs, effect_stage, stages, data=os.fspath(data),
        dataset_info=index.info, baseline=baseline_desc, method=method, options=options,
        model_path=None if model_path is None else os.fspath(model_path), n_train=len(train),
        n_test=len(test), figures=figures, seconds=time.perf_counter() - t_start)
    found = "; ".join(e["physical"]["statement"] for e in report["effects"])
    say(f"{'found: ' + found if found else 'nothing significant'}"
        + (f"; suspected: {', '.join(s['family'] for s in report['suspected'])}"
           if report["suspected"] else "")
        + f"; wrote {out / 'report.md'} in {time.perf_counter() - t_start:.1f} s")
    return report


def _stages(feature_sets, loaded, method, options, train, test, target, seed, data,
            projections, projection_alpha, say):
    """Fit and score the report model for every feature set (the loop's stages)."""
    stages: list[dict[str, Any]] = []
    last_model = None
    for k, fs_k in enumerate(feature_sets):
        t0 = time.perf_counter()
        if k == 0 and loaded is not None:
            m, note = loaded, None
        else:
            info = {"diagnosis_stage": k, "data_dir": os.fspath(data)}
            m, note = _fit_with_fallback(fs_k, method, options, train, target, seed, info, say)
        if m is None:
            scores = _failed_stage(note, projections, projection_alpha)
        else:
            scores = score_on_test(m, test, projections, projection_alpha)
            if note:
                scores["note"] = note
        scores["feature_set"] = fs_k.to_dict()
        scores["feature_set_description"] = fs_k.describe()
        scores["fit_and_score_seconds"] = time.perf_counter() - t0
        stages.append(scores)
        last_model = m
        if m is None:
            say(f"stage {k} ({fs_k.describe()}): {note}")
            continue
        say(f"stage {k} ({fs_k.describe()}): TestPool nMSE mean {scores['nmse_mean']:.4f}, "
            f"final xy error {_fmt(scores['rollout'])} in {time.perf_counter() - t0:.1f} s")
    return stages, last_model


def augmentation_for(family: str, scope: str, params: Mapping[str, Any]):
    """The online feature (an :class:`..models.features.Augmentation`) that lets a learned model
    carry a physically identified effect, or None if the model trained on the data carries it
    already (a constant change of the robot is a function of the model's inputs): the family's
    :meth:`.families.Family.augmentation`."""
    from .families import FAMILIES
    return FAMILIES[family].augmentation(scope, params)


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
