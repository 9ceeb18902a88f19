"""Collision detection: broadphase, narrowphase by pair kind, reduction -> Contacts.

``find_contacts`` is the world's per-step query over all bodies; ``collide`` asks
the same question for two shapes at two poses. Both return a ``Contacts`` bundle
(world frame): normal unit from body a toward body b, depth > 0 overlapping,
point midway between the two surfaces, feature keys stable from step to step.

One step of ``find_contacts`` (no Python loop over bodies, pairs or contacts):

1. world AABBs of all bodies, each grown by half the speculative distance plus
   the body's reach (below), so boxes meet whenever the bodies are closer than the
   pair's margin (``broadphase``);
2. candidate pairs by sort-and-sweep (numba), keeping pairs with a movable body;
3. pairs oriented lower kind first (circle < mesh < sdf; for equal kinds, lower
   shape id first) and grouped by their two Shape objects: one pair-function call
   per group, each evaluating a field once per batch of points (``narrowphase``).
   With the world's ``ContactCache`` (``contact_cache``), a pair that moved less
   than ``Settings.reuse_distance`` relative to itself since its contacts were
   found keeps them, carried with the bodies, and is not searched (the
   closed-form pairs of the fast path below never are);
4. contacts with depth > -margin of their pair kept, reduced to at most
   ``contacts_per_pair`` per pair (``reduce``), sorted by (body_a, body_b, feature);
5. a circle against a body that turns, or that it moves against, by more than the
   slop this step gets one more, speculative contact, and an sdf pair with a contact
   and a turning body gets its end-pose contacts at the turning body's corners: the
   pair at its end-of-step poses carried back (``predicted``;
   ``Settings.predicted_contacts``).

Fast path (``circle_kernels``, the default): steps 1-2 are one compiled pass over
the bodies and the grid broadphase; the circle-circle, circle-box (``TriangleMesh.box``)
and convex polygon (boxes and convex meshes: ``polygons.clip_pair``, at most two
contacts, a manifold the reduction keeps whole) candidate pairs go straight from the
sorted pair list to their contacts in one compiled pass, in (body_a, body_b, feature)
order; only the other pairs take steps 3-4, and the two sorted lists are merged. The
result is identical to the general path (``find_contacts(..., fast_circles=False)``),
bit for bit.

Velocity-aware speculative margin. A contact found before the bodies touch costs
nothing (the solver's speculative rows, s > 0, only forbid closing more than s), and
one found late costs a step's travel of overlap. So the pair margin is

    margin(a, b) = speculative_distance + reach_a + reach_b,
    reach = min(dt (|v| + |w| r), REACH_CAP_RADII r),

|v| + |w| r bounding the speed of every point of a body (r its bounding radius about
the centre of mass), so no two points of a and b close more than reach_a + reach_b
in a step. The velocities are the step's start values; gravity adds at most g dt^2
(2.7 mm at 60 Hz), inside the speculative distance. The cap keeps one fast body from
pulling far pairs into the narrowphase; a body moving more than about half its
extent per step is caught by time of impact instead. Unbounded shapes (r = inf)
count as r = ``UNBOUNDED_RADIUS`` (their reach is then not a bound when they spin;
ground fields are static). Boxes grow symmetrically by each body's reach, not only
along its motion: the narrowphase margin is symmetric too, and a receding pair's
speculative contacts are inert. Without velocities the reach is 0: the margin is
the speculative distance alone.
"""

from __future__ import annotations

import sys
import types
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .. import _compile_lock
from ..sdf import compiled
from ..sdf.polygonal import Box
from ..settings import Settings
from ..shapes import Shape, shape_from_spec
from .broadphase import candidate_pairs, world_bounds
from .circle_kernels import (
    BOX,
    CIRCLE,
    OTHER,
    POLYGON,
    analytic_contacts,
    analytic_pair,
    merge_order,
    predicted_box_rows,
    reach_and_boxes,
)
from .contact_cache import ContactCache, body_turns
from .contacts import Contacts
from .filter import PairFilter
from .narrowphase import BATCH_FUNCTIONS, KIND_ORDER, PAIR_FUNCTIONS
from .polygons import SOURCE_CLIP, polygon_table
from .predicted import (
    IMPLIED_COSINE,
    IMPLIED_ROUND_OFF,
    predicted_contacts,
    predicted_pair_contacts,
)
from .reduce import reduce_contacts
from .shape_fields import ShapeFields

__all__ = ["REACH_CAP_RADII", "UNBOUNDED_RADIUS", "ContactCache", "Contacts", "collide",
           "compile_behind", "compile_evaluator", "find_contacts", "shape_fields",
           "speculative_reach"]

#: A body's reach (extra speculative margin) is capped at this many bounding radii.
REACH_CAP_RADII = 2.0

#: Bounding radius (m) assumed for the reach of unbounded shapes.
UNBOUNDED_RADIUS = 1.0


def _distinct(shapes: Sequence[Shape]) -> tuple[list[Shape], np.ndarray]:
    """Distinct Shape objects and, per entry of ``shapes``, its index among them."""
    first: dict[int, int] = {}
    canonical = np.array([first.setdefault(id(s), len(first)) for s in shapes], np.int64)
    unique = list({id(s): s for s in shapes}.values())
    return unique, canonical


