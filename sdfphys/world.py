"""World: body state as arrays, bodies added and removed, and ``step()``.

Body state is a struct of arrays, split hot and cold as in Box2D v3 (``world_bodies``:
the body table). Body indices are the order of ``add_body`` calls (scene order);
``remove_body(i)`` shifts the later bodies down by one. ``add_body`` returns a ``Body``
handle that follows its body's index through removals (``World.body(name)`` too).

Frames: a body's frame has its origin at the centre of mass; the shape's ``origin`` is
where the user's frame origin (a scene's ``position``) sits in it, so the centre of
mass of a body at user pose (p, a) is com = p - R(a) origin, and ``position`` reports
p = com + R(a) origin. ``velocity`` is the centre of mass's (as pymunk's
``Body.velocity``), ``angular_velocity`` is counter-clockwise, rad/s.

Kinds: ``dynamic`` bodies have mass and feel gravity and contacts; ``static`` bodies
never move; ``kinematic`` bodies move with their velocity and are pushed by nothing.
Static and kinematic bodies have zero inverse mass and inertia (``mass`` reports inf).
Materials mix per contact: friction sqrt(f_a f_b), restitution max(e_a, e_b).

This module is the public class; its parts live beside it: ``world_bodies`` (the body
arrays, ``Body`` handles, adding and removing), ``world_stages`` (the stages of
``step``), ``world_sleep`` (sleeping islands), ``world_forces`` (forces, impulses,
blasts); the joints' methods come from ``joints.WorldJoints``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from . import _warm, queries, rays, scheduled, terrain, world_bodies, world_forces, world_sleep
from . import world_stages as stage
from .blasts import Blast, check_blast, fire_due
from .collide import ContactCache, Contacts
from .collide.filter import PairFilter
from .errors import SpecError
from .events import Events, StepReport, WorldContacts
from .joints import JointTable, WorldJoints
from .limits import (
    KINDS,
    MAX_BITS,
    check_angle,
    check_angular_velocity,
    check_body,
    check_gravity,
    check_position,
    check_velocity,
)
from .sdf.build import suggest
from .settings import Settings
from .shapes import Shape, shape_from_spec
from .solver import ImpulseCache
from .vec2 import rotate
from .world_bodies import (
    ARRAYS,
    DYNAMIC,
    STATIC,
    Body,
    add,
    check_index,
    read_only,
    rotate_one,
)
from .world_stages import PAIR_STAGES, STAGES

__all__ = ["KINDS", "PAIR_STAGES", "STAGES", "Body", "World"]


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
                      for name, (shape, dtype) in ARRAYS.items()}
        self._shapes: list[Shape] = []
        self._shape_index: dict[int, int] = {}
        self._names: list[str] = []
        self._name_set: set[str] = set()
        self._shape_rows: dict[int, tuple] = {}
        self._created = 0
        self._contacts = WorldContacts.empty()
        self._impulses = ImpulseCache.empty()
        # Sleeping islands' contacts and impulses, kept for their warm start (``world_sleep``).
        self._sleep_contacts = WorldContacts.empty()
        self._sleep_impulses = ImpulseCache.empty()
        self._contact_cache = ContactCache()   # descent pairs' kept contacts (``collide``)
        self._islands_made = 0
        self._joints = JointTable()     # ``joints.WorldJoints``
        self._filter: PairFilter | None = None   # ``world_stages.pair_filter``
        self._filter_stale = False
        self._scaled = False            # some gravity_scale is not 1 (``pair_filter``)
        self._forces = False            # some force or torque held for the next step
        self._report = StepReport()     # ``events``
        self._sensor_pass: tuple[Contacts, np.ndarray] | None = None
        self._blasts: list[Blast] = []  # ``explode_at``, by time
        self._scheduled: list[terrain.Edit] = []    # ``terrain.schedule``: [[carve]]

    # Waking the bodies resting on one, as a method: ``joints.WorldJoints`` (a base of
    # this class) and ``terrain`` call it on a world.
    _wake_touching = world_sleep.wake_touching

    # ----------------------------------------------------------------------------------
    # Bodies
    # ----------------------------------------------------------------------------------

    @property
    def gravity(self) -> np.ndarray:
        """(2,) m/s^2, a read-only copy; assign a pair to change it (checked: finite,
        magnitude at most ``limits.MAX_GRAVITY``). Setting it wakes every sleeping
        island."""
        return read_only(self._gravity.copy())

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
                 linear_damping: float = 0.0, angular_damping: float = 0.0,
                 category: int = 1, mask: int = MAX_BITS, group: int = 0,
                 sensor: bool = False, gravity_scale: float = 1.0) -> Body:
        """Add a body and return its handle (``Body``: its index now, and wherever an
        index goes, valid while other bodies are removed).

        shape: a Shape or a scene shape dict (``{"type": "circle", "radius": 0.5}``).
        position: (2,) m, where the user frame origin goes; angle: rad.
        velocity: (2,) m/s of the centre of mass; angular_velocity: rad/s.
        density: kg/m^2, or ``mass`` (kg) which overrides it; inertia follows the shape.
        friction >= 0, restitution in [0, 1]. kind: dynamic | static | kinematic.
        name: unique; default ``body<k>`` with k counting every body ever added.
        linear_damping, angular_damping: 1/s (v / (1 + h c) per substep).
        category, mask (64-bit fields), group (signed): the collision filter, Box2D's
        rule (``collide.filter``); sensor: reports overlaps (``events``), takes no
        contact response; gravity_scale: the body feels gravity_scale * gravity.
        Every value is checked as a scene's (``limits``: finite, within the documented
        ranges); a bad one raises SpecError naming the argument, e.g.
        ``position[0]: must be finite, got nan``.
        """
        shape = shape_from_spec(shape)
        values = check_body(position=position, angle=angle, velocity=velocity,
                            angular_velocity=angular_velocity, density=density, mass=mass,
                            friction=friction, restitution=restitution, kind=kind,
                            linear_damping=linear_damping, angular_damping=angular_damping,
                            category=category, mask=mask, group=group, sensor=sensor,
                            gravity_scale=gravity_scale)
        if name is not None and (not isinstance(name, str) or not name):
            raise SpecError("name", f"must be a non-empty string, got {name!r}")
        if kind == "dynamic" and not math.isfinite(shape.radius):
            raise SpecError("shape", "an unbounded shape can only be static")
        i = add(self, shape, values, name)      # may grow the arrays: index them after
        return Body(self, int(self._data["uid"][i]))

    def body(self, name: str) -> Body:
        """The handle of the body named ``name`` (KeyError, with the nearest name, if
        there is none)."""
        if name not in self._name_set:
            raise KeyError(f"no body named {name!r}" + suggest(str(name), self._names))
        i = self._names.index(name)
        return Body(self, int(self._data["uid"][i]))

    def __getstate__(self) -> dict:
        """``pickle`` and ``copy.deepcopy``: everything but the caches keyed by object
        identity (rebuilt by ``__setstate__``); the copy steps on bit for bit as the
        original."""
        state = self.__dict__.copy()
        state["_shape_rows"] = {}
        state["_shape_index"] = None
        state["_filter"] = None
        state["_filter_stale"] = True
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._shape_index = {id(shape): k for k, shape in enumerate(self._shapes)}

    def remove_body(self, index: int | Body) -> None:
        """Remove body ``index``; later bodies move down one index (their contacts too).
        Sleeping islands it belonged to or touched wake up."""
        i = check_index(self, index)
        world_sleep.wake_touching(self, i)
        world_bodies.remove(self, i)

    def set_state(self, index: int | Body, *, position: Any = None, angle: float | None = None,
                  velocity: Any = None, angular_velocity: float | None = None) -> None:
        """Set a body's pose (user frame origin, m; rad) and/or velocities (m/s, rad/s).

        Changing only the angle turns the body about its user origin. Static bodies
        may be moved but not given a velocity. The body's sleeping island, and the
        islands it touches, wake up. Values are checked as ``add_body``'s (SpecError
        naming the argument); nothing changes if one is bad.
        """
        i = check_index(self, index)
        d = self._data
        if position is not None:
            position = check_position(position, "position")
        if angle is not None:
            angle = check_angle(angle, "angle")
        if velocity is not None:
            velocity = check_velocity(velocity, "velocity")
        if angular_velocity is not None:
            angular_velocity = check_angular_velocity(angular_velocity, "angular_velocity")
        if d["kind"][i] == STATIC and ((velocity is not None and velocity != (0.0, 0.0))
                                       or angular_velocity not in (None, 0.0)):
            raise SpecError("velocity", "a static body cannot move; use kind='kinematic'")
        world_sleep.wake_touching(self, i)
        if position is not None or angle is not None:
            user = self.position[i] if position is None else np.array(position)
            if angle is not None:
                d["angle"][i] = angle
            d["com"][i] = user - rotate_one(d["origin"][i], float(d["angle"][i]))
        if velocity is not None:
            d["velocity"][i] = velocity
        if angular_velocity is not None:
            d["angular_velocity"][i] = angular_velocity

    def _view(self, name: str) -> np.ndarray:
        return self._data[name][:self._n]

    # ----------------------------------------------------------------------------------
    # Step (``sdfphys.world_stages``, docs/architecture.md)
    # ----------------------------------------------------------------------------------

    def step(self) -> None:
        """Advance the world by ``settings.dt`` (docs/solver.md, "One step").

        Stages: blasts due (``explode_at``); collide once; prepare the contact rows
        (warm start matched by feature key); the substeps (each: integrate velocities,
        warm start, solve, integrate positions, relax); restitution; time of impact for
        fast bodies; store impulses; with ``settings.sleeping``, islands at rest fall
        asleep (``sdfphys.sleep``): a step with no awake dynamic and no moving kinematic
        body only advances the time, and sleeping islands within contact range of an
        active body wake first.
        Afterwards ``contacts`` carry the step's impulses and ``events`` its events;
        forces and torques held by ``apply_force`` and ``apply_torque`` are released.
        """
        if self.step_count == 0:
            _warm.start(self)
        if self._scheduled:
            terrain.apply_due(self)
        if self._blasts:
            fire_due(self)
        sleeping = self.settings.sleeping
        # What moves this step (awake dynamic bodies, moving kinematic ones), None
        # without sleeping: changed within a step only by waking islands.
        active = world_sleep.active(self) if sleeping else None
        if not sleeping or active.any():
            bodies = stage.body_state(self)
            start_com, start_angle = bodies.com.copy(), bodies.angle.copy()
            contacts = stage.collide(self, bodies, active)
            if sleeping:
                if world_sleep.wake_reached(self, contacts, active):
                    active = world_sleep.active(self)
                    bodies = stage.body_state(self)
                    contacts = stage.collide(self, bodies, active)
                # Kinematic-static pairs, found because moving kinematic bodies were
                # movable for the wake test, carry no row.
                awake = world_sleep.awake(self)
                keep = awake[contacts.body_a] | awake[contacts.body_b]
                if not keep.all():
                    self._contacts = contacts = contacts.take(keep)
            constraints = stage.prepare(self, contacts, bodies)
            islands = stage.substeps(self, constraints, bodies)
            stage.restitution(self, constraints, bodies)
            stage.time_of_impact(self, bodies, start_com, start_angle, contacts)
            stage.store_impulses(self, constraints)
            self._contacts = rows = WorldContacts.of(contacts, constraints.total_normal_impulse,
                                                     constraints.total_tangent_impulse)
            if sleeping:
                world_sleep.fall_asleep(self, bodies, constraints, start_com, start_angle,
                                        awake, active, islands)
            stage.record(self, rows, constraints.relative_velocity)
        else:
            self._report = self._report.idle()
        if self._forces:
            self._data["force"][:self._n] = 0.0
            self._data["torque"][:self._n] = 0.0
            self._forces = False
        self.time += self.settings.dt
        self.step_count += 1

    @property
    def events(self) -> Events:
        """The last step's events (``events.Events``, docs/toolkit.md): ``begin``,
        ``end`` (K, 2) body pairs (lower index first) that started / stopped touching,
        ``sensor_begin``, ``sensor_end`` (K, 2) (sensor, visitor) rows, ``hit``
        (``events.Hits``: body_a, body_b, point, normal, speed > ``Settings.hit_speed``).
        Empty before the first step and after a step that moved nothing. Computed on
        first request from what the step kept (a step costs nothing for it)."""
        return self._report.events(self._n)

    @property
    def sensor_overlaps(self) -> np.ndarray:
        """(K, 2) int64 (sensor, visitor) pairs overlapping after the last step."""
        return read_only(self._report.sensors.copy())

    # ----------------------------------------------------------------------------------
    # Forces, impulses and blasts (``sdfphys.world_forces``)
    # ----------------------------------------------------------------------------------

    def apply_force(self, i: Any, force: Any, point: Any = None) -> None:
        """Hold ``force`` (N, (2,) or (N, 2)) on body ``i`` (an index or (N,) indices)
        for the next step, at world ``point`` (m, (2,) or (N, 2); None: the centre of
        mass, no torque): every substep adds h F / m to the velocity and h (r x F) / I to
        the angular velocity (r = point - centre of mass when applied). Forces add up
        (repeated indices too) and are released after the step. Static and kinematic
        bodies ignore them; sleeping ones wake."""
        idx, f = world_forces.targets(self, i, force, "force")
        torque = world_forces.lever(self, idx, f, point)
        np.add.at(self._data["force"], idx, f)
        np.add.at(self._data["torque"], idx, torque)
        self._forces = True
        world_sleep.wake_bodies(self, idx)

    def apply_torque(self, i: Any, torque: Any) -> None:
        """Hold ``torque`` (N m, counter-clockwise; a number or (N,)) on body ``i`` (an
        index or (N,) indices) for the next step (as ``apply_force``)."""
        idx, t = world_forces.targets(self, i, torque, "torque", width=1)
        np.add.at(self._data["torque"], idx, t)
        self._forces = True
        world_sleep.wake_bodies(self, idx)

    def apply_impulse(self, i: Any, impulse: Any, point: Any = None) -> None:
        """Apply ``impulse`` (N s, (2,) or (N, 2)) to body ``i`` (an index or (N,)
        indices) now, at world ``point`` (m; None: the centre of mass): v += J / m,
        w += (r x J) / I. Static and kinematic bodies ignore it; sleeping ones wake."""
        idx, j = world_forces.targets(self, i, impulse, "impulse")
        torque = world_forces.lever(self, idx, j, point)
        world_sleep.wake_bodies(self, idx)
        np.add.at(self._data["velocity"], idx, j * self._view("inv_mass")[idx, None])
        np.add.at(self._data["angular_velocity"], idx, torque * self._view("inv_inertia")[idx])

    def explode(self, center: Any, radius: float, impulse: float) -> np.ndarray:
        """A blast at ``center`` (2,) m: every dynamic body whose surface is within
        ``radius`` (m, > 0) of it gets, at its surface point nearest the centre, an
        impulse pointing away from the centre of ``impulse`` (N s per metre, >= 0) times
        the body's width facing the blast (its extent across the blast direction; Box2D
        v3's impulse per length). A circle of radius r at distance d gets 2 r impulse
        along its centre's direction, no spin. A body the centre lies inside is pushed
        from its centre of mass. Widths: exact for circles and polygons, the body-frame
        bounding box's for SDF bodies. Returns the indices of the bodies pushed (sleeping
        ones wake)."""
        return world_forces.explode(self, center, radius, impulse)

    def explode_at(self, time: float, center: Any, radius: float, impulse: float) -> None:
        """Schedule ``explode(center, radius, impulse)`` for the start of the first step
        that begins at or after ``time`` (s, >= 0; a step begins at ``self.time``, and
        one within a millionth of a step before ``time`` counts: ``sdfphys.scheduled``). A
        time already past runs at the next step. A scene's ``[[explode]]`` tables
        schedule these (docs/toolkit.md)."""
        blast = check_blast(time=time, center=center, radius=radius, impulse=impulse)
        scheduled.add(self._blasts, (blast,))

    # ----------------------------------------------------------------------------------
    # Editable terrain (``sdfphys.terrain``, docs/terrain.md)
    # ----------------------------------------------------------------------------------

    def carve(self, body: Any, field: Any, position: Any, angle: float = 0.0) -> None:
        """Remove ``field`` (a FIELD dict such as ``{"type": "circle", "radius": 0.3}``,
        or a Field), its origin placed at world ``position`` (2,) m and turned by
        ``angle`` rad, from ``body`` (an index, name or Body; bounded).

        The body's field becomes a baked grid at its first edit (an analytic field at
        ``settings.carve_cell``, m) and is edited in place: max(v, -c) on the nodes the
        field's bounds cover, then re-distanced (``sdf.edit``); the part beyond the grid
        is clipped. Bodies resting on it wake; its contacts and warm starts are dropped.
        A dynamic body takes the mass, centre of mass and inertia of what is left, and
        each further piece cut off becomes a new body named ``<name>.<k>``, appended
        (``sdfphys.pieces``); a body carved to nothing is removed.
        Bad input (unknown or unbounded body, NaN position, bad FIELD) raises SpecError
        naming it.
        """
        terrain.edit(self, body, field, position, angle, deposit=False)

    def deposit(self, body: Any, field: Any, position: Any, angle: float = 0.0) -> None:
        """Add ``field`` to static or kinematic ``body``: min(v, c) instead of
        ``carve``'s max(v, -c); the rest as ``carve`` (a deposit reaching beyond the grid
        is clipped at its edge; a dynamic body raises SpecError)."""
        terrain.edit(self, body, field, position, angle, deposit=True)

    def field(self, body: Any) -> Any:
        """Body ``body``'s current field (a Field: m, < 0 inside) in its own frame, the
        one its ``position`` and ``angle`` place: after edits, the edited grid."""
        return terrain.user_field(self, body)

    # ----------------------------------------------------------------------------------
    # Sleeping (``sdfphys.sleep``, ``sdfphys.world_sleep``)
    # ----------------------------------------------------------------------------------

    def wake(self) -> None:
        """Wake every sleeping island."""
        world_sleep.wake_islands(self, self._view("island")[self._view("asleep")])

    # ----------------------------------------------------------------------------------
    # State (read-only copies, scene order: set_state changes a body)
    # ----------------------------------------------------------------------------------

    def __len__(self) -> int:
        return self._n

    @property
    def position(self) -> np.ndarray:
        """(B, 2) m, world position of each body's user frame origin."""
        return read_only(self._view("com") + rotate(self._view("origin"),
                                                    self._view("angle")))

    @property
    def center_of_mass(self) -> np.ndarray:
        """(B, 2) m, world position of each body's centre of mass."""
        return read_only(self._view("com").copy())

    @property
    def angle(self) -> np.ndarray:
        """(B,) rad, counter-clockwise."""
        return read_only(self._view("angle").copy())

    @property
    def velocity(self) -> np.ndarray:
        """(B, 2) m/s, velocity of each centre of mass."""
        return read_only(self._view("velocity").copy())

    @property
    def angular_velocity(self) -> np.ndarray:
        """(B,) rad/s, counter-clockwise."""
        return read_only(self._view("angular_velocity").copy())

    @property
    def contacts(self) -> Contacts:
        """The contacts found at the start of the last step (empty before the first),
        with those of sleeping islands as they fell asleep; sorted by (body_a, body_b,
        feature)."""
        if len(self._sleep_contacts) == 0:
            return self._contacts
        c = WorldContacts.concatenate([self._contacts, self._sleep_contacts])
        return c.take(np.lexsort((c.feature, c.body_b, c.body_a)))

    @property
    def asleep(self) -> np.ndarray:
        """(B,) bool: bodies of sleeping islands (``settings.sleeping``)."""
        return read_only(self._view("asleep").copy())

    @property
    def shapes(self) -> list[Shape]:
        """Distinct Shape objects; ``shape_id`` indexes into this list."""
        return list(self._shapes)

    @property
    def shape_id(self) -> np.ndarray:
        """(B,) int64, each body's index into ``shapes``."""
        return read_only(self._view("shape_id").copy())

    @property
    def names(self) -> list[str]:
        return list(self._names)

    @property
    def mass(self) -> np.ndarray:
        """(B,) kg (inf for static and kinematic bodies)."""
        return read_only(self._view("mass").copy())

    @property
    def inertia(self) -> np.ndarray:
        """(B,) kg m^2 about the centre of mass (inf for static and kinematic bodies)."""
        return read_only(self._view("inertia").copy())

    @property
    def kind(self) -> np.ndarray:
        """(B,) str: dynamic | static | kinematic."""
        return read_only(np.array(KINDS)[self._view("kind")])

    @property
    def friction(self) -> np.ndarray:
        """(B,) friction coefficients."""
        return read_only(self._view("friction").copy())

    @property
    def restitution(self) -> np.ndarray:
        """(B,) restitution coefficients."""
        return read_only(self._view("restitution").copy())

    def kinetic_energy(self) -> float:
        """J: sum over dynamic bodies of m |v|^2 / 2 + I w^2 / 2."""
        dynamic = self._view("kind") == DYNAMIC
        v, w = self._view("velocity")[dynamic], self._view("angular_velocity")[dynamic]
        return float(0.5 * np.sum(self._view("mass")[dynamic] * np.sum(v * v, axis=1))
                     + 0.5 * np.sum(self._view("inertia")[dynamic] * w * w))

    def potential_energy(self) -> float:
        """J: sum over dynamic bodies of -m g.com (zero at the origin, so at y = 0 for
        vertical gravity)."""
        dynamic = self._view("kind") == DYNAMIC
        return float(-np.sum(self._view("mass")[dynamic]
                             * (self._view("com")[dynamic] @ self.gravity)))

    # ----------------------------------------------------------------------------------
    # Queries (``sdfphys.rays``, ``sdfphys.queries``, docs/queries.md)
    # ----------------------------------------------------------------------------------

    def ray_cast(self, origins: Any, directions: Any, max_distance: float = math.inf,
                 mask: Any = None, bodies: Any = None) -> queries.RayHits:
        """Closest hit of each ray (``queries.RayHits``: body (N,), -1 for none; point
        (N, 2) m; normal (N, 2); distance (N,) m, 0 for a ray starting inside a body).

        origins, directions: (N, 2) (a direction's length does not matter, it must not
        be zero); max_distance: m, >= 0. bodies: an index array limiting the bodies
        hit (None: all); mask: reserved for collision categories (None)."""
        return rays.cast(self, origins, directions, max_distance, False, mask, bodies)

    def ray_cast_all(self, origins: Any, directions: Any, max_distance: float = math.inf,
                     mask: Any = None, bodies: Any = None) -> queries.RayHits:
        """Every body each ray enters within max_distance, as flat arrays (H,) sorted
        by (ray, distance): ``ray`` (H,) the ray index, ``body``, ``point``, ``normal``,
        ``distance`` as ``ray_cast``'s (each body once, at its first entry)."""
        return rays.cast(self, origins, directions, max_distance, True, mask, bodies)

    def circle_cast(self, origins: Any, directions: Any, radius: float,
                    max_distance: float = math.inf, mask: Any = None,
                    bodies: Any = None) -> queries.RayHits:
        """``ray_cast`` of a disc of ``radius`` (m, >= 0) swept from each origin: the first
        body it touches; ``distance`` is how far its centre travelled (0 if it overlaps
        a body at the start), ``point`` the contact on the body's surface, ``normal`` the
        body's outward normal there (pymunk's ``segment_query_first`` with a radius)."""
        return rays.cast(self, origins, directions, max_distance, False, mask, bodies,
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
