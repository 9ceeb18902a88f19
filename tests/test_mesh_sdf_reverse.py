"""Mesh-sdf pairs from the sdf's side: the sdf body's corners and faces pressing into mesh faces.

Exact answers (geometry of boxes and discs, tolerance 1e-6 m / 1e-6 on unit normals:
the field-field descent that seeds the search converges to ~1e-12 of the region).
A mesh plank ``{"type": "box"}`` is body a or b; an sdf box or disc presses into
its top face y = 0.1. Normal from a toward b, depth > 0 overlapping, point midway.
"""

import importlib
import inspect
import math

import numpy as np
import pytest
from oracles import opaque_shape

from sdfphys.collide import collide
from sdfphys.collide.narrowphase import SOURCE_SDF_IN_MESH
from sdfphys.sdf.build import field as build_field
from sdfphys.settings import Settings

mesh_sdf = importlib.import_module("sdfphys.collide.mesh_sdf")

PLANK = {"type": "box", "size": [4.0, 0.2]}                   # top face at y = 0.1
SDF_BOX = {"type": "sdf", "field": {"type": "box", "size": [1.0, 0.5]}}
SDF_SQUARE = {"type": "sdf", "field": {"type": "box", "size": [0.5, 0.5]}}
HALF = np.array([0.5, 0.25])
TOL = 1e-6


def rotation(theta):
    return np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])


def moved(pose, theta, shift):
    """A user pose (x, y, a) after the rigid motion: rotate by theta about 0, then shift."""
    return (*(rotation(theta) @ np.asarray(pose[:2]) + shift), pose[2] + theta)


def both_orders(plank_pose, sdf_shape, sdf_pose, margin=0.0):
    """[(contacts, sign)]: plank as a (normal sign +1) and as b (sign -1)."""
    return [(collide(PLANK, plank_pose, sdf_shape, sdf_pose, margin=margin), 1.0),
            (collide(sdf_shape, sdf_pose, PLANK, plank_pose, margin=margin), -1.0)]


def lowest_corner(half, angle):
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half @ rotation(angle).T
    return corners[np.argmin(corners[:, 1])]


@pytest.mark.parametrize("gap", [-0.01, 0.005])
def test_sdf_box_flat_on_a_mesh_plank_gets_its_two_corners(rng, gap):
    """Overlap 0.01 (or a 5 mm gap within a 2 cm margin): contacts at the box's bottom
    corners x = -0.2 and 0.8, depth -gap, normal the plank's face normal (a toward b),
    in both argument orders and after rigid motions of the whole scene."""
    box = (0.3, 0.1 + 0.25 + gap, 0.0)
    corners = np.array([[-0.2, 0.1 + 0.5 * gap], [0.8, 0.1 + 0.5 * gap]])
    for theta, shift in [(0.0, np.zeros(2))] + [(rng.uniform(-4, 4), rng.uniform(-5, 5, 2))
                                                  for _ in range(4)]:
        plank, sdf = moved((0.0, 0.0, 0.0), theta, shift), moved(box, theta, shift)
        up = rotation(theta)[:, 1]
        for c, sign in both_orders(plank, SDF_BOX, sdf, margin=0.02):
            assert len(c) >= 2
            np.testing.assert_allclose(c.depth, -gap, atol=TOL)
            np.testing.assert_allclose(c.normal, np.tile(sign * up, (len(c), 1)), atol=TOL)
            local = (c.point - shift) @ rotation(theta)          # back to the unmoved scene
            for corner in corners:
                assert np.min(np.linalg.norm(local - corner, axis=1)) <= TOL
            # every contact lies on the face between the two corners
            np.testing.assert_allclose(local[:, 1], 0.1 + 0.5 * gap, atol=TOL)
            assert np.all((local[:, 0] >= -0.2 - TOL) & (local[:, 0] <= 0.8 + TOL))


@pytest.mark.parametrize("gap", [-0.01, 0.004])
def test_sdf_square_corner_at_45_degrees_into_a_mesh_face(gap):
    """The corner presses 0.01 into the top face (or hovers 4 mm above it, margin 2 cm):
    one contact, depth -gap (not 0.01 cos 45 deg), normal (0, +-1), point the corner
    moved half the depth toward the face."""
    corner_y = 0.1 + gap
    r = 0.25 * math.sqrt(2.0)
    sdf = (0.2, corner_y + r, math.pi / 4)
    for c, sign in both_orders((0.0, 0.0, 0.0), SDF_SQUARE, sdf, margin=0.02):
        assert len(c) == 1
        np.testing.assert_allclose(c.depth, [-gap], atol=TOL)
        np.testing.assert_allclose(c.normal, [[0.0, sign]], atol=TOL)
        np.testing.assert_allclose(c.point, [[0.2, corner_y - 0.5 * gap]], atol=TOL)
        if gap < 0.0:        # separated, the forward direction is exact too (and wins the tie)
            assert c.feature[0] >> 56 == SOURCE_SDF_IN_MESH


