"""The compiled stages of ``mesh_contacts.mesh_in_field`` around the descent.

``_place`` puts the mesh in the other body's frame and culls its triangles;
``_finish`` turns the descent's minima into contacts (merged starts, vertex and edge
keys, the normals measured on faces and kinks); ``_evaluate`` runs a field program on
a batch of points. Each follows the numpy stages of ``mesh_contacts``, which the tests
compare it with; the method and the constants' reasons are in that module's docstring.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..sdf.compiled import run_shared, scratch
from ..sorting import stable_argsort
from ..vec2 import unit_or
from ._compiled_descent import enclosing_circles

__all__ = ["EDGE_START", "VERTEX_START"]

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
#: The probes of ``_face_normals`` as offsets (4, 2), computed as numpy does there.
_PROBE_OFFSETS = _PROBE * _AXES


@njit(cache=True, error_model="numpy")
def _evaluate(code: np.ndarray, consts: np.ndarray, depth: int, nesting: int,
              points: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Value (n,) and gradient (n, 2) of a program (``sdf.compiled``) at points[:n]."""
    stack, frames, cur = scratch(depth, nesting, n)
    value, grad = np.empty(n), np.empty((n, 2))
    run_shared(code, consts, points, n, stack, frames, cur, value, grad, 0, 0, 0)
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
        for j in range(3):
            tri[h, j, 0], tri[h, j, 1] = local[kept[h], j, 0], local[kept[h], j, 1]
    return vertices, local, kept, tri


@njit(cache=True, error_model="numpy")
def _first_rows(pair: np.ndarray, element: np.ndarray, start: np.ndarray, n: int
                ) -> np.ndarray:
    """``_first_per_key`` of the first n rows (element * 256 + start: start < 256)."""
    key = element[:n] * 256 + start[:n]
    order = stable_argsort(key)
    order = order[stable_argsort(pair[:n][order])]
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
            so: np.ndarray, pose_other: np.ndarray, pose_mesh: np.ndarray):
    """Stages 1 (after the descent) to 4 and the world frame, as ``_mesh_in_field_numpy``.

    vertices (n, V, 2), kept (K,): from ``_place``; point (K, S, 2), value (K, S),
    distinct (K, S): the descent's minima of the kept triangles and
    ``descent.merge_minima``; start_ids (S,): their start ids; pose_mesh (n, 3): the
    mesh's poses (its centre of mass in other's frame, for crossed kinks). The rest as
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
    # 3. Normals (``_face_normals`` for a polygon pair). alt_of, per row: the row of the
    # face it falls back from (a kink's second face), or -1.
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
        # Up to two rows per candidate (a kink crossed by the mesh's edge: both faces).
        q_pair = np.empty(2 * c, dtype=np.int64)
        q_element = np.empty(2 * c, dtype=np.int64)
        q_start = np.empty(2 * c, dtype=np.int64)
        q_p = np.empty((2 * c, 2))
        q_depth = np.empty(2 * c)
        normal = np.empty((2 * c, 2))
        alt_of = np.full(2 * c, -1, dtype=np.int64)
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
            alt = -1
            if not ok and d > 0.0:
                # A kink on a mesh edge running along one of its faces takes that face;
                # one the edge crosses, first the face on the side of the mesh's centre
                # of mass, then the face turned most from it (see _face_normals).
                best, arg = np.inf, 0
                for a in range(4):
                    j = c + 4 * i + a
                    facing = 0.0 + g[j, 0] * edge_normal[i, 0] + g[j, 1] * edge_normal[i, 1]
                    if facing < best:
                        best, arg = facing, a
                along = best <= -_RUNS_ALONG
                crossed = not along and (edge_normal[i, 0] != 0.0 or edge_normal[i, 1] != 0.0)
                if crossed:
                    k = pair[i]
                    dx, dy = pose_mesh[k, 0] - pose_other[k, 0], pose_mesh[k, 1] - pose_other[k, 1]
                    tx = (co[k] * dx + so[k] * dy) - p[i, 0]
                    ty = (-so[k] * dx + co[k] * dy) - p[i, 1]
                    most = -np.inf
                    for a in range(4):
                        j = c + 4 * i + a
                        toward = 0.0 + g[j, 0] * tx + g[j, 1] * ty
                        if toward > most:
                            most, arg = toward, a
                if along or crossed:
                    j = c + 4 * i + arg
                    gx, gy = g[j, 0], g[j, 1]
                    d = -(f_probe[j] - (0.0 + _PROBE_OFFSETS[arg, 0] * gx
                                        + _PROBE_OFFSETS[arg, 1] * gy))
                    ok = True
                if crossed:
                    turn = -1.0
                    for a in range(4):
                        j = c + 4 * i + a
                        t = (g[j, 0] - gx) * (g[j, 0] - gx) + (g[j, 1] - gy) * (g[j, 1] - gy)
                        if t > turn:
                            turn, alt = t, a
                    if turn <= kink2:
                        alt = -1
            if ok:
                q_pair[face], q_element[face], q_start[face] = pair[i], element[i], start[i]
                q_p[face, 0], q_p[face, 1], q_depth[face] = p[i, 0], p[i, 1], d
                normal[face, 0], normal[face, 1] = gx, gy
                face += 1
                if alt >= 0:
                    j = c + 4 * i + alt
                    hx, hy = g[j, 0], g[j, 1]
                    q_pair[face], q_element[face], q_start[face] = pair[i], element[i], start[i]
                    q_p[face, 0], q_p[face, 1] = p[i, 0], p[i, 1]
                    q_depth[face] = -(f_probe[j] - (0.0 + _PROBE_OFFSETS[alt, 0] * hx
                                                    + _PROBE_OFFSETS[alt, 1] * hy))
                    normal[face, 0], normal[face, 1] = hx, hy
                    alt_of[face] = face - 1
                    face += 1
        c = face
        pair, element, start, p, depth = q_pair, q_element, q_start, q_p, q_depth
    else:
        normal = np.empty((c, 2))
        alt_of = np.full(c, -1, dtype=np.int64)
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
        # Behind the plane (s < 0), only a vertex inside other (see _reference_faces).
        supported[l] = abs(f[l]) <= _ON_FACE and f[n_near + l] <= (
            reach if sep[l] >= 0.0 else _ON_FACE)
        if supported[l] and -sep[l] > deepest[pair[r_idx[l]]] + slop:
            accepted[r_idx[l]] = False
    for r in range(c):              # a kink's second face only where its first is cut
        if alt_of[r] >= 0 and accepted[alt_of[r]]:
            accepted[r] = False
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
    order = stable_argsort(minus)
    order = use[order[stable_argsort(of[order])]]
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
