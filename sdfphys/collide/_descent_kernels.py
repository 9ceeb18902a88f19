"""Compiled kernels of ``descent``: one round of the line-search descent, for every start.

``descent._descend`` runs rounds of: ``propose`` (numba) writes the candidate
points of every running start into one buffer; ONE problem evaluation (numpy,
the fields are Python objects) gives their values and gradients; ``accept``
(numba) updates every start's best point, line-search bracket, second bundle
plane and step scale. The algorithm is described in ``descent``'s module
docstring; the derivations of its pieces sit above the functions below.

Kinds of problem (``kind``): ``TRIANGLE`` (f restricted to a triangle, paths
projected onto the start's triangle) and ``PAIR`` (a balance of two fields over
the plane, see ``descent._PairProblem``; data columns f_a, f_b, grad f_a, grad f_b).

State of P starts, updated in place (columns named by the constants below):

- ``state`` (P, N_STATE) float64: best point b (m), its objective and gradient,
  the second plane of the bundle (point, value, gradient), the path of the line
  search in progress (``PATH``: 8 parameters, see ``_proximal_step``) and its
  bracket ends (s, value, slope), the step scale sigma (path units), the
  Barzilai-Borwein memory (last b, last direction), and per round the slope of
  the steepest path at s = 0 and the ladder's scale.
- ``flags`` (P, N_FLAGS) int64: bracketed, rounds without decrease in a row,
  rounds run, BB memory usable, per round the number and offset of the start's
  candidates and whether its steepest ladder ended at the path's end, whether
  the minimiser of its triangle's model (cone or cuts) was tried, and whether
  its last continued line search shrank its bracket less than half.
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
from numba import njit

TRIANGLE = 0
PAIR = 1

#: Step multipliers of the ladder on a path from the best point, ascending.
LADDER = np.array([1.0 / 16.0, 0.25, 1.0, 4.0])
#: Rungs per ladder: the geometric ones and, on a triangle's steepest path, its end.
N_RUNGS = len(LADDER) + 1
#: Candidate columns: steepest ladder | bundle ladder | two model points.
COLUMN_BUNDLE = N_RUNGS
COLUMN_MODEL = 2 * N_RUNGS
N_COLUMNS = 2 * N_RUNGS + 2
#: The end of a triangle's steepest path is a rung when within this many scales.
END_REACH = 16.0
#: Two unit directions with |cosine| above 1 - PARALLEL are along one line.
PARALLEL = 1e-12
#: sigma is divided by this after a round without decrease.
SHRINK = 64.0
#: Model points stay this fraction of the bracket away from its ends.
GUARD = 1e-3
#: The path's slope at its start is read at s = PROBE * sigma (past any corner at s = 0).
PROBE = 1e-9
#: A projected gradient shorter than this (unit gradients) means a stationary point.
STATIONARY = 1e-12
#: The Barzilai-Borwein scale stays within this factor of the last step's scale.
BB_RANGE = 16.0
#: Two unit gradients with cosine below 1 - KINK are taken as the two sides of a kink.
KINK = 1e-3
#: Weight k of the imbalance in the field-field objective (f_a + f_b) / 2 + k |f_a - f_b|.
IMBALANCE = 0.25
EPS = np.finfo(np.float64).eps
TINY = 1e-300

# Columns of ``state``.
BEST = 0          # b (2)
PHI = 2           # objective at b
GRAD = 3          # its gradient (2)
ALT = 5           # second plane: point (2), value, gradient (2)
PATH = 10         # path of the line search in progress (8)
LEFT = 18         # its bracket: s, value, slope at the left end
RIGHT = 21        # ... and at the right end
SIGMA = 24        # step scale
PREVIOUS = 25     # Barzilai-Borwein memory: last b (2), last direction (2)
D0 = 29           # this round's slope of the steepest path at s = 0
SCALE = 30        # this round's ladder scale
N_STATE = 31
# Columns of ``flags``.
BRACKETED = 0
FAILS = 1
ROUNDS = 2
HAS_PREVIOUS = 3
COUNT = 4
OFFSET = 5
ENDED = 6
MODEL = 7         # a model's minimiser: 0 not tried, 1 tried this round, 2 tried
SLOW = 8          # the last round continued a line search that shrank less than half
N_FLAGS = 9
# What f is over a triangle (``triangle_known``).
GENERAL = 0
PLANE = 1
CONE = 2
CUTS = 3
# Sources of candidates that need no evaluation.
AT_BEST = -1
AT_CORNER = -2


# --------------------------------------------------------------------------------------
# Paths
# --------------------------------------------------------------------------------------

# The proximal min-max path of two linear models l_i(b + delta) = f_i + g_i . delta:
# delta(tau) minimises max(l_1, l_2) + |delta|^2 / (2 tau), tau >= 0. Dual:
# delta = -tau (lam g1 + (1 - lam) g2) with lam in [0, 1] maximising
# lam f1 + (1 - lam) f2 - tau |lam g1 + (1 - lam) g2|^2 / 2, i.e. with w = g1 - g2,
# D = f1 - f2:
#
#     lam = clamp((D / tau - g2 . w) / |w|^2, 0, 1).
#
# For small tau lam is clamped and the path is steepest descent of the larger
# model; from tau* = |D| / (g_larger . w) on it is the balancing correction
# -(D / |w|^2) w plus tau times -(g2 - (g2 . w / |w|^2) w), the min-norm element of
# the models' gradient hull, which runs along the line l_1 = l_2 (a ridge, or the
# contact between two fields). Where w = 0 the larger model's (first on a tie)
# gradient is followed. With the same plane twice it is plain steepest descent.

# Scalar helpers use math, not numpy's ufuncs (np.isfinite, np.sign on a float):
# the same values, but a ufunc on a scalar compiles numba's ufunc machinery,
# seconds at a cold start.

@njit(cache=True, error_model="numpy")
def _max(a, b):
    """The builtin max(a, b) (b if b > a else a: the first of a tie or of a NaN),
    inlined: numba calls its overload of max as a function."""
    return b if b > a else a  # noqa: FURB136 (max() would be a call)


@njit(cache=True, error_model="numpy")
def _min(a, b):
    """The builtin min(a, b) (b if b < a else a), inlined."""
    return b if b < a else a  # noqa: FURB136 (min() would be a call)


@njit(cache=True, error_model="numpy")
def _sign(x: float) -> float:
    """np.sign of a float: -1, 0 or +1 (NaN stays NaN)."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x if math.isnan(x) else 0.0


