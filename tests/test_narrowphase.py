"""Narrowphase, reduction and find_contacts: analytic answers, instancing, keys, speed."""

import itertools
import math
import time
from pathlib import Path

import numpy as np
import pytest

import sdfphys
from sdfphys.collide import collide, find_contacts
from sdfphys.collide.narrowphase import KIND_ORDER, PAIR_FUNCTIONS
from sdfphys.collide.reduce import reduce_contacts
from sdfphys.sdf import Field, field
from sdfphys.settings import Settings

ROOT = Path(__file__).resolve().parents[1]
from sdfphys.shapes import SdfShape, shape_from_spec
from sdfphys.world import World

BALL = {"type": "circle", "radius": 0.5}


class Counting(Field):
    """A field that counts its evaluate / distance calls (instancing checks)."""

    def __init__(self, of: Field):
        self.of = of
        self.exact = of.exact
        self.calls = 0

    def evaluate(self, points):
        self.calls += 1
        return self.of.evaluate(points)

    def distance(self, points):
        self.calls += 1
        return self.of.distance(points)

    def bounds(self):
        return self.of.bounds()


def test_dispatch_table_covers_every_kind_pair_lower_kind_first():
    expected = {(a, b) for i, a in enumerate(KIND_ORDER) for b in KIND_ORDER[i:]}
    assert set(PAIR_FUNCTIONS) == expected


def test_circle_against_sdf_circle_equals_circle_circle(rng):
    sdf_ball = {"type": "sdf", "field": {"type": "circle", "radius": 0.8,
                                         "offset": [0.3, -0.2]}}
    shape = shape_from_spec(sdf_ball)
    for _ in range(50):
        pa = np.r_[rng.uniform(-1, 1, 2), rng.uniform(-3, 3)]
        pb = np.r_[rng.uniform(-1, 1, 2), rng.uniform(-3, 3)]
        got = collide(BALL, pa, sdf_ball, pb, margin=10.0)
        centre_b = pb[:2] - np.array([[math.cos(pb[2]), -math.sin(pb[2])],
                                      [math.sin(pb[2]), math.cos(pb[2])]]) @ shape.origin
        expected = collide(BALL, pa, {"type": "circle", "radius": 0.8}, (*centre_b, 0.0),
                           margin=10.0)
        # the sdf circle's centre of mass comes from quadrature (1e-4 relative)
        np.testing.assert_allclose(got.depth, expected.depth, atol=1e-4)
        np.testing.assert_allclose(got.normal, expected.normal, atol=1e-4)
        np.testing.assert_allclose(got.point, expected.point, atol=1e-4)


def test_circle_against_half_plane_ground():
    class Ground(Field):
        def evaluate(self, points):
            p = np.asarray(points, float).reshape(-1, 2)
            return p[:, 1].copy(), np.tile([0.0, 1.0], (len(p), 1))

        def bounds(self):
            return np.array([-np.inf, -np.inf, np.inf, 0.0])

    ground = SdfShape(Ground())
    ball = shape_from_spec(BALL)
    x = np.linspace(-100, 100, 7)
    position = np.concatenate([np.stack([x, np.full(7, 0.49)], axis=1), [[0.0, 0.0]]])
    c = find_contacts([ball, ground], np.r_[np.zeros(7, int), 1], position, np.zeros(8),
                      np.r_[np.ones(7, bool), False], Settings())
    np.testing.assert_array_equal(c.body_a, np.arange(7))
    np.testing.assert_array_equal(c.body_b, np.full(7, 7))
    np.testing.assert_allclose(c.depth, 0.01, atol=1e-12)
    np.testing.assert_allclose(c.normal, np.tile([0.0, -1.0], (7, 1)))
    np.testing.assert_allclose(c.point, np.stack([x, np.full(7, -0.005)], axis=1), atol=1e-12)


def test_instancing_one_field_evaluation_per_pair_group(rng):
    """100 balls on 100 sdf bodies sharing one shape: one evaluate for the whole group."""
    counting = Counting(field({"type": "box", "size": [1.0, 1.0]}))
    block = SdfShape(counting)
    _ = block.field, block.radius                       # mass properties (quadrature) first
    ball = shape_from_spec(BALL)
    n = 100
    base = np.stack([np.arange(n) * 5.0, np.zeros(n)], axis=1)
    position = np.concatenate([base, base + [0.0, 0.95]])
    angle = np.r_[rng.uniform(-0.1, 0.1, n), rng.uniform(-3, 3, n)]
    counting.calls = 0
    c = find_contacts([block, ball], np.r_[np.zeros(n, int), np.ones(n, int)], position,
                      angle, np.ones(2 * n, bool), Settings())
    assert counting.calls == 1
    assert len(c) == n
    np.testing.assert_array_equal(c.body_a, np.arange(n))
    np.testing.assert_array_equal(c.body_b, np.arange(n) + n)
    np.testing.assert_array_less(0.0, c.depth)


def test_find_contacts_contract(rng):
    """Sorted, body_a < body_b, a movable body in each pair, depth > -speculative."""
    ball, small = shape_from_spec(BALL), shape_from_spec({"type": "circle", "radius": 0.3})
    floor = shape_from_spec({"type": "box", "size": [20.0, 1.0]})
    n = 400
    position = np.concatenate([rng.uniform([-9, 0], [9, 6], (n, 2)), [[0.0, -0.5]],
                               [[0.0, 0.1]]])
    shape_id = np.r_[rng.integers(0, 2, n), 2, 1]
    movable = np.r_[np.ones(n, bool), False, False]
    settings = Settings()
    c = find_contacts([ball, small, floor], shape_id, position, np.zeros(n + 2), movable,
                      settings)
    assert np.all(c.body_a < c.body_b)
    assert np.all(movable[c.body_a] | movable[c.body_b])
    assert not np.any((c.body_a == n) & (c.body_b == n + 1))        # two static bodies
    assert np.all(c.depth > -settings.speculative_distance)
    order = np.lexsort((c.feature, c.body_b, c.body_a))
    np.testing.assert_array_equal(order, np.arange(len(c)))
    np.testing.assert_allclose(np.linalg.norm(c.normal, axis=1), 1.0)
    # brute force over all circle pairs
    radius = np.array([0.5, 0.3, np.nan])[shape_id]
    i, j = np.triu_indices(n, 1)
    gap = np.linalg.norm(position[i] - position[j], axis=1) - radius[i] - radius[j]
    near = gap < settings.speculative_distance
    circles = c.body_b < n
    np.testing.assert_array_equal(np.stack([c.body_a[circles], c.body_b[circles]], axis=1),
                                  np.stack([i[near], j[near]], axis=1))
    np.testing.assert_allclose(c.depth[circles], -gap[near], atol=1e-12)


