"""The stages of ``World.step``, one function each, and what they share.

``World.step`` (``sdfphys/world.py``) calls them in order; docs/architecture.md maps each
stage to the module that implements it and docs/solver.md gives the design. Each stage
takes the world and the step's ``BodyState`` (``body_state``: the solver's view of the
body arrays, updated in place) and counts itself in ``World.stage_counts`` (keys:
``STAGES``) when it ran; a stage with nothing to do is skipped and not counted.
Falling asleep (stage 7) is ``world_sleep.fall_asleep``.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from . import world_sleep
from .collide import REACH_CAP_RADII, Contacts, compile_evaluator, find_contacts, shape_fields
from .collide import compile_ahead as collide_ahead
from .collide import compile_behind as collide_behind
from .collide.curvature import curvature_radii, turning_bodies
from .collide.filter import PairFilter
from .collide.narrowphase import PAIR_FUNCTIONS
from .events import StepReport, WorldContacts, sensor_overlaps
from .islands import island_roots
from .limits import MAX_BITS
from .shapes import Shape, collision_shape
from .solver import (
    BodyState,
    ContactConstraints,
    ImpulseCache,
    apply_restitution,
    prepare_contacts,
    solve_substeps,
)
from .solver import store_impulses as impulse_cache
from .solver.bundles import substep_rows
from .solver.softness import loaded_rows, row_softness_params
from .toi import Programs, fast_bodies, step_fractions, trace_ahead
from .world_bodies import DYNAMIC, STATIC

if TYPE_CHECKING:
    from .world import World

__all__ = ["PAIR_STAGES", "STAGES", "accelerations", "body_state", "collide",
           "collision_shapes", "compile_ahead", "compile_behind", "compile_later",
           "pair_filter", "prepare", "record", "restitution", "store_impulses", "substeps",
           "time_of_impact"]

#: Narrowphase stages, one per pair kind (``collide.narrowphase.PAIR_FUNCTIONS``):
#: ``circle_circle``, ``circle_mesh``, ..., ``sdf_sdf``, counted once per step in which
#: that pair function ran (some candidate pair of that kind was near enough).
PAIR_STAGES = tuple(f"{a}_{b}" for a, b in PAIR_FUNCTIONS)

#: The stages of ``World.step``, as counted in ``World.stage_counts``.
STAGES = ("collide",) + PAIR_STAGES + (
    "prepare", "integrate_velocities", "warm_start", "solve", "converge", "push_out",
    "integrate_positions", "relax", "joints", "friction", "restitution", "time_of_impact",
    "store_impulses")


def body_state(world: World) -> BodyState:
    """The solver's view; sleeping bodies take part with zero inverse mass."""
    v = world._view
    inv_mass, inv_inertia = v("inv_mass"), v("inv_inertia")
    asleep = v("asleep")
    if asleep.any():
        inv_mass = np.where(asleep, 0.0, inv_mass)
        inv_inertia = np.where(asleep, 0.0, inv_inertia)
    return BodyState(v("com"), v("angle"), v("velocity"), v("angular_velocity"),
                     inv_mass, inv_inertia, v("linear_damping"),
                     v("angular_damping"), v("round"), v("radius"))


def pair_filter(world: World) -> PairFilter | None:
    """The bodies' collision filter, or None while every body has the default
    category, mask and group and none is a sensor (then nothing is filtered and
    nothing computed); rebuilt, with ``_scaled``, after bodies are added or removed."""
    if world._filter_stale:
        v = world._view
        special = (np.any(v("category") != 1) or np.any(v("mask") != MAX_BITS)
                   or np.any(v("group") != 0) or np.any(v("sensor")))
        world._filter = (PairFilter(v("category"), v("mask"), v("group"), v("sensor"))
                         if special else None)
        world._scaled = bool(np.any(v("gravity_scale") != 1.0))
        world._filter_stale = False
    return world._filter


def accelerations(world: World) -> tuple[np.ndarray, np.ndarray] | None:
    """Per body, (linear (B, 2) m/s^2, angular (B,) rad/s^2): gravity_scale * gravity
    plus the held force / mass and torque / inertia, for the substeps; None while
    every gravity scale is 1 and no force is held (gravity alone, as before)."""
    pair_filter(world)                      # refreshes _scaled
    if not (world._forces or world._scaled):
        return None
    scale = world._view("gravity_scale")
    inv_mass = world._view("inv_mass")
    linear = scale[:, None] * world._gravity + world._view("force") * inv_mass[:, None]
    return linear, world._view("torque") * world._view("inv_inertia")


def collision_shapes(world: World) -> list[Shape]:
    """The distinct shapes as collisions see them under the field knobs."""
    s = world.settings
    return [collision_shape(shape, s.gradient, s.field_representation, s.grid_cell)
            for shape in world._shapes]


