"""Queries (``sdfphys.queries``): ray casts against pymunk's ``segment_query_first`` and
brute-force sampling along the ray, point queries and box overlaps against brute force,
and bad input."""

import math

import numpy as np
import pymunk
import pytest

from sdfphys.errors import SpecError
from sdfphys.world import World

RING = {"op": "difference", "of": [{"type": "circle", "radius": 1.0},
                                   {"type": "circle", "radius": 0.5}]}
NOTCH = {"op": "difference", "of": [{"type": "box", "size": [2.0, 1.2]},
                                    {"op": "translate", "of": {"type": "circle", "radius": 0.4},
                                     "by": [0.6, 0.6]}]}
BLOB = {"op": "smooth_union", "k": 0.2, "of": [{"type": "circle", "radius": 0.6},
                                               {"type": "box", "size": [1.6, 0.5]}]}
GRID = {"op": "bake", "cell": 0.05, "of": RING}
ARC = {"type": "ring", "half_angle": 2.5, "radius": 1.0, "thickness": 0.3}


def pymunk_scene(rng, count=24):
    """A world and the pymunk space of the same circles, boxes and convex polygons
    (static), spread over [-10, 10]^2; shape -> body index."""
    world, space, index = World(), pymunk.Space(), {}
    for i in range(count):
        pos = rng.uniform(-10, 10, 2)
        angle = float(rng.uniform(-math.pi, math.pi))
        body = pymunk.Body(body_type=pymunk.Body.STATIC)
        body.position, body.angle = tuple(pos), angle
        kind = i % 3
        if kind == 0:
            r = float(rng.uniform(0.3, 1.5))
            spec, shape = {"type": "circle", "radius": r}, pymunk.Circle(body, r)
        elif kind == 1:
            size = rng.uniform(0.3, 2.5, 2)
            spec, shape = {"type": "box", "size": size.tolist()}, pymunk.Poly.create_box(
                body, tuple(size))
        else:
            n = int(rng.integers(3, 8))
            a = np.sort(rng.uniform(0, 2 * math.pi, n))
            pts = np.column_stack([np.cos(a), np.sin(a)]) * rng.uniform(0.5, 1.5) \
                + rng.uniform(-0.3, 0.3, 2)
            spec, shape = {"type": "polygon", "points": pts.tolist()}, pymunk.Poly(
                body, [tuple(p) for p in pts])
        space.add(body, shape)
        index[shape] = world.add_body(spec, position=pos, angle=angle, kind="static")
    return world, space, index


def compare_with_pymunk(index, hits, origins, directions, length, query):
    """Rays whose pymunk hit ``query(start, end)`` (a SegmentQueryInfo or None) agrees with
    ``hits`` to 1e-9 m in body, point, normal and distance; returns how many hit."""
    unit = directions / np.hypot(*directions.T)[:, None]
    checked = 0
    for k in range(len(origins)):
        info = query(tuple(origins[k]), tuple(origins[k] + length * unit[k]))
        if info is None:
            assert hits.body[k] == -1, k
            continue
        checked += 1
        assert hits.body[k] == index[info.shape], k
        np.testing.assert_allclose(hits.point[k], info.point, atol=1e-9)
        np.testing.assert_allclose(hits.normal[k], info.normal, atol=1e-9)
        assert abs(hits.distance[k] - info.alpha * length) < 1e-9
    return checked


def test_ray_cast_matches_pymunk_segment_query_first():
    rng = np.random.default_rng(19)
    world, space, index = pymunk_scene(rng)
    n, length = 3000, 15.0
    origins = rng.uniform(-12, 12, (n, 2))
    directions = rng.normal(size=(n, 2))
    outside = world.point_query(origins, 1e-6).body < 0
    origins, directions = origins[outside], directions[outside]
    hits = world.ray_cast(origins, directions, length)

    def query(start, end):
        return space.segment_query_first(start, end, 0.0, pymunk.ShapeFilter())

    assert compare_with_pymunk(index, hits, origins, directions, length, query) > 500


