"""Curved primitives: exactness, hand-computed values, degenerate points, bounds,
parameter errors, and cross-checks against pymunk and brute-force closest points."""

import math

import numpy as np
import pymunk
import pytest
from fieldcheck import boundary_samples, check_field, sample_points

import sdfphys
from sdfphys.sdf import PRIMITIVES, field

pytestmark = pytest.mark.filterwarnings("error")  # no RuntimeWarning (NaN, 0/0) anywhere

SQ2 = math.sqrt(2.0)
QUARTER = math.pi / 4

# Several parameter sets per primitive, including the limits (half angles pi/2 and
# pi, a cut through the centre, the arc's reach, a circle-shaped ellipse, a
# nearly straight Bezier).
EXACT_SPECS = [
    {"type": "segment", "a": [-1.0, -0.3], "b": [1.2, 0.8]},
    {"type": "capsule", "a": [-1.0, -0.3], "b": [1.2, 0.8], "radius": 0.4},
    {"type": "uneven_capsule", "bottom_radius": 0.8, "top_radius": 0.3, "height": 1.5},
    {"type": "uneven_capsule", "bottom_radius": 0.2, "top_radius": 0.7, "height": 0.6},
    {"type": "pie", "half_angle": 0.6, "radius": 1.2},
    {"type": "pie", "half_angle": math.pi / 2, "radius": 1.0},
    {"type": "pie", "half_angle": 2.3, "radius": 1.0},
    {"type": "pie", "half_angle": math.pi, "radius": 1.0},
    {"type": "cut_disk", "radius": 1.0, "cut_height": 0.4},
    {"type": "cut_disk", "radius": 1.0, "cut_height": 0.0},
    {"type": "cut_disk", "radius": 1.0, "cut_height": -0.6},
    {"type": "arc", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3},
    {"type": "arc", "half_angle": 3 * QUARTER, "radius": 1.0, "thickness": SQ2 - 1e-9},
    {"type": "arc", "half_angle": math.pi, "radius": 1.0, "thickness": 0.6},
    {"type": "ring", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3},
    {"type": "ring", "half_angle": 2.6, "radius": 1.0, "thickness": 0.5},
    {"type": "ring", "half_angle": math.pi, "radius": 1.0, "thickness": 0.5},
    {"type": "horseshoe", "half_opening": 1.2, "radius": 1.0, "length": 0.8, "thickness": 0.3},
    {"type": "horseshoe", "half_opening": 0.5, "radius": 1.0, "length": 0.05, "thickness": 0.4},
    {"type": "horseshoe", "half_opening": 2.2, "radius": 0.8, "length": 1.0, "thickness": 0.3},
    {"type": "vesica", "radius": 1.0, "distance": 0.6},
    {"type": "vesica", "radius": 1.0, "distance": 0.0},
    {"type": "moon", "radius": 1.0, "bite_radius": 0.8, "distance": 0.5},
    {"type": "moon", "radius": 1.0, "bite_radius": 1.5, "distance": 1.2},
    {"type": "moon", "radius": 1.0, "bite_radius": 0.5, "distance": 1.2},
    {"type": "egg", "radius": 1.0, "top_radius": 0.3},
    {"type": "egg", "radius": 1.0, "top_radius": 0.0},
    {"type": "heart", "scale": 2.0},
    {"type": "ellipse", "size": [4.0, 2.0]},
    {"type": "ellipse", "size": [0.5, 3.0]},
    {"type": "ellipse", "size": [10.0, 0.2]},
    {"type": "ellipse", "size": [1.0, 1.0]},
    {"type": "quadratic_bezier", "a": [-1.0, 0.0], "b": [0.0, 1.0], "c": [1.0, 0.0]},
    {"type": "quadratic_bezier", "a": [-1.0, 0.0], "b": [0.0, 1.0], "c": [1.0, 0.0],
     "radius": 0.99},
    {"type": "quadratic_bezier", "a": [-1.0, -1.0], "b": [2.0, 1.5], "c": [0.5, -0.2],
     "radius": 0.015},   # sharp turn: smallest radius of curvature 0.0156
    {"type": "quadratic_bezier", "a": [-1.0, 0.0], "b": [0.0, 1e-9], "c": [1.0, 0.0],
     "radius": 0.2},
]

# Fields that are only bounds: the arc's caps overlap its band, the stroke is
# wider than the Bezier's smallest radius of curvature.
BOUND_SPECS = [
    {"type": "arc", "half_angle": 3 * QUARTER, "radius": 1.0, "thickness": 1.8},
    {"type": "arc", "half_angle": 1.0, "radius": 1.0, "thickness": 2.6},
    {"type": "quadratic_bezier", "a": [-1.0, 0.0], "b": [0.0, 1.0], "c": [1.0, 0.0],
     "radius": 1.3},
    {"type": "quadratic_bezier", "a": [-1.0, -1.0], "b": [2.0, 1.5], "c": [0.5, -0.2],
     "radius": 0.3},
]

CURVED = ["circle", "segment", "capsule", "uneven_capsule", "pie", "cut_disk", "arc", "ring",
          "horseshoe", "vesica", "moon", "egg", "heart", "ellipse", "quadratic_bezier"]


def _ids(specs):
    return [f"{s['type']}-{i}" for i, s in enumerate(specs)]


# --------------------------------------------------------------------------------------
# Independent definitions of each shape as a set (for sign checks)
# --------------------------------------------------------------------------------------

def _angle_from_up(p):
    return np.abs(np.arctan2(p[:, 0], p[:, 1]))


