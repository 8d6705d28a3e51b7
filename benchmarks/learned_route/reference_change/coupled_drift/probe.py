"""The probe that led to decision 069 (README.md): how much of a drift's one-step excess over the
reference's model a held-out linear correction takes, by its columns.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/coupled_drift/probe.py ZOO ID[:SCOPE],... \
        --work SCRATCH

ZOO's recordings are read from SCRATCH/ZOO (``../whole_drift``'s ``record_and_read.sh``
records them there). For each recording (an effect ``zNN``/``gNN`` or a clean
``sNNN_eX``) at SCOPE (default all): the reference's model (the learned route's start
features, fitted on every reference move) predicts the data's next step; its residual's sum of
squares over the scope's joint angles and rates, above the data's own model's held-out one
(``excess``: the ratio), is what a correction must remove. Each column set is fitted per scope
joint by ridge least squares, held out by the route's folds, and its share of that excess is
printed: ``servo`` u - q, dq, 1; ``stiff`` and t (u - q); ``whole`` and t dq (decision 068);
``leg`` the servo's and t (u - q), t dq of the joint's leg's three joints, and their u - q, dq;
``scope`` the servo's and t (u - q), t dq of every scope joint (decision 069); ``all12`` the
same of all 12 joints; ``pred`` the servo's, t (u - q), t dq and t times the reference model's
own prediction of the joint's angle and rate change; with ``--forms``, also ``cservo`` the
servo's and u - q, dq of every scope joint (a coupled servo response), and ``cscope`` those and
``scope``'s drift columns. ``--of-all`` measures every share on all 12 joints' excess, the
correction still at the scope's joints only. ``csource`` is ``cscope`` with the drift columns
of ``--source``'s joints only (the joints whose drift moves the scope's). Nothing here is the screen's decision
(no reference side, no significance): it measures what each column set can explain.
"""
import argparse
import json
import os
import sys
import time
from pathlib import Path
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[4])]
import numpy as np
from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.diagnose import change
from littledog_mlsim.diagnose.candidates import measured_robot_features
from littledog_mlsim.diagnose.families.scopes import leg_scopes, scope_joints
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route
from littledog_mlsim.layout import N_STATE, S

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("zoo")
ap.add_argument("ids")
ap.add_argument("--work", type=Path, required=True, help="the recordings' scratch directory")
ap.add_argument("--of-all", action="store_true",
                help="measure every share on all 12 joints' excess (a narrower scope's "
                     "correction leaves the other joints' residual as it is)")
ap.add_argument("--source", default=None,
                help="csource's drift columns come from this scope's joints (default the scope's)")
ap.add_argument("--forms", default="servo,stiff,whole,leg,scope,all12,pred",
                help="the column sets, comma-separated (also cservo, cscope, csource)")
a = ap.parse_args()
zoo, ids, FORMS = a.zoo, a.ids.split(","), a.forms.split(",")
W = a.work / zoo
opts, fs = LearnedOptions(), measured_robot_features()
quiet = lambda s: None
ref = _Route(load_moves(W / "reference", "train"), fs, opts, quiet)
ref_model, ev_ref = ref.fit(fs, one_step=True)
LEG = {int(j): [int(k) for k in scope_joints(g)] for g in leg_scopes() for j in scope_joints(g)}
for d in ids:
    d, _, scope = d.partition(":")
    scope = scope or "all"
    t0 = time.time()
    p = W / ("clean" if d.startswith("s") else "effects") / d
    r = _Route(load_moves(p, "train"), fs, opts, quiet)
    _, ev_own = r.fit(fs, one_step=True)
    X, Y, mi = fs.features_responses(r.train)
    D = Y - X[:, :N_STATE]
    n, nf, K = r.mv.n, fs.n_features, opts.n_folds
    p0 = ref_model.predict(X[:, :nf], -1)
    R = D - p0
    fold = r.fold_of_move[mi]
    t = change.elapsed_s(mi)
    js = [int(j) for j in scope_joints(scope)]
    cols = change._columns_of(range(12) if a.of_all else js)
    own = change._move_sse(ev_own.one_step, mi, n)[:, cols].sum()
    un = change._move_sse(R, mi, n)[:, cols].sum()
    E = X[:, N_STATE:N_STATE + 12] - X[:, S.q]
    V = X[:, S.dq]
    def Z_of(form, j):
        one = np.ones(len(X))
        base = [E[:, j], V[:, j], one]
        if form == "servo":
            return np.stack(base, 1)
        if form == "stiff":
            return np.stack(base + [t * E[:, j]], 1)
        if form == "whole":
            return np.stack(base + [t * E[:, j], t * V[:, j]], 1)
        if form == "leg":
            L = LEG[j]
            return np.column_stack(base + [E[:, L], V[:, L], t[:, None] * E[:, L], t[:, None] * V[:, L]])
        if form == "all12":
            return np.column_stack(base + [t[:, None] * E, t[:, None] * V])
        if form == "scope":
            return np.column_stack(base + [t[:, None] * E[:, js], t[:, None] * V[:, js]])
        if form == "cservo":
            return np.column_stack(base + [E[:, js], V[:, js]])
        if form == "csource":
            src = [int(k) for k in scope_joints(a.source or scope)]
            return np.column_stack(base + [E[:, js], V[:, js], t[:, None] * E[:, src],
                                           t[:, None] * V[:, src]])
        if form == "cscope":
            return np.column_stack(base + [E[:, js], V[:, js], t[:, None] * E[:, js],
                                           t[:, None] * V[:, js]])
        if form == "pred":
            return np.column_stack(base + [t * E[:, j], t * V[:, j], t * p0[:, S.dq.start + j], t * p0[:, S.q.start + j]])
    res = {}
    for form in FORMS:
        Rh = R.copy()
        for j in js:
            Z = Z_of(form, j)
            sd = Z.std(0); sd[sd < 1e-12] = 1.0
            Zs = Z / sd
            outs = [S.q.start + j, S.dq.start + j]
            for f in range(K):
                tr, te = fold != f, fold == f
                A = Zs[tr].T @ Zs[tr]
                c = np.linalg.solve(A + 1e-3 * tr.sum() * np.eye(Z.shape[1]), Zs[tr].T @ R[tr][:, outs])
                Rh[np.ix_(te, outs)] = R[np.ix_(te, outs)] - Zs[te] @ c
        after = change._move_sse(Rh, mi, n)[:, cols].sum()
        res[form] = round((un - after) / (un - own), 3)
    print(json.dumps({"zoo": zoo, "data": d, "at": scope, "source": a.source, "excess": round(un / own, 3), **res, "s": round(time.time() - t0, 1)}), flush=True)
