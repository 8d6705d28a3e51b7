"""Fitting one hypothesis by re-simulation: magnitude, direction, position (method, step 4).

Every step takes an :class:`~.context.Objective` (the search context, or a stand-in) and a
:class:`~.records.Candidate` and returns a new candidate; none changes the one it is given.
A joint family is fitted on the 1 s segments' channels only (the 4 s replays of a few moves
flip between gaits at some magnitudes and not at neighbouring ones, which makes their error
jump about the true value), a body or leg family on all channels.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Mapping, Sequence

import numpy as np

from ..families import FAMILIES
from ..families.body import within_reach
from ..families.scopes import related_scopes
from .context import Objective
from .records import Candidate, Hypothesis

__all__ = ["fit", "fit_magnitude", "refine_wide", "wide_magnitude", "refine_direction",
           "refine_position", "ridge_mass", "start_side", "scope_variants", "form_variants",
           "located_variants", "segments_only"]


def segments_only(family: str) -> bool:
    """Whether a family's magnitude is fitted on the 1 s segments' channels only."""
    return FAMILIES[family].kind == "joints"


def _evaluate(obj: Objective, c: Candidate, mags: Sequence[float], F: Sequence[int],
              w: np.ndarray, evals: dict[float, float]) -> None:
    """J of ``c`` at each new magnitude on the moves F, into the fit's table ``evals``."""
    new = [m for m in mags if m not in evals]
    if new:
        Js = obj.evaluate([c.hyp(m) for m in new], F, w, segments_only(c.family))
        evals.update(zip(new, Js))


def _grid(c: Candidate) -> list[float]:
    """The first grid around the first-order estimate; beyond the family's range (a strongly
    nonlinear effect such as a foot that only slips below the friction its stance needs) a
    finer grid up to the bound."""
    spec = FAMILIES[c.family]
    lo, hi = spec.bounds
    m0 = float(np.clip(c.magnitude, lo, hi))
    dev = m0 - spec.neutral
    if abs(dev) < 1e-9:
        dev = spec.probe
    fractions = (0.6, 1.0, 1.5) if m0 == c.magnitude else (0.2, 0.4, 0.6, 0.8, 0.95)
    return sorted({float(np.clip(spec.neutral + dev * f, lo, hi)) for f in fractions})


def _extend(family: str, evals: dict[float, float]) -> float | None:
    """A minimum at the grid's edge: the next magnitude that way (None if none)."""
    spec = FAMILIES[family]
    lo, hi = spec.bounds
    ms = sorted(evals, key=lambda m: abs(m - spec.neutral))
    best_m = min(evals, key=evals.get)
    if best_m == ms[-1]:
        new = float(np.clip(spec.neutral + (best_m - spec.neutral) * 1.6, lo, hi))
    elif best_m == ms[0] and len(ms) > 1:
        new = float(np.clip(spec.neutral + (best_m - spec.neutral) * 0.4, lo, hi))
    else:
        return None
    return None if new in evals or abs(new - best_m) < 1e-9 else new


def _vertex(evals: Mapping[float, float]) -> float | None:
    """The vertex of the parabola through the best point and its neighbours, if it is a
    minimum and a new point."""
    ms = sorted(evals)
    k = int(np.argmin([evals[m] for m in ms]))
    if not 0 < k < len(ms) - 1:
        return None
    x = np.array(ms[k - 1:k + 2])
    y = np.array([evals[m] for m in x])
    A = np.vstack([x ** 2, x, np.ones(3)]).T
    try:
        a2, a1, _ = np.linalg.solve(A, y)
    except np.linalg.LinAlgError:
        return None
    if a2 <= 0:
        return None
    xm = float(np.clip(-a1 / (2 * a2), x[0], x[2]))
    return xm if all(abs(xm - m) > 1e-6 for m in evals) else None


#: decision 057: the midpoint steps of a fit on the screening moves that a refit on every fit
#: move follows (:func:`wide_magnitude`, which searches its own +-30-40 % around the result)
SCREENING_HALVINGS = 0


