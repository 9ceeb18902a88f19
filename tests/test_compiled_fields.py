"""Tests of sdfphys.sdf.compiled: compiled programs give the numpy fields' values and
gradients (to 1e-12) at random points and at the degenerate ones (centres, medial
axes, mirror lines, vertices, boundaries), and unsupported fields fall back. The
primitives evaluated point by point (ellipse, star, grids, ...) are tested in
test_compiled_fields_shapes.py."""

from __future__ import annotations

import numpy as np
import numpy_fields
import pytest

from sdfphys.sdf import Field, compiled, field
from sdfphys.sdf.gradient import NumericGradientField
from sdfphys.shapes import TriangleMesh

BOX = {"type": "box", "size": [2.0, 1.0]}
CIRCLE = {"type": "circle", "radius": 0.8}
POLY = {"type": "polygon", "points": [[-1, -0.5], [1, -0.7], [1.2, 0.4], [0, 1], [-0.8, 0.6]]}
L_SHAPE = {"type": "polygon", "points": [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]}
SQUARE = {"type": "box", "size": [1.0, 1.0], "offset": [0.3, 0.0]}

SPECS = {
    "circle": CIRCLE,
    "box": BOX,
    "rounded_box": {"type": "rounded_box", "size": [2.0, 1.2], "radii": [0.1, 0.2, 0.3, 0.0]},
    "rounded_box_one": {"type": "rounded_box", "size": [1.0, 1.0], "radii": 0.5},
    "polygon": POLY,
    "polygon_concave": L_SHAPE,
    "half_plane": {"type": "half_plane", "normal": [0.3, 1.0], "distance": 0.2},
    "half_plane_axis": {"type": "half_plane", "normal": [0.0, 1.0]},
    "segment": {"type": "segment", "a": [-0.5, 0.1], "b": [0.7, 0.4]},
    "segment_point": {"type": "segment", "a": [0.2, 0.1], "b": [0.2, 0.1]},
    "capsule": {"type": "capsule", "a": [-0.5, 0.0], "b": [0.5, 0.0], "radius": 0.3},
    "transform": dict(BOX, offset=[0.3, -0.2], angle=0.7),
    "translate": {"op": "translate", "of": CIRCLE, "by": [0.5, 0.25]},
    "rotate": {"op": "rotate", "of": BOX, "by": -1.1},
    "scale": {"op": "scale", "of": POLY, "factor": 1.7},
    "union": {"op": "union", "of": [CIRCLE, SQUARE, dict(CIRCLE, offset=[1.0, 0.0])]},
    "intersection": {"op": "intersection", "of": [CIRCLE, SQUARE]},
    "difference": {"op": "difference", "of": [BOX, CIRCLE, SQUARE]},
    "xor": {"op": "xor", "of": [CIRCLE, SQUARE, BOX]},
    "round": {"op": "round", "of": BOX, "r": 0.2},
    "onion": {"op": "onion", "of": CIRCLE, "thickness": 0.1},
    "nested": {"op": "onion", "thickness": 0.05, "offset": [0.1, 0.2], "angle": 0.4, "of": {
        "op": "round", "r": 0.1, "of": {"op": "difference", "of": [
            {"op": "smooth_union", "k": 0.2, "of": [BOX, dict(CIRCLE, offset=[1.0, 0.5])]},
            {"op": "scale", "factor": 0.5, "of": L_SHAPE}]}}},
}
for _mode in ("smooth_union", "smooth_intersection", "smooth_difference"):
    for _blend in ("polynomial", "cubic", "circular", "exponential"):
        SPECS[f"{_mode}_{_blend}"] = {"op": _mode, "k": 0.4, "blend": _blend,
                                      "of": [CIRCLE, SQUARE, dict(BOX, angle=0.3)]}


