"""Operators: exact answers where they are exact, bounds where they are not, gradients,
boxes, spec building and the absence of NaN at ties and on medial axes."""

import math

import numpy as np
import pytest
from fieldcheck import check_field, sample_points

import sdfphys
from sdfphys.sdf import OPERATORS, PRIMITIVES, Field, field
from sdfphys.sdf.operators import BLENDS, level_bounds, smooth_min

CIRCLE = PRIMITIVES["circle"]
BOX = PRIMITIVES["box"]


def circle(r, x=0.0, y=0.0):
    return field({"type": "circle", "radius": r, "offset": [x, y]})


def box(w, h, x=0.0, y=0.0, angle=0.0):
    return field({"type": "box", "size": [w, h], "offset": [x, y], "angle": angle})


def outline_distance(p, c0, r0, c1, r1, keep_inside):
    """Exact distance from points p (N, 2) to the outline of the union (keep_inside False)
    or of the intersection (True) of two crossing circles: the arc of each circle that
    lies outside (or inside) the other one. Where the radial projection of p falls off
    the arc, the nearest arc point is one of the two crossing points."""
    c0, c1 = np.asarray(c0, float), np.asarray(c1, float)
    axis = c1 - c0
    span = np.linalg.norm(axis)
    along = (span**2 + r0**2 - r1**2) / (2 * span)
    half = math.sqrt(r0**2 - along**2)
    u = axis / span
    crossings = c0 + along * u + half * np.array([[-u[1], u[0]], [u[1], -u[0]]])
    to_cross = np.min(np.linalg.norm(p[:, None] - crossings[None], axis=2), axis=1)
    out = np.full(len(p), np.inf)
    for c, r, other, ro in ((c0, r0, c1, r1), (c1, r1, c0, r0)):
        rho = np.linalg.norm(p - c, axis=1)
        q = c + r * (p - c) / rho[:, None]
        on_arc = (np.linalg.norm(q - other, axis=1) <= ro) == keep_inside
        out = np.minimum(out, np.where(on_arc, np.abs(rho - r), to_cross))
    return out


class ClaimedExact(Field):
    """A field re-labelled exact, to run fieldcheck's exactness checks on a special case."""

    exact = True

    def __init__(self, of):
        self.of = of

    def evaluate(self, points):
        return self.of.evaluate(points)

    def bounds(self):
        return self.of.bounds()


def assert_level_bounds_contain(f, rng, level=0.0, n=40000, minimum=200):
    """Random points with f <= level (at least ``minimum``) lie in level_bounds(level)."""
    x0, y0, x1, y1 = level_bounds(f, level)
    w, h = max(x1 - x0, 1.0), max(y1 - y0, 1.0)
    lo = np.array([x0 - w, y0 - h])
    p = lo + np.array([x1 - x0 + 2 * w, y1 - y0 + 2 * h]) * rng.random((n, 2))
    inside = p[f.distance(p) <= level]
    assert len(inside) >= minimum
    assert np.all(inside >= [x0, y0]) and np.all(inside <= [x1, y1])


# --------------------------------------------------------------------------------------
# Boolean operators against exact answers.
# --------------------------------------------------------------------------------------

def test_union_is_exact_outside_and_a_bound_inside(rng):
    f = OPERATORS["union"]([circle(1.0), circle(0.8, 1.0, 0.3)])
    assert not f.exact
    p = sample_points(f, 4000, rng)
    d = f.distance(p)
    true = outline_distance(p, (0, 0), 1.0, (1.0, 0.3), 0.8, keep_inside=False)
    out = d > 0
    assert out.sum() > 1000 and (~out).sum() > 200
    np.testing.assert_allclose(d[out], true[out], rtol=0, atol=1e-12)
    assert np.all(-d[~out] <= true[~out] + 1e-12)
    # Strictly inside: midway between two unit circles 1 apart f = -0.5, but the outline
    # is 0.866 away (the points where the two arcs meet).
    g = OPERATORS["union"]([circle(1.0), circle(1.0, 1.0)])
    mid = np.array([[0.5, 0.0]])
    np.testing.assert_allclose(g.distance(mid), [-0.5])
    np.testing.assert_allclose(outline_distance(mid, (0, 0), 1.0, (1, 0), 1.0, False),
                               [math.sqrt(0.75)])


