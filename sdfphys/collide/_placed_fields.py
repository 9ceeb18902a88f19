"""The field-field descent's problem for a pair group, from the placements, compiled.

``field_pairs.placed_field_contacts`` (sdf-sdf pairs and the sdf-in-mesh direction of
mesh-sdf pairs) needs, per group: the overlap regions of the two bounds, the Halton
starts over them, then the descent (``_compiled_descent.descend``) and the merges
and patch search after it (``_compiled_field_contacts.field_contacts``). In numpy the
glue before the descent (a few dozen small operations) cost as much as the kernels in
a scene of a few bodies per shape pair (the showcase: about 200 us a group, most
groups one pair). :func:`placed_starts` computes it in one call, with the operations
of ``field_pairs.field_field_contacts`` in the same order (the trigonometry stays with
the caller: numpy's cos and sin, which the rest of the narrowphase uses), so the
contacts are the same bits. The descent and the merges stay separate calls: a kernel
calling them would link and compile their code again (about 4 s more at a cold start).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..vec2 import TINY

__all__ = ["overlap_regions", "placed_starts"]


@njit(cache=True, error_model="numpy")
def overlap_regions(bounds_a: np.ndarray, bounds_b: np.ndarray, offset: np.ndarray,
                    cos: np.ndarray, sin: np.ndarray, margin: np.ndarray) -> np.ndarray:
    """(n, 4) boxes (xmin, ymin, xmax, ymax) in a's frame where a and b may overlap,
    grown by ``margin`` (n,) (m): b's body-frame AABB bounds_b (n, 4), rotated by (cos,
    sin) (n,) and moved by offset (n, 2) (b's placement in a's frame), is bounded by
    interval arithmetic, as in the broadphase, and intersected with a's bounds_a (n, 4)
    (possibly infinite: a half-plane; b is bounded, two unbounded shapes are both
    static and never pair); row k of each is pair k's.

    A rotated corner is x = (c x_b - s y_b) + o_x, y = (s x_b + c y_b) + o_y; each
    rounded operation is monotone in its operands, so the extremes over the four
    corners are those of the extreme products, taken per axis: the same bits as the
    corners' extremes."""
    n = cos.shape[0]
    region = np.empty((n, 4))
    for k in range(n):
        c, s = cos[k], sin[k]
        b0, b1, b2, b3 = bounds_b[k, 0], bounds_b[k, 1], bounds_b[k, 2], bounds_b[k, 3]
        cx0, cx1, sx0, sx1 = c * b0, c * b2, s * b0, s * b2
        cy0, cy1, sy0, sy1 = c * b1, c * b3, s * b1, s * b3
        m = margin[k]
        region[k, 0] = max((min(cx0, cx1) - max(sy0, sy1)) + offset[k, 0], bounds_a[k, 0]) - m
        region[k, 1] = max((min(sx0, sx1) + min(cy0, cy1)) + offset[k, 1], bounds_a[k, 1]) - m
        region[k, 2] = min((max(cx0, cx1) - min(sy0, sy1)) + offset[k, 0], bounds_a[k, 2]) + m
        region[k, 3] = min((max(sx0, sx1) + max(cy0, cy1)) + offset[k, 1], bounds_a[k, 3]) + m
    return region


@njit(cache=True, error_model="numpy")
def placed_starts(bounds_a: np.ndarray, bounds_b: np.ndarray, offset: np.ndarray,
                  cos: np.ndarray, sin: np.ndarray, margin: np.ndarray, unit: np.ndarray):
    """The descent's problem and starts for field b placed in field a's frame (n pairs).

    bounds_a, bounds_b (n, 4): each pair's body-frame AABBs (a's may be infinite, b's
    finite); offset (n, 2), cos, sin (n,): b's origin and the cos and sin of its angle
    in a's frame (numpy's); margin (n,): m; unit (S, 2): the Halton starts in the unit
    square (``field_pairs._starts``).

    Returns region (n, 4) (``overlap_regions``), live (L,) the rows
    whose region is not empty, and for them (``field_pairs.field_field_contacts``'
    operations): rotation (L, 2, 2), offset (L, 2), scale (L,) the regions'
    diagonals, and per start (L S): pair (L S,), point (L S, 2), first step scale
    sigma (L S,) and tolerance tol (L S,) (m).
    """
    region = overlap_regions(bounds_a, bounds_b, offset, cos, sin, margin)
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
    pair_of = np.empty(n_live * n_starts, dtype=np.int64)
    points = np.empty((n_live * n_starts, 2))
    sigma = np.empty(n_live * n_starts)
    tol = np.empty(n_live * n_starts)
    for j in range(n_live):
        k = live[j]
        rotation[j, 0, 0], rotation[j, 0, 1] = cos[k], -sin[k]
        rotation[j, 1, 0], rotation[j, 1, 1] = sin[k], cos[k]
        placed[j, 0], placed[j, 1] = offset[k, 0], offset[k, 1]
        lo_x, lo_y = region[k, 0], region[k, 1]
        ex, ey = region[k, 2] - lo_x, region[k, 3] - lo_y
        scale[j] = max(math.hypot(ex, ey), TINY)
        for s in range(n_starts):
            i = j * n_starts + s
            pair_of[i] = j
            points[i, 0], points[i, 1] = lo_x + ex * unit[s, 0], lo_y + ey * unit[s, 1]
            sigma[i], tol[i] = 0.25 * scale[j], 1e-12 * scale[j]
    return region, live, rotation, placed, scale, pair_of, points, sigma, tol
