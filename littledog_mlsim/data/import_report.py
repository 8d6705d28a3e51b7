"""The report of ``littledog-mlsim import``: ``import_report.json``, ``.md`` and ``.png``.

Per bag and topic: message count, rate, interval percentiles and jitter, which time base was
used and why (header stamps, stamps of another clock shifted onto the receive clock, receive
time), the clock offset (median receive - header stamp), messages dropped and why; per bag the
breaks (gaps, resets, time jumps), the segments that became moves (name, type and where the
type came from, split, start, steps, what ended them), segments dropped and why, and the
command statistics (commands superseded before any step used them, steps that held the previous
command). Schema: ``docs/import.md``.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..fileio import atomic_write_text

__all__ = ["write_report", "REPORT_JSON", "REPORT_MD", "REPORT_PNG", "REPORT_FORMAT"]

REPORT_JSON = "import_report.json"
REPORT_MD = "import_report.md"
REPORT_PNG = "import_report.png"
REPORT_FORMAT = "littledog_mlsim.import_report"
_NS = 1e9


def _plain(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float):
        return round(x, 6)
    return x


def write_report(directory: Path, *, bags: list[dict], entries: Sequence, opts: dict,
                 n_messages: int, read_s: float, wall_s: float, read_cpu_s: float | None = None,
                 figure: bool = True) -> dict:
    """Write the three report files into ``directory``; return the JSON document."""
    split = {e.name: e.split for e in entries}
    series: list[tuple[str, dict, list]] = []
    doc_bags = []
    for orig in bags:
        b = dict(orig)
        segs = b.pop("_segments", [])
        topics = {}
        for role, rep in (b.get("topics") or {}).items():
            rep = dict(rep)
            rep.pop("interval_series", None)
            topics[role] = rep
        if "topics" in b:
            b["topics"] = topics
            series.append((b["path"], orig["topics"], segs))
        b["segments"] = [{"name": s.rec.name, "move_type": s.rec.move_type,
                          "type_from": s.label_source, "split": split[s.rec.name],
                          "start_s": s.start_ns / _NS, "n_steps": s.rec.n_steps,
                          "ended_by": s.ended_by} for s in segs]
        doc_bags.append(b)
    n_train = sum(e.split == "train" for e in entries)
    doc = {
        "format": REPORT_FORMAT, "format_version": 1,
        "options": opts,
        "moves": len(entries), "train": n_train, "test": len(entries) - n_train,
        "messages": n_messages, "read_s": read_s, "read_cpu_s": read_cpu_s, "import_s": wall_s,
        "messages_per_s": n_messages / read_s if read_s > 0 else None,
        "messages_per_cpu_s": n_messages / read_cpu_s if read_cpu_s else None,
        "bags": doc_bags,
    }
    doc = _plain(doc)
    atomic_write_text(directory / "import_report.json", json.dumps(doc, indent=1) + "\n")
    atomic_write_text(directory / "import_report.md", _markdown(doc))
    if figure:
        _figure(directory / REPORT_PNG, series)
    return doc


def _fmt(v: Any, spec: str = ".1f") -> str:
    return "-" if v is None else format(v, spec)


def _markdown(doc: dict) -> str:
    L = ["# Import report", "",
         f"{doc['moves']} moves ({doc['train']} TrainPool / {doc['test']} TestPool) from "
         f"{len(doc['bags'])} bag(s); {doc['messages']} messages read, decoded, segmented and "
         f"resampled in {doc['read_s']:.2f} s ({_fmt(doc['messages_per_s'], ',.0f')} messages/s; "
         f"{_fmt(doc['messages_per_cpu_s'], ',.0f')} per CPU second).", ""]
    for b in doc["bags"]:
        L += [f"## {b['path']}", ""]
        if b.get("skipped"):
            L += [f"Skipped: {b['skipped']}", ""]
            continue
        if b.get("recovered"):
            L += [f"Recovered (cut short): {b['recovered']}.", ""]
        L += [f"{b['kind']}, {b['messages']} messages on the three topics "
              f"({b['messages_in_bag']} in the bag).", "",
              "| role | topic | type | count | rate [Hz] | interval p1/p50/p99/max [ms] | "
              "jitter [ms] | time base | clock offset [s] | dropped |",
              "|---|---|---|---|---|---|---|---|---|---|"]
        for role, t in b["topics"].items():
            iv = t.get("interval_ms") or {}
            ivs = "/".join(_fmt(iv.get(k)) for k in ("p1", "p50", "p99", "max"))
            dropped = ", ".join(f"{k} {v}" for k, v in (t.get("dropped") or {}).items()) or "none"
            L.append(f"| {role} | {t['topic']} | {t['msgtype']} | {t['count']} | "
                     f"{_fmt(t.get('rate_hz'))} | {ivs} | {_fmt(t.get('jitter_ms'), '.2f')} | "
                     f"{t['time_source']} | {_fmt(t.get('clock_offset_s'), '.4f')} | {dropped} |")
        L.append("")
        for role, t in b["topics"].items():
            extra = ""
            if t.get("receive_minus_aligned_ms"):
                r = t["receive_minus_aligned_ms"]
                extra = f" Receive - aligned time: p50 {r['p50']:.2f} ms, p99 {r['p99']:.2f} ms."
            if t.get("velocity_from_positions"):
                extra += " No velocities in the messages: joint velocities from positions."
            if role == "pose" and not t.get("has_twist"):
                extra += " No twist in the messages: twist from the poses."
            L.append(f"- {role}: {t['time_source_reason']}.{extra}")
        c = b.get("commands", {})
        L += ["", f"Commands: {c.get('superseded', 0)} superseded (a newer one arrived before "
                  f"the step that would have used it), {c.get('held_steps', 0)} steps held the "
                  f"previous command (no new one arrived in time). Joint states and pose are "
                  f"interpolated onto the 10 ms grid (orientation by slerp).", ""]
        if b.get("breaks"):
            L.append(f"Breaks ({len(b['breaks'])}):")
            for br in b["breaks"][:30]:
                L.append(f"- {br['from_s']:.3f} - {br['to_s']:.3f} s: {br['why']}")
            if len(b["breaks"]) > 30:
                L.append(f"- ... {len(b['breaks']) - 30} more in import_report.json")
            L.append("")
        L += ["| move | type | type from | split | start [s] | steps | ended by |",
              "|---|---|---|---|---|---|---|"]
        for s in b["segments"]:
            L.append(f"| {s['name']} | {s['move_type']} | {s['type_from']} | {s['split']} | "
                     f"{s['start_s']:.3f} | {s['n_steps']} | {s['ended_by']} |")
        if b.get("dropped_segments"):
            L += ["", f"Dropped segments ({len(b['dropped_segments'])}):"]
            L += [f"- {d['from_s']:.3f} - {d['to_s']:.3f} s: {d['why']}"
                  for d in b["dropped_segments"][:30]]
        L.append("")
    return "\n".join(L) + "\n"


def _figure(path: Path, series: list) -> None:
    """Per bag: message intervals of each topic over time, segments shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = series[:8]
    fig, axes = plt.subplots(max(len(shown), 1), 1, figsize=(9, 2.4 * max(len(shown), 1)),
                             squeeze=False)
    for ax, (name, topics, segs) in zip(axes[:, 0], shown):
        t_ref = None
        for role, rep in topics.items():
            t, dt = rep.get("interval_series", (None, None))
            if t is None or len(t) < 2:
                continue
            t_ref = t[0] if t_ref is None else min(t_ref, t[0])
        for role, rep in topics.items():
            t, dt = rep.get("interval_series", (None, None))
            if t is None or len(t) < 2:
                continue
            ax.plot((t[1:] - t_ref) / _NS, dt, ".", ms=1.5, label=f"{role} ({rep['time_source']})")
        for s in segs:
            a = (s.start_ns - t_ref) / _NS
            ax.axvspan(a, a + s.rec.n_steps * 0.01, color="tab:green", alpha=0.12)
        ax.set_yscale("log")
        ax.set_ylabel("interval [ms]")
        ax.set_title(f"{Path(name).name}: {len(segs)} moves (shaded)", fontsize=9)
        ax.legend(fontsize=7, loc="upper right", markerscale=4)
    axes[-1, 0].set_xlabel("time since the first message [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)   # inside the dataset's temporary directory (atomic as a whole)
    plt.close(fig)
