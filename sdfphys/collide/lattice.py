"""Starts chosen by sampling (``Settings.descent_lattice``): a triangle-field query
that samples f on each triangle's barycentric lattice and descends from the lowest
samples and hidden dips, instead of the fixed starts of ``descent.triangle_deepest``.

The lattice and its neighbour pairs are built once per degree; the starts' choice and
the dips are compiled (``_descent_starts``), and with fields that compile the whole
query is one call (``_compiled_descent.descend_sampled``); a field that does not compile
keeps the Python-driven loop, the reference of the tests.
"""

from __future__ import annotations

import numpy as np

from ..sdf import Field
from ..sdf.compiled import compile_field
from . import _descent_starts as start_kernels
from . import descent
from ._compiled_descent import descend_sampled

__all__ = ["HIDDEN_DIPS", "lattice_size", "triangle_deepest_sampled"]

_LATTICES: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _lattice(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """The barycentric lattice of a degree: weights (N, 3) = (a, b, c) / degree over
    a + b + c = degree, a descending then b descending (N = (degree + 1)(degree + 2) / 2;
    weight 1 exactly at the vertices), and each point's lattice neighbours (N, 6),
    -1 padded: one unit moved between two of a, b, c (cached)."""
    if degree not in _LATTICES:
        index = [(a, b, degree - a - b) for a in range(degree, -1, -1)
                 for b in range(degree - a, -1, -1)]
        where = {abc: n for n, abc in enumerate(index)}
        neighbours = np.full((len(index), 6), -1, dtype=np.int64)
        moves = ((1, -1, 0), (-1, 1, 0), (1, 0, -1), (-1, 0, 1), (0, 1, -1), (0, -1, 1))
        for n, (a, b, c) in enumerate(index):
            near = [where[m] for m in ((a + x, b + y, c + z) for x, y, z in moves) if m in where]
            neighbours[n, :len(near)] = near
        _LATTICES[degree] = (np.ascontiguousarray(np.array(index, dtype=np.float64) / degree),
                             neighbours)
    return _LATTICES[degree]


#: Hidden dips (``_descent_starts.hidden_dips``: a local minimum between two lattice
#: samples that neither shows) evaluated per triangle as extra start candidates.
HIDDEN_DIPS = 2

_EDGES: dict[int, np.ndarray] = {}


def _lattice_edges(degree: int) -> np.ndarray:
    """(E, 2) int64: the lattice's neighbour pairs (c, n), c < n, in order (cached)."""
    if degree not in _EDGES:
        _, neighbours = _lattice(degree)
        pairs = sorted({(c, int(n)) for c in range(len(neighbours)) for n in neighbours[c]
                        if n > c})
        _EDGES[degree] = np.array(pairs, dtype=np.int64).reshape(-1, 2)
    return _EDGES[degree]


def lattice_size(degree: int) -> int:
    """Samples per triangle of the lattice of ``degree``: (degree + 1)(degree + 2) / 2."""
    return (degree + 1) * (degree + 2) // 2


def triangle_deepest_sampled(field: Field, triangles: np.ndarray, degree: int, n_starts: int,
                             iterations: int = 16, tol: float = 1e-12
                             ) -> tuple[np.ndarray, np.ndarray]:
    """``triangle_deepest`` from starts chosen by sampling: (point (T, K, 2), value (T, K)).

    f is evaluated at the (degree + 1)(degree + 2) / 2 points of each triangle's
    barycentric lattice of ``degree`` (>= 1; its vertices included), then at up
    to HIDDEN_DIPS hidden dips: places between two neighbouring samples where the
    cubic through their values and slopes has a local minimum that neither sample
    shows (``_descent_starts.hidden_dips``; a vertex that is a local minimum with
    a deeper dip 10 % along an edge). The starts are K = min(n_starts, N) samples
    or dips taken by increasing value, skipping those within one lattice spacing
    (longest edge / degree) of one already taken: first the discrete local minima
    (no lattice neighbour lower: one per separate dip) and the hidden dips, then
    the other samples, then, when too few are left, the lowest of the rest
    (``_descent_starts.pick_starts``). Start rank k = column k
    (rank 0: the lowest sample of all; ``merge_minima`` keeps the lowest rank of a
    cluster). What the samples tell of f over the triangle (vertex values, a
    plane, a cone, see ``_descent_starts.triangle_known``) is read from all N
    samples; not a convex field's cutting-plane model (O(N^3) over N samples:
    costlier than the descents it saves). Each start
    then descends as in ``triangle_deepest`` (iterations, tol the same). Costs N
    evaluations per triangle plus K descents: with fields that compile, one
    compiled call (``_compiled_descent.descend_sampled``); otherwise the Python
    loop (one ``field.evaluate`` for the samples, one for the starts, then one
    per round), with the same results.
    """
    if degree < 1 or n_starts < 1:
        raise ValueError(f"degree and n_starts must be >= 1, got {degree}, {n_starts}")
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 2)
    weights, neighbours = _lattice(int(degree))
    edges = _lattice_edges(int(degree))
    n_sample = len(weights)
    with_slots = np.vstack([neighbours, np.full((HIDDEN_DIPS, neighbours.shape[1]), -1)])
    k = min(int(n_starts), n_sample)
    n_tri = len(tri)
    if n_tri == 0:
        return np.zeros((0, k, 2)), np.zeros((0, k))
    tri = np.ascontiguousarray(tri)
    program = compile_field(field)
    if program is not None:
        best, value, _, _ = descend_sampled(
            program.code, program.consts, program.depth, program.nesting, tri, weights,
            with_slots, edges, 1.0 / degree, k, iterations, float(tol), descent.SHAPE_TOL,
            descent.work())
        return best.reshape(n_tri, k, 2), value.reshape(n_tri, k)
    spoints, _, ssigma, sat = start_kernels.triangle_starts(tri, weights)
    sphi, sgrad = field.evaluate(spoints)
    sphi = np.ascontiguousarray(sphi, dtype=np.float64)
    sgrad = np.ascontiguousarray(sgrad, dtype=np.float64)
    known = start_kernels.triangle_known(tri, sat, spoints, sphi, sgrad, n_sample, True, False,
                                         descent.SHAPE_TOL)
    dip_points, dip_place = start_kernels.present_dips(start_kernels.hidden_dips(
        spoints, sphi, sgrad, n_sample, edges, HIDDEN_DIPS))
    dip_phi, dip_grad = field.evaluate(dip_points)
    spoints, sphi, sgrad, ssigma = start_kernels.with_dips(
        spoints, sphi, sgrad, ssigma, n_sample, HIDDEN_DIPS, dip_points, dip_place,
        np.ascontiguousarray(dip_phi, dtype=np.float64),
        np.ascontiguousarray(dip_grad, dtype=np.float64))
    chosen = start_kernels.pick_starts(sphi, spoints, ssigma, n_sample + HIDDEN_DIPS,
                                       with_slots, 1.0 / degree, k, n_sample)
    points, _, _, sigma, owner = start_kernels.gather_starts(
        n_sample + HIDDEN_DIPS, chosen, spoints, sphi, sgrad, ssigma)
    problem = descent._TriangleProblem(field, tri, owner, _no_vertex_starts(n_tri), k, False)
    problem.known = lambda *_: known                          # read from the samples
    problem.programs = lambda: None                           # the Python loop
    best, value, _, _ = descent._descend(problem, points, iterations, sigma, tol)
    return best.reshape(n_tri, k, 2), value.reshape(n_tri, k)


def _no_vertex_starts(n_tri: int) -> np.ndarray:
    """at_vertex (T, 3) with no start at a vertex (-1)."""
    return np.full((n_tri, 3), -1, dtype=np.int64)
