"""Screening every family x scope by first-order sensitivities (method, step 3), and the shortlist.

Each family is simulated once per screening probe (:meth:`~..families.Family.screen_probes`:
per joint, per leg, per component, or per direction or position) at a probe magnitude on the
screening moves; the change of the outputs is that probe's sensitivity. A scope's sensitivity is
the sum of its joints' (first order), so every joint scope is scored from 12 simulations. The
score is the summed relative SSE cut over the channels of the weighted least-squares fit of the
sensitivity to the residual; the family's :attr:`~..families.Family.screen_style` says how its
probes become hypotheses.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Callable, Mapping, Sequence

import numpy as np

from ...layout import N_JOINTS
from ..families import FAMILIES, Family, scope_joints
from .channels import SCREEN_SEGMENTS, errors, flat
from .context import SearchContext
from .records import Candidate, Hypothesis

__all__ = ["screen", "shortlist"]

Sensitivities = Mapping[tuple, Mapping[int, np.ndarray]]


def screen(ctx: SearchContext, F: Sequence[int], fams: Sequence[str],
           say: Callable[[str], None]) -> list[Candidate]:
    """First-order scores of every family x scope on the screening moves ``F``, best first."""
    t0 = time.perf_counter()
    w = ctx.weights(F)
    jobs = [(fam, p) for fam in fams for p in FAMILIES[fam].screen_probes()]
    tasks = [(i, list(ctx.base) + [Hypothesis(fam, p.scope, p.params)],
              "full" if FAMILIES[fam].long_screen else "short") for fam, p in jobs for i in F]
    sens = _sensitivities(ctx, jobs, ctx.runner.map(tasks), F, w)
    res = _Residual(
        {i: flat({"short": -ctx.base_err[i]["short"][list(SCREEN_SEGMENTS)]}, w, False)
         for i in F},  # meas - sim0 on the screening segments
        {i: flat({"short": -ctx.base_err[i]["short"], "long": -ctx.base_err[i]["long"]}, w,
                 True) for i in F}, F)
    cands: list[Candidate] = []
    for fam in fams:
        spec = FAMILIES[fam]
        found = _SCREEN_STYLES[spec.screen_style](spec, sens[fam], res)
        # first-order magnitude in the family's units
        cands += [c if c.direction is not None else
                  replace(c, magnitude=spec.neutral + c.magnitude * spec.probe) for c in found]
    cands.sort(key=lambda c: -c.score)
    say(f"physics screening: {len(cands)} family x scope hypotheses from {len(tasks)} "
        f"sensitivity simulations in {time.perf_counter() - t0:.1f} s; best " + ", ".join(
            f"{c.family} {c.scope} {c.score:.2f}" for c in cands[:5]))
    return cands


def _sensitivities(ctx: SearchContext, jobs: list, sims: list, F: Sequence[int],
                   w: np.ndarray) -> dict[str, dict[tuple, dict[int, np.ndarray]]]:
    """Per family, per probe key, per move: the change of the outputs the probe causes, as a
    flat weighted vector (the 4 s replay too for a family screened on it)."""
    sens: dict[str, dict[tuple, dict[int, np.ndarray]]] = {}
    k = 0
    for fam, p in jobs:
        long = FAMILIES[fam].long_screen
        out = sens.setdefault(fam, {}).setdefault(p.key, {})
        for i in F:
            e = errors(sims[k], ctx.meas[i])
            d = {"short": e["short"] - ctx.base_err[i]["short"][sims[k]["seg_idx"]]}
            k += 1
            if long:
                d["long"] = e["long"] - ctx.base_err[i]["long"]
            out[i] = flat(d, w, long)
    return sens


@dataclass(frozen=True)
class _Residual:
    """The screen's residuals (measured minus simulated, weighted, flat per move): on the
    screening segments (``short``) and on the whole move (``full``), and the moves ``F``."""

    short: Mapping[int, np.ndarray]
    full: Mapping[int, np.ndarray]
    F: Sequence[int]

    def fit_1d(self, sens: Mapping[int, np.ndarray]) -> tuple[float, float]:
        """(score, scale a) of one sensitivity fitted to the whole-move residual by least
        squares, summed over the screening moves."""
        gg = sum(float(sens[i] @ sens[i]) for i in self.F)
        bb = sum(float(sens[i] @ self.full[i]) for i in self.F)
        a = bb / gg if gg > 0 else 0.0
        return bb * a, a


def _screen_joints(spec: Family, sens: Sensitivities,
                   res: _Residual) -> list[Candidate]:
    """Every joint scope from one probe per joint (first order: a scope's sensitivity is the
    sum of its joints'), per scope the probe that explains more; a family screened on the whole
    move (a drift that grows over 4 s) against the whole-move residual."""
    best: dict[str, Candidate] = {}
    for k in range(1 if spec.deep_probe is None else 2):
        G = np.zeros((N_JOINTS, N_JOINTS))
        b = np.zeros(N_JOINTS)
        for i in res.F:
            D = np.stack([sens[(k, j)][i] for j in range(N_JOINTS)])
            r = res.full[i] if spec.long_screen else res.short[i]
            G += D @ D.T
            b += D @ r
        for c in _scope_scores(spec.name, G, b):
            if k == 1:   # in units of the first probe (converted by the caller)
                c = replace(c, magnitude=c.magnitude * spec.deep_probe / spec.probe)
            if c.scope not in best or c.score > best[c.scope].score:
                best[c.scope] = c
    return list(best.values())


def _screen_legs(spec: Family, sens: Sensitivities,
                 res: _Residual) -> list[Candidate]:
    out = []
    for p in spec.screen_probes():
        score, a = res.fit_1d(sens[p.key])
        out.append(Candidate(spec.name, p.scope, score, a))
    return out


def _screen_each(spec: Family, sens: Sensitivities,
                 res: _Residual) -> list[Candidate]:
    """Every probe a hypothesis of its own (a tilt towards one direction, a mass at one
    position), scaled in 1-D; only a positive scale counts."""
    out = []
    for k, p in enumerate(spec.screen_probes()):
        score, a = res.fit_1d(sens[p.key])
        mag, direction, extra = spec.probe_candidate(k, a)
        out.append(Candidate(spec.name, p.scope, score if a > 0 else 0.0, mag, direction,
                             extra=extra))
    return out


def _screen_components(spec: Family, sens: Sensitivities,
                       res: _Residual) -> list[Candidate]:
    """A vector family's components fitted jointly (one probe per component)."""
    keys = [p.key for p in spec.screen_probes()]
    nc = len(keys)
    G = np.zeros((nc, nc))
    b = np.zeros(nc)
    for i in res.F:
        D = np.stack([sens[key][i] for key in keys])
        G += D @ D.T
        b += D @ res.full[i]
    a = np.linalg.lstsq(G + 1e-12 * np.eye(nc), b, rcond=None)[0]
    score = float(b @ a)
    if nc > 1:
        mag = float(np.linalg.norm(a)) * spec.probe
        direction = a / np.linalg.norm(a) if np.linalg.norm(a) > 0 else np.eye(nc)[0]
        return [Candidate(spec.name, "body", score, mag, direction)]
    return [Candidate(spec.name, "body", score, float(a[0]))]


_SCREEN_STYLES: dict[str, Callable[..., list[Candidate]]] = {
    "joints": _screen_joints, "legs": _screen_legs, "each": _screen_each,
    "components": _screen_components}


def _scope_scores(fam: str, G: np.ndarray, b: np.ndarray) -> list[Candidate]:
    out = []
    for scope in FAMILIES[fam].scopes():
        idx = scope_joints(scope)
        gg = float(G[np.ix_(idx, idx)].sum())
        bb = float(b[idx].sum())
        a = bb / gg if gg > 0 else 0.0
        out.append(Candidate(fam, scope, bb * a, a))
    return out


def shortlist(cands: list[Candidate], n: int) -> list[Candidate]:
    """The hypotheses to fit: the best scope of the best joint families (half, at most three), of
    the best body families (all but one of the rest) and of every leg family, then the next
    best overall up to ``n`` joint, body and leg places. With the default 8 that is 3 joint, 4
    body and the 4 leg families: the body classes number seven, and with two body places a
    body-fixed force or a tilted floor was screened but never fitted
    (docs/decisions/009-shortlist-of-eight.md); the leg families' first-order scores are not
    comparable either (a foot's friction acts only once the foot slips), and with one leg place
    a worn foot pad scored below a lift-off adhesion and was never fitted
    (docs/decisions/049-every-leg-family-is-fitted.md). Joint
    families are screened on the 1 s segments, body and leg families also on the 4 s replay, so
    their scores are not compared directly: the held-out decision compares them after the fit.
    A push fixed in odom and a slope count as one class here (they act alike; the rival is
    reported by :func:`.advice.inseparable`)."""
    pos = [c for c in cands if c.score > 0]

    def cls(c: Candidate) -> str:
        return FAMILIES[c.family].shortlist_class

    n_joint = min((n + 1) // 2, 3)
    n_body = max(1, n - n_joint - 1)
    legs = [c for c in pos if FAMILIES[c.family].kind == "leg"]
    n_leg = max(1, len({cls(c) for c in legs}))
    groups = [([c for c in pos if FAMILIES[c.family].kind == "joints"], n_joint),
              ([c for c in pos if FAMILIES[c.family].kind == "body"], n_body),
              (legs, n_leg)]
    out: list[Candidate] = []
    for group, k in groups:
        seen: set[str] = set()
        for c in group:
            if len(seen) >= k:
                break
            if cls(c) not in seen:
                out.append(c)
                seen.add(cls(c))
    cap = max(n, 1) + n_leg - 1   # the leg families beyond the one place of ``n``
    for c in pos:
        if len(out) >= cap:
            break
        if c not in out and cls(c) not in {cls(o) for o in out}:
            out.append(c)
    return out[:cap] or cands[:1]