def test_circle_cast_matches_pymunk_segment_query_with_a_radius():
    rng = np.random.default_rng(23)
    world, _, index = pymunk_scene(rng)
    n, length, radius = 2000, 15.0, 0.25
    origins = rng.uniform(-12, 12, (n, 2))
    directions = rng.normal(size=(n, 2))
    outside = world.point_query(origins, radius + 1e-6).body < 0
    origins, directions = origins[outside], directions[outside]
    hits = world.circle_cast(origins, directions, radius, length)

    def query(start, end):
        # Each shape's own query, the nearest: pymunk's space query looks the segment up
        # in its spatial index without the radius, and misses shapes it grazes.
        found = [q.segment_query(start, end, radius) for q in index]
        found = [q for q in found if q is not None and q.shape is not None]
        return min(found, key=lambda q: q.alpha) if found else None

    assert compare_with_pymunk(index, hits, origins, directions, length, query) > 400


def test_circle_cast_on_fields_is_the_ray_cast_of_the_grown_field():
    world = World()
    world.add_body({"type": "sdf", "field": RING}, position=(0.0, 0.0), kind="static")
    world.add_body({"type": "sdf", "field": {"type": "circle", "radius": 1.0}},
                   position=(6.0, 0.0), kind="static")
    hits = world.circle_cast([[-3.0, 0.0], [0.0, 0.0], [3.0, 0.3]], [[1, 0], [1, 0], [1, 0]],
                             0.2, 10.0)
    assert hits.body.tolist() == [0, 0, 1]
    np.testing.assert_allclose(hits.distance[:2], [3.0 - 1.2, 0.3], atol=1e-12)
    # The SDF circle grown by 0.2: |(3 + t, 0.3) - (6, 0)| = 1.2.
    assert abs(hits.distance[2] - (3.0 - math.sqrt(1.2 ** 2 - 0.09))) < 1e-12
    np.testing.assert_allclose(np.hypot(*(hits.point[2] - [6.0, 0.0])), 1.0, atol=1e-12)


def test_ray_from_inside_hits_at_zero_with_the_field_gradient():
    world = World()
    world.add_body({"type": "circle", "radius": 1.0}, position=(0, 0), kind="static")
    world.add_body({"type": "box", "size": [2, 1]}, position=(5, 0), angle=0.3, kind="static")
    world.add_body({"type": "sdf", "field": BLOB}, position=(10, 0), kind="static")
    origins = np.array([[0.5, 0.1], [5.1, 0.2], [10.3, 0.05]])
    hits = world.ray_cast(origins, [[1, 0]] * 3, 10.0)
    assert hits.body.tolist() == [0, 1, 2]
    np.testing.assert_array_equal(hits.distance, 0.0)
    np.testing.assert_array_equal(hits.point, origins)
    for i in range(3):
        shape = world.shapes[world.shape_id[i]]
        a = world.angle[i]
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        local = rot.T @ (origins[i] - world.center_of_mass[i])
        g = shape.field.evaluate(local[None])[1][0]
        np.testing.assert_allclose(hits.normal[i], rot @ g / np.hypot(*g), atol=1e-12)


def first_root(f, origin, direction, top, samples=400_001):
    """Brute force: f sampled densely along the ray, the first sign change (or a
    sample <= 0) refined by bisection; inf if none."""
    t = np.linspace(0.0, top, samples)
    values = f.distance(origin + t[:, None] * direction)
    inside = np.flatnonzero(values <= 0.0)
    if len(inside) == 0:
        return math.inf
    k = inside[0]
    if k == 0:
        return 0.0
    lo, hi = t[k - 1], t[k]
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if f.distance((origin + mid * direction)[None])[0] > 0.0:
            lo = mid
        else:
            hi = mid
    return lo


@pytest.mark.parametrize("spec", [RING, NOTCH, BLOB, GRID, ARC],
                         ids=["ring", "notch", "blob", "grid", "arc"])
