"""Bit-for-bit determinism of the curved primitives that take dot products of points.

segment, capsule, pie, ring, horseshoe and quadratic_bezier project points on fixed
directions. ``Field.evaluate`` (the compiled program) must give a point the same bits
alone as in any batch, shuffled or sliced. The numpy oracle (tests/numpy_fields)
writes those products out (``vec2.rows_dot``) instead of BLAS ``q @ c``, which rounds
a row differently with its place in the batch, so segment, capsule, pie, ring and
horseshoe give exactly the compiled program's bits; star and quadratic_bezier differ
in the last bits (numpy's arctan2 / cbrt / arccos).
"""

from __future__ import annotations

import numpy as np
import numpy_fields
import pytest
from fieldcheck import FAR_POINTS, boundary_and_sides, bounds_and_axes
from test_compiled_fields_shapes import PRIMITIVES

from sdfphys.sdf import compiled, field

#: Kinds that must match the compiled program exactly; variants change branches
#: (a == b, full angles, wide apertures, short legs).
IDENTICAL = {
    "segment": {"type": "segment", "a": [-0.5, 0.1], "b": [0.7, 0.4]},
    "segment_axis": {"type": "segment", "a": [-1.0, 0.0], "b": [1.0, 0.0]},
    "segment_point": {"type": "segment", "a": [0.2, 0.1], "b": [0.2, 0.1]},
    "capsule": {"type": "capsule", "a": [-0.5, 0.0], "b": [0.5, 0.0], "radius": 0.3},
    "capsule_slanted": {"type": "capsule", "a": [-9.0, 9.0], "b": [-1.0, 6.5],
                        "radius": 0.2},
    "capsule_disk": {"type": "capsule", "a": [0.3, 0.3], "b": [0.3, 0.3], "radius": 0.5},
    **{kind: PRIMITIVES[kind] for kind in (
        "pie", "pie_half", "pie_wide", "pie_full", "ring", "ring_wide", "ring_full",
        "horseshoe", "horseshoe_short", "horseshoe_open")},
}

#: Batch independent, but not bit-identical to the compiled code (transcendentals).
OTHERS = {kind: PRIMITIVES[kind] for kind in (
    "star", "quadratic_bezier", "quadratic_bezier_stroke", "quadratic_bezier_line")}

ALL = {**IDENTICAL, **OTHERS}


def _special_points(f) -> np.ndarray:
    """Where branches meet: the origin, axes and diagonals, the corners and centre of
    the bounds, the field's own points (ends, directions), boundary points (random
    points moved along -f grad f) and points 1e-9 either side, far and tiny points."""
    rng = np.random.default_rng(3)
    x0, y0, x1, y1 = f.bounds()
    box, lines = bounds_and_axes((x0, y0, x1, y1))
    own = [np.zeros((0, 2))]
    for name in ("a", "b", "c", "n", "d"):
        v = getattr(f, name, None)
        if isinstance(v, np.ndarray) and v.shape == (2,):
            for scale in (1.0, -1.0, getattr(f, "radius", 1.0)):
                own.append(np.array([scale * v, scale * v[::-1] * [-1.0, 1.0]]))
    p = rng.uniform([x0 - 0.5, y0 - 0.5], [x1 + 0.5, y1 + 0.5], (500, 2))
    return np.concatenate([box, lines, *own, *boundary_and_sides(f, p), FAR_POINTS])


def _points(f, n: int = 3000) -> np.ndarray:
    rng = np.random.default_rng(17)
    x0, y0, x1, y1 = f.bounds()
    special = _special_points(f)
    near = rng.uniform([x0 - 0.5, y0 - 0.5], [x1 + 0.5, y1 + 0.5], (n // 2, 2))
    wide = rng.uniform(-4.0, 4.0, (n - n // 2, 2))
    return np.concatenate([special, near, wide])[:n] if len(special) < n else special[:n]


def _bits(a: np.ndarray) -> np.ndarray:
    """The float64 bit patterns (tells -0.0 from 0.0, unlike assert_array_equal)."""
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


@pytest.mark.parametrize("name", sorted(IDENTICAL))
def test_numpy_matches_the_compiled_program_bit_for_bit(name):
    f = field(IDENTICAL[name])
    assert compiled.compile_field(f) is not None
    rng = np.random.default_rng(23)
    p = np.concatenate([_special_points(f), rng.uniform(-3.0, 3.0, (20000, 2)),
                        rng.uniform(-40.0, 40.0, (500, 2))])
    value, grad = numpy_fields.evaluate(f, p)
    c_value, c_grad = compiled.evaluate(f, p)
    np.testing.assert_array_equal(value, c_value)
    np.testing.assert_array_equal(grad, c_grad)


@pytest.mark.parametrize("name", sorted(IDENTICAL))
def test_placed_numpy_matches_the_compiled_program_bit_for_bit(name):
    f = field(dict(IDENTICAL[name], offset=[0.25, -0.5], angle=0.9))
    p = np.random.default_rng(29).uniform(-3.0, 3.0, (5000, 2))
    value, grad = numpy_fields.evaluate(f, p)
    c_value, c_grad = compiled.evaluate(f, p)
    np.testing.assert_array_equal(value, c_value)
    np.testing.assert_array_equal(grad, c_grad)


@pytest.mark.parametrize("name", sorted(ALL))
def test_a_point_gets_the_same_bits_alone_and_in_a_shuffled_batch(name):
    f = field(ALL[name])
    p = _points(f)
    assert len(p) == 3000
    value, grad = f.evaluate(p)
    order = np.random.default_rng(31).permutation(len(p))
    s_value, s_grad = f.evaluate(p[order])
    np.testing.assert_array_equal(_bits(s_value), _bits(value[order]))
    np.testing.assert_array_equal(_bits(s_grad), _bits(grad[order]))
    alone = [f.evaluate(p[i:i + 1]) for i in range(len(p))]
    np.testing.assert_array_equal(_bits(np.concatenate([v for v, _ in alone])), _bits(value))
    np.testing.assert_array_equal(_bits(np.concatenate([g for _, g in alone])), _bits(grad))
    # Odd-sized slices starting at odd offsets (BLAS kernels work in blocks).
    for start, stop in ((1, 4), (3, 20), (5, 1000), (7, 2999)):
        v, g = f.evaluate(p[start:stop])
        np.testing.assert_array_equal(_bits(v), _bits(value[start:stop]))
        np.testing.assert_array_equal(_bits(g), _bits(grad[start:stop]))