def _shape_class(shape: Shape) -> int:
    """CIRCLE, BOX (a mesh whose field is the box primitive), POLYGON (another convex
    mesh) or OTHER (general path)."""
    if shape.kind == "circle":
        return CIRCLE
    if shape.kind == "mesh" and type(shape.field) is Box:
        return BOX
    if shape.kind == "mesh" and shape.convex:
        return POLYGON
    return OTHER


class _ShapeTables:
    """Per distinct shape, what the compiled stages read (built once per shape list).

    bounds (S, 4) body-frame AABBs; radius (S,); shape_class (S,) int64; half (S, 2)
    box half-extents; polygons: ``polygons.polygon_table`` of the boxes and convex
    meshes; sdf, concave (S,) bool: sdf shapes, triangulated meshes that are not convex;
    kind_rank (S,) int64: each shape's kind's place in KIND_ORDER; mixed, any_sdf,
    any_concave: whether the shapes hold a circle and a shape that is not one, an sdf
    shape, a concave mesh (the predicted contacts' kinds, ``_with_predicted``); fields:
    ``shape_fields.ShapeFields`` (built when first read).
    """

    def __init__(self, shapes: Sequence[Shape]):
        self.bounds = np.array([s.bounds() for s in shapes], np.float64).reshape(-1, 4)
        self.kind_rank = np.array([KIND_ORDER.index(s.kind) for s in shapes], np.int64)
        self.radius = np.array([s.radius for s in shapes], np.float64)
        self.shape_class = np.array([_shape_class(s) for s in shapes], np.int64)
        self.sdf = np.array([s.kind == "sdf" for s in shapes], bool)
        self.concave = (np.array([s.kind == "mesh" for s in shapes], bool)
                        & (self.shape_class == OTHER))
        self.half = np.array([s.field.half if c == BOX else (0.0, 0.0)
                              for s, c in zip(shapes, self.shape_class)],
                             np.float64).reshape(-1, 2)
        self.polygons = polygon_table([s.vertices if c >= BOX else None
                                       for s, c in zip(shapes, self.shape_class)])
        circle = self.shape_class == CIRCLE
        self.mixed = bool(np.any(circle) and not np.all(circle))
        self.any_sdf = bool(np.any(self.sdf))
        self.any_concave = bool(np.any(self.concave))
        self.shapes = list(shapes)
        self._fields: tuple[int, ShapeFields] | None = None

    @property
    def fields(self) -> ShapeFields:
        """The shapes' ``ShapeFields`` (their fields' programs in one table), built on
        first use and again after a program's constants changed in place (a terrain
        edit, ``sdf.compiled.consts_changed``): the batched pair functions'
        (``BATCH_FUNCTIONS``)."""
        if self._fields is None or self._fields[0] != compiled.consts_version():
            self._fields = (compiled.consts_version(), ShapeFields.of(self.shapes))
        return self._fields[1]


_TABLES: dict[tuple[Shape, ...], _ShapeTables] = {}
#: Shape lists whose tables are kept (a world keeps one; tests make many).
_TABLES_KEPT = 16


def shape_fields(shapes: Sequence[Shape]) -> tuple[ShapeFields, np.ndarray]:
    """The distinct ``shapes``' ``ShapeFields`` (cached with their tables) and, per entry
    of ``shapes``, its row in it."""
    distinct, canonical = _distinct(shapes)
    return _tables(distinct).fields, canonical


def _tables(shapes: list[Shape]) -> _ShapeTables:
    """The tables of a list of distinct shapes, cached by the shapes' identities."""
    key = tuple(shapes)
    tables = _TABLES.get(key)
    if tables is None:
        if len(_TABLES) >= _TABLES_KEPT:
            _TABLES.pop(next(iter(_TABLES)))
        tables = _TABLES[key] = _ShapeTables(shapes)
    return tables


def speculative_reach(radius: np.ndarray, velocity: np.ndarray,
                      angular_velocity: np.ndarray, dt: float) -> np.ndarray:
    """Per body (B,), m: how far any of its points may move in ``dt`` (see module doc).

    radius: (B,) bounding radius about the centre of mass (inf if unbounded);
    velocity: (B, 2) m/s of the centre of mass; angular_velocity: (B,) rad/s.
    """
    r = np.where(np.isfinite(radius), radius, UNBOUNDED_RADIUS)
    speed = np.hypot(velocity[:, 0], velocity[:, 1]) + np.abs(angular_velocity) * r
    return np.minimum(dt * speed, REACH_CAP_RADII * r)


