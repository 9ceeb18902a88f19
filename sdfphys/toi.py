"""Time of impact for fast bodies: conservative advancement on the signed distance fields.

A body that moves more than about half its smallest extent in one step can pass
through a thin obstacle between two collision queries. After the substeps, each such
fast body's centre-of-mass path over the step, c(t) = c0 + t (c1 - c0) for t in
[0, 1], is sphere-traced against the field f of every other nearby body at its end
pose: f is 1-Lipschitz (exact SDFs, and the bounds the sdf module marks inexact, never
exceed the true distance), so while a disc of radius r about c(t) stays clear,
f(c(t)) - r is a distance the disc can travel without touching, and

    t <- t + (f(c(t)) - r - slop) / |c1 - c0|

never steps past the first contact (conservative advancement; Mirtich 1996, Tang et
al. 2009 for the SDF form). The trace stops when the gap f - r is below 2 slop, and the
body is put back at that time: its separation then lies in [slop, 2 slop], inside the
speculative distance, so the next step's contacts catch it. Its velocity is kept.

Which disc. The bounding disc (``Shape.radius`` about the centre of mass) holds the
whole body at any rotation, so tracing it never lets any part of the body touch. For
a circle it is exact; for a box or polygon it stops early by up to radius - core (the
body's corner direction versus its face direction). If the bounding disc already
touches at t = 0 (an earlier trace stopped it there, or it is resting on something),
the core disc is traced instead: the largest disc about the centre of mass inside the
body (-f_body(0), at least the speculative distance), like Box2D v3's fallback to the
centroid. That lets a body stopped early finish its approach; corners may then reach
into the obstacle by up to radius - core, which the next step's contacts push out. A
pair whose core disc already touches is left to the contact solver (resting contact,
sliding along the ground).

Rotation (``vertex_time_of_impact``). The discs are about the centre of mass, so they
do not see a body turning: a plank whose near end strikes the ground spins up and
swings its far end down through the surface within one step. For polygons (meshes),
each vertex v is traced along the body's interpolated motion, centre c(t) as above and
angle a(t) = a0 + t (a1 - a0), so p(t) = c(t) + R(a(t)) v. No point of the body moves
faster than |c1 - c0| + |a1 - a0| |v| per unit of t, so with that bound L the same
step t <- t + (f(p(t)) - slop) / L is conservative (Mirtich 1996's bound for a rotating
body). Vertices already within 2 slop of the obstacle at t = 0 are left to the contact
solver (the near end resting on the ground), as the core disc is. Between obstacles
with corners an edge of the polygon may still cross a corner while its vertices stay
clear; against faces (the ground, walls) the vertices are exact.

Not traced: fast bodies against each other (each is traced only against bodies that
are not fast), and the motion of the obstacle during the step (its end pose is used).
The world traces fast bodies against static and kinematic bodies only, as Box2D v3
does its non-bullet bodies (``step_fractions``' ``obstacles``); dynamic pairs are left
to their contact rows, whose margin grows with the bodies' reach, but for bodies that
moved beyond that reach (``bullets``), traced against every body.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ._toi_kernels import trace
from .collide.broadphase import candidate_pairs
from .sdf import Field, compiled
from .sdf.program_table import ProgramTable

__all__ = ["fast_bodies", "step_fractions", "time_of_impact", "trace_ahead",
           "vertex_time_of_impact"]

#: Conservative-advancement iterations per pair; a trace still running after them stops
#: where it is, which is safe (never past a contact) and only stops the body early.
MAX_ITERATIONS = 32

#: The shapes' fields as programs: a ``ProgramTable`` and, per shape, its program in it
#: (-1: the field does not compile). With every traced target's field compiled, the
#: traces run in one compiled call (``_toi_kernels.trace``, the same stop times).
Programs = tuple[ProgramTable | None, np.ndarray]


def fast_bodies(start: np.ndarray, end: np.ndarray, core_radius: np.ndarray,
                movable: np.ndarray, turn: np.ndarray | None = None,
                radius: np.ndarray | None = None) -> np.ndarray:
    """Indices (F,) of movable bodies whose centre moved, or whose outline turned (if
    ``turn`` and ``radius`` are given), by more than half their core radius.

    start, end: (B, 2) centre-of-mass positions before and after the step, m;
    core_radius: (B,) m, the smallest extent about the centre of mass; movable: (B,) bool.
    turn: (B,) rad, the angle each body turned in the step; radius: (B,) m, bounding
    radius about the centre of mass (a point at it moves |turn| radius).
    """
    d = end - start
    moved2 = d[:, 0] ** 2 + d[:, 1] ** 2
    fast = moved2 > (0.5 * core_radius) ** 2
    if turn is not None and radius is not None:
        with np.errstate(invalid="ignore"):
            fast |= np.abs(turn) * radius > 0.5 * core_radius
    return np.flatnonzero(movable & fast)


def _candidate_pairs(fast: np.ndarray, start: np.ndarray, end: np.ndarray,
                     radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(fast body, other body) pairs whose swept box meets the other's bounding box.

    Boxes: the fast body's segment inflated by its bounding radius; the other body's
    end position inflated by its radius (infinite for unbounded fields). Fast bodies
    are not candidates for each other. Returns (index into ``fast``, body index),
    sorted, found by the broadphase (``collide.broadphase.candidate_pairs``: the grid,
    O(bodies + pairs)), never by comparing every fast body with every body.
    """
    is_fast = np.zeros(len(radius), bool)
    is_fast[fast] = True
    with np.errstate(invalid="ignore"):
        lo = end - radius[:, None]
        hi = end + radius[:, None]
    lo[fast] = np.minimum(start[fast], end[fast]) - radius[fast, None]
    hi[fast] = np.maximum(start[fast], end[fast]) + radius[fast, None]
    pairs = candidate_pairs(np.column_stack([lo, hi]), is_fast)
    i, j = pairs[:, 0], pairs[:, 1]
    one = is_fast[i] != is_fast[j]
    i, j = i[one], j[one]
    body, other = np.where(is_fast[i], i, j), np.where(is_fast[i], j, i)
    slot = np.empty(len(radius), np.int64)
    slot[fast] = np.arange(len(fast))
    order = np.lexsort((other, slot[body]))
    return slot[body][order], other[order]