def test_ray_cast_into_fields_matches_sampling_along_the_ray(spec):
    world = World()
    world.add_body({"type": "sdf", "field": spec}, position=(0.0, 0.0), angle=0.4,
                   kind="static")
    f = world.shapes[0].field
    rng = np.random.default_rng(3)
    n = 60
    angles = rng.uniform(0, 2 * math.pi, n)
    origins = 2.5 * np.column_stack([np.cos(angles), np.sin(angles)])
    targets = rng.uniform(-1.0, 1.0, (n, 2))
    directions = targets - origins
    directions /= np.hypot(*directions.T)[:, None]
    hits = world.ray_cast(origins, directions, 6.0)
    com, a = world.center_of_mass[0], world.angle[0]
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    tolerance = 1e-9
    for k in range(n):
        expected = first_root(f, rot.T @ (origins[k] - com), rot.T @ directions[k], 6.0)
        if expected == math.inf:
            assert hits.body[k] == -1, k
        else:
            assert hits.body[k] == 0, k
            assert abs(hits.distance[k] - expected) < tolerance, k
            local = rot.T @ (hits.point[k] - com)
            assert abs(f.distance(local[None])[0]) < 1e-12 or spec is GRID


def test_ray_through_the_hole_and_the_gap():
    world = World()
    world.add_body({"type": "sdf", "field": RING}, position=(0.0, 0.0), kind="static")
    world.add_body({"type": "sdf", "field": ARC}, position=(10.0, 0.0), kind="static")
    hits = world.ray_cast([[0.0, 0.0], [10.0, 0.0]], [[1.0, 0.0], [0.0, -1.0]], 5.0)
    # From the ring's hole: not inside, the inner wall at 0.5 (normal into the hole).
    assert hits.body[0] == 0 and abs(hits.distance[0] - 0.5) < 1e-12
    np.testing.assert_allclose(hits.normal[0], [-1.0, 0.0], atol=1e-12)
    # Down through the arc's gap (its opening faces -y): a miss.
    assert hits.body[1] == -1 and math.isnan(hits.distance[1])


def test_grazing_rays():
    world = World()
    world.add_body({"type": "sdf", "field": {"type": "circle", "radius": 1.0}},
                   position=(0.0, 0.0), kind="static")
    world.add_body({"type": "circle", "radius": 1.0}, position=(0.0, 5.0), kind="static")
    for y0, body in ((0.0, 0), (5.0, 1)):
        ys = y0 + np.array([1.0 - 1e-6, 1.0 - 1e-9, 1.0 + 1e-7, 1.0 + 1e-4])
        origins = np.column_stack([np.full(4, -3.0), ys])
        hits = world.ray_cast(origins, [[1.0, 0.0]] * 4, 10.0)
        assert hits.body.tolist() == [body, body, -1, -1]
        for k in range(2):
            c = ys[k] - y0
            expected = 3.0 - math.sqrt(1.0 - c * c)
            assert abs(hits.distance[k] - expected) < 1e-6
            assert abs(np.hypot(*(hits.point[k] - [0.0, y0])) - 1.0) < 1e-12


def test_ray_cast_all_lists_every_body_along_the_ray():
    world = World()
    for x in (2.0, 4.0, 6.0):
        world.add_body({"type": "circle", "radius": 0.5}, position=(x, 0.0), kind="static")
    world.add_body({"type": "sdf", "field": RING}, position=(8.0, 0.0), kind="static")
    hits = world.ray_cast_all([[0.0, 0.0], [0.0, 3.0]], [[1.0, 0.0], [1.0, 0.0]], 7.6)
    assert hits.ray.tolist() == [0, 0, 0, 0]
    assert hits.body.tolist() == [0, 1, 2, 3]
    np.testing.assert_allclose(hits.distance, [1.5, 3.5, 5.5, 7.0], atol=1e-12)
    one = world.ray_cast_all([[0.0, 0.0]], [[1.0, 0.0]], 100.0, bodies=[1, 3])
    assert one.body.tolist() == [1, 3]
    closest = world.ray_cast([[0.0, 0.0]], [[1.0, 0.0]], 100.0, bodies=np.array([2]))
    assert closest.body.tolist() == [2]


