"""Tests of the compiled triangle descent (sdfphys.collide._compiled_descent): for
fields that compile, ``triangle_deepest`` run in one compiled call gives the same
minima, values and rounds as the Python-driven loop, on the cases of
tests/test_descent.py; fields that do not compile take the Python loop."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from oracles import Opaque, enclosing_circles, merge_minima
from test_descent import CIRCLE, FIELDS, UNION, random_triangles

from sdfphys.collide import descent, field_pairs
from sdfphys.sdf import compiled, field
from sdfphys.sdf.program_table import pair_table

CASES = dict(FIELDS, plain_circle=CIRCLE, union_again=UNION,
             rounded={"op": "round", "r": 0.1, "of": {"type": "box", "size": [1.0, 0.5]}},
             onion={"op": "onion", "thickness": 0.1, "of": {"type": "circle", "radius": 0.7}},
             difference={"op": "difference", "of": [
                 {"type": "box", "size": [2.0, 2.0]}, {"type": "circle", "radius": 0.6}]})
STARTS = {"default": None, "centroid": descent.START_BARYCENTRIC[[6]],
          "vertices": descent.START_BARYCENTRIC[[0, 1, 2]],
          "mesh_order": descent.START_BARYCENTRIC[[6, 3, 4, 5, 0, 1, 2]]}


def both_paths(f, tri, iterations, starts):
    fast = descent._triangle_minima(f, tri, iterations, starts, 1e-12)
    slow = descent._triangle_minima(Opaque(f), tri, iterations, starts, 1e-12)
    return fast, slow


@pytest.mark.parametrize("starts", sorted(STARTS))
@pytest.mark.parametrize("name", sorted(CASES))
def test_compiled_descent_equals_the_python_loop(name, starts):
    f = field(CASES[name])
    assert compiled.compile_field(f) is not None
    tri = random_triangles(f, 300, np.random.default_rng(sorted(CASES).index(name)))
    tri[:5, 2] = 0.5 * (tri[:5, 0] + tri[:5, 1])                    # degenerate
    for iterations in (1, 4, 16, 32):
        (p1, v1, r1), (p2, v2, r2) = both_paths(f, tri, iterations, STARTS[starts])
        np.testing.assert_allclose(p1, p2, rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(v1, v2, rtol=0.0, atol=1e-12)
        np.testing.assert_array_equal(r1, r2)
        keep1, keep2 = descent.merge_minima(p1, 1e-6), descent.merge_minima(p2, 1e-6)
        np.testing.assert_array_equal(keep1, keep2)


def test_compiled_descent_handles_batches_of_every_size():
    f = field(FIELDS["smooth_union"])
    rng = np.random.default_rng(5)
    for count in (0, 1, 2, 50, 3000, 7):                            # buffers grow, then shrink
        tri = random_triangles(f, count, rng)
        (p1, v1, r1), (p2, v2, r2) = both_paths(f, tri, 16, None)
        assert p1.shape == (count, 7, 2)
        np.testing.assert_allclose(p1, p2, atol=1e-12)
        np.testing.assert_allclose(v1, v2, atol=1e-12)
        np.testing.assert_array_equal(r1, r2)


def test_fields_that_do_not_compile_take_the_python_loop():
    f = Opaque(field({"type": "ellipse", "size": [2.0, 1.0]}))
    assert compiled.compile_field(f) is None
    tri = random_triangles(f, 20, np.random.default_rng(0))
    point, value = descent.triangle_deepest(f, tri)
    np.testing.assert_allclose(value, f.distance(point.reshape(-1, 2)).reshape(value.shape),
                               atol=1e-12)


PAIRS = {
    "smooth_union_box": (FIELDS["smooth_union"], {"type": "box", "size": [1.0, 0.4]}),
    "box_polygon": ({"type": "box", "size": [1.0, 0.4]}, FIELDS["polygon"]),
    "circle_onion": (CIRCLE, {"op": "onion", "thickness": 0.1,
                              "of": {"type": "circle", "radius": 0.5}}),
    "half_plane_union": ({"type": "half_plane", "normal": [0.0, 1.0]}, UNION),
}


@pytest.mark.parametrize("name", sorted(PAIRS))
def test_compiled_field_field_descent_equals_the_python_loop(name):
    a, b = (field(spec) for spec in PAIRS[name])
    rng = np.random.default_rng(sorted(PAIRS).index(name))
    count = 60
    poses = np.column_stack([rng.uniform(-1.5, 1.5, (count, 2)), rng.uniform(0.0, 6.0, count)])
    # Regions of different sizes: per-start tolerances (the uneven stopping rule).
    regions = np.column_stack([poses[:, :2] - rng.uniform(0.3, 1.0, (count, 2)),
                               poses[:, :2] + rng.uniform(0.3, 1.0, (count, 2))])
    regions[::7, 2] = regions[::7, 0] - 1.0                          # empty
    pair_of = np.repeat(np.arange(count), 5)
    rotation = field_pairs._rotations(poses[:, 2])
    problem = field_pairs._PairProblem(a, b, rotation, poses[:, :2], pair_of)
    numpy_problem = field_pairs._PairProblem(Opaque(a), Opaque(b), rotation, poses[:, :2],
                                             pair_of)
    starts = np.repeat(poses[:, :2], 5, axis=0) + rng.uniform(-0.8, 0.8, (5 * count, 2))
    sigma = rng.uniform(0.1, 1.0, 5 * count)
    tol = 1e-12 * np.repeat(rng.uniform(0.5, 3.0, count), 5)
    for iterations in (0, 1, 3, 24):
        fast = descent._descend(problem, starts, iterations, sigma, tol)
        slow = descent._descend(numpy_problem, starts, iterations, sigma, tol)
        for x, y in zip(fast, slow):
            np.testing.assert_allclose(x, y, rtol=0.0, atol=1e-12)
    for margin in (0.0, 0.05):
        fast = field_pairs.field_field_contacts(a, b, poses, regions, margin=margin)
        slow = field_pairs.field_field_contacts(Opaque(a), Opaque(b), poses, regions,
                                                margin=margin)
        for x, y in zip(fast, slow):
            assert x.shape == y.shape
            np.testing.assert_allclose(x, y, rtol=0.0, atol=1e-12)


def test_compiled_field_field_descent_in_blocks_equals_the_python_loop():
    """More starts than one block of ``_compiled_descent.descend`` (``_BLOCK``), with
    per-start tolerances: the blocks give the one batch's results."""
    from sdfphys.collide import _compiled_descent

    a, b = (field(spec) for spec in PAIRS["smooth_union_box"])
    rng = np.random.default_rng(11)
    count = _compiled_descent._BLOCK // 5 + 300
    poses = np.column_stack([rng.uniform(-1.5, 1.5, (count, 2)), rng.uniform(0.0, 6.0, count)])
    pair_of = np.repeat(np.arange(count), 5)
    rotation = field_pairs._rotations(poses[:, 2])
    problem = field_pairs._PairProblem(a, b, rotation, poses[:, :2], pair_of)
    numpy_problem = field_pairs._PairProblem(Opaque(a), Opaque(b), rotation, poses[:, :2],
                                             pair_of)
    starts = np.repeat(poses[:, :2], 5, axis=0) + rng.uniform(-0.8, 0.8, (5 * count, 2))
    sigma = rng.uniform(0.1, 1.0, 5 * count)
    tol = 1e-12 * np.repeat(rng.uniform(0.5, 3.0, count), 5)
    tol[-5:] = 1e-13                                      # the smallest in the last block
    fast = descent._descend(problem, starts, 16, sigma, tol)
    slow = descent._descend(numpy_problem, starts, 16, sigma, tol)
    for x, y in zip(fast, slow):
        np.testing.assert_allclose(x, y, rtol=0.0, atol=1e-12)


