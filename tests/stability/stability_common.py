"""Shared ground of the stability study: bounds, checked stepping, scene builders for two engines.

The study (issue: numerical stability at the extremes) is split by topic into
``stability_stacking``, ``stability_speed``, ``stability_energy`` and
``stability_input``. Each case is a pair of functions, ``ours_<case>`` (sdfphys) and
``pymunk_<case>``, returning a dict of named figures; each bound is a ``Bound``
constant beside its case, with the reason it has that value. ``tests/stability``
asserts the bounds on sdfphys; ``tools/stability_report.py`` prints every figure with
pymunk's beside it.

Conventions. SI units. The ground is a static box whose top face is y = 0, gravity is
-9.81 m/s^2, dt 1/60 s and every other knob the ``balanced`` default, unless a case
says otherwise. pymunk runs its defaults: 10 iterations, collision_slop 0.1 m, the
default collision_bias. Every sdfphys run goes through ``advance``, which checks after
each step that positions, angles and velocities are finite (``NonFiniteState``).

Materials mix differently (sdfphys: friction sqrt(a b), restitution max(a, b);
pymunk: a b for both), so every pymunk shape gets friction sqrt(mu) and the contact
sees the same coefficient mu in both engines; an elastic case gives both of pymunk's
shapes the elasticity.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pymunk

from sdfphys.settings import Settings
from sdfphys.world import World

G = 9.81
DT = 1.0 / 60.0
MU = 0.6                                  # friction of the stacking cases
UNIT_BOX = {"type": "box", "size": [1.0, 1.0]}
SETTINGS = Settings()


@dataclass(frozen=True)
class Bound:
    """figure <= limit (``at_least``: figure >= limit), in ``unit``; ``why``: its source."""

    limit: float
    unit: str
    why: str
    at_least: bool = False

    def holds(self, figure: float) -> bool:
        """The figure meets the bound."""
        return figure >= self.limit if self.at_least else figure <= self.limit

    def __str__(self) -> str:
        """The bound as the table prints it, e.g. ``<= 0.02 m``."""
        return f"{'>=' if self.at_least else '<='} {self.limit:g} {self.unit}".rstrip()


# ---------------------------------------------------------------------------------------
# Stepping with the finiteness check
# ---------------------------------------------------------------------------------------


class NonFiniteState(AssertionError):
    """A valid scene produced NaN or infinity in its state."""


def assert_finite(world: World) -> None:
    """Raise NonFiniteState unless every position, angle and velocity of ``world`` is finite."""
    state = {"position": world.position, "angle": world.angle, "velocity": world.velocity,
             "angular_velocity": world.angular_velocity}
    for name, value in state.items():
        bad = ~np.isfinite(value.reshape(len(value), -1)).all(axis=1)
        if np.any(bad):
            body = int(np.flatnonzero(bad)[0])
            raise NonFiniteState(f"step {world.step_count}: {name} of body {body} "
                                 f"({world.names[body]}) is {value[body]}")


def advance(world: World, steps: int) -> Iterator[int]:
    """Step ``world`` ``steps`` times, checking finiteness; yields 1, 2, ... after each step."""
    for k in range(1, steps + 1):
        world.step()
        assert_finite(world)
        yield k


def pm_steps(space: pymunk.Space, steps: int, dt: float = DT) -> Iterator[int]:
    """Step ``space`` ``steps`` times; yields 1, 2, ... after each step."""
    for k in range(1, steps + 1):
        space.step(dt)
        yield k


# ---------------------------------------------------------------------------------------
# Builders (sdfphys, then the same in pymunk)
# ---------------------------------------------------------------------------------------


def ground_world(width: float = 200.0, friction: float = MU, centre: tuple = (0.0, 0.0),
                 thickness: float = 20.0, gravity: float = -G, **settings) -> World:
    """A World (``settings``: Settings knobs) with a static ground box of ``width`` x
    ``thickness`` m whose top face is y = centre[1], centred on x = centre[0].

    Sleeping is off unless a case turns it on: these cases measure the solver, and a
    sleeping island cannot drift."""
    world = World(gravity=(0.0, gravity), settings=Settings(**{"sleeping": False,
                                                               **settings}))
    world.add_body({"type": "box", "size": [width, thickness]},
                   position=(centre[0], centre[1] - thickness / 2), kind="static",
                   friction=friction, name="ground")
    return world


def pyramid_cells(base: int, side: float) -> list[tuple[float, float]]:
    """Centres of a pyramid of boxes of ``side`` m standing on y = 0 about x = 0: rows of
    base, base - 1, ..., 1 boxes, bottom row first (the top box last)."""
    return [((i - (base - 1 - row) / 2) * side, (0.5 + row) * side)
            for row in range(base) for i in range(base - row)]


def b2_ground_world():
    """A Box2D v3 world (pyb2d3, imported here: a ``[bench]`` extra) with ``ground_world``'s
    ground, 200 m wide, top face y = 0, sleeping off; (world, ground body)."""
    import pyb2d3 as b2

    world = b2.World(gravity=(0.0, -G))
    world.sleeping_enabled = False
    ground = world.create_static_body(position=(0.0, -10.0))
    ground.create_polygon_shape(b2.shape_def(), b2.box(100.0, 10.0))
    return world, ground


def pm_space(gravity: float = -G) -> pymunk.Space:
    """A pymunk Space at its defaults with vertical ``gravity`` (m/s^2)."""
    space = pymunk.Space()
    space.gravity = (0.0, gravity)
    return space


def pm_box(space: pymunk.Space, size: tuple, position: tuple,
           body_type: int = pymunk.Body.DYNAMIC, angle: float = 0.0,
           velocity: tuple = (0.0, 0.0), angular_velocity: float = 0.0,
           mass: float | None = None, friction: float = MU,
           elasticity: float = 0.0) -> pymunk.Body:
    """A ``size`` (w, h) box centred on its body; density 1 unless ``mass`` (kg)."""
    body = pymunk.Body(body_type=body_type)
    body.position = tuple(map(float, position))
    body.angle = angle
    shape = pymunk.Poly.create_box(body, tuple(map(float, size)), radius=0.0)
    if body_type == pymunk.Body.DYNAMIC:
        if mass is None:
            shape.density = 1.0
        else:
            shape.mass = mass
    shape.friction = math.sqrt(friction)
    shape.elasticity = elasticity
    space.add(body, shape)
    if body_type == pymunk.Body.DYNAMIC:
        body.velocity = tuple(map(float, velocity))
        body.angular_velocity = angular_velocity
    return body


def pm_circle(space: pymunk.Space, radius: float, position: tuple,
              velocity: tuple = (0.0, 0.0), friction: float = MU,
              elasticity: float = 0.0) -> pymunk.Body:
    """A disc of ``radius`` m, density 1."""
    body = pymunk.Body()
    body.position = tuple(map(float, position))
    shape = pymunk.Circle(body, radius)
    shape.density = 1.0
    shape.friction = math.sqrt(friction)
    shape.elasticity = elasticity
    space.add(body, shape)
    body.velocity = tuple(map(float, velocity))
    return body


def pm_ground(space: pymunk.Space, width: float = 200.0, friction: float = MU,
              centre: tuple = (0.0, 0.0), thickness: float = 20.0,
              elasticity: float = 0.0) -> pymunk.Body:
    """The ``ground_world`` ground as a static pymunk box."""
    return pm_box(space, (width, thickness), (centre[0], centre[1] - thickness / 2),
                  pymunk.Body.STATIC, friction=friction, elasticity=elasticity)


def pm_deepest(bodies: list[pymunk.Body]) -> float:
    """The deepest overlap (m) of any contact point of ``bodies``' arbiters, 0 if none."""
    arbiters: list[pymunk.Arbiter] = []
    for body in bodies:
        body.each_arbiter(arbiters.append)
    return max([0.0] + [-p.distance for a in arbiters for p in a.contact_point_set.points])


def pm_state(bodies: list[pymunk.Body]) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                 np.ndarray]:
    """(positions (B, 2), angles (B,), velocities (B, 2), angular velocities (B,))."""
    return (np.array([tuple(b.position) for b in bodies]), np.array([b.angle for b in bodies]),
            np.array([tuple(b.velocity) for b in bodies]),
            np.array([b.angular_velocity for b in bodies]))