def collide(world: World, bodies: BodyState, active: np.ndarray | None) -> Contacts:
    """Stage 1: every contact closer than the speculative distance plus the pair's
    reach at the step's starting velocities (``sdfphys.collide``), once per step;
    each pair kind whose narrowphase ran is counted (PAIR_STAGES). active: (B,)
    bool, the bodies that move (``world_sleep.active``) with sleeping, None without: the
    dynamic ones. Pairs the collision filter rejects never reach the narrowphase;
    contacts with a sensor are kept aside (``_sensor_pass``, for ``events``) and get
    no row."""
    ran: set[tuple[str, str]] = set()
    movable = world._view("kind") == DYNAMIC if active is None else active
    filter_ = pair_filter(world)
    contacts = find_contacts(collision_shapes(world), world._view("shape_id"),
                             bodies.com, bodies.angle, movable, world.settings,
                             bodies.velocity, bodies.angular_velocity, ran,
                             exclude=world._joints.excluded_pairs(world._n),
                             pair_filter=filter_, cache=world._contact_cache)
    if filter_ is not None and filter_.has_sensors:
        sensor = filter_.sensor
        touches = sensor[contacts.body_a] | sensor[contacts.body_b]
        world._sensor_pass = (contacts.take(touches), movable)
        contacts = contacts.take(~touches)
    world._contacts = contacts
    world.stage_counts["collide"] += 1
    for a, b in ran:
        world.stage_counts[f"{a}_{b}"] += 1
    return world._contacts


def prepare(world: World, contacts: Contacts, bodies: BodyState) -> ContactConstraints:
    """Stage 2: anchors (at the centre of curvature of a turning sdf body's surface,
    ``collide.curvature``), masses, base separations, warm-start impulses."""
    curvature = None
    if world.settings.curvature_anchors and len(contacts):
        fields, canonical = shape_fields(collision_shapes(world))
        body_shape = canonical[world._view("shape_id")]
        turning = np.zeros(0, bool)                     # no sdf shape: none turns
        if fields.sdf.any():
            turning = fields.sdf[body_shape] & turning_bodies(
                world._view("kind") == STATIC, bodies.angular_velocity, bodies.radius,
                world.settings.dt)
        if turning.any():
            curvature = curvature_radii(fields, body_shape, bodies.com, bodies.angle, turning,
                                        contacts)
    constraints = prepare_contacts(contacts, bodies, world._view("friction"),
                                   world._view("restitution"), world._impulses,
                                   world.settings.warm_starting, world._gravity,
                                   world.settings.linear_slop, curvature)
    if len(constraints):
        world.stage_counts["prepare"] += 1
    return constraints


def substeps(world: World, constraints: ContactConstraints, bodies: BodyState,
             kernel_only: bool = False) -> np.ndarray | None:
    """Stage 3: per substep integrate v, warm start, solve, integrate x, relax; loaded
    islands (mass ratios, heavy loads: ``solver.row_softness``) get extra passes until
    converged, counted one by one as ``converge``; ``push_out`` counts the substeps
    with a row deeper than ``soft_depth`` (its overlap pushed out through
    pseudo-velocities, solver "Split push-out"); ``joints`` the solve and relax passes
    over the joints (each a Gauss-Seidel pass over the rows the islands' direct solves
    do not take, then those solves; ``solver.joint_direct``). kernel_only: see
    ``solve_substeps`` (``compile_ahead``). Returns the contacts' islands (B,) int64
    (``solve_substeps``; None with kernel_only)."""
    s = world.settings
    use_friction = bool((constraints.friction > 0.0).any())
    extra, push_outs, joint_runs, root = solve_substeps(
        bodies, constraints, world._gravity, s, use_friction,
        (world._joints.rows, world._joints.stiffness_cap), accelerations(world), kernel_only)
    counts = world.stage_counts
    counts["converge"] += extra
    counts["push_out"] += push_outs
    counts["joints"] += joint_runs
    counts["integrate_velocities"] += s.substeps
    counts["integrate_positions"] += s.substeps
    if len(constraints):
        counts["warm_start"] += s.substeps
        counts["solve"] += s.substeps
        counts["relax"] += s.substeps * s.relax_passes
    if use_friction:
        counts["friction"] += s.substeps * (1 + s.relax_passes)
    return root


def restitution(world: World, constraints: ContactConstraints, bodies: BodyState) -> None:
    """Stage 4: restitution passes, if some contact has restitution and approached fast.
    A row's restitution is the larger of its bodies' (``solver.rows``): with none among
    the bodies, no row is read."""
    if not np.any(world._view("restitution") > 0.0):
        return
    needed = (constraints.restitution > 0.0) & (
        constraints.relative_velocity < -world.settings.restitution_threshold)
    if needed.any():
        apply_restitution(bodies, constraints, world.settings)
        world.stage_counts["restitution"] += world.settings.restitution_passes


