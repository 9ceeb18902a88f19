"""Tests of sdfphys.collide._descent_kernels: the geometry the descent builds on, what
the starts of a triangle are read to show, and the batch independence of results.

The descent's answers themselves are tested against exact answers and a brute
force in tests/test_descent.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles import Opaque
from test_descent import brute_minimum, closest_on_triangle

from sdfphys.collide import _descent_paths as paths
from sdfphys.collide import _descent_starts as start_kernels
from sdfphys.collide import descent, field_pairs
from sdfphys.collide._placed_fields import placed_starts
from sdfphys.sdf import field
from sdfphys.sdf.compiled import compile_field


def random_triangles(count: int, rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, (count, 1, 2)) + rng.uniform(-0.5, 0.5, (count, 3, 2))


def closest_point(tri: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Closest point of triangle tri (3, 2) to x (2,); degenerate triangles allowed."""
    (ux, uy), (vx, vy) = tri[1] - tri[0], tri[2] - tri[0]
    area = ux * vy - uy * vx
    if area != 0.0:
        return closest_on_triangle(tri, x[None])[0]
    feet = []
    for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
        e = b - a
        t = np.clip((x - a) @ e / (e @ e), 0.0, 1.0) if e @ e > 0.0 else 0.0
        feet.append(a + t * e)
    return min(feet, key=lambda q: np.sum((x - q) ** 2))


def test_projection_is_the_closest_point_with_its_derivative():
    rng = np.random.default_rng(1)
    tri = random_triangles(200, rng)
    tri[:10, 2] = 0.5 * (tri[:10, 0] + tri[:10, 1])                # collinear
    tri[10:15] = tri[10:15, :1]                                     # points
    h = 1e-7
    for t in range(len(tri)):
        for x in rng.uniform(-2.0, 2.0, (10, 2)):
            u = rng.normal(size=2)
            q = np.array(paths.project(paths._vertices(tri, t), x[0], x[1], u[0], u[1]))
            expected = closest_point(tri[t], x)
            np.testing.assert_allclose(q[:2], expected, atol=1e-12)
            ahead = closest_point(tri[t], x + h * u)
            behind = closest_point(tri[t], x - h * u)
            one_sided = [(ahead - expected) / h, (expected - behind) / h]
            # dq is the derivative along u (one-sided where x sits on a region border).
            assert min(np.abs(q[2:] - d).max() for d in one_sided) < 1e-5, (t, x, u)


def test_projection_returns_vertices_exactly():
    tri = np.array([[[0.1, 0.2], [1.3, -0.4], [0.7, 0.9]]])
    for v in range(3):
        outward = tri[0, v] - tri[0].mean(axis=0)
        x = tri[0, v] + 3.0 * outward
        q = paths.project(paths._vertices(tri, 0), x[0], x[1], 1.0, 0.0)
        assert (q[0], q[1]) == (tri[0, v, 0], tri[0, v, 1])
        assert (q[2], q[3]) == (0.0, 0.0)


def test_the_projected_ray_stops_at_its_computed_end():
    """Checked against ``project`` (itself checked above against a brute force, whose
    rounding far from the triangle would blur the last 1e-7 m of a grazing slide)."""
    rng = np.random.default_rng(2)
    tri = random_triangles(300, rng)
    for t in range(len(tri)):
        w = rng.dirichlet(np.ones(3))
        b = w @ tri[t]
        u = rng.normal(size=2)
        end, dx, dy = paths._ray_end(paths._vertices(tri, t), b[0], b[1], u[0], u[1])
        at_end = np.array(paths.project(paths._vertices(tri, t), *(b + end * u), *u))
        np.testing.assert_allclose(at_end[:2], closest_point(tri[t], b + end * u), atol=1e-12)
        for later in (1.5, 4.0, 100.0):
            after = paths.project(paths._vertices(tri, t), *(b + later * end * u), *u)
            np.testing.assert_allclose(after[:2], at_end[:2], atol=1e-12)
        if end > 1e-6:
            # Just before the end the path still moves, with dq/ds as returned.
            s = end * (1.0 - 1e-6)
            before = np.array(paths.project(paths._vertices(tri, t), *(b + s * u), *u))
            np.testing.assert_allclose((at_end[:2] - before[:2]) / (end - s), [dx, dy],
                                       atol=1e-6)
            np.testing.assert_allclose(before[2:], [dx, dy], atol=1e-12)


def known(spec: dict, tri: np.ndarray) -> np.ndarray:
    f = field(spec)
    weights = descent.START_BARYCENTRIC
    points, _, _, at_vertex = start_kernels.triangle_starts(tri, weights)
    d, g = f.evaluate(points)
    _, shape = start_kernels.triangle_known(tri, at_vertex, points, d, np.ascontiguousarray(g),
                                      len(weights), True, descent._convex(f.spec), 1e-12)
    return shape


BOX = {"type": "box", "size": [2.0, 1.0], "angle": 0.3}


