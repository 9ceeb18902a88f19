"""Tests of sdfphys.collide.descent against exact answers.

Triangles: analytic minima (circle, union of circles) and an independent brute
force (dense barycentric grid refined by a projected pattern search) for random
triangles against several fields. Field-field contacts: the analytic answers for
two circles and a circle against a box, and the geometry of a box resting on a
box and of a concave field touching a box twice.
"""

from __future__ import annotations

import numpy as np
import pytest

from sdfphys.collide import descent, field_pairs
from sdfphys.sdf import field

CIRCLE = {"type": "circle", "radius": 1.0}
UNION = {"op": "union", "of": [{"type": "circle", "radius": 1.0, "offset": [-2.0, 0.0]},
                               {"type": "circle", "radius": 1.5, "offset": [2.0, 0.0]}]}
FIELDS = {
    "box": {"type": "box", "size": [2.0, 1.0], "angle": 0.3},
    "circle": {"type": "circle", "radius": 0.8, "offset": [0.2, -0.1]},
    "polygon": {"type": "polygon",
                "points": [[-1, -0.5], [1, -0.7], [1.2, 0.4], [0, 1], [-0.8, 0.6]]},
    "smooth_union": {"op": "smooth_union", "k": 0.3, "of": [
        {"type": "circle", "radius": 0.6, "offset": [-0.5, 0.0]},
        {"type": "box", "size": [1.0, 0.6], "offset": [0.5, 0.1], "angle": 0.5}]},
    "union": UNION,
}


# --------------------------------------------------------------------------------------
# Independent references
# --------------------------------------------------------------------------------------

def closest_on_triangle(tri: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Closest points (M, 2) of triangle tri (3, 2) to points x (M, 2), by regions."""
    a, b, c = tri
    det = (b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0]
    u = ((x - a)[:, 0] * (c - a)[1] - (x - a)[:, 1] * (c - a)[0]) / det
    v = ((b - a)[0] * (x - a)[:, 1] - (b - a)[1] * (x - a)[:, 0]) / det
    inside = (u >= 0) & (v >= 0) & (u + v <= 1)
    best = np.full(len(x), np.inf)
    out = x.copy()
    for p, q in ((a, b), (b, c), (c, a)):
        t = np.clip((x - p) @ (q - p) / ((q - p) @ (q - p)), 0.0, 1.0)
        foot = p + t[:, None] * (q - p)
        d = np.sum((x - foot) ** 2, axis=1)
        out = np.where((d < best)[:, None], foot, out)
        best = np.minimum(best, d)
    return np.where(inside[:, None], x, out)


def brute_minimum(f, tri: np.ndarray, n: int = 400, seeds: int = 8) -> float:
    """min of f over triangle tri (3, 2): barycentric grid n x n, then a projected
    pattern search (72 directions, step halved when no direction improves) from the
    ``seeds`` best grid points; accurate to ~1e-9 for the fields used here."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    ok = i + j <= n
    w = np.stack([i[ok], j[ok]], axis=1) / n
    grid = tri[0] + w[:, :1] * (tri[1] - tri[0]) + w[:, 1:] * (tri[2] - tri[0])
    d = f.distance(grid)
    x = grid[np.argsort(d)[:seeds]]
    value = f.distance(x)
    size = np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=0), axis=1))
    step = np.full(len(x), 2.0 * size / n)
    angle = np.linspace(0.0, 2.0 * np.pi, 72, endpoint=False)
    ring = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    while np.any(step > 1e-13 * size):
        trial = x[:, None, :] + step[:, None, None] * ring[None]
        trial = closest_on_triangle(tri, trial.reshape(-1, 2)).reshape(len(x), -1, 2)
        v = f.distance(trial.reshape(-1, 2)).reshape(len(x), -1)
        k = np.argmin(v, axis=1)
        better = v[np.arange(len(x)), k] < value
        x = np.where(better[:, None], trial[np.arange(len(x)), k], x)
        value = np.where(better, v[np.arange(len(x)), k], value)
        step = np.where(better, step, 0.5 * step)
    return float(value.min())