def _dense_distance(p, curve):
    """Distance from p (N, 2) to a densely sampled curve (M, 2)."""
    return np.array([np.min(np.linalg.norm(curve - x, axis=1)) for x in p])


def _arc_curve(radius, half_angle, n=10001):
    phi = np.linspace(-half_angle, half_angle, n)
    return radius * np.column_stack([np.sin(phi), np.cos(phi)])


def _bezier_curve(a, b, c, t):
    a, b, c = (np.asarray(v, dtype=float) for v in (a, b, c))
    t = np.asarray(t)[:, None]
    return (1 - t) ** 2 * a + 2 * t * (1 - t) * b + t * t * c


def inside(spec, p):
    """True where p (N, 2) lies in the shape, from its set definition."""
    kind = spec["type"]
    x, y = p[:, 0], p[:, 1]
    r = spec.get("radius")
    if kind == "uneven_capsule":
        r1, r2, h = spec["bottom_radius"], spec["top_radius"], spec["height"]
        s = np.linspace(0.0, 1.0, 4001)   # the hull of two disks: interpolated disks
        centres = np.column_stack([0 * s, s * h])
        gap = np.linalg.norm(p[:, None] - centres[None], axis=2) - (r1 + s * (r2 - r1))
        return gap.min(axis=1) <= 0
    if kind == "pie":
        return (np.hypot(x, y) <= r) & (_angle_from_up(p) <= spec["half_angle"])
    if kind == "cut_disk":
        return (np.hypot(x, y) <= r) & (y >= spec["cut_height"])
    if kind == "arc":
        return _dense_distance(p, _arc_curve(r, spec["half_angle"])) <= spec["thickness"] / 2
    if kind == "ring":
        return ((np.abs(np.hypot(x, y) - r) <= spec["thickness"] / 2)
                & (_angle_from_up(p) <= spec["half_angle"]))
    if kind == "horseshoe":
        t, w, length = spec["half_opening"], spec["thickness"] / 2, spec["length"]
        sector = (np.abs(np.hypot(x, y) - r) <= w) & (_angle_from_up(p) >= t)
        u = -math.cos(t) * np.abs(x) + math.sin(t) * y
        v = math.sin(t) * np.abs(x) + math.cos(t) * y
        return sector | ((u >= 0) & (u <= length) & (np.abs(v - r) <= w))
    if kind == "vesica":
        d = spec["distance"]
        return (np.hypot(x - d, y) <= r) & (np.hypot(x + d, y) <= r)
    if kind == "moon":
        return (np.hypot(x, y) <= r) & (np.hypot(x - spec["distance"], y) >= spec["bite_radius"])
    if kind == "egg":
        rb = spec["top_radius"]
        core_r = r - rb
        th = np.linspace(0.0, math.pi / 3, 4001)
        core_boundary = np.concatenate([
            core_r * np.column_stack([np.cos(3 * th), -np.sin(3 * th)]),
            np.column_stack([core_r * (2 * np.cos(th) - 1), 2 * core_r * np.sin(th)]),
            np.column_stack([core_r * (1 - 2 * np.cos(th)), 2 * core_r * np.sin(th)])])
        core = np.where(y < 0, np.hypot(x, y) <= core_r,
                        (np.hypot(x + core_r, y) <= 2 * core_r) & (np.hypot(x - core_r, y) <= 2 * core_r))
        return core | (_dense_distance(p, core_boundary) <= rb)
    if kind == "heart":
        q = p / spec["scale"]
        lobe = math.sqrt(2) / 4
        lobes = ((np.hypot(q[:, 0] - 0.25, q[:, 1] - 0.75) <= lobe)
                 | (np.hypot(q[:, 0] + 0.25, q[:, 1] - 0.75) <= lobe))
        square = (q[:, 1] >= np.abs(q[:, 0])) & (q[:, 1] <= 1 - np.abs(q[:, 0]))
        return lobes | square
    if kind == "ellipse":
        w, h = spec["size"]
        return (x / (w / 2)) ** 2 + (y / (h / 2)) ** 2 <= 1
    if kind == "quadratic_bezier":
        curve = _bezier_curve(spec["a"], spec["b"], spec["c"], np.linspace(0, 1, 10001))
        return _dense_distance(p, curve) <= spec.get("radius", 0.0)
    if kind == "capsule":
        a, b = np.array(spec["a"]), np.array(spec["b"])
        return _dense_distance(p, a + np.linspace(0, 1, 10001)[:, None] * (b - a)) <= r
    if kind == "segment":
        return np.zeros(len(p), dtype=bool)
    raise AssertionError(kind)


# --------------------------------------------------------------------------------------
# Generic properties
# --------------------------------------------------------------------------------------

def test_all_curved_primitives_are_registered():
    assert set(CURVED) <= set(PRIMITIVES)


@pytest.mark.parametrize("spec", EXACT_SPECS, ids=_ids(EXACT_SPECS))
def test_exact_fields_pass_the_generic_checks(spec, rng):
    f = field(spec)
    assert f.exact
    check_field(f, rng)


@pytest.mark.parametrize("spec", EXACT_SPECS + BOUND_SPECS, ids=_ids(EXACT_SPECS + BOUND_SPECS))
def test_sign_matches_the_set_definition(spec, rng):
    f = field(spec)
    p = sample_points(f, 600, rng, pad=0.3)
    d = f.distance(p)
    x0, y0, x1, y1 = f.bounds()
    clear = np.abs(d) > 1e-3 * max(x1 - x0, y1 - y0)   # away from the boundary
    np.testing.assert_array_equal(d[clear] < 0, inside(spec, p[clear]))


