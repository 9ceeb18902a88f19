"""Split push-out (solver, "Split push-out"): overlap deeper than Settings.soft_depth
moves positions through pseudo-velocities and never enters the velocities."""

import numpy as np
import pytest

from sdfphys.settings import Settings
from sdfphys.solver import contact_softness
from sdfphys.world import World

GROUND = {"type": "box", "size": [40.0, 2.0]}      # static, top face at y = 0
BALL = {"type": "circle", "radius": 0.5}


def _sunk_ball(gravity: float, depth: float, settings: Settings) -> World:
    """A ball of radius 0.5 sunk ``depth`` into the ground."""
    world = World(gravity=(0.0, -gravity), settings=settings)
    world.add_body(GROUND, position=(0.0, -1.0), kind="static")
    world.add_body(BALL, position=(0.0, 0.5 - depth))
    return world


def _push_out_depths(depth: float, settings: Settings, substeps: int) -> list[float]:
    """The overlap after each substep of a split row against a static body: each substep
    moves the ball out by h min(max(mass_scale bias_rate d, split_push_out (d -
    soft_depth) / h), max_push_out): the faster of the row's soft bias (the static
    contact's coefficients, contact_softness) and the split fraction of the overlap
    beyond soft_depth, capped; while the row stays split."""
    stiff = contact_softness(settings)[1]
    h = settings.dt / settings.substeps
    rate = stiff.mass_scale * stiff.bias_rate
    depths = []
    for _ in range(substeps):
        if depth > settings.soft_depth:
            push = max(rate * depth, settings.split_push_out * (depth - settings.soft_depth) / h)
            depth -= h * min(push, settings.max_push_out)
        depths.append(depth)
    return depths


@pytest.mark.parametrize("split_push_out", [0.0, Settings().split_push_out])
@pytest.mark.parametrize("gravity", [0.0, 9.81])
def test_a_deep_ball_leaves_the_ground_at_the_split_rate_without_velocity(gravity,
                                                                          split_push_out):
    """A ball 0.2 m deep: its overlap follows the split row's push-out substep by substep
    (3 m/s capped at first, then the larger of the soft rate 17/s and split_push_out of
    the overlap beyond soft_depth per substep), to round-off, for as long as it is
    deeper than soft_depth, and its velocity stays 0 (gravity is held by the rigid
    row)."""
    settings = Settings(split_push_out=split_push_out)
    world = _sunk_ball(gravity, 0.2, settings)
    expected = _push_out_depths(0.2, settings, 12 * settings.substeps)
    # The steps whose every substep starts split (the overlap only shrinks).
    steps = sum(expected[(k + 1) * settings.substeps - 1] > settings.soft_depth
                for k in range(12))
    assert steps >= 3
    for k in range(steps):
        world.step()
        depth = 0.5 - world.position[1, 1]
        assert depth == pytest.approx(expected[(k + 1) * settings.substeps - 1], abs=1e-12)
        np.testing.assert_allclose(world.velocity[1], 0.0, rtol=0, atol=1e-14)
        assert world.angular_velocity[1] == 0.0
    assert world.stage_counts["push_out"] == steps * settings.substeps


def _shaft_column(settings: Settings, steps: int) -> dict:
    """25 balls of radius 0.5 stacked 0.8 m apart (0.2 m overlaps) in a 1.02 m wide
    shaft, stepped until no overlap exceeds soft_depth or ``steps`` ran out: speed, m/s,
    the fastest ball; separation, m/s, the fastest decrease of a pair's overlap;
    overlap, the total overlap (m) after each step; steps, the steps run."""
    world = World(gravity=(0.0, -9.81), settings=settings)
    world.add_body(GROUND, position=(0.0, -1.0), kind="static")
    for side in (-1.0, 1.0):
        world.add_body({"type": "box", "size": [1.0, 40.0]}, position=(side * 1.01, 20.0),
                       kind="static")
    for i in range(25):
        world.add_body(BALL, position=(0.0, 0.4 + 0.8 * i), friction=0.6)
    speed = separation = 0.0
    previous: dict = {}
    overlap = []
    for k in range(steps):
        world.step()
        c = world.contacts
        depth = dict(zip(zip(c.body_a.tolist(), c.body_b.tolist()), c.depth.tolist()))
        shrink = [previous[p] - d for p, d in depth.items() if p in previous]
        separation = max([separation, *shrink])
        previous = depth
        speed = max(speed, float(np.hypot(*world.velocity[3:].T).max()))
        overlap.append(float(np.sum(np.maximum(c.depth, 0.0))))
        if c.depth.max() <= settings.soft_depth:
            break
    return {"speed": speed, "separation": separation / settings.dt, "overlap": overlap,
            "steps": k + 1}


def test_a_column_of_deep_overlaps_is_pushed_out_without_ejection():
    """Split (default): no ball moves faster than the 3 m/s push-out cap, no overlap
    shrinks faster than the cap (to round-off), the total overlap (4.9 m) shrinks at
    every step and no overlap exceeds soft_depth within 15 s (measured: 2.0 s at
    split_push_out 0.5, 10.5 s at the soft rate alone; pymunk still has 0.18 m after
    5 s). All soft: the 25 contacts' push-out adds up along the column and the balls
    leave faster than the cap (measured: 22 m/s, the top one thrown 15 m above where it
    finally rests)."""
    settings = Settings()
    for split in (_shaft_column(settings, 900),
                  _shaft_column(settings.with_values(split_push_out=0.0), 900)):
        assert split["speed"] <= settings.max_push_out
        assert split["separation"] <= settings.max_push_out * (1.0 + 1e-12)
        assert np.all(np.diff(split["overlap"]) < 0.0)
        assert split["steps"] < 900
    soft = _shaft_column(settings.with_values(soft_depth=1.0), 60)
    assert soft["speed"] > settings.max_push_out


def test_scenes_without_deep_overlap_run_bit_for_bit_as_all_soft():
    """Balls dropped on the ground and boxes resting side by side never overlap by
    soft_depth: no row is split, and the trajectory is the all-soft one to the bit."""
    def run(settings):
        world = World(gravity=(0.0, -9.81), settings=settings)
        world.add_body(GROUND, position=(0.0, -1.0), kind="static")
        for i in range(6):
            world.add_body({"type": "circle", "radius": 0.4}, position=(-15.0 + 3.0 * i, 2.0 + i),
                           restitution=0.5, friction=0.4)
            world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(2.0 + 1.5 * i, 0.6),
                           mass=1.0 + 0.5 * i, friction=0.6)
        deepest = 0.0
        for _ in range(180):
            world.step()
            deepest = max([deepest, *world.contacts.depth.tolist()])
        return world, deepest

    split, deepest = run(Settings())
    soft, _ = run(Settings(soft_depth=1.0))
    assert 0.0 < deepest < Settings().soft_depth
    assert split.stage_counts["push_out"] == 0
    np.testing.assert_array_equal(split.position, soft.position)
    np.testing.assert_array_equal(split.velocity, soft.velocity)
    np.testing.assert_array_equal(split.angle, soft.angle)
