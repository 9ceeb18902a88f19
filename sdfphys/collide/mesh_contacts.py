"""Contact candidates of a triangle mesh inside another shape's field, n pairs at once.

Used by the narrowphase for mesh-mesh (both ways) and mesh-sdf pairs. Everything
happens in the other shape's body frame ("local"); one call handles n pairs that
share the same mesh and the same other shape, so each stage is one batched field
evaluation whatever n is.

Stages (derivations in each function's docstring):

1. ``_descent_minima``: local minima of the other field f over every triangle
   (``descent.triangle_deepest``, Macklin et al. 2020): the points of the mesh
   deepest in the other shape, depth -f, normal grad f.
2. ``_samples``: the mesh's outline vertices and outline edge midpoints with
   f < margin. A descent minimum is a LOCAL minimum: a box resting slightly tilted
   has one (its deeper corner); its other corner is still a contact.
3. Polygon filters (other is a polygon too and the pair also runs the other way):
   minima off the outline are slivers of triangles cut by a corner of the other
   polygon; ``_face_normals`` drops candidates whose normal is not a face's (on a
   medial axis, or nearest to a vertex of the other polygon). Polygon contacts are
   vertex-face or face-face (separating axis theorem), so the other direction, or
   step 4, carries what is dropped.
4. ``_reference_faces`` (Box2D's reference face and clipping, in SDF form): every
   kept candidate proposes the face under it as a contact plane; a plane under
   which some mesh vertex inside the other shape lies deeper than anything reaches
   into it (plus the slop) is cut by the mesh, not pressed by it, and is rejected
   (a side face near the end of a thin overlap strip: SAT's non-minimal axis). Mesh
   vertices are measured against the accepted planes.

When the other field compiles (``sdf.compiled``), the stages run in two compiled
kernels around the descent, with the field's program evaluated inside them:
``_place`` (the mesh in other's frame and ``descent.triangle_cull``) and
``_finish`` (stages 1 after the descent to 4, the first row per key and the world
frame), each stage's points still evaluated in one batch; a call then costs a
fixed handful of Python calls, nothing per pair or candidate. ``mesh_in_fields`` (a
batched pair function's) takes the pairs of many meshes and fields: the two kernels
per shape pair, the descent of all their triangles in one call. Otherwise the
numpy stages run (``_mesh_in_field_numpy``: the functions above, the reference
the compiled kernels are tested against, bit for bit, with the field wrapped so
that it does not compile: tests/oracles.py).

Keys (see ``narrowphase`` for the layout): descent minima keep (triangle, start id; with
starts chosen by sampling, ``settings.descent_lattice`` > 0, ``SAMPLED_START`` + the
start's rank); a minimum at a mesh vertex, a vertex sample and a vertex measured against
a face all get the vertex key (element = vertex index, start ``VERTEX_START``), edge
midpoints the edge key (element = outline edge index, start ``EDGE_START``); one
candidate per key and pair survives, in the order: face measures (deepest face first),
then descent minima and samples.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..sdf import Field, compiled, safe_normalize
from ..settings import Settings
from ..shapes import Shape
from . import descent, lattice
from ._mesh_contacts_kernels import (
    _AXES,
    _KINK,
    _ON_EDGE,
    _ON_FACE,
    _PROBE,
    _RUNS_ALONG,
    EDGE_START,
    VERTEX_START,
    _finish,
    _place,
)
from ._runs import run_starts
from .shape_fields import ShapeFields, pair_fields

__all__ = ["EDGE_START", "SAMPLED_START", "VERTEX_START", "mesh_in_field", "mesh_in_fields"]

#: Descent start ids in the order ``settings.descent_starts`` takes them: centroid, edge
#: midpoints, then vertices (the vertices are sampled anyway, see ``_samples``).
_START_PRIORITY = np.array([6, 3, 4, 5, 0, 1, 2])
#: Start id of rank 0 of starts chosen by sampling (``settings.descent_lattice`` > 0):
#: rank k (by sample value) has id SAMPLED_START + k, apart from the fixed starts' ids.
SAMPLED_START = 16
#: Descent starts of one triangle ending closer than this (m) are one minimum (the
#: lowest start id is kept, a stable key); far below any physical length.
_MERGE_RADIUS = 1e-6


@dataclass
class _Candidates:
    """C candidate contacts in other's frame: mesh point, depth (m), outward normal."""

    pair: np.ndarray        # (C,) index of the pair in the batch
    element: np.ndarray     # (C,) triangle, vertex or edge index (see start)
    start: np.ndarray       # (C,) descent start id, VERTEX_START or EDGE_START
    point: np.ndarray       # (C, 2) the mesh's point, other's frame
    depth: np.ndarray       # (C,) -f(point), or the depth below a reference face
    normal: np.ndarray      # (C, 2) unit outward normal of other (zeros: not yet known)

    def take(self, index: np.ndarray) -> _Candidates:
        return _Candidates(*(getattr(self, f.name)[index] for f in fields(self)))

    @classmethod
    def concatenate(cls, parts: list[_Candidates]) -> _Candidates:
        return cls(*(np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(cls)))


