"""numpy evaluation of the fields of ``sdfphys.sdf.polygonal``: a test oracle.

The vectorized numpy code these primitives had before their compiled kernels became
their one implementation (``sdfphys.sdf.compiled``); tests compare the two."""

from __future__ import annotations

import numpy as np

from sdfphys.sdf.base import as_points
from sdfphys.sdf.polygonal import _Segment
from sdfphys.vec2 import rows_dot, rows_unit_or

#: Polygon's (points x edges) pairs per chunk (a few MB of work arrays).
_CHUNK_PAIRS = 1 << 14


def _sign(x: np.ndarray) -> np.ndarray:
    """+1 where ``x >= 0``, -1 where ``x < 0`` (sign(0) = +1: deterministic folds)."""
    return np.where(x < 0.0, -1.0, 1.0)


def _reflect(q: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fold rows of ``q`` with n.q < 0 across the mirror through the origin with
    unit normal ``n`` (Quilez's ``p -= 2 min(dot(n, p), 0) n``); also which rows moved."""
    k = rows_dot(q, n)
    return q - 2.0 * np.minimum(k, 0.0)[:, None] * n, k < 0.0


def _unreflect(g: np.ndarray, n: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """Gradients mapped back through ``_reflect`` (a reflection is its own inverse)."""
    return np.where(moved[:, None], g - 2.0 * rows_dot(g, n)[:, None] * n, g)


def _nearest(q: np.ndarray, segments: list[_Segment]
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Nearest of a few fixed segments to each row of ``q`` (N, 2) (Quilez's sdSegment).

    Returns the distance (N,), ``v = q - closest`` (N, 2), the chosen segment's
    outward normal (N, 2) and ``interior`` (N,): True where the closest point is
    strictly inside the segment. Ties go to the earlier segment.
    """
    for i, seg in enumerate(segments):
        e = seg.b - seg.a
        w = q - seg.a
        t = np.clip(rows_dot(w, e) / rows_dot(e, e), 0.0, 1.0)
        v = w - t[:, None] * e
        d2 = rows_dot(v, v)
        interior = (t > 0.0) & (t < 1.0)
        if i == 0:
            best, best_v, best_in = d2, v, interior
            best_n = np.broadcast_to(seg.normal, q.shape)
        else:
            closer = d2 < best
            best = np.where(closer, d2, best)
            best_v = np.where(closer[:, None], v, best_v)
            best_n = np.where(closer[:, None], seg.normal, best_n)
            best_in = np.where(closer, interior, best_in)
    return np.sqrt(best), best_v, best_n, best_in


def _signed(dist: np.ndarray, v: np.ndarray, normal: np.ndarray, interior: np.ndarray,
            inside: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Value and gradient from the nearest-feature data of ``_nearest`` (see the
    module docstring): f = s |v|, grad f = the edge normal where the closest point
    is inside an edge, else s v / |v|, falling back to the edge normal if |v| < eps."""
    s = np.where(inside, -1.0, 1.0)
    g = np.where(interior[:, None], normal, rows_unit_or(s[:, None] * v, normal, eps))
    return s * dist, g


def _box(p: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quilez's sdgBox for half-extents ``half`` ((2,) or per point (N, 2)).

    With w = |p| - half: outside the value is |max(w, 0)| and the gradient
    sign(p) max(w, 0) / |max(w, 0)|; inside the value is max(w_x, w_y) and the
    gradient the axis of the nearest face (x wins a tie, so the medial axis is
    deterministic), times sign(p).
    """
    w = np.abs(p) - half
    s = _sign(p)
    outside = np.maximum(w, 0.0)
    out_len = np.hypot(outside[:, 0], outside[:, 1])
    inner = np.minimum(np.maximum(w[:, 0], w[:, 1]), 0.0)
    x_face = w[:, 0] >= w[:, 1]
    g_in = np.where(x_face[:, None], [1.0, 0.0], [0.0, 1.0])
    g_out = outside / np.where(out_len > 0.0, out_len, 1.0)[:, None]
    g = np.where((out_len > 0.0)[:, None], g_out, g_in) * s
    return out_len + inner, g


def Box_evaluate(field, points):
    return _box(as_points(points), field.half)


def RoundedBox_evaluate(field, points):
    p = as_points(points)
    right, top = p[:, 0] >= 0.0, p[:, 1] >= 0.0
    r0, r1, r2, r3 = field.radii
    r = np.where(top, np.where(right, r0, r1), np.where(right, r3, r2))
    d, g = _box(p, field.half - r[:, None])
    return d - r, g


def OrientedBox_evaluate(field, points):
    r = as_points(points) - field.centre
    ux, uy = field.axis
    local = np.stack([r[:, 0] * ux + r[:, 1] * uy, r[:, 1] * ux - r[:, 0] * uy], axis=1)
    d, gl = _box(local, field.half)
    return d, np.stack([gl[:, 0] * ux - gl[:, 1] * uy, gl[:, 0] * uy + gl[:, 1] * ux], axis=1)


def Rhombus_evaluate(field, points):
    p = as_points(points)
    q = np.abs(p)
    bx, by = field.half
    dist, v, n, interior = _nearest(q, field._edge)
    inside = q[:, 0] * by + q[:, 1] * bx < bx * by
    d, g = _signed(dist, v, n, interior, inside, field._eps)
    return d, g * _sign(p)


def Trapezoid_evaluate(field, points):
    p = as_points(points)
    q = np.stack([np.abs(p[:, 0]), p[:, 1]], axis=1)
    dist, v, n, interior = _nearest(q, field._edges)
    inside = (np.abs(q[:, 1]) < field.he) & (rows_dot(q - field._side.a, field._side.normal) < 0)
    d, g = _signed(dist, v, n, interior, inside, field._eps)
    g[:, 0] *= _sign(p[:, 0])
    return d, g


def _ConvexPolygon_evaluate(field, points):
    p = as_points(points)
    dist, v, n, interior = _nearest(p, field._edges)
    inside = np.ones(len(p), dtype=bool)
    for e in field._edges:
        inside &= rows_dot(p - e.a, e.normal) < 0.0
    return _signed(dist, v, n, interior, inside, field._eps)


def _SymmetricTriangle_evaluate(field, points):
    p = as_points(points)
    q = np.stack([np.abs(p[:, 0]), p[:, 1]], axis=1)
    dist, v, n, interior = _nearest(q, field._edges)
    inside = (q[:, 1] > field.y_base) & (rows_dot(q - field._side.a, field._side.normal) < 0)
    d, g = _signed(dist, v, n, interior, inside, field._eps)
    g[:, 0] *= _sign(p[:, 0])
    return d, g


def Polygon_evaluate(field, points):
    p = as_points(points)
    d = np.empty(len(p))
    g = np.empty((len(p), 2))
    step = max(1, _CHUNK_PAIRS // len(field._ax))
    for lo in range(0, len(p), step):
        d[lo:lo + step], g[lo:lo + step] = Polygon__evaluate_chunk(field, p[lo:lo + step])
    return d, g


def Polygon__evaluate_chunk(field, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    # (n, M) arrays, updated in place to keep the working set in cache.
    ex, ey = field._ex, field._ey
    px, py = q[:, 0:1], q[:, 1:2]
    wx = px - field._ax
    wy = py - field._ay
    t = wx * ex
    t += wy * ey
    t *= field._inv_ee
    np.clip(t, 0.0, 1.0, out=t)
    d2 = wx - t * ex
    d2 *= d2
    vy = wy - t * ey
    vy *= vy
    d2 += vy
    k = np.argmin(d2, axis=1)
    # Crossing parity: edge i toggles when (py >= a_y) == (py < b_y) == (q left of it).
    below_b = py < field._by
    crossed = np.equal(py >= field._ay, below_b)
    crossed &= np.equal(below_b, ex * wy > ey * wx)
    inside = np.count_nonzero(crossed, axis=1) % 2 == 1
    rows = np.arange(len(q))
    tk = t[rows, k]
    v = np.stack([wx[rows, k] - tk * ex[k], wy[rows, k] - tk * ey[k]], axis=1)
    return _signed(np.sqrt(d2[rows, k]), v, field._normals[k], (tk > 0.0) & (tk < 1.0),
                   inside, field._eps)


def HalfPlane_evaluate(field, points):
    p = as_points(points)
    d = rows_dot(p, field.normal) - field.level
    return d, np.broadcast_to(field.normal, p.shape).copy()
