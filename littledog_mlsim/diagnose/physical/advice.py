"""Physical words and advice: a fit's parameters and sentence, rivals, and what to record next.

- :func:`physical_params`, :func:`statement`: the family's own reading of a fitted hypothesis;
- :func:`inseparable`: rivals of another family the held-out moves cannot tell from a finding,
  with what separates them (:meth:`..families.Family.separation`);
- :func:`suspicions` (method, step 6): effects the data suggests but cannot establish, and the
  recording that would settle it.
"""
from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from ..families import FAMILIES, FittedEffect, scope_words, vocabulary_family
from .records import Finding

__all__ = ["physical_params", "statement", "inseparable", "suspicions", "INSEPARABLE_SHARE"]


def physical_params(c: FittedEffect, foot_mu: float = 0.81) -> dict[str, Any]:
    """The vocabulary's parameters of a fitted candidate (primary first); ``foot_mu``: the
    transducer's normal foot-ground friction coefficient (pybullet multiplies foot and ground)."""
    return FAMILIES[c.family].physical_params(c, foot_mu)


def statement(family: str, scope: str, params: Mapping[str, Any]) -> str:
    """A roboticist's sentence for a finding."""
    where = scope_words(scope)
    if family not in FAMILIES:
        return f"{family} on {where}: {dict(params)}"
    return FAMILIES[family].statement(where, params)


INSEPARABLE_SHARE = 0.8   # a rival with this share of the finding's held-out cut: data can't tell
# another scope of the finding's own family with this share: the scopes differ in joints the
# held-out moves hardly drive (scopes of one family share the parameter, so a tighter share)
SCOPE_INSEPARABLE_SHARE = 0.95


def inseparable(f: Finding, alpha: float) -> list[dict[str, Any]]:
    """Rivals that the held-out moves cannot tell from an accepted finding, significant on
    their own (adjusted p < alpha): another family with at least INSEPARABLE_SHARE of the
    finding's summed held-out SSE cut, or the finding's own family at another scope with at
    least SCOPE_INSEPARABLE_SHARE of it (the best such scope; decision 054). Each names what
    would separate them."""
    mine = vocabulary_family(f.family)
    own = [a for a in f.alternatives
           if a.get("searched_family", a["family"]) == f.family and a["scope"] == f.scope]
    if not own or not own[0]["held_out_total_gain"] or own[0]["held_out_total_gain"] <= 0:
        return []
    g0 = own[0]["held_out_total_gain"]
    out, seen = [], {f.family}
    for a in sorted(f.alternatives, key=lambda a: -(a["held_out_total_gain"] or -np.inf)):
        g = a["held_out_total_gain"]
        searched = a.get("searched_family", a["family"])
        if searched in seen or g is None or g < INSEPARABLE_SHARE * g0 or \
                not a["held_out_p"] < alpha:
            continue
        seen.add(searched)
        how, rec = _separation(f.family, searched)
        # two forms of one vocabulary family (a gain drift and a supply sag): say which
        what = (f"{mine} in the form '{FAMILIES[f.family].form}'"
                if vocabulary_family(searched) == mine and getattr(FAMILIES[f.family], "form", "")
                else mine)
        out.append({"family": a["family"], "scope": a["scope"], "params": a["params"],
                    "why": (f"cannot be told from the accepted {what} on these data: held-out "
                            f"cut {g:.3g} against {g0:.3g}; {how}"),
                    "recording": rec, "kind": "inseparable"})
    scopes = [a for a in f.alternatives
              if a.get("searched_family", a["family"]) == f.family and a["scope"] != f.scope
              and a["held_out_total_gain"] is not None
              and a["held_out_total_gain"] >= SCOPE_INSEPARABLE_SHARE * g0
              and a["held_out_p"] < alpha]
    if scopes:
        a = max(scopes, key=lambda a: a["held_out_total_gain"])
        out.append({"family": a["family"], "scope": a["scope"], "params": a["params"],
                    "why": (f"the accepted {mine} at {scope_words(a['scope'])} instead of "
                            f"{scope_words(f.scope)}: held-out cut {a['held_out_total_gain']:.4g} "
                            f"against {g0:.4g}; the joints where the two scopes differ hardly "
                            f"take part in these moves"),
                    "recording": EXCITED, "kind": "inseparable"})
    return out