def test_union_of_disjoint_circles_is_the_exact_distance(rng):
    f = field({"op": "union", "of": [{"type": "circle", "radius": 1.0, "offset": [-2, 0]},
                                     {"type": "circle", "radius": 0.5, "offset": [1, 1]}]})
    p = sample_points(f, 2000, rng)
    exact = np.minimum(np.hypot(p[:, 0] + 2, p[:, 1]) - 1.0,
                       np.hypot(p[:, 0] - 1, p[:, 1] - 1) - 0.5)
    np.testing.assert_array_equal(f.distance(p), exact)


def test_intersection_is_exact_inside_and_a_bound_outside(rng):
    f = OPERATORS["intersection"]([circle(1.0), circle(1.0, 1.0)])
    assert not f.exact
    p = sample_points(f, 4000, rng)
    d = f.distance(p)
    true = outline_distance(p, (0, 0), 1.0, (1, 0), 1.0, keep_inside=True)
    inside = d < 0
    assert inside.sum() > 100
    np.testing.assert_allclose(-d[inside], true[inside], rtol=0, atol=1e-12)
    assert np.all(d[~inside] <= true[~inside] + 1e-12)
    # Strictly outside: above the lens, its tip (0.5, 0.866) is farther than max(a, b).
    q = np.array([[0.5, 1.5]])
    assert f.distance(q)[0] < outline_distance(q, (0, 0), 1.0, (1, 0), 1.0, True)[0] - 0.05


@pytest.mark.parametrize("op, rule", [
    ("intersection", lambda ins: ins[0] & ins[1] & ins[2]),
    ("difference", lambda ins: ins[0] & ~ins[1] & ~ins[2]),
    ("union", lambda ins: ins[0] | ins[1] | ins[2]),
    ("xor", lambda ins: ins[0] ^ ins[1] ^ ins[2]),
])
def test_boolean_signs_match_set_membership(op, rule, rng):
    parts = [circle(1.2), box(1.5, 0.8, 0.7, 0.2, 0.4), circle(0.6, 0.3, 0.0)]
    f = OPERATORS[op](parts)
    p = sample_points(f, 5000, rng, pad=0.3)
    values = np.array([g.distance(p) for g in parts])
    expected = rule(values < 0)
    d = f.distance(p)
    clear = np.min(np.abs(values), axis=0) > 1e-9
    np.testing.assert_array_equal(d[clear] < 0, expected[clear])
    assert expected.sum() > 50


def test_difference_and_xor_values():
    a, b = circle(1.0), circle(0.5, 0.8)
    # In both, in a only, outside both, in b only.
    p = np.array([[0.5, 0.0], [-0.5, 0.0], [2.0, 0.0], [1.15, 0.0]])
    diff = OPERATORS["difference"]([a, b])
    np.testing.assert_allclose(diff.distance(p), [0.2, -0.5, 1.0, 0.15], atol=1e-12)
    xor = OPERATORS["xor"]([a, b])
    np.testing.assert_allclose(xor.distance(p), [0.2, -0.5, 0.7, -0.15], atol=1e-12)


# --------------------------------------------------------------------------------------
# Smooth blends.
# --------------------------------------------------------------------------------------

COMPACT = ["polynomial", "cubic", "circular"]


@pytest.mark.parametrize("blend", COMPACT)
def test_smooth_min_is_min_outside_the_blend_zone(blend, rng):
    a = rng.normal(size=20000)
    b = rng.normal(size=20000)
    k = 0.3
    value, w = smooth_min(a, b, k, blend)
    far = np.abs(a - b) >= k
    assert far.sum() > 1000
    np.testing.assert_array_equal(value[far], np.minimum(a, b)[far])
    np.testing.assert_array_equal(w[far], (b < a)[far].astype(float))


def test_exponential_blend_differs_from_min_by_its_stated_tail(rng):
    a, b, k = rng.normal(size=20000), rng.normal(size=20000), 0.3
    value, _ = smooth_min(a, b, k, "exponential")
    far = np.abs(a - b) >= k
    assert np.all(np.minimum(a, b)[far] - value[far] <= 0.022 * k)
    assert np.all(value <= np.minimum(a, b))