def test_tilted_sdf_box_corner_into_a_mesh_face(rng):
    """Any tilt: the box's lowest corner, depth d, normal (0, 1), point corner + d/2."""
    for _ in range(20):
        angle = rng.uniform(0.1, math.pi / 2 - 0.1)
        d = rng.uniform(0.002, 0.05)
        low = lowest_corner(HALF, angle)
        x = rng.uniform(-1.0, 1.0)
        c = collide(PLANK, (0.0, 0.0, 0.0), SDF_BOX, (x, 0.1 - d - low[1], angle))
        deepest = np.argmax(c.depth)
        np.testing.assert_allclose(c.depth[deepest], d, atol=TOL)
        np.testing.assert_allclose(c.normal[deepest], [0.0, 1.0], atol=TOL)
        np.testing.assert_allclose(c.point[deepest], [x + low[0], 0.1 - d / 2], atol=TOL)
        # nothing else deeper or with another normal survives the reduction
        np.testing.assert_array_less(c.depth, d + TOL)


def test_sdf_disc_on_a_mesh_face():
    """A disc (curved: no corner) pressing 0.01: depth r - distance, normal (0, 1)."""
    disc = {"type": "sdf", "field": {"type": "circle", "radius": 0.3}}
    for c, sign in both_orders((0.0, 0.0, 0.0), disc, (0.5, 0.39, 0.7)):
        deepest = np.argmax(c.depth)
        np.testing.assert_allclose(c.depth[deepest], 0.01, atol=TOL)
        np.testing.assert_allclose(c.normal[deepest], [0.0, sign], atol=TOL)
        np.testing.assert_allclose(c.point[deepest], [0.5, 0.095], atol=1e-4)


def test_mesh_corner_into_an_sdf_face_is_unchanged():
    """The forward direction's case: a mesh box's corner 0.01 into an sdf ground, 45 deg.
    The reverse direction's view of it (the ground's face point on the box's medial
    axis, shallower, with a side's normal) is shadowed: one contact, exact."""
    ground = {"type": "sdf", "field": {"type": "box", "size": [4.0, 0.2]}}
    mesh = {"type": "box", "size": [0.5, 0.5]}
    pose = (0.2, 0.1 - 0.01 + 0.25 * math.sqrt(2.0), math.pi / 4)
    for c, sign in [(collide(mesh, pose, ground, (0.0, 0.0, 0.0)), -1.0),
                    (collide(ground, (0.0, 0.0, 0.0), mesh, pose), 1.0)]:
        assert len(c) == 1
        np.testing.assert_allclose(c.depth, [0.01], atol=1e-9)
        np.testing.assert_allclose(c.normal, [[0.0, sign]], atol=1e-9)
        np.testing.assert_allclose(c.point, [[0.2, 0.095]], atol=1e-9)


@pytest.mark.parametrize("compiled", [True, False])
def test_a_mesh_corner_in_an_sdf_face_gives_no_reverse_point_on_its_medial_axis(compiled):
    """A mesh box's corner 0.01 into an sdf ground, at 45 deg (the case above) and
    tilted: the reverse direction's search ends on the box's medial axis, the ground's
    face point on the corner's bisector (at 45 deg (0.2, 0.1), 0.01 sin 45 deg from
    both bottom sides), with one side's normal. It is dropped: the forward direction
    holds the vertex (the sdf corners pressing into mesh faces above keep theirs)."""
    from sdfphys.shapes import shape_from_spec

    ground = shape_from_spec({"type": "sdf", "field": {"type": "box", "size": [4.0, 0.2]}})
    ground = ground if compiled else opaque_shape(ground)
    mesh = shape_from_spec({"type": "box", "size": [0.5, 0.5]})
    pose_sdf = np.array([[0.0, 0.0, 0.0]])
    rows = []
    for tilt in (0.0, 0.02, -0.3):
        y = 0.1 - 0.01 + 0.25 * math.sqrt(2.0) * math.cos(tilt)
        pose_mesh = np.array([[0.2, y, math.pi / 4 + tilt]])
        rows.append(mesh_sdf.sdf_in_mesh(mesh, ground, pose_mesh, pose_sdf, 0.0, Settings()))
    assert [len(row[0]) for row in rows] == [0, 0, 0]


