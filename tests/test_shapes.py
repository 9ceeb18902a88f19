"""Shapes: body frames, mass properties, bounds, spec validation and instancing."""

import math

import numpy as np
import pytest

from sdfphys.errors import SpecError
from sdfphys.sdf import Field
from sdfphys.shapes import Circle, SdfShape, TriangleMesh, shape_from_spec

L_POINTS = [[0.0, 0.0], [3.0, 0.0], [3.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]


def test_circle():
    s = shape_from_spec({"type": "circle", "radius": 0.5})
    assert isinstance(s, Circle) and s.kind == "circle"
    assert s.area == pytest.approx(math.pi * 0.25, rel=1e-15)
    assert s.second_moment == pytest.approx(0.5 * math.pi * 0.5 ** 4, rel=1e-15)
    np.testing.assert_array_equal(s.bounds(), [-0.5, -0.5, 0.5, 0.5])
    np.testing.assert_array_equal(s.origin, [0.0, 0.0])
    assert s.radius == 0.5
    np.testing.assert_allclose(s.field.distance([[1.0, 0.0], [0.0, 0.0]]), [0.5, -0.5])
    assert s.spec == {"type": "circle", "radius": 0.5}


def test_box_is_a_mesh_with_the_box_field():
    s = shape_from_spec({"type": "box", "size": [2, 1]})
    assert isinstance(s, TriangleMesh) and s.kind == "mesh"
    assert s.field.spec == {"type": "box", "size": [2.0, 1.0]}
    assert s.area == pytest.approx(2.0)
    assert s.second_moment == pytest.approx(2.0 * (4.0 + 1.0) / 12.0)
    assert s.radius == pytest.approx(math.hypot(1.0, 0.5))
    np.testing.assert_array_equal(s.bounds(), [-1.0, -0.5, 1.0, 0.5])
    v = s.vertices
    area = 0.5 * np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])
    assert area == pytest.approx(2.0)                         # counter-clockwise
    tri = v[s.triangles]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    assert np.all(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0)
    np.testing.assert_allclose(s.field.distance(v), 0.0, atol=1e-15)
    assert s.triangles.dtype == np.int64 and s.outline.shape == (4, 2)


