"""State layout and descent paths of ``descent``'s compiled rounds (``_descent_kernels``).

The kinds of problem (``TRIANGLE``, ``PAIR``), the columns of the per-start ``state``
and ``flags`` tables, the ladder and the tolerances of a round; then the paths a round
samples from a start's best point: the proximal min-max path of two linear models
(steepest descent, or along a ridge where two planes balance), projected onto the
start's triangle (Bertsekas' projection arc) and ended where the projected ray stops;
a field pair's osculating point (the two fields' osculating circles' deepest balanced
point); the stationarity measure that stops a start. ``_descent_kernels``' docstring describes
the tables and the round.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types

from .._jit import njit
from .._shared_kernel import shared
from ..vec2 import TINY

TRIANGLE = 0
PAIR = 1

#: Step multipliers of the ladder on a path from the best point, ascending.
LADDER = np.array([1.0 / 16.0, 0.25, 1.0, 4.0])
#: Rungs per ladder: the geometric ones and, on a triangle's steepest path, its end.
N_RUNGS = len(LADDER) + 1
#: Candidate columns: steepest ladder | bundle ladder | two model points | a field
#: pair's osculating point (``_osculating_point``).
COLUMN_BUNDLE = N_RUNGS
COLUMN_MODEL = 2 * N_RUNGS
COLUMN_OSCULATING = 2 * N_RUNGS + 2
N_COLUMNS = 2 * N_RUNGS + 3
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
#: ... of a field pair's objective (``PAIR``). Where the two surfaces balance, the
#: projected gradient is the min-norm element of the two planes' hull, about e kappa at
#: a distance e along the contact's tangent from its minimum (kappa, 1/m, the two
#: surfaces' curvatures apart); the rounds after it falls under 1e-8 moved the point by
#: a tenth of a micrometre and the depth by 1e-14 m (the showcase's field-field queries:
#: 10 % fewer evaluations, the same contacts and keys). 1e-7 turns two circles' normal
#: by more than 1e-9 (tests/test_descent.py). docs/performance.md, "2026-11-29, session 30".
STATIONARY_PAIR = 1e-8
#: The Barzilai-Borwein scale stays within this factor of the last step's scale.
BB_RANGE = 16.0
#: Two unit gradients with cosine below 1 - KINK are taken as the two sides of a kink.
KINK = 1e-3
#: Weight k of the imbalance in the field-field objective (f_a + f_b) / 2 + k |f_a - f_b|.
IMBALANCE = 0.25
EPS = np.finfo(np.float64).eps

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
PRIOR = 31        # PAIR: the best point before b (2), grad f_a (2) and grad f_b (2) there
N_STATE = 37
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
HAS_PRIOR = 9     # PAIR: PRIOR is set
OSCULATING = 10   # PAIR: the osculating point won the last round (1), this round
                  # proposes the next one alone (2)
N_FLAGS = 11
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
def _osculating(bx: float, by: float, gx: float, gy: float, px: float, py: float, hx: float,
                hy: float) -> tuple[bool, float, float, float]:
    """A field's centre of curvature c from its gradients g at b and h at p: where the
    gradient lines b + s g and p + r h cross, c = b + s u (u = g / |g|, s in m). Returns
    (curved, cx, cy, s); not curved (a flat field there) when the lines' directions
    differ by less than 1e-9 rad."""
    ux, uy = _unit(gx, gy)
    vx, vy = _unit(hx, hy)
    cross = ux * vy - uy * vx
    if abs(cross) <= 1e-9:
        return False, 0.0, 0.0, 0.0
    s = ((px - bx) * vy - (py - by) * vx) / cross
    return True, bx + s * ux, by + s * uy, s


@njit(cache=True, error_model="numpy")
def _along(curved: bool, t: float, v: float, s: float, f: float, k: float, l: float,
           u: float) -> tuple[float, float]:
    """Slope and intercept in u of a field's model along the line o + u e, on the linear
    piece around u: an osculating circle's f(b) + v (|u - t| - |s|) (centre at t), or a
    plane's k + l u."""
    if not curved:
        return l, k
    side = 1.0 if u >= t else -1.0
    return v * side, f - v * (side * t + abs(s))


