"""Stability study, energy: extreme time steps, deep initial overlap, restitution 1.

Cases: ``*_time_step`` (energy gain over the initial energy), ``*_overlapping_boxes``
and ``*_packed_circles`` (separation speed, body speed, decay of the kinetic energy),
``*_elastic_balls`` (height above the drop, energy gain). See ``stability_common`` for
the conventions.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pymunk
from stability_common import (
    DT,
    MU,
    SETTINGS,
    UNIT_BOX,
    Bound,
    G,
    advance,
    ground_world,
    pm_box,
    pm_circle,
    pm_ground,
    pm_space,
    pm_state,
    pm_steps,
)

import sdfphys
from sdfphys.world import World

#: Energy never rises above its start by more than this fraction.
ENERGY_MARGIN = Bound(0.01, "", "1 % of the initial energy: a passive scene gains none")
#: Overlap is removed no faster than the push-out cap.
PUSH_OUT = Bound(SETTINGS.max_push_out, "m/s", "Settings.max_push_out (docs/solver.md: 3 m/s)")
#: Once the overlap is gone the motion dies out.
DECAYS = Bound(0.01, "", "kinetic energy over the last second below 1 % of its peak")
#: A perfectly elastic ball never rises above where it was dropped.
NO_HIGHER = Bound(0.0, "m", "the issue: never above the drop height")
#: The energy of a perfectly elastic ball never exceeds its start.
NO_GAIN = Bound(0.0, "", "e = 1 can at best keep the energy")


def _energy(mass: np.ndarray, inertia: np.ndarray, position: np.ndarray,
            velocity: np.ndarray, angular_velocity: np.ndarray) -> np.ndarray:
    """J per body: kinetic plus potential, zero at y = 0 (``position``: centres of mass)."""
    return (0.5 * mass * np.sum(velocity ** 2, axis=1) + 0.5 * inertia * angular_velocity ** 2
            + G * mass * position[:, 1])


# ---------------------------------------------------------------------------------------
# Time step
# ---------------------------------------------------------------------------------------

#: (shape, position, angle, restitution) of the time-step scene: a resting two-box stack
#: with a ball dropped 5 cm onto it, a tilted box dropped 0.25 m (lowest corner) and a
#: ball (e = 0.5) dropped 0.3 m onto the ground.
DT_BODIES = (
    (UNIT_BOX, (0.0, 0.5), 0.0, 0.0),
    (UNIT_BOX, (0.0, 1.5), 0.0, 0.0),
    ({"type": "circle", "radius": 0.25}, (0.1, 2.3), 0.0, 0.0),
    (UNIT_BOX, (3.0, 0.9), 0.4, 0.0),
    ({"type": "circle", "radius": 0.5}, (6.0, 0.8), 0.0, 0.5),
)


@cache
def ours_time_step(dt: float, seconds: float) -> dict[str, float]:
    """DT_BODIES (friction 0.6) stepped at ``dt`` for ``seconds``.

    gain: max over the steps of (E - E0) / E0, E the total energy measured from y = 0
    (the ground's top face).
    """
    world = ground_world(dt=dt)
    for shape, p, a, e in DT_BODIES:
        world.add_body(shape, position=p, angle=a, restitution=e, friction=MU)
    e0 = world.kinetic_energy() + world.potential_energy()
    gain = -math.inf
    for _ in advance(world, round(seconds / dt)):
        gain = max(gain, (world.kinetic_energy() + world.potential_energy() - e0) / e0)
    return {"gain": gain}


def pymunk_time_step(dt: float, seconds: float) -> dict[str, float]:
    """The same case in pymunk (the ground's elasticity 1 keeps each ball's e)."""
    space = pm_space()
    pm_ground(space, elasticity=1.0)
    bodies = []
    for shape, p, a, e in DT_BODIES:
        if shape["type"] == "box":
            bodies.append(pm_box(space, shape["size"], p, angle=a, elasticity=e))
        else:
            bodies.append(pm_circle(space, shape["radius"], p, elasticity=e))
    mass = np.array([b.mass for b in bodies])
    inertia = np.array([b.moment for b in bodies])
    x, _, v, w = pm_state(bodies)
    e0 = float(np.sum(_energy(mass, inertia, x, v, w)))
    gain = -math.inf
    for _ in pm_steps(space, round(seconds / dt), dt):
        x, _, v, w = pm_state(bodies)
        gain = max(gain, (float(np.sum(_energy(mass, inertia, x, v, w))) - e0) / e0)
    return {"gain": gain}


# ---------------------------------------------------------------------------------------
# Deep initial overlap
# ---------------------------------------------------------------------------------------

OVERLAP_SECONDS = 5.0


def _overlap_boxes() -> list[tuple[float, float]]:
    """Unit boxes overlapping by 25 % of their side: a stack of two, a row of four, and
    one sunk a quarter into the ground."""
    return ([(0.0, 0.5), (0.0, 1.25)] + [(3.0 + 0.75 * i, 0.5) for i in range(4)]
            + [(8.0, 0.25)])


PACK_SIDE = 25
PACK_SPACING = 0.8      # m between centres of circles of radius 0.5 (0.2 m overlaps)
PACK_WIDTH = 20.0       # m inside the container: 25 circles side by side need 25 m


def _pack_circles() -> list[tuple[float, float]]:
    """625 centres on a 0.8 m grid, bottom row 0.1 m into the ground, outer columns 0.1 m
    into the walls."""
    xs = (np.arange(PACK_SIDE) - (PACK_SIDE - 1) / 2) * PACK_SPACING
    return [(float(x), 0.4 + PACK_SPACING * row) for row in range(PACK_SIDE) for x in xs]


def _pair_depths(c: sdfphys.Contacts, bodies: int) -> tuple[np.ndarray, np.ndarray]:
    """Deepest contact of each body pair: (sorted pair keys, depths)."""
    key = c.body_a.astype(np.int64) * bodies + c.body_b
    order = np.lexsort((-c.depth, key))
    key, depth = key[order], c.depth[order]
    first = np.r_[True, key[1:] != key[:-1]] if len(key) else np.zeros(0, bool)
    return key[first], depth[first]


def _overlap_figures(separation: float, speed: float, peak: float,
                     late: float) -> dict[str, float]:
    """The figures of an overlap run from its running maxima (see ``_overlap_run``)."""
    return {"separation": separation, "speed": speed, "decay": late / peak if peak else 0.0}


def _overlap_run(world: World, dynamic: np.ndarray) -> dict[str, float]:
    """Over OVERLAP_SECONDS: separation, m/s, the fastest decrease of a pair's deepest
    overlap between consecutive steps; speed, m/s, the fastest body at the end of any
    step (after the relax pass, which removes the push-out velocity); decay, the peak
    kinetic energy over the last second divided by the peak over the run."""
    steps = round(OVERLAP_SECONDS / DT)
    last_second = steps - round(1.0 / DT)
    previous = None
    separation = speed = peak = late = 0.0
    for k in advance(world, steps):
        # Contacts of step k are measured at its start: the state after step k - 1.
        key, depth = _pair_depths(world.contacts, len(world))
        if previous is not None:
            _, i, j = np.intersect1d(previous[0], key, return_indices=True)
            if len(i):
                separation = max(separation, float(np.max(previous[1][i] - depth[j])) / DT)
        previous = key, depth
        speed = max(speed, float(np.hypot(*world.velocity[dynamic].T).max()))
        kinetic = world.kinetic_energy()
        peak = max(peak, kinetic)
        if k > last_second:
            late = max(late, kinetic)
    return _overlap_figures(separation, speed, peak, late)


def _pm_overlap_run(space: pymunk.Space, bodies: list[pymunk.Body]) -> dict[str, float]:
    """As ``_overlap_run``, the overlaps being pymunk's own contact distances."""
    steps = round(OVERLAP_SECONDS / DT)
    last_second = steps - round(1.0 / DT)
    mass = np.array([b.mass for b in bodies])
    inertia = np.array([b.moment for b in bodies])
    previous: dict = {}
    separation = speed = peak = late = 0.0
    for k in pm_steps(space, steps):
        arbiters: list[pymunk.Arbiter] = []
        for body in bodies:
            body.each_arbiter(arbiters.append)
        depths = {}
        for arbiter in arbiters:
            points = arbiter.contact_point_set.points
            if points:
                pair = tuple(sorted(id(s) for s in arbiter.shapes))
                depths[pair] = max(-p.distance for p in points)
        for pair, depth in depths.items():
            if pair in previous:
                separation = max(separation, (previous[pair] - depth) / DT)
        previous = depths
        _, _, v, w = pm_state(bodies)
        speed = max(speed, float(np.hypot(*v.T).max()))
        kinetic = float(np.sum(0.5 * mass * np.sum(v ** 2, axis=1) + 0.5 * inertia * w ** 2))
        peak = max(peak, kinetic)
        if k > last_second:
            late = max(late, kinetic)
    return _overlap_figures(separation, speed, peak, late)


@cache
def ours_overlapping_boxes() -> dict[str, float]:
    """Unit boxes overlapping by 25 % (``_overlap_boxes``, friction 0.6), 5 s;
    figures of ``_overlap_run``."""
    world = ground_world()
    for p in _overlap_boxes():
        world.add_body(UNIT_BOX, position=p, friction=MU)
    return _overlap_run(world, np.arange(1, len(world)))


def pymunk_overlapping_boxes() -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space)
    return _pm_overlap_run(space, [pm_box(space, (1, 1), p) for p in _overlap_boxes()])


