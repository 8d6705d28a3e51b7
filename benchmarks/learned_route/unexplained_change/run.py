"""The unexplained-change test (decision 026) on each dataset of a zoo against its reference.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/unexplained_change/run.py \
        --reference WORK/reference --data WORK/effects/z01 WORK/clean/s81_e0 ... --out OUT

For speed the test runs at the route's start feature set (the measured robot's), as the route's
first round sees the data; the route itself runs it at its final feature set, after the
families it added (``diagnose_learned``). Each dataset: its TrainPool and the reference's, the
route's cross-fit and held-out rollouts (``learned._Route``), the test at the decision horizon
(``excess.unexplained_change``). Writes OUT.md and OUT.json.
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
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route  # noqa: E402
from littledog_mlsim.layout import CONTROL_DT  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--reference", type=Path, required=True)
    p.add_argument("--data", type=Path, nargs="+", required=True)
    p.add_argument("--label", default=None, help="a name for the zoo in the table")
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args()
    opts, start = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    ref = _Route(load_moves(a.reference, "train"), start, opts, quiet)
    _, ev_ref = ref.fit(start, one_step=False)
    rows = []
    for d in a.data:
        t = time.perf_counter()
        r = _Route(load_moves(d, "train"), start, opts, quiet)
        _, ev = r.fit(start, one_step=False)
        h = r.h_dec
        u = unexplained_change(ev.err[h], ev.move[h], ev.t0[h], r.mv.types, ev_ref.err[h],
                               ev_ref.move[h], ev_ref.t0[h], ref.mv.types, h * CONTROL_DT,
                               opts.alpha)
        rows.append({"data": d.name, **{k: u[k] for k in ("significant", "ratio", "p_value",
                                                          "scope", "concentration")},
                     "seconds": time.perf_counter() - t})
        print(f"{d.name}: ratio {u['ratio']:.2f} p {u['p_value']:.2g} "
              f"{'SIGNIFICANT ' + u['scope'] if u['significant'] else 'no'}", flush=True)
    code = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip()
    cmd = "OPENBLAS_NUM_THREADS=1 .venv/bin/python " + " ".join(
        [os.path.relpath(__file__, ROOT)] + sys.argv[1:])
    L = [f"# Unexplained change against the reference{': ' + a.label if a.label else ''}\n",
         f"Command: `{cmd}`  ", f"Code: {code}; {time.strftime('%Y-%m-%d %H:%M')}\n",
         "| data | ratio | p | significant | scope | concentration |", "|---|---|---|---|---|---|"]
    L += [f"| {x['data']} | {x['ratio']:.2f} | {x['p_value']:.2g} | "
          f"{'yes' if x['significant'] else 'no'} | {x['scope']} | {x['concentration']:.2f} |"
          for x in rows]
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.with_suffix(".md").write_text("\n".join(L) + "\n")
    a.out.with_suffix(".json").write_text(json.dumps({"command": cmd, "code": code,
                                                      "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