def fit_magnitude(obj: Objective, c: Candidate, F: Sequence[int],
                  known: Mapping[float, float] | None = None, halvings: int = 2) -> Candidate:
    """1-D fit of the magnitude: a grid around the first-order estimate (extended once or
    twice if the minimum is at its edge), a parabola through the best point and its
    neighbours, then the midpoints between the best point and its neighbours, ``halvings``
    times (:data:`SCREENING_HALVINGS` where a refit on every fit move follows, decision 057).
    ``known``: J already evaluated on these moves with these weights, by magnitude; a grid
    point found there is not simulated again."""
    w = obj.weights(F, segments_only(c.family))
    J0 = obj.baseline(F, w)
    grid = _grid(c)
    evals = {m: j for m, j in (known or {}).items() if m in grid}
    _evaluate(obj, c, grid, F, w, evals)
    for _ in range(2):
        new = _extend(c.family, evals)
        if new is None:
            break
        _evaluate(obj, c, [new], F, w, evals)
    _settle(obj, c, F, w, evals, halvings=halvings)
    best = min(evals, key=evals.get)
    return replace(c, fitted=best, J=evals[best], J0=J0,
                   profile=[{"magnitude": m, "J_relative": evals[m] / J0} for m in sorted(evals)])


def wide_magnitude(obj: Objective, c: Candidate, F: Sequence[int],
                   fractions: Sequence[float] = (0.7, 1.0, 1.4),
                   known: Mapping[float, float] | None = None) -> Candidate:
    """The magnitude refitted on the moves ``F`` at ``fractions`` of its fitted deviation from
    neutral and at the vertex of the parabola through those three; the best is kept.
    ``known``: J already evaluated on these moves along the current direction, by magnitude.
    A minimum at the edge of what was tried is followed outwards (:func:`_follow_edge`).
    Over a few screening moves a weak joint effect's profile is flat and its minimum wanders,
    so joint magnitudes are refitted so too, once the scope is chosen."""
    spec = FAMILIES[c.family]
    lo, hi = spec.bounds
    w = obj.weights(F, segments_only(c.family))
    J0 = obj.baseline(F, w)
    dev = float(c.fitted) - spec.neutral
    if abs(dev) < 1e-9:
        return c
    evals: dict[float, float] = dict(known or {})
    x = [float(np.clip(spec.neutral + dev * f, lo, hi)) for f in fractions]
    _evaluate(obj, c, x, F, w, evals)
    xs = np.array(sorted(evals))
    if len(xs) == 3:
        try:
            a2, a1, _ = np.polyfit(xs, [evals[m] for m in xs], 2)
            if a2 > 0:
                v = np.clip(-a1 / (2 * a2), min(x[0], x[-1]) - 0.2 * abs(dev),
                            max(x[0], x[-1]) + 0.2 * abs(dev))
                _evaluate(obj, c, [float(np.clip(v, lo, hi))], F, w, evals)
        except (np.linalg.LinAlgError, ValueError):
            pass
    if _follow_edge(obj, c, F, w, evals):
        _settle(obj, c, F, w, evals)
    best = min(evals, key=evals.get)
    return replace(c, fitted=best, J=evals[best], J0=J0,
                   profile=[{"magnitude": m, "J_relative": evals[m] / J0, "moves": len(F)}
                            for m in sorted(evals)])


#: decision 051: how often the refit follows a minimum at the edge of what it has tried
EDGE_STEPS = 4


def _follow_edge(obj: Objective, c: Candidate, F: Sequence[int], w: np.ndarray,
                 evals: dict[float, float]) -> bool:
    """While the best magnitude tried is the one furthest from neutral (or the nearest), the
    next one that way: its deviation from neutral x1.4 (or x0.7), within the family's range,
    at most :data:`EDGE_STEPS` times, until one fits worse. The screening moves' fit can stop
    well short of the true value where the response is strongly nonlinear (a foot that slips
    only below the friction its stance needs: 0.35 of normal read 0.73 at the edge of the
    refit's three points, decision 051). Whether any step improved the fit."""
    spec = FAMILIES[c.family]
    lo, hi = spec.bounds
    moved = False
    for _ in range(EDGE_STEPS):
        best = min(evals, key=evals.get)
        by_reach = sorted(evals, key=lambda m: abs(m - spec.neutral))
        if len(by_reach) < 2:
            break
        if best == by_reach[-1]:
            f = 1.4
        elif best == by_reach[0]:
            f = 0.7
        else:
            break
        new = float(np.clip(spec.neutral + (best - spec.neutral) * f, lo, hi))
        if any(abs(new - m) < 1e-9 for m in evals):
            break
        _evaluate(obj, c, [new], F, w, evals)
        if evals[new] >= evals[best]:
            break
        moved = True
    return moved


