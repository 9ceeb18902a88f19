"""Compiled kernels of ``descent``: one round of the line-search descent, for every start.

``descent._descend`` runs rounds of: ``propose`` (numba) writes the candidate
points of every running start into one buffer; ONE problem evaluation (numpy,
the fields are Python objects) gives their values and gradients; ``accept``
(numba) updates every start's best point, line-search bracket, second bundle
plane and step scale. The algorithm is described in ``descent``'s module
docstring; the derivations of its pieces sit above the functions below.

Kinds of problem (``kind``): ``TRIANGLE`` (f restricted to a triangle, paths
projected onto the start's triangle) and ``PAIR`` (a balance of two fields over
the plane, see ``field_pairs._PairProblem``; data columns f_a, f_b, grad f_a, grad f_b).

State of P starts, updated in place (columns named by the constants below):

- ``state`` (P, N_STATE) float64: best point b (m), its objective and gradient,
  the second plane of the bundle (point, value, gradient), the path of the line
  search in progress (``PATH``: 8 parameters, see ``_proximal_step``) and its
  bracket ends (s, value, slope), the step scale sigma (path units), the
  Barzilai-Borwein memory (last b, last direction), per round the slope of
  the steepest path at s = 0 and the ladder's scale, and (PAIR) the prior best
  point with the two fields' gradients there.
- ``flags`` (P, N_FLAGS) int64: bracketed, rounds without decrease in a row,
  rounds run, BB memory usable, per round the number and offset of the start's
  candidates and whether its steepest ladder ended at the path's end, whether
  the minimiser of its triangle's model (cone or cuts) was tried, whether
  its last continued line search shrank its bracket less than half, and (PAIR)
  whether the prior point is set and whether the osculating point won the last
  round (then proposed alone).
- ``running`` (P,) int64: the indices of the running starts (the leading R).
- ``data`` (P, kd): the problem's data at b (TRIANGLE: the gradient).

Per triangle (TRIANGLE; one dummy row for PAIR), from the starts
(``triangle_starts``, ``triangle_known``): ``corner`` (T, 3, 3), f and its
gradient at each vertex where a start was placed (NaN elsewhere), and ``shape``
(T, 4), what f is over the triangle (GENERAL, PLANE with its gradient, CONE or
CUTS with the model's minimiser and its predicted value).

Candidates of a round: ``cand`` (C, 5) float64 (step s, point, dq/ds),
``cand_i`` (C, 2) int64 (column, source: the row of the evaluated points, or
``AT_BEST`` (b itself), or ``AT_CORNER - v`` (vertex v of the start's triangle,
whose value is known from a start placed there)).
"""

from __future__ import annotations

import math

import numpy as np
from numba import types

from .._jit import njit
from .._shared_kernel import F1, F2, F3, I1, I2, shared
from ._descent_paths import (
    ALT,
    AT_BEST,
    AT_CORNER,
    BB_RANGE,
    BEST,
    BRACKETED,
    COLUMN_BUNDLE,
    COLUMN_MODEL,
    COLUMN_OSCULATING,
    CONE,
    COUNT,
    D0,
    END_REACH,
    ENDED,
    EPS,
    FAILS,
    GENERAL,
    GRAD,
    GUARD,
    HAS_PREVIOUS,
    HAS_PRIOR,
    KINK,
    LADDER,
    LEFT,
    MODEL,
    N_COLUMNS,
    N_RUNGS,
    OFFSET,
    OSCULATING,
    PARALLEL,
    PHI,
    PLANE,
    PREVIOUS,
    PRIOR,
    PROBE,
    RIGHT,
    ROUNDS,
    SCALE,
    SHRINK,
    SIGMA,
    SLOW,
    STATIONARY,
    STATIONARY_PAIR,
    TINY,
    TRIANGLE,
    _bundle_free,
    _bundle_path,
    _max,
    _min,
    _norm,
    _path,
    _ray_end,
    _stationarity,
    _steep_path,
    _store_path,
    _stored_path,
    _unit,
    _vertices,
    osculating_point_shared,
)

# --------------------------------------------------------------------------------------
# Line-search models
# --------------------------------------------------------------------------------------

