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
from ...layout import LEGS
from .advice import suspicions
from .channels import (DEFAULT_HORIZONS_S, MIN_STEPS, errors, horizon_errors, measured,
                       seg_starts)
from .context import SearchContext
from .fit import (fit, form_variants, located_variants, scope_variants, segments_only,
                  wide_magnitude)
from .records import Candidate, Finding, HeldOutDecision, PhysIdResult
from .resim import DaskRunner, Memo, Move, Runner
from .screen import screen, shortlist
from .validate import push_twin, validate

__all__ = ["PhysicalOptions", "exceeds", "identify", "lead_channel", "p_words", "pick_moves",
           "remainder"]


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
    a recorder for benchmarks that does not change the diagnosis. With a reference recording:
    ``reference_per_type`` of its TrainPool moves of each type are the control, and at most
    ``reference_rounds`` findings are taken as the twin's errors (module doc);
    ``reference_excitation``: the reference's command excitation [rad] (None: taken to be the
    data's), which decides whether the excess left over it is compared (:func:`name_left`,
    decision 052). ``scheduler``:
    re-simulate on the workers of this Dask cluster (:class:`.resim.DaskRunner`) instead of
    ``jobs`` local processes; the result is the same. ``initial_state``: each re-simulated
    segment starts from the state as measured, or ``"smoothed"`` (a local fit of the body's
    pose around it, :meth:`~littledog_mlsim.robot.sim.InitialState.smoothed`).
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
    reference_per_type: int = 2
    reference_rounds: int = 3
    reference_excitation: float | None = None
    scheduler: str | None = None
    initial_state: str = "measured"

    @classmethod
    def from_keywords(cls, base: "PhysicalOptions | None" = None, **kw: Any
                      ) -> "PhysicalOptions":
        """``base`` (default the defaults) with the keyword options ``kw`` (a ValueError
        names an unknown one)."""
        known = {f.name for f in fields(cls)}
        bad = sorted(set(kw) - known)
        if bad:
            raise ValueError(f"unknown physics option {bad[0]!r} (known: {', '.join(sorted(known))})")
        out = replace(base or cls(), **kw)
        if out.initial_state not in ("measured", "smoothed"):   # robot.sim.INITIAL_STATES
            raise ValueError("physics option initial_state must be measured or smoothed, got "
                             f"{out.initial_state!r}")
        return out


@dataclass(frozen=True)
class _Split:
    """The moves of a run: recordings (fit, held-out, TestPool) and their index ranges."""

    recs: list[MoveRecording]
    F: list[int]
    V: list[int]
    T: list[int]
    R: list[int]         # the reference's moves (the control), empty without a reference


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
           o: PhysicalOptions, reference: Sequence[MoveRecording] = ()) -> _Split:
    fit_idx = pick_moves(train, o.fit_per_type)
    val_idx = pick_moves(train, o.validate_per_type, skip=o.fit_per_type)
    if len(val_idx) < 3:
        val_idx = fit_idx
    test_idx = pick_moves(test, o.test_per_type) if len(test) else []
    ref_idx = pick_moves(reference, o.reference_per_type) if len(reference) else []
    recs = ([train[i] for i in fit_idx] + [train[i] for i in val_idx]
            + [test[i] for i in test_idx])
    n_fit, n_val, n_main = len(fit_idx), len(val_idx), len(recs)
    recs += [reference[i] for i in ref_idx]
    return _Split(recs, list(range(n_fit)), list(range(n_fit, n_fit + n_val)),
                  list(range(n_fit + n_val, n_main)), list(range(n_main, len(recs))))