def _settle(obj: Objective, c: Candidate, F: Sequence[int], w: np.ndarray,
            evals: dict[float, float], halvings: int = 1) -> None:
    """The vertex of the parabola through the best magnitude and its neighbours, then the
    midpoints between the best and its neighbours, ``halvings`` times: the end of
    :func:`fit_magnitude` (twice), and of a refit whose edge was followed (once: the steps of
    x1.4 leave the minimum up to 40 % of the deviation away)."""
    xm = _vertex(evals)
    if xm is not None:
        _evaluate(obj, c, [xm], F, w, evals)
    for _ in range(halvings):
        ms = sorted(evals)
        k = int(np.argmin([evals[m] for m in ms]))
        _evaluate(obj, c, [0.5 * (ms[k] + ms[j]) for j in (k - 1, k + 1) if 0 <= j < len(ms)],
                  F, w, evals)


def refine_wide(obj: Objective, c: Candidate, F: Sequence[int],
                fractions: Sequence[float] = (0.7, 1.0, 1.4)) -> Candidate:
    """A body or leg family's magnitude refitted on every fit move (:func:`wide_magnitude`;
    over one move of each type the jagged replay profile is smoother than over a few), then a
    planar force or slope turned by +-12 and +-6 deg on every fit move too and, if that helps,
    its magnitude refitted once more."""
    if c.fitted is None or len(F) == 0:
        return c
    c = wide_magnitude(obj, c, F, fractions)
    if c.direction is not None and len(c.direction) == 2 and c.J is not None:
        turned = _turn(obj, c, F, obj.weights(F), (12.0, 6.0))
        if turned is not None:   # its J at the fitted magnitude is known: not simulated again
            c = wide_magnitude(obj, turned, F, fractions, {float(turned.fitted): turned.J})
    return c


def refine_direction(obj: Objective, c: Candidate, F: Sequence[int],
                     steps_deg: Sequence[float] = (30.0, 12.0), halvings: int = 2
                     ) -> Candidate:
    """A vector family's first-order direction searched around it (biased where the response
    is not linear in the components): turned by +-30 deg, then +-12 deg around the best so far,
    at the fitted magnitude; then the magnitude refitted along the best direction
    (:func:`fit_magnitude` with ``halvings``)."""
    if c.direction is None or c.fitted is None or len(c.direction) != 2:
        return c
    turned = _turn(obj, c, F, obj.weights(F), steps_deg)
    if turned is None:
        return c
    return fit_magnitude(obj, replace(turned, magnitude=float(turned.fitted)), F,
                         halvings=halvings)


def _turn(obj: Objective, c: Candidate, F: Sequence[int], w: np.ndarray,
          steps_deg: Sequence[float]) -> Candidate | None:
    """``c`` turned by -+step around its best direction so far, for each step, at its fitted
    magnitude (against ``c.J`` on the same moves): the best direction and its J, or None if no
    turn helped."""
    spec = FAMILIES[c.family]

    def J_of(vec: np.ndarray) -> float:
        par = spec.params_from(float(np.linalg.norm(vec)), vec / np.linalg.norm(vec))
        return obj.evaluate([Hypothesis(c.family, c.scope, par)], F, w)[0]

    best = float(c.fitted) * np.asarray(c.direction, dtype=float)
    best_J = float(c.J)
    r = float(np.linalg.norm(best))
    for step in steps_deg:
        a0 = math.atan2(best[1], best[0])
        for s in (-1, 1):
            v = r * np.array([math.cos(a0 + s * math.radians(step)),
                              math.sin(a0 + s * math.radians(step))])
            j = J_of(v)
            if j < best_J:
                best, best_J = v, j
    if best_J < c.J:
        return replace(c, direction=best / np.linalg.norm(best), J=best_J)
    return None


