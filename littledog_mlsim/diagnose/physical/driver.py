"""The physical route's driver: :func:`identify`, the method of the package doc round by round.

Per round: screen every family x scope on a few fit moves (:func:`.screen.screen`), fit the
shortlist by re-simulation (:func:`.fit.fit`, a push's twin beside it, the best joint
hypothesis's related scopes), refit joint magnitudes on every fit move, then decide on held-out
moves (:func:`.validate.validate`); an accepted finding joins the base for the next round.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, fields, replace
from typing import Any, Callable, Sequence

import numpy as np

from ...data.recording import MoveRecording
from ..families import FAMILIES, library_size
from .advice import suspicions
from .channels import DEFAULT_HORIZONS_S, SEG_STARTS, errors, horizon_errors, measured
from .context import SearchContext
from .fit import fit, scope_variants, segments_only, wide_magnitude
from .records import Candidate, Finding, HeldOutDecision, PhysIdResult
from .resim import Move, Runner
from .screen import screen, shortlist
from .validate import push_twin, validate

__all__ = ["PhysicalOptions", "identify", "pick_moves"]


@dataclass(frozen=True)
class PhysicalOptions:
    """Options of :func:`identify`.

    ``robot``: the transducer's robot (name or RobotConfig; sensor noise is switched off).
    ``fit_per_type`` moves of each type choose and fit the effect, the next
    ``validate_per_type`` of each type decide on it; ``test_per_type`` TestPool moves of each
    type give the before/after; ``screen_moves`` of the fit moves are screened on; ``n_refine``
    hypotheses are fitted; ``excitation``: the dataset's command excitation [rad] (for the
    "cannot tell" advice); ``families``: the families searched (default all registered);
    ``observer``: called with each round's held-out decision (:class:`.records.HeldOutDecision`),
    a recorder for benchmarks that does not change the diagnosis.
    """

    robot: Any = "measured"
    fit_per_type: int = 1
    validate_per_type: int = 2
    test_per_type: int = 2
    alpha: float = 0.01
    min_gain: float = 0.05
    max_rounds: int = 1
    n_refine: int = 8
    jobs: int = 2
    screen_moves: int = 4
    excitation: float = 0.0
    families: Sequence[str] | None = None
    horizons_s: Sequence[float] = DEFAULT_HORIZONS_S
    observer: Callable[[HeldOutDecision], None] | None = None

    @classmethod
    def from_keywords(cls, base: "PhysicalOptions | None" = None, **kw: Any
                      ) -> "PhysicalOptions":
        """``base`` (default the defaults) with the keyword options ``kw`` (a ValueError
        names an unknown one)."""
        known = {f.name for f in fields(cls)}
        bad = sorted(set(kw) - known)
        if bad:
            raise ValueError(f"unknown physics option {bad[0]!r} (known: {', '.join(sorted(known))})")
        return replace(base or cls(), **kw)


@dataclass(frozen=True)
class _Split:
    """The moves of a run: recordings (fit, held-out, TestPool) and their index ranges."""

    recs: list[MoveRecording]
    F: list[int]
    V: list[int]
    T: list[int]


def pick_moves(recs: Sequence[MoveRecording], per_type: int, skip: int = 0) -> list[int]:
    """Indices of ``per_type`` moves of each type (after skipping ``skip`` of each)."""
    by: dict[str, list[int]] = {}
    for i, r in enumerate(recs):
        by.setdefault(r.move_type, []).append(i)
    out = []
    for t in sorted(by):
        out += by[t][skip:skip + per_type]
    return sorted(out)


def _split(train: Sequence[MoveRecording], test: Sequence[MoveRecording],
           o: PhysicalOptions) -> _Split:
    fit_idx = pick_moves(train, o.fit_per_type)
    val_idx = pick_moves(train, o.validate_per_type, skip=o.fit_per_type)
    if len(val_idx) < 3:
        val_idx = fit_idx
    test_idx = pick_moves(test, o.test_per_type) if len(test) else []
    recs = ([train[i] for i in fit_idx] + [train[i] for i in val_idx]
            + [test[i] for i in test_idx])
    n_fit, n_val = len(fit_idx), len(val_idx)
    return _Split(recs, list(range(n_fit)), list(range(n_fit, n_fit + n_val)),
                  list(range(n_fit + n_val, len(recs))))


def identify(train: Sequence[MoveRecording], test: Sequence[MoveRecording] = (),
             options: PhysicalOptions | None = None, *,
             progress: Callable[[str], None] | None = None, **kw: Any) -> PhysIdResult:
    """Identify effects on ``train`` (the TrainPool); report before/after on ``test``.
    ``options`` (:class:`PhysicalOptions`), or its fields as keywords."""
    from ...robot.config import as_config
    from ...robot.sim import InitialState, get_sim
    o = PhysicalOptions.from_keywords(options, **kw)
    say = progress or (lambda s: None)
    t_start = time.perf_counter()
    cfg = replace(as_config(o.robot), sensor_noise=False)
    sp = _split(train, test, o)
    moves = [Move(r.name, r.move_type, np.asarray(r.cmd, dtype=np.float64),
                  {k: InitialState.from_recording(r, k) for k in SEG_STARTS}) for r in sp.recs]
    runner = Runner(cfg, moves, o.jobs)
    robot_mass = get_sim(cfg).total_mass()
    try:
        ctx = _rebase(SearchContext(runner, (), [], [measured(r) for r in sp.recs]), ())
        baseline_h = horizon_errors([ctx.base_err[i] for i in sp.T or sp.V], o.horizons_s)
        say(f"physics: baseline re-simulation of {len(sp.recs)} moves ({len(sp.F)} fit, "
            f"{len(sp.V)} held out, {len(sp.T)} TestPool) with robot '{cfg.name}' in "
            f"{time.perf_counter() - t_start:.1f} s")
        findings, rejected = _rounds(ctx, sp, o, robot_mass,
                                     cfg.foot_friction * cfg.ground_friction, say)
        n_sims = runner.n_sims
    finally:
        runner.close()
    sus = suspicions(findings, rejected, o.excitation, o.alpha, o.min_gain)
    return PhysIdResult(findings, rejected, sus, cfg.name, len(sp.F), len(sp.V), n_sims,
                        time.perf_counter() - t_start, o.alpha, o.min_gain, library_size(),
                        tuple(o.horizons_s), baseline_h, [])


def _rebase(ctx: SearchContext, base: Sequence[tuple]) -> SearchContext:
    """The context with ``base`` accepted: every move re-simulated with it (full runs)."""
    n = len(ctx.meas)
    sims = ctx.runner.map([(i, list(base), "full") for i in range(n)])
    return ctx.with_base(base, [errors(s, m) for s, m in zip(sims, ctx.meas)])


def _rounds(ctx: SearchContext, sp: _Split, o: PhysicalOptions, robot_mass: float,
            foot_mu: float, say: Callable[[str], None]) -> tuple[list[Finding], list[Finding]]:
    findings: list[Finding] = []
    rejected: list[Finding] = []
    for rnd in range(o.max_rounds):
        t1 = time.perf_counter()
        fin = _round(ctx, sp, o, robot_mass, foot_mu, say, rnd)
        say(f"physics round {rnd + 1}: {fin.statement}: p = {fin.p_value:.2g}, max held-out "
            f"cut {np.nanmax(fin.gain):.3f} -> "
            f"{'accepted' if fin.accepted else 'not accepted'} "
            f"({time.perf_counter() - t1:.1f} s)")
        if not fin.accepted:
            rejected.append(fin)
            break
        findings.append(fin)
        if rnd + 1 >= o.max_rounds:
            break
        ctx = _rebase(ctx, ctx.base + (fin.hyp,))
    return findings, rejected


def _round(ctx: SearchContext, sp: _Split, o: PhysicalOptions, robot_mass: float,
           foot_mu: float, say: Callable[[str], None], rnd: int) -> Finding:
    """One round: screen, fit the shortlist, decide on the held-out moves."""
    F = sp.F
    FS = F[::max(1, len(F) // o.screen_moves)][:o.screen_moves]  # screening and fit moves
    cands = screen(ctx, FS, list(FAMILIES if o.families is None else o.families), say)
    top = [fit(ctx, c, FS, F) for c in shortlist(cands, o.n_refine)]
    # the push class's other form, fitted on its own: the held-out moves then compare a push
    # and a slope each at its best magnitude (the shortlist holds one of them)
    for c in [c for c in top if FAMILIES[c.family].twin_family]:
        twin = push_twin(c, robot_mass)
        top.append(fit(ctx, replace(twin, magnitude=float(twin.fitted), fitted=None), FS, F))
    top += scope_variants(ctx, top, FS)
    # joint magnitudes too on every fit move, once the scope is chosen
    top = [wide_magnitude(ctx, c, F) if segments_only(c.family) else c for c in top]
    top.sort(key=lambda c: c.J / c.J0)
    say(f"physics round {rnd + 1}: fitted " + "; ".join(
        f"{c.family} {c.scope} {_fmt_params(c)} J {c.J / c.J0:.3f}" for c in top))
    return validate(ctx, top, sp.V, sp.T, o.alpha, o.min_gain, o.horizons_s, cands,
                    robot_mass, foot_mu, o.observer)


def _fmt_params(c: Candidate) -> str:
    return ", ".join(f"{k}={v:.3g}" if isinstance(v, (int, float)) else
                     f"{k}=({', '.join(f'{x:.3g}' for x in v)})" for k, v in c.params().items())