def _sampled_minima(field: Field, tri: np.ndarray, settings: Settings
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``lattice.triangle_deepest_sampled`` with the settings' lattice, starts and
    iterations: point (T, K, 2), value (T, K) and the start ids (K,) of the ranks."""
    point, value = lattice.triangle_deepest_sampled(
        field, tri, settings.descent_lattice, settings.descent_starts,
        iterations=settings.descent_iterations)
    return point, value, SAMPLED_START + np.arange(point.shape[1], dtype=np.int64)


def _barycentric(triangle: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Barycentric weights (C, 3) of points (C, 2) in triangles (C, 3, 2) (signed areas)."""
    v0, v1, v2 = triangle[:, 0], triangle[:, 1], triangle[:, 2]

    def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]

    area = cross(v1 - v0, v2 - v0)
    return np.stack([cross(v1 - point, v2 - point), cross(v2 - point, v0 - point),
                     cross(v0 - point, v1 - point)], axis=1) / area[:, None]


def _first_per_key(*keys: np.ndarray) -> np.ndarray:
    """Sorted indices of the first row (in input order) of each distinct key tuple."""
    if len(keys[0]) == 0:
        return np.zeros(0, np.int64)
    order = np.lexsort((np.arange(len(keys[0])),) + keys[::-1])
    sorted_keys = np.stack([k[order] for k in keys], axis=1)
    new = np.r_[True, np.any(sorted_keys[1:] != sorted_keys[:-1], axis=1)]
    return np.sort(order[new])


def _descent_minima(mesh: Shape, field: Field, local: np.ndarray, margin: float,
                    settings: Settings, outline_only: bool) -> _Candidates:
    """Minima of f over each triangle (n pairs x T triangles ``local`` (n T, 3, 2)).

    ``descent.triangle_cull`` drops triangles that cannot reach f < margin,
    ``descent.triangle_deepest`` descends from each triangle's first
    ``settings.descent_starts`` starts in ``_START_PRIORITY`` order (start ids keep
    their ``descent.START_BARYCENTRIC`` numbering),
    ``descent.merge_minima`` keeps one start per distinct minimum. With
    ``outline_only``, minima off the mesh's outline are dropped (see the module
    docstring); minima at a mesh vertex get the vertex key. Normals are left zero.
    """
    n_tri = len(mesh.triangles)
    start_ids = _START_PRIORITY[:max(1, min(settings.descent_starts, len(_START_PRIORITY)))]
    kept = np.nonzero(descent.triangle_cull(field, local, margin))[0]
    if settings.descent_lattice > 0:
        point, value, start_ids = _sampled_minima(field, local[kept], settings)
    else:
        point, value = descent.triangle_deepest(field, local[kept],
                                                iterations=settings.descent_iterations,
                                                starts=descent.START_BARYCENTRIC[start_ids])
    distinct = descent.merge_minima(point, _MERGE_RADIUS)
    hit, column = np.nonzero(distinct & (value < margin))
    start = start_ids[column]
    flat = kept[hit]
    element = flat % n_tri
    p = point[hit, column]
    weight = _barycentric(local[flat], p)
    keep = (np.any((weight <= _ON_EDGE) & mesh.outline_edges[element], axis=1)
            if outline_only else np.ones(len(p), bool))
    at_vertex = np.max(weight, axis=1) >= 1.0 - _ON_EDGE
    corner = mesh.triangles[element, np.argmax(weight, axis=1)]
    c = _Candidates(flat // n_tri, np.where(at_vertex, corner, element),
                    np.where(at_vertex, VERTEX_START, start), p, -value[hit, column],
                    np.zeros_like(p))
    return c.take(keep)


