"""The world's sleeping islands: which bodies a step moves, falling asleep, waking.

The rule is ``sdfphys.sleep``'s (its docstring; the per-body kernels ``rest_times`` and
``falling_asleep``): this module keeps the world's books. A sleeping body has
``asleep`` set and the number of its island in ``island``; the contacts and impulses of
sleeping islands move to ``World._sleep_contacts`` and ``World._sleep_impulses`` as they
fall asleep (``fall_asleep``) and come back to the warm-start cache when they wake
(``wake_islands``). An island wakes whole: when an active body reaches it
(``wake_reached``, in ``World.step``), when a body of it or touching it is set, removed
or carved (``wake_touching``), when a force or impulse is applied to one of its bodies
(``wake_bodies``), or on ``World.wake``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .collide import Contacts
from .events import WorldContacts
from .islands import island_roots
from .sleep import falling_asleep, rest_times
from .solver import BodyState, ContactConstraints, ImpulseCache
from .world_bodies import DYNAMIC, KINEMATIC

if TYPE_CHECKING:
    from .world import World

__all__ = ["active", "awake", "fall_asleep", "islands_falling", "wake_bodies", "wake_islands",
           "wake_reached", "wake_touching"]


def awake(world: World) -> np.ndarray:
    """(B,) bool: dynamic bodies that are not asleep."""
    return (world._view("kind") == DYNAMIC) & ~world._view("asleep")


def active(world: World) -> np.ndarray:
    """(B,) bool: awake dynamic bodies and moving kinematic ones (what a step moves)."""
    kinematic = world._view("kind") == KINEMATIC
    if not kinematic.any():
        return awake(world)
    v, w = world._view("velocity"), world._view("angular_velocity")
    moving = (v[:, 0] != 0.0) | (v[:, 1] != 0.0) | (w != 0.0)
    return awake(world) | (kinematic & moving)


def wake_reached(world: World, contacts: Contacts, active: np.ndarray) -> bool:
    """Wake the sleeping islands that an active body (``active`` (B,) bool,
    ``active()``) has a contact with; True if any."""
    asleep = world._view("asleep")
    if len(contacts) == 0 or not asleep.any():
        return False
    a, b = contacts.body_a, contacts.body_b
    reached = np.r_[b[active[a] & asleep[b]], a[asleep[a] & active[b]]]
    if len(reached) == 0:
        return False
    wake_islands(world, world._view("island")[reached])
    return True


def wake_touching(world: World, index: int) -> None:
    """Wake body ``index``'s island and the sleeping islands that touch it
    (``World._wake_touching``)."""
    c = world._sleep_contacts
    touching = np.r_[c.body_a[c.body_b == index], c.body_b[c.body_a == index], index]
    touching = touching[world._view("asleep")[touching]]
    if len(touching):
        wake_islands(world, world._view("island")[touching])


def wake_bodies(world: World, idx: np.ndarray) -> None:
    """Wake the sleeping islands of bodies ``idx``."""
    asleep = world._view("asleep")[idx]
    if asleep.any():
        wake_islands(world, world._view("island")[idx[asleep]])


def wake_islands(world: World, islands: np.ndarray) -> None:
    """Wake every body of the given sleeping islands; their contacts' impulses return
    to the warm-start cache."""
    if len(islands) == 0:
        return
    d = world._data
    woken = world._view("asleep") & np.isin(world._view("island"), islands)
    d["asleep"][:world._n][woken] = False
    d["sleep_time"][:world._n][woken] = 0.0
    rows = woken[world._sleep_impulses.body_a] | woken[world._sleep_impulses.body_b]
    world._impulses = ImpulseCache.concatenate(
        [world._impulses, world._sleep_impulses.take(rows)]).sorted()
    world._sleep_impulses = world._sleep_impulses.take(~rows)
    c = world._sleep_contacts
    world._sleep_contacts = c.take(~(woken[c.body_a] | woken[c.body_b]))


def islands_falling(world: World, bodies: BodyState, constraints: ContactConstraints,
                    awake: np.ndarray, contact_islands: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The islands (B,) int64 roots (``islands.island_roots``: bodies tied by the
    contacts of ``constraints`` and by joints) and the awake bodies (B,) bool whose
    island has rested ``time_to_sleep`` in every body (``sleep.falling_asleep``).
    contact_islands: the contacts' own roots for ``bodies.inv_mass`` if known (the step's
    row softness found them: ``solve_substeps``), the answer when no joint links two
    bodies; None: found here."""
    c = constraints
    body_a, body_b = world._joints.linked(c.body_a, c.body_b)
    if contact_islands is not None and len(body_a) == len(c.body_a):   # no joint links
        root = contact_islands
    else:
        root = island_roots(bodies.inv_mass, body_a, body_b)
    return root, falling_asleep(root, awake, world._view("sleep_time"),
                                world.settings.time_to_sleep)


def fall_asleep(world: World, bodies: BodyState, constraints: ContactConstraints,
                start_com: np.ndarray, start_angle: np.ndarray, awake: np.ndarray,
                active: np.ndarray, contact_islands: np.ndarray | None = None) -> None:
    """Stage 7: count each awake body's rest (``sleep.rest_times``) and put to sleep the
    islands that have rested ``time_to_sleep``: velocities zeroed, their contacts and
    impulses moved to the sleeping caches. start_com, start_angle: the poses at the
    start of the step (a body pushed out of overlap moves without velocity); awake,
    active: (B,) bool, ``awake()`` and ``active()`` of this step; contact_islands: the
    contacts' islands if the step found them (``islands_falling``)."""
    s = world.settings
    sleep_time = world._view("sleep_time")
    rested = rest_times(bodies.velocity, bodies.angular_velocity, bodies.com, bodies.angle,
                        start_com, start_angle, world._view("radius"), awake, sleep_time,
                        s.dt, s.sleep_speed, s.time_to_sleep)
    c = constraints
    kinematic = active & (world._view("kind") == KINEMATIC)
    if kinematic.any():
        sleep_time[c.body_b[kinematic[c.body_a]]] = 0.0
        sleep_time[c.body_a[kinematic[c.body_b]]] = 0.0
        rested = bool((sleep_time[awake] >= s.time_to_sleep).any())
    if not rested:
        return                       # no body has rested long enough: no island can sleep
    root, falling = islands_falling(world, bodies, constraints, awake, contact_islands)
    if not falling.any():
        return
    d = world._data
    n = world._n
    d["asleep"][:n][falling] = True
    d["velocity"][:n][falling] = 0.0
    d["angular_velocity"][:n][falling] = 0.0
    roots, label = np.unique(root[falling], return_inverse=True)
    d["island"][:n][falling] = world._islands_made + label
    world._islands_made += len(roots)
    cache = world._impulses
    rows = falling[cache.body_a] | falling[cache.body_b]
    world._sleep_impulses = ImpulseCache.concatenate([world._sleep_impulses,
                                                      cache.take(rows)])
    world._impulses = cache.take(~rows)
    contacts = world._contacts
    rows = falling[contacts.body_a] | falling[contacts.body_b]
    world._sleep_contacts = WorldContacts.concatenate([world._sleep_contacts,
                                                       contacts.take(rows)])
    world._contacts = contacts.take(~rows)
