"""Where each effect the learned route did not find stood in its diagnosis: a reading aid for the
no-twin arm's misses (``learned``, ``learned+reference``), once the truth may be read, as
``misses.py`` is for the physical route.

    .venv/bin/python benchmarks/blind_zoo/harness/learned_misses.py RUN ZOO/truth.yaml [--all]
    .venv/bin/python benchmarks/blind_zoo/harness/learned_misses.py --zoos --skip zoo64,zoo65 \\
        [--summary]

RUN is a collected run directory (``results.json``, and per effect ``reports/<id>.report.json``
or ``reports/<id>/report.json``, else ``reports/<id>.report.md`` and
``logs/diagnose*_<id>.log``). For each effect not found (every effect with ``--all``) it prints:

- the truth (family, scope, primary parameter, ``learned_inputs``) and what the run named;
- where the truth's family stood in each search: per round the best probe of that family
  (its scope, p-value, total gain, significant, material, rank by p among the round's
  probes), the one-step loop's rounds as well as the rollout route's (full-scope screen and
  narrower scopes), and whether the truth's own family x scope was probed at all;
- what the reference contrast did with what the search accepted (``p(change)``);
- ``unexplained_change`` and ``reference_change`` (ratio, p, scope, concentration,
  significant, named; the change screen's kept family and its best hypothesis of the truth's
  family);
- ``suspected`` entries of the truth's family, and one line: where the miss stood.

``--zoos`` reads the first, blind runs of the no-twin arm that ``learned_by_family/tally.py``
reads (each zoo's ``runs/run1/learned*``; a zoo still sealed must be named in ``--skip``);
``--summary`` prints, per true family, how many misses stood where (effects outside the
model's inputs only, the arm's target).

Most committed runs keep ``report.md`` and the diagnose log but not ``report.json``: the
report is then rebuilt in part from those two (:func:`report_from_text`) and says so. The log
lists every full-scope probe with its total gain and p, but only the narrower screen's four
smallest p (where the truth's scope is not among them, the screen's rule says whether it was
probed: :func:`_unlisted`); a probe is significant where p < alpha (the route's test);
whether it is material is read from the round's "against the reference" line (it lists the
probes the round may accept: significant, material and with a total gain > 0). A probe
missing from that line counts as not material only where its total gain is > 0 and, for the
position probe (which the route holds back, unlisted, where the moves' starts are confounded
with it), where the run's suspects are in ``results.json``; otherwise, and without a
reference, unknown. zoo9-zoo11 froze code older than 44362a20: their ``results.json`` holds
none of the rollout route's suspects, so "suspected of its family" is always empty there and
their position probe's materiality unknown. alpha and ``narrow_p`` are those of the code the
run froze (:func:`frozen_options`; where git lacks that commit, this build's defaults, and
the evidence line says so). The floor is in neither file: a ``ground_slope`` truth whose
position probe ran reads "the position probe ran, its reading as a slope unknown", not
"never probed". Where no round of either search parses, the miss stands at "nothing
readable". A missing ``results.json`` or ``truth.yaml`` is a one-line message naming it
(``--zoos``: that run is skipped with a note). The one-step loop's candidates come from report.md's tables (else
the log's picks), its picks' contrast with the reference from the log.
``unexplained_change`` and ``reference_change`` come from report.md's statements (the log
states them only where significant); the change screen's hypotheses are not in either. A
diagnosis that stopped with an error says so. Families are compared in the vocabulary: a
learned label reads as the family and scope the route reports it under
(:func:`~littledog_mlsim.diagnose.families.learned.physical_reading`), a searched form as its
vocabulary family (:func:`~littledog_mlsim.diagnose.families.vocabulary_family`). Nothing is
re-run; it reads files only.
"""
from __future__ import annotations

import argparse
import collections
import dataclasses
import functools
import json
import math
import re
import subprocess
import sys
from pathlib import Path
from typing import Any, Iterator, Mapping

import yaml

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from benchmarks.blind_zoo.harness.misses import _fmt_params, _truth_value  # noqa: E402
from benchmarks.blind_zoo.harness.misses import _num as _fmt_num  # noqa: E402
from benchmarks.blind_zoo.learned_by_family.tally import first_runs  # noqa: E402
from littledog_mlsim.diagnose.change import Hypothesis  # noqa: E402
from littledog_mlsim.diagnose.excess import MIN_RATIO  # noqa: E402
from littledog_mlsim.diagnose.families import vocabulary_family  # noqa: E402
from littledog_mlsim.diagnose.families.learned import physical_reading  # noqa: E402
from littledog_mlsim.diagnose.families.scopes import (joint_scopes, scope_group,  # noqa: E402
                                                       scope_words)
from littledog_mlsim.diagnose.learned import SCOPES, LearnedOptions  # noqa: E402
from littledog_mlsim.diagnose.learned import family_probes as route_probes  # noqa: E402
from littledog_mlsim.diagnose.selection import DEFAULT_ALPHA, DEFAULT_MIN_GAIN  # noqa: E402
from littledog_mlsim.models.feature_base import (AUGMENTATIONS, Augmentation,  # noqa: E402
                                                 FeatureSetError, augmentation_from_dict)

#: where a miss stood, furthest along the route first (:func:`standing`)
STANDINGS = (
    "named its family at another scope",
    "no report or log committed",
    "the diagnosis stopped with an error",
    "accepted by the search, not named",
    "accepted by the search, set aside by the reference contrast",
    "accepted by the search, not compared (reference under another excitation)",
    "kept by the change screen, not named",
    "seen in unexplained_change (material), not named",
    "nothing readable",
    "significant and material at its scope, held back as suspected",
    "significant and material at its scope, not taken",
    "significant at its scope, not material",
    "significant at its scope (materiality not in the log)",
    "probed at its scope, p above alpha",
    "probed at its scope (by the screen's rule), p not in the log",
    "the position probe ran, its reading as a slope unknown",
    "never probed at its scope; its family significant elsewhere",
    "never probed at its scope; its family probed elsewhere",
    "its family never probed",
)
#: the change screen's hypothesis families (``change.Hypothesis``), by their label's words
CHANGE_FAMILIES = ("servo_gain", "encoder_offset", "command_delay", "command_filter",
                   "backlash", "contact_phase", "time_drift")