def _samples(mesh: Shape, field: Field, vertices: np.ndarray, margin: float) -> _Candidates:
    """Outline vertices and outline edge midpoints (n, V, 2) of every pair with f < margin.

    ``vertices``: the mesh's vertices in other's frame per pair. One distance call.
    """
    m = vertices.shape[1]
    midpoints = 0.5 * (vertices + np.roll(vertices, -1, axis=1))
    points = np.concatenate([vertices, midpoints], axis=1).reshape(-1, 2)
    f = compiled.distance(field, points)
    index = np.nonzero(f < margin)[0]
    slot = index % (2 * m)
    return _Candidates(index // (2 * m), slot % m,
                       np.where(slot < m, VERTEX_START, EDGE_START), points[index],
                       -f[index], np.zeros((len(index), 2)))


def _edge_normals(mesh: Shape, local: np.ndarray, c: _Candidates) -> np.ndarray:
    """Outward unit normal (C, 2) of the mesh's outline edge under each descent minimum.

    local: (n T, 3, 2) the pairs' triangles in other's frame (counter-clockwise); a
    descent minimum of triangle t lies on its edge k (opposite vertex k) when its
    barycentric weight k is at most ``_ON_EDGE``; the first such outline edge is taken.
    Zeros for vertex and edge-midpoint keys and minima on no outline edge.
    """
    normal = np.zeros((len(c.depth), 2))
    rows = np.flatnonzero((c.start != VERTEX_START) & (c.start != EDGE_START))
    tri = local[c.pair[rows] * len(mesh.triangles) + c.element[rows]]
    on = (_barycentric(tri, c.point[rows]) <= _ON_EDGE) & mesh.outline_edges[c.element[rows]]
    k = np.argmax(on, axis=1)
    a = tri[np.arange(len(rows)), (k + 1) % 3]
    e = tri[np.arange(len(rows)), (k + 2) % 3] - a
    length = np.sqrt(e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1])
    out = np.stack([e[:, 1] / length, -e[:, 0] / length], axis=1)
    normal[rows] = np.where(np.any(on, axis=1)[:, None], out, 0.0)
    return normal