#: Normals of candidates on one horizontal plane.
UP = np.tile([[0.0, 1.0]], (64, 1))


def test_reduction_keeps_the_ends_of_a_flat_patch():
    x = np.linspace(-1.0, 1.0, 21)
    point = np.stack([x, np.zeros(21)], axis=1)
    depth = np.full(21, 0.01)
    order = np.argsort(np.abs(x), kind="stable")           # a middle point comes first
    keep = reduce_contacts(np.array([0, 21]), point[order], depth[order], UP[:21], 4, 0.005)
    np.testing.assert_array_equal(np.sort(x[order][keep]), [-1.0, 1.0])


def test_reduction_keeps_a_deeper_middle_and_two_faces():
    # a flat patch whose middle is deeper than its ends: the middle stays
    point = np.array([[0.0, 0.0], [-1.0, 0.0], [1.0, 0.0], [0.5, 0.0]])
    depth = np.array([0.03, 0.01, 0.01, 0.01])
    keep = reduce_contacts(np.array([0, 4]), point, depth, UP[:4], 4, 0.005)
    np.testing.assert_array_equal(keep, [True, True, True, False])
    # a box in a V groove: two points on each wall, budget 4, then budget 2
    point = np.array([[-1.0, 1.0], [-0.5, 0.5], [0.5, 0.5], [1.0, 1.0], [-0.75, 0.75]])
    depth = np.array([0.02, 0.02, 0.02, 0.02, 0.02])
    walls = np.array([[1.0, 1.0], [1.0, 1.0], [-1.0, 1.0], [-1.0, 1.0], [1.0, 1.0]]) / np.sqrt(2)
    keep = reduce_contacts(np.array([0, 5]), point, depth, walls, 4, 0.005)
    np.testing.assert_array_equal(keep, [True, True, True, True, False])
    keep = reduce_contacts(np.array([0, 5]), point, depth, walls, 2, 0.005)
    assert keep.sum() == 2 and keep[0] and keep[3]


def test_reduction_spends_its_budget_on_touching_points_before_far_gaps():
    """scenes/showcase.toml at t = 1.233 s: a spinning star (-9.2 rad/s) touches an L
    polygon with its shaft (11.6 mm deep) and, 0.55 m away, with a spike tip (3.8 mm);
    the other candidates are gaps of 8.7 to 20 cm. Ranked by novelty alone the budget
    of 4 went to the far gaps (the most spread) and dropped the tip, which the star's
    spin drove 11 cm into the L in the next step. Ranked by novelty less the gap, the
    tip is kept."""
    point = np.array([[1.76528746, 1.32110185], [1.76283363, 1.31782651],
                      [1.76860064, 1.31861901], [2.23984869, 0.96402048],
                      [2.23984869, 0.96402048], [2.23069509, 0.91977788],
                      [1.63516199, 1.23225526], [2.82928537, 1.53453908],
                      [2.82928537, 1.53453908], [1.55739663, 1.2176575],
                      [2.32032988, 0.90298658]])
    depth = np.array([0.011642, 0.008232, 0.008232, 0.003805, 0.003805, -0.08694,
                      -0.13060, -0.15520, -0.15520, -0.19809, -0.20205])
    keep = reduce_contacts(np.array([0, len(depth)]), point, depth, UP[:len(depth)], 4,
                           0.005)
    assert keep.sum() == 4 and keep[0]
    assert keep[3] or keep[4]                                  # the spike tip


def test_a_segment_covers_only_candidates_on_its_plane():
    """scenes/fracture.toml's beam cut by a round hole instead, a nudged run at 1.75 s: a
    sharp corner of the piece 21.9 mm above the ground, seen from the piece (normal the
    ground's), 22.6 mm seen from the ground (normal the corner's blunted side, tilted 34
    degrees), and the piece's far end. The corner's vertical row lies between the other
    two, 2.4 mm deeper than their interpolation, and they are on no common plane: it is
    kept (dropped, the tilted row let the corner sink 44 mm in the step)."""
    point = np.array([[1.3458, 0.0110], [1.3516, 0.0093], [1.0138, 0.0595]])
    depth = np.array([-0.02192, -0.02263, -0.11908])
    normal = np.array([[0.0, 1.0], [0.566, 0.824], [0.0, 1.0]])
    keep = reduce_contacts(np.array([0, 3]), point, depth, normal, 4, 0.005)
    assert keep[0] and keep[2]
    # On one plane the segment covers the corner's row, as before.
    keep = reduce_contacts(np.array([0, 3]), point, depth, UP[:3], 4, 0.005)
    assert not keep[0] and keep[1] and keep[2]