def random_triangles(f, count: int, rng: np.random.Generator) -> np.ndarray:
    """Triangles (count, 3, 2) of sizes 0.05..1.5 around the field's bounds."""
    x0, y0, x1, y1 = f.bounds()
    centre = rng.uniform([x0 - 0.5, y0 - 0.5], [x1 + 0.5, y1 + 0.5], (count, 2))
    size = rng.uniform(0.05, 1.5, (count, 1, 1))
    return centre[:, None, :] + rng.uniform(-1.0, 1.0, (count, 3, 2)) * size


def in_triangle(tri: np.ndarray, p: np.ndarray) -> bool:
    return bool(np.linalg.norm(closest_on_triangle(tri, p[None])[0] - p) < 1e-12)


# --------------------------------------------------------------------------------------
# triangle_deepest
# --------------------------------------------------------------------------------------

def test_circle_pierced_by_an_edge_with_no_vertex_or_centroid_inside():
    f = field(CIRCLE)
    tri = np.array([[[-2.0, 0.9], [2.0, 0.9], [0.0, 3.0]]])
    starts = np.einsum("kj,tjd->tkd", descent.START_BARYCENTRIC, tri)[0]
    assert np.all(f.distance(starts[[0, 1, 2, 6]]) > 0.0)      # vertices, centroid outside
    point, value = descent.triangle_deepest(f, tri)
    k = np.argmin(value[0])
    assert value[0, k] == pytest.approx(-0.1, abs=1e-12)
    np.testing.assert_allclose(point[0, k], [0.0, 0.9], atol=1e-9)
    np.testing.assert_allclose(f.normal(point[0, k]), [[0.0, 1.0]], atol=1e-9)
    assert value[0, k] == pytest.approx(brute_minimum(f, tri[0]), abs=1e-9)
    # Every start reaches the single minimum.
    np.testing.assert_allclose(value[0], -0.1, atol=1e-12)


def test_concave_field_both_local_minima_on_one_edge():
    f = field(UNION)
    tri = np.array([[[-3.0, 0.9], [3.0, 0.9], [0.0, 3.0]]])
    point, value = descent.triangle_deepest(f, tri)
    keep = descent.merge_minima(point, 1e-6)[0]
    found = sorted(zip(point[0, keep, 0], value[0, keep]))
    assert len(found) == 2
    (xl, vl), (xr, vr) = found
    # Left: circle r = 1 at (-2, 0), nearest point of the edge (-2, 0.9): -0.1.
    assert xl == pytest.approx(-2.0, abs=1e-6) and vl == pytest.approx(-0.1, abs=1e-9)
    # Right: circle r = 1.5 at (2, 0): -0.6, the deepest.
    assert xr == pytest.approx(2.0, abs=1e-6) and vr == pytest.approx(-0.6, abs=1e-9)
    assert -value.min() == pytest.approx(0.6, abs=1e-9)


def test_triangle_containing_the_centre_of_a_circle():
    f = field({"type": "circle", "radius": 0.7, "offset": [0.1, -0.2]})
    tri = np.array([[[-0.5, -0.6], [0.9, -0.4], [0.0, 0.8]],
                    [[0.1, -0.2], [1.0, -0.2], [0.1, 0.7]]])           # centre at a vertex
    point, value = descent.triangle_deepest(f, tri)
    assert np.all(np.isfinite(point)) and np.all(np.isfinite(value))
    for t in range(2):
        k = np.argmin(value[t])
        assert value[t, k] == pytest.approx(-0.7, abs=1e-9)
        np.testing.assert_allclose(point[t, k], [0.1, -0.2], atol=1e-9)


def test_degenerate_triangle_is_searched_as_a_segment():
    f = field(CIRCLE)
    tri = np.array([[[-2.0, 0.5], [2.0, 0.5], [0.0, 0.5]],             # collinear
                    [[1.5, 1.5], [1.5, 1.5], [1.5, 1.5]]])             # a point
    point, value = descent.triangle_deepest(f, tri)
    assert np.all(np.isfinite(point))
    assert value[0].min() == pytest.approx(-0.5, abs=1e-9)
    np.testing.assert_allclose(value[1], np.hypot(1.5, 1.5) - 1.0, atol=1e-12)