@pytest.mark.parametrize("spec", EXACT_SPECS + BOUND_SPECS, ids=_ids(EXACT_SPECS + BOUND_SPECS))
def test_bounds_contain_the_shape_and_are_tight(spec, rng):
    f = field(spec)
    box = f.bounds()
    p = sample_points(f, 20000, rng, pad=0.5)
    inner = p[f.distance(p) <= 0]
    assert np.all(inner >= box[:2]) and np.all(inner <= box[2:])
    edge = boundary_samples(f, rng)
    assert np.all(edge >= box[:2] - 1e-9) and np.all(edge <= box[2:] + 1e-9)
    size = max(box[2] - box[0], box[3] - box[1])
    np.testing.assert_allclose(np.concatenate([edge.min(axis=0), edge.max(axis=0)]), box,
                               atol=0.01 * size)


@pytest.mark.parametrize("spec", BOUND_SPECS, ids=_ids(BOUND_SPECS))
def test_bound_fields_never_overestimate_the_distance(spec, rng):
    f = field(spec)
    assert not f.exact
    check_field(f, rng)
    p = sample_points(f, 300, rng, pad=0.3)
    d = f.distance(p)
    edge = boundary_samples(f, rng, n=40000)
    nearest = np.min(np.linalg.norm(p[:, None] - edge[None], axis=2), axis=1)
    assert np.all(np.abs(d) <= nearest + 1e-9)


def test_thick_arc_is_flagged_because_it_underestimates_inside():
    # Caps of radius 0.9 at (+-0.707, -0.707) overlap below the centre: between
    # them f = 0.707 - 0.9, but the boundary is 0.557 away (straight down).
    f = field({"type": "arc", "half_angle": 3 * QUARTER, "radius": 1.0, "thickness": 1.8})
    d = f.distance(np.array([[0.0, -SQ2 / 2]]))
    np.testing.assert_allclose(d, SQ2 / 2 - 0.9, rtol=1e-12)
    down = math.sqrt(0.81 - 0.5)
    np.testing.assert_allclose(f.distance(np.array([[0.0, -SQ2 / 2 - down]])), 0.0, atol=1e-12)
    assert abs(d[0]) < down - 0.3


@pytest.mark.parametrize("spec, exact", [
    ({"type": "arc", "half_angle": math.pi / 2, "radius": 1.0, "thickness": 2.0}, True),
    ({"type": "arc", "half_angle": math.pi / 2, "radius": 1.0, "thickness": 2.01}, False),
    ({"type": "arc", "half_angle": 3 * QUARTER, "radius": 1.0, "thickness": 1.4}, True),
    ({"type": "arc", "half_angle": 3 * QUARTER, "radius": 1.0, "thickness": 1.42}, False),
    ({"type": "arc", "half_angle": math.pi, "radius": 1.0, "thickness": 2.0}, True),
    # y = (1 - x^2) / 2: smallest radius of curvature 1, at the vertex.
    ({"type": "quadratic_bezier", "a": [-1, 0], "b": [0, 1], "c": [1, 0], "radius": 1.0}, True),
    ({"type": "quadratic_bezier", "a": [-1, 0], "b": [0, 1], "c": [1, 0], "radius": 1.01}, False),
    ({"type": "quadratic_bezier", "a": [0, 0], "b": [1, 0], "c": [3, 0], "radius": 5.0}, True),
])
def test_exact_flag_follows_the_reach(spec, exact):
    assert field(spec).exact is exact


def test_empty_batches():
    for name in CURVED:
        spec = next((s for s in EXACT_SPECS if s["type"] == name), {"type": "circle", "radius": 1})
        d, g = field(spec).evaluate(np.zeros((0, 2)))
        assert d.shape == (0,) and g.shape == (0, 2)


# --------------------------------------------------------------------------------------
# Hand-computed values
# --------------------------------------------------------------------------------------

MOON_HORN = (0.61, math.sqrt(1 - 0.61 ** 2))   # radius 1, bite 0.8 at distance 0.5
EGG_APEX = math.sqrt(3) * 0.7                   # radius 1, top radius 0.3

