"""Sleeping (``sdfphys.sleep``, ``Settings.sleeping``): islands at rest fall asleep, cost
no collision, keep their poses, and wake whole when something reaches or moves them."""

from __future__ import annotations

import numpy as np
import pytest

from sdfphys import world_sleep
from sdfphys import world_stages as stage
from sdfphys.islands import island_roots
from sdfphys.settings import Settings
from sdfphys.world import World

BOX = {"type": "box", "size": [1.0, 1.0]}


def ground(**settings) -> World:
    world = World(settings=Settings(**settings))
    world.add_body({"type": "box", "size": [60.0, 1.0]}, position=(0.0, -0.5), kind="static",
                   friction=0.6, name="ground")
    return world


def pyramid(base: int = 10, **settings) -> World:
    world = ground(**settings)
    for row in range(base):
        for i in range(base - row):
            world.add_body(BOX, position=(-(base - row - 1) * 0.5 + i, 0.5 + row),
                           friction=0.6)
    return world


def run(world: World, steps: int) -> World:
    for _ in range(steps):
        world.step()
    return world


def test_a_settled_pyramid_falls_asleep_and_then_costs_no_collision():
    world = run(pyramid(), 240)
    assert world.asleep[1:].all() and not world.asleep[0]
    position, collide = world.position, world.stage_counts["collide"]
    t = world.time
    run(world, 60)
    assert world.stage_counts["collide"] == collide
    np.testing.assert_array_equal(world.position, position)
    assert world.step_count == 300 and world.time == pytest.approx(t + 1.0)
    assert np.all(world.velocity == 0.0) and np.all(world.angular_velocity == 0.0)


def test_asleep_poses_equal_awake_poses_within_a_millimetre():
    asleep, awake = run(pyramid(), 600), run(pyramid(sleeping=False), 600)
    assert asleep.asleep[1:].all() and not awake.asleep.any()
    assert np.max(np.abs(asleep.position - awake.position)) < 1e-3
    assert np.max(np.abs(asleep.angle - awake.angle)) < 1e-3


def test_sleeping_islands_keep_their_contacts():
    world = run(pyramid(4), 200)
    assert world.asleep[1:].all()
    c = world.contacts
    assert len(c) >= 2 * 9                    # every box rests on two points at least
    key = c.body_a * len(world) + c.body_b
    assert np.all(np.diff(key) >= 0)


def test_a_ball_dropped_on_a_sleeping_pyramid_wakes_it_and_lands_on_top():
    world = run(pyramid(4), 200)
    assert world.asleep[1:].all()
    top = world.position[-1, 1] + 0.5
    ball = world.add_body({"type": "circle", "radius": 0.3}, position=(0.0, top + 2.0),
                          mass=5.0)
    woke = False
    for _ in range(120):
        world.step()
        woke |= not world.asleep[1:ball].all()
        assert world.position[ball, 1] > top + 0.3 - 0.01        # never sinks in
    assert woke
    assert abs(world.position[ball, 1] - (top + 0.3)) < 0.01


def test_a_ball_away_from_the_island_does_not_wake_it():
    world = run(pyramid(4), 200)
    world.add_body({"type": "circle", "radius": 0.3}, position=(20.0, 3.0))
    for _ in range(30):
        world.step()
        assert world.asleep[1:11].all()


def test_set_state_wakes_the_island_and_the_islands_resting_on_a_moved_support():
    world = run(pyramid(3), 200)
    assert world.asleep[1:].all()
    world.set_state(6, angular_velocity=0.0)
    assert not world.asleep[1:].any()
    run(world, 200)
    assert world.asleep[1:].all()
    world.set_state(0, position=(0.0, -1.5))          # the ground drops by a metre
    assert not world.asleep[1:].any()
    run(world, 20)
    assert world.position[1, 1] < 0.5 - 0.5 * 9.81 * 0.1