def refine_position(obj: Objective, c: Candidate, F: Sequence[int],
                    steps_m: Sequence[tuple[float, float]] = ((0.04, 0.03), (0.02, 0.015)),
                    step_up_m: float = 0.03,
                    valley_steps: Sequence[float] = (1.5, 1.2), halvings: int = 2
                    ) -> Candidate:
    """Where a family that acts at a position (a payload) acts, searched around the best
    screening position at the fitted mass: +-4 cm ahead and +-3 cm to the side, then +-2 and
    +-1.5 cm around the best so far, then 3 cm higher or lower, within the body's reach
    (:func:`~..families.body.within_reach`); then along the valley of a constant first moment
    (a lighter mass further out tilts the body as a heavier one nearer in does): the mass
    scaled by each step in ``valley_steps`` and its offset divided by it, while the fit
    improves. The mass is refitted at the best position (:func:`fit_magnitude` with
    ``halvings``)."""
    if not FAMILIES[c.family].searches_position or c.fitted is None or c.J is None:
        return c
    w = obj.weights(F)

    def J_at(pos: tuple[float, ...], mass: float | None = None) -> float:
        hyp = Hypothesis(c.family, c.scope, {**c.params(mass), "com_offset_m": pos})
        return obj.evaluate([hyp], F, w)[0]

    best = tuple(float(x) for x in c.extra.get("com_offset_m", (0.0, 0.0, 0.0)))
    best, best_J = _position_steps(J_at, best, float(c.J), steps_m, step_up_m)
    best, best_J, mass = _position_valley(J_at, best, best_J, float(c.fitted),
                                          FAMILIES[c.family].bounds, valley_steps)
    if best_J >= c.J:
        return c
    return fit_magnitude(obj, replace(c, extra={**c.extra, "com_offset_m": best},
                                      magnitude=mass), F, halvings=halvings)


def _position_steps(J_at, best: tuple[float, ...], best_J: float,
                    steps_m: Sequence[tuple[float, float]], step_up_m: float
                    ) -> tuple[tuple[float, ...], float]:
    moves = [[(s * dx, 0.0, 0.0) for s in (-1, 1)] + [(0.0, s * dy, 0.0) for s in (-1, 1)]
             for dx, dy in steps_m] + [[(0.0, 0.0, s * step_up_m) for s in (1, -1)]]
    for tries in moves:
        start = best
        for d in tries:
            pos = tuple(round(a + b, 4) for a, b in zip(start, d))
            if not within_reach(pos):
                continue
            j = J_at(pos)
            if j < best_J:
                best, best_J = pos, j
    return best, best_J


def _position_valley(J_at, best: tuple[float, ...], best_J: float, mass: float,
                     bounds: tuple[float, float], valley_steps: Sequence[float]
                     ) -> tuple[tuple[float, ...], float, float]:
    lo, hi = bounds
    for step in valley_steps:
        for f in (step, 1.0 / step):
            moved = False
            while lo <= mass * f <= hi:
                pos = tuple(round(a / f, 4) for a in best)
                if not within_reach(pos):
                    break
                j = J_at(pos, mass * f)
                if j >= best_J:
                    break
                best, best_J, mass, moved = pos, j, mass * f, True
            if moved:
                break
    return best, best_J, mass


def fit(obj: Objective, c: Candidate, FS: Sequence[int], F: Sequence[int]) -> Candidate:
    """Step 4 of the method for one hypothesis: magnitude, direction and position on the
    screening moves ``FS``, then body and leg magnitudes on all fit moves ``F`` (joint
    magnitudes are refitted on them by the driver, once the scope is chosen); the magnitude
    fits on ``FS`` stop at their parabola's vertex (decision 057)."""
    h = SCREENING_HALVINGS
    c = fit_magnitude(obj, c, FS, halvings=h)
    c = refine_direction(obj, c, FS, halvings=h)
    c = refine_position(obj, c, FS, halvings=h)
    if not segments_only(c.family):
        c = refine_wide(obj, c, F)
        c = ridge_mass(obj, c, F)
    return c


#: decision 060: the ridge search's first steps (factors of the mass) and how often it follows
#: a minimum at the edge of what it has tried
RIDGE_FACTORS: tuple[float, float] = (0.7, 1.4)
RIDGE_STEPS = 4