def _groups(shapes: list[Shape], body_shape: np.ndarray, pairs: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The pairs (P, 2) as (first, second) bodies, the lower kind first (KIND_ORDER, then
    the lower shape index), sorted stably by their two shapes, and the first and end
    rows (G,) of each group of pairs sharing two shapes."""
    kind_rank = _tables(shapes).kind_rank
    sa, sb = body_shape[pairs[:, 0]], body_shape[pairs[:, 1]]
    ka, kb = kind_rank[sa], kind_rank[sb]
    swap = (ka > kb) | ((ka == kb) & (sa > sb))
    first = np.where(swap, pairs[:, 1], pairs[:, 0])
    second = np.where(swap, pairs[:, 0], pairs[:, 1])
    group = body_shape[first] * len(shapes) + body_shape[second]
    order = np.argsort(group, kind="stable")
    first, second, group = first[order], second[order], group[order]
    if len(group) == 0:
        none = np.zeros(0, np.int64)
        return first, second, none, none
    lo = np.flatnonzero(np.r_[True, np.diff(group) != 0])
    return first, second, lo, np.r_[lo[1:], len(group)]


#: The kind pairs with a batched pair function, as kind_rank[a] * 3 + kind_rank[b] ...
_BATCHED = {KIND_ORDER.index(a) * 3 + KIND_ORDER.index(b): (a, b) for a, b in BATCH_FUNCTIONS}
#: ... and whether each such code (9,) has one (a lookup, not ``np.isin``, per query).
_HAS_BATCH = np.isin(np.arange(len(KIND_ORDER) ** 2), list(_BATCHED))


def _batched_groups(tables: _ShapeTables, sa: np.ndarray, sb: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Per group of shapes sa, sb (G,): its kind pair as kind_rank[a] * 3 + kind_rank[b],
    and whether a batched pair function takes it (its kind pair has one and both fields
    compile)."""
    kind = tables.kind_rank[sa] * 3 + tables.kind_rank[sb]
    batched = _HAS_BATCH[kind]
    if batched.any():
        fields = tables.fields
        batched &= (fields.program[sa] >= 0) & (fields.program[sb] >= 0)
    return kind, batched


def _pair_calls(shapes: list[Shape], body_shape: np.ndarray, first: np.ndarray,
                second: np.ndarray, lo: np.ndarray, hi: np.ndarray, pose: np.ndarray,
                group_margin: np.ndarray, settings: Settings,
                ran: set[tuple[str, str]] | None) -> list[Contacts]:
    """The contacts of the groups [lo, hi) (G,) of pairs (first, second), each group's
    pairs with its margin (G,) m: one batched call (``BATCH_FUNCTIONS``) per kind pair
    for the groups whose two fields compile, a pair-function call per group for the
    others (``_narrowphase``)."""
    tables = _tables(shapes)
    sa, sb = body_shape[first[lo]], body_shape[second[lo]]
    kind, batched = _batched_groups(tables, sa, sb)
    parts = []
    for g in np.flatnonzero(~batched):
        shape_a, shape_b = shapes[sa[g]], shapes[sb[g]]
        kinds = (shape_a.kind, shape_b.kind)
        if ran is not None:
            ran.add(kinds)
        a, b = first[lo[g]:hi[g]], second[lo[g]:hi[g]]
        parts.append(PAIR_FUNCTIONS[kinds](shape_a, shape_b, a, b, pose[a], pose[b],
                                           float(group_margin[g]), settings))
    count = hi - lo
    for code in np.unique(kind[batched]):
        kinds = _BATCHED[int(code)]
        if ran is not None:
            ran.add(kinds)
        chosen = np.repeat(batched & (kind == code), count)
        run = np.repeat(np.arange(len(lo)), count)[chosen]
        a, b = first[chosen], second[chosen]
        parts.append(BATCH_FUNCTIONS[kinds](tables.fields, body_shape[a], body_shape[b], a, b,
                                            pose[a], pose[b], group_margin[run], run,
                                            settings))
    return parts


def _narrowphase(shapes: list[Shape], body_shape: np.ndarray, pairs: np.ndarray,
                 pose: np.ndarray, margin: float, reach: np.ndarray,
                 settings: Settings, ran: set[tuple[str, str]] | None = None,
                 cache: ContactCache | None = None, radius: np.ndarray | None = None,
                 round_: np.ndarray | None = None) -> Contacts:
    """Contacts of the candidate ``pairs`` (P, 2), reduced and sorted (see module doc).

    shapes: distinct Shape objects; body_shape: (B,) index into them per body;
    pose: (B, 3) centre-of-mass poses (x, y, angle); margin: m, the speculative
    distance; reach: (B,) m per body, a pair keeping contacts with depth >
    -(margin + reach_a + reach_b). Each pair-function call gets its group's largest
    pair margin; contacts beyond their own pair's margin are then dropped. ``ran``,
    if given, receives the (kind_a, kind_b) of every pair function called. cache:
    the world's ``ContactCache`` (with radius (B,), the bodies' bounding radii, and
    round_ (B,) bool, the circles): pairs that barely moved keep their contacts, the
    others are searched with their margin grown by ``settings.reuse_distance`` and
    kept; None: all searched.
    """
    tau, kept = 0.0, None
    if cache is not None and settings.reuse_distance > 0.0:
        tau = settings.reuse_distance
        turns = body_turns(pose)
        pair_margin = margin + reach[pairs[:, 0]] + reach[pairs[:, 1]]
        reused, kept = cache.reuse(pairs, pose, turns, radius, round_, body_shape,
                                   pair_margin, tau, settings)
        pairs = pairs[~reused]
    first, second, lo, hi = _groups(shapes, body_shape, pairs)
    # Each group's largest reach_a + reach_b, all groups at once.
    largest = (np.maximum.reduceat(reach[first] + reach[second], lo) if len(lo)
               else np.zeros(0))
    group_margin = margin + largest + tau
    found_margin = np.repeat(group_margin, hi - lo)
    c = Contacts.concatenate(_pair_calls(shapes, body_shape, first, second, lo, hi, pose,
                                         group_margin, settings, ran))
    flip = c.body_a > c.body_b
    c.body_a, c.body_b = np.where(flip, c.body_b, c.body_a), np.where(flip, c.body_a, c.body_b)
    c.normal = np.where(flip[:, None], -c.normal, c.normal)
    if kept is not None:
        cache.store(np.column_stack([first, second]), found_margin, c, pose, turns, radius,
                    round_, body_shape)
        c = Contacts.concatenate([kept, c])
    c = c.take(c.depth > -(margin + reach[c.body_a] + reach[c.body_b]))

    pair_key = c.body_a * np.int64(len(pose)) + c.body_b
    order = np.argsort(pair_key, kind="stable")
    if np.all(np.diff(pair_key[order]) > 0):            # one contact per pair: done
        return c.take(order)
    order = np.lexsort((c.feature, -c.depth, pair_key))
    c, pair_key = c.take(order), pair_key[order]
    starts = np.flatnonzero(np.diff(pair_key)) + 1
    keep = reduce_contacts(np.r_[0, starts, len(c)], c.point, c.depth, c.normal,
                           settings.contacts_per_pair, settings.linear_slop)
    if settings.contacts_per_pair >= 2:
        # Clipped polygon manifolds (two points at most) are kept whole.
        keep |= (c.feature >> np.int64(56)) == SOURCE_CLIP
    c, pair_key = c.take(keep), pair_key[keep]
    return c.take(np.lexsort((c.feature, pair_key)))


def _without(pairs: np.ndarray, exclude: np.ndarray | None, n: int) -> np.ndarray:
    """``pairs`` (P, 2) without those whose key i * n + j is in ``exclude`` (sorted)."""
    if exclude is None or len(pairs) == 0:
        return pairs
    return pairs[~np.isin(pairs[:, 0] * np.int64(n) + pairs[:, 1], exclude,
                          assume_unique=False)]


def _candidates(boxes: np.ndarray, movable: np.ndarray, exclude: np.ndarray | None, n: int,
                pair_filter: PairFilter | None, cache: ContactCache | None = None
                ) -> np.ndarray:
    """The broadphase's pairs (P, 2) without the excluded and the filtered ones (from
    the pairs ``cache`` keeps, ``broadphase.PairCache``, if given)."""
    pairs = (candidate_pairs(boxes, movable) if cache is None
             else cache.broadphase.candidate_pairs(boxes, movable))
    pairs = _without(pairs, exclude, n)
    return pairs if pair_filter is None else pair_filter.pairs(pairs)


def find_contacts(shapes: Sequence[Shape], shape_id: np.ndarray, position: np.ndarray,
                  angle: np.ndarray, movable: np.ndarray, settings: Settings,
                  velocity: np.ndarray | None = None,
                  angular_velocity: np.ndarray | None = None,
                  ran: set[tuple[str, str]] | None = None,
                  fast_circles: bool = True, exclude: np.ndarray | None = None,
                  pair_filter: PairFilter | None = None,
                  cache: ContactCache | None = None) -> Contacts:
    """All contacts of B bodies this step, sorted by (body_a, body_b, feature).

    shapes: Shape objects; shape_id: (B,) int index into ``shapes`` per body;
    position: (B, 2) centre-of-mass world positions (m); angle: (B,) rad;
    movable: (B,) bool (pairs of two immovable bodies are skipped);
    velocity: (B, 2) m/s and angular_velocity: (B,) rad/s at the start of the step
    (None: at rest), which widen each pair's margin by its bodies' reach (module doc).
    ran: if given, receives the (kind_a, kind_b) of every pair function called
    (``PAIR_FUNCTIONS`` keys): which narrowphase machinery this query needed.
    fast_circles: compiled boxes, circle-circle and circle-box contacts (module doc); False runs
    every stage in numpy and every pair through ``_narrowphase`` (same result).
    exclude: sorted int64 keys i * B + j (i < j) of body pairs that never collide (bodies
    joined by a joint), dropped from the candidate pairs; None: none.
    pair_filter: the bodies' collision filter (``filter.PairFilter``: category, mask,
    group, sensors), applied to the candidate pairs before any narrowphase; None: every
    pair may collide.
    cache: a ``ContactCache`` kept from step to step: the descent pairs that barely
    moved keep their contacts (``contact_cache``, ``Settings.reuse_distance``); None:
    every pair searched.
    Returns contacts with body_a < body_b, depth > -(settings.speculative_distance +
    reach_a + reach_b), at most settings.contacts_per_pair per pair.
    """
    distinct, canonical = _distinct(shapes)
    body_shape = canonical[np.asarray(shape_id, np.int64)]
    tables = _tables(distinct)
    local_bounds, radius = tables.bounds, tables.radius
    position = np.ascontiguousarray(position, np.float64).reshape(-1, 2)
    angle = np.ascontiguousarray(angle, np.float64).reshape(-1)
    n = len(angle)
    velocity = (np.zeros((n, 2)) if velocity is None
                else np.ascontiguousarray(velocity, np.float64).reshape(-1, 2))
    angular_velocity = (np.zeros(n) if angular_velocity is None
                        else np.ascontiguousarray(angular_velocity, np.float64).reshape(-1))
    margin = settings.speculative_distance
    movable = np.asarray(movable, bool)
    if not fast_circles:
        reach = speculative_reach(radius[body_shape], velocity, angular_velocity,
                                  settings.dt)
        boxes = world_bounds(local_bounds[body_shape], radius[body_shape], position, angle,
                             0.5 * margin + reach)
        pairs = _candidates(boxes, movable, exclude, n, pair_filter)
        pose = np.column_stack([position, angle])
        shape_class = tables.shape_class[body_shape]
        closed = analytic_pair(shape_class[pairs[:, 0]], shape_class[pairs[:, 1]])
        plain = _narrowphase(distinct, body_shape, pairs[closed], pose, margin, reach,
                             settings, ran)
        other = _narrowphase(distinct, body_shape, pairs[~closed], pose, margin, reach,
                             settings, ran, cache, radius[body_shape], shape_class == CIRCLE)
        order = merge_order(plain.body_a * np.int64(n) + plain.body_b,
                            other.body_a * np.int64(n) + other.body_b)
        return _with_predicted(Contacts.concatenate([plain, other]).take(order), distinct,
                               tables, body_shape, pairs, radius[body_shape], position, angle,
                               velocity, angular_velocity, reach, settings, pair_filter)

    reach, boxes = np.empty(n), np.empty((n, 4))
    reach_and_boxes(local_bounds, radius, body_shape, position, angle, velocity,
                    angular_velocity, float(settings.dt), 0.5 * margin,
                    UNBOUNDED_RADIUS, REACH_CAP_RADII, reach, boxes)
    pairs = _candidates(boxes, movable, exclude, n, pair_filter, cache)
    shape_class = tables.shape_class
    predict = bool(settings.predicted_contacts and tables.mixed)
    # Circle-box pairs' predicted rows are made right after the fast path
    # (``predicted_box_rows``), unless a sensor could be among them
    # (``_with_predicted`` leaves sensor pairs out).
    box_rows = predict and (pair_filter is None or not pair_filter.has_sensors)
    trig = np.empty((n, 10 if box_rows else 4))
    box_body = np.flatnonzero(shape_class[body_shape] == BOX) if tables.mixed else ()
    if len(box_body):                          # read by circle-box pairs only
        a_box = angle[box_body]
        trig[box_body, 0], trig[box_body, 1] = np.cos(-a_box), np.sin(-a_box)
        trig[box_body, 2], trig[box_body, 3] = np.cos(a_box), np.sin(a_box)
    pairs = np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2)
    (a, b, point, normal, depth, feature, rest, n_circles, n_boxes, n_polygons, chosen,
     box_chosen) = analytic_contacts(
        pairs.view(np.uint64), body_shape, shape_class, radius, tables.half, tables.polygons,
        position, angle, trig, reach, float(margin), float(settings.linear_slop),
        int(settings.contacts_per_pair), velocity, angular_velocity, float(settings.dt),
        predict, box_rows)
    if len(box_chosen):             # the circle-box pairs' predicted rows, in pair order
        # The picked boxes' end-pose trig, as ``predicted_contacts`` takes it.
        i, j = pairs[box_chosen, 0], pairs[box_chosen, 1]
        box = np.where(shape_class[body_shape[i]] == BOX, i, j)
        turn = angular_velocity[box] * float(settings.dt)
        end = angle[box] + turn
        trig[box, 4], trig[box, 5] = np.cos(-end), np.sin(-end)
        trig[box, 6], trig[box, 7] = np.cos(end), np.sin(end)
        trig[box, 8], trig[box, 9] = np.cos(-turn), np.sin(-turn)
        key = a * np.int64(n) + b
        rows = predicted_box_rows(
            box_chosen, pairs.view(np.uint64), body_shape, shape_class, radius, tables.half,
            position, velocity, angular_velocity, trig, reach, float(margin),
            float(settings.linear_slop), float(settings.dt), key, normal, depth)
        if len(rows[0]):            # each after its pair's contact (feature 0 < its)
            order = merge_order(2 * key, 2 * (rows[0] * np.int64(n) + rows[1]) + 1)
            a, b, point, normal, depth, feature = (
                np.concatenate([mine, theirs])[order]
                for mine, theirs in zip((a, b, point, normal, depth, feature), rows,
                                        strict=True))
    if ran is not None:
        if n_circles:
            ran.add(("circle", "circle"))
        if n_boxes:
            ran.add(("circle", "mesh"))
        if n_polygons:
            ran.add(("mesh", "mesh"))
    contacts = Contacts(a, b, point, normal, depth, feature)
    if len(rest):
        pose = np.column_stack([position, angle])
        other = _narrowphase(distinct, body_shape, pairs[rest], pose, margin, reach, settings,
                             ran, cache, radius[body_shape], shape_class[body_shape] == CIRCLE)
        order = merge_order(a * np.int64(n) + b, other.body_a * np.int64(n) + other.body_b)
        contacts = Contacts.concatenate([contacts, other]).take(order)
    return _with_predicted(contacts, distinct, tables, body_shape, pairs, radius[body_shape],
                           position, angle, velocity, angular_velocity, reach, settings,
                           pair_filter, chosen)