def _face_normals(field: Field, p: np.ndarray, depth: np.ndarray, edge: np.ndarray,
                  centre: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                             np.ndarray]:
    """Unit gradient (C, 2) at points p (C, 2), (C,) bool: it is a face's normal, and
    the depths (C,) (changed where a kink takes a face's, below); then a second face
    for kinks crossed by the mesh's edge, (C,) bool: there is one, its normal (C, 2)
    and the depths below it (C,).

    One evaluation of 7 C points. The normal at p is trusted when (a) the gradient
    is the same at p +- h x and p +- h y (p is not on a kink of f, such as the
    medial axis of a polygon, where the gradient picks one of two faces) and (b)
    the gradient is the same at the foot q = p + depth g +- h t, t the tangent
    (the nearest boundary point is inside a face, not a vertex: outside a corner
    the gradient points from that corner and the normal of a vertex-vertex pair
    is ill-defined). (b) applies outside the field only (depth <= 0): the nearest
    boundary point of a point inside is a vertex only if that vertex is reflex (a
    concave corner of the other polygon), which the other direction cannot report,
    and the gradient there, from the corner to p, is the direction that separates
    them (a star's spike tip pushed into an arrow's notch was missed 4 cm deep).
    h = ``_PROBE``; "the same" is within ``_KINK`` (rad).

    A kink inside other (depth > 0) on a mesh outline edge of outward normal e
    (``edge`` (C, 2), zeros elsewhere) takes the face, among the probes' gradients
    g_a, most anti-parallel to e when g_a.e <= -``_RUNS_ALONG``: the mesh's edge runs
    along that face of other (two polygons' corners crossing, a sliver overlap along
    one side; Box2D's reference face is the one most anti-parallel to the incident
    edge). Its normal is g_a and its depth p's below that face, -(f(p + h_a) - h_a.g_a)
    (exact for a polygon's field). The corner's other face, crossed by the edge, is
    no contact plane; without the rule the kink (the deepest point of the overlap,
    on other's medial axis) was dropped and the pair reported a vertex 3.4 mm deep
    where the overlap is 1.4 cm.

    A kink inside other on a mesh outline edge that runs along neither face is
    crossed by the edge: the edge cuts across a corner of other, or across one of its
    arms (a star's spike through an L's corner, two L's arms in a '+'). The kink is
    the deepest point of that edge inside other, and no vertex of either polygon may
    be (each outline crosses the other's with its vertices outside). Neither face is
    the incident edge's reference face; it takes first the face on the side of the
    mesh's centre of mass (``centre`` (C, 2), in other's frame: among the probes'
    gradients the g_a with the largest g_a.(centre - p), so that every crossed kink of
    a pair pushes the mesh the same way, out where its bulk is), then the face the
    probes' gradients turn most from it, its second (``_reference_faces`` takes the
    second only where the first is cut). Without it such a crossing was seen by no
    row: the '+' read 0.1 m where its arms overlap 0.2 m deep on either side of the
    kink, and a star's spike cut 92 mm into an L's corner while the rows read under
    2 mm (docs/stability.md).
    """
    n = len(p)
    points = np.concatenate([p, (p[:, None, :] + _PROBE * _AXES[None]).reshape(-1, 2)])
    f, g = compiled.evaluate(field, points)
    g = safe_normalize(g)
    g0, around = g[:n], g[n:].reshape(n, 4, 2)
    foot = p + depth[:, None] * g0
    tangent = np.stack([-g0[:, 1], g0[:, 0]], axis=1)
    sides = np.concatenate([foot + _PROBE * tangent, foot - _PROBE * tangent])
    g_foot = safe_normalize(compiled.evaluate(field, sides)[1])
    g_foot = g_foot.reshape(2, n, 2).transpose(1, 0, 2)
    turn = np.sum((np.concatenate([around, g_foot], axis=1) - g0[:, None, :]) ** 2, axis=2)
    same = turn <= _KINK ** 2
    face = np.all(same[:, :4], axis=1) & (np.all(same[:, 4:], axis=1) | (depth > 0.0))
    facing = np.einsum("cad,cd->ca", around, edge)                       # (C, 4)
    a = np.argmin(facing, axis=1)
    rows = np.arange(n)
    along = ~face & (depth > 0.0) & (facing[rows, a] <= -_RUNS_ALONG)
    crossed = ~face & (depth > 0.0) & ~along & np.any(edge != 0.0, axis=1)
    toward = np.einsum("cad,cd->ca", around, centre - p)                   # (C, 4)
    a = np.where(crossed, np.argmax(toward, axis=1), a)
    g_a = around[rows, a]
    below = -(f[n:].reshape(n, 4)[rows, a] - np.einsum("cd,cd->c", _PROBE * _AXES[a], g_a))
    turn = np.sum((around - g_a[:, None, :]) ** 2, axis=2)                # (C, 4)
    b = np.argmax(turn, axis=1)
    second = crossed & (turn[rows, b] > _KINK ** 2)
    g_b = around[rows, b]
    below_b = -(f[n:].reshape(n, 4)[rows, b] - np.einsum("cd,cd->c", _PROBE * _AXES[b], g_b))
    taken = along | crossed
    return (np.where(taken[:, None], g_a, g0), face | taken, np.where(taken, below, depth),
            second, g_b, below_b)


