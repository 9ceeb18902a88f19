"""World: body state as arrays, bodies added and removed, and ``step()``.

Body state is a struct of arrays, split hot and cold as in Box2D v3: the solver reads
and writes the centre-of-mass position, angle, velocities and inverse masses; shapes,
materials, kinds and names are bookkeeping. Arrays grow by doubling, so adding B bodies
costs O(B). Body indices are the order of ``add_body`` calls (scene order);
``remove_body(i)`` shifts the later bodies down by one.

Frames: a body's frame has its origin at the centre of mass; the shape's ``origin`` is
where the user's frame origin (a scene's ``position``) sits in it, so the centre of
mass of a body at user pose (p, a) is com = p - R(a) origin, and ``position`` reports
p = com + R(a) origin. ``velocity`` is the centre of mass's (as pymunk's
``Body.velocity``), ``angular_velocity`` is counter-clockwise, rad/s.

Kinds: ``dynamic`` bodies have mass and feel gravity and contacts; ``static`` bodies
never move; ``kinematic`` bodies move with their velocity and are pushed by nothing.
Static and kinematic bodies have zero inverse mass and inertia (``mass`` reports inf).
Materials mix per contact: friction sqrt(f_a f_b), restitution max(e_a, e_b).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from . import _warm, queries
from .collide import Contacts, find_contacts
from .collide.narrowphase import PAIR_FUNCTIONS
from .errors import SpecError
from .islands import island_roots
from .joints import JointTable, WorldJoints
from .limits import (
    KINDS,
    BodyValues,
    check_angle,
    check_angular_velocity,
    check_body,
    check_gravity,
    check_position,
    check_velocity,
)
from .settings import Settings
from .shapes import Shape, collision_shape, shape_from_spec
from .sleep import falling_asleep, rest_times
from .solver import (
    BodyState,
    ContactConstraints,
    ImpulseCache,
    apply_restitution,
    prepare_contacts,
    solve_substeps,
    store_impulses,
)
from .toi import fast_bodies, step_fractions

__all__ = ["KINDS", "PAIR_STAGES", "STAGES", "World"]

#: Body kinds, in the order of their integer codes (``limits.KINDS``).
_DYNAMIC, _STATIC, _KINEMATIC = range(3)

#: Narrowphase stages, one per pair kind (``collide.narrowphase.PAIR_FUNCTIONS``):
#: ``circle_circle``, ``circle_mesh``, ..., ``sdf_sdf``, counted once per step in which
#: that pair function ran (some candidate pair of that kind was near enough).
PAIR_STAGES = tuple(f"{a}_{b}" for a, b in PAIR_FUNCTIONS)

#: The stages of ``World.step``, as counted in ``World.stage_counts``.
STAGES = ("collide",) + PAIR_STAGES + (
    "prepare", "integrate_velocities", "warm_start", "solve", "converge", "push_out",
    "integrate_positions", "relax", "friction", "restitution", "time_of_impact",
    "store_impulses")

# Per-body arrays: name -> (trailing shape, dtype). Capacity grows by doubling.
_ARRAYS: dict[str, tuple[tuple[int, ...], Any]] = {
    "com": ((2,), np.float64),
    "angle": ((), np.float64),
    "velocity": ((2,), np.float64),
    "angular_velocity": ((), np.float64),
    "inv_mass": ((), np.float64),
    "inv_inertia": ((), np.float64),
    "linear_damping": ((), np.float64),
    "angular_damping": ((), np.float64),
    "round": ((), np.bool_),
    "mass": ((), np.float64),
    "inertia": ((), np.float64),
    "friction": ((), np.float64),
    "restitution": ((), np.float64),
    "origin": ((2,), np.float64),
    "radius": ((), np.float64),
    "core_radius": ((), np.float64),
    "shape_id": ((), np.int64),
    "kind": ((), np.int8),
    "sleep_time": ((), np.float64),
    "asleep": ((), np.bool_),
    "island": ((), np.int64),
}


def _rotate(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rows of ``v`` (N, 2) rotated counter-clockwise by ``angle`` (N,) rad."""
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]])