def _container_walls() -> list[tuple[float, float]]:
    """Centres of the container's two static 1 x 40 m side walls."""
    return [(side * (PACK_WIDTH / 2 + 0.5), 20.0) for side in (-1, 1)]


@cache
def ours_packed_circles() -> dict[str, float]:
    """625 circles r 0.5 on a 0.8 m grid (0.2 m overlaps) in a 20 m wide open-top
    container that 25 circles side by side would need 25 m of; 5 s. Figures of
    ``_overlap_run``."""
    world = ground_world(width=PACK_WIDTH + 2.0)
    for p in _container_walls():
        world.add_body({"type": "box", "size": [1.0, 40.0]}, position=p, kind="static",
                       friction=MU)
    for p in _pack_circles():
        world.add_body({"type": "circle", "radius": 0.5}, position=p, friction=MU)
    return _overlap_run(world, np.arange(3, len(world)))


def pymunk_packed_circles() -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space, width=PACK_WIDTH + 2.0)
    for p in _container_walls():
        pm_box(space, (1.0, 40.0), p, pymunk.Body.STATIC)
    return _pm_overlap_run(space, [pm_circle(space, 0.5, p) for p in _pack_circles()])


# ---------------------------------------------------------------------------------------
# Restitution 1
# ---------------------------------------------------------------------------------------

