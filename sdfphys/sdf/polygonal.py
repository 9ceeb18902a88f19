"""Primitives with straight edges (Quilez, "2D distance functions"), and the two
whose corners are arcs (rounded_box).

Each primitive is centred at its local origin as in Quilez's list, except the
isosceles triangle (centred on its bounding box) and those placed by their own
coordinates (oriented_box, triangle, polygon, half_plane). Gradients are analytic
(his ``sdg*`` forms where published, else derived from the closest-point
branch); see ``base.py`` for the conventions. Sizes given as ``size`` are full
widths and heights; Quilez's half-extents are ``size / 2``. Every primitive
here is exact except ``cross`` with a non-zero ``rounding`` (a bound).

Primitives here: box, rounded_box, oriented_box, rhombus, trapezoid, parallelogram,
equilateral_triangle, isosceles_triangle, triangle, polygon, half_plane; the folded
ones (pentagon, hexagon, octagon, hexagram, star, cross, rounded_cross) are in
``folded``. Their one implementation is the compiled kernels
(``primitive_kernels``); the classes hold the parameters, validation and bounds.

How the gradients are obtained (one derivation for all of them). For an exact
field f(p) = s |p - c(p)|, with c(p) the closest boundary point and s = -1
inside, +1 outside, the gradient is s (p - c) / |p - c|: the derivative of c
drops out because p - c is normal to the boundary at c. Where c lies inside a
straight edge this is that edge's outward normal, which is used as is (no
division, no round-off); where c is a vertex it is s (p - c) / |p - c|; and
where |p - c| is below ``_DEGENERATE`` times the primitive's size (a point on
the boundary, or a vertex) it is the nearest edge's outward normal, a valid
subgradient. Folded primitives (Quilez's abs / reflect / polar reductions)
evaluate this in the folded frame and map the gradient back through the folds
in reverse order: a reflection maps gradients by itself, abs() by the sign of
the coordinate (sign(0) = +1, so folds are deterministic on mirror lines).
Ties between equally near edges (medial axes, centres) go to the first edge in
a fixed order, so degenerate points get a deterministic unit vector.

References: Inigo Quilez, https://iquilezles.org/articles/distfunctions2d/ and
https://iquilezles.org/articles/distgradfunctions2d/ (sdgBox, sdgSegment).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ..errors import SpecError
from ..vec2 import rows_dot
from .base import REQUIRED, Field, Param, primitive

#: Below this many times a primitive's size, a closest-point offset counts as zero
#: and the gradient is the outward normal of the nearest edge.
_DEGENERATE = 1e-12


# --------------------------------------------------------------------------------------
# Shared pieces: folds, nearest of a few segments, signed value and gradient.
# --------------------------------------------------------------------------------------


class _Segment(NamedTuple):
    """A boundary edge from ``a`` to ``b`` with the unit ``normal`` pointing out of the shape."""

    a: np.ndarray
    b: np.ndarray
    normal: np.ndarray


def _segment(a: Any, b: Any, normal: Any) -> _Segment:
    n = np.asarray(normal, dtype=np.float64)
    return _Segment(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64),
                    n / math.hypot(n[0], n[1]))


def _edges(vertices: np.ndarray) -> list[_Segment]:
    """The edges of a counter-clockwise polygon (M, 2); outward normal (e_y, -e_x)/|e|."""
    b = np.roll(vertices, -1, axis=0)
    return [_segment(vertices[i], b[i], (b[i, 1] - vertices[i, 1], vertices[i, 0] - b[i, 0]))
            for i in range(len(vertices))]


def _aabb(vertices: np.ndarray) -> np.ndarray:
    return np.concatenate([vertices.min(axis=0), vertices.max(axis=0)])


# --------------------------------------------------------------------------------------
# Boxes
# --------------------------------------------------------------------------------------

@primitive("box", Param("size", "size2", REQUIRED, "full width and height [w, h], m"))
class Box(Field):
    """Axis-aligned box of full ``size`` [w, h] (m) centred at the origin, exact.

    Quilez's sdgBox: with q = |p| - b (b the half-extents), outside the
    gradient is sign(p) * max(q, 0) / |max(q, 0)|, inside it is the axis of
    the nearest face (x wins a tie, so the medial axis is deterministic).
    """

    def __init__(self, size: Any):
        self.half = np.array(size, dtype=np.float64) / 2.0

    def bounds(self):
        hx, hy = self.half
        return np.array([-hx, -hy, hx, hy])


@primitive("rounded_box",
           Param("size", "size2", REQUIRED, "full width and height [w, h], m"),
           Param("radii", "radii4", REQUIRED,
                 "corner radii, m: one number, or [top-right, top-left, bottom-left, "
                 "bottom-right]; each <= half the smaller side"))
class RoundedBox(Field):
    """Box of full ``size`` [w, h] (m) with rounded corners, centred at the origin, exact.

    ``radii``: one radius for all corners, or four in the order of the quadrants,
    counter-clockwise from +x+y: [top-right (x >= 0, y >= 0), top-left (x < 0,
    y >= 0), bottom-left (x < 0, y < 0), bottom-right (x >= 0, y < 0)]. Each must
    be between 0 and half the smaller side (min(w, h) / 2; equal to it makes that
    end a half disk).
    """

    # Quilez's sdRoundedBox: pick the radius r of the point's quadrant, then
    # f = sdBox(p, b - r) - r, a box shrunk by r and grown back by r. It is exact
    # with different radii per corner: outside, the closest point of a point in a
    # closed quadrant lies in that quadrant (the outward normals of the other
    # corners' arcs point into other quadrants); inside, for an outward direction n
    # in another quadrant, the support value h(n) - n.p is at least min(b_x + p_x,
    # b_y + p_y, b - p) >= the distance to this quadrant's faces (since
    # cos + sin >= 1 on [0, pi/2]). The gradient is sdgBox's for the shrunk box.

    def __init__(self, size: Any, radii: Any):
        self.half = np.array(size, dtype=np.float64) / 2.0
        self.radii = np.broadcast_to(np.asarray(radii, dtype=np.float64), (4,)).copy()
        limit = float(self.half.min())
        for i, r in enumerate(self.radii):
            if not 0.0 <= r <= limit:
                path = "radii" if np.all(self.radii == r) else f"radii[{i}]"
                raise SpecError(path, f"must be between 0 and {limit:g} (half the smaller "
                                      f"side), got {r:g}")

    def bounds(self):
        hx, hy = self.half
        return np.array([-hx, -hy, hx, hy])


@primitive("oriented_box",
           Param("a", "vec2", REQUIRED, "one end of the centre line [x, y], m"),
           Param("b", "vec2", REQUIRED, "the other end of the centre line [x, y], m"),
           Param("thickness", "positive", REQUIRED, "full width across the centre line, m"))
class OrientedBox(Field):
    """Rectangle whose centre line runs from ``a`` to ``b`` (m), ``thickness`` wide, exact.

    The end faces pass through ``a`` and ``b`` (no caps: a box, not a capsule).
    Quilez's sdOrientedBox: rotate p - (a + b)/2 into the frame (u, u_perp) of the
    centre line, u = (b - a)/|b - a|, evaluate sdgBox with half-extents
    (|b - a|/2, thickness/2), and rotate the gradient back.
    """

    def __init__(self, a: Any, b: Any, thickness: float):
        a = np.array(a, dtype=np.float64)
        b = np.array(b, dtype=np.float64)
        length = math.hypot(*(b - a))
        if not length > 0.0:
            raise SpecError("b", f"must differ from a = {a.tolist()} (zero length)")
        self.centre = (a + b) / 2.0
        self.axis = (b - a) / length
        self.half = np.array([length / 2.0, float(thickness) / 2.0])

    def bounds(self):
        ux, uy = np.abs(self.axis)
        hl, ht = self.half
        ext = np.array([hl * ux + ht * uy, hl * uy + ht * ux])
        return np.concatenate([self.centre - ext, self.centre + ext])


# --------------------------------------------------------------------------------------
# Quadrilaterals and triangles
# --------------------------------------------------------------------------------------

@primitive("rhombus", Param("size", "size2", REQUIRED, "full width and height [w, h], m"))
class Rhombus(Field):
    """Rhombus with vertices (+-w/2, 0) and (0, +-h/2), ``size`` = [w, h] (m), exact.

    Quilez's sdRhombus folded by |p| onto one edge, from (w/2, 0) to (0, h/2);
    inside where x h/2 + y w/2 < w h / 4 (folded). Gradient: the closest-point
    branch (module docstring), unfolded by sign(p).
    """

    def __init__(self, size: Any):
        self.half = np.array(size, dtype=np.float64) / 2.0
        bx, by = self.half
        self._edge = [_segment((bx, 0.0), (0.0, by), (by, bx))]
        self._eps = _DEGENERATE * max(bx, by)

    def bounds(self):
        hx, hy = self.half
        return np.array([-hx, -hy, hx, hy])


@primitive("trapezoid",
           Param("bottom_width", "nonneg", REQUIRED, "full width of the bottom edge (y = -h/2), m"),
           Param("top_width", "nonneg", REQUIRED, "full width of the top edge (y = +h/2), m"),
           Param("height", "positive", REQUIRED, "full height h, m"))
class Trapezoid(Field):
    """Isosceles trapezoid centred at the origin, exact.

    ``bottom_width`` spans y = -height/2 and ``top_width`` spans y = +height/2
    (m); either may be 0 (a triangle), not both. Quilez's sdTrapezoid(p, r1, r2,
    he) with r1 = bottom_width/2, r2 = top_width/2, he = height/2: folded by |x|
    onto the half bottom edge, the half top edge and the slanted side from
    (r1, -he) to (r2, he); inside where |y| < he and left of the side.
    """

    def __init__(self, bottom_width: float, top_width: float, height: float):
        r1, r2, he = bottom_width / 2.0, top_width / 2.0, height / 2.0
        if r1 == 0.0 and r2 == 0.0:
            raise SpecError("top_width", "bottom_width and top_width cannot both be 0")
        self.r1, self.r2, self.he = r1, r2, he
        self._side = _segment((r1, -he), (r2, he), (2.0 * he, r1 - r2))
        self._edges = [s for s, w in ((_segment((0.0, -he), (r1, -he), (0.0, -1.0)), r1),
                                      (_segment((0.0, he), (r2, he), (0.0, 1.0)), r2)) if w > 0.0]
        self._edges.append(self._side)
        self._eps = _DEGENERATE * max(r1, r2, he)

    def bounds(self):
        r = max(self.r1, self.r2)
        return np.array([-r, -self.he, r, self.he])


class _ConvexPolygon(Field):
    """A convex polygon given by counter-clockwise vertices: the nearest of its
    edges, inside where every edge's line has the point on its inner side."""

    def _set_vertices(self, vertices: np.ndarray) -> None:
        self.vertices = vertices
        self._edges = _edges(vertices)
        self._eps = _DEGENERATE * float(np.ptp(vertices, axis=0).max())

    def bounds(self):
        return _aabb(self.vertices)


