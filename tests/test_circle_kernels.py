"""The compiled circle path of find_contacts gives exactly the general path's contacts.

``find_contacts(..., fast_circles=False)`` runs the numpy stages and sends every pair
through ``_narrowphase`` (grouping, ``collide_circles``, margin filter, flip, sort,
reduction); the default compiled path must give the same contacts in the same order,
bit for bit, on random scenes: several circle radii (distinct Shape objects, listed
in either order and repeated), coincident centres, static and kinematic bodies,
velocities that widen the margins, and boxes, polygons and sdf shapes (including a
half-plane ground) mixed in.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import sdfphys.world_stages as stages_module
from sdfphys.collide import REACH_CAP_RADII, UNBOUNDED_RADIUS, find_contacts, speculative_reach
from sdfphys.collide import broadphase
from sdfphys.collide.broadphase import world_bounds
from sdfphys.collide.circle_kernels import reach_and_boxes
from sdfphys.settings import Settings
from sdfphys.shapes import shape_from_spec
from sdfphys.world import World

CIRCLES = [{"type": "circle", "radius": r} for r in (0.5, 0.3, 0.5 + 1e-9)]
OTHERS = [
    {"type": "box", "size": [1.0, 0.6]},
    {"type": "polygon", "points": [[0, 0], [1, 0], [1, 1], [0.5, 0.3], [0, 1]]},
    {"type": "sdf", "field": {"type": "circle", "radius": 0.4}},
    {"type": "sdf", "field": {"type": "half_plane", "normal": [0.0, 1.0], "distance": -3.0}},
]


def assert_same_contacts(fast, general):
    assert len(fast) == len(general)
    for name in ("body_a", "body_b", "point", "normal", "depth", "feature"):
        a, b = getattr(fast, name), getattr(general, name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)


def random_scene(rng, n, mixed):
    """shapes, shape_id, position, angle, movable, velocity, angular_velocity."""
    specs = CIRCLES + (OTHERS[:-1] if mixed else [])
    order = rng.permutation(len(specs))
    # The half-plane leads: an sdf-sdf pair needs its unbounded shape first
    # (_placed_fields.overlap_regions), so a scene lists its ground first.
    shapes = [shape_from_spec(OTHERS[-1])] * mixed + [shape_from_spec(specs[k]) for k in order]
    shapes.append(shapes[0])                       # the same Shape object twice
    weights = np.array([8.0 if s.kind == "circle" else 1.0 for s in shapes])
    plane = [k for k, s in enumerate(shapes) if not np.isfinite(s.radius)]
    weights[plane] = 0.0
    shape_id = rng.choice(len(shapes), n, p=weights / weights.sum())
    side = np.sqrt(n) * 0.8
    position = rng.uniform(-side / 2, side / 2, (n, 2))
    dup = rng.choice(n, n // 10, replace=False)
    position[dup[::2]] = position[dup[1::2]][:len(dup[::2])]      # coincident centres
    angle = rng.uniform(-np.pi, np.pi, n)
    kind = rng.choice(3, n, p=[0.8, 0.1, 0.1])     # dynamic, static, kinematic
    velocity = rng.normal(0.0, 3.0, (n, 2)) * (kind != 1)[:, None]
    angular_velocity = rng.normal(0.0, 5.0, n) * (kind != 1)
    if mixed and plane:
        shape_id = np.r_[shape_id, plane[0]]
        position = np.vstack([position, [0.0, 0.0]])
        angle = np.r_[angle, 0.0]
        kind = np.r_[kind, 1]
        velocity = np.vstack([velocity, [0.0, 0.0]])
        angular_velocity = np.r_[angular_velocity, 0.0]
    return shapes, shape_id, position, angle, kind == 0, velocity, angular_velocity


@pytest.mark.parametrize("mixed", [False, True])
@pytest.mark.parametrize("seed", range(6))
def test_fast_path_equals_general_path(seed, mixed):
    rng = np.random.default_rng(seed)
    shapes, shape_id, position, angle, movable, velocity, w = random_scene(rng, 300, mixed)
    settings = Settings()
    for v, om in ((velocity, w), (None, None)):
        ran_fast, ran_general = set(), set()
        fast = find_contacts(shapes, shape_id, position, angle, movable, settings, v, om,
                             ran_fast)
        general = find_contacts(shapes, shape_id, position, angle, movable, settings, v, om,
                                ran_general, fast_circles=False)
        assert len(fast) > 50
        assert_same_contacts(fast, general)
        assert ran_fast == ran_general
        if mixed:
            assert np.any(fast.feature != 0)       # a mesh or sdf pair took part


def test_coincident_centres_take_the_fallback_normal():
    c = shape_from_spec(CIRCLES[0])
    small = shape_from_spec(CIRCLES[1])
    position = np.array([[1.0, 2.0], [1.0, 2.0], [1.0, 2.0]])
    args = ([small, c], np.array([1, 0, 1]), position, np.zeros(3), np.ones(3, bool),
            Settings())
    fast = find_contacts(*args)
    assert_same_contacts(fast, find_contacts(*args, fast_circles=False))
    # body 0 (shape 1) against body 1 (shape 0): oriented from body 1, then flipped.
    np.testing.assert_array_equal(fast.normal, [[-1.0, 0.0], [1.0, 0.0], [1.0, 0.0]])
    np.testing.assert_allclose(fast.depth, [0.8, 1.0, 0.8])


def test_only_circles_or_no_circles_or_no_pairs():
    rng = np.random.default_rng(7)
    settings = Settings()
    for specs in (CIRCLES[:1], OTHERS[:2]):
        shapes = [shape_from_spec(s) for s in specs]
        n = 60
        shape_id = rng.choice(len(shapes), n)
        position = rng.uniform(0, 6, (n, 2))
        args = (shapes, shape_id, position, rng.uniform(-3, 3, n), np.ones(n, bool), settings)
        assert_same_contacts(find_contacts(*args), find_contacts(*args, fast_circles=False))
    far = (shapes, np.zeros(2, np.int64), np.array([[0.0, 0.0], [50.0, 0.0]]), np.zeros(2),
           np.ones(2, bool), settings)
    assert len(find_contacts(*far)) == 0 and len(find_contacts(*far, fast_circles=False)) == 0


def test_reach_and_boxes_equal_the_numpy_stages():
    rng = np.random.default_rng(3)
    shapes = [shape_from_spec(s) for s in CIRCLES + OTHERS]
    shapes.append(shape_from_spec({"type": "sdf", "field": {
        "type": "half_plane", "normal": [1.0, 0.0], "distance": 2.0}}))
    n = 500
    shape_id = rng.choice(len(shapes), n)
    local = np.array([s.bounds() for s in shapes])
    radius = np.array([s.radius for s in shapes])
    position = rng.uniform(-10, 10, (n, 2))
    angle = rng.uniform(-4, 4, n)
    angle[::5] = np.pi                                    # sin(pi) = 1.2e-16, not 0
    angle[1::5] = 0.0
    velocity = rng.normal(0, 5, (n, 2))
    w = rng.normal(0, 5, n)
    dt, margin = 1 / 60, 0.02
    reach, boxes = np.empty(n), np.empty((n, 4))
    reach_and_boxes(local, radius, shape_id, position, angle, velocity, w, dt, 0.5 * margin,
                    UNBOUNDED_RADIUS, REACH_CAP_RADII, reach, boxes)
    expected_reach = speculative_reach(radius[shape_id], velocity, w, dt)
    np.testing.assert_array_equal(reach, expected_reach)
    expected = world_bounds(local[shape_id], radius[shape_id], position, angle,
                            0.5 * margin + expected_reach)
    # cos / sin may come from different libraries: boxes agree to round-off.
    np.testing.assert_allclose(boxes, expected, rtol=1e-14, atol=1e-12)
    circles = radius[shape_id] == 0.5
    np.testing.assert_array_equal(boxes[circles], expected[circles])


def test_world_trajectory_is_bit_identical_with_the_general_path(monkeypatch):
    """A pile of circles of two sizes with boxes, a kinematic and a static body."""
    def build():
        w = World()
        w.add_body({"type": "box", "size": [30.0, 1.0]}, position=(0.0, -0.5), kind="static")
        w.add_body({"type": "box", "size": [3.0, 0.3]}, position=(0.0, 4.0),
                   velocity=(0.5, 0.0), kind="kinematic")
        rng = np.random.default_rng(11)
        for k in range(120):
            spec = CIRCLES[k % 2] if k % 7 else OTHERS[0]
            w.add_body(spec, position=(rng.uniform(-6, 6), 0.6 + 0.4 * k / 3),
                       velocity=rng.normal(0, 1, 2), restitution=0.3 * (k % 3 == 0))
        return w

    fast = build()
    for _ in range(60):
        fast.step()
    monkeypatch.setattr(stages_module, "find_contacts",
                        functools.partial(find_contacts, fast_circles=False))
    general = build()
    for _ in range(60):
        general.step()
    np.testing.assert_array_equal(fast.center_of_mass, general.center_of_mass)
    np.testing.assert_array_equal(fast.velocity, general.velocity)
    assert fast.stage_counts == general.stage_counts


@pytest.mark.parametrize("n", [3, 60, 400])
def test_grid_and_sweep_give_the_same_pairs(n, monkeypatch):
    """candidate_pairs: the sort-and-sweep (small scenes) and the hashed grid agree,
    with infinite boxes, huge boxes, touching and duplicate boxes and static bodies."""
    rng = np.random.default_rng(n)
    lo = rng.uniform(0, np.sqrt(n) * 1.5, (n, 2))
    bounds = np.concatenate([lo, lo + rng.uniform(0.01, 2.0, (n, 2))], axis=1)
    bounds[::11, 2:] = bounds[::11, :2] + 30.0                 # huge (brute force)
    bounds[1::13] = bounds[2::13][:len(bounds[1::13])]          # duplicates
    touch = np.arange(3, n - 1, 17)
    bounds[touch, 0] = bounds[touch + 1, 2]                     # touching on x
    bounds[touch, 2] = bounds[touch, 0] + 0.5
    inf = np.inf
    bounds = np.vstack([bounds, [[-inf, -inf, inf, 1.0], [2.0, -inf, inf, inf]]])
    movable = rng.random(len(bounds)) < 0.7
    movable[-2:] = False
    monkeypatch.setattr(broadphase, "SWEEP_BODIES", 10 ** 9)
    swept = broadphase.candidate_pairs(bounds, movable)
    monkeypatch.setattr(broadphase, "SWEEP_BODIES", 0)
    gridded = broadphase.candidate_pairs(bounds, movable)
    assert len(swept) > n // 2
    np.testing.assert_array_equal(gridded, swept)