@pytest.mark.parametrize("name", sorted(FIELDS))
def test_deepest_over_starts_matches_brute_force(name):
    f = field(FIELDS[name])
    rng = np.random.default_rng(sorted(FIELDS).index(name))
    tri = random_triangles(f, 16, rng)
    point, value = descent.triangle_deepest(f, tri)
    # Each answer is a point of its triangle with the value f has there ...
    for t in range(len(tri)):
        for k in range(point.shape[1]):
            assert in_triangle(tri[t], point[t, k])
    np.testing.assert_allclose(value, f.distance(point.reshape(-1, 2)).reshape(value.shape),
                               rtol=0, atol=1e-15)
    # ... and the deepest over the starts is the brute-force minimum.
    reference = np.array([brute_minimum(f, tri[t]) for t in range(len(tri))])
    np.testing.assert_allclose(value.min(axis=1), reference, rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", ["box", "circle", "smooth_union", "union"])
def test_every_start_ends_at_a_local_minimum(name):
    """No point of the triangle within 1e-6..1e-4 of a start's answer is lower by 1e-6.

    (Not asserted for the polygon: see the module's Limits, a start can stop at an
    interior medial-axis vertex of three faces.)"""
    f = field(FIELDS[name])
    rng = np.random.default_rng(100 + sorted(FIELDS).index(name))
    tri = random_triangles(f, 150, rng)
    point, value = descent.triangle_deepest(f, tri)
    angle = np.linspace(0.0, 2.0 * np.pi, 32, endpoint=False)
    ring = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    for t in range(len(tri)):
        probes = (point[t, :, None, None, :] + np.array([1e-6, 1e-5, 1e-4])[:, None, None]
                  * ring[None, None]).reshape(-1, 2)
        lowest = f.distance(closest_on_triangle(tri[t], probes)).reshape(point.shape[1], -1)
        assert np.all(lowest.min(axis=1) >= value[t] - 1e-6), (t, tri[t])


def test_values_never_increase_and_budget_is_respected():
    f = field(FIELDS["polygon"])
    tri = random_triangles(f, 40, np.random.default_rng(7))
    starts = np.einsum("kj,tjd->tkd", descent.START_BARYCENTRIC, tri)
    start_value = f.distance(starts.reshape(-1, 2)).reshape(40, 7)
    previous = start_value
    for budget in (0, 1, 2, 4, 16):
        _, value = descent.triangle_deepest(f, tri, iterations=budget)
        assert np.all(value <= start_value)
        if budget == 0:
            np.testing.assert_array_equal(value, start_value)
        previous = np.minimum(previous, value)
    np.testing.assert_allclose(previous, value, atol=0)              # 16 is the best


def test_custom_starts_and_empty_input():
    f = field(CIRCLE)
    tri = np.array([[[-2.0, 0.9], [2.0, 0.9], [0.0, 3.0]]])
    point, value = descent.triangle_deepest(f, tri, starts=np.array([[1.0, 0.0, 0.0]]))
    assert point.shape == (1, 1, 2) and value[0, 0] == pytest.approx(-0.1, abs=1e-12)
    point, value = descent.triangle_deepest(f, np.zeros((0, 3, 2)))
    assert point.shape == (0, 7, 2) and value.shape == (0, 7)


def test_merge_minima_keeps_the_lowest_start_of_each_cluster():
    point = np.array([[[0.0, 0.0], [1.0, 0.0], [1e-9, 0.0], [1.0, 1e-9], [5.0, 5.0]]])
    keep = descent.merge_minima(point, 1e-6)
    np.testing.assert_array_equal(keep, [[True, True, False, False, True]])


# --------------------------------------------------------------------------------------
# triangle_cull
# --------------------------------------------------------------------------------------

def test_enclosing_circles_are_minimal():
    tri = random_triangles(field(CIRCLE), 500, np.random.default_rng(3))
    centre, radius = descent.enclosing_circles(tri)
    distance = np.linalg.norm(tri - centre[:, None, :], axis=2)
    assert np.all(distance <= radius[:, None] * (1 + 1e-12) + 1e-15)
    edge = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2)
    # No enclosing circle is smaller than half the longest edge; equality for
    # obtuse triangles, else all three vertices lie on the circle (circumcircle).
    assert np.all(radius >= 0.5 * edge.max(axis=1) * (1 - 1e-12))
    on_diameter = np.isclose(radius, 0.5 * edge.max(axis=1), rtol=1e-12)
    np.testing.assert_allclose(distance[~on_diameter], radius[~on_diameter, None] * np.ones(3),
                               rtol=1e-9)