EXCITED = ("littledog-mlsim record --out DIR --moves-per-type 20 --excitation 0.03 "
           "[same options, a new seed]")


def _separation(a: str, b: str) -> tuple[str, str]:
    """Why families ``a`` and ``b`` act alike and the recording that separates them: the
    stronger of the two families' views (:meth:`~.families.Family.separation`), else more
    moves with command excitation."""
    fa, fb = FAMILIES[a], FAMILIES[b]
    views = [v for v in (fa.separation(fb), fb.separation(fa)) if v is not None]
    if not views:
        return "both explain the held-out moves about equally well", EXCITED
    best = max(views, key=lambda v: v.priority)
    return best.how, best.recording


def _timing(alt: Mapping[str, Any]) -> bool:
    fam = FAMILIES.get(alt.get("searched_family", alt["family"]))
    return fam is not None and fam.timing_rival


def suspicions(findings: Sequence[Finding], rejected: Sequence[Finding], excitation: float,
               alpha: float, min_gain: float) -> list[dict[str, Any]]:
    """Effects the data suggests but cannot establish, and the recording that would settle it.

    - a command-path family (delay, filter, backlash on the set-points) as the best candidate
      that was not accepted, on data without command excitation: a smooth open-loop trot
      hardly tells a late or filtered set-point from the robot's own dynamics;
    - any best candidate that is significant but below the materiality bar: more moves would
      settle it;
    - an accepted command delay or filter whose rival (filter or delay) fitted nearly as well:
      excitation separates a pure delay from a lag.
    """
    out = []
    cmd = ("littledog-mlsim record --out DIR --moves-per-type 20 --excitation 0.03 "
           "[--effects ... as before]")
    more = "littledog-mlsim record --out DIR --moves-per-type 20 [same options, a new seed]"
    for f in rejected:
        fit_cut = None
        if f.profile:
            fit_cut = 1.0 - min(p["J_relative"] for p in f.profile)
        path = FAMILIES[f.family].needs_excitation
        held = bool(np.nanmin(f.p_channel) < alpha) and float(np.nansum(f.gain)) > 0
        if path and excitation <= 0 and (fit_cut or 0) >= 2 * min_gain and held:
            out.append({"family": f.family, "scope": f.scope, "params": f.params,
                        "why": (f"{f.statement} explains {fit_cut:.0%} of the fit moves' "
                                "output error but is not established on the held-out moves; "
                                "on a smooth trot without command excitation a set-point "
                                "effect is hard to tell from the robot's own dynamics"),
                        "recording": cmd})
        elif f.significant and not f.material:
            out.append({"family": f.family, "scope": f.scope, "params": f.params,
                        "why": f"{f.statement} is significant on held-out moves (p = "
                               f"{f.p_value:.2g}) but cuts no output error by {min_gain:.0%}",
                        "recording": more})
    for f in findings:
        out += inseparable(f, alpha)
    for f in findings:
        if FAMILIES[f.family].timing_rival and excitation <= 0:
            rival = [a for a in f.alternatives if _timing(a) and a["family"] != f.family
                     and a["J_relative"] is not None]
            mine = [a for a in f.alternatives if a["family"] == f.family
                    and a["scope"] == f.scope and a["J_relative"] is not None]
            if rival and mine and rival[0]["J_relative"] <= mine[0]["J_relative"] * 1.05:
                out.append({"family": rival[0]["family"], "scope": rival[0]["scope"],
                            "params": rival[0]["params"],
                            "why": f"fits almost as well as the accepted {f.family}; a delay "
                                   "and a lag differ in how they pass fast set-point changes, "
                                   "which this data hardly has",
                            "recording": cmd})
    return out
