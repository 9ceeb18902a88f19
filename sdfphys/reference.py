"""The same scene in pymunk (Chipmunk2D): contact-level and trajectory comparison.

pymunk is the reference for circle contacts (DESIGN.md). ``PymunkWorld`` builds a
scene in pymunk and steps it like sdfphys's World; ``compare`` runs both from the
same initial state and, at every frame, also feeds sdfphys's poses to a second
pymunk space to compare the contacts of the two engines at identical poses;
``report`` prints both as tables per time window; ``compare_main`` is
``sdfphys compare SCENE``.

What is modelled
----------------
Circles, boxes and polygons of any kind (``pymunk.Circle``, ``pymunk.Poly``; a
concave polygon as the convex parts of ``pymunk.autogeometry.convex_decomposition``
at tolerance 0, which cover it exactly), and static or kinematic ``capsule`` /
``segment`` fields, optionally placed by ``offset`` and ``angle``
(``pymunk.Segment`` with the capsule's radius, 0 for a segment). Other SDF bodies
raise ``NotModelledError`` naming them.

A pair with a circle against a convex shape has one contact, exact in both engines
(``tests/test_collide_pymunk.py``): its point, normal and depth are compared to
``CONTACT_TOLERANCE`` and decide the exit status. Other pairs (two polygons, or a
circle against a decomposed polygon) have manifolds that the two engines build
differently (clipped edges in pymunk, deepest points of triangles in fields in
sdfphys, other points and counts): they are compared by their deepest contact's depth
and normal, for information.

How the engines are matched, and what cannot be
-----------------------------------------------
- Bodies: each pymunk body sits at sdfphys's centre of mass and angle, with its
  shape in the body frame (user geometry shifted by ``Shape.origin``). Mass is
  ``mass`` or density x area, the moment ``pymunk.moment_for_circle(m, 0, r)``
  (= m r^2 / 2) or the sum of ``moment_for_poly`` over a polygon's parts, sdfphys's
  values to round-off. Gravity is the scene's; no damping;
  pymunk never sleeps by default.
- Time: pymunk has no substeps, so one sdfphys step is ``substeps`` calls of
  ``Space.step(h)``, h = dt / substeps. (One call with dt would integrate gravity
  four times more coarsely: free flight would differ by about g t dt.)
- Step phase: Chipmunk's step is "integrate positions, collide, integrate
  velocities, solve"; sdfphys's substep is "integrate velocities, solve, integrate
  positions": the same loop entered at another stage. The first pymunk step runs with
  position integration switched off (``Body.position_func`` a no-op), so that every
  later pymunk position update uses the velocity of the matching substep of
  sdfphys. Positions are then at the same time in both engines and free flight
  agrees to round-off; pymunk's velocities are one substep's kick ahead (sdfphys's
  velocity + h g in free flight).
- Materials: pymunk multiplies the two shapes' friction and elasticity; sdfphys
  mixes friction sqrt(f_a f_b) and restitution max(e_a, e_b), with no restitution
  for approach speeds under ``settings.restitution_threshold``. Per-shape values can
  match the friction for every pair (sqrt(f) per shape multiplies to sqrt(f_a f_b)),
  but no per-shape values give max(e_a, e_b) for every pair. So each shape carries
  sdfphys's raw values and a ``pre_solve`` handler on every pair sets
  ``arbiter.friction = sqrt(f_a f_b)`` and ``arbiter.restitution = max(e_a, e_b)``
  when the pair approaches faster than the threshold at its contact point, else 0.
  Every pair then mixes exactly as in sdfphys.
- Solver: pymunk runs ``iterations`` sequential-impulse sweeps per pymunk step, each
  solving the bias (pseudo) velocity and the real velocity together; sdfphys runs
  one biased and ``relax_passes`` rigid sweeps per substep. ``iterations`` is set to
  1 + relax_passes, the same number of sweeps over the contacts per substep. (On the
  reference scenes 10, pymunk's default, gives the same trajectories: their circle
  pairs have one point and converge in one sweep.)
- Overlap: sdfphys's soft contacts push an overlap s out at about
  k = mass_scale x bias_rate (per second, s' = -k s; 17/s against static bodies at
  the defaults, half that between two dynamic bodies) up to ``max_push_out``, down
  to s = 0; pymunk removes the fraction 1 - collision_bias^h of the overlap beyond
  ``collision_slop`` per pymunk step, a rate of -ln(collision_bias) per second. So
  collision_bias = exp(-k) with sdfphys's rate against static bodies (the contacts
  of the reference scenes are mostly against the ground). collision_slop is
  ``linear_slop``, not 0: pymunk only keeps contacts that overlap, and with no slop
  its piles jitter (circles_in_box after 8 s: median speed 3e-3 m/s at slop 0,
  2e-6 m/s at 0.005). Resting bodies therefore sit anywhere from 0 to
  collision_slop deep in pymunk, and at the soft contact's steady depth
  impulse_scale g h / (mass_scale bias_rate) (7e-5 m at the defaults) in sdfphys.
  Not matched: the contact softness itself (pymunk's contacts are rigid), the
  push-out cap, and the rate between two dynamic bodies.
- Contacts: sdfphys collides once per step and keeps contacts closer than
  ``speculative_distance`` plus the distance the two bodies can close in one step
  (capped at two radii per body); pymunk collides every pymunk step and keeps only
  overlapping shapes. Only a body faster than that cap can overlap by a step's
  travel before sdfphys sees the contact; restitution is aimed at the approach
  speed on arrival. Impacts may thus land a step apart in the two engines, and
  positions after them differ by up to |v_after - v_before| x 2 dt. Both anchor a
  contact differently: pymunk at each body's own surface point, sdfphys (as Box2D v3)
  at the midpoint, so
  a ball sunk by d rolls on radius r - d / 2 in sdfphys.
- Restitution: sdfphys applies it after the substeps, toward -e times the approach
  speed at the start of the step; pymunk inside every sweep, toward -e times the
  approach speed at the start of its pymunk step. Both conserve momentum exactly.
- Time of impact: pymunk has none; scenes whose bodies move more than half their
  size in one step are not comparable.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pymunk
import pymunk.autogeometry

from .collide import Contacts, find_contacts
from .errors import SpecError
from .limits import check_steps
from .progress import Progress
from .scene import Scene, read_scene
from .shapes import Circle, SdfShape, Shape, TriangleMesh
from .solver import contact_softness

__all__ = ["CONTACT_TOLERANCE", "Comparison", "NotModelledError", "PymunkWorld",
           "check_modelled", "compare", "compare_main", "contact_difference", "report",
           "sdfphys_contacts"]

#: Contact points, normals and depths of the two engines agree to this (m; exact
#: formulas on both sides, differing by round-off).
CONTACT_TOLERANCE = 1e-9

#: Width of the time windows of ``report``'s tables, s.
WINDOW = 0.5

#: Shape field types built as pymunk.Segment (a capsule's radius, 0 for a segment).
SEGMENT_FIELDS = ("capsule", "segment")

#: What the reference can build, for error messages.
MODELLED = ("circles, boxes and polygons (concave ones as pymunk's convex decomposition), "
            "and static or kinematic capsule or segment fields")


class NotModelledError(SpecError):
    """The scene has bodies the pymunk reference cannot build (the message names them)."""


def _segment(shape: Shape) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(a, b, radius) in the body frame if ``shape`` is a capsule or segment field."""
    if not isinstance(shape, SdfShape):
        return None
    spec = shape.spec["field"]
    if not isinstance(spec, dict) or spec.get("type") not in SEGMENT_FIELDS:
        return None
    angle = spec.get("angle", 0.0)
    c, s = math.cos(angle), math.sin(angle)
    offset = np.asarray(spec.get("offset", (0.0, 0.0)), np.float64) + shape.origin
    ends = [np.array([c * x - s * y, s * x + c * y]) + offset
            for x, y in (spec["a"], spec["b"])]
    return ends[0], ends[1], float(spec.get("radius", 0.0))