def identify(train: Sequence[MoveRecording], test: Sequence[MoveRecording] = (),
             options: PhysicalOptions | None = None, *,
             reference: Sequence[MoveRecording] = (),
             progress: Callable[[str], None] | None = None, **kw: Any) -> PhysIdResult:
    """Identify effects on ``train`` (the TrainPool); report before/after on ``test``.
    ``options`` (:class:`PhysicalOptions`), or its fields as keywords. ``reference``: clean
    recordings of the same robot (a reference dataset's TrainPool) to cancel the twin's own
    errors against (module doc)."""
    from ...robot.config import as_config
    from ...robot.sim import InitialState, get_sim
    o = PhysicalOptions.from_keywords(options, **kw)
    say = progress or (lambda s: None)
    t_start = time.perf_counter()
    cfg = replace(as_config(o.robot), sensor_noise=False)
    train, test, reference, notes = _long_enough(train, test, reference)
    for note in notes:
        say(f"physics: {note}")
    sp = _split(train, test, o, reference)
    moves = [Move(r.name, r.move_type, np.asarray(r.cmd, dtype=np.float64),
                  {k: InitialState.at(r, k, o.initial_state) for k in seg_starts(r.n_steps)},
                  seg_starts(r.n_steps)) for r in sp.recs]
    runner = Memo(DaskRunner(cfg, moves, o.scheduler) if o.scheduler
                  else Runner(cfg, moves, o.jobs))
    robot_mass = get_sim(cfg).total_mass()
    try:
        ctx = _rebase(SearchContext(runner, (), [], [measured(r) for r in sp.recs]), ())
        baseline_h = horizon_errors([ctx.base_err[i] for i in sp.T or sp.V], o.horizons_s)
        say(f"physics: baseline re-simulation of {len(sp.recs)} moves ({len(sp.F)} fit, "
            f"{len(sp.V)} held out, {len(sp.T)} TestPool"
            + (f", {len(sp.R)} of the reference" if sp.R else "")
            + f") with robot '{cfg.name}' in {time.perf_counter() - t_start:.1f} s")
        findings, rejected, twin_errors, ctx = _rounds(
            ctx, sp, o, robot_mass, cfg.foot_friction * cfg.ground_friction, say)
        left = None
        if sp.R:
            findings, left = _left_against_reference(ctx, findings, sp, o, say)
        n_sims = runner.n_sims
    finally:
        runner.close()
    sus = suspicions(findings, rejected, o.excitation, o.alpha, o.min_gain)
    if left is not None:
        left = name_left(left, _conditions(o))
        sus += left_suspicion(left, len(twin_errors) >= o.reference_rounds)
        if left["named"]:
            say("physics: unexplained: other at " + left["scope"] + ": " + left["statement"])
    res = PhysIdResult(findings, rejected, sus, cfg.name, len(sp.F), len(sp.V), n_sims,
                       time.perf_counter() - t_start, o.alpha, o.min_gain, library_size(),
                       tuple(o.horizons_s), baseline_h, notes)
    if sp.R:
        res.reference = {"n_moves": len(sp.R), "moves": [sp.recs[i].name for i in sp.R],
                         "twin_errors": twin_errors, "unexplained": left}
    return res


def _conditions(o: PhysicalOptions) -> Any:
    """The data's and the reference's command excitation (:class:`..conditions.Conditions`),
    or None where the reference's is not given."""
    if o.reference_excitation is None:
        return None
    from ..conditions import Conditions
    return Conditions(float(o.excitation), float(o.reference_excitation))


def _compared(left: dict[str, Any], conditions: Any) -> bool:
    """Whether ``left`` (:func:`unexplained`) is compared against the reference: recorded
    alike, or concentrated at one joint, leg or side where not (decisions 052 and 064,
    :func:`name_left`)."""
    if conditions is None or conditions.comparable:
        return True
    from ..learned import concentrated_at_joints
    return concentrated_at_joints(left)


def _left_against_reference(ctx: SearchContext, findings: list[Finding], sp: _Split,
                            o: PhysicalOptions, say: Callable[[str], None]
                            ) -> tuple[list[Finding], dict[str, Any]]:
    """(the findings, what is left): :func:`unexplained` with every finding in the twin; where
    that is significant and material, the same without the findings (the twin errors kept)
    reads them (:func:`remainder`, decision 045) and each finding carries it. "Significant
    and material" is :func:`exceeds` (decisions 062 and 063)."""
    if findings and findings[-1].hyp not in ctx.base:
        ctx = _rebase(ctx, ctx.base + (findings[-1].hyp,))
    left = unexplained(ctx, sp.V, sp.R, o.alpha)
    if findings and exceeds(left) and _compared(left, _conditions(o)):
        found = [f.hyp for f in findings]
        without = _rebase(ctx, tuple(h for h in ctx.base if h not in found))
        rem = remainder(unexplained(without, sp.V, sp.R, o.alpha), left)
        findings = [replace(f, remainder=rem) for f in findings]
        say(f"physics: the findings leave the data's error {rem['ratio_after']:.2f}x the "
            f"reference's ({p_words(rem)}; {rem['ratio_before']:.2f}x without "
            f"them): {rem['reading']}")
    return findings, left


