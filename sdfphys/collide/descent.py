"""Local minimisation of signed distance fields: over triangles, and over two fields' overlap.

Three pure functions serve the narrowphase (all arrays float64, metres, each
field's own frame; sign convention of ``sdfphys.sdf``: f < 0 inside):

- ``triangle_deepest``: for each triangle, the local minima of f restricted to the
  triangle, one per start (3 vertices, 3 edge midpoints, centroid);
  ``merge_minima`` keeps one start per distinct minimum.
- ``triangle_cull``: which triangles may reach f < margin (enclosing-circle test).
- ``field_field_contacts``: contact points between two fields placed relative to
  each other, found by descent on max(f_a, f_b) from starts spread over the
  overlap of their bounds.

The fields are Python objects, so every descent iteration gathers the candidate
points of ALL active starts into ONE ``field.evaluate`` call; the only Python loop
is over iterations, and a start leaves the batch as soon as it has converged.

The descent (shared by the triangle and the field-field problems)
-----------------------------------------------------------------
Both minimise a piecewise smooth, 1-Lipschitz function phi: f over a triangle,
or a balance of f_a and f_b over the plane (see ``_PairProblem``). From the
current best point b, a *path* q(s), s >= 0, leaves b downhill. It is the
proximal path of two linear models (``_proximal_path``): while one model is
clearly larger, steepest descent of it; from where they balance on, along the
line where they are equal. With the linearisation of phi at b as both models it
is plain steepest descent. For a triangle the path is projected onto it:
Proj_T(b + delta(s)) runs straight, slides along an edge, may stop at a vertex
(Bertsekas' projection arc, equivalent to projected descent in barycentric
coordinates with the Euclidean metric). Along a path phi is a 1D function whose
slope phi'(s) = grad phi(q) . dq/ds is known at every sample, so each iteration
evaluates, in one batch:

1. a geometric ladder s = scale * (1/16, 1/4, 1, 4) on the steepest path from b;
2. the same ladder on the *bundle* path, whose second model is the plane of a
   point seen nearby with a clearly different gradient (cosine < 1 - _KINK),
   the most active one (smallest linearisation error at b, as in bundle
   methods). Two such planes meet along a ridge of the medial axis (or through
   the apex of a cone, the centre of a circle); the bundle path follows it where
   steepest descent would zigzag across it;
3. two model points inside the bracket [s_l, s_r] of the line search in
   progress (a local minimum lies in it: phi'(s_l) < 0 and either
   phi'(s_r) >= 0 or phi(s_r) > phi(s_l)):
   - the zero of the secant of phi' (exact for a quadratic, superlinear on
     smooth minima), or the minimiser of the quadratic through phi(s_l),
     phi'(s_l), phi(s_r) when phi'(s_r) < 0;
   - the crossing of the tangent lines at s_l and s_r, exact at a kink between
     two linear pieces (a polygon's medial axis, or a circle's centre along a
     ray through it: f(c + t u) = |t| - r is V-shaped);
   both kept a fraction ``_GUARD`` of the bracket away from its ends.

On each ladder only the first valley counts (samples up to the first one where
phi rises or its slope turns >= 0): a start finds the minimum of its own basin
rather than jumping over a hill into a deeper one, which is what lets several
starts report several minima. The best candidate replaces b when it lowers phi;
the bracket is then rebuilt from the winner's ladder neighbours, or shrunk by
the model samples. The scale is that of the accepted step (16 times larger when
the last ladder sample still descends); for the field pair it is the
Barzilai-Borwein step s.s / s.y of the last two iterations, which makes the
slide along a contact's tangent converge superlinearly. A round without
decrease divides the scale by 64 and brackets the first ladder step, so the
next round searches finely around b; a second such round ends the descent, as
does a zero projected gradient (b is a vertex whose normal cone contains
-grad f, or the two fields' gradients are antiparallel and balanced) or an
accepted step shorter than ``tol``. phi never increases: whatever the budget,
the returned point is the best one seen.

Limits: a start that reaches an interior vertex of a polygon's medial axis
where three faces are equally near, but which is not a minimum, can stop there
(a bundle of two planes cannot describe three; about 1 start in 1000 on random
triangles deep inside a pentagon); the other starts of the triangle usually
reach the deeper point.

References: M. Macklin et al., "Local Optimization for Robust Signed Distance
Field Collision", Proc. ACM Comput. Graph. Interact. Tech. 3(1), 2020 (projected
descent over a triangle's barycentric coordinates, several starts); D. P.
Bertsekas, "Nonlinear Programming", sec. 2.3 (projection arc); P. Liu, Y. Zhang
et al., "Real-time Collision Detection between General SDFs", 2024, and MuJoCo's
SDF-SDF collision (descent on max(f_a, f_b) from low-discrepancy starts over the
intersection of the bounding boxes, normal from grad f_a - grad f_b).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from ..sdf import Field, safe_normalize

__all__ = [
    "START_BARYCENTRIC",
    "field_field_contacts",
    "merge_minima",
    "triangle_cull",
    "triangle_deepest",
]

#: Default starts of ``triangle_deepest`` as barycentric weights of (v0, v1, v2);
#: row k is start id k: 0-2 the vertices, 3 mid(v0, v1), 4 mid(v1, v2),
#: 5 mid(v2, v0), 6 the centroid. The ids are contact feature keys: keep them stable.
START_BARYCENTRIC = np.array([
    [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0],
    [0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5],
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
])

#: Step multipliers of the ladder evaluated on the path from the best point, descending.
_LADDER = np.array([4.0, 1.0, 0.25, 1.0 / 16.0])
#: sigma is divided by this after a round without decrease.
_SHRINK = 64.0
#: Model points stay this fraction of the bracket away from its ends.
_GUARD = 1e-3
#: The path's slope at its start is read at s = _PROBE * sigma (past any corner at s = 0).
_PROBE = 1e-9
#: A projected gradient shorter than this (unit gradients) means a stationary point.
_STATIONARY = 1e-12
#: The Barzilai-Borwein scale stays within this factor of the last step's scale.
_BB_RANGE = 16.0
#: Two unit gradients with cosine below 1 - _KINK are taken as the two sides of a kink.
_KINK = 1e-3
#: Weight k of the imbalance in the field-field objective (f_a + f_b) / 2 + k |f_a - f_b|.
_IMBALANCE = 0.25
#: Contacts of two fields closer than this fraction of the region's diagonal are one.
_MERGE = 1e-3
#: Thickness of the sliver measuring a flat patch, as a fraction of the region's diagonal.
_SLIVER = 1e-9
_EPS = np.finfo(np.float64).eps
_TINY = 1e-300


# --------------------------------------------------------------------------------------
# Triangle geometry
# --------------------------------------------------------------------------------------

def _project_to_triangles(tri: np.ndarray, x: np.ndarray, u: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of triangles to points, and the derivative of the projection along u.

    tri: (n, 3, 2); x, u: (n, m, 2). Returns q = Proj_T(x) (n, m, 2) and
    dq = D Proj_T(x) u (n, m, 2): u itself inside, its component along the edge
    when q lies inside an edge, 0 when q is a vertex. Degenerate (collinear)
    triangles are handled as their edges.
    """
    start = tri
    edge = np.roll(tri, -1, axis=1) - tri                          # (n, 3, 2): v_k -> v_k+1
    rel = x[:, :, None, :] - start[:, None, :, :]                  # (n, m, 3, 2)
    length2 = np.einsum("nkd,nkd->nk", edge, edge)
    t = np.einsum("nmkd,nkd->nmk", rel, edge) / np.maximum(length2, _TINY)[:, None, :]
    t = np.clip(t, 0.0, 1.0)
    foot = start[:, None, :, :] + t[..., None] * edge[:, None, :, :]
    k = np.argmin(np.einsum("nmkd,nmkd->nmk", x[:, :, None] - foot, x[:, :, None] - foot),
                  axis=2)
    q_edge = np.take_along_axis(foot, k[..., None, None], axis=2)[:, :, 0]
    t_edge = np.take_along_axis(t, k[..., None], axis=2)[..., 0]

    # Inside test: x on the inner side of all three edges (orientation-independent).
    cross = edge[:, None, :, 0] * rel[..., 1] - edge[:, None, :, 1] * rel[..., 0]
    area = edge[:, 0, 0] * (-edge[:, 2, 1]) - edge[:, 0, 1] * (-edge[:, 2, 0])
    inside = np.all(cross * np.sign(area)[:, None, None] >= 0.0, axis=2) & (area != 0.0)[:, None]

    unit = edge / np.sqrt(np.maximum(length2, _TINY))[..., None]
    e = np.take_along_axis(unit[:, None].repeat(x.shape[1], axis=1), k[..., None, None],
                           axis=2)[:, :, 0]
    along = np.einsum("nmd,nmd->nm", u, e)
    on_edge = (t_edge > 0.0) & (t_edge < 1.0)
    dq = np.where(on_edge[..., None], along[..., None] * e, 0.0)
    q = np.where(inside[..., None], x, q_edge)
    dq = np.where(inside[..., None], u, dq)
    return q, dq