def _is_convex(vertices: np.ndarray) -> bool:
    """True if the counter-clockwise outline (M, 2) turns left or goes straight at every
    vertex (cross products >= -1e-12 x the squared size: collinear points count)."""
    edge = np.roll(vertices, -1, axis=0) - vertices
    turn = np.roll(edge, -1, axis=0)
    cross = edge[:, 0] * turn[:, 1] - edge[:, 1] * turn[:, 0]
    return bool(np.all(cross >= -1e-12 * float(np.max(np.sum(edge * edge, axis=1)))))


def _why_not(shape: Shape, kind: str) -> str | None:
    """Why the reference cannot build this body, or None if it can."""
    if isinstance(shape, (Circle, TriangleMesh)):
        return None
    if kind == "dynamic":
        return "dynamic sdf"
    if _segment(shape) is not None:
        return None
    return "sdf"


def convex_parts(vertices: np.ndarray) -> list[np.ndarray]:
    """The convex pieces (each (M_k, 2), counter-clockwise) pymunk builds a polygon
    ``vertices`` (M, 2, counter-clockwise, body frame) from: itself if convex, else
    ``pymunk.autogeometry.convex_decomposition`` of the closed outline at tolerance 0.
    Raises NotModelledError if the pieces do not cover the polygon's area (to 1e-9)."""
    if _is_convex(vertices):
        return [np.asarray(vertices, np.float64)]
    closed = [tuple(v) for v in vertices] + [tuple(vertices[0])]
    parts = [np.array([tuple(v) for v in part[:-1]], np.float64)
             for part in pymunk.autogeometry.convex_decomposition(closed, 0.0)]
    area = sum(_area(p) for p in parts)
    if not math.isclose(area, _area(vertices), rel_tol=1e-9):
        raise NotModelledError("", f"pymunk's convex decomposition covers {area:g} m^2 of "
                                   f"a polygon of {_area(vertices):g} m^2")
    return parts


