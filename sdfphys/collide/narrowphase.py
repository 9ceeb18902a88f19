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

    source   0  analytic (circle-circle, circle-any): element = start = 0
             1  a's mesh inside b's field
             2  b's mesh inside a's field
             3  field-field descent (sdf pairs), start = start id
    element  triangle index in the mesh, or vertex index when start = 255 (< 2^48)
    start    descent start id: 0-2 vertices, 3-5 edge midpoints, 6 centroid of the
             triangle; 255 (``VERTEX_START``): a mesh vertex (whatever triangle or
             route found it, so a vertex contact keeps its key)

Approximations (documented where they act): for a triangle point p inside the
other field f, depth = -f(p) and normal = -grad f(p); the contact point is p moved
by depth / 2 along grad f. This is exact when the other surface is flat near the
contact (a corner pressing into a face) and underestimates depth where a sharp
feature of the field pokes into a face of the mesh, which is why mesh pairs are
run both ways.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..sdf import safe_normalize
from ..settings import Settings
from ..shapes import Shape
from .contacts import Contacts

__all__ = [
    "KIND_ORDER",
    "PAIR_FUNCTIONS",
    "PairFunction",
    "collide_circle_and_field",
    "collide_circles",
    "collide_mesh_and_sdf",
    "collide_meshes",
    "collide_sdfs",
    "feature_key",
]

#: Shape kinds in dispatch order: a pair is handled by PAIR_FUNCTIONS[(lower, higher)].
KIND_ORDER = ("circle", "mesh", "sdf")

PairFunction = Callable[[Shape, Shape, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                         float, Settings], Contacts]

SOURCE_ANALYTIC, SOURCE_A_IN_B, SOURCE_B_IN_A, SOURCE_FIELDS = 0, 1, 2, 3

#: Barycentric weight under which a point counts as on the opposite edge (descent
#: minima on an edge come from a projection onto it, exact up to round-off).
_ON_EDGE = 1e-9
#: A reference-face candidate's foot point must be this close to the surface (m).
_ON_FACE = 1e-9
#: Start id of vertex keys: the key's element is then a mesh vertex index.
VERTEX_START = 255
#: Descent starts of one triangle ending closer than this (m) are one minimum (the
#: lowest start id is kept, a stable key); far below any physical length.
_MERGE_RADIUS = 1e-6


def feature_key(source: int, element: np.ndarray | int, start: np.ndarray | int) -> np.ndarray:
    """Feature keys (int64) ``source << 56 | element << 8 | start`` (see the module doc)."""
    return ((np.int64(source) << np.int64(56)) | (np.asarray(element, np.int64) << np.int64(8))
            | np.asarray(start, np.int64))