def _with_predicted(contacts: Contacts, shapes: list[Shape], tables: _ShapeTables,
                    body_shape: np.ndarray, pairs: np.ndarray, radius: np.ndarray,
                    position: np.ndarray, angle: np.ndarray, velocity: np.ndarray,
                    angular_velocity: np.ndarray, reach: np.ndarray, settings: Settings,
                    pair_filter: PairFilter | None, chosen: np.ndarray | None = None
                    ) -> Contacts:
    """``contacts`` (sorted by (body_a, body_b, feature)) with the predicted contacts
    (``predicted``) of circles among the candidate ``pairs`` (those a contact of the
    pair implies dropped, ``_implied``) and of sdf pairs and concave mesh pairs with a
    contact (sensor pairs left out: a prediction is not a touch), in the same order;
    none without ``settings.predicted_contacts``. An sdf pair's row is another material
    point than its contact's, so no contact implies it; a mesh pair's is on a face no
    contact of its element has. tables: the distinct ``shapes``' ``_ShapeTables``;
    chosen: the rows of ``pairs`` that get a circle's predicted row if the caller picked
    them (``analytic_contacts``, which makes the circle-box pairs' rows itself and
    leaves them out), None: picked here."""
    if not settings.predicted_contacts:
        return contacts
    is_circle = tables.shape_class[body_shape] == CIRCLE
    n = np.int64(len(angle))
    extra = Contacts.empty()
    if tables.mixed:             # a circle and a body that is not one: their pairs
        if chosen is not None:
            pairs = pairs[chosen]
        extra = predicted_contacts(tables.fields, body_shape,
                                   _without_sensors(pairs, pair_filter), is_circle, radius,
                                   position, angle, velocity,
                                   angular_velocity, float(settings.dt),
                                   float(settings.linear_slop),
                                   float(settings.speculative_distance), reach,
                                   picked=chosen is not None)
    if len(extra):
        extra = extra.take(~_implied(contacts, extra, n))
    # Pairs with a contact only (the others are farther apart than their margin, which
    # holds every point's travel in the step, so they cannot meet); contacts are sorted
    # by pair. Sdf pairs, and pairs of a concave (triangulated) mesh with a body that is
    # not a circle.
    a, b = contacts.body_a, contacts.body_b
    fields = meshes = np.zeros(0, bool)
    if tables.any_sdf:
        sdf = tables.sdf[body_shape]
        fields = sdf[a] & sdf[b]
    if tables.any_concave:
        concave = tables.concave[body_shape]
        meshes = (concave[a] | concave[b]) & ~is_circle[a] & ~is_circle[b]
    state = (radius, position, angle, velocity, angular_velocity, reach, settings)

    def touching(chosen: np.ndarray) -> np.ndarray:
        """The distinct pairs (P, 2) of the ``chosen`` contacts, sensors left out."""
        key = a[chosen] * n + b[chosen]
        key = key[np.concatenate([[True], key[1:] != key[:-1]])]
        return _without_sensors(np.column_stack([key // n, key % n]), pair_filter)

    if fields.any() or meshes.any():
        none = np.zeros((0, 2), np.int64)
        extra = Contacts.concatenate([extra, predicted_pair_contacts(
            shapes, tables.fields, body_shape, contacts,
            touching(fields) if fields.any() else none,
            touching(meshes) if meshes.any() else none, *state)])
    if len(extra) == 0:
        return contacts
    c = Contacts.concatenate([contacts, extra])
    return c.take(np.lexsort((c.feature, c.body_a * n + c.body_b)))


def _without_sensors(pairs: np.ndarray, pair_filter: PairFilter | None) -> np.ndarray:
    """The body pairs (P, 2) without those with a sensor (a prediction is not a touch)."""
    if pair_filter is None or not pair_filter.has_sensors or len(pairs) == 0:
        return pairs
    return pairs[~(pair_filter.sensor[pairs[:, 0]] | pair_filter.sensor[pairs[:, 1]])]


def _implied(contacts: Contacts, extra: Contacts, n: np.int64) -> np.ndarray:
    """(len(extra),) bool: whether each predicted contact is implied by a contact of its
    pair in ``contacts`` (sorted by pair) with the same normal and no larger
    separation, both to round-off (``IMPLIED_ROUND_OFF`` m): both measure the circle's
    move along one normal, so the predicted row would only repeat it (a circle falling
    on or rolling along a flat face)."""
    owner, row = contacts.pair_rows(extra, n)
    same = np.einsum("ij,ij->i", contacts.normal[row], extra.normal[owner]) >= IMPLIED_COSINE
    repeats = same & (contacts.depth[row] >= extra.depth[owner] - IMPLIED_ROUND_OFF)
    implied = np.zeros(len(extra), bool)
    np.logical_or.at(implied, owner, repeats)
    return implied


def compile_ahead(shapes: Sequence[Shape], shape_id: np.ndarray, position: np.ndarray,
                  angle: np.ndarray, movable: np.ndarray, settings: Settings,
                  later: bool = False) -> None:
    """The collisions' part of a cold start's compiling child (``sdfphys._warm``): the
    pair functions of the pairs whose boxes meet at these poses (arguments as
    ``find_contacts``; margin the speculative distance), group by group in the reverse
    of ``find_contacts``'s order, and a mesh-sdf group's second direction
    (``mesh_sdf.sdf_in_mesh``) before the whole pair function, whose first direction
    is the other end's start. With ``later``, instead, the pairs that may meet in a
    later step: for each set of kernels (``path``) that no pair meeting at these poses
    runs, one pair of bodies of two shapes (one body movable) with its second body
    placed on its first (the same pose: they overlap). What it finds is dropped: it
    runs for the kernels it compiles."""
    from .mesh_sdf import sdf_in_mesh
    from .shape_fields import flat_field

    distinct, canonical = _distinct(shapes)
    body_shape = canonical[np.asarray(shape_id, np.int64)]
    tables = _tables(distinct)
    position = np.ascontiguousarray(position, np.float64).reshape(-1, 2)
    angle = np.ascontiguousarray(angle, np.float64).reshape(-1)
    movable = np.asarray(movable, bool)
    margin = settings.speculative_distance
    boxes = world_bounds(tables.bounds[body_shape], tables.radius[body_shape], position,
                         angle, 0.5 * margin)
    pairs = candidate_pairs(boxes, movable)
    shape_class = tables.shape_class[body_shape]
    pose = np.column_stack([position, angle])

    def path(a: int, b: int) -> tuple:
        """What sets the kernels a pair (a, b) of ``_groups``' order runs."""
        shape_a, shape_b = distinct[body_shape[a]], distinct[body_shape[b]]
        return (shape_a.kind, shape_b.kind, bool(tables.concave[body_shape[a]]),
                bool(tables.concave[body_shape[b]]),
                shape_b.kind == "sdf" and flat_field(shape_b))

    def run(a: np.ndarray, b: np.ndarray, pose_a: np.ndarray, pose_b: np.ndarray) -> None:
        shape_a, shape_b = distinct[body_shape[a[0]]], distinct[body_shape[b[0]]]
        kinds = (shape_a.kind, shape_b.kind)
        if kinds == ("mesh", "sdf") and not flat_field(shape_b):
            sdf_in_mesh(shape_a, shape_b, pose_a, pose_b, margin, settings)
        PAIR_FUNCTIONS[kinds](shape_a, shape_b, a, b, pose_a, pose_b, margin, settings)

    rest = pairs[~analytic_pair(shape_class[pairs[:, 0]], shape_class[pairs[:, 1]])]
    first, second, lo, hi = _groups(distinct, body_shape, rest)
    if not later:
        # ``_pair_calls``' order (the groups without a batched function, then the batched
        # kinds in turn), from its end.
        kind, batched = _batched_groups(tables, body_shape[first[lo]], body_shape[second[lo]])
        for g in reversed(np.lexsort((np.arange(len(lo)), np.where(batched, kind, -1)))):
            a, b = first[lo[g]:hi[g]], second[lo[g]:hi[g]]
            run(a, b, pose[a], pose[b])
        return
    # Among two bodies of each shape (movable ones first), every pair with a movable
    # body whose path no pair meeting now runs.
    seen = {path(first[g], second[g]) for g in lo}
    order = np.lexsort((~movable, body_shape))
    run_start = np.r_[True, body_shape[order][1:] != body_shape[order][:-1]]
    some = order[run_start | (np.r_[False, run_start[:-1]] & ~run_start)]
    i, j = np.triu_indices(len(some), 1)
    maybe = np.column_stack([some[i], some[j]])
    maybe = maybe[movable[maybe[:, 0]] | movable[maybe[:, 1]]]
    maybe = maybe[~analytic_pair(shape_class[maybe[:, 0]], shape_class[maybe[:, 1]])]
    first, second, lo, _ = _groups(distinct, body_shape, maybe)
    for g in lo:
        key = path(first[g], second[g])
        if key not in seen:
            seen.add(key)
            a, b = first[g:g + 1], second[g:g + 1]
            run(a, b, pose[a], pose[a])


def compile_evaluator(shapes: Sequence[Shape]) -> None:
    """The field program's evaluator (``sdf.compiled.run``), compiled or loaded, where a
    query of bodies of these shapes may evaluate a field: a circle's predicted contacts
    against a body that is not one, sdf shapes, concave meshes (``_ShapeTables``'
    ``mixed``, ``any_sdf``, ``any_concave``). For a cold start's compiling child
    (``world_stages.compile_ahead``): the first step of bodies that start apart
    evaluates none, a later one does. Nothing while another process compiles it (the
    parent, whose first step evaluates a field): the child goes on with its other
    kernels rather than wait."""
    distinct, _ = _distinct(shapes)
    tables = _tables(distinct)
    if ((tables.mixed or tables.any_sdf or tables.any_concave)
            and not _compile_lock.held_elsewhere(compiled.run)):
        field = next(shape.field for shape in distinct if shape.kind != "circle")
        compiled.evaluate(field, np.zeros((1, 2)))


def compile_behind(shapes: Sequence[Shape], shape_id: np.ndarray,
                   settings: Settings) -> list[Callable[[], None]]:
    """The end of a collision query of bodies of these shapes (``shape_id`` (B,) into
    ``shapes``), as jobs for a cold start's parent (``world_stages.compile_behind``): a
    contact cache's store (``_merged``; its reuse, ``_carry``, comes first in every
    query, before any wait) and the reduction (``_reduce``), on no pairs, with the
    argument types of ``_narrowphase``'s calls; then, where a mesh meets a field
    through ``mesh_contacts.mesh_in_field`` (a concave mesh and a body that is not a
    circle, a mesh and an sdf body), the end of that path (``compile_finish``), which
    the compiling child reaches last. None where every pair of them is a closed form
    (``analytic_contacts``: no cache, no reduction). They touch no world."""
    from .mesh_contacts import compile_finish

    distinct, canonical = _distinct(shapes)
    tables = _tables(distinct)
    body_shape = canonical[np.asarray(shape_id)]
    present = np.unique(tables.shape_class[body_shape])
    first, second = np.meshgrid(present, present)
    if np.all(analytic_pair(first.ravel(), second.ravel())):
        return []
    n = len(shape_id)
    pose = np.zeros((n, 3))
    bodies = (body_turns(pose), np.ones(n), np.zeros(n, np.bool_), np.zeros(n, np.int64))
    no_pairs = np.zeros((0, 2), np.int64)

    def cache() -> None:
        ContactCache().store(no_pairs, np.zeros(0), Contacts.empty(), pose, *bodies)

    def reduction() -> None:
        reduce_contacts(np.zeros(1, np.int64), np.zeros((0, 2)), np.zeros(0),
                        np.zeros((0, 2)), settings.contacts_per_pair, settings.linear_slop)

    jobs = [cache, reduction]
    count = np.bincount(body_shape, minlength=len(distinct))
    mesh = np.array([s.kind == "mesh" for s in distinct]) & (count > 0)
    sdf, concave = tables.sdf & (count > 0), tables.concave & (count > 0)
    if (np.any(sdf) and np.any(mesh)) or (np.any(concave) and count[mesh].sum() >= 2):
        mesh_shape = distinct[np.flatnonzero(mesh)[0]]
        field_shape = distinct[np.flatnonzero(sdf | concave)[0]]
        jobs.append(lambda: compile_finish(mesh_shape, field_shape, settings))
    return jobs


def collide(shape_a: Any, pose_a: Sequence[float], shape_b: Any, pose_b: Sequence[float],
            margin: float = 0.0, settings: Settings | None = None) -> Contacts:
    """Contacts between two shapes at two poses (body_a = 0, body_b = 1).

    shape_a, shape_b: scene shape dicts (``{"type": "circle", "radius": 0.5}``) or
    Shape objects. pose_a, pose_b: (x, y, angle) of each shape's USER frame (the
    scene's ``position`` and ``angle``), m and rad. margin: m, contacts with
    depth > -margin are returned (0: overlapping only). Normal unit from a toward b,
    depth > 0 overlapping, point midway between the surfaces (world), at most
    ``settings.contacts_per_pair`` points.
    """
    settings = settings or Settings()
    shapes = [shape_from_spec(shape_a, "shape_a"), shape_from_spec(shape_b, "shape_b")]
    user = np.array([pose_a, pose_b], np.float64).reshape(2, 3)
    pose = user.copy()
    for k, shape in enumerate(shapes):
        c, s = np.cos(user[k, 2]), np.sin(user[k, 2])
        ox, oy = shape.origin
        pose[k, :2] -= [c * ox - s * oy, s * ox + c * oy]
    distinct, canonical = _distinct(shapes)
    return _narrowphase(distinct, canonical, np.array([[0, 1]], np.int64), pose,
                        float(margin), np.zeros(2), settings)


class _CollideModule(types.ModuleType):
    """This subpackage, callable as ``collide``: ``sdfphys.collide(shape_a, pose_a, shape_b,
    pose_b)`` is the documented API (DESIGN's contract), and ``import sdfphys.collide``,
    ``from sdfphys.collide import find_contacts`` reach the subpackage, not a function
    that shadows it."""

    def __call__(self, shape_a: Any, pose_a: Sequence[float], shape_b: Any,
                 pose_b: Sequence[float], margin: float = 0.0,
                 settings: Settings | None = None) -> Contacts:
        return collide(shape_a, pose_a, shape_b, pose_b, margin, settings)


sys.modules[__name__].__class__ = _CollideModule
