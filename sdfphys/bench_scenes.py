"""The scenes of ``sdfphys bench``: small worlds with known answers, and what they record.

Each ``BenchScene`` builds a World under given Settings, runs for its duration and is
scored from its ``Trace`` (positions, velocities, energy and the deepest overlap per
step) against a closed form (free fall, a box sliding and a disc rolling down inclines
of rigid and SDF bodies, a bouncing ball, a bullet against a thin wall) or against a
converged reference run (a settling box, a small pyramid, a pile of discs). The suite
and its measures are described in ``sdfphys.bench``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .settings import Settings
from .world import World

__all__ = ["G", "SAMPLE_TIMES", "SCENES", "BenchScene", "Trace"]

G = 9.81

#: Times (s) at which positions are compared: multiples of every swept dt.
SAMPLE_TIMES = (0.5, 1.0, 1.5, 2.0)


@dataclass
class Trace:
    """What one run recorded: per step k = 0..n (state after k steps; k = 0 initial).

    com (n+1, B, 2) m (centres of mass), angle (n+1, B) rad, velocity (n+1, B, 2)
    m/s, energy (n+1,) J; depth: (n,) deepest contact found in step k+1 (nan without
    contacts), at the pose com[k], angle[k]; step_s (n,) wall seconds of each
    ``World.step``; stage_counts: the world's at the end.
    """

    dt: float
    com: np.ndarray
    angle: np.ndarray
    velocity: np.ndarray
    energy: np.ndarray
    depth: np.ndarray
    step_s: np.ndarray
    stage_counts: dict[str, int]

    def at(self, t: float) -> int:
        """Index of the state at time ``t`` (s), which must be a whole number of steps."""
        k = round(t / self.dt)
        if abs(k * self.dt - t) > 1e-9 * max(1.0, t):
            raise ValueError(f"t = {t} is not a multiple of dt = {self.dt}")
        return k


@dataclass(frozen=True)
class BenchScene:
    """One scene of the suite.

    build(settings) -> World; duration (s); answer: "closed form" or "reference";
    energy_scale: J, the energy the scene can release; conservative: energy should
    stay E(0). Closed form: evaluate(trace) -> (error, pos_error_m), and where the
    contact depth is known exact_depth(trace) -> (n,) exact deepest depth per step
    (m). Reference: points(trace, k) -> (P, 2) outline points compared with the
    reference run, and size (m), which divides the reference error.
    """

    name: str
    description: str
    build: Callable[[Settings], World]
    duration: float
    answer: str
    energy_scale: float
    conservative: bool = False
    evaluate: Callable[[Trace], tuple[float, float]] | None = None
    exact_depth: Callable[[Trace], np.ndarray] | None = None
    points: Callable[[Trace, int], np.ndarray] | None = None
    size: float = 1.0


GROUND = {"type": "box", "size": [40.0, 1.0]}       # top face at y = 0 at (0, -0.5)
UNIT_BOX = {"type": "box", "size": [1.0, 1.0]}
DISC = {"type": "circle", "radius": 0.5}
SDF_DISC = {"type": "sdf", "field": {"type": "circle", "radius": 0.5}}
SDF_RAMP = {"type": "sdf", "field": {"type": "box", "size": [40.0, 1.0]}}


def _rotation(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def _corners(com: np.ndarray, angle: np.ndarray, half: float = 0.5) -> np.ndarray:
    """(..., 4, 2) corners of boxes of half-size ``half`` at com (..., 2), angle (...)."""
    local = half * np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    return com[..., None, :] + np.einsum("...ij,kj->...ki", _rotation(angle), local)


def _free_fall(settings: Settings) -> World:
    world = World(settings=settings)
    world.add_body(DISC, position=(0.0, 10.0))
    return world


def _free_fall_eval(trace: Trace) -> tuple[float, float]:
    k = trace.at(1.0)
    drop = trace.com[0, 0, 1] - trace.com[k, 0, 1]
    times = [t for t in SAMPLE_TIMES if t <= 1.0]
    exact = [10.0 - 0.5 * G * t * t for t in times]
    pos = [trace.com[trace.at(t), 0, 1] - y for t, y in zip(times, exact, strict=True)]
    return abs(drop - 0.5 * G) / (0.5 * G), float(np.sqrt(np.mean(np.square(pos))))


def _incline(degrees: float, mu: float, shape: dict, ramp: dict, half: float,
             settings: Settings) -> World:
    """A static 40 x 1 ramp through the origin tilted by ``degrees`` (top face at n.p =
    0.5) and ``shape`` (half-height ``half``) resting on it 5 m up the slope."""
    a = math.radians(degrees)
    tangent, normal = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    world = World(settings=settings)
    world.add_body(ramp, angle=a, kind="static", friction=mu)
    world.add_body(shape, position=5.0 * tangent + (0.5 + half) * normal, angle=a, friction=mu)
    return world


def _slope_axes(degrees: float) -> tuple[np.ndarray, np.ndarray]:
    a = math.radians(degrees)
    return np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])


def _acceleration_eval(degrees: float, exact: float, t0: float, t1: float
                       ) -> Callable[[Trace], tuple[float, float]]:
    """Error of the mean acceleration along the slope between t0 and t1 (s), and the
    RMS error of the displacement along the slope at the sample times up to t1
    against s = exact t^2 / 2 (from rest)."""
    tangent, _ = _slope_axes(degrees)

    def evaluate(trace: Trace) -> tuple[float, float]:
        v = trace.velocity[:, 1] @ tangent
        measured = (v[trace.at(t1)] - v[trace.at(t0)]) / (t1 - t0)
        s = (trace.com[:, 1] - trace.com[0, 1]) @ tangent
        times = [t for t in SAMPLE_TIMES if t <= t1]
        pos = [s[trace.at(t)] - 0.5 * exact * t * t for t in times]
        return abs(measured - exact) / abs(exact), float(np.sqrt(np.mean(np.square(pos))))

    return evaluate


def _box_on_plane_depth(degrees: float) -> Callable[[Trace], np.ndarray]:
    """Exact deepest depth of the sliding box: its lowest corner below the plane."""
    _, normal = _slope_axes(degrees)

    def exact(trace: Trace) -> np.ndarray:
        corners = _corners(trace.com[:-1, 1], trace.angle[:-1, 1])
        return np.max(0.5 - corners @ normal, axis=1)

    return exact


def _disc_on_plane_depth(degrees: float, radius: float, body: int = 1, level: float = 0.5
                         ) -> Callable[[Trace], np.ndarray]:
    """Exact depth of a disc on the plane n.p = level: r - (n.c - level)."""
    _, normal = _slope_axes(degrees)

    def exact(trace: Trace) -> np.ndarray:
        return radius - (trace.com[:-1, body] @ normal - level)

    return exact


SLIDE_DEGREES, SLIDE_MU = 30.0, 0.2
SLIDE_A = G * (math.sin(math.radians(SLIDE_DEGREES))
               - SLIDE_MU * math.cos(math.radians(SLIDE_DEGREES)))
ROLL_DEGREES, ROLL_MU = 20.0, 0.5
ROLL_A = 2.0 / 3.0 * G * math.sin(math.radians(ROLL_DEGREES))
BOUNCE_E, BOUNCE_H = 0.8, 1.0
BULLET_SPEED, BULLET_RADIUS, WALL_FACE = 100.0, 0.1, 2.95


def _bounce(settings: Settings) -> World:
    world = World(settings=settings)
    world.add_body(GROUND, position=(0.0, -0.5), kind="static", friction=0.0)
    world.add_body(DISC, position=(0.0, BOUNCE_H + 0.5), restitution=BOUNCE_E, friction=0.0)
    return world


def _bounce_eval(trace: Trace) -> tuple[float, float]:
    """The first apex: the highest bottom height after the ball first moves up."""
    vy, bottom = trace.velocity[:, 1, 1], trace.com[:, 1, 1] - 0.5
    up = np.flatnonzero(vy > 0.0)
    apex = float(np.max(bottom[up[0]:])) if len(up) else 0.0
    exact = BOUNCE_E ** 2 * BOUNCE_H
    return abs(apex - exact) / exact, abs(apex - exact)


def _bullet(settings: Settings) -> World:
    world = World(settings=settings)
    world.add_body({"type": "box", "size": [0.1, 4.0]}, position=(WALL_FACE + 0.05, 2.0),
                   kind="static")
    world.add_body({"type": "circle", "radius": BULLET_RADIUS}, position=(-6.0, 1.0),
                   velocity=(BULLET_SPEED, 0.0), friction=0.2)
    return world


def _bullet_eval(trace: Trace) -> tuple[float, float]:
    """How far the bullet's front got past the wall's face (in diameters, and m)."""
    past = max(float(np.max(trace.com[:, 1, 0])) + BULLET_RADIUS - WALL_FACE, 0.0)
    return past / (2.0 * BULLET_RADIUS), past


def _box_settle(settings: Settings) -> World:
    world = World(settings=settings)
    world.add_body(GROUND, position=(0.0, -0.5), kind="static", friction=0.6)
    world.add_body(UNIT_BOX, position=(0.0, 1.2), angle=0.5, friction=0.6)
    return world


def _box_points(trace: Trace, k: int) -> np.ndarray:
    return _corners(trace.com[k, 1:], trace.angle[k, 1:]).reshape(-1, 2)


def _pyramid(settings: Settings) -> World:
    world = World(settings=settings)
    world.add_body(GROUND, position=(0.0, -0.5), kind="static", friction=0.6)
    for row in range(4):
        for i in range(4 - row):
            world.add_body(UNIT_BOX, position=(i - (3 - row) / 2.0, 0.5 + row), friction=0.6)
    return world


PILE_RADIUS = 0.2


def _circle_pile(settings: Settings) -> World:
    world = World(settings=settings)
    world.add_body(GROUND, position=(0.0, -0.5), kind="static", friction=0.5)
    for x in (-1.45, 1.45):
        world.add_body({"type": "box", "size": [0.5, 6.0]}, position=(x, 3.0), kind="static",
                       friction=0.5)
    disc = {"type": "circle", "radius": PILE_RADIUS}
    for k in range(16):
        row, col = divmod(k, 4)
        world.add_body(disc, position=(-0.75 + 0.5 * col + 0.1 * (row % 2), 0.5 + 0.5 * row),
                       friction=0.5)
    return world


def _centres(first: int) -> Callable[[Trace, int], np.ndarray]:
    def points(trace: Trace, k: int) -> np.ndarray:
        return trace.com[k, first:]

    return points


def _scenes() -> dict[str, BenchScene]:
    m_disc, m_box = math.pi * 0.25, 1.0
    slide = _acceleration_eval(SLIDE_DEGREES, -SLIDE_A, 0.5, 1.0)
    roll = _acceleration_eval(ROLL_DEGREES, -ROLL_A, 0.5, 1.5)
    scenes = [
        BenchScene("free_fall", "a disc falls 1 s: drop g t^2 / 2", _free_fall, 1.0,
                   "closed form", m_disc * G * 0.5 * G, conservative=True,
                   evaluate=_free_fall_eval),
        BenchScene("incline_slide", "box slides down 30 deg, mu 0.2: a = g (sin - mu cos)",
                   lambda s: _incline(SLIDE_DEGREES, SLIDE_MU, UNIT_BOX, GROUND, 0.5, s),
                   1.0, "closed form", m_box * G * 0.5 * SLIDE_A * math.sin(
                       math.radians(SLIDE_DEGREES)), evaluate=slide,
                   exact_depth=_box_on_plane_depth(SLIDE_DEGREES)),
        BenchScene("rolling_disk", "disc rolls down 20 deg, mu 0.5: a = 2/3 g sin",
                   lambda s: _incline(ROLL_DEGREES, ROLL_MU, DISC, GROUND, 0.5, s), 1.5,
                   "closed form", m_disc * G * 0.5 * ROLL_A * 1.5 ** 2 * math.sin(
                       math.radians(ROLL_DEGREES)), conservative=True, evaluate=roll,
                   exact_depth=_disc_on_plane_depth(ROLL_DEGREES, 0.5)),
        BenchScene("bounce", "ball (e 0.8) dropped from 1 m: first apex e^2 h", _bounce, 1.0,
                   "closed form", m_disc * G * BOUNCE_H, evaluate=_bounce_eval,
                   exact_depth=_disc_on_plane_depth(0.0, 0.5, level=0.0)),
        BenchScene("bullet", "0.1 m disc at 100 m/s at a 0.1 m wall: never past its face",
                   _bullet, 0.5, "closed form",
                   0.5 * math.pi * BULLET_RADIUS ** 2 * BULLET_SPEED ** 2,
                   evaluate=_bullet_eval),
        BenchScene("sdf_slide", "box slides on an SDF ramp (mesh-sdf), 30 deg, mu 0.2",
                   lambda s: _incline(SLIDE_DEGREES, SLIDE_MU, UNIT_BOX, SDF_RAMP, 0.5, s),
                   1.0, "closed form", m_box * G * 0.5 * SLIDE_A * math.sin(
                       math.radians(SLIDE_DEGREES)), evaluate=slide,
                   exact_depth=_box_on_plane_depth(SLIDE_DEGREES)),
        BenchScene("sdf_roll", "SDF disc rolls on an SDF ramp (sdf-sdf), 20 deg, mu 0.5",
                   lambda s: _incline(ROLL_DEGREES, ROLL_MU, SDF_DISC, SDF_RAMP, 0.5, s),
                   1.5, "closed form", m_disc * G * 0.5 * ROLL_A * 1.5 ** 2 * math.sin(
                       math.radians(ROLL_DEGREES)), conservative=True, evaluate=roll,
                   exact_depth=_disc_on_plane_depth(ROLL_DEGREES, 0.5)),
        BenchScene("box_settle", "tilted box dropped on the ground settles", _box_settle, 2.0,
                   "reference", m_box * G * 0.7, points=_box_points),
        BenchScene("pyramid", "4-box-base pyramid (10 boxes) stands", _pyramid, 2.0,
                   "reference", 10 * m_box * G * 0.1, points=_box_points),
        BenchScene("circle_pile", "16 discs (r 0.2) poured into a bin", _circle_pile, 2.0,
                   "reference", 16 * math.pi * PILE_RADIUS ** 2 * G * 1.0,
                   points=_centres(3), size=2 * PILE_RADIUS),
    ]
    return {s.name: s for s in scenes}


#: The suite, by name.
SCENES: dict[str, BenchScene] = _scenes()
