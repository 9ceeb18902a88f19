"""The compiled stages 2 and 3 of ``mesh_sdf.sdf_in_mesh`` and the constants they share.

``mesh_sdf`` describes the method (the support search from the field-field points over
the sdf body's boundary, then the incident face's far end); its numpy functions
(``_deepest_on_sdf``, ``_far_ends``, ``_support_numpy``) are the reference these
kernels are tested against, bit for bit. :func:`_support` runs both stages with the
two fields' programs (``sdf.compiled``) evaluated inside it, the same batches as
numpy's.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..sorting import stable_argsort
from ..vec2 import unit_or
from ._mesh_contacts_kernels import _evaluate

#: Rounds of the support search (``_deepest_on_sdf``), one evaluation of each field
#: per round for all contacts: 4 rungs x 4 growth per round span 4^8 in step size.
REFINE_ROUNDS = 8
#: Steps tried per round, times the contact's step scale (one evaluation batch).
_LADDER = np.array([1.0 / 16.0, 0.25, 1.0, 4.0])
#: A round without decrease divides the step scale by this (below the lowest rung).
_SHRINK = 64.0
#: |tangential part of -n| (sin of the angle between the sdf normal and -n) under
#: which the sdf surface is parallel to the mesh face: every point of it is as deep,
#: the search stops (a face resting on a face keeps the patch ends it started from).
_PARALLEL = 1e-9
#: Steps shorter than this fraction of the pair's overlap diagonal end the search.
_MIN_STEP = 1e-12
#: Far ends (``_far_ends``): probe distance either side of the deepest point and the
#: ladder's rungs along the incident face, as fractions of the overlap diagonal
#: (rung k at 2^(k - _RUNGS + 1): from 1.2e-7 to 1 diagonal), and the distance under
#: which a point is on the face's line (projection did not move it).
_PROBE = 1e-6
_RUNGS = 24
_ON_LINE = 1e-9
#: Rounded ends (``_far_ends``): rungs of the second ladder, evenly spaced between the
#: last rung on the face and the first off it (the flat part's end to 1/16 of that gap,
#: which is at most the flat length found), and the shortest flat part, as a fraction of
#: the overlap diagonal, whose end is reported (a curved surface stays on its tangent
#: line, within the on-line tolerance, for a few 1e-5 diagonals).
_FINE = 16
_MIN_FLAT = 2.0 ** -10
#: The two probes' normals agree within this (1 - cos, about 1.4 mrad): z is a smooth
#: point of the sdf (no corner), both sides face the mesh alike, and the incident face
#: is the side toward the body's centre (a rounded box's deepest point lies where its
#: flat bottom runs into the rounded corner).
_SMOOTH = 1e-6
#: There, the ladders start from the surface point this many overlap diagonals from z
#: toward the centre (on the flat part when it is longer).
_ANCHOR = 2.0 ** -6
#: The incident face must face the mesh face: (-n).g at least this (60 degrees).
_FACING = 0.5
#: A normal n is an outline edge's when |n . edge direction| <= this (1 urad).
_FACE_NORMAL = 1e-6
#: Start ids of far-end contacts: the deepest point's start id plus this (the
#: field-field ids are < 3 x 1024, so it needs one more bit, see ``narrowphase``).
FAR_END = 4096
#: A point of the sdf inside the mesh whose two nearest outline edges are within this
#: fraction of its depth of each other is on the mesh's medial axis (``_on_medial_axis``).
_MEDIAL = 1e-2
#: Relative tolerance of the support search's decrease test (4 ulps).
_FALL = 4.0 * np.finfo(float).eps


# --------------------------------------------------------------------------------------
# Stages 2 and 3 compiled: the operations of mesh_sdf's numpy functions, per contact
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def _project_compiled(code: np.ndarray, consts: np.ndarray, depth: int, nesting: int,
                      w: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``_project`` of w[:n] with the sdf's program: (z (n, 2), unit normal g (n, 2))."""
    f, g = _evaluate(code, consts, depth, nesting, w, n)
    z = np.empty((n, 2))
    for j in range(n):
        g[j, 0], g[j, 1] = unit_or(g[j, 0], g[j, 1], 1.0, 0.0)
        z[j, 0], z[j, 1] = w[j, 0] - f[j] * g[j, 0], w[j, 1] - f[j] * g[j, 1]
    return z, g