def test_reduction_per_pair_and_budget(rng):
    sizes = rng.integers(1, 30, 200)
    start = np.r_[0, np.cumsum(sizes)]
    point = rng.uniform(-1, 1, (start[-1], 2))
    depth = rng.uniform(-0.02, 0.05, start[-1])
    for s, e in itertools.pairwise(start):
        order = np.argsort(-depth[s:e], kind="stable") + s
        depth[s:e], point[s:e] = depth[order], point[order]
    normal = np.tile(UP[:1], (start[-1], 1))
    keep = reduce_contacts(start, point, depth, normal, 4, 0.005)
    kept_per_pair = np.add.reduceat(keep.astype(int), start[:-1])
    assert np.all(kept_per_pair >= 1) and np.all(kept_per_pair <= 4)
    assert np.all(keep[start[:-1]] | (kept_per_pair > 1))
    np.testing.assert_array_equal(keep, reduce_contacts(start, point, depth, normal, 4, 0.005))


def test_two_thousand_circles_in_a_box_in_a_few_ms(rng):
    n, cols = 2000, 50
    ball = shape_from_spec(BALL)
    floor = shape_from_spec({"type": "box", "size": [52.0, 1.0]})
    wall = shape_from_spec({"type": "box", "size": [1.0, 60.0]})
    grid = np.stack(np.divmod(np.arange(n), cols), axis=1)[:, ::-1]
    position = grid * 0.99 + 0.5 + rng.uniform(-0.01, 0.01, (n, 2))
    position = np.concatenate([position, [[24.75, -0.49], [-0.49, 30.0], [49.99, 30.0]]])
    shape_id = np.r_[np.zeros(n, int), 1, 2, 2]
    angle = np.zeros(n + 3)
    movable = np.r_[np.ones(n, bool), np.zeros(3, bool)]
    settings = Settings()
    c = find_contacts([ball, floor, wall], shape_id, position, angle, movable, settings)
    best = np.inf
    for _ in range(10):
        t0 = time.perf_counter()
        c = find_contacts([ball, floor, wall], shape_id, position, angle, movable, settings)
        best = min(best, time.perf_counter() - t0)
    print(f"\n2,000 circles in a box: {len(c)} contacts in {best * 1e3:.2f} ms")
    assert len(c) == 49 * 40 + 50 * 39 + 50 + 2 * 40       # neighbours, floor, walls
    assert np.sum(c.body_b == n) == cols                    # the bottom row on the floor
    assert best < 0.015


@pytest.mark.parametrize("margin", [0.0, 0.02])
def test_collide_margin(margin):
    c = collide(BALL, (0.0, 0.0, 0.0), BALL, (1.01, 0.0, 0.0), margin=margin)
    assert len(c) == (1 if margin > 0.01 else 0)


def test_reduction_drops_points_shadowed_by_a_deeper_one():
    # a corner 0.02 deep, and the other direction's view of it (shallower, 7 mm away)
    point = np.array([[0.0, -0.01], [0.006, -0.005], [0.03, -0.004]])
    depth = np.array([0.02, 0.014, 0.001])
    keep = reduce_contacts(np.array([0, 3]), point, depth, UP[:3], 4, 0.005)
    np.testing.assert_array_equal(keep, [True, False, True])


# --------------------------------------------------------------------------------------
# Mesh pairs (triangles of one body in the other's exact polygon field)
# --------------------------------------------------------------------------------------

GROUND = {"type": "box", "size": [4.0, 1.0]}           # top face at y = 0.5
TOP = {"type": "box", "size": [1.0, 0.5]}
#: The L of scenes/concave_polygons.toml: arms 0.4 m wide, 1.2 m long.
L_ARMS = {"type": "polygon", "points": [[-0.6, -0.6], [0.6, -0.6], [0.6, -0.2], [-0.2, -0.2],
                                        [-0.2, 0.6], [-0.6, 0.6]]}
L_SHAPE = {"type": "polygon", "points": [[0, 0], [3, 0], [3, 1], [1, 1], [1, 2], [0, 2]]}
TABLE = {"type": "polygon", "points": [[0, 0], [0.5, 0], [0.5, 1], [2.5, 1], [2.5, 0],
                                       [3, 0], [3, 1.5], [0, 1.5]]}


def rotation(theta):
    return np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])


def moved(pose, theta, shift):
    """A user pose (x, y, a) after the rigid motion: rotate by theta about 0, then shift."""
    return (*(rotation(theta) @ pose[:2] + shift), pose[2] + theta)


def sorted_rows(c):
    order = np.lexsort((c.point[:, 1], c.point[:, 0]))
    return c.point[order], c.normal[order], c.depth[order]


def test_box_resting_flat_on_a_box_two_corner_contacts(rng):
    """Overlap 0.01: the two corners of the top box's bottom face, normal (0, +-1)."""
    top = (0.3, 0.5 + 0.25 - 0.01, 0.0)
    expected_point = np.array([[-0.2, 0.495], [0.8, 0.495]])
    for theta, shift in [(0.0, np.zeros(2))] + [(rng.uniform(-4, 4), rng.uniform(-5, 5, 2))
                                                  for _ in range(5)]:
        pa, pb = moved((0.0, 0.0, 0.0), theta, shift), moved(top, theta, shift)
        for first, second, sign in [((GROUND, pa), (TOP, pb), 1.0),
                                    ((TOP, pb), (GROUND, pa), -1.0)]:
            c = collide(first[0], first[1], second[0], second[1])
            point, normal, depth = sorted_rows(c)
            world = expected_point @ rotation(theta).T + shift
            world = world[np.lexsort((world[:, 1], world[:, 0]))]
            np.testing.assert_allclose(point, world, atol=1e-9)
            np.testing.assert_allclose(depth, [0.01, 0.01], atol=1e-9)
            np.testing.assert_allclose(normal, np.tile(sign * rotation(theta)[:, 1], (2, 1)),
                                       atol=1e-9)


def test_box_overhanging_a_box_edge():
    """Overlap interval [1.8, 2.0]: one corner from each box."""
    c = collide(GROUND, (0.0, 0.0, 0.0), TOP, (2.3, 0.74, 0.0))
    point, normal, depth = sorted_rows(c)
    np.testing.assert_allclose(point, [[1.8, 0.495], [2.0, 0.495]], atol=1e-9)
    np.testing.assert_allclose(normal, [[0.0, 1.0], [0.0, 1.0]], atol=1e-9)
    np.testing.assert_allclose(depth, [0.01, 0.01], atol=1e-9)