def test_a_box_corner_in_a_baked_terrain_keeps_the_terrain_normal():
    """grid_terrain's box19 at t = 1.03 s and 1.13 s (poses from the scene): its corner
    in the baked terrain, whose field is a bound there (|grad f| 0.63), so the forward
    depth -f(v) is short of the reverse view's medial-axis point (3.07 vs 2.75 cm), which
    was the pair's deepest contact, with a box side's normal flipping from step to step.
    Now the deepest contact is the corner's: depth -f(v), normal -grad f(v) / |grad f(v)|
    (terrain toward box, a = terrain), point v + f(v) / 2 normal, as ``mesh_contacts``."""
    terrain = {"type": "sdf", "field": {
        "op": "bake", "cell": 0.1, "band": 1.0, "of": {"op": "smooth_union", "k": 1.0, "of": [
            {"type": "box", "size": [24.0, 2.0], "offset": [0.0, -1.0]},
            {"type": "circle", "radius": 2.5, "offset": [-6.0, -1.2]},
            {"type": "circle", "radius": 1.8, "offset": [1.0, -0.8]},
            {"type": "ellipse", "size": [6.0, 2.0], "offset": [6.5, 0.0]}]}}}
    f = build_field(terrain["field"])
    box = {"type": "box", "size": [0.6, 0.6]}
    for pose in [(3.0685218758548705, 0.6190136002320614, 0.9710631157320789),
                 (2.976460479533133, 0.5755262114670766, 1.162341565593501)]:
        c = collide(terrain, (0.0, 0.0, 0.0), box, pose)
        corners = np.array([[-0.3, -0.3], [0.3, -0.3], [0.3, 0.3], [-0.3, 0.3]])
        v = corners @ rotation(pose[2]).T + pose[:2]
        value, grad = f.evaluate(v)
        k = np.argmin(value)
        unit = grad[k] / np.linalg.norm(grad[k])
        assert np.linalg.norm(grad[k]) < 0.7
        deepest = np.argmax(c.depth)
        np.testing.assert_allclose(c.depth[deepest], -value[k], atol=TOL)
        np.testing.assert_allclose(c.normal[deepest], unit, atol=TOL)
        sides = rotation(pose[2]) @ np.array([[0.0, -1.0], [-1.0, 0.0], [1.0, 0.0], [0.0, 1.0]]).T
        assert np.max(np.abs(c.normal[c.depth > 0.0] @ sides)) < 0.99


def test_mesh_box_on_an_unbounded_sdf_half_plane():
    """The reverse direction is solved in the sdf's frame: a half-plane ground works."""
    ground = {"type": "sdf", "field": {"type": "half_plane", "normal": [0.0, 1.0]}}
    mesh = {"type": "box", "size": [1.0, 0.5]}
    c = collide(ground, (0.0, 0.0, 0.0), mesh, (0.3, 0.24, 0.0))
    order = np.argsort(c.point[:, 0])
    np.testing.assert_allclose(c.point[order], [[-0.2, -0.005], [0.8, -0.005]], atol=TOL)
    np.testing.assert_allclose(c.depth, 0.01, atol=TOL)
    np.testing.assert_allclose(c.normal, [[0.0, 1.0], [0.0, 1.0]], atol=TOL)


@pytest.mark.parametrize("field", [
    {"type": "half_plane", "normal": [0.0, 1.0]},
    {"op": "rotate", "by": 0.3, "of": {"op": "translate", "by": [0.0, -0.2],
                                    "of": {"type": "half_plane", "normal": [0.0, 1.0]}}}])
def test_a_flat_sdf_skips_the_reverse_direction(field, monkeypatch):
    """Against a half-plane (moved or not) the mesh's corners are the exact deepest
    points, so the reverse direction is not run (it would add nothing: measured, the
    same contacts); a bounded sdf still runs it. The deepest contact is the deepest
    corner, the normal the plane's."""
    mesh_sdf = importlib.import_module("sdfphys.collide.mesh_sdf")
    calls = []
    real = mesh_sdf.sdf_in_meshes

    def spy(*args, **kwargs):
        calls.append(len(args[1]))
        return real(*args, **kwargs)

    monkeypatch.setattr(mesh_sdf, "sdf_in_meshes", spy)
    mesh = {"type": "box", "size": [1.0, 0.5]}
    c = collide({"type": "sdf", "field": field}, (0.0, 0.0, 0.0), mesh, (0.3, 0.1, 0.2))
    assert calls == []
    assert len(c) >= 2 and np.all((c.feature >> 56) == 1)
    f = build_field(field)
    corners = np.array([[-0.5, -0.25], [0.5, -0.25], [0.5, 0.25], [-0.5, 0.25]])
    rot = np.array([[math.cos(0.2), -math.sin(0.2)], [math.sin(0.2), math.cos(0.2)]])
    world = corners @ rot.T + [0.3, 0.1]
    np.testing.assert_allclose(np.max(c.depth), np.max(-f.distance(world)), atol=TOL)
    np.testing.assert_allclose(c.normal, f.evaluate(c.point)[1], atol=TOL)
    collide(SDF_BOX, (0.0, 0.0, 0.0), mesh, (0.3, 0.1, 0.2))
    assert len(calls) == 1


