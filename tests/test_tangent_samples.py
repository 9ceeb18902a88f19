"""Field-field contacts' tangent samples (``field_pairs.tangent_samples``): the far side of a
tilted sdf body, against closed forms."""

import math

import numpy as np
import pytest

from sdfphys.collide import collide
from sdfphys.collide.field_pairs import tangent_samples
from sdfphys.sdf.build import field
from sdfphys.settings import Settings

TILT = 0.1
GROUND = field({"type": "box", "size": [10.0, 1.0], "offset": [0.0, -0.5]})   # top face y = 0
PLANK = field({"type": "box", "size": [1.0, 0.2]})


def plank_pose() -> tuple[np.ndarray, np.ndarray]:
    """The plank tilted by TILT with its lowest corner at the origin: its bottom face
    rises to the right at slope tan(TILT)."""
    corner = np.array([-0.5 * math.cos(TILT) + 0.1 * math.sin(TILT),
                       -0.5 * math.sin(TILT) - 0.1 * math.cos(TILT)])
    return -corner[None], np.array([TILT])


def test_samples_measure_the_gap_under_the_tilted_face_and_stop_at_the_margin():
    """From the corner contact (point 0, normal +y), samples every 0.25 m out to 1 m
    each way along the tangent (-1, 0): to the right of the corner the ground point
    (x, 0) lies x sin(TILT) under the plank's bottom face, kept while under the margin
    (0.05 m: x = 0.25 and 0.5, elements 5 and 6 of the -t side); to the left the plank
    is farther than the margin. Each sample: depth minus the gap, point midway."""
    offset, angle = plank_pose()
    pair, point, depth, normal, start, element = tangent_samples(
        GROUND, PLANK, offset, angle, np.array([0]), np.zeros((1, 2)), np.zeros(1),
        np.array([[0.0, 1.0]]), np.array([3]), 0.05, 1.0, 4)
    np.testing.assert_array_equal(pair, [0, 0, 0])
    np.testing.assert_array_equal(element, [0, 5, 6])
    np.testing.assert_array_equal(start, [3, 3, 3])
    x = np.array([0.25, 0.5])
    np.testing.assert_allclose(depth[1:], -x * math.sin(TILT), rtol=0, atol=1e-12)
    # The normal is normalize(grad f_ground - grad f_plank): the ground's (0, 1) plus the
    # plank face's inward normal (-sin, cos); the point midway between the surfaces.
    face_normal = np.array([-math.sin(TILT), math.cos(TILT)])
    n = np.array([0.0, 1.0]) + face_normal
    n /= np.linalg.norm(n)
    np.testing.assert_allclose(normal[1:], np.tile(n, (2, 1)), atol=1e-12)
    gap = x * math.sin(TILT)
    np.testing.assert_allclose(point[1:], np.column_stack([x, np.zeros(2)])
                               + 0.5 * gap[:, None] * n, atol=1e-12)


def test_no_samples_when_asked_for_none_or_unbounded():
    offset, angle = plank_pose()
    args = (GROUND, PLANK, offset, angle, np.array([0]), np.zeros((1, 2)), np.zeros(1),
            np.array([[0.0, 1.0]]), np.array([3]), 0.05)
    assert len(tangent_samples(*args, 1.0, 0)[0]) == 1
    assert len(tangent_samples(*args, math.inf, 4)[0]) == 1


@pytest.mark.parametrize("samples", [0, 4])
def test_a_tilted_sdf_plank_gets_rows_under_its_far_side(samples):
    """The same plank as an sdf body on sdf ground, 2 mm above at its corner: without
    samples one contact (the corner); with them also points under the rising face, the
    farthest within the 5 cm margin."""
    settings = Settings(field_tangent_samples=samples, contacts_per_pair=8)
    offset, _ = plank_pose()
    plank = {"type": "sdf", "field": {"type": "box", "size": [1.0, 0.2]}}
    ground = {"type": "sdf", "field": {"type": "box", "size": [10.0, 1.0]}}
    c = collide(ground, (0.0, -0.5, 0.0), plank, (offset[0, 0], offset[0, 1] + 0.002, TILT),
                margin=0.05, settings=settings)
    xs = np.sort(c.point[:, 0])
    if samples == 0:
        assert len(c) == 1
    else:
        assert len(c) > 1 and xs[-1] > 0.3
        # Each depth is the face's height over the ground there, to first order.
        far = np.argmax(c.point[:, 0])
        assert -c.depth[far] == pytest.approx(0.002 + c.point[far, 0] * math.tan(TILT),
                                              rel=0.02)