def test_rotated_box_corner_pressing_into_a_face(rng):
    """A tilted box's lowest corner depth d into the ground: one contact at that corner."""
    half = np.array([0.5, 0.25])
    for _ in range(20):
        angle = rng.uniform(0.15, math.pi / 2 - 0.15)
        d = rng.uniform(0.002, 0.05)
        corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half @ rotation(angle).T
        low = corners[np.argmin(corners[:, 1])]
        x = rng.uniform(-1.0, 1.0)
        pose = (x, 0.5 - d - low[1], angle)
        c = collide(GROUND, (0.0, 0.0, 0.0), TOP, pose)
        assert len(c) == 1
        np.testing.assert_allclose(c.depth, [d], atol=1e-9)
        np.testing.assert_allclose(c.normal, [[0.0, 1.0]], atol=1e-9)
        np.testing.assert_allclose(c.point, [[x + low[0], 0.5 - d / 2]], atol=1e-9)


def test_aligned_stacked_boxes_get_their_corners_with_the_face_normal():
    """Equal boxes exactly aligned, 1 mm overlap: the shared corners lie on the side
    faces (f = 0 there, gradient tie), yet the contacts are the corners with (0, 1)."""
    unit = {"type": "box", "size": [1.0, 1.0]}
    for dx, expected_x in [(0.0, [-0.5, 0.5]), (1e-4, [-0.4999, 0.5]),
                           (-1e-4, [-0.5, 0.4999])]:
        c = collide(unit, (0.0, 0.5, 0.0), unit, (dx, 1.499, 0.0))
        point, normal, depth = sorted_rows(c)
        np.testing.assert_allclose(point, np.stack([expected_x, [0.9995] * 2], axis=1),
                                   atol=1e-9)
        np.testing.assert_allclose(normal, [[0.0, 1.0], [0.0, 1.0]], atol=1e-9)
        np.testing.assert_allclose(depth, [0.001, 0.001], atol=1e-9)
    before = collide(unit, (0.0, 0.5, 0.0), unit, (0.0, 1.499, 0.0))
    after = collide(unit, (0.0, 0.5, 0.0), unit, (0.0, 1.4991, 0.0))
    np.testing.assert_array_equal(after.feature, before.feature)


@pytest.mark.parametrize("theta", [0.002, -0.002, 0.01])
def test_slightly_tilted_box_keeps_both_bottom_corners(theta):
    """The shallower corner is no local minimum of f, yet it must be reported
    (measured against the face under the deeper one), speculative if separated."""
    half = np.array([0.5, 0.25])
    corners = np.array([[-1.0, -1.0], [1.0, -1.0]]) * half @ rotation(theta).T
    y = 0.5 - 0.005 - corners[:, 1].min()
    c = collide(GROUND, (0.0, 0.0, 0.0), TOP, (0.2, y, theta), margin=0.02)
    point, normal, depth = sorted_rows(c)
    bottom = corners + [0.2, y]
    expected_depth = 0.5 - bottom[:, 1]
    np.testing.assert_allclose(depth, expected_depth, atol=1e-9)
    np.testing.assert_allclose(point, bottom + np.c_[np.zeros(2), expected_depth / 2],
                               atol=1e-9)
    np.testing.assert_allclose(normal, [[0.0, 1.0], [0.0, 1.0]], atol=1e-9)


def test_concave_table_on_its_two_legs():
    """Four leg corners touch, colinear: the reduction keeps the two outer ones."""
    c = collide({"type": "box", "size": [10.0, 1.0]}, (0.0, -0.49, 0.0), TABLE, (-1.0, 0.0, 0.0))
    point, normal, depth = sorted_rows(c)
    np.testing.assert_allclose(point, [[-1.0, 0.005], [2.0, 0.005]], atol=1e-9)
    np.testing.assert_allclose(normal, [[0.0, 1.0], [0.0, 1.0]], atol=1e-9)
    np.testing.assert_allclose(depth, [0.01, 0.01], atol=1e-9)


def test_box_in_the_notch_of_an_l():
    """A box pressed 0.02 into the L's arm and 0.01 into its wall, corner in the notch.

    Its bottom-left corner (0.99, 0.98) is inside the L, nearest the L's re-entrant
    vertex (1, 1): its exact depth sqrt(0.01^2 + 0.02^2) and the gradient from that
    vertex, (1, 2) / sqrt(5), which is also the direction of the push that clears both
    faces (0.01 right, 0.02 up); its contact point is midway to the vertex. The other
    corners press on faces: the box's bottom-right corner (1.79, 0.98) into the arm,
    normal (0, 1), depth 0.02; the wall against the box's left face at its top-left
    corner (0.99, 1.58), normal (1, 0), depth 0.01. (The re-entrant vertex measured
    against the box's bottom face, at (1, 0.99), lies within the corner contact's depth
    of it: the reduction's shadowing drops it.)
    """
    c = collide(L_SHAPE, (0.0, 0.0, 0.0), {"type": "box", "size": [0.8, 0.6]},
                (1.39, 1.28, 0.0))
    point, normal, depth = sorted_rows(c)
    np.testing.assert_allclose(depth, [np.hypot(0.01, 0.02), 0.01, 0.02], atol=1e-9)
    np.testing.assert_allclose(normal, [np.array([1.0, 2.0]) / np.sqrt(5.0), [1.0, 0.0],
                                        [0.0, 1.0]], atol=1e-9)
    np.testing.assert_allclose(point, [[0.995, 0.99], [0.995, 1.58], [1.79, 0.99]],
                               atol=1e-9)


