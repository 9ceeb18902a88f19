"""Runs of pairs in the batched kernels: where each starts.

A batched pair function (``narrowphase.BATCH_FUNCTIONS``) gives each pair a run id, the
same for the pairs of one shape pair, which are consecutive. The compiled descent keeps
each run's starts together (its blocks and tolerances, ``_compiled_descent._rounds``),
as a call of that shape pair alone did; the mesh stages take them one at a time
(``mesh_contacts.mesh_in_fields``, ``mesh_sdf.sdf_in_meshes``).
"""

from __future__ import annotations

import numpy as np

from .._jit import njit

__all__ = ["run_starts"]


@njit(cache=True, error_model="numpy")
def run_starts(run: np.ndarray) -> np.ndarray:
    """(R + 1,) int64: the first row of each run of equal ``run`` (n,) values, then n."""
    n = run.shape[0]
    count = 1 if n > 0 else 0
    for i in range(1, n):
        count += run[i] != run[i - 1]
    starts = np.empty(count + 1, np.int64)
    r = 0
    for i in range(n):
        if i == 0 or run[i] != run[i - 1]:
            starts[r] = i
            r += 1
    starts[count] = n
    return starts