def _area(vertices: np.ndarray) -> float:
    """Area (m^2) of a counter-clockwise polygon (M, 2), by the shoelace formula."""
    x, y = vertices[:, 0], vertices[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def check_modelled(scene: Scene) -> None:
    """Raise NotModelledError naming every body the reference cannot build (up to ten)."""
    bad = []
    for i, body in enumerate(scene.bodies):
        reason = _why_not(body.shape, body.kind)
        if reason is not None:
            bad.append(f"body[{i}] {body.name!r} ({reason})")
    if bad:
        shown = ", ".join(bad[:10]) + (f" and {len(bad) - 10} more" if len(bad) > 10 else "")
        raise NotModelledError("", f"pymunk cannot model {shown}; the reference models "
                                   f"{MODELLED}", scene.source)


def _noop_position(body: pymunk.Body, dt: float) -> None:
    """A position update that leaves the body where it is (the priming step)."""


class PymunkWorld:
    """A modelled Scene built in pymunk; ``step()`` advances one sdfphys step.

    Body i is scene body i. State accessors return arrays like World's: centre of
    mass (B, 2) m, angle (B,) rad, velocity (B, 2) m/s. See the module docstring for
    how each setting is matched.
    """

    def __init__(self, scene: Scene):
        check_modelled(scene)
        settings = scene.settings
        self.settings = settings
        self.substep = settings.dt / settings.substeps
        _, stiff = contact_softness(settings)
        space = pymunk.Space()
        space.gravity = tuple(scene.gravity)
        space.iterations = 1 + settings.relax_passes
        space.collision_slop = settings.linear_slop
        space.collision_bias = math.exp(-stiff.bias_rate * stiff.mass_scale)
        self.space = space
        self.bodies: list[pymunk.Body] = []
        self.parts: list[list[pymunk.Shape]] = []
        self._index: dict[int, int] = {}
        for i, spec in enumerate(scene.bodies):
            body, parts = self._build(spec)
            space.add(body, *parts)
            self.bodies.append(body)
            self.parts.append(parts)
            for part in parts:
                self._index[id(part)] = i
        self.shapes = [parts[0] for parts in self.parts]
        """Each body's (first) pymunk shape; ``parts`` has all of a decomposed polygon's."""
        self.dynamic = np.array([b.kind == "dynamic" for b in scene.bodies])
        self.circle = np.array([isinstance(s, pymunk.Circle) for s in self.shapes])
        self.exact = np.where(self.circle, 2,
                              np.array([len(parts) == 1 for parts in self.parts], int))
        """(B,) 2 for a circle, 1 for a single convex shape, 0 for a decomposed polygon:
        a pair with a circle and no decomposed polygon has one exact contact."""
        self._threshold = settings.restitution_threshold
        self._primed = False
        space.on_collision(None, None, pre_solve=self._mix_materials)

    @staticmethod
    def _build(spec) -> tuple[pymunk.Body, list[pymunk.Shape]]:
        """The pymunk body (at the centre of mass) and shapes of one modelled BodySpec
        (several for a concave polygon), carrying the body's friction and restitution.

        A dynamic polygon's moment is the sum of ``pymunk.moment_for_poly`` over its
        parts, each with its share of the mass (sdfphys's exact polygon moment to
        round-off)."""
        shape = spec.shape
        parts = convex_parts(shape.vertices) if isinstance(shape, TriangleMesh) else None
        if spec.kind == "dynamic":
            mass = spec.mass if spec.mass is not None else spec.density * shape.area
            if parts is None:
                moment = pymunk.moment_for_circle(mass, 0.0, shape.radius)
            else:
                moment = sum(pymunk.moment_for_poly(mass * _area(p) / shape.area,
                                                    [tuple(v) for v in p]) for p in parts)
            body = pymunk.Body(mass, moment)
        else:
            body = pymunk.Body(body_type=pymunk.Body.STATIC if spec.kind == "static"
                               else pymunk.Body.KINEMATIC)
        c, s = math.cos(spec.angle), math.sin(spec.angle)
        ox, oy = shape.origin
        body.position = (spec.position[0] - (c * ox - s * oy),
                         spec.position[1] - (s * ox + c * oy))
        body.angle = spec.angle
        if spec.kind != "static":
            body.velocity = spec.velocity
            body.angular_velocity = spec.angular_velocity
        if isinstance(shape, Circle):
            made = [pymunk.Circle(body, shape.radius)]
        elif parts is not None:
            made = [pymunk.Poly(body, [tuple(v) for v in p]) for p in parts]
        else:
            a, b, radius = _segment(shape)
            made = [pymunk.Segment(body, tuple(a), tuple(b), radius)]
        for part in made:
            part.friction = spec.friction
            part.elasticity = spec.restitution
        return body, made

    def _mix_materials(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        """pre_solve on every pair: sdfphys's mixing and restitution threshold."""
        shape_a, shape_b = arbiter.shapes
        arbiter.friction = math.sqrt(shape_a.friction * shape_b.friction)
        n = arbiter.normal
        approach = 0.0
        for p in arbiter.contact_point_set.points:
            mid = (p.point_a + p.point_b) / 2
            relative = (shape_b.body.velocity_at_world_point(mid)
                        - shape_a.body.velocity_at_world_point(mid))
            approach = max(approach, -relative.dot(n))
        bouncy = approach > self._threshold
        arbiter.restitution = max(shape_a.elasticity, shape_b.elasticity) if bouncy else 0.0

    def step(self) -> None:
        """Advance by settings.dt: ``substeps`` pymunk steps of h (after the priming step)."""
        if not self._primed:
            moving = [b for b in self.bodies if b.body_type != pymunk.Body.STATIC]
            for body in moving:
                body.position_func = _noop_position
            self.space.step(self.substep)
            for body in moving:
                body.position_func = pymunk.Body.update_position
            self._primed = True
        for _ in range(self.settings.substeps):
            self.space.step(self.substep)

    def describe(self) -> str:
        """One line: pymunk's version and the settings chosen for this scene."""
        space = self.space
        return (f"pymunk {pymunk.version}: {self.settings.substeps} x Space.step("
                f"{self.substep:.6g} s) per step after a priming step, iterations "
                f"{space.iterations}, collision_slop {space.collision_slop:g} m, "
                f"collision_bias {space.collision_bias:.3g}; materials mixed as sdfphys's")

    @property
    def center_of_mass(self) -> np.ndarray:
        """(B, 2) m."""
        return np.array([tuple(b.position) for b in self.bodies], np.float64)

    @property
    def angle(self) -> np.ndarray:
        """(B,) rad."""
        return np.array([b.angle for b in self.bodies], np.float64)

    @property
    def velocity(self) -> np.ndarray:
        """(B, 2) m/s (one substep's kick ahead of sdfphys's, see the module docstring)."""
        return np.array([tuple(b.velocity) for b in self.bodies], np.float64)

    def set_poses(self, com: np.ndarray, angle: np.ndarray) -> None:
        """Move every body to centre of mass ``com`` (B, 2) m and ``angle`` (B,) rad."""
        for body, p, a in zip(self.bodies, com, angle):
            body.position = (float(p[0]), float(p[1]))
            body.angle = float(a)
            self.space.reindex_shapes_for_body(body)

    def contacts(self) -> Contacts:
        """pymunk's contacts at the current poses, as sdfphys's Contacts.

        Pairs with a dynamic body that pymunk finds overlapping (``Space.shape_query``),
        body_a < body_b; each pair's contacts from ``Shape.shapes_collide`` of every two
        parts that touch, called with a circle first (pymunk reports a wrong-signed
        distance when a polygon comes first): point midway between point_a and point_b,
        normal from a to b, depth = -distance. ``feature`` is 0.
        """
        pairs = set()
        for i in np.flatnonzero(self.dynamic):
            for part in self.parts[i]:
                for info in self.space.shape_query(part):
                    j = self._index[id(info.shape)]
                    if j != i:
                        pairs.add((min(i, j), max(i, j)))
        rows = []
        for i, j in sorted(pairs):
            first, second = (i, j) if self.circle[i] else (j, i)
            sign = 1.0 if first == i else -1.0
            for part_a in self.parts[first]:
                for part_b in self.parts[second]:
                    try:
                        result = part_a.shapes_collide(part_b)
                    except AssertionError:   # pymunk 7 asserts when the shapes do not touch
                        continue
                    for p in result.points:
                        point = (np.array(p.point_a) + np.array(p.point_b)) / 2
                        rows.append((i, j, point, sign * np.array(result.normal),
                                     -p.distance))
        if not rows:
            return Contacts.empty()
        return Contacts(np.array([r[0] for r in rows], np.int64),
                        np.array([r[1] for r in rows], np.int64),
                        np.array([r[2] for r in rows]), np.array([r[3] for r in rows]),
                        np.array([r[4] for r in rows], np.float64),
                        np.zeros(len(rows), np.int64))


def sdfphys_contacts(world) -> Contacts:
    """The contacts sdfphys's next step will use (``find_contacts`` at the world's state;
    its read-only state copies copied to writeable arrays, as the step passes its own)."""
    return find_contacts(world.shapes, np.array(world.shape_id),
                         np.array(world.center_of_mass), np.array(world.angle),
                         np.array(world.kind == "dynamic"), world.settings,
                         np.array(world.velocity), np.array(world.angular_velocity))


@dataclass
class ContactDifference:
    """One frame's contact comparison.

    compared: exact pairs (one contact each: a circle against a convex shape) found by
    both engines. point, normal, depth: largest differences over them (m, unit-vector
    components, m). one_sided: exact pairs found by one engine only with depth >
    CONTACT_TOLERANCE (a pair that barely touches may be found by one engine and not the
    other; sdfphys's speculative contacts, depth <= 0, are not counted).
    manifolds: other pairs overlapping in both engines; manifold_depth,
    manifold_normal: largest differences of their deepest contacts' depth (m) and
    normal (for information: the engines build manifolds differently).
    """

    compared: int
    point: float
    normal: float
    depth: float
    one_sided: int
    manifolds: int = 0
    manifold_depth: float = 0.0
    manifold_normal: float = 0.0


def _deepest(contacts: Contacts, pairs: np.ndarray) -> dict[tuple[int, int], int]:
    """Index of the deepest contact of each pair (body_a, body_b) whose ``pairs`` flag is
    set."""
    out: dict[tuple[int, int], int] = {}
    for k, (a, b) in enumerate(zip(contacts.body_a.tolist(), contacts.body_b.tolist())):
        if pairs[k] and ((a, b) not in out or contacts.depth[k] > contacts.depth[out[a, b]]):
            out[a, b] = k
    return out


def contact_difference(ours: Contacts, theirs: Contacts,
                       exact: np.ndarray | None = None) -> ContactDifference:
    """Compare two Contacts pair by pair. ``exact`` (B,) bool: the bodies whose pairs
    with a circle have one exact contact (default: every pair is exact, as when every
    pair has a circle against a convex shape)."""
    if exact is None:
        exact_ours = np.ones(len(ours.depth), bool)
        exact_theirs = np.ones(len(theirs.depth), bool)
    else:
        exact_ours = _exact_pairs(ours, exact)
        exact_theirs = _exact_pairs(theirs, exact)
    difference = _exact_difference(ours.take(exact_ours), theirs.take(exact_theirs))
    mine = _deepest(ours, ~exact_ours & (ours.depth > CONTACT_TOLERANCE))
    other = _deepest(theirs, ~exact_theirs & (theirs.depth > CONTACT_TOLERANCE))
    both = sorted(mine.keys() & other.keys())
    if both:
        k_ours = np.array([mine[p] for p in both], np.int64)
        k_theirs = np.array([other[p] for p in both], np.int64)
        difference.manifolds = len(both)
        difference.manifold_depth = float(np.max(np.abs(ours.depth[k_ours]
                                                        - theirs.depth[k_theirs])))
        difference.manifold_normal = float(np.max(np.abs(ours.normal[k_ours]
                                                         - theirs.normal[k_theirs])))
    return difference


def _exact_pairs(contacts: Contacts, exact: np.ndarray) -> np.ndarray:
    """(C,) bool: contacts whose pair is exact. ``exact`` (B,) marks circles with 2 and
    convex (single-part) shapes with 1: a pair is exact when it holds a circle and both
    are convex."""
    a, b = exact[contacts.body_a], exact[contacts.body_b]
    return (a > 0) & (b > 0) & ((a == 2) | (b == 2))


def _exact_difference(ours: Contacts, theirs: Contacts) -> ContactDifference:
    """The exact pairs' comparison (one contact per pair)."""
    mine = {(a, b): k for k, (a, b) in enumerate(zip(ours.body_a.tolist(), ours.body_b.tolist()))}
    other = {(a, b): k for k, (a, b) in enumerate(zip(theirs.body_a.tolist(),
                                                       theirs.body_b.tolist()))}
    both = sorted(mine.keys() & other.keys())
    k_ours = np.array([mine[p] for p in both], np.int64)
    k_theirs = np.array([other[p] for p in both], np.int64)

    def largest(x: np.ndarray) -> float:
        return float(np.max(np.abs(x))) if x.size else 0.0

    one_sided = (sum(ours.depth[k] > CONTACT_TOLERANCE for p, k in mine.items() if p not in other)
                 + sum(theirs.depth[k] > CONTACT_TOLERANCE
                       for p, k in other.items() if p not in mine))
    return ContactDifference(
        len(both), largest(ours.point[k_ours] - theirs.point[k_theirs]),
        largest(ours.normal[k_ours] - theirs.normal[k_theirs]),
        largest(ours.depth[k_ours] - theirs.depth[k_theirs]), int(one_sided))


@dataclass
class Comparison:
    """sdfphys and pymunk over F frames (frame 0: the initial state; then one per step).

    names: (B,) body names. time: (F,) s. ours_*, theirs_*: sdfphys's and pymunk's
    centres of mass (F, B, 2) m, angles (F, B) rad and velocities (F, B, 2) m/s
    (pymunk's are one substep's kick ahead, see the module docstring). contacts: (F,)
    ContactDifference at sdfphys's poses of each frame.
    """

    names: list[str]
    time: np.ndarray
    ours_com: np.ndarray
    theirs_com: np.ndarray
    ours_angle: np.ndarray
    theirs_angle: np.ndarray
    ours_velocity: np.ndarray
    theirs_velocity: np.ndarray
    contacts: list[ContactDifference]

    def position_difference(self) -> np.ndarray:
        """(F, B) m, |centre of mass (sdfphys) - centre of mass (pymunk)|."""
        d = self.ours_com - self.theirs_com
        return np.hypot(d[..., 0], d[..., 1])

    def contact_failures(self) -> int:
        """Frames whose contacts differ by more than CONTACT_TOLERANCE or are one-sided."""
        return sum(max(c.point, c.normal, c.depth) > CONTACT_TOLERANCE or c.one_sided > 0
                   for c in self.contacts)


def compare(scene: Scene, seconds: float | None = None,
            progress: Callable[[int], None] | None = None) -> Comparison:
    """Run sdfphys and pymunk for ``seconds`` (default: the scene's duration).

    Frames are the initial state and the state after every step. Each frame also
    moves a second, never-stepped pymunk space to sdfphys's poses and compares the
    contacts of the two engines there. Raises NotModelledError (see check_modelled).
    progress: called with the number of steps done after each step.
    """
    seconds = scene.duration if seconds is None else seconds
    world = scene.build()
    reference = PymunkWorld(scene)
    probe = PymunkWorld(scene)
    steps = max(1, round(seconds / scene.settings.dt))
    states: list[list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = [[], []]
    contacts = []
    for step in range(steps + 1):
        if step:
            world.step()
            reference.step()
            if progress is not None:
                progress(step)
        probe.set_poses(world.center_of_mass, world.angle)
        contacts.append(contact_difference(sdfphys_contacts(world), probe.contacts(),
                                           probe.exact))
        for engine, record in zip((world, reference), states):
            record.append((engine.center_of_mass, engine.angle, engine.velocity))
    (ours_com, ours_angle, ours_velocity), (theirs_com, theirs_angle, theirs_velocity) = (
        [np.array(column) for column in zip(*record)] for record in states)
    return Comparison(world.names, np.arange(steps + 1) * scene.settings.dt, ours_com,
                      theirs_com, ours_angle, theirs_angle, ours_velocity, theirs_velocity,
                      contacts)


def _windows(time: np.ndarray, width: float) -> list[np.ndarray]:
    """Frame indices per window [k w, (k + 1) w) of ``time`` (F,) s; a last frame that
    starts a window of its own joins the one before. (The 1e-9 keeps k dt / w from
    rounding down a window.)"""
    last = max(0.0, math.floor(time[-1] / width - 1e-9))
    window = np.minimum(np.floor(time / width + 1e-9), last)
    return [np.flatnonzero(window == k) for k in np.unique(window)]


def _label(time: np.ndarray, frames: np.ndarray) -> str:
    """A window's first and last frame times, ``0.50-0.98``, right-aligned in 13 columns."""
    return f"{time[frames[0]]:.2f}-{time[frames[-1]]:.2f}".rjust(13)


def report(comparison: Comparison, window: float = WINDOW) -> list[str]:
    """The two tables of ``sdfphys compare`` as lines (per time window of ``window`` s)."""
    c = comparison
    title = ("contacts at sdfphys's poses (find_contacts vs pymunk shapes_collide; "
             f"pairs with a circle: agreement expected to {CONTACT_TOLERANCE:g}; other pairs: "
             "their deepest contacts, for information); pairs summed over the window's "
             "frames")
    header = (f"{'window s':>13} {'pairs':>6} {'|d point| m':>12} {'|d normal|':>11} "
              f"{'|d depth| m':>12} {'one engine only':>16} {'other pairs':>12} "
              f"{'|d depth| m':>12} {'|d normal|':>11}")
    lines = [title, header]
    for frames in _windows(c.time, window):
        rows = [c.contacts[f] for f in frames]
        lines.append(f"{_label(c.time, frames)} {sum(r.compared for r in rows):>6} "
                     f"{max(r.point for r in rows):>12.2e} {max(r.normal for r in rows):>11.2e} "
                     f"{max(r.depth for r in rows):>12.2e} {sum(r.one_sided for r in rows):>16} "
                     f"{sum(r.manifolds for r in rows):>12} "
                     f"{max(r.manifold_depth for r in rows):>12.2e} "
                     f"{max(r.manifold_normal for r in rows):>11.2e}")
    header = (f"{'window s':>13} {'max |dx| m':>11} {'body':>12} {'max |dangle| rad':>17} "
              f"{'body':>12}")
    lines += ["", "trajectories from the same initial state (centres of mass and angles)",
              header]
    dx = c.position_difference()
    da = np.abs(c.ours_angle - c.theirs_angle)
    for frames in _windows(c.time, window):
        bx = int(np.argmax(dx[frames].max(axis=0)))
        ba = int(np.argmax(da[frames].max(axis=0)))
        lines.append(f"{_label(c.time, frames)} {dx[frames, bx].max():>11.2e} {c.names[bx]:>12} "
                     f"{da[frames, ba].max():>17.2e} {c.names[ba]:>12}")
    return lines


def compare_main(scene_path: str | Path, seconds: float | None = None,
                 overrides: Sequence[str] = (), max_steps: int | None = None) -> int:
    """``sdfphys compare SCENE``: print the settings and the two tables.

    Returns 0, 1 if some frame's contacts differ by more than CONTACT_TOLERANCE (or a
    pair is found by one engine only), 2 for bad input, including a scene the
    reference cannot model (one line naming the bodies) and more than ``max_steps``
    steps (default ``limits.MAX_STEPS``).
    """
    try:
        if seconds is not None and not (math.isfinite(seconds) and seconds > 0.0):
            raise SpecError("--seconds", f"must be a positive number, got {seconds}")
        scene = read_scene(scene_path, overrides)
        check_modelled(scene)
        steps = max(1, round((scene.duration if seconds is None else seconds)
                             / scene.settings.dt))
        check_steps(steps, "steps", max_steps)
        PymunkWorld(scene)                          # a polygon pymunk cannot decompose
    except SpecError as err:
        print(f"sdfphys: error: {err}", file=sys.stderr)
        return 2
    bar = Progress(steps, "steps", "sdfphys compare")
    try:
        comparison = compare(scene, seconds, bar.update)
    finally:
        bar.close()
    print(PymunkWorld(scene).describe())
    print()
    for line in report(comparison):
        print(line)
    failures = comparison.contact_failures()
    if failures:
        print(f"\ncontacts differ by more than {CONTACT_TOLERANCE:g} at {failures} frames")
        return 1
    return 0