def _long_enough(*groups: Sequence[MoveRecording]) -> tuple:
    """Each group of moves without those shorter than :data:`.channels.MIN_STEPS`, and a note
    per group that lost any (an imported move may be short); ValueError if the data keep none."""
    out, notes = [], []
    for name, g in zip(("TrainPool", "TestPool", "reference"), groups):
        keep = [r for r in g if r.n_steps >= MIN_STEPS]
        if len(keep) < len(g):
            notes.append(f"{len(g) - len(keep)} of {len(g)} {name} moves are shorter than "
                         f"{MIN_STEPS} steps and left out")
        out.append(keep)
    if not out[0]:
        raise ValueError(f"no TrainPool move has the {MIN_STEPS} steps the physical route "
                         "re-simulates; take the learned route (--physics off)")
    return (*out, notes)


def _rebase(ctx: SearchContext, base: Sequence[tuple]) -> SearchContext:
    """The context with ``base`` accepted: every move re-simulated with it (full runs)."""
    n = len(ctx.meas)
    sims = ctx.runner.map([(i, list(base), "full") for i in range(n)])
    return ctx.with_base(base, [errors(s, m) for s, m in zip(sims, ctx.meas)])


def _rounds(ctx: SearchContext, sp: _Split, o: PhysicalOptions, robot_mass: float,
            foot_mu: float, say: Callable[[str], None]
            ) -> tuple[list[Finding], list[Finding], list[dict[str, Any]], SearchContext]:
    """(findings, rejected, twin errors, the last context): rounds until one is not accepted or
    ``max_rounds`` findings. With a reference, a finding the reference shares joins the base as
    a twin error instead (at most ``reference_rounds`` of them); the same round's other fitted
    hypotheses are then tried as the change (:func:`_changed_alternative`), and the search
    stops once the data's held-out error no longer exceeds the reference's (:func:`unexplained`)."""
    findings: list[Finding] = []
    rejected: list[Finding] = []
    twin_errors: list[dict[str, Any]] = []
    rnd = 0
    while len(findings) < o.max_rounds:
        t1 = time.perf_counter()
        last: list[HeldOutDecision] = []
        fin, cands = _round(ctx, replace_observer(o, last), sp, robot_mass, foot_mu, say, rnd)
        rnd += 1
        verdict = "accepted" if fin.accepted else "not accepted"
        check = None
        if fin.accepted and sp.R:
            check = reference_check(ctx, fin, last[-1], sp.R, o.alpha)
            if not check["changed"]:
                verdict = "the reference shares it: a twin error, not a change"
        say(f"physics round {rnd}: {fin.statement}: p = {fin.p_value:.2g}, max held-out "
            f"cut {np.nanmax(fin.gain):.3f} -> {verdict} " + _check_text(check)
            + f"({time.perf_counter() - t1:.1f} s)")
        if not fin.accepted:
            rejected.append(fin)
            break
        if check is None or check["changed"]:
            if check is not None:
                fin = replace(fin, reference_check=check)
            findings.append(fin)
            if len(findings) >= o.max_rounds:
                break
            ctx = _rebase(ctx, ctx.base + (fin.hyp,))
            continue
        twin_errors.append({"family": fin.family, "scope": fin.scope, "params": fin.params,
                            "statement": fin.statement, "finding_p_value": fin.p_value,
                            **check})
        before, ctx = ctx, _rebase(ctx, ctx.base + (fin.hyp,))
        alt = _changed_alternative(before, ctx, last[-1], sp, o, robot_mass, foot_mu, cands, say)
        if alt is not None:
            findings.append(alt)
        if len(findings) >= o.max_rounds:
            break
        if len(twin_errors) >= o.reference_rounds:
            say("physics: the most twin errors the reference may cancel "
                f"({o.reference_rounds}) are taken; stopping")
            break
        if alt is not None:
            ctx = _rebase(ctx, ctx.base + (alt.hyp,))
            continue
        left = unexplained(ctx, sp.V, sp.R, o.alpha)
        if not left["significant"] and not left["channel_significant"]:
            say("physics: with the twin errors absorbed, the data's held-out error does not "
                f"exceed the reference's (pooled p = {left['p_value']:.2g}, per channel "
                f"p = {left['channel_p_value']:.2g}); stopping")
            break
    return findings, rejected, twin_errors, ctx


#: how many of a round's other significant hypotheses are tried as the change once its finding
#: is a twin error (each costs one re-simulation of the reference's moves)
MAX_ALTERNATIVES = 4


def _check_text(check: dict[str, Any] | None) -> str:
    if check is None:
        return ""
    return (f"(move cut {check['data_move_cut']:.3f} here, "
            f"{check['reference_move_cut']:.3f} on the reference, p = {check['p_value']:.2g}) ")


