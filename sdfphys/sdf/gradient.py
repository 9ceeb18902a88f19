"""Numeric gradients: for accuracy studies and for user fields without an analytic gradient.

Every field in ``sdfphys.sdf`` has an analytic gradient; these schemes exist to
measure what the analytic ones buy (the "gradient method" setting) and to give a
normal to a field that only has values. Each returns unit directions (N, 2) (a zero
difference gives the fallback direction (1, 0), never NaN) and batches all its
evaluations into a few calls of ``field.distance``. Cost is counted in field
evaluations per point.

- ``central_difference``: 4 evaluations, error O(h^2) (seed 003 and the report's
  first attempt: f(p +- h e_x), f(p +- h e_y)).
- ``three_point``: 3 evaluations, f(p), f(p + h e_x), f(p + h e_y) (forward
  differences), error O(h); 2 when f(p) is already known.
- ``angle_bisection``: the method the seed report (000, section 2.3) settled on:
  sample f on a circle of radius o around p and bisect towards the angle of
  steepest ascent. 3 + n evaluations for n iterations (+1 for f(p) when ``offset``
  is the report's o = max(0.005, f(p) * 0.005 / 20) and f(p) is not given).

Measured angular errors (radians, max / median over 4000 random points where the
field has no kink within 0.02; tests/test_sdf_gradient.py prints this table):
circle r = 1, box 2 x 1 rotated by 0.3, smooth union of the two (k = 0.3).

    method                                cost   circle            box               smooth union
    central_difference, h = 1e-3            4    9.4e-06 / 6e-08   3.8e-04 / 4e-14   3.1e-04 / 5e-08
    three_point, h = 1e-3                   3    4.4e-03 / 3e-04   4.5e-03 / 6e-14   3.7e-02 / 3e-04
    angle_bisection, n = 16, report's o    20    8.0e-06 / 4e-06   8.0e-06 / 3e-06   2.1e-01 / 4e-06
    angle_bisection, n = 16, o = 1e-4      19    8.1e-06 / 4e-06   8.0e-06 / 3e-06   4.7e-03 / 4e-06

Differences are exact on the box's linear regions (median ~1e-14); their maxima
sit on C1 seams (beyond the box's corners, at the edges of the blend zone) where
the curvature jumps. The bisection's error on exact fields is its resolution,
(2 pi / 3) / 2^(n + 2) = 8.0e-6 at n = 16, whatever o: any exact SDF has
H grad f = 0, so the sampled profile f(p + o u(alpha)) is symmetric about the
gradient up to O(o^3) terms. It cannot go below sqrt(2 eps |f| / o) (the profile
is flat at its top, differences drown in rounding). On a bound such as a smooth
union, H grad f != 0 in the blend and the steepest direction on the sampling
circle moves by O(o |H| / |grad f|): first order in o, and large where the
gradient is short (0.21 rad with the report's o >= 5 mm).
"""

from __future__ import annotations

import math

import numpy as np

from .base import Field, as_points, safe_normalize
from .operators import level_bounds

__all__ = ["METHODS", "NumericGradientField", "angle_bisection", "central_difference",
           "three_point"]

#: Names of the numeric gradient methods accepted by ``NumericGradientField``.
METHODS = ("central", "three_point", "angle_bisection")

#: Default step h (m) of each method in ``NumericGradientField`` (None: the report's o).
_DEFAULT_STEP = {"central": 1e-5, "three_point": 1e-7, "angle_bisection": None}

_EX = np.array([1.0, 0.0])
_EY = np.array([0.0, 1.0])
_THIRD = 2.0 * math.pi / 3.0


def central_difference(field: Field, points: np.ndarray, h: float) -> np.ndarray:
    """Unit gradient (N, 2) from central differences with step ``h`` (m); 4 evaluations/point.

    g = normalize(f(p + h e_x) - f(p - h e_x), f(p + h e_y) - f(p - h e_y)); the
    truncation error of each difference is h^2 / 6 f''', so the direction errs by
    O(h^2) where f is smooth within h.
    """
    p = as_points(points)
    n = len(p)
    f = field.distance(np.concatenate([p + h * _EX, p - h * _EX, p + h * _EY, p - h * _EY]))
    return safe_normalize(np.stack([f[:n] - f[n:2 * n], f[2 * n:3 * n] - f[3 * n:]], axis=1))


def three_point(field: Field, points: np.ndarray, h: float,
                value: np.ndarray | None = None) -> np.ndarray:
    """Unit gradient (N, 2) from forward differences with step ``h`` (m).

    Uses f(p), f(p + h e_x), f(p + h e_y): 3 evaluations per point, 2 if ``value``
    (f at ``points``, (N,)) is given. Each difference errs by h / 2 f'', so the
    direction errs by O(h).
    """
    p = as_points(points)
    n = len(p)
    if value is None:
        f = field.distance(np.concatenate([p, p + h * _EX, p + h * _EY]))
        value, f = f[:n], f[n:]
    else:
        f = field.distance(np.concatenate([p + h * _EX, p + h * _EY]))
    return safe_normalize(np.stack([f[:n] - value, f[n:] - value], axis=1))


