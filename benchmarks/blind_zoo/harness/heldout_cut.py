"""The held-out SSE cut of one hypothesis (or several compared), per channel and per move, as
``diagnose`` decides.

Re-simulates a dataset's held-out TrainPool moves (2 of each type after the fit move, as
``physid.identify`` picks them) with and without each hypothesis and prints the decision
(``physid.decide``: summed cut, adjusted p, significant, material), the pooled t-test alone,
the summed cut of the short (1 s) and long (4 s) channels, every channel's cut, the per-move cuts
(pooled relative to each channel's total, and bounded, as the rank test takes them) and the moves
that lose most. With ``--also`` the hypotheses are compared as ``diagnose`` compares a shortlist
(``physid.decide_all``). This is how LOG.md's account of zoo2's torque-limit miss was
measured:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/harness/heldout_cut.py \
        DATA torque_saturation type:hip_pitches '{"torque_limit_ratio": 0.518}'

with DATA zoo2's ``y07`` dataset (seed 7) that ``run.py`` records.
"""
from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from littledog_mlsim.data.dataset import load_moves, read_index
from littledog_mlsim.diagnose import physid as P
from littledog_mlsim.robot.config import as_config
from littledog_mlsim.robot.sim import InitialState


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", help="dataset directory")
    ap.add_argument("family", help="a family of physid.FAMILIES")
    ap.add_argument("scope", help="e.g. type:hip_pitches, body, leg:back_left")
    ap.add_argument("params", help="the plug-in parameters as JSON, e.g. '{\"delay_ms\": 30}'")
    ap.add_argument("--n-choice", type=int, default=7,
                    help="hypotheses compared (the Bonferroni factor; diagnose: the shortlist)")
    ap.add_argument("--also", nargs=3, action="append", default=[],
                    metavar=("FAMILY", "SCOPE", "PARAMS"), help="another hypothesis to compare")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    index = read_index(a.data)
    train = load_moves(a.data, "train")
    cfg = replace(as_config(index.info.get("robot", "measured")), sensor_noise=False)
    recs = [train[i] for i in P._pick_moves(train, 2, skip=1)]
    moves = [P._Move(r.name, r.move_type, np.asarray(r.cmd, dtype=float),
                     {k: InitialState.from_recording(r, k) for k in P.SEG_STARTS}) for r in recs]
    meas = [P._measured(r) for r in recs]
    hyps = [(a.family, a.scope, json.loads(a.params))] + [(f, sc, json.loads(pa))
                                                          for f, sc, pa in a.also]
    runner = P._Runner(cfg, moves, a.jobs)
    try:
        V = range(len(recs))
        S0 = np.array([P._sse(P._errors(s, meas[i]))
                       for i, s in zip(V, runner.map([(i, [], "full") for i in V]))])
        S1s = [np.array([P._sse(P._errors(s, meas[i]))
                         for i, s in zip(V, runner.map([(i, [hyp], "full") for i in V]))])
               for hyp in hyps]
    finally:
        runner.close()
    if len(hyps) == 1:   # one hypothesis standing for a shortlist of --n-choice: Bonferroni
        p1 = float(P.rank_max_p([P.move_cuts(S0, S1s[0])])[0])
        decisions = [P.decide(S0, S1s[0], a.n_choice, 0.01, 0.05, min(1.0, a.n_choice * p1))]
    else:
        decisions = P.decide_all(S0, S1s, 0.01, 0.05)
    for hyp, S1, (gain, p_ch, p_adj, sig, mat) in zip(hyps, S1s, decisions):
        share = (S0 - S1) / np.where(S0.sum(axis=0) > 0, S0.sum(axis=0), 1.0)
        pooled = len(recs) * np.nansum(share, axis=1)   # decide's pooled per-move cut
        print(f"{hyp}: {len(recs)} held-out moves: summed cut {np.nansum(gain):+.2f} (short "
              f"{np.nansum(gain[P.SHORT]):+.2f}, long {np.nansum(gain[P.LONG]):+.2f}), adjusted "
              f"p {p_adj:.3g}, significant {sig}, material {mat}; pooled t-test alone p "
              f"{float(P._t_greater(pooled[:, None])[0]):.3g}")
        print("  per-move pooled cuts, sorted: " + " ".join(f"{c:+.2f}" for c in np.sort(pooled)))
        print("  per-move cuts of the rank test, sorted: "
              + " ".join(f"{c:+.2f}" for c in np.sort(P.move_cuts(S0, S1))))
        for j in np.argsort(gain):
            print(f"  {P.CHANNELS[j]:30s} cut {gain[j]:+8.3f}  p {p_ch[j]:.3g}  "
                  f"baseline SSE {S0[:, j].sum():.3g}")
        for m in np.argsort(share.sum(axis=1))[:3]:
            print(f"  move {recs[m].name}: its part of the summed cut {share[m].sum():+.2f}")


if __name__ == "__main__":
    main()