def _changed_alternative(before: SearchContext, after: SearchContext, held: HeldOutDecision,
                         sp: _Split, o: PhysicalOptions, robot_mass: float, foot_mu: float,
                         cands: Sequence[Candidate], say: Callable[[str], None]
                         ) -> Finding | None:
    """Once a round's finding is a twin error: the round's other fitted hypotheses that were
    significant and material on the data's held-out moves, best first (at most
    :data:`MAX_ALTERNATIVES`), each checked against the reference as the finding was
    (:func:`reference_check`, on the base it was fitted on, ``before``), at ``alpha`` over the
    number checked. Each that the reference does not share is, in turn, fitted again on the
    base with the twin error (``after``), decided again on the held-out moves at ``alpha`` over
    the number of hypotheses the round compared (its choice among them is not free), and
    checked against the reference again (same level); the first that passes is the round's
    finding. None if none does: the caller then tests what is left, or screens afresh."""
    order = sorted(range(len(held.hypotheses)), key=lambda k: -held.move_cut[k])
    eligible = [k for k in order if k != held.chosen
                and held.decisions[k].significant and held.decisions[k].material]
    eligible = eligible[:MAX_ALTERNATIVES]
    level = o.alpha / max(len(eligible), 1)
    for k in eligible:
        c = held.hypotheses[k]
        check = _contrast(before, c.hyp(), held.S0, held.S1[k], sp.R, level)
        say(f"physics: the round's alternative {c.family} {c.scope} "
            f"{'is a change' if check['changed'] else 'is shared with the reference'} "
            + _check_text(check))
        if not check["changed"]:
            continue
        start = c.fitted if c.fitted is not None else c.magnitude
        refit = fit(after, replace(c, magnitude=float(start), fitted=None),
                    _screen_moves(sp.F, o.screen_moves), sp.F)
        if segments_only(refit.family):
            refit = wide_magnitude(after, refit, sp.F)
        last: list[HeldOutDecision] = []
        fin = validate(after, [refit], sp.V, sp.T, o.alpha / len(held.hypotheses), o.min_gain,
                       o.horizons_s, cands, robot_mass, foot_mu, last.append)
        check = reference_check(after, fin, last[-1], sp.R, level) if fin.accepted else None
        ok = fin.accepted and check["changed"]
        say(f"physics: with the twin error absorbed: {fin.statement}: p = {fin.p_value:.2g} "
            f"(at {o.alpha / len(held.hypotheses):.2g}) -> "
            + ("accepted, a change " if ok else "not accepted ") + _check_text(check))
        if ok:
            return replace(fin, reference_check=check)
    return None


def left_suspicion(left: dict[str, Any], capped: bool) -> list[dict[str, Any]]:
    """The ``suspected`` entry (kind ``unexplained``) for what :func:`unexplained` leaves: an
    excess over the reference that is significant and material, pooled or in a few channels
    (:func:`exceeds`); one that is material pooled and not significant by either test (the
    data cannot tell it from chance); one that is significant in a few channels but not
    material there; none otherwise (neither significant nor material, or significant pooled
    only and not material). ``capped``: the search stopped at the most corrections the
    reference may cancel."""
    from ..excess import RECORDINGS
    exceeding = exceeds(left)
    untold = left["material"] and not _significant(left)
    if not (exceeding or untold or left.get("channel_significant")):
        return []
    where = ", ".join(c["channel"] for c in left["channels"][:4])
    cond = left.get("conditions") or {}
    apart = cond.get("comparable") is False and not left.get("concentrated")
    if exceeding and apart:
        why = (f"{_left_statement(left)}; but {cond['statement']}: the twin's own error under "
               "the data's excitation is not in the reference, so the excess is not named")
    elif exceeding:
        why = (f"named other at {left.get('scope', 'body')}, not what it is: "
               f"{_left_statement(left)}")
    elif untold:
        why = (f"the data's re-simulation error is {left['pooled_ratio']:.2f}x the reference's, "
               f"material, but the data cannot tell it from chance (p = {left['p_value']:.2g}, "
               f"per channel p = {left['channel_p_value']:.2g}), "
               f"most on {where}")
    else:
        why = (f"the data's re-simulation error exceeds the reference's on {where} (per channel "
               f"p = {left['channel_p_value']:.2g}; {left['pooled_ratio']:.2f}x pooled)")
    if apart and not exceeding:
        why += f"; {cond['statement']}"
    if capped:
        why += "; the search stopped at the most twin errors the reference may cancel"
    elif not apart:
        why += "; no family of the library explains it"
    scope = left.get("scope", "body")
    more = ("record more moves of the same types (record --moves-per-type 20, a new seed), and "
            if untold else "")
    recording = (cond["recording"] if apart else
                 RECORDINGS["body" if scope == "body" else "joints"]
                 + ", beside a new clean reference")
    return [{"family": "other", "scope": scope, "params": {}, "kind": "unexplained",
             "why": why, "recording": more + recording}]


