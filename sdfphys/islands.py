"""Islands: the dynamic bodies connected through contacts between dynamic bodies.

Static, kinematic and sleeping bodies (zero inverse mass in the step's body state) do
not join islands: a pile on the ground is one island, two boxes on the ground apart
from each other are two. The solver treats loaded islands (``solver.row_softness``)
and sleeping puts whole islands to sleep (``sleep``); both take them from here.

Union-find with path halving (Tarjan 1975), the root of each island being its lowest
body index, so the labels are deterministic and independent of the contact order.
"""

from __future__ import annotations

import numpy as np

from ._jit import njit

__all__ = ["island_roots", "join", "root_of"]


@njit(cache=True, error_model="numpy", refcounts=False)
def root_of(parent, i):
    """Union-find root of i, halving the path on the way."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True, error_model="numpy", refcounts=False)
def join(parent, inv_mass, a, b):
    """Union of the islands of bodies a and b in ``parent`` (B,) int64 when both are
    dynamic (inv_mass (B,) > 0), the lower root kept."""
    if inv_mass[a] > 0.0 and inv_mass[b] > 0.0:
        ra = root_of(parent, a)
        rb = root_of(parent, b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)


@njit(cache=True, error_model="numpy")
def island_roots(inv_mass, body_a, body_b):
    """(B,) int64: the lowest body index of each body's island (itself if alone).

    inv_mass: (B,) 1/kg, > 0 for the bodies that join islands; body_a, body_b: (K,)
    int64 contact rows (several rows of one pair are fine).
    """
    n = inv_mass.shape[0]
    parent = np.arange(n)
    for k in range(body_a.shape[0]):
        join(parent, inv_mass, body_a[k], body_b[k])
    root = np.empty(n, np.int64)
    for i in range(n):
        root[i] = root_of(parent, i)
    return root
