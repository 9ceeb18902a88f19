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
   which some mesh vertex lies deeper than anything reaches into the other shape
   (plus the slop) is cut by the mesh, not pressed by it, and is rejected (a side
   face near the end of a thin overlap strip: SAT's non-minimal axis). Mesh
   vertices are measured against the accepted planes.

When the other field compiles (``sdf.compiled``), the stages run in two compiled
kernels around the descent, with the field's program evaluated inside them:
``_place`` (the mesh in other's frame and ``descent.triangle_cull``) and
``_finish`` (stages 1 after the descent to 4, the first row per key and the world
frame), each stage's points still evaluated in one batch; a call then costs a
fixed handful of Python calls, nothing per pair or candidate. Otherwise the
numpy stages run (``_mesh_in_field_numpy``: the functions above, the reference
the compiled kernels are tested against, bit for bit; ``USE_COMPILED = False``
forces them).

Keys (see ``narrowphase`` for the layout): descent minima keep (triangle, start
id; with starts chosen by sampling, ``settings.descent_lattice`` > 0,
``SAMPLED_START`` + the start's rank); a minimum at a mesh vertex, a vertex
sample and a vertex measured against a face all get the vertex key (element = vertex index, start ``VERTEX_START``), edge
midpoints the edge key (element = outline edge index, start ``EDGE_START``); one
candidate per key and pair survives, in the order: face measures (deepest face
first), then descent minima and samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from .._jit import njit
from ..sdf import Field, compiled, safe_normalize
from ..sdf.compiled import run, scratch
from ..settings import Settings
from ..shapes import Shape
from ..vec2 import unit_or
from . import descent
from ._compiled_descent import enclosing_circles

__all__ = ["EDGE_START", "SAMPLED_START", "VERTEX_START", "mesh_in_field"]

#: Start id of vertex keys: the key's element is then a mesh vertex index.
VERTEX_START = 255
#: Start id of edge-midpoint keys: the key's element is then an outline edge index.
EDGE_START = 254
#: Barycentric weight under which a point counts as on the opposite edge (descent
#: minima on an edge come from a projection onto it, exact up to round-off).
_ON_EDGE = 1e-9
#: A vertex measured against a face must have its foot this close to the surface (m).
_ON_FACE = 1e-9
#: Probe distance (m) and largest gradient turn (rad) of ``_face_normals``: a normal
#: that turns by more within 1e-7 m is a kink (medial axis) or a vertex's.
_PROBE = 1e-7
_KINK = 1e-3
#: A kink's face is taken when the mesh's edge there is within 30 deg of anti-parallel
#: to it (-cos 30 deg, see ``_face_normals``).
_RUNS_ALONG = math.cos(math.pi / 6.0)
_AXES = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
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
    """``descent.triangle_deepest_sampled`` with the settings' lattice, starts and
    iterations: point (T, K, 2), value (T, K) and the start ids (K,) of the ranks."""
    point, value = descent.triangle_deepest_sampled(
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


def _face_normals(field: Field, p: np.ndarray, depth: np.ndarray, edge: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit gradient (C, 2) at points p (C, 2), (C,) bool: it is a face's normal, and
    the depths (C,) (changed where a kink takes a face's, below).

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
    g_a = around[rows, a]
    below = -(f[n:].reshape(n, 4)[rows, a] - np.einsum("cd,cd->c", _PROBE * _AXES[a], g_a))
    return (np.where(along[:, None], g_a, g0), face | along,
            np.where(along, below, depth))


def _reference_faces(field: Field, c: _Candidates, vertices: np.ndarray, deepest: np.ndarray,
                     margin: float, slop: float) -> tuple[np.ndarray, _Candidates]:
    """Which candidates' faces are contact planes, and the vertices measured on them.

    For candidate r (point p, depth d, outward normal g), the face point is
    q = p + d g (on other's surface for an exact field). A mesh vertex v of the same
    pair is *supported* by the face when its foot v - s g, s = (v - q).g, lies on
    other's surface (|f| <= ``_ON_FACE``: the face extends under v) and
    f(v) <= margin (v is near other, not across it). The face is a contact plane
    when no supported vertex lies deeper below it than the pair's deepest point
    (``deepest`` (n,): max of -f over the mesh, from the descent) plus ``slop``:
    otherwise the mesh cuts through the plane (a side face near the end of a thin
    overlap), and pushing along it would take more than the actual penetration.
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
    supported = ((np.abs(f[:len(vv)]) <= _ON_FACE) & (f[len(vv):] <= margin + _ON_FACE))
    cut = supported & (-sep > deepest[c.pair[r_idx]] + slop)
    accepted = np.ones(len(c.depth), bool)
    accepted[r_idx[cut]] = False
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
        c.normal, face, c.depth = _face_normals(other.field, c.point, c.depth,
                                                _edge_normals(mesh, local, c))
        c = c.take(face)
        if len(c.depth) == 0:
            return c.pair, c.point, c.normal, c.depth, c.element, c.start
    else:
        c.normal = safe_normalize(compiled.evaluate(other.field, c.point)[1])
    accepted, measured = _reference_faces(other.field, c, vertices, deepest, margin,
                                          settings.linear_slop)
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

#: Run ``mesh_in_field`` through the compiled kernels when the field compiles
#: (``sdf.compiled``); False forces the numpy stages (the tests compare the two).
USE_COMPILED = True
#: The probes of ``_face_normals`` as offsets (4, 2), computed as numpy does there.
_PROBE_OFFSETS = _PROBE * _AXES
#: Start weights (K, 3) per number of descent starts, in ``_START_PRIORITY`` order.
_STARTS = {k: np.ascontiguousarray(descent.START_BARYCENTRIC[_START_PRIORITY[:k]])
           for k in range(1, len(_START_PRIORITY) + 1)}


@njit(cache=True, error_model="numpy")
def _evaluate(code: np.ndarray, consts: np.ndarray, depth: int, nesting: int,
              points: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Value (n,) and gradient (n, 2) of a program (``sdf.compiled``) at points[:n]."""
    stack, frames, cur = scratch(depth, nesting, n)
    value, grad = np.empty(n), np.empty((n, 2))
    run(code, consts, points, n, stack, frames, cur, value, grad)
    return value, grad


@njit(cache=True, error_model="numpy")
def _place(mesh_vertices: np.ndarray, triangles: np.ndarray, cos: np.ndarray, sin: np.ndarray,
           co: np.ndarray, so: np.ndarray, pose_mesh: np.ndarray, pose_other: np.ndarray,
           code: np.ndarray, consts: np.ndarray, depth: int, nesting: int, margin: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The mesh in other's frame for n pairs, and ``descent.triangle_cull``.

    mesh_vertices (V, 2), triangles (T, 3): the mesh; cos, sin (n,): of the mesh's
    angle relative to other; co, so (n,): of other's angle (numpy's cos and sin,
    computed by the caller); poses (n, 3) world; the program of other's field.
    Returns vertices (n, V, 2), triangles (n T, 3, 2) in other's frame, the kept
    triangles' indices (K,) into them (f < R + margin at the enclosing circle's
    centre) and their vertices (K, 3, 2). The operations of ``_mesh_in_field_numpy``
    (einsum's sums start from 0.0).
    """
    n, m, n_tri = cos.shape[0], mesh_vertices.shape[0], triangles.shape[0]
    vertices = np.empty((n, m, 2))
    for k in range(n):
        dx, dy = pose_mesh[k, 0] - pose_other[k, 0], pose_mesh[k, 1] - pose_other[k, 1]
        ox, oy = co[k] * dx + so[k] * dy, -so[k] * dx + co[k] * dy
        c, s = cos[k], sin[k]
        for v in range(m):
            x, y = mesh_vertices[v, 0], mesh_vertices[v, 1]
            vertices[k, v, 0] = (0.0 + c * x + (-s) * y) + ox
            vertices[k, v, 1] = (0.0 + s * x + c * y) + oy
    local = np.empty((n * n_tri, 3, 2))
    for k in range(n):
        for t in range(n_tri):
            for j in range(3):
                local[k * n_tri + t, j, 0] = vertices[k, triangles[t, j], 0]
                local[k * n_tri + t, j, 1] = vertices[k, triangles[t, j], 1]
    centre, radius = enclosing_circles(local)
    f, _ = _evaluate(code, consts, depth, nesting, centre, centre.shape[0])
    count = 0
    kept = np.empty(n * n_tri, dtype=np.int64)
    for i in range(n * n_tri):
        if f[i] < radius[i] + margin:
            kept[count] = i
            count += 1
    kept = kept[:count]
    tri = np.empty((count, 3, 2))
    for h in range(count):
        tri[h] = local[kept[h]]
    return vertices, local, kept, tri


@njit(cache=True, error_model="numpy")
def _first_rows(pair: np.ndarray, element: np.ndarray, start: np.ndarray, n: int
                ) -> np.ndarray:
    """``_first_per_key`` of the first n rows (element * 256 + start: start < 256)."""
    key = element[:n] * 256 + start[:n]
    order = np.argsort(key, kind="mergesort")
    order = order[np.argsort(pair[:n][order], kind="mergesort")]
    first = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        j = order[i]
        if i == 0:
            first[j] = True
        else:
            h = order[i - 1]
            first[j] = pair[j] != pair[h] or element[j] != element[h] or start[j] != start[h]
    return np.flatnonzero(first)


@njit(cache=True, error_model="numpy")
def _finish(triangles: np.ndarray, outline_edges: np.ndarray, vertices: np.ndarray,
            kept: np.ndarray, point: np.ndarray, value: np.ndarray, distinct: np.ndarray,
            start_ids: np.ndarray, code: np.ndarray, consts: np.ndarray, depth_p: int,
            nesting: int, margin: float, polygon_pair: bool, slop: float, co: np.ndarray,
            so: np.ndarray, pose_other: np.ndarray):
    """Stages 1 (after the descent) to 4 and the world frame, as ``_mesh_in_field_numpy``.

    vertices (n, V, 2), kept (K,): from ``_place``; point (K, S, 2), value (K, S),
    distinct (K, S): the descent's minima of the kept triangles and
    ``descent.merge_minima``; start_ids (S,): their start ids. The rest as
    ``mesh_in_field``. Returns its six arrays. Rows are written in the numpy
    stages' order; sorts are stable, as lexsort.
    """
    n, m = vertices.shape[0], vertices.shape[1]
    n_tri = triangles.shape[0]
    n_kept, n_start = value.shape[0], value.shape[1]
    cap = n_kept * n_start + 2 * n * m
    pair = np.empty(cap, dtype=np.int64)
    element = np.empty(cap, dtype=np.int64)
    start = np.empty(cap, dtype=np.int64)
    p = np.empty((cap, 2))
    depth = np.empty(cap)
    edge_normal = np.zeros((cap, 2))
    c = 0
    # 1. Descent minima (``_descent_minima``), the outline edge under each (``_edge_normals``).
    on_vertex = 1.0 - _ON_EDGE
    for h in range(n_kept):
        flat = kept[h]
        e = flat % n_tri
        tri = triangles[e]
        v0x, v0y = vertices[flat // n_tri, tri[0], 0], vertices[flat // n_tri, tri[0], 1]
        v1x, v1y = vertices[flat // n_tri, tri[1], 0], vertices[flat // n_tri, tri[1], 1]
        v2x, v2y = vertices[flat // n_tri, tri[2], 0], vertices[flat // n_tri, tri[2], 1]
        area = (v1x - v0x) * (v2y - v0y) - (v1y - v0y) * (v2x - v0x)
        for col in range(n_start):
            if not (distinct[h, col] and value[h, col] < margin):
                continue
            x, y = point[h, col, 0], point[h, col, 1]
            w0 = ((v1x - x) * (v2y - y) - (v1y - y) * (v2x - x)) / area
            w1 = ((v2x - x) * (v0y - y) - (v2y - y) * (v0x - x)) / area
            w2 = ((v0x - x) * (v1y - y) - (v0y - y) * (v1x - x)) / area
            if polygon_pair and not ((w0 <= _ON_EDGE and outline_edges[e, 0])
                                     or (w1 <= _ON_EDGE and outline_edges[e, 1])
                                     or (w2 <= _ON_EDGE and outline_edges[e, 2])):
                continue
            largest, arg = w0, 0
            if w1 > largest:
                largest, arg = w1, 1
            if w2 > largest:
                largest, arg = w2, 2
            nan = math.isnan(w0) or math.isnan(w1) or math.isnan(w2)
            pair[c] = flat // n_tri
            if not nan and largest >= on_vertex:
                element[c], start[c] = tri[arg], VERTEX_START
            else:
                element[c], start[c] = e, start_ids[col]
                weights = (w0, w1, w2)
                for j in range(3):
                    if weights[j] <= _ON_EDGE and outline_edges[e, j]:
                        a, b = tri[(j + 1) % 3], tri[(j + 2) % 3]
                        ex = vertices[flat // n_tri, b, 0] - vertices[flat // n_tri, a, 0]
                        ey = vertices[flat // n_tri, b, 1] - vertices[flat // n_tri, a, 1]
                        length = math.sqrt(ex * ex + ey * ey)
                        edge_normal[c, 0], edge_normal[c, 1] = ey / length, -ex / length
                        break
            p[c, 0], p[c, 1] = x, y
            depth[c] = -value[h, col]
            c += 1
    # 2. Outline vertices and edge midpoints (``_samples``).
    samples = np.empty((n * 2 * m, 2))
    for k in range(n):
        for j in range(m):
            i, q = k * 2 * m + j, (j + 1) % m
            samples[i, 0], samples[i, 1] = vertices[k, j, 0], vertices[k, j, 1]
            samples[i + m, 0] = 0.5 * (vertices[k, j, 0] + vertices[k, q, 0])
            samples[i + m, 1] = 0.5 * (vertices[k, j, 1] + vertices[k, q, 1])
    f, _ = _evaluate(code, consts, depth_p, nesting, samples, n * 2 * m)
    for i in range(n * 2 * m):
        if f[i] < margin:
            slot = i % (2 * m)
            pair[c], element[c] = i // (2 * m), slot % m
            start[c] = VERTEX_START if slot < m else EDGE_START
            p[c, 0], p[c, 1] = samples[i, 0], samples[i, 1]
            depth[c] = -f[i]
            c += 1
    # The deepest point of each pair (np.maximum.at).
    deepest = np.full(n, -np.inf)
    for i in range(c):
        now = deepest[pair[i]]
        if not (now >= depth[i] or math.isnan(now)):
            deepest[pair[i]] = depth[i]
    # 3. Normals (``_face_normals`` for a polygon pair).
    normal = np.empty((c, 2))
    if polygon_pair:
        probes = np.empty((5 * c, 2))
        for i in range(c):
            probes[i, 0], probes[i, 1] = p[i, 0], p[i, 1]
            for a in range(4):
                probes[c + 4 * i + a, 0] = p[i, 0] + _PROBE_OFFSETS[a, 0]
                probes[c + 4 * i + a, 1] = p[i, 1] + _PROBE_OFFSETS[a, 1]
        f_probe, g = _evaluate(code, consts, depth_p, nesting, probes, 5 * c)
        for i in range(5 * c):
            g[i, 0], g[i, 1] = unit_or(g[i, 0], g[i, 1], 1.0, 0.0)
        sides = np.empty((2 * c, 2))
        for i in range(c):
            fx, fy = p[i, 0] + depth[i] * g[i, 0], p[i, 1] + depth[i] * g[i, 1]
            tx, ty = _PROBE * -g[i, 1], _PROBE * g[i, 0]
            sides[i, 0], sides[i, 1] = fx + tx, fy + ty
            sides[c + i, 0], sides[c + i, 1] = fx - tx, fy - ty
        _, g_foot = _evaluate(code, consts, depth_p, nesting, sides, 2 * c)
        kink2 = _KINK ** 2
        face = 0
        for i in range(c):
            gx, gy = g[i, 0], g[i, 1]
            ok = True
            # The foot test only outside other (see _face_normals).
            for a in range(6 if depth[i] <= 0.0 else 4):
                if a < 4:
                    hx, hy = g[c + 4 * i + a, 0], g[c + 4 * i + a, 1]
                else:
                    hx, hy = unit_or(g_foot[i + (a - 4) * c, 0], g_foot[i + (a - 4) * c, 1],
                                     1.0, 0.0)
                ok = ok and (hx - gx) * (hx - gx) + (hy - gy) * (hy - gy) <= kink2
            d = depth[i]
            if not ok and d > 0.0:
                # A kink on a mesh edge running along one of its faces takes that face.
                best, arg = np.inf, 0
                for a in range(4):
                    j = c + 4 * i + a
                    facing = 0.0 + g[j, 0] * edge_normal[i, 0] + g[j, 1] * edge_normal[i, 1]
                    if facing < best:
                        best, arg = facing, a
                if best <= -_RUNS_ALONG:
                    j = c + 4 * i + arg
                    gx, gy = g[j, 0], g[j, 1]
                    d = -(f_probe[j] - (0.0 + _PROBE_OFFSETS[arg, 0] * gx
                                        + _PROBE_OFFSETS[arg, 1] * gy))
                    ok = True
            if ok:
                pair[face], element[face], start[face] = pair[i], element[i], start[i]
                p[face, 0], p[face, 1], depth[face] = p[i, 0], p[i, 1], d
                normal[face, 0], normal[face, 1] = gx, gy
                face += 1
        c = face
    else:
        _, g = _evaluate(code, consts, depth_p, nesting, p, c)
        for i in range(c):
            normal[i, 0], normal[i, 1] = unit_or(g[i, 0], g[i, 1], 1.0, 0.0)
    # 4. Reference faces (``_reference_faces``).
    r_idx = np.empty(c * m, dtype=np.int64)
    v_idx = np.empty(c * m, dtype=np.int64)
    sep = np.empty(c * m)
    n_near = 0
    for r in range(c):
        k = pair[r]
        nx, ny = normal[r, 0], normal[r, 1]
        qx, qy = p[r, 0] + depth[r] * nx, p[r, 1] + depth[r] * ny
        for v in range(m):
            s = 0.0 + (vertices[k, v, 0] - qx) * nx + (vertices[k, v, 1] - qy) * ny
            if s < margin:
                r_idx[n_near], v_idx[n_near], sep[n_near] = r, v, s
                n_near += 1
    feet = np.empty((2 * n_near, 2))
    for l in range(n_near):
        r, k, s = r_idx[l], pair[r_idx[l]], sep[l]
        vx, vy = vertices[k, v_idx[l], 0], vertices[k, v_idx[l], 1]
        feet[l, 0], feet[l, 1] = vx - s * normal[r, 0], vy - s * normal[r, 1]
        feet[n_near + l, 0], feet[n_near + l, 1] = vx, vy
    f, _ = _evaluate(code, consts, depth_p, nesting, feet, 2 * n_near)
    supported = np.empty(n_near, dtype=np.bool_)
    accepted = np.ones(c, dtype=np.bool_)
    reach = margin + _ON_FACE
    for l in range(n_near):
        supported[l] = abs(f[l]) <= _ON_FACE and f[n_near + l] <= reach
        if supported[l] and -sep[l] > deepest[pair[r_idx[l]]] + slop:
            accepted[r_idx[l]] = False
    use = np.empty(n_near, dtype=np.int64)
    n_use = 0
    for l in range(n_near):
        if supported[l] and accepted[r_idx[l]]:
            use[n_use] = l
            n_use += 1
    use = use[:n_use]
    minus = np.empty(n_use)
    of = np.empty(n_use, dtype=np.int64)
    for u in range(n_use):
        minus[u], of[u] = -depth[r_idx[use[u]]], pair[r_idx[use[u]]]
    order = np.argsort(minus, kind="mergesort")
    order = use[order[np.argsort(of[order], kind="mergesort")]]
    # Measured vertices, then the accepted candidates; the first row of each key.
    rows = n_use
    for r in range(c):
        if accepted[r]:
            rows += 1
    o_pair = np.empty(rows, dtype=np.int64)
    o_element = np.empty(rows, dtype=np.int64)
    o_start = np.empty(rows, dtype=np.int64)
    o_point = np.empty((rows, 2))
    o_normal = np.empty((rows, 2))
    o_depth = np.empty(rows)
    for u in range(n_use):
        l = order[u]
        r = r_idx[l]
        k = pair[r]
        o_pair[u], o_element[u], o_start[u] = k, v_idx[l], VERTEX_START
        o_point[u, 0], o_point[u, 1] = vertices[k, v_idx[l], 0], vertices[k, v_idx[l], 1]
        o_depth[u] = -sep[l]
        o_normal[u, 0], o_normal[u, 1] = normal[r, 0], normal[r, 1]
    u = n_use
    for r in range(c):
        if accepted[r]:
            o_pair[u], o_element[u], o_start[u] = pair[r], element[r], start[r]
            o_point[u, 0], o_point[u, 1] = p[r, 0], p[r, 1]
            o_depth[u] = depth[r]
            o_normal[u, 0], o_normal[u, 1] = normal[r, 0], normal[r, 1]
            u += 1
    take = _first_rows(o_pair, o_element, o_start, rows)
    out = take.shape[0]
    world_mid = np.empty((out, 2))
    world_normal = np.empty((out, 2))
    for j in range(out):
        i = take[j]
        k = o_pair[i]
        nx, ny = o_normal[i, 0], o_normal[i, 1]
        half = 0.5 * o_depth[i]
        mx, my = o_point[i, 0] + half * nx, o_point[i, 1] + half * ny
        world_mid[j, 0] = (co[k] * mx - so[k] * my) + pose_other[k, 0]
        world_mid[j, 1] = (so[k] * mx + co[k] * my) + pose_other[k, 1]
        world_normal[j, 0] = co[k] * nx - so[k] * ny
        world_normal[j, 1] = so[k] * nx + co[k] * ny
    return (o_pair[take], world_mid, world_normal, o_depth[take], o_element[take],
            o_start[take])


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
    kernels around the descent (``_place``, ``_finish``); otherwise, and with
    ``USE_COMPILED = False``, in numpy (``_mesh_in_field_numpy``). Same results.
    """
    program = compiled.compile_field(other.field) if USE_COMPILED else None
    if program is None:
        return _mesh_in_field_numpy(mesh, other, pose_mesh, pose_other, margin, settings,
                                    polygon_pair)
    angle = pose_mesh[:, 2] - pose_other[:, 2]
    cos, sin = np.cos(angle), np.sin(angle)
    co, so = np.cos(pose_other[:, 2]), np.sin(pose_other[:, 2])
    pose_mesh = np.ascontiguousarray(pose_mesh, dtype=np.float64)
    pose_other = np.ascontiguousarray(pose_other, dtype=np.float64)
    code, consts, depth, nesting = program.code, program.consts, program.depth, program.nesting
    margin = float(margin)
    vertices, _, kept, tri = _place(mesh.vertices, mesh.triangles, cos, sin, co, so, pose_mesh,
                                    pose_other, code, consts, depth, nesting, margin)
    n_starts = max(1, min(settings.descent_starts, len(_START_PRIORITY)))
    if settings.descent_lattice > 0:
        point, value, start_ids = _sampled_minima(other.field, tri, settings)
    else:
        point, value = descent.triangle_deepest(other.field, tri,
                                                iterations=settings.descent_iterations,
                                                starts=_STARTS[n_starts])
        start_ids = _START_PRIORITY[:n_starts]
    distinct = descent.merge_minima(point, _MERGE_RADIUS)
    return _finish(mesh.triangles, mesh.outline_edges, vertices, kept,
                   np.ascontiguousarray(point), np.ascontiguousarray(value), distinct,
                   start_ids, code, consts, depth, nesting, margin,
                   bool(polygon_pair), float(settings.linear_slop), co, so, pose_other)
