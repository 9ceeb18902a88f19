"""Circle contacts against pymunk's ``Shape.shapes_collide`` (Chipmunk2D) to 1e-9.

pymunk reports, per contact, point_a on a's surface, point_b on b's, a normal and a
``distance`` (< 0 overlapping). Ours: point midway = (point_a + point_b) / 2, the
same normal, depth = -distance. pymunk's quirk: when the polygon is the first shape,
its normal still points from a to b but ``distance`` comes out with the opposite sign
(> 0 while overlapping), so there depth = +distance. Shapes that do not touch make
pymunk raise or return no point: those configurations are skipped (we draw until
N overlapping ones are found).
"""

import math

import numpy as np
import pymunk
import pytest

from sdfphys.collide import collide, find_contacts
from sdfphys.settings import Settings
from sdfphys.shapes import shape_from_spec

N = 1000


def pymunk_contact(make_a, pose_a, make_b, pose_b):
    """(point (2,), normal (2,), distance) of pymunk's single contact, or None."""
    shapes = []
    for make, pose in ((make_a, pose_a), (make_b, pose_b)):
        body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        shape = make(body)
        body.position = (pose[0], pose[1])
        body.angle = pose[2]
        shape.cache_bb()
        shapes.append(shape)
    try:
        result = shapes[0].shapes_collide(shapes[1])
    except AssertionError:            # pymunk 7 asserts when the shapes do not touch
        return None
    if not result.points:
        return None
    (cp,) = result.points
    point = (np.array(cp.point_a) + np.array(cp.point_b)) / 2
    return point, np.array(result.normal), cp.distance


def check_against_pymunk(rng, draw, polygon_first=False):
    """Draw configurations until N overlap (pymunk agrees); compare every one."""
    found = 0
    while found < N:
        spec_a, make_a, pose_a, spec_b, make_b, pose_b = draw(rng)
        expected = pymunk_contact(make_a, pose_a, make_b, pose_b)
        if expected is None:
            continue
        point, normal, distance = expected
        depth = distance if polygon_first else -distance
        if depth < 1e-6:
            continue
        c = collide(spec_a, pose_a, spec_b, pose_b)
        assert len(c) == 1, (spec_a, pose_a, spec_b, pose_b)
        np.testing.assert_allclose(c.depth[0], depth, rtol=0, atol=1e-9)
        np.testing.assert_allclose(c.normal[0], normal, rtol=0, atol=1e-9)
        np.testing.assert_allclose(c.point[0], point, rtol=0, atol=1e-9)
        assert c.body_a[0] == 0 and c.body_b[0] == 1
        found += 1


def circle(r):
    return {"type": "circle", "radius": r}, lambda body: pymunk.Circle(body, r)


def draw_circles(rng):
    ra, rb = rng.uniform(0.05, 2.0, 2)
    pose_a = np.r_[rng.uniform(-5, 5, 2), rng.uniform(-4, 4)]
    direction = rng.normal(size=2)
    gap = rng.uniform(0.0, 1.0) * (ra + rb)
    pose_b = np.r_[pose_a[:2] + gap * direction / np.linalg.norm(direction),
                   rng.uniform(-4, 4)]
    return (*circle(ra), pose_a, *circle(rb), pose_b)


def test_circle_circle_matches_pymunk(rng):
    check_against_pymunk(rng, draw_circles)


def test_coincident_circles_use_pymunks_normal():
    c = collide(circle(1.0)[0], (2.0, 3.0, 0.0), circle(0.5)[0], (2.0, 3.0, 1.0))
    point, normal, distance = pymunk_contact(circle(1.0)[1], (2.0, 3.0, 0.0),
                                             circle(0.5)[1], (2.0, 3.0, 1.0))
    np.testing.assert_allclose(c.normal[0], normal)
    np.testing.assert_allclose(c.normal[0], [1.0, 0.0])
    np.testing.assert_allclose(c.point[0], point)
    assert c.depth[0] == pytest.approx(-distance)


def box(w, h):
    corners = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
    return {"type": "box", "size": [w, h]}, lambda body: pymunk.Poly(body, corners)