def _distance(fields: list[Field], shape_id: np.ndarray, com: np.ndarray,
              angle: np.ndarray, target: np.ndarray, points: np.ndarray,
              gradient: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """f_target(points): each point (P, 2, world) in the body frame of its target (P,).

    One field evaluation per distinct target shape (instancing), through the field's
    compiled program where it compiles (``sdf.compiled.distance``; the numpy
    ``distance`` otherwise): the same values as the numpy fields, bit for bit but for
    the kinds listed in ``sdf.compiled``'s "Rounding" (an ulp or so), and the values
    the contact pipeline's compiled queries see. gradient: also return the field's
    gradient (P, 2) turned into the world frame (``sdf.compiled.evaluate``).
    """
    rel = points - com[target]
    c, s = np.cos(angle[target]), np.sin(angle[target])
    local = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]])
    d = np.empty(len(points))
    g = np.empty((len(points), 2))
    ids = shape_id[target]
    for sid in np.unique(ids):
        rows = np.flatnonzero(ids == sid)
        if gradient:
            d[rows], g[rows] = compiled.evaluate(fields[sid], local[rows])
        else:
            d[rows] = compiled.distance(fields[sid], local[rows])
    if not gradient:
        return d
    return d, np.column_stack([c * g[:, 0] - s * g[:, 1], s * g[:, 0] + c * g[:, 1]])