@pytest.mark.parametrize("sdf_shape", [
    {"type": "sdf", "field": {"type": "box", "size": [0.3, 0.2]}},
    {"type": "sdf", "field": {"type": "circle", "radius": 0.15}},
    {"type": "sdf", "field": {"type": "box", "size": [3.0, 0.1]}}])
def test_sdf_centre_inside_the_mesh_gives_finite_contacts(rng, sdf_shape):
    """Deep overlaps (the sdf body's centre inside the plank, or the body wholly inside
    it): finite points, unit normals, positive depths."""
    for _ in range(10):
        pose = (rng.uniform(-1.5, 1.5), rng.uniform(-0.08, 0.08), rng.uniform(-3, 3))
        for c, _ in both_orders((0.0, 0.0, 0.0), sdf_shape, pose, margin=0.02):
            assert len(c) > 0
            assert np.all(np.isfinite(c.point)) and np.all(np.isfinite(c.depth))
            np.testing.assert_allclose(np.linalg.norm(c.normal, axis=1), 1.0, atol=1e-12)
            assert np.max(c.depth) > 0.0


def test_reverse_keys_are_stable_and_unique(rng):
    """Source-4 keys (mesh edge, start id) survive a small motion of the sdf body."""
    r = 0.25 * math.sqrt(2.0)
    cases = [(SDF_BOX, (0.3, 0.34, 0.0)), (SDF_SQUARE, (0.2, 0.09 + r, math.pi / 4)),
             (SDF_BOX, (-0.4, 0.1 - 0.02 - lowest_corner(HALF, 0.6)[1], 0.6))]
    for shape, pose in cases:
        before = collide(PLANK, (0.0, 0.0, 0.0), shape, pose)
        assert np.any(before.feature >> 56 == SOURCE_SDF_IN_MESH)
        assert len(np.unique(before.feature)) == len(before)
        for shift in [(1e-4, 0.0), (0.0, 1e-4), (-1e-4, 1e-4)]:
            after = collide(PLANK, (0.0, 0.0, 0.0), shape, np.add(pose, (*shift, 0.0)))
            np.testing.assert_array_equal(after.feature, before.feature)


def test_sdf_in_mesh_batched_over_pairs_equals_one_by_one(rng):
    """One call for n pairs gives each pair what a call for that pair alone gives."""
    from sdfphys.shapes import shape_from_spec

    mesh, sdf = shape_from_spec(PLANK), shape_from_spec(SDF_BOX)
    settings = Settings()
    n = 12
    pose_mesh = np.column_stack([rng.uniform(-5, 5, (n, 2)), rng.uniform(-3, 3, n)])
    local = np.column_stack([rng.uniform(-1.5, 1.5, n), rng.uniform(0.2, 0.4, n)])
    angle = rng.uniform(-3, 3, n)
    world = np.array([rotation(a) @ p for a, p in zip(pose_mesh[:, 2], local)])
    pose_sdf = np.column_stack([pose_mesh[:, :2] + world, pose_mesh[:, 2] + angle])

    def run(index):
        return mesh_sdf.sdf_in_mesh(mesh, sdf, pose_mesh[index], pose_sdf[index], 0.02,
                                    settings)

    batch = run(np.arange(n))
    assert len(np.unique(batch[0])) > n // 2
    for k in range(n):
        alone = run(np.array([k]))
        rows = batch[0] == k
        for got, expected in zip(batch[1:], alone[1:]):
            np.testing.assert_allclose(got[rows], expected, atol=1e-12)