VALUES = [
    ({"type": "segment", "a": [0, 0], "b": [2, 0]},
     [(1, 1, 1), (3, 0, 1), (-1, -1, SQ2), (1, 0, 0), (0.5, -0.25, 0.25)]),
    ({"type": "capsule", "a": [0, 0], "b": [2, 0], "radius": 0.5},
     [(1, 1, 0.5), (1, 0, -0.5), (3, 0, 0.5), (-0.3, 0.4, 0.0), (2, -0.2, -0.3)]),
    ({"type": "uneven_capsule", "bottom_radius": 1.0, "top_radius": 0.5, "height": 2.0},
     [(0, -3, 2), (0, 4, 1.5), (0, 0, -1), (0, 2, -0.5),
      (math.sqrt(15) / 4 * 1.3, 0.25 * 1.3, 0.3)]),   # along the side's normal (cos t, sin t)
    ({"type": "pie", "half_angle": QUARTER, "radius": 1.0},
     [(0, 0.5, -0.5 / SQ2), (0, 2, 1), (0, -1, 1), (1, 0, 1 / SQ2), (0, 0, 0), (0, 1, 0)]),
    ({"type": "pie", "half_angle": math.pi, "radius": 1.0},
     [(0.3, -0.4, -0.5), (0, -2, 1)]),
    ({"type": "cut_disk", "radius": 1.0, "cut_height": 0.5},
     [(0, 0, 0.5), (0, 0.7, -0.2), (0, 2, 1), (2, 0.5, 2 - math.sqrt(0.75)), (0, 0.5, 0)]),
    ({"type": "arc", "half_angle": math.pi / 2, "radius": 1.0, "thickness": 0.2},
     [(0, 1, -0.1), (0, 0, 0.9), (0, -1, SQ2 - 0.1), (1.5, 0, 0.4), (-1, -0.3, 0.2)]),
    ({"type": "ring", "half_angle": math.pi / 2, "radius": 1.0, "thickness": 0.2},
     [(0, 1, -0.1), (0, 0, 0.9), (1, -0.5, 0.5), (-1, -0.05, 0.05), (1.2, -1, math.hypot(0.1, 1))]),
    ({"type": "horseshoe", "half_opening": math.pi / 2, "radius": 1.0, "length": 1.0,
      "thickness": 0.2},
     [(1, 0.5, -0.1), (-1, 1.5, 0.5), (0, -1, -0.1), (0, 0, 0.9), (1.3, 0.5, 0.2),
      (0, 0.5, 0.9), (-1.05, 0.98, -0.02), (1.2, 1.1, math.hypot(0.1, 0.1))]),
    ({"type": "vesica", "radius": 1.0, "distance": 0.6},
     [(0, 0, -0.4), (0, 0.8, 0), (0, -1.8, 1), (1, 0, 0.6), (-0.2, 0, -0.2)]),
    ({"type": "moon", "radius": 1.0, "bite_radius": 0.8, "distance": 0.5},
     [(-0.5, 0, -0.2), (0.5, 0, 0.8), (-2, 0, 1), (MOON_HORN[0], -MOON_HORN[1], 0),
      (MOON_HORN[0] + 0.5, MOON_HORN[1], 0.5)]),   # within the horn's normal cone
    ({"type": "egg", "radius": 1.0, "top_radius": 0.3},
     [(0, -2, 1), (0, 0, -1), (0, EGG_APEX + 0.8, 0.5), (0, -1, 0), (1.5, 0, 0.5)]),
    ({"type": "heart", "scale": 1.0},
     [(0, 0, 0), (0, -1, 1), (0, 1, 0), (0, 0.5, -0.5 / SQ2),
      (-0.25, 0.75 + SQ2 / 4, 0), (1, 0, 1 / SQ2), (0, 1.2, math.hypot(0.25, 0.45) - SQ2 / 4)]),
    ({"type": "heart", "scale": 2.0}, [(0, 1, -1 / SQ2), (0, -2, 2)]),
    ({"type": "ellipse", "size": [4.0, 2.0]},
     [(3, 0, 1), (0, -2, 1), (0, 0, -1), (0, 0.5, -0.5), (-2.5, 0, 0.5),
      (1, 0, -math.sqrt(6) / 3),   # inside the evolute: closest (4/3, sqrt(5)/3)
      (2, 1, None)]),
    ({"type": "ellipse", "size": [2.0, 6.0]}, [(0, 4, 1), (2, 0, 1), (0, 0, -1)]),
    ({"type": "quadratic_bezier", "a": [-1, 0], "b": [0, 1], "c": [1, 0]},   # y = (1 - x^2) / 2
     [(0, 0.5, 0), (0, 2, 1.5), (0, -1, SQ2), (2, 0, 1), (0.5, 0.375, 0)]),
    ({"type": "quadratic_bezier", "a": [-1, 0], "b": [0, 1], "c": [1, 0], "radius": 0.25},
     [(0, 2, 1.25), (0, 0.5, -0.25)]),
]


@pytest.mark.parametrize("spec, cases", VALUES, ids=[s["type"] for s, _ in VALUES])
def test_values_at_hand_computed_points(spec, cases):
    f = field(spec)
    cases = [c for c in cases if c[2] is not None]
    p = np.array([c[:2] for c in cases], dtype=float)
    np.testing.assert_allclose(f.distance(p), [c[2] for c in cases], rtol=0, atol=1e-12)


def test_ellipse_point_outside_the_corner_of_its_box():
    # For (2, 1) and semi-axes (2, 1) the closest point (2 cos t, sin t) solves
    # 2 sin t = cos t ... checked here against the normal condition instead.
    f = field({"type": "ellipse", "size": [4.0, 2.0]})
    d, g = f.evaluate(np.array([[2.0, 1.0]]))
    q = np.array([2.0, 1.0]) - d[0] * g[0]
    np.testing.assert_allclose((q[0] / 2) ** 2 + q[1] ** 2, 1.0, atol=1e-14)
    normal = np.array([q[0] / 4, q[1]]) / np.hypot(q[0] / 4, q[1])
    np.testing.assert_allclose(g[0], normal, atol=1e-14)