def convex_polygon(rng):
    """A random convex polygon, not centred on its user origin (tests Shape.origin)."""
    m = rng.integers(3, 9)
    angles = np.sort(rng.uniform(0, 2 * math.pi, m))
    if np.max(np.diff(np.r_[angles, angles[0] + 2 * math.pi])) > 0.9 * math.pi:
        angles = np.linspace(0, 2 * math.pi, m, endpoint=False) + rng.uniform(0, 1)
    radii = rng.uniform(0.3, 1.5, 2)
    points = np.stack([radii[0] * np.cos(angles), radii[1] * np.sin(angles)], axis=1)
    points += rng.uniform(-0.5, 0.5, 2)
    pts = [tuple(p) for p in points]
    return ({"type": "polygon", "points": points.tolist()},
            lambda body: pymunk.Poly(body, pts))


def near(rng, pose, reach):
    return np.r_[pose[:2] + rng.uniform(-reach, reach, 2), rng.uniform(-4, 4)]


def draw_circle_box(rng):
    r = rng.uniform(0.05, 1.5)
    w, h = rng.uniform(0.1, 3.0, 2)
    pose_b = np.r_[rng.uniform(-5, 5, 2), rng.uniform(-4, 4)]
    return (*circle(r), near(rng, pose_b, 0.5 * max(w, h) + r), *box(w, h), pose_b)


def draw_circle_polygon(rng):
    r = rng.uniform(0.05, 1.5)
    pose_b = np.r_[rng.uniform(-5, 5, 2), rng.uniform(-4, 4)]
    return (*circle(r), near(rng, pose_b, 2.0 + r), *convex_polygon(rng), pose_b)


def swapped(draw):
    def draw_swapped(rng):
        spec_a, make_a, pose_a, spec_b, make_b, pose_b = draw(rng)
        return spec_b, make_b, pose_b, spec_a, make_a, pose_a
    return draw_swapped


def test_circle_box_matches_pymunk(rng):
    check_against_pymunk(rng, draw_circle_box)


def test_box_circle_matches_pymunk(rng):
    check_against_pymunk(rng, swapped(draw_circle_box), polygon_first=True)


def test_circle_convex_polygon_matches_pymunk(rng):
    check_against_pymunk(rng, draw_circle_polygon)


def test_convex_polygon_circle_matches_pymunk(rng):
    check_against_pymunk(rng, swapped(draw_circle_polygon), polygon_first=True)


def test_find_contacts_matches_pymunk_for_a_batch_of_circle_pairs(rng):
    """The batched world path: many separate circle-box and circle-circle pairs at once."""
    shapes = [shape_from_spec(circle(0.5)[0]), shape_from_spec(box(2.0, 1.0)[0]),
              shape_from_spec(circle(0.3)[0])]
    makers = [circle(0.5)[1], box(2.0, 1.0)[1], circle(0.3)[1]]
    n = 300
    shape_id = np.repeat([[0, 1], [0, 2]], n // 2, axis=0).ravel()
    centre = np.repeat(np.arange(n)[:, None] * [10.0, 0.0], 2, axis=0)
    position = centre.copy()
    position[1::2] += rng.uniform(-1.1, 1.1, (n, 2))
    angle = rng.uniform(-4, 4, 2 * n)
    movable = np.ones(2 * n, bool)
    c = find_contacts(shapes, shape_id, position, angle, movable, Settings())
    assert np.all(c.body_a < c.body_b) and np.all(c.body_a % 2 == 0)
    compared = 0
    for k in range(len(c)):
        i, j = c.body_a[k], c.body_b[k]
        expected = pymunk_contact(makers[shape_id[i]], (*position[i], angle[i]),
                                  makers[shape_id[j]], (*position[j], angle[j]))
        if expected is None:
            assert c.depth[k] <= 1e-9
            continue
        point, normal, distance = expected
        np.testing.assert_allclose(c.depth[k], -distance, rtol=0, atol=1e-9)
        np.testing.assert_allclose(c.normal[k], normal, rtol=0, atol=1e-9)
        np.testing.assert_allclose(c.point[k], point, rtol=0, atol=1e-9)
        compared += 1
    assert compared > n // 2