def _enclosing_circles(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Minimal enclosing circles (centre (T, 2), radius (T,)) of triangles (T, 3, 2).

    For a triangle with an obtuse or right angle (collinear points included) it is
    the circle on the longest edge as diameter; otherwise the circumcircle.
    """
    edge = np.roll(tri, -1, axis=1) - tri                          # edge k: v_k -> v_k+1
    length2 = np.einsum("tkd,tkd->tk", edge, edge)
    k = np.argmax(length2, axis=1)
    rows = np.arange(len(tri))
    a, b = tri[rows, k], tri[rows, (k + 1) % 3]
    c = tri[rows, (k + 2) % 3]                                     # opposite the longest edge
    obtuse = np.einsum("td,td->t", a - c, b - c) <= 0.0
    centre = 0.5 * (a + b)
    radius = 0.5 * np.sqrt(length2[rows, k])

    # Circumcentre relative to c, with p = a - c and r = b - c: the point o with
    # |o|^2 = |o - p|^2 = |o - r|^2, i.e. 2 o.p = |p|^2, 2 o.r = |r|^2 (Cramer):
    # o = (r_y |p|^2 - p_y |r|^2, p_x |r|^2 - r_x |p|^2) / (2 (p_x r_y - p_y r_x)).
    # An acute triangle is not degenerate, so the determinant is not zero.
    acute = ~obtuse
    p, r = (a - c)[acute], (b - c)[acute]
    det = 2.0 * (p[:, 0] * r[:, 1] - p[:, 1] * r[:, 0])
    pp, rr = np.einsum("td,td->t", p, p), np.einsum("td,td->t", r, r)
    off = np.stack([r[:, 1] * pp - p[:, 1] * rr, p[:, 0] * rr - r[:, 0] * pp], axis=1)
    off /= det[:, None]
    centre[acute] = c[acute] + off
    radius[acute] = np.hypot(off[:, 0], off[:, 1])
    return centre, radius


def triangle_cull(field: Field, triangles: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """(T,) bool: False only for triangles on which f >= margin everywhere.

    triangles: (T, 3, 2) in the field's frame (m); margin: m. With c, R the
    minimal enclosing circle of a triangle, the triangle is kept iff
    f(c) < R + margin. One ``field.distance`` call on T points.

    Why it never rejects a triangle holding a point q with f(q) < margin: every
    field of ``sdfphys.sdf`` is 1-Lipschitz (an exact distance is; min, max and
    the smooth minima of 1-Lipschitz fields have gradients that are convex
    combinations of unit vectors, so they are too), hence
    f(q) >= f(c) - |q - c| >= f(c) - R for every q in the circle. For a field that
    only satisfies the weaker ``exact = False`` promise (|f| <= distance) but is
    not 1-Lipschitz, the test still never misses a triangle that truly overlaps
    the shape (d(q) >= d(c) - R >= f(c) - R), i.e. it is safe for margin <= 0.
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 2)
    if len(tri) == 0:
        return np.zeros(0, dtype=bool)
    centre, radius = _enclosing_circles(tri)
    return field.distance(centre) < radius + margin


# --------------------------------------------------------------------------------------
# The line-search descent engine
# --------------------------------------------------------------------------------------

