"""Convex polygon pairs (``collide.polygons``): against pymunk and brute force.

pymunk (Chipmunk2D) collides convex polygons by separating axes and clipping too; for
overlapping pairs its contact points (midway between its point_a and point_b), normal
and distance are the same numbers as ours to round-off. Separated pairs within the
margin are checked against the exact polygon distance (brute force over vertices and
edges), and the keys for uniqueness and stability under small motions.
"""

from __future__ import annotations

import numpy as np
import pymunk
import pytest

from sdfphys.collide import collide, find_contacts
from sdfphys.collide.polygons import SOURCE_CLIP
from sdfphys.settings import Settings
from sdfphys.shapes import shape_from_spec

N = 400


def convex(rng):
    """A random box or convex polygon: (scene spec, vertices in user coordinates)."""
    if rng.random() < 0.4:
        w, h = rng.uniform(0.1, 2.0, 2)
        return {"type": "box", "size": [w, h]}, np.array(
            [[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
    n = int(rng.integers(3, 9))
    angle = np.sort(rng.uniform(0, 2 * np.pi, n))
    while np.min(np.diff(np.r_[angle, angle[0] + 2 * np.pi])) < 0.05:
        angle = np.sort(rng.uniform(0, 2 * np.pi, n))
    ax, ay = rng.uniform(0.2, 1.5, 2)
    points = np.column_stack([ax * np.cos(angle), ay * np.sin(angle)])
    return {"type": "polygon", "points": points.tolist()}, points


def world_vertices(points, pose):
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return points @ np.array([[c, s], [-s, c]]) + pose[:2]


def pymunk_manifold(points_a, pose_a, points_b, pose_b):
    shapes = []
    for points, pose in ((points_a, pose_a), (points_b, pose_b)):
        body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        shape = pymunk.Poly(body, [tuple(p) for p in points])
        body.position = (float(pose[0]), float(pose[1]))
        body.angle = float(pose[2])
        shape.cache_bb()
        shapes.append(shape)
    try:
        result = shapes[0].shapes_collide(shapes[1])
    except AssertionError:               # pymunk 7 asserts when the shapes do not touch
        return None
    return result if result.points else None


def segment_distance(p, a, b):
    """Distance of points p (n, 2) to the segment a-b."""
    e = b - a
    t = np.clip(((p - a) @ e) / (e @ e), 0.0, 1.0)
    return np.hypot(*(a + t[:, None] * e - p).T)


def polygon_distance(va, vb):
    """Exact distance between two disjoint convex polygons (world vertices)."""
    best = np.inf
    for v, w in ((va, vb), (vb, va)):
        for i in range(len(w)):
            best = min(best, segment_distance(v, w[i], w[(i + 1) % len(w)]).min())
    return best


def touching_pose(rng, points_a, pose_a, points_b, depth):
    """A pose of b that overlaps a by ``depth`` along a random direction (bisection on
    pymunk's own collision), or None."""
    direction = rng.normal(size=2)
    direction /= np.linalg.norm(direction)
    angle = rng.uniform(-4, 4)
    lo, hi = 0.0, 10.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        pose = np.r_[pose_a[:2] + mid * direction, angle]
        if pymunk_manifold(points_a, pose_a, points_b, pose) is None:
            hi = mid
        else:
            lo = mid
    return np.r_[pose_a[:2] + (lo - depth) * direction, angle]


def test_overlapping_pairs_equal_pymunk():
    rng = np.random.default_rng(7)
    found = 0
    while found < N:
        spec_a, points_a = convex(rng)
        spec_b, points_b = convex(rng)
        pose_a = np.r_[rng.uniform(-3, 3, 2), rng.uniform(-4, 4)]
        pose_b = touching_pose(rng, points_a, pose_a, points_b, rng.uniform(1e-4, 0.05))
        expected = pymunk_manifold(points_a, pose_a, points_b, pose_b)
        if expected is None or max(-p.distance for p in expected.points) < 1e-6:
            continue
        c = collide(spec_a, pose_a, spec_b, pose_b)
        assert len(c) == len(expected.points)
        for p in expected.points:
            point = (np.array(p.point_a) + np.array(p.point_b)) / 2
            k = int(np.argmin(np.hypot(*(c.point - point).T)))
            np.testing.assert_allclose(c.point[k], point, rtol=0, atol=1e-9)
            np.testing.assert_allclose(c.depth[k], -p.distance, rtol=0, atol=1e-9)
            np.testing.assert_allclose(c.normal[k], expected.normal, rtol=0, atol=1e-9)
        assert np.all((c.feature >> 56) == SOURCE_CLIP)
        assert len(np.unique(c.feature)) == len(c)
        found += 1


def test_separated_pairs_report_the_exact_distance():
    """Within the margin and apart: the deepest contact is minus the polygons' distance."""
    rng = np.random.default_rng(3)
    checked = 0
    while checked < 200:
        spec_a, points_a = convex(rng)
        spec_b, points_b = convex(rng)
        pose_a = np.r_[rng.uniform(-3, 3, 2), rng.uniform(-4, 4)]
        gap = rng.uniform(1e-3, 0.05)
        pose_b = touching_pose(rng, points_a, pose_a, points_b, -gap)
        distance = polygon_distance(world_vertices(points_a, pose_a),
                                    world_vertices(points_b, pose_b))
        if not 0.0 < distance < 0.09 or pymunk_manifold(points_a, pose_a, points_b, pose_b):
            continue                    # the bisection's direction met a sliver: overlap
        c = collide(spec_a, pose_a, spec_b, pose_b, margin=0.1)
        assert len(c) >= 1
        np.testing.assert_allclose(c.depth.max(), -distance, rtol=0, atol=1e-9)
        assert np.all(c.depth <= -distance + 1e-12)
        checked += 1


def test_corners_closest_keep_the_far_end_of_the_faces_within_the_margin():
    """Separated boxes whose nearest features are two corners while their facing sides
    are nearly parallel (turned 0.06 rad): the corners' contact (the exact distance,
    along the corner-corner line) and, within the margin, the far end of the clipped
    side, so the far corners have a speculative row before they meet (two spinning
    crates of destructible_terrain closed 73 mm there in one step without one)."""
    box = {"type": "box", "size": [0.6, 0.6]}
    pose_b = (0.68, -0.02, -0.06)
    va = world_vertices(np.array([[-0.3, -0.3], [0.3, -0.3], [0.3, 0.3], [-0.3, 0.3]]),
                        np.zeros(3))
    vb = world_vertices(va, np.array(pose_b))
    c = collide(box, (0.0, 0.0, 0.0), box, pose_b, margin=0.15)
    assert len(c) == 2
    near, far = np.argsort(-c.depth)
    np.testing.assert_allclose(c.depth[near], -polygon_distance(va, vb), rtol=0, atol=1e-12)
    assert abs(c.normal[near, 1]) > 0.01                  # the corner-corner line
    np.testing.assert_allclose(c.normal[far], [1.0, 0.0], atol=1e-12)
    on_b = c.point[far] - c.depth[far] * c.normal[far] / 2
    gap = min(segment_distance(on_b[None], va[i], va[(i + 1) % 4])[0] for i in range(4))
    np.testing.assert_allclose(c.depth[far], -gap, rtol=0, atol=1e-12)
    assert len(np.unique(c.feature)) == 2
    # Beyond the margin the far end is dropped; the corners' contact stays.
    c = collide(box, (0.0, 0.0, 0.0), box, pose_b, margin=0.09)
    assert len(c) == 1 and abs(c.normal[0, 1]) > 0.01


def test_resting_boxes_touch_at_the_ends_of_their_shared_face():
    c = collide({"type": "box", "size": [4.0, 1.0]}, (0.0, 0.0, 0.0),
                {"type": "box", "size": [1.0, 1.0]}, (1.2, 0.999, 0.0))
    order = np.argsort(c.point[:, 0])
    np.testing.assert_allclose(c.point[order], [[0.7, 0.4995], [1.7, 0.4995]], atol=1e-12)
    np.testing.assert_allclose(c.depth, [0.001, 0.001], atol=1e-12)
    np.testing.assert_allclose(c.normal, [[0.0, 1.0], [0.0, 1.0]], atol=1e-12)
    # Overhanging the end: the patch is clipped to the lower box's face.
    c = collide({"type": "box", "size": [4.0, 1.0]}, (0.0, 0.0, 0.0),
                {"type": "box", "size": [1.0, 1.0]}, (2.2, 0.999, 0.0))
    np.testing.assert_allclose(np.sort(c.point[:, 0]), [1.7, 2.0], atol=1e-12)


def test_one_contact_per_pair_keeps_the_deepest():
    a, b = {"type": "box", "size": [4.0, 1.0]}, {"type": "box", "size": [1.0, 1.0]}
    pose_b = (1.2, 0.99, 0.01)
    both = collide(a, (0.0, 0.0, 0.0), b, pose_b)
    one = collide(a, (0.0, 0.0, 0.0), b, pose_b, settings=Settings(contacts_per_pair=1))
    assert len(both) == 2 and len(one) == 1
    assert one.depth[0] == both.depth.max()


def test_keys_survive_a_small_motion():
    rng = np.random.default_rng(11)
    for _ in range(50):
        spec_a, points_a = convex(rng)
        spec_b, points_b = convex(rng)
        pose_a = np.r_[rng.uniform(-3, 3, 2), rng.uniform(-4, 4)]
        pose_b = touching_pose(rng, points_a, pose_a, points_b, 0.01)
        before = collide(spec_a, pose_a, spec_b, pose_b)
        after = collide(spec_a, pose_a, spec_b, pose_b + [1e-4, -1e-4, 1e-5])
        if len(before) == len(after):
            assert set(before.feature) == set(after.feature)


@pytest.mark.parametrize("per_pair", [1, 4])
def test_world_path_equals_the_pair_function(per_pair):
    """find_contacts' compiled pass and collide()'s pair function give the same contacts.

    The world orients a pair by its shapes' order (the lower shape first, whose vertex
    comes first in the key), then lists it with body_a < body_b (normal negated)."""
    rng = np.random.default_rng(5)
    settings = Settings(contacts_per_pair=per_pair)
    shapes = [shape_from_spec(convex(rng)[0]) for _ in range(6)]
    n = 60
    shape_id = rng.integers(0, len(shapes), n)
    position = rng.uniform(-4, 4, (n, 2))
    angle = rng.uniform(-4, 4, n)
    world = find_contacts(shapes, shape_id, position, angle, np.ones(n, bool), settings)
    assert len(world) > 20
    for a, b in set(zip(world.body_a.tolist(), world.body_b.tolist())):
        rows = (world.body_a == a) & (world.body_b == b)
        first, second = (a, b) if shape_id[a] <= shape_id[b] else (b, a)
        pose = []
        for i in (first, second):
            shape = shapes[shape_id[i]]
            c, s = np.cos(angle[i]), np.sin(angle[i])
            ox, oy = shape.origin
            pose.append((position[i, 0] + c * ox - s * oy, position[i, 1] + s * ox + c * oy,
                         angle[i]))
        pair = collide(shapes[shape_id[first]], pose[0], shapes[shape_id[second]], pose[1],
                       margin=settings.speculative_distance, settings=settings)
        order = np.argsort(pair.feature)
        sign = 1.0 if first == a else -1.0
        np.testing.assert_array_equal(world.feature[rows], pair.feature[order])
        np.testing.assert_allclose(world.depth[rows], pair.depth[order], rtol=0, atol=1e-12)
        np.testing.assert_allclose(world.point[rows], pair.point[order], rtol=0, atol=1e-12)
        np.testing.assert_allclose(world.normal[rows], sign * pair.normal[order], rtol=0,
                                   atol=1e-12)
