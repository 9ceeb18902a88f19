"""Symmetric polygons evaluated on one folded edge (Quilez, "2D distance functions").

Regular pentagon, hexagon and octagon and the hexagram (reflections fold the plane
onto one edge on y = r), the star (polar reduction to one sector) and the crosses
(abs folds, and the rounded cross's arcs). Conventions, the gradient derivation
through the folds and the references are those of ``polygonal``'s docstring.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import SpecError
from .base import REQUIRED, Field, Param, primitive
from .polygonal import (
    _DEGENERATE,
    _aabb,
    _segment,
)

# --------------------------------------------------------------------------------------
# Regular polygons and the hexagram: reflections fold the plane onto one edge on y = r.
# --------------------------------------------------------------------------------------

class _MirrorFolded(Field):
    """Shapes that Quilez folds with |p| and a few mirrors onto one edge on y = r.

    Subclasses set ``_abs_y`` (fold y too), ``_mirrors`` (unit normals, applied
    in order) and call ``_set_edge``. The folded point is inside when below the
    line y = r (the edge spans the whole folded sector).
    """

    _abs_y: bool = True
    _mirrors: tuple[np.ndarray, ...] = ()

    def _set_edge(self, radius: float, x0: float, x1: float, size: float) -> None:
        self.radius = float(radius)
        self._edge = [_segment((x0, radius), (x1, radius), (0.0, 1.0))]
        self._eps = _DEGENERATE * size


def _unit_at(degrees: float) -> np.ndarray:
    a = math.radians(degrees)
    return np.array([math.cos(a), math.sin(a)])


@primitive("pentagon",
           Param("radius", "positive", REQUIRED, "inradius (apothem): centre to edge midpoint, m"))
class Pentagon(_MirrorFolded):
    """Regular pentagon of inradius ``radius`` r (m), centred at the origin, exact.

    As Quilez's sdPentagon: the top edge is horizontal at y = r, a vertex points
    down at (0, -R) with circumradius R = r / cos 36deg. Folds: |x|, then the
    mirrors through the origin at 54deg and 126deg onto the top edge.
    """

    _abs_y = False
    _mirrors = (_unit_at(144.0), _unit_at(36.0))

    def __init__(self, radius: float):
        r = float(radius)
        half_edge = r * math.tan(math.radians(36.0))
        self._set_edge(r, -half_edge, half_edge, r)

    def bounds(self):
        big = self.radius / math.cos(math.radians(36.0))
        x = big * math.cos(math.radians(18.0))
        return np.array([-x, -big, x, self.radius])


@primitive("hexagon",
           Param("radius", "positive", REQUIRED, "inradius (apothem): centre to edge midpoint, m"))
class Hexagon(_MirrorFolded):
    """Regular hexagon of inradius ``radius`` r (m), centred at the origin, exact.

    As Quilez's sdHexagon: flat top and bottom edges at y = +-r, vertices at
    (+-2r/sqrt(3), 0). Folds: |p|, then the mirror at 60deg onto the top edge.
    """

    _mirrors = (_unit_at(150.0),)

    def __init__(self, radius: float):
        r = float(radius)
        self._set_edge(r, -r / math.sqrt(3.0), r / math.sqrt(3.0), r)

    def bounds(self):
        x = 2.0 * self.radius / math.sqrt(3.0)
        return np.array([-x, -self.radius, x, self.radius])


@primitive("octagon",
           Param("radius", "positive", REQUIRED, "inradius (apothem): centre to edge midpoint, m"))
class Octagon(_MirrorFolded):
    """Regular octagon of inradius ``radius`` r (m), centred at the origin, exact.

    As Quilez's sdOctogon: edges at x = +-r and y = +-r and on the diagonals.
    Folds: |p|, then the mirrors at 67.5deg and 112.5deg onto the top edge.
    """

    _mirrors = (_unit_at(157.5), _unit_at(22.5))

    def __init__(self, radius: float):
        r = float(radius)
        half_edge = r * math.tan(math.radians(22.5))
        self._set_edge(r, -half_edge, half_edge, r)

    def bounds(self):
        r = self.radius
        return np.array([-r, -r, r, r])


@primitive("hexagram",
           Param("radius", "positive", REQUIRED,
                 "inradius r of the inner hexagon (centre to edge line), m; tips at 2r"))
class Hexagram(_MirrorFolded):
    """Six-pointed star (two overlapping equilateral triangles), centred at the origin, exact.

    As Quilez's sdHexagram(p, r): every edge lies on a line at distance r
    (``radius``, m) from the centre; the six tips are at distance 2r, one
    pointing up (+y), the six inner (concave) corners at 2r/sqrt(3). Folds: |p|,
    then the mirrors at 30deg and 60deg onto the edge from the inner corner
    (r/sqrt(3), r) to the tip (r sqrt(3), r).
    """

    _mirrors = (_unit_at(120.0), _unit_at(-30.0))

    def __init__(self, radius: float):
        r = float(radius)
        self._set_edge(r, r / math.sqrt(3.0), r * math.sqrt(3.0), 2.0 * r)

    def bounds(self):
        r = self.radius
        return np.array([-r * math.sqrt(3.0), -2.0 * r, r * math.sqrt(3.0), 2.0 * r])


# --------------------------------------------------------------------------------------
# Star: polar reduction to one sector
# --------------------------------------------------------------------------------------

@primitive("star",
           Param("radius", "positive", REQUIRED, "centre-to-tip distance, m"),
           Param("points", "count", REQUIRED, "number of tips n, >= 3"),
           Param("m", "real", REQUIRED,
                 "Quilez's m, 2 <= m < points: 2 gives a regular n-gon, larger is spikier"))
class Star(Field):
    """Star with ``points`` = n tips at distance ``radius`` (m), one pointing up, exact.

    Quilez's sdStar(p, r, n, m). The boundary is 2n equal edges; each runs from
    a tip at an angle pi/m to the ray through the neighbouring inner corner, so
    the inner corners have interior angle 2 pi (1 - 1/m) and the tips 2 pi
    (1/m - 1/n). ``m`` = 2 is the regular n-gon with circumradius r; m must be
    below n (m = n would put the inner corners at the centre: zero area). Inner
    corners are at distance r sin(pi/m - pi/n) / sin(pi/m); the distance from the
    centre to every edge line is r sin(pi/m - pi/n).
    """

    # Reduction (Quilez): with theta = atan2(|x|, y), the angle from +y, and
    # an = pi/n, bn = mod(theta, 2 an) - an in [-an, an); the point is replaced by
    # q = |p| (cos bn, |sin bn|), in the sector [0, an] between an inner corner
    # V = (|V|, 0) and the tip T = r (cos an, sin an); the edge runs from V to T
    # in direction (cos en, sin en), en = pi/m, with outward normal
    # (sin en, -cos en). Gradient: the map p -> q keeps |p| and maps the polar
    # angle with slope e = -1 where bn >= 0 and +1 where bn < 0, so with the
    # folded gradient split into radial g_r and tangential g_t parts about q,
    # grad f = g_r p^ + e g_t t^ (p^ = (sin theta, cos theta), t^ its +90deg
    # rotation), then x times sign(x). At the centre atan2(0, 0) = 0 makes
    # p^ = +y: a deterministic branch.

    def __init__(self, radius: float, points: int, m: float):
        n = int(points)
        if n < 3:
            raise SpecError("points", f"must be >= 3, got {n}")
        if not 2.0 <= m < n:
            raise SpecError("m", f"must satisfy 2 <= m < points = {n}, got {m:g}")
        self.radius, self.n, self.m = float(radius), n, float(m)
        self._an = math.pi / n
        en = math.pi / self.m
        tip = self.radius * np.array([math.cos(self._an), math.sin(self._an)])
        length = self.radius * math.sin(self._an) / math.sin(en)
        inner = tip - length * np.array([math.cos(en), math.sin(en)])
        self._edge = [_segment(inner, tip, (math.sin(en), -math.cos(en)))]
        self._eps = _DEGENERATE * self.radius

    def bounds(self):
        angles = math.pi / 2.0 + 2.0 * self._an * np.arange(self.n)
        tips = self.radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        return _aabb(tips)


# --------------------------------------------------------------------------------------
# Crosses
# --------------------------------------------------------------------------------------

@primitive("cross",
           Param("size", "size2", REQUIRED,
                 "[length, thickness] of the two bars, m (the larger is the length)"),
           Param("rounding", "real", 0.0,
                 "Quilez's r, m: f = f_cross + r; < 0 rounds the outer corners, > 0 the "
                 "inner ones"))
class Cross(Field):
    """Plus sign: a horizontal and a vertical bar, ``size`` = [length, thickness] (m).

    Each bar is ``length`` long (tip to tip) and ``thickness`` wide, centred at
    the origin; the larger of the two numbers is taken as the length.
    ``rounding`` r (m) is Quilez's: f = f_cross + r. r < 0 grows the cross by
    |r| and rounds its outer corners with radius |r|; 0 < r < thickness/2 thins
    it by r and rounds its inner corners with radius r. Exact when r = 0; else a
    bound (exact outside for r < 0, inside for r > 0), and ``exact`` is False.
    """

    # Folded by |p| and a swap into x >= y >= 0, where the nearest boundary is the
    # horizontal bar's right end (b_x, 0)-(b_x, b_y) or its exposed top face
    # (b_y, b_y)-(b_x, b_y) (b the half length and half thickness); inside where
    # x < b_x and y < b_y. This is Quilez's sdCross except in the central square
    # of a stubby cross (b_x < 2 b_y), where his formula takes the distance to the
    # inner corner past a nearer end face and is not exact.

    def __init__(self, size: Any, rounding: float = 0.0):
        bx, by = max(size) / 2.0, min(size) / 2.0
        if not rounding < by:
            raise SpecError("rounding", f"must be < {by:g} (half the thickness), "
                                        f"got {rounding:g}")
        self.half = np.array([bx, by])
        self.rounding = float(rounding)
        self.exact = self.rounding == 0.0
        self._edges = [_segment((bx, 0.0), (bx, by), (1.0, 0.0))]
        if bx > by:
            self._edges.append(_segment((by, by), (bx, by), (0.0, 1.0)))
        self._eps = _DEGENERATE * bx

    def bounds(self):
        h = self.half[0] - self.rounding
        return np.array([-h, -h, h, h])


@primitive("rounded_cross",
           Param("h", "positive", REQUIRED,
                 "height of the y tips relative to the x tips, 0 < h <= 1"),
           Param("radius", "positive", 1.0, "distance from the centre to the x tips, m"))
class RoundedCross(Field):
    """Four-pointed star with concave circular sides (Quilez's sdRoundedCross), exact.

    Tips at (+-R, 0) and (0, +-h R) with R = ``radius`` (m) and 0 < ``h`` <= 1;
    each side is an arc of the circle of radius k R centred at (+-R, +-k R),
    k = (h + 1/h) / 2, which passes through both neighbouring tips. Quilez's
    version is R = 1 (here scaled: f = R f_1(p / R)).
    """

    # Folded by |p|. Inside the wedge of the arc (x < 1 and below the line from
    # the tip (0, h) to the circle's centre c = (1, k)) the closest boundary point
    # is on the arc: f = k - |p - c|, gradient (c - p)/|c - p|. Elsewhere it is
    # the nearer tip, outside: f = |p - tip|, gradient (p - tip)/|p - tip|, and at
    # a tip itself the tip's axis. The shape lies in the wedges, so the sign holds.

    def __init__(self, h: float, radius: float = 1.0):
        if not h <= 1.0:
            raise SpecError("h", f"must be <= 1, got {h:g}")
        self.h, self.radius = float(h), float(radius)
        self._k = 0.5 * (self.h + 1.0 / self.h)

    def bounds(self):
        r, hr = self.radius, self.h * self.radius
        return np.array([-r, -hr, r, hr])
