"""Field-field contacts at a sharp feature (``field_pairs.one_sided_depths``), against
closed forms: a square's corner pressed into a flat face."""

import math

import numpy as np
import pytest

from sdfphys.collide import collide
from sdfphys.collide.field_pairs import one_sided_depths, placed_field_contacts
from sdfphys.sdf.build import field
from sdfphys.settings import Settings

DEPTH = 0.02
FLAT = field({"type": "box", "size": [10.0, 1.0], "offset": [0.0, -0.5]})   # top face y = 0
SQUARE = field({"type": "box", "size": [0.4, 0.4]})
ROUND = field({"type": "circle", "radius": 0.3})
#: The square turned by 45 degrees with its lowest corner DEPTH under y = 0 at x = 0.3.
CORNER_POSE = (np.array([[0.3, 0.2 * math.sqrt(2.0) - DEPTH]]), np.array([math.pi / 4]))


def _balanced(field_a, field_b, offset, angle):
    """The descent's contacts of b placed in a (before any re-measure)."""
    _, pair, point, depth, normal, _ = placed_field_contacts(
        field_a, field_b, offset, angle, field_a.bounds(), field_b.bounds(), 0.05, 7, 24)
    return pair, point, depth, normal


def test_a_corner_in_a_flat_face_is_measured_from_the_corner():
    """The balance of max(f_a, f_b) sits at the overlap triangle's incentre, depth
    2 D sin(45) / (1 + sin(45)) = 0.83 D along a normal between the face's and the
    square's; measured from the corner: depth D, the face's normal (0, 1), the point
    midway between the corner (0.3, -D) and the face."""
    pair, point, depth, normal = _balanced(FLAT, SQUARE, *CORNER_POSE)
    assert len(depth) >= 1
    s = math.sin(math.pi / 4)
    np.testing.assert_allclose(depth, 2.0 * DEPTH * s / (1.0 + s), rtol=1e-3)
    point, depth, normal = one_sided_depths(FLAT, SQUARE, *CORNER_POSE, pair, point, depth,
                                            normal)
    np.testing.assert_allclose(depth, DEPTH, rtol=0, atol=1e-12)
    np.testing.assert_allclose(normal, np.tile([0.0, 1.0], (len(depth), 1)), rtol=0,
                               atol=1e-12)
    np.testing.assert_allclose(point, np.tile([0.3, -0.5 * DEPTH], (len(depth), 1)),
                               rtol=0, atol=1e-12)


def test_a_flat_face_on_a_corner_is_measured_from_the_corner_too():
    """The same pair the other way round (the square first): the corner is a's, the
    normal a -> b is the face's inward normal, -(0, 1) in the square's frame turned."""
    # The flat placed in the square's frame: turned by -45 degrees about the square.
    angle = -math.pi / 4
    c, s = math.cos(angle), math.sin(angle)
    x, y = -CORNER_POSE[0][0]
    offset = np.array([[c * x - s * y, s * x + c * y]])
    pair, point, depth, normal = _balanced(SQUARE, FLAT, offset, np.array([angle]))
    point, depth, normal = one_sided_depths(SQUARE, FLAT, offset, np.array([angle]), pair,
                                            point, depth, normal)
    np.testing.assert_allclose(depth, DEPTH, rtol=0, atol=1e-12)
    # The face's outward normal (0, 1), turned into the square's frame and reversed.
    expected = [-math.sin(math.pi / 4), -math.cos(math.pi / 4)]
    np.testing.assert_allclose(normal, np.tile(expected, (len(depth), 1)), rtol=0,
                               atol=1e-12)


def test_smooth_contacts_keep_their_bits():
    """Two discs (and a disc on the flat): the three measures agree, nothing changes."""
    for field_a, offset in ((ROUND, np.array([[0.59, 0.0]])),
                            (FLAT, np.array([[0.0, 0.29]]))):
        pair, point, depth, normal = _balanced(field_a, ROUND, offset, np.zeros(1))
        assert len(depth) == 1 and depth[0] > 0.0
        out = one_sided_depths(field_a, ROUND, offset, np.zeros(1), pair, point, depth,
                               normal)
        for before, after in zip((point, depth, normal), out, strict=True):
            np.testing.assert_array_equal(before, after)


def test_an_sdf_square_pressed_corner_first_reports_its_corner():
    """Through ``collide`` (sdf bodies): the corner contact's depth and normal."""
    square = {"type": "sdf", "field": {"type": "box", "size": [0.4, 0.4]}}
    ground = {"type": "sdf", "field": {"type": "box", "size": [10.0, 1.0]}}
    offset, angle = CORNER_POSE
    c = collide(ground, (0.0, -0.5, 0.0), square, (offset[0, 0], offset[0, 1], angle[0]),
                margin=0.05, settings=Settings(field_tangent_samples=0))
    deepest = np.argmax(c.depth)
    assert c.depth[deepest] == pytest.approx(DEPTH, abs=1e-12)
    np.testing.assert_allclose(c.normal[deepest], [0.0, 1.0], atol=1e-12)


def test_a_reading_against_the_balance_normal_is_not_taken():
    """The square's corner driven through a plate 6 cm thick (3 cm out of its far face):
    among the descent's contacts one balances at 6.0 cm along (0.92, -0.38); measured
    from a side, the deepest reading there is 6.2 cm along (-0.71, 0.71), against it (a
    depth to the nearest face of a thin part passed through, which pushes the wrong
    way): that contact keeps its balance, and no contact's normal turns against its
    balance normal (scenes/sdf_primitives.toml: the vesica's tip in the rounded cross,
    its normal flipping from step to step, 10.03 mm; 9.6 mm with this rule)."""
    plate = field({"type": "box", "size": [10.0, 0.06]})
    offset, angle = np.array([[0.3, 0.224]]), np.array([math.pi / 4])
    pair, point, depth, normal = _balanced(plate, SQUARE, offset, angle)
    across = np.flatnonzero(normal[:, 0] > 0.9)
    assert len(across) >= 1
    np.testing.assert_allclose(depth[across], 0.06, atol=1e-9)
    out_point, out_depth, out_normal = one_sided_depths(plate, SQUARE, offset, angle, pair,
                                                        point, depth, normal)
    np.testing.assert_array_equal(out_depth[across], depth[across])
    np.testing.assert_array_equal(out_normal[across], normal[across])
    assert np.all(np.einsum("ij,ij->i", out_normal, normal) > 0.0)
