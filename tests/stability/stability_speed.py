"""Stability study, speed: bullets into thin walls and into stacks, fast spinning planks.

Cases: ``*_thin_wall`` and ``*_stack_bullets`` (fraction of bullets that tunnelled),
``*_spinning_plank`` (lowest corner height, m). See ``stability_common`` for the
conventions.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pymunk
from stability_common import (
    DT,
    MU,
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

from sdfphys.world import World

#: Nothing tunnels.
NO_TUNNELLING = Bound(0.0, "", "the issue: never")
#: No corner of the spinning plank goes under the ground by more than the plank's thickness.
ABOVE_GROUND = Bound(-0.02, "m", "the plank's thickness: deeper, its end is wholly under the "
                                 "ground's surface", at_least=True)

WALL_LENGTH = 120.0     # m, along y, centred on the origin
CAPSULE_RADIUS = 0.005  # m: a segment 1 cm thick
#: The thin walls, on x = 0. A zero-thickness sdf segment cannot be a body (its region
#: f <= 0 has no inside, and SdfShape computes a centroid even for static bodies), so the
#: segment is a capsule 1 cm thick, whose mass quadrature is given a cell of half its
#: radius (the default cell of a 120 m long shape would cost seconds).
WALLS = {
    "box 0.02 m": {"type": "box", "size": [0.02, WALL_LENGTH]},
    "segment 0.01 m": {"type": "sdf", "cell": CAPSULE_RADIUS / 2,
                       "field": {"type": "capsule", "a": [0.0, -WALL_LENGTH / 2],
                                 "b": [0.0, WALL_LENGTH / 2], "radius": CAPSULE_RADIUS}},
}
BULLETS = {
    "circle r 0.1": {"type": "circle", "radius": 0.1},
    "circle r 0.02": {"type": "circle", "radius": 0.02},
    "plank 0.2 x 0.02": {"type": "box", "size": [0.2, 0.02]},
}
#: The issue's pymunk case: (speed, bullets, walls, angles, lanes) for ``*_thin_wall``.
ISSUE_BULLETS = (200.0, ("circle r 0.1",), ("segment 0.01 m",), (0.0,), 200)
BULLET_SPIN = 100.0     # rad/s, for the plank bullets
LANE_SPACING = 0.5      # m between lanes along the wall


def bullet_lanes(speed: float, angle: float, lanes: int,
                 reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Start centres (L, 2) and velocity (2,) of bullets crossing x = 0 at y = 0.5 (k - L/2).

    ``angle``: rad from the +x axis. Lane k starts 2 m + ``reach`` + k/L of one step's
    travel before its crossing, so the lanes sweep every phase of the step at which a
    bullet reaches the wall.
    """
    direction = np.array([math.cos(angle), math.sin(angle)])
    k = np.arange(lanes)
    back = 2.0 + reach + speed * DT * k / lanes
    cross = np.column_stack([np.zeros(lanes), LANE_SPACING * (k - lanes / 2)])
    return cross - back[:, None] * direction, speed * direction


def _reach(spec: dict) -> float:
    """Bounding radius of a bullet shape, m."""
    return spec["radius"] if spec["type"] == "circle" else math.hypot(*spec["size"]) / 2


@cache
def ours_thin_wall(speed: float = 300.0, bullets: tuple = tuple(BULLETS),
                   walls: tuple = tuple(WALLS), angles: tuple = (0.0, 45.0),
                   lanes: int = 100) -> dict[str, float]:
    """Bullets (friction 0.5) at ``speed`` m/s into a static thin wall on x = 0, no gravity.

    For each (bullet, wall, incidence angle in degrees), ``lanes`` bullets
    (``bullet_lanes``), each in a world of its own so that bullets stopped by the wall
    and sliding along it never meet the next lane's; plank bullets spin at BULLET_SPIN;
    6 steps (every bullet reaches the wall within 2). tunnelled: fraction of all
    bullets whose centre was ever at x > 0 (past the wall's mid-line).
    """
    crossed = total = 0
    for bullet in bullets:
        spec = BULLETS[bullet]
        spin = BULLET_SPIN if spec["type"] == "box" else 0.0
        for wall in walls:
            for angle in angles:
                start, velocity = bullet_lanes(speed, math.radians(angle), lanes, _reach(spec))
                for p in start:
                    world = World(gravity=(0.0, 0.0))
                    world.add_body(WALLS[wall], kind="static", name="wall")
                    world.add_body(spec, position=p, velocity=velocity, angular_velocity=spin)
                    crossed += any(world.position[1, 0] > 0.0 for _ in advance(world, 6))
                total += lanes
    return {"tunnelled": crossed / total}