#: A clamp round the right end of PLANK (a 2 x 0.1 box at the origin): its upper arm's
#: spike, tip (0, 0.03), reaches 0.02 into the plank from above; its lower arm's spike,
#: tip (0.3, -0.06), stops 0.01 under it.
PLANK = {"type": "box", "size": [2.0, 0.1]}
BOX_1 = {"type": "box", "size": [1.0, 1.0]}
CLAMP = {"type": "polygon", "points": [
    [-0.2, 0.15], [-0.1, 0.15], [0.0, 0.03], [0.1, 0.15], [1.1, 0.15], [1.1, -0.15],
    [0.4, -0.15], [0.3, -0.06], [0.2, -0.15], [0.2, -0.35], [1.3, -0.35], [1.3, 0.35],
    [-0.2, 0.35]]}


@pytest.mark.parametrize("margin", [0.0, 0.02, 0.05])
def test_a_spike_in_a_plank_is_seen_past_a_vertex_across_it(rng, margin):
    """The clamp's upper spike tip is inside the plank, 0.02 under its top face (0.08
    over its bottom one): one contact, depth 0.02, normal (0, 1) from the plank to the
    clamp, midway at (0, 0.04). The lower spike's tip lies under the top face's plane
    too, 0.11 deep, its foot on that face, but across the plank, outside it: it does
    not cut the face (stage 4 of collide/mesh_contacts.py). It once did whenever it was
    within the margin (the world's margin is 0.02 plus the bodies' reach): no contact
    at all. The bottom face is a cut plane (the upper tip lies 0.08 behind it) and the
    lower tip's row goes with it; a wider margin adds speculative rows only."""
    for theta, shift in [(0.0, np.zeros(2))] + [(rng.uniform(-4, 4), rng.uniform(-5, 5, 2))
                                                  for _ in range(3)]:
        turn = rotation(theta)
        pa, pb = moved((0.0, 0.0, 0.0), theta, shift), moved((0.0, 0.0, 0.0), theta, shift)
        for first, second, sign in [((PLANK, pa), (CLAMP, pb), 1.0),
                                    ((CLAMP, pb), (PLANK, pa), -1.0)]:
            c = collide(first[0], first[1], second[0], second[1], margin=margin)
            deep = c.depth > 0.0          # the margin's speculative rows aside
            np.testing.assert_allclose(c.depth[deep], [0.02], atol=1e-9)
            np.testing.assert_allclose(c.normal[deep], [sign * turn @ [0.0, 1.0]], atol=1e-9)
            np.testing.assert_allclose(c.point[deep], [turn @ [0.0, 0.04] + shift], atol=1e-9)


SPIKE = {"type": "polygon", "points": [[0.499, 0.35], [0.48, 0.6], [0.9, 0.9], [0.2, 0.9],
                                       [0.249, 0.6]]}


def test_a_spike_through_a_corner_is_seen_at_its_deepest_point(rng):
    """A spike whose tip is 1 mm inside a unit box's right face (0.499, 0.35) and whose
    left edge rises at 45 deg out through the box's top face: the tip's row reads 1 mm,
    the overlap is a 0.15 m triangle. The spike's outline is deepest in the box where
    that edge crosses the corner's bisector, (0.4245, 0.4245), 0.0755 from both faces
    (0.001 + t = 0.15 - t along the edge): a kink of the box's field crossed by the
    edge (``mesh_contacts._face_normals``). Its first face, the top (the spike's bulk
    is above), is cut by the tip 0.15 under it; its second, the right face, holds:
    depth 0.0755, normal (1, 0), midway (0.46225, 0.4245). No overlapping row pushes
    the spike back into the corner. Before, the kink was dropped and the deepest row
    was the tip's 1 mm (a star's spike through an L's corner, docs/stability.md)."""
    for theta, shift in [(0.0, np.zeros(2))] + [(rng.uniform(-4, 4), rng.uniform(-5, 5, 2))
                                                  for _ in range(3)]:
        turn = rotation(theta)
        pose = moved((0.0, 0.0, 0.0), theta, shift)
        for first, second, sign in [((BOX_1, pose), (SPIKE, pose), 1.0),
                                    ((SPIKE, pose), (BOX_1, pose), -1.0)]:
            c = collide(first[0], first[1], second[0], second[1], margin=0.02)
            k = np.argmax(c.depth)
            assert abs(c.depth[k] - 0.0755) < 1e-12
            np.testing.assert_allclose(c.normal[k], sign * turn @ [1.0, 0.0], atol=1e-12)
            np.testing.assert_allclose(c.point[k], turn @ [0.46225, 0.4245] + shift,
                                       atol=1e-12)
            out = sign * (c.normal[c.depth > 0.0] @ turn)     # box to spike, box frame
            assert np.all(out >= -1e-12)


def test_crossing_arms_of_two_concave_polygons_are_seen_as_deep_as_they_overlap():
    """Two L's whose arms cross in a '+' (the overlap a 0.4 m square, no vertex of either
    inside the other): the deepest contact is at least the overlap's inscribed depth, 0.2
    m (the arms' half width: the point of the overlap farthest from both outlines; a
    point of one outline inside the other is at least that deep where it crosses the
    other's arm). The rows that see it are kinks of one L's field crossed by the other's
    edges (``mesh_contacts._face_normals``); before them the pair read 0.1 m, and in
    scenes/concave_polygons.toml under another sweep order a star's arm cut through a
    U's corner this way: 120 mm of overlap over 20 steps while every row read under 6
    mm (docs/stability.md)."""
    for pose_a, pose_b in (((0.0, 0.0, 0.0), (0.5, -0.5, 0.0)),
                           ((0.5, -0.5, 0.0), (0.0, 0.0, 0.0))):
        c = collide(L_ARMS, pose_a, L_ARMS, pose_b)
        assert len(c) > 0
        assert c.depth.max() >= 0.2 - 1e-9