def test_polygon_is_moved_to_its_centroid():
    s = shape_from_spec({"type": "polygon", "points": L_POINTS[::-1]})   # clockwise input
    # L = [0,3]x[0,1] (area 3, centroid (1.5, 0.5)) + [0,1]x[1,2] (area 1, centroid (.5, 1.5))
    centroid = np.array([(3 * 1.5 + 0.5) / 4, (3 * 0.5 + 1.5) / 4])
    assert s.area == pytest.approx(4.0)
    np.testing.assert_allclose(s.origin, -centroid, atol=1e-15)
    # polar moments about each part's centroid, then the parallel-axis theorem
    j = (3 * (9 + 1) / 12 + 3 * np.sum((np.array([1.5, 0.5]) - centroid) ** 2)
         + 1 * (1 + 1) / 12 + 1 * np.sum((np.array([0.5, 1.5]) - centroid) ** 2))
    assert s.second_moment == pytest.approx(j, rel=1e-12)
    assert len(s.triangles) == 4
    np.testing.assert_allclose(s.vertices.mean(axis=0) + centroid,
                               np.mean(L_POINTS, axis=0), atol=1e-15)
    np.testing.assert_allclose(s.field.distance(s.vertices), 0.0, atol=1e-12)
    # the notch corner (1, 1) is on the boundary; (2, 1.5) is outside by 0.5
    np.testing.assert_allclose(s.field.distance(np.array([[1.0, 1.0], [2.0, 1.5]]) - centroid),
                               [0.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(s.bounds(), np.r_[-centroid, np.array([3.0, 2.0]) - centroid])


def test_sdf_shape_mass_properties_to_1e_4():
    s = shape_from_spec({"type": "sdf", "field": {"type": "circle", "radius": 0.7,
                                                  "offset": [1.0, -2.0]}})
    assert s.kind == "sdf"
    assert s.area == pytest.approx(math.pi * 0.49, rel=1e-4)
    assert s.second_moment == pytest.approx(0.5 * math.pi * 0.7 ** 4, rel=1e-4)
    np.testing.assert_allclose(s.origin, [-1.0, 2.0], atol=1e-4)
    # body frame: the field is centred on the centre of mass
    assert s.field.distance([[0.0, 0.0]])[0] == pytest.approx(-0.7, abs=1e-4)
    np.testing.assert_allclose(s.bounds(), [-0.7, -0.7, 0.7, 0.7], atol=1e-4)
    assert s.radius == pytest.approx(0.7 * math.sqrt(2), rel=1e-3)

    b = shape_from_spec({"type": "sdf", "field": {"type": "box", "size": [2.0, 0.5],
                                                  "angle": 0.3}})
    assert b.area == pytest.approx(1.0, rel=1e-4)
    assert b.second_moment == pytest.approx(1.0 * (4.0 + 0.25) / 12.0, rel=1e-4)
    np.testing.assert_allclose(b.origin, [0.0, 0.0], atol=1e-4)      # 1e-4 sqrt(area)


class HalfPlane(Field):
    """y <= 0, for the unbounded-shape checks without depending on the primitive."""

    def evaluate(self, points):
        p = np.asarray(points, float).reshape(-1, 2)
        return p[:, 1].copy(), np.tile([0.0, 1.0], (len(p), 1))

    def bounds(self):
        return np.array([-np.inf, -np.inf, np.inf, 0.0])


def test_unbounded_sdf_shape_is_static_only():
    s = SdfShape(HalfPlane())
    assert s.radius == math.inf
    np.testing.assert_array_equal(s.origin, [0.0, 0.0])
    np.testing.assert_array_equal(s.bounds(), [-np.inf, -np.inf, np.inf, 0.0])
    assert s.field.distance([[3.0, 2.0]])[0] == 2.0
    with pytest.raises(SpecError, match="static"):
        _ = s.area
    with pytest.raises(SpecError, match="static"):
        _ = s.second_moment


def test_equal_specs_share_one_shape():
    a = shape_from_spec({"type": "box", "size": [2, 1]})
    assert a is shape_from_spec({"size": [2.0, 1.0], "type": "box"})
    assert a is not shape_from_spec({"type": "box", "size": [1, 2]})
    c = shape_from_spec({"type": "sdf", "field": {"op": "round", "r": 0.1,
                                                  "of": {"type": "box", "size": [1, 1]}}})
    assert c is shape_from_spec({"type": "sdf", "field": {"of": {"size": [1.0, 1.0],
                                                                 "type": "box"},
                                                          "op": "round", "r": 0.1}})
    assert shape_from_spec(a) is a
    assert shape_from_spec(a.spec) is a


@pytest.mark.parametrize("spec, path, message", [
    ({"type": "cirlce", "radius": 1}, "body[2].shape.type", "did you mean 'circle'"),
    ({"type": "circle", "radius": -1.0}, "body[2].shape.radius", "must be >= 0.001"),
    ({"type": "circle", "radius": 1, "size": 2}, "body[2].shape.size", "unknown key"),
    ({"type": "box", "sise": [1, 1]}, "body[2].shape.sise", "did you mean 'size'"),
    ({"type": "box"}, "body[2].shape.size", "required"),
    ({"type": "box", "size": [1, 0]}, "body[2].shape.size[1]", "must be > 0"),
    ({"type": "polygon", "points": [[0, 0], [1, 0]]}, "body[2].shape.points", "at least 3"),
    ({"type": "polygon", "points": [[0, 0], [1, 1], [1, 0], [0, 1]]},
     "body[2].shape.points", ""),
    ({"type": "sdf", "field": {"type": "bxo", "size": [1, 1]}}, "body[2].shape.field.type",
     "did you mean 'box'"),
    ({"radius": 1}, "body[2].shape", "needs a 'type'"),
    ([1, 2], "body[2].shape", "must be a table"),
])
def test_bad_specs_name_the_key_path(spec, path, message):
    with pytest.raises(SpecError) as err:
        shape_from_spec(spec, "body[2].shape")
    assert err.value.path.startswith(path)
    assert message in err.value.message


@pytest.mark.parametrize("spec", [
    {"type": "circle", "radius": 0.37},
    {"type": "box", "size": [0.9, 0.3]},
    {"type": "box", "size": [0.2, 0.7]},
    {"type": "polygon", "points": [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]},
    {"type": "polygon", "points": [[0, 0], [1, 0], [0.5, 0.8]]},
    {"type": "sdf", "field": {"type": "star", "radius": 0.7, "points": 5, "m": 3.0}},
])
def test_core_radius_is_minus_the_field_at_the_centre_of_mass_bit_for_bit(spec):
    """Circles and boxes give it in closed form (no field evaluated when a scene loads,
    so a scene of circles and boxes compiles no field program), the same bits."""
    shape = shape_from_spec(spec)
    expected = -float(shape.field.evaluate(np.zeros((1, 2)))[0][0])
    assert shape.core_radius == expected
    assert math.copysign(1.0, shape.core_radius) == math.copysign(1.0, expected)
