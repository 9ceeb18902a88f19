"""Narrowphase: contact candidates for a batch of body pairs sharing two Shape objects.

``PAIR_FUNCTIONS[(kind_a, kind_b)]`` (kinds in the order circle < mesh < sdf, lower
kind first as in Box2D's ``b2CollidePolygonAndCircle``) is a pure function

    fn(shape_a, shape_b, body_a, body_b, pose_a, pose_b, margin, settings) -> Contacts

over n pairs that all use the same two Shape objects: body_a, body_b (n,) int64
ids copied into the result; pose_a, pose_b (n, 3) centre-of-mass poses
(x, y, angle) in the world (m, rad); margin (m): candidates with depth > -margin are
returned (speculative contacts). Each shape's field is evaluated in its own body
frame on ONE batch of points gathered from all n pairs (instancing), so the Python
cost is per shape pair, not per body. Results (world frame): ``point`` midway
between the two surfaces, ``normal`` unit from a toward b, ``depth`` > 0
overlapping, ``feature`` a key stable while the contact persists (layout below).
No reduction here: ``collide.reduce`` keeps a few points per pair.

Feature key layout (int64): ``source << 56 | element << 8 | start``

    source   0  analytic (circle-circle, circle-any): element = start = 0; a
                circle outside a concave mesh: element = outline edge e (start 254)
                or vertex (start 255)
             1  a's mesh inside b's field
             2  b's mesh inside a's field
             3  field-field descent (sdf pairs), start = start id
             4  (``SOURCE_SDF_IN_MESH``) the sdf body's point inside mesh a
                (mesh-sdf pairs, ``mesh_sdf``): element = e << 13 with e the mesh
                outline edge pressed on, start = field-field start id k (< 3 x 1024)
                of the deepest point, k + 4096 (``mesh_sdf.FAR_END``) for the far
                end of its incident face; start uses 13 bits, so the key is
                ``4 << 56 | e << 21 | start``
             5  (``polygons.SOURCE_CLIP``) two convex meshes, separating axes and
                clipping: element = vertex_a << 24 | vertex_b, start = 0
             6  (``predicted.SOURCE_PREDICTED``) a circle against a body turning
                fast, at the pair's end-of-step poses: element = start = 0
    start    0-6: a descent minimum of triangle ``element`` from start id 0-2
             (vertices), 3-5 (edge midpoints), 6 (centroid);
             255 (``VERTEX_START``): mesh vertex ``element``, whichever triangle or
             route found it, so a vertex contact keeps its key;
             254 (``EDGE_START``): midpoint of outline edge ``element``;
             sources 3 and 4: a field-field start id (``field_pairs.field_field_contacts``:
             Halton start k < field_descent_starts, or n + 2k, n + 2k + 1 for the two
             ends of start k's flat patch)
    element  < 2^48; source 3: 0 for a descent contact, 1 .. 2 field_tangent_samples
             for the speculative points along its tangent (``field_pairs.tangent_samples``)

Approximations (documented where they act): for a mesh point p inside the other
field f, depth = -f(p) and normal = -grad f(p), or the depth below the face the
pair presses on (``mesh_contacts``); the contact point is p moved by depth / 2 along
the outward normal. This is exact when the other surface is flat near the contact
(a corner pressing into a face) and underestimates depth where a sharp feature of
the field pokes into a face of the mesh, which is why mesh pairs run both ways:
mesh-mesh with each mesh in the other's field, mesh-sdf with the mesh in the sdf's
field and the sdf body's deepest points in the mesh's polygon field (``mesh_sdf``).
The reduction keeps the deeper, exact view: each direction's view of the other's
case is shallower and within its depth of it (shadowed, see ``reduce``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np

from ..sdf import compiled, safe_normalize
from ..sdf.program_table import evaluate_runs
from ..settings import Settings
from ..shapes import Shape
from ..vec2 import rotate
from ._runs import run_starts
from .contacts import Contacts
from .mesh_contacts import EDGE_START, VERTEX_START, mesh_in_field
from .polygons import polygon_contacts, polygon_table
from .shape_fields import ShapeFields, flat_field, pair_fields

__all__ = [
    "BATCH_FUNCTIONS",
    "KIND_ORDER",
    "PAIR_FUNCTIONS",
    "BatchFunction",
    "PairFunction",
    "collide_circle_and_field",
    "collide_circle_field_pairs",
    "collide_circles",
    "collide_mesh_and_sdf",
    "collide_mesh_pairs",
    "collide_mesh_sdf_pairs",
    "collide_meshes",
    "collide_sdf_pairs",
    "collide_sdfs",
    "feature_key",
]

#: Shape kinds in dispatch order: a pair is handled by PAIR_FUNCTIONS[(lower, higher)].
KIND_ORDER = ("circle", "mesh", "sdf")

PairFunction = Callable[[Shape, Shape, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                         float, Settings], Contacts]


#: A batched pair function: ``fn(fields, shape_a, shape_b, body_a, body_b, pose_a, pose_b,
#: margin, run, settings) -> Contacts`` over P pairs of one kind pair and any shapes
#: whose fields compile: shape_a, shape_b (P,) int64 rows of ``fields``
#: (``ShapeFields``), margin (P,) m each pair's, run (P,) int64 each pair's batch (the
#: pairs of one shape pair share one: ``sdf.program_table``); the other arguments and
#: the result as a ``PairFunction``'s. One call for all of a query's pairs of the kind:
#: the same contacts as a ``PairFunction`` call per shape pair.
BatchFunction = Callable[[ShapeFields, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                          np.ndarray, np.ndarray, np.ndarray, np.ndarray, Settings], Contacts]

SOURCE_ANALYTIC, SOURCE_A_IN_B, SOURCE_B_IN_A, SOURCE_FIELDS = 0, 1, 2, 3
#: Source of mesh-sdf contacts found from the sdf's side (``mesh_sdf.sdf_in_mesh``).
SOURCE_SDF_IN_MESH = 4
#: Source 4 keys hold the mesh edge this many bits above the start field, whose
#: field-field start ids (< 3 * 1024, ``field_descent_starts`` <= 1024) plus the far
#: end flag (4096) need 13 bits.
_EDGE_SHIFT = 13


def feature_key(source: int, element: np.ndarray | int, start: np.ndarray | int) -> np.ndarray:
    """Feature keys (int64) ``source << 56 | element << 8 | start`` (see the module doc)."""
    return ((np.int64(source) << np.int64(56)) | (np.asarray(element, np.int64) << np.int64(8))
            | np.asarray(start, np.int64))


#: The key of an analytic contact (source 0, element and start 0).
_ANALYTIC_KEY = int(feature_key(SOURCE_ANALYTIC, 0, 0))


def _one_run(batch: BatchFunction, fields: ShapeFields, body_a: np.ndarray,
             body_b: np.ndarray, pose_a: np.ndarray, pose_b: np.ndarray, margin: float,
             settings: Settings) -> Contacts:
    """A batched pair function on n pairs of one shape pair (rows 0 and 1 of ``fields``),
    one run: what a ``PairFunction`` call of those shapes computes."""
    n = len(body_a)
    zero = np.zeros(n, np.int64)
    return batch(fields, zero, zero + 1, body_a, body_b, pose_a, pose_b,
                 np.full(n, float(margin)), zero, settings)


def _to_local(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """World points (n, 2) into the body frames of poses (n, 3): R^T (p - x)."""
    return rotate(points - pose[:, :2], -pose[:, 2])


def collide_circles(circle_a: Shape, circle_b: Shape, body_a: np.ndarray, body_b: np.ndarray,
                    pose_a: np.ndarray, pose_b: np.ndarray, margin: float,
                    settings: Settings) -> Contacts:
    """Circle-circle, analytic (no field evaluation).

    With centres c_a, c_b, radii r_a, r_b and d = |c_b - c_a|: normal n = (c_b - c_a)/d
    (coincident centres: (1, 0), as pymunk / Chipmunk's circle-circle), depth
    r_a + r_b - d, point midway between c_a + r_a n and c_b - r_b n.
    """
    delta = pose_b[:, :2] - pose_a[:, :2]
    distance = np.hypot(delta[:, 0], delta[:, 1])
    depth = circle_a.radius + circle_b.radius - distance
    keep = depth > -margin
    normal = safe_normalize(delta[keep])
    depth = depth[keep]
    offset = circle_a.radius - 0.5 * depth
    point = pose_a[keep, :2] + offset[:, None] * normal
    n = len(depth)
    return Contacts(body_a[keep], body_b[keep], point, normal, depth,
                    np.full(n, _ANALYTIC_KEY, np.int64))


def collide_circle_and_field(circle_a: Shape, shape_b: Shape, body_a: np.ndarray,
                             body_b: np.ndarray, pose_a: np.ndarray, pose_b: np.ndarray,
                             margin: float, settings: Settings) -> Contacts:
    """Circle against any shape's field: one batched evaluation of f_b at the centres.

    With c the circle centre in b's body frame, (d, g) = f_b(c), grad f_b(c) and
    r the radius: depth = r - d, normal a->b = -R_b g (g points out of b, toward the
    circle), point = c - (d + r)/2 g (midway between b's surface point c - d g and
    the circle's surface point c - r g), in the world. Exact for exact fields;
    inside b, g is the direction to b's nearest boundary point, as pymunk's
    circle-polygon (least-penetrating face). f_b runs as its compiled program
    (``sdf.compiled.evaluate``; the numpy field where it does not compile).

    A centre outside a concave mesh gets instead a contact per outline feature (edge
    or convex vertex) within r + margin (``_circle_outside_concave_mesh``; the
    nearest is the field's contact): a circle in a notch touches two faces, as it
    touches two of Box2D's convex pieces.
    """
    r = circle_a.radius
    concave = shape_b.kind == "mesh" and not shape_b.convex
    if not concave and compiled.compile_field(shape_b.field) is not None:
        return _one_run(collide_circle_field_pairs, pair_fields(circle_a, shape_b), body_a,
                        body_b, pose_a, pose_b, margin, settings)
    centre = _to_local(pose_a[:, :2], pose_b)
    d, g = compiled.evaluate(shape_b.field, centre)
    keep = r - d > -margin
    if concave:
        outside = d > 0.0            # these get a contact per outline feature within reach
        keep &= ~outside
    contacts = _circle_rows(np.full(len(d), r), d, g, keep, body_a, body_b, pose_a, pose_b)
    if not concave:
        return contacts
    row, out, s, element, start = _circle_outside_concave_mesh(shape_b, centre[outside], r,
                                                               margin)
    rows = np.flatnonzero(outside)[row]
    normal = rotate(out, pose_b[rows, 2])
    point = pose_a[rows, :2] - (0.5 * (s + r))[:, None] * normal
    return Contacts.concatenate([contacts, Contacts(
        body_a[rows], body_b[rows], point, -normal, r - s,
        feature_key(SOURCE_ANALYTIC, element, start))])


def collide_circle_field_pairs(fields: ShapeFields, shape_a: np.ndarray, shape_b: np.ndarray,
                               body_a: np.ndarray, body_b: np.ndarray, pose_a: np.ndarray,
                               pose_b: np.ndarray, margin: np.ndarray, run: np.ndarray,
                               settings: Settings) -> Contacts:
    """``collide_circle_and_field`` of circle-sdf pairs of any shapes whose fields compile
    (a ``BatchFunction``): one evaluation of all the fields at the circles' centres
    (``sdf.program_table.evaluate_runs``, each shape pair's centres one batch), the same
    contacts, to the bit, as a call per shape pair."""
    r = fields.radius[shape_a]
    centre = _to_local(pose_a[:, :2], pose_b)
    table = fields.table
    d, g = evaluate_runs(table.code, table.consts, table.start, table.depth, table.nesting,
                         fields.program[shape_b], run, np.arange(len(run)),
                         np.ascontiguousarray(centre), len(run))
    return _circle_rows(r, d, g, r - d > -margin, body_a, body_b, pose_a, pose_b)


def _circle_rows(r: np.ndarray, d: np.ndarray, g: np.ndarray, keep: np.ndarray,
                 body_a: np.ndarray, body_b: np.ndarray, pose_a: np.ndarray,
                 pose_b: np.ndarray) -> Contacts:
    """The contacts of circles of radii r (n,) whose centres have the values d (n,) and
    gradients g (n, 2) of the other fields (their frames), the rows ``keep`` (n,) bool
    (``collide_circle_and_field``'s formulas)."""
    g_world = rotate(safe_normalize(g[keep]), pose_b[keep, 2])
    point = pose_a[keep, :2] - (0.5 * (d[keep] + r[keep]))[:, None] * g_world
    return Contacts(body_a[keep], body_b[keep], point, -g_world, (r - d)[keep],
                    np.full(len(point), _ANALYTIC_KEY, np.int64))


@functools.lru_cache(maxsize=64)
def _outline(mesh: Shape) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A mesh's counter-clockwise outline (M, 2), its edges (M, 2) from vertex j to
    j + 1, the edges into each vertex (M, 2) and whether each vertex is convex (M,):
    the per-mesh part of ``_circle_outside_concave_mesh``, computed once per shape."""
    vertices = mesh.vertices
    edge = np.roll(vertices, -1, axis=0) - vertices
    previous = np.roll(edge, 1, axis=0)
    convex = previous[:, 0] * edge[:, 1] - previous[:, 1] * edge[:, 0] > 0.0
    return vertices, edge, previous, convex


def _circle_outside_concave_mesh(mesh: Shape, centre: np.ndarray, radius: float,
                                 margin: float) -> tuple[np.ndarray, ...]:
    """The outline features of a concave mesh a circle outside it may touch.

    mesh: its counter-clockwise outline ``vertices`` (M, 2); centre: (K, 2) circle centres
    outside it, in its frame; radius, margin: m. A circle in a concave mesh's notch
    touches two faces, but the field at the centre gives the nearest one only (the
    L's side face met a circle 1.9 cm deep a step after its bottom face was the
    contact). Each outline edge whose nearest point to the centre is inside it, with
    the centre on the edge's outer side, and each convex vertex whose region holds
    the centre (nearest point of both its edges) is a feature; those with distance
    s < radius + margin are returned. The nearest feature is the field's contact
    (distance d(c), normal grad f(c)); the others are the faces the circle may meet
    next. Returns (row into centre (F,), unit normal out of the mesh toward the
    centre (F, 2), distance s (F,), key element (F,): edge or vertex index, key start
    (F,): ``mesh_contacts.EDGE_START`` for an edge, ``VERTEX_START`` for a vertex).
    """
    vertices, edge, previous, convex = _outline(mesh)    # previous: the edge into vertex j
    m = len(vertices)
    rel = centre[:, None, :] - vertices[None, :, :]                      # (K, M, 2)
    along = np.sum(rel * edge[None], axis=2)                              # (K, M)
    t = along / np.sum(edge * edge, axis=1)[None, :]
    outer = rel[:, :, 0] * edge[None, :, 1] - rel[:, :, 1] * edge[None, :, 0]
    foot = rel - t[:, :, None] * edge[None]
    face = (t > 0.0) & (t < 1.0) & (outer > 0.0)
    corner = (convex[None, :] & (along <= 0.0)
              & (np.sum(rel * previous[None], axis=2) >= 0.0))
    offset = np.where(face[:, :, None], foot, rel)
    distance = np.hypot(offset[:, :, 0], offset[:, :, 1])
    row, j = np.nonzero((face | corner) & (distance < radius + margin))
    s = distance[row, j]
    normal = offset[row, j] / s[:, None]
    start = np.where(face[row, j], EDGE_START, VERTEX_START)
    return row, normal, s, j % m, start


def collide_meshes(mesh_a: Shape, mesh_b: Shape, body_a: np.ndarray, body_b: np.ndarray,
                   pose_a: np.ndarray, pose_b: np.ndarray, margin: float,
                   settings: Settings) -> Contacts:
    """Mesh-mesh: two convex meshes by separating axes and clipping
    (``polygons.polygon_contacts``); otherwise a's triangles in b's polygon field, then
    b's triangles in a's field.

    Both directions are needed: a vertex of a inside b is found by the first, a
    vertex of b inside a by the second (each is the exact deepest point when the
    face it presses on is flat, which the reduction then picks from).
    """
    if mesh_a.convex and mesh_b.convex:
        vertices, normals, start, count = polygon_table([mesh_a.vertices, mesh_b.vertices])
        pair, point, normal, depth, feature = polygon_contacts(
            vertices, normals, start[0], count[0], start[1], count[1],
            np.ascontiguousarray(pose_a, np.float64), np.ascontiguousarray(pose_b, np.float64),
            float(margin), float(settings.linear_slop))
        return Contacts(body_a[pair], body_b[pair], point, normal, depth, feature)
    return _one_run(collide_mesh_pairs, pair_fields(mesh_a, mesh_b), body_a, body_b, pose_a,
                    pose_b, margin, settings)


def collide_mesh_pairs(fields: ShapeFields, shape_a: np.ndarray, shape_b: np.ndarray,
                       body_a: np.ndarray, body_b: np.ndarray, pose_a: np.ndarray,
                       pose_b: np.ndarray, margin: np.ndarray, run: np.ndarray,
                       settings: Settings) -> Contacts:
    """``collide_meshes`` of mesh-mesh pairs of any shapes (a ``BatchFunction``; mesh
    fields always compile): the pairs with a concave mesh, each mesh in the other's
    field both ways, in two passes of compiled calls over all of them
    (``mesh_contacts.mesh_in_fields``, run by run); pairs of two convex meshes (met here
    only off the closed-form fast path) by a ``collide_meshes`` call per shape pair. The
    same contacts, to the bit, as a call per shape pair."""
    from .mesh_contacts import mesh_in_fields

    convex = fields.convex_mesh[shape_a] & fields.convex_mesh[shape_b]
    parts = []
    bounds = run_starts(run)
    shapes = fields.shape_of
    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
        if convex[lo]:
            parts.append(collide_meshes(shapes[shape_a[lo]], shapes[shape_b[lo]],
                                        body_a[lo:hi], body_b[lo:hi], pose_a[lo:hi],
                                        pose_b[lo:hi], float(margin[lo]), settings))
    rows = np.flatnonzero(~convex)
    if len(rows) == 0:
        return Contacts.concatenate(parts)
    a, b, pa, pb = shape_a[rows], shape_b[rows], pose_a[rows], pose_b[rows]
    m, r = margin[rows], run[rows]
    pair, point, out_b, depth, tri, start = mesh_in_fields(fields, a, b, pa, pb, m, r, settings,
                                                           True)
    pair = rows[pair]
    parts.append(Contacts(body_a[pair], body_b[pair], point, -out_b, depth,
                          feature_key(SOURCE_A_IN_B, tri, start)))
    pair, point, out_a, depth, tri, start = mesh_in_fields(fields, b, a, pb, pa, m, r, settings,
                                                           True)
    pair = rows[pair]
    parts.append(Contacts(body_a[pair], body_b[pair], point, out_a, depth,
                          feature_key(SOURCE_B_IN_A, tri, start)))
    return Contacts.concatenate(parts)


def collide_mesh_and_sdf(mesh_a: Shape, sdf_b: Shape, body_a: np.ndarray, body_b: np.ndarray,
                         pose_a: np.ndarray, pose_b: np.ndarray, margin: float,
                         settings: Settings) -> Contacts:
    """Mesh-sdf: the mesh in the sdf's field, then the sdf body in the mesh, both batched.

    1. ``mesh_contacts.mesh_in_field``: the mesh's triangles (descent minima),
       vertices and edge midpoints in the sdf's field (source 1). Exact for a mesh
       vertex or edge pressing on the sdf, and for faces resting on faces.
    2. ``mesh_sdf.sdf_in_mesh``: where the sdf body is inside the mesh
       (``field_pairs.field_field_contacts`` on the sdf's field and the mesh's exact
       polygon field, over the overlap of the bounds in the sdf's frame), each point
       then moved to the sdf body's deepest point along the mesh face's inward
       normal (source 4), plus the far end of the sdf face leaving it toward the
       mesh face (Box2D's incident face: the other bottom corner of a box resting
       slightly tilted), measured against the same mesh face. Exact for a corner or
       face of the sdf pressing on a face of the mesh, where the first direction
       underestimates the depth (a square corner pressed straight in: by 29 %) and
       takes the corner's side as normal.

    A flat sdf (a half-plane, ``shape_fields.flat_field``) runs the first direction only:
    it is exact there.
    Each direction's wrong view of the other's case (shallower, within its depth of
    the right one) is shadowed in the reduction (``reduce``). Cost per group: the
    first direction's ``descent_iterations + 3`` evaluations of the sdf field, one
    ``field_field_contacts`` (at most ``2 field_descent_iterations + 3``) and
    ``mesh_sdf.SDF_CALLS``, each over all pairs at once.
    """
    from .mesh_sdf import sdf_in_mesh

    fields = pair_fields(mesh_a, sdf_b)
    if fields.program[0] >= 0 and fields.program[1] >= 0:
        return _one_run(collide_mesh_sdf_pairs, fields, body_a, body_b, pose_a, pose_b, margin,
                        settings)
    pair, point, out_b, depth, tri, start = mesh_in_field(mesh_a, sdf_b, pose_a, pose_b,
                                                          margin, settings, False)
    forward = Contacts(body_a[pair], body_b[pair], point, -out_b, depth,
                       feature_key(SOURCE_A_IN_B, tri, start))
    if flat_field(sdf_b):
        return forward
    pair, point, normal, depth, edge, start = sdf_in_mesh(mesh_a, sdf_b, pose_a, pose_b,
                                                          margin, settings)
    reverse = Contacts(body_a[pair], body_b[pair], point, normal, depth,
                       feature_key(SOURCE_SDF_IN_MESH, edge << _EDGE_SHIFT, start))
    return Contacts.concatenate([forward, reverse])


def collide_mesh_sdf_pairs(fields: ShapeFields, shape_a: np.ndarray, shape_b: np.ndarray,
                           body_a: np.ndarray, body_b: np.ndarray, pose_a: np.ndarray,
                           pose_b: np.ndarray, margin: np.ndarray, run: np.ndarray,
                           settings: Settings) -> Contacts:
    """``collide_mesh_and_sdf`` of mesh-sdf pairs of any shapes whose fields compile (a
    ``BatchFunction``): the meshes in the sdf fields (``mesh_contacts.mesh_in_fields``),
    then the sdf bodies in the meshes where the sdf is not flat
    (``mesh_sdf.sdf_in_meshes``), each a pass of compiled calls over all pairs, run by
    run: the same contacts, to the bit, as a call per shape pair."""
    from .mesh_contacts import mesh_in_fields
    from .mesh_sdf import sdf_in_meshes

    pair, point, out_b, depth, tri, start = mesh_in_fields(fields, shape_a, shape_b, pose_a,
                                                           pose_b, margin, run, settings, False)
    forward = Contacts(body_a[pair], body_b[pair], point, -out_b, depth,
                       feature_key(SOURCE_A_IN_B, tri, start))
    rows = np.flatnonzero(~fields.flat[shape_b])
    if len(rows) == 0:
        return forward
    pair, point, normal, depth, edge, start = sdf_in_meshes(
        fields, shape_a[rows], shape_b[rows], pose_a[rows], pose_b[rows], margin[rows],
        run[rows], settings)
    pair = rows[pair]
    reverse = Contacts(body_a[pair], body_b[pair], point, normal, depth,
                       feature_key(SOURCE_SDF_IN_MESH, edge << _EDGE_SHIFT, start))
    return Contacts.concatenate([forward, reverse])


def collide_sdfs(sdf_a: Shape, sdf_b: Shape, body_a: np.ndarray, body_b: np.ndarray,
                 pose_a: np.ndarray, pose_b: np.ndarray, margin: float,
                 settings: Settings) -> Contacts:
    """Sdf-sdf: ``field_pairs.field_field_contacts`` (Liu et al. 2024; MuJoCo's SDF-SDF).

    Each pair is solved in a's body frame: b placed by the relative pose (angle
    a_b - a_a, offset R_a^T (x_b - x_a)), ``settings.field_descent_starts`` Halton
    starts over the overlap of the two bounds (grown by the margin), at most
    ``settings.field_descent_iterations`` descent iterations on max(f_a, f_b); the
    overlapping contacts re-measured one-sided at sharp features
    (``field_pairs.one_sided_depths``), then speculative points along each contact's
    tangent (``field_pairs.tangent_samples``). Points, normals (a toward b) and depths
    come back in a's frame and are rotated to the world; keys are (source 3, start id).

    The region needs b bounded: when only a is bounded (an sdf body whose shape was
    made before the sdf ground's), the pair is solved the other way round and flipped.

    When both fields compile this is ``collide_sdf_pairs`` (the batched pair function
    ``_narrowphase`` calls for all sdf-sdf pairs of a query at once); otherwise the
    numpy path of the same stages, the tests' reference.
    """
    from .field_pairs import one_sided_depths, placed_field_contacts, tangent_samples

    fields = pair_fields(sdf_a, sdf_b)
    if fields.program[0] >= 0 and fields.program[1] >= 0:
        return _one_run(collide_sdf_pairs, fields, body_a, body_b, pose_a, pose_b, margin,
                        settings)
    if not math.isfinite(sdf_b.radius) and math.isfinite(sdf_a.radius):   # bounded: finite
        c = collide_sdfs(sdf_b, sdf_a, body_b, body_a, pose_b, pose_a, margin, settings)
        return Contacts(c.body_b, c.body_a, c.point, -c.normal, c.depth, c.feature)
    angle = pose_b[:, 2] - pose_a[:, 2]
    offset = _to_local(pose_b[:, :2], pose_a)
    _, pair, point, depth, normal, start = placed_field_contacts(
        sdf_a.field, sdf_b.field, offset, angle, sdf_a.bounds(), sdf_b.bounds(), margin,
        settings.field_descent_starts, settings.field_descent_iterations)
    point, depth, normal = one_sided_depths(sdf_a.field, sdf_b.field, offset, angle, pair,
                                            point, depth, normal)
    pair, point, depth, normal, start, element = tangent_samples(
        sdf_a.field, sdf_b.field, offset, angle, pair, point, depth, normal, start, margin,
        min(sdf_a.radius, sdf_b.radius), settings.field_tangent_samples)
    rot = pose_a[pair, 2]
    return Contacts(body_a[pair], body_b[pair], rotate(point, rot) + pose_a[pair, :2],
                    rotate(normal, rot), depth, feature_key(SOURCE_FIELDS, element, start))


def collide_sdf_pairs(fields: ShapeFields, shape_a: np.ndarray, shape_b: np.ndarray,
                      body_a: np.ndarray, body_b: np.ndarray, pose_a: np.ndarray,
                      pose_b: np.ndarray, margin: np.ndarray, run: np.ndarray,
                      settings: Settings) -> Contacts:
    """``collide_sdfs`` of sdf-sdf pairs of any shapes whose fields compile, in one pass
    of compiled calls (a ``BatchFunction``): the placements, the descent and the merges
    (``field_pairs.placed_contacts``), the one-sided depths and the tangent samples,
    each pair with its own fields, bounds and margin, each shape pair's points in its
    own batches: the same contacts, to the bit, as a call per shape pair. A pair whose
    b is unbounded and a bounded is solved the other way round and flipped back."""
    from .field_pairs import PairPrograms, one_sided_programs, placed_contacts, tangent_programs

    radius = fields.radius
    flip = ~np.isfinite(radius[shape_b]) & np.isfinite(radius[shape_a])
    if flip.any():
        swap = flip[:, None]
        shape_a, shape_b = np.where(flip, shape_b, shape_a), np.where(flip, shape_a, shape_b)
        body_a, body_b = np.where(flip, body_b, body_a), np.where(flip, body_a, body_b)
        pose_a, pose_b = np.where(swap, pose_b, pose_a), np.where(swap, pose_a, pose_b)
    programs = PairPrograms(fields.table, fields.program[shape_a], fields.program[shape_b],
                            run)
    angle = pose_b[:, 2] - pose_a[:, 2]
    offset = _to_local(pose_b[:, :2], pose_a)
    _, pair, point, depth, normal, start = placed_contacts(
        programs, offset, angle, fields.bounds[shape_a], fields.bounds[shape_b], margin,
        settings.field_descent_starts, settings.field_descent_iterations)
    point, depth, normal = one_sided_programs(programs, offset, angle, pair, point, depth,
                                              normal)
    pair, point, depth, normal, start, element = tangent_programs(
        programs, offset, angle, pair, point, depth, normal, start, margin,
        np.minimum(radius[shape_a], radius[shape_b]), settings.field_tangent_samples)
    rot = pose_a[pair, 2]
    normal = rotate(normal, rot)
    lo, hi = body_a[pair], body_b[pair]
    if flip.any():
        back = flip[pair]
        lo, hi = np.where(back, hi, lo), np.where(back, lo, hi)
        normal = np.where(back[:, None], -normal, normal)
    return Contacts(lo, hi, rotate(point, rot) + pose_a[pair, :2], normal, depth,
                    feature_key(SOURCE_FIELDS, element, start))


#: (kind_a, kind_b) -> pair function, kind_a <= kind_b in KIND_ORDER.
PAIR_FUNCTIONS: dict[tuple[str, str], PairFunction] = {
    ("circle", "circle"): collide_circles,
    ("circle", "mesh"): collide_circle_and_field,
    ("circle", "sdf"): collide_circle_and_field,
    ("mesh", "mesh"): collide_meshes,
    ("mesh", "sdf"): collide_mesh_and_sdf,
    ("sdf", "sdf"): collide_sdfs,
}

#: (kind_a, kind_b) -> batched pair function (``BatchFunction``), where there is one.
BATCH_FUNCTIONS: dict[tuple[str, str], BatchFunction] = {
    ("circle", "sdf"): collide_circle_field_pairs,
    ("mesh", "mesh"): collide_mesh_pairs,
    ("mesh", "sdf"): collide_mesh_sdf_pairs,
    ("sdf", "sdf"): collide_sdf_pairs,
}