@primitive("parallelogram",
           Param("width", "positive", REQUIRED, "full width of the top and bottom edges, m"),
           Param("height", "positive", REQUIRED, "full height h, m"),
           Param("skew", "real", 0.0, "x offset of the top edge from the bottom edge, m"))
class Parallelogram(_ConvexPolygon):
    """Parallelogram with horizontal top and bottom edges, centred at the origin, exact.

    Vertices (-w/2 - k, -h/2), (w/2 - k, -h/2), (w/2 + k, h/2), (-w/2 + k, h/2)
    with k = skew/2: the top edge (y = h/2) is ``skew`` metres to the right of
    the bottom edge (Quilez's sdParallelogram(p, wi, he, sk) has wi = width/2,
    he = height/2, sk = skew/2). Distance: nearest of the four edges; gradient
    from the closest-point branch (module docstring).
    """

    def __init__(self, width: float, height: float, skew: float = 0.0):
        w, h, k = width / 2.0, height / 2.0, skew / 2.0
        self._set_vertices(np.array([[-w - k, -h], [w - k, -h], [w + k, h], [-w + k, h]]))


class _SymmetricTriangle(Field):
    """Triangle symmetric about the y axis: base from (-hw, y0) to (hw, y0), apex (0, y1).

    Folded by |x| onto the half base and the right side (as Quilez's
    sdTriangleIsosceles); inside where y > y0 and left of the right side.
    """

    def _set_shape(self, half_width: float, y_base: float, y_apex: float) -> None:
        self.half_width, self.y_base, self.y_apex = half_width, y_base, y_apex
        self._side = _segment((half_width, y_base), (0.0, y_apex),
                              (y_apex - y_base, half_width))
        self._edges = [_segment((0.0, y_base), (half_width, y_base), (0.0, -1.0)), self._side]
        self._eps = _DEGENERATE * max(half_width, y_apex - y_base)

    def bounds(self):
        return np.array([-self.half_width, self.y_base, self.half_width, self.y_apex])


