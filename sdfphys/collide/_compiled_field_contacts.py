"""Field-field contacts after the descent, compiled: the patch search and the merges.

``field_pairs.field_field_contacts`` descends on max(f_a, f_b) from its starts
(``_compiled_descent.descend``, problem ``PAIR``) and then, in one compiled call of
``field_contacts``, merges the minima per pair, measures each contact's normal and
depth, and searches along the contact patch for its two ends (``patch_ends``): the
same operations, in the same order, as the numpy reference in ``field_pairs``
(``_clusters``, ``_patch_ends``), with both fields given by their stack-machine
programs (``sdf.compiled``).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..sdf.compiled import run_shared, scratch
from ..sorting import stable_argsort
from ._descent_paths import EPS, PAIR, _stationarity

__all__ = ["field_contacts", "patch_ends"]


# --------------------------------------------------------------------------------------
# The patch search of field-field contacts
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy", refcounts=False)
def _h(code_a: np.ndarray, code_b: np.ndarray, consts: np.ndarray, work,
       rotation: np.ndarray, offset: np.ndarray, k: int, ox: float, oy: float, dx: float,
       dy: float, sx: float, sy: float, s: np.ndarray, m: int, value: np.ndarray,
       slope: np.ndarray) -> None:
    """h(s) = max(f_a(x), f_b(x - shift)), x = origin + s direction, and its slope in s,
    at s[:m] into value, slope (``field_pairs._patch_ends``'s ``h``, pair k, the same
    operations). code_a, code_b: the programs' rows, consts: their table's constants;
    work: (stack, frames, cur, points a (M, 2), f_a (M,), grad a (M, 2), points b, f_b,
    grad b)."""
    stack, frames, cur, xa, fa, ga, xb, fb, gb = work
    r00, r01, r10, r11 = rotation[k, 0, 0], rotation[k, 0, 1], rotation[k, 1, 0], \
        rotation[k, 1, 1]
    for j in range(m):
        x, y = ox + s[j] * dx, oy + s[j] * dy
        xa[j, 0], xa[j, 1] = x, y
        px, py = (x - sx) - offset[k, 0], (y - sy) - offset[k, 1]
        xb[j, 0], xb[j, 1] = px * r00 + py * r10, px * r01 + py * r11
    run_shared(code_a, consts, xa, m, stack, frames, cur, fa, ga, 0, 0, 0)
    run_shared(code_b, consts, xb, m, stack, frames, cur, fb, gb, 0, 0, 0)
    for j in range(m):
        if fa[j] >= fb[j]:
            value[j], slope[j] = fa[j], ga[j, 0] * dx + ga[j, 1] * dy
        else:
            value[j] = max(fa[j], fb[j])
            slope[j] = (gb[j, 0] * r00 + gb[j, 1] * r01) * dx + \
                (gb[j, 0] * r10 + gb[j, 1] * r11) * dy


@njit(cache=True, error_model="numpy")
def _work(depth: int, nesting: int):
    """Work arrays of ``_h`` for up to 3 points."""
    points = np.empty((3, 2))
    stack, frames, cur = scratch(depth, nesting, points.shape[0])   # not a literal 3
    return (stack, frames, cur, points, np.empty(3), np.empty((3, 2)), np.empty((3, 2)),
            np.empty(3), np.empty((3, 2)))


@njit(cache=True, error_model="numpy")
def patch_ends(code: np.ndarray, consts: np.ndarray, program_start: np.ndarray,
               table_depth: int, nesting: int, prog_a: np.ndarray, prog_b: np.ndarray,
               rotation: np.ndarray, offset: np.ndarray, pair: np.ndarray, centre: np.ndarray,
               normal: np.ndarray, depth: np.ndarray, sliver: np.ndarray, reach: np.ndarray,
               iterations: int, tol: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``field_pairs._patch_ends`` with both fields given by their programs: those of
    pair k are programs prog_a[k], prog_b[k] of the table code, consts, program_start,
    table_depth, nesting (``sdf.program_table.ProgramTable``).

    Same other arguments (pair (K,), centre (K, 2), normal (K, 2), depth, sliver, reach,
    tol (K,)) and results (s (K, 2), found (K, 2): column 0 the -t end, 1 the +t
    end). The Python version iterates all search directions at once while any is
    unfinished; each direction's iterates depend on its own values only, so here
    each runs its own loop, with the same steps.
    """
    n = depth.shape[0]
    work = _work(table_depth, nesting)
    ends = np.zeros((n, 2))
    found = np.zeros((n, 2), dtype=np.bool_)
    trials = np.empty(3)
    value = np.empty(3)
    slope = np.empty(3)
    # Batch sizes as variables: a literal argument would compile _h once per value.
    two, three = trials.shape[0] - 1, trials.shape[0]
    for c in range(n):
        k = pair[c]
        a, b = prog_a[k], prog_b[k]
        code_a = code[program_start[a]:program_start[a + 1]]
        code_b = code[program_start[b]:program_start[b + 1]]
        nx, ny = normal[c, 0], normal[c, 1]
        half = 0.5 * depth[c] - 0.5 * sliver[c]
        ox, oy = centre[c, 0] + half * nx, centre[c, 1] + half * ny
        sx, sy = (depth[c] - sliver[c]) * nx, (depth[c] - sliver[c]) * ny
        for side in range(2):
            dx, dy = (ny, -nx) if side == 0 else (-ny, nx)       # -t, then t = perp(n)
            lo, hi = 0.0, reach[c]
            trials[0], trials[1] = lo, hi
            _h(code_a, code_b, consts, work, rotation, offset, k, ox, oy, dx, dy, sx, sy,
               trials, two, value, slope)
            h_lo, h_hi, d_hi = value[0], value[1], slope[1]
            found[c, side] = h_lo < 0.0
            if not found[c, side]:
                continue
            if not h_hi > 0.0:
                ends[c, side] = hi
                continue
            for _ in range(iterations):
                if not hi - lo > tol[c]:
                    break
                a, b = lo, hi
                width = b - a
                middle = a + 0.5 * width
                trials[0] = b - h_hi / d_hi
                trials[1] = a - h_lo * width / (h_hi - h_lo)
                trials[2] = middle
                low, high = a + 1e-3 * width, b - 1e-3 * width
                for j in range(3):
                    t = trials[j] if math.isfinite(trials[j]) else middle
                    trials[j] = min(max(t, low), high)
                # Sort the three (a network, not ndarray.sort: cheaper to compile).
                if trials[0] > trials[1]:
                    trials[0], trials[1] = trials[1], trials[0]
                if trials[1] > trials[2]:
                    trials[1], trials[2] = trials[2], trials[1]
                if trials[0] > trials[1]:
                    trials[0], trials[1] = trials[1], trials[0]
                _h(code_a, code_b, consts, work, rotation, offset, k, ox, oy, dx, dy, sx, sy,
                   trials, three, value, slope)
                # The new bracket: the last trial with h < 0 and the first with h >= 0 after it.
                last_in = -1
                for j in range(3):
                    if value[j] < 0.0:
                        last_in = j
                first_out = 3
                for j in range(2, last_in, -1):
                    if not value[j] < 0.0:
                        first_out = j
                if last_in >= 0:
                    lo, h_lo = trials[last_in], value[last_in]
                if first_out < 3:
                    hi, h_hi, d_hi = trials[first_out], value[first_out], slope[first_out]
            ends[c, side] = lo
    return ends, found


