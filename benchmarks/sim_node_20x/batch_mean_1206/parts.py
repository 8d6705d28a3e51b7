"""Where the batched mean's time goes: ``LGPR._batch_mean``'s parts timed one by one (thread CPU
time) on the queries of 300 steps of the batched simulator (the robots of ``run.py``'s batch
phase, std off, gated alpha-PROJ).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/batch_mean_1206/parts.py \
        --model MODEL --data DATA --n 64

The parts repeat ``_batch_mean``'s code (keep the two the same); the result is checked equal to
the model's own batched mean.
"""
import argparse, os, sys, time
from pathlib import Path
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
ap = argparse.ArgumentParser()
ap.add_argument("--model", required=True)
ap.add_argument("--data", required=True)
ap.add_argument("--n", type=int, default=64)
a = ap.parse_args()
import numpy as np
from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.models.onestep import OneStepModel
from littledog_mlsim.rollout.simulate import prepare_test_moves
from littledog_mlsim.rollout.vector_sim import VectorLearnedSimulator
from littledog_mlsim.models.kernel_rows import before_exp, scale_blocks
from littledog_mlsim.models.clustering import nearest_rows
from benchmarks._common import batch_robots
model = OneStepModel.load(a.model)
radius = model.gate_radius()[0]
projection = model.projection("alpha", alpha=0.5, radius=radius)
projection.nn.prepare()
moves = prepare_test_moves(load_moves(a.data, split="test"))
s0, u, pose0 = batch_robots(moves, a.n)
sim = VectorLearnedSimulator(model, projection, s0, pose0, trust_radius=radius)
est = model.estimator
Xs = []
orig = est.predict
def rec(X, return_std=False):
    Xs.append(np.array(X)); return orig(X, return_std=return_std)
est.predict = rec
for t in range(300): sim.step(u[:, t % u.shape[1]])
est.predict = orig
self = est
T = {k: 0 for k in ("labels","prep","gemm1","before","exp","scale","gemm2","out")}
for X in Xs:
    t0 = time.thread_time_ns()
    labels = nearest_rows(X, self.centers_)
    t1 = time.thread_time_ns(); T["labels"] += t1 - t0
    st = self._stacked
    ns, p = X.shape[0], self.n_outputs_
    order = np.argsort(labels, kind="stable")
    lab = labels[order]
    cut = np.flatnonzero(np.diff(lab)) + 1
    r0 = np.concatenate([[0], cut]).astype(np.int64)
    r1 = np.concatenate([cut, [ns]]).astype(np.int64)
    cl = lab[r0]
    A = (X[order] - st["shift"][lab]) * st["inv_l"][lab]
    aa = np.einsum("ij,ij->i", A, A)
    width = st["width"][cl]
    size = (r1 - r0) * width
    b1 = np.cumsum(size); b0 = b1 - size
    K = np.empty(int(b1[-1])); mean = np.empty((ns, p))
    t2 = time.thread_time_ns(); T["prep"] += t2 - t1
    for b in range(cl.shape[0]):
        np.matmul(A[r0[b]:r1[b]], self._rows[cl[b]][2], out=K[b0[b]:b1[b]].reshape(r1[b] - r0[b], width[b]))
    t3 = time.thread_time_ns(); T["gemm1"] += t3 - t2
    before_exp(K, b0, r0, r1, width, st["zz_start"][cl], aa, st["zz"])
    t4 = time.thread_time_ns(); T["before"] += t4 - t3
    np.exp(K, out=K)
    t5 = time.thread_time_ns(); T["exp"] += t5 - t4
    scale_blocks(K, b0, b1, st["sf2"][cl])
    t6 = time.thread_time_ns(); T["scale"] += t6 - t5
    for b in range(cl.shape[0]):
        np.matmul(K[b0[b]:b1[b]].reshape(r1[b] - r0[b], width[b]), self._alpha[cl[b]], out=mean[r0[b]:r1[b]])
    t7 = time.thread_time_ns(); T["gemm2"] += t7 - t6
    mean *= self.y_std_[lab]; mean += self.y_mean_[lab]
    out = np.empty((ns, p)); out[order] = mean
    T["out"] += time.thread_time_ns() - t7
    assert np.array_equal(out, self._batch_mean(X, labels), equal_nan=True)
n = len(Xs)
print(f"N={a.n}, {n} steps: us per step (mean)", {k: round(v / n / 1e3, 1) for k, v in T.items()},
      "; clusters per step (mean)", round(float(np.mean([len(np.unique(nearest_rows(X, est.centers_))) for X in Xs])), 1),
      "; load", os.getloadavg())