def test_removing_a_support_wakes_what_it_carried():
    world = ground()
    world.add_body(BOX, position=(0.0, 0.5))
    world.add_body(BOX, position=(0.0, 1.5))
    run(world, 120)
    assert world.asleep[1:].all()
    world.remove_body(1)
    assert not world.asleep[1]
    run(world, 60)
    np.testing.assert_allclose(world.position[1], (0.0, 0.5), atol=2e-3)


def test_changing_gravity_wakes_everything():
    world = run(pyramid(3), 200)
    assert world.asleep[1:].all()
    world.gravity = (0.0, 5.0)
    assert not world.asleep.any()
    y = world.position[1:, 1].copy()
    run(world, 30)
    assert np.all(world.position[1:, 1] > y + 0.1)


def test_a_moving_platform_keeps_its_passenger_awake_and_a_pusher_wakes_a_sleeper():
    world = ground()
    platform = world.add_body({"type": "box", "size": [3.0, 0.3]}, position=(-8.0, 2.0),
                              velocity=(0.2, 0.0), kind="kinematic", friction=0.9)
    crate = world.add_body(BOX, position=(-8.0, 2.65), friction=0.9)
    sleeper = world.add_body(BOX, position=(8.0, 0.5))
    pusher = world.add_body({"type": "box", "size": [0.5, 1.0]}, position=(5.0, 0.55),
                            kind="kinematic")
    for _ in range(180):
        world.step()
        assert not world.asleep[crate]
    assert world.asleep[sleeper]
    world.set_state(pusher, velocity=(1.0, 0.0))
    run(world, 240)
    assert world.position[sleeper, 0] > 8.5
    assert world.position[platform, 0] > -8.0 + 0.2 * 6.9


def test_waking_restores_the_warm_start():
    """An island woken by set_state takes its stored impulses: the stack does not dip."""
    def dip(keep_impulses: bool) -> float:
        world = ground()
        for k in range(5):
            world.add_body(BOX, position=(0.0, 0.5 + k))
        run(world, 200)
        assert world.asleep[1:].all()
        if not keep_impulses:
            world._sleep_impulses = world._sleep_impulses.take(np.zeros(0, np.int64))
        world.set_state(5, velocity=(0.0, 0.0))
        world.step()
        return float(np.max(np.abs(world.velocity[1:, 1])))
    assert dip(True) < 0.02
    assert dip(False) > 2.0 * dip(True)


def test_a_rolling_ball_and_sleeping_off_never_sleep():
    world = ground()
    ball = world.add_body({"type": "circle", "radius": 0.5}, position=(-20.0, 0.5),
                          velocity=(2.0, 0.0), friction=0.0)
    run(world, 120)
    assert not world.asleep[ball]
    assert not run(pyramid(3, sleeping=False), 200).asleep.any()


def test_falling_asleep_takes_the_islands_the_row_softness_found_unless_joints_link_them():
    """The substep stage returns the contacts' islands (the row softness kernel's union-
    find); they are ``island_roots`` of the same rows, and falling asleep uses them only
    while no joint ties two bodies (a joint joins the islands it links)."""
    world = ground(sleeping=True)
    for x in (-6.0, 6.0):                                       # two stacks: two islands
        for i in range(3):
            world.add_body(BOX, position=(x, 0.5 + i), friction=0.6)
    run(world, 30)
    bodies = stage.body_state(world)
    constraints = stage.prepare(world, stage.collide(world, bodies, world_sleep.active(world)),
                                bodies)
    islands = stage.substeps(world, constraints, bodies)
    expected = island_roots(bodies.inv_mass, constraints.body_a, constraints.body_b)
    np.testing.assert_array_equal(islands, expected)
    assert len(np.unique(islands[1:])) == 2
    awake = world_sleep.awake(world)
    root, _ = world_sleep.islands_falling(world, bodies, constraints, awake, islands)
    np.testing.assert_array_equal(root, expected)
    world.add_joint({"type": "distance", "bodies": [3, 6]})   # the stacks' tops
    root, _ = world_sleep.islands_falling(world, bodies, constraints, awake, islands)
    assert len(np.unique(root[1:])) == 1