def test_many_bodies_use_the_grid_and_agree_with_brute_force():
    rng = np.random.default_rng(7)
    world, _, _ = pymunk_scene(rng, count=150)
    world.add_body({"type": "sdf", "field": {"type": "half_plane", "normal": [0, 1],
                                             "distance": -11.0}}, kind="static")
    origins = rng.uniform(-12, 12, (400, 2))
    directions = rng.normal(size=(400, 2))
    hits = world.ray_cast(origins, directions, 30.0)
    every = world.ray_cast_all(origins, directions, 30.0)
    first = np.full(400, -1)
    for k in range(len(every.ray) - 1, -1, -1):
        first[every.ray[k]] = every.body[k]
    np.testing.assert_array_equal(hits.body, first)
    # Point queries through the grid (small boxes, many bodies) against brute force.
    near = world.point_query(origins, 0.5)
    np.testing.assert_array_equal(near.body, brute_nearest(world, origins, 0.5)[0])


def brute_nearest(world, points, top):
    """(body (N,), distance (N,)): every body's field at every point, the least."""
    table = np.empty((len(world), len(points)))
    for i in range(len(world)):
        shape = world.shapes[world.shape_id[i]]
        a = world.angle[i]
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        table[i] = shape.field.distance((points - world.center_of_mass[i]) @ rot)
    best = np.argmin(table, axis=0)
    d = table[best, np.arange(len(points))]
    return np.where(d <= top, best, -1), np.where(d <= top, d, np.inf)


def test_point_query_matches_brute_force():
    rng = np.random.default_rng(5)
    world, _, _ = pymunk_scene(rng, count=12)
    world.add_body({"type": "sdf", "field": NOTCH}, position=(1.0, -2.0), angle=0.7,
                   kind="static")
    points = rng.uniform(-11, 11, (500, 2))
    result = world.point_query(points, 2.0)
    body, distance = brute_nearest(world, points, 2.0)
    np.testing.assert_array_equal(result.body, body)
    np.testing.assert_allclose(result.distance, distance, atol=1e-12)


def test_overlap_box_matches_pymunk_shape_query():
    rng = np.random.default_rng(11)
    world, space, index = pymunk_scene(rng, count=30)
    for _ in range(40):
        lo = rng.uniform(-11, 9, 2)
        hi = lo + rng.uniform(0.1, 3.0, 2)
        body = pymunk.Body(body_type=pymunk.Body.STATIC)
        probe = pymunk.Poly(body, [(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]),
                                   (lo[0], hi[1])])
        probe.cache_bb()
        expected = sorted(index[q.shape] for q in space.shape_query(probe))
        assert world.overlap_box(lo, hi).tolist() == expected


def test_overlap_box_on_fields_follows_the_rule():
    world = World()
    world.add_body({"type": "sdf", "field": RING}, position=(0.0, 0.0), kind="static")
    inside_hole = world.overlap_box([-0.2, -0.2], [0.2, 0.2])
    assert inside_hole.tolist() == []
    assert world.overlap_box([0.45, -0.01], [0.55, 0.01]).tolist() == [0]
    assert world.overlap_box([1.01, -0.1], [1.2, 0.1]).tolist() == []
    # Random boxes: every box that meets the ring (a sampled point inside) is
    # reported; a reported one comes within r / 2^OVERLAP_LEVELS (r: its half-diagonal).
    from sdfphys.queries import OVERLAP_LEVELS

    f = world.shapes[0].field
    rng = np.random.default_rng(2)
    for _ in range(200):
        lo = rng.uniform(-1.3, 1.1, 2)
        hi = lo + rng.uniform(0.005, 0.4, 2)
        u = np.linspace(0.0, 1.0, 101)
        grid = lo + np.stack(np.meshgrid(u, u), -1).reshape(-1, 2) * (hi - lo)
        least = f.distance(grid).min()
        spacing = np.hypot(*(hi - lo)) / 100
        reported = world.overlap_box(lo, hi).tolist() == [0]
        if least <= 0.0:
            assert reported
        if reported:
            assert least <= np.hypot(*(hi - lo)) / 2 / 2 ** OVERLAP_LEVELS + spacing