def ridge_mass(obj: Objective, c: Candidate, F: Sequence[int]) -> Candidate:
    """A payload's mass searched along its ridge of constant horizontal first moment on every
    fit move ``F`` (decision 060): the mass times each of :data:`RIDGE_FACTORS` with its
    horizontal offset divided by it (the height kept), a minimum at the edge followed outwards
    (x1.4 or x0.7, at most :data:`RIDGE_STEPS` times; a step beyond the family's range or the
    body's reach is not taken, so the walk can stop up to 30 % short of either), then the vertex
    of the parabola in log mass through the best and its neighbours. Where the mass moves, the
    points tried join the candidate's profile, tagged ``"along": "ridge"``.
    The data fix the moment the weight makes about the body's centre well and the mass less
    well; the position search on the screening moves and the magnitude refit at a fixed
    position (:func:`refine_wide`) both leave the mass where it started along that ridge, which
    was low in most blind payloads. ``c`` unchanged if it has no horizontal offset or nothing
    along the ridge fits better."""
    spec = FAMILIES[c.family]
    if not spec.searches_position or c.fitted is None or c.J is None or len(F) == 0:
        return c
    lo, hi = spec.bounds
    m0 = float(c.fitted)
    x0, y0, z0 = (float(v) for v in c.extra.get("com_offset_m", (0.0, 0.0, 0.0)))
    if abs(x0) + abs(y0) < 1e-6:
        return c
    w = obj.weights(F)

    def pos(f: float) -> tuple[float, float, float]:
        return (round(x0 / f, 4), round(y0 / f, 4), z0)

    evals: dict[float, float] = {1.0: float(c.J)}

    def tried(fs: Sequence[float]) -> list[float]:
        new = [f for f in fs if all(abs(f - g) > 1e-9 for g in evals)
               and lo <= m0 * f <= hi and within_reach(pos(f))]
        if new:
            hyps = [Hypothesis(c.family, c.scope, {**c.params(m0 * f), "com_offset_m": pos(f)})
                    for f in new]
            evals.update(zip(new, obj.evaluate(hyps, F, w)))
        return new

    tried(RIDGE_FACTORS)
    for _ in range(RIDGE_STEPS):
        best = min(evals, key=evals.get)
        fs = sorted(evals)
        if best == fs[-1] and len(fs) > 1:
            step = RIDGE_FACTORS[1]
        elif best == fs[0] and len(fs) > 1:
            step = RIDGE_FACTORS[0]
        else:
            break
        new = tried([best * step])
        if not new or evals[new[0]] >= evals[best]:
            break
    logs = {math.log(f): j for f, j in evals.items()}
    v = _vertex(logs)
    if v is not None:
        tried([math.exp(v)])
    best = min(evals, key=evals.get)
    if best == 1.0:
        return c
    J0 = c.J0 if c.J0 is not None else obj.baseline(F, w)
    ridge = [{"magnitude": m0 * f, "J_relative": evals[f] / J0, "moves": len(F),
              "com_offset_m": list(pos(f)), "along": "ridge"}
             for f in sorted(evals) if f != 1.0]
    return replace(c, fitted=m0 * best, J=evals[best],
                   extra={**c.extra, "com_offset_m": pos(best)},
                   profile=list(c.profile or []) + ridge)


def start_side(obj: Objective, c: Candidate, F: Sequence[int]
               ) -> tuple[Candidate, dict[float, float]]:
    """For a family signed about its neutral value, ``c`` with its magnitude mirrored about
    neutral if the mirror image fits the moves ``F`` better; and the J of the magnitude kept,
    for :func:`fit_magnitude` (empty if nothing was evaluated)."""
    spec = FAMILIES[c.family]
    lo, hi = spec.bounds
    dev = float(c.magnitude) - spec.neutral
    if not lo < spec.neutral < hi or abs(dev) < 1e-9:
        return c, {}
    mags = [float(np.clip(spec.neutral + s * dev, lo, hi)) for s in (1, -1)]
    evals: dict[float, float] = {}
    _evaluate(obj, c, mags, F, obj.weights(F, segments_only(c.family)), evals)
    m = min(evals, key=evals.get)
    return replace(c, magnitude=m), {m: evals[m]}