def _advance(gap: np.ndarray, speed: np.ndarray, slop: float,
             gap_at: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> np.ndarray:
    """Conservative advancement of R independent traces; the stop time of each (R,), inf
    for a trace that reaches t = 1 clear.

    gap: (R,) m, the clearance at t = 0; speed: (R,) m per unit of t, a bound on how fast
    the clearance can shrink; gap_at(rows, t): the clearance of traces ``rows`` at times
    ``t``. A trace runs while its gap exceeds 2 slop and it moves; each advancement
    t <- t + (gap - slop) / speed never passes the first contact (module docstring). A
    trace still running after MAX_ITERATIONS stops where it is (safe, early).
    """
    t = np.zeros(len(gap))
    stop = np.full(len(gap), np.inf)
    active = (gap > 2.0 * slop) & (speed > 0.0)
    for _ in range(MAX_ITERATIONS):
        rows = np.flatnonzero(active)
        if len(rows) == 0:
            break
        t[rows] += (gap[rows] - slop) / speed[rows]
        beyond = t[rows] >= 1.0
        active[rows[beyond]] = False
        rows = rows[~beyond]
        gap[rows] = gap_at(rows, t[rows])
        close = rows[gap[rows] <= 2.0 * slop]
        stop[close] = t[close]
        active[close] = False
    stop[active] = t[active]
    return stop


def _compiled_targets(programs: Programs | None, shape_id: np.ndarray,
                      target: np.ndarray) -> np.ndarray | None:
    """Each target body's (T,) program (``Programs``), or None unless all compile."""
    if programs is None or programs[0] is None:
        return None
    program = programs[1][shape_id[target]]
    return program if np.all(program >= 0) else None


def _traced(programs: Programs, program: np.ndarray, end: np.ndarray, end_angle: np.ndarray,
            target: np.ndarray, rotating: bool, c0: np.ndarray, path: np.ndarray,
            a0: np.ndarray, turn: np.ndarray, vertex: np.ndarray, radius: np.ndarray,
            core: np.ndarray, speed: np.ndarray, slop: float) -> np.ndarray:
    """``_toi_kernels.trace`` of traces against ``target`` (T,) bodies at their end
    poses, each target's field its ``program`` in the table of ``programs``."""
    table = programs[0]
    angle = end_angle[target]
    return trace(table.code, table.consts, table.start, table.depth, table.nesting,
                 program, np.ascontiguousarray(end[target]), np.cos(angle), np.sin(angle),
                 rotating, c0, path, a0, turn, vertex, radius, core, speed, float(slop),
                 MAX_ITERATIONS)


def trace_ahead(programs: Programs) -> None:
    """Compile the traces' kernel (a cold start's, ``world_stages.compile_later``): one
    made-up disc trace against the first program of ``programs``' table, if any."""
    table = programs[0]
    if table is None:
        return
    one, zero, point = np.ones(1), np.zeros(1), np.zeros((1, 2))
    trace(table.code, table.consts, table.start, table.depth, table.nesting,
          np.zeros(1, np.int64), point, one, zero, False, point, np.ones((1, 2)), zero, zero,
          point, one, one, one, 0.005, 1)


def _disc_fractions(fields: list[Field], shape_id: np.ndarray, start: np.ndarray,
                    end: np.ndarray, end_angle: np.ndarray, radius: np.ndarray,
                    core_radius: np.ndarray, fast: np.ndarray, slop: float,
                    pairs: tuple[np.ndarray, np.ndarray],
                    programs: Programs | None = None) -> np.ndarray:
    """``time_of_impact`` over given candidate ``pairs`` (indices into fast, other
    bodies); in one compiled call where ``programs`` has every target's field."""
    fraction = np.ones(len(fast))
    pair_fast, pair_other = pairs
    if len(pair_fast) == 0:
        return fraction
    body = fast[pair_fast]
    c0 = start[body]
    path = end[body] - c0
    program = _compiled_targets(programs, shape_id, pair_other)
    if program is not None:
        unused = np.zeros(len(body))                 # a disc trace has no vertex
        stop = _traced(programs, program, end, end_angle, pair_other, False, c0, path, unused,
                       unused, np.zeros((len(body), 2)), radius[body], core_radius[body],
                       np.hypot(path[:, 0], path[:, 1]), slop)
        np.minimum.at(fraction, pair_fast, stop)
        return fraction
    d0 = _distance(fields, shape_id, end, end_angle, pair_other, c0)
    # The disc traced for each pair: bounding if clear at t = 0, else core, else none.
    disc = np.where(d0 - radius[body] > 2.0 * slop, radius[body], core_radius[body])

    def gap_at(rows: np.ndarray, t: np.ndarray) -> np.ndarray:
        return _distance(fields, shape_id, end, end_angle, pair_other[rows],
                         c0[rows] + t[:, None] * path[rows]) - disc[rows]

    stop = _advance(d0 - disc, np.hypot(path[:, 0], path[:, 1]), slop, gap_at)
    np.minimum.at(fraction, pair_fast, stop)
    return fraction


def _vertex_fractions(fields: list[Field], vertices: list[np.ndarray | None],
                      shape_id: np.ndarray, start: np.ndarray, end: np.ndarray,
                      start_angle: np.ndarray, end_angle: np.ndarray, fast: np.ndarray,
                      slop: float, pairs: tuple[np.ndarray, np.ndarray],
                      programs: Programs | None = None) -> np.ndarray:
    """``vertex_time_of_impact`` over given candidate ``pairs``.

    One row per (pair, vertex of the fast body's polygon), gathered from one table of
    every shape's vertices (a loop over the shapes, never over bodies or pairs); the
    traces in one compiled call where ``programs`` has every target's field.
    """
    fraction = np.ones(len(fast))
    count = np.array([0 if v is None else len(v) for v in vertices], np.int64)
    if len(pairs[0]) == 0 or not count.any():
        return fraction
    table = np.concatenate([v for v in vertices if v is not None])
    offset = np.cumsum(count) - count
    pair_fast, pair_other = pairs
    shape = shape_id[fast[pair_fast]]
    n = count[shape]
    row_pair = np.repeat(np.arange(len(pair_fast)), n)
    within = np.arange(len(row_pair)) - np.repeat(np.cumsum(n) - n, n)
    local = table[offset[shape][row_pair] + within]
    body = fast[pair_fast[row_pair]]
    other = pair_other[row_pair]
    c0, path = start[body], end[body] - start[body]
    a0, turn = start_angle[body], end_angle[body] - start_angle[body]
    speed = np.hypot(path[:, 0], path[:, 1]) + np.abs(turn) * np.hypot(local[:, 0], local[:, 1])
    program = _compiled_targets(programs, shape_id, other)
    if program is not None:
        unused = np.zeros(len(speed))                # a vertex trace has no disc
        stop = _traced(programs, program, end, end_angle, other, True, c0, path, a0, turn,
                       np.ascontiguousarray(local), unused, unused, speed, slop)
        np.minimum.at(fraction, pair_fast[row_pair], stop)
        return fraction

    def gap_at(rows: np.ndarray, t: np.ndarray) -> np.ndarray:
        a = a0[rows] + t * turn[rows]
        c, s = np.cos(a), np.sin(a)
        v = local[rows]
        p = c0[rows] + t[:, None] * path[rows] + np.column_stack(
            [c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]])
        return _distance(fields, shape_id, end, end_angle, other[rows], p)

    rows = np.arange(len(row_pair))
    stop = _advance(gap_at(rows, np.zeros(len(rows))), speed, slop, gap_at)
    np.minimum.at(fraction, pair_fast[row_pair], stop)
    return fraction