@njit(cache=True, error_model="numpy")
def _proximal_step(f1: float, f2: float, g1x: float, g1y: float, g2x: float, g2y: float,
                   tau: float) -> tuple[float, float, float, float]:
    """delta(tau) and d delta / d tau (m, m per path unit) of the proximal min-max path."""
    wx, wy = g1x - g2x, g1y - g2y
    ww = wx * wx + wy * wy
    gap = f1 - f2
    g2w = g2x * wx + g2y * wy
    free = False
    if ww <= TINY:
        lam = 1.0 if gap >= 0.0 else 0.0
        ww = 1.0
    else:
        lam = ((gap / tau if tau > 0.0 else _sign(gap) * np.inf) - g2w) / ww
        free = lam > 0.0 and lam < 1.0
        lam = _min(_max(lam, 0.0), 1.0)
    dx = lam * g1x + (1.0 - lam) * g2x
    dy = lam * g1y + (1.0 - lam) * g2y
    if free:
        return -tau * dx, -tau * dy, -(g2x - g2w / ww * wx), -(g2y - g2w / ww * wy)
    return -tau * dx, -tau * dy, -dx, -dy


# Projection onto a triangle and its derivative (Bertsekas' projection arc).
# D Proj_T(x) u is u inside, the component of u along the edge when the closest
# point is inside an edge, and 0 at a vertex. The closest point is found by
# Voronoi regions (Ericson, "Real-Time Collision Detection", 5.1.5), with
# ab = b - a, ac = c - a and the dot products d1 = ab.ap, d2 = ac.ap (p - a),
# d3 = ab.bp, d4 = ac.bp, d5 = ab.cp, d6 = ac.cp: vertex a when d1, d2 <= 0,
# b when d3 >= 0 and d4 <= d3, c when d6 >= 0 and d5 <= d6; edge ab at
# t = d1 / (d1 - d3) when vc = d1 d4 - d3 d2 <= 0, d1 >= 0, d3 <= 0; edge ac at
# t = d2 / (d2 - d6) when vb = d5 d2 - d1 d6 <= 0, d2 >= 0, d6 <= 0; edge bc at
# t = (d4 - d3) / ((d4 - d3) + (d5 - d6)) when va = d3 d6 - d5 d4 <= 0 and both
# differences >= 0; else inside (in 2D the face region is the triangle). Vertices
# are returned exactly. A degenerate (collinear) triangle has no inside and is
# searched as its three edges (the closest clamped foot, the first on ties).

@njit(cache=True, error_model="numpy")
def _on_edge(px: float, py: float, ex: float, ey: float, t: float, ux: float, uy: float
             ) -> tuple[float, float, float, float]:
    """p + t e and the component of u along e."""
    along = (ux * ex + uy * ey) / (ex * ex + ey * ey)
    return px + t * ex, py + t * ey, along * ex, along * ey


@njit(cache=True, error_model="numpy")
def _project_edges(v: tuple, x: float, y: float, ux: float, uy: float
                   ) -> tuple[float, float, float, float]:
    """``project`` onto the three edges of triangle v (a degenerate triangle)."""
    best = np.inf
    qx = qy = dqx = dqy = 0.0
    for k in range(3):
        px, py = v[2 * k], v[2 * k + 1]
        nx, ny = v[2 * ((k + 1) % 3)], v[2 * ((k + 1) % 3) + 1]
        ex, ey = nx - px, ny - py
        along = ((x - px) * ex + (y - py) * ey) / _max(ex * ex + ey * ey, TINY)
        if along <= 0.0:
            fx, fy, fdx, fdy = px, py, 0.0, 0.0
        elif along >= 1.0:
            fx, fy, fdx, fdy = nx, ny, 0.0, 0.0
        else:
            fx, fy, fdx, fdy = _on_edge(px, py, ex, ey, along, ux, uy)
        d2 = (x - fx) * (x - fx) + (y - fy) * (y - fy)
        if d2 < best:
            best, qx, qy, dqx, dqy = d2, fx, fy, fdx, fdy
    return qx, qy, dqx, dqy


@njit(cache=True, error_model="numpy")
def _vertices(tri: np.ndarray, t: int) -> tuple[float, float, float, float, float, float]:
    """Triangle tri[t] (tri: (T, 3, 2)) as the tuple (ax, ay, bx, by, cx, cy).

    The hot helpers below take triangles and paths as tuples of floats, not as
    arrays: an array passed to an inlined function is a new reference, whose
    atomic count updates cost more than the arithmetic of a path point."""
    return tri[t, 0, 0], tri[t, 0, 1], tri[t, 1, 0], tri[t, 1, 1], tri[t, 2, 0], tri[t, 2, 1]