def pymunk_thin_wall(speed: float = 300.0, bullets: tuple = tuple(BULLETS),
                     walls: tuple = tuple(WALLS), angles: tuple = (0.0, 45.0),
                     lanes: int = 100) -> dict[str, float]:
    """As ``ours_thin_wall``; the segment wall is a pymunk Segment of radius 0.005."""
    crossed = total = 0
    for bullet in bullets:
        spec = BULLETS[bullet]
        for wall in walls:
            for angle in angles:
                start, velocity = bullet_lanes(speed, math.radians(angle), lanes, _reach(spec))
                for p in start:
                    space = pm_space(0.0)
                    if WALLS[wall]["type"] == "sdf":
                        segment = pymunk.Segment(space.static_body, (0.0, -WALL_LENGTH / 2),
                                                 (0.0, WALL_LENGTH / 2), CAPSULE_RADIUS)
                        segment.friction = math.sqrt(0.5)
                        space.add(segment)
                    else:
                        pm_box(space, WALLS[wall]["size"], (0.0, 0.0), pymunk.Body.STATIC,
                               friction=0.5)
                    if spec["type"] == "circle":
                        body = pm_circle(space, spec["radius"], p, velocity, friction=0.5)
                    else:
                        body = pm_box(space, spec["size"], p, velocity=velocity,
                                      angular_velocity=BULLET_SPIN, friction=0.5)
                    crossed += any(body.position.x > 0.0 for _ in pm_steps(space, 6))
                total += lanes
    return {"tunnelled": crossed / total}


STACK_HEIGHT = 5
STACKS = 20             # one per start phase
STACK_SPACING = 20.0    # m between stacks
SLUG_RADIUS = 0.05
SLUG_SPEED = 300.0      # m/s
#: No body of the volley moves faster than a slug falling the stacks' height could
#: (no restitution: a collision only loses energy; v^2 <= v0^2 + 2 g h): m/s over v0.
NO_SPEED_GAINED = Bound(math.sqrt(SLUG_SPEED ** 2 + 2.0 * G * STACK_HEIGHT) - SLUG_SPEED,
                        "m/s", "energy: v^2 <= v0^2 + 2 g h, no restitution")


def _stack_volley(speed: float) -> tuple[list[tuple], list[tuple], tuple[float, float]]:
    """Box centres, bullet starts (one per box, aimed at its centre) and bullet velocity.

    Stack j stands at x = 20 j; its bullets start 2 m plus j/20 of one step's travel
    before the boxes' faces (every phase).
    """
    boxes, slugs = [], []
    for j in range(STACKS):
        x = STACK_SPACING * (j - STACKS / 2)
        for i in range(STACK_HEIGHT):
            boxes.append((x, 0.5 + i))
            slugs.append((x - 0.5 - SLUG_RADIUS - 2.0 - speed * DT * j / STACKS, 0.5 + i))
    return boxes, slugs, (speed, 0.0)


