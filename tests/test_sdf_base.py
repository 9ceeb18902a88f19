"""The Field contract, the spec builder and its error messages."""

import numpy as np
import pytest
from fieldcheck import check_field

import sdfphys
from sdfphys.sdf import PRIMITIVES, field


def test_circle_and_box_are_exact(rng):
    check_field(field({"type": "circle", "radius": 1.3}), rng)
    check_field(field({"type": "box", "size": [2.0, 0.6]}), rng)


def test_circle_centre_gradient_is_finite_unit_and_deterministic():
    f = PRIMITIVES["circle"](radius=1.0)
    d, g = f.evaluate(np.zeros((3, 2)))
    np.testing.assert_array_equal(d, -1.0)
    np.testing.assert_array_equal(g, [[1.0, 0.0]] * 3)


def test_box_medial_axis_gradient_is_unit():
    f = PRIMITIVES["box"](size=[2.0, 2.0])
    d, g = f.evaluate(np.array([[0.0, 0.0], [0.5, 0.5], [-0.5, -0.5]]))
    np.testing.assert_allclose(d, [-1.0, -0.5, -0.5])
    np.testing.assert_allclose(np.linalg.norm(g, axis=1), 1.0)


def test_placement_rotates_then_translates():
    f = field({"type": "box", "size": [2.0, 1.0], "offset": [3.0, 1.0], "angle": np.pi / 2})
    # The rotated box is 1 wide and 2 tall around (3, 1).
    d = f.distance(np.array([[3.0, 2.5], [4.0, 1.0], [3.0, 1.0]]))
    np.testing.assert_allclose(d, [0.5, 0.5, -0.5], atol=1e-12)
    np.testing.assert_allclose(f.bounds(), [2.5, 0.0, 3.5, 2.0], atol=1e-12)


@pytest.mark.parametrize("spec, message", [
    ("circle", "field: must be a table with 'type' or 'op'"),
    ({"radius": 1.0}, "field: needs 'type' (a primitive) or 'op'"),
    ({"type": "circel", "radius": 1.0}, "field.type: unknown primitive 'circel' (did you mean 'circle'?)"),
    ({"type": "circle"}, "field.radius: is required for 'circle'"),
    ({"type": "circle", "radius": -1.0}, "field.radius: must be > 0, got -1"),
    ({"type": "circle", "radius": float("nan")}, "field.radius: must be finite, got nan"),
    ({"type": "circle", "radius": True}, "field.radius: must be a number, got True"),
    ({"type": "box", "size": [1.0]}, "field.size: must be a pair [x, y], got [1.0]"),
    ({"type": "box", "size": [1.0, 0.0]}, "field.size[1]: must be > 0, got 0"),
    ({"type": "circle", "radius": 1.0, "ofset": [0, 0]}, "field.ofset: unknown key for 'circle' (did you mean 'offset'?)"),
    ({"type": "circle", "radius": 1.0, "angle": "x"}, "field.angle: must be a number, got 'x'"),
])
def test_bad_specs_name_the_key_path(spec, message):
    with pytest.raises(sdfphys.SpecError) as err:
        field(spec)
    assert str(err.value).startswith(message)
