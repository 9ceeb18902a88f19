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
quantity that can vanish; the iterative solvers (ellipse, Bezier: ``conics``, which
shares the helpers below) run a fixed number of steps.

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
from .base import REQUIRED, Field, Param, primitive

_DOWN = np.array([0.0, -1.0])


# --------------------------------------------------------------------------------------
# Small vectorized helpers. Points are (N, 2); "fallback" is a (2,) or (N, 2) unit vector.
# --------------------------------------------------------------------------------------


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

    def bounds(self) -> np.ndarray:
        r, w, L, t = self.radius, self.half_width, self.length, self.half_opening
        x_arc = (r + w) * (1.0 if t <= math.pi / 2 else math.sin(t))
        y_top = (r + w if t <= math.pi / 2 else r - w) * math.cos(t)
        tips = np.array([(r - w) * self.n + L * self.d, (r + w) * self.n + L * self.d])
        x = max(x_arc, float(np.max(tips[:, 0])))
        return np.array([-x, -(r + w), x, max(y_top, float(np.max(tips[:, 1])))])
