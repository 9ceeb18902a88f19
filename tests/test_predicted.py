"""Predicted contacts (``collide.predicted``): circles against bodies that turn fast or
that they move fast against."""

import math

import numpy as np
import pytest

from sdfphys.collide.predicted import SOURCE_PREDICTED, predicted_contacts
from sdfphys.collide.shape_fields import ShapeFields
from sdfphys.shapes import shape_from_spec
from sdfphys.vec2 import rotate

DT = 1.0 / 60.0
SLOP = 0.005
PADDLE = {"type": "box", "size": [1.2, 0.2]}
BALL = {"type": "circle", "radius": 0.1}


def query(position, angle, velocity, spin, margin=0.5, specs=(PADDLE, BALL)):
    """predicted_contacts of body 0 and body 1 (one candidate pair)."""
    shapes = [shape_from_spec(s) for s in specs]
    return predicted_contacts(
        ShapeFields.of(shapes), np.arange(2), np.array([[0, 1]]),
        np.array([s.kind == "circle" for s in shapes]), np.array([s.radius for s in shapes]),
        np.array(position, float), np.array(angle, float), np.array(velocity, float),
        np.array(spin, float), DT, SLOP, margin, np.zeros(2))


def test_the_row_is_the_pair_at_its_end_poses_carried_back_to_the_start():
    """A paddle spinning at 20 rad/s (0.33 rad a step) and moving, a ball moving: the row's
    normal is the paddle's outward normal at the ball's end position (turned into the
    world, negated: ball -> paddle is b -> a here, stored a -> b), its paddle point turned
    and moved by the step is the paddle's surface point nearest the ball's end centre,
    and its separation is the end-pose gap |c' - q'| - r (exact box field)."""
    paddle_v, ball_v, spin = np.array([0.3, -0.2]), np.array([-0.5, 0.4]), 20.0
    position = [[0.0, 0.0], [0.40, 0.45]]
    c = query(position, [0.1, 0.0], [paddle_v, ball_v], [spin, 0.0])
    assert len(c) == 1 and c.body_a[0] == 0 and c.body_b[0] == 1
    assert c.feature[0] == SOURCE_PREDICTED << 56
    end_angle = 0.1 + spin * DT
    centre_end = np.array(position[1]) + ball_v * DT
    paddle_end = np.array(position[0]) + paddle_v * DT
    box = shape_from_spec(PADDLE).field
    local = rotate((centre_end - paddle_end)[None], -end_angle)
    d = float(box.distance(local)[0])
    gap = d - 0.1
    assert gap > 0.0
    n, s0 = c.normal[0], -c.depth[0]                # paddle (a) -> ball (b)
    # The paddle's material point under the row, carried to the end pose, lies on the
    # paddle's end surface, d from the ball's end centre along -n; the row's separation
    # carried by the two bodies' moves is the end-pose gap.
    material = c.point[0] - 0.5 * s0 * n             # a's surface point: point - s0 n / 2
    carried = paddle_end + rotate((material - position[0])[None], spin * DT)[0]
    np.testing.assert_allclose(carried, centre_end - d * n, atol=1e-12)
    end_local = rotate((carried - paddle_end)[None], -end_angle)
    assert abs(float(box.distance(end_local)[0])) < 1e-12
    moved = (carried - material) - (centre_end - position[1])
    assert s0 - n @ moved == pytest.approx(gap, abs=1e-12)


def test_a_predicted_overlap_is_held_as_touching_never_reported_deep():
    """Where the end pose would overlap, the row starts at separation 0 (it stops the
    approach along its normal; it does not push now): depth exactly 0."""
    c = query([[0.0, 0.0], [0.62, 0.12]], [0.0, 0.0], [[0.0, 0.0], [0.0, 0.0]], [30.0, 0.0])
    assert len(c) == 1 and c.depth[0] == 0.0


def test_no_prediction_for_slow_turns_two_circles_or_far_pairs():
    """|w| R dt at most the slop (R = 0.608 m: w <= 0.49 rad/s), two circles, or a gap
    beyond the pair's margin: no row."""
    rest = [[0.0, 0.0], [0.0, 0.0]]
    assert len(query([[0.0, 0.0], [0.45, 0.3]], [0.1, 0.0], rest, [0.49, 0.0])) == 0
    assert len(query([[0.0, 0.0], [0.45, 0.3]], [0.1, 0.0], rest, [0.5, 0.0])) == 1
    assert len(query([[0.0, 0.0], [0.25, 0.0]], [0.0, 0.0], rest, [50.0, 0.0],
                     specs=(BALL, BALL))) == 0
    assert len(query([[0.0, 0.0], [0.45, 0.3]], [0.1, 0.0], rest, [20.0, 0.0],
                     margin=0.01)) == 0