@pytest.mark.parametrize("name", sorted(FIELDS))
@pytest.mark.parametrize("margin", [0.0, 0.1])
def test_cull_never_rejects_a_triangle_that_reaches_the_margin(name, margin):
    f = field(FIELDS[name])
    tri = random_triangles(f, 300, np.random.default_rng(11 + sorted(FIELDS).index(name)))
    keep = descent.triangle_cull(f, tri, margin)
    n = 60
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    ok = i + j <= n
    w = np.stack([i[ok], j[ok]], axis=1) / n
    grid = (tri[:, None, 0] + w[None, :, :1] * (tri[:, None, 1] - tri[:, None, 0])
            + w[None, :, 1:] * (tri[:, None, 2] - tri[:, None, 0]))
    reaches = f.distance(grid.reshape(-1, 2)).reshape(len(tri), -1).min(axis=1) < margin
    assert reaches.any() and not reaches.all()
    assert np.all(keep[reaches])


def test_cull_rejects_far_triangles():
    f = field(FIELDS["polygon"])
    rng = np.random.default_rng(5)
    far = random_triangles(f, 200, rng) + np.array([6.0, 0.0])
    assert not descent.triangle_cull(f, far, 0.1).any()
    assert descent.triangle_cull(f, np.zeros((0, 3, 2))).shape == (0,)


# --------------------------------------------------------------------------------------
# field_field_contacts
# --------------------------------------------------------------------------------------

def region_of(fa, fb, pose, grow: float = 0.0) -> np.ndarray:
    """Overlap of a's bounds and b's placed bounds, in a's frame, grown by ``grow``."""
    a, b = fa.bounds(), fb.bounds()
    c, s = np.cos(pose[2]), np.sin(pose[2])
    corners = np.array([[b[0], b[1]], [b[2], b[1]], [b[2], b[3]], [b[0], b[3]]])
    corners = corners @ np.array([[c, s], [-s, c]]) + pose[:2]
    lo = np.maximum(a[:2], corners.min(axis=0)) - grow
    hi = np.minimum(a[2:], corners.max(axis=0)) + grow
    return np.concatenate([lo, hi])


def contacts(fa, fb, pose, margin: float = 0.0):
    pose = np.asarray(pose, dtype=np.float64)
    return field_pairs.field_field_contacts_single(fa, fb, pose, region_of(fa, fb, pose, margin),
                                               margin=margin)


def test_two_circles_exact():
    rng = np.random.default_rng(21)
    for _ in range(60):
        ra, rb = rng.uniform(0.2, 1.5, 2)
        d = rng.uniform(0.02, ra + rb - 1e-3)
        theta = rng.uniform(0.0, 2.0 * np.pi)
        u = np.array([np.cos(theta), np.sin(theta)])
        fa, fb = field({"type": "circle", "radius": ra}), field({"type": "circle", "radius": rb})
        point, depth, normal, start = contacts(fa, fb, [*(d * u), rng.uniform(-3, 3)])
        assert len(depth) == 1
        assert depth[0] == pytest.approx(ra + rb - d, abs=1e-9)
        np.testing.assert_allclose(normal[0], u, atol=1e-9)
        # Midway between a's surface point ra u and b's (d - rb) u.
        np.testing.assert_allclose(point[0], 0.5 * (ra + d - rb) * u, atol=1e-9)
        assert 0 <= start[0] < 16