def special_points() -> np.ndarray:
    """Centres, axes, medial axes (|x| - 1 == |y| - 0.5 for the box), vertices and
    boundary points of the fields above, exactly representable where possible."""
    ticks = np.array([-2.0, -1.2, -1.0, -0.8, -0.5, -0.3, -0.2, 0.0, 0.1, 0.2, 0.3, 0.5, 0.7,
                      0.8, 1.0, 1.2, 2.0])
    grid = np.stack(np.meshgrid(ticks, ticks), axis=-1).reshape(-1, 2)
    s = np.linspace(-2.0, 2.0, 41)
    medial = np.concatenate([np.stack([s, s - 0.5], 1), np.stack([s, -s + 0.5], 1),
                             np.stack([s, s], 1), np.stack([s, 0.5 * s], 1)])
    poly = np.array(POLY["points"], dtype=float)
    l_pts = np.array(L_SHAPE["points"], dtype=float)
    mids = 0.5 * (poly + np.roll(poly, -1, axis=0))
    return np.concatenate([grid, medial, poly, mids, l_pts, 0.5 * l_pts, [[0.5, 0.5],
                                                                          [-0.0, -0.0]]])


POINTS = np.concatenate([np.random.default_rng(3).uniform(-2.5, 2.5, (4000, 2)),
                         special_points()])