GRADIENTS = [
    ({"type": "segment", "a": [0, 0], "b": [2, 0]},
     [(1, 1, (0, 1)), (3, 0, (1, 0)), (1, -0.5, (0, -1)), (1, 0, (0, 1))]),
    ({"type": "pie", "half_angle": QUARTER, "radius": 1.0},
     [(0, 0.5, (1 / SQ2, -1 / SQ2)), (-0.1, 0.5, (-1 / SQ2, -1 / SQ2)), (0, 2, (0, 1)),
      (0, 0, (1 / SQ2, -1 / SQ2))]),
    ({"type": "cut_disk", "radius": 1.0, "cut_height": 0.5},
     [(0, 0, (0, -1)), (0, 0.7, (0, -1)), (0.6, 0.8, (0.6, 0.8))]),
    ({"type": "ring", "half_angle": math.pi / 2, "radius": 1.0, "thickness": 0.2},
     [(1, -0.5, (0, -1)), (-1, -0.05, (0, -1)), (0, 0.95, (0, -1)), (0, 1.02, (0, 1))]),
    ({"type": "horseshoe", "half_opening": math.pi / 2, "radius": 1.0, "length": 1.0,
      "thickness": 0.2},
     [(1, 0.5, (1, 0)), (0.95, 0.5, (-1, 0)), (-1, 1.5, (0, 1)), (0, -1.05, (0, -1))]),
    ({"type": "heart", "scale": 1.0},
     [(0.3, 0.2, (1 / SQ2, -1 / SQ2)), (-0.3, 0.2, (-1 / SQ2, -1 / SQ2)), (0, 0, (1 / SQ2, -1 / SQ2)),
      (0, 1, (0, 1)), (0, 0.9, (0, 1))]),
    ({"type": "ellipse", "size": [4.0, 2.0]},
     [(3, 0, (1, 0)), (0, -2, (0, -1)), (0, 0, (0, 1)),
      (-1, 0, (-1 / math.sqrt(6), math.sqrt(5 / 6)))]),   # normal at (-4/3, sqrt(5)/3)
    ({"type": "quadratic_bezier", "a": [-1, 0], "b": [0, 1], "c": [1, 0]},
     [(0, 2, (0, 1)), (0, 0.2, (0, -1)), (2, 0, (1, 0)), (0, 0.5, (0, 1))]),
]


@pytest.mark.parametrize("spec, cases", GRADIENTS, ids=[s["type"] for s, _ in GRADIENTS])
def test_gradients_at_hand_computed_points(spec, cases):
    f = field(spec)
    p = np.array([c[:2] for c in cases], dtype=float)
    np.testing.assert_allclose(f.evaluate(p)[1], [c[2] for c in cases], rtol=0, atol=1e-12)


# --------------------------------------------------------------------------------------
# Degenerate points: centres, apexes, corners, cusps, medial axes, points on curves
# --------------------------------------------------------------------------------------

DEGENERATE = [
    ({"type": "segment", "a": [0, 0], "b": [2, 0]}, [(0, 0), (1, 0), (2, 0)]),
    ({"type": "segment", "a": [1, 1], "b": [1, 1]}, [(1, 1), (0, 0)]),
    ({"type": "capsule", "a": [0, 0], "b": [2, 0], "radius": 0.5}, [(0, 0), (1, 0), (2, 0)]),
    ({"type": "uneven_capsule", "bottom_radius": 1.0, "top_radius": 0.5, "height": 2.0},
     [(0, 0), (0, 2), (0, 1)]),
    ({"type": "pie", "half_angle": QUARTER, "radius": 1.0},
     [(0, 0), (0, 0.5), (1 / SQ2, 1 / SQ2), (0, 1)]),
    ({"type": "pie", "half_angle": math.pi, "radius": 1.0}, [(0, 0), (0, -1), (0, -0.5)]),
    ({"type": "cut_disk", "radius": 1.0, "cut_height": 0.6}, [(0, 0), (0.8, 0.6), (-0.8, 0.6)]),
    ({"type": "arc", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3},
     [(0, 0), (0, 1), (math.sin(1), math.cos(1))]),
    ({"type": "arc", "half_angle": math.pi, "radius": 1.0, "thickness": 0.3}, [(0, 0), (0, -1)]),
    ({"type": "ring", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3},
     [(0, 0), (0, 1), (math.sin(1), math.cos(1)), (1.15 * math.sin(1), 1.15 * math.cos(1))]),
    ({"type": "horseshoe", "half_opening": 1.0, "radius": 1.0, "length": 0.5, "thickness": 0.3},
     [(0, 0), (0, -1), (math.sin(1), math.cos(1))]),
    ({"type": "vesica", "radius": 1.0, "distance": 0.6},
     [(0, 0), (0, 0.8), (0, -0.8), (0.6, 0), (-0.6, 0)]),
    ({"type": "vesica", "radius": 1.0, "distance": 0.0}, [(0, 0)]),
    ({"type": "moon", "radius": 1.0, "bite_radius": 0.8, "distance": 0.5},
     [(0, 0), (0.5, 0), MOON_HORN, (MOON_HORN[0], -MOON_HORN[1])]),
    ({"type": "egg", "radius": 1.0, "top_radius": 0.3},
     [(0, 0), (0, EGG_APEX), (0.7, 0), (-0.7, 0)]),
    ({"type": "egg", "radius": 1.0, "top_radius": 0.0}, [(0, EGG_APEX)]),
    ({"type": "heart", "scale": 1.0}, [(0, 0), (0, 1), (0.25, 0.75), (-0.25, 0.75), (0.5, 0.5)]),
    ({"type": "ellipse", "size": [4.0, 2.0]},
     [(0, 0), (1.5, 0), (-1.5, 0), (math.sqrt(3), 0), (0, 1e-300), (1.5, 1e-300), (2, 0)]),
    ({"type": "ellipse", "size": [1.0, 1.0]}, [(0, 0)]),
    ({"type": "quadratic_bezier", "a": [-1, 0], "b": [0, 1], "c": [1, 0]},
     [(-1, 0), (0, 1), (1, 0), (0, 0.5), (0, -0.5)]),
    ({"type": "quadratic_bezier", "a": [0, 0], "b": [2, 0], "c": [1, 0]},   # folds back at t = 2/3
     [(4 / 3, 0), (1, 0), (0, 0)]),
    ({"type": "quadratic_bezier", "a": [0, 0], "b": [1, 0], "c": [2, 0]}, [(1, 0), (1, 1)]),
    ({"type": "quadratic_bezier", "a": [1, 1], "b": [1, 1], "c": [1, 1]}, [(1, 1), (2, 1)]),
]


