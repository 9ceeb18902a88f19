"""The sweep order of the solve and relax passes (solver.substeps, "Sweep order").

Islands over ``rest_island_limit`` are swept in reverse in the second and third substep
of every four; every other island keeps the forward order, so its trajectory does not
depend on what else the world holds. The benefit (a base-50 pyramid stays symmetric
and comes to rest) is a slow study: tests/stability/test_stability_stacking.py.
"""

import numpy as np

from sdfphys import Settings, World
from sdfphys.solver.bundles import substep_rows
from sdfphys.solver.softness import loaded_rows, row_softness_params
from sdfphys.solver.substeps import _mirrored_order
from sdfphys.world_stages import body_state, prepare

UNIT_BOX = {"type": "box", "size": [1.0, 1.0]}


def test_the_mirrored_order_puts_the_large_islands_pairs_last_in_reverse():
    large = np.array([False, True, True, False, True, False])
    assert _mirrored_order(large).tolist() == [0, 3, 5, 4, 2, 1]
    assert _mirrored_order(np.zeros(4, bool)).tolist() == [0, 1, 2, 3]
    assert _mirrored_order(np.ones(3, bool)).tolist() == [2, 1, 0]


def _ground(settings: Settings) -> World:
    world = World(gravity=(0.0, -9.81), settings=settings)
    world.add_body({"type": "box", "size": [100.0, 2.0]}, position=(0.0, -1.0),
                   kind="static", friction=0.6)
    return world


def _stack(world: World, x: float, count: int) -> None:
    for i in range(count):
        world.add_body(UNIT_BOX, position=(x + 0.1 * i, 0.5 + i), friction=0.6)


def _pyramid(world: World, x: float, base: int) -> None:
    for row in range(base):
        for i in range(base - row):
            world.add_body(UNIT_BOX, position=(x + i - (base - 1 - row) / 2, 0.5 + row),
                           friction=0.6)


def test_pairs_are_flagged_large_by_their_island_s_size():
    """A 3-box stack and a 10-box pyramid with rest_island_limit 4: the pyramid's pairs
    (its rows against the ground too) are large, the stack's are not."""
    settings = Settings(rest_island_limit=4, sleeping=False)
    world = _ground(settings)
    _stack(world, -20.0, 3)
    _pyramid(world, 20.0, 4)
    world.step()
    bodies = body_state(world)
    constraints = prepare(world, world.contacts, bodies)
    k = len(constraints.feature)
    rows = substep_rows(constraints, np.empty(k), np.empty(k), np.empty(k))
    _, _, large, _ = loaded_rows(bodies.inv_mass, rows,
                                 row_softness_params(settings, world._gravity))
    first = constraints.pair_start[:-1]
    in_pyramid = np.maximum(constraints.body_a[first], constraints.body_b[first]) >= 4
    assert in_pyramid.any() and (~in_pyramid).any()
    assert np.array_equal(large, in_pyramid)


def test_an_island_within_the_limit_runs_as_alone_beside_a_larger_one():
    """The 3-box stack beside a 10-box pyramid that is over rest_island_limit (4) and so
    swept in mirrored order: after 2 s the stack's bodies are where the same stack alone
    puts them, bit for bit (islands share no movable body, and its own pairs keep their
    order). stiff_island_limit 4 too: the loaded islands' extra passes stop on one
    measure over all of them, so a loaded pyramid would couple them whatever the order."""
    settings = Settings(rest_island_limit=4, stiff_island_limit=4, sleeping=False)
    both = _ground(settings)
    _stack(both, -20.0, 3)
    _pyramid(both, 20.0, 4)
    alone = _ground(settings)
    _stack(alone, -20.0, 3)
    for _ in range(120):
        both.step()
        alone.step()
    assert np.array_equal(both.center_of_mass[:4], alone.center_of_mass)
    assert np.array_equal(both.angle[:4], alone.angle)
    assert np.array_equal(both.velocity[:4], alone.velocity)