#: the data's re-simulation error against the reference's above which the difference is
#: material (the blind benchmark's "within 1.25x of clean")
UNEXPLAINED_RATIO = 1.25


def _significant(left: dict[str, Any]) -> bool:
    """Whether :func:`unexplained`'s excess is significant, pooled over the channels or in a
    few of them (the smallest channel's p times the number of channels)."""
    return bool(left["significant"] or left.get("channel_significant"))


def exceeds(left: dict[str, Any]) -> bool:
    """Whether the data's held-out error exceeds the reference's (:func:`unexplained`)
    significantly and materially: the pooled test significant and the pooled ratio at least
    :data:`UNEXPLAINED_RATIO`, or the per-channel test significant with a significant
    channel's own ratio at least that (decisions 062 and 063: material where it is
    significant). An excess that lives on one joint's angles or the body's path is significant
    in those channels while the pooled rank test over all 36, each move's mean ratio, is not;
    and where findings have brought the other channels below the reference's, the pooled
    ratio can stay near 1 with one joint's angle many times the reference's."""
    return _by_pooled(left) or lead_channel(left) is not None


def _by_pooled(left: dict[str, Any]) -> bool:
    """Whether the pooled test alone makes ``left`` exceed: significant and material pooled."""
    return bool(left.get("significant", True) and left.get("material", True))


def lead_channel(left: dict[str, Any]) -> dict[str, Any] | None:
    """The most significant channel of ``left``'s per-channel test whose own ratio is material
    (``{channel, ratio, p_value}``), or None (decision 063)."""
    if not left.get("channel_significant"):
        return None
    return next((c for c in left.get("significant_channels", ())
                 if c["ratio"] >= UNEXPLAINED_RATIO), None)


def _naming_channel(left: dict[str, Any]) -> dict[str, Any] | None:
    """The lead channel (:func:`lead_channel`) where only the per-channel test makes ``left``
    exceed; None where the pooled test does (or nothing does)."""
    return None if _by_pooled(left) else lead_channel(left)


def p_words(left: dict[str, Any]) -> str:
    """The test that makes ``left`` (or a :func:`remainder`) exceed, in words: the pooled p
    where the pooled test does (significant and material), else the per-channel p with the
    pooled one beside it."""
    if _by_pooled(left) or not left.get("channel_significant"):
        return f"p = {left['p_value']:.2g}"
    return f"per channel p = {left['channel_p_value']:.2g}; pooled p = {left['p_value']:.2g}"


#: the share of the excess over the reference (pooled ratio minus 1) that findings must remove
#: to be read as part of the change rather than a stand-in for it (decision 045)
STAND_IN_SHARE = 0.5


def remainder(before: dict[str, Any], after: dict[str, Any]) -> dict[str, Any]:
    """What accepted findings leave against the reference where :func:`unexplained`, with
    them in the twin (``after``), is still significant and material: the pooled ratio without
    them (``before``, the twin errors kept) and with them, the share of the excess over the
    reference they removed, and the reading (decision 045): ``"partial"`` where they removed
    at least :data:`STAND_IN_SHARE` of it (the change is theirs in part: a size, or a second
    effect), ``"stand-in"`` where they removed less (the best of the library for a change it
    does not hold). Where only the per-channel test makes ``after`` exceed (decision 063), the
    ratios and the share are its lead channel's (:func:`lead_channel`, ``channel``), else the
    pooled ratios (``channel`` None). ``channels``: where the rest lives; ``p_value``,
    ``significant``, ``material``, ``channel_p_value``, ``channel_significant``: ``after``'s
    tests."""
    lead = _naming_channel(after)
    if lead is not None and lead["channel"] in before.get("channel_ratios", {}):
        r0, r1 = float(before["channel_ratios"][lead["channel"]]), float(lead["ratio"])
    else:
        lead = None
        r0, r1 = float(before["pooled_ratio"]), float(after["pooled_ratio"])
    share = (r0 - r1) / (r0 - 1.0) if r0 > 1.0 else None
    return {"ratio_before": r0, "ratio_after": r1, "p_value": float(after["p_value"]),
            "channel": None if lead is None else lead["channel"],
            "significant": bool(after["significant"]),
            "material": bool(after["material"]),
            "channel_p_value": float(after.get("channel_p_value", 1.0)),
            "channel_significant": bool(after.get("channel_significant", False)),
            "share_of_excess_removed": share,
            "reading": "partial" if share is not None and share >= STAND_IN_SHARE else "stand-in",
            "channels": [c["channel"] for c in after["channels"][:4]]}