DROP_HEIGHTS = tuple(1.0 + 0.5 * k for k in range(10))     # m, ball bottoms: 1 ... 5.5
ELASTIC_STEPS = 10_000
BALL_RADIUS = 0.5


def _elastic_figures(heights: np.ndarray, energy: np.ndarray,
                     e0: np.ndarray) -> dict[str, float]:
    """``above`` and ``gain`` (see ``ours_elastic_balls``) from per-ball maxima."""
    return {"above": float(np.max(heights - np.array(DROP_HEIGHTS))),
            "gain": float(np.max(energy / e0 - 1.0))}


@cache
def ours_elastic_balls() -> dict[str, float]:
    """Balls r 0.5 (restitution 1, no friction) dropped from DROP_HEIGHTS (bottom above
    the ground), 3 m apart, 10,000 steps.

    above: m, max over balls and steps of (bottom height - drop height); gain: max over
    balls and steps of E / E0 - 1 (energy measured from the ground's top face).
    """
    world = ground_world(friction=0.0)
    for k, h in enumerate(DROP_HEIGHTS):
        world.add_body({"type": "circle", "radius": BALL_RADIUS},
                       position=(3.0 * k, h + BALL_RADIUS), restitution=1.0, friction=0.0)
    balls = np.arange(1, len(world))
    mass, inertia = world.mass[balls], world.inertia[balls]

    def energy() -> np.ndarray:
        """J per ball, now."""
        return _energy(mass, inertia, world.position[balls], world.velocity[balls],
                       world.angular_velocity[balls])

    e0 = energy()
    heights = most = np.full(len(balls), -np.inf)
    for _ in advance(world, ELASTIC_STEPS):
        heights = np.maximum(heights, world.position[balls, 1] - BALL_RADIUS)
        most = np.maximum(most, energy())
    return _elastic_figures(heights, most, e0)


def pymunk_elastic_balls() -> dict[str, float]:
    """The same case in pymunk (elasticity 1 on ball and ground)."""
    space = pm_space()
    pm_ground(space, friction=0.0, elasticity=1.0)
    balls = [pm_circle(space, BALL_RADIUS, (3.0 * k, h + BALL_RADIUS), friction=0.0,
                       elasticity=1.0) for k, h in enumerate(DROP_HEIGHTS)]
    mass = np.array([b.mass for b in balls])
    inertia = np.array([b.moment for b in balls])

    def energy() -> np.ndarray:
        """J per ball, now."""
        x, _, v, w = pm_state(balls)
        return _energy(mass, inertia, x, v, w)

    e0 = energy()
    heights = most = np.full(len(balls), -np.inf)
    for _ in pm_steps(space, ELASTIC_STEPS):
        heights = np.maximum(heights, pm_state(balls)[0][:, 1] - BALL_RADIUS)
        most = np.maximum(most, energy())
    return _elastic_figures(heights, most, e0)
