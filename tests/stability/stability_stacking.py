"""Stability study, stacking: mass ratios, tall stacks, big pyramids, scale, distance, rest.

Cases (figures in metres unless said): ``*_mass_ratio`` and ``*_big_box_drop`` (sink of
the heavy box), ``*_tall_stack``, ``*_pyramid`` and ``*_heavy_top_pyramid`` (top box
displacement; the big pyramids also their deepest contact), ``*_scaled_pyramid``
(displacement over side), ``*_far_pyramid`` (difference from the same pyramid at the
origin), ``*_resting_stacks`` (fastest box point, m/s). See ``stability_common`` for
the conventions.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
from stability_common import (
    DT,
    MU,
    SETTINGS,
    UNIT_BOX,
    Bound,
    G,
    advance,
    b2_ground_world,
    ground_world,
    pm_box,
    pm_deepest,
    pm_ground,
    pm_space,
    pm_state,
    pm_steps,
    pyramid_cells,
)

from sdfphys.world import World

#: The light box is not crushed: the heavy box above it never sinks more than this.
NOT_CRUSHED = Bound(0.02, "m", "2 % of the 1 m light box (4 linear slops, the speculative "
                               "distance): a box squashed by more is visibly crushed")
#: A stack or pyramid stands: its top box moves less than this over the run.
STANDS = Bound(0.05, "m", "5 % of a 1 m box, as the 10-box stack and 20-base pyramid of "
                          "tests/test_world.py")
#: Boxes of a big pyramid do not sink into each other: no contact is deeper than this.
NOT_SUNK = Bound(0.02, "m", "NOT_CRUSHED for every contact of the pyramid")
#: The scaled pyramids stand: every box moves less than this fraction of its side.
STANDS_RELATIVE = Bound(0.05, "", "STANDS in units of the box side")
#: A pyramid 141 km from the origin matches the one at the origin.
SAME_FAR_AWAY = Bound(1e-3, "m", "the issue: relative positions within 1e-3 m")
#: Resting stacks come to rest.
AT_REST = Bound(1e-3, "m/s", "the issue: speeds below 1 mm/s")
#: A symmetric pyramid on level ground stays symmetric: the mean horizontal displacement of
#: its boxes stays under this.
SYMMETRIC = Bound(0.005, "m", "one linear slop: by symmetry the mean is zero")
#: A big pyramid settles: its fastest box at the end is slower than this.
SETTLED = Bound(0.05, "m/s", "Settings.sleep_speed (Box2D v3's sleep threshold): it could "
                             "fall asleep")

RATIO_SECONDS = 5.0


def soft_sink(light: float, heavy: float, gravity: float = G) -> float:
    """Predicted resting sink (m) of a unit box of ``heavy`` kg on one of ``light`` kg
    under the plain soft step (without load stiffening, which divides it by the light
    box's load ratio, (heavy + light) / light: solver.row_softness).

    The soft step (solver.contact_softness, docs/solver.md) makes each contact point a
    spring of stiffness m_eff w^2, m_eff the point's effective mass along the normal and
    w = 2 pi f (f = contact_hertz, doubled against the static ground), whatever load it
    carries. A unit box's corner has lever arm 0.5 across the normal and inertia m / 6,
    so m_eff = 1 / (2.5 / m_a + 2.5 / m_b) (2.5 / m alone against the ground); two
    corners carry each interface. The upper interface carries heavy g, the ground's
    (heavy + light) g.
    """
    w = 2.0 * math.pi * min(SETTINGS.contact_hertz, 0.25 * SETTINGS.substeps / SETTINGS.dt)
    upper = 2.0 / (2.5 / light + 2.5 / heavy) * w * w
    lower = 2.0 * light / 2.5 * (2.0 * w) ** 2
    return heavy * gravity / upper + (heavy + light) * gravity / lower


@cache
def ours_mass_ratio(ratio: float) -> dict[str, float]:
    """A 1 kg unit box on the ground under a unit box of ``ratio`` kg, both at rest, 5 s.

    sink: max over the run of how far the heavy box's centre fell below its start
    (1.5 m): the light box's loss of height, in the ground and under the heavy box.
    rest_sink: the same at the end.
    """
    world = ground_world()
    world.add_body(UNIT_BOX, position=(0.0, 0.5), mass=1.0, friction=MU)
    heavy = world.add_body(UNIT_BOX, position=(0.0, 1.5), mass=float(ratio), friction=MU)
    sink = 0.0
    for _ in advance(world, round(RATIO_SECONDS / DT)):
        sink = max(sink, 1.5 - world.position[heavy, 1])
    return {"sink": sink, "rest_sink": 1.5 - world.position[heavy, 1]}


def pymunk_mass_ratio(ratio: float) -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space)
    pm_box(space, (1, 1), (0.0, 0.5), mass=1.0)
    heavy = pm_box(space, (1, 1), (0.0, 1.5), mass=float(ratio))
    sink = 0.0
    for _ in pm_steps(space, round(RATIO_SECONDS / DT)):
        sink = max(sink, 1.5 - heavy.position.y)
    return {"sink": sink, "rest_sink": 1.5 - heavy.position.y}


BIG_BOX = (4.0, 1.0)
BIG_MASS = 400.0
BIG_DROP = 0.5          # m, gap under the big box at the start


@cache
def ours_big_box_drop() -> dict[str, float]:
    """A 4 x 1 box of 400 kg dropped from 0.5 m onto two 1 kg unit boxes under its ends, 5 s.

    sink: max over the run of how far the big box's centre went below its resting
    height on intact boxes (1.5 m).
    """
    world = ground_world()
    for x in (-1.5, 1.5):
        world.add_body(UNIT_BOX, position=(x, 0.5), mass=1.0, friction=MU)
    big = world.add_body({"type": "box", "size": list(BIG_BOX)}, position=(0.0, 1.5 + BIG_DROP),
                         mass=BIG_MASS, friction=MU)
    sink = 0.0
    for _ in advance(world, round(RATIO_SECONDS / DT)):
        sink = max(sink, 1.5 - world.position[big, 1])
    return {"sink": sink}


def pymunk_big_box_drop() -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space)
    for x in (-1.5, 1.5):
        pm_box(space, (1, 1), (x, 0.5), mass=1.0)
    big = pm_box(space, BIG_BOX, (0.0, 1.5 + BIG_DROP), mass=BIG_MASS)
    sink = 0.0
    for _ in pm_steps(space, round(RATIO_SECONDS / DT)):
        sink = max(sink, 1.5 - big.position.y)
    return {"sink": sink}


# ---------------------------------------------------------------------------------------
# Tall stacks and big pyramids
# ---------------------------------------------------------------------------------------


@cache
def ours_tall_stack(count: int = 20, seconds: float = 30.0) -> dict[str, float]:
    """``count`` unit boxes stacked on the ground (friction 0.6), ``seconds`` s.

    top: displacement of the top box from its start at the end.
    """
    world = ground_world()
    for i in range(count):
        world.add_body(UNIT_BOX, position=(0.0, 0.5 + i), friction=MU)
    start = world.position[-1]
    for _ in advance(world, round(seconds / DT)):
        pass
    return {"top": float(np.linalg.norm(world.position[-1] - start))}


def pymunk_tall_stack(count: int = 20, seconds: float = 30.0) -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space)
    boxes = [pm_box(space, (1, 1), (0.0, 0.5 + i)) for i in range(count)]
    start = np.array(boxes[-1].position)
    for _ in pm_steps(space, round(seconds / DT)):
        pass
    return {"top": float(np.linalg.norm(np.array(boxes[-1].position) - start))}


#: Seconds the big pyramids (base 20 and 40) run.
PYRAMID_SECONDS = 5.0


def _pyramid_world(base: int) -> World:
    """Unit boxes in a pyramid of ``base`` on the ground (4 base + 20 m wide), sleeping off."""
    world = ground_world(width=4.0 * base + 20.0)
    for x, y in pyramid_cells(base, 1.0):
        world.add_body(UNIT_BOX, position=(x, y), friction=MU)
    return world


@cache
def ours_pyramid(base: int, seconds: float = PYRAMID_SECONDS) -> dict[str, float]:
    """A pyramid of unit boxes with ``base`` boxes in its bottom row, ``seconds`` s.

    top: displacement of the top box at the end; penetration: the deepest contact of
    any step (m).
    """
    world = _pyramid_world(base)
    start = world.position[-1]
    penetration = 0.0
    for _ in advance(world, round(seconds / DT)):
        penetration = max([penetration, *world.contacts.depth.tolist()])
    return {"top": float(np.linalg.norm(world.position[-1] - start)),
            "penetration": penetration}


SYMMETRY_BASE = 50
SYMMETRY_SECONDS = 3.0


@cache
def ours_pyramid_symmetry(base: int = SYMMETRY_BASE,
                          seconds: float = SYMMETRY_SECONDS) -> dict[str, float]:
    """A pyramid of unit boxes (``base`` in its bottom row), sleeping off, ``seconds`` s.

    lean: the mean horizontal displacement of its boxes at the end, absolute (m: the
    pyramid's shift to either side); speed: the fastest box's speed at the end (m/s).
    """
    world = _pyramid_world(base)
    start = world.position[1:, 0].copy()
    for _ in advance(world, round(seconds / DT)):
        pass
    return {"lean": abs(float(np.mean(world.position[1:, 0] - start))),
            "speed": float(np.linalg.norm(world.velocity, axis=1).max())}


@cache
def pymunk_pyramid_symmetry(base: int = SYMMETRY_BASE,
                            seconds: float = SYMMETRY_SECONDS) -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space, width=4.0 * base + 20.0)
    boxes = [pm_box(space, (1, 1), c) for c in pyramid_cells(base, 1.0)]
    start = np.array([b.position.x for b in boxes])
    for _ in pm_steps(space, round(seconds / DT)):
        pass
    return {"lean": abs(float(np.mean([b.position.x for b in boxes] - start))),
            "speed": max(float(abs(b.velocity)) for b in boxes)}


@cache
def box2d_pyramid_symmetry(base: int = SYMMETRY_BASE,
                           seconds: float = SYMMETRY_SECONDS) -> dict[str, float]:
    """The same case in Box2D v3 at its defaults (4 substeps, sleeping off)."""
    import pyb2d3 as b2

    world, _ = b2_ground_world()
    boxes = []
    for c in pyramid_cells(base, 1.0):
        body = world.create_dynamic_body(position=c)
        body.create_polygon_shape(b2.shape_def(density=1.0), b2.box(0.5, 0.5))
        boxes.append(body)
    start = np.array([b.position[0] for b in boxes])
    for _ in range(round(seconds / DT)):
        world.step(DT, 4)
    return {"lean": abs(float(np.mean([b.position[0] for b in boxes] - start))),
            "speed": max(float(np.hypot(*b.linear_velocity)) for b in boxes)}


@cache
def pymunk_pyramid(base: int, seconds: float = PYRAMID_SECONDS) -> dict[str, float]:
    """The same case in pymunk (penetration: its arbiters' deepest contact point)."""
    space = pm_space()
    pm_ground(space, width=4.0 * base + 20.0)
    boxes = [pm_box(space, (1, 1), c) for c in pyramid_cells(base, 1.0)]
    start = np.array(boxes[-1].position)
    penetration = 0.0
    for _ in pm_steps(space, round(seconds / DT)):
        penetration = max(penetration, pm_deepest(boxes))
    return {"top": float(np.linalg.norm(np.array(boxes[-1].position) - start)),
            "penetration": penetration}


HEAVY_TOP_BASE = 5
HEAVY_TOP_SECONDS = 10.0


@cache
def ours_heavy_top_pyramid(ratio: float) -> dict[str, float]:
    """A base-5 pyramid of 1 kg unit boxes whose top box weighs ``ratio`` kg, 10 s.

    top: displacement of the top box at the end; sink: how far it went below its start
    at most (the boxes under it crushed).
    """
    world = ground_world(width=4.0 * HEAVY_TOP_BASE + 20.0)
    cells = pyramid_cells(HEAVY_TOP_BASE, 1.0)
    for k, (x, y) in enumerate(cells):
        mass = float(ratio) if k == len(cells) - 1 else 1.0
        world.add_body(UNIT_BOX, position=(x, y), mass=mass, friction=MU)
    start = world.position[-1].copy()
    sink = 0.0
    for _ in advance(world, round(HEAVY_TOP_SECONDS / DT)):
        sink = max(sink, start[1] - world.position[-1, 1])
    return {"top": float(np.linalg.norm(world.position[-1] - start)), "sink": sink}


def pymunk_heavy_top_pyramid(ratio: float) -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space, width=4.0 * HEAVY_TOP_BASE + 20.0)
    cells = pyramid_cells(HEAVY_TOP_BASE, 1.0)
    boxes = [pm_box(space, (1, 1), c, mass=float(ratio) if k == len(cells) - 1 else 1.0)
             for k, c in enumerate(cells)]
    start = np.array(boxes[-1].position)
    sink = 0.0
    for _ in pm_steps(space, round(HEAVY_TOP_SECONDS / DT)):
        sink = max(sink, start[1] - boxes[-1].position.y)
    return {"top": float(np.linalg.norm(np.array(boxes[-1].position) - start)), "sink": sink}


# ---------------------------------------------------------------------------------------
# Scale and distance from the origin
# ---------------------------------------------------------------------------------------

SCALE_BASE = 5
SCALE_SECONDS = 10.0


@cache
def ours_scaled_pyramid(side: float) -> dict[str, float]:
    """A base-5 pyramid of boxes of ``side`` m (density 1, friction 0.6), 10 s, g = 9.81.

    relative: the largest box displacement at the end divided by ``side``.
    """
    world = ground_world(width=8.0 * SCALE_BASE * side, thickness=20.0 * side)
    box = {"type": "box", "size": [side, side]}
    for x, y in pyramid_cells(SCALE_BASE, side):
        world.add_body(box, position=(x, y), friction=MU)
    start = world.position[1:]
    for _ in advance(world, round(SCALE_SECONDS / DT)):
        pass
    moved = np.linalg.norm(world.position[1:] - start, axis=1)
    return {"relative": float(moved.max() / side)}


def pymunk_scaled_pyramid(side: float) -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space, width=8.0 * SCALE_BASE * side, thickness=20.0 * side)
    boxes = [pm_box(space, (side, side), c) for c in pyramid_cells(SCALE_BASE, side)]
    start = pm_state(boxes)[0]
    for _ in pm_steps(space, round(SCALE_SECONDS / DT)):
        pass
    moved = np.linalg.norm(pm_state(boxes)[0] - start, axis=1)
    return {"relative": float(moved.max() / side)}


FAR = (1e5, 1e5)        # m, 141 km from the origin


@cache
def ours_far_pyramid() -> dict[str, float]:
    """The base-5 unit-box pyramid at the origin and at FAR, stepped side by side 10 s.

    difference: largest difference of box positions relative to each pyramid's origin,
    over every step.
    """
    worlds = []
    for centre in ((0.0, 0.0), FAR):
        world = ground_world(width=40.0, centre=centre)
        for x, y in pyramid_cells(SCALE_BASE, 1.0):
            world.add_body(UNIT_BOX, position=(centre[0] + x, centre[1] + y), friction=MU)
        worlds.append(world)
    near, far = worlds
    steps = round(SCALE_SECONDS / DT)
    difference = 0.0
    for _ in zip(advance(near, steps), advance(far, steps), strict=True):
        relative = far.position - np.array(FAR)
        difference = max(difference, float(np.abs(relative - near.position).max()))
    return {"difference": difference}


def pymunk_far_pyramid() -> dict[str, float]:
    """The same case in pymunk (two spaces stepped side by side)."""
    runs = []
    for centre in ((0.0, 0.0), FAR):
        space = pm_space()
        pm_ground(space, width=40.0, centre=centre)
        boxes = [pm_box(space, (1, 1), (centre[0] + x, centre[1] + y))
                 for x, y in pyramid_cells(SCALE_BASE, 1.0)]
        runs.append((space, boxes))
    difference = 0.0
    for _ in range(round(SCALE_SECONDS / DT)):
        for space, _boxes in runs:
            space.step(DT)
        near = pm_state(runs[0][1])[0]
        far = pm_state(runs[1][1])[0] - np.array(FAR)
        difference = max(difference, float(np.abs(far - near).max()))
    return {"difference": difference}


# ---------------------------------------------------------------------------------------
# Rest
# ---------------------------------------------------------------------------------------

REST_SETTLE = 2.0       # s allowed to come to rest
REST_SECONDS = 10.0     # s of the whole run


def _rest_cells() -> list[tuple[float, float]]:
    """A 5-box stack at x = 0 and a base-5 pyramid at x = 10."""
    return ([(0.0, 0.5 + i) for i in range(5)]
            + [(10.0 + x, y) for x, y in pyramid_cells(5, 1.0)])


def _surface_speed(velocity: np.ndarray, angular_velocity: np.ndarray) -> float:
    """Fastest point of any unit box: max of |v| + |w| sqrt(2) / 2 (its corners)."""
    return float(np.max(np.hypot(*velocity.T) + np.abs(angular_velocity) * math.sqrt(0.5)))


@cache
def ours_resting_stacks() -> dict[str, float]:
    """``_rest_cells`` unit boxes (friction 0.6) for 10 s.

    speed: m/s, fastest point of any box over the steps after the first 2 s.
    """
    world = ground_world()
    for p in _rest_cells():
        world.add_body(UNIT_BOX, position=p, friction=MU)
    settle = round(REST_SETTLE / DT)
    speed = 0.0
    for k in advance(world, round(REST_SECONDS / DT)):
        if k > settle:
            speed = max(speed, _surface_speed(world.velocity[1:], world.angular_velocity[1:]))
    return {"speed": speed}


def pymunk_resting_stacks() -> dict[str, float]:
    """The same case in pymunk."""
    space = pm_space()
    pm_ground(space)
    boxes = [pm_box(space, (1, 1), p) for p in _rest_cells()]
    settle = round(REST_SETTLE / DT)
    speed = 0.0
    for k in pm_steps(space, round(REST_SECONDS / DT)):
        if k > settle:
            _, _, v, w = pm_state(boxes)
            speed = max(speed, _surface_speed(v, w))
    return {"speed": speed}
