"""Two hot paths of the diagnosis, each against the way it was computed before, on one
recorded dataset: the same numbers (bit for bit) and the time.

1. ``models.features.integrate_pose``: the pose (x, y, yaw in odom) of every state of a move,
   which every batch feature set with a pose column (``heading()``, the position features)
   and the learned route's rollout evidence compute. Before: a Python loop over the steps,
   one ``_pose_step`` each. Now: the yaw, each step's displacement and their running sums
   over the move at once.
2. ``diagnose.selection.SearchModel.candidate_fit``: one candidate's cross-fit in the
   one-step screen (every candidate of every round). Before: each fold's rows of the design
   taken from the whole design (a copy per fold per candidate). Now: each fold's rows copied
   once at the fit.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose_speed/hot_paths/hot_paths.py \
        [--data DATASET] [--out RESULT.md]

Without ``--data`` it records one (4 moves of each type, seed 5, ``record --jobs 2``) in a
temporary directory. Medians over repeats, one process, one BLAS thread.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from _common import git_state  # noqa: E402

from littledog_mlsim.diagnose import selection  # noqa: E402
from littledog_mlsim.models import features as F  # noqa: E402


def pose_by_steps(states: np.ndarray, pose0: np.ndarray) -> np.ndarray:
    """``integrate_pose`` as it was: one ``_pose_step`` per step."""
    s = np.asarray(states, dtype=np.float64)
    B, T = s.shape[:2]
    pose = np.empty((B, T, 3))
    pose[:, 0] = pose0
    for t in range(1, T):
        pose[:, t] = F._pose_step(pose[:, t - 1], s[:, t - 1], s[:, t])
    return pose


def candidate_fit_from_whole(m: selection.SearchModel, Z: np.ndarray):
    """``SearchModel.candidate_fit`` as it was: each fold's rows taken from the whole design
    per candidate."""
    from scipy.linalg import cho_solve
    Zs, _, _ = selection._standardise(np.asarray(Z, dtype=np.float64))
    B, Dn = m.B_, m.Dn_
    q = Zs.shape[1]
    BZ_f = [B[r].T @ Zs[r] for r in m.rows_]
    ZZ_f = [Zs[r].T @ Zs[r] for r in m.rows_]
    ZD_f = [Zs[r].T @ Dn[r] for r in m.rows_]
    BZ, ZZ, ZD = sum(BZ_f), sum(ZZ_f), sum(ZD_f)
    corr = np.empty_like(Dn)
    for f, r in enumerate(m.rows_):
        BZt = BZ - BZ_f[f]
        GiBZ = cho_solve(m.chol_[f], BZt)
        Szz = ZZ - ZZ_f[f] - BZt.T @ GiBZ + m.ridge * np.eye(q)
        Szd = ZD - ZD_f[f] - BZt.T @ m.W0_[f]
        beta = np.linalg.solve(Szz, Szd)
        corr[r] = (Zs[r] - B[r] @ GiBZ) @ beta
    return m.residual_ - corr, corr


def _median_s(fn, repeats: int) -> float:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return float(np.median(out))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path)
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("result.md"))
    a = ap.parse_args(argv)
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.data.states import states_from_recording
    from littledog_mlsim.diagnose.candidates import measured_robot_features
    tmp = None
    data = a.data
    if data is None:
        from littledog_mlsim.apps.record import record_dataset
        tmp = tempfile.TemporaryDirectory()
        data = Path(tmp.name) / "ds"
        record_dataset(data, moves_per_type=4, seed=5, jobs=2, progress=False)
    train = load_moves(data, "train")
    load = os.getloadavg()

    # 1. the pose of every state, move by move (as features_responses calls it)
    S_all = [states_from_recording(m)[None] for m in train]
    p0 = np.array([[0.1, -0.2, 0.3]])
    for S_ in S_all:
        np.testing.assert_array_equal(pose_by_steps(S_, p0), F.integrate_pose(S_, p0))
    old_pose = _median_s(lambda: [pose_by_steps(S_, p0) for S_ in S_all], 3)
    new_pose = _median_s(lambda: [F.integrate_pose(S_, p0) for S_ in S_all], 3)

    # 2. a candidate's cross-fit in the one-step screen
    fs = measured_robot_features()
    X, Y, mi = fs.features_responses(train)
    D = Y - X[:, :33]
    types = [m.move_type for m in train]
    model = selection.SearchModel(n_random_features=1000, n_gp_points=300,
                                  gp_max_iter=30).fit(X, D, mi, types)
    rng = np.random.default_rng(0)
    Zs = [X[:, :q] + rng.standard_normal((X.shape[0], q)) for q in (1, 3, 12)]
    for Z in Zs:
        for u, v in zip(candidate_fit_from_whole(model, Z), model.candidate_fit(Z)):
            np.testing.assert_array_equal(u, v)
    old_fit = _median_s(lambda: [candidate_fit_from_whole(model, Z) for Z in Zs], 5)
    new_fit = _median_s(lambda: [model.candidate_fit(Z) for Z in Zs], 5)

    n_steps = sum(S_.shape[1] for S_ in S_all)
    lines = [
        "# Two hot paths of the diagnosis: before and now",
        "",
        f"Code: {git_state()}. Command: `OPENBLAS_NUM_THREADS="
        f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')} .venv/bin/python "
        "benchmarks/diagnose_speed/hot_paths/hot_paths.py"
        + (f" --data {a.data}" if a.data else "") + "`. Data: "
        + (str(a.data) if a.data else "recorded by the script (4 moves of each type, seed 5)")
        + f": {len(train)} TrainPool moves, {n_steps} states, {X.shape[0]} one-step rows. "
        f"Load average at the start {load[0]:.2f}, {load[1]:.2f}, {load[2]:.2f}.",
        "",
        "Both give the same numbers as before, bit for bit (asserted by the script).",
        "",
        "| path | before [s] | now [s] | before / now |",
        "|---|---|---|---|",
        f"| `integrate_pose`, every TrainPool move (median of 3) | {old_pose:.3f} | "
        f"{new_pose:.4f} | {old_pose / new_pose:.0f} |",
        f"| `SearchModel.candidate_fit`, 3 candidates of 1, 3 and 12 columns (median of 5) | "
        f"{old_fit:.3f} | {new_fit:.3f} | {old_fit / new_fit:.2f} |",
        "",
    ]
    a.out.write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