@primitive("equilateral_triangle",
           Param("side", "positive", REQUIRED, "side length, m"))
class EquilateralTriangle(_SymmetricTriangle):
    """Equilateral triangle of side length ``side`` (m), centroid at the origin, exact.

    One vertex points up at (0, side/sqrt(3)); the base is horizontal at
    y = -side/(2 sqrt(3)). Quilez's sdEquilateralTriangle(p, r) has r = side/2.
    """

    def __init__(self, side: float):
        self.side = float(side)
        inradius = self.side / (2.0 * math.sqrt(3.0))
        self._set_shape(self.side / 2.0, -inradius, 2.0 * inradius)


@primitive("isosceles_triangle",
           Param("width", "positive", REQUIRED, "full width of the base, m"),
           Param("height", "positive", REQUIRED, "height from base to apex, m"))
class IsoscelesTriangle(_SymmetricTriangle):
    """Isosceles triangle, base ``width`` and ``height`` (m), centred on its bounding box, exact.

    Base from (-width/2, -height/2) to (width/2, -height/2), apex at
    (0, height/2). (Quilez's sdTriangleIsosceles puts the apex at the origin.)
    """

    def __init__(self, width: float, height: float):
        self._set_shape(width / 2.0, -height / 2.0, height / 2.0)


@primitive("triangle",
           Param("points", "polygon", REQUIRED,
                 "the three vertices [[x, y], ...], m, either winding"))