def time_of_impact(world: World, bodies: BodyState, start_com: np.ndarray,
                   start_angle: np.ndarray, contacts: Contacts) -> None:
    """Stage 5: fast bodies stopped at their time of impact (``sdfphys.toi``) against
    static and kinematic bodies, and against every body where they moved beyond their
    rows' reach (``_bullets``); a circle is not traced against a body it had a contact
    row with (``contacts``, this step's). A stopped body stops its joint group and the
    dynamic bodies it touches (``_stop_groups``)."""
    s = world.settings
    if not s.time_of_impact:
        return
    core = np.maximum(world._view("core_radius"), s.speculative_distance)
    radius = world._view("radius")
    fast = fast_bodies(start_com, bodies.com, core, world._view("kind") == DYNAMIC,
                       bodies.angle - start_angle, radius)
    if len(fast) == 0:
        return
    group = world._joints.groups(world._n)
    fraction = step_fractions([shape.field for shape in world._shapes],
                              [getattr(shape, "vertices", None) for shape in world._shapes],
                              world._view("shape_id"), start_com, bodies.com, start_angle,
                              bodies.angle, radius, core, fast, s.linear_slop, group,
                              pair_filter(world),
                              np.column_stack([contacts.body_a, contacts.body_b]),
                              _programs(world), world._view("kind") != DYNAMIC,
                              _bullets(start_com, bodies.com, start_angle, bodies.angle,
                                       radius, fast))
    fast, fraction = world._joints.spread_fractions(_stop_groups(world, fast, contacts),
                                                    fast, fraction)
    t = fraction[:, None]
    bodies.com[fast] = start_com[fast] + t * (bodies.com[fast] - start_com[fast])
    bodies.angle[fast] = start_angle[fast] + fraction * (bodies.angle[fast]
                                                         - start_angle[fast])
    world.stage_counts["time_of_impact"] += 1


def _bullets(start_com: np.ndarray, end_com: np.ndarray, start_angle: np.ndarray,
             end_angle: np.ndarray, radius: np.ndarray, fast: np.ndarray) -> np.ndarray:
    """(F,) bool: the ``fast`` bodies whose step carried a point of them farther
    (|c1 - c0| + |a1 - a0| r, r the bounding radius) than a contact row can reach
    (``collide.REACH_CAP_RADII`` r): their rows may not have seen what they crossed, and
    the time of impact traces them against every body (``toi.step_fractions``)."""
    travel = (np.hypot(*(end_com[fast] - start_com[fast]).T)
              + np.abs(end_angle[fast] - start_angle[fast]) * radius[fast])
    return travel > REACH_CAP_RADII * radius[fast]


def _stop_groups(world: World, fast: np.ndarray, contacts: Contacts) -> np.ndarray | None:
    """(B,) labels (``islands.island_roots``) of the bodies that stop together at a time
    of impact, or None if every body stops alone: bodies joined by joints (a forearm
    rewound alone opened its elbow, ``JointTable.spread_fractions``), and a fast body
    with the dynamic bodies it touches (a row of ``contacts`` within the speculative
    distance). A body put back alone along its path goes into what moved with it: in
    scenes/showcase.toml an L spinning with the sdf star it held was put back to 0.15
    of its step against the terrain, 22 mm into the star."""
    is_fast = np.zeros(world._n, bool)
    is_fast[fast] = True
    dynamic = world._view("kind") == DYNAMIC
    a, b = contacts.body_a, contacts.body_b
    touching = ((is_fast[a] | is_fast[b]) & dynamic[a] & dynamic[b]
                & (contacts.depth > -world.settings.speculative_distance))
    a, b = world._joints.linked(a[touching], b[touching])
    if len(a) == 0:
        return None
    return island_roots(np.ones(world._n), a, b)


def _programs(world: World) -> Programs:
    """The world's shapes' fields as programs for the traces (``toi.Programs``: the
    collisions' cached ``ShapeFields`` of the same shapes)."""
    fields, canonical = shape_fields(world._shapes)
    return fields.table, fields.program[canonical]


def store_impulses(world: World, constraints: ContactConstraints) -> None:
    """Stage 6: keep this step's impulses for the next step's warm start."""
    world._impulses = impulse_cache(constraints)
    world.stage_counts["store_impulses"] += 1


def record(world: World, rows: WorldContacts, relative_velocity: np.ndarray) -> None:
    """Stage 8: keep what ``events`` needs of this step (references; sensor overlaps, if
    any sensor took part, resolved now: they carry over steps that do not test them)."""
    s = world.settings
    before = world._report
    sensors = before.sensors[:0]
    if world._sensor_pass is not None:
        found, movable = world._sensor_pass
        sensors = sensor_overlaps(found, world._view("sensor"), before.sensors, movable)
        world._sensor_pass = None
    world._report = StepReport([world._contacts, world._sleep_contacts], before.touching,
                               sensors, before.sensors, rows, relative_velocity,
                               s.linear_slop, s.hit_speed)


