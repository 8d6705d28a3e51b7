"""The kernel rows of a batch of queries over several LGPR clusters, in one compiled pass.

``LGPR.kernel_rows`` turns one cluster's GEMM ``G = A Z^T`` into the squared-exponential
kernel with seven NumPy calls: ``K = sf2 exp(-0.5 max(-2 G + |a|^2 + |z|^2, 0))``. A batch of
robots on different clusters pays those calls once per cluster visited (about 38 of them for
64 robots on the paper-size model), and their fixed cost, not the arithmetic, is most of the
prediction (``benchmarks/sim_node_20x``, ``batch_bound``). :func:`before_exp` does the steps
before the exponential for every visited cluster's block of one flat buffer in one call;
the exponential stays NumPy's (one call over the buffer), and :func:`scale_blocks` applies each
block's ``sf2``. Each step is the same IEEE operation on the same operands as NumPy's, in the
same order (multiplications by -2 and -0.5 are exact, and numba does not fuse or reassociate
without ``fastmath``), so the kernel rows are NumPy's bit for bit
(``test/models/test_lgpr.py``).
"""
from __future__ import annotations

from numba import njit


@njit(cache=True, nogil=True)
def before_exp(K, block_start, row_start, row_end, width, zz_start, aa, zz):
    """In place, per block b (rows ``row_start[b]:row_end[b]`` of the batch, ``width[b]``
    columns, stored row-major from ``K[block_start[b]]``): ``K = -0.5 max(-2 K + aa[row] +
    zz[zz_start[b] + col], 0)``, the operations of ``LGPR.kernel_rows`` before ``exp``."""
    for b in range(block_start.shape[0]):
        pos = block_start[b]
        n = width[b]
        z0 = zz_start[b]
        for i in range(row_start[b], row_end[b]):
            a = aa[i]
            for j in range(n):
                t = K[pos] * -2.0
                t = t + a
                t = t + zz[z0 + j]
                if t < 0.0:          # np.maximum(t, 0.0): NaN and -0.0 stay as they are
                    t = 0.0
                K[pos] = t * -0.5
                pos += 1


@njit(cache=True, nogil=True)
def scale_blocks(K, block_start, block_end, sf2):
    """In place: ``K[block_start[b]:block_end[b]] *= sf2[b]`` for every block b."""
    for b in range(block_start.shape[0]):
        s = sf2[b]
        for q in range(block_start[b], block_end[b]):
            K[q] = K[q] * s
