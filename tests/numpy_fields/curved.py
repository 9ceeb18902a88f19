"""numpy evaluation of the fields of ``sdfphys.sdf.curved``: a test oracle.

The vectorized numpy code these primitives had before their compiled kernels became
their one implementation (``sdfphys.sdf.compiled``); tests compare the two."""

from __future__ import annotations

import numpy as np

from sdfphys.sdf.base import as_points, safe_normalize
from sdfphys.vec2 import rows_dot, rows_unit_or

_UP = np.array([0.0, 1.0])
_DOWN = np.array([0.0, -1.0])
_RIGHT = np.array([1.0, 0.0])
_LEFT = np.array([-1.0, 0.0])


def _norm(v: np.ndarray) -> np.ndarray:
    return np.hypot(v[:, 0], v[:, 1])


def _pick(mask: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rows of ``a`` where ``mask`` (N,), else rows of ``b``; for (N,) and (N, 2) arrays."""
    return np.where(mask[:, None] if np.ndim(a) == 2 or np.ndim(b) == 2 else mask, a, b)


def _fold_x(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mirror ``p`` into x >= 0; returns the folded points and the sign of x (+1 at x = 0)."""
    sx = np.where(p[:, 0] < 0.0, -1.0, 1.0)
    return np.column_stack([np.abs(p[:, 0]), p[:, 1]]), sx


def _unfold(g: np.ndarray, sx: np.ndarray | float = 1.0,
            sy: np.ndarray | float = 1.0) -> np.ndarray:
    """Gradient of a folded field back in the unfolded frame (undo the mirror signs)."""
    return np.column_stack([g[:, 0] * sx, g[:, 1] * sy])


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Unsigned distance (N,) from ``p`` to the segment ab and its gradient (N, 2).

    Quilez's sdSegment: h = clamp((p - a).(b - a) / |b - a|^2, 0, 1), closest point
    a + h (b - a). For 0 < h < 1 the gradient is the unit normal of ab on p's side
    (the left normal when p is on the segment: the distance has a kink there); at a
    clamped end it is (p - end) / |p - end|. a == b is a point (left normal = (1, 0)).
    """
    ba = b - a
    pa = p - a
    length2 = float(ba @ ba)
    h = np.clip(rows_dot(pa, ba) / length2, 0.0, 1.0) if length2 > 0.0 else np.zeros(len(p))
    rel = pa - h[:, None] * ba
    left = safe_normalize(np.array([[-ba[1], ba[0]]]))[0]
    side = ba[0] * pa[:, 1] - ba[1] * pa[:, 0]
    g_side = np.where((side < 0.0)[:, None], -left, left)
    interior = (h > 0.0) & (h < 1.0)
    return _norm(rel), _pick(interior, g_side, rows_unit_or(rel, left))


def Circle_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p = as_points(points)
    length = np.hypot(p[:, 0], p[:, 1])
    return length - field.radius, safe_normalize(p)


def Segment_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return _segment_distance(as_points(points), field.a, field.b)


def Capsule_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d, g = _segment_distance(as_points(points), field.a, field.b)
    return d - field.radius, g


def UnevenCapsule_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q, sx = _fold_x(as_points(points))
    s, c, h = field.sin_t, field.cos_t, field.height
    top_centre = np.array([0.0, h])
    k = -s * q[:, 0] + c * q[:, 1]
    bottom, top = k < 0.0, k > c * h
    d_side = c * q[:, 0] + s * q[:, 1] - field.r1
    d = np.where(bottom, _norm(q) - field.r1,
                 np.where(top, _norm(q - top_centre) - field.r2, d_side))
    g = _pick(bottom, rows_unit_or(q, _DOWN),
              _pick(top, rows_unit_or(q - top_centre, _UP), np.array([c, s])))
    return d, _unfold(g, sx)


def Pie_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q, sx = _fold_x(as_points(points))
    r = field.radius
    d_arc = _norm(q) - r
    g_arc = rows_unit_or(q, _UP)
    if field.full:
        return d_arc, _unfold(g_arc, sx)
    # max() is exact: the edge lies in the disk, so beyond it m >= |p| - r; inside
    # the wedge the radial projection r p/|p| is on the arc, so there
    # -min(r - |p|, m) is minus the distance to the nearer of arc and edge.
    c = field.c
    normal = np.array([c[1], -c[0]])
    beyond = rows_dot(q, normal) > 0.0
    s = np.where(beyond, 1.0, -1.0)
    h = np.clip(rows_dot(q, c), 0.0, r)
    rel = q - h[:, None] * c
    d_edge = s * _norm(rel)
    interior = (h > 0.0) & (h < r)
    g_edge = _pick(interior, normal, rows_unit_or(s[:, None] * rel, normal))
    arc = d_arc >= d_edge
    return np.where(arc, d_arc, d_edge), _unfold(_pick(arc, g_arc, g_edge), sx)


def CutDisk_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q, sx = _fold_x(as_points(points))
    r, h, w = field.radius, field.h, field.half_chord
    corner = np.array([w, h])
    length = _norm(q)
    s = np.where((length < r) & (q[:, 1] > h), -1.0, 1.0)
    rel_c = q - corner
    d_c = _norm(rel_c)
    g_c = rows_unit_or(s[:, None] * rel_c, _DOWN)
    # The radial projection r q/|q| is on the kept arc iff q is on or above the
    # ray from the origin through the corner: h x - w y <= 0; else the corner.
    on_arc = h * q[:, 0] - w * q[:, 1] <= 0.0
    d_arc = np.where(on_arc, np.abs(length - r), d_c)
    g_arc = _pick(on_arc, rows_unit_or(q, _UP), g_c)
    on_chord = q[:, 0] < w
    d_chord = np.where(on_chord, np.abs(q[:, 1] - h), d_c)
    g_chord = _pick(on_chord, _DOWN, g_c)
    arc = d_arc <= d_chord
    d = s * np.where(arc, d_arc, d_chord)
    return d, _unfold(_pick(arc, g_arc, g_chord), sx)


def Arc_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q, sx = _fold_x(as_points(points))
    r, c = field.radius, field.c
    length = _norm(q)
    # The radial projection lies on the arc iff q is not beyond the end ray.
    on_arc = c[1] * q[:, 0] - c[0] * q[:, 1] <= 0.0
    rel = q - r * c
    d = np.where(on_arc, np.abs(length - r), _norm(rel))
    outward = np.where(length >= r, 1.0, -1.0)[:, None]
    g = _pick(on_arc, outward * rows_unit_or(q, _UP), rows_unit_or(rel, c))
    return d - field.half_width, _unfold(g, sx)


def Ring_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q, sx = _fold_x(as_points(points))
    r, w, c = field.radius, field.half_width, field.c
    length = _norm(q)
    d_ring = np.abs(length - r) - w
    g_ring = np.where(length >= r, 1.0, -1.0)[:, None] * rows_unit_or(q, _UP)
    if field.full:
        return d_ring, _unfold(g_ring, sx)
    # Frame of the right end face: u along its outward normal (cos a, -sin a),
    # v along it (the direction c); the face is u = 0, r - w <= v <= r + w.
    # As for the pie, max() is exact: the face lies in the annulus, and inside
    # the wedge the radial projections onto both circles are on the sector.
    normal = np.array([c[1], -c[0]])
    u, v = rows_dot(q, normal), rows_dot(q, c)
    s = np.where(u > 0.0, 1.0, -1.0)
    rel = np.column_stack([u, v - np.clip(v, r - w, r + w)])
    d_face = s * _norm(rel)
    on_face = (v > r - w) & (v < r + w)
    g_local = _pick(on_face, _RIGHT, rows_unit_or(s[:, None] * rel, _RIGHT))
    g_face = g_local[:, :1] * normal + g_local[:, 1:] * c
    ring = d_ring >= d_face
    return np.where(ring, d_ring, d_face), _unfold(_pick(ring, g_ring, g_face), sx)


def Horseshoe_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q, sx = _fold_x(as_points(points))
    r, w, L, n, d = field.radius, field.half_width, field.length, field.n, field.d
    u, v = rows_dot(q, d), rows_dot(q, n)
    sv = np.where(v >= r, 1.0, -1.0)
    # Leg: box distance (Quilez's sdBox) in the (u, |v - r|) frame.
    bx, by = u - L, np.abs(v - r) - w
    ox, oy = np.maximum(bx, 0.0), np.maximum(by, 0.0)
    out = np.hypot(ox, oy)
    d_leg = out + np.minimum(np.maximum(bx, by), 0.0)
    g_out = np.column_stack([ox, oy * sv]) / np.where(out > 0.0, out, 1.0)[:, None]
    g_in = np.where((bx >= by)[:, None], [1.0, 0.0], np.column_stack([0 * sv, sv]))
    g_leg_local = _pick(out > 0.0, g_out, g_in)
    g_leg = g_leg_local[:, :1] * d + g_leg_local[:, 1:] * n
    # Arc: annulus distance; inside the band the tip face u = L may be nearer.
    length = _norm(q)
    d_ann = np.abs(length - r) - w
    g_ann = np.where(length >= r, 1.0, -1.0)[:, None] * rows_unit_or(q, _DOWN)
    tip = np.column_stack([u - L, v - np.clip(v, r - w, r + w)])
    d_tip = -_norm(tip)
    g_tip_local = rows_unit_or(-tip, _RIGHT)
    g_tip = g_tip_local[:, :1] * d + g_tip_local[:, 1:] * n
    use_tip = (d_ann < 0.0) & (d_tip > d_ann)
    d_arc = np.where(use_tip, d_tip, d_ann)
    g_arc = _pick(use_tip, g_tip, g_ann)
    leg = u > 0.0
    return np.where(leg, d_leg, d_arc), _unfold(_pick(leg, g_leg, g_arc), sx)