# The documented choices where the gradient is undefined.
FALLBACKS = [
    ({"type": "segment", "a": [0, 0], "b": [2, 0]}, (1, 0), (0, 1)),
    ({"type": "capsule", "a": [0, 0], "b": [0, -2], "radius": 0.5}, (0, -1), (1, 0)),
    ({"type": "uneven_capsule", "bottom_radius": 1.0, "top_radius": 0.5, "height": 2.0},
     (0, 0), (math.sqrt(15) / 4, 0.25)),
    ({"type": "pie", "half_angle": QUARTER, "radius": 1.0}, (0, 0), (1 / SQ2, -1 / SQ2)),
    ({"type": "cut_disk", "radius": 1.0, "cut_height": 0.6}, (-0.8, 0.6), (-0.8, 0.6)),
    ({"type": "arc", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3}, (0, 0), (0, -1)),
    ({"type": "arc", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3}, (0, 1), (0, 1)),
    ({"type": "ring", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3}, (0, 0), (0, -1)),
    ({"type": "horseshoe", "half_opening": 1.0, "radius": 1.0, "length": 0.5, "thickness": 0.3},
     (0, 0), (0, 1)),
    ({"type": "vesica", "radius": 1.0, "distance": 0.6}, (0, -0.8), (0.6, -0.8)),
    ({"type": "vesica", "radius": 1.0, "distance": 0.0}, (0, 0), (1, 0)),
    ({"type": "egg", "radius": 1.0, "top_radius": 0.3}, (0, EGG_APEX), (0, 1)),
    ({"type": "heart", "scale": 1.0}, (0, 0), (1 / SQ2, -1 / SQ2)),
    ({"type": "heart", "scale": 1.0}, (0, 1), (0, 1)),
    ({"type": "ellipse", "size": [4.0, 2.0]}, (0, 0), (0, 1)),
    ({"type": "ellipse", "size": [2.0, 4.0]}, (0, 0), (1, 0)),
    ({"type": "ellipse", "size": [2.0, 2.0]}, (0, 0), (1, 0)),
    ({"type": "quadratic_bezier", "a": [-1, 0], "b": [0, 1], "c": [1, 0]}, (0, 0.5), (0, 1)),
    ({"type": "quadratic_bezier", "a": [-1, 0], "b": [0, 1], "c": [1, 0]}, (1, 0),
     (1 / SQ2, 1 / SQ2)),
]


@pytest.mark.parametrize("spec, point, gradient", FALLBACKS,
                         ids=[s["type"] for s, _, _ in FALLBACKS])
def test_documented_gradient_at_degenerate_points(spec, point, gradient):
    g = field(spec).evaluate(np.array([point], dtype=float))[1]
    np.testing.assert_allclose(g[0], gradient, atol=1e-15)


@pytest.mark.parametrize("spec, points", DEGENERATE, ids=[s["type"] for s, _ in DEGENERATE])
def test_degenerate_points_give_finite_unit_deterministic_gradients(spec, points):
    f = field(spec)
    p = np.array(points, dtype=float)
    d, g = f.evaluate(p)
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(g))
    np.testing.assert_allclose(np.linalg.norm(g, axis=1), 1.0, atol=1e-12)
    # The same point gives the same answer alone, repeated, or in another order.
    for i in range(len(p)):
        d1, g1 = f.evaluate(np.repeat(p[i:i + 1], 3, axis=0))
        np.testing.assert_array_equal(d1, d[i])
        np.testing.assert_array_equal(g1, np.repeat(g[i:i + 1], 3, axis=0))
    d2, g2 = f.evaluate(p[::-1])
    np.testing.assert_array_equal(d2[::-1], d)
    np.testing.assert_array_equal(g2[::-1], g)


def test_points_on_the_boundary_get_the_outward_normal():
    # Exactly on an edge or arc (f = 0) the gradient is the surface normal, not a
    # direction from round-off.
    cases = [
        ({"type": "pie", "half_angle": QUARTER, "radius": 1.0}, (0.3, 0.3), (1 / SQ2, -1 / SQ2)),
        ({"type": "cut_disk", "radius": 1.0, "cut_height": 0.5}, (0.1, 0.5), (0, -1)),
        ({"type": "ring", "half_angle": math.pi / 2, "radius": 1.0, "thickness": 0.2},
         (0.95, 0), (0, -1)),
        ({"type": "heart", "scale": 1.0}, (0.2, 0.2), (1 / SQ2, -1 / SQ2)),
        ({"type": "vesica", "radius": 1.0, "distance": 0.6}, (0.4, 0), (1, 0)),
        ({"type": "moon", "radius": 1.0, "bite_radius": 0.8, "distance": 0.5}, (-0.3, 0), (1, 0)),
    ]
    for spec, point, normal in cases:
        d, g = field(spec).evaluate(np.array([point], dtype=float))
        np.testing.assert_allclose(d, 0.0, atol=1e-15)
        np.testing.assert_allclose(g[0], normal, atol=1e-15)