# Two trial steps inside a bracket [sl, sr] from values p and slopes d at its ends:
# (1) the zero of the secant of the slope, sl - dl w / (dr - dl) (w = sr - sl; exact
#     for a quadratic), when dr > 0; else the minimiser of the quadratic with value
#     pl and slope dl at sl and value pr at sr, sl - dl w^2 / (2 (pr - pl - dl w));
# (2) the crossing of the tangent lines at both ends,
#     (pr - pl + dl sl - dr sr) / (dl - dr), exact at a kink between two linear
#     pieces (a polygon's medial axis, a circle's centre along a ray through it).
# Both are kept GUARD w away from the ends; invalid models fall back to the midpoint.

@njit(cache=True, error_model="numpy")
def _model_steps(sl: float, pl: float, dl: float, sr: float, pr: float, dr: float
                 ) -> tuple[float, float]:
    """The two model steps (ascending) in a bracket: s, value and slope at its ends."""
    w = sr - sl
    mid = sl + 0.5 * w
    first = mid
    if dr > 0.0:
        if dr > dl:
            first = sl - dl * w / (dr - dl)
    else:
        curvature = pr - pl - dl * w
        if curvature > 0.0:
            first = sl - 0.5 * dl * w * w / curvature
    second = mid
    if dr > dl:
        second = (pr - pl + dl * sl - dr * sr) / (dl - dr)
    if not math.isfinite(first):
        first = mid
    if not math.isfinite(second):
        second = mid
    lo, hi = sl + GUARD * w, sr - GUARD * w
    first = _min(_max(first, lo), hi)
    second = _min(_max(second, lo), hi)
    return _min(first, second), _max(first, second)


# --------------------------------------------------------------------------------------
# One round
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def _code(kind: int, shape: np.ndarray, t: int, state: np.ndarray, i: int) -> int:
    """What is known of f around start i: its triangle's shape code, except that a
    start no longer on its triangle's plane (another gradient at b: the plane was
    read from the starts alone) descends as on a GENERAL triangle."""
    if kind != TRIANGLE:
        return GENERAL
    return _shape_code(shape[t, 0], shape[t, 1], shape[t, 2], state[i, GRAD],
                       state[i, GRAD + 1])


@njit(cache=True, error_model="numpy")
def _shape_code(code: float, plane_x: float, plane_y: float, gx: float, gy: float) -> int:
    """``_code`` of a triangle start from its shape row (code, plane gradient) and the
    gradient at b."""
    if int(code) == PLANE and (gx != plane_x or gy != plane_y):
        return GENERAL
    return int(code)


@njit(cache=True, error_model="numpy")
def _moving(kind: int, v: tuple, steep: tuple, sigma: float) -> tuple[bool, float, float]:
    """Whether the steepest path ``steep`` leaves b (a projected gradient longer than
    ``STATIONARY``, ``STATIONARY_PAIR`` for a field pair), and its dq/ds there (read at
    s = PROBE sigma, past any corner)."""
    _, _, dqx, dqy = _path(kind, v, steep, PROBE * sigma)
    return _norm(dqx, dqy) > (STATIONARY if kind == TRIANGLE else STATIONARY_PAIR), dqx, dqy


@njit(cache=True, error_model="numpy", refcounts=False)
def _most_candidates(kind: int, owner: np.ndarray, shape: np.ndarray, state: np.ndarray,
                     flags: np.ndarray, i: int) -> int:
    """Most candidates ``propose`` can write for start i next round."""
    code = _code(kind, shape, owner[i] if kind == TRIANGLE else 0, state, i)
    flat = code == PLANE or (code >= CONE and flags[i, MODEL] == 0)
    total = 1 if flat else N_RUNGS
    if not flat and (state[i, ALT] != state[i, BEST] or state[i, ALT + 1] != state[i, BEST + 1]):
        total += N_RUNGS - 1
    if flags[i, BRACKETED]:
        total += 2
    return total + (1 if kind != TRIANGLE else 0)            # the osculating point


@njit(cache=True, error_model="numpy")
def bound(kind: int, owner: np.ndarray, shape: np.ndarray, state: np.ndarray,
          flags: np.ndarray, running: np.ndarray) -> int:
    """Most candidates ``propose`` can write this round (the buffers' size)."""
    total = 0
    for i in running:
        total += _most_candidates(kind, owner, shape, state, flags, i)
    return total