def test_the_circle_may_be_either_body():
    """Ball first (body 0), paddle second: the same row, normal a -> b (ball -> paddle)."""
    one = query([[0.0, 0.0], [0.40, 0.45]], [0.1, 0.0], [[0.0, 0.0], [0.0, 0.0]], [20.0, 0.0])
    two = query([[0.40, 0.45], [0.0, 0.0]], [0.0, 0.1], [[0.0, 0.0], [0.0, 0.0]], [0.0, 20.0],
                specs=(BALL, PADDLE))
    assert len(one) == len(two) == 1 and one.depth[0] < 0.0
    assert two.depth[0] == one.depth[0]
    np.testing.assert_allclose(two.normal[0], -one.normal[0], atol=1e-15)
    np.testing.assert_allclose(two.point[0], one.point[0], atol=1e-15)


@pytest.mark.parametrize("on", [True, False])
def test_the_world_query_adds_the_row_unless_the_knob_is_off(on):
    """``find_contacts`` with the paddle spinning at 20 rad/s beside the ball: its contacts
    plus the predicted row (source 6) with ``predicted_contacts`` on, without it off, the
    other rows the same either way."""
    from sdfphys.collide import find_contacts
    from sdfphys.settings import Settings

    shapes = [shape_from_spec(s) for s in (PADDLE, BALL)]
    settings = Settings(predicted_contacts=on)
    args = (shapes, np.arange(2), np.array([[0.0, 0.0], [0.40, 0.35]]), np.array([0.1, 0.0]),
            np.array([True, True]), settings, np.zeros((2, 2)), np.array([20.0, 0.0]))
    got = find_contacts(*args)
    predicted = (got.feature >> 56) == SOURCE_PREDICTED
    assert np.count_nonzero(predicted) == (1 if on else 0)
    plain = find_contacts(*args[:5], Settings(predicted_contacts=False), *args[6:])
    np.testing.assert_array_equal(got.feature[~predicted], plain.feature)
    np.testing.assert_array_equal(got.depth[~predicted], plain.depth)


def test_a_fast_circle_gets_its_end_pose_row_through_its_centre():
    """A still paddle, a ball moving at (3, -2) m/s past its corner: the row's normal is
    the paddle's outward normal at the ball's end centre, its separation carried by the
    ball's move is the end-pose gap d' - r, and its point lies on the line through the
    ball's centre along the normal (no torque on the ball), midway across the gap."""
    ball_v = np.array([3.0, -2.0])
    position = [[0.0, 0.0], [0.62, 0.22]]
    c = query(position, [0.0, 0.0], [[0.0, 0.0], ball_v], [0.0, 0.0])
    assert len(c) == 1 and c.body_a[0] == 0 and c.body_b[0] == 1
    centre_end = np.array(position[1]) + ball_v * DT
    box = shape_from_spec(PADDLE).field
    d = float(box.distance(centre_end[None])[0])
    corner = np.array([0.6, 0.1])
    n_end = (centre_end - corner) / np.linalg.norm(centre_end - corner)   # corner region
    np.testing.assert_allclose(c.normal[0], n_end, atol=1e-12)
    s0 = -c.depth[0]
    assert s0 > 0.0
    assert s0 + n_end @ (ball_v * DT) == pytest.approx(d - 0.1, abs=1e-12)
    arm = c.point[0] - np.array(position[1])
    assert abs(arm[0] * n_end[1] - arm[1] * n_end[0]) < 1e-12
    assert -arm @ n_end == pytest.approx(0.1 + 0.5 * s0, abs=1e-12)


def test_a_fast_circle_inside_its_end_tangent_gets_no_row():
    """Against a body that does not turn the row is kept only when speculative: a ball
    sliding fast along the paddle's top face into its corner region, already below the
    end pose's tangent line through the corner (s0 < 0), gets none."""
    c = query([[0.0, 0.0], [0.55, 0.2]], [0.0, 0.0], [[0.0, 0.0], [6.0, 0.0]], [0.0, 0.0])
    assert len(c) == 0


def test_a_row_that_repeats_a_contact_is_dropped():
    """``find_contacts``: a ball falling fast onto the paddle's flat top has its plain
    contact and no predicted row (same normal, same separation: it would repeat it); the
    same ball moving fast toward the paddle's corner has one."""
    from sdfphys.collide import find_contacts
    from sdfphys.settings import Settings

    shapes = [shape_from_spec(s) for s in (PADDLE, BALL)]

    def rows(ball, velocity):
        got = find_contacts(shapes, np.arange(2), np.array([[0.0, 0.0], ball]),
                            np.zeros(2), np.array([True, True]), Settings(),
                            np.array([[0.0, 0.0], velocity]), np.zeros(2))
        return got, (got.feature >> 56) == SOURCE_PREDICTED

    got, predicted = rows([0.0, 0.25], [0.0, -5.0])
    assert len(got) == 1 and not predicted.any()
    got, predicted = rows([0.72, 0.16], [-4.0, 0.0])
    assert np.count_nonzero(predicted) == 1


