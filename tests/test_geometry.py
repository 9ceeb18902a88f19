"""Polygon validation, triangulation and mass properties against exact answers.

References: brute force (exact rational arithmetic, point-in-polygon by crossing
number, all-pairs edge tests), closed forms (rectangle, disk) and pymunk's
area_for_poly / moment_for_poly / moment_for_circle.
"""

from __future__ import annotations

import time
from fractions import Fraction

import numpy as np
import pytest

from sdfphys.errors import SpecError
from sdfphys.geometry import _orient, triangulate, validate_polygon

# --------------------------------------------------------------------------------------
# Test polygons
# --------------------------------------------------------------------------------------

SQUARE = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
L_SHAPE = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]
U_SHAPE = [[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]]


def comb(teeth: int) -> np.ndarray:
    """A base bar 0 <= y <= 1 with ``teeth`` teeth of width 0.5 up to y = 4, CCW."""
    pts = [[0.0, 0.0], [teeth - 0.5, 0.0]]
    for k in range(teeth - 1, -1, -1):
        pts += [[k + 0.5, 4.0], [k, 4.0], [k, 1.0] if k else [0.0, 4.0]]
    pts = [q for i, q in enumerate(pts) if i == 0 or q != pts[i - 1]]
    return np.array(pts[:-1] if pts[-1] == pts[0] else pts)


def star(n: int, rng: np.random.Generator, r_min: float = 0.2) -> np.ndarray:
    """Random star-shaped polygon: sorted distinct angles, radii in [r_min, 1], CCW."""
    theta = np.sort(rng.uniform(0.0, 2.0 * np.pi, n))
    radius = rng.uniform(r_min, 1.0, n)
    return np.column_stack([radius * np.cos(theta), radius * np.sin(theta)])


def spiral(turns: float = 2.5, n: int = 200, width: float = 0.3) -> np.ndarray:
    """A thick Archimedean spiral arm: outer wall out, inner wall back, CCW."""
    t = np.linspace(0.0, 2.0 * np.pi * turns, n)
    r = 0.5 + 1.0 * t / (2.0 * np.pi)
    outer = np.column_stack([r * np.cos(t), r * np.sin(t)])
    inner = np.column_stack([(r - width) * np.cos(t), (r - width) * np.sin(t)])
    return np.vstack([outer, inner[::-1]])[::-1]


def collinear_rich() -> np.ndarray:
    """A triangle and a square notch with extra vertices on their straight sides."""
    bottom = [[x, 0.0] for x in np.linspace(0.0, 4.0, 9)]
    right = [[4.0 - s, s] for s in np.linspace(0.5, 4.0, 8)]
    return np.array(bottom + right[:-1] + [[0.0, 4.0]] + [[0.0, y] for y in (3.0, 2.0, 1.0)])


# --------------------------------------------------------------------------------------
# Brute-force references
# --------------------------------------------------------------------------------------

def signed_areas(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                  - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def shoelace(p: np.ndarray) -> float:
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]))


