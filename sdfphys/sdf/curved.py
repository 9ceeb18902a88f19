"""Primitives with curved boundaries (Quilez, "2D distance functions").

Each primitive sits in its own local frame as in Quilez's list (most are centred
at the origin and symmetric about the y axis). Sign convention: f < 0 inside.

Gradients are analytic and come from the closest boundary point q of p: where q
lies inside a smooth piece of the boundary (an edge or an arc) the gradient is
that piece's outward normal at q, which equals Quilez's ``sdg*`` gradients
wherever the field is differentiable and stays exact for p on or near the
boundary; where q is a vertex (a corner, an end point, a cusp) it is
sign(f) (p - q) / |p - q|. Where the gradient is undefined (a centre, a medial
axis, a point on a bare segment or curve) the result is still a deterministic
unit vector; each docstring names the notable cases. No branch divides by a
quantity that can vanish; the iterative solvers (ellipse, Bezier) run a fixed
number of steps.

Angles are in radians; "half" angles are measured from the +y axis on both
sides, so ``half_angle = pi / 2`` is a half disk above the x axis.

References: Inigo Quilez, https://iquilezles.org/articles/distfunctions2d/ and
https://iquilezles.org/articles/distgradfunctions2d/; D. Eberly, "Distance from
a point to an ellipse, an ellipsoid, or a hyperellipsoid" (2013);
J. Moré and D. Sorensen, "Computing a trust region step" (1983).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SpecError
from .base import REQUIRED, Field, Param, as_points, primitive, safe_normalize

_TINY = 1e-300
_UP = np.array([0.0, 1.0])
_DOWN = np.array([0.0, -1.0])
_RIGHT = np.array([1.0, 0.0])
_LEFT = np.array([-1.0, 0.0])


# --------------------------------------------------------------------------------------
# Small vectorized helpers. Points are (N, 2); "fallback" is a (2,) or (N, 2) unit vector.
# --------------------------------------------------------------------------------------

def _norm(v: np.ndarray) -> np.ndarray:
    return np.hypot(v[:, 0], v[:, 1])


def _unit(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Rows of ``v`` scaled to unit length; (near) zero rows become ``fallback``."""
    n = _norm(v)
    ok = n > _TINY
    return np.where(ok[:, None], v / np.where(ok, n, 1.0)[:, None], fallback)


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


def _vec(value: ArrayLike) -> np.ndarray:
    return np.array(value, dtype=np.float64).reshape(2)


def _check_half_angle(name: str, value: float, *, allow_pi: bool = True) -> float:
    value = float(value)
    if not value > 0.0:
        raise SpecError(name, f"must be > 0, got {value:g}")
    if allow_pi and not value <= math.pi:
        raise SpecError(name, f"must be <= pi (3.14159...), got {value:g}")
    if not allow_pi and not value < math.pi:
        raise SpecError(name, f"must be < pi (3.14159...), got {value:g}")
    return value


def _check_positive(name: str, value: float) -> float:
    value = float(value)
    if not value > 0.0:
        raise SpecError(name, f"must be > 0, got {value:g}")
    return value


def _arc_box(radius: float, half_angle: float) -> np.ndarray:
    """AABB of the circular arc of ``radius`` spanning ``half_angle`` either side of +y."""
    x = radius * math.sin(min(half_angle, math.pi / 2))
    return np.array([-x, radius * math.cos(half_angle), x, radius])