def time_of_impact(fields: list[Field], shape_id: np.ndarray, start: np.ndarray,
                   end: np.ndarray, end_angle: np.ndarray, radius: np.ndarray,
                   core_radius: np.ndarray, fast: np.ndarray, slop: float) -> np.ndarray:
    """Fraction of the step (F,) in [0, 1] at which each fast body first comes within slop.

    fields: body-frame field of each shape; shape_id: (B,) index into ``fields``.
    start, end: (B, 2) centre-of-mass positions at the start and end of the step, m;
    end_angle: (B,) rad, the obstacles' orientation. radius, core_radius: (B,) m,
    bounding and core disc radii about the centre of mass (module docstring).
    fast: (F,) indices of the traced bodies. 1 means no impact within the step.
    """
    return _disc_fractions(fields, shape_id, start, end, end_angle, radius, core_radius,
                           fast, slop, _candidate_pairs(fast, start, end, radius))


def vertex_time_of_impact(fields: list[Field], vertices: list[np.ndarray | None],
                          shape_id: np.ndarray, start: np.ndarray, end: np.ndarray,
                          start_angle: np.ndarray, end_angle: np.ndarray,
                          radius: np.ndarray, fast: np.ndarray, slop: float) -> np.ndarray:
    """Fraction of the step (F,) at which a vertex of each fast polygon first comes within
    slop of another body, tracing rotation (module docstring, "Rotation"); 1 if none.

    vertices: per shape, its polygon's vertices (V, 2) in the body frame (centre of mass
    at the origin), or None (circles and sdf bodies: not traced here). start, end: (B, 2)
    centres of mass, m; start_angle, end_angle: (B,) rad; the obstacles are taken at
    their end poses. radius: (B,) bounding radii, m. fast: (F,) traced bodies.
    """
    return _vertex_fractions(fields, vertices, shape_id, start, end, start_angle, end_angle,
                             fast, slop, _candidate_pairs(fast, start, end, radius))