# --------------------------------------------------------------------------------------
# Ellipse and Bezier against brute force (dense sampling, then ternary refinement)
# --------------------------------------------------------------------------------------

def _brute_force_distance(p, curve, lo, hi, n=4001, rounds=60):
    """min over s in [lo, hi] of |p - curve(s)| for each row of p, to round-off.

    Every local minimum of the densely sampled distance is refined by ternary
    search within one sample spacing (two minima can be closer in value than the
    sampling error, so refining only the best sample is not enough).
    """
    s = np.linspace(lo, hi, n)
    h = (hi - lo) / (n - 1)
    samples = curve(s)
    out = []
    for x in p:
        d = np.linalg.norm(samples - x, axis=1)
        padded = np.concatenate([[np.inf], d, [np.inf]])
        minima = s[(d <= padded[:-2]) & (d <= padded[2:])]
        a, b = np.maximum(minima - h, lo), np.minimum(minima + h, hi)
        for _ in range(rounds):
            m1, m2 = a + (b - a) / 3, b - (b - a) / 3
            left = np.linalg.norm(curve(m1) - x, axis=1) <= np.linalg.norm(curve(m2) - x, axis=1)
            a, b = np.where(left, a, m1), np.where(left, m2, b)
        out.append(np.min(np.linalg.norm(curve((a + b) / 2) - x, axis=1)))
    return np.array(out)


@pytest.mark.parametrize("size", [[4.0, 2.0], [0.6, 5.0], [10.0, 0.1], [1.0, 1.0 - 1e-9]])
def test_ellipse_matches_brute_force(size, rng):
    a, b = size[0] / 2, size[1] / 2
    f = field({"type": "ellipse", "size": size})
    big = max(a, b)
    e = abs(a * a - b * b) / big
    p = np.concatenate([
        (rng.random((60, 2)) * 2 - 1) * [a * 1.5, b * 1.5],
        (rng.random((20, 2)) * 2 - 1) * 6 * big,
        # near the major axis inside, around the evolute's cusp
        np.column_stack([e * rng.uniform(0.5, 1.5, 20), 10.0 ** rng.uniform(-12, -2, 20) * min(a, b)])
        if a >= b else
        np.column_stack([10.0 ** rng.uniform(-12, -2, 20) * min(a, b), e * rng.uniform(0.5, 1.5, 20)]),
    ])

    def curve(s):
        return np.column_stack([a * np.cos(s), b * np.sin(s)])
    # The parameter range overlaps itself so that no minimum sits at its ends.
    truth = _brute_force_distance(p, curve, -math.pi - 0.5, math.pi + 0.5, n=10001)
    d = f.distance(p)
    np.testing.assert_allclose(np.abs(d), truth, rtol=0, atol=1e-11 * big)
    np.testing.assert_array_equal(d < 0, (p[:, 0] / a) ** 2 + (p[:, 1] / b) ** 2 < 1)


BEZIERS = [
    ([-1, 0], [0, 1], [1, 0]),
    ([-1, -1], [2, 1.5], [0.5, -0.2]),
    ([0, 0], [3, 0.2], [0, 0.4]),            # sharp turn
    ([-1, 0], [0, 1e-7], [1, 0]),            # nearly straight
    ([-1, 0], [0, 0], [1, 0]),               # straight, B = 0
    ([0, 0], [2, 0], [1, 0]),                # collinear, folds back
    ([0, 0], [0, 0], [1, 1]),                # a == b
]


@pytest.mark.parametrize("a, b, c", BEZIERS)
def test_quadratic_bezier_matches_brute_force(a, b, c, rng):
    f = field({"type": "quadratic_bezier", "a": a, "b": b, "c": c})
    p = sample_points(f, 150, rng, pad=0.6)
    truth = _brute_force_distance(p, lambda t: _bezier_curve(a, b, c, t), 0.0, 1.0)
    np.testing.assert_allclose(f.distance(p), truth, rtol=0, atol=1e-11)


def test_quadratic_bezier_random_curves_match_brute_force(rng):
    for _ in range(6):
        a, b, c = rng.standard_normal((3, 2))
        f = field({"type": "quadratic_bezier", "a": list(a), "b": list(b), "c": list(c)})
        p = sample_points(f, 50, rng, pad=0.6)
        truth = _brute_force_distance(p, lambda t, ctrl=(a, b, c): _bezier_curve(*ctrl, t),
                                      0.0, 1.0)
        np.testing.assert_allclose(f.distance(p), truth, rtol=0, atol=1e-11)


# --------------------------------------------------------------------------------------
# pymunk's point queries as an independent implementation
# --------------------------------------------------------------------------------------

def _pymunk_query(shape, points):
    shape.cache_bb()
    info = [shape.point_query(tuple(x)) for x in points]
    return np.array([i.distance for i in info]), np.array([tuple(i.gradient) for i in info])


def test_circle_matches_pymunk(rng):
    body = pymunk.Body(body_type=pymunk.Body.STATIC)
    shape = pymunk.Circle(body, 0.7, (0.4, -0.2))
    f = field({"type": "circle", "radius": 0.7, "offset": [0.4, -0.2]})
    p = rng.uniform(-2, 2, (300, 2))
    d_ref, g_ref = _pymunk_query(shape, p)
    d, g = f.evaluate(p)
    np.testing.assert_allclose(d, d_ref, atol=1e-12)
    np.testing.assert_allclose(g, g_ref, atol=1e-12)


