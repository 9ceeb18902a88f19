"""Field-field contacts' second looks, compiled: the one-sided re-measure at a sharp
feature and the speculative samples along each contact's tangent.

``field_pairs.one_sided_depths`` and ``field_pairs.tangent_samples`` with both fields
given by their stack-machine programs (``sdf.compiled``): the same operations in the
same order, so the same bits, in one call instead of some forty small numpy
operations per group of pairs. Pair k's fields are programs prog_a[k], prog_b[k] of a
``ProgramTable`` (``sdf.program_table``: ``table`` below stands for its code, consts,
start, depth and nesting), their points evaluated in batches by run[k]. b is placed
in a's frame by placement k's cosine, sine (cos[k], sin[k], numpy's, as the numpy glue
computes them) and offset[k]: a point p of a's frame is R^T (p - offset) in b's, and
b's gradient g is R g in a's.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit
from ..sdf.program_table import evaluate_runs
from ..sorting import stable_argsort
from ._compiled_field_contacts import _safe_unit

__all__ = ["one_sided", "tangent_points"]


@njit(cache=True, error_model="numpy")
def _in_b(code: np.ndarray, consts: np.ndarray, start: np.ndarray, depth: int, nesting: int,
          prog_b: np.ndarray, run: np.ndarray, cos: np.ndarray, sin: np.ndarray,
          offset: np.ndarray, placed: np.ndarray, q: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """f_b and grad f_b (a's frame) at points q (N, 2) of a's frame, b placed by
    placements ``placed`` (N,) (``field_pairs._in_b``)."""
    n = q.shape[0]
    local = np.empty((n, 2))
    for i in range(n):
        c, s = cos[placed[i]], sin[placed[i]]
        rx, ry = q[i, 0] - offset[placed[i], 0], q[i, 1] - offset[placed[i], 1]
        local[i, 0], local[i, 1] = c * rx + s * ry, c * ry - s * rx
    value, grad = evaluate_runs(code, consts, start, depth, nesting, prog_b, run, placed, local,
                                n)
    for i in range(n):
        c, s = cos[placed[i]], sin[placed[i]]
        gx, gy = grad[i, 0], grad[i, 1]
        grad[i, 0], grad[i, 1] = c * gx - s * gy, s * gx + c * gy
    return value, grad


@njit(cache=True, error_model="numpy")
def one_sided(code: np.ndarray, consts: np.ndarray, start: np.ndarray, table_depth: int,
              nesting: int, prog_a: np.ndarray, prog_b: np.ndarray, run: np.ndarray,
              cos: np.ndarray, sin: np.ndarray, offset: np.ndarray, pair: np.ndarray,
              point: np.ndarray, depth: np.ndarray, normal: np.ndarray, ring: np.ndarray,
              relative: float, absolute: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``field_pairs.one_sided_depths``: (point (K, 2), depth (K,), normal (K, 2)) of the
    contacts pair (K,) (in pair order), point, depth, normal (a's frame), re-measured
    from each side where deeper by ``relative`` of the depth and by ``absolute`` m. ring
    (M, 2): the sample directions (the contact point's own first, (0, 0)). New arrays."""
    point, depth, normal = point.copy(), depth.copy(), normal.copy()
    m = ring.shape[0]
    count = 0
    for k in range(depth.shape[0]):
        count += depth[k] > 0.0
    rows = np.empty(count, np.int64)
    count = 0
    for k in range(depth.shape[0]):
        if depth[k] > 0.0:
            rows[count] = k
            count += 1
    if count == 0:
        return point, depth, normal
    q = np.empty((count * m, 2))
    placed = np.empty(count * m, np.int64)
    for r in range(count):
        k = rows[r]
        radius = 2.0 * depth[k]
        for t in range(m):
            i = r * m + t
            q[i, 0] = point[k, 0] + radius * ring[t, 0]
            q[i, 1] = point[k, 1] + radius * ring[t, 1]
            placed[i] = pair[k]
    # b's surface near q, measured in a; a's surface near q, measured in b.
    f_b, g_b = _in_b(code, consts, start, table_depth, nesting, prog_b, run, cos, sin, offset,
                     placed, q)
    on_b = np.empty_like(q)
    for i in range(q.shape[0]):
        on_b[i, 0], on_b[i, 1] = q[i, 0] - f_b[i] * g_b[i, 0], q[i, 1] - f_b[i] * g_b[i, 1]
    f_a_on_b, g_a_on_b = evaluate_runs(code, consts, start, table_depth, nesting, prog_a, run,
                                       placed, on_b, on_b.shape[0])
    f_a, g_a = evaluate_runs(code, consts, start, table_depth, nesting, prog_a, run, placed, q,
                             q.shape[0])
    on_a = np.empty_like(q)
    for i in range(q.shape[0]):
        on_a[i, 0], on_a[i, 1] = q[i, 0] - f_a[i] * g_a[i, 0], q[i, 1] - f_a[i] * g_a[i, 1]
    f_b_on_a, g_b_on_a = _in_b(code, consts, start, table_depth, nesting, prog_b, run, cos,
                               sin, offset, placed, on_a)
    for r in range(count):
        k = rows[r]
        # The deepest sample of each side (the first of equals, numpy's argmax).
        at_a = at_b = r * m
        for t in range(1, m):
            if -f_a_on_b[r * m + t] > -f_a_on_b[at_a]:
                at_a = r * m + t
            if -f_b_on_a[r * m + t] > -f_b_on_a[at_b]:
                at_b = r * m + t
        deep_a, deep_b = -f_a_on_b[at_a], -f_b_on_a[at_b]
        if not max(deep_a, deep_b) > max(depth[k] * (1.0 + relative), depth[k] + absolute):
            continue
        if deep_a >= deep_b:
            nx, ny = _safe_unit(g_a_on_b[at_a, 0], g_a_on_b[at_a, 1])
            new_depth = deep_a
            x, y, half = on_b[at_a, 0], on_b[at_a, 1], 0.5
        else:
            nx, ny = _safe_unit(g_b_on_a[at_b, 0], g_b_on_a[at_b, 1])
            nx, ny = -nx, -ny
            new_depth = deep_b
            x, y, half = on_a[at_b, 0], on_a[at_b, 1], -0.5
        if not nx * normal[k, 0] + ny * normal[k, 1] > 0.0:
            continue
        step = half * new_depth
        point[k, 0], point[k, 1] = x + step * nx, y + step * ny
        depth[k] = new_depth
        normal[k, 0], normal[k, 1] = nx, ny
    return point, depth, normal


@njit(cache=True, error_model="numpy")
def tangent_points(code: np.ndarray, consts: np.ndarray, program_start: np.ndarray,
                   table_depth: int, nesting: int, prog_a: np.ndarray, prog_b: np.ndarray,
                   run: np.ndarray, cos: np.ndarray, sin: np.ndarray, offset: np.ndarray,
                   pair: np.ndarray, point: np.ndarray, depth: np.ndarray, normal: np.ndarray,
                   start: np.ndarray, margin: np.ndarray, extent: np.ndarray, per_side: int):
    """``field_pairs.tangent_samples`` (k > 0, per_side >= 1): the contacts pair (K,) (in
    pair order), point (K, 2), depth (K,), normal (K, 2), start (K,) with the samples
    within their pair's margin (L,) m after their pair's contacts, out to their pair's
    extent (L,) m (finite), and each row's element (0 for a contact, 1 .. 2 per_side for
    its samples). New arrays."""
    k = pair.shape[0]
    width = 2 * per_side
    t = np.empty(width)
    n = k * width
    q = np.empty((n, 2))
    placed = np.empty(n, np.int64)
    for c in range(k):
        spacing = extent[pair[c]] / per_side
        for i in range(per_side):
            t[i] = (i + 1) * spacing
            t[per_side + i] = -t[i]
        tx, ty = -normal[c, 1], normal[c, 0]
        for s in range(width):
            i = c * width + s
            q[i, 0], q[i, 1] = point[c, 0] + t[s] * tx, point[c, 1] + t[s] * ty
            placed[i] = pair[c]
    f_a, g_a = evaluate_runs(code, consts, program_start, table_depth, nesting, prog_a, run,
                             placed, q, n)
    f_b, g_b = _in_b(code, consts, program_start, table_depth, nesting, prog_b, run, cos, sin,
                     offset, placed, q)
    count = 0
    for i in range(n):
        gap = f_a[i] + f_b[i]
        m = margin[placed[i]]
        count += gap >= 0.0 and gap < m and f_a[i] < m and f_b[i] < m
    total = k + count
    all_pair = np.empty(total, np.int64)
    for c in range(k):
        all_pair[c] = pair[c]
    rows = np.empty(count, np.int64)
    count = 0
    for i in range(n):
        gap = f_a[i] + f_b[i]
        m = margin[placed[i]]
        if gap >= 0.0 and gap < m and f_a[i] < m and f_b[i] < m:
            rows[count] = i
            all_pair[k + count] = placed[i]
            count += 1
    order = stable_argsort(all_pair)
    o_pair = np.empty(total, np.int64)
    o_point = np.empty((total, 2))
    o_depth = np.empty(total)
    o_normal = np.empty((total, 2))
    o_start = np.empty(total, np.int64)
    o_element = np.empty(total, np.int64)
    for o in range(total):
        src = order[o]
        o_pair[o] = all_pair[src]
        if src < k:
            o_point[o, 0], o_point[o, 1], o_depth[o] = point[src, 0], point[src, 1], depth[src]
            o_normal[o, 0], o_normal[o, 1] = normal[src, 0], normal[src, 1]
            o_start[o], o_element[o] = start[src], 0
            continue
        i = rows[src - k]
        nx, ny = _safe_unit(g_a[i, 0] - g_b[i, 0], g_a[i, 1] - g_b[i, 1])
        half = 0.5 * (f_b[i] - f_a[i])
        o_point[o, 0], o_point[o, 1] = q[i, 0] + half * nx, q[i, 1] + half * ny
        o_depth[o] = -(f_a[i] + f_b[i])
        o_normal[o, 0], o_normal[o, 1] = nx, ny
        o_start[o], o_element[o] = start[i // width], i % width + 1
    return o_pair, o_point, o_depth, o_normal, o_start, o_element