def test_mask_selects_bodies_by_category():
    # Box2D's query filter: a body is seen when its category shares a bit with the mask;
    # bodies= narrows the selection further.
    world = World()
    near = world.add_body({"type": "circle", "radius": 0.5}, position=(2.0, 0.0), category=2)
    far = world.add_body({"type": "circle", "radius": 0.5}, position=(5.0, 0.0), category=4)
    cast = [[0.0, 0.0]], [[1.0, 0.0]], 10.0
    assert world.ray_cast(*cast).body.tolist() == [near]
    assert world.ray_cast(*cast, mask=4).body.tolist() == [far]
    assert world.ray_cast(*cast, mask=6).distance.tolist() == [1.5]
    assert world.ray_cast(*cast, mask=1).body.tolist() == [-1]
    assert world.ray_cast(*cast, mask=6, bodies=[far]).body.tolist() == [far]
    assert world.point_query([[2.0, 0.0]], 1.0, mask=4).body.tolist() == [-1]
    assert world.overlap_box([1.0, -1.0], [6.0, 1.0], mask=2).tolist() == [near]


@pytest.mark.parametrize("call, message", [
    (lambda w: w.ray_cast([[math.nan, 0.0]], [[1, 0]], 1.0), "origins[0][0]: must be finite"),
    (lambda w: w.ray_cast([[0.0, 0.0]], [[0, 0]], 1.0), "directions[0]: must be a nonzero"),
    (lambda w: w.ray_cast([[0.0, 0.0]], [[1, 0]], -1.0), "max_distance: must be >= 0"),
    (lambda w: w.ray_cast([0.0, 0.0, 1.0], [[1, 0]], 1.0), "origins: must have shape (N, 2)"),
    (lambda w: w.ray_cast([[0.0, 0.0]], [[1, 0], [0, 1]], 1.0),
     "directions: must have the shape of origins"),
    (lambda w: w.ray_cast([[0.0, 0.0]], [[1, 0]], 1.0, mask=-1), "mask: must be >= 0"),
    (lambda w: w.ray_cast([[0.0, 0.0]], [[1, 0]], 1.0, bodies=[5]), "bodies: has an index"),
    (lambda w: w.point_query([[0.0, 0.0]], math.inf), "max_distance: must be finite"),
    (lambda w: w.overlap_box([0, 0], [-1, 1]), "hi[0]: must be >= lo[0]"),
    (lambda w: w.circle_cast([[0.0, 0.0]], [[1, 0]], -0.1), "radius: must be >= 0"),
])
def test_bad_input_raises_one_line_naming_the_argument(call, message):
    world = World()
    world.add_body({"type": "circle", "radius": 1.0})
    with pytest.raises(SpecError) as error:
        call(world)
    assert message in str(error.value)
    assert "\n" not in str(error.value)



def test_the_ray_kernel_s_shape_tables_hold_the_packing_in_order_and_are_kept():
    """``rays._shape_tables_of`` lists SHAPE_FIELDS by hand (compiled, cached), the
    fields of ``queries._Packed``; the bundle is made once per packing and made anew
    when a shape is added."""
    import dataclasses
    import inspect

    from sdfphys import queries, rays

    assert tuple(inspect.signature(rays._shape_tables_of.py_func).parameters) == \
        rays.SHAPE_FIELDS
    assert rays.SHAPE_FIELDS == tuple(f.name for f in dataclasses.fields(queries._Packed))
    world = World()
    world.add_body({"type": "circle", "radius": 0.5}, position=(0.0, 0.0))
    first = rays._shape_tables(world, queries._packed(world))
    assert rays._shape_tables(world, queries._packed(world)) is first
    world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(3.0, 0.0))
    assert rays._shape_tables(world, queries._packed(world)) is not first
    hits = world.ray_cast([[-2.0, 0.0], [5.0, 0.0]], [[1.0, 0.0], [-1.0, 0.0]])
    np.testing.assert_array_equal(hits.body, [0, 1])
