"""Field-field contacts of a pair group from the placements on, in one compiled call.

``field_pairs.placed_field_contacts`` (sdf-sdf pairs and the sdf-in-mesh direction of
mesh-sdf pairs) needs, per group: the overlap regions of the two bounds, the Halton
starts over them, the descent (``_compiled_descent.descend``) and the merges and patch
search after it (``_compiled_descent.field_contacts``). Driven from Python, the glue
between those kernels (a few dozen small numpy operations) cost as much as the
kernels in a scene of a few bodies per shape pair (the showcase: about 200 us a group,
most groups one pair). :func:`placed_contacts` runs the same operations in the same
order inside one call; only the trigonometry stays with the caller (numpy's cos and
sin, which the rest of the narrowphase uses), so the results are the same bits as
``field_pairs.field_field_contacts`` on ``narrowphase._overlap_region``'s regions.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..vec2 import TINY
from ._compiled_descent import descend, field_contacts
from ._descent_paths import N_FLAGS, N_STATE

__all__ = ["placed_contacts"]


@njit(cache=True, error_model="numpy")
def _regions(bounds_a: np.ndarray, bounds_b: np.ndarray, offset: np.ndarray, cos: np.ndarray,
             sin: np.ndarray, margin: float) -> np.ndarray:
    """``narrowphase._overlap_region`` (n, 4) with the same operations: b's bounds
    (4,) rotated by (cos, sin) (n,) and moved by offset (n, 2), intersected with a's
    bounds (4,) (possibly infinite), grown by margin (m)."""
    n = cos.shape[0]
    region = np.empty((n, 4))
    for k in range(n):
        c, s = cos[k], sin[k]
        cx0, cx1, sx0, sx1 = c * bounds_b[0], c * bounds_b[2], s * bounds_b[0], s * bounds_b[2]
        cy0, cy1, sy0, sy1 = c * bounds_b[1], c * bounds_b[3], s * bounds_b[1], s * bounds_b[3]
        region[k, 0] = max((min(cx0, cx1) - max(sy0, sy1)) + offset[k, 0], bounds_a[0]) - margin
        region[k, 1] = max((min(sx0, sx1) + min(cy0, cy1)) + offset[k, 1], bounds_a[1]) - margin
        region[k, 2] = min((max(cx0, cx1) - min(sy0, sy1)) + offset[k, 0], bounds_a[2]) + margin
        region[k, 3] = min((max(sx0, sx1) + max(cy0, cy1)) + offset[k, 1], bounds_a[3]) + margin
    return region


@njit(cache=True, error_model="numpy")
def placed_contacts(kind: int, barzilai_borwein: bool, kd: int,
                    code_a: np.ndarray, consts_a: np.ndarray, depth_a: int, nesting_a: int,
                    code_b: np.ndarray, consts_b: np.ndarray, depth_b: int, nesting_b: int,
                    bounds_a: np.ndarray, bounds_b: np.ndarray, offset: np.ndarray,
                    cos: np.ndarray, sin: np.ndarray, margin: float, unit: np.ndarray,
                    iterations: int, merge: float, sliver: float, shape_tol: float,
                    no_triangle: np.ndarray, no_owner: np.ndarray, no_corners: np.ndarray,
                    cand: np.ndarray, cand_i: np.ndarray, candidates: np.ndarray):
    """Contacts of field b placed in field a's frame for n pairs (one group).

    kind, barzilai_borwein, kd: ``PAIR``, True, 6 (``descend``'s arguments).
    code_*, consts_*, depth_*, nesting_*: the two fields' programs. bounds_a, bounds_b (4,): body-frame
    AABBs (a's may be infinite, b's finite). offset (n, 2), cos, sin (n,): b's
    origin and the cos and sin of its angle in a's frame (numpy's). margin: m.
    unit (S, 2): the Halton starts in the unit square (``field_pairs._starts``).
    iterations: descent rounds (and patch-search iterations). merge, sliver:
    ``field_pairs._MERGE``, ``_SLIVER``; shape_tol: ``descent.SHAPE_TOL``;
    no_triangle (1, 3, 2), no_owner (0,), no_corners (1, 3): a pair problem's
    unused triangle arguments. cand, cand_i, candidates: the descent's round
    buffers (grown when needed, returned).

    Returns region (n, 4), then ``field_pairs.field_field_contacts``' results for the
    pose rows (offset, angle) and these regions: pair (K,) into the n rows, point
    (K, 2), depth (K,), normal (K, 2) (a's frame), start id (K,); and the buffers.
    """
    region = _regions(bounds_a, bounds_b, offset, cos, sin, margin)
    n, n_starts = cos.shape[0], unit.shape[0]
    live = np.empty(n, dtype=np.int64)
    n_live = 0
    for k in range(n):
        if region[k, 2] >= region[k, 0] and region[k, 3] >= region[k, 1]:
            live[n_live] = k
            n_live += 1
    live = live[:n_live]
    rotation = np.empty((n_live, 2, 2))
    placed = np.empty((n_live, 2))
    scale = np.empty(n_live)
    for j in range(n_live):
        k = live[j]
        rotation[j, 0, 0], rotation[j, 0, 1] = cos[k], -sin[k]
        rotation[j, 1, 0], rotation[j, 1, 1] = sin[k], cos[k]
        placed[j, 0], placed[j, 1] = offset[k, 0], offset[k, 1]
        ex, ey = region[k, 2] - region[k, 0], region[k, 3] - region[k, 1]
        scale[j] = max(math.hypot(ex, ey), TINY)
    n_points = n_live * n_starts
    pair_of = np.empty(n_points, dtype=np.int64)
    points = np.empty((n_points, 2))
    sigma = np.empty(n_points)
    tol = np.empty(n_points)
    for j in range(n_live):
        k = live[j]
        lo_x, lo_y = region[k, 0], region[k, 1]
        ex, ey = region[k, 2] - lo_x, region[k, 3] - lo_y
        for s in range(n_starts):
            i = j * n_starts + s
            pair_of[i] = j
            points[i, 0], points[i, 1] = lo_x + ex * unit[s, 0], lo_y + ey * unit[s, 1]
            sigma[i], tol[i] = 0.25 * scale[j], 1e-12 * scale[j]
    state = np.empty((n_points, N_STATE))
    flags = np.empty((n_points, N_FLAGS), dtype=np.int64)
    running = np.empty(n_points, dtype=np.int64)
    best, phi, data, _, _, cand, cand_i, candidates = descend(
        kind, barzilai_borwein, kd, code_a, consts_a, depth_a, nesting_a, code_b, consts_b,
        depth_b, nesting_b, rotation, placed, pair_of, no_triangle, no_owner, no_corners, 0,
        False, False, points, sigma, iterations, tol, shape_tol, state, flags, running, cand,
        cand_i, candidates)
    pair, point, depth, normal, start_id = field_contacts(
        code_a, consts_a, depth_a, nesting_a, code_b, consts_b, depth_b, nesting_b, rotation,
        placed, pair_of, best, phi, data, scale, n_starts, margin, iterations, merge, sliver)
    return (region, live[pair], point, depth, normal, start_id, cand, cand_i, candidates)
