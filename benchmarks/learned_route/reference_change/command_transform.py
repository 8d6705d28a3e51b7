"""Not kept: the reference's model as the twin, each family a transformation of the commands.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/command_transform.py --zoo-dir WORK17 \
        --truth benchmarks/blind_zoo/zoos/zoo17/truth.yaml --label zoo17 --out OUT \
        --case z04@side:right --case z03@leg:back_left

Each family of a joint change is written as what the servo would have to be commanded for the
reference's robot to do what the data's robot did: a set-point delay (the commands ``d`` ms
back, interpolated between steps), a low-pass (a first-order filter of time constant ``tau``),
a servo gain ratio ``k`` (``q + k (u - q)``: the P term of a PD servo scaled), a drift of that
gain with the time since the move started (``1 + r t``), a play band on the set-point, a
Coulomb friction (``u - c tanh(dq / 0.05) / kp``, ``kp`` the ``nominal`` robot's). The search
model fitted on the whole reference predicts the data's next step with the transformed commands
at the located scope (``--case DATA@SCOPE``), one parameter value at a time; the table gives
each family's best value and the one-step SSE of the scope's angles and rates with it (the
reference's model never saw the data) over the untransformed commands' (``identity``), and the data's own model's (``own``) as the
floor. Writes OUT.md and OUT.json (appending rows where OUT.json exists).
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

from _common import appended_study, study_commands, zoo_study_parser  # noqa: E402

import numpy as np   # noqa: E402
import yaml   # noqa: E402

from littledog_mlsim.data.dataset import load_moves   # noqa: E402
from littledog_mlsim.diagnose.candidates import measured_robot_features   # noqa: E402
from littledog_mlsim.diagnose.change import _columns_of, _move_sse   # noqa: E402
from littledog_mlsim.diagnose.families.scopes import scope_joints   # noqa: E402
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route   # noqa: E402
from littledog_mlsim.layout import CONTROL_DT, N_STATE, S   # noqa: E402
from littledog_mlsim.robot.config import per_joint, robot_config   # noqa: E402

KP = per_joint(robot_config("nominal").kp)


def delay(U, q, dq, t, J, d_ms):
    """The set-points of joints J ``d_ms`` back, interpolated between steps."""
    s = d_ms / 10.0
    k0 = int(np.floor(s)); f = s - k0
    T = U.shape[0]
    idx0 = np.clip(np.arange(T) - k0, 0, T - 1)
    idx1 = np.clip(np.arange(T) - k0 - 1, 0, T - 1)
    out = U.copy()
    out[:, J] = (1 - f) * U[idx0][:, J] + f * U[idx1][:, J]
    return out


def lowpass(U, q, dq, t, J, tau):
    """The set-points of joints J through a first-order low-pass of ``tau`` ms."""
    a = 1 - np.exp(-10.0 / tau)
    out = U.copy()
    y = U[0, J].copy()
    for i in range(U.shape[0]):
        y = y + a * (U[i, J] - y)
        out[i, J] = y
    return out


def play(U, q, dq, t, J, w):
    """The set-points of joints J through a play band of width ``w`` rad."""
    out = U.copy()
    y = U[0, J].copy()
    for i in range(U.shape[0]):
        y = np.minimum(np.maximum(y, U[i, J] - w / 2), U[i, J] + w / 2)
        out[i, J] = y
    return out


def servo(U, q, dq, t, J, k):
    """The set-point a servo of gain 1 needs to act as one of gain ratio ``k``."""
    out = U.copy()
    out[:, J] = q[:, J] + k * (U[:, J] - q[:, J])
    return out


def drift(U, q, dq, t, J, r):
    """As :func:`servo`, the gain ratio 1 + r t at the time t since the move started."""
    out = U.copy()
    g = (1 + r * t)[:, None]
    out[:, J] = q[:, J] + g * (U[:, J] - q[:, J])
    return out


def friction(U, q, dq, t, J, c):
    """The set-point shifted by a Coulomb friction ``c`` N m over the servo's stiffness."""
    out = U.copy()
    out[:, J] = U[:, J] - (c / KP[J]) * np.tanh(dq[:, J] / 0.05)
    return out


GRID = {
    "command_delay": (delay, [5, 10, 15, 20, 25, 30, 40, 50, 60]),
    "command_filter": (lowpass, [10, 15, 20, 25, 35, 50, 70, 100, 140]),
    "servo_gain": (servo, [0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.1, 1.25, 1.5]),
    "time_drift": (drift, [-0.15, -0.1, -0.07, -0.05, -0.03, 0.03, 0.05, 0.1]),
    "backlash": (play, [0.01, 0.02, 0.035, 0.05, 0.08, 0.12]),
    "joint_friction": (friction, [0.02, 0.04, 0.07, 0.1, 0.15, 0.2, 0.3]),
}


