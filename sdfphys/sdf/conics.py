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
from ..vec2 import rows_dot, rows_unit_or
from .base import REQUIRED, Field, Param, as_points, primitive
from .curved import (
    _DOWN,
    _LEFT,
    _RIGHT,
    _UP,
    _check_positive,
    _fold_x,
    _norm,
    _pick,
    _unfold,
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
        g = _pick(on_arc, rows_unit_or(rel, _RIGHT), rows_unit_or(rel_c, _UP))
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
        g_k = rows_unit_or(s[:, None] * rel_k, self.horn / ra)
        # With y folded to |y| the outer arc runs from the horn to (-ra, 0) and the
        # bitten arc from the horn to (dc - rb, 0); a radial projection lands on an
        # arc iff the direction is past the horn's: cross(horn direction, q) >= 0.
        on_a = ka * q[:, 1] - kb * q[:, 0] >= 0.0
        on_b = (ka - dc) * v[:, 1] - kb * v[:, 0] >= 0.0
        d_a = np.where(on_a, np.abs(length - ra), d_k)
        d_b = np.where(on_b, np.abs(lv - rb), d_k)
        g_a = _pick(on_a, rows_unit_or(q, _LEFT), g_k)
        g_b = _pick(on_b, rows_unit_or(-v, _RIGHT), g_k)
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
        g = _pick(lower, rows_unit_or(q, _DOWN),
                  _pick(above, rows_unit_or(q - apex, _UP), rows_unit_or(q - side_centre, _RIGHT)))
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
        g_lobe = rows_unit_or(rel_l, _UP)
        # Below the line x + y = 1: the segment from the tip along (1, 1) (its
        # projection t stays <= 0.5 there) or the cusp; inside iff x < y.
        s = np.where(q[:, 0] > q[:, 1], 1.0, -1.0)
        t = np.maximum(q[:, 0] + q[:, 1], 0.0) / 2.0
        rel_s = q - t[:, None]
        d_seg = _norm(rel_s)
        g_seg = _pick(t > 0.0, self._EDGE_NORMAL,
                      rows_unit_or(s[:, None] * rel_s, self._EDGE_NORMAL))
        rel_k = q - self._CUSP
        d_cusp = _norm(rel_k)
        g_cusp = rows_unit_or(s[:, None] * rel_k, _UP)
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
    # Most points need no bisection: _FAST_NEWTON Newton steps straight from lo (the
    # same monotone rise) whose last step is under _SETTLED u have reached the root to
    # round-off (quadratic convergence: the next step would be ~1e-20 u). Measured on
    # 1.2e6 points (aspects 1 to 1000; around, on rays through and far from the
    # ellipse, y down to 1e-300): 99.3 % settle so, their distances within 6.7e-16
    # (relative) of the bracketed solver's; the others (near the major axis inside,
    # near the largest doubles) run the bracketed solver.
    _BISECTIONS = 12
    _NEWTON = 6
    _FAST_NEWTON = 8
    _SETTLED = 1e-10

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
        u = previous = lo
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            for _ in range(self._FAST_NEWTON):         # NaN where it overflows: slow
                previous, u = u, self._newton(big_a, big_b, e, u)
        slow = ~(np.abs(u - previous) <= self._SETTLED * u)
        if np.any(slow):
            lo, hi, fa, fb = lo[slow], hi[slow], big_a[slow], big_b[slow]
            for _ in range(self._BISECTIONS):
                mid = np.sqrt(lo) * np.sqrt(hi)
                f = (fa / (mid + e)) ** 2 + (fb / mid) ** 2 - 1.0
                lo, hi = np.where(f >= 0.0, mid, lo), np.where(f >= 0.0, hi, mid)
            for _ in range(self._NEWTON):
                fx, fy = fa / (lo + e), fb / lo
                n = np.hypot(fx, fy)
                slope = fx * fx / (lo + e) + fy * fy / lo
                lo = lo + n * n * (n - 1.0) / slope
            u = u.copy()
            u[slow] = lo
        xc = np.where(general, a * big_a / (u + e), 0.0)
        yc = np.where(general, b * big_b / u, 0.0)
        interior = big_a < e
        x_axis = np.where(interior, a * big_a / (e if e > 0.0 else 1.0), a)
        y_axis = np.where(interior, b * np.sqrt(np.maximum(1.0 - (x_axis / a) ** 2, 0.0)), 0.0)
        xc, yc = np.where(general, xc, x_axis), np.where(general, yc, y_axis)
        dist = np.hypot(x - xc, y - yc)
        inside = (x / a) ** 2 + (y / b) ** 2 < 1.0
        g = rows_unit_or(np.column_stack([xc / (a * a), yc / (b * b)]), _RIGHT)
        g = _unfold(g, sx, sy)
        if self.swap:
            g = g[:, ::-1]
        return np.where(inside, -dist, dist), g

    @staticmethod
    def _newton(big_a: np.ndarray, big_b: np.ndarray, e: float, u: np.ndarray) -> np.ndarray:
        """One Newton step on psi(u) = 1 / |(A / (u + e), B / u)| - 1 (above): with
        F = (f_x, f_y) = (A / (u + e), B / u), u + |F|^2 (|F| - 1) / (f_x^2 / (u + e)
        + f_y^2 / u), in two divisions and a square root. The bracketed solver's steps
        divide and take hypot instead: near the largest doubles 1 / (u + e) is
        subnormal (a NaN here, so such a point does not settle and goes there)."""
        inner, outer = 1.0 / (u + e), 1.0 / u
        fx, fy = big_a * inner, big_b * outer
        square = fx * fx + fy * fy
        slope = fx * fx * inner + fy * fy * outer
        return u + square * (np.sqrt(square) - 1.0) / slope

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
        k1 = 2.0 * (A @ A) + rows_dot(ap, B)
        k0 = rows_dot(ap, A)
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
        normal = rows_unit_or(left, rows_unit_or(rel, _RIGHT))
        side = np.where(rows_dot(rel, left) < 0.0, -1.0, 1.0)
        near = dist * self.cross < 2.0 * _norm(tangent) ** 3
        interior = (t > 0.0) & (t < 1.0) & near
        g = _pick(interior, side[:, None] * normal, rows_unit_or(rel, normal))
        return dist - self.radius, g

    def bounds(self) -> np.ndarray:
        # Extremes of each coordinate: the ends and the stationary t = -A_i / B_i.
        t = [0.0, 1.0] + [-self.A[i] / self.B[i] for i in range(2)
                          if self.B[i] != 0.0 and 0.0 < -self.A[i] / self.B[i] < 1.0]
        q = self._curve(np.array(t))
        r = self.radius
        return np.concatenate([q.min(axis=0) - r, q.max(axis=0) + r])