def _rows_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of (N, 2) arrays (either may be a broadcast (2,)).

    Written out rather than ``a @ b`` (as ``polygonal._rows_dot``): BLAS rounds a
    row differently depending on its position in the batch, and a field must give
    a point the same answer alone or among others.
    """
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]


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
    h = np.clip(_rows_dot(pa, ba) / length2, 0.0, 1.0) if length2 > 0.0 else np.zeros(len(p))
    rel = pa - h[:, None] * ba
    left = safe_normalize(np.array([[-ba[1], ba[0]]]))[0]
    side = ba[0] * pa[:, 1] - ba[1] * pa[:, 0]
    g_side = np.where((side < 0.0)[:, None], -left, left)
    interior = (h > 0.0) & (h < 1.0)
    return _norm(rel), _pick(interior, g_side, _unit(rel, left))


# --------------------------------------------------------------------------------------
# Disks, segments and capsules
# --------------------------------------------------------------------------------------

@primitive("circle", Param("radius", "positive", REQUIRED, "radius, m"))
class Circle(Field):
    """Disk of ``radius`` centred at the origin: f = |p| - r, exact.

    Gradient p / |p|; at the centre the fallback direction (1, 0).
    """

    def __init__(self, radius: float):
        self.radius = float(radius)

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = as_points(points)
        length = np.hypot(p[:, 0], p[:, 1])
        return length - self.radius, safe_normalize(p)

    def distance(self, points: np.ndarray) -> np.ndarray:
        p = as_points(points)
        return np.hypot(p[:, 0], p[:, 1]) - self.radius

    def bounds(self) -> np.ndarray:
        r = self.radius
        return np.array([-r, -r, r, r])


@primitive("segment", Param("a", "vec2", REQUIRED, "first end point [x, y], m"),
           Param("b", "vec2", REQUIRED, "second end point [x, y], m"))
class Segment(Field):
    """Unsigned distance to the segment from ``a`` to ``b``: f >= 0, exact.

    f is 0 on the segment itself (the region f <= 0 has no interior). Gradient
    (p - q) / |p - q| with q the closest point; on the segment (a kink of f) the
    unit left normal of b - a. ``a == b`` is allowed (a point; fallback (1, 0)).
    """

    def __init__(self, a: ArrayLike, b: ArrayLike):
        self.a = _vec(a)
        self.b = _vec(b)

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _segment_distance(as_points(points), self.a, self.b)

    def bounds(self) -> np.ndarray:
        return np.concatenate([np.minimum(self.a, self.b), np.maximum(self.a, self.b)])


@primitive("capsule", Param("a", "vec2", REQUIRED, "centre of the first cap [x, y], m"),
           Param("b", "vec2", REQUIRED, "centre of the second cap [x, y], m"),
           Param("radius", "positive", REQUIRED, "radius of the caps and half width, m"))
class Capsule(Field):
    """Points within ``radius`` of the segment ab: f = dist(p, ab) - radius, exact.

    The gradient is the segment's (see ``segment``); on the axis ab it is the unit
    left normal of b - a. ``a == b`` gives a disk.
    """

    def __init__(self, a: ArrayLike, b: ArrayLike, radius: float):
        self.a = _vec(a)
        self.b = _vec(b)
        self.radius = _check_positive("radius", radius)

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d, g = _segment_distance(as_points(points), self.a, self.b)
        return d - self.radius, g

    def bounds(self) -> np.ndarray:
        r = self.radius
        return np.concatenate([np.minimum(self.a, self.b) - r, np.maximum(self.a, self.b) + r])


@primitive("uneven_capsule",
           Param("bottom_radius", "positive", REQUIRED, "radius of the disk at the origin, m"),
           Param("top_radius", "positive", REQUIRED, "radius of the disk at (0, height), m"),
           Param("height", "positive", REQUIRED, "distance between the two centres, m"))
class UnevenCapsule(Field):
    """Convex hull of a disk of ``bottom_radius`` at the origin and one of
    ``top_radius`` at (0, ``height``) (Quilez's sdUnevenCapsule), exact.

    Requires height > |bottom_radius - top_radius| (else one disk contains the
    other). Gradient: radial from the nearer centre on the caps, the constant
    normal of the tangent line on the sides. On the y axis the right side's normal.
    """

    def __init__(self, bottom_radius: float, top_radius: float, height: float):
        self.r1 = _check_positive("bottom_radius", bottom_radius)
        self.r2 = _check_positive("top_radius", top_radius)
        self.height = _check_positive("height", height)
        gap = abs(self.r1 - self.r2)
        if not self.height > gap:
            raise SpecError("height", f"must be > |bottom_radius - top_radius| = {gap:g} "
                            f"(else one disk contains the other), got {self.height:g}")
        # The right tangent line touches both circles; its outward unit normal is
        # (cos t, sin t) with sin t = (r1 - r2) / h. Along the line, k = p.(-sin t, cos t)
        # runs from 0 at the bottom tangent point to h cos t at the top one.
        self.sin_t = (self.r1 - self.r2) / self.height
        self.cos_t = math.sqrt(1.0 - self.sin_t ** 2)

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, sx = _fold_x(as_points(points))
        s, c, h = self.sin_t, self.cos_t, self.height
        top_centre = np.array([0.0, h])
        k = -s * q[:, 0] + c * q[:, 1]
        bottom, top = k < 0.0, k > c * h
        d_side = c * q[:, 0] + s * q[:, 1] - self.r1
        d = np.where(bottom, _norm(q) - self.r1,
                     np.where(top, _norm(q - top_centre) - self.r2, d_side))
        g = _pick(bottom, _unit(q, _DOWN),
                  _pick(top, _unit(q - top_centre, _UP), np.array([c, s])))
        return d, _unfold(g, sx)

    def bounds(self) -> np.ndarray:
        w = max(self.r1, self.r2)
        return np.array([-w, -self.r1, w, self.height + self.r2])


# --------------------------------------------------------------------------------------
# Sectors, cut disks, arcs, rings and horseshoes
# --------------------------------------------------------------------------------------

@primitive("pie", Param("half_angle", "positive", REQUIRED,
                        "half aperture in (0, pi], radians, measured from +y"),
           Param("radius", "positive", REQUIRED, "radius, m"))
class Pie(Field):
    """Circular sector of ``radius`` with apex at the origin, symmetric about +y,
    spanning ``half_angle`` on each side (Quilez's sdPie), exact.

    ``half_angle = pi`` is the full disk. With x folded to |x| and
    c = (sin a, cos a) the right edge is the segment 0 -> r c:
    f = max(|p| - r, s m), m the distance to that edge, s = +1 beyond it.
    Gradient: radial on the arc, the edge's outward normal (cos a, -sin a) on the
    edges; at the apex that normal (mirrored for x < 0).
    """

    def __init__(self, half_angle: float, radius: float):
        self.half_angle = _check_half_angle("half_angle", half_angle)
        self.radius = _check_positive("radius", radius)
        self.full = self.half_angle >= math.pi
        self.c = np.array([math.sin(self.half_angle), math.cos(self.half_angle)])

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, sx = _fold_x(as_points(points))
        r = self.radius
        d_arc = _norm(q) - r
        g_arc = _unit(q, _UP)
        if self.full:
            return d_arc, _unfold(g_arc, sx)
        # max() is exact: the edge lies in the disk, so beyond it m >= |p| - r; inside
        # the wedge the radial projection r p/|p| is on the arc, so there
        # -min(r - |p|, m) is minus the distance to the nearer of arc and edge.
        c = self.c
        normal = np.array([c[1], -c[0]])
        beyond = _rows_dot(q, normal) > 0.0
        s = np.where(beyond, 1.0, -1.0)
        h = np.clip(_rows_dot(q, c), 0.0, r)
        rel = q - h[:, None] * c
        d_edge = s * _norm(rel)
        interior = (h > 0.0) & (h < r)
        g_edge = _pick(interior, normal, _unit(s[:, None] * rel, normal))
        arc = d_arc >= d_edge
        return np.where(arc, d_arc, d_edge), _unfold(_pick(arc, g_arc, g_edge), sx)

    def bounds(self) -> np.ndarray:
        box = _arc_box(self.radius, self.half_angle)
        box[1] = min(box[1], 0.0)
        return box


@primitive("cut_disk", Param("radius", "positive", REQUIRED, "radius, m"),
           Param("cut_height", "real", REQUIRED,
                 "the disk keeps the part above y = cut_height; -radius < cut_height < radius"))
class CutDisk(Field):
    """Disk of ``radius`` centred at the origin, cut by the line y = ``cut_height``
    (the part above is kept; Quilez's sdCutDisk), exact.

    Boundary: the arc y >= h and the chord from (-w, h) to (w, h),
    w = sqrt(r^2 - h^2). Gradient: radial on the arc, (0, -1) on the chord,
    from the corner near the corners; at a corner the radial direction.
    """

    def __init__(self, radius: float, cut_height: float):
        self.radius = _check_positive("radius", radius)
        self.h = float(cut_height)
        if not -self.radius < self.h < self.radius:
            raise SpecError("cut_height", f"must be in (-radius, radius) = "
                            f"({-self.radius:g}, {self.radius:g}), got {self.h:g}")
        self.half_chord = math.sqrt(self.radius ** 2 - self.h ** 2)

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, sx = _fold_x(as_points(points))
        r, h, w = self.radius, self.h, self.half_chord
        corner = np.array([w, h])
        length = _norm(q)
        s = np.where((length < r) & (q[:, 1] > h), -1.0, 1.0)
        rel_c = q - corner
        d_c = _norm(rel_c)
        g_c = _unit(s[:, None] * rel_c, _DOWN)
        # The radial projection r q/|q| is on the kept arc iff q is on or above the
        # ray from the origin through the corner: h x - w y <= 0; else the corner.
        on_arc = h * q[:, 0] - w * q[:, 1] <= 0.0
        d_arc = np.where(on_arc, np.abs(length - r), d_c)
        g_arc = _pick(on_arc, _unit(q, _UP), g_c)
        on_chord = q[:, 0] < w
        d_chord = np.where(on_chord, np.abs(q[:, 1] - h), d_c)
        g_chord = _pick(on_chord, _DOWN, g_c)
        arc = d_arc <= d_chord
        d = s * np.where(arc, d_arc, d_chord)
        return d, _unfold(_pick(arc, g_arc, g_chord), sx)

    def bounds(self) -> np.ndarray:
        w = self.half_chord if self.h >= 0.0 else self.radius
        return np.array([-w, self.h, w, self.radius])


@primitive("arc", Param("half_angle", "positive", REQUIRED,
                        "half aperture in (0, pi], radians, measured from +y"),
           Param("radius", "positive", REQUIRED, "radius of the centre line, m"),
           Param("thickness", "positive", REQUIRED,
                 "full width of the band, m (the end caps have radius thickness / 2)"))
class Arc(Field):
    """Band of width ``thickness`` around the circular arc of ``radius`` spanning
    ``half_angle`` either side of +y, with round end caps (Quilez's sdArc).

    f = dist(p, arc) - thickness / 2. Exact when thickness / 2 is at most the
    arc's reach: radius if half_angle <= pi / 2 (or = pi, a full ring), else
    radius * sin(half_angle) (the end caps would overlap the band's far side);
    otherwise ``exact`` is False and f is a bound inside (exact outside).
    Gradient: radial on the band, from the end point on the caps; on the centre
    line the outward radial direction, at the centre (0, -1).
    """

    def __init__(self, half_angle: float, radius: float, thickness: float):
        self.half_angle = _check_half_angle("half_angle", half_angle)
        self.radius = _check_positive("radius", radius)
        self.half_width = _check_positive("thickness", thickness) / 2.0
        full = self.half_angle >= math.pi
        self.c = _DOWN.copy() if full else np.array([math.sin(self.half_angle),
                                                     math.cos(self.half_angle)])
        reach = self.radius if full or self.half_angle <= math.pi / 2 else self.radius * self.c[0]
        self.exact = bool(self.half_width <= reach)

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, sx = _fold_x(as_points(points))
        r, c = self.radius, self.c
        length = _norm(q)
        # The radial projection lies on the arc iff q is not beyond the end ray.
        on_arc = c[1] * q[:, 0] - c[0] * q[:, 1] <= 0.0
        rel = q - r * c
        d = np.where(on_arc, np.abs(length - r), _norm(rel))
        outward = np.where(length >= r, 1.0, -1.0)[:, None]
        g = _pick(on_arc, outward * _unit(q, _UP), _unit(rel, c))
        return d - self.half_width, _unfold(g, sx)

    def bounds(self) -> np.ndarray:
        x0, y0, x1, y1 = _arc_box(self.radius, self.half_angle)
        w = self.half_width
        return np.array([x0 - w, y0 - w, x1 + w, y1 + w])


@primitive("ring", Param("half_angle", "positive", REQUIRED,
                         "half aperture in (0, pi], radians, measured from +y"),
           Param("radius", "positive", REQUIRED, "radius of the centre line, m"),
           Param("thickness", "positive", REQUIRED,
                 "full radial width of the band, m; < 2 * radius"))
class Ring(Field):
    """Annular sector: radii radius +- thickness / 2, angles within ``half_angle``
    of +y, cut by flat radial end faces (Quilez's sdRing), exact.

    ``half_angle = pi`` is the full annulus. f = max(annulus, s m) with m the
    distance to the right end face (x folded) and s = +1 beyond it. Gradient:
    radial on the circles, the face's outward normal (cos a, -sin a) on the end
    faces; on the centre line the outward radial direction, at the centre (0, -1).
    """

    def __init__(self, half_angle: float, radius: float, thickness: float):
        self.half_angle = _check_half_angle("half_angle", half_angle)
        self.radius = _check_positive("radius", radius)
        thickness = _check_positive("thickness", thickness)
        if not thickness < 2.0 * self.radius:
            raise SpecError("thickness", f"must be < 2 * radius = {2.0 * self.radius:g}, "
                            f"got {thickness:g}")
        self.half_width = thickness / 2.0
        self.full = self.half_angle >= math.pi
        self.c = np.array([math.sin(self.half_angle), math.cos(self.half_angle)])

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, sx = _fold_x(as_points(points))
        r, w, c = self.radius, self.half_width, self.c
        length = _norm(q)
        d_ring = np.abs(length - r) - w
        g_ring = np.where(length >= r, 1.0, -1.0)[:, None] * _unit(q, _UP)
        if self.full:
            return d_ring, _unfold(g_ring, sx)
        # Frame of the right end face: u along its outward normal (cos a, -sin a),
        # v along it (the direction c); the face is u = 0, r - w <= v <= r + w.
        # As for the pie, max() is exact: the face lies in the annulus, and inside
        # the wedge the radial projections onto both circles are on the sector.
        normal = np.array([c[1], -c[0]])
        u, v = _rows_dot(q, normal), _rows_dot(q, c)
        s = np.where(u > 0.0, 1.0, -1.0)
        rel = np.column_stack([u, v - np.clip(v, r - w, r + w)])
        d_face = s * _norm(rel)
        on_face = (v > r - w) & (v < r + w)
        g_local = _pick(on_face, _RIGHT, _unit(s[:, None] * rel, _RIGHT))
        g_face = g_local[:, :1] * normal + g_local[:, 1:] * c
        ring = d_ring >= d_face
        return np.where(ring, d_ring, d_face), _unfold(_pick(ring, g_ring, g_face), sx)

    def bounds(self) -> np.ndarray:
        a, r, w = self.half_angle, self.radius, self.half_width
        x0, y0, x1, y1 = _arc_box(r + w, a)
        return np.array([x0, min(y0, (r - w) * math.cos(a)), x1, y1])


@primitive("horseshoe",
           Param("half_opening", "positive", REQUIRED,
                 "half aperture of the gap at the top in (0, pi), radians, from +y"),
           Param("radius", "positive", REQUIRED, "radius of the centre line, m"),
           Param("length", "nonneg", REQUIRED, "length of each straight leg, m"),
           Param("thickness", "positive", REQUIRED,
                 "full width of the band, m; < 2 * radius"))
class Horseshoe(Field):
    """A U-shaped band (Quilez's sdHorseshoe): the annular sector of centre radius
    ``radius`` and width ``thickness`` that leaves a gap of ``half_opening``
    either side of +y, continued from its ends by straight legs of ``length``
    along the tangent, with flat tips. Exact.

    With x folded, n = (sin t, cos t) points to the arc's end and d = (-cos t,
    sin t) along the leg; u = p.d, v = p.n. Where u > 0 f is the distance to the
    leg rectangle 0 <= u <= L, |v - r| <= w; elsewhere the annulus distance,
    and inside the band also the distance to the tip face (nearer than the
    band's circles when L < w). Unlike Quilez's version this last term keeps
    short legs exact. The legs must not cross the y axis:
    length <= (radius - thickness / 2) tan(half_opening).
    Gradient: radial on the arc, +-n on the leg sides, d on the tips; on the
    centre line the outward side, at the centre (0, 1).
    """

    def __init__(self, half_opening: float, radius: float, length: float, thickness: float):
        t = _check_half_angle("half_opening", half_opening, allow_pi=False)
        self.radius = _check_positive("radius", radius)
        self.length = float(length)
        if not self.length >= 0.0:
            raise SpecError("length", f"must be >= 0, got {self.length:g}")
        thickness = _check_positive("thickness", thickness)
        if not thickness < 2.0 * self.radius:
            raise SpecError("thickness", f"must be < 2 * radius = {2.0 * self.radius:g}, "
                            f"got {thickness:g}")
        self.half_width = thickness / 2.0
        self.half_opening = t
        self.n = np.array([math.sin(t), math.cos(t)])
        self.d = np.array([-math.cos(t), math.sin(t)])
        # The inner tip corner (r - w) n + L d must stay at x >= 0 so that folding x
        # is exact (the mirrored halves never overlap).
        if (self.radius - self.half_width) * self.n[0] + self.length * self.d[0] < 0.0:
            limit = (self.radius - self.half_width) * math.tan(t)
            raise SpecError("length", f"the legs would cross the y axis: must be <= "
                            f"(radius - thickness / 2) * tan(half_opening) = {limit:g}, "
                            f"got {self.length:g}")

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, sx = _fold_x(as_points(points))
        r, w, L, n, d = self.radius, self.half_width, self.length, self.n, self.d
        u, v = _rows_dot(q, d), _rows_dot(q, n)
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
        g_ann = np.where(length >= r, 1.0, -1.0)[:, None] * _unit(q, _DOWN)
        tip = np.column_stack([u - L, v - np.clip(v, r - w, r + w)])
        d_tip = -_norm(tip)
        g_tip_local = _unit(-tip, _RIGHT)
        g_tip = g_tip_local[:, :1] * d + g_tip_local[:, 1:] * n
        use_tip = (d_ann < 0.0) & (d_tip > d_ann)
        d_arc = np.where(use_tip, d_tip, d_ann)
        g_arc = _pick(use_tip, g_tip, g_ann)
        leg = u > 0.0
        return np.where(leg, d_leg, d_arc), _unfold(_pick(leg, g_leg, g_arc), sx)

    def bounds(self) -> np.ndarray:
        r, w, L, t = self.radius, self.half_width, self.length, self.half_opening
        x_arc = (r + w) * (1.0 if t <= math.pi / 2 else math.sin(t))
        y_top = (r + w if t <= math.pi / 2 else r - w) * math.cos(t)
        tips = np.array([(r - w) * self.n + L * self.d, (r + w) * self.n + L * self.d])
        x = max(x_arc, float(np.max(tips[:, 0])))
        return np.array([-x, -(r + w), x, max(y_top, float(np.max(tips[:, 1])))])


# --------------------------------------------------------------------------------------
# Lens, crescent, egg and heart
# --------------------------------------------------------------------------------------

@primitive("vesica", Param("radius", "positive", REQUIRED, "radius of both disks, m"),
           Param("distance", "nonneg", REQUIRED,
                 "the disk centres are at (+-distance, 0), m; 0 <= distance < radius"))
class Vesica(Field):
    """Lens: intersection of the two disks of ``radius`` centred at
    (+-``distance``, 0) (Quilez's sdVesica), exact.

    Width 2 (radius - distance), height 2 b with b = sqrt(radius^2 - distance^2);
    corners at (0, +-b). Gradient: radial from the opposite disk's centre on the
    arcs, from the corner near the corners; at a corner the normal of the arc
    on the x >= 0 side, (distance, +-b) / radius; at the centre of a circle
    (distance = 0) (1, 0).
    """

    def __init__(self, radius: float, distance: float):
        self.radius = _check_positive("radius", radius)
        self.centre_distance = float(distance)
        if not 0.0 <= self.centre_distance < self.radius:
            raise SpecError("distance", f"must be in [0, radius) = [0, {self.radius:g}), "
                            f"got {self.centre_distance:g}")
        self.half_height = math.sqrt(self.radius ** 2 - self.centre_distance ** 2)

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = as_points(points)
        sx = np.where(p[:, 0] < 0.0, -1.0, 1.0)
        sy = np.where(p[:, 1] < 0.0, -1.0, 1.0)
        q = np.abs(p)
        r, dc, b = self.radius, self.centre_distance, self.half_height
        # In the quadrant x, y >= 0 the boundary is the arc of the circle centred
        # at (-dc, 0) from (r - dc, 0) to the corner (0, b); the radial projection
        # is on it iff q is not above the ray from (-dc, 0) through the corner.
        rel = q + np.array([dc, 0.0])
        on_arc = rel[:, 0] * b - rel[:, 1] * dc >= 0.0
        rel_c = q - np.array([0.0, b])
        d = np.where(on_arc, _norm(rel) - r, _norm(rel_c))
        g = _pick(on_arc, _unit(rel, _RIGHT), _unit(rel_c, _UP))
        return d, _unfold(g, sx, sy)

    def bounds(self) -> np.ndarray:
        w, b = self.radius - self.centre_distance, self.half_height
        return np.array([-w, -b, w, b])


@primitive("moon", Param("radius", "positive", REQUIRED, "radius of the disk at the origin, m"),
           Param("bite_radius", "positive", REQUIRED, "radius of the disk cut away, m"),
           Param("distance", "positive", REQUIRED,
                 "the cut disk is centred at (distance, 0), m"))
class Moon(Field):
    """Crescent: the disk of ``radius`` at the origin minus the disk of
    ``bite_radius`` at (``distance``, 0) (Quilez's sdMoon), exact.

    The circles must cross: |radius - bite_radius| < distance < radius +
    bite_radius. Boundary: the outer arc, the bitten arc and the two horns
    K = (a, +-b). Gradient: radial on the outer arc, towards the bite's centre on
    the bitten arc, from the horn near the horns; at a horn the normal of one
    of its two arcs.
    """

    def __init__(self, radius: float, bite_radius: float, distance: float):
        ra = self.radius = _check_positive("radius", radius)
        rb = self.bite_radius = _check_positive("bite_radius", bite_radius)
        dc = self.centre_distance = _check_positive("distance", distance)
        if not abs(ra - rb) < dc < ra + rb:
            raise SpecError("distance", f"the circles must cross: need |radius - bite_radius|"
                            f" = {abs(ra - rb):g} < distance < radius + bite_radius = "
                            f"{ra + rb:g}, got {dc:g}")
        # Horn: the crossing point of the circles, a = (ra^2 - rb^2 + dc^2) / (2 dc).
        a = (ra * ra - rb * rb + dc * dc) / (2.0 * dc)
        self.horn = np.array([a, math.sqrt(max(ra * ra - a * a, 0.0))])

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = as_points(points)
        sy = np.where(p[:, 1] < 0.0, -1.0, 1.0)
        q = np.column_stack([p[:, 0], np.abs(p[:, 1])])
        ra, rb, dc = self.radius, self.bite_radius, self.centre_distance
        ka, kb = self.horn
        length = _norm(q)
        v = q - np.array([dc, 0.0])
        lv = _norm(v)
        s = np.where((length < ra) & (lv > rb), -1.0, 1.0)
        rel_k = q - self.horn
        d_k = _norm(rel_k)
        g_k = _unit(s[:, None] * rel_k, self.horn / ra)
        # With y folded to |y| the outer arc runs from the horn to (-ra, 0) and the
        # bitten arc from the horn to (dc - rb, 0); a radial projection lands on an
        # arc iff the direction is past the horn's: cross(horn direction, q) >= 0.
        on_a = ka * q[:, 1] - kb * q[:, 0] >= 0.0
        on_b = (ka - dc) * v[:, 1] - kb * v[:, 0] >= 0.0
        d_a = np.where(on_a, np.abs(length - ra), d_k)
        d_b = np.where(on_b, np.abs(lv - rb), d_k)
        g_a = _pick(on_a, _unit(q, _LEFT), g_k)
        g_b = _pick(on_b, _unit(-v, _RIGHT), g_k)
        outer = d_a <= d_b
        d = s * np.where(outer, d_a, d_b)
        return d, _unfold(_pick(outer, g_a, g_b), 1.0, sy)

    def bounds(self) -> np.ndarray:
        # The rightmost boundary point is the horn (both arcs have their largest x
        # there); the outer arc reaches y = +-radius only if it passes over the top.
        ra, (ka, kb) = self.radius, self.horn
        y = ra if ka >= 0.0 else kb
        return np.array([-ra, -y, ka, y])


@primitive("egg", Param("radius", "positive", REQUIRED, "radius of the bottom, m"),
           Param("top_radius", "nonneg", REQUIRED,
                 "radius of the rounded top, m; 0 <= top_radius < radius"))
class Egg(Field):
    """Egg (Quilez's sdEgg): a convex core rounded by ``top_radius``, exact.

    With r = radius - top_radius the core is the lower half disk of radius r and,
    above y = 0, the arcs of radius 2r centred at (-+r, 0) meeting at the apex
    (0, sqrt(3) r). Total height radius + sqrt(3) r + top_radius, width 2 radius.
    Rounding a convex set keeps it exact. Gradient: radial from the origin
    below, from the far side's centre on the sides, from the apex above it; at
    the apex (0, 1).
    """

    def __init__(self, radius: float, top_radius: float):
        self.radius = _check_positive("radius", radius)
        self.top_radius = float(top_radius)
        if not 0.0 <= self.top_radius < self.radius:
            raise SpecError("top_radius", f"must be in [0, radius) = [0, {self.radius:g}), "
                            f"got {self.top_radius:g}")
        self.core = self.radius - self.top_radius

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, sx = _fold_x(as_points(points))
        r = self.core
        apex = np.array([0.0, math.sqrt(3.0) * r])
        side_centre = np.array([-r, 0.0])
        lower = q[:, 1] < 0.0
        # Above the line from (-r, 0) through the apex the nearest core point is the apex.
        above = math.sqrt(3.0) * (q[:, 0] + r) <= q[:, 1]
        d = np.where(lower, _norm(q) - r,
                     np.where(above, _norm(q - apex), _norm(q - side_centre) - 2.0 * r))
        g = _pick(lower, _unit(q, _DOWN),
                  _pick(above, _unit(q - apex, _UP), _unit(q - side_centre, _RIGHT)))
        return d - self.top_radius, _unfold(g, sx)

    def bounds(self) -> np.ndarray:
        ra = self.radius
        return np.array([-ra, -ra, ra, math.sqrt(3.0) * self.core + self.top_radius])


@primitive("heart", Param("scale", "positive", REQUIRED,
                          "size factor, m: width 1.207 * scale, height 1.104 * scale"))
class Heart(Field):
    """Quilez's sdHeart scaled by ``scale``: tip at the origin, exact.

    In unit coordinates (x folded) the boundary is the segment from the tip to
    (0.5, 0.5), the half circle of radius sqrt(2)/4 centred at (0.25, 0.75) on
    the far side of the line x + y = 1, and the cusp at (0, 1) where the lobes
    meet. Gradient: (1, -1)/sqrt(2) on the segment (mirrored for x < 0), radial
    on the lobes, from the cusp or the tip near them; at the tip (1, -1)/sqrt(2),
    at the cusp (0, 1).
    """

    _LOBE_CENTRE = np.array([0.25, 0.75])
    _LOBE_RADIUS = math.sqrt(2.0) / 4.0
    _CUSP = np.array([0.0, 1.0])
    _EDGE_NORMAL = np.array([1.0, -1.0]) / math.sqrt(2.0)

    def __init__(self, scale: float):
        self.scale = _check_positive("scale", scale)

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, sx = _fold_x(as_points(points) / self.scale)
        lobe = q[:, 0] + q[:, 1] > 1.0
        rel_l = q - self._LOBE_CENTRE
        d_lobe = _norm(rel_l) - self._LOBE_RADIUS
        g_lobe = _unit(rel_l, _UP)
        # Below the line x + y = 1: the segment from the tip along (1, 1) (its
        # projection t stays <= 0.5 there) or the cusp; inside iff x < y.
        s = np.where(q[:, 0] > q[:, 1], 1.0, -1.0)
        t = np.maximum(q[:, 0] + q[:, 1], 0.0) / 2.0
        rel_s = q - t[:, None]
        d_seg = _norm(rel_s)
        g_seg = _pick(t > 0.0, self._EDGE_NORMAL, _unit(s[:, None] * rel_s, self._EDGE_NORMAL))
        rel_k = q - self._CUSP
        d_cusp = _norm(rel_k)
        g_cusp = _unit(s[:, None] * rel_k, _UP)
        seg = d_seg <= d_cusp
        d_low = s * np.where(seg, d_seg, d_cusp)
        g_low = _pick(seg, g_seg, g_cusp)
        d = np.where(lobe, d_lobe, d_low) * self.scale
        return d, _unfold(_pick(lobe, g_lobe, g_low), sx)

    def bounds(self) -> np.ndarray:
        x = (self._LOBE_CENTRE[0] + self._LOBE_RADIUS) * self.scale
        return np.array([-x, 0.0, x, (self._LOBE_CENTRE[1] + self._LOBE_RADIUS) * self.scale])


# --------------------------------------------------------------------------------------
# Ellipse and quadratic Bezier: closest points from fixed-count root finders
# --------------------------------------------------------------------------------------

@primitive("ellipse", Param("size", "size2", REQUIRED, "full width and height [w, h], m"))
class Ellipse(Field):
    """Axis-aligned ellipse of full ``size`` [w, h] centred at the origin, exact.

    The closest point is found to round-off by a fixed-count solver (below);
    the gradient is the outward normal there, (x/a^2, y/b^2) normalized, also
    for inside points. At the centre it is (0, +-1) towards the nearer vertex
    ((1, 0) for a circle).
    """

    # Closest point (Eberly 2013): fold to x, y >= 0 and orient a >= b. The closest
    # point is q = (a^2 x / (u + e), b^2 y / u) with e = a^2 - b^2 and u > 0 the
    # unique root of F(u) = (A / (u + e))^2 + (B / u)^2 - 1, A = a x, B = b y > 0;
    # F decreases from +inf. Bracket: lo = max(B, A - e) (each term alone is >= 1
    # there, so F(lo) >= 0), hi = |(A, B)| (F(hi) <= 0). The root can be far below
    # hi (points near the major axis inside, u* ~ B), so _BISECTIONS geometric-mean
    # bisections shrink the ratio hi / lo to < 2 even from 1e-300. Then Newton on
    # psi(u) = 1 / |(A / (u + e), B / u)| - 1, which is increasing and concave (the
    # secular equation of Moré & Sorensen 1983) and nearly linear, so from the left
    # end it rises monotonically to the root without overshoot and converges fast.
    # Measured on 6e5 points per shape (aspect 1 to 1000, y down to 1e-300, points
    # at the evolute cusp): the distance reaches round-off after 4 Newton steps;
    # _NEWTON = 6 leaves a margin. On the major axis (B = 0) the closed form:
    # q = (a^2 x / e, b sqrt(1 - (a x / e)^2)) if A < e, else the vertex (a, 0).
    _BISECTIONS = 12
    _NEWTON = 6

    def __init__(self, size: ArrayLike):
        w, h = _vec(size)
        if not (w > 0.0 and h > 0.0):
            raise SpecError("size", f"must be two positive numbers, got {[w, h]}")
        self.half = np.array([w, h]) / 2.0
        self.swap = h > w
        self.a, self.b = (self.half[1], self.half[0]) if self.swap else (self.half[0], self.half[1])

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = as_points(points)
        if self.swap:
            p = p[:, ::-1]
        sx = np.where(p[:, 0] < 0.0, -1.0, 1.0)
        sy = np.where(p[:, 1] < 0.0, -1.0, 1.0)
        x, y = np.abs(p[:, 0]), np.abs(p[:, 1])
        a, b = self.a, self.b
        e = a * a - b * b
        big_a, big_b = a * x, b * y
        general = big_b > 0.0
        # Dummy bracket [1, 1] on the axis rows keeps every division finite.
        lo = np.where(general, np.maximum(big_b, big_a - e), 1.0)
        hi = np.where(general, np.hypot(big_a, big_b), 1.0)
        big_b = np.where(general, big_b, 1.0)
        for _ in range(self._BISECTIONS):
            mid = np.sqrt(lo) * np.sqrt(hi)
            f = (big_a / (mid + e)) ** 2 + (big_b / mid) ** 2 - 1.0
            lo, hi = np.where(f >= 0.0, mid, lo), np.where(f >= 0.0, hi, mid)
        u = lo
        for _ in range(self._NEWTON):
            fx, fy = big_a / (u + e), big_b / u
            n = np.hypot(fx, fy)
            slope = fx * fx / (u + e) + fy * fy / u
            u = u + n * n * (n - 1.0) / slope
        xc = np.where(general, a * big_a / (u + e), 0.0)
        yc = np.where(general, b * big_b / u, 0.0)
        interior = big_a < e
        x_axis = np.where(interior, a * big_a / (e if e > 0.0 else 1.0), a)
        y_axis = np.where(interior, b * np.sqrt(np.maximum(1.0 - (x_axis / a) ** 2, 0.0)), 0.0)
        xc, yc = np.where(general, xc, x_axis), np.where(general, yc, y_axis)
        dist = np.hypot(x - xc, y - yc)
        inside = (x / a) ** 2 + (y / b) ** 2 < 1.0
        g = _unit(np.column_stack([xc / (a * a), yc / (b * b)]), _RIGHT)
        g = _unfold(g, sx, sy)
        if self.swap:
            g = g[:, ::-1]
        return np.where(inside, -dist, dist), g

    def bounds(self) -> np.ndarray:
        hx, hy = self.half
        return np.array([-hx, -hy, hx, hy])


def _cubic_roots(k3: np.ndarray, k2: np.ndarray, k1: np.ndarray, k0: np.ndarray
                 ) -> np.ndarray:
    """Approximate real roots (N, 3) of k3 t^3 + k2 t^2 + k1 t + k0 with k3 > 0.

    Depressed cubic s^3 + P s + Q (t = s - k2 / (3 k3)). One real root when
    h = (Q/2)^2 + (P/3)^3 >= 0 (Cardano, with the cube root taken on the side
    that avoids cancellation; repeated three times), else three (Viète's
    trigonometric form). Callers polish the roots and replace non-finite values.
    """
    a2, a1, a0 = k2 / k3, k1 / k3, k0 / k3
    shift = a2 / 3.0
    big_p = a1 - a2 * shift
    big_q = (2.0 * a2 * a2 / 27.0 - a1 / 3.0) * a2 + a0
    h = (big_q / 2.0) ** 2 + (big_p / 3.0) ** 3
    one = h >= 0.0
    w = np.cbrt(-big_q / 2.0 - np.copysign(np.sqrt(np.where(one, h, 0.0)), big_q))
    single = np.where(w != 0.0, w - big_p / (3.0 * np.where(w != 0.0, w, 1.0)), 0.0)
    m = np.sqrt(np.maximum(-big_p / 3.0, 0.0))
    cos3 = np.clip(-big_q / 2.0 / np.where(one, 1.0, m ** 3), -1.0, 1.0)
    phi = np.arccos(cos3) / 3.0
    three = [2.0 * m * np.cos(phi - 2.0 * math.pi * k / 3.0) for k in range(3)]
    return np.column_stack([np.where(one, single, r) for r in three]) - shift[:, None]


@primitive("quadratic_bezier", Param("a", "vec2", REQUIRED, "start point [x, y], m"),
           Param("b", "vec2", REQUIRED, "control point [x, y], m"),
           Param("c", "vec2", REQUIRED, "end point [x, y], m"),
           Param("radius", "nonneg", 0.0,
                 "half width of the stroke, m: f = distance to the curve - radius"))
class QuadraticBezier(Field):
    """The quadratic Bezier curve q(t) = (1-t)^2 a + 2 t (1-t) b + t^2 c, t in [0, 1],
    stroked with ``radius``: f = min_t |p - q(t)| - radius (Quilez's sdBezier).

    With ``radius = 0`` f is the unsigned distance to the curve (>= 0, exact).
    With radius > 0 f is exact outside; inside it is exact when radius is at most
    the curve's reach, which for a parabola arc (turning < pi) is its smallest
    radius of curvature 2 |A + t* B|^3 / |A x B| (A = b - a, B = a - 2b + c, t*
    minimizing |q'|); otherwise ``exact`` is False (a bound inside).
    Gradient: the curve's normal on p's side at the closest point (the left
    normal of q' on the curve itself), (p - q) / |p - q| at an end.
    """

    # The closest parameter is a root of (q(t) - p).q'(t) / 2 = |B|^2 t^3 +
    # 3 (A.B) t^2 + (2|A|^2 + (a - p).B) t + (a - p).A, or an end. Candidates:
    # the cubic's real roots (Cardano), the root of its linear part (accurate for
    # nearly straight curves, where Cardano's 1/|B|^2 scaling loses everything),
    # each polished by _POLISH Newton steps kept only when they reduce |g|, and
    # the ends t = 0, 1. The nearest candidate wins: distance errors are second
    # order in the parameter error at an interior minimum.
    _POLISH = 3

    def __init__(self, a: ArrayLike, b: ArrayLike, c: ArrayLike, radius: float = 0.0):
        self.a, self.b, self.c = _vec(a), _vec(b), _vec(c)
        self.radius = float(radius)
        if not self.radius >= 0.0:
            raise SpecError("radius", f"must be >= 0, got {self.radius:g}")
        self.A = self.b - self.a
        self.B = self.a - 2.0 * self.b + self.c
        AA, AB, BB = self.A @ self.A, self.A @ self.B, self.B @ self.B
        # Cardano is used only when the cubic term is not negligible.
        self.cubic = BB > 1e-16 * (AA + BB)
        self.cross = cross = abs(self.A[0] * self.B[1] - self.A[1] * self.B[0])
        if cross > 0.0:
            t_min = min(max(-AB / BB, 0.0), 1.0)
            self.min_curvature_radius = 2.0 * float(np.linalg.norm(self.A + t_min * self.B)) ** 3 / cross
        else:
            self.min_curvature_radius = math.inf
        self.exact = bool(self.radius <= self.min_curvature_radius)

    def _curve(self, t: np.ndarray) -> np.ndarray:
        return self.a + 2.0 * t[..., None] * self.A + (t * t)[..., None] * self.B

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = as_points(points)
        n = len(p)
        A, B = self.A, self.B
        ap = self.a - p
        k3 = np.full(n, B @ B)
        k2 = np.full(n, 3.0 * (A @ B))
        k1 = 2.0 * (A @ A) + _rows_dot(ap, B)
        k0 = _rows_dot(ap, A)
        lin = np.where(k1 != 0.0, -k0 / np.where(k1 != 0.0, k1, 1.0), 0.0)[:, None]
        if self.cubic:
            with np.errstate(over="ignore", invalid="ignore"):
                seeds = np.concatenate([_cubic_roots(k3, k2, k1, k0), lin], axis=1)
        else:
            seeds = lin
        t = np.clip(np.where(np.isfinite(seeds), seeds, 0.5), 0.0, 1.0)
        k3, k2, k1, k0 = k3[:, None], k2[:, None], k1[:, None], k0[:, None]
        g = ((k3 * t + k2) * t + k1) * t + k0
        for _ in range(self._POLISH):
            dg = (3.0 * k3 * t + 2.0 * k2) * t + k1
            step = np.where(dg != 0.0, g / np.where(dg != 0.0, dg, 1.0), 0.0)
            t_new = np.clip(t - step, 0.0, 1.0)
            g_new = ((k3 * t_new + k2) * t_new + k1) * t_new + k0
            better = np.abs(g_new) < np.abs(g)
            t, g = np.where(better, t_new, t), np.where(better, g_new, g)
        t = np.concatenate([t, np.zeros((n, 1)), np.ones((n, 1))], axis=1)
        dist = np.linalg.norm(self._curve(t) - p[:, None, :], axis=2)
        best = np.argmin(dist, axis=1)
        rows = np.arange(n)
        t, dist = t[rows, best], dist[rows, best]
        # Gradient: at an interior t it is the curve's normal on p's side; an error e
        # in t turns the normal by e |q'| / rho but the direction p - q only by
        # e |q'| / |p - q|, so the normal is used within the local radius of
        # curvature rho(t) = 2 |A + t B|^3 / |A x B| (always on the curve itself)
        # and p - q beyond it (near a sharp turn).
        rel = p - self._curve(t)
        tangent = A + t[:, None] * B
        left = np.column_stack([-tangent[:, 1], tangent[:, 0]])
        normal = _unit(left, _unit(rel, _RIGHT))
        side = np.where(_rows_dot(rel, left) < 0.0, -1.0, 1.0)
        near = dist * self.cross < 2.0 * _norm(tangent) ** 3
        interior = (t > 0.0) & (t < 1.0) & near
        g = _pick(interior, side[:, None] * normal, _unit(rel, normal))
        return dist - self.radius, g

    def bounds(self) -> np.ndarray:
        # Extremes of each coordinate: the ends and the stationary t = -A_i / B_i.
        t = [0.0, 1.0] + [-self.A[i] / self.B[i] for i in range(2)
                          if self.B[i] != 0.0 and 0.0 < -self.A[i] / self.B[i] < 1.0]
        q = self._curve(np.array(t))
        r = self.radius
        return np.concatenate([q.min(axis=0) - r, q.max(axis=0) + r])