def _reference_faces(field: Field, c: _Candidates, vertices: np.ndarray, deepest: np.ndarray,
                     margin: float, slop: float, second_of: np.ndarray
                     ) -> tuple[np.ndarray, _Candidates]:
    """Which candidates' faces are contact planes, and the vertices measured on them.

    For candidate r (point p, depth d, outward normal g), the face point is
    q = p + d g (on other's surface for an exact field). A mesh vertex v of the same
    pair is *supported* by the face when its foot v - s g, s = (v - q).g, lies on
    other's surface (|f| <= ``_ON_FACE``: the face extends under v) and v is near
    other, not across it: f(v) <= margin in front of the plane (s >= 0), f(v) <= 0
    (inside other, to ``_ON_FACE``) behind it. A vertex behind the face whose foot is
    on it but which lies outside other has passed through other to its far side
    (the inward ray from the foot leaves other before it reaches v): it cuts no
    plane, and is no contact. With f(v) <= margin there too, the tip of a clamp's
    spike 0.02 deep in a plank went unseen whenever the tip of its other spike lay
    across the plank within the margin (the world's margin grows with the bodies'
    reach; tests/test_narrowphase.py, the plank and the clamp), and a star's spike
    crossed a U's arm 85 mm deep while the pair's rows read 0.3 mm (docs/stability.md,
    "Every shipped scene under 1 cm"). The face is a contact plane when no supported
    vertex lies deeper below it than the pair's deepest point (``deepest`` (n,): max
    of -f over the mesh, from the descent) plus ``slop``:
    otherwise the mesh cuts through the plane (a side face near the end of a thin
    overlap), and pushing along it would take more than the actual penetration.
    second_of (C,): for a kink's second face (``_face_normals``) the row of its first,
    else -1; a second face is a contact plane only where its first is not.
    Returns the (C,) mask and the supported vertices of accepted faces with s <
    margin as candidates (depth -s, normal g), deepest faces first.
    """
    v = vertices[c.pair]                                            # (C, V, 2)
    q = c.point + c.depth[:, None] * c.normal
    s = np.einsum("cvi,ci->cv", v - q[:, None, :], c.normal)
    r_idx, v_idx = np.nonzero(s < margin)
    sep = s[r_idx, v_idx]
    vv = v[r_idx, v_idx]
    f = compiled.distance(field,
                          np.concatenate([vv - sep[:, None] * c.normal[r_idx], vv]))
    near = np.where(sep >= 0.0, margin + _ON_FACE, _ON_FACE)
    supported = (np.abs(f[:len(vv)]) <= _ON_FACE) & (f[len(vv):] <= near)
    cut = supported & (-sep > deepest[c.pair[r_idx]] + slop)
    accepted = np.ones(len(c.depth), bool)
    accepted[r_idx[cut]] = False
    second = np.flatnonzero(second_of >= 0)
    accepted[second] &= ~accepted[second_of[second]]
    use = supported & accepted[r_idx]
    r_idx, v_idx, sep = r_idx[use], v_idx[use], sep[use]
    order = np.lexsort((-c.depth[r_idx], c.pair[r_idx]))
    r_idx, v_idx, sep = r_idx[order], v_idx[order], sep[order]
    measured = _Candidates(c.pair[r_idx], v_idx, np.full(len(v_idx), VERTEX_START),
                           v[r_idx, v_idx], -sep, c.normal[r_idx])
    return accepted, measured


