"""Numeric gradients: convergence orders against the analytic gradients, the cost in
field evaluations per point, and the NumericGradientField wrapper.

Fields: circle r = 1, box 2 x 1 rotated by 0.3, and their smooth union (polynomial,
k = 0.3, the box moved to (1.2, 0.4)). Points: 4000 random points whose analytic
gradient varies by less than 0.2 over a radius of 0.02 (no kink within the widest
stencil). ``measure()`` prints the table quoted in ``sdfphys/sdf/gradient.py``.
"""

import math

import numpy as np
import pytest
from fieldcheck import check_field

from sdfphys.sdf import OPERATORS, Field, field
from sdfphys.sdf.gradient import (
    METHODS,
    NumericGradientField,
    angle_bisection,
    central_difference,
    three_point,
)
from sdfphys.sdf.operators import level_bounds

CIRCLE = field({"type": "circle", "radius": 1.0})
BOX = field({"type": "box", "size": [2.0, 1.0], "angle": 0.3})
BLEND = OPERATORS["smooth_union"](
    [CIRCLE, field({"type": "box", "size": [2.0, 1.0], "angle": 0.3, "offset": [1.2, 0.4]})],
    k=0.3)
FIELDS = {"circle": CIRCLE, "box": BOX, "smooth union": BLEND}


def smooth_points(f, n=4000, seed=7, radius=0.02):
    rng = np.random.default_rng(seed)
    x0, y0, x1, y1 = f.bounds()
    p = np.array([x0 - 0.5, y0 - 0.5]) + np.array([x1 - x0 + 1, y1 - y0 + 1]) * rng.random(
        (4 * n, 2))
    g = f.evaluate(p)[1]
    ok = np.ones(len(p), dtype=bool)
    for a in np.linspace(0.0, 2 * np.pi, 8, endpoint=False):
        q = p + radius * np.array([np.cos(a), np.sin(a)])
        ok &= np.linalg.norm(f.evaluate(q)[1] - g, axis=1) < 0.2
    assert ok.sum() >= n
    return p[ok][:n]


POINTS = {name: smooth_points(f) for name, f in FIELDS.items()}


def angular_error(g, f, p):
    """Angle (rad) between unit directions g (N, 2) and the analytic gradient of f at p."""
    ga = f.evaluate(p)[1]
    return np.abs(np.arctan2(g[:, 0] * ga[:, 1] - g[:, 1] * ga[:, 0], np.sum(g * ga, axis=1)))


def resolution(n):
    return (2 * math.pi / 3) / 2 ** (n + 2)


def errors(name, method, **kw):
    f, p = FIELDS[name], POINTS[name]
    return angular_error(method(f, p, **kw), f, p)


def order(coarse, fine):
    return math.log2(coarse / fine)


# --------------------------------------------------------------------------------------
# Convergence.
# --------------------------------------------------------------------------------------

def test_central_difference_is_second_order():
    # Circle: max error; smooth union: median (its max sits on the C1 seams of the
    # blend, where the second derivative jumps).
    assert 1.8 <= order(errors("circle", central_difference, h=1e-3).max(),
                        errors("circle", central_difference, h=5e-4).max()) <= 2.2
    assert 1.8 <= order(np.median(errors("smooth union", central_difference, h=1e-3)),
                        np.median(errors("smooth union", central_difference, h=5e-4))) <= 2.2
    assert errors("circle", central_difference, h=1e-3).max() < 1e-5


def test_three_point_is_first_order():
    assert 0.8 <= order(errors("circle", three_point, h=1e-3).max(),
                        errors("circle", three_point, h=5e-4).max()) <= 1.2
    assert 0.8 <= order(np.median(errors("smooth union", three_point, h=1e-3)),
                        np.median(errors("smooth union", three_point, h=5e-4))) <= 1.2


@pytest.mark.parametrize("name", ["circle", "box"])
@pytest.mark.parametrize("n", [4, 8, 12, 16])
def test_angle_bisection_reaches_its_resolution_on_exact_fields(name, n):
    # Exact SDF: the sampled profile is symmetric about the gradient, so the only
    # error is the bracket's: (2 pi / 3) / 2^(n + 2), whatever the radius.
    for offset in (None, 1e-3):
        err = errors(name, angle_bisection, iterations=n, offset=offset)
        assert err.max() <= resolution(n) * (1 + 1e-9)
    assert err.max() > 0.5 * resolution(n)          # and the resolution is what it costs


def test_angle_bisection_on_a_bound_errs_in_proportion_to_the_radius():
    # Smooth union: H grad f != 0 in the blend, so the steepest direction on the
    # sampling circle moves by O(o). Enough iterations to be below that.
    coarse = errors("smooth union", angle_bisection, iterations=30, offset=1e-3).max()
    fine = errors("smooth union", angle_bisection, iterations=30, offset=5e-4).max()
    assert 0.8 <= order(coarse, fine) <= 1.2


