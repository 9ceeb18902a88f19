"""Compiled fast paths of ``find_contacts``: body boxes, circle contacts, merge.

``find_contacts`` (module doc of ``sdfphys.collide``) is a pipeline of numpy stages
whose Python cost is per stage. For scenes of many circles the per-pair numpy work
(orienting and grouping the pairs by shape, the circle narrowphase, the margin
filter, the flip to body_a < body_b, the sort) dominated a step. Here:

``reach_and_boxes``
    one pass over the bodies: the speculative reach (``speculative_reach``) and the
    world AABB grown by half the speculative distance plus the reach
    (``broadphase.body_box``, the kernel of ``world_bounds``).

``analytic_contacts``
    one pass over the sorted candidate pairs (``broadphase.candidate_pairs``,
    sorted by (i, j)): pairs of two circles, and of a circle and a box mesh
    (``TriangleMesh.box``, whose field is the ``Box`` primitive), become contacts
    directly; the others are handed back for the general narrowphase. Such a pair
    has at most one contact, so the reduction is a no-op for it and the contacts
    come out already sorted by (body_a, body_b). The arithmetic reproduces the
    general path bit for bit (circle-box: ``analytic_contacts``); circle-circle:

    - orientation: the body whose Shape comes first in the distinct-shape order is
      ``first`` (ties: the lower body id), as ``_narrowphase`` orients a pair;
    - with ``d = x_second - x_first``, ``|d| = hypot(d)``: depth = (r_first +
      r_second) - |d|; normal = d / |d| (coincident centres, |d| <= 1e-300: (1, 0),
      ``sdf.safe_normalize``), from first to second; point = x_first + (r_first -
      depth / 2) normal;
    - kept if depth > -(margin + max over the shape pair's group of (reach_first
      + reach_second)) (the margin ``collide_circles`` is called with) and depth >
      -((margin + reach_first) + reach_second) (the pair's own margin);
    - if first > second the bodies are swapped and the normal negated (point and
      depth unchanged).

    A bit-identical rotation needs numpy's cos and sin (numba's libm calls may
    differ in the last bit): the caller passes them per box body.

``predicted_box_rows``
    the predicted rows (``predicted.predicted_contacts``) of the circle-box pairs
    ``analytic_contacts`` picked, operation for operation, the implied ones left out;
    compiled only in scenes that have such pairs.

``merge_order``
    the order that merges the circle contacts and the general path's contacts, both
    sorted by (body_a, body_b[, feature]) and never sharing a body pair, into one
    sorted list.

All kernels are ``cache=True`` and run without a Python loop over bodies, pairs or
contacts.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..solver.pair_rows import unsigned
from ..vec2 import TINY, unit_or
from .broadphase import body_box
from .polygons import clip_pair
from .predicted import IMPLIED_COSINE, IMPLIED_ROUND_OFF, SOURCE_PREDICTED

__all__ = ["BOX", "CIRCLE", "OTHER", "POLYGON", "analytic_contacts", "merge_order",
           "predicted_box_rows", "reach_and_boxes"]


@njit(cache=True)
def reach_and_boxes(shape_bounds: np.ndarray, shape_radius: np.ndarray,
                    body_shape: np.ndarray, position: np.ndarray, angle: np.ndarray,
                    velocity: np.ndarray, angular_velocity: np.ndarray, dt: float,
                    half_margin: float, unbounded_radius: float, reach_cap: float,
                    reach: np.ndarray, boxes: np.ndarray) -> None:
    """Fill ``reach`` (B,) m and ``boxes`` (B, 4) ``[xmin, ymin, xmax, ymax]`` m.

    shape_bounds: (S, 4) body-frame AABBs of the distinct shapes (may be infinite);
    shape_radius: (S,) bounding radii (inf if unbounded); body_shape: (B,) int64
    index into them; position: (B, 2) centres of mass, m; angle: (B,) rad;
    velocity: (B, 2) m/s; angular_velocity: (B,) rad/s; dt: s.
    reach = min(dt (|v| + |w| r), reach_cap r), r = radius or ``unbounded_radius``
    if infinite (``collide.speculative_reach``); box = world AABB grown by
    half_margin + reach (``broadphase.body_box``, as ``world_bounds``).
    """
    for i in range(angle.shape[0]):
        s = body_shape[i]
        radius = shape_radius[s]
        r = radius if math.isfinite(radius) else unbounded_radius
        speed = math.hypot(velocity[i, 0], velocity[i, 1]) + abs(angular_velocity[i]) * r
        reach[i] = min(dt * speed, reach_cap * r)
        body_box(shape_bounds, s, radius, position[i, 0], position[i, 1], angle[i],
                 half_margin + reach[i], boxes, i)


#: Shape classes of ``analytic_contacts``: handled by the general path, circle, box
#: (``TriangleMesh.box``), other convex polygon (``TriangleMesh.convex``).
OTHER, CIRCLE, BOX, POLYGON = 0, 1, 2, 3


def analytic_pair(class_i: np.ndarray, class_j: np.ndarray) -> np.ndarray:
    """(P,) bool: the pairs of these shape classes that ``analytic_contacts`` finds
    (circle-circle, circle-box, box or convex polygon pairs; its branches), the others
    being left to the general path."""
    circle_i, circle_j = class_i == CIRCLE, class_j == CIRCLE
    return ((circle_i & circle_j) | (circle_i & (class_j == BOX))
            | ((class_i == BOX) & circle_j) | ((class_i >= BOX) & (class_j >= BOX)))


@njit(cache=True)
def _box_field(px: float, py: float, hx: float, hy: float) -> tuple[float, float, float]:
    """(value, gradient x, gradient y) of the box of half-extents (hx, hy) at (px, py):
    ``sdf.polygonal._box`` (Quilez's sdgBox) operation for operation."""
    wx = abs(px) - hx
    wy = abs(py) - hy
    ox = wx if wx >= 0.0 else 0.0
    oy = wy if wy >= 0.0 else 0.0
    out_len = math.hypot(ox, oy)
    inner = wx if wx >= wy else wy
    inner = inner if inner <= 0.0 else 0.0
    if out_len > 0.0:
        gx = ox / out_len
        gy = oy / out_len
    elif wx >= wy:
        gx, gy = 1.0, 0.0
    else:
        gx, gy = 0.0, 1.0
    gx *= -1.0 if px < 0.0 else 1.0
    gy *= -1.0 if py < 0.0 else 1.0
    return out_len + inner, gx, gy


@njit(cache=True)
def analytic_contacts(pairs: np.ndarray, body_shape: np.ndarray, shape_class: np.ndarray,
                      shape_radius: np.ndarray, shape_half: np.ndarray, polygons: tuple,
                      position: np.ndarray, angle: np.ndarray, trig: np.ndarray,
                      reach: np.ndarray, margin: float, slop: float, budget: int,
                      velocity: np.ndarray, angular_velocity: np.ndarray, dt: float,
                      predict: bool, box_rows: bool):
    """Contacts of the circle-circle, circle-box and convex polygon candidate pairs;
    the others' indices.

    pairs: (P, 2) uint64 candidate pairs (i < j), sorted by (i, j): a uint64 view of
    the int64 pairs (unsigned indices: numba wraps signed ones around, a compare and a
    select per access; ``solver.pair_rows.unsigned``; made by the caller, which costs
    no compiling); body_shape: (B,)
    int64 index into the distinct shapes, whose order decides the orientation of a
    pair of the same kinds; shape_class: (S,) int64 OTHER / CIRCLE / BOX / POLYGON;
    shape_radius: (S,) m, bounding radii (a circle's radius; the predicted rows' turning
    test reads the others'); shape_half: (S, 2) m, half-extents (boxes);
    polygons: ``polygons.polygon_table`` of the shapes (boxes and convex polygons);
    position: (B, 2) centres of mass, m; angle: (B,) rad; trig: (B, 4 or more), columns
    0 to 3 ``[cos(-a), sin(-a), cos(a), sin(a)]`` of each box body's angle a (numpy's
    values; other rows unused); reach: (B,) m; margin: m, the speculative distance;
    slop: m, ``Settings.linear_slop``; budget: ``Settings.contacts_per_pair``.

    Circle-circle: module doc. Circle-box (``collide_circle_and_field`` with the box
    field): the circle is first; its centre in the box frame c = R(-a)(x_c - x_b),
    (d, g) = box field and gradient at c, g normalized (``safe_normalize``) and
    turned to the world by R(a); depth = r - d, normal = -g, point = x_c - (d + r)/2 g;
    kept and flipped by the same rules. Two convex polygons (boxes or convex meshes):
    ``polygons.clip_pair`` with the pair's own margin, at most two contacts (the
    deeper one if budget is 1, ties to the smaller key), in key order.

    With ``predict``, the same pass picks the pairs that get a predicted row
    (``predicted.predicted_contacts``): a circle c and a body b that is not one, b
    turning by more than the slop at its bounding radius this step, |w_b| R_b dt > slop,
    or c moving against it by more than that, |v_c - v_b| dt > slop (velocity (B, 2)
    m/s, angular_velocity (B,) rad/s, dt s). With ``box_rows`` too, the picked
    circle-box pairs are returned apart, for ``predicted_box_rows``.

    Returns (body_a, body_b (K,) int64 with body_a < body_b, point (K, 2) m,
    normal (K, 2) unit a -> b, depth (K,) m > 0 overlapping, feature (K,) int64,
    rest (R,) int64 indices into ``pairs`` of the other pairs, n_circles, n_boxes,
    n_polygons: the circle-circle, circle-box and polygon candidate pairs seen,
    predicted (M,) int64 indices into ``pairs`` of the pairs picked for a predicted row,
    box_predicted (N,) int64 those of them that are circle-box pairs with ``box_rows``
    (then not in ``predicted``), in order). Contacts are sorted by (body_a, body_b,
    feature).
    """
    vertices, normals, poly_start, poly_count = polygons
    n_pairs = pairs.shape[0]
    n_shapes = shape_radius.shape[0]
    group_reach = np.empty((n_shapes, n_shapes))
    for u in range(n_shapes):
        for v in range(n_shapes):
            group_reach[u, v] = -np.inf
    code = np.empty(n_pairs, np.int64)
    rest = np.empty(n_pairs, np.int64)
    predicted = np.empty(n_pairs if predict else 0, np.int64)
    box_predicted = np.empty(n_pairs if predict and box_rows else 0, np.int64)
    n_predicted = 0
    n_box_predicted = 0
    n_rest = 0
    n_fast = 0
    n_circles = 0
    n_boxes = 0
    n_polygons = 0
    ushape = unsigned(body_shape)
    for p in range(n_pairs):
        i = pairs[p, 0]
        j = pairs[p, 1]
        ci = shape_class[ushape[i]]
        cj = shape_class[ushape[j]]
        if predict and (ci == CIRCLE) != (cj == CIRCLE):
            b = j if ci == CIRCLE else i
            c = i + j - b
            rx = velocity[c, 0] - velocity[b, 0]
            ry = velocity[c, 1] - velocity[b, 1]
            if (abs(angular_velocity[b]) * shape_radius[ushape[b]] * dt > slop
                    or (rx * rx + ry * ry) * dt * dt > slop * slop):
                if box_rows and shape_class[ushape[b]] == BOX:
                    box_predicted[n_box_predicted] = p
                    n_box_predicted += 1
                else:
                    predicted[n_predicted] = p
                    n_predicted += 1
        if ci == CIRCLE and cj == CIRCLE:
            swap = ushape[i] > ushape[j]
            n_circles += 1
        elif ci == CIRCLE and cj == BOX:
            swap = False
            n_boxes += 1
        elif ci == BOX and cj == CIRCLE:
            swap = True
            n_boxes += 1
        elif ci >= BOX and cj >= BOX:
            swap = ushape[i] > ushape[j]
            n_polygons += 1
        else:
            rest[n_rest] = p
            n_rest += 1
            continue
        f = j if swap else i
        s = i if swap else j
        code[n_fast] = -p - 1 if swap else p
        n_fast += 1
        value = reach[f] + reach[s]
        if value > group_reach[ushape[f], ushape[s]]:
            group_reach[ushape[f], ushape[s]] = value
    rows = 2 * n_fast
    body_a = np.empty(rows, np.int64)
    body_b = np.empty(rows, np.int64)
    point = np.empty((rows, 2))
    normal = np.empty((rows, 2))
    depth = np.empty(rows)
    feature = np.zeros(rows, np.int64)
    largest = 0
    for u in range(poly_count.shape[0]):
        largest = max(largest, poly_count[u])
    work = np.empty((2 * largest, 2))
    k = 0
    for c in range(n_fast):
        p = code[c] if code[c] >= 0 else -code[c] - 1
        f = pairs[p, 0] if code[c] >= 0 else pairs[p, 1]
        s = pairs[p, 1] if code[c] >= 0 else pairs[p, 0]
        sf = ushape[f]
        ss = ushape[s]
        found = 1
        if shape_class[sf] >= BOX:
            found = clip_pair(vertices, normals, poly_start[sf], poly_count[sf],
                              poly_start[ss], poly_count[ss], position[f, 0], position[f, 1],
                              angle[f], position[s, 0], position[s, 1], angle[s],
                              (margin + reach[f]) + reach[s], slop, work, point, normal,
                              depth, feature, k) - k
            if found == 2 and (budget == 1 or feature[k + 1] < feature[k]):
                if budget == 1:
                    found = 1
                    if depth[k + 1] > depth[k] or (depth[k + 1] == depth[k]
                                                   and feature[k + 1] < feature[k]):
                        _move_row(point, normal, depth, feature, k + 1, k)
                else:
                    _swap_rows(point, normal, depth, feature, k, k + 1)
        elif shape_class[ss] == CIRCLE:
            rf = shape_radius[sf]
            group_margin = margin + group_reach[sf, ss]
            dx = position[s, 0] - position[f, 0]
            dy = position[s, 1] - position[f, 1]
            # Pairs clearly beyond their margin are dropped before the distance (a
            # relative 1e-9 over the squared reach: rounding cannot turn a kept pair
            # into a dropped one); the others take the test below.
            gap = (rf + shape_radius[ss]) + min(group_margin, (margin + reach[f]) + reach[s])
            if dx * dx + dy * dy > (1.0 + 1e-9) * (gap * gap):
                continue
            distance = math.hypot(dx, dy)
            d = (rf + shape_radius[ss]) - distance
            if not (d > -group_margin and d > -((margin + reach[f]) + reach[s])):
                continue
            if distance > TINY:
                nx = dx / distance
                ny = dy / distance
            else:
                nx = 1.0
                ny = 0.0
            offset = rf - 0.5 * d
            point[k, 0] = position[f, 0] + offset * nx
            point[k, 1] = position[f, 1] + offset * ny
            normal[k, 0] = nx
            normal[k, 1] = ny
            depth[k] = d
        else:
            rf = shape_radius[sf]
            group_margin = margin + group_reach[sf, ss]
            vx = position[f, 0] - position[s, 0]
            vy = position[f, 1] - position[s, 1]
            cl, sl = trig[s, 0], trig[s, 1]
            value, gx, gy = _box_field(cl * vx - sl * vy, sl * vx + cl * vy,
                                       shape_half[ss, 0], shape_half[ss, 1])
            d = rf - value
            if not (d > -group_margin and d > -((margin + reach[f]) + reach[s])):
                continue
            length = math.hypot(gx, gy)
            if length > TINY:
                gx = gx / length
                gy = gy / length
            else:
                gx = 1.0
                gy = 0.0
            cw, sw = trig[s, 2], trig[s, 3]
            wx = cw * gx - sw * gy
            wy = sw * gx + cw * gy
            half = 0.5 * (value + rf)
            point[k, 0] = position[f, 0] - half * wx
            point[k, 1] = position[f, 1] - half * wy
            normal[k, 0] = -wx
            normal[k, 1] = -wy
            depth[k] = d
        for r in range(k, k + found):
            if f > s:
                body_a[r] = np.int64(s)
                body_b[r] = np.int64(f)
                normal[r, 0] = -normal[r, 0]
                normal[r, 1] = -normal[r, 1]
            else:
                body_a[r] = np.int64(f)
                body_b[r] = np.int64(s)
        k += found
    return (body_a[:k], body_b[:k], point[:k], normal[:k], depth[:k], feature[:k],
            rest[:n_rest], n_circles, n_boxes, n_polygons, predicted[:n_predicted],
            box_predicted[:n_box_predicted])


#: Feature key of a predicted row (element and start 0).
_PREDICTED_KEY = np.int64(SOURCE_PREDICTED) << np.int64(56)


@njit(cache=True, error_model="numpy")
def predicted_box_rows(chosen: np.ndarray, pairs: np.ndarray, body_shape: np.ndarray,
                       shape_class: np.ndarray, shape_radius: np.ndarray,
                       shape_half: np.ndarray, position: np.ndarray, velocity: np.ndarray,
                       angular_velocity: np.ndarray, trig: np.ndarray, reach: np.ndarray,
                       margin: float, slop: float, dt: float, key: np.ndarray,
                       normal_now: np.ndarray, depth_now: np.ndarray):
    """The predicted rows of the circle-box pairs ``chosen`` (M,) (rows of ``pairs``,
    (P, 2) uint64, in order: ``analytic_contacts``' box_predicted), as
    ``predicted.predicted_contacts`` makes them, operation for operation (its module
    docstring derives the row), less those a contact of the pair implies
    (``collide._implied``).

    A circle c (radius r) and a box b (bounding radius R, half-extents): the circle's
    centre at the step's end in the box's end frame, the box field there, its surface
    point at the end carried back to the box's material point, the gap along the end
    normal; kept when under the pair's margin (margin + reach_i + reach_j, m) and the box
    turns by more than ``slop`` at R or the gap is open. Implied: a contact of the pair
    (pair keys ``key`` (K,) = body_a B + body_b, sorted, with ``normal_now`` (K, 2) and
    ``depth_now`` (K,)) with the same normal (cosine at least ``IMPLIED_COSINE``) and a
    depth at least the row's less ``IMPLIED_ROUND_OFF``. trig (B, 10): as
    ``analytic_contacts`` takes it and, in columns 4 to 9 of each box given, ``[cos(-a'),
    sin(-a'), cos(a'), sin(a'), cos(-w dt), sin(-w dt)]`` of its end angle a' = a + w dt
    (numpy's values, as ``predicted_contacts`` turns by them). Other arguments as
    ``analytic_contacts``.

    Returns body_a, body_b (N,) int64 (body_a < body_b), point (N, 2), normal (N, 2) a ->
    b, depth (N,), feature (N,) int64: the kept rows, in pair order.
    """
    n = chosen.shape[0]
    n_bodies = np.int64(position.shape[0])
    body_a = np.empty(n, np.int64)
    body_b = np.empty(n, np.int64)
    point = np.empty((n, 2))
    normal = np.empty((n, 2))
    depth = np.empty(n)
    ushape = unsigned(body_shape)
    k = 0
    for q in range(n):
        i = np.int64(pairs[chosen[q], 0])
        j = np.int64(pairs[chosen[q], 1])
        c, b = (i, j) if shape_class[ushape[i]] == CIRCLE else (j, i)
        radius_c = shape_radius[ushape[c]]
        sb = ushape[b]
        turning = abs(angular_velocity[b]) * shape_radius[sb] * dt > slop
        pair_margin = (margin + reach[i]) + reach[j]
        cex = position[c, 0] + velocity[c, 0] * dt
        cey = position[c, 1] + velocity[c, 1] * dt
        bex = position[b, 0] + velocity[b, 0] * dt
        bey = position[b, 1] + velocity[b, 1] * dt
        vx, vy = cex - bex, cey - bey
        cl, sl = trig[b, 4], trig[b, 5]
        value, gx, gy = _box_field(cl * vx - sl * vy, sl * vx + cl * vy, shape_half[sb, 0],
                                   shape_half[sb, 1])
        gx, gy = unit_or(gx, gy, 1.0, 0.0)                     # sdf.safe_normalize's
        cw, sw = trig[b, 6], trig[b, 7]
        ox = cw * gx - sw * gy                                  # n', out of b
        oy = sw * gx + cw * gy
        qx = (cex - value * ox) - bex                           # q' - x'_b
        qy = (cey - value * oy) - bey
        ct, st = trig[b, 8], trig[b, 9]
        mx = position[b, 0] + (ct * qx - st * qy)               # q0
        my = position[b, 1] + (st * qx + ct * qy)
        nx, ny = -ox, -oy                                       # circle -> b
        gap = (nx * (mx - position[c, 0]) + ny * (my - position[c, 1])) - radius_c
        if not (gap < pair_margin and (turning or gap > 0.0)):
            continue
        gap = gap if gap >= 0.0 else 0.0
        if turning:
            px = mx - (0.5 * gap) * nx
            py = my - (0.5 * gap) * ny
        else:
            px = position[c, 0] + (radius_c + 0.5 * gap) * nx
            py = position[c, 1] + (radius_c + 0.5 * gap) * ny
        if c > b:                                               # rows are body_a < body_b
            nx, ny = -nx, -ny
        wanted = i * n_bodies + j
        implied = False
        for r in range(np.searchsorted(key, wanted), key.shape[0]):
            if key[r] != wanted:
                break
            if (normal_now[r, 0] * nx + normal_now[r, 1] * ny >= IMPLIED_COSINE
                    and depth_now[r] >= -gap - IMPLIED_ROUND_OFF):
                implied = True
                break
        if implied:
            continue
        body_a[k], body_b[k] = i, j
        point[k, 0], point[k, 1] = px, py
        normal[k, 0], normal[k, 1] = nx, ny
        depth[k] = -gap
        k += 1
    return (body_a[:k], body_b[:k], point[:k], normal[:k], depth[:k],
            np.full(k, _PREDICTED_KEY, np.int64))


@njit(cache=True)
def _move_row(point, normal, depth, feature, source, target):
    """Copy contact row ``source`` over row ``target``."""
    point[target, 0] = point[source, 0]
    point[target, 1] = point[source, 1]
    normal[target, 0] = normal[source, 0]
    normal[target, 1] = normal[source, 1]
    depth[target] = depth[source]
    feature[target] = feature[source]


@njit(cache=True)
def _swap_rows(point, normal, depth, feature, u, v):
    """Exchange contact rows u and v."""
    for axis in range(2):
        point[u, axis], point[v, axis] = point[v, axis], point[u, axis]
        normal[u, axis], normal[v, axis] = normal[v, axis], normal[u, axis]
    depth[u], depth[v] = depth[v], depth[u]
    feature[u], feature[v] = feature[v], feature[u]


@njit(cache=True)
def merge_order(key_a: np.ndarray, key_b: np.ndarray) -> np.ndarray:
    """The order (K_a + K_b,) that merges two lists sorted by their pair keys (body_a *
    n_bodies + body_b), as indices into their concatenation [a, b]; the lists share no
    key, and rows with one key keep their order."""
    na = key_a.shape[0]
    nb = key_b.shape[0]
    order = np.empty(na + nb, np.int64)
    u = 0
    v = 0
    for k in range(na + nb):
        if v >= nb or (u < na and key_a[u] < key_b[v]):
            order[k] = u
            u += 1
        else:
            order[k] = na + v
            v += 1
    return order