def step_fractions(fields: list[Field], vertices: list[np.ndarray | None],
                   shape_id: np.ndarray, start: np.ndarray, end: np.ndarray,
                   start_angle: np.ndarray, end_angle: np.ndarray, radius: np.ndarray,
                   core_radius: np.ndarray, fast: np.ndarray, slop: float,
                   group: np.ndarray | None = None, pair_filter=None,
                   contact_pairs: np.ndarray | None = None,
                   programs: Programs | None = None,
                   obstacles: np.ndarray | None = None,
                   bullets: np.ndarray | None = None) -> np.ndarray:
    """The world's stage: min of ``time_of_impact`` and ``vertex_time_of_impact`` (F,),
    the candidate pairs found once for both (arguments as theirs). pair_filter: the
    bodies' ``collide.filter.PairFilter`` or None: pairs it filters out, and pairs with a
    sensor, are not traced. contact_pairs: (K, 2) int64 body pairs that had contact
    rows this step (any order, repeats allowed), or None: a fast disc that is its
    body's own outline (a circle: bounding radius = core radius) is not traced against a
    body it had a row with (see "Rows" below). group: (B,) labels
    of bodies joined by joints (``joints.JointTable.groups``), or None: a fast body is
    not stopped against a body of its own group (the group stops as one, and rewinding
    one member against another would open their joints).

    Jointed bodies against moving obstacles. The trace uses the obstacle's end pose, and a
    fast body of a joint group stops its whole group (``JointTable.spread_fractions``).
    Against an obstacle that moved this step that is wrong twice over: the obstacle was
    elsewhere at the time found, and the group, rewound to it, lands where the obstacle
    now is. A crate falling onto a bridge plank rising into it stopped the plank at 2/3
    of its step, and the whole bridge with it, under the crate: 33 mm deep the next step
    (scenes/chain_bridge.toml, t = 0.85 s). So a fast body joined to others is not traced
    against an obstacle whose centre moved more than ``slop`` this step; their contact
    rows keep them apart. Bodies without joints keep the trace against moving
    obstacles (kinematic ones, in the world: ``obstacles`` below).

    Rows. A circle with a contact row against an obstacle cannot pass through it: the
    row's speculative bound along its normal stops the approach the step began with,
    and its depth is exact (the circle is its own bounding disc). The trace would only
    rewind it when it arrives within 2 slop, which is landing, not tunnelling, and it
    rewinds it along its path into whatever followed it: in scenes/circles_in_box.toml
    a circle landing on the pile at 7.8 m/s was put back 12.6 mm up its path, into the
    circle falling on top of it, 16.5 mm deep the next step (t = 1.2 s). So such pairs
    are left to the rows; polygons (the bounding disc is not the body, the vertices
    turn) keep the trace. programs: the shapes' fields as programs (``Programs``), or None:
    the traces run in numpy rounds (the same stop times).

    Obstacles. obstacles: (B,) bool, the bodies a fast body may be stopped against, or
    None: every body; bullets: (F,) bool, fast bodies stopped against every body
    whatever ``obstacles`` says, or None: none. The world passes its static and
    kinematic bodies as obstacles, and as bullets the fast bodies that moved farther
    than their contact rows reached (``collide.REACH_CAP_RADII`` bounding radii; Box2D
    v3 traces its bodies that are not bullets against static shapes only): against a
    dynamic obstacle the trace used its end pose, and the rewind put the fast body
    back along its path into whatever moved with it. In scenes/concave_polygons.toml
    two polygons fell together, 3 mm apart; the solver stopped the lower one on a
    third, dynamic, 3 mm deep and the upper one on it (-0.7 mm), and the trace against
    the third put the lower one back 8.6 mm, 10.3 mm into the upper one (t = 0.93 s,
    the scene's deepest contact). Dynamic pairs keep their contact rows, whose margin
    grows with the bodies' reach, except where the reach was capped: a slug at 300
    m/s crosses 5 m a step and its rows reach 0.1 m, so it is traced against the
    boxes of a stack as against the ground (tests/stability, the stack bullets)."""
    if len(fast) == 0:
        return np.ones(0)
    pairs = _candidate_pairs(fast, start, end, radius)
    if obstacles is not None:
        keep = obstacles[pairs[1]]
        if bullets is not None:
            keep |= bullets[pairs[0]]
        pairs = (pairs[0][keep], pairs[1][keep])
    if pair_filter is not None:
        keep = pair_filter.allows(fast[pairs[0]], pairs[1], solid=True)
        pairs = (pairs[0][keep], pairs[1][keep])
    if group is not None:
        keep = group[fast[pairs[0]]] != group[pairs[1]]
        pairs = (pairs[0][keep], pairs[1][keep])
        _, inverse, members = np.unique(group, return_inverse=True, return_counts=True)
        joined = members[inverse.reshape(-1)] > 1
        other = pairs[1]
        moved = np.hypot(*(end[other] - start[other]).T) > slop
        keep = ~(joined[fast[pairs[0]]] & moved)
        pairs = (pairs[0][keep], pairs[1][keep])
    if contact_pairs is not None and len(contact_pairs) and len(pairs[0]):
        body, other = fast[pairs[0]], pairs[1]
        n = np.int64(len(radius))
        rows = np.unique(np.minimum(contact_pairs[:, 0], contact_pairs[:, 1]) * n
                         + np.maximum(contact_pairs[:, 0], contact_pairs[:, 1]))
        key = np.minimum(body, other) * n + np.maximum(body, other)
        at = np.minimum(np.searchsorted(rows, key), len(rows) - 1)
        keep = ~((rows[at] == key) & (radius[body] <= core_radius[body]))
        pairs = (pairs[0][keep], pairs[1][keep])
    return np.minimum(
        _disc_fractions(fields, shape_id, start, end, end_angle, radius, core_radius, fast,
                        slop, pairs, programs),
        _vertex_fractions(fields, vertices, shape_id, start, end, start_angle, end_angle,
                          fast, slop, pairs, programs))