def unexplained(ctx: SearchContext, V: Sequence[int], R: Sequence[int], alpha: float
                ) -> dict[str, Any]:
    """What the findings leave unexplained against the reference: the held-out moves' SSE per
    channel over the reference moves' mean (both with the twin and every accepted correction
    and finding), pooled per move; significant if the data's moves exceed the reference's
    (one-sided Mann-Whitney U at ``alpha``), material if the pooled ratio is at least
    :data:`UNEXPLAINED_RATIO`. ``channel_p_value``: the same test per channel, the smallest p
    times the number of channels (``channel_significant`` below ``alpha``), for a difference
    that lives in a few channels; ``significant_channels``: each channel significant so
    (``{channel, ratio, p_value}``, its p times the number of channels), most significant first
    (the larger ratio first among equal p); ``channel_ratios``: every channel's ratio that has
    a reference. ``channels``: the channels with the largest ratios."""
    from scipy.stats import mannwhitneyu
    from .channels import CHANNELS
    SV, SR = ctx.sse(None, V), ctx.sse(None, R)
    ref = np.nanmean(SR, axis=0)
    ok = np.isfinite(ref) & (ref > 0)
    per_v = np.nanmean(SV[:, ok] / ref[ok], axis=1)
    per_r = np.nanmean(SR[:, ok] / ref[ok], axis=1)
    p = float(mannwhitneyu(per_v, per_r, alternative="greater").pvalue)
    ratio = np.full(len(CHANNELS), np.nan)
    ratio[ok] = np.nanmean(SV[:, ok], axis=0) / ref[ok]
    order = [int(j) for j in np.argsort(-np.nan_to_num(ratio, nan=-np.inf))[:8]]
    pooled = float(np.mean(per_v))
    tested = [(int(j), float(mannwhitneyu(SV[:, j], SR[:, j], alternative="greater",
                                          nan_policy="omit").pvalue))
              for j in np.flatnonzero(ok)]
    tested = [(j, x) for j, x in tested if np.isfinite(x)]
    n_tested = max(len(tested), 1)
    p_channel = min(1.0, min((x for _, x in tested), default=1.0) * n_tested)
    sig_channels = sorted(({"channel": CHANNELS[j], "ratio": float(ratio[j]),
                            "p_value": min(1.0, x * n_tested)}
                           for j, x in tested if x * n_tested < alpha),
                          key=lambda c: (c["p_value"], -c["ratio"]))
    scope, scope_ratios, conc = _locate(ratio)
    return {"pooled_ratio": pooled, "p_value": p, "significant": bool(p < alpha),
            "channel_p_value": p_channel, "channel_significant": bool(p_channel < alpha),
            "significant_channels": sig_channels,
            "channel_ratios": {CHANNELS[j]: float(ratio[j]) for j in np.flatnonzero(ok)},
            "material": bool(pooled >= UNEXPLAINED_RATIO),
            "channels": [{"channel": CHANNELS[j], "ratio": float(ratio[j])} for j in order],
            "n_data_moves": len(V), "n_reference_moves": len(R),
            "scope": scope, "concentration": conc, "scope_ratios": scope_ratios}


#: decision 048: a joint scope keeps the excess only where the body's motion carries less than
#: this share of that scope's ratio (the same tolerance as the widest concentrated scope's)
BODY_SHARE = 0.8


def _locate(ratio: np.ndarray) -> tuple[str, dict[str, float], float]:
    """Where the excess over the reference lives (decision 047): the learned route's rule
    (:func:`..excess.locate`, decision 026) on the channels' ratios, a scope's ratio the mean
    of its channels' (:func:`.channels.channels_of`). Decision 048: where the body's ratio is
    at least :data:`BODY_SHARE` of the joint scope's so found, the excess is placed on the
    body: what acts on the body (a soft floor, a pull) moves the joints that carry it as much,
    where a cause at a joint leaves the body's motion far less changed than that joint's."""
    from ..excess import locate
    from .channels import channels_of

    def of(cols: np.ndarray) -> float:
        r = ratio[cols]
        r = r[np.isfinite(r)]
        return float(r.mean()) if r.size else float("nan")
    scope, ratios, conc = locate(of, channels_of)
    body = ratios.get("body", float("nan"))
    if scope != "body" and np.isfinite(body) and body >= BODY_SHARE * ratios[scope]:
        scope = "body"
        conc = body / ratios["all"] if ratios["all"] > 0 else float("nan")
    return scope, {k: float(v) for k, v in ratios.items()}, float(conc)