_CHANGE_WORDS = {Hypothesis(f, "all").label()[:-len(" @ all")]: f for f in CHANGE_FAMILIES}
#: a vocabulary scope by its words in a statement (``scope_words``'s inverse)
_SCOPE_BY_WORDS = {scope_words(s): s for s in joint_scopes() + ["body"]}
_NUM = r"[-+]?(?:\d+\.?\d*(?:e[-+]?\d+)?|nan|inf)"
_LABEL = r"[a-z_]+\([^()]*\)"
#: the narrower screen's probes the diagnose log lists, smallest p first (``learned._search``)
LOG_NARROWER = 4
#: the commit from which results.json holds the rollout route's suspects (a position probe
#: held back as confounded with the moves' start among them); zoo9-zoo11 froze older code
SUSPECTS_SINCE = "44362a20"
#: the position probe (``feature_library.PlanarPosition``), which reads as a slope only where
#: the report gives the floor
POSITION = "planar_position("


class MissingFile(Exception):
    """A file a run's reading needs (``results.json``, ``truth.yaml``) is not there."""


def _float(x: str | None) -> float | None:
    return None if x is None else float(x)


# ---------------------------------------------------------------------------------------------
# learned labels in the vocabulary


def parse_label(label: str) -> tuple[str, dict[str, Any]] | None:
    """(augmentation name, params) of a learned label such as ``command_lag(lag=2,
    joints=all)``; None for anything else."""
    m = re.fullmatch(r"([a-z_]+)\((.*)\)", label.strip())
    if m is None:
        return None
    params: dict[str, Any] = {}
    for part in filter(None, (p.strip() for p in m.group(2).split(","))):
        key, _, value = part.partition("=")
        for cast in (int, float):
            try:
                params[key] = cast(value)
                break
            except ValueError:
                continue
        else:
            params[key] = value
    return m.group(1), params


def augmentation_of(label: str) -> Augmentation | None:
    """The augmentation a learned label names, in this build; a parameter its class does not
    have (a label of older code) is left out. None where the label names no augmentation this
    build can make."""
    parsed = parse_label(label)
    if parsed is None or parsed[0] not in AUGMENTATIONS:
        return None
    name, params = parsed
    fields = {f.name for f in dataclasses.fields(AUGMENTATIONS[name])}
    try:
        return augmentation_from_dict({"name": name, "params": {
            k: v for k, v in params.items() if k in fields}})
    except FeatureSetError:
        return None


def label_reading(label: str, floor: Mapping[str, Any] | None = None
                  ) -> dict[str, Any] | None:
    """The vocabulary's ``{family, scope}`` a learned label reads as: the route's own
    :func:`physical_reading` of its augmentation (``floor``: the report's ``floor_plane``, by
    which a position effect reads as an inclined floor); None where :func:`augmentation_of`
    has none."""
    aug = augmentation_of(label)
    if aug is None:
        return None
    r = physical_reading(aug, floor)
    return {"family": r["family"], "scope": r["scope"]}


def change_family(label: str | None) -> str | None:
    """The family of a change-screen hypothesis label (``set-point delay 2 step(s) @ all``)."""
    words = str(label or "").split(" @ ")[0]
    return next((f for w, f in _CHANGE_WORDS.items() if words.startswith(w)), None)


# ---------------------------------------------------------------------------------------------
# a report rebuilt in part from report.md and the diagnose log