def _mesh_in_field_numpy(mesh: Shape, other: Shape, pose_mesh: np.ndarray,
                        pose_other: np.ndarray, margin: float, settings: Settings,
                        polygon_pair: bool
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                   np.ndarray]:
    """``mesh_in_field`` stage by stage in numpy: the path of fields that do not
    compile, and the reference of the compiled one (same results, bit for bit)."""
    n = len(pose_mesh)
    angle = pose_mesh[:, 2] - pose_other[:, 2]
    cos, sin = np.cos(angle), np.sin(angle)
    rotation = np.stack([np.stack([cos, -sin], axis=1), np.stack([sin, cos], axis=1)], axis=1)
    d = pose_mesh[:, :2] - pose_other[:, :2]
    co, so = np.cos(pose_other[:, 2]), np.sin(pose_other[:, 2])
    offset = np.stack([co * d[:, 0] + so * d[:, 1], -so * d[:, 0] + co * d[:, 1]], axis=1)
    vertices = np.einsum("nij,vj->nvi", rotation, mesh.vertices) + offset[:, None, :]
    local = vertices[:, mesh.triangles].reshape(-1, 3, 2)

    c = _Candidates.concatenate([
        _descent_minima(mesh, other.field, local, margin, settings, polygon_pair),
        _samples(mesh, other.field, vertices, margin)])
    if len(c.depth) == 0:
        return c.pair, c.point, c.normal, c.depth, c.element, c.start
    deepest = np.full(n, -np.inf)
    np.maximum.at(deepest, c.pair, c.depth)
    if polygon_pair:
        normal, face, depth, second, normal_b, depth_b = _face_normals(
            other.field, c.point, c.depth, _edge_normals(mesh, local, c), offset[c.pair])
        # Each kept candidate, then its second face if it has one.
        row, which = np.nonzero(np.stack([face, second], axis=1))
        c = c.take(row)
        c.normal = np.where((which == 1)[:, None], normal_b[row], normal[row])
        c.depth = np.where(which == 1, depth_b[row], depth[row])
        second_of = np.where(which == 1, np.arange(len(row)) - 1, -1)
        if len(c.depth) == 0:
            return c.pair, c.point, c.normal, c.depth, c.element, c.start
    else:
        c.normal = safe_normalize(compiled.evaluate(other.field, c.point)[1])
        second_of = np.full(len(c.depth), -1)
    accepted, measured = _reference_faces(other.field, c, vertices, deepest, margin,
                                          settings.linear_slop, second_of)
    c = _Candidates.concatenate([measured, c.take(accepted)])
    c = c.take(_first_per_key(c.pair, c.element, c.start))

    mid = c.point + (0.5 * c.depth)[:, None] * c.normal
    co, so = co[c.pair], so[c.pair]
    world_mid = np.stack([co * mid[:, 0] - so * mid[:, 1], so * mid[:, 0] + co * mid[:, 1]],
                         axis=1) + pose_other[c.pair, :2]
    world_normal = np.stack([co * c.normal[:, 0] - so * c.normal[:, 1],
                             so * c.normal[:, 0] + co * c.normal[:, 1]], axis=1)
    return c.pair, world_mid, world_normal, c.depth, c.element, c.start


# --------------------------------------------------------------------------------------
# The compiled path: the same stages, the field's program evaluated in the kernels
# --------------------------------------------------------------------------------------

#: Start weights (K, 3) per number of descent starts, in ``_START_PRIORITY`` order.
_STARTS = {k: np.ascontiguousarray(descent.START_BARYCENTRIC[_START_PRIORITY[:k]])
           for k in range(1, len(_START_PRIORITY) + 1)}