def _field_rows(specs, position, angle, velocity, spin):
    """``find_contacts`` of two sdf bodies: (all contacts, the sdf pair's predicted rows)."""
    from sdfphys.collide import find_contacts
    from sdfphys.collide.predicted import FIELD_PAIR
    from sdfphys.settings import Settings

    shapes = [shape_from_spec(s) for s in specs]
    got = find_contacts(shapes, np.arange(2), np.array(position, float),
                        np.array(angle, float), np.array([False, True]), Settings(),
                        np.array(velocity, float), np.array(spin, float))
    field = ((got.feature >> 56) == SOURCE_PREDICTED) & ((got.feature & FIELD_PAIR) != 0)
    return got, got.take(field)


SLAB = {"type": "sdf", "field": {"type": "box", "size": [4.0, 1.0]}}    # top face y = 0.5


def test_a_turning_sdf_corner_gets_rows_at_its_end_pose():
    """An sdf square (side 0.4) spinning at 20 rad/s and falling at 2 m/s, a corner 2 mm
    over a still sdf slab: at the end poses (one step on, 0.33 rad turned) its lowest
    corner e is in the slab, a contact along the face's normal (0, 1) (measured from the
    corner). Carried back, the row holds that corner's start position m against the
    face point under e: separation max(m_y - 0.5, 0), point midway between the two."""
    square = {"type": "sdf", "field": {"type": "box", "size": [0.4, 0.4]}}
    centre = np.array([0.0, 0.5 + 0.2 * math.sqrt(2.0) + 0.002])
    fall, spin = np.array([0.0, -2.0]), 20.0
    _, rows = _field_rows((SLAB, square), [[0.0, 0.0], centre], [0.0, math.pi / 4],
                          [[0.0, 0.0], fall], [0.0, spin])
    assert len(rows) == 1 and rows.body_a[0] == 0 and rows.body_b[0] == 1
    corners = np.array([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]])
    end_angle = math.pi / 4 + spin * DT
    ends = centre + fall * DT + rotate(corners, np.full(4, end_angle))
    lowest = int(np.argmin(ends[:, 1]))
    e = ends[lowest]
    assert e[1] < 0.5                                   # the end pose overlaps
    m = centre + rotate(corners[lowest:lowest + 1], np.array([math.pi / 4]))[0]
    np.testing.assert_allclose(rows.normal[0], [0.0, 1.0], atol=1e-12)
    assert -rows.depth[0] == pytest.approx(max(m[1] - 0.5, 0.0), abs=1e-9)
    np.testing.assert_allclose(rows.point[0], 0.5 * (np.array([e[0], 0.5]) + m), atol=1e-9)


def test_no_field_rows_for_a_rolling_curve_or_a_slow_turn():
    """An sdf disc rolling on the slab (its end contact has a centre of curvature: its
    own rows, anchored there, hold it; a row on the point ahead would brake it), and the
    square turning at 0.05 rad/s: none."""
    disc = {"type": "sdf", "field": {"type": "circle", "radius": 0.3}}
    _, rows = _field_rows((SLAB, disc), [[0.0, 0.0], [0.0, 0.8]], [0.0, 0.0],
                          [[0.0, 0.0], [3.0, 0.0]], [0.0, -10.0])
    assert len(rows) == 0
    square = {"type": "sdf", "field": {"type": "box", "size": [0.4, 0.4]}}
    _, rows = _field_rows((SLAB, square), [[0.0, 0.0], [0.0, 0.5 + 0.2 * math.sqrt(2.0)]],
                          [0.0, math.pi / 4], [[0.0, 0.0], [0.0, 0.0]], [0.0, 0.05])
    assert len(rows) == 0


STEP = {"type": "polygon", "points": [[-2, -1], [1, -1], [1, 1], [0, 1], [0, 0], [-2, 0]]}
SMALL_BOX = {"type": "box", "size": [0.2, 0.2]}