@njit(cache=True, error_model="numpy")
def propose(kind: int, tri: np.ndarray, owner: np.ndarray, corner: np.ndarray,
            shape: np.ndarray, state: np.ndarray, flags: np.ndarray, data: np.ndarray,
            barzilai_borwein: bool, running: np.ndarray, cand: np.ndarray, cand_i: np.ndarray,
            points: np.ndarray) -> tuple[int, int, int]:
    """Candidates of the running starts (``running``: their indices) for this round.

    Returns (C, U, R): the number of candidates, of distinct points to evaluate
    (``points[:U]``) and of starts that proposed some (``running[:R]`` on return).

    tri (T, 3, 2), owner (P,): the starts' triangles (TRIANGLE); corner (T, 3, 3):
    value and gradient of f at each vertex, NaN where unknown; shape (T, 4): what
    f is over the triangle (``triangle_known``): on a plane the steepest path runs
    straight to its end and only the end is evaluated; on a cone or cuts the start
    tries the model's minimiser first. A field pair's start adds its osculating point
    (``_osculating_point``), alone when it won the last round. Stops the starts whose
    projected gradient vanishes; writes the per-round columns of ``state`` and
    ``flags`` and the candidates (rows 0..C-1 of ``cand``, ``cand_i``).
    """
    # Paths of a round (rows: steepest, bundle, the line search's) and the plan of
    # a start's candidates: path (-1: the model's minimiser, 3: the osculating point),
    # step, column,
    # candidate it may repeat (-1: none), and whether it is the steepest path's end.
    plan_path = np.empty(N_COLUMNS, dtype=np.int64)
    plan_s = np.empty(N_COLUMNS)
    plan_twin = np.empty(N_COLUMNS, dtype=np.int64)
    plan_end = np.empty(N_COLUMNS, dtype=np.bool_)
    n = u = kept = 0
    shared_t = shared_source = -1                     # the last model minimiser evaluated
    for i in running:
        t = owner[i] if kind == TRIANGLE else 0
        v = _vertices(tri, t)
        code = _code(kind, shape, t, state, i)
        sigma = state[i, SIGMA]
        # The steepest path from b and its slope at the start; a zero projected
        # gradient is a stationary point (the start stops). Paths of a round:
        # steepest, bundle, the line search's.
        steep = _steep_path(kind, state, data, i)
        bundle = search = steep
        moving, dqx, dqy = _moving(kind, v, steep, sigma)
        if not moving:
            continue
        running[kept] = i
        kept += 1
        flags[i, ROUNDS] += 1
        state[i, D0] = state[i, GRAD] * dqx + state[i, GRAD + 1] * dqy
        count = 0
        end, end_dx, end_dy = np.inf, 0.0, 0.0
        # A field pair's osculating point (once b has a prior point), alone when it won
        # the last round.
        osculating, model_x, model_y = False, 0.0, 0.0
        if kind != TRIANGLE and flags[i, HAS_PRIOR]:
            osculating, model_x, model_y = osculating_point_shared(
                data[i, 0], data[i, 1], data[i, 2], data[i, 3], data[i, 4], data[i, 5],
                state[i, BEST], state[i, BEST + 1], state[i, PRIOR], state[i, PRIOR + 1],
                state[i, PRIOR + 2], state[i, PRIOR + 3], state[i, PRIOR + 4],
                state[i, PRIOR + 5])
        alone = osculating and flags[i, OSCULATING] == 1
        flags[i, OSCULATING] = 2 if alone else 0
        if alone:
            plan_path[0], plan_s[0], plan_twin[0], plan_end[0] = 3, 0.0, -1, False
            count = 1
            osculating = False
        elif code >= CONE and flags[i, MODEL] == 0:
            # The model's minimiser, shared by the starts of the triangle.
            flags[i, MODEL] = 1
            plan_path[0], plan_s[0], plan_twin[0], plan_end[0] = -1, 0.0, -1, False
            count = 1
        else:
            has_alt = code != PLANE and (state[i, ALT] != state[i, BEST]
                                         or state[i, ALT + 1] != state[i, BEST + 1])
            if has_alt:
                bundle = _bundle_path(state, i)
                if kind == TRIANGLE:
                    has_alt = _bundle_free(v, bundle, PROBE * sigma)

            # The ladder's scale: sigma, or the Barzilai-Borwein step s.s / s.y from
            # the last accepted step s = b - b_prev and the change y of the path's
            # direction at scale sigma (exact for a locally quadratic model: it
            # places the ladder around the step that lands on the minimum), kept
            # within a factor BB_RANGE of sigma (next to a kink y jumps and s.s / s.y
            # is meaningless).
            scale = sigma
            if barzilai_borwein:
                _, _, vx, vy = _path(kind, v, steep, sigma)
                sx = state[i, BEST] - state[i, PREVIOUS]
                sy = state[i, BEST + 1] - state[i, PREVIOUS + 1]
                curvature = sx * (state[i, PREVIOUS + 2] - vx) + sy * (state[i, PREVIOUS + 3] - vy)
                if flags[i, HAS_PREVIOUS] and curvature > 0.0:
                    bb = (sx * sx + sy * sy) / curvature
                    if not math.isfinite(bb):
                        bb = sigma
                    scale = _min(_max(bb, sigma / BB_RANGE), sigma * BB_RANGE)
                state[i, PREVIOUS], state[i, PREVIOUS + 1] = state[i, BEST], state[i, BEST + 1]
                state[i, PREVIOUS + 2], state[i, PREVIOUS + 3] = vx, vy
            state[i, SCALE] = scale

            # A line search on one straight piece of its path (the same dq/ds at both
            # ends of its bracket: a slide along an edge, or a straight gradient
            # line), with b at an end of its bracket and the steepest path from b
            # along the same line, needs no new ladder: the bracket still holds the
            # first valley ahead, the model points find it.
            ladders = True
            if flags[i, BRACKETED]:
                search = _stored_path(state, i)
                if kind == TRIANGLE and not flags[i, FAILS] and not flags[i, SLOW]:
                    at_end, one_piece = False, True
                    ux = uy = 0.0
                    for side in range(2):
                        x, y, dx, dy = _path(kind, v, search,
                                             state[i, LEFT if side == 0 else RIGHT])
                        at_end = at_end or (x == state[i, BEST] and y == state[i, BEST + 1])
                        if side == 0:
                            ux, uy = dx, dy
                        else:
                            one_piece = (abs(ux - dx) + abs(uy - dy)
                                         <= PARALLEL * (abs(ux) + abs(uy) + abs(dx) + abs(dy)))
                    ux, uy = _unit(ux, uy)
                    wx, wy = _unit(dqx, dqy)
                    ladders = not (at_end and one_piece
                                   and abs(ux * wx + uy * wy) > 1.0 - PARALLEL)

            # Candidates: a ladder on each path, ended on a triangle's steepest path
            # by the path's end (the vertex or edge point where the projected ray
            # stops; with dq/ds just before it, so that a slide that still descends
            # there reads as descending), and two model points in the bracket.
            if kind == TRIANGLE:
                end, end_dx, end_dy = _ray_end(v, state[i, BEST], state[i, BEST + 1],
                                               -state[i, GRAD], -state[i, GRAD + 1])
                if end > END_REACH * scale and code != PLANE:
                    end = np.inf
            for k in range(N_RUNGS if ladders else 0):
                s = _min(scale * LADDER[k] if k < N_RUNGS - 1 and code != PLANE else end, end)
                if not math.isfinite(s):
                    break
                plan_path[count], plan_s[count], plan_twin[count] = 0, s, -1
                plan_end[count] = s == end
                count += 1
                if s == end:
                    break
            steep_rungs = count
            flags[i, ENDED] = steep_rungs > 0 and plan_end[steep_rungs - 1]
            for k in range(N_RUNGS - 1 if has_alt and ladders else 0):
                s = scale * LADDER[k]
                plan_path[count], plan_s[count], plan_end[count] = 1, s, False
                plan_twin[count] = k if k < steep_rungs and plan_s[k] == s else -1
                count += 1
            if flags[i, BRACKETED]:
                s_first, s_second = _model_steps(state[i, LEFT], state[i, LEFT + 1],
                                                 state[i, LEFT + 2], state[i, RIGHT],
                                                 state[i, RIGHT + 1], state[i, RIGHT + 2])
                plan_path[count], plan_s[count], plan_twin[count] = 2, s_first, -1
                plan_path[count + 1], plan_s[count + 1], plan_twin[count + 1] = 2, s_second, count
                plan_end[count] = plan_end[count + 1] = False
                count += 2
        if osculating:
            plan_path[count], plan_s[count], plan_twin[count], plan_end[count] = 3, 0.0, -1, False
            count += 1

        # The plan's candidates; columns: steepest rungs from 0, bundle rungs from
        # COLUMN_BUNDLE, model points from COLUMN_MODEL (the model's minimiser: 0), the
        # osculating point COLUMN_OSCULATING.
        start = n
        rung = bundle_rung = model = 0
        for j in range(count):
            which = plan_path[j]
            if which < 0:
                x, y, dx, dy = shape[t, 1], shape[t, 2], 0.0, 0.0
                col = 0
            elif which == 3:
                x, y, dx, dy = model_x, model_y, 0.0, 0.0
                col = COLUMN_OSCULATING
            else:
                x, y, dx, dy = _path(kind, v, steep if which == 0 else
                                     (bundle if which == 1 else search), plan_s[j])
                if plan_end[j]:
                    dx, dy = end_dx, end_dy
                if which == 0:
                    col, rung = rung, rung + 1
                elif which == 1:
                    col, bundle_rung = COLUMN_BUNDLE + bundle_rung, bundle_rung + 1
                else:
                    col, model = COLUMN_MODEL + model, model + 1
            if which < 0 and shared_t == t and shared_source != AT_BEST:
                cand[n, 0], cand[n, 1], cand[n, 2], cand[n, 3], cand[n, 4] = 0.0, x, y, 0.0, 0.0
                cand_i[n, 0], cand_i[n, 1] = 0, shared_source
            else:
                # Candidate n. One at b, at a vertex of the triangle whose value is
                # known, or at the same point and derivative as its twin (the same
                # rung of the other ladder, or the previous rung past the end of a
                # path) reuses that value instead of adding a point.
                twin = start + plan_twin[j] if plan_twin[j] >= 0 else -1
                cand[n, 0], cand[n, 1], cand[n, 2], cand[n, 3], cand[n, 4] = \
                    plan_s[j], x, y, dx, dy
                cand_i[n, 0] = col
                source = u
                if x == state[i, BEST] and y == state[i, BEST + 1]:
                    source = AT_BEST
                else:
                    for k in range(3 if kind == TRIANGLE else 0):
                        if x == v[2 * k] and y == v[2 * k + 1] and not math.isnan(corner[t, k, 0]):
                            source = AT_CORNER - k
                            break
                    if (source == u and twin >= 0 and x == cand[twin, 1] and y == cand[twin, 2]
                            and dx == cand[twin, 3] and dy == cand[twin, 4]):
                        source = cand_i[twin, 1]
                cand_i[n, 1] = source
                if source == u:
                    points[u, 0], points[u, 1] = x, y
                    u += 1
                if which < 0:
                    shared_t, shared_source = t, cand_i[n, 1]
            n += 1
        flags[i, COUNT], flags[i, OFFSET] = n - start, start
    return n, u, kept