@njit(cache=True, error_model="numpy")
def _to_mesh(x: float, y: float, k: int, cos: np.ndarray, sin: np.ndarray,
             offset: np.ndarray) -> tuple[float, float]:
    """``_MeshInSdfFrame.to_mesh`` of one point of pair k."""
    vx, vy = x - offset[k, 0], y - offset[k, 1]
    c, s = cos[k], -sin[k]
    return c * vx - s * vy, s * vx + c * vy


@njit(cache=True, error_model="numpy")
def _from_edge(vertices: np.ndarray, j: int, x: float, y: float) -> tuple[float, float]:
    """(x, y) less its nearest point on the mesh's closed outline's edge j, from vertex
    j to vertex j + 1 (m, mesh frame)."""
    m = vertices.shape[0]
    ax, ay = vertices[j, 0], vertices[j, 1]
    q = (j + 1) % m
    ex, ey = vertices[q, 0] - ax, vertices[q, 1] - ay
    rx, ry = x - ax, y - ay
    along = min(max((rx * ex + ry * ey) / (ex * ex + ey * ey), 0.0), 1.0)
    return rx - along * ex, ry - along * ey


@njit(cache=True, error_model="numpy")
def _mesh_compiled(code: np.ndarray, consts: np.ndarray, depth: int, nesting: int,
                   cos: np.ndarray, sin: np.ndarray, offset: np.ndarray, points: np.ndarray,
                   pair: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``_MeshInSdfFrame.evaluate`` of points[:n] of pairs pair[:n] with the mesh's program."""
    q = np.empty((n, 2))
    for j in range(n):
        q[j, 0], q[j, 1] = _to_mesh(points[j, 0], points[j, 1], pair[j], cos, sin, offset)
    f, g = _evaluate(code, consts, depth, nesting, q, n)
    for j in range(n):
        ux, uy = unit_or(g[j, 0], g[j, 1], 1.0, 0.0)
        c, s = cos[pair[j]], sin[pair[j]]
        g[j, 0], g[j, 1] = c * ux - s * uy, s * ux + c * uy
    return f, g


@njit(cache=True, error_model="numpy")
def _support(code_s: np.ndarray, consts_s: np.ndarray, depth_s: int, nesting_s: int,
             code_m: np.ndarray, consts_m: np.ndarray, depth_m: int, nesting_m: int,
             vertices: np.ndarray, cos: np.ndarray, sin: np.ndarray, offset: np.ndarray,
             co: np.ndarray, so: np.ndarray, pose_sdf: np.ndarray, region: np.ndarray,
             margin: float, pair: np.ndarray, point: np.ndarray, depth: np.ndarray,
             start: np.ndarray):
    """``_support_numpy`` with the sdf's (``*_s``) and the mesh's (``*_m``) programs.

    vertices (M, 2): the mesh's outline; cos, sin (n,): of the mesh's angle in the
    sdf's frame, offset (n, 2) its position there; co, so (n,): of the sdf's angle
    (numpy's cos and sin, from the caller); pose_sdf (n, 3), region (n, 4); the
    field-field contacts pair (K,), point (K, 2), depth (K,), start (K,). Returns
    ``sdf_in_mesh``'s six arrays. Each support-search round and the far ends'
    probes and ladder evaluate the rows of all contacts in one batch, as numpy does.
    """
    n_c = pair.shape[0]
    m = vertices.shape[0]
    rungs = _LADDER.shape[0]
    diagonal = np.empty(n_c)
    step = np.empty(n_c)
    min_step = np.empty(n_c)
    for i in range(n_c):
        k = pair[i]
        ex, ey = region[k, 2] - region[k, 0], region[k, 3] - region[k, 1]
        diagonal[i] = math.hypot(ex, ey)
        step[i] = abs(depth[i]) + 1e-3 * diagonal[i]
        min_step[i] = _MIN_STEP * diagonal[i]
    # Stage 2: the support search (``_deepest_on_sdf``).
    z, g = _project_compiled(code_s, consts_s, depth_s, nesting_s, point, n_c)
    phi, n = _mesh_compiled(code_m, consts_m, depth_m, nesting_m, cos, sin, offset, z, pair,
                            n_c)
    active = np.ones(n_c, dtype=np.bool_)
    rows = np.empty(n_c, dtype=np.int64)
    t = np.empty((n_c, 2))
    w = np.empty((n_c * rungs, 2))
    w_pair = np.empty(n_c * rungs, dtype=np.int64)
    for _ in range(REFINE_ROUNDS):
        n_rows = 0
        for i in range(n_c):
            if not active[i]:
                continue
            ng = 0.0 + n[i, 0] * g[i, 0] + n[i, 1] * g[i, 1]
            tx, ty = -n[i, 0] + ng * g[i, 0], -n[i, 1] + ng * g[i, 1]
            length = math.hypot(tx, ty)
            if not length > _PARALLEL:
                active[i] = False
                continue
            rows[n_rows] = i
            t[n_rows, 0], t[n_rows, 1] = tx / length, ty / length
            n_rows += 1
        if n_rows == 0:
            break
        for r in range(n_rows):
            i = rows[r]
            for j in range(rungs):
                s = step[i] * _LADDER[j]
                w[r * rungs + j, 0] = z[i, 0] + s * t[r, 0]
                w[r * rungs + j, 1] = z[i, 1] + s * t[r, 1]
                w_pair[r * rungs + j] = pair[i]
        zc, gc = _project_compiled(code_s, consts_s, depth_s, nesting_s, w, n_rows * rungs)
        fc, nc = _mesh_compiled(code_m, consts_m, depth_m, nesting_m, cos, sin, offset, zc,
                                w_pair, n_rows * rungs)
        for r in range(n_rows):
            i = rows[r]
            count = 0
            before = phi[i]
            for j in range(rungs):
                value = fc[r * rungs + j]
                if not value < before - _FALL * max(1.0, abs(before)):
                    break
                count += 1
                before = value
            if count > 0:
                best = count - 1
                flat = r * rungs + best
                z[i, 0], z[i, 1], g[i, 0], g[i, 1] = zc[flat, 0], zc[flat, 1], gc[flat, 0], \
                    gc[flat, 1]
                phi[i], n[i, 0], n[i, 1] = fc[flat], nc[flat, 0], nc[flat, 1]
                grow = 4.0 if best == rungs - 1 else 1.0
                step[i] = step[i] * _LADDER[best] * grow
            else:
                step[i] /= _SHRINK
                active[i] = step[i] >= min_step[i]
    # Contacts within the margin and off the mesh's medial axis (``_on_medial_axis``).
    keep = np.empty(n_c, dtype=np.int64)
    n_k = 0
    for i in range(n_c):
        d = -phi[i]
        medial = False
        if d > 0.0:
            k = pair[i]
            zx, zy = _to_mesh(z[i, 0], z[i, 1], k, cos, sin, offset)
            gx, gy = _to_mesh(g[i, 0] + offset[k, 0], g[i, 1] + offset[k, 1], k, cos, sin,
                              offset)
            d1, d2, first, second = np.inf, np.inf, 0, 0
            for j in range(m):
                hx, hy = _from_edge(vertices, j, zx, zy)
                distance = math.sqrt(hx * hx + hy * hy)
                if distance < d1:
                    d2, second, d1, first = d1, first, distance, j
                elif distance < d2:
                    d2, second = distance, j
            vertex = second if second == (first + 1) % m else first
            adjacent = second == (first + 1) % m or first == (second + 1) % m
            bx, by = vertices[(vertex - 1) % m, 0], vertices[(vertex - 1) % m, 1]
            vx, vy = vertices[vertex, 0], vertices[vertex, 1]
            cx, cy = vertices[(vertex + 1) % m, 0], vertices[(vertex + 1) % m, 1]
            turn = (vx - bx) * (cy - vy) - (vy - by) * (cx - vx)
            below = 0.0 + (zx - vx) * gx + (zy - vy) * gy
            medial = (adjacent and turn > 0.0 and d2 - d1 <= _MEDIAL * d
                      and below >= d)
        if d > -margin and not medial:
            keep[n_k] = i
            n_k += 1
    edge = np.empty(n_k, dtype=np.int64)
    for h in range(n_k):
        i = keep[h]
        d = -phi[i]
        fx, fy = _to_mesh(z[i, 0] + d * n[i, 0], z[i, 1] + d * n[i, 1], pair[i], cos, sin,
                          offset)
        nearest, arg = np.inf, 0
        for j in range(m):
            gx, gy = _from_edge(vertices, j, fx, fy)
            gap = gx * gx + gy * gy
            if gap < nearest or (j == 0 and math.isnan(gap)):
                nearest, arg = gap, j
        edge[h] = arg
    # Stage 3: the far ends (``_far_ends``): two probes per contact, then the ladder.
    probes = np.empty((2 * n_k, 2))
    for h in range(n_k):
        i = keep[h]
        tx, ty = -n[i, 1], n[i, 0]
        size = _PROBE * diagonal[i]
        probes[h, 0], probes[h, 1] = z[i, 0] + size * tx, z[i, 1] + size * ty
        probes[n_k + h, 0], probes[n_k + h, 1] = z[i, 0] - size * tx, z[i, 1] - size * ty
    _, gp = _project_compiled(code_s, consts_s, depth_s, nesting_s, probes, 2 * n_k)
    facing = np.empty(n_k)
    face_g = np.empty((n_k, 2))
    u = np.empty((n_k, 2))
    rung = np.empty((n_k * _RUNGS, 2))
    lengths = np.empty(_RUNGS)
    for r in range(_RUNGS):
        lengths[r] = 2.0 ** (r - _RUNGS + 1)
    smooth = np.zeros(n_k, dtype=np.bool_)
    anchors = np.empty((n_k, 2))
    for h in range(n_k):
        i = keep[h]
        f0 = -(0.0 + gp[h, 0] * n[i, 0] + gp[h, 1] * n[i, 1])
        f1 = -(0.0 + gp[n_k + h, 0] * n[i, 0] + gp[n_k + h, 1] * n[i, 1])
        side = 1 if f1 > f0 or (math.isnan(f1) and not math.isnan(f0)) else 0
        smooth[h] = (0.0 + gp[h, 0] * gp[n_k + h, 0] + gp[h, 1] * gp[n_k + h, 1]
                     >= 1.0 - _SMOOTH)
        if smooth[h]:
            side = 0 if (0.0 + z[i, 0] * -n[i, 1] + z[i, 1] * n[i, 0]) < 0.0 else 1
        facing[h] = f1 if side == 1 else f0
        gx, gy = gp[side * n_k + h, 0], gp[side * n_k + h, 1]
        face_g[h, 0], face_g[h, 1] = gx, gy
        sign = 1.0 if side == 0 else -1.0
        ux, uy = -gy, gx
        flip = 1.0 if (0.0 + ux * -n[i, 1] + uy * n[i, 0]) * sign >= 0.0 else -1.0
        u[h, 0], u[h, 1] = ux * flip, uy * flip
        a = _ANCHOR * diagonal[i]
        anchors[h, 0], anchors[h, 1] = z[i, 0] + a * u[h, 0], z[i, 1] + a * u[h, 1]
    anchor, g_anchor = _project_compiled(code_s, consts_s, depth_s, nesting_s, anchors, n_k)
    origin = np.empty((n_k, 2))
    for h in range(n_k):
        i = keep[h]
        origin[h, 0], origin[h, 1] = z[i, 0], z[i, 1]
        if smooth[h]:
            gx, gy = g_anchor[h, 0], g_anchor[h, 1]
            ux, uy = -gy, gx
            flip = 1.0 if (0.0 + ux * u[h, 0] + uy * u[h, 1]) >= 0.0 else -1.0
            u[h, 0], u[h, 1] = ux * flip, uy * flip
            face_g[h, 0], face_g[h, 1] = gx, gy
            origin[h, 0], origin[h, 1] = anchor[h, 0], anchor[h, 1]
            facing[h] = -(0.0 + gx * n[i, 0] + gy * n[i, 1])
        for r in range(_RUNGS):
            length = diagonal[i] * lengths[r]
            rung[h * _RUNGS + r, 0] = origin[h, 0] + length * u[h, 0]
            rung[h * _RUNGS + r, 1] = origin[h, 1] + length * u[h, 1]
    projected, _ = _project_compiled(code_s, consts_s, depth_s, nesting_s, rung,
                                     n_k * _RUNGS)
    # The corners, and the second ladder toward each rounded end (``_far_ends``).
    found = np.zeros(n_k, dtype=np.bool_)
    rounded = np.zeros(n_k, dtype=np.bool_)
    reached = np.empty(n_k)
    corner = np.empty((n_k, 2))
    on_face = np.empty(_RUNGS, dtype=np.bool_)
    fine = np.empty((n_k, _FINE - 1))
    fine_rung = np.empty((n_k * (_FINE - 1), 2))
    for h in range(n_k):
        i = keep[h]
        tol = _ON_LINE * diagonal[i]
        first_off = 0                                   # argmin of the cumprod: 0 if none
        for r in range(_RUNGS):
            dx = projected[h * _RUNGS + r, 0] - rung[h * _RUNGS + r, 0]
            dy = projected[h * _RUNGS + r, 1] - rung[h * _RUNGS + r, 1]
            on_face[r] = math.sqrt(dx * dx + dy * dy) <= tol
        for r in range(_RUNGS):
            if not on_face[r]:
                first_off = r
                break
        off_face = not on_face[first_off]
        reached[h] = diagonal[i] * lengths[first_off - 1] if first_off > 0 else 0.0
        ex, ey = projected[h * _RUNGS + first_off, 0], projected[h * _RUNGS + first_off, 1]
        corner[h, 0], corner[h, 1] = ex, ey
        ox, oy = origin[h, 0], origin[h, 1]
        along = 0.0 + (ex - ox) * u[h, 0] + (ey - oy) * u[h, 1]
        off_line = abs(0.0 + (ex - ox) * face_g[h, 0] + (ey - oy) * face_g[h, 1])
        found[h] = (facing[h] >= _FACING and off_face and off_line <= tol
                    and along > reached[h] and along <= diagonal[i] * lengths[first_off])
        rounded[h] = facing[h] >= _FACING and not found[h] and first_off > 0 and off_face
        gap = diagonal[i] * lengths[first_off] - reached[h]
        for r in range(_FINE - 1):
            fine[h, r] = reached[h] + gap * ((r + 1) / _FINE)
            fine_rung[h * (_FINE - 1) + r, 0] = ox + fine[h, r] * u[h, 0]
            fine_rung[h * (_FINE - 1) + r, 1] = oy + fine[h, r] * u[h, 1]
    fine_projected, _ = _project_compiled(code_s, consts_s, depth_s, nesting_s, fine_rung,
                                          n_k * (_FINE - 1))
    # The far ends measured against the deepest point's mesh face, kept or not.
    far = np.zeros(n_k, dtype=np.bool_)
    end = np.empty((n_k, 2))
    end_depth = np.empty(n_k)
    for h in range(n_k):
        i = keep[h]
        tol = _ON_LINE * diagonal[i]
        flat = reached[h]
        for r in range(_FINE - 1):
            dx = fine_projected[h * (_FINE - 1) + r, 0] - fine_rung[h * (_FINE - 1) + r, 0]
            dy = fine_projected[h * (_FINE - 1) + r, 1] - fine_rung[h * (_FINE - 1) + r, 1]
            if not math.sqrt(dx * dx + dy * dy) <= tol:
                break
            flat = fine[h, r]
        rounded[h] = rounded[h] and flat > _MIN_FLAT * diagonal[i]
        if rounded[h]:
            ex, ey = origin[h, 0] + flat * u[h, 0], origin[h, 1] + flat * u[h, 1]
        else:
            ex, ey = corner[h, 0], corner[h, 1]
        found_h = found[h] or rounded[h]
        d = -phi[i]
        e_d = d + (0.0 + (z[i, 0] - ex) * n[i, 0] + (z[i, 1] - ey) * n[i, 1])
        end[h, 0], end[h, 1], end_depth[h] = ex, ey, e_d
        fx, fy = _to_mesh(ex + e_d * n[i, 0], ey + e_d * n[i, 1], pair[i], cos, sin, offset)
        v0x, v0y = vertices[edge[h], 0], vertices[edge[h], 1]
        q = (edge[h] + 1) % m
        evx, evy = vertices[q, 0] - v0x, vertices[q, 1] - v0y
        e_length2 = 0.0 + evx * evx + evy * evy
        t_foot = (0.0 + (fx - v0x) * evx + (fy - v0y) * evy) / e_length2
        k = pair[i]
        mx, my = _to_mesh(n[i, 0] + offset[k, 0], n[i, 1] + offset[k, 1], k, cos, sin, offset)
        face_normal = abs(0.0 + mx * evx + my * evy) <= _FACE_NORMAL * math.sqrt(e_length2)
        far[h] = (found_h and face_normal and t_foot >= -_ON_LINE and t_foot <= 1.0 + _ON_LINE
                  and e_d > -margin and e_d <= d + _ON_LINE * diagonal[i])
    # The contacts, then their far ends, stably by pair; to the world.
    n_far = 0
    for h in range(n_k):
        if far[h]:
            n_far += 1
    rows_of = np.empty(n_k + n_far, dtype=np.int64)          # h, or n_k + h for a far end
    of_pair = np.empty(n_k + n_far, dtype=np.int64)
    for h in range(n_k):
        rows_of[h], of_pair[h] = h, pair[keep[h]]
    j = n_k
    for h in range(n_k):
        if far[h]:
            rows_of[j], of_pair[j] = n_k + h, pair[keep[h]]
            j += 1
    order = stable_argsort(of_pair)
    total = n_k + n_far
    out_pair = np.empty(total, dtype=np.int64)
    out_mid = np.empty((total, 2))
    out_normal = np.empty((total, 2))
    out_depth = np.empty(total)
    out_edge = np.empty(total, dtype=np.int64)
    out_start = np.empty(total, dtype=np.int64)
    for o in range(total):
        row = rows_of[order[o]]
        h = row % n_k
        i = keep[h]
        k = pair[i]
        nx, ny = n[i, 0], n[i, 1]
        if row < n_k:
            px, py, d, s_id = z[i, 0], z[i, 1], -phi[i], start[i]
        else:
            px, py, d, s_id = end[h, 0], end[h, 1], end_depth[h], start[i] + FAR_END
        half = 0.5 * d
        mx, my = px + half * nx, py + half * ny
        out_pair[o], out_depth[o], out_edge[o], out_start[o] = k, d, edge[h], s_id
        out_mid[o, 0] = (co[k] * mx - so[k] * my) + pose_sdf[k, 0]
        out_mid[o, 1] = (so[k] * mx + co[k] * my) + pose_sdf[k, 1]
        out_normal[o, 0], out_normal[o, 1] = co[k] * nx - so[k] * ny, so[k] * nx + co[k] * ny
    return out_pair, out_mid, out_normal, out_depth, out_edge, out_start