def _rotate(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rows of v (n, 2) rotated counter-clockwise by angle (n,) radians."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)


def _to_local(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """World points (n, 2) into the body frames of poses (n, 3): R^T (p - x)."""
    return _rotate(points - pose[:, :2], -pose[:, 2])


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
                    np.full(n, feature_key(SOURCE_ANALYTIC, 0, 0), np.int64))


def collide_circle_and_field(circle_a: Shape, shape_b: Shape, body_a: np.ndarray,
                             body_b: np.ndarray, pose_a: np.ndarray, pose_b: np.ndarray,
                             margin: float, settings: Settings) -> Contacts:
    """Circle against any shape's field: one batched evaluation of f_b at the centres.

    With c the circle centre in b's body frame, (d, g) = f_b(c), grad f_b(c) and
    r the radius: depth = r - d, normal a->b = -R_b g (g points out of b, toward the
    circle), point = c - (d + r)/2 g (midway between b's surface point c - d g and
    the circle's surface point c - r g), in the world. Exact for exact fields;
    inside b, g is the direction to b's nearest boundary point, as pymunk's
    circle-polygon (least-penetrating face).
    """
    r = circle_a.radius
    centre = _to_local(pose_a[:, :2], pose_b)
    d, g = shape_b.field.evaluate(centre)
    depth = r - d
    keep = depth > -margin
    g_world = _rotate(safe_normalize(g[keep]), pose_b[keep, 2])
    depth = depth[keep]
    point = pose_a[keep, :2] - (0.5 * (d[keep] + r))[:, None] * g_world
    return Contacts(body_a[keep], body_b[keep], point, -g_world, depth,
                    np.full(len(depth), feature_key(SOURCE_ANALYTIC, 0, 0), np.int64))


def _barycentric(triangle: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Barycentric weights (C, 3) of points (C, 2) in triangles (C, 3, 2) (signed areas)."""
    v0, v1, v2 = triangle[:, 0], triangle[:, 1], triangle[:, 2]

    def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]

    area = cross(v1 - v0, v2 - v0)
    return np.stack([cross(v1 - point, v2 - point), cross(v2 - point, v0 - point),
                     cross(v0 - point, v1 - point)], axis=1) / area[:, None]


def _first_per_key(*keys: np.ndarray) -> np.ndarray:
    """Indices of the first row (in input order) of each distinct key tuple, sorted."""
    order = np.lexsort((np.arange(len(keys[0])),) + keys[::-1])
    sorted_keys = np.stack([k[order] for k in keys], axis=1)
    new = np.r_[True, np.any(sorted_keys[1:] != sorted_keys[:-1], axis=1)]
    return np.sort(order[new])


def _mesh_in_field(mesh: Shape, other: Shape, pose_mesh: np.ndarray, pose_other: np.ndarray,
                   margin: float, settings: Settings, outline_only: bool
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                              np.ndarray]:
    """Contact candidates of ``mesh`` inside ``other``'s field, n pairs at once.

    1. Descent. The triangles (T, 3, 2) of the mesh are moved into other's body frame
       for each pair (relative angle a_m - a_o, offset R_o^T (x_m - x_o)), giving
       n T triangles; ``descent.triangle_cull`` drops those that cannot reach
       depth > -margin, ``descent.triangle_deepest`` finds the local minima of f
       over each remaining triangle from its starts, ``descent.merge_minima`` keeps
       one start per distinct minimum; one more evaluation gives the gradients.
       Depth = -f(p), outward normal g = grad f(p) / |grad f(p)|.
    2. Outline filter (``outline_only``): keep minima on the mesh's outline (its
       vertices and boundary edges). Against a polygon that loses nothing: the
       deepest point of a polygon A in a polygon B lies on A's boundary unless B
       pokes into A, and then B's vertices inside A come from the other direction.
       It removes minima on internal diagonals and inside triangles, i.e. slivers
       of a triangle cut by a corner of B, whose medial point has half the depth
       and a side normal (two aligned stacked boxes would get normals (+-1, 0)).
    3. Reference face (Box2D's clipping, in SDF form). A descent minimum is a
       local minimum of f, so when the mesh rests nearly flat on a face only its
       deeper end is found. Every mesh vertex v is therefore also measured against
       the face under the pair's deepest minimum (surface point q = p + depth g,
       outward normal g): separation s = (v - q).g, depth -s, normal g, kept when
       s < margin, f(v) <= margin (v is near other, not across it) and v's
       projection v - s g lies on other's surface (|f| <= ``_ON_FACE``), i.e. the
       face extends under v.
    Keys: a minimum at a mesh vertex, and every reference-face candidate, gets the
    vertex key (element = vertex index, start = ``VERTEX_START``), so one vertex
    found from several triangles or both ways gets one key (descent kept first).

    Returns pair index (C,), midway point (C, 2) world, outward normal of other
    (C, 2) world (pointing from other toward the mesh), depth (C,), element (C,)
    and start id (C,).
    """
    from . import descent

    n = len(pose_mesh)
    tri = mesh.vertices[mesh.triangles]
    n_tri = len(tri)
    angle = pose_mesh[:, 2] - pose_other[:, 2]
    c, s = np.cos(angle), np.sin(angle)
    rotation = np.stack([np.stack([c, -s], axis=1), np.stack([s, c], axis=1)], axis=1)
    offset = _to_local(pose_mesh[:, :2], pose_other)
    local = np.einsum("nij,tkj->ntki", rotation, tri) + offset[:, None, None, :]
    local = local.reshape(n * n_tri, 3, 2)

    kept = np.nonzero(descent.triangle_cull(other.field, local, margin))[0]
    point, value = descent.triangle_deepest(other.field, local[kept],
                                            iterations=settings.descent_iterations)
    distinct = descent.merge_minima(point, _MERGE_RADIUS)
    hit_tri, start = np.nonzero(distinct & (value < margin))
    flat = kept[hit_tri]
    p = point[hit_tri, start]
    depth = -value[hit_tri, start]
    pair, element = flat // n_tri, flat % n_tri
    weight = _barycentric(local[flat], p)
    if outline_only:
        on = np.any((weight <= _ON_EDGE) & mesh.outline_edges[element], axis=1)
        pair, element, start, p, depth, weight = (pair[on], element[on], start[on], p[on],
                                                  depth[on], weight[on])
    at_vertex = np.max(weight, axis=1) >= 1.0 - _ON_EDGE
    corner = mesh.triangles[element, np.argmax(weight, axis=1)]
    element = np.where(at_vertex, corner, element)
    start = np.where(at_vertex, VERTEX_START, start)
    if len(p) == 0:
        return pair, p, p, depth, element, start
    g = safe_normalize(other.field.evaluate(p)[1])

    # Reference face under each pair's deepest minimum.
    deepest = np.lexsort((-depth, pair))
    ref = deepest[np.r_[True, np.diff(pair[deepest]) != 0]]
    ref_pair = pair[ref]
    q = p[ref] + depth[ref, None] * g[ref]
    vertices = (np.einsum("nij,vj->nvi", rotation[ref_pair], mesh.vertices)
                + offset[ref_pair, None, :])                          # (R, V, 2)
    separation = np.einsum("rvi,ri->rv", vertices - q[:, None, :], g[ref])
    r_idx, v_idx = np.nonzero(separation < margin)
    sep = separation[r_idx, v_idx]
    v = vertices[r_idx, v_idx]
    f = other.field.distance(np.concatenate([v - sep[:, None] * g[ref][r_idx], v]))
    on_face = (np.abs(f[:len(v)]) <= _ON_FACE) & (f[len(v):] <= margin + _ON_FACE)
    r_idx, v_idx, sep = r_idx[on_face], v_idx[on_face], sep[on_face]

    pair = np.r_[pair, ref_pair[r_idx]]
    element = np.r_[element, v_idx]
    start = np.r_[start, np.full(len(v_idx), VERTEX_START)]
    p = np.concatenate([p, vertices[r_idx, v_idx]])
    depth = np.r_[depth, -sep]
    g = np.concatenate([g, g[ref][r_idx]])
    first = _first_per_key(pair, element, start)
    pair, element, start, p, depth, g = (pair[first], element[first], start[first],
                                         p[first], depth[first], g[first])

    mid = p + (0.5 * depth)[:, None] * g
    rot = pose_other[pair, 2]
    return (pair, _rotate(mid, rot) + pose_other[pair, :2], _rotate(g, rot), depth,
            element, start)


def collide_meshes(mesh_a: Shape, mesh_b: Shape, body_a: np.ndarray, body_b: np.ndarray,
                   pose_a: np.ndarray, pose_b: np.ndarray, margin: float,
                   settings: Settings) -> Contacts:
    """Mesh-mesh: a's triangles in b's polygon field, then b's triangles in a's field.

    Both directions are needed: a vertex of a inside b is found by the first, a
    vertex of b inside a by the second (each is the exact deepest point when the
    face it presses on is flat, which the reduction then picks from).
    """
    pair, point, out_b, depth, tri, start = _mesh_in_field(mesh_a, mesh_b, pose_a, pose_b,
                                                           margin, settings, True)
    first = Contacts(body_a[pair], body_b[pair], point, -out_b, depth,
                     feature_key(SOURCE_A_IN_B, tri, start))
    pair, point, out_a, depth, tri, start = _mesh_in_field(mesh_b, mesh_a, pose_b, pose_a,
                                                           margin, settings, True)
    second = Contacts(body_a[pair], body_b[pair], point, out_a, depth,
                      feature_key(SOURCE_B_IN_A, tri, start))
    return Contacts.concatenate([first, second])


def collide_mesh_and_sdf(mesh_a: Shape, sdf_b: Shape, body_a: np.ndarray, body_b: np.ndarray,
                         pose_a: np.ndarray, pose_b: np.ndarray, margin: float,
                         settings: Settings) -> Contacts:
    """Mesh-sdf: the mesh's triangles in the sdf's field (see ``_mesh_in_field``)."""
    pair, point, out_b, depth, tri, start = _mesh_in_field(mesh_a, sdf_b, pose_a, pose_b,
                                                           margin, settings, False)
    return Contacts(body_a[pair], body_b[pair], point, -out_b, depth,
                    feature_key(SOURCE_A_IN_B, tri, start))


def collide_sdfs(sdf_a: Shape, sdf_b: Shape, body_a: np.ndarray, body_b: np.ndarray,
                 pose_a: np.ndarray, pose_b: np.ndarray, margin: float,
                 settings: Settings) -> Contacts:
    """Sdf-sdf: projected descent from sampled starts (Liu et al. 2024)."""
    raise NotImplementedError("sdf-sdf contacts wait for sdfphys.collide.descent")


#: (kind_a, kind_b) -> pair function, kind_a <= kind_b in KIND_ORDER.
PAIR_FUNCTIONS: dict[tuple[str, str], PairFunction] = {
    ("circle", "circle"): collide_circles,
    ("circle", "mesh"): collide_circle_and_field,
    ("circle", "sdf"): collide_circle_and_field,
    ("mesh", "mesh"): collide_meshes,
    ("mesh", "sdf"): collide_mesh_and_sdf,
    ("sdf", "sdf"): collide_sdfs,
}
