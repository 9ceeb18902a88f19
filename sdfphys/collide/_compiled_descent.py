"""The triangle descent with its field compiled in: every round inside one numba call.

``descent._descend`` alternates two compiled kernels (``_descent_kernels.propose``
and ``accept``) with a Python ``field.evaluate`` per round; for the few hundred
points of a physics step, the numpy overhead of the evaluation (~30 us per node
of the field's tree) dominates. When the field compiles to a stack-machine
program (``sdfphys.sdf.compiled``), :func:`descend_triangles` runs the same loop
(the starts' evaluation, ``initialize``, ``triangle_known``, ``bound``, then
``propose`` -> evaluate -> ``accept`` rounds) with the program evaluated per point
in the same compiled code: a query costs one Python call whatever the number of
rounds. The kernels and their arguments are those of the Python-driven loop, in
the same order, so the results are the same (to the last bit where the program
rounds as numpy does, see ``sdf.compiled``).

Only the triangle problem with one ``tol`` for all starts (``triangle_deepest``)
runs here; the field-field problem (two fields, per-pair placements, per-start
tolerances) stays on the Python-driven loop.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..sdf.compiled import eval_point
from ._descent_kernels import accept, bound, initialize, propose, results, \
    triangle_known

__all__ = ["descend_triangles"]


@njit(cache=True, error_model="numpy")
def _grown(rows: np.ndarray, n: int) -> np.ndarray:
    """``rows`` if it has at least n rows, else a new (max(n, 2 len), width) array."""
    if rows.shape[0] >= n:
        return rows
    return np.empty((max(n, 2 * rows.shape[0]), rows.shape[1]), dtype=rows.dtype)


@njit(cache=True, error_model="numpy")
def descend_triangles(kind: int, barzilai_borwein: bool, code: np.ndarray, consts: np.ndarray, depth: int, nesting: int,
                      tri: np.ndarray, owner: np.ndarray, at_vertex: np.ndarray, n_start: int,
                      spanning: bool, convex: bool, points: np.ndarray, sigma: np.ndarray,
                      iterations: int, tol: float, shape_tol: float, state: np.ndarray,
                      flags: np.ndarray, running: np.ndarray, cand: np.ndarray,
                      cand_i: np.ndarray, candidates: np.ndarray):
    """``descent._descend`` of the triangle problem, the field given by its program.

    kind, barzilai_borwein: ``TRIANGLE`` and False, passed in (not constants) so that
    the kernels are the same compiled functions as the Python-driven loop's (a
    literal argument would compile them again, costing seconds at a cold start).
    code, consts, depth, nesting: ``sdf.compiled.Program``. tri (T, 3, 2), owner
    (P,), at_vertex (T, 3), n_start, spanning, convex: as ``descent._TriangleProblem``;
    points (P, 2) the starts, sigma (P,) their first step scales, iterations the
    round budget, tol (m) the step below which a start stops, shape_tol the
    tolerance of ``triangle_known``. Work arrays (contents undefined, reused
    between calls): state (P, N_STATE), flags (P, N_FLAGS), running (P,), and the
    round buffers cand (C, 5), cand_i (C, 2) int64 and candidates (C, 2) (the
    points to evaluate), grown here when a round needs more.

    Returns best (P, 2), phi (P,), data (P, 2) (the gradient at best), rounds (P,),
    the number of points evaluated, and the round buffers (possibly grown).
    """
    n_points = points.shape[0]
    stack = np.empty((depth, 3))
    frames = np.empty((nesting, 2))
    phi = np.empty(n_points)
    grad = np.empty((n_points, 2))
    for i in range(n_points):
        phi[i], grad[i, 0], grad[i, 1] = eval_point(code, consts, points[i, 0], points[i, 1],
                                                    stack, frames)
    data = grad.copy()                                   # updated in place by accept
    initialize(points, phi, grad, sigma, state, flags)
    corner, shape = triangle_known(tri, at_vertex, points, phi, grad, n_start, spanning, convex,
                                   shape_tol)
    for i in range(n_points):
        running[i] = i
    n_running = n_points
    size = bound(kind, owner, shape, state, flags, running[:n_running])
    evaluated = n_points
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
        value = np.empty(n_eval)
        gradient = np.empty((n_eval, 2))
        for j in range(n_eval):
            value[j], gradient[j, 0], gradient[j, 1] = eval_point(
                code, consts, candidates[j, 0], candidates[j, 1], stack, frames)
        evaluated += n_eval
        n_running, size = accept(kind, tri, owner, corner, state, flags, data, cand[:size],
                                 cand_i[:size], value, gradient, gradient, tol,
                                 running[:n_running], shape, shape_tol)
    best, phi, rounds = results(state, flags)
    return best, phi, data, rounds, evaluated, cand, cand_i, candidates