@pytest.mark.parametrize("shift", [(1e-4, 0.0), (0.0, 1e-4), (-1e-4, 1e-4)])
def test_feature_keys_survive_a_small_motion(shift):
    cases = [(GROUND, (0.0, 0.0, 0.0), TOP, (0.3, 0.74, 0.0)),
             (GROUND, (0.0, 0.0, 0.0), TOP, (2.3, 0.74, 0.0)),
             (GROUND, (0.0, 0.0, 0.0), TOP, (0.1, 0.9, 0.6)),
             (L_SHAPE, (0.0, 0.0, 0.0), {"type": "box", "size": [0.8, 0.6]}, (1.39, 1.28, 0.0)),
             ({"type": "box", "size": [10.0, 1.0]}, (0.0, -0.49, 0.0), TABLE, (-1.0, 0.0, 0.0)),
             (BALL, (0.0, 0.0, 0.0), TOP, (0.3, 0.7, 0.2))]
    for shape_a, pose_a, shape_b, pose_b in cases:
        before = collide(shape_a, pose_a, shape_b, pose_b)
        after = collide(shape_a, pose_a, shape_b, np.add(pose_b, (*shift, 0.0)))
        assert len(before) > 0
        np.testing.assert_array_equal(after.feature, before.feature)
        assert len(np.unique(before.feature)) == len(before)


def test_mesh_instancing_field_calls_do_not_grow_with_bodies(rng):
    """Boxes sharing one shape on an sdf ground: field calls bounded whatever the count.

    The mesh in the sdf's field: one call for the cull, one for the descent starts, one
    per descent iteration (all triangles of all pairs at once), one for the gradients
    at the minima. The sdf in the mesh (``mesh_sdf``, raised on purpose for it): one
    ``field_field_contacts`` (the starts, one call per descent iteration, the patch
    search's two bracket ends and one call per iteration: 2 field_descent_iterations
    + 3, as for sdf-sdf groups), then the support search's projection, one call per
    round and four for the far ends: probes, anchors, two ladders (SDF_CALLS). All
    independent of the number of bodies.
    """
    from sdfphys.collide.mesh_sdf import SDF_CALLS

    counting = Counting(field({"type": "box", "size": [400.0, 1.0]}))
    ground = SdfShape(counting)
    _ = ground.field, ground.radius
    box = shape_from_spec(TOP)
    calls = []
    for n in (10, 100):
        x = np.arange(n) * 2.0 - 100.0
        position = np.concatenate([[[0.0, 0.0]], np.stack([x, np.full(n, 0.74)], axis=1)])
        angle = np.r_[0.0, rng.uniform(-0.01, 0.01, n)]
        counting.calls = 0
        settings = Settings()
        c = find_contacts([ground, box], np.r_[0, np.ones(n, int)], position, angle,
                          np.r_[False, np.ones(n, bool)], settings)
        calls.append(counting.calls)
        assert set(c.body_b) == set(range(1, n + 1))
    assert max(calls) <= (settings.descent_iterations + 3
                          + 2 * settings.field_descent_iterations + 3 + SDF_CALLS)


@pytest.mark.parametrize("quality", ["fast", "accurate"])
def test_mesh_contacts_do_not_depend_on_the_quality_preset(quality):
    from sdfphys.settings import preset

    for pose in [(0.3, 0.74, 0.0), (0.1, 0.9, 0.6), (0.2, 0.7451, 0.002)]:
        expected = collide(GROUND, (0.0, 0.0, 0.0), TOP, pose, margin=0.02)
        got = collide(GROUND, (0.0, 0.0, 0.0), TOP, pose, margin=0.02,
                      settings=preset(quality))
        for e, g in zip(sorted_rows(expected), sorted_rows(got), strict=True):
            np.testing.assert_allclose(g, e, atol=1e-9)


# --------------------------------------------------------------------------------------
# Sdf pairs
# --------------------------------------------------------------------------------------

def test_sdf_discs_equal_analytic_circles(rng):
    """Two sdf discs: field-field descent against circle-circle (exact for circles)."""
    disc_a = {"type": "sdf", "field": {"type": "circle", "radius": 0.5}}
    disc_b = {"type": "sdf", "field": {"type": "circle", "radius": 0.3}}
    for _ in range(20):
        pa = np.r_[rng.uniform(-1, 1, 2), rng.uniform(-3, 3)]
        direction = rng.normal(size=2)
        pb = np.r_[pa[:2] + rng.uniform(0.2, 0.78) * direction / np.linalg.norm(direction),
                   rng.uniform(-3, 3)]
        got = collide(disc_a, pa, disc_b, pb)
        expected = collide(BALL, pa, {"type": "circle", "radius": 0.3}, pb)
        assert len(got) == 1
        # the sdf discs' centres of mass come from quadrature (1e-4 relative)
        np.testing.assert_allclose(got.depth, expected.depth, atol=1e-4)
        np.testing.assert_allclose(got.normal, expected.normal, atol=1e-3)
        np.testing.assert_allclose(got.point, expected.point, atol=1e-4)


def test_sdf_box_resting_flat_on_an_sdf_box():
    ground = {"type": "sdf", "field": GROUND}
    top = {"type": "sdf", "field": TOP}
    c = collide(ground, (0.0, 0.0, 0.0), top, (0.3, 0.74, 0.0))
    point, normal, depth = sorted_rows(c)
    np.testing.assert_allclose(point, [[-0.2, 0.495], [0.8, 0.495]], atol=1e-6)
    np.testing.assert_allclose(normal, [[0.0, 1.0], [0.0, 1.0]], atol=1e-6)
    np.testing.assert_allclose(depth, [0.01, 0.01], atol=1e-6)