def report_offset(value: np.ndarray) -> np.ndarray:
    """The seed report's sampling radius o = max(0.005, f * 0.005 / 20), m.

    As written in the report, negative f (inside) always gives the floor 0.005.
    """
    return np.maximum(0.005, value * (0.005 / 20.0))


# The report evaluates f at 3 points around p and converges "by dichotomy" to the
# angle alpha maximizing f(p + o (cos alpha, sin alpha)). Our reading, for a
# profile that is unimodal and symmetric about its maximum theta (f + o |g|
# cos(alpha - theta) + O(o^2) even terms for a smooth field):
#   1. sample alpha = 0, 2 pi / 3, 4 pi / 3; the best sample is within pi / 3 of
#      theta, and theta lies between it and the better of its two neighbours (the
#      counter-clockwise one on a tie): a bracket [a, b] of width 2 pi / 3;
#   2. with f(a) >= f(b), theta is nearer to a, so it lies in [a, mid]; otherwise
#      in [mid, b]. The choice costs nothing; evaluating the new end costs one
#      evaluation, needed by the next step;
#   3. after n evaluations, halve once more and return the bracket's middle:
#      angular error <= (2 pi / 3) / 2^(n + 2).
# Ties (a constant profile, e.g. at a circle's centre) keep the lower end, so the
# result is deterministic: within the resolution of angle 0, the fallback direction.

def angle_bisection(field: Field, points: np.ndarray, iterations: int = 16,
                    offset: float | None = None,
                    value: np.ndarray | None = None) -> np.ndarray:
    """Unit gradient (N, 2) by the seed report's angle bisection (see the comment above).

    ``iterations`` n >= 0 halvings, each one evaluation; ``offset``: sampling radius
    o (m), default the report's ``max(0.005, f(p) * 0.005 / 20)``, which needs f(p):
    pass ``value`` (N,) if known. Cost: 3 + n evaluations per point, +1 for f(p)
    when the default offset is used without ``value``. Resolution
    (2 pi / 3) / 2^(n + 2) radians (8.0e-6 at n = 16).
    """
    if iterations < 0:
        raise ValueError(f"iterations must be >= 0, got {iterations}")
    p = as_points(points)
    n = len(p)
    if offset is not None:
        radius = np.full(n, float(offset))
    else:
        radius = report_offset(field.distance(p) if value is None else value)

    def sample(angle: np.ndarray) -> np.ndarray:
        return field.distance(p + radius[:, None] * np.stack([np.cos(angle), np.sin(angle)], 1))

    start = np.array([0.0, _THIRD, 2.0 * _THIRD])
    f = field.distance(np.concatenate(
        [p + radius[:, None] * [math.cos(a), math.sin(a)] for a in start])).reshape(3, n)
    rows = np.arange(n)
    best = np.argmax(f, axis=0)
    ccw, cw = f[(best + 1) % 3, rows], f[(best + 2) % 3, rows]
    side = np.where(ccw >= cw, 1.0, -1.0)
    a_lo, f_lo = start[best], f[best, rows]
    a_hi, f_hi = a_lo + side * _THIRD, np.maximum(ccw, cw)
    for _ in range(iterations):
        mid = 0.5 * (a_lo + a_hi)
        f_mid = sample(mid)
        keep_lo = f_lo >= f_hi
        a_hi, f_hi = np.where(keep_lo, mid, a_hi), np.where(keep_lo, f_mid, f_hi)
        a_lo, f_lo = np.where(keep_lo, a_lo, mid), np.where(keep_lo, f_lo, f_mid)
    mid = 0.5 * (a_lo + a_hi)
    angle = np.where(f_lo >= f_hi, 0.5 * (a_lo + mid), 0.5 * (mid + a_hi))
    return np.stack([np.cos(angle), np.sin(angle)], axis=1)


class NumericGradientField(Field):
    """``field`` with its gradient replaced by a numeric one (the "gradient method" knob).

    ``method``: "central" (h default 1e-5 m; 5 evaluations per point with the
    value), "three_point" (h default 1e-7 m; 3 with the value), or
    "angle_bisection" (h is the sampling radius o, default the report's formula;
    4 + ``iterations`` with the value). Values, exactness and bounds are the
    wrapped field's; gradients are unit vectors.
    """

    def __init__(self, field: Field, method: str = "central", h: float | None = None,
                 iterations: int = 16):
        if method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
        if h is not None and not h > 0.0:
            raise ValueError(f"h must be > 0, got {h}")
        if iterations < 0:
            raise ValueError(f"iterations must be >= 0, got {iterations}")
        self.field = field
        self.method = method
        self.h = _DEFAULT_STEP[method] if h is None else float(h)
        self.iterations = int(iterations)
        self.exact = field.exact

    def evaluate(self, points):
        p = as_points(points)
        d = self.field.distance(p)
        if self.method == "central":
            return d, central_difference(self.field, p, self.h)
        if self.method == "three_point":
            return d, three_point(self.field, p, self.h, value=d)
        return d, angle_bisection(self.field, p, self.iterations, self.h, value=d)

    def distance(self, points):
        return self.field.distance(points)

    def bounds(self):
        return self.field.bounds()

    def level_bounds(self, level: float) -> np.ndarray:
        """Those of the wrapped field."""
        return level_bounds(self.field, level)