def test_coincident_and_nested_circles_give_finite_contacts():
    fa, fb = field({"type": "circle", "radius": 1.0}), field({"type": "circle", "radius": 0.5})
    for pair in ((fa, fb), (fb, fa), (fa, fa)):
        point, depth, normal, _ = contacts(*pair, [0.0, 0.0, 0.3])
        assert len(depth) >= 1
        assert np.all(np.isfinite(point)) and np.all(np.isfinite(normal))
        np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-12)
        expected = pair[0].bounds()[2] + pair[1].bounds()[2]          # r_a + r_b - 0
        np.testing.assert_allclose(depth, expected, atol=1e-9)
    # Nested off-centre: b (r = 0.3) inside a (r = 1.2) at distance 0.5.
    point, depth, normal, _ = contacts(field({"type": "circle", "radius": 1.2}),
                                       field({"type": "circle", "radius": 0.3}), [0.3, 0.4, 0.0])
    assert len(depth) == 1
    assert depth[0] == pytest.approx(1.5 - 0.5, abs=1e-9)
    np.testing.assert_allclose(normal[0], [0.6, 0.8], atol=1e-9)


def test_circle_against_box_matches_the_analytic_contact():
    """depth = r - f_box(c), normal = -grad f_box(c) (from the circle toward the box),
    point midway, wherever the box's nearest feature is the same at c and at the
    deepest point of the overlap (the contact's segment crosses no medial axis)."""
    rng = np.random.default_rng(8)
    tested = 0
    while tested < 60:
        r = rng.uniform(0.2, 1.0)
        w, h = rng.uniform(0.5, 3.0, 2)
        box = field({"type": "box", "size": [w, h]})
        c_box = rng.uniform([-w / 2 - r, -h / 2 - r], [w / 2 + r, h / 2 + r])
        f_c, g_c = (v[0] for v in box.evaluate(c_box[None]))
        t = 0.5 * (r + f_c)
        if f_c > r - 1e-3 or t <= 0.0:
            continue
        if np.abs(box.evaluate((c_box - t * g_c)[None])[1][0] - g_c).max() > 1e-12:
            continue
        tested += 1
        angle = rng.uniform(-3.0, 3.0)
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        offset = -rot @ c_box                                  # circle centre at a's origin
        point, depth, normal, _ = contacts(field({"type": "circle", "radius": r}), box,
                                           [*offset, angle])
        n = -(rot @ g_c)
        assert len(depth) == 1
        assert depth[0] == pytest.approx(r - f_c, abs=1e-9)
        np.testing.assert_allclose(normal[0], n, atol=1e-9)
        np.testing.assert_allclose(point[0], n * (r - 0.5 * (r - f_c)), atol=1e-9)


def test_box_resting_on_box_gives_the_corners_of_the_overlap():
    base = field({"type": "box", "size": [4.0, 1.0]})
    top = field({"type": "box", "size": [2.0, 1.0]})
    for x, angle in ((1.5, 0.0), (0.0, 0.0), (-0.7, np.pi)):
        point, depth, normal, start = contacts(base, top, [x, 0.99, angle])
        order = np.argsort(point[:, 0])
        x0, x1 = max(-2.0, x - 1.0), min(2.0, x + 1.0)
        np.testing.assert_allclose(point[order], [[x0, 0.495], [x1, 0.495]], atol=1e-9)
        np.testing.assert_allclose(depth, 0.01, atol=1e-9)
        np.testing.assert_allclose(normal, [[0.0, 1.0], [0.0, 1.0]], atol=1e-9)
        assert np.all((start >= 16) & (start < 48))
    # Standing on its short side (b rotated a quarter turn): overlap x in [-0.5, 0.5].
    point, depth, normal, _ = contacts(base, top, [0.0, 1.49, np.pi / 2])
    np.testing.assert_allclose(np.sort(point[:, 0]), [-0.5, 0.5], atol=1e-9)
    np.testing.assert_allclose(depth, 0.01, atol=1e-9)