def inside(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Crossing-number point-in-polygon test, vectorized over points (N, 2) and edges."""
    a = poly[None, :, :]
    b = np.roll(poly, -1, axis=0)[None, :, :]
    x, y = pts[:, None, 0], pts[:, None, 1]
    straddle = (a[..., 1] > y) != (b[..., 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = a[..., 0] + (y - a[..., 1]) * (b[..., 0] - a[..., 0]) / (b[..., 1] - a[..., 1])
    return (np.sum(straddle & (x < x_cross), axis=1) % 2) == 1


def boundary_distance(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Distance (N,) from points (N, 2) to the polygon's outline, brute force over edges."""
    a = poly[None, :, :]
    e = np.roll(poly, -1, axis=0)[None, :, :] - a
    t = np.clip(((pts[:, None, :] - a) * e).sum(-1) / (e * e).sum(-1), 0.0, 1.0)
    return np.linalg.norm(pts[:, None, :] - a - t[..., None] * e, axis=-1).min(axis=1)


def check_triangulation(poly_in) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate and check every property a valid triangulation must have."""
    p = validate_polygon(poly_in)
    tri = triangulate(poly_in)
    m = p.shape[0]
    assert tri.dtype == np.int64 and tri.shape == (m - 2, 3)
    assert set(np.unique(tri)) <= set(range(m))
    areas = signed_areas(p, tri)
    assert np.all(areas > 0.0), "every triangle counter-clockwise with positive area"
    area = shoelace(p)
    assert area > 0.0
    assert abs(areas.sum() - area) <= 1e-12 * np.abs(areas).sum() * m
    # Centroids inside (crossing number); a sliver of nearly collinear outline points
    # may have its centroid within round-off of the outline, where the test is moot.
    centroids = p[tri].mean(axis=1)
    scale = np.ptp(p, axis=0).max()
    on_outline = boundary_distance(p, centroids) <= 1e-12 * scale
    assert (inside(p, centroids) | on_outline).all(), "triangle centroid outside the polygon"
    # Combinatorics of a tiling: each polygon edge in exactly one triangle, each
    # diagonal in exactly two (once each way).
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    keys = {(int(u), int(v)) for u, v in directed}
    assert len(keys) == directed.shape[0], "a directed edge used twice (overlap)"
    for i in range(m):
        assert (i, (i + 1) % m) in keys, f"polygon edge {i} not covered"
    for u, v in keys:
        if v != (u + 1) % m:
            assert (v, u) in keys, f"diagonal {u}-{v} borders one triangle only"
    return p, tri


# --------------------------------------------------------------------------------------
# Exact predicate
# --------------------------------------------------------------------------------------

def exact_sign(a, b, c) -> int:
    ax, ay, bx, by, cx, cy = (Fraction(float(v)) for v in (*a, *b, *c))
    det = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return (det > 0) - (det < 0)


def test_orient_matches_rational_arithmetic_on_near_collinear_points(rng):
    for _ in range(2000):
        a = rng.uniform(-10, 10, 2)
        b = rng.uniform(-10, 10, 2)
        t = rng.uniform(-2, 3)
        c = a + t * (b - a)
        c = c + rng.choice([0.0, 1e-15, -1e-15, 1e-300]) * rng.standard_normal(2)
        for pa, pb, pc in ((a, b, c), (c, a, b), (b, c, a)):
            assert _orient(*pa, *pb, *pc) == exact_sign(pa, pb, pc)
    for a, b, c in (((0.1, 0.3), (0.2, 0.6), (0.3, 0.9)),
                    ((0.5, 0.5), (12.0, 12.0), (24.0, 24.0)),
                    ((0.0, 0.0), (1.0, 1e-300), (2.0, 2e-300))):
        assert _orient(*a, *b, *c) == exact_sign(a, b, c)


# --------------------------------------------------------------------------------------
# validate_polygon
# --------------------------------------------------------------------------------------

def test_validate_keeps_ccw_and_reverses_cw_keeping_first_vertex():
    ccw = validate_polygon(SQUARE)
    assert ccw.dtype == np.float64 and ccw.shape == (4, 2)
    np.testing.assert_array_equal(ccw, SQUARE)
    cw = validate_polygon(SQUARE[::-1])
    np.testing.assert_array_equal(cw, np.roll(np.array(SQUARE[::-1])[::-1], 1, axis=0))
    assert shoelace(cw) == 1.0
    np.testing.assert_array_equal(validate_polygon(cw), cw)


def test_validate_accepts_arrays_ints_and_drops_closing_duplicate():
    np.testing.assert_array_equal(validate_polygon(np.array(L_SHAPE)), L_SHAPE)
    closed = validate_polygon(SQUARE + [SQUARE[0]])
    np.testing.assert_array_equal(closed, SQUARE)


def test_validate_keeps_collinear_vertices():
    p = collinear_rich()
    np.testing.assert_array_equal(validate_polygon(p), p)


@pytest.mark.parametrize("points, path, message", [
    ([[0, 0], [1, 0]], "points", "needs at least 3 points, got 2"),
    (np.zeros((2, 2)), "points", "needs at least 3 points, got 2"),
    (np.zeros((3, 3)), "points", "must be a list of [x, y] points"),
    ("abc", "points", "must be a list of [x, y] points"),
    ([[0, 0], [1, 0], [1]], "points[2]", "must be a pair [x, y]"),
    ([[0, 0], [1, float("nan")], [0, 1]], "points[1][1]", "must be finite"),
    (np.array([[0, 0], [1, 0], [np.inf, 1]]), "points[2]", "must be finite"),
    ([[0, 0], [1, 0], [1, 0], [0, 1]], "points[2]", "repeats points[1]"),
    ([[0, 0], [1, 0], [0, 0]], "points", "fewer than 3 distinct points"),
    ([[0, 0], [1, 1], [3, 3]], "points", "all points are collinear (zero area)"),
    ([[0, 0], [1, 1], [3, 3], [2, 2]], "points", "all points are collinear (zero area)"),
    ([[0, 0], [2, 0], [1, 0], [1, 1]], "points", "edges 0 and 1 overlap"),
    ([[0, 0], [1, 0], [1, 1], [1, 3], [1, 2], [0, 2]], "points", "edges 2 and 3 overlap"),
    ([[0, 0], [1, 1], [1, 0], [0, 1]], "points", "edges 0 and 2 cross (self-intersecting"),
    ([[0, 0], [4, 0], [4, 4], [2, -1], [0, 4]], "points", "edges 0 and 2 cross"),
    ([[0, 0], [2, 0], [2, 2], [1, 0], [0, 2]], "points", "edges 0 and 2 touch"),
    ([[0, 0], [2, 0], [1, 1], [2, 2], [0, 2], [1, 1]], "points", "edges 1 and 4 touch"),
])
def test_validate_rejects_bad_polygons_with_a_clear_message(points, path, message):
    with pytest.raises(SpecError) as err:
        validate_polygon(points)
    assert err.value.path == path
    assert message in err.value.message


def test_validate_names_the_lowest_crossing_pair_in_input_numbering():
    # A bow-tie drawn clockwise: numbering stays that of the input.
    with pytest.raises(SpecError, match=r"^body\[0\]\.shape\.points: edges 1 and 3 cross"):
        validate_polygon([[0, 0], [0, 1], [1, 0], [1, 1]], path="body[0].shape.points")


def test_validate_agrees_with_brute_force_on_random_polygons(rng):
    """Random 6-gons: simple iff no pair of non-adjacent edges meets (all-pairs test).

    Integer-jittered hexagons give simple, self-touching and crossing outlines, with
    collinear vertices and folds, in roughly equal numbers.
    """
    hexagon = 2.0 * np.column_stack([np.cos(np.arange(6) * np.pi / 3),
                                     np.sin(np.arange(6) * np.pi / 3)])
    seen = {True: 0, False: 0}
    for _ in range(300):
        p = np.round(hexagon + rng.integers(-2, 3, size=(6, 2)))
        if (p == np.roll(p, 1, axis=0)).all(axis=1).any():
            continue
        q = np.roll(p, -1, axis=0)
        collinear = all(exact_sign(p[0], p[1], r) == 0 for r in p)
        fold = any(exact_sign(p[k - 1], p[k], q[k]) == 0
                   and np.dot(p[k - 1] - p[k], q[k] - p[k]) > 0 for k in range(6))
        meets = False
        for i in range(6):
            for j in range(i + 2, 6):
                if i == 0 and j == 5:
                    continue
                o1 = exact_sign(p[j], q[j], p[i])
                o2 = exact_sign(p[j], q[j], q[i])
                o3 = exact_sign(p[i], q[i], p[j])
                o4 = exact_sign(p[i], q[i], q[j])
                if o1 * o2 <= 0 and o3 * o4 <= 0:
                    lo = np.maximum(np.minimum(p[i], q[i]), np.minimum(p[j], q[j]))
                    hi = np.minimum(np.maximum(p[i], q[i]), np.maximum(p[j], q[j]))
                    meets |= bool(np.all(lo <= hi))
        simple = not (collinear or fold or meets)
        try:
            validate_polygon(p)
            ok = True
        except SpecError:
            ok = False
        assert ok == simple, p
        seen[simple] += 1
        if ok:
            check_triangulation(p)
    assert seen[True] > 50 and seen[False] > 50


# --------------------------------------------------------------------------------------
# triangulate
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("name, poly", [
    ("triangle", [[0, 0], [1, 0], [0, 1]]),
    ("square", SQUARE),
    ("regular 12-gon", [[np.cos(t), np.sin(t)] for t in np.linspace(0, 2 * np.pi, 13)[:-1]]),
    ("L", L_SHAPE),
    ("U", U_SHAPE),
    ("comb", comb(8)),
    ("spiral", spiral()),
    ("collinear sides", collinear_rich()),
    ("star 40", star(40, np.random.default_rng(7))),
])
@pytest.mark.parametrize("winding", ["ccw", "cw"])
def test_triangulation_tiles_the_polygon(name, poly, winding):
    poly = np.asarray(poly, dtype=float)
    if winding == "cw":
        poly = poly[::-1]
    check_triangulation(poly)


def test_triangulation_of_flat_vertices_on_a_triangle():
    # Triangle with points on all three sides: the only valid tiling uses the inner
    # triangle of side points; no ear may have a flat tip.
    p = [[0, 0], [1, 0], [2, 0], [1.5, 0.5], [1, 1], [0.5, 0.5]]
    _, tri = check_triangulation(p)
    assert {tuple(sorted(t)) for t in tri.tolist()} == {(0, 1, 5), (1, 2, 3), (3, 4, 5),
                                                        (1, 3, 5)}


def test_triangulation_of_nearly_degenerate_decimal_collinear_points():
    # 0.1 steps are not exact in binary: points are only nearly collinear, and the
    # exact predicate decides; the result must still be a valid tiling.
    xs = np.arange(11) * 0.1
    p = np.vstack([np.column_stack([xs, 3.0 * xs]), [[0.5, 4.0], [-0.5, 1.0]]])
    check_triangulation(p)


def test_large_star_polygons_are_fast(rng):
    validate_polygon(star(50, rng))  # compiled (or loaded from cache) before timing
    triangulate(star(50, rng))
    for _ in range(3):
        p = star(2000, rng)
        start = time.perf_counter()
        tri = triangulate(p)
        elapsed = time.perf_counter() - start
        assert elapsed < 0.25, f"2,000-vertex triangulation took {elapsed:.3f} s"
        check_triangulation(p)
        assert tri.shape == (1998, 3)