def compile_finish(mesh: Shape, other: Shape, settings: Settings) -> None:
    """``_finish`` compiled (or loaded) with the argument types of ``mesh_in_fields``'
    calls, on no pairs (one compilation serves every mesh and field: the types do not
    depend on them): a cold start's parent compiles the end of the path while it waits
    for the compiling child, which compiles its start (``collide.compile_behind``).
    Nothing where the path does not call it (a field that does not compile)."""
    fields = pair_fields(mesh, other)
    if fields.program[1] < 0:
        return
    start_ids = _START_PRIORITY[:max(1, min(settings.descent_starts, len(_START_PRIORITY)))]
    starts = len(start_ids)
    table, p = fields.table, fields.program[1]
    t0, t1 = fields.triangle_start[0], fields.triangle_start[1]
    _finish(fields.triangles[t0:t1], fields.outline_edges[t0:t1],
            np.zeros((0, len(mesh.vertices), 2)),
            np.zeros(0, np.int64), np.zeros((0, starts, 2)), np.zeros((0, starts)),
            np.zeros((0, starts), np.bool_), start_ids,
            table.code[table.start[p]:table.start[p + 1]], table.consts, table.depth,
            table.nesting, 0.0, True, float(settings.linear_slop), np.zeros(0), np.zeros(0),
            np.zeros((0, 3)), np.zeros((0, 3)))


def mesh_in_field(mesh: Shape, other: Shape, pose_mesh: np.ndarray, pose_other: np.ndarray,
                  margin: float, settings: Settings, polygon_pair: bool
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                             np.ndarray]:
    """Contacts of ``mesh`` inside ``other``'s field for n pairs (see the module doc).

    pose_mesh, pose_other: (n, 3) centre-of-mass poses (x, y, angle), world.
    margin: m, candidates with depth > -margin. polygon_pair: other is a polygon
    and the caller also runs other's mesh in this mesh's field (stage 3).
    Returns pair index (C,), midway point (C, 2) world (the mesh point moved by
    depth / 2 along the normal), outward normal of other (C, 2) world (from other
    toward the mesh), depth (C,), key element (C,) and key start (C,).

    When other's field compiles (``sdf.compiled``) the stages run in two compiled
    kernels around the descent (``_place``, ``_finish``); otherwise in numpy
    (``_mesh_in_field_numpy``). Same results.
    """
    fields = pair_fields(mesh, other)
    if fields.program[1] < 0:
        return _mesh_in_field_numpy(mesh, other, pose_mesh, pose_other, margin, settings,
                                    polygon_pair)
    n = len(pose_mesh)
    zero = np.zeros(n, np.int64)
    return mesh_in_fields(fields, zero, zero + 1, pose_mesh, pose_other, np.full(n, margin),
                          zero, settings, polygon_pair)