@njit(cache=True, error_model="numpy")
def project(v: tuple, x: float, y: float, ux: float, uy: float
            ) -> tuple[float, float, float, float]:
    """Closest point q of triangle v (``_vertices``) to (x, y) and dq = D Proj_T(x) u."""
    ax, ay, bx, by, cx, cy = v
    abx, aby, acx, acy = bx - ax, by - ay, cx - ax, cy - ay
    if abx * acy - aby * acx == 0.0:
        return _project_edges(v, x, y, ux, uy)
    d1 = abx * (x - ax) + aby * (y - ay)
    d2 = acx * (x - ax) + acy * (y - ay)
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, 0.0, 0.0
    d3 = abx * (x - bx) + aby * (y - by)
    d4 = acx * (x - bx) + acy * (y - by)
    if d3 >= 0.0 and d4 <= d3:
        return bx, by, 0.0, 0.0
    if d1 * d4 - d3 * d2 <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        return _on_edge(ax, ay, abx, aby, d1 / (d1 - d3), ux, uy)
    d5 = abx * (x - cx) + aby * (y - cy)
    d6 = acx * (x - cx) + acy * (y - cy)
    if d6 >= 0.0 and d5 <= d6:
        return cx, cy, 0.0, 0.0
    if d5 * d2 - d1 * d6 <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        return _on_edge(ax, ay, acx, acy, d2 / (d2 - d6), ux, uy)
    if d3 * d6 - d5 * d4 <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        return _on_edge(bx, by, cx - bx, cy - by, (d4 - d3) / ((d4 - d3) + (d5 - d6)), ux, uy)
    return x, y, ux, uy


# Where the projected ray Proj_T(b + s u) stops. For large s, b + s u lies in the
# normal cone of the support vertex v (the vertex maximising u . v): the wedge
# {x : (x - v) . (w - v) <= 0 for both neighbours w}, where the projection is v.
# The ray enters the half-plane of neighbour w at s_w = (b - v) . e / (-u . e),
# e = w - v (u . e <= 0 at the support vertex), and stays in it; the end is the
# largest of the two. Just before it the ray is on w's side of the last one
# entered, so the path arrives sliding along the edge (w, v): dq/ds is the
# component of u along that edge. When u is normal to the edge (v, w) (u . e = 0)
# the ray ends in that edge's slab instead, once it crosses the edge's line, at
# s = -(b - v) . u / |u|^2, arriving with dq/ds = u.

@njit(cache=True, error_model="numpy")
def _ray_end(v: tuple, bx: float, by: float, ux: float, uy: float
             ) -> tuple[float, float, float]:
    """Step s >= 0 from which Proj_T(b + s u) no longer moves (triangle v), and
    dq/ds just before it."""
    top = 0
    for k in range(1, 3):
        if ux * v[2 * k] + uy * v[2 * k + 1] > ux * v[2 * top] + uy * v[2 * top + 1]:
            top = k
    vx, vy = v[2 * top], v[2 * top + 1]
    end, dx, dy = 0.0, 0.0, 0.0
    for k in range(1, 3):
        w = (top + k) % 3
        ex, ey = v[2 * w] - vx, v[2 * w + 1] - vy
        be = (bx - vx) * ex + (by - vy) * ey
        if be <= 0.0:
            continue
        ue = ux * ex + uy * ey
        if ue < 0.0:
            if be / -ue > end:
                slide = ue / _max(ex * ex + ey * ey, TINY)
                end, dx, dy = be / -ue, slide * ex, slide * ey
        else:
            cross = -((bx - vx) * ux + (by - vy) * uy) / _max(ux * ux + uy * uy, TINY)
            if cross > end:
                end, dx, dy = cross, ux, uy
    return end, dx, dy


@njit(cache=True, error_model="numpy")
def _path(kind: int, v: tuple, p: tuple, s: float) -> tuple[float, float, float, float]:
    """Point and dq/ds at step s of the path with parameters p (8 floats: origin,
    the two models' values and gradients), projected onto triangle v (TRIANGLE)."""
    dx, dy, ddx, ddy = _proximal_step(p[2], p[3], p[4], p[5], p[6], p[7], s)
    if kind == TRIANGLE:
        return project(v, p[0] + dx, p[1] + dy, ddx, ddy)
    return p[0] + dx, p[1] + dy, ddx, ddy


@njit(cache=True, error_model="numpy")
def _norm(x: float, y: float) -> float:
    return math.sqrt(x * x + y * y)


@njit(cache=True, error_model="numpy")
def _unit(x: float, y: float) -> tuple[float, float]:
    norm = _norm(x, y)
    if norm > TINY:
        return x / norm, y / norm
    return 0.0, 0.0


@njit(cache=True, error_model="numpy")
def _bundle_free(v: tuple, p: tuple, probe: float) -> bool:
    """The bundle path p (8 parameters) enters triangle v: its first direction (-g1) or its ridge
    direction (-m, the min-norm element of the two gradients' hull) is not cut by
    the projection at b.

    Where both are, b is on an edge with the kink leading out of the triangle: the
    kink is then a 1D V along the edge, which the steepest path's bracket resolves
    exactly, and a projected bundle path would only add breakpoints.
    """
    g1x, g1y, g2x, g2y = p[4], p[5], p[6], p[7]
    wx, wy = g1x - g2x, g1y - g2y
    ww = _max(wx * wx + wy * wy, TINY)
    g2w = (g2x * wx + g2y * wy) / ww
    for which in range(2):
        if which == 0:
            ux, uy = _unit(-g1x, -g1y)
        else:
            ux, uy = _unit(-(g2x - g2w * wx), -(g2y - g2w * wy))
        _, _, dqx, dqy = project(v, p[0] + probe * ux, p[1] + probe * uy, ux, uy)
        if (dqx - ux) ** 2 + (dqy - uy) ** 2 <= STATIONARY * STATIONARY:
            return True
    return False