def scope_variants(obj: Objective, top: Sequence[Candidate], F: Sequence[int]
                   ) -> list[Candidate]:
    """Each fitted joint hypothesis refitted on its related scopes
    (:func:`~..families.scopes.related_scopes`), the best first. For the best joint hypothesis
    by the fit moves' error, the best of its variants joins the shortlist if it fits about as
    well (within 10 %), so that the held-out decision also chooses the scope; for each other
    one (another family, or another form of one), its best variant joins if it fits better than
    it does (decision 051: a supply sag fitted at the hip rolls, where its gain-drift form's
    screen pointed, was never tried on every joint, where it acted). A family signed about
    neutral (an encoder offset, a servo gain) starts each scope's fit on the side that fits it
    better (:func:`start_side`): the neighbouring joint's offset that best imitates the true one
    can have the other sign. For a joint type, the other joint types are tried for the
    best-fitting joint hypothesis only (decision 061)."""
    joint = sorted((c for c in top if segments_only(c.family) and c.J is not None),
                   key=lambda c: c.J)
    if not joint:
        return []
    have = {(c.family, c.scope) for c in top}
    out = []
    for k, c in enumerate(joint):
        variants = []
        for scope in related_scopes(c.scope, other_types=k == 0):
            if (c.family, scope) in have:
                continue
            v, side = start_side(obj, Candidate(c.family, scope, 0.0, float(c.fitted)), F)
            variants.append(fit_magnitude(obj, v, F, known=side,
                                          halvings=SCREENING_HALVINGS))
            have.add((c.family, scope))
        if not variants:
            continue
        best = min(variants, key=lambda v: v.J)
        if (best.J <= 1.1 * c.J) if k == 0 else (best.J < c.J):
            out.append(best)
    return out


def form_variants(obj: Objective, top: Sequence[Candidate], F: Sequence[int],
                  allowed: Sequence[str] | None = None) -> list[Candidate]:
    """Each fitted hypothesis's other physical forms (:attr:`..families.Family.other_forms`:
    a supply sag beside a gain drift), fitted on the moves ``F`` at its scope, starting from its
    magnitude; a form joins the shortlist if it fits about as well (within 10 %), so that the
    held-out decision chooses the form as it chooses the scope (:func:`scope_variants`).
    ``allowed``: the families the search may report (None: all)."""
    have = {(c.family, c.scope) for c in top}
    out = []
    for c in top:
        if c.fitted is None or c.J is None:
            continue
        for form in FAMILIES[c.family].other_forms:
            if (form, c.scope) in have or (allowed is not None and form not in allowed):
                continue
            v = fit_magnitude(obj, Candidate(form, c.scope, c.score, float(c.fitted)), F,
                              halvings=SCREENING_HALVINGS if segments_only(form) else 2)
            have.add((form, c.scope))
            if v.J is not None and v.J <= 1.1 * c.J:
                out.append(v)
    return out


def located_variants(obj: Objective, top: Sequence[Candidate], scopes: Sequence[str],
                     F: Sequence[int], allowed: Sequence[str] | None = None,
                     cands: Sequence[Candidate] = (),
                     into: list[Candidate] | None = None) -> list[Candidate]:
    """Every joint family of the library, and every other form of one, fitted at ``scopes``:
    where the fit moves' excess over the reference lives (:func:`.driver.located_scopes`,
    decision 051). The screen ranks a family by its first-order fit to the whole residual and
    fits only the best three joint families, each at its best scope; a threshold effect
    (play, a weak drive) can rank below them there and still be what the excess at one joint
    asks for. Each starts from the screen's first-order magnitude at that scope where the
    screen found one of the right sign (``cands``), else from the family's probe, on the side
    that fits it better (:func:`start_side`). The best of them joins the shortlist if it fits
    about as well as the best joint hypothesis already there (within 10 %), or if there is
    none; the held-out decision then chooses, adjusted for the larger shortlist.
    ``allowed``: the families the search may report (None: all). ``into``, if given, receives
    every fit made here (for the log)."""
    have = {(c.family, c.scope) for c in top}
    first: dict[tuple[str, str], Candidate] = {}
    for c in cands:
        first.setdefault((c.family, c.scope), c)
    names = [f for f in (allowed if allowed is not None else FAMILIES)
             if f in FAMILIES and FAMILIES[f].kind == "joints"]
    out = []
    for scope in scopes:
        for name in names:
            spec = FAMILIES[name]
            if (name, scope) in have or scope not in spec.scopes():
                continue
            c0 = first.get((name, scope))
            m0 = (float(c0.magnitude) if c0 is not None and c0.score > 0
                  else spec.neutral + spec.probe)
            v, side = start_side(obj, Candidate(name, scope, 0.0, m0), F)
            out.append(fit_magnitude(obj, v, F, known=side, halvings=SCREENING_HALVINGS))
            have.add((name, scope))
    out = [c for c in out if c.J is not None]
    if into is not None:
        into.extend(sorted(out, key=lambda c: c.J))
    if not out:
        return []
    best = min(out, key=lambda c: c.J)
    joint = [c.J for c in top if segments_only(c.family) and c.J is not None]
    return [best] if not joint or best.J <= 1.1 * min(joint) else []