# --------------------------------------------------------------------------------------
# Field-field contacts after the descent
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def _clusters(group: np.ndarray, point: np.ndarray, key: np.ndarray, score: np.ndarray,
              tiebreak: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``field_pairs._clusters`` (same arguments and results): per group (a run of equal
    ``group``), each point's leader is the lowest-key point within the group's
    radius (numpy's argmin: the first on ties, slot 0 when none); per head, the
    member with the lowest score (to 4 ulps) and then the lowest tiebreak."""
    n = point.shape[0]
    leader = np.empty(n, dtype=np.int64)
    head = np.empty(n, dtype=np.int64)
    best = np.empty(n, dtype=np.int64)
    count = 0
    lo = 0
    while lo < n:
        hi = lo + 1
        while hi < n and group[hi] == group[lo]:
            hi += 1
        r2 = radius[lo] * radius[lo]
        for k in range(lo, hi):
            lowest_key, arg = np.iinfo(np.int64).max, lo
            for j in range(lo, hi):
                dx, dy = point[k, 0] - point[j, 0], point[k, 1] - point[j, 1]
                if 0.0 + dx * dx + dy * dy < r2 and key[j] < lowest_key:
                    lowest_key, arg = key[j], j
            leader[k] = arg
        for h in range(lo, hi):
            if leader[h] != h:
                continue
            lowest = np.inf
            for k in range(lo, hi):
                if leader[k] == h and (score[k] < lowest or math.isnan(score[k])) \
                        and not math.isnan(lowest):
                    lowest = score[k]
            rounding = 4.0 * EPS * max(1.0, abs(lowest))
            arg, top = lo, np.inf
            for k in range(lo, hi):
                v = tiebreak[k] if leader[k] == h and score[k] <= lowest + rounding else np.inf
                if k == lo:
                    top = v
                elif not math.isnan(top) and (v < top or math.isnan(v)):
                    arg, top = k, v
            head[count], best[count] = h, arg
            count += 1
        lo = hi
    return head[:count], best[:count]


@njit(cache=True, error_model="numpy")
def _safe_unit(x: float, y: float) -> tuple[float, float]:
    """``sdf.safe_normalize`` of one row ((1, 0) for a zero vector)."""
    length = math.hypot(x, y)
    if length > 1e-300:
        return x / length, y / length
    return 1.0, 0.0


@njit(cache=True, error_model="numpy")
def field_contacts(code: np.ndarray, consts: np.ndarray, program_start: np.ndarray,
                   table_depth: int, nesting: int, prog_a: np.ndarray, prog_b: np.ndarray,
                   rotation: np.ndarray, offset: np.ndarray, pair_of: np.ndarray,
                   best: np.ndarray, phi: np.ndarray, data: np.ndarray, scale: np.ndarray,
                   n_starts: int, margin: np.ndarray, iterations: int, merge: float,
                   sliver: float):
    """``field_pairs.field_field_contacts`` from the descent's results on: contacts of the
    starts that hit, merged (``_clusters``), flat patches replaced by their ends
    (``patch_ends``), merged again. The same operations in the same order.

    code .. nesting: the fields' ``ProgramTable``, pair k's fields its programs
    prog_a[k], prog_b[k] (L,); rotation (L, 2, 2), offset (L, 2): b's placements;
    pair_of (S,): each start's pair (S = L n_starts, start id = row % n_starts);
    best (S, 2), phi (S,), data (S, 6): the descent's results; scale (L,): the
    regions' diagonals; margin (L,) m, each pair's; merge, sliver: ``field_pairs._MERGE``
    and ``field_pairs._SLIVER``. Returns (pair (K,) into the L placements, point (K,
    2), depth (K,), normal (K, 2), start id (K,)).
    """
    n_s = phi.shape[0]
    hits = np.empty(n_s, dtype=np.int64)
    n_hit = 0
    for i in range(n_s):
        if phi[i] < 0.5 * margin[pair_of[i]]:
            hits[n_hit] = i
            n_hit += 1
    group = np.empty(n_hit, dtype=np.int64)
    at = np.empty((n_hit, 2))
    key = np.empty(n_hit, dtype=np.int64)
    score = np.empty(n_hit)
    tiebreak = np.empty(n_hit)
    radius = np.empty(n_hit)
    point = np.empty((n_hit, 2))
    depth = np.empty(n_hit)
    normal = np.empty((n_hit, 2))
    for h in range(n_hit):
        i = hits[h]
        k = pair_of[i]
        fa, fb = data[i, 0], data[i, 1]
        gax, gay, gbx, gby = data[i, 2], data[i, 3], data[i, 4], data[i, 5]
        if abs(fa - fb) <= 1e-9 * scale[k]:
            nx, ny = _safe_unit(gax - gbx, gay - gby)
        elif fa > fb:
            nx, ny = _safe_unit(-gbx, -gby)
        else:
            nx, ny = _safe_unit(gax, gay)
        normal[h, 0], normal[h, 1] = nx, ny
        depth[h] = -(fa + fb)
        half = 0.5 * (fb - fa)
        point[h, 0], point[h, 1] = best[i, 0] + half * nx, best[i, 1] + half * ny
        group[h], at[h, 0], at[h, 1], key[h] = k, best[i, 0], best[i, 1], i % n_starts
        score[h], tiebreak[h] = phi[i], _stationarity(PAIR, data, i)
        radius[h] = merge * scale[k]
    head, chosen = _clusters(group, at, key, score, tiebreak, radius)
    n_c = head.shape[0]
    pair = np.empty(n_c, dtype=np.int64)
    c_point = np.empty((n_c, 2))
    c_depth = np.empty(n_c)
    c_normal = np.empty((n_c, 2))
    start_id = np.empty(n_c, dtype=np.int64)
    c_sliver, reach, tol = np.empty(n_c), np.empty(n_c), np.empty(n_c)
    for c in range(n_c):
        h = chosen[c]
        pair[c] = group[h]
        c_point[c, 0], c_point[c, 1], c_depth[c] = point[h, 0], point[h, 1], depth[h]
        c_normal[c, 0], c_normal[c, 1] = normal[h, 0], normal[h, 1]
        start_id[c] = key[head[c]]
        s = scale[pair[c]]
        c_sliver[c], reach[c], tol[c] = sliver * s, 2.0 * s, 1e-12 * s
    ends, found = patch_ends(code, consts, program_start, table_depth, nesting, prog_a, prog_b,
                             rotation, offset, pair, c_point, c_normal, c_depth, c_sliver,
                             reach, iterations, tol)
    # Per pair: its contacts kept as they are, then the -t ends, then the +t ends.
    flat = np.empty(n_c, dtype=np.bool_)
    n_flat = 0
    for c in range(n_c):
        r = merge * scale[pair[c]]
        flat[c] = (found[c, 0] and ends[c, 0] > r) or (found[c, 1] and ends[c, 1] > r)
        n_flat += flat[c]
    total = n_c + n_flat
    o_pair = np.empty(total, dtype=np.int64)
    source = np.empty(total, dtype=np.int64)         # c, or (side + 1) n_c + c for an end
    j = 0
    for c in range(n_c):
        if not flat[c]:
            o_pair[j], source[j] = pair[c], c
            j += 1
    for side in range(2):
        for c in range(n_c):
            if flat[c]:
                o_pair[j], source[j] = pair[c], (side + 1) * n_c + c
                j += 1
    order = stable_argsort(o_pair)
    e_pair = np.empty(total, dtype=np.int64)
    e_point = np.empty((total, 2))
    e_depth = np.empty(total)
    e_normal = np.empty((total, 2))
    e_id = np.empty(total, dtype=np.int64)
    e_score = np.empty(total)
    e_tiebreak = np.empty(total)
    e_radius = np.empty(total)
    for o in range(total):
        src = source[order[o]]
        c = src % n_c
        nx, ny = c_normal[c, 0], c_normal[c, 1]
        x, y = c_point[c, 0], c_point[c, 1]
        if src < n_c:
            e_id[o] = start_id[c]
        elif src < 2 * n_c:
            x, y = x - ends[c, 0] * -ny, y - ends[c, 0] * nx
            e_id[o] = n_starts + 2 * start_id[c]
        else:
            x, y = x + ends[c, 1] * -ny, y + ends[c, 1] * nx
            e_id[o] = n_starts + 2 * start_id[c] + 1
        e_pair[o], e_point[o, 0], e_point[o, 1], e_depth[o] = pair[c], x, y, c_depth[c]
        e_normal[o, 0], e_normal[o, 1] = nx, ny
        e_score[o], e_tiebreak[o] = -c_depth[c], float(e_id[o])
        e_radius[o] = merge * scale[pair[c]]
    head, chosen = _clusters(e_pair, e_point, e_id, e_score, e_tiebreak, e_radius)
    return e_pair[chosen], e_point[chosen], e_depth[chosen], e_normal[chosen], e_id[head]