@njit(cache=True, error_model="numpy")
def _steep_path(kind: int, state: np.ndarray, data: np.ndarray, i: int) -> tuple:
    """The steepest path from b (8 floats, see ``_path``): the linearisation at b
    twice (TRIANGLE), or the two planes whose max is phi (PAIR: phi = max(A, B)
    with A, B = (1/2 +- k) f_a + (1/2 -+ k) f_b, k = IMBALANCE)."""
    if kind == TRIANGLE:
        phi, gx, gy = state[i, PHI], state[i, GRAD], state[i, GRAD + 1]
        return state[i, BEST], state[i, BEST + 1], phi, phi, gx, gy, gx, gy
    high, low = 0.5 + IMBALANCE, 0.5 - IMBALANCE
    return (state[i, BEST], state[i, BEST + 1],
            high * data[i, 0] + low * data[i, 1], low * data[i, 0] + high * data[i, 1],
            high * data[i, 2] + low * data[i, 4], high * data[i, 3] + low * data[i, 5],
            low * data[i, 2] + high * data[i, 4], low * data[i, 3] + high * data[i, 5])


@njit(cache=True, error_model="numpy")
def _bundle_path(state: np.ndarray, i: int) -> tuple:
    """The bundle path from b (8 floats): b's linearisation and the second plane,
    capped at phi(b)."""
    cap = _min(state[i, ALT + 2] + state[i, ALT + 3] * (state[i, BEST] - state[i, ALT])
              + state[i, ALT + 4] * (state[i, BEST + 1] - state[i, ALT + 1]), state[i, PHI])
    return (state[i, BEST], state[i, BEST + 1], state[i, PHI], cap, state[i, GRAD],
            state[i, GRAD + 1], state[i, ALT + 3], state[i, ALT + 4])


@njit(cache=True, error_model="numpy")
def _store_path(state: np.ndarray, i: int, p: tuple) -> None:
    """Keep path p (8 floats) as start i's line-search path (``PATH`` columns)."""
    state[i, PATH], state[i, PATH + 1], state[i, PATH + 2], state[i, PATH + 3] = \
        p[0], p[1], p[2], p[3]
    state[i, PATH + 4], state[i, PATH + 5], state[i, PATH + 6], state[i, PATH + 7] = \
        p[4], p[5], p[6], p[7]


@njit(cache=True, error_model="numpy")
def _stored_path(state: np.ndarray, i: int) -> tuple:
    """Start i's line-search path (8 floats)."""
    return (state[i, PATH], state[i, PATH + 1], state[i, PATH + 2], state[i, PATH + 3],
            state[i, PATH + 4], state[i, PATH + 5], state[i, PATH + 6], state[i, PATH + 7])


@njit(cache=True, error_model="numpy")
def _stationarity(kind: int, data: np.ndarray, i: int) -> float:
    """PAIR: |f_a - f_b| plus the length of the min-norm element of the gradients'
    hull at data[i]; both vanish at a balanced minimum (antiparallel gradients),
    where the normal is exact. Breaks ties of phi at rounding level. TRIANGLE: 0
    (f itself is the answer)."""
    if kind == TRIANGLE:
        return 0.0
    wx, wy = data[i, 2] - data[i, 4], data[i, 3] - data[i, 5]
    mx, my = 0.5 * (data[i, 2] + data[i, 4]), 0.5 * (data[i, 3] + data[i, 5])
    ww = _max(wx * wx + wy * wy, TINY)
    c = (mx * wx + my * wy) / ww
    return abs(data[i, 0] - data[i, 1]) + _norm(mx - c * wx, my - c * wy)


@njit(cache=True, error_model="numpy")
def stationarity(kind: int, data: np.ndarray) -> np.ndarray:
    """``_stationarity`` of every row of data (N, kd): (N,)."""
    out = np.empty(len(data))
    for i in range(len(data)):
        out[i] = _stationarity(kind, data, i)
    return out


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
    """Whether the steepest path ``steep`` leaves b (a projected gradient that does
    not vanish), and its dq/ds there (read at s = PROBE sigma, past any corner)."""
    _, _, dqx, dqy = _path(kind, v, steep, PROBE * sigma)
    return _norm(dqx, dqy) > STATIONARY, dqx, dqy


@njit(cache=True, error_model="numpy")
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
    return total


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
    tries the model's minimiser first. Stops the starts whose projected gradient
    vanishes; writes the per-round columns of ``state`` and ``flags`` and the
    candidates (rows 0..C-1 of ``cand``, ``cand_i``).
    """
    # Paths of a round (rows: steepest, bundle, the line search's) and the plan of
    # a start's candidates: path (-1: the model's minimiser), step, column,
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
        if code >= CONE and flags[i, MODEL] == 0:
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

        # The plan's candidates; columns: steepest rungs from 0, bundle rungs from
        # COLUMN_BUNDLE, model points from COLUMN_MODEL (the model's minimiser: 0).
        start = n
        rung = bundle_rung = model = 0
        for j in range(count):
            which = plan_path[j]
            if which < 0:
                x, y, dx, dy = shape[t, 1], shape[t, 2], 0.0, 0.0
                col = 0
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
           value: np.ndarray, gradient: np.ndarray, cand_data: np.ndarray, tol: float,
           running: np.ndarray, shape: np.ndarray, shape_tol: float) -> tuple[int, int]:
    """Update the starts that proposed candidates (``running``) from the values (U,),
    gradients (U, 2) and data (U, kd) at the evaluated points (see ``descent``'s
    module docstring for the rules). Returns R, the number of starts still running
    (``running[:R]`` on return), and ``bound`` of them for the next round. A start
    that stops at a stationary point is dropped here rather than next round; one
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
                for c in range(COLUMN_MODEL, N_COLUMNS):
                    s = cand[where[c], 0]
                    if state[i, LEFT] < s < state[i, RIGHT]:
                        end = LEFT if slope[c] < 0.0 and table[c] <= state[i, LEFT + 1] else RIGHT
                        state[i, end], state[i, end + 1], state[i, end + 2] = s, table[c], slope[c]
                if improved and win >= COLUMN_MODEL:
                    new_sigma = _max(moved, 0.25 * scale)
            # A continued line search whose models failed to halve the bracket gets
            # ladders again next round (the bracket holds more than one kink or bend).
            flags[i, SLOW] = rungs[0] == 0 and state[i, RIGHT] - state[i, LEFT] > 0.5 * width

            if improved and win < COLUMN_MODEL:
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
            flags[i, FAILS] = 0 if improved else flags[i, FAILS] + 1
            flags[i, HAS_PREVIOUS] = improved
            keep = flags[i, FAILS] < 2 and not (improved and moved < tol)
        if keep:
            steep = _steep_path(kind, state, data, i)
            if _moving(kind, _vertices(tri, t), steep, state[i, SIGMA])[0]:
                running[kept] = i
                kept += 1
                total += _most_candidates(kind, owner, shape, state, flags, i)
    return kept, total