def mesh_in_fields(fields: ShapeFields, mesh_of: np.ndarray, other_of: np.ndarray,
                   pose_mesh: np.ndarray, pose_other: np.ndarray, margin: np.ndarray,
                   run: np.ndarray, settings: Settings, polygon_pair: bool
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                              np.ndarray]:
    """``mesh_in_field`` of n pairs of any meshes and other shapes whose fields compile:
    pair k's mesh is shape mesh_of[k], its other shape other_of[k] (n,) of ``fields``,
    its margin margin[k] (n,) m, its run run[k] (n,) (the pairs of one shape pair:
    consecutive, one run id, one margin). ``_place`` and ``_finish`` run run by run (a
    call each per shape pair: kernels looping over the runs themselves compiled 1 to
    1.5 s longer each at a cold start), the descent over all kept triangles at once
    (``descent.triangle_deepest_programs``; with sampled starts, a call per run): the
    same contacts, to the bit, as a ``mesh_in_field`` call per shape pair. Returns its
    six arrays, pairs into the n."""
    if len(run) == 0:
        none = np.zeros(0, np.int64)
        return none, np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), none, none
    angle = pose_mesh[:, 2] - pose_other[:, 2]
    cos, sin = np.cos(angle), np.sin(angle)
    co, so = np.cos(pose_other[:, 2]), np.sin(pose_other[:, 2])
    pose_mesh = np.ascontiguousarray(pose_mesh, dtype=np.float64)
    pose_other = np.ascontiguousarray(pose_other, dtype=np.float64)
    table, program = fields.table, fields.program[other_of]
    bounds = run_starts(run).tolist()
    runs = list(zip(bounds[:-1], bounds[1:], strict=True))
    placed, kept_of, tris = [], [], []
    for lo, hi in runs:
        s, p = mesh_of[lo], program[lo]
        vertices, _, kept, tri = _place(
            fields.vertices[fields.vertex_start[s]:fields.vertex_start[s + 1]],
            fields.triangles[fields.triangle_start[s]:fields.triangle_start[s + 1]],
            cos[lo:hi], sin[lo:hi], co[lo:hi], so[lo:hi], pose_mesh[lo:hi], pose_other[lo:hi],
            table.code[table.start[p]:table.start[p + 1]], table.consts, table.depth,
            table.nesting, float(margin[lo]))
        placed.append(vertices)
        kept_of.append(kept)
        tris.append(tri)
    count = np.array([len(k) for k in kept_of], np.int64)
    tri = np.concatenate(tris)
    tri_run = np.repeat(np.array([lo for lo, _ in runs], np.int64), count)   # a pair of it
    n_starts = max(1, min(settings.descent_starts, len(_START_PRIORITY)))
    if settings.descent_lattice > 0:
        point, value, start_ids = _sampled_runs(fields, other_of, run, tri_run, tri, settings)
    else:
        point, value = descent.triangle_deepest_programs(
            table, program[tri_run], run[tri_run], fields.convex[other_of[tri_run]], tri,
            settings.descent_iterations, _STARTS[n_starts])
        start_ids = _START_PRIORITY[:n_starts]
    distinct = descent.merge_minima(point, _MERGE_RADIUS)
    point, value = np.ascontiguousarray(point), np.ascontiguousarray(value)
    parts, at = [], 0
    for (lo, hi), vertices, kept, k in zip(runs, placed, kept_of, count, strict=True):
        s, p = mesh_of[lo], program[lo]
        t0, t1 = fields.triangle_start[s], fields.triangle_start[s + 1]
        pair, *rest = _finish(
            fields.triangles[t0:t1], fields.outline_edges[t0:t1], vertices, kept,
            point[at:at + k], value[at:at + k], distinct[at:at + k], start_ids,
            table.code[table.start[p]:table.start[p + 1]], table.consts, table.depth,
            table.nesting, float(margin[lo]), bool(polygon_pair), float(settings.linear_slop),
            co[lo:hi], so[lo:hi], pose_other[lo:hi], pose_mesh[lo:hi])
        parts.append((pair + lo, *rest))
        at += k
    return tuple(np.concatenate(column) for column in zip(*parts, strict=True))


def _sampled_runs(fields: ShapeFields, other_of: np.ndarray, run: np.ndarray,
                  kept_pair: np.ndarray, tri: np.ndarray, settings: Settings
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``_sampled_minima`` of the kept triangles (K, 3, 2), each of pair kept_pair (K,),
    run by run (each run's field is one shape's, ``settings.descent_lattice`` > 0): point
    (K, k, 2), value (K, k), the start ids (k,)."""
    k = settings.descent_starts
    point, value = np.empty((len(tri), k, 2)), np.empty((len(tri), k))
    start_ids = SAMPLED_START + np.arange(k, dtype=np.int64)
    of_run = run[kept_pair]
    bounds = run_starts(of_run)
    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
        field = fields.shape_of[other_of[kept_pair[lo]]].field
        p, v, start_ids = _sampled_minima(field, tri[lo:hi], settings)
        point[lo:hi], value[lo:hi] = p, v
    return point, value, start_ids