def name_left(left: dict[str, Any], conditions: Any = None) -> dict[str, Any]:
    """``left`` (:func:`unexplained`) with its reading (decision 047): where the data's error
    significantly and materially exceeds the reference's (:func:`exceeds`, decisions 062 and
    063: pooled or in a few channels) with every finding in the twin, the excess is named in the
    vocabulary as ``other`` at the scope where it lives (``named``, ``vocabulary``,
    ``statement``): something changed that the library does not hold, or not all of it.
    Otherwise ``named`` is false.

    ``conditions`` (:class:`..conditions.Conditions`, None: the same recording): where the
    reference was recorded under another command excitation than the data, the twin's own
    error under the data's excitation is not in the reference, so the excess is named only
    where it concentrates at one joint (standing out of its type's other joints), one leg or
    one side, which a difference of excitation over every joint does not give (decision 052,
    the physical route's reading of decisions 031 and 033; a joint type does not count,
    decision 064: :func:`..learned.concentrated_at_joints`); ``conditions`` is then kept in
    ``left``, with ``comparable`` false, and ``concentrated`` says which reading was taken."""
    named = exceeds(left)
    out = {**left, "named": named, "statement": _left_statement(left)}
    out.pop("vocabulary", None)
    if conditions is not None and not conditions.comparable:
        from ..learned import concentrated_at_joints
        concentrated = concentrated_at_joints(left)
        out.update(conditions=conditions.to_dict(), comparable=False,
                   concentrated=concentrated)
        if named and concentrated:
            out["statement"] = (f"{conditions.recorded}, but the excess concentrates at one "
                                "place of the joints, which a difference of excitation over "
                                f"every joint does not give: {out['statement']}")
        elif named:
            out["named"] = named = False
            out["statement"] = f"not compared: {conditions.statement} ({out['statement']})"
    if named:
        params: dict[str, Any] = {"error_ratio": round(float(left["pooled_ratio"]), 3)}
        lead = _naming_channel(left)
        if lead is not None:
            params.update(channel=lead["channel"], channel_ratio=round(float(lead["ratio"]), 3))
        out["vocabulary"] = {"family": "other", "scope": left["scope"], "params": params,
                             "statement": out["statement"]}
    return out


def _left_statement(left: dict[str, Any]) -> str:
    from ..excess import where_words
    lead = _naming_channel(left)
    if lead is None:
        return (f"the data's held-out re-simulation error is {left['pooled_ratio']:.2f} times "
                f"the reference's ({p_words(left)}) with every finding in the twin, most on "
                f"{where_words(left)}")
    return (f"with every finding in the twin, the data's held-out re-simulation error in the "
            f"channel {lead['channel']} is {lead['ratio']:.2f} times the reference's (per "
            f"channel p = {lead['p_value']:.2g}), and over every channel "
            f"{left['pooled_ratio']:.2f} times (pooled p = {left['p_value']:.2g}); it lives in "
            f"{where_words(left)}")


def replace_observer(o: PhysicalOptions, into: list) -> PhysicalOptions:
    """``o`` whose observer also appends each held-out decision to ``into``."""
    user = o.observer

    def observe(d: HeldOutDecision) -> None:
        into.append(d)
        if user is not None:
            user(d)
    return replace(o, observer=observe)


def reference_check(ctx: SearchContext, fin: Finding, held: HeldOutDecision,
                    R: Sequence[int], alpha: float) -> dict[str, Any]:
    """Is ``fin`` a change since the reference, or the twin's own error?

    The finding's hypothesis is re-simulated on the reference's moves ``R``. Each move's cut
    (:func:`..stats.move_cuts`) on the data's held-out moves is compared with the reference's:
    a change cuts the data's error and not the reference's. Changed: the data's cuts exceed the
    reference's (one-sided Mann-Whitney U at ``alpha``) and the reference's mean cut is below
    half the data's."""
    return _contrast(ctx, fin.hyp, held.S0, held.S1[held.chosen], R, alpha)