# --------------------------------------------------------------------------------------
# Set-up
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def triangle_starts(tri: np.ndarray, weights: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Starts of triangles tri (T, 3, 2) at barycentric weights (K, 3).

    Returns points (T K, 2) (a start with weight 1 on a vertex is that vertex
    exactly), owner (T K,), sigma (T K,): the triangle's longest edge (the first
    ladder's scale, at least TINY), and at_vertex (T, 3): the start placed at each
    vertex, -1 if none.
    """
    n_tri, n_start = len(tri), len(weights)
    points = np.empty((n_tri * n_start, 2))
    owner = np.empty(n_tri * n_start, dtype=np.int64)
    sigma = np.empty(n_tri * n_start)
    at_vertex = np.full((n_tri, 3), -1, dtype=np.int64)
    for t in range(n_tri):
        longest = 0.0
        for v in range(3):
            w = (v + 1) % 3
            longest = _max(longest, _norm(tri[t, w, 0] - tri[t, v, 0], tri[t, w, 1] - tri[t, v, 1]))
        for k in range(n_start):
            i = t * n_start + k
            owner[i], sigma[i] = t, _max(longest, TINY)
            points[i, 0] = points[i, 1] = 0.0
            for v in range(3):
                corner = (weights[k, v] == 1.0 and weights[k, (v + 1) % 3] == 0.0
                          and weights[k, (v + 2) % 3] == 0.0)
                if corner and at_vertex[t, v] < 0:
                    at_vertex[t, v] = i
                points[i, 0] += weights[k, v] * tri[t, v, 0]
                points[i, 1] += weights[k, v] * tri[t, v, 1]
    return points, owner, sigma, at_vertex


# What the starts of a triangle tell of f over it. With K >= 3 starts spanning
# the triangle, x_k, f_k, g_k:
#
# - a plane when all g_k are equal and f_k = f_0 + g_0 . (x_k - x_0) to rounding:
#   f is then linear over the triangle (all samples in one face's region of a
#   polygon, exact where that region is convex);
# - a cone when all gradient lines meet in one point c (f = |x - c| + const: a
#   circle's field, a polygon's field near a corner, outside): c minimises
#   sum_k |(I - g_k g_k^T)(c - x_k)|^2, i.e. solves
#   sum_k (I - g_k g_k^T) c = sum_k (I - g_k g_k^T) x_k, and is accepted when
#   every g_k is the unit vector (x_k - c) / |x_k - c| and every f_k - |x_k - c|
#   is the same, to ``tol``. Over the triangle f is then lowest at the point
#   closest to c, Proj_T(c): the one minimum of a convex function on a convex set;
# - else, for a field known to be convex (``convex``), cuts: the starts' tangent
#   planes l_k(x) = f_k + g_k . (x - x_k) are then lower bounds of f, and so is
#   their maximum m(x) = max_k l_k(x) (Kelley's cutting-plane model). Its minimum
#   over the triangle is at p* (a linear programme, solved by enumerating the
#   candidates: the vertices, where the lines l_j = l_k cross the edges, and where
#   three planes meet inside), and f(p*) = m(p*) certifies p* as the minimum of f
#   over the triangle: m(p*) <= min f <= f(p*). That is exact where f is the max
#   of planes (a convex polygon's interior near its medial axis); a curved field
#   fails the check at p* and descends. (Without convexity tangent planes may lie
#   above f, in concave pieces or past the end of a polygon's edge, and the
#   check proves nothing.)

@njit(cache=True, error_model="numpy")
def _model_value(planes: np.ndarray, m: int, x: float, y: float) -> float:
    """max of the planes (m, 3) (value at the origin, gradient) at (x, y)."""
    top = -np.inf
    for j in range(m):
        top = _max(top, planes[j, 0] + planes[j, 1] * x + planes[j, 2] * y)
    return top


@njit(cache=True, error_model="numpy")
def _cuts(tri: np.ndarray, t: int, points: np.ndarray, phi: np.ndarray, grad: np.ndarray,
          o: int, n_start: int, tol: float, shape: np.ndarray) -> bool:
    """The cutting-plane model of triangle t from starts o..o+n_start-1 (see above).

    Returns False when the samples contradict convexity (a sample below another's
    tangent plane: rounding, or a field that is not convex after all); else
    writes the model's minimiser over the triangle and its value to shape[t, 1:4].
    """
    planes = np.empty((n_start, 3))
    m = 0
    for k in range(n_start):
        i = o + k
        a = phi[i] - grad[i, 0] * points[i, 0] - grad[i, 1] * points[i, 1]
        same = False
        for j in range(m):
            same = same or (planes[j, 1] == grad[i, 0] and planes[j, 2] == grad[i, 1]
                            and abs(planes[j, 0] - a) <= tol)
        if not same:
            planes[m, 0], planes[m, 1], planes[m, 2] = a, grad[i, 0], grad[i, 1]
            m += 1
    for k in range(n_start):
        i = o + k
        if _model_value(planes, m, points[i, 0], points[i, 1]) > phi[i] + tol:
            return False
    best, bx, by = np.inf, 0.0, 0.0
    for v in range(3):
        value = _model_value(planes, m, tri[t, v, 0], tri[t, v, 1])
        if value < best:
            best, bx, by = value, tri[t, v, 0], tri[t, v, 1]
    for j in range(m):
        for k in range(j + 1, m):
            da, dgx, dgy = planes[j, 0] - planes[k, 0], planes[j, 1] - planes[k, 1], \
                planes[j, 2] - planes[k, 2]
            for v in range(3):
                px, py = tri[t, v, 0], tri[t, v, 1]
                ex, ey = tri[t, (v + 1) % 3, 0] - px, tri[t, (v + 1) % 3, 1] - py
                rate = dgx * ex + dgy * ey
                if rate == 0.0:
                    continue
                along = -(da + dgx * px + dgy * py) / rate
                if 0.0 < along < 1.0:
                    x, y = px + along * ex, py + along * ey
                    value = _model_value(planes, m, x, y)
                    if value < best:
                        best, bx, by = value, x, y
            for q in range(k + 1, m):
                ex, ey = planes[j, 1] - planes[q, 1], planes[j, 2] - planes[q, 2]
                det = dgx * ey - dgy * ex
                if det == 0.0:
                    continue
                eb = planes[q, 0] - planes[j, 0]
                x, y = (-da * ey - eb * dgy) / det, (dgx * eb + ex * da) / det
                qx, qy, _, _ = project(_vertices(tri, t), x, y, 0.0, 0.0)
                if qx == x and qy == y:
                    value = _model_value(planes, m, x, y)
                    if value < best:
                        best, bx, by = value, x, y
    shape[t, 1], shape[t, 2], shape[t, 3] = bx, by, best
    return True


@njit(cache=True, error_model="numpy")
def triangle_known(tri: np.ndarray, at_vertex: np.ndarray, points: np.ndarray,
                   phi: np.ndarray, grad: np.ndarray, n_start: int, spanning: bool,
                   convex: bool, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """What the starts (P = T K, in triangle order) tell of each triangle tri (T, 3, 2).

    Returns corner (T, 3, 3): value and gradient at each vertex, NaN where no
    start is there; shape (T, 4): code (GENERAL, PLANE, CONE or CUTS) and, for a
    plane, its gradient; for a cone or cuts, the point of the triangle where f is
    lowest and the value f should have there.
    """
    n_tri = len(at_vertex)
    corner = np.full((n_tri, 3, 3), np.nan)
    shape = np.zeros((n_tri, 4))
    for t in range(n_tri):
        for v in range(3):
            i = at_vertex[t, v]
            if i >= 0:
                corner[t, v, 0], corner[t, v, 1], corner[t, v, 2] = phi[i], grad[i, 0], grad[i, 1]
        if not spanning:
            continue
        o = t * n_start
        size = 1.0 + abs(points[o, 0]) + abs(points[o, 1]) + abs(phi[o])
        plane = True
        for k in range(1, n_start):
            i = o + k
            size = _max(size, 1.0 + abs(points[o, 0]) + abs(points[o, 1]) + abs(phi[o])
                       + abs(points[i, 0] - points[o, 0]) + abs(points[i, 1] - points[o, 1]))
            plane = plane and grad[i, 0] == grad[o, 0] and grad[i, 1] == grad[o, 1]
        for k in range(1, n_start):
            i = o + k
            linear = phi[o] + grad[o, 0] * (points[i, 0] - points[o, 0]) \
                + grad[o, 1] * (points[i, 1] - points[o, 1])
            plane = plane and abs(phi[i] - linear) <= tol * size
        if plane:
            shape[t, 0], shape[t, 1], shape[t, 2] = PLANE, grad[o, 0], grad[o, 1]
            continue
        a00 = a01 = a11 = b0 = b1 = 0.0
        for k in range(n_start):
            i = o + k
            gx, gy = grad[i, 0], grad[i, 1]
            m00, m01, m11 = 1.0 - gx * gx, -gx * gy, 1.0 - gy * gy
            a00, a01, a11 = a00 + m00, a01 + m01, a11 + m11
            b0 += m00 * points[i, 0] + m01 * points[i, 1]
            b1 += m01 * points[i, 0] + m11 * points[i, 1]
        det = a00 * a11 - a01 * a01
        cone = det > tol * n_start * n_start
        cx, cy = (a11 * b0 - a01 * b1) / det, (a00 * b1 - a01 * b0) / det
        offset = 0.0
        for k in range(n_start if cone else 0):
            i = o + k
            dx, dy = points[i, 0] - cx, points[i, 1] - cy
            d = _norm(dx, dy)
            if not d > tol * size:
                cone = False
                break
            if k == 0:
                offset = phi[i] - d
            cone = (cone and abs(dx / d - grad[i, 0]) <= tol and abs(dy / d - grad[i, 1]) <= tol
                    and abs(phi[i] - d - offset) <= tol * size)
        if cone:
            shape[t, 0] = CONE
            shape[t, 1], shape[t, 2], _, _ = project(_vertices(tri, t), cx, cy, 0.0, 0.0)
            shape[t, 3] = offset + _norm(shape[t, 1] - cx, shape[t, 2] - cy)
            continue
        if convex and _cuts(tri, t, points, phi, grad, o, n_start, tol * size, shape):
            shape[t, 0] = CUTS
    return corner, shape


@njit(cache=True, error_model="numpy")
def initialize(points: np.ndarray, phi: np.ndarray, grad: np.ndarray, sigma: np.ndarray,
               state: np.ndarray, flags: np.ndarray) -> None:
    """Fill ``state`` and ``flags`` (all rows) for starts at points (P, 2) with
    values (P,), gradients (P, 2) and initial step scales (P,): no second plane
    (b's own), no line search. Columns left unset (the line search's path and
    bracket, the per-round ones) are written before they are read."""
    for i in range(len(state)):
        for c in range(N_FLAGS):
            flags[i, c] = 0
        state[i, BEST], state[i, BEST + 1], state[i, PHI] = points[i, 0], points[i, 1], phi[i]
        state[i, GRAD], state[i, GRAD + 1] = grad[i, 0], grad[i, 1]
        for c in range(5):
            state[i, ALT + c] = state[i, BEST + c]
        state[i, SIGMA] = sigma[i]
        state[i, PREVIOUS], state[i, PREVIOUS + 1] = points[i, 0], points[i, 1]
        state[i, PREVIOUS + 2] = state[i, PREVIOUS + 3] = 0.0


@njit(cache=True, error_model="numpy")
def results(state: np.ndarray, flags: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Best points (P, 2), their objective (P,) and the rounds run (P,), as new arrays."""
    n = len(state)
    best, phi, rounds = np.empty((n, 2)), np.empty(n), np.empty(n, dtype=np.int64)
    for i in range(n):
        best[i, 0], best[i, 1], phi[i] = state[i, BEST], state[i, BEST + 1], state[i, PHI]
        rounds[i] = flags[i, ROUNDS]
    return best, phi, rounds


# --------------------------------------------------------------------------------------
# Starts chosen by sampling (``descent.triangle_deepest_sampled``)
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def hidden_dips(points: np.ndarray, phi: np.ndarray, grad: np.ndarray, n_sample: int,
                edges: np.ndarray, h: int) -> np.ndarray:
    """Dips between lattice samples that no sample shows: (T, h, 2) points, NaN where none.

    points (T n_sample, 2), phi, grad (T n_sample, 2): each triangle's lattice samples
    and f, grad f there; edges (E, 2): the lattice's neighbour pairs (c, n), c < n.
    Along an edge, with e = x_n - x_c, f(x_c + t e) is fitted by the cubic Hermite
    polynomial H through the two values and slopes p = grad_c . e, q = grad_n . e (m).
    In Bernstein form H'(t) = p (1 - t)^2 + 2 m t (1 - t) + q t^2 with
    m = 3 (f_n - f_c) - p - q (the mean of H' over [0, 1] is f_n - f_c). When p and q
    have one sign, H' changes sign inside [0, 1] iff m < -sqrt(p q) (p, q > 0) or
    m > sqrt(p q) (p, q < 0): the segment then holds a local minimum that neither end
    shows (as a vertex that is itself a local minimum with a deeper dip 10 % along an
    edge: the smooth union of tools/bench_collide.py, 8e-5 m deeper). The dip is the
    root of H' = C + B t + A t^2 (C = p, B = 2 (m - p), A = p - 2 m + q) where
    H'' = B + 2 A t > 0, predicted at H(t) = f_c + C t + B t^2 / 2 + A t^3 / 3. Of a
    triangle's edges, the h with the lowest predicted values give the points (by
    increasing prediction); the rest of the h rows are NaN.
    """
    n_tri = phi.shape[0] // n_sample
    out = np.full((n_tri, h, 2), np.nan)
    best = np.empty(h)
    for t in range(n_tri):
        o = t * n_sample
        found = 0
        for j in range(edges.shape[0]):
            c, n = o + edges[j, 0], o + edges[j, 1]
            ex, ey = points[n, 0] - points[c, 0], points[n, 1] - points[c, 1]
            p = grad[c, 0] * ex + grad[c, 1] * ey
            q = grad[n, 0] * ex + grad[n, 1] * ey
            if not p * q > 0.0:                    # slopes of one sign (and not NaN)
                continue
            m = 3.0 * (phi[n] - phi[c]) - p - q
            if not (m * p < 0.0 and m * m > p * q):     # m beyond -+sqrt(p q), against p
                continue
            a, b = p - 2.0 * m + q, 2.0 * (m - p)
            if a == 0.0:
                at = -p / b
            else:
                disc = math.sqrt(b * b - 4.0 * a * p)
                at = (-b + disc) / (2.0 * a)
                if not b + 2.0 * a * at > 0.0:
                    at = (-b - disc) / (2.0 * a)
            if not 0.0 < at < 1.0:
                continue
            value = phi[c] + at * (p + at * (0.5 * b + at * a / 3.0))
            # Insert by predicted value into the h kept so far.
            r = min(found, h)
            while r > 0 and value < best[r - 1]:
                if r < h:
                    best[r] = best[r - 1]
                    out[t, r, 0], out[t, r, 1] = out[t, r - 1, 0], out[t, r - 1, 1]
                r -= 1
            if r < h:
                best[r] = value
                out[t, r, 0], out[t, r, 1] = points[c, 0] + at * ex, points[c, 1] + at * ey
            found += 1
    return out


@njit(cache=True, error_model="numpy")
def present_dips(dips: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The dips (T, h, 2) that are there (not NaN): their points (M, 2) and their
    places t h + r (M,), in that order."""
    n_tri, h = dips.shape[0], dips.shape[1]
    count = 0
    for t in range(n_tri):
        for r in range(h):
            count += not math.isnan(dips[t, r, 0])
    points = np.empty((count, 2))
    place = np.empty(count, dtype=np.int64)
    i = 0
    for t in range(n_tri):
        for r in range(h):
            if not math.isnan(dips[t, r, 0]):
                points[i, 0], points[i, 1], place[i] = dips[t, r, 0], dips[t, r, 1], t * h + r
                i += 1
    return points, place


@njit(cache=True, error_model="numpy")
def with_dips(points: np.ndarray, phi: np.ndarray, grad: np.ndarray, sigma: np.ndarray,
              n_sample: int, h: int, dip_points: np.ndarray, dip_place: np.ndarray,
              dip_phi: np.ndarray, dip_grad: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each triangle's n_sample samples followed by its h dip slots: points, phi, grad,
    sigma of T (n_sample + h) rows. The dips (``present_dips``: points (M, 2), places
    t h + r, and f, grad f there) fill their slots; empty slots have NaN phi."""
    n_tri = phi.shape[0] // n_sample
    width = n_sample + h
    p = np.empty((n_tri * width, 2))
    f = np.full(n_tri * width, np.nan)
    g = np.zeros((n_tri * width, 2))
    s = np.empty(n_tri * width)
    for t in range(n_tri):
        for r in range(width):
            i = t * width + r
            j = t * n_sample + min(r, n_sample - 1)
            s[i] = sigma[j]
            if r < n_sample:
                p[i, 0], p[i, 1], f[i] = points[j, 0], points[j, 1], phi[j]
                g[i, 0], g[i, 1] = grad[j, 0], grad[j, 1]
            else:
                p[i, 0], p[i, 1] = points[j, 0], points[j, 1]
    for d in range(dip_place.shape[0]):
        i = (dip_place[d] // h) * width + n_sample + dip_place[d] % h
        p[i, 0], p[i, 1], f[i] = dip_points[d, 0], dip_points[d, 1], dip_phi[d]
        g[i, 0], g[i, 1] = dip_grad[d, 0], dip_grad[d, 1]
    return p, f, g, s


@njit(cache=True, error_model="numpy")
def pick_starts(phi: np.ndarray, points: np.ndarray, sigma: np.ndarray, n_sample: int,
                neighbours: np.ndarray, spacing: float, k: int, n_lattice: int) -> np.ndarray:
    """(T, k) the samples to descend from, per triangle, in rank order.

    phi (T n_sample,), points (T n_sample, 2), sigma (T n_sample,): f at each
    triangle's samples (triangle by triangle), the samples, and their triangle's
    longest edge; the first n_lattice of each triangle are its lattice samples,
    the rest its dip slots (``with_dips``; an empty one, NaN, is never taken);
    neighbours (n_sample, 6): each sample's lattice neighbours, -1 padded (none
    for a dip). Taken by increasing value (the first on ties; NaN last),
    skipping samples within spacing x sigma (spacing = 1 / degree: one lattice
    step; on a sliver also the samples of other rows that fall next to a taken
    one) of one already taken: first the discrete local minima (no lattice
    neighbour lower; every dip), one per separate dip, then the other samples,
    then (when fewer than k are left so) the lowest of the rest (k <= n_lattice).
    """
    n_tri = phi.shape[0] // n_sample
    chosen = np.empty((n_tri, k), dtype=np.int64)
    taken = np.empty(n_sample, dtype=np.bool_)
    for t in range(n_tri):
        o = t * n_sample
        for s in range(n_sample):
            taken[s] = s >= n_lattice and math.isnan(phi[o + s])
        reach = spacing * sigma[o] * (1.0 + 1e-6)          # a neighbour, with rounding
        reach2 = reach * reach
        m = 0
        stage = 0
        while m < k:
            # The lowest sample eligible at this stage (the first of equals; NaN last).
            pick = -1
            for c in range(n_sample):
                if taken[c]:
                    continue
                if pick >= 0 and not (phi[o + c] < phi[o + pick] or (
                        math.isnan(phi[o + pick]) and not math.isnan(phi[o + c]))):
                    continue
                if stage == 0:                             # a discrete local minimum?
                    lowest = True
                    for q in range(neighbours.shape[1]):
                        n = neighbours[c, q]
                        lowest = lowest and (n < 0 or not phi[o + n] < phi[o + c])
                    if not lowest:
                        continue
                near = False
                for r in range(m if stage < 2 else 0):
                    dx = points[o + c, 0] - points[o + chosen[t, r], 0]
                    dy = points[o + c, 1] - points[o + chosen[t, r], 1]
                    near = near or dx * dx + dy * dy <= reach2
                if not near:
                    pick = c
            if pick < 0:
                stage += 1
                continue
            chosen[t, m] = pick
            taken[pick] = True
            m += 1
    return chosen


@njit(cache=True, error_model="numpy")
def gather_starts(n_sample: int, chosen: np.ndarray, points: np.ndarray, phi: np.ndarray,
                  grad: np.ndarray, sigma: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The chosen samples (T, k) of per-triangle samples (T n_sample rows of points,
    phi, grad, sigma) as starts: points (T k, 2), phi, grad, sigma, owner (T k,)."""
    n_tri, k = chosen.shape[0], chosen.shape[1]
    p = np.empty((n_tri * k, 2))
    f = np.empty(n_tri * k)
    g = np.empty((n_tri * k, 2))
    s = np.empty(n_tri * k)
    owner = np.empty(n_tri * k, dtype=np.int64)
    for t in range(n_tri):
        for r in range(k):
            i, j = t * k + r, t * n_sample + chosen[t, r]
            p[i, 0], p[i, 1], f[i], g[i, 0], g[i, 1] = points[j, 0], points[j, 1], phi[j], \
                grad[j, 0], grad[j, 1]
            s[i], owner[i] = sigma[j], t
    return p, f, g, s, owner