def compile_ahead(world: World, early: bool = False) -> None:
    """What the compiling child (``sdfphys._warm``) runs in its copy of the world, for
    the kernels' sake: the substep kernel (alone, on no contacts); unless ``early`` (the
    parent then compiles it for the SDF bodies' masses), the field evaluator where a
    step may evaluate a field (``collide.compile_evaluator``); the collisions' pair
    functions that are no closed form (descents, field programs) of the pairs meeting
    now, from the last group to the first (``collide.compile_ahead``); then the other
    stages after the preparation of the contact rows, on no contacts, last stage first
    (the restitution only where some body has it); the later steps' kernels
    (``compile_later``); the pairs that may meet in a later step (``compile_ahead``'s
    ``later``); the row softness last. The parent starts from the other end (its first
    frame's field evaluator, the closed-form contacts, the first groups) and compiles
    the end of the collisions, the row softness, the preparation and the restitution
    while it waits for the child (``compile_behind``; docs/performance.md, "Start-up
    and the numba cache")."""
    bodies = body_state(world)
    constraints = ContactConstraints.empty()
    substeps(world, constraints, bodies, kernel_only=True)
    if not early:
        compile_evaluator(collision_shapes(world))
    movable = world._view("kind") == DYNAMIC
    pairs = (collision_shapes(world), world._view("shape_id"), bodies.com, bodies.angle,
             movable, world.settings)
    collide_ahead(*pairs)
    if world.settings.sleeping:
        world_sleep.fall_asleep(world, bodies, constraints, bodies.com.copy(),
                                bodies.angle.copy(), world_sleep.awake(world),
                                world_sleep.active(world))
    if (world._view("restitution") > 0.0).any():
        apply_restitution(bodies, constraints, world.settings)
    compile_later(world, bodies)
    collide_ahead(*pairs, later=True)
    substeps(world, constraints, bodies)


def compile_behind(world: World) -> list[Callable[[], None]]:
    """The parent's share of a cold start's compiling (``sdfphys._warm``): jobs that run
    the first step's last stages on no contacts, for the kernels' sake, while it waits
    for a kernel the compiling child holds (``_compile_lock.while_waiting``): the end of
    the collision query where some pair is no closed form (``collide.compile_behind``),
    the row softness, the preparation, the restitution (where some body has it), in the
    order a step meets them. They act on copies of the bodies made now: the world does
    not change."""
    bodies = copy.deepcopy(body_state(world))
    settings, gravity = world.settings, np.array(world._gravity, np.float64)

    def softness() -> None:
        empty = ContactConstraints.empty()
        rows = substep_rows(empty, np.empty(0), np.empty(0), np.empty(0))
        loaded_rows(bodies.inv_mass, rows, row_softness_params(settings, gravity),
                    np.zeros(len(bodies.inv_mass), np.bool_))

    def preparation() -> None:
        prepare(world, Contacts.empty(), bodies)

    def restitution() -> None:
        apply_restitution(bodies, ContactConstraints.empty(), settings)

    def later() -> None:
        compile_later(world, bodies)

    bouncy = bool(np.any(world._view("restitution") > 0.0))     # else never needed
    shapes = collide_behind(collision_shapes(world), world._view("shape_id"), settings)
    return shapes + [softness, preparation] + ([restitution] if bouncy else []) + [later]


def compile_later(world: World, bodies: BodyState) -> None:
    """For a cold start's two processes (``sdfphys._warm``), once the first step's kernels
    are done: the kernels a first step does not call and the next steps do, on one
    made-up row with the argument types of a step's calls. The warm start's match
    against the impulses a step left (``ImpulseCache.match``: by key, then by place;
    with ``warm_starting``), with ``sleeping``, the islands falling asleep once a body
    has rested ``time_to_sleep`` (``world_sleep.islands_falling``), and with
    ``time_of_impact``, the traces of a fast body (``toi.trace_ahead``). Changes
    nothing: the child compiles them while the parent ends its first step
    (``compile_ahead``), the parent while it waits for the child (``compile_behind``)."""
    s = world.settings
    if s.warm_starting:
        ints = np.zeros(1, np.int64)
        ImpulseCache(ints, ints + 1, ints, np.zeros(1), np.zeros(1), np.zeros((1, 2))).match(
            ints.copy(), ints + 1, ints + 1, np.zeros((1, 2)), float(s.linear_slop))
    if s.sleeping:
        world_sleep.islands_falling(world, bodies, ContactConstraints.empty(),
                                    world_sleep.awake(world))
    if s.time_of_impact:
        trace_ahead(_programs(world))