@pytest.mark.parametrize("radius", [0.0, 0.35])
def test_segment_and_capsule_match_pymunk(radius, rng):
    a, b = (-0.8, 0.3), (1.1, -0.4)
    body = pymunk.Body(body_type=pymunk.Body.STATIC)
    shape = pymunk.Segment(body, a, b, radius)
    spec = ({"type": "capsule", "a": a, "b": b, "radius": radius} if radius
            else {"type": "segment", "a": a, "b": b})
    f = field(spec)
    p = rng.uniform(-2, 2, (300, 2))
    d_ref, g_ref = _pymunk_query(shape, p)
    d, g = f.evaluate(p)
    np.testing.assert_allclose(d, d_ref, atol=1e-12)
    off_axis = d_ref + radius > 1e-6   # on the segment itself the gradient is a choice
    np.testing.assert_allclose(g[off_axis], g_ref[off_axis], atol=1e-9)


# --------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("spec, message", [
    ({"type": "vesica", "radius": 1.0, "distance": 1.0},
     "field.distance: must be in [0, radius) = [0, 1), got 1"),
    ({"type": "vesica", "radius": 1.0, "distance": -0.1}, "field.distance: must be >= 0"),
    ({"type": "pie", "half_angle": 3.5, "radius": 1.0}, "field.half_angle: must be <= pi"),
    ({"type": "pie", "half_angle": 0.0, "radius": 1.0}, "field.half_angle: must be > 0"),
    ({"type": "pie", "half_angle": 1.0}, "field.radius: is required for 'pie'"),
    ({"type": "cut_disk", "radius": 1.0, "cut_height": 1.0},
     "field.cut_height: must be in (-radius, radius) = (-1, 1), got 1"),
    ({"type": "cut_disk", "radius": 1.0, "cut_height": -1.5}, "field.cut_height: must be in"),
    ({"type": "uneven_capsule", "bottom_radius": 1.0, "top_radius": 0.4, "height": 0.5},
     "field.height: must be > |bottom_radius - top_radius| = 0.6"),
    ({"type": "arc", "half_angle": 4.0, "radius": 1.0, "thickness": 0.1},
     "field.half_angle: must be <= pi"),
    ({"type": "arc", "half_angle": 1.0, "radius": 1.0, "thickness": 0.0},
     "field.thickness: must be > 0"),
    ({"type": "ring", "half_angle": 1.0, "radius": 1.0, "thickness": 2.0},
     "field.thickness: must be < 2 * radius = 2, got 2"),
    ({"type": "horseshoe", "half_opening": math.pi, "radius": 1.0, "length": 1.0,
      "thickness": 0.2}, "field.half_opening: must be < pi"),
    ({"type": "horseshoe", "half_opening": 0.3, "radius": 1.0, "length": 1.0,
      "thickness": 0.2}, "field.length: the legs would cross the y axis: must be <= "),
    ({"type": "horseshoe", "half_opening": 1.0, "radius": 1.0, "length": -1.0,
      "thickness": 0.2}, "field.length: must be >= 0"),
    ({"type": "horseshoe", "half_opening": 1.0, "radius": 1.0, "length": 1.0,
      "thickness": 2.5}, "field.thickness: must be < 2 * radius"),
    ({"type": "moon", "radius": 1.0, "bite_radius": 0.5, "distance": 0.4},
     "field.distance: the circles must cross"),
    ({"type": "moon", "radius": 1.0, "bite_radius": 0.5, "distance": 1.5},
     "field.distance: the circles must cross"),
    ({"type": "egg", "radius": 1.0, "top_radius": 1.0},
     "field.top_radius: must be in [0, radius) = [0, 1), got 1"),
    ({"type": "heart", "scale": -2.0}, "field.scale: must be > 0"),
    ({"type": "ellipse", "size": [1.0, 0.0]}, "field.size[1]: must be > 0"),
    ({"type": "quadratic_bezier", "a": [0, 0], "b": [1, 1], "c": [2, 0], "radius": -0.1},
     "field.radius: must be >= 0"),
    ({"type": "quadratic_bezier", "a": [0, 0], "b": [1, 1]}, "field.c: is required"),
    ({"type": "segment", "a": [0, 0], "b": [1]}, "field.b: must be a pair [x, y]"),
    ({"type": "capsule", "a": [0, 0], "b": [1, 0], "radius": 0.0}, "field.radius: must be > 0"),
    ({"type": "pie", "half_angel": 1.0, "radius": 1.0},
     "field.half_angel: unknown key for 'pie' (did you mean 'half_angle'?)"),
])
def test_bad_parameters_name_the_key_path(spec, message):
    with pytest.raises(sdfphys.SpecError) as err:
        field(spec)
    assert str(err.value).startswith(message), str(err.value)


def test_constructors_reject_impossible_combinations_directly():
    with pytest.raises(ValueError, match="distance"):
        PRIMITIVES["vesica"](radius=1.0, distance=2.0)
    with pytest.raises(ValueError, match="half_angle"):
        PRIMITIVES["ring"](half_angle=7.0, radius=1.0, thickness=0.1)


def test_placement_applies_to_curved_primitives():
    f = field({"type": "pie", "half_angle": QUARTER, "radius": 1.0, "angle": math.pi,
               "offset": [2.0, 0.0]})
    # Turned upside down: the sector now opens towards -y from its apex at (2, 0).
    np.testing.assert_allclose(f.distance(np.array([[2.0, -0.5], [2.0, 0.5]])),
                               [-0.5 / SQ2, 0.5], atol=1e-12)