@pytest.mark.parametrize("bounded_first", [True, False])
def test_sdf_box_on_an_unbounded_sdf_ground_in_either_order(bounded_first):
    """The half-plane may be either body of the pair (its shape made first or not): the
    same two corners, 0.01 deep, normal from a toward b. (Bounded first used to raise:
    the descent's region was the half-plane's bounds placed in the box's frame.)"""
    plane = {"type": "sdf", "field": {"type": "half_plane", "normal": [0.0, 1.0]}}
    box = {"type": "sdf", "field": TOP}
    world = World(gravity=(0.0, 0.0))
    if bounded_first:
        world.add_body(box, position=(0.3, 0.24))
        world.add_body(plane, kind="static")
    else:
        world.add_body(plane, kind="static")
        world.add_body(box, position=(0.3, 0.24))
    world.step()
    c = world.contacts
    box_body = 0 if bounded_first else 1
    sign = -1.0 if c.body_a[0] == box_body else 1.0
    np.testing.assert_allclose(np.sort(c.point[:, 0]), [-0.2, 0.8], atol=1e-6)
    np.testing.assert_allclose(c.normal, [[0.0, sign], [0.0, sign]], atol=1e-6)
    np.testing.assert_allclose(c.depth, [0.01, 0.01], atol=1e-6)


def test_sdf_pair_group_field_calls_do_not_grow_with_pairs(rng):
    """50 sdf boxes on one sdf ground (one group): each field is evaluated a bounded
    number of times, the same bound as for 5 pairs (all pairs of a descent round in
    one call): the starts, one call per descent iteration, and the patch search (its
    two bracket ends, one call per iteration)."""
    counting_ground = Counting(field({"type": "box", "size": [400.0, 1.0]}))
    counting_box = Counting(field(TOP))
    ground, box = SdfShape(counting_ground), SdfShape(counting_box)
    _ = ground.field, ground.radius, box.field, box.radius
    settings = Settings()
    bound = 2 * settings.field_descent_iterations + 3
    for n in (5, 50):
        x = np.arange(n) * 2.0 - 50.0
        position = np.concatenate([[[0.0, 0.0]], np.stack([x, np.full(n, 0.74)], axis=1)])
        angle = np.r_[0.0, rng.uniform(-0.01, 0.01, n)]
        counting_ground.calls = counting_box.calls = 0
        c = find_contacts([ground, box], np.r_[0, np.ones(n, int)], position, angle,
                          np.r_[False, np.ones(n, bool)], settings)
        assert set(c.body_b) == set(range(1, n + 1))
        assert 0 < counting_ground.calls <= bound
        assert 0 < counting_box.calls <= bound


def test_mesh_box_resting_on_an_sdf_ground():
    """Mesh-sdf: the mesh's corners against the sdf's face, either kind order."""
    ground = {"type": "sdf", "field": GROUND}
    for first, second, sign in [((ground, (0.0, 0.0, 0.0)), (TOP, (0.3, 0.74, 0.0)), 1.0),
                                ((TOP, (0.3, 0.74, 0.0)), (ground, (0.0, 0.0, 0.0)), -1.0)]:
        c = collide(first[0], first[1], second[0], second[1])
        point, normal, depth = sorted_rows(c)
        np.testing.assert_allclose(point, [[-0.2, 0.495], [0.8, 0.495]], atol=1e-6)
        np.testing.assert_allclose(normal, [[0.0, sign], [0.0, sign]], atol=1e-6)
        np.testing.assert_allclose(depth, [0.01, 0.01], atol=1e-6)


def test_first_per_key_of_no_rows_is_empty():
    """Regression: a mesh whose reference faces all fail measured no vertex and crashed
    (IndexError) in scenes/concave_polygons.toml at step 45."""
    from sdfphys.collide.mesh_contacts import _first_per_key

    empty = np.zeros(0, np.int64)
    assert _first_per_key(empty, empty, empty).shape == (0,)


def test_concave_polygons_scene_steps_past_the_former_crash():
    world = sdfphys.load_scene(ROOT / "scenes" / "concave_polygons.toml")
    for _ in range(50):
        world.step()
    assert np.all(np.isfinite(world.position))


STAR = {"type": "polygon", "points": [
    [0.0, 0.7], [-0.1763, 0.2427], [-0.6657, 0.2163], [-0.2853, -0.0927], [-0.4114, -0.5663],
    [-0.0, -0.3], [0.4114, -0.5663], [0.2853, -0.0927], [0.6657, 0.2163], [0.1763, 0.2427]]}
ARROW = {"type": "polygon", "points": [[-0.65, 0.25], [0.15, 0.25], [0.15, 0.5], [0.65, 0.0],
                                       [0.15, -0.5], [0.15, -0.25], [-0.65, -0.25]]}


def test_a_spike_tip_in_a_notch_is_found_at_its_exact_depth():
    """scenes/concave_polygons.toml at t = 1.067 s: the star's spike tip is 4.1 cm inside
    the arrow, nearest the arrow's re-entrant corner (the deepest point of the star in
    the arrow, by brute force over a 1 mm grid of the star and its vertices). The contacts reached
    -1.9e-5 m before reflex corners gave normals; the stars then sank 18 cm."""
    pose_star = (-0.494332864716853, 0.572414104840528, 1.241222173627571)
    pose_arrow = (-0.23584928556841564, 1.3535525034783593, 2.5399083167657674)
    c = collide(STAR, pose_star, ARROW, pose_arrow)
    star, arrow = shape_from_spec(STAR), shape_from_spec(ARROW)
    lo, hi = star.bounds()[:2], star.bounds()[2:]
    grid = np.stack(np.meshgrid(*(np.arange(lo[i], hi[i], 1e-3) for i in range(2))),
                    -1).reshape(-1, 2)
    grid = np.concatenate([grid[star.field.distance(grid) <= 0.0], star.vertices])

    def frame(shape, pose):
        c_, s_ = np.cos(pose[2]), np.sin(pose[2])
        rot = np.array([[c_, -s_], [s_, c_]])
        return rot, np.asarray(pose[:2]) - rot @ shape.origin      # centre of mass

    rot_s, com_s = frame(star, pose_star)
    rot_a, com_a = frame(arrow, pose_arrow)
    inside = (grid @ rot_s.T + com_s - com_a) @ rot_a
    deepest = -arrow.field.distance(inside).min()
    assert deepest > 0.04
    assert len(c) > 0 and c.depth.max() == pytest.approx(deepest, abs=1e-3)