def _rotate_one(v: np.ndarray, angle: float) -> np.ndarray:
    """(2,) ``v`` rotated counter-clockwise by ``angle`` rad (numpy's cos and sin, as
    ``_rotate``: the same bits)."""
    a = np.array([angle], dtype=np.float64)
    c, s = float(np.cos(a)[0]), float(np.sin(a)[0])
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def _read_only(array: np.ndarray) -> np.ndarray:
    """``array`` (a fresh copy) marked read-only: writing to it raises numpy's
    "assignment destination is read-only"."""
    array.flags.writeable = False
    return array


class World(WorldJoints):
    """A 2D rigid-body world: bodies as arrays, ``step()`` advances ``settings.dt``.

    gravity: (2,) m/s^2 (settable attribute). settings: every knob (Settings).
    ``stage_counts``: how many times each stage of ``step()`` ran (STAGES); a stage
    with nothing to do (no pair of a kind, no contacts, no friction, no restitution,
    no fast body) is skipped and not counted. Contact queries see each SDF shape
    through the ``gradient`` and ``field_representation`` knobs
    (``shapes.collision_shape``); time of impact keeps the shapes' own fields (a baked
    field is not a distance bound, which conservative advancement needs).
    """

    def __init__(self, gravity: Any = (0.0, -9.81), settings: Settings | None = None):
        self._gravity = np.array(check_gravity(gravity, "gravity"), np.float64)
        self.settings = settings if settings is not None else Settings()
        self.time = 0.0
        self.step_count = 0
        self.stage_counts = dict.fromkeys(STAGES, 0)
        self._n = 0
        self._data = {name: np.zeros((16,) + shape, dtype)
                      for name, (shape, dtype) in _ARRAYS.items()}
        self._shapes: list[Shape] = []
        self._shape_index: dict[int, int] = {}
        self._names: list[str] = []
        self._name_set: set[str] = set()
        self._shape_rows: dict[int, tuple] = {}
        self._created = 0
        self._contacts = Contacts.empty()
        self._impulses = ImpulseCache.empty()
        # Sleeping islands' contacts and impulses, kept for their warm start (``sleep``).
        self._sleep_contacts = Contacts.empty()
        self._sleep_impulses = ImpulseCache.empty()
        self._islands_made = 0
        self._joints = JointTable()     # ``joints.WorldJoints``

    # ----------------------------------------------------------------------------------
    # Bodies
    # ----------------------------------------------------------------------------------

    @property
    def gravity(self) -> np.ndarray:
        """(2,) m/s^2, a read-only copy; assign a pair to change it (checked: finite,
        magnitude at most ``limits.MAX_GRAVITY``). Setting it wakes every sleeping
        island."""
        return _read_only(self._gravity.copy())

    @gravity.setter
    def gravity(self, value: Any) -> None:
        self._gravity = np.array(check_gravity(value, "gravity"), np.float64)
        if self._n:
            self.wake()

    @property
    def settings(self) -> Settings:
        """Every knob (``Settings``, validated on construction); assign a Settings."""
        return self._settings

    @settings.setter
    def settings(self, value: Settings) -> None:
        if not isinstance(value, Settings):
            raise SpecError("settings", f"must be a Settings, got {value!r}")
        self._settings = value

    def add_body(self, shape: Shape | Mapping, position: Any = (0.0, 0.0), angle: float = 0.0,
                 velocity: Any = (0.0, 0.0), angular_velocity: float = 0.0,
                 density: float = 1.0, mass: float | None = None, friction: float = 0.5,
                 restitution: float = 0.0, kind: str = "dynamic", name: str | None = None,
                 linear_damping: float = 0.0, angular_damping: float = 0.0) -> int:
        """Add a body and return its index.

        shape: a Shape or a scene shape dict (``{"type": "circle", "radius": 0.5}``).
        position: (2,) m, where the user frame origin goes; angle: rad.
        velocity: (2,) m/s of the centre of mass; angular_velocity: rad/s.
        density: kg/m^2, or ``mass`` (kg) which overrides it; inertia follows the shape.
        friction >= 0, restitution in [0, 1]. kind: dynamic | static | kinematic.
        name: unique; default ``body<k>`` with k counting every body ever added.
        linear_damping, angular_damping: 1/s (v / (1 + h c) per substep).
        Every value is checked as a scene's (``limits``: finite, within the documented
        ranges); a bad one raises SpecError naming the argument, e.g.
        ``position[0]: must be finite, got nan``.
        """
        shape = shape_from_spec(shape)
        values = check_body(position=position, angle=angle, velocity=velocity,
                            angular_velocity=angular_velocity, density=density, mass=mass,
                            friction=friction, restitution=restitution, kind=kind,
                            linear_damping=linear_damping, angular_damping=angular_damping)
        if name is not None and (not isinstance(name, str) or not name):
            raise SpecError("name", f"must be a non-empty string, got {name!r}")
        if kind == "dynamic" and not math.isfinite(shape.radius):
            raise SpecError("shape", "an unbounded shape can only be static")
        return self._add(shape, values, name)

    def _add(self, shape: Shape, values: BodyValues, name: str | None) -> int:
        """Add a body whose values ``limits.check_body`` validated (``Scene.build`` calls
        this directly: the scene was checked when read)."""
        if name is None:
            name = f"body{self._created}"
        if name in self._name_set:
            raise SpecError("name", f"duplicate body name {name!r}")
        number, origin, radius, core_radius, area, second_moment = self._shape_row(shape)
        code = KINDS.index(values.kind)
        if code == _DYNAMIC:
            m = values.mass if values.mass is not None else values.density * area
            inertia = m / area * second_moment
        else:
            m = inertia = math.inf

        i = self._n
        self._reserve(i + 1)
        self._n = i + 1
        d = self._data
        if origin[0] == 0.0 and origin[1] == 0.0:     # circles and boxes
            d["com"][i] = values.position
        else:
            d["com"][i] = np.asarray(values.position) - _rotate_one(origin, values.angle)
        d["angle"][i] = values.angle
        d["velocity"][i] = values.velocity
        d["angular_velocity"][i] = values.angular_velocity
        d["mass"][i] = m
        d["inertia"][i] = inertia
        d["inv_mass"][i] = 1.0 / m
        d["inv_inertia"][i] = 1.0 / inertia if inertia > 0.0 else 0.0
        d["linear_damping"][i] = values.linear_damping
        d["angular_damping"][i] = values.angular_damping
        d["round"][i] = shape.kind == "circle"
        d["friction"][i] = values.friction
        d["restitution"][i] = values.restitution
        d["origin"][i] = origin
        d["radius"][i] = radius
        d["core_radius"][i] = core_radius
        d["shape_id"][i] = number
        d["kind"][i] = code
        d["sleep_time"][i] = 0.0
        d["asleep"][i] = False
        d["island"][i] = 0
        self._names.append(name)
        self._name_set.add(name)
        self._created += 1
        return i

    def _shape_row(self, shape: Shape) -> tuple:
        """(shape number, origin (2,), radius, core radius, area, second moment) of
        ``shape``, computed once per distinct shape (area and second moment None for an
        unbounded one). The core radius is -f(centre of mass): the deepest inside."""
        row = self._shape_rows.get(id(shape))
        if row is None:
            bounded = math.isfinite(shape.radius)
            row = (self._shape_number(shape), np.asarray(shape.origin, dtype=np.float64),
                   shape.radius, -float(shape.field.distance(np.zeros((1, 2)))[0]),
                   shape.area if bounded else None,
                   shape.second_moment if bounded else None)
            self._shape_rows[id(shape)] = row
        return row

    def remove_body(self, index: int) -> None:
        """Remove body ``index``; later bodies move down one index (their contacts too).
        Sleeping islands it belonged to or touched wake up."""
        i = self._check(index)
        self._wake_touching(i)
        n = self._n
        for array in self._data.values():
            array[i:n - 1] = array[i + 1:n]
        self._n = n - 1
        self._name_set.discard(self._names[i])
        del self._names[i]
        self._impulses = self._impulses.without_body(i)
        self._sleep_impulses = self._sleep_impulses.without_body(i)
        self._contacts = self._contacts.without_body(i)
        self._sleep_contacts = self._sleep_contacts.without_body(i)
        self._joints.without_body(i)

    def set_state(self, index: int, *, position: Any = None, angle: float | None = None,
                  velocity: Any = None, angular_velocity: float | None = None) -> None:
        """Set a body's pose (user frame origin, m; rad) and/or velocities (m/s, rad/s).

        Changing only the angle turns the body about its user origin. Static bodies
        may be moved but not given a velocity. The body's sleeping island, and the
        islands it touches, wake up. Values are checked as ``add_body``'s (SpecError
        naming the argument); nothing changes if one is bad.
        """
        i = self._check(index)
        d = self._data
        if position is not None:
            position = check_position(position, "position")
        if angle is not None:
            angle = check_angle(angle, "angle")
        if velocity is not None:
            velocity = check_velocity(velocity, "velocity")
        if angular_velocity is not None:
            angular_velocity = check_angular_velocity(angular_velocity, "angular_velocity")
        if d["kind"][i] == _STATIC and ((velocity is not None and velocity != (0.0, 0.0))
                                        or angular_velocity not in (None, 0.0)):
            raise SpecError("velocity", "a static body cannot move; use kind='kinematic'")
        self._wake_touching(i)
        if position is not None or angle is not None:
            user = self.position[i] if position is None else np.array(position)
            if angle is not None:
                d["angle"][i] = angle
            d["com"][i] = user - _rotate_one(d["origin"][i], float(d["angle"][i]))
        if velocity is not None:
            d["velocity"][i] = velocity
        if angular_velocity is not None:
            d["angular_velocity"][i] = angular_velocity

    def _shape_number(self, shape: Shape) -> int:
        number = self._shape_index.get(id(shape))
        if number is None:
            number = len(self._shapes)
            self._shapes.append(shape)
            self._shape_index[id(shape)] = number
        return number

    def _reserve(self, count: int) -> None:
        capacity = len(self._data["angle"])
        if count <= capacity:
            return
        while capacity < count:
            capacity *= 2
        for name, array in self._data.items():
            grown = np.zeros((capacity,) + array.shape[1:], array.dtype)
            grown[:self._n] = array[:self._n]
            self._data[name] = grown

    def _check(self, index: int) -> int:
        if not -self._n <= index < self._n:
            raise IndexError(f"body index {index} out of range ({self._n} bodies)")
        return index % self._n

    def _view(self, name: str) -> np.ndarray:
        return self._data[name][:self._n]

    # ----------------------------------------------------------------------------------
    # Step
    # ----------------------------------------------------------------------------------

    def step(self) -> None:
        """Advance the world by ``settings.dt`` (docs/solver.md, "One step").

        Stages: collide once; prepare the contact rows (warm start matched by feature
        key); the substeps (each: integrate velocities, warm start, solve, integrate
        positions, relax); restitution; time of impact for fast bodies; store impulses;
        with ``settings.sleeping``, islands at rest fall asleep (``sdfphys.sleep``): a
        step with no awake dynamic and no moving kinematic body only advances the time,
        and sleeping islands within contact range of an active body wake first.
        """
        if self.step_count == 0:
            _warm.start(self)
        sleeping = self.settings.sleeping
        # What moves this step (awake dynamic bodies, moving kinematic ones), None
        # without sleeping: changed within a step only by waking islands.
        active = self._active() if sleeping else None
        if not sleeping or np.any(active):
            bodies = self._body_state()
            start_com, start_angle = bodies.com.copy(), bodies.angle.copy()
            contacts = self._collide(bodies, active)
            if sleeping:
                if self._wake_reached(contacts, active):
                    active = self._active()
                    bodies = self._body_state()
                    contacts = self._collide(bodies, active)
                # Kinematic-static pairs, found because moving kinematic bodies were
                # movable for the wake test, carry no row.
                awake = self._awake()
                keep = awake[contacts.body_a] | awake[contacts.body_b]
                if not np.all(keep):
                    self._contacts = contacts = contacts.take(keep)
            constraints = self._prepare(contacts, bodies)
            if self.step_count == 0:
                _warm.join()
            self._substeps(constraints, bodies)
            self._restitution(constraints, bodies)
            self._time_of_impact(bodies, start_com, start_angle)
            self._store_impulses(constraints)
            if sleeping:
                self._fall_asleep(bodies, constraints, start_com, start_angle, awake, active)
        self.time += self.settings.dt
        self.step_count += 1

    def _compile_ahead(self) -> None:
        """What the compiling child (``sdfphys._warm``) runs in its copy of the world, for
        the kernels' sake: the stages after the preparation of the contact rows, which
        the parent compiles itself after the collisions, once on no contacts, last
        stage first."""
        bodies = self._body_state()
        constraints = ContactConstraints.empty()
        if self.settings.sleeping:
            self._fall_asleep(bodies, constraints, bodies.com.copy(), bodies.angle.copy(),
                              self._awake(), self._active())
        apply_restitution(bodies, constraints, self.settings)
        self._substeps(constraints, bodies)

    def _body_state(self) -> BodyState:
        """The solver's view; sleeping bodies take part with zero inverse mass."""
        v = self._view
        inv_mass, inv_inertia = v("inv_mass"), v("inv_inertia")
        asleep = v("asleep")
        if np.any(asleep):
            inv_mass = np.where(asleep, 0.0, inv_mass)
            inv_inertia = np.where(asleep, 0.0, inv_inertia)
        return BodyState(v("com"), v("angle"), v("velocity"), v("angular_velocity"),
                         inv_mass, inv_inertia, v("linear_damping"),
                         v("angular_damping"), v("round"), v("radius"))

    # ----------------------------------------------------------------------------------
    # Sleeping (``sdfphys.sleep``)
    # ----------------------------------------------------------------------------------

    def _awake(self) -> np.ndarray:
        """(B,) bool: dynamic bodies that are not asleep."""
        return (self._view("kind") == _DYNAMIC) & ~self._view("asleep")

    def _active(self) -> np.ndarray:
        """(B,) bool: awake dynamic bodies and moving kinematic ones (what a step moves)."""
        v, w = self._view("velocity"), self._view("angular_velocity")
        moving = (v[:, 0] != 0.0) | (v[:, 1] != 0.0) | (w != 0.0)
        return self._awake() | ((self._view("kind") == _KINEMATIC) & moving)

    def _wake_reached(self, contacts: Contacts, active: np.ndarray) -> bool:
        """Wake the sleeping islands that an active body (``active`` (B,) bool,
        ``_active``) has a contact with; True if any."""
        asleep = self._view("asleep")
        if len(contacts) == 0 or not np.any(asleep):
            return False
        a, b = contacts.body_a, contacts.body_b
        reached = np.r_[b[active[a] & asleep[b]], a[asleep[a] & active[b]]]
        if len(reached) == 0:
            return False
        self._wake_islands(self._view("island")[reached])
        return True

    def _wake_touching(self, index: int) -> None:
        """Wake body ``index``'s island and the sleeping islands that touch it."""
        c = self._sleep_contacts
        touching = np.r_[c.body_a[c.body_b == index], c.body_b[c.body_a == index], index]
        touching = touching[self._view("asleep")[touching]]
        if len(touching):
            self._wake_islands(self._view("island")[touching])

    def wake(self) -> None:
        """Wake every sleeping island."""
        self._wake_islands(self._view("island")[self._view("asleep")])

    def _wake_islands(self, islands: np.ndarray) -> None:
        """Wake every body of the given sleeping islands; their contacts' impulses return
        to the warm-start cache."""
        if len(islands) == 0:
            return
        d = self._data
        woken = self._view("asleep") & np.isin(self._view("island"), islands)
        d["asleep"][:self._n][woken] = False
        d["sleep_time"][:self._n][woken] = 0.0
        rows = woken[self._sleep_impulses.body_a] | woken[self._sleep_impulses.body_b]
        self._impulses = ImpulseCache.concatenate(
            [self._impulses, self._sleep_impulses.take(rows)]).sorted()
        self._sleep_impulses = self._sleep_impulses.take(~rows)
        c = self._sleep_contacts
        self._sleep_contacts = c.take(~(woken[c.body_a] | woken[c.body_b]))

    def _fall_asleep(self, bodies: BodyState, constraints: ContactConstraints,
                     start_com: np.ndarray, start_angle: np.ndarray, awake: np.ndarray,
                     active: np.ndarray) -> None:
        """Count each awake body's rest (``sleep.rest_times``) and put to sleep the
        islands that have rested ``time_to_sleep``: velocities zeroed, their contacts and
        impulses moved to the sleeping caches. start_com, start_angle: the poses at the
        start of the step (a body pushed out of overlap moves without velocity); awake,
        active: (B,) bool, ``_awake`` and ``_active`` of this step."""
        s = self.settings
        sleep_time = self._view("sleep_time")
        rest_times(bodies.velocity, bodies.angular_velocity, bodies.com, bodies.angle,
                   start_com, start_angle, self._view("radius"), awake, sleep_time, s.dt,
                   s.sleep_speed)
        c = constraints
        kinematic = active & (self._view("kind") == _KINEMATIC)
        sleep_time[c.body_b[kinematic[c.body_a]]] = 0.0
        sleep_time[c.body_a[kinematic[c.body_b]]] = 0.0
        root = island_roots(bodies.inv_mass, *self._joints.linked(c.body_a, c.body_b))
        falling = falling_asleep(root, awake, sleep_time, s.time_to_sleep)
        if not np.any(falling):
            return
        d = self._data
        n = self._n
        d["asleep"][:n][falling] = True
        d["velocity"][:n][falling] = 0.0
        d["angular_velocity"][:n][falling] = 0.0
        roots, label = np.unique(root[falling], return_inverse=True)
        d["island"][:n][falling] = self._islands_made + label
        self._islands_made += len(roots)
        cache = self._impulses
        rows = falling[cache.body_a] | falling[cache.body_b]
        self._sleep_impulses = ImpulseCache.concatenate([self._sleep_impulses,
                                                         cache.take(rows)])
        self._impulses = cache.take(~rows)
        contacts = self._contacts
        rows = falling[contacts.body_a] | falling[contacts.body_b]
        self._sleep_contacts = Contacts.concatenate([self._sleep_contacts,
                                                     contacts.take(rows)])
        self._contacts = contacts.take(~rows)

    def _collision_shapes(self) -> list[Shape]:
        """The distinct shapes as collisions see them under the field knobs."""
        s = self.settings
        return [collision_shape(shape, s.gradient, s.field_representation, s.grid_cell)
                for shape in self._shapes]

    def _collide(self, bodies: BodyState, active: np.ndarray | None) -> Contacts:
        """Stage 1: every contact closer than the speculative distance plus the pair's
        reach at the step's starting velocities (``sdfphys.collide``), once per step;
        each pair kind whose narrowphase ran is counted (PAIR_STAGES). active: (B,)
        bool, the bodies that move (``_active``) with sleeping, None without: the
        dynamic ones."""
        ran: set[tuple[str, str]] = set()
        movable = self._view("kind") == _DYNAMIC if active is None else active
        self._contacts = find_contacts(self._collision_shapes(), self._view("shape_id"),
                                       bodies.com, bodies.angle, movable, self.settings,
                                       bodies.velocity, bodies.angular_velocity, ran,
                                       exclude=self._joints.excluded_pairs(self._n))
        self.stage_counts["collide"] += 1
        for a, b in ran:
            self.stage_counts[f"{a}_{b}"] += 1
        return self._contacts

    def _prepare(self, contacts: Contacts, bodies: BodyState) -> ContactConstraints:
        """Stage 2: anchors, masses, base separations, warm-start impulses."""
        constraints = prepare_contacts(contacts, bodies, self._view("friction"),
                                       self._view("restitution"), self._impulses,
                                       self.settings.warm_starting, self._gravity,
                                       self.settings.linear_slop)
        if len(constraints):
            self.stage_counts["prepare"] += 1
        return constraints

    def _substeps(self, constraints: ContactConstraints, bodies: BodyState) -> None:
        """Stage 3: per substep integrate v, warm start, solve, integrate x, relax; loaded
        islands (mass ratios, heavy loads: ``solver.row_softness``) get extra passes until
        converged, counted one by one as ``converge``; ``push_out`` counts the substeps
        with a row deeper than ``soft_depth`` (its overlap pushed out through
        pseudo-velocities, solver "Split push-out")."""
        s = self.settings
        use_friction = bool(np.any(constraints.friction > 0.0))
        extra, push_outs = solve_substeps(bodies, constraints, self._gravity, s, use_friction,
                                          (self._joints.rows, self._joints.stiffness_cap))
        counts = self.stage_counts
        counts["converge"] += extra
        counts["push_out"] += push_outs
        counts["integrate_velocities"] += s.substeps
        counts["integrate_positions"] += s.substeps
        if len(constraints):
            counts["warm_start"] += s.substeps
            counts["solve"] += s.substeps
            counts["relax"] += s.substeps * s.relax_passes
        if use_friction:
            counts["friction"] += s.substeps * (1 + s.relax_passes)

    def _restitution(self, constraints: ContactConstraints, bodies: BodyState) -> None:
        """Stage 4: restitution passes, if some contact has restitution and approached fast."""
        needed = (constraints.restitution > 0.0) & (
            constraints.relative_velocity < -self.settings.restitution_threshold)
        if np.any(needed):
            apply_restitution(bodies, constraints, self.settings)
            self.stage_counts["restitution"] += self.settings.restitution_passes

    def _time_of_impact(self, bodies: BodyState, start_com: np.ndarray,
                        start_angle: np.ndarray) -> None:
        """Stage 5: fast bodies stopped at their time of impact (``sdfphys.toi``)."""
        s = self.settings
        if not s.time_of_impact:
            return
        core = np.maximum(self._view("core_radius"), s.speculative_distance)
        radius = self._view("radius")
        fast = fast_bodies(start_com, bodies.com, core, self._view("kind") == _DYNAMIC,
                           bodies.angle - start_angle, radius)
        if len(fast) == 0:
            return
        group = self._joints.groups(self._n)
        fraction = step_fractions([shape.field for shape in self._shapes],
                                  [getattr(shape, "vertices", None) for shape in self._shapes],
                                  self._view("shape_id"), start_com, bodies.com, start_angle,
                                  bodies.angle, radius, core, fast, s.linear_slop, group)
        fast, fraction = self._joints.spread_fractions(group, fast, fraction)
        t = fraction[:, None]
        bodies.com[fast] = start_com[fast] + t * (bodies.com[fast] - start_com[fast])
        bodies.angle[fast] = start_angle[fast] + fraction * (bodies.angle[fast]
                                                             - start_angle[fast])
        self.stage_counts["time_of_impact"] += 1

    def _store_impulses(self, constraints: ContactConstraints) -> None:
        """Stage 6: keep this step's impulses for the next step's warm start."""
        self._impulses = store_impulses(constraints)
        self.stage_counts["store_impulses"] += 1

    # ----------------------------------------------------------------------------------
    # State (read-only copies, scene order: set_state changes a body)
    # ----------------------------------------------------------------------------------

    def __len__(self) -> int:
        return self._n

    @property
    def position(self) -> np.ndarray:
        """(B, 2) m, world position of each body's user frame origin."""
        return _read_only(self._view("com") + _rotate(self._view("origin"),
                                                      self._view("angle")))

    @property
    def center_of_mass(self) -> np.ndarray:
        """(B, 2) m, world position of each body's centre of mass."""
        return _read_only(self._view("com").copy())

    @property
    def angle(self) -> np.ndarray:
        """(B,) rad, counter-clockwise."""
        return _read_only(self._view("angle").copy())

    @property
    def velocity(self) -> np.ndarray:
        """(B, 2) m/s, velocity of each centre of mass."""
        return _read_only(self._view("velocity").copy())

    @property
    def angular_velocity(self) -> np.ndarray:
        """(B,) rad/s, counter-clockwise."""
        return _read_only(self._view("angular_velocity").copy())

    @property
    def contacts(self) -> Contacts:
        """The contacts found at the start of the last step (empty before the first),
        with those of sleeping islands as they fell asleep; sorted by (body_a, body_b,
        feature)."""
        if len(self._sleep_contacts) == 0:
            return self._contacts
        c = Contacts.concatenate([self._contacts, self._sleep_contacts])
        return c.take(np.lexsort((c.feature, c.body_b, c.body_a)))

    @property
    def asleep(self) -> np.ndarray:
        """(B,) bool: bodies of sleeping islands (``settings.sleeping``)."""
        return _read_only(self._view("asleep").copy())

    @property
    def shapes(self) -> list[Shape]:
        """Distinct Shape objects; ``shape_id`` indexes into this list."""
        return list(self._shapes)

    @property
    def shape_id(self) -> np.ndarray:
        """(B,) int64, each body's index into ``shapes``."""
        return _read_only(self._view("shape_id").copy())

    @property
    def names(self) -> list[str]:
        return list(self._names)

    @property
    def mass(self) -> np.ndarray:
        """(B,) kg (inf for static and kinematic bodies)."""
        return _read_only(self._view("mass").copy())

    @property
    def inertia(self) -> np.ndarray:
        """(B,) kg m^2 about the centre of mass (inf for static and kinematic bodies)."""
        return _read_only(self._view("inertia").copy())

    @property
    def kind(self) -> np.ndarray:
        """(B,) str: dynamic | static | kinematic."""
        return _read_only(np.array(KINDS)[self._view("kind")])

    @property
    def friction(self) -> np.ndarray:
        """(B,) friction coefficients."""
        return _read_only(self._view("friction").copy())

    @property
    def restitution(self) -> np.ndarray:
        """(B,) restitution coefficients."""
        return _read_only(self._view("restitution").copy())

    def kinetic_energy(self) -> float:
        """J: sum over dynamic bodies of m |v|^2 / 2 + I w^2 / 2."""
        dynamic = self._view("kind") == _DYNAMIC
        v, w = self._view("velocity")[dynamic], self._view("angular_velocity")[dynamic]
        return float(0.5 * np.sum(self._view("mass")[dynamic] * np.sum(v * v, axis=1))
                     + 0.5 * np.sum(self._view("inertia")[dynamic] * w * w))

    def potential_energy(self) -> float:
        """J: sum over dynamic bodies of -m g.com (zero at the origin, so at y = 0 for
        vertical gravity)."""
        dynamic = self._view("kind") == _DYNAMIC
        return float(-np.sum(self._view("mass")[dynamic]
                             * (self._view("com")[dynamic] @ self.gravity)))

    # ----------------------------------------------------------------------------------
    # Queries (``sdfphys.queries``, docs/queries.md)
    # ----------------------------------------------------------------------------------

    def ray_cast(self, origins: Any, directions: Any, max_distance: float = math.inf,
                 mask: Any = None, bodies: Any = None) -> queries.RayHits:
        """Closest hit of each ray (``queries.RayHits``: body (N,), -1 for none; point
        (N, 2) m; normal (N, 2); distance (N,) m, 0 for a ray starting inside a body).

        origins, directions: (N, 2) (a direction's length does not matter, it must not
        be zero); max_distance: m, >= 0. bodies: an index array limiting the bodies
        hit (None: all); mask: reserved for collision categories (None)."""
        return queries.cast(self, origins, directions, max_distance, False, mask, bodies)

    def ray_cast_all(self, origins: Any, directions: Any, max_distance: float = math.inf,
                     mask: Any = None, bodies: Any = None) -> queries.RayHits:
        """Every body each ray enters within max_distance, as flat arrays (H,) sorted
        by (ray, distance): ``ray`` (H,) the ray index, ``body``, ``point``, ``normal``,
        ``distance`` as ``ray_cast``'s (each body once, at its first entry)."""
        return queries.cast(self, origins, directions, max_distance, True, mask, bodies)

    def circle_cast(self, origins: Any, directions: Any, radius: float,
                    max_distance: float = math.inf, mask: Any = None,
                    bodies: Any = None) -> queries.RayHits:
        """``ray_cast`` of a disc of ``radius`` (m, >= 0) swept from each origin: the first
        body it touches; ``distance`` is how far its centre travelled (0 if it overlaps
        a body at the start), ``point`` the contact on the body's surface, ``normal`` the
        body's outward normal there (pymunk's ``segment_query_first`` with a radius)."""
        return queries.cast(self, origins, directions, max_distance, False, mask, bodies,
                            radius)

    def point_query(self, points: Any, max_distance: float, mask: Any = None,
                    bodies: Any = None) -> queries.PointHits:
        """Nearest body to each point within max_distance (m, finite): ``body`` (N,), -1
        for none, and its signed distance (N,) m (< 0 inside, inf for none)."""
        return queries.nearest(self, points, max_distance, mask, bodies)

    def overlap_box(self, lo: Any, hi: Any, mask: Any = None,
                    bodies: Any = None) -> np.ndarray:
        """Indices (K,) int64, increasing, of the bodies whose shape overlaps the
        axis-aligned box [lo, hi] (each (2,), m); rule in ``queries.overlapping``."""
        return queries.overlapping(self, lo, hi, mask, bodies)