def test_what_the_starts_show():
    # Above the long face of the box: one plane. Beyond a corner: a cone.
    face = np.array([[[-0.2, 0.8], [0.3, 0.8], [0.0, 1.1]]])
    face = face @ np.array([[np.cos(0.3), np.sin(0.3)], [-np.sin(0.3), np.cos(0.3)]])
    assert known(BOX, face)[0, 0] == paths.PLANE
    corner = np.array([[[1.3, 0.7], [1.6, 0.9], [1.4, 1.2]]])
    shape = known({"type": "box", "size": [2.0, 1.0]}, corner)
    assert shape[0, 0] == paths.CONE
    np.testing.assert_allclose(shape[0, 1:3], [1.3, 0.7], atol=1e-12)   # nearest the corner
    circle = np.array([[[1.0, 0.2], [1.6, -0.3], [1.4, 0.6]]])
    shape = known({"type": "circle", "radius": 0.8}, circle)
    assert shape[0, 0] == paths.CONE
    np.testing.assert_allclose(shape[0, 3], field({"type": "circle", "radius": 0.8}).distance(
        shape[0, 1:3][None])[0], atol=1e-12)
    # Inside the box across its medial axis: cuts, whose minimum is exact.
    inside = np.array([[[0.3, -0.3], [0.9, 0.1], [0.6, 0.35]]])
    shape = known({"type": "box", "size": [2.0, 1.0]}, inside)
    assert shape[0, 0] == paths.CUTS
    f = field({"type": "box", "size": [2.0, 1.0]})
    assert f.distance(shape[0, 1:3][None])[0] == pytest.approx(shape[0, 3], abs=1e-12)
    assert shape[0, 3] == pytest.approx(brute_minimum(f, inside[0]), abs=1e-9)


def test_no_cutting_planes_for_fields_not_known_convex():
    inside = np.array([[[0.3, -0.3], [0.9, 0.1], [0.6, 0.35]]])
    union = {"op": "union", "of": [{"type": "box", "size": [2.0, 1.0]},
                                   {"type": "circle", "radius": 0.1, "offset": [5.0, 5.0]}]}
    assert known(union, inside)[0, 0] == paths.GENERAL
    assert descent._convex(field(BOX).spec)
    assert descent._convex(field({"op": "round", "r": 0.1, "of": BOX}).spec)
    assert descent._convex(field({"type": "polygon",
                                  "points": [[0, 0], [1, 0], [1, 1], [0, 1]]}).spec)
    assert not descent._convex(field({"type": "polygon",
                                      "points": [[0, 0], [2, 0], [2, 1], [1, 0.3], [0, 1]]}).spec)
    assert not descent._convex(field(union).spec)
    assert not descent._convex(None)


@pytest.mark.parametrize("spec", [BOX, {"type": "circle", "radius": 0.8}, {
    "op": "smooth_union", "k": 0.3, "of": [
        {"type": "circle", "radius": 0.6, "offset": [-0.5, 0.0]},
        {"type": "box", "size": [1.0, 0.6], "offset": [0.5, 0.1], "angle": 0.5}]}])
def test_a_triangles_answer_does_not_depend_on_its_batch(spec):
    """Bit for bit: alone, at another place of another batch, or after a larger call
    (the work arrays are reused between calls)."""
    f = field(spec)
    tri = random_triangles(300, np.random.default_rng(4))
    point, value = descent.triangle_deepest(f, tri)
    for t in (0, 17, 299):
        alone_point, alone_value = descent.triangle_deepest(f, tri[t:t + 1])
        np.testing.assert_array_equal(alone_point[0], point[t])
        np.testing.assert_array_equal(alone_value[0], value[t])
    shuffled = np.random.default_rng(5).permutation(len(tri))
    point2, value2 = descent.triangle_deepest(f, tri[shuffled])
    np.testing.assert_array_equal(point2, point[shuffled])
    np.testing.assert_array_equal(value2, value[shuffled])


# --------------------------------------------------------------------------------------
# The osculating point of a field pair (_descent_paths._osculating_point)
# --------------------------------------------------------------------------------------

def osculating_point(b: np.ndarray, prior: np.ndarray, fields) -> tuple[bool, np.ndarray]:
    """``_osculating_point`` of one start at b with its prior point, fields (fa, fb): callables
    x -> (value, gradient) in a's frame."""
    (fa, ga), (fb, gb) = fields[0](b), fields[1](b)
    found, x, y = paths._osculating_point(fa, fb, *ga, *gb, *b, *prior, *fields[0](prior)[1],
                                      *fields[1](prior)[1])
    return found, np.array([x, y])


def circle(centre: np.ndarray, radius: float):
    return lambda x: (np.hypot(*(x - centre)) - radius, (x - centre) / np.hypot(*(x - centre)))


def plane(normal: np.ndarray, offset: float):
    """f(x) = n . x - offset (n unit)."""
    return lambda x: (normal @ x - offset, normal.copy())


