"""Compiled set-up of ``descent``: where the starts are, what is known of a triangle,
and the state the descent rounds (``_descent_kernels``) begin from and end in.

- ``triangle_starts``: the starts of triangles at barycentric weights, with their step
  scales and which vertex (if any) each sits on.
- ``triangle_known`` (with ``_cuts`` and ``_model_value``): what f is over a triangle
  from its values and gradients at the starts (a plane, a cone, or the cuts of the
  planes seen), which ``propose`` uses to reach the model's minimiser.
- ``initialize`` and ``results``: the descent's state and flags (columns named in
  ``_descent_kernels``) before the first round, and the best points after the last.
- ``hidden_dips``, ``present_dips``, ``with_dips``, ``pick_starts`` and
  ``gather_starts``: starts chosen by sampling a lattice of the triangle
  (``settings.descent_lattice``; ``lattice.triangle_deepest_sampled``).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ._descent_paths import (
    ALT,
    BEST,
    CONE,
    CUTS,
    GRAD,
    N_FLAGS,
    PHI,
    PLANE,
    PREVIOUS,
    ROUNDS,
    SIGMA,
    TINY,
    _max,
    _norm,
    _vertices,
    project,
)

__all__ = ["gather_starts", "hidden_dips", "initialize", "pick_starts", "present_dips",
           "results", "triangle_known", "triangle_starts", "with_dips"]

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
# Starts chosen by sampling (``lattice.triangle_deepest_sampled``)
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

