"""Convex polygon pairs: separating axes and clipping, compiled (after Box2D v3).

A pair of convex polygons (boxes, convex ``TriangleMesh`` outlines) needs no descent:
their fields are convex, each has one deepest region, and the contact manifold has
at most two points. This is Box2D v3's ``b2CollidePolygons`` (``manifold.c``; E.
Catto, "Contact Manifolds", GDC 2007), written for our conventions:

1. Everything in a's body frame; b's vertices and normals moved there by the relative
   pose (rotation by angle_b - angle_a, offset R(-angle_a) (x_b - x_a)).
2. Separating axes. For each face i of polygon 1 (outward unit normal n_i, vertex
   v_i), s_i = min over the vertices w of polygon 2 of n_i . (w - v_i): the largest
   s_i over the faces of both polygons is their separation along the best axis (the
   distance when positive and the closest features are a face and a vertex; minus
   the least push-out depth when they overlap). Beyond the pair's margin: no contact.
3. The reference face is a's best face unless b's is better by more than a tenth of
   the linear slop (a tolerance that keeps the choice steady for flush faces); the
   incident face is the face of the other polygon most anti-parallel to it.
4. Separated by more than a tenth of the slop: the closest points of the reference
   and incident edges (segment distance, Ericson 2005, 5.1.9). If both lie at
   vertices, the pair is vertex-vertex: one contact along the vertex-vertex line
   (the exact distance and the gradient of both fields there). Box2D stops there; here
   the far end of the clipped incident edge (step 5) is kept too when it lies on the
   incident edge facing the reference face and within the margin: two sides nearly
   parallel whose near corners are closest also bring their far corners within reach
   (two crates spinning at 4 rad/s toward each other closed 73 mm at their far
   corners in one step, and overlapped 12 mm, with no row there).
5. Otherwise the incident edge is clipped to the reference face's side planes; each
   clipped point w has separation s = n . (w - v_ref) (negative overlapping) and its
   contact is the midpoint between w and its foot on the reference face, w - s n / 2,
   with depth -s and normal n (or -n when b's face is the reference: normals point
   from a toward b). Points with depth <= -margin are dropped.

For a vertex pressed into a face this is the vertex's depth in the face's field, as
the field queries of the other pairs give; for faces resting on faces the two
clipped points are the ends of the shared patch.

Feature keys: ``SOURCE_CLIP << 56 | (vertex_a << 24 | vertex_b) << 8``, the two
vertex indices that name the point as in Box2D's ``B2_MAKE_ID`` (the reference and
incident vertices of its clip end, a's first): stable while the same features touch,
and unique within a pair.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..vec2 import TINY

__all__ = ["SOURCE_CLIP", "clip_pair", "polygon_contacts", "polygon_table"]

#: Feature key source of clipped polygon contacts (``narrowphase`` key layout).
SOURCE_CLIP = 5
#: Vertex indices take this many bits in a key's element (vertex_a << 24 | vertex_b).
_VERTEX_BITS = 24


def polygon_table(polygons: list[np.ndarray | None]) -> tuple[np.ndarray, ...]:
    """Concatenated vertex and normal tables of convex polygons.

    polygons: per shape, its counter-clockwise vertices (V, 2) in the body frame, or
    None (not a convex polygon). Returns (vertices (N, 2), normals (N, 2) outward
    unit normal of edge i from vertex i to i + 1, start (S,) int64 first row of each
    shape, count (S,) int64 its vertex count, 0 for None).
    """
    count = np.array([0 if p is None else len(p) for p in polygons], np.int64)
    start = np.cumsum(count) - count
    rows = [p for p in polygons if p is not None]
    if not rows:
        return np.zeros((0, 2)), np.zeros((0, 2)), start, count
    vertices = np.ascontiguousarray(np.concatenate(rows), np.float64)
    edges = np.concatenate([np.roll(p, -1, axis=0) - p for p in rows])
    length = np.hypot(edges[:, 0], edges[:, 1])
    normals = np.column_stack([edges[:, 1], -edges[:, 0]]) / length[:, None]
    return vertices, normals, start, count


@njit(cache=True, inline="always")
def _max_separation(v1, o1, n1, m1, c1, v2, o2, c2):
    """(largest face separation, its face) of polygon 1 (vertices v1[o1:o1 + c1],
    normals n1[m1:m1 + c1]) against the vertices v2[o2:o2 + c2]:
    max_i min_j n_i . (w_j - v_i). Offsets rather than slices, inlined as
    ``_incident_face`` and ``_write`` are: ``clip_pair`` runs for every pair of
    polygons, and a slice is a new array."""
    best = -np.inf
    face = 0
    for i in range(c1):
        nx = n1[m1 + i, 0]
        ny = n1[m1 + i, 1]
        px = v1[o1 + i, 0]
        py = v1[o1 + i, 1]
        low = np.inf
        for j in range(c2):
            s = nx * (v2[o2 + j, 0] - px) + ny * (v2[o2 + j, 1] - py)
            if s < low:
                low = s
        if low > best:
            best = low
            face = i
    return best, face


@njit(cache=True, inline="always")
def _incident_face(direction_x, direction_y, n, m, c):
    """The face of a polygon (normals n[m:m + c]) most anti-parallel to a direction."""
    low = np.inf
    face = 0
    for i in range(c):
        d = direction_x * n[m + i, 0] + direction_y * n[m + i, 1]
        if d < low:
            low = d
            face = i
    return face


@njit(cache=True)
def _segment_fractions(p1x, p1y, q1x, q1y, p2x, p2y, q2x, q2y):
    """Fractions (s, t) in [0, 1] of the closest points p1 + s (q1 - p1) and
    p2 + t (q2 - p2) of two segments (Ericson, Real-Time Collision Detection, 5.1.9)."""
    d1x = q1x - p1x
    d1y = q1y - p1y
    d2x = q2x - p2x
    d2y = q2y - p2y
    rx = p1x - p2x
    ry = p1y - p2y
    a = d1x * d1x + d1y * d1y
    e = d2x * d2x + d2y * d2y
    f = d2x * rx + d2y * ry
    c = d1x * rx + d1y * ry
    b = d1x * d2x + d1y * d2y
    denominator = a * e - b * b
    s = 0.0
    if denominator > 0.0:
        s = min(max((b * f - c * e) / denominator, 0.0), 1.0)
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0)
    return s, t


@njit(cache=True, refcounts=False)
def clip_pair(vertices, normals, start_a, count_a, start_b, count_b, xa, ya, angle_a,
              xb, yb, angle_b, margin, slop, work, out_point, out_normal, out_depth,
              out_feature, k):
    """Contacts of convex polygons a and b (module doc), written from row k; returns
    the next free row (k, k + 1 or k + 2).

    vertices, normals, start_*, count_*: ``polygon_table`` and the two shapes' rows;
    (xa, ya, angle_a), (xb, yb, angle_b): centre-of-mass poses, m and rad; margin: m,
    contacts with depth > -margin are kept; slop: m, ``Settings.linear_slop``; work:
    (>= 2 count_b, 2) scratch for b's vertices and normals in a's frame. Outputs, in
    the world: out_point (K, 2) m midway between the surfaces, out_normal (K, 2) unit
    a -> b, out_depth (K,) m > 0 overlapping, out_feature (K,) int64 keys.

    Compiled without reference counts (``refcounts=False``, ``sdfphys._jit``): it runs
    for every pair of polygons, and its arrays' counts were 12 % of a base-100
    pyramid's step; without them a recorded state's collision query 3.38 -> 2.10 ms.
    """
    # b's vertices and normals in a's frame: work[j] and work[count_b + j].
    ca = math.cos(angle_a)
    sa = math.sin(angle_a)
    dx = xb - xa
    dy = yb - ya
    ox = ca * dx + sa * dy
    oy = -sa * dx + ca * dy
    cr = math.cos(angle_b - angle_a)
    sr = math.sin(angle_b - angle_a)
    for j in range(count_b):
        px = vertices[start_b + j, 0]
        py = vertices[start_b + j, 1]
        work[j, 0] = cr * px - sr * py + ox
        work[j, 1] = sr * px + cr * py + oy
        qx = normals[start_b + j, 0]
        qy = normals[start_b + j, 1]
        work[count_b + j, 0] = cr * qx - sr * qy
        work[count_b + j, 1] = sr * qx + cr * qy

    separation_a, face_a = _max_separation(vertices, start_a, normals, start_a, count_a, work,
                                           0, count_b)
    if separation_a > margin:
        return k
    separation_b, face_b = _max_separation(work, 0, work, count_b, count_b, vertices,
                                           start_a, count_a)
    flip = separation_b > separation_a + 0.1 * slop
    # Every contact lies at least the reference face's separation away.
    if flip and separation_b > margin:
        return k
    if flip:
        face_a = _incident_face(work[count_b + face_b, 0], work[count_b + face_b, 1], normals,
                                start_a, count_a)
    else:
        face_b = _incident_face(normals[start_a + face_a, 0], normals[start_a + face_a, 1],
                                work, count_b, count_b)
    a1 = face_a
    a2 = face_a + 1 if face_a + 1 < count_a else 0
    b1 = face_b
    b2 = face_b + 1 if face_b + 1 < count_b else 0
    # The two faces' ends (b's in a's frame).
    a1x, a1y = vertices[start_a + a1, 0], vertices[start_a + a1, 1]
    a2x, a2y = vertices[start_a + a2, 0], vertices[start_a + a2, 1]
    b1x, b1y = work[b1, 0], work[b1, 1]
    b2x, b2y = work[b2, 0], work[b2, 1]

    n_found = 0
    # Vertex-vertex: the corners' own contact, then the far clip end (step 4 of the
    # module doc).
    corner_a = -1
    corner_b = -1
    if max(separation_a, separation_b) > 0.1 * slop:
        s, t = _segment_fractions(a1x, a1y, a2x, a2y, b1x, b1y, b2x, b2y)
        if (s == 0.0 or s == 1.0) and (t == 0.0 or t == 1.0):
            corner_a = a1 if s == 0.0 else a2
            corner_b = b1 if t == 0.0 else b2
            cax, cay = (a1x, a1y) if s == 0.0 else (a2x, a2y)
            cbx, cby = (b1x, b1y) if t == 0.0 else (b2x, b2y)
            ux = cbx - cax
            uy = cby - cay
            distance = math.hypot(ux, uy)
            if not -distance > -margin:
                return k
            if distance > TINY:
                ux /= distance
                uy /= distance
            else:
                ux = 1.0
                uy = 0.0
            _write(out_point, out_normal, out_depth, out_feature, k,
                   0.5 * (cax + cbx), 0.5 * (cay + cby), ux, uy, distance, corner_a,
                   corner_b, xa, ya, ca, sa)
            n_found = 1

    # Clip the incident edge (w1 -> w2, running against the reference edge) to the
    # reference face's side planes.
    if flip:
        r1x, r1y, r2x, r2y = b1x, b1y, b2x, b2y
        nx, ny = work[count_b + b1, 0], work[count_b + b1, 1]
        w1x, w1y, w2x, w2y = a1x, a1y, a2x, a2y
    else:
        r1x, r1y, r2x, r2y = a1x, a1y, a2x, a2y
        nx, ny = normals[start_a + a1, 0], normals[start_a + a1, 1]
        w1x, w1y, w2x, w2y = b1x, b1y, b2x, b2y
    tx = -ny
    ty = nx
    upper_ref = (r2x - r1x) * tx + (r2y - r1y) * ty
    upper = (w1x - r1x) * tx + (w1y - r1y) * ty
    lower = (w2x - r1x) * tx + (w2y - r1y) * ty
    span = upper - lower
    low_x, low_y = w2x, w2y
    if lower < 0.0 and span > 0.0:
        u = (0.0 - lower) / span
        low_x = w2x + u * (w1x - w2x)
        low_y = w2y + u * (w1y - w2y)
    high_x, high_y = w1x, w1y
    if upper > upper_ref and span > 0.0:
        u = (upper_ref - lower) / span
        high_x = w2x + u * (w1x - w2x)
        high_y = w2y + u * (w1y - w2y)
    s_low = (low_x - r1x) * nx + (low_y - r1y) * ny
    s_high = (high_x - r1x) * nx + (high_y - r1y) * ny
    # (vertex of a, vertex of b) naming each clip end: the low end is the reference
    # face's first vertex against the incident face's last, the high end the reverse.
    if flip:
        mx, my = -nx, -ny
        first_a, first_b, second_a, second_b = a1, b2, a2, b1
        first_x, first_y, first_s = high_x, high_y, s_high
        second_x, second_y, second_s = low_x, low_y, s_low
    else:
        mx, my = nx, ny
        first_a, first_b, second_a, second_b = a1, b2, a2, b1
        first_x, first_y, first_s = low_x, low_y, s_low
        second_x, second_y, second_s = high_x, high_y, s_high
    if corner_a >= 0:
        # The far end only (the nearer one is the corners' contact), and only where it
        # is a point of the incident edge facing the reference face: there its
        # separation is its distance to the polygon. An incident edge beside the face
        # (which is why the corners are closest) clips to points off the edge.
        if first_s > second_s:
            second_x, second_y, second_s = first_x, first_y, first_s
            second_a, second_b = first_a, first_b
        along = (second_x - r1x) * tx + (second_y - r1y) * ty
        ex = w1x - w2x
        ey = w1y - w2y
        on_edge = ((second_x - w2x) * ex + (second_y - w2y) * ey) / max(ex * ex + ey * ey,
                                                                          TINY)
        if ((second_a == corner_a and second_b == corner_b) or not 0.0 <= along <= upper_ref
                or not 0.0 <= on_edge <= 1.0):
            return k + n_found
    elif -first_s > -margin:
        _write(out_point, out_normal, out_depth, out_feature, k,
               first_x - 0.5 * first_s * nx, first_y - 0.5 * first_s * ny, mx, my,
               first_s, first_a, first_b, xa, ya, ca, sa)
        n_found += 1
    if -second_s > -margin:
        _write(out_point, out_normal, out_depth, out_feature, k + n_found,
               second_x - 0.5 * second_s * nx, second_y - 0.5 * second_s * ny, mx, my,
               second_s, second_a, second_b, xa, ya, ca, sa)
        n_found += 1
    return k + n_found


@njit(cache=True, inline="always")
def _write(out_point, out_normal, out_depth, out_feature, k, px, py, nx, ny, separation,
           vertex_a, vertex_b, xa, ya, ca, sa):
    """Row k: a's frame point (px, py) and normal (nx, ny) turned to the world, depth
    -separation, key of (vertex_a, vertex_b)."""
    out_point[k, 0] = xa + ca * px - sa * py
    out_point[k, 1] = ya + sa * px + ca * py
    out_normal[k, 0] = ca * nx - sa * ny
    out_normal[k, 1] = sa * nx + ca * ny
    out_depth[k] = -separation
    out_feature[k] = (np.int64(SOURCE_CLIP) << 56) | (
        ((np.int64(vertex_a) << _VERTEX_BITS) | np.int64(vertex_b)) << 8)


@njit(cache=True)
def polygon_contacts(vertices, normals, start_a, count_a, start_b, count_b, pose_a, pose_b,
                     margin, slop):
    """``clip_pair`` over n pairs of the same two convex polygons.

    pose_a, pose_b: (n, 3) centre-of-mass poses (x, y, angle), m and rad. Returns
    (pair (K,) int64 index of each contact's pair, point (K, 2), normal (K, 2) a -> b,
    depth (K,), feature (K,) int64), each pair's contacts in order.
    """
    n = pose_a.shape[0]
    point = np.empty((2 * n, 2))
    normal = np.empty((2 * n, 2))
    depth = np.empty(2 * n)
    feature = np.empty(2 * n, np.int64)
    pair = np.empty(2 * n, np.int64)
    work = np.empty((2 * count_b, 2))
    k = 0
    for p in range(n):
        end = clip_pair(vertices, normals, start_a, count_a, start_b, count_b,
                        pose_a[p, 0], pose_a[p, 1], pose_a[p, 2], pose_b[p, 0],
                        pose_b[p, 1], pose_b[p, 2], margin, slop, work, point, normal,
                        depth, feature, k)
        pair[k:end] = p
        k = end
    return pair[:k], point[:k], normal[:k], depth[:k], feature[:k]