@njit(cache=True, error_model="numpy")
def _root_on(curved_a: bool, curved_b: bool, tb: float, va: float, vb: float, sa: float,
             sb: float, fa: float, fb: float, ka: float, kb: float, la: float, lb: float,
             lo: float, hi: float, near: float, found: bool, u: float) -> tuple[bool, float]:
    """The balance f_a = f_b of the two models (``_along``; a's centre, if curved, at 0,
    b's at tb) on their linear piece [lo, hi] of the line, when it lies on it and closer
    to ``near`` than the root u found so far (if found); else (found, u)."""
    inside = hi - 1.0 if lo == -np.inf else (lo + 1.0 if hi == np.inf else 0.5 * (lo + hi))
    slope_a, at_a = _along(curved_a, 0.0, va, sa, fa, ka, la, inside)
    slope_b, at_b = _along(curved_b, tb, vb, sb, fb, kb, lb, inside)
    slope = slope_a - slope_b
    if abs(slope) > 1e-12:
        root = (at_b - at_a) / slope
        if lo <= root <= hi and (not found or abs(root - near) < abs(u - near)):
            return True, root
    return found, u


@njit(cache=True, error_model="numpy")
def _osculating_point(fa: float, fb: float, gax: float, gay: float, gbx: float,
                      gby: float, bx: float, by: float, px: float, py: float, hax: float,
                      hay: float, hbx: float, hby: float) -> tuple[bool, float, float]:
    """PAIR: the point where a start's osculating model of the two fields is deepest.

    At b the fields have values fa, fb and gradients g_a, g_b; at the prior point p
    gradients h_a, h_b. Each field near b is modelled by its osculating circle, its
    centre c where its gradient lines through b and p cross (``_osculating``): f(x) =
    f(b) + v (|x - c| - |s|), v = -sign(s) |grad f(b)| (a convex side's centre lies
    behind b); or, where the lines do not turn, by its tangent plane at b. Two circles'
    (a circle's and a plane's) balanced deepest point lies on the line through the
    centres (through the centre along the plane's gradient), where both models are
    piecewise linear (breaking at the centres): the balance f_a = f_b there, the root
    nearest b. Two planes: b's balancing step -(f_a - f_b) w / |w|^2 (w = g_a - g_b)
    when they oppose. The step from b is kept within 4 |b - p| + 2 |f_a - f_b|. Returns
    (found, x, y); not found where the models have no balance on that line (gradients
    that do not oppose, nested circles)."""
    ma, mb = _norm(gax, gay), _norm(gbx, gby)
    curved_a, cax, cay, sa = _osculating(bx, by, gax, gay, px, py, hax, hay)
    curved_b, cbx, cby, sb = _osculating(bx, by, gbx, gby, px, py, hbx, hby)
    if not (curved_a or curved_b):
        wx, wy = gax - gbx, gay - gby
        ww = wx * wx + wy * wy
        if ww <= TINY or gax * gbx + gay * gby > (-1.0 + KINK) * ma * mb:
            return False, bx, by
        balance = (fa - fb) / ww
        return True, bx - balance * wx, by - balance * wy
    # The line o + u e: from a's centre to b's, or from the centre along the plane's
    # gradient; the centres on it at u = 0 (the one at o) and u = tb (b's, of two).
    if curved_a:
        ox, oy = cax, cay
        ex, ey = (cbx - cax, cby - cay) if curved_b else (gbx, gby)
    else:
        ox, oy, ex, ey = cbx, cby, gax, gay
    norm = _norm(ex, ey)
    if norm <= TINY:
        return False, bx, by
    ex, ey = ex / norm, ey / norm
    tb = norm if curved_a and curved_b else 0.0
    va, vb = -_sign(sa) * ma, -_sign(sb) * mb
    ka, la = fa + gax * (ox - bx) + gay * (oy - by), gax * ex + gay * ey
    kb, lb = fb + gbx * (ox - bx) + gby * (oy - by), gbx * ex + gby * ey
    near = (bx - ox) * ex + (by - oy) * ey
    found, u = _root_on(curved_a, curved_b, tb, va, vb, sa, sb, fa, fb, ka, kb, la, lb,
                        -np.inf, 0.0, near, False, 0.0)
    found, u = _root_on(curved_a, curved_b, tb, va, vb, sa, sb, fa, fb, ka, kb, la, lb,
                        0.0, tb, near, found, u)
    found, u = _root_on(curved_a, curved_b, tb, va, vb, sa, sb, fa, fb, ka, kb, la, lb,
                        tb, np.inf, near, found, u)
    if not found:
        return False, bx, by
    dx, dy = ox + u * ex - bx, oy + u * ey - by
    step = _norm(dx, dy)
    limit = 4.0 * _norm(bx - px, by - py) + 2.0 * abs(fa - fb)
    if step > limit:
        dx, dy = dx * (limit / step), dy * (limit / step)
    return True, bx + dx, by + dy


# ``_osculating_point`` for ``propose``: its own machine code, not built into propose's
# (whose compilation, on a cold start's path, it lengthened by 0.75 s; 0.3 s apart).
osculating_point_shared = shared(_osculating_point, (types.float64,) * 14,
                                 "sdfphys_collide_descent_osculating_point",
                                 types.Tuple((types.boolean, types.float64, types.float64)))


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
