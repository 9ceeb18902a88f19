"""Broadphase: world bounding boxes of every body and candidate pairs by sort-and-sweep.

World AABB of one body (vectorized over all bodies, one numpy pass, no loop over
shapes or bodies): the shape's body-frame AABB ``[x0, y0, x1, y1]`` rotated by the
body angle ``a`` and moved to its centre of mass ``c``, by interval arithmetic,

    x-extent = c_x + cos(a) [x0, x1] - sin(a) [y0, y1]
    y-extent = c_y + sin(a) [x0, x1] + cos(a) [y0, y1]

(``k [lo, hi]`` is ``[k lo, k hi]`` for k > 0, ``[k hi, k lo]`` for k < 0 and
``[0, 0]`` for k = 0, so infinite bounds of unbounded fields stay meaningful: a
half-plane ``y <= 0`` at angle 0 keeps ``y1 = 0``). Multiplying an infinite end,
|k| < 1e-12 counts as 0, so that angle = pi (whose sine is 1.2e-16, not 0) keeps
a flipped ground bounded on one side; the bound is then off by |k| L at distance
L along the boundary, under 1e-6 m for L < 1e6 m. The box is then intersected
with the disc box
``c +- radius`` (radius: bounding radius about the centre of mass). The result is
exact for circles and boxes (the rotated box is its own tightest bound) and
conservative for polygons and fields.

Pairs: sort-and-sweep on x (Baraff 1992; Box2D v1's "SAP" broadphase): sort the
boxes by their lower x; sweeping in that order, each box is tested against the
following ones while their lower x does not pass its upper x, with a y-overlap
test. Cost O(n log n + n k) for k overlapping neighbours on x; an infinite box
(a ground half-plane) costs O(n) once. The sweep runs in numba (``cache=True``),
counting first and then filling an exact-size array.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["candidate_pairs", "world_bounds"]

#: Rotation coefficients below this count as 0 against infinite bounds (see above).
_TINY_COEFFICIENT = 1e-12


def _scaled(k: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Interval ``k * [lo, hi]`` (all (B,)); ``k ~ 0`` gives ``[0, 0]`` for infinite ends."""
    with np.errstate(invalid="ignore"):
        a, b = k * lo, k * hi
    zero = (k == 0.0) | ((np.abs(k) < _TINY_COEFFICIENT) & ~(np.isfinite(lo) & np.isfinite(hi)))
    return (np.where(zero, 0.0, np.minimum(a, b)), np.where(zero, 0.0, np.maximum(a, b)))


def world_bounds(local_bounds: np.ndarray, radius: np.ndarray, position: np.ndarray,
                 angle: np.ndarray, margin: float | np.ndarray = 0.0) -> np.ndarray:
    """World AABBs (B, 4) ``[xmin, ymin, xmax, ymax]`` of B bodies, grown by ``margin`` (m).

    margin: one growth for all bodies, or (B,) one per body (``find_contacts`` grows a
    moving body's box by the distance its points may travel in a step).

    local_bounds: (B, 4) body-frame AABBs (centre of mass at the origin; entries may
        be infinite for unbounded fields). radius: (B,) bounding radius about the
        centre of mass (inf if unbounded). position: (B, 2) centres of mass, world.
        angle: (B,) radians, counter-clockwise.
    """
    c, s = np.cos(angle), np.sin(angle)
    x0, y0, x1, y1 = local_bounds.T
    ax_lo, ax_hi = _scaled(c, x0, x1)
    bx_lo, bx_hi = _scaled(-s, y0, y1)
    ay_lo, ay_hi = _scaled(s, x0, x1)
    by_lo, by_hi = _scaled(c, y0, y1)
    px, py = position[:, 0], position[:, 1]
    out = np.empty((len(angle), 4))
    out[:, 0] = np.maximum(ax_lo + bx_lo, -radius) + px - margin
    out[:, 1] = np.maximum(ay_lo + by_lo, -radius) + py - margin
    out[:, 2] = np.minimum(ax_hi + bx_hi, radius) + px + margin
    out[:, 3] = np.minimum(ay_hi + by_hi, radius) + py + margin
    return out


@njit(cache=True)
def _sweep(order: np.ndarray, box: np.ndarray, movable: np.ndarray, out: np.ndarray) -> int:
    """Overlapping pairs (lo, hi) of body ids into ``out`` (C, 2); returns their count.

    ``box`` (B, 4) and ``movable`` (B,) are already in sweep order (sorted by lower x,
    so the inner loop reads memory sequentially); ``order`` maps back to body ids.
    Pairs beyond ``out``'s capacity are counted but not written.
    """
    n = order.shape[0]
    capacity = out.shape[0]
    count = 0
    for i in range(n):
        hi_x = box[i, 2]
        lo_y = box[i, 1]
        hi_y = box[i, 3]
        for j in range(i + 1, n):
            if box[j, 0] > hi_x:
                break
            if not (movable[i] or movable[j]):
                continue
            if box[j, 1] > hi_y or lo_y > box[j, 3]:
                continue
            if count < capacity:
                out[count, 0] = min(order[i], order[j])
                out[count, 1] = max(order[i], order[j])
            count += 1
    return count


def candidate_pairs(bounds: np.ndarray, movable: np.ndarray) -> np.ndarray:
    """Pairs (P, 2) int64 ``(i, j)``, i < j, whose boxes overlap and one of which can move.

    bounds: (B, 4) world AABBs (closed boxes: touching boxes pair).
    movable: (B,) bool. Output sorted by (i, j), deterministic.
    """
    order = np.argsort(bounds[:, 0], kind="stable")
    box = np.ascontiguousarray(bounds[order], dtype=np.float64)
    moving = np.ascontiguousarray(movable[order], dtype=np.bool_)
    pairs = np.empty((4 * len(order) + 16, 2), np.int64)
    count = _sweep(order, box, moving, pairs)
    if count > len(pairs):
        pairs = np.empty((count, 2), np.int64)
        _sweep(order, box, moving, pairs)
    n = np.int64(len(order))
    keys = np.sort(pairs[:count, 0] * n + pairs[:count, 1])
    return np.stack([keys // n, keys % n], axis=1)
