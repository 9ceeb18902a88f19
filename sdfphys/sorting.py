"""A stable argsort for the compiled kernels, small enough to compile in a fraction of a second.

Inside njit code ``np.argsort`` makes numba compile its generic sort machinery for each
key type on every cold start (the merge sort's templates for ``kind="mergesort"``, the
quicksort's otherwise, and the shape checks that come with them): about 5 s of the
showcase's first run went to compiling ``_mesh_contacts_kernels._finish``'s two
argsorts (cProfile of its compilation). ``stable_argsort`` is a plain bottom-up merge
sort over runs sorted by insertion. A stable sort's permutation is unique, so it gives
numpy's ``argsort(kind="stable")`` exactly, NaN keys last as numpy puts them.
"""

from __future__ import annotations

import numpy as np

from ._jit import njit

__all__ = ["stable_argsort"]

#: Rows sorted by insertion before the merges start.
RUN = 16


@njit(cache=True)
def _after(a, b) -> bool:
    """Whether key a sorts strictly after key b (NaN after every number)."""
    return a > b or (a != a and b == b)


@njit(cache=True)
def stable_argsort(keys: np.ndarray) -> np.ndarray:
    """The indices (n,) int64 that sort ``keys`` (n,) ascending, equal keys in their
    order: ``np.argsort(keys, kind="stable")``."""
    n = keys.shape[0]
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[i] = i
    for lo in range(0, n, RUN):
        hi = min(lo + RUN, n)
        for i in range(lo + 1, hi):
            v = order[i]
            j = i - 1
            while j >= lo and _after(keys[order[j]], keys[v]):
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = v
    other = np.empty(n, dtype=np.int64)
    width = RUN
    while width < n:
        for lo in range(0, n, 2 * width):
            mid, hi = min(lo + width, n), min(lo + 2 * width, n)
            i, j = lo, mid
            for k in range(lo, hi):
                if j < hi and (i >= mid or _after(keys[order[i]], keys[order[j]])):
                    other[k] = order[j]
                    j += 1
                else:
                    other[k] = order[i]
                    i += 1
        order, other = other, order
        width *= 2
    return order
