"""The descent with its fields compiled in: every round inside one numba call.

``descent._descend`` alternates two compiled kernels (``_descent_kernels.propose``
and ``accept``) with a Python problem evaluation per round; for the few hundred
points of a physics step, the numpy overhead of a field evaluation (~30 us per
node of the field's tree) dominates. When the fields compile to stack-machine
programs (``sdfphys.sdf.compiled``), :func:`descend` runs the same loop (the
starts' evaluation, ``initialize``, ``triangle_known``, ``bound``, then rounds of
``propose`` -> evaluate -> ``accept``, and the per-start tolerances) with the
programs evaluated per point in the same compiled code: a query costs one Python
call whatever the number of rounds. The kernels and their arguments are those of
the Python-driven loop, in the same order, so the results are the same (to the
last bit where the programs round as numpy does, see ``sdf.compiled``).

Both problems of ``descent``:

- ``TRIANGLE`` (``descent._TriangleProblem``): f of program a over triangles;
  phi = f, data = grad f (2 columns).
- ``PAIR`` (``descent._PairProblem``): fields a and b, pair k placing b in a's
  frame by p_a = R_k p_b + o_k; a point of start i belongs to pair
  ``pair_of[i]``. At a point p of a's frame, with q = R^T (p - o) (b's frame):
  data = (f_a(p), f_b(q), grad f_a(p), R grad f_b(q)) (6 columns) and
  phi = (f_a + f_b) / 2 + IMBALANCE |f_a - f_b|,
  grad phi = (grad f_a + grad f_b) / 2 + IMBALANCE sign(f_a - f_b) (grad f_a - grad f_b)
  with sign(0) = +1, as ``_PairProblem.evaluate`` computes them.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..sdf.compiled import eval_point
from ._descent_kernels import (
    AT_BEST, BEST, COUNT, HAS_PREVIOUS, IMBALANCE, TRIANGLE, accept, bound, initialize, propose,
    results, triangle_known,
)

__all__ = ["descend"]


@njit(cache=True, error_model="numpy")
def _grown(rows: np.ndarray, n: int) -> np.ndarray:
    """``rows`` if it has at least n rows, else a new (max(n, 2 len), width) array."""
    if rows.shape[0] >= n:
        return rows
    return np.empty((max(n, 2 * rows.shape[0]), rows.shape[1]), dtype=rows.dtype)


@njit(cache=True, error_model="numpy")
def _evaluate(kind: int, code_a: np.ndarray, consts_a: np.ndarray, stack_a: np.ndarray,
              frames_a: np.ndarray, code_b: np.ndarray, consts_b: np.ndarray,
              stack_b: np.ndarray, frames_b: np.ndarray, rotation: np.ndarray,
              offset: np.ndarray, points: np.ndarray, pair: np.ndarray, n: int,
              phi: np.ndarray, grad: np.ndarray, data: np.ndarray) -> None:
    """The problem at points[:n] (of pairs pair[:n], PAIR): phi, grad phi, data rows.

    The operations are those of ``descent._PairProblem.values`` / ``evaluate``
    (``_times`` writes v @ M as v_x M_0j + v_y M_1j).
    """
    for j in range(n):
        x, y = points[j, 0], points[j, 1]
        fa, gax, gay = eval_point(code_a, consts_a, x, y, stack_a, frames_a)
        if kind == TRIANGLE:
            phi[j], grad[j, 0], grad[j, 1] = fa, gax, gay
            data[j, 0], data[j, 1] = gax, gay
            continue
        k = pair[j]
        r00, r01, r10, r11 = rotation[k, 0, 0], rotation[k, 0, 1], rotation[k, 1, 0], \
            rotation[k, 1, 1]
        px, py = x - offset[k, 0], y - offset[k, 1]
        fb, gbx, gby = eval_point(code_b, consts_b, px * r00 + py * r10, px * r01 + py * r11,
                                  stack_b, frames_b)
        gbx, gby = gbx * r00 + gby * r01, gbx * r10 + gby * r11    # times the transpose
        data[j, 0], data[j, 1], data[j, 2], data[j, 3], data[j, 4], data[j, 5] = \
            fa, fb, gax, gay, gbx, gby
        sign = 1.0 if fa >= fb else -1.0
        phi[j] = 0.5 * (fa + fb) + IMBALANCE * abs(fa - fb)
        grad[j, 0] = 0.5 * (gax + gbx) + (IMBALANCE * sign) * (gax - gbx)
        grad[j, 1] = 0.5 * (gay + gby) + (IMBALANCE * sign) * (gay - gby)


@njit(cache=True, error_model="numpy")
def descend(kind: int, barzilai_borwein: bool, kd: int,
            code_a: np.ndarray, consts_a: np.ndarray, depth_a: int, nesting_a: int,
            code_b: np.ndarray, consts_b: np.ndarray, depth_b: int, nesting_b: int,
            rotation: np.ndarray, offset: np.ndarray, pair_of: np.ndarray,
            tri: np.ndarray, owner: np.ndarray, at_vertex: np.ndarray, n_start: int,
            spanning: bool, convex: bool, points: np.ndarray, sigma: np.ndarray,
            iterations: int, tol: np.ndarray, shape_tol: float, state: np.ndarray,
            flags: np.ndarray, running: np.ndarray, cand: np.ndarray, cand_i: np.ndarray,
            candidates: np.ndarray):
    """``descent._descend`` of a problem given by its fields' programs (module docstring).

    kind, barzilai_borwein, kd: the problem's kind, whether it uses the
    Barzilai-Borwein scale, its data width (2 TRIANGLE, 6 PAIR); passed in, not
    constants, so that the kernels are the same compiled functions as the
    Python-driven loop's (a literal argument would compile them again, costing
    seconds at a cold start). code_*, consts_*, depth_*, nesting_*: the programs
    (``sdf.compiled.Program``) of field a and, for PAIR, field b (any program for
    TRIANGLE). rotation (L, 2, 2), offset (L, 2), pair_of (P,): the placements of
    b and each start's pair (PAIR; unused for TRIANGLE). tri (T, 3, 2), owner (P,),
    at_vertex (T, 3), n_start, spanning, convex: as ``descent._TriangleProblem``
    (for PAIR: one dummy triangle, owner empty). points (P, 2): the starts, sigma
    (P,) their first step scales, iterations the round budget, tol (P,) (m) the
    step below which each start stops, shape_tol the tolerance of
    ``triangle_known``. Work arrays (contents undefined, reused between calls):
    state (P, N_STATE), flags (P, N_FLAGS), running (P,), and the round buffers
    cand (C, 5), cand_i (C, 2) int64 and candidates (C, 2), grown here when a
    round needs more.

    Returns best (P, 2), phi (P,), data (P, kd) at best, rounds (P,), the number
    of points evaluated, and the round buffers (possibly grown).
    """
    n_points = points.shape[0]
    stack_a = np.empty((depth_a, 3))
    frames_a = np.empty((nesting_a, 2))
    stack_b = np.empty((depth_b, 3))
    frames_b = np.empty((nesting_b, 2))
    phi = np.empty(n_points)
    grad = np.empty((n_points, 2))
    data = np.empty((n_points, kd))                      # updated in place by accept
    _evaluate(kind, code_a, consts_a, stack_a, frames_a, code_b, consts_b, stack_b, frames_b,
              rotation, offset, points, pair_of, n_points, phi, grad, data)
    least = np.inf
    most = -np.inf
    for i in range(n_points):
        least = min(least, tol[i])
        most = max(most, tol[i])
    uneven = n_points > 0 and most > least
    initialize(points, phi, grad, sigma, state, flags)
    if kind == TRIANGLE:
        corner, shape = triangle_known(tri, at_vertex, points, phi, grad, n_start, spanning,
                                       convex, shape_tol)
    else:
        corner, shape = np.full((1, 3, 3), np.nan), np.zeros((1, 4))
    for i in range(n_points):
        running[i] = i
    n_running = n_points
    size = bound(kind, owner, shape, state, flags, running[:n_running])
    evaluated = n_points
    value = np.empty(0)
    gradient = np.empty((0, 2))
    cand_data = np.empty((0, kd))
    pair = np.empty(0, dtype=np.int64)
    before = np.empty((n_points if uneven else 0, 2))
    for _ in range(iterations):
        if size == 0:
            break
        cand = _grown(cand, size)
        cand_i = _grown(cand_i, size)
        candidates = _grown(candidates, size)
        n, n_eval, n_running = propose(kind, tri, owner, corner, shape, state, flags, data,
                                       barzilai_borwein, running[:n_running], cand[:size],
                                       cand_i[:size], candidates[:size])
        if n == 0:
            break
        if value.shape[0] < n_eval:
            m = max(n_eval, 2 * value.shape[0])
            value, gradient, cand_data = np.empty(m), np.empty((m, 2)), np.empty((m, kd))
            pair = np.empty(m, dtype=np.int64)
        if kind != TRIANGLE:
            # The pair of each evaluated point: the starts wrote their candidates one
            # after the other (flags[i, COUNT] each); a source >= 0 is a point's row.
            row = 0
            for r in range(n_running):
                i = running[r]
                for _c in range(flags[i, COUNT]):
                    source = cand_i[row, 1]
                    if source > AT_BEST:
                        pair[source] = pair_of[i]
                    row += 1
        _evaluate(kind, code_a, consts_a, stack_a, frames_a, code_b, consts_b, stack_b,
                  frames_b, rotation, offset, candidates, pair, n_eval, value, gradient,
                  cand_data)
        evaluated += n_eval
        if uneven:
            for r in range(n_running):
                i = running[r]
                before[i, 0], before[i, 1] = state[i, BEST], state[i, BEST + 1]
        n_running, size = accept(kind, tri, owner, corner, state, flags, data, cand[:size],
                                 cand_i[:size], value[:n_eval], gradient[:n_eval],
                                 cand_data[:n_eval], least, running[:n_running], shape,
                                 shape_tol)
        if uneven:
            kept = 0
            for r in range(n_running):
                i = running[r]
                dx, dy = state[i, BEST] - before[i, 0], state[i, BEST + 1] - before[i, 1]
                moved = np.sqrt(dx * dx + dy * dy)
                if not (flags[i, HAS_PREVIOUS] != 0 and moved < tol[i]):
                    running[kept] = i
                    kept += 1
            if kept < n_running:
                n_running = kept
                size = bound(kind, owner, shape, state, flags, running[:n_running])
    best, phi, rounds = results(state, flags)
    return best, phi, data, rounds, evaluated, cand, cand_i, candidates