@pytest.mark.parametrize("theta", [1e-5, 0.004, -0.01])
def test_slightly_tilted_sdf_box_keeps_both_bottom_corners(theta):
    """The shallower corner is no minimum of f_mesh (nor of the field-field descent),
    yet it is a contact: the far end of the incident face, measured against the plank's
    face (depth exact, speculative when above it), key start + FAR_END."""
    corners = np.array([[-1.0, -1.0], [1.0, -1.0]]) * HALF @ rotation(theta).T
    y = 0.1 - 0.005 - corners[:, 1].min()
    bottom = corners + [0.3, y]
    expected_depth = 0.1 - bottom[:, 1]
    for c, sign in both_orders((0.0, 0.0, 0.0), SDF_BOX, (0.3, y, theta), margin=0.02):
        order = np.argsort(c.point[:, 0])
        np.testing.assert_allclose(c.depth[order], expected_depth, atol=TOL)
        np.testing.assert_allclose(c.point[order],
                                   bottom + np.c_[np.zeros(2), expected_depth / 2], atol=TOL)
        np.testing.assert_allclose(c.normal, [[0.0, sign]] * 2, atol=TOL)
        far = (c.feature & ((1 << 13) - 1)) >= mesh_sdf.FAR_END
        assert np.sum(far) == 1 and c.depth[far][0] == np.min(c.depth)


SDF_ROUNDED = {"type": "sdf", "field": {"type": "rounded_box", "size": [1.4, 0.9],
                                        "radii": 0.2}}


@pytest.mark.parametrize("theta", [0.0156, -0.004])
def test_slightly_tilted_rounded_box_keeps_both_ends_of_its_flat_bottom(theta):
    """A rounded box (flat bottom from x = -0.5 to 0.5 in its frame, corners of radius
    0.2) 1 mm into the plank, tilted: its deepest point is on the lower rounding, where
    both probes see one normal, so the incident face is the side toward the centre and
    its line is found from a surface point on the flat part; its far end (the flat
    part's end, to 1/16 of the last ladder gap) is a contact too. scenes/csg_bodies.toml
    at t = 0.917 s: the far end, 1.3 cm above the ground and falling at -3.2 rad/s, was
    missed and landed 4.4 cm deep."""
    c_, s_ = math.cos(theta), math.sin(theta)
    low = -0.5 if theta > 0 else 0.5                     # the lower end of the bottom
    lowest = (np.array([low * c_, low * s_]) + rotation(theta) @ [0.0, -0.25]
              + [0.0, -0.2])                              # the rounding's lowest point
    y = 0.1 - 0.001 - lowest[1]
    for c, sign in both_orders((0.0, 0.0, 0.0), SDF_ROUNDED, (0.3, y, theta), margin=0.03):
        far = (c.feature & ((1 << 13) - 1)) >= mesh_sdf.FAR_END
        assert np.sum(far) == 1
        end = c.point[far][0] - [0.0, c.depth[far][0] / 2]         # the sdf's point
        local = rotation(theta).T @ (end - [0.3, y])
        np.testing.assert_allclose(local[1], -0.45, atol=TOL)      # on the flat bottom
        assert 0.5 - 1.0 / 16 <= -np.sign(low) * local[0] <= 0.5   # near its end
        np.testing.assert_allclose(c.depth[far][0], 0.1 - end[1], atol=TOL)
        np.testing.assert_allclose(c.normal[far][0], [0.0, sign], atol=TOL)
        np.testing.assert_allclose(c.depth.max(), 0.001, atol=TOL)


def test_sdf_box_overhanging_the_mesh_plank_end():
    """The box spans x in [1.5, 2.5], the plank ends at x = 2: the far end past the
    plank is not on its face (dropped); contacts at the box's corner x = 1.5 and the
    plank's corner x = 2 (forward direction), depth 0.01, normal (0, 1)."""
    c = collide(PLANK, (0.0, 0.0, 0.0), SDF_BOX, (2.0, 0.34, 0.0))
    order = np.argsort(c.point[:, 0])
    np.testing.assert_allclose(c.point[order], [[1.5, 0.095], [2.0, 0.095]], atol=TOL)
    np.testing.assert_allclose(c.depth, 0.01, atol=TOL)
    np.testing.assert_allclose(c.normal, [[0.0, 1.0]] * 2, atol=TOL)


def test_field_descent_knobs_reach_mesh_sdf_pairs(monkeypatch):
    """The reverse direction's field-field descent takes the field_descent knobs."""
    from sdfphys.collide import field_pairs

    seen = []
    real = field_pairs.placed_contacts

    def spy(*args, **kwargs):
        given = inspect.signature(real).bind(*args, **kwargs).arguments
        seen.append((given["n_starts"], given["iterations"]))
        return real(*args, **kwargs)

    monkeypatch.setattr(field_pairs, "placed_contacts", spy)
    settings = Settings(field_descent_starts=3, field_descent_iterations=5)
    collide(PLANK, (0.0, 0.0, 0.0), SDF_BOX, (0.3, 0.34, 0.0), settings=settings)
    assert seen == [(3, 5)]
