"""Polygon validation, triangulation and mass properties against exact answers.

References: brute force (exact rational arithmetic, point-in-polygon by crossing
number, all-pairs edge tests), closed forms (rectangle, disk) and pymunk's
area_for_poly / moment_for_poly / moment_for_circle.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from fractions import Fraction

import numpy as np
import pymunk
import pytest

from sdfphys import geometry
from sdfphys._jit import interpreted
from sdfphys.errors import SpecError
from sdfphys.geometry import (
    _cell_moments,
    _orient,
    circle_mass_properties,
    field_mass_properties,
    polygon_bounds,
    polygon_mass_properties,
    triangulate,
    validate_polygon,
)
from sdfphys.sdf import Field, field

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
    return np.vstack([outer, inner[::-1]])


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
    ([[0, 0], [1, 0], [0, 1e120]], "points[2]", "coordinates beyond 1e+100 m"),
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
    # compiled (or loaded from cache) before timing: longer than the interpreted outlines
    validate_polygon(star(geometry.INTERPRETED_VERTICES + 1, rng))
    triangulate(star(geometry.INTERPRETED_VERTICES + 1, rng))
    for _ in range(3):
        p = star(2000, rng)
        start = time.perf_counter()
        tri = triangulate(p)
        elapsed = time.perf_counter() - start
        assert elapsed < 0.25, f"2,000-vertex triangulation took {elapsed:.3f} s"
        check_triangulation(p)
        assert tri.shape == (1998, 3)


def test_spiral_and_comb_of_about_2000_vertices_are_fast():
    triangulate(spiral())
    for p in (spiral(turns=6.0, n=1000), comb(650)):
        start = time.perf_counter()
        tri = triangulate(p)
        elapsed = time.perf_counter() - start
        assert elapsed < 0.25, f"{len(p)}-vertex triangulation took {elapsed:.3f} s"
        assert tri.shape == (len(p) - 2, 3)
        assert np.all(signed_areas(validate_polygon(p), tri) > 0.0)


def test_the_interpreted_kernels_give_the_compiled_kernels_bits(rng):
    """``_jit.interpreted``: the simplicity tests and the ear clipping run as Python (for
    short outlines) give what their compiled kernels give, to the bit and index: on
    random concave stars, integer-jittered hexagons (exact ties: collinear vertices,
    folds, touching and crossing edges, both windings) and nearly collinear decimal
    points (the exact predicate's path)."""
    hexagon = 2.0 * np.column_stack([np.cos(np.arange(6) * np.pi / 3),
                                     np.sin(np.arange(6) * np.pi / 3)])
    xs = np.arange(11) * 0.1
    outlines = ([star(n, rng) for n in (5, 12, 40, 64)]
                + [np.round(hexagon + rng.integers(-2, 3, size=(6, 2))) for _ in range(200)]
                + [np.vstack([np.column_stack([xs, 3.0 * xs]), [[0.5, 4.0], [-0.5, 1.0]]]),
                   collinear_rich(), np.asarray(U_SHAPE, float)[::-1], comb(5)])
    kernels = (geometry._all_collinear, geometry._first_fold, geometry._first_intersection)
    valid = 0
    for p in outlines:
        p = np.ascontiguousarray(p, dtype=np.float64)
        if (p == np.roll(p, 1, axis=0)).all(axis=1).any():
            continue                        # repeated points: validation stops earlier
        for kernel in kernels:
            assert interpreted(kernel)(p) == kernel(p), (kernel.__name__, p)
        try:
            q = validate_polygon(p)
        except SpecError:
            continue
        valid += 1
        assert interpreted(geometry._is_counter_clockwise)(p) == \
            geometry._is_counter_clockwise(p)
        np.testing.assert_array_equal(interpreted(geometry._ear_clip)(q), geometry._ear_clip(q))
    assert valid > 50
    triples = rng.uniform(-1.0, 1.0, (2000, 6))
    triples[:, 4:] = triples[:, :2] + rng.uniform(0.0, 1.0, (2000, 1)) * (
        triples[:, 2:4] - triples[:, :2])                   # c on the line a-b, rounded
    for t in triples:
        assert interpreted(_orient)(*t) == _orient(*t)


SMALL_POLYGONS = """
import numpy as np
from sdfphys import geometry
kernels = (geometry._all_collinear, geometry._first_fold, geometry._first_intersection,
           geometry._is_counter_clockwise, geometry._ear_clip)
theta = np.linspace(0.0, 2.0 * np.pi, {n}, endpoint=False)
radius = np.where(np.arange({n}) % 2 == 0, 1.0, 0.5)
geometry.triangulate([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]])
geometry.triangulate(np.column_stack([radius * np.cos(theta), radius * np.sin(theta)]))
print(sum(len(k.signatures) for k in kernels))
"""


def test_short_outlines_compile_no_kernel_and_long_ones_take_the_kernels():
    """A scene's polygons (up to INTERPRETED_VERTICES vertices) are checked and
    triangulated with no geometry kernel compiled or loaded (a cold start skips their
    compile); a longer outline takes the five kernels."""
    n = geometry.INTERPRETED_VERTICES
    counts = [subprocess.run([sys.executable, "-c", SMALL_POLYGONS.format(n=m)],
                             capture_output=True, text=True, check=True, timeout=600,
                             env={**os.environ, "SDFPHYS_COMPILE_NOTICE": "0"}).stdout.split()
              for m in (n, n + 2)]
    assert counts == [["0"], ["5"]]


def test_triangulate_reports_errors_under_the_callers_path():
    with pytest.raises(SpecError, match=r"^body\[1\]\.shape\.points: edges 0 and 2 cross"):
        triangulate([[0, 0], [1, 1], [1, 0], [0, 1]], path="body[1].shape.points")


# --------------------------------------------------------------------------------------
# polygon_mass_properties, circle_mass_properties, polygon_bounds
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("w, h, x0, y0", [(1.0, 1.0, 0.0, 0.0), (2.0, 0.5, 3.0, -1.0),
                                          (0.1, 7.0, -2.5, 4.0)])
def test_rectangle_mass_properties_closed_form(w, h, x0, y0):
    rect = np.array([[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
    for poly in (rect + [x0, y0], (rect + [x0, y0])[::-1]):
        area, centroid, second_moment = polygon_mass_properties(poly)
        assert area == pytest.approx(w * h, rel=1e-14)
        np.testing.assert_allclose(centroid, [x0, y0], rtol=0, atol=1e-14 * (w + h))
        assert second_moment == pytest.approx(w * h * (w * w + h * h) / 12.0, rel=1e-13)


@pytest.mark.parametrize("n", [3, 5, 64, 4096])
def test_regular_polygon_second_moment_closed_form(n):
    # n isosceles triangles of apex angle q = 2 pi / n and legs R about the centre:
    # J = n R^4 sin(q) (2 + cos q) / 12, tending to the disk's pi R^4 / 2.
    radius, angle = 1.7, 2.0 * np.pi / n
    t = np.arange(n) * angle + 0.3
    poly = radius * np.column_stack([np.cos(t), np.sin(t)]) + [0.4, -0.9]
    area, centroid, second_moment = polygon_mass_properties(poly)
    assert area == pytest.approx(0.5 * n * radius ** 2 * np.sin(angle), rel=1e-13)
    np.testing.assert_allclose(centroid, [0.4, -0.9], atol=1e-13)
    assert second_moment == pytest.approx(
        n * radius ** 4 * np.sin(angle) * (2.0 + np.cos(angle)) / 12.0, rel=1e-12)
    if n == 4096:
        assert second_moment == pytest.approx(np.pi * radius ** 4 / 2.0, rel=1e-6)


@pytest.mark.parametrize("name, poly", [("L", L_SHAPE), ("U", U_SHAPE), ("comb", comb(5)),
                                        ("spiral", spiral()),
                                        ("star", star(300, np.random.default_rng(3)))])
def test_polygon_mass_properties_match_pymunk(name, poly):
    poly = np.asarray(poly, dtype=float) * 0.7 + [1.5, -2.0]
    assert shoelace(poly) > 0.0  # pymunk's area is signed, positive counter-clockwise
    area, centroid, second_moment = polygon_mass_properties(poly[::-1])
    assert area == pytest.approx(pymunk.area_for_poly(poly.tolist()), rel=1e-12)
    centred = (poly - centroid).tolist()
    # pymunk: moment of a body of `mass` about the origin of the vertices' frame.
    assert second_moment == pytest.approx(pymunk.moment_for_poly(area, centred, (0, 0)),
                                          rel=1e-11)
    # The centroid is where the first moment vanishes: pymunk's moment about any
    # other point is larger by area * distance^2 (parallel axes).
    shifted = pymunk.moment_for_poly(area, (poly - centroid - [0.3, 0.2]).tolist(), (0, 0))
    assert shifted == pytest.approx(second_moment + area * 0.13, rel=1e-11)


def test_polygon_mass_properties_far_from_origin_and_rotated():
    base = np.asarray(U_SHAPE, dtype=float)
    area0, centroid0, j0 = polygon_mass_properties(base)
    angle = 0.7
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    far = base @ rot.T + [1e6, -3e6]
    area, centroid, j = polygon_mass_properties(far)
    assert area == pytest.approx(area0, rel=1e-9)
    np.testing.assert_allclose(centroid, rot @ centroid0 + [1e6, -3e6], rtol=0, atol=1e-8)
    assert j == pytest.approx(j0, rel=1e-9)


def test_polygon_mass_properties_validates():
    with pytest.raises(SpecError, match="collinear"):
        polygon_mass_properties([[0, 0], [1, 1], [2, 2]])


@pytest.mark.parametrize("radius", [0.05, 1.0, 3.5])
def test_circle_mass_properties_match_pymunk(radius):
    area, centroid, second_moment = circle_mass_properties(radius)
    assert area == pytest.approx(pymunk.area_for_circle(0.0, radius), rel=1e-15)
    np.testing.assert_array_equal(centroid, [0.0, 0.0])
    assert second_moment == pytest.approx(np.pi * radius ** 4 / 2.0, rel=1e-15)
    assert second_moment == pytest.approx(pymunk.moment_for_circle(area, 0.0, radius),
                                          rel=1e-14)


@pytest.mark.parametrize("radius", [0.0, -1.0, float("nan"), "1"])
def test_circle_mass_properties_rejects_bad_radius(radius):
    with pytest.raises(SpecError) as err:
        circle_mass_properties(radius, path="body[0].shape.radius")
    assert err.value.path == "body[0].shape.radius"


def test_polygon_bounds():
    np.testing.assert_array_equal(polygon_bounds(U_SHAPE), [0, 0, 3, 3])
    np.testing.assert_array_equal(polygon_bounds([[1.5, -2.0]]), [1.5, -2.0, 1.5, -2.0])
    with pytest.raises(ValueError, match="shape"):
        polygon_bounds([1.0, 2.0, 3.0])


# --------------------------------------------------------------------------------------
# field_mass_properties
# --------------------------------------------------------------------------------------

class ExactPolygonField(Field):
    """Exact SDF of a simple polygon, brute force over edges (a reference for tests)."""

    def __init__(self, vertices: np.ndarray):
        self.vertices = np.asarray(vertices, dtype=float)

    def evaluate(self, points):
        p = self.vertices
        a = p[None, :, :]
        e = np.roll(p, -1, axis=0)[None, :, :] - a
        t = np.clip(((points[:, None, :] - a) * e).sum(-1) / (e * e).sum(-1), 0.0, 1.0)
        offset = points[:, None, :] - a - t[..., None] * e
        length = np.hypot(offset[..., 0], offset[..., 1])
        nearest = length.argmin(axis=1)
        rows = np.arange(len(points))
        distance = length[rows, nearest]
        sign = np.where(inside(p, points), -1.0, 1.0)
        gradient = sign[:, None] * offset[rows, nearest] / np.maximum(distance, 1e-300)[:, None]
        return sign * distance, gradient

    def bounds(self):
        return polygon_bounds(self.vertices)


class HalfPlane(Field):
    """y <= 0: unbounded."""

    def evaluate(self, points):
        return points[:, 1].copy(), np.tile([0.0, 1.0], (len(points), 1))

    def bounds(self):
        return np.array([-np.inf, -np.inf, np.inf, 0.0])


class Nowhere(Field):
    """f = 1 everywhere, with finite (loose) bounds: an empty region."""

    def evaluate(self, points):
        return np.ones(len(points)), np.tile([1.0, 0.0], (len(points), 1))

    def bounds(self):
        return np.array([-1.0, -1.0, 1.0, 1.0])


def clipped_square(n: np.ndarray, d: float) -> np.ndarray:
    """Part of the unit cell [-1/2, 1/2]^2 with n.u <= -d (Sutherland-Hodgman, one plane)."""
    square = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    out = []
    for i in range(4):
        p, q = square[i], square[(i + 1) % 4]
        sp, sq = p @ n + d, q @ n + d
        if sp <= 0:
            out.append(p)
        if sp * sq < 0:
            out.append(p + (q - p) * sp / (sp - sq))
    return np.array(out)


def test_cell_moments_are_exact_for_a_half_plane(rng):
    for _ in range(400):
        angle = rng.uniform(0.0, 2.0 * np.pi)
        if rng.random() < 0.2:
            angle = rng.integers(0, 8) * np.pi / 4  # axis-aligned and diagonal normals
        n = np.array([np.cos(angle), np.sin(angle)])
        d = rng.uniform(-0.8, 0.8)
        scale = rng.uniform(0.5, 2.0)  # |grad f| != 1: d = f / |grad f|
        w, m, normal = _cell_moments(np.array([d * scale]), scale * n[None, :], 1.0)
        part = clipped_square(n, d)
        if len(part) < 3:
            assert w[0] == pytest.approx(0.0, abs=1e-15) and m[0] == pytest.approx(0, abs=1e-15)
            continue
        q = np.roll(part, -1, axis=0)
        cross = part[:, 0] * q[:, 1] - part[:, 1] * q[:, 0]
        area = 0.5 * cross.sum()
        first = (cross[:, None] * (part + q)).sum(axis=0) / 6.0
        assert w[0] == pytest.approx(area, abs=1e-14)
        np.testing.assert_allclose(normal[0], n, atol=1e-15)
        assert m[0] == pytest.approx(first @ n, abs=1e-14)


def random_shapes(rng: np.random.Generator, count: int):
    """(name, field, (area, centroid, second moment)) for disks, rotated boxes, rotated Ls."""
    ell = np.array(L_SHAPE, dtype=float)
    for _ in range(count):
        r = rng.uniform(0.5, 1.5)
        c = rng.uniform(-1.0, 1.0, 2)
        yield ("disk", field({"type": "circle", "radius": r, "offset": c.tolist()}),
               (np.pi * r * r, c, np.pi * r ** 4 / 2.0))
        w, h = rng.uniform(1.5, 2.5), rng.uniform(0.8, 1.2)
        c = rng.uniform(-1.0, 1.0, 2)
        box = field({"type": "box", "size": [w, h], "offset": c.tolist(),
                     "angle": rng.uniform(0.0, np.pi / 2)})
        yield "box", box, (w * h, c, w * h * (w * w + h * h) / 12.0)
        angle = rng.uniform(0.0, np.pi / 2)
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        poly = ell @ rot.T * rng.uniform(0.8, 1.2) + rng.uniform(-1.0, 1.0, 2)
        yield "L", ExactPolygonField(poly), polygon_mass_properties(poly)


def test_field_mass_properties_are_second_order_within_the_stated_bounds(rng):
    """Relative area error < (h/D)^2, second moment < 2 (h/D)^2, centroid < 0.3 h^2/D."""
    worst: dict[tuple[str, int], np.ndarray] = {}
    for name, f, (area, centroid, second_moment) in random_shapes(rng, 4):
        size = np.sqrt(area)
        for k, h in enumerate((size / 10.0, size / 20.0)):
            a, c, j = field_mass_properties(f, h)
            errors = np.array([abs(a - area) / area, abs(j - second_moment) / second_moment,
                               np.linalg.norm(c - centroid) / size])
            coefficients = errors / (h / size) ** 2
            assert coefficients[0] < 1.0, (name, h, coefficients)
            assert coefficients[1] < 2.0, (name, h, coefficients)
            assert coefficients[2] < 0.3, (name, h, coefficients)
            worst[name, k] = np.maximum(worst.get((name, k), 0.0), errors)
    # Halving the cell: on the smooth disk, where the error is the h^2 bias alone, the
    # area and second-moment errors drop by 4; with corners the O(h^2) corner terms
    # change sign with the grid offset, and the worst of four drops by 2 to 6.
    ratio = {name: worst[name, 1] / worst[name, 0] for name in ("disk", "box", "L")}
    np.testing.assert_allclose(ratio["disk"][:2], 0.25, atol=0.03)
    assert np.all(ratio["box"][:2] < 0.7) and np.all(ratio["L"][:2] < 0.7), ratio


def test_field_mass_properties_do_not_depend_on_chunking(monkeypatch):
    f = field({"type": "circle", "radius": 1.0, "offset": [0.2, 0.1]})
    whole = field_mass_properties(f, 0.02)
    monkeypatch.setattr(geometry, "_CHUNK_POINTS", 1000)
    chunked = field_mass_properties(f, 0.02)
    assert chunked[0] == pytest.approx(whole[0], rel=1e-12)
    np.testing.assert_allclose(chunked[1], whole[1], atol=1e-12)
    assert chunked[2] == pytest.approx(whole[2], rel=1e-12)


def test_field_mass_properties_rejects_unbounded_empty_and_bad_cell():
    with pytest.raises(SpecError, match=r"^body\[3\]\.shape\.field: is unbounded"):
        field_mass_properties(HalfPlane(), 0.1, path="body[3].shape.field")
    with pytest.raises(SpecError, match="has no inside"):
        field_mass_properties(Nowhere(), 0.1)
    for cell in (0.0, -0.1, float("nan")):
        with pytest.raises(SpecError) as err:
            field_mass_properties(field({"type": "circle", "radius": 1.0}), cell)
        assert err.value.path == "cell"
