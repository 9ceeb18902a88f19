"""Curved primitives beyond arcs and capsules (Quilez, "2D distance functions").

Vesica (lens), moon (crescent), egg and heart, assembled from circle arcs, and the
ellipse and the quadratic Bezier segment, whose closest points come from fixed-count
root finders (Eberly's bisection for the ellipse, the closed-form cubic with Newton
polish for the Bezier). Conventions, gradients and references are those of
``curved``'s docstring.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SpecError
from .base import REQUIRED, Field, Param, primitive
from .curved import (
    _check_positive,
    _vec,
)

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

    def bounds(self) -> np.ndarray:
        x = (self._LOBE_CENTRE[0] + self._LOBE_RADIUS) * self.scale
        return np.array([-x, 0.0, x, (self._LOBE_CENTRE[1] + self._LOBE_RADIUS) * self.scale])


# --------------------------------------------------------------------------------------
# Ellipse and quadratic Bezier: closest points from fixed-count root finders
# --------------------------------------------------------------------------------------

@primitive("ellipse", Param("size", "size2", REQUIRED, "full width and height [w, h], m"))
class Ellipse(Field):
    """Axis-aligned ellipse of full ``size`` [w, h] centred at the origin, exact.

    The closest point is found to round-off by a fixed-count solver
    (``ellipse_kernel._ellipse``, Eberly's);
    the gradient is the outward normal there, (x/a^2, y/b^2) normalized, also
    for inside points. At the centre it is (0, +-1) towards the nearer vertex
    ((1, 0) for a circle).
    """

    def __init__(self, size: ArrayLike):
        w, h = _vec(size)
        if not (w > 0.0 and h > 0.0):
            raise SpecError("size", f"must be two positive numbers, got {[w, h]}")
        self.half = np.array([w, h]) / 2.0
        self.swap = h > w
        self.a, self.b = (self.half[1], self.half[0]) if self.swap else (self.half[0], self.half[1])

    def bounds(self) -> np.ndarray:
        hx, hy = self.half
        return np.array([-hx, -hy, hx, hy])


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
            speed = float(np.linalg.norm(self.A + t_min * self.B))
            self.min_curvature_radius = 2.0 * speed ** 3 / cross
        else:
            self.min_curvature_radius = math.inf
        self.exact = bool(self.radius <= self.min_curvature_radius)

    def _curve(self, t: np.ndarray) -> np.ndarray:
        return self.a + 2.0 * t[..., None] * self.A + (t * t)[..., None] * self.B

    def bounds(self) -> np.ndarray:
        # Extremes of each coordinate: the ends and the stationary t = -A_i / B_i.
        t = [0.0, 1.0] + [-self.A[i] / self.B[i] for i in range(2)
                          if self.B[i] != 0.0 and 0.0 < -self.A[i] / self.B[i] < 1.0]
        q = self._curve(np.array(t))
        r = self.radius
        return np.concatenate([q.min(axis=0) - r, q.max(axis=0) + r])