@pytest.mark.parametrize("name", sorted(SPECS))
def test_program_matches_numpy(name):
    f = field(SPECS[name])
    program = compiled.compile_field(f)
    assert program is not None
    value, grad = compiled.evaluate(f, POINTS)
    expected_value, expected_grad = numpy_fields.evaluate(f, POINTS)
    np.testing.assert_allclose(value, expected_value, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(grad, expected_grad, rtol=0.0, atol=1e-12)
    np.testing.assert_array_equal(compiled.distance(f, POINTS), value)
    np.testing.assert_array_equal(f.evaluate(POINTS)[0], value)


def test_mesh_shapes_compile():
    for mesh in (TriangleMesh([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]),
                 TriangleMesh.box([0.5, 0.4])):
        points = np.concatenate([POINTS, mesh.vertices, 0.5 * mesh.vertices])
        assert compiled.compile_field(mesh.field) is not None
        value, grad = compiled.evaluate(mesh.field, points)
        expected_value, expected_grad = numpy_fields.evaluate(mesh.field, points)
        np.testing.assert_allclose(value, expected_value, atol=1e-12)
        np.testing.assert_allclose(grad, expected_grad, atol=1e-12)


def test_unsupported_fields_fall_back_and_the_program_is_cached():
    numeric = NumericGradientField(field({"type": "ellipse", "size": [2.0, 1.0]}))
    assert compiled.compile_field(numeric) is None
    assert compiled.compile_field(field({"op": "union", "of": [CIRCLE, numeric]})) is None
    value, _ = compiled.evaluate(numeric, POINTS[:10])
    np.testing.assert_array_equal(value, numeric.evaluate(POINTS[:10])[0])
    f = field(BOX)
    assert compiled.compile_field(f) is compiled.compile_field(f)


class _UserDisk(Field):
    """A field of the user's own: a disk of radius 0.4 at (0.2, 0.1), in numpy."""

    exact = True

    def evaluate(self, points):
        q = np.asarray(points, dtype=float) - [0.2, 0.1]
        length = np.hypot(q[:, 0], q[:, 1])
        return length - 0.4, q / np.maximum(length, 1e-300)[:, None]

    def bounds(self):
        return np.array([-0.2, -0.3, 0.6, 0.5])


@pytest.mark.parametrize("mode", ["smooth_union", "smooth_difference", "xor", "difference"])
def test_trees_with_fields_of_the_user_s_own_run_the_program_around_them(mode):
    """Operators over a user's field: the program stops at each EXTERNAL leaf, Python
    evaluates the leaf at the points in its frame (a transform and a scale above it),
    the program resumes; the numpy oracle, which calls the leaf itself, agrees."""
    leaf = {"op": "scale", "factor": 1.5, "of": _UserDisk()}
    spec = {"op": mode, "of": [BOX, {"op": "transform", "of": field(leaf), "offset": [0.4, 0.0],
                                     "angle": 0.3}, _UserDisk()]}
    if mode.startswith("smooth"):
        spec["k"] = 0.3
    f = field(spec)
    assert compiled.compile_field(f) is None
    program = compiled.field_program(f)
    assert np.sum(program.code[:, 0] == compiled.EXTERNAL) == len(program.externals) == 2
    value, grad = f.evaluate(POINTS)
    expected_value, expected_grad = numpy_fields.evaluate(f, POINTS)
    np.testing.assert_allclose(value, expected_value, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(grad, expected_grad, rtol=0.0, atol=1e-12)
    assert compiled.evaluate(f, np.zeros((0, 2)))[0].shape == (0,)


def test_a_field_without_evaluate_is_named():
    class Bare(Field):
        def bounds(self):
            return np.zeros(4)

    with pytest.raises(NotImplementedError, match="Bare is a Field without evaluate"):
        Bare().evaluate(POINTS[:3])


def test_empty_and_single_point():
    f = field(SPECS["nested"])
    value, grad = compiled.evaluate(f, np.zeros((0, 2)))
    assert value.shape == (0,) and grad.shape == (0, 2)
    value, grad = compiled.evaluate(f, np.array([0.3, 0.1]))
    np.testing.assert_allclose(value, numpy_fields.evaluate(f, np.array([0.3, 0.1]))[0],
                               atol=1e-12)


FAR = {
    "inner": {"op": "smooth_union", "k": 0.2, "of": [CIRCLE, {"type": "box",
                                                             "size": [1.6, 0.5]}]},
    "terrain": {"op": "smooth_union", "k": 0.8, "of": [
        {"type": "box", "size": [26.0, 1.0], "offset": [0.0, -0.5]},
        {"type": "circle", "radius": 2.0, "offset": [-5.0, -1.0]},
        {"type": "ellipse", "size": [5.0, 1.6], "offset": [5.0, 0.0]}]},
    "placed": {"op": "smooth_union", "k": 0.3, "blend": "circular", "angle": 0.4,
               "offset": [0.2, -0.1], "of": [BOX, dict(CIRCLE, offset=[2.5, 0.3]),
                                             {"op": "scale", "factor": 0.5, "of": L_SHAPE}]},
}


@pytest.mark.parametrize("name", sorted(FAR))
def test_far_operands_skipped_give_the_blend_point_by_point(name):
    """A smooth union's exact operands with finite boxes are guarded by SKIP_FAR, which
    skips them for a batch far enough outside their box; the value and gradient are the
    numpy field's at every point evaluated alone (a batch of one: far or not, inside the
    operand's box or not) and in batches of neighbours, near the operands and far from
    them (the skip taken)."""
    from sdfphys.sdf.opcodes import SKIP_FAR

    f = field(FAR[name])
    program = compiled.compile_field(f)
    assert np.sum(program.code[:, 0] == SKIP_FAR) == len(FAR[name]["of"]) - 1
    x0, y0, x1, y1 = f.bounds()
    rng = np.random.default_rng(4)
    points = np.column_stack([rng.uniform(x0 - 2.0, x1 + 2.0, 600),
                              rng.uniform(y0 - 2.0, y1 + 2.0, 600)])
    expected_value, expected_grad = numpy_fields.evaluate(f, points)
    for i in range(len(points)):
        value, grad = compiled.evaluate(f, points[i:i + 1])
        np.testing.assert_allclose(value, expected_value[i:i + 1], rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(grad, expected_grad[i:i + 1], rtol=0.0, atol=1e-12)
    for centre in points[:60]:
        batch = centre + rng.normal(scale=0.05, size=(16, 2))
        value, grad = compiled.evaluate(f, batch)
        expected = numpy_fields.evaluate(f, batch)
        np.testing.assert_allclose(value, expected[0], rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(grad, expected[1], rtol=0.0, atol=1e-12)