def test_angle_bisection_floor_is_set_by_rounding():
    # Near the top the profile is flat: f differences o * delta^2 / 2 fall below the
    # rounding of f when delta < sqrt(2 eps / o); 30 iterations reach that floor.
    err = errors("circle", angle_bisection, iterations=30, offset=1e-3)
    assert err.max() < 3 * math.sqrt(2 * np.finfo(float).eps / 1e-3)


# --------------------------------------------------------------------------------------
# Cost.
# --------------------------------------------------------------------------------------

class Counting(Field):
    """Counts evaluations (points passed to distance / evaluate)."""

    def __init__(self, of):
        self.of, self.count, self.exact = of, 0, of.exact

    def evaluate(self, points):
        self.count += len(points)
        return self.of.evaluate(points)

    def distance(self, points):
        self.count += len(points)
        return self.of.distance(points)

    def bounds(self):
        return self.of.bounds()


@pytest.mark.parametrize("call, per_point", [
    (lambda f, p: central_difference(f, p, 1e-4), 4),
    (lambda f, p: three_point(f, p, 1e-4), 3),
    (lambda f, p: three_point(f, p, 1e-4, value=np.zeros(len(p))), 2),
    (lambda f, p: angle_bisection(f, p, 10, offset=1e-3), 13),
    (lambda f, p: angle_bisection(f, p, 10), 14),
    (lambda f, p: angle_bisection(f, p, 10, value=np.zeros(len(p))), 13),
    (lambda f, p: NumericGradientField(f, "central").evaluate(p), 5),
    (lambda f, p: NumericGradientField(f, "three_point").evaluate(p), 3),
    (lambda f, p: NumericGradientField(f, "angle_bisection", iterations=10).evaluate(p), 14),
])
def test_evaluations_per_point(call, per_point):
    f = Counting(CIRCLE)
    call(f, POINTS["circle"][:100])
    assert f.count == per_point * 100


# --------------------------------------------------------------------------------------
# Robustness and the wrapper.
# --------------------------------------------------------------------------------------

class Constant(Field):
    exact = False

    def evaluate(self, points):
        return np.zeros(len(points)), np.zeros((len(points), 2))

    def bounds(self):
        return np.array([-1.0, -1.0, 1.0, 1.0])


@pytest.mark.parametrize("method", [
    lambda f, p: central_difference(f, p, 1e-4), lambda f, p: three_point(f, p, 1e-4),
    lambda f, p: angle_bisection(f, p, 12)])
def test_unit_finite_and_deterministic_at_degenerate_points(method):
    p = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.0], [1e9, -1e9], [0.3, 0.3]])
    for f in (CIRCLE, BOX, BLEND):
        g = method(f, p)
        assert np.all(np.isfinite(g))
        np.testing.assert_allclose(np.linalg.norm(g, axis=1), 1.0, atol=1e-12)
        np.testing.assert_array_equal(g[0], g[2])
    # A constant field (every sample ties): the fallback direction (1, 0), to within
    # the bisection's resolution.
    np.testing.assert_allclose(method(Constant(), p), np.tile([1.0, 0.0], (5, 1)),
                               atol=resolution(12))


def test_wrapper_keeps_values_exactness_and_bounds(rng):
    for method in METHODS:
        wrapped = NumericGradientField(BOX, method)
        p = POINTS["box"][:500]
        d, g = wrapped.evaluate(p)
        np.testing.assert_array_equal(d, BOX.distance(p))
        assert np.max(angular_error(g, BOX, p)) < 1e-5
        assert wrapped.exact and np.array_equal(wrapped.bounds(), BOX.bounds())
        np.testing.assert_array_equal(level_bounds(wrapped, 0.3), level_bounds(BOX, 0.3))
    check_field(NumericGradientField(CIRCLE, "central"), rng)


def test_wrapper_rejects_bad_arguments():
    with pytest.raises(ValueError, match="method must be one of central, three_point"):
        NumericGradientField(CIRCLE, "sobel")
    with pytest.raises(ValueError, match="h must be > 0"):
        NumericGradientField(CIRCLE, "central", h=0.0)
    with pytest.raises(ValueError, match="iterations must be >= 0"):
        angle_bisection(CIRCLE, np.zeros((1, 2)), -1)


def measure() -> str:
    """The table of angular errors quoted in gradient.py (max / median, radians)."""
    rows = [("central_difference, h = 1e-3", 4, lambda f, p: central_difference(f, p, 1e-3)),
            ("three_point, h = 1e-3", 3, lambda f, p: three_point(f, p, 1e-3)),
            ("angle_bisection, n = 16, report's o", 20, lambda f, p: angle_bisection(f, p, 16)),
            ("angle_bisection, n = 16, o = 1e-4", 19,
             lambda f, p: angle_bisection(f, p, 16, offset=1e-4))]
    lines = []
    for label, cost, method in rows:
        cells = []
        for name, f in FIELDS.items():
            e = angular_error(method(f, POINTS[name]), f, POINTS[name])
            cells.append(f"{e.max():.1e} / {np.median(e):.0e}")
        lines.append(f"{label:38s} {cost:3d}   " + "   ".join(cells))
    return "\n".join(lines)


if __name__ == "__main__":
    print(measure())