def rows(fs, arrays, Us):
    """``fs``'s rows of the moves' ``arrays`` (``fs.move_arrays``) with the commands ``Us``."""
    ex = [None] * len(arrays)
    by = {}
    for i, a in enumerate(arrays):
        by.setdefault(a[0].shape[0], []).append(i)
    for T, idx in by.items():
        S_ = np.stack([arrays[i][0] for i in idx])
        U = np.stack([Us[i] for i in idx])
        pose = np.stack([arrays[i][3] for i in idx]) if fs.needs_pose else None
        E = fs._extra_batch(S_, U, pose)
        for j, i in enumerate(idx):
            ex[i] = E[j]
    return np.vstack([np.hstack([a[0], u, e]) for a, u, e in zip(arrays, Us, ex)])


def scan(route, ref_model, fs, scope, n):
    """Every family's scan at ``scope``: its best value and SSE ratio, and the whole scan."""
    arrays = [fs.move_arrays(r) for r in route.train]
    Y = np.vstack([a[2] for a in arrays])
    mi = np.concatenate([np.full(a[0].shape[0], i) for i, a in enumerate(arrays)])
    J = scope_joints(scope)
    cols = _columns_of(J)

    def sse_of(Us):
        X = rows(fs, arrays, Us)
        R = Y - X[:, :N_STATE] - ref_model.predict(X, -1)
        return _move_sse(R, mi, n)[:, cols]

    out = {"identity": float(sse_of([a[1] for a in arrays]).sum())}
    for fam, (fn, grid) in GRID.items():
        vals = []
        for th in grid:
            Us = [fn(a[1], a[0][:, S.q], a[0][:, S.dq],
                     (np.arange(a[0].shape[0]) + 1) * CONTROL_DT, J, th) for a in arrays]
            vals.append(float(sse_of(Us).sum()))
        b = int(np.argmin(vals))
        out[fam] = {"best": grid[b], "ratio": round(vals[b] / out["identity"], 3),
                    "scan": dict(zip(map(str, grid), [round(v / out["identity"], 3)
                                                      for v in vals]))}
    return out



def main() -> None:
    p = zoo_study_parser(__doc__.splitlines()[0])
    p.add_argument("--case", action="append", required=True, help="DATA@SCOPE")
    a = p.parse_args()
    truth = {e["id"]: e for e in yaml.safe_load(a.truth.read_text())["effects"]}
    opts, fs = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    ref = _Route(load_moves(a.zoo_dir / "reference", "train"), fs, opts, quiet)
    ref_model, _ = ref.fit(fs, one_step=True)
    out_json = a.out.with_suffix(".json")
    doc = appended_study(out_json)
    for case in a.case:
        name, scope = case.split("@")
        t = time.perf_counter()
        r = _Route(load_moves(a.zoo_dir / "effects" / name, "train"), fs, opts, quiet)
        _, ev_own = r.fit(fs, one_step=True)
        _, _, mi = fs.features_responses(r.train)
        own = float(_move_sse(ev_own.one_step, mi, r.mv.n)[:, _columns_of(
            scope_joints(scope))].sum())
        res = scan(r, ref_model, fs, scope, r.mv.n)
        e = truth.get(name, {})
        row = {"zoo": a.label, "data": name, "scope": scope,
               "truth": f"{e.get('family')} @ {e.get('scope')} {e.get('params')}",
               "own": round(own / res["identity"], 3),
               "families": {k: v for k, v in res.items() if k != "identity"},
               "seconds": round(time.perf_counter() - t, 1)}
        doc["rows"].append(row)
        print(row, flush=True)
    out_json.write_text(json.dumps(doc, indent=1))
    lines = ["# Not kept: the reference's model with each family's commands", ""]
    lines += study_commands(doc)
    lines += ["", "Each cell: the best value of the family's parameter and the one-step SSE of the "
              "scope's angles and rates with it, over the untransformed commands'. `own`: the "
              "data's own model's held-out SSE, the floor.", "",
              "| zoo | data | truth | scope | own | " + " | ".join(GRID) + " |",
              "|---" * (5 + len(GRID)) + "|"]
    for r in doc["rows"]:
        cells = [f"{r['families'][f]['best']}: {r['families'][f]['ratio']:.2f}" for f in GRID]
        lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['scope']} | "
                     f"{r['own']:.3f} | " + " | ".join(cells) + " |")
    a.out.with_suffix(".md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