@functools.lru_cache(maxsize=None)
def frozen_options(code: str) -> dict[str, float]:
    """The rollout route's ``alpha`` and ``narrow_p`` defaults in the code a run froze
    (``results.json``'s ``code``, its first word a commit), read from that commit's
    ``diagnose/learned.py``; this build's defaults where git does not have it, and then
    ``note`` says so (the evidence line prints it). ``narrow_p`` is 1 where that code had
    none (a narrower screen, if any, of every family that gained). ``suspects``: whether
    that code put the rollout route's suspects in results.json (it descends from
    :data:`SUSPECTS_SINCE`); None where git cannot tell."""
    out: dict[str, Any] = {"alpha": LearnedOptions().alpha,
                           "narrow_p": LearnedOptions().narrow_p, "suspects": None,
                           "note": "alpha/narrow_p: this build's defaults, the run's commit "
                                   "not found"}
    commit = (code or "").split(" ")[0]
    if not re.fullmatch(r"[0-9a-f]{7,40}", commit):
        return out
    r = subprocess.run(["git", "show", f"{commit}:littledog_mlsim/diagnose/learned.py"],
                       cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        return out
    found = dict(re.findall(rf"^\s+(alpha|narrow_p): float = ({_NUM})", r.stdout, re.M))
    anc = subprocess.run(["git", "merge-base", "--is-ancestor", SUSPECTS_SINCE, commit],
                         cwd=ROOT, capture_output=True, text=True).returncode
    return {"alpha": float(found.get("alpha", out["alpha"])),
            "narrow_p": float(found.get("narrow_p", 1.0)),
            "suspects": True if anc == 0 else False if anc == 1 else None, "note": None}


def _items(text: str, pattern: str) -> list[re.Match]:
    return list(re.finditer(pattern, text))


def _md_rounds(md: str) -> list[dict[str, Any]]:
    """The one-step loop's rounds from report.md's "Rounds" section: per round the candidates
    its table lists (``best``) and what it picked. A candidate is significant where its
    adjusted p is below the loop's alpha and material where its largest cut reaches the
    minimum, both as report.md states them (else the one-step defaults)."""
    level = re.search(rf"adjusted p < ({_NUM})\) and materially \(>= ({_NUM})%", md)
    alpha = float(level.group(1)) if level else DEFAULT_ALPHA
    min_gain = float(level.group(2)) / 100.0 if level else DEFAULT_MIN_GAIN
    section = md.split("## Rounds", 1)[1].split("\n## ", 1)[0] if "## Rounds" in md else ""
    out: list[dict[str, Any]] = []
    for block in re.split(r"\n(?=Round \d+ )", section):
        head = re.match(r"Round (\d+) .*?: (\d+) significant, (\d+) significant and material; "
                        r"picked (?:`([^`]*)`|nothing)", block)
        if head is None:
            continue
        best = []
        for m in _items(block, rf"\| `([^`]*)` \|([^|]*)\| ({_NUM})% \| ({_NUM}) \| ({_NUM}) \|"):
            p, cut = float(m.group(5)), float(m.group(3)) / 100.0
            best.append({"candidate": m.group(1), "family": m.group(2).strip(),
                         "max_gain": cut, "total_gain": float(m.group(4)), "p_value": p,
                         "significant": p < alpha, "material": cut >= min_gain})
        out.append({"round": int(head.group(1)), "picked": head.group(4), "best": best,
                    "n_significant": int(head.group(2)), "n_material": int(head.group(3))})
    return out


def _log_rounds(lines: list[str]) -> list[dict[str, Any]]:
    """The one-step loop's rounds from the diagnose log (where report.md is not committed):
    what each round picked (significant and material, as picked), or that it picked
    nothing; the log lists no other candidate."""
    out = []
    for ln in lines:
        m = re.match(rf"round (\d+): ({_LABEL}) \((.+)\), p = ({_NUM}), max gain ({_NUM})", ln)
        if m is not None:
            out.append({"round": int(m.group(1)) + 1, "picked": m.group(2), "best": [
                {"candidate": m.group(2), "family": m.group(3), "p_value": float(m.group(4)),
                 "max_gain": float(m.group(5)), "total_gain": None, "significant": True,
                 "material": True}]})
        elif (m := re.match(r"round (\d+): no effect accepted", ln)) is not None:
            out.append({"round": int(m.group(1)) + 1, "picked": None, "best": []})
    return out


def _md_line(md: str, start: str) -> str | None:
    line = next((ln for ln in md.splitlines() if ln.startswith(start)), None)
    return None if line is None else line[len(start):].strip()


def _scope_of(words: str | None) -> str | None:
    return None if words is None else _SCOPE_BY_WORDS.get(words.strip(), words.strip())


def unexplained_from_statement(text: str | None, significant: bool | None
                               ) -> dict[str, Any] | None:
    """``unexplained_change``'s numbers read off its statement (report.md)."""
    if not text:
        return None
    m = re.search(rf"rollout error is ({_NUM}) times the reference's \(p = ({_NUM})", text)
    where = re.search(rf"it lives in (.+?) \((?:({_NUM}) times the reference's there, "
                      rf"({_NUM}) times the rest's ratio|spread)", text)
    scope = None
    if where is not None:
        scope = "body" if where.group(1) == "the body's motion" else _scope_of(where.group(1))
    ratio = _float(m.group(1)) if m else None
    return {"ratio": ratio, "p_value": _float(m.group(2)) if m else None,
            "scope": scope, "concentration": _float(where.group(3)) if where else None,
            "significant": significant,
            "material": None if ratio is None else ratio >= MIN_RATIO,
            "comparable": False if "not compared" in text or "cannot be compared" in text
            else None, "statement": text}


def reference_change_from_statement(text: str | None) -> dict[str, Any] | None:
    """``reference_change``'s numbers read off its statement (report.md): ratio, p, the scope
    where the excess is measured, whether named, the kept family or the best hypothesis."""
    if not text:
        return None
    head = re.search(rf"next step ({_NUM}) times as far off as its own held-out moves at (.+?) "
                     rf"\(p = ({_NUM}); 1 s rollouts ({_NUM}) times\)", text)
    named = re.match(r"(?:a change since the reference at (.+?), ([a-z_]+) \()", text)
    best = re.search(r"best hypothesis \((.+?)\) removes (\d+) %", text)
    removes = re.search(r"it removes (\d+) % of the excess", text)
    significant = not text.endswith("no material and significant change since the reference")
    is_named = named is not None and "not named" not in text
    out = {"ratio": _float(head.group(1)) if head else None,
           "scope": _scope_of(head.group(2)) if head else None,
           "p_value": _float(head.group(3)) if head else None,
           "rollout_ratio": _float(head.group(4)) if head else None,
           "significant": significant and "not compared" not in text, "named": is_named,
           "family": None, "kept_scope": None, "label": None, "explained": None,
           "concentration": None, "statement": text}
    if is_named:
        out.update(family=named.group(2), kept_scope=_scope_of(named.group(1)),
                   explained=int(removes.group(1)) / 100.0 if removes else None)
    elif best is not None:
        out.update(label=best.group(1), family=change_family(best.group(1)),
                   explained=int(best.group(2)) / 100.0)
    return out


def report_from_text(log: str | None, md: str | None, alpha: float | None = None,
                     narrow_p: float | None = None, suspects: bool | None = True,
                     note: str | None = None) -> dict[str, Any]:
    """A report dict in report.json's shape, rebuilt in part from the diagnose log and
    report.md (either may be None): the one-step loop's rounds (report.md's tables, else
    the log's picks), the
    rollout route's rounds (every full-scope probe, the narrower screen's four smallest p),
    what each round accepted and the reference contrast's p(change) (the one-step loop's
    picks, as ``effects`` or ``shared`` by the log's contrast line), ``unexplained_change``
    and ``reference_change`` (report.md's statements; the log's where significant).
    ``source`` says what it was read from. A probe is significant where p < ``alpha``
    (default: the route's, ``learned.py``'s ``p_value < alpha``). It is material where the
    round's reference line lists it (the line lists the probes the round may accept:
    significant, material and with a total gain > 0). It is not material only where a
    reference was given, it is significant, its total gain is > 0, the line does not list it
    and the round could have printed one (not a last round that may have stopped at the
    reference contrast's share limit), and, for the position probe (which the route holds
    back, unlisted, where the moves' starts are confounded with its reading), where
    ``suspects`` says the run's suspects are in results.json (:func:`standing_facts` marks
    the held-back probe material from them); else unknown (None). ``narrow_p``: the narrower
    screen's, kept in ``options`` (:func:`_unlisted`). ``note``: that alpha and ``narrow_p``
    are this build's defaults (:func:`frozen_options`). The floor is not in either file:
    ``floor_known`` is False."""
    alpha = LearnedOptions().alpha if alpha is None else alpha
    narrow_p = LearnedOptions().narrow_p if narrow_p is None else narrow_p
    lines = [ln.split("diagnose: ", 1)[1] for ln in (log or "").splitlines()
             if ln.startswith("diagnose: ")]
    with_reference = (any(ln.startswith("reference: ") for ln in lines)
                      or _md_line(md or "", "Against the reference:") is not None)
    rounds: dict[int, dict[str, Any]] = {}
    ok: dict[int, set[str]] = collections.defaultdict(set)
    effects, shared, not_comparable = [], [], []
    contrasts: dict[str, dict[str, Any]] = {}
    probe = rf"({_LABEL}) gain ({_NUM}) p ({_NUM})"
    for ln in lines:
        m = re.match(r"round (\d+)(, narrower scopes)?: (.*)$", ln)
        if m is None:
            continue
        k, body = int(m.group(1)), m.group(3)
        if body.startswith("against the reference: "):
            ok[k] |= {x.group(1) for x in _items(body, rf"({_LABEL}) p\(change\)")}
        elif body.startswith("accepted "):
            label = re.match(rf"accepted ({_LABEL})", body).group(1)
            entry = {"label": label, "round": k, "reference": contrasts.get(label)}
            (shared if "in the reference as well" in body else
             not_comparable if "cannot tell" in body else effects).append(entry)
        elif (c := re.match(rf"({_LABEL}) gain ({_NUM}) here, ({_NUM}) on the reference: "
                            rf"p\(change\) ({_NUM})", body)) is not None:
            contrasts[c.group(1)] = {"reference_total_gain": float(c.group(3)),
                                     "p_change": float(c.group(4))}
        elif (found := _items(body, probe)):
            key = "scoped" if m.group(2) else "probes"
            r = rounds.setdefault(k, {"round": k, "probes": []})
            r[key] = [{"label": x.group(1), "total_gain": float(x.group(2)),
                       "p_value": float(x.group(3))} for x in found]
            if key == "scoped":
                r["scoped_complete"] = len(found) < LOG_NARROWER
    accepted = {e["label"] for e in effects + shared + not_comparable}
    last = max(rounds, default=None)
    for k, r in rounds.items():
        # a last round without its reference line may have stopped before printing it (the
        # share limit) once something was set aside; its unlisted probes are then unknown
        lined = k in ok or not (k == last and (shared or not_comparable))
        for p in r["probes"] + r.get("scoped", []):
            p["significant"] = p["p_value"] < alpha
            p["material"] = (True if p["label"] in ok[k] or p["label"] in accepted else
                             False if with_reference and p["significant"] and lined
                             and p["total_gain"] > 0
                             and (suspects or not p["label"].startswith(POSITION)) else None)
    one_step = _md_rounds(md) if md else _log_rounds(lines)
    verdicts = {m.group(1): m.group(2) for ln in lines if (m := re.match(
        rf"one-step ({_LABEL}) against the reference: .*: (a change|the robot's own)", ln))}
    picked = [{"label": r["picked"], "round": r["round"]} for r in one_step if r["picked"]]
    said = {ln.split(": ", 1)[0]: ln.split(": ", 1)[1] for ln in lines
            if ln.startswith(("unexplained change: ", "change since the reference: "))}
    unexplained = _md_line(md or "", "Against the reference: ")
    changed = _md_line(md or "", "The reference's model on this data: ")
    source = " and ".join(n for n, t in (("report.md", md), ("the diagnose log", log)) if t)
    error = next((ln.split("error: ", 1)[1] for ln in (log or "").splitlines()
                  if ln.startswith("littledog-mlsim diagnose: error: ")), None)
    return {"source": source or "nothing", "floor_plane": None, "floor_known": False,
            "rounds": one_step, **({"error": error} if error else {}),
            **({"options_note": note} if note else {}),
            "effects": [e for e in picked if verdicts.get(e["label"]) != "the robot's own"],
            "shared": [e for e in picked if verdicts.get(e["label"]) == "the robot's own"],
            "rollout_route": {
                "options": {"alpha": alpha, "narrow_p": narrow_p},
                "rounds": [rounds[k] for k in sorted(rounds)],
                "effects": effects,
                "reference": {"shared": shared, "not_comparable": not_comparable}
                if with_reference else None,
                "unexplained_change": unexplained_from_statement(
                    unexplained or said.get("unexplained change"),
                    "unexplained change" in said if log else None) if with_reference else None,
                "reference_change": reference_change_from_statement(
                    changed or said.get("change since the reference"))
                if with_reference else None}}


def load_report(run: Path, eid: str, code: str = "") -> dict[str, Any] | None:
    """The report of effect ``eid`` in ``run``: report.json where committed (``source``:
    "report.json"), else rebuilt from report.md and the diagnose log at the options of the
    code the run froze (``code``, :func:`frozen_options`); None where neither is."""
    for path in (run / "reports" / f"{eid}.report.json", run / "reports" / eid / "report.json"):
        if path.is_file():
            return {**json.loads(path.read_text()), "source": "report.json"}
    md = run / "reports" / f"{eid}.report.md"
    logs = sorted((run / "logs").glob(f"diagnose*_{eid}.log")) if (run / "logs").is_dir() else []
    if not md.is_file() and not logs:
        return None
    return report_from_text(logs[0].read_text() if logs else None,
                            md.read_text() if md.is_file() else None, **frozen_options(code))



# ---------------------------------------------------------------------------------------------
# where the truth stood (the core: a report dict in, facts out)


def _rank(p: dict[str, Any], probes: list[dict[str, Any]]) -> int:
    """1 + how many of ``probes`` have a smaller p than ``p``."""
    pv = p.get("p_value")
    return 1 + sum(1 for q in probes
                   if pv is not None and q.get("p_value") is not None and q["p_value"] < pv)


def probes_of_family(probes: list[dict[str, Any]], family: str,
                     floor: Mapping[str, Any] | None, key: str = "label"
                     ) -> list[dict[str, Any]]:
    """The probes of ``probes`` whose label reads as the vocabulary family ``family``, each
    with its ``scope`` and ``rank`` (by p among ``probes``), smallest p first."""
    out = []
    for p in probes:
        r = label_reading(str(p.get(key)), floor)
        if r is not None and r["family"] == family:
            out.append({**p, "label": p.get(key), "scope": r["scope"], "rank": _rank(p, probes),
                        "of": len(probes)})
    return sorted(out, key=lambda p: (p.get("p_value") if p.get("p_value") is not None
                                      else math.inf, -(p.get("total_gain") or 0.0)))


def _blocks(label: str, fam: str) -> list[str]:
    """The rollout route's full-scope probes of ``fam`` that a one-step finding ``label``
    keeps out: a round probes no augmentation one of whose columns the feature set already
    holds (``learned._search``; play's columns do not name its width, a lag's name its lag),
    and the narrower screen only narrows the full-scope probes a round made."""
    aug = augmentation_of(label)
    if aug is None:
        return []
    have = set(aug.columns())
    return [f"{a.label()} (by {label})" for a in route_probes()
            if (label_reading(a.label()) or {}).get("family") == fam
            and have & set(a.columns())]


def _unlisted(r: Mapping[str, Any], fam: str, scope: str, floor: Mapping[str, Any] | None,
              alpha: float | None, narrow_p: float) -> list[dict[str, Any]]:
    """The truth's family x scope in a round's narrower screen the log lists only in part
    (:data:`LOG_NARROWER` smallest p): where it is not listed but the screen's rule
    (``learned.screen_narrower``: every leg, type and side of a family whose full-scope probe
    gained with p at most ``narrow_p``; below it, at zoo11's code) probed it, an entry
    ``inferred`` with ``p_at_least`` the largest p listed, and significant false where that is
    not below ``alpha``."""
    listed = r.get("scoped") or []
    if scope_group(scope) not in SCOPES or any(
            (label_reading(str(p["label"]), floor) or {}) == {"family": fam, "scope": scope}
            for p in listed):
        return []
    gained = [p for p in r.get("probes") or []
              if (label_reading(str(p["label"]), floor) or {}).get("family") == fam
              and "joints" in (parse_label(str(p["label"])) or ("", {}))[1]
              and (p.get("total_gain") or 0.0) > 0
              and (p["p_value"] <= narrow_p if narrow_p >= 1.0 else p["p_value"] < narrow_p)]
    if not gained or not listed:
        return []
    floor_p = max(p["p_value"] for p in listed)
    return [{"label": f"{gained[0]['label']} at {scope}", "scope": scope, "p_value": None,
             "p_at_least": floor_p, "total_gain": None, "inferred": True,
             "significant": False if alpha is not None and floor_p >= alpha else None,
             "material": None,
             "where": f"rollout round {r.get('round')}, narrower (not listed in the log: "
                      f"inferred from the screen's rule, p >= {floor_p:.2g})"}]


def standing_facts(report: dict[str, Any] | None, truth: Mapping[str, Any],
                   score: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Where the truth (``family``, ``scope``) stood in the learned route's ``report`` (a
    report.json dict, or :func:`report_from_text`'s); ``score``: the harness's score of the
    row (``named``, ``found``, ``family_right``, ``suspected``). Returns a dict:
    ``one_step`` and ``rollout`` (per round and screen the best probe of the truth's family
    and the one at its scope), ``own_scope`` (every probe of its family x scope, with where),
    ``contrast`` (what the search accepted or set aside, with p(change)), ``unexplained`` and
    ``change`` (the two readings against the reference), ``change_best`` (the change
    screen's best hypothesis of the truth's family, report.json only), ``suspected`` (the
    truth family's entries), ``alpha``, and ``standing`` (:func:`standing`)."""
    score = score or {}
    fam, scope = vocabulary_family(truth["family"]), truth["scope"]
    out: dict[str, Any] = {"family": fam, "scope": scope, "source": None, "one_step": [],
                           "rollout": [], "own_scope": [], "contrast": [], "unexplained": None,
                           "change": None, "change_best": None, "suspected": [],
                           "alpha": None, "family_probed": False,
                           "family_significant_elsewhere": False, "blocked_by": [],
                           "error": None, "note": None, "position_probe": None}
    suspected = (report or {}).get("suspected", score.get("suspected")) or []
    out["suspected"] = [s for s in suspected if vocabulary_family(str(s.get("family"))) == fam]
    if report is None:
        out["standing"] = standing(out, score)
        return out
    out["source"] = report.get("source", "report.json")
    out["error"] = report.get("error")
    out["note"] = report.get("options_note")
    floor = report.get("floor_plane")
    unknown_floor = report.get("floor_known") is False and fam == "ground_slope"
    # a probe the route held back although significant and material (a position effect where
    # the moves' starts are confounded) is suspected as such; the log's reading misses it
    held = {s.get("label") for s in suspected
            if str(s.get("why", "")).startswith("significant and material")}

    def mark(hits: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [{**h, "material": True} if h["label"] in held else h for h in hits]
    for r in report.get("rounds") or []:
        hits = mark(probes_of_family(r.get("best") or [], fam, floor, key="candidate"))
        out["one_step"].append({"round": r.get("round"), "picked": r.get("picked"),
                                "n": len(r.get("best") or []), "best": hits[:1],
                                "at_scope": [h for h in hits if h["scope"] == scope][:1]})
        out["family_probed"] |= bool(hits)
        out["own_scope"] += [{**h, "where": f"one-step round {r.get('round')}"}
                             for h in hits if h["scope"] == scope]
    rr = report.get("rollout_route") or {}
    out["alpha"] = (rr.get("options") or {}).get("alpha")
    for r in rr.get("rounds") or []:
        for screen in ("probes", "scoped"):
            probes = r.get(screen)
            if probes is None:
                continue
            hits = mark(probes_of_family(probes, fam, floor))
            if unknown_floor:      # the position probe would read as a slope at the floor
                pos = [p for p in probes if str(p.get("label")).startswith(POSITION)
                       and p.get("p_value") is not None]
                prev = out["position_probe"]
                out["position_probe"] = min(pos + ([prev] if prev else []),
                                            key=lambda p: p["p_value"], default=None)
            out["rollout"].append({"round": r.get("round"), "screen": screen, "n": len(probes),
                                   "best": hits[:1],
                                   "at_scope": [h for h in hits if h["scope"] == scope][:1]})
            out["family_probed"] |= bool(hits)
            out["family_significant_elsewhere"] |= any(
                h.get("significant") and h["scope"] != scope for h in hits)
            out["own_scope"] += [{**h, "where": f"rollout round {r.get('round')}"
                                                + (", narrower" if screen == "scoped" else "")}
                                 for h in hits if h["scope"] == scope]
            if screen == "scoped" and r.get("scoped_complete") is False:
                out["own_scope"] += _unlisted(r, fam, scope, floor, out["alpha"],
                                              (rr.get("options") or {}).get("narrow_p", 1.0))
    # the one-step loop's findings: a finding excitation shows, moved to suspected where the
    # reference was recorded under another excitation (report.md does not list those apart)
    apart = {s_.get("label") for s_ in suspected
             if "recorded with command excitation" in str(s_.get("why", ""))}
    for kind, rows in (("one-step accepted", report.get("effects") or []),
                       ("one-step, in the reference as well", report.get("shared") or []),
                       ("one-step, not comparable", report.get("not_comparable") or [])):
        for e in rows:
            reading = (e.get("physical") if "family" in (e.get("physical") or {})
                       else label_reading(str(e.get("label")), floor)) or {}
            c = e.get("reference") or {}
            out["contrast"].append({
                "label": e.get("label"), "family": reading.get("family"),
                "kind": "one-step, not comparable" if e.get("label") in apart else kind,
                "scope": reading.get("scope"), "p_change": c.get("p_change"),
                "reference_total_gain": c.get("reference_total_gain")})
            if reading.get("family") == fam:
                out["blocked_by"] += _blocks(str(e.get("label")), fam)
    ref = rr.get("reference") or {}
    for kind, rows in (("accepted", rr.get("effects") or []),
                       ("in the reference as well", ref.get("shared") or []),
                       ("not comparable", ref.get("not_comparable") or [])):
        for e in rows:
            reading = (e.get("vocabulary") if kind == "accepted" and e.get("vocabulary")
                       else label_reading(str(e.get("label")), floor)) or {}
            c = e.get("reference") or {}
            out["contrast"].append({"label": e.get("label"), "kind": kind,
                                    "family": reading.get("family"),
                                    "scope": reading.get("scope"),
                                    "p_change": c.get("p_change"),
                                    "reference_total_gain": c.get("reference_total_gain")})
            for s in e.get("scan") or []:       # the scope scan of what it accepted
                r = label_reading(str(s.get("label")), floor) or {}
                if r.get("family") == fam and r.get("scope") == scope:
                    sig = (None if s.get("p_value") is None or out["alpha"] is None
                           else s["p_value"] < out["alpha"])
                    out["own_scope"].append({**s, "scope": scope, "significant": sig,
                                             "where": f"scope scan of {e.get('label')}"})
    out["unexplained"] = rr.get("unexplained_change")
    rc = rr.get("reference_change")
    out["change"] = rc
    hyps = [h for h in (rc or {}).get("hypotheses") or []
            if vocabulary_family(str(h.get("family"))) == fam and h.get("p_value") is not None]
    if hyps:
        out["change_best"] = min(hyps, key=lambda h: (h["p_value"], -(h.get("total_gain") or 0)))
    out["standing"] = standing(out, score)
    return out


def standing(f: Mapping[str, Any], score: Mapping[str, Any]) -> str:
    """Where a miss stood, furthest along the route first (one of :data:`STANDINGS`): its
    family named at another scope; no report; the diagnosis stopped; accepted by the search
    (not named, set aside by the reference contrast, or not compared with it); kept by the
    change screen, not named; for an effect outside the vocabulary (``other``, which the
    route names only from ``unexplained_change``), a material unexplained change; nothing
    readable where no round of either search parses from the files; then the best probe of
    its own family x scope (significant and material: held back as suspected or not taken;
    significant; p above alpha; p not in the log); for a slope read from text (the floor
    unknown), that the position probe ran; else never probed at its scope (its family
    significant or probed elsewhere, or never probed)."""
    fam = f["family"]
    if score.get("family_right"):
        return "named its family at another scope"
    if f["source"] is None:
        return "no report or log committed"
    if f.get("error"):
        return "the diagnosis stopped with an error"
    mine = [c for c in f["contrast"] if c["family"] == fam]
    if any(c["kind"] in ("accepted", "one-step accepted") for c in mine):
        return "accepted by the search, not named"
    if any("in the reference as well" in c["kind"] for c in mine):
        return "accepted by the search, set aside by the reference contrast"
    if mine:
        return "accepted by the search, not compared (reference under another excitation)"
    rc = f.get("change") or {}
    if rc.get("family") == fam and not rc.get("named"):
        return "kept by the change screen, not named"
    if fam == "other" and (f.get("unexplained") or {}).get("material"):
        return "seen in unexplained_change (material), not named"
    if f["source"] != "report.json" and not f["one_step"] and not f["rollout"]:
        return "nothing readable"
    own = [p for p in f["own_scope"] if p.get("significant") is not None]
    held = {s_.get("label") for s_ in f["suspected"]}
    if any(p["significant"] and p.get("material") and p["label"] in held for p in own):
        return "significant and material at its scope, held back as suspected"
    if any(p["significant"] and p.get("material") for p in own):
        return "significant and material at its scope, not taken"
    if any(p["significant"] and p.get("material") is False for p in own):
        return "significant at its scope, not material"
    if any(p["significant"] for p in own):
        return "significant at its scope (materiality not in the log)"
    if any(p.get("significant") is False for p in f["own_scope"]):
        return "probed at its scope, p above alpha"
    if f["own_scope"]:
        return "probed at its scope (by the screen's rule), p not in the log"
    if f.get("position_probe"):
        return "the position probe ran, its reading as a slope unknown"
    if f["family_significant_elsewhere"]:
        return "never probed at its scope; its family significant elsewhere"
    return ("never probed at its scope; its family probed elsewhere" if f["family_probed"]
            else "its family never probed")


# ---------------------------------------------------------------------------------------------
# printing


def _num(x: Any, f: str = ".2g") -> str:
    """``misses._num``, and a string as it is (the files give some numbers as text)."""
    return _fmt_num(x, f) if x is None or isinstance(x, (int, float)) else str(x)


def _yes(x: Any) -> str:
    return "?" if x is None else "yes" if x else "no"


def _probe(p: Mapping[str, Any]) -> str:
    """One probe of :func:`probes_of_family` on a line ("?": the files do not say)."""
    return (f"`{p['label']}` @ {p['scope']}: p {_num(p.get('p_value'))}, gain "
            f"{_num(p.get('total_gain'), '+.2f')}, significant {_yes(p.get('significant'))}, "
            f"material {_yes(p.get('material'))}, rank {p['rank']} of {p['of']} by p")


def fact_lines(f: Mapping[str, Any]) -> list[str]:
    """Markdown lines of :func:`standing_facts`'s dict."""
    out = [f"- evidence: {f['source'] or 'none committed'}"
           + ("" if f["alpha"] is None else f"; rollout alpha {_num(f['alpha'])}")
           + (f"; {f['note']}" if f.get("note") else "")]
    if f.get("error"):
        out.append(f"- the diagnosis stopped with an error: {f['error'][:200]}")
    if f["source"] is None:
        return out + [f"- suspected of its family: {_suspected(f)}", f"- stood: {f['standing']}"]
    for r in f["one_step"]:
        best = r["best"][0] if r["best"] else None
        none = (f"its family not among the {r['n']} listed" if r["n"] else
                "the log names no other candidate")
        out.append(f"- one-step round {r['round']} (picked {r['picked'] or 'nothing'}): "
                   + (_probe(best) if best else none)
                   + ("" if not best or best["scope"] == f["scope"] else
                      f"; at {f['scope']}: " + (_probe(r["at_scope"][0]) if r["at_scope"]
                                                 else "not listed")))
    for r in f["rollout"]:
        name = f"rollout round {r['round']}" + (", narrower" if r["screen"] == "scoped" else "")
        best = r["best"][0] if r["best"] else None
        listed = "probes" if f["source"] == "report.json" else "probes in the log"
        absent = "not probed" if f["source"] == "report.json" else "not in the log"
        out.append(f"- {name} ({r['n']} {listed}): "
                   + (_probe(best) if best else f"its family {absent}")
                   + ("" if not best or best["scope"] == f["scope"] else
                      f"; at {f['scope']}: " + (_probe(r["at_scope"][0]) if r["at_scope"]
                                                 else absent)))
    if f["blocked_by"]:
        out.append("- the rollout route could not probe: " + "; ".join(f["blocked_by"]))
    if f.get("position_probe"):
        out.append(f"- the position probe ran (p {_num(f['position_probe']['p_value'])}), its "
                   "reading as a slope unknown (the floor is in neither report.md nor the log)")
    if f["source"] and f["source"] != "report.json" and not f["one_step"] and not f["rollout"]:
        out.append("- nothing readable: no round of either search parses from "
                   + f["source"])
    out.append("- its own family x scope probed: " + ("; ".join(
        f"{p['where']}: `{p['label']}` p "
        + (_num(p.get("p_value")) if p.get("p_value") is not None
           else f">= {_num(p.get('p_at_least'))}")
        for p in f["own_scope"]) or "no"))
    for c in f["contrast"]:
        out.append(f"- search {c['kind']}: `{c['label']}` ({c['family']} @ {c['scope']}), "
                   f"p(change) {_num(c['p_change'])}, gain on the reference "
                   f"{_num(c['reference_total_gain'], '+.2f')}")
    u = f["unexplained"]
    if u is not None:
        out.append(f"- unexplained_change: {_reading(u)}, material {_yes(u.get('material'))}"
                   + (", not comparable" if u.get("comparable") is False else ""))
    c = f["change"]
    if c is not None:
        out.append(f"- reference_change: {_reading(c)}, named {_yes(c.get('named'))}; kept "
                   f"{c.get('family') or '-'} @ {c.get('kept_scope') or '-'}"
                   + (f" (best: {c['label']}; " if c.get("label") else " (")
                   + f"explains {_num(c.get('explained'), '.0%')})")
        b = f["change_best"]
        out.append("  - its family in the change screen: " + (
            f"{b.get('label')} ({b.get('stage')}): p {_num(b.get('p_value'))}, gain "
            f"{_num(b.get('total_gain'), '+.2f')}, significant {_yes(b.get('significant'))}, "
            f"material {_yes(b.get('material'))}" if b else
            "no hypothesis" if "hypotheses" in c else "hypotheses not in report.md"))
    out.append(f"- suspected of its family: {_suspected(f)}")
    out.append(f"- stood: {f['standing']}")
    return out


def _reading(r: Mapping[str, Any]) -> str:
    """A reading against the reference in words: ratio, p, scope, concentration, significant."""
    return (f"ratio {_num(r.get('ratio'), '.2f')}, p {_num(r.get('p_value'))}, scope "
            f"{r.get('scope') or '-'}, concentration {_num(r.get('concentration'), '.2f')}, "
            f"significant {_yes(r.get('significant'))}")


def _suspected(f: Mapping[str, Any]) -> str:
    """The truth family's suspected entries on a line, each with its p and why."""
    return "; ".join(f"{s.get('label') or s.get('family')} @ {s.get('scope')} (p "
                     f"{_num(s.get('p_value'))}: {s.get('why')})" for s in f["suspected"]
                     ) or "none"


def misses(run: Path, truth_file: Path, every: bool = False
           ) -> Iterator[tuple[dict[str, Any], dict[str, Any], dict[str, Any]]]:
    """(truth, results row, :func:`standing_facts`) of each first-pass effect of ``run`` not
    found (every one with ``every``)."""
    for path in (truth_file, run / "results.json"):
        if not path.is_file():
            raise MissingFile(f"{path}: not found")
    truth = {t["id"]: t for t in yaml.safe_load(truth_file.read_text())["effects"]}
    results = json.loads((run / "results.json").read_text())
    for row in results.get("rows", []):
        t = truth.get(row["id"])
        s = row.get("score") or {}
        if t is None or (s.get("found") and not every):   # a follow-up row, or found
            continue
        yield t, row, standing_facts(load_report(run, row["id"], str(results.get("code", ""))),
                                     t, s)


def rows(run: Path, truth_file: Path, every: bool = False, zoo: str = "") -> list[str]:
    """Markdown lines of :func:`misses` for one run."""
    out = []
    for t, row, f in misses(run, truth_file, every):
        s = row.get("score") or {}
        named = "; ".join(f"{n.get('family')} @ {n.get('scope')} {_fmt_params(n.get('params'))}"
                          for n in s.get("named", [])) or "nothing"
        out.append(f"### {zoo + ' ' if zoo else ''}{row['id']}: {t['family']} @ {t['scope']} "
                   f"({_truth_value(t)}), learned_inputs {t.get('learned_inputs', False)}")
        out.append(f"- named: {named}; found {s.get('found')}")
        out += fact_lines(f) + [""]
    return out


def summary(skip: set[str]) -> list[str]:
    """Per true family, where the misses outside the model's inputs stood (markdown: a row
    per standing that occurs, a column per family), and a second table of facts beside it."""
    by: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    zoos, skipped = [], []
    for zoo, run, truth in first_runs(skip):
        try:
            found = list(misses(run, truth))
        except MissingFile as e:
            skipped.append(f"{zoo} ({e})")
            continue
        zoos.append(zoo)
        for t, _, f in found:
            if t.get("learned_inputs", False):
                continue
            u, rc = f["unexplained"] or {}, f["change"] or {}
            c = by[t["family"]]
            c.update({"misses": 1, f["standing"]: 1,
                      "report.json committed": f["source"] == "report.json",
                      "rests on the narrower screen's rule (log)": bool(f["own_scope"]) and all(
                          p.get("inferred") for p in f["own_scope"]),
                      "its family x scope probed": bool(f["own_scope"]),
                      "the one-step loop's finding kept its family out of the rollout route":
                          bool(f["blocked_by"]),
                      "suspected of its family": bool(f["suspected"]),
                      "unexplained_change material (ratio >= 1.5)": bool(u.get("material")),
                      "unexplained_change significant": bool(u.get("significant")),
                      "reference_change significant": bool(rc.get("significant")),
                      "reference_change significant at its scope": bool(
                          rc.get("significant")) and (rc.get("kept_scope") or rc.get(
                              "scope")) == t["scope"],
                      "the change screen kept its family": rc.get("family") == f["family"]})
    fams = sorted(by, key=lambda k: -by[k]["misses"])
    head = ["| | " + " | ".join(fams) + " | all |", "|---|" + "---|" * (len(fams) + 1)]

    def row(key: str) -> str:
        return (f"| {key} | " + " | ".join(str(by[k][key] or "") for k in fams)
                + f" | {sum(by[k][key] for k in fams)} |")
    facts = ("report.json committed", "its family x scope probed",
             "rests on the narrower screen's rule (log)",
             "the one-step loop's finding kept its family out of the rollout route",
             "suspected of its family", "unexplained_change material (ratio >= 1.5)",
             "unexplained_change significant", "reference_change significant",
             "reference_change significant at its scope", "the change screen kept its family")
    return ([f"Zoos: {', '.join(zoos)}", ""]
            + ([f"Skipped: {'; '.join(skipped)}", ""] if skipped else []) + head
            + [row("misses")]
            + [row(st) for st in STANDINGS if any(by[k][st] for k in fams)]
            + ["", "Beside it (not exclusive):", ""] + head + [row(x) for x in facts])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path, nargs="?")
    ap.add_argument("truth", type=Path, nargs="?")
    ap.add_argument("--all", action="store_true", help="every effect, found or not")
    ap.add_argument("--zoos", action="store_true",
                    help="every zoo's first no-twin run (runs/run1/learned*), as tally.py reads")
    ap.add_argument("--skip", default=None,
                    help="with --zoos (required): comma-separated zoos left out (every sealed "
                         "zoo), e.g. zoo64,zoo65")
    ap.add_argument("--summary", action="store_true",
                    help="with --zoos: per true family, where the misses stood")
    a = ap.parse_args(argv)
    if not a.zoos:
        if a.run is None or a.truth is None or a.summary:
            ap.error("give RUN and TRUTH, or --zoos --skip ZOOS [--summary]")
        try:
            print("\n".join(rows(a.run, a.truth, a.all)))
        except MissingFile as e:
            print(f"learned_misses: {e}", file=sys.stderr)
            return 1
        return 0
    if a.skip is None:
        ap.error("--zoos needs --skip (every sealed zoo, e.g. zoo64,zoo65)")
    skip = {z.strip() for z in a.skip.split(",") if z.strip()}
    if a.summary:
        print("\n".join(summary(skip)))
        return 0
    for zoo, run, truth in first_runs(skip):
        try:
            print("\n".join(rows(run, truth, a.all, zoo)))
        except MissingFile as e:
            print(f"### {zoo}: skipped ({e})\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