def _mesh_rows(floor, box_x, speed):
    """``find_contacts`` of a still polygon ``floor`` (user origin at the world origin) and
    a 0.2 m box 1 mm over its top y = 0 at ``box_x``, sliding along +x at ``speed``:
    (all contacts, the predicted rows with the end-pose bit)."""
    from sdfphys.collide import find_contacts
    from sdfphys.collide.predicted import FIELD_PAIR
    from sdfphys.settings import Settings

    shapes = [shape_from_spec(floor), shape_from_spec(SMALL_BOX)]
    got = find_contacts(shapes, np.arange(2), np.array([-shapes[0].origin, [box_x, 0.101]]),
                        np.zeros(2), np.array([False, True]), Settings(),
                        np.array([[0.0, 0.0], [speed, 0.0]]), np.zeros(2))
    end = ((got.feature >> 56) == SOURCE_PREDICTED) & ((got.feature & FIELD_PAIR) != 0)
    return got, got.take(end)


def test_a_vertex_sliding_toward_a_concave_body_s_wall_gets_a_row_on_that_wall():
    """A box slides at 3 m/s (5 cm a step) on a concave step's floor toward its wall
    x = 0, its right face 2 cm from it. Its bottom-right corner's contact is on the floor
    (normal (0, 1)); at the end poses that corner is 3 cm into the wall. The row carried
    back: along the wall's normal (-1, 0) (step -> box), on the corner's start position
    against the wall point level with it, separation 2 cm, at their midpoint; its key
    names the corner's contact (same low bits), under the predicted source."""
    got, rows = _mesh_rows(STEP, -0.12, 3.0)
    assert len(rows) == 1 and rows.body_a[0] == 0 and rows.body_b[0] == 1
    np.testing.assert_allclose(rows.normal[0], [-1.0, 0.0], atol=1e-12)
    assert -rows.depth[0] == pytest.approx(0.02, abs=1e-12)
    np.testing.assert_allclose(rows.point[0], [-0.01, 0.001], atol=1e-12)
    low = (1 << 52) - 1
    corner = [k for k in range(len(got)) if (got.feature[k] >> 56) != SOURCE_PREDICTED
              and (got.feature[k] & low) == (rows.feature[0] & low)]
    assert len(corner) == 1
    np.testing.assert_allclose(got.normal[corner[0]], [0.0, 1.0], atol=1e-12)


def test_no_end_pose_row_for_a_slow_slide_a_face_already_held_or_a_convex_floor():
    """The same box at 0.2 m/s (3.3 mm a step, under the slop); at 3 m/s far from the
    wall (every end contact on the floor its contacts already hold); at 3 m/s toward a
    box's face (convex pairs are clipped, no end-pose pass): no row."""
    assert len(_mesh_rows(STEP, -0.12, 0.2)[1]) == 0
    assert len(_mesh_rows(STEP, -1.5, 3.0)[1]) == 0
    wall = {"type": "polygon", "points": [[-2, -1], [2, -1], [2, 1], [-2, 1]]}   # x >= -2
    got, rows = _mesh_rows(wall, -2.12, 3.0)
    assert len(got) > 0 and len(rows) == 0


def test_an_unbounded_still_body_still_gets_end_pose_rows():
    """A concave L sliding at 3 m/s on unbounded ground (a half-plane y < 0 united with
    a wall x in [0, 2]) toward the wall, 2 cm from it: the row on the wall (its bounding
    radius is infinite, its spin zero: it sweeps nothing). Along the wall's normal
    (-1, 0) (ground -> L), separation 2 cm."""
    from sdfphys.collide import find_contacts
    from sdfphys.collide.predicted import FIELD_PAIR
    from sdfphys.settings import Settings

    ground = {"type": "sdf", "field": {"op": "union", "of": [
        {"type": "half_plane", "normal": [0.0, 1.0]},
        {"type": "box", "size": [2.0, 2.0], "offset": [1.0, 0.0]}]}}
    ell = {"type": "polygon", "points": [[-0.3, -0.1], [0.1, -0.1], [0.1, 0.0],
                                         [-0.2, 0.0], [-0.2, 0.3], [-0.3, 0.3]]}
    shapes = [shape_from_spec(ground), shape_from_spec(ell)]
    # The L's user origin 1 mm over the ground, its right end (x = 0.1) 2 cm from the wall.
    user = np.array([-0.12, 0.101])
    got = find_contacts(shapes, np.arange(2), np.array([[0.0, 0.0], user - shapes[1].origin]),
                        np.zeros(2), np.array([False, True]), Settings(),
                        np.array([[0.0, 0.0], [3.0, 0.0]]), np.zeros(2))
    rows = got.take(((got.feature >> 56) == SOURCE_PREDICTED)
                    & ((got.feature & FIELD_PAIR) != 0))
    wall = np.abs(rows.normal[:, 0] + 1.0) < 1e-9
    assert np.any(wall)
    np.testing.assert_allclose(-rows.depth[wall], 0.02, atol=1e-9)