class Triangle(_ConvexPolygon):
    """Triangle with the three vertices ``points`` (m) in either winding, exact.

    A zero-area (collinear or repeated) triple is rejected with a SpecError (a
    ValueError). As Quilez's sdTriangle: nearest of the three edges, inside
    where the point is on the inner side of all three; gradient as sdgTriangle
    (the closest-point branch).
    """

    def __init__(self, points: Any):
        from ..geometry import validate_polygon  # geometry imports sdf: import on use

        if len(points) != 3:
            raise SpecError("points", f"needs exactly 3 points, got {len(points)}")
        self._set_vertices(validate_polygon(points, "points"))


# --------------------------------------------------------------------------------------
# General polygon and half-plane
# --------------------------------------------------------------------------------------

@primitive("polygon",
           Param("points", "polygon", REQUIRED,
                 "vertices [[x, y], ...], m: a simple polygon, either winding"))
class Polygon(Field):
    """Simple polygon with vertices ``points`` (m), concave allowed, either winding, exact.

    Validated and oriented counter-clockwise by ``sdfphys.geometry.validate_polygon``
    (self-intersecting, collinear or repeated points are SpecErrors naming
    ``points``). Quilez's sdPolygon: the distance is the nearest edge's, the sign
    the parity of the edges crossed by the ray from the point towards +x (an edge
    counts when it spans the point's y, upward with the point on its left or
    downward with the point on its right). Cost O(N M) for N points and M edges.
    Gradient from the closest-point branch (module docstring).
    """

    def __init__(self, points: Any):
        from ..geometry import validate_polygon  # geometry imports sdf: import on use

        self.vertices = validate_polygon(points, "points")
        a = self.vertices
        e = np.roll(a, -1, axis=0) - a
        ee = rows_dot(e, e)
        # Per-edge rows, contiguous, for the (points, edges) broadcasts.
        self._ax, self._ay = a[:, 0].copy(), a[:, 1].copy()
        self._ex, self._ey = e[:, 0].copy(), e[:, 1].copy()
        self._by = self._ay + self._ey
        self._inv_ee = 1.0 / ee
        self._normals = np.stack([e[:, 1], -e[:, 0]], axis=1) / np.sqrt(ee)[:, None]
        self._eps = _DEGENERATE * float(np.ptp(a, axis=0).max())

    def bounds(self):
        return _aabb(self.vertices)


@primitive("half_plane",
           Param("normal", "vec2", REQUIRED, "outward normal [nx, ny] (normalized here; not 0)"),
           Param("distance", "real", 0.0, "offset c of the boundary line along the normal, m"))
class HalfPlane(Field):
    """Half-plane f(p) = n . p - c (m), exact; n = ``normal`` / |normal|, c = ``distance``.

    The solid side is where n . p < c (the boundary line is at signed distance c
    from the origin along n); the gradient is n everywhere. Bounds are infinite
    except on the solid side of an axis-aligned normal, e.g. normal [0, 1] gives
    [-inf, -inf, inf, c].
    """

    def __init__(self, normal: Any, distance: float = 0.0):
        nx, ny = (float(c) for c in normal)
        length = math.hypot(nx, ny)
        if not length > 0.0:
            raise SpecError("normal", f"must not be the zero vector, got {[nx, ny]}")
        self.normal = np.array([nx, ny]) / length
        self.level = float(distance)

    def bounds(self):
        lo = np.full(2, -np.inf)
        hi = np.full(2, np.inf)
        for axis in (0, 1):
            if self.normal[1 - axis] == 0.0:
                if self.normal[axis] > 0.0:
                    hi[axis] = self.level
                else:
                    lo[axis] = -self.level
        return np.concatenate([lo, hi])