def test_the_osculating_point_of_two_circles_is_their_contact():
    """Circles are their own osculating circles: from any b and prior point (gradients
    that turn between them), the point is the balanced deepest point of the two exact
    fields, on the line through the centres midway between the surfaces (overlapping or
    apart; not nested, where f_a - f_b keeps its sign along that line)."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        ca, cb = rng.uniform(-1.0, 1.0, 2), rng.uniform(-1.0, 1.0, 2)
        gap = np.hypot(*(cb - ca))
        ra = rng.uniform(0.1, 1.0)
        rb = rng.uniform(max(0.05, ra - 0.9 * gap), ra + 0.9 * gap)
        e = (cb - ca) / gap
        b = 0.5 * (ca + cb) + rng.uniform(-0.3, 0.3, 2)
        prior = b + rng.uniform(-2.0, 2.0, 2)
        found, point = osculating_point(b, prior, (circle(ca, ra), circle(cb, rb)))
        assert found
        np.testing.assert_allclose(point, ca + 0.5 * (gap + ra - rb) * e, atol=1e-9)


def test_the_osculating_point_of_a_circle_and_a_plane_is_their_contact():
    """A plane does not turn its gradient: it is modelled by itself, and the point lies
    on the normal through the circle's centre, midway between the plane and the
    circle."""
    rng = np.random.default_rng(6)
    for _ in range(200):
        c, r = rng.uniform(-1.0, 1.0, 2), rng.uniform(0.1, 1.0)
        angle = rng.uniform(0.0, 2.0 * np.pi)
        n = np.array([np.cos(angle), np.sin(angle)])
        height = rng.uniform(0.05 - r, r + 0.3)        # the centre above -r: they balance
        offset = n @ c - height
        b = c - 0.5 * height * n + rng.uniform(-0.3, 0.3, 2)
        prior = b + rng.uniform(-2.0, 2.0, 2)
        for fields, sign in (((plane(n, offset), circle(c, r)), 1.0),
                             ((circle(c, r), plane(n, offset)), 1.0)):
            found, point = osculating_point(b, prior, fields)
            assert found
            np.testing.assert_allclose(point, c - 0.5 * (height + r) * n * sign, atol=1e-9)


def test_two_opposed_planes_balance_and_two_planes_that_do_not_oppose_give_nothing():
    """Two flat fields: the point is b moved onto their mid-plane when they oppose (every
    point of it is a minimum); none when their gradients do not oppose."""
    rng = np.random.default_rng(7)
    n = np.array([0.6, 0.8])
    b, prior = rng.uniform(-1.0, 1.0, 2), rng.uniform(-1.0, 1.0, 2)
    found, point = osculating_point(b, prior, (plane(n, 0.3), plane(-n, 0.1)))
    assert found
    # f_a = n.x - 0.3 and f_b = -n.x - 0.1 balance where n.x = 0.1, moved along n.
    np.testing.assert_allclose(n @ point, 0.1, atol=1e-12)
    np.testing.assert_allclose(point - b, (n @ (point - b)) * n, atol=1e-12)
    tilted = np.array([0.8, -0.6])
    assert not osculating_point(b, prior, (plane(n, 0.3), plane(tilted, 0.1)))[0]


def test_starts_on_two_crossing_circles_converge_in_two_rounds():
    """A field pair's start takes one ladder round to get a prior point, then the
    osculating point, exact for circles, where it stops (its gradients antiparallel and
    balanced): two rounds for every start, compiled or Python-driven (the ladders alone
    took 4 to 13)."""
    rng = np.random.default_rng(21)
    for _ in range(40):
        ra, rb = rng.uniform(0.2, 1.5, 2)
        d = rng.uniform(abs(ra - rb) + 0.02, ra + rb - 1e-3)       # crossing, not nested
        theta = rng.uniform(0.0, 2.0 * np.pi)
        angle = rng.uniform(-3.0, 3.0)
        fa, fb = field({"type": "circle", "radius": ra}), field({"type": "circle", "radius": rb})
        _, _, rotation, offset, _, pair_of, points, sigma, tol = placed_starts(
            np.array([fa.bounds()], float), np.array([fb.bounds()], float),
            d * np.array([[np.cos(theta), np.sin(theta)]]), np.cos([angle]), np.sin([angle]),
            np.zeros(1), field_pairs._starts(7))
        programs = field_pairs.PairPrograms.of(compile_field(fa), compile_field(fb), 1)
        compiled = descent.descend_pairs(programs.table, programs.prog_a, programs.prog_b,
                                         programs.run, rotation, offset, pair_of, points, sigma,
                                         tol.copy(), 16)
        problem = field_pairs._PairProblem(Opaque(fa), Opaque(fb), rotation, offset, pair_of)
        python = descent._descend(problem, points, 16, sigma, tol.copy())
        np.testing.assert_array_equal(compiled[3], 2)
        np.testing.assert_array_equal(python[3], 2)