def _contrast(ctx: SearchContext, hyp: Any, S0: np.ndarray, S1_data: np.ndarray,
              R: Sequence[int], alpha: float) -> dict[str, Any]:
    """:func:`reference_check` of the hypothesis ``hyp`` whose held-out SSE on the data is
    ``S1_data`` against the base's ``S0``."""
    from scipy.stats import mannwhitneyu
    from ..stats import move_cuts
    from .channels import sse
    cut_data = move_cuts(S0, S1_data)
    S0_ref = ctx.sse(None, R)
    S1_ref = np.array([sse(e) for e in ctx.run([hyp], R)[0]])
    cut_ref = move_cuts(S0_ref, S1_ref)
    p = float(mannwhitneyu(cut_data, cut_ref, alternative="greater").pvalue)
    m_data, m_ref = float(np.mean(cut_data)), float(np.mean(cut_ref))
    return {"changed": bool(p < alpha and m_ref < 0.5 * m_data), "p_value": p,
            "data_move_cut": m_data, "reference_move_cut": m_ref,
            "n_data_moves": int(cut_data.size), "n_reference_moves": int(cut_ref.size)}


def located_scopes(left: dict[str, Any]) -> list[str]:
    """Where a round also fits every joint family (decision 051): the scope where the fit
    moves' excess over the reference lives (:func:`unexplained` on the fit moves, so the
    held-out moves stay out of the choice), if that excess is significant, pooled or in some
    channel, and lives on the joints: a joint and its leg, or the one group so found (a leg, a
    side, a joint type, or ``all`` where it is spread over the joints). None where it lives on
    the body's motion or is not significant."""
    if not (left["significant"] or left["channel_significant"]) or left["scope"] == "body":
        return []
    scope = left["scope"]
    kind, _, what = scope.partition(":")
    if kind == "joint":
        leg = next(g for g in LEGS if what.startswith(g + "_"))
        return [scope, f"leg:{leg}"]
    return [scope]


def _screen_moves(F: Sequence[int], n: int) -> list[int]:
    """The fit moves a round screens and first fits on: ``n`` of ``F``, spread."""
    return list(F[::max(1, len(F) // n)][:n])


def _round(ctx: SearchContext, o: PhysicalOptions, sp: _Split, robot_mass: float,
           foot_mu: float, say: Callable[[str], None], rnd: int
           ) -> tuple[Finding, list[Candidate]]:
    """One round: screen, fit the shortlist, decide on the held-out moves; (the finding, the
    screen's candidates)."""
    F = sp.F
    FS = _screen_moves(F, o.screen_moves)
    allowed = list(FAMILIES if o.families is None else o.families)
    cands = screen(ctx, FS, [f for f in allowed if FAMILIES[f].screened], say)
    top = [fit(ctx, c, FS, F) for c in shortlist(cands, o.n_refine)]
    # the push class's other form, fitted on its own: the held-out moves then compare a push
    # and a slope each at its best magnitude (the shortlist holds one of them)
    for c in [c for c in top if FAMILIES[c.family].twin_family]:
        twin = push_twin(c, robot_mass)
        top.append(fit(ctx, replace(twin, magnitude=float(twin.fitted), fitted=None), FS, F))
    top += form_variants(ctx, top, FS, allowed)
    top += scope_variants(ctx, top, FS)
    if sp.R:
        where = located_scopes(unexplained(ctx, F, sp.R, o.alpha))
        if where:
            tried: list[Candidate] = []
            top += located_variants(ctx, top, where, FS, allowed, cands, into=tried)
            say(f"physics round {rnd + 1}: the fit moves' excess over the reference lives at "
                f"{', '.join(where)}: every joint family fitted there; best "
                + "; ".join(f"{c.family} {c.scope} {_fmt_params(c)} J {c.J / c.J0:.3f}"
                            for c in tried[:6]))
    # joint magnitudes too on every fit move, once the scope is chosen
    top = [wide_magnitude(ctx, c, F) if segments_only(c.family) else c for c in top]
    top.sort(key=lambda c: c.J / c.J0)
    say(f"physics round {rnd + 1}: fitted " + "; ".join(
        f"{c.family} {c.scope} {_fmt_params(c)} J {c.J / c.J0:.3f}" for c in top))
    return validate(ctx, top, sp.V, sp.T, o.alpha, o.min_gain, o.horizons_s, cands,
                    robot_mass, foot_mu, o.observer), cands


def _fmt_params(c: Candidate) -> str:
    return ", ".join(f"{k}={v:.3g}" if isinstance(v, (int, float)) else
                     f"{k}=({', '.join(f'{x:.3g}' for x in v)})" for k, v in c.params().items())