class _Problem(Protocol):
    """What ``_descend`` needs from a problem (see the module docstring).

    ``evaluate`` returns, at points (N, 2), the objective (N,), its (sub)gradient
    (N, 2) and the per-point data (N, kd) a path needs; ``fresh`` builds the
    parameters (n, kp) of the path leaving each best point, given the second
    plane of the bundle (a point, its objective and gradient; b's own plane for
    the steepest path); ``path`` maps path parameters and steps (n, m) to points
    q and dq/ds (n, m, 2); ``bundle_free`` says where a bundle path is worth a
    ladder; ``stationarity`` (N,) >= 0 breaks ties of the objective at rounding
    level (zero: no tie-breaking). ``rows`` index the starts (for per-start
    geometry such as a start's triangle).
    """

    #: Scale the ladder by the Barzilai-Borwein step (else by the last step).
    barzilai_borwein: bool

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def fresh(self, rows: np.ndarray, best: np.ndarray, phi: np.ndarray, data: np.ndarray,
              plane: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray: ...

    def path(self, rows: np.ndarray, params: np.ndarray, s: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]: ...

    def bundle_free(self, rows: np.ndarray, params: np.ndarray, probe: np.ndarray
                    ) -> np.ndarray: ...

    def stationarity(self, data: np.ndarray) -> np.ndarray: ...


def _proximal_path(f1: np.ndarray, f2: np.ndarray, g1: np.ndarray, g2: np.ndarray,
                   tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Step delta(tau) and d delta / d tau (n, m, 2) of the proximal min-max path.

    Two linear models l_i(b + delta) = f_i + g_i . delta (f: (n,), g: (n, 2)) and
    tau: (n, m) >= 0. delta(tau) minimises max(l_1, l_2) + |delta|^2 / (2 tau).
    Dual: delta = -tau (lam g1 + (1 - lam) g2) with lam in [0, 1] maximising
    lam f1 + (1 - lam) f2 - tau |lam g1 + (1 - lam) g2|^2 / 2, i.e. with
    w = g1 - g2, D = f1 - f2:

        lam = clamp((D / tau - g2 . w) / |w|^2, 0, 1).

    For small tau lam is clamped and the path is steepest descent of the larger
    model; from tau* = |D| / (g_larger . w) on it is the balancing correction
    -(D / |w|^2) w plus tau times -(g2 - (g2 . w / |w|^2) w), the min-norm element
    of the models' gradient hull, which runs along the line l_1 = l_2 (a ridge, or
    the contact between two fields). Where w = 0 the larger model's (first on a
    tie) gradient is followed.
    """
    w = g1 - g2
    ww = np.einsum("nd,nd->n", w, w)
    gap = (f1 - f2)[:, None]
    flat = ww <= _TINY
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = (gap / tau - np.einsum("nd,nd->n", g2, w)[:, None]) / np.where(flat, 1.0, ww)[:, None]
    lam = np.where(flat[:, None], np.where(gap >= 0.0, 1.0, 0.0), lam)
    free = (lam > 0.0) & (lam < 1.0)
    lam = np.clip(lam, 0.0, 1.0)
    direction = lam[..., None] * g1[:, None] + (1.0 - lam[..., None]) * g2[:, None]
    delta = -tau[..., None] * direction
    along = g2 - (np.einsum("nd,nd->n", g2, w) / np.where(flat, 1.0, ww))[:, None] * w
    d_delta = -np.where(free[..., None], along[:, None], direction)
    return delta, d_delta


def _model_steps(sl: np.ndarray, pl: np.ndarray, dl: np.ndarray,
                 sr: np.ndarray, pr: np.ndarray, dr: np.ndarray) -> np.ndarray:
    """Two trial steps (n, 2) inside brackets [sl, sr] from values p and slopes d at the ends.

    Column 0: zero of the secant of the slope (dr > 0), else the minimiser of the
    quadratic with value pl, slope dl at sl and value pr at sr. Column 1: the
    crossing of the tangent lines at both ends. Both are clamped to
    [sl + g w, sr - g w] (w = sr - sl, g = _GUARD); invalid models (zero or
    negative denominators) fall back to the midpoint.
    """
    w = sr - sl
    mid = sl + 0.5 * w
    with np.errstate(divide="ignore", invalid="ignore"):
        secant = sl - dl * w / (dr - dl)
        curvature = pr - pl - dl * w
        quadratic = sl - 0.5 * dl * w * w / curvature
        first = np.where(dr > 0.0, np.where(dr > dl, secant, mid),
                         np.where(curvature > 0.0, quadratic, mid))
        tangent = (pr - pl + dl * sl - dr * sr) / (dl - dr)
        second = np.where(dr > dl, tangent, mid)
    first = np.where(np.isfinite(first), first, mid)
    second = np.where(np.isfinite(second), second, mid)
    lo, hi = sl + _GUARD * w, sr - _GUARD * w
    return np.stack([np.clip(first, lo, hi), np.clip(second, lo, hi)], axis=1)


def _descend(problem: _Problem, points: np.ndarray, iterations: int, sigma: np.ndarray,
             tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Minimise the problem's objective from each start (P, 2) (see the module docstring).

    sigma: (P,) initial step scale (path units); tol: a start stops when its
    accepted step is shorter (m). At most ``iterations`` rounds, each ONE
    ``problem.evaluate`` call over the candidates of all running starts. Returns
    the best point (P, 2), its objective (P,), its data (P, kd) and the number of
    iterations each start took (P,) (a start is counted while it is in the batch).
    """
    phi, grad_best, data = problem.evaluate(points)
    best = points.copy()
    n_points = len(best)
    sigma = np.asarray(sigma, dtype=np.float64).copy()
    fails = np.zeros(n_points, dtype=np.int64)
    rounds = np.zeros(n_points, dtype=np.int64)
    active = np.ones(n_points, dtype=bool)
    # The previous best point and path direction, for the Barzilai-Borwein scale.
    prev_x, prev_v = best.copy(), np.zeros_like(best)
    has_prev = np.zeros(n_points, dtype=bool)
    # The second plane of the bundle (see ``_proximal_path``): initially b's own.
    alt_x, alt_phi, alt_g = best.copy(), phi.copy(), grad_best.copy()
    # The line search in progress: its path and bracket ends (s, value, slope).
    params: np.ndarray | None = None
    left_end, right_end = np.zeros((n_points, 3)), np.zeros((n_points, 3))
    bracketed = np.zeros(n_points, dtype=bool)
    n_ladder = len(_LADDER)
    n_cand = 2 * n_ladder + 2                  # columns: steepest ladder | bundle ladder | models

    for _ in range(iterations):
        rows = np.flatnonzero(active)
        if len(rows) == 0:
            break
        # The steepest path from b and its slope at the start; a zero projected
        # gradient is a stationary point (the start leaves the batch).
        own = (best[rows], phi[rows], grad_best[rows])
        steep = problem.fresh(rows, best[rows], phi[rows], data[rows], own)
        if params is None:
            params = np.zeros((n_points, steep.shape[1]))
        _, dq0 = problem.path(rows, steep, (_PROBE * sigma[rows])[:, None])
        still = np.hypot(dq0[:, 0, 0], dq0[:, 0, 1]) > _STATIONARY
        active[rows[~still]] = False
        rows, steep = rows[still], steep[still]
        n = len(rows)
        if n == 0:
            break
        rounds[rows] += 1
        d0 = np.einsum("nd,nd->n", grad_best[rows], dq0[still, 0])
        bundle = problem.fresh(rows, best[rows], phi[rows], data[rows],
                               (alt_x[rows], alt_phi[rows], alt_g[rows]))
        has_alt = np.any(alt_x[rows] != best[rows], axis=1)
        has_alt[has_alt] = problem.bundle_free(rows[has_alt], bundle[has_alt],
                                               (_PROBE * sigma[rows[has_alt]])[:, None])

        # The ladder's scale: sigma, or the Barzilai-Borwein step s.s / s.y from the
        # last accepted step s = b - b_prev and the change y of the path's
        # direction at scale sigma (exact for a locally quadratic model: it places
        # the ladder around the step that lands on the minimum), kept within a
        # factor _BB_RANGE of sigma (next to a kink y jumps and s.s / s.y is
        # meaningless).
        _, direction = problem.path(rows, steep, sigma[rows, None])
        direction = direction[:, 0]
        step = best[rows] - prev_x[rows]
        change = prev_v[rows] - direction
        curvature = np.einsum("nd,nd->n", step, change)
        with np.errstate(divide="ignore", invalid="ignore"):
            bb = np.einsum("nd,nd->n", step, step) / curvature
        use_bb = problem.barzilai_borwein & has_prev[rows] & (curvature > 0.0)
        bb = np.clip(np.where(np.isfinite(bb), bb, sigma[rows]), sigma[rows] / _BB_RANGE,
                     sigma[rows] * _BB_RANGE)
        scale = np.where(use_bb, bb, sigma[rows])
        prev_x[rows], prev_v[rows] = best[rows], direction

        # Candidates, one evaluation for all: a ladder on each path (ascending s)
        # and two model points in each bracket.
        s_ladder = scale[:, None] * _LADDER[::-1]
        q_steep, dq_steep = problem.path(rows, steep, s_ladder)
        arows = rows[has_alt]
        q_bundle, dq_bundle = problem.path(arows, bundle[has_alt], s_ladder[has_alt])
        has = bracketed[rows]
        brows = rows[has]
        s_model = np.sort(_model_steps(*left_end[brows].T, *right_end[brows].T), axis=1)
        q_model, dq_model = problem.path(brows, params[brows], s_model)
        value, grad, cand_data = problem.evaluate(np.concatenate(
            [q_steep.reshape(-1, 2), q_bundle.reshape(-1, 2), q_model.reshape(-1, 2)]))
        slope = np.einsum("nd,nd->n", grad, np.concatenate(
            [dq_steep.reshape(-1, 2), dq_bundle.reshape(-1, 2), dq_model.reshape(-1, 2)]))

        # Table of candidates per row (inf where absent); index into the evaluation.
        table = np.full((n, n_cand), np.inf)
        table_slope = np.zeros((n, n_cand))
        table_q = np.repeat(best[rows, None], n_cand, axis=1)
        index = np.zeros((n, n_cand), dtype=np.int64)
        blocks = ((np.ones(n, dtype=bool), slice(0, n_ladder), q_steep),
                  (has_alt, slice(n_ladder, 2 * n_ladder), q_bundle),
                  (has, slice(2 * n_ladder, n_cand), q_model))
        start = 0
        for mask, cols, q in blocks:
            count = q.shape[0] * q.shape[1]
            where = np.arange(start, start + count).reshape(q.shape[:2])
            table[mask, cols] = value[where]
            table_slope[mask, cols] = slope[where]
            table_q[mask, cols] = q
            index[mask, cols] = where
            start += count

        # On each path only the first valley counts (samples up to the first one
        # where phi rises or its slope turns >= 0): the descent stays local, each
        # start finds the minimum of its own basin.
        samples = []
        for cols in (slice(0, n_ladder), slice(n_ladder, 2 * n_ladder)):
            s_asc = np.concatenate([np.zeros((n, 1)), s_ladder], axis=1)
            p_asc = np.concatenate([phi[rows, None], table[:, cols]], axis=1)
            d_asc = np.concatenate([d0[:, None], table_slope[:, cols]], axis=1)
            rise = (d_asc[:, 1:] >= 0.0) | (p_asc[:, 1:] > p_asc[:, :-1])
            first_rise = np.where(rise.any(axis=1), np.argmax(rise, axis=1) + 1, n_ladder)
            reachable = np.arange(1, n_ladder + 1) <= first_rise[:, None]
            table[:, cols] = np.where(reachable, table[:, cols], np.inf)
            samples.append(np.stack([s_asc, p_asc, d_asc], axis=2))  # (n, 1 + ladder, 3)

        at = np.arange(n)
        win = np.argmin(table, axis=1)
        phi_old = phi[rows]
        phi_win = table[at, win]
        rounding = 4.0 * _EPS * np.maximum(1.0, np.abs(phi_old))
        improved = phi_win < phi_old - rounding
        # Near a smooth minimum phi stops changing in double precision long before
        # the point stops moving; there a candidate whose value ties with b's (to
        # rounding) is taken when it halves the problem's stationarity measure.
        tied = np.where(table <= (phi_old + rounding)[:, None], problem.stationarity(
            cand_data[index.ravel()]).reshape(n, n_cand), np.inf)
        tie_win = np.argmin(tied, axis=1)
        by_tie = ~improved & (tied[at, tie_win] < 0.5 * problem.stationarity(data[rows]))
        win = np.where(by_tie, tie_win, win)
        phi_win = table[at, win]
        improved |= by_tie
        moved = np.hypot(*(table_q[at, win] - best[rows]).T)
        left, right = left_end[rows], right_end[rows]
        new_has = has.copy()
        new_params = params[rows].copy()
        new_sigma = scale.copy()

        # (a) The model samples shrink their bracket: one with phi' < 0 and phi <=
        #     phi(s_l) becomes the left end, otherwise the right end (the second only
        #     if it still lies inside).
        hb = np.flatnonzero(has)
        for col in (0, 1):
            sample = np.stack([s_model[:, col], table[hb, 2 * n_ladder + col],
                               table_slope[hb, 2 * n_ladder + col]], axis=1)
            inside = (sample[:, 0] > left[hb, 0]) & (sample[:, 0] < right[hb, 0])
            to_left = inside & (sample[:, 2] < 0.0) & (sample[:, 1] <= left[hb, 1])
            to_right = inside & ~to_left
            left[hb] = np.where(to_left[:, None], sample, left[hb])
            right[hb] = np.where(to_right[:, None], sample, right[hb])
        from_model = improved & (win >= 2 * n_ladder)
        new_sigma = np.where(from_model, np.maximum(moved, 0.25 * scale), new_sigma)

        # (b) A ladder winner at position k starts a new line search on its path,
        #     bracketed by its neighbours (k - 1, k) if phi' >= 0 there, else
        #     (k, k + 1); open (no bracket) past the last sample, where the scale
        #     then grows by 16 (a long slide along an edge or a ridge).
        for number, path_params in enumerate((steep, bundle)):
            pick = improved & (win >= number * n_ladder) & (win < (number + 1) * n_ladder)
            k = np.clip(win - number * n_ladder, 0, n_ladder - 1) + 1
            smp = samples[number]
            down = smp[at, k, 2] < 0.0
            lk = np.where(down, k, k - 1)
            rk = np.minimum(np.where(down, k + 1, k), n_ladder)
            new_params[pick] = path_params[pick]
            left = np.where(pick[:, None], smp[at, lk], left)
            right = np.where(pick[:, None], smp[at, rk], right)
            open_end = down & (k == n_ladder)
            new_has = np.where(pick, ~open_end, new_has)
            new_sigma = np.where(pick, smp[at, k, 0] * np.where(open_end, _LADDER[0], 1.0),
                                 new_sigma)

        # (c) No decrease: search finely around b on the steepest path next round.
        stuck = ~improved
        new_params[stuck] = steep[stuck]
        left = np.where(stuck[:, None], samples[0][:, 0], left)
        right = np.where(stuck[:, None], samples[0][:, 1], right)
        new_has = np.where(stuck, d0 < 0.0, new_has)
        new_sigma = np.where(stuck, scale / _SHRINK, new_sigma)

        # The next second plane: among the planes seen near the new best (this
        # round's samples, the old best and the old second plane, within the step
        # scale) whose gradient differs from the new best's, the one most active
        # there, i.e. with the smallest linearisation error |f(b) - l_i(b)| (the
        # bundle methods' rule). A different gradient close by reveals a kink (a
        # ridge of the medial axis, or a minimum just passed); the bundle path then
        # follows the ridge l_1 = l_2 instead of zigzagging across it.
        new_x = table_q[at, win]
        new_g = np.where(improved[:, None], grad[index[at, win]], grad_best[rows])
        new_phi = np.where(improved, phi_win, phi_old)
        seen = np.isfinite(table)
        seen_x = np.concatenate([table_q, best[rows, None], alt_x[rows, None]], axis=1)
        seen_phi = np.concatenate([np.where(seen, table, 0.0), phi[rows, None],
                                   alt_phi[rows, None]], axis=1)
        seen_g = np.concatenate([grad[index], grad_best[rows, None], alt_g[rows, None]], axis=1)
        cosine = np.einsum("nkd,nd->nk", seen_g, _unit_or_zero(new_g))
        cosine /= np.maximum(np.linalg.norm(seen_g, axis=2), _TINY)
        error = np.abs(new_phi[:, None] - seen_phi
                       - np.einsum("nkd,nkd->nk", seen_g, new_x[:, None] - seen_x))
        reach = np.maximum(scale, new_sigma)
        usable = np.linalg.norm(seen_x - new_x[:, None], axis=2) <= reach[:, None]
        usable &= np.concatenate([seen, np.ones((n, 2), dtype=bool)], axis=1)
        usable &= cosine < 1.0 - _KINK
        error = np.where(usable, error, np.inf)
        pick_alt = np.argmin(error, axis=1)
        kink = usable[at, pick_alt]
        alt_x[rows] = np.where(kink[:, None], seen_x[at, pick_alt], new_x)
        alt_g[rows] = np.where(kink[:, None], seen_g[at, pick_alt], new_g)
        alt_phi[rows] = np.where(kink, seen_phi[at, pick_alt], new_phi)

        # Commit.
        take = rows[improved]
        best[take] = table_q[improved, win[improved]]
        phi[take] = phi_win[improved]
        data[take] = cand_data[index[improved, win[improved]]]
        grad_best[take] = grad[index[improved, win[improved]]]
        left_end[rows], right_end[rows] = left, right
        bracketed[rows] = new_has & (right[:, 0] > left[:, 0])
        params[rows] = new_params
        sigma[rows] = np.maximum(new_sigma, _TINY)
        fails[rows] = np.where(improved, 0, fails[rows] + 1)
        has_prev[rows] = improved
        done = (fails[rows] >= 2) | (improved & (moved < tol))
        active[rows[done]] = False

    return best, phi, data, rounds