@cache
def ours_stack_bullets(speed: float = SLUG_SPEED, time_of_impact: bool = True) -> dict[str, float]:
    """Circles r 0.05 (density 1) at ``speed`` m/s into 5-box stacks, one at each box's
    centre height; 20 stacks 20 m apart, one per start phase; 0.5 s (every step's state
    finite). ``time_of_impact``: the Settings knob.

    tunnelled: fraction of bullets whose centre ever got past the centre of the box it
    was aimed at; gained: m/s, the largest speed any body had at the end of a step less
    ``speed``.
    """
    world = ground_world(width=STACK_SPACING * STACKS + 40.0, time_of_impact=time_of_impact)
    boxes, slugs, velocity = _stack_volley(speed)
    target = [world.add_body(UNIT_BOX, position=c, friction=MU) for c in boxes]
    shot = [world.add_body({"type": "circle", "radius": SLUG_RADIUS}, position=c,
                           velocity=velocity, friction=MU) for c in slugs]
    past = np.zeros(len(shot), bool)
    fastest = 0.0
    for _ in advance(world, 30):
        x = world.position[:, 0]
        past |= x[shot] > x[target]
        fastest = max(fastest, float(np.max(np.hypot(*world.velocity.T))))
    return {"tunnelled": float(past.mean()), "gained": fastest - speed}


def pymunk_stack_bullets(speed: float = SLUG_SPEED) -> dict[str, float]:
    """The same case in pymunk (which has no time of impact)."""
    space = pm_space()
    pm_ground(space, width=STACK_SPACING * STACKS + 40.0)
    boxes, slugs, velocity = _stack_volley(speed)
    target = [pm_box(space, (1, 1), c) for c in boxes]
    shot = [pm_circle(space, SLUG_RADIUS, c, velocity) for c in slugs]
    past = np.zeros(len(shot), bool)
    fastest = 0.0
    for _ in pm_steps(space, 30):
        past |= pm_state(shot)[0][:, 0] > pm_state(target)[0][:, 0]
        moving = np.concatenate([pm_state(shot)[2], pm_state(target)[2]])
        fastest = max(fastest, float(np.max(np.hypot(*moving.T))))
    return {"tunnelled": float(past.mean()), "gained": fastest - speed}


PLANK = (1.0, 0.02)
PLANKS = 50
PLANK_SPEED = 100.0     # m/s, downward
PLANK_SPIN = 20.0       # rad/s


def _plank_starts() -> list[tuple[float, float]]:
    """50 planks 3 m apart about x = 0, 5 m up plus k/50 of one step's fall (every phase)."""
    return [(3.0 * (k - PLANKS / 2), 5.0 + PLANK_SPEED * DT * k / PLANKS)
            for k in range(PLANKS)]


def _lowest_corner(position: np.ndarray, angle: np.ndarray) -> float:
    """Lowest corner height (m) of planks at centres ``position`` (P, 2), ``angle`` (P,)."""
    half_w, half_h = PLANK[0] / 2, PLANK[1] / 2
    reach = np.abs(np.sin(angle)) * half_w + np.abs(np.cos(angle)) * half_h
    return float(np.min(position[:, 1] - reach))


@cache
def ours_spinning_plank() -> dict[str, float]:
    """1 x 0.02 m planks (start angle 0.1 k rad) falling at 100 m/s, spinning at 20 rad/s,
    onto the ground; 2 s.

    lowest: m, the lowest height any plank corner reaches at the end of a step.
    """
    world = ground_world(width=3.0 * PLANKS + 20.0)
    planks = [world.add_body({"type": "box", "size": list(PLANK)}, position=p, angle=0.1 * k,
                             velocity=(0.0, -PLANK_SPEED), angular_velocity=PLANK_SPIN,
                             friction=MU)
              for k, p in enumerate(_plank_starts())]
    lowest = math.inf
    for _ in advance(world, 120):
        lowest = min(lowest, _lowest_corner(world.position[planks], world.angle[planks]))
    return {"lowest": lowest}


def pymunk_spinning_plank() -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space, width=3.0 * PLANKS + 20.0)
    planks = [pm_box(space, PLANK, p, angle=0.1 * k, velocity=(0.0, -PLANK_SPEED),
                     angular_velocity=PLANK_SPIN) for k, p in enumerate(_plank_starts())]
    lowest = math.inf
    for _ in pm_steps(space, 120):
        x, a, _, _ = pm_state(planks)
        lowest = min(lowest, _lowest_corner(x, a))
    return {"lowest": lowest}