@njit(cache=True, error_model="numpy")
def accept(kind: int, tri: np.ndarray, owner: np.ndarray, corner: np.ndarray,
           state: np.ndarray,
           flags: np.ndarray, data: np.ndarray, cand: np.ndarray, cand_i: np.ndarray,
           value: np.ndarray, gradient: np.ndarray, cand_data: np.ndarray, tol: np.ndarray,
           running: np.ndarray, shape: np.ndarray, shape_tol: float) -> tuple[int, int]:
    """Update the starts that proposed candidates (``running``) from the values (U,),
    gradients (U, 2) and data (U, kd) at the evaluated points (see ``descent``'s
    module docstring for the rules). Returns R, the number of starts still running
    (``running[:R]`` on return), and ``bound`` of them for the next round. A start
    that stops at a stationary point (its step shorter than tol[i], m) is dropped
    here rather than next round; one
    that tried its triangle model's minimiser stops there when f has the value the
    model predicts (to ``shape_tol``)."""
    table = np.empty(N_COLUMNS)                         # value per column (inf: none)
    slope = np.empty(N_COLUMNS)
    where = np.empty(N_COLUMNS, dtype=np.int64)         # column -> candidate row
    seen = np.empty((N_COLUMNS + 2, 5))                 # planes: point, value, gradient
    samples = np.empty((2, N_RUNGS + 1, 3))             # per ladder: s, value, slope
    rungs = np.empty(2, dtype=np.int64)
    kept = total = 0
    for i in running:
        count, offset = flags[i, COUNT], flags[i, OFFSET]
        t = owner[i] if kind == TRIANGLE else 0
        d0, scale, phi_old = state[i, D0], state[i, SCALE], state[i, PHI]
        if flags[i, MODEL] == 1:
            # The model's minimiser: taken when lower; the start is done there when
            # f has the value the model predicts (or when it is there already),
            # else the descent goes on.
            flags[i, MODEL] = 2
            src = cand_i[offset, 1]
            keep = src != AT_BEST
            value_m = gx = gy = 0.0
            if src <= AT_CORNER:
                v = AT_CORNER - src
                value_m, gx, gy = corner[t, v, 0], corner[t, v, 1], corner[t, v, 2]
            elif src >= 0:
                value_m, gx, gy = value[src], gradient[src, 0], gradient[src, 1]
            if keep and value_m < phi_old - 4.0 * EPS * _max(1.0, abs(phi_old)):
                state[i, BEST], state[i, BEST + 1] = cand[offset, 1], cand[offset, 2]
                state[i, PHI], state[i, GRAD], state[i, GRAD + 1] = value_m, gx, gy
                for c in range(5):
                    state[i, ALT + c] = state[i, BEST + c]
                data[i, 0], data[i, 1] = gx, gy
                size = 1.0 + abs(cand[offset, 1]) + abs(cand[offset, 2]) + abs(value_m)
                keep = abs(value_m - shape[t, 3]) > shape_tol * size
        else:
            for c in range(N_COLUMNS):
                table[c], slope[c], where[c] = np.inf, 0.0, -1
            rungs[0] = rungs[1] = 0
            for j in range(offset, offset + count):
                c, src = cand_i[j, 0], cand_i[j, 1]
                where[c] = j
                if src == AT_BEST:
                    table[c], gx, gy = phi_old, state[i, GRAD], state[i, GRAD + 1]
                elif src <= AT_CORNER:
                    v = AT_CORNER - src
                    table[c], gx, gy = corner[t, v, 0], corner[t, v, 1], corner[t, v, 2]
                else:
                    table[c], gx, gy = value[src], gradient[src, 0], gradient[src, 1]
                slope[c] = gx * cand[j, 3] + gy * cand[j, 4]
                seen[c, 0], seen[c, 1], seen[c, 2] = cand[j, 1], cand[j, 2], table[c]
                seen[c, 3], seen[c, 4] = gx, gy
                if c < COLUMN_MODEL:
                    rungs[c // N_RUNGS] += 1

            # On each path only the first valley counts (samples up to the first one
            # where phi rises or its slope turns >= 0): the descent stays local, each
            # start finds the minimum of its own basin.
            for ladder in range(2):
                samples[ladder, 0, 0] = 0.0
                samples[ladder, 0, 1], samples[ladder, 0, 2] = phi_old, d0
                rise = rungs[ladder]
                for k in range(1, rungs[ladder] + 1):
                    c = ladder * N_RUNGS + k - 1
                    samples[ladder, k, 0] = cand[where[c], 0]
                    samples[ladder, k, 1] = table[c]
                    samples[ladder, k, 2] = slope[c]
                    if rise == rungs[ladder] and (slope[c] >= 0.0
                                                  or table[c] > samples[ladder, k - 1, 1]):
                        rise = k
                    if k > rise or (k == rise and ladder == 0 and k == rungs[0]
                                    and flags[i, ENDED] and slope[c] >= 0.0):
                        table[c] = np.inf

            win = 0                                     # np.argmin: the first NaN, or
            for c in range(1, N_COLUMNS):               # the first minimum
                if not math.isnan(table[win]) and (table[c] < table[win]
                                                   or math.isnan(table[c])):
                    win = c
            phi_win = table[win]
            rounding = 4.0 * EPS * _max(1.0, abs(phi_old))
            improved = phi_win < phi_old - rounding
            if not improved and kind != TRIANGLE:
                # Near a smooth minimum phi stops changing in double precision long
                # before the point stops moving; there a candidate whose value ties with
                # b's (to rounding) is taken when it halves the stationarity measure.
                tie, tie_win = np.inf, -1
                for c in range(N_COLUMNS):
                    if table[c] <= phi_old + rounding and cand_i[where[c], 1] >= 0:
                        measure = _stationarity(kind, cand_data, cand_i[where[c], 1])
                        if measure < tie:
                            tie, tie_win = measure, c
                if tie_win >= 0 and tie < 0.5 * _stationarity(kind, data, i):
                    win, phi_win, improved = tie_win, table[tie_win], True
            w = where[win]
            moved = _norm(cand[w, 1] - state[i, BEST], cand[w, 2] - state[i, BEST + 1])
            new_sigma = scale

            # (a) The model samples shrink their bracket: one with phi' < 0 and phi <=
            #     phi(s_l) becomes the left end, otherwise the right end (the second only
            #     if it still lies inside).
            has = flags[i, BRACKETED] != 0
            width = state[i, RIGHT] - state[i, LEFT]
            if has:
                for c in range(COLUMN_MODEL, COLUMN_OSCULATING):
                    s = cand[where[c], 0]
                    if state[i, LEFT] < s < state[i, RIGHT]:
                        end = LEFT if slope[c] < 0.0 and table[c] <= state[i, LEFT + 1] else RIGHT
                        state[i, end], state[i, end + 1], state[i, end + 2] = s, table[c], slope[c]
                if improved and COLUMN_MODEL <= win < COLUMN_OSCULATING:
                    new_sigma = _max(moved, 0.25 * scale)
            # A continued line search whose models failed to halve the bracket gets
            # ladders again next round (the bracket holds more than one kink or bend).
            flags[i, SLOW] = rungs[0] == 0 and state[i, RIGHT] - state[i, LEFT] > 0.5 * width

            alone = flags[i, OSCULATING] == 2
            flags[i, OSCULATING] = 1 if improved and win == COLUMN_OSCULATING else 0
            if alone or (improved and win == COLUMN_OSCULATING):
                # The osculating point won (the next round tries the next one alone) or
                # failed alone (the ladders come back): no bracket, the same scale.
                has = False
                new_sigma = scale
            elif improved and win < COLUMN_MODEL:
                # (b) A ladder winner at rung k starts a new line search on its path,
                #     bracketed by its neighbours (k - 1, k) if phi' >= 0 there, else
                #     (k, k + 1); open (no bracket) past the last rung, where the scale
                #     then grows (a long slide along an edge or a ridge).
                ladder = win // N_RUNGS
                k = win - ladder * N_RUNGS + 1
                down = samples[ladder, k, 2] < 0.0
                lk = k if down else k - 1
                rk = _min(k + 1 if down else k, rungs[ladder])
                if ladder == 0:
                    _store_path(state, i, _steep_path(kind, state, data, i))
                else:
                    _store_path(state, i, _bundle_path(state, i))
                for c in range(3):
                    state[i, LEFT + c] = samples[ladder, lk, c]
                    state[i, RIGHT + c] = samples[ladder, rk, c]
                open_end = down and k == rungs[ladder]
                has = not open_end
                new_sigma = samples[ladder, k, 0] * (LADDER[-1] if open_end else 1.0)
            elif not improved and rungs[0] == 0:
                # (c) No decrease in a continued line search: its bracket, shrunk by the
                #     model samples, stands; the next round brings ladders back.
                new_sigma = scale / SHRINK
            elif not improved:
                # (d) No decrease: search finely around b on the steepest path next round.
                _store_path(state, i, _steep_path(kind, state, data, i))
                for c in range(3):
                    state[i, LEFT + c] = samples[0, 0, c]
                    state[i, RIGHT + c] = samples[0, 1, c]
                has = d0 < 0.0
                new_sigma = scale / SHRINK

            # The next second plane: among the planes seen near the new best (this
            # round's samples, the old best and the old second plane, within the step
            # scale) whose gradient differs from the new best's, the one most active
            # there, i.e. with the smallest linearisation error |f(b) - l_i(b)| (the
            # bundle methods' rule). A different gradient close by reveals a kink (a
            # ridge of the medial axis, or a minimum just passed); the bundle path then
            # follows the ridge l_1 = l_2 instead of zigzagging across it. Without a
            # decrease b's own plane is carried to the best candidate's point.
            new_x, new_y = cand[w, 1], cand[w, 2]
            if improved:
                new_phi, new_gx, new_gy = phi_win, seen[win, 3], seen[win, 4]
            else:
                new_phi, new_gx, new_gy = phi_old, state[i, GRAD], state[i, GRAD + 1]
            for c in range(5):
                seen[N_COLUMNS, c] = state[i, BEST + c]
                seen[N_COLUMNS + 1, c] = state[i, ALT + c]
            ux, uy = _unit(new_gx, new_gy)
            reach2 = _max(scale, new_sigma) ** 2
            pick, error = -1, np.inf
            for c in range(N_COLUMNS + 2):
                if c < N_COLUMNS and not math.isfinite(table[c]):
                    continue
                gx, gy = seen[c, 3], seen[c, 4]
                along = gx * ux + gy * uy               # cosine >= 1 - KINK: the same plane
                if along > 0.0 and along * along >= (1.0 - KINK) ** 2 * (gx * gx + gy * gy):
                    continue
                if (seen[c, 0] - new_x) ** 2 + (seen[c, 1] - new_y) ** 2 > reach2:
                    continue
                e = abs(new_phi - seen[c, 2] - gx * (new_x - seen[c, 0])
                        - gy * (new_y - seen[c, 1]))
                if e < error:
                    pick, error = c, e
            if pick >= 0:
                for c in range(5):
                    state[i, ALT + c] = seen[pick, c]
            else:
                state[i, ALT], state[i, ALT + 1], state[i, ALT + 2] = new_x, new_y, new_phi
                state[i, ALT + 3], state[i, ALT + 4] = new_gx, new_gy

            # Commit.
            if improved:
                if kind != TRIANGLE:
                    state[i, PRIOR], state[i, PRIOR + 1] = state[i, BEST], state[i, BEST + 1]
                    for c in range(4):
                        state[i, PRIOR + 2 + c] = data[i, 2 + c]
                    flags[i, HAS_PRIOR] = 1
                state[i, BEST], state[i, BEST + 1], state[i, PHI] = new_x, new_y, phi_win
                state[i, GRAD], state[i, GRAD + 1] = new_gx, new_gy
                src = cand_i[w, 1]
                if src >= 0:
                    for c in range(data.shape[1]):
                        data[i, c] = cand_data[src, c]
                elif src <= AT_CORNER:
                    data[i, 0], data[i, 1] = new_gx, new_gy
            flags[i, BRACKETED] = has and state[i, RIGHT] > state[i, LEFT]
            state[i, SIGMA] = _max(new_sigma, TINY)
            if improved:
                flags[i, FAILS] = 0
            elif not alone:
                flags[i, FAILS] += 1
            flags[i, HAS_PREVIOUS] = improved
            keep = flags[i, FAILS] < 2 and not (improved and moved < tol[i])
        if keep:
            steep = _steep_path(kind, state, data, i)
            if _moving(kind, _vertices(tri, t), steep, state[i, SIGMA])[0]:
                running[kept] = i
                kept += 1
                total += _most_candidates(kind, owner, shape, state, flags, i)
    return kept, total


# ``propose`` and ``accept`` for the compiled descent (``_compiled_descent._rounds``): one
# machine code of each per process (``sdfphys._shared_kernel``), not a copy built into
# every kernel that runs the rounds. Their one signature there:
propose_shared = shared(
    propose, (types.int64, F3, I1, F3, F2, F2, I2, F2, types.boolean, I1, F2, I2, F2),
    "sdfphys_collide_descent_propose", types.UniTuple(types.int64, 3))
accept_shared = shared(
    accept, (types.int64, F3, I1, F3, F2, I2, F2, F2, I2, F1, F2, F2, F1, I1, F2,
             types.float64),
    "sdfphys_collide_descent_accept", types.UniTuple(types.int64, 2))