# --------------------------------------------------------------------------------------
# Deepest points of triangles
# --------------------------------------------------------------------------------------

def _unit_or_zero(v: np.ndarray) -> np.ndarray:
    """Rows of v (n, 2) scaled to unit length; zero rows stay zero."""
    norm = np.hypot(v[:, 0], v[:, 1])
    return v / np.where(norm > _TINY, norm, 1.0)[:, None]


class _TriangleProblem:
    """f restricted to a triangle; start i belongs to triangle ``owner[i]``.

    Point data: the gradient of f. Path parameters: origin b, the two planes'
    values at b and gradients (f1, f2, g1, g2), and q(s) = Proj_T(b + delta(s))
    with delta the proximal path of ``_proximal_path``: plane 1 is the
    linearisation at b, plane 2 the bundle's second plane capped at f(b) (so the
    path leaves b along -grad f). Without a second plane it is the projected
    gradient arc Proj_T(b - s grad f).
    """

    barzilai_borwein = False

    def __init__(self, field: Field, triangles: np.ndarray, owner: np.ndarray):
        self.field = field
        self.triangles = triangles
        self.owner = owner

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        d, g = self.field.evaluate(points)
        return d, g, g

    def fresh(self, rows: np.ndarray, best: np.ndarray, phi: np.ndarray, data: np.ndarray,
              plane: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
        x2, phi2, g2 = plane
        f2 = np.minimum(phi2 + np.einsum("nd,nd->n", g2, best - x2), phi)
        return np.column_stack([best, phi, f2, data, g2])

    def path(self, rows: np.ndarray, params: np.ndarray, s: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
        delta, d_delta = _proximal_path(params[:, 2], params[:, 3], params[:, 4:6],
                                        params[:, 6:8], s)
        return _project_to_triangles(self.triangles[self.owner[rows]],
                                     params[:, None, :2] + delta, d_delta)

    def bundle_free(self, rows: np.ndarray, params: np.ndarray, probe: np.ndarray
                    ) -> np.ndarray:
        """(n,) bool: the bundle path is worth a ladder: it enters the triangle.

        That is, its first direction (-g1) or its ridge direction (-m, see
        ``_proximal_path``) is not cut by the projection at b. Where both are, b is
        on an edge with the kink leading out of the triangle: the kink is then a 1D
        V along the edge, which the steepest path's bracket resolves exactly, and a
        projected bundle path would only add breakpoints to the line search.
        """
        g1, g2 = params[:, 4:6], params[:, 6:8]
        w = g1 - g2
        ww = np.maximum(np.einsum("nd,nd->n", w, w), _TINY)
        ridge = -(g2 - (np.einsum("nd,nd->n", g2, w) / ww)[:, None] * w)
        u = np.stack([_unit_or_zero(-g1), _unit_or_zero(ridge)], axis=1)
        x = params[:, None, :2] + probe[:, :, None] * u
        _, dq = _project_to_triangles(self.triangles[self.owner[rows]], x, u)
        cut = np.einsum("nkd,nkd->nk", dq - u, dq - u) > _STATIONARY ** 2
        return ~np.all(cut, axis=1)

    def stationarity(self, data: np.ndarray) -> np.ndarray:
        # No tie-breaking: f itself is the answer, its value is what matters.
        return np.zeros(len(data))


def _triangle_minima(field: Field, triangles: np.ndarray, iterations: int,
                     starts: np.ndarray | None, tol: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``triangle_deepest`` plus the iterations each start took (T, K)."""
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 2)
    weights = START_BARYCENTRIC if starts is None else np.asarray(starts, np.float64)
    weights = weights.reshape(-1, 3)
    n_tri, n_start = len(tri), len(weights)
    if n_tri == 0:
        return np.zeros((0, n_start, 2)), np.zeros((0, n_start)), np.zeros((0, n_start), int)
    points = np.einsum("kj,tjd->tkd", weights, tri).reshape(-1, 2)
    owner = np.repeat(np.arange(n_tri), n_start)
    edge = np.roll(tri, -1, axis=1) - tri
    longest = np.sqrt(np.einsum("tkd,tkd->tk", edge, edge).max(axis=1))
    problem = _TriangleProblem(field, tri, owner)
    best, value, _, rounds = _descend(problem, points, iterations,
                                      np.maximum(longest[owner], _TINY), tol)
    return (best.reshape(n_tri, n_start, 2), value.reshape(n_tri, n_start),
            rounds.reshape(n_tri, n_start))


def triangle_deepest(field: Field, triangles: np.ndarray, iterations: int = 16,
                     starts: np.ndarray | None = None, tol: float = 1e-12
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Local minima of f over each triangle, one per start: (point (T, K, 2), value (T, K)).

    triangles: (T, 3, 2) vertices in the field's frame (m), either orientation,
    degenerate ones allowed. starts: (K, 3) barycentric weights of the starts,
    default ``START_BARYCENTRIC`` (K = 7; start id k = row k: 0-2 vertices, 3-5
    edge midpoints (v0v1, v1v2, v2v0), 6 centroid). iterations: at most this many
    descent iterations, each one ``field.evaluate`` call over every start still
    running (plus one call for the starts). tol: m, a start stops when its accepted
    step is shorter.

    point[t, k] lies in triangle t and is the best point the descent from start k
    reached: a local minimum of f over the triangle for analytic fields (to 1e-9 m
    typically, see the module docstring), never worse than the start itself.
    value[t, k] = f(point[t, k]) (m; < 0 inside the field's shape). Several starts
    may reach the same minimum: ``merge_minima`` keeps one.
    """
    point, value, _ = _triangle_minima(field, triangles, iterations, starts, tol)
    return point, value


def merge_minima(point: np.ndarray, radius: float) -> np.ndarray:
    """(T, K) bool: True for the starts to keep, one per distinct minimum of each triangle.

    point: (T, K, 2) from ``triangle_deepest``; radius: m. Start k is dropped when
    a start with a lower id (same triangle) ended within ``radius`` of it, so the
    lowest start id of each cluster is kept (a stable feature key).
    """
    p = np.asarray(point, dtype=np.float64)
    gap = p[:, :, None, :] - p[:, None, :, :]                     # (T, K, K, 2): k - j
    near = np.einsum("tkjd,tkjd->tkj", gap, gap) < radius * radius
    earlier = np.tril(np.ones(near.shape[1:], dtype=bool), k=-1)  # j < k
    return ~np.any(near & earlier, axis=2)


# --------------------------------------------------------------------------------------
# Contacts between two fields
# --------------------------------------------------------------------------------------

def _rotation(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


class _PairProblem:
    """phi = max(f_a, f_b) over the plane, b placed in a's frame by (rotation, offset).

    Point data: f_a, f_b, grad f_a, grad f_b (6 columns, a's frame). Path
    parameters: origin and its data; the path is the proximal min-max path of
    the two fields' linearisations (``_proximal_path``): steepest descent of the
    larger field until the linear models balance, then along the line where they
    are equal, down the min-norm element of {grad f_a, grad f_b} - the contact's
    tangent, where the sum f_a + f_b (minus the depth) decreases.
    """

    barzilai_borwein = True

    def __init__(self, field_a: Field, field_b: Field, rotation: np.ndarray,
                 offset: np.ndarray):
        self.field_a, self.field_b = field_a, field_b
        self.rotation, self.offset = rotation, offset

    def values(self, points: np.ndarray) -> np.ndarray:
        """(N, 6): f_a, f_b, grad f_a, grad f_b at points (N, 2) of a's frame."""
        fa, ga = self.field_a.evaluate(points)
        fb, gb = self.field_b.evaluate((points - self.offset) @ self.rotation)
        return np.column_stack([fa, fb, ga, gb @ self.rotation.T])

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        data = self.values(points)
        fa, fb, ga, gb = data[:, 0], data[:, 1], data[:, 2:4], data[:, 4:6]
        sign = np.where(fa >= fb, 1.0, -1.0)
        phi = 0.5 * (fa + fb) + _IMBALANCE * np.abs(fa - fb)
        grad = 0.5 * (ga + gb) + (_IMBALANCE * sign)[:, None] * (ga - gb)
        return phi, grad, data

    def fresh(self, rows: np.ndarray, best: np.ndarray, phi: np.ndarray, data: np.ndarray,
              plane: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
        # Own plane: phi = max(A, B) with A, B = (1/2 +- k) f_a + (1/2 -+ k) f_b,
        # k = _IMBALANCE, and the path of those two planes. A second plane (a
        # kink of f_a or f_b nearby, e.g. the centre of a circle nested in the
        # other body): the bundle path of phi's linearisation and that plane.
        fa, fb, ga, gb = data[:, 0], data[:, 1], data[:, 2:4], data[:, 4:6]
        high, low = 0.5 + _IMBALANCE, 0.5 - _IMBALANCE
        pair = np.column_stack([best, high * fa + low * fb, low * fa + high * fb,
                                high * ga + low * gb, low * ga + high * gb])
        x2, phi2, g2 = plane
        own = np.all(x2 == best, axis=1)
        sign = np.where(fa >= fb, _IMBALANCE, -_IMBALANCE)[:, None]
        g1 = 0.5 * (ga + gb) + sign * (ga - gb)
        f2 = np.minimum(phi2 + np.einsum("nd,nd->n", g2, best - x2), phi)
        bundle = np.column_stack([best, phi, f2, g1, g2])
        return np.where(own[:, None], pair, bundle)

    def path(self, rows: np.ndarray, params: np.ndarray, s: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
        delta, d_delta = _proximal_path(params[:, 2], params[:, 3], params[:, 4:6],
                                        params[:, 6:8], s)
        return params[:, None, :2] + delta, d_delta

    def bundle_free(self, rows: np.ndarray, params: np.ndarray, probe: np.ndarray
                    ) -> np.ndarray:
        return np.ones(len(rows), dtype=bool)

    def stationarity(self, data: np.ndarray) -> np.ndarray:
        """|f_a - f_b| plus the length of the min-norm element of the planes' hull.

        Both vanish at a balanced minimum (antiparallel gradients), where the
        normal is exact; used to break ties of phi at rounding level.
        """
        fa, fb, ga, gb = data[:, 0], data[:, 1], data[:, 2:4], data[:, 4:6]
        w = ga - gb
        mean = 0.5 * (ga + gb)
        ww = np.maximum(np.einsum("nd,nd->n", w, w), _TINY)
        across = mean - (np.einsum("nd,nd->n", mean, w) / ww)[:, None] * w
        return np.abs(fa - fb) + np.hypot(across[:, 0], across[:, 1])


def _halton(index: np.ndarray, base: int) -> np.ndarray:
    """Radical inverse of the integers ``index`` (n,) in ``base``: values in [0, 1)."""
    result = np.zeros(len(index))
    fraction = 1.0 / base
    i = index.astype(np.int64).copy()
    while np.any(i > 0):
        result += fraction * (i % base)
        i //= base
        fraction /= base
    return result


def _clusters(point: np.ndarray, key: np.ndarray, score: np.ndarray, tiebreak: np.ndarray,
              radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Merge points closer than radius: (head (C,), best (C,)) indices into the K points.

    Each point joins the lowest-key point within radius of it (itself if none is
    lower); per cluster, ``head`` is that lowest-key point (its key names the
    cluster) and ``best`` the member to report: lowest score, and among scores
    equal to rounding, lowest tiebreak.
    """
    gap = point[:, None, :] - point[None, :, :]
    near = np.einsum("kjd,kjd->kj", gap, gap) < radius * radius
    leader = np.argmin(np.where(near, key[None, :], np.iinfo(np.int64).max), axis=1)
    head = np.flatnonzero(leader == np.arange(len(point)))
    member = leader[None, :] == head[:, None]                          # (C, K)
    lowest = np.min(np.where(member, score[None, :], np.inf), axis=1, keepdims=True)
    rounding = 4.0 * _EPS * np.maximum(1.0, np.abs(lowest))
    member &= score[None, :] <= lowest + rounding
    best = np.argmin(np.where(member, tiebreak[None, :], np.inf), axis=1)
    return head, best


def _patch_ends(problem: _PairProblem, centre: np.ndarray, normal: np.ndarray,
                depth: np.ndarray, sliver: float, reach: float, iterations: int,
                tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Extent of each contact's patch along its tangent: (s (K, 2), found (K, 2)).

    centre: (K, 2) midway points, normal (K, 2), depth (K,). Shifting b by
    (depth - sliver) along the normal leaves an overlap only where the two
    surfaces are within ``sliver`` of the full depth of each other: a sliver of
    thickness ``sliver`` just inside a's surface, over the flat part of the
    contact patch (two parallel faces), a point-like lens where a surface is
    curved. Its ends along t = perp(n) are the roots of
    h(s) = max(f_a(x(s)), f_b(x(s) - shift)), x(s) = m + s t, m in the middle of
    the sliver, found by a safeguarded Newton / regula falsi / bisection search
    on [0, reach] (h(0) < 0 < h(reach)) in both directions at once. Column 0 is
    the -t end, column 1 the +t end (s >= 0 along its direction); ``found`` is
    False where the sliver is empty at m (depth overestimated).
    """
    n_contacts = len(depth)
    tangent = np.column_stack([-normal[:, 1], normal[:, 0]])
    direction = np.concatenate([-tangent, tangent])                     # (2K, 2)
    middle = centre + (0.5 * depth - 0.5 * sliver)[:, None] * normal
    origin = np.concatenate([middle, middle])
    shift = np.concatenate([(depth - sliver)[:, None] * normal] * 2)

    def h(s: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = origin[rows] + s[:, None] * direction[rows]
        fa, ga = problem.field_a.evaluate(x)
        fb, gb = problem.field_b.evaluate((x - shift[rows] - problem.offset) @ problem.rotation)
        slope = np.where(fa >= fb, np.einsum("nd,nd->n", ga, direction[rows]),
                         np.einsum("nd,nd->n", gb @ problem.rotation.T, direction[rows]))
        return np.maximum(fa, fb), slope

    everything = np.arange(2 * n_contacts)
    h_lo = h(np.zeros(2 * n_contacts), everything)[0]
    lo = np.zeros(2 * n_contacts)
    hi = np.full(2 * n_contacts, reach)
    h_hi, d_hi = h(hi, everything)
    found = h_lo < 0.0
    active = found & (h_hi > 0.0)
    lo[found & ~active] = reach
    for _ in range(iterations):
        rows = np.flatnonzero(active & (hi - lo > tol))
        if len(rows) == 0:
            break
        a, b = lo[rows], hi[rows]
        width = b - a
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = b - h_hi[rows] / d_hi[rows]
            falsi = a - h_lo[rows] * width / (h_hi[rows] - h_lo[rows])
        trials = np.stack([newton, falsi, a + 0.5 * width], axis=1)
        trials = np.where(np.isfinite(trials), trials, (a + 0.5 * width)[:, None])
        trials = np.sort(np.clip(trials, a[:, None] + 1e-3 * width[:, None],
                                 b[:, None] - 1e-3 * width[:, None]), axis=1)
        value, slope = h(trials.ravel(), np.repeat(rows, 3))
        value, slope = value.reshape(-1, 3), slope.reshape(-1, 3)
        # The new bracket: the last trial with h < 0 and the first with h >= 0 after it.
        inside = value < 0.0
        last_in = np.where(inside.any(axis=1), 2 - np.argmax(inside[:, ::-1], axis=1), -1)
        first_out = np.where(~inside & (np.arange(3) > last_in[:, None]), np.arange(3), 3).min(1)
        at = np.arange(len(rows))
        moved_lo = last_in >= 0
        lo[rows] = np.where(moved_lo, trials[at, np.maximum(last_in, 0)], a)
        h_lo[rows] = np.where(moved_lo, value[at, np.maximum(last_in, 0)], h_lo[rows])
        moved_hi = first_out < 3
        hi[rows] = np.where(moved_hi, trials[at, np.minimum(first_out, 2)], b)
        h_hi[rows] = np.where(moved_hi, value[at, np.minimum(first_out, 2)], h_hi[rows])
        d_hi[rows] = np.where(moved_hi, slope[at, np.minimum(first_out, 2)], d_hi[rows])
    return lo.reshape(2, n_contacts).T, found.reshape(2, n_contacts).T


def field_field_contacts(field_a: Field, field_b: Field, pose_b_in_a: Sequence[float],
                         region: Sequence[float], n_starts: int = 16, iterations: int = 24,
                         margin: float = 0.0
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Contacts between two fields: (point (K, 2), depth (K,), normal (K, 2), start_id (K,)).

    pose_b_in_a: (x, y, angle) placing b's frame in a's (p_a = R(angle) p_b + (x, y),
    m, rad). region: (4,) finite box (xmin, ymin, xmax, ymax) in a's frame where
    the bodies may overlap (the overlap of their bounds; grown by the margin for
    speculative contacts). n_starts: starts over the region, the Halton (2, 3)
    points 1..n_starts (a fixed pattern: start id k is always the same relative
    place). iterations: descent iterations (each one evaluation of each field).
    margin: m, contacts with depth > -margin are reported.

    Method (Liu et al. 2024, MuJoCo's SDF-SDF collision): every start descends
    phi = max(f_a, f_b) (see ``_PairProblem``), whose minima are the points
    deepest in both bodies. A converged point p with f_a, f_b is a contact when
    max(f_a, f_b) < margin / 2 (so f_a + f_b < margin), with

    - depth = -(f_a(p) + f_b(p)): the overlap's thickness along the normal. On
      the segment between two circles' centres f_a + f_b = |c_b - c_a| - r_a - r_b,
      so it is exact for circles (also nested, or coincident), for a circle and
      any exact field (r - f(c)), and for two parallel faces; elsewhere it is the
      first-order estimate from the distances to the two surfaces.
    - normal: from a toward b, normalize(grad f_a - grad f_b) where the two fields
      balance (|f_a - f_b| <= 1e-9 per metre of region); where one field is
      clearly larger, p sits at that field's deepest point (a kink, where its
      gradient says nothing) and the other field gives it: -grad f_b if f_a > f_b,
      else grad f_a. Never NaN (``safe_normalize``'s fallback for a zero vector).
    - point: p moved to midway between the two surfaces along the normal,
      p + (f_b - f_a) / 2 n (a's surface at p - f_a n, b's at p + f_b n).

    Contacts of different starts within 1e-3 of the region's diagonal are one
    (the lowest start id is kept). Then each contact's patch is measured along
    its tangent (``_patch_ends``): where the two surfaces stay parallel at the
    full depth (a box resting on a box) the contact is replaced by the two ends
    of that flat patch, with the same depth and normal, ids n_starts + 2k (the -t
    end, t = perp(n)) and n_starts + 2k + 1 (the +t end) for start k; merged
    again by distance. Ids are < n_starts * 3.

    Limits: a start may stop at a local minimum of max(f_a, f_b) that is not a
    contact (it is then dropped); two contacts closer than the merge distance are
    one; a slightly tilted flat contact reports its deepest end only.
    """
    region = np.asarray(region, dtype=np.float64).reshape(4)
    empty = (np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), np.zeros(0, dtype=np.int64))
    if not np.all(np.isfinite(region)):
        raise ValueError(f"region must be finite, got {region}")
    lo, hi = region[:2], region[2:]
    if np.any(hi < lo) or n_starts < 1:
        return empty
    x, y, angle = (float(v) for v in pose_b_in_a)
    problem = _PairProblem(field_a, field_b, _rotation(angle), np.array([x, y]))
    diagonal = float(np.hypot(*(hi - lo)))
    scale = max(diagonal, _TINY)

    # Starts and descent.
    index = np.arange(1, n_starts + 1)
    starts = lo + (hi - lo) * np.column_stack([_halton(index, 2), _halton(index, 3)])
    best, phi, data, _ = _descend(problem, starts, iterations, np.full(n_starts, 0.25 * scale),
                                  1e-12 * scale)
    fa, fb, ga, gb = data[:, 0], data[:, 1], data[:, 2:4], data[:, 4:6]
    hit = phi < 0.5 * margin
    balanced = np.abs(fa - fb) <= 1e-9 * scale
    normal = np.where(balanced[:, None], ga - gb, np.where((fa > fb)[:, None], -gb, ga))
    normal = safe_normalize(normal)
    depth = -(fa + fb)
    point = best + (0.5 * (fb - fa))[:, None] * normal
    start_id = np.arange(n_starts)
    hits = np.flatnonzero(hit)
    if len(hits) == 0:
        return empty
    head, chosen = _clusters(best[hits], start_id[hits], phi[hits],
                             problem.stationarity(data[hits]), _MERGE * scale)
    take = hits[chosen]
    point, depth, normal, start_id = point[take], depth[take], normal[take], start_id[hits[head]]

    # Flat patches: replace a contact by the two ends of its patch when either is far.
    radius = _MERGE * scale
    sliver = _SLIVER * scale
    ends, found = _patch_ends(problem, point, normal, depth, sliver, 2.0 * scale,
                              iterations, 1e-12 * scale)
    flat = np.any(found & (ends > radius), axis=1)
    tangent = np.column_stack([-normal[:, 1], normal[:, 0]])
    end_point = np.concatenate([point - ends[:, :1] * tangent, point + ends[:, 1:] * tangent])
    end_id = np.concatenate([n_starts + 2 * start_id, n_starts + 2 * start_id + 1])
    two = np.concatenate([flat, flat])
    point = np.concatenate([point[~flat], end_point[two]])
    depth = np.concatenate([depth[~flat], np.concatenate([depth, depth])[two]])
    normal = np.concatenate([normal[~flat], np.concatenate([normal, normal])[two]])
    start_id = np.concatenate([start_id[~flat], end_id[two]])
    head, chosen = _clusters(point, start_id, -depth, start_id.astype(np.float64), radius)
    return point[chosen], depth[chosen], normal[chosen], start_id[head]