def test_compiled_triangle_helpers_equal_the_numpy_ones():
    rng = np.random.default_rng(9)
    tri = rng.uniform(-1.0, 1.0, (3000, 3, 2))
    tri[:10, 2] = 0.5 * (tri[:10, 0] + tri[:10, 1])                # collinear
    tri[10:20] = tri[10:20, :1]                                     # points
    tri[20:30, 1] = tri[20:30, 0]                                   # a repeated vertex
    tri[30:40] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]               # right angle
    centre, radius = descent.enclosing_circles(tri)
    expected_centre, expected_radius = enclosing_circles(tri)
    np.testing.assert_array_equal(centre, expected_centre)
    np.testing.assert_array_equal(radius, expected_radius)
    point = rng.uniform(0.0, 2e-6, (2000, 7, 2))
    point[::3] = 0.5
    np.testing.assert_array_equal(descent.merge_minima(point, 1e-6),
                                  merge_minima(point, 1e-6))


def test_the_descent_bundles_hold_their_fields_in_order_and_type_the_shared_signature():
    """``_compiled_descent``'s makers list PROBLEM_FIELDS and WORK_FIELDS by hand
    (compiled, cached) and make the types of the shared ``_rounds`` signature (PROBLEM,
    WORK); a descent through a small work bundle grows its arrays in the bundle and
    gives the results of the thread's own."""
    import inspect

    from numba import typeof

    from sdfphys.collide import _compiled_descent as cd

    assert tuple(inspect.signature(cd._descent_problem.py_func).parameters) == \
        cd.PROBLEM_FIELDS
    assert tuple(inspect.signature(cd._descent_work.py_func).parameters) == cd.WORK_FIELDS
    small = cd.descent_work(1)
    assert typeof(small) == cd.WORK
    f = field(FIELDS["smooth_union"])
    program = compiled.compile_field(f)
    tri = random_triangles(f, 40, np.random.default_rng(9))
    points, owner, sigma, at_vertex = descent.start_kernels.triangle_starts(
        tri, np.ascontiguousarray(descent.START_BARYCENTRIC))
    first = np.zeros(1, np.int64)
    problem = cd.descent_problem(cd.TRIANGLE, False, 2, pair_table(program, program), first,
                                 first, first, np.zeros((1, 2, 2)), np.zeros((1, 2)), owner, tri,
                                 owner, at_vertex, 7, True, False)
    assert typeof(problem) == cd.PROBLEM
    tol = np.full(len(points), 1e-12)
    results = [cd.descend(problem, points, sigma, 16, tol, descent.SHAPE_TOL, work)
               for work in (small, descent.work(), small)]
    for other in results[1:]:
        for mine, theirs in zip(results[0], other):
            np.testing.assert_array_equal(mine, theirs)
    assert _state_rows(small) >= len(points)


@njit
def _state_rows(work):
    return work.state.shape[0]
