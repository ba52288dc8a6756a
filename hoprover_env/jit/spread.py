"""The order in which a threaded loop visits its rows, so that every thread gets a fair
share of the costly ones.

numba's OpenMP and workqueue threading layers split a ``prange`` loop into one
contiguous block of iterations per thread, whatever ``numba.set_parallel_chunksize``
says (docs/SCALING.md, "How the loop splits the rovers"). Rovers whose cost differs by
group (a batch whose first half hops and second half rests, a vector env whose early
rows ended their episodes) then leave one thread with most of the work. The threaded
loops therefore read row ``order[j]`` at iteration j, with `order` from `spread_order`:
a fixed permutation, so that each row is still computed by the same code on its own
data (every output bit for bit what it was, whichever thread runs it).
"""

from __future__ import annotations

import math

import numpy as np

BLOCK = 8  # rows kept together: neighbours' outputs share cache lines
# 1 / golden ratio: the stride whose multiples mod 1 are the most evenly spread
_STRIDE = (math.sqrt(5.0) - 1.0) / 2.0


def spread_order(n: int, block: int = BLOCK) -> np.ndarray:
    """A permutation of range(n) (a new int64 array) for a threaded loop to read its rows
    through: blocks of `block` consecutive rows, block j of the loop being block
    ``j * a mod nb`` of the rows (nb blocks, a the integer nearest nb / golden ratio
    that is prime to nb). Any contiguous range of the loop, the share of one thread
    for any thread count, then holds blocks from all over the rows: the stride's
    multiples mod nb are as evenly spread as any sequence's (a low-discrepancy
    sequence), so grouped costs are split evenly, where a random shuffle would split
    them only up to its own noise. Deterministic, the same for every call with n."""
    if n < 0 or block < 1:
        raise ValueError(f"spread_order needs n >= 0 and block >= 1, got {n}, {block}")
    nb = -(-n // block)
    a = max(1, round(nb * _STRIDE))
    while math.gcd(a, nb) > 1:  # prime to nb: j -> j * a mod nb is a bijection
        a += 1
    first = (np.arange(nb, dtype=np.int64) * a) % nb * block
    order = (first[:, None] + np.arange(block, dtype=np.int64)[None, :]).ravel()
    # the last block may be short; writable, as the kernels' declared signatures want
    return np.ascontiguousarray(order[order < n])