@pytest.mark.parametrize("blend", list(BLENDS))
def test_smooth_min_dip_weights_and_derivatives(blend, rng):
    k = 0.4
    a = rng.uniform(-1, 1, 5000)
    b = a + rng.uniform(-1.5 * k, 1.5 * k, 5000)
    value, w = smooth_min(a, b, k, blend)
    dip = BLENDS[blend] * k
    assert np.all(value <= np.minimum(a, b)) and np.all(value >= np.minimum(a, b) - dip - 1e-15)
    tie, wt = smooth_min(np.array([0.2]), np.array([0.2]), k, blend)
    np.testing.assert_allclose(tie, [0.2 - dip], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(wt, [0.5])
    assert np.all((w >= 0) & (w <= 1))
    h = 1e-6
    da = (smooth_min(a + h, b, k, blend)[0] - smooth_min(a - h, b, k, blend)[0]) / (2 * h)
    db = (smooth_min(a, b + h, k, blend)[0] - smooth_min(a, b - h, k, blend)[0]) / (2 * h)
    np.testing.assert_allclose(da, 1.0 - w, atol=1e-6)
    np.testing.assert_allclose(db, w, atol=1e-6)


def test_circular_blend_level_sets_are_quarter_circles(rng):
    k = 0.5
    a = rng.uniform(-1, 1, 2000)
    b = a + rng.uniform(-k, k, 2000)
    s, _ = smooth_min(a, b, k, "circular")
    np.testing.assert_allclose((a - s - k) ** 2 + (b - s - k) ** 2, k * k, atol=1e-12)


@pytest.mark.parametrize("blend", COMPACT)
def test_smooth_union_reduces_to_union_away_from_the_blend(blend, rng):
    parts = [circle(1.0), box(1.0, 2.0, 1.6, 0.3)]
    k = 0.25
    smooth = OPERATORS["smooth_union"](parts, k=k, blend=blend)
    hard = OPERATORS["union"](parts)
    p = sample_points(hard, 4000, rng)
    a, b = parts[0].distance(p), parts[1].distance(p)
    far = np.abs(a - b) >= k
    ds, gs = smooth.evaluate(p)
    dh, gh = hard.evaluate(p)
    assert far.sum() > 1000
    np.testing.assert_array_equal(ds[far], dh[far])
    np.testing.assert_array_equal(gs[far], gh[far])
    inter = OPERATORS["smooth_intersection"](parts, k=k, blend=blend)
    hard_inter = OPERATORS["intersection"](parts)
    np.testing.assert_array_equal(inter.distance(p)[far], hard_inter.distance(p)[far])
    sub = OPERATORS["smooth_difference"](parts, k=k, blend=blend)
    hard_sub = OPERATORS["difference"](parts)
    far_sub = np.abs(a + b) >= k
    np.testing.assert_array_equal(sub.distance(p)[far_sub], hard_sub.distance(p)[far_sub])


@pytest.mark.parametrize("blend", list(BLENDS))
def test_smooth_operators_sit_on_the_right_side_of_the_hard_ones(blend, rng):
    parts = [circle(1.0), circle(0.7, 1.3, 0.2), box(0.6, 0.6, -0.4, 1.0)]
    k = 0.3
    p = sample_points(OPERATORS["union"](parts), 4000, rng)
    dip = BLENDS[blend] * k
    hard = OPERATORS["union"](parts).distance(p)
    soft = OPERATORS["smooth_union"](parts, k=k, blend=blend).distance(p)
    assert np.all(soft <= hard) and np.all(soft >= hard - 2 * dip - 1e-12)
    hard = OPERATORS["intersection"](parts).distance(p)
    assert np.all(OPERATORS["smooth_intersection"](parts, k=k, blend=blend).distance(p) >= hard)
    hard = OPERATORS["difference"](parts).distance(p)
    assert np.all(OPERATORS["smooth_difference"](parts, k=k, blend=blend).distance(p) >= hard)


# --------------------------------------------------------------------------------------
# Gradients against finite differences (fieldcheck skips points near kinks).
# --------------------------------------------------------------------------------------

def _gallery():
    a, b, c = circle(1.0), box(1.4, 0.8, 0.9, 0.3, 0.5), circle(0.5, -0.2, 0.9)
    out = {
        "union": OPERATORS["union"]([a, b, c]),
        "intersection": OPERATORS["intersection"]([a, b]),
        "difference": OPERATORS["difference"]([a, b, c]),
        "xor": OPERATORS["xor"]([a, b, c]),
        "round": OPERATORS["round"](b, r=0.2),
        "onion": OPERATORS["onion"](a, thickness=0.15),
        "transform": OPERATORS["transform"](b, offset=(0.3, -1.0), angle=0.7),
        "translate": OPERATORS["translate"](b, by=(0.3, -1.0)),
        "rotate": OPERATORS["rotate"](b, by=-2.0),
        "scale": OPERATORS["scale"](b, factor=2.5),
    }
    for blend in BLENDS:
        out[f"smooth_union/{blend}"] = OPERATORS["smooth_union"]([a, b, c], k=0.3, blend=blend)
        out[f"smooth_intersection/{blend}"] = OPERATORS["smooth_intersection"](
            [a, b], k=0.3, blend=blend)
        out[f"smooth_difference/{blend}"] = OPERATORS["smooth_difference"](
            [a, b, c], k=0.3, blend=blend)
    return out


GALLERY = _gallery()


@pytest.mark.parametrize("name", sorted(GALLERY))
def test_gradient_matches_finite_differences_and_claims_hold(name, rng):
    check_field(GALLERY[name], rng)


@pytest.mark.parametrize("name, params", [
    ("transform", {"offset": (1.0, 0.0), "angle": 0.3}), ("translate", {"by": (1.0, 0.0)}),
    ("rotate", {"by": 0.3}), ("scale", {"factor": 2.0})])
def test_placement_and_scale_keep_exactness(name, params):
    assert OPERATORS[name](box(1.0, 2.0), **params).exact
    assert not OPERATORS[name](GALLERY["union"], **params).exact


def test_scale_values():
    f = OPERATORS["scale"](box(2.0, 1.0), factor=3.0)
    np.testing.assert_allclose(f.distance([[4.0, 0.0], [0.0, 0.0], [3.0, 1.5]]), [1.0, -1.5, 0.0])
    np.testing.assert_allclose(f.bounds(), [-3.0, -1.5, 3.0, 1.5])


@pytest.mark.parametrize("blend", list(BLENDS))
def test_smooth_gradient_is_the_blend_of_the_operand_gradients(blend, rng):
    a, b = circle(1.0), box(1.0, 1.0, 1.2)
    f = OPERATORS["smooth_union"]([a, b], k=0.5, blend=blend)
    p = sample_points(f, 2000, rng)
    da, ga = a.evaluate(p)
    db, gb = b.evaluate(p)
    _, w = smooth_min(da, db, 0.5, blend)
    np.testing.assert_allclose(f.evaluate(p)[1], (1 - w)[:, None] * ga + w[:, None] * gb,
                               rtol=0, atol=1e-15)


# --------------------------------------------------------------------------------------
# Round and onion: exact where claimed, bounds elsewhere.
# --------------------------------------------------------------------------------------

def test_round_of_a_convex_exact_field_is_exact(rng):
    check_field(ClaimedExact(OPERATORS["round"](box(2.0, 1.0, angle=0.3), r=0.25)), rng)


def test_onion_of_a_circle_thinner_than_its_radius_is_exact(rng):
    check_field(ClaimedExact(OPERATORS["onion"](circle(1.0), thickness=0.3)), rng)


def shell_distance(p, t):
    """Exact distance to the outline of the shell {|box(2, 2)| <= t}, t < 1: the square
    of half-side 1 - t and the rounded square at distance t around [-1, 1]^2 (convex,
    so ``box - t`` is its exact distance)."""
    inner = np.abs(box(2.0 - 2.0 * t, 2.0 - 2.0 * t).distance(p))
    return np.minimum(inner, np.abs(box(2.0, 2.0).distance(p) - t))


@pytest.mark.parametrize("make, t", [
    (lambda: OPERATORS["onion"](box(2.0, 2.0), thickness=0.3), 0.3),
    (lambda: OPERATORS["round"](OPERATORS["onion"](box(2.0, 2.0), thickness=0.3), r=0.2), 0.5),
])
def test_onion_and_round_are_exact_outside_and_bounds_inside(make, t, rng):
    f = make()
    p = sample_points(f, 4000, rng, pad=0.2)
    d = f.distance(p)
    true = shell_distance(p, t)
    inside = d < 0
    assert inside.sum() > 200 and (~inside).sum() > 1000
    np.testing.assert_allclose(d[~inside], true[~inside], rtol=0, atol=1e-12)
    assert np.all(-d[inside] <= true[inside] + 1e-12)
    assert np.any(-d[inside] < true[inside] - 0.01)          # strictly, near the medial axis


def test_documented_counter_examples():
    # onion(box 2 x 2, t = 0.3) at (0.8, 0.75): f = -0.1, depth 0.112 (inner corner).
    f = OPERATORS["onion"](box(2.0, 2.0), thickness=0.3)
    q = np.array([[0.8, 0.75]])
    np.testing.assert_allclose(f.distance(q), [-0.1])
    np.testing.assert_allclose(shell_distance(q, 0.3), [math.hypot(0.1, 0.05)])
    # onion(circle 1, t = 1.2) is a disk of radius 2.2: at r = 0.5 f = -0.7, depth 1.7.
    ring = OPERATORS["onion"](circle(1.0), thickness=1.2)
    r = np.linspace(0.0, 2.19, 50)
    assert np.all(ring.distance(np.stack([r, 0 * r], axis=1)) < 0)
    np.testing.assert_allclose(ring.distance([[0.5, 0.0], [2.2, 0.0], [0.0, 2.7]]),
                               [-0.7, 0.0, 0.5], atol=1e-12)
    # round(onion(circle 1, t = 0.2), r = 0.9) closes the hole: a disk of radius 2.1, yet
    # f(0) = -0.1 against a depth of 2.1.
    closed = OPERATORS["round"](OPERATORS["onion"](circle(1.0), thickness=0.2), r=0.9)
    r = np.linspace(0.0, 2.09, 50)
    assert np.all(closed.distance(np.stack([r, 0 * r], axis=1)) < 0)
    np.testing.assert_allclose(closed.distance([[0.0, 0.0], [2.1, 0.0]]), [-0.1, 0.0],
                               atol=1e-12)


# --------------------------------------------------------------------------------------
# Bounds.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(GALLERY))
@pytest.mark.parametrize("level", [0.0, 0.2])
def test_bounds_contain_the_region(name, level, rng):
    f = GALLERY[name]
    if level == 0.0:
        np.testing.assert_array_equal(f.bounds(), level_bounds(f, 0.0))
    assert_level_bounds_contain(f, rng, level)


@pytest.mark.parametrize("blend", list(BLENDS))
def test_smooth_union_bounds_cover_the_bridge(blend, rng):
    # Two disks 0.2 apart with k = 1: the blend bridges the gap; the box must grow.
    f = OPERATORS["smooth_union"]([circle(0.5, -0.6), circle(0.5, 0.6)], k=1.0, blend=blend)
    assert f.distance([[0.0, 0.0]])[0] < 0
    dip = BLENDS[blend]
    np.testing.assert_allclose(f.bounds(), [-1.1 - dip, -0.5 - dip, 1.1 + dip, 0.5 + dip])
    assert_level_bounds_contain(f, rng)


def test_boxes_of_boolean_operators():
    a, b = box(2.0, 2.0), box(2.0, 2.0, 3.0, 0.5)
    np.testing.assert_allclose(OPERATORS["union"]([a, b]).bounds(), [-1, -1, 4, 1.5])
    np.testing.assert_allclose(OPERATORS["difference"]([a, b]).bounds(), [-1, -1, 1, 1])
    # Disjoint intersection: a zero-size box (the empty x-range collapses to its middle).
    np.testing.assert_allclose(OPERATORS["intersection"]([a, b]).bounds(), [1.5, -0.5, 1.5, 1])
    np.testing.assert_allclose(OPERATORS["round"](a, r=0.5).bounds(), [-1.5, -1.5, 1.5, 1.5])
    np.testing.assert_allclose(OPERATORS["transform"](a, offset=(1, 0), angle=np.pi / 4).bounds(),
                               [1 - math.sqrt(2), -math.sqrt(2), 1 + math.sqrt(2), math.sqrt(2)])


def test_smooth_union_of_an_empty_intersection_still_covers_its_blend(rng):
    # max(a, b) of two disjoint disks is small between them; a smooth union with a third
    # field there must still be covered by level_bounds (not by the empty box grown).
    gap = OPERATORS["intersection"]([circle(0.5, -0.6), circle(0.5, 0.6)])
    f = OPERATORS["smooth_union"]([gap, circle(0.3, 0.0, 0.9)], k=0.8, blend="circular")
    assert_level_bounds_contain(f, rng, minimum=50)


# --------------------------------------------------------------------------------------
# Specs.
# --------------------------------------------------------------------------------------

def test_nested_spec_builds_the_same_field_as_python(rng):
    spec = {"op": "smooth_union", "k": 0.3, "blend": "cubic", "of": [
        {"type": "circle", "radius": 1.0},
        {"op": "round", "r": 0.1, "of": {"type": "box", "size": [1.0, 2.0]}, "offset": [1.2, 0]},
        {"op": "scale", "factor": 0.5, "of": {"op": "onion", "thickness": 0.2,
                                               "of": {"type": "circle", "radius": 1.0}}},
    ]}
    f = field(spec)
    g = OPERATORS["smooth_union"]([
        CIRCLE(radius=1.0),
        OPERATORS["transform"](OPERATORS["round"](BOX(size=(1.0, 2.0)), r=0.1), offset=(1.2, 0)),
        OPERATORS["scale"](OPERATORS["onion"](CIRCLE(radius=1.0), thickness=0.2), factor=0.5),
    ], k=0.3, blend="cubic")
    p = sample_points(g, 500, rng)
    np.testing.assert_array_equal(f.distance(p), g.distance(p))
    np.testing.assert_array_equal(field(f.spec).distance(p), g.distance(p))
    assert f.spec["of"][1]["offset"] == [1.2, 0.0]


def test_placement_keys_apply_once_on_operators():
    f = field({"op": "transform", "of": {"type": "circle", "radius": 1.0}, "offset": [1.0, 0.0]})
    np.testing.assert_allclose(f.distance([[1.0, 0.0], [2.0, 0.0]]), [-1.0, 0.0])
    f = field({"op": "translate", "by": [1.0, 0.0], "of": {"type": "circle", "radius": 1.0},
               "offset": [0.0, 2.0]})
    np.testing.assert_allclose(f.distance([[1.0, 2.0]]), [-1.0])
    f = field({"op": "rotate", "by": np.pi / 2, "of": {"type": "box", "size": [2.0, 1.0]}})
    np.testing.assert_allclose(f.distance([[0.0, 1.0], [0.5, 0.0]]), [0.0, 0.0], atol=1e-12)


def _circle_spec(r):
    return {"type": "circle", "radius": r}


@pytest.mark.parametrize("spec, message", [
    ({"op": "union", "of": [_circle_spec(1.0), _circle_spec(-1.0)]},
     "field.of[1].radius: must be > 0, got -1"),
    ({"op": "union", "of": [_circle_spec(1.0)]},
     "field.of: must be a list of at least two FIELDs"),
    ({"op": "union", "of": _circle_spec(1.0)}, "field.of: must be a list of at least two FIELDs"),
    ({"op": "round", "r": 0.1}, "field.of: is required for 'round'"),
    ({"op": "round", "r": -0.1, "of": _circle_spec(1.0)}, "field.r: must be >= 0, got -0.1"),
    ({"op": "onion", "thickness": 0.0, "of": _circle_spec(1.0)},
     "field.thickness: must be > 0, got 0"),
    ({"op": "smooth_union", "k": 0.0, "of": [_circle_spec(1.0), _circle_spec(2.0)]},
     "field.k: must be > 0, got 0"),
    ({"op": "smooth_union", "k": 0.1, "blend": "quadratic",
      "of": [_circle_spec(1.0), _circle_spec(2.0)]},
     "field.blend: must be one of polynomial, cubic, circular, exponential; got 'quadratic'"),
    ({"op": "scale", "factor": -2.0, "of": _circle_spec(1.0)}, "field.factor: must be > 0"),
    ({"op": "translate", "of": _circle_spec(1.0)}, "field.by: is required for 'translate'"),
    ({"op": "difference", "of": [_circle_spec(1.0), {"op": "round", "r": 0.1,
                                                      "of": {"type": "circel"}}]},
     "field.of[1].of.type: unknown primitive 'circel' (did you mean 'circle'?)"),
    ({"op": "smooth_union", "k": 0.1, "of": [_circle_spec(1.0), _circle_spec(2.0)], "kk": 1},
     "field.kk: unknown key for 'smooth_union' (did you mean 'k'?)"),
    ({"op": "unoin", "of": []}, "field.op: unknown operator 'unoin' (did you mean 'union'?)"),
])
def test_bad_operator_specs_name_the_key_path(spec, message):
    with pytest.raises(sdfphys.SpecError) as err:
        field(spec)
    assert str(err.value).startswith(message)


def test_python_constructors_validate_too():
    with pytest.raises(sdfphys.SpecError, match="of: must be a list of at least two"):
        OPERATORS["union"]([circle(1.0)])
    with pytest.raises(sdfphys.SpecError, match="blend: must be one of"):
        OPERATORS["smooth_union"]([circle(1.0), circle(2.0)], k=0.1, blend="smooth")
    with pytest.raises(sdfphys.SpecError, match="k: must be > 0"):
        OPERATORS["smooth_union"]([circle(1.0), circle(2.0)], k=-1.0)


# --------------------------------------------------------------------------------------
# No NaN, deterministic ties.
# --------------------------------------------------------------------------------------

def test_ties_take_the_first_operand_and_never_nan():
    # The same circle twice; the second is rotated by pi, so at the centre (a tie, and
    # the circle's fallback direction) its gradient is (-1, 0) against the first's (1, 0).
    a, b = circle(1.0), OPERATORS["rotate"](circle(1.0), by=np.pi)
    centre = np.zeros((1, 2))
    np.testing.assert_allclose(b.evaluate(centre)[1], [[-1.0, 0.0]], atol=1e-15)
    for op, expected in [("union", [1.0, 0.0]), ("intersection", [1.0, 0.0]),
                         ("xor", [-1.0, 0.0])]:      # xor(a, a) = |a|: -grad a inside
        d, g = OPERATORS[op]([a, b]).evaluate(centre)
        np.testing.assert_array_equal(g, [expected])
    # Two circles touching at the origin: a == b there with opposite gradients.
    pair = [circle(1.0, -1.0), circle(1.0, 1.0)]
    _, g = OPERATORS["union"](pair).evaluate(centre)
    np.testing.assert_array_equal(g, [[1.0, 0.0]])                  # the first circle's
    for blend in BLENDS:
        d, g = OPERATORS["smooth_union"](pair, k=0.2, blend=blend).evaluate(centre)
        np.testing.assert_allclose(d, [-BLENDS[blend] * 0.2], rtol=0, atol=1e-15)
        np.testing.assert_array_equal(g, [[0.0, 0.0]])             # a genuine saddle


def test_medial_axes_and_extreme_values_give_finite_results():
    parts = [box(2.0, 2.0), circle(1.0), circle(1e-3, 1e6, 0.0)]
    p = np.array([[0.0, 0.0], [0.5, 0.5], [-0.3, 0.3], [1e6, 0.0], [-1e9, 1e9], [1.0, 1.0]])
    for name, f in list(GALLERY.items()) + [
            ("far", OPERATORS["smooth_union"](parts, k=0.5, blend="exponential")),
            ("far_onion", OPERATORS["onion"](OPERATORS["union"](parts), thickness=1.0))]:
        d, g = f.evaluate(p)
        assert np.all(np.isfinite(d)) and np.all(np.isfinite(g)), name
        assert np.all(np.linalg.norm(g, axis=1) <= 1.0 + 1e-12), name