def test_concave_field_touching_a_box_twice():
    pair = field({"op": "union", "of": [
        {"type": "circle", "radius": 1.0, "offset": [-2.0, 0.0]},
        {"type": "circle", "radius": 1.0, "offset": [2.0, 0.0]}]})
    ground = field({"type": "box", "size": [8.0, 1.0]})
    point, depth, normal, _ = contacts(pair, ground, [0.3, -1.45, 0.0])
    order = np.argsort(point[:, 0])
    np.testing.assert_allclose(point[order], [[-2.0, -0.975], [2.0, -0.975]], atol=1e-9)
    np.testing.assert_allclose(depth, 0.05, atol=1e-9)
    np.testing.assert_allclose(normal, [[0.0, -1.0], [0.0, -1.0]], atol=1e-9)


def test_separated_fields_give_no_contact_unless_within_the_margin():
    fa, fb = field({"type": "circle", "radius": 1.0}), field({"type": "circle", "radius": 0.5})
    assert len(contacts(fa, fb, [1.6, 0.0, 0.0])[1]) == 0
    point, depth, normal, _ = contacts(fa, fb, [1.6, 0.0, 0.0], margin=0.2)
    assert len(depth) == 1
    assert depth[0] == pytest.approx(-0.1, abs=1e-9)
    np.testing.assert_allclose(normal[0], [1.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(point[0], [1.05, 0.0], atol=1e-9)
    base, top = field({"type": "box", "size": [4.0, 1.0]}), field({"type": "box", "size": [2.0, 1.0]})
    assert len(contacts(base, top, [0.0, 1.005, 0.0])[1]) == 0
    point, depth, _, _ = contacts(base, top, [0.0, 1.005, 0.0], margin=0.02)
    np.testing.assert_allclose(np.sort(point[:, 0]), [-1.0, 1.0], atol=1e-9)
    np.testing.assert_allclose(depth, -0.005, atol=1e-9)


def test_field_field_batch_equals_single_calls():
    """P random placements in one call give, pair by pair, the contacts of P single
    calls (same bits): the batch changes who is evaluated together, not the result."""
    rng = np.random.default_rng(33)
    base, top = field({"type": "box", "size": [4.0, 1.0]}), field({"type": "box", "size": [2.0, 1.0]})
    for fa, fb, low, high in ((field(FIELDS["polygon"]), field(FIELDS["smooth_union"]),
                               [-1.5, -1.5, -3.0], [1.5, 1.5, 3.0]),
                              (base, top, [-2.0, 0.9, -0.05], [2.0, 1.05, 0.05])):
        n = 40
        poses = rng.uniform(low, high, (n, 3))
        poses[::4, 2] = 0.0                                   # some exactly flat contacts
        margin = 0.05
        regions = np.array([region_of(fa, fb, pose, margin) for pose in poses])
        regions[3] = [1.0, 1.0, 0.0, 0.0]                     # empty: no contact
        pair, point, depth, normal, start = field_pairs.field_field_contacts(
            fa, fb, poses, regions, margin=margin)
        assert np.all(np.diff(pair) >= 0) and 3 not in pair
        assert len(np.unique(pair)) > n // 2
        for k in range(n):
            expected = field_pairs.field_field_contacts_single(fa, fb, poses[k], regions[k],
                                                           margin=margin)
            mine = pair == k
            for got, want in zip((point[mine], depth[mine], normal[mine], start[mine]),
                                 expected, strict=True):
                np.testing.assert_array_equal(got, want)
    with pytest.raises(ValueError):
        field_pairs.field_field_contacts(base, top, np.zeros((2, 3)), np.zeros((3, 4)))


def test_field_field_is_deterministic_and_rejects_infinite_regions():
    fa = field(FIELDS["polygon"])
    fb = field(FIELDS["smooth_union"])
    pose = np.array([0.3, 1.2, 0.4])
    first = contacts(fa, fb, pose)
    second = contacts(fa, fb, pose)
    assert len(first[1]) >= 1
    for x, y in zip(first, second):
        np.testing.assert_array_equal(x, y)
    with pytest.raises(ValueError):
        field_pairs.field_field_contacts_single(fa, fb, pose, [-np.inf, 0.0, 1.0, 1.0])
    empty = field_pairs.field_field_contacts_single(fa, fb, pose, [1.0, 1.0, 0.0, 0.0])
    assert all(len(x) == 0 for x in empty)