L_PIECE = {"type": "polygon", "points": [[-0.6, -0.6], [0.6, -0.6], [0.6, -0.2], [-0.2, -0.2],
                                         [-0.2, 0.6], [-0.6, 0.6]]}


def test_two_crossing_corners_get_the_face_the_overlap_runs_along():
    """scenes/concave_polygons.toml at t = 2.30 s (poly7, poly12): the arrow's tip and
    the L's arm-end corner cross, each vertex only 3.4 and 0.9 mm inside the other, the
    overlap a 7 cm sliver between the arrow's side [0.65, 0]-[0.15, -0.5] and the L's
    arm side, 14 deg apart (brute force over a 0.5 mm grid: 1.4 cm deep each way). Its
    deepest point lies on a medial axis, where the field's normal is either face's; such
    minima were dropped and the pair's deepest contact was the tip's 3.4 mm. The face
    the sliver runs along is taken: the L's corner [0.6, -0.2] is measured below the
    arrow's side (closed form), normal that side's outward normal (arrow toward L)."""
    pose_arrow = (-0.44188065759161116, 1.4314755117100781, 2.569280654727023)
    pose_l = (-0.3104870539715962, 2.082024956753468, 3.5972444198103384)
    arrow, piece = shape_from_spec(ARROW), shape_from_spec(L_PIECE)

    def to_world(shape, pose, points):
        """User-frame points of ``shape`` at the centre-of-mass pose ``pose``."""
        c_, s_ = np.cos(pose[2]), np.sin(pose[2])
        rot = np.array([[c_, -s_], [s_, c_]])
        return (np.asarray(points) + shape.origin) @ rot.T + pose[:2]

    def user(shape, pose):
        return (*to_world(shape, pose, [[0.0, 0.0]])[0], pose[2])

    c = collide(ARROW, user(arrow, pose_arrow), L_PIECE, user(piece, pose_l))
    tip, end = to_world(arrow, pose_arrow, [[0.65, 0.0], [0.15, -0.5]])
    corner = to_world(piece, pose_l, [[0.6, -0.2]])[0]
    along = (tip - end) / np.linalg.norm(tip - end)           # counter-clockwise
    outward = np.array([along[1], -along[0]])
    expected = -np.dot(corner - tip, outward)

    def brute(a, pose_a, b, pose_b):
        lo, hi = a.bounds()[:2], a.bounds()[2:]
        grid = np.stack(np.meshgrid(*(np.arange(lo[i], hi[i], 5e-4) for i in range(2))),
                        -1).reshape(-1, 2)
        grid = grid[a.field.distance(grid) <= 0.0]
        c_, s_ = np.cos(pose_b[2]), np.sin(pose_b[2])
        rot = np.array([[c_, -s_], [s_, c_]])
        world = to_world(a, pose_a, grid - a.origin)
        return -b.field.distance((world - pose_b[:2]) @ rot).min()

    deepest = max(brute(arrow, pose_arrow, piece, pose_l), brute(piece, pose_l, arrow, pose_arrow))
    assert 0.014 < deepest < expected
    k = np.argmax(c.depth)
    assert c.depth[k] == pytest.approx(expected, abs=1e-9)
    np.testing.assert_allclose(c.normal[k], outward, atol=1e-9)


def test_a_circle_in_the_notch_of_a_concave_polygon_touches_both_faces():
    """A disc of radius 0.5 in the L's notch (faces y = 1 and x = 1 meet at the reflex
    corner (1, 1)), centre (1.45, 1.48): it overlaps the bottom face by 0.02 and the
    side face by 0.05 (closed form), each its own contact with that face's normal
    (circle toward L); the field at the centre saw the nearest face only. Beside
    them, a convex corner of the L (3, 1) gives its vertex contact, and a centre
    0.6 from both faces none."""
    ball = {"type": "circle", "radius": 0.5}
    c = collide(ball, (1.45, 1.48, 0.0), L_SHAPE, (0.0, 0.0, 0.0), margin=0.02)
    order = np.argsort(c.depth)
    np.testing.assert_allclose(c.depth[order], [0.02, 0.05], atol=1e-12)
    np.testing.assert_allclose(c.normal[order], [[0.0, -1.0], [-1.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(c.point[order], [[1.45, 0.99], [0.975, 1.48]], atol=1e-12)
    corner = collide(ball, (3.3, 1.2, 0.0), L_SHAPE, (0.0, 0.0, 0.0))
    gap = math.hypot(0.3, 0.2)
    np.testing.assert_allclose(corner.depth, [0.5 - gap], atol=1e-12)
    np.testing.assert_allclose(corner.normal, [[-0.3 / gap, -0.2 / gap]], atol=1e-12)
    assert len(collide(ball, (1.6, 1.6, 0.0), L_SHAPE, (0.0, 0.0, 0.0), margin=0.05)) == 0


def test_sdfphys_collide_is_the_subpackage_and_callable():
    """``import sdfphys.collide`` reaches the subpackage (no function shadows it), and
    ``sdfphys.collide(...)`` is still the two-shape query of the API."""
    import importlib
    import types

    import sdfphys

    module = importlib.import_module("sdfphys.collide")
    assert isinstance(module, types.ModuleType) and module is sdfphys.collide
    assert module.find_contacts is find_contacts
    c = sdfphys.collide(BALL, (0.0, 0.0, 0.0), BALL, (1.01, 0.0, 0.0), margin=0.1)
    expected = collide(BALL, (0.0, 0.0, 0.0), BALL, (1.01, 0.0, 0.0), margin=0.1)
    np.testing.assert_array_equal(c.depth, expected.depth)
    np.testing.assert_array_equal(c.point, expected.point)
