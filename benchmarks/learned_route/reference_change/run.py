"""The reference's model on the data: a change since the reference that the data's model carries.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/reference_change/run.py \
        --reference WORK/reference --data WORK/effects/z01 WORK/clean/s91_e0 ... --out OUT

Decision 027 (``littledog_mlsim.diagnose.change.reference_change``) on each dataset of a zoo
against its reference, at the route's start feature set (the measured robot's, as the route's
first round sees the data; the route itself runs it at its final feature set, where its search
and decision 026 named nothing): the reference's model on the data, one step and 1 s
rollouts, against its own held-out moves; where the change concentrates at a joint scope, the
change screen's hypotheses and what it names. Beside it, decision 026's ratio: the data's own
held-out 1 s rollout error against the reference's. Writes OUT.md and OUT.json.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.diagnose.candidates import measured_robot_features  # noqa: E402
from littledog_mlsim.diagnose.excess import unexplained_change  # noqa: E402
from littledog_mlsim.diagnose import change  # noqa: E402
from littledog_mlsim.diagnose.change import reference_change  # noqa: E402
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route  # noqa: E402
from littledog_mlsim.layout import CONTROL_DT  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--reference", type=Path, required=True)
    p.add_argument("--data", type=Path, nargs="+", required=True)
    p.add_argument("--label", default=None, help="a name for the zoo in the table")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--no-replay", action="store_true",
                   help="name a set-point change by its fitted column, as before decision 036")
    a = p.parse_args()
    if a.no_replay:
        change.REPLAY_SETPOINT = False
    opts, start = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    ref = _Route(load_moves(a.reference, "train"), start, opts, quiet)
    _, ev_ref = ref.fit(start, one_step=False)
    rows = []
    for d in a.data:
        t = time.perf_counter()
        r = _Route(load_moves(d, "train"), start, opts, quiet)
        _, ev = r.fit(start, one_step=True)
        h = r.h_dec
        own = unexplained_change(ev.err[h], ev.move[h], ev.t0[h], r.mv.types, ev_ref.err[h],
                                 ev_ref.move[h], ev_ref.t0[h], ref.mv.types, h * CONTROL_DT,
                                 opts.alpha)
        c = reference_change(r, ref, start, own["ratio"], ev.one_step)
        rows.append({"data": d.name, "own": {k: own[k] for k in ("ratio", "p_value")},
                     **c, "seconds": time.perf_counter() - t})
        print(f"{d.name}: own {own['ratio']:.2f}; {c['statement']}", flush=True)
        for hyp in c["hypotheses"]:
            if "total_gain" not in hyp:          # a size, alone or replay row
                print(f"    {hyp['stage']} {hyp['label']}: SSE {hyp['sse']:.4g}", flush=True)
                continue
            ok = " ok" if hyp["significant"] and hyp["material"] else ""
            print(f"    {hyp['stage']} {hyp['label']}: gain {hyp['total_gain']:+.2f} "
                  f"p {hyp['p_value']:.2g}{ok}", flush=True)
    code = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip()
    cmd = "OPENBLAS_NUM_THREADS=1 .venv/bin/python " + " ".join(
        [os.path.relpath(__file__, ROOT)] + sys.argv[1:])
    L = [f"# The reference's model on the data{': ' + a.label if a.label else ''}\n",
         f"Command: `{cmd}`  ", f"Code: {code}; {time.strftime('%Y-%m-%d %H:%M')}\n",
         "| data | own rollout / reference | reference's model: one step / reference | "
         "p | 1 s rollout / reference | significant | scope | concentration | named | "
         "family @ scope | size | explained | replay (decision 036) | seconds |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    L += [f"| {x['data']} | {x['own']['ratio']:.2f} | {x['ratio']:.2f} | {x['p_value']:.2g} | "
          f"{x['rollout_ratio']:.2f} | {'yes' if x['significant'] else 'no'} | {x['scope']} | "
          f"{x['concentration']:.2f} | {'yes' if x['named'] else 'no'} | "
          f"{(x.get('family') or '-') + ' @ ' + (x.get('kept_scope') or '-')} | "
          f"{ {k: v for k, v in (x.get('size') or {}).items() if k != 'per_joint'} or '-'} | "
          f"{x.get('explained', float('nan')):.2f} | {_replay_cell(x.get('replay'))} | "
          f"{x['seconds']:.0f} |" for x in rows]
    L += [""] + [f"- {x['data']}: {x['statement']}" for x in rows]
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.with_suffix(".md").write_text("\n".join(L) + "\n")
    a.out.with_suffix(".json").write_text(json.dumps({"command": cmd, "code": code,
                                                      "rows": rows}, indent=1))


def _replay_cell(r: dict | None) -> str:
    """Decision 036's best replayed set-point: its label, the share of the excess it removes,
    and whether it was kept; '-' where it did not run or no replay beat the recorded
    set-point."""
    if not r:
        return "-"
    return (f"{r['label'].split(' @')[0]}, explains {r['explained']:.2f}"
            f"{'' if r['kept'] else ', not kept'}")


if __name__ == "__main__":
    main()
