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
last bit where the programs round as numpy does, see ``sdf.compiled``). The
field-field contacts' merges and patch search after the descent
(``field_contacts``, ``patch_ends``) and two triangle helpers are compiled here too.

Both problems of ``descent``:

- ``TRIANGLE`` (``descent._TriangleProblem``): f of program a over triangles;
  phi = f, data = grad f (2 columns).
- ``PAIR`` (``field_pairs._PairProblem``): fields a and b, pair k placing b in a's
  frame by p_a = R_k p_b + o_k; a point of start i belongs to pair
  ``pair_of[i]``. At a point p of a's frame, with q = R^T (p - o) (b's frame):
  data = (f_a(p), f_b(q), grad f_a(p), R grad f_b(q)) (6 columns) and
  phi = (f_a + f_b) / 2 + IMBALANCE |f_a - f_b|,
  grad phi = (grad f_a + grad f_b) / 2 + IMBALANCE sign(f_a - f_b) (grad f_a - grad f_b)
  with sign(0) = +1, as ``_PairProblem.evaluate`` computes them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.experimental import structref

from .._bundles import PlainFields
from .._jit import njit
from .._shared_kernel import F1, F2, F3, I1, I2, shared
from ..sdf.compiled import run_shared, scratch
from ..sdf.program_table import ProgramTable
from ._descent_kernels import (
    accept_shared,
    bound,
    propose_shared,
)
from ._descent_paths import (
    AT_BEST,
    BEST,
    COUNT,
    HAS_PREVIOUS,
    IMBALANCE,
    N_FLAGS,
    N_STATE,
    TRIANGLE,
)
from ._descent_starts import (
    gather_starts,
    hidden_dips,
    initialize,
    pick_starts,
    present_dips,
    results,
    triangle_known,
    triangle_starts,
    with_dips,
)
from ._runs import run_starts

__all__ = ["PROBLEM_FIELDS", "WORK_FIELDS", "DescentProblem", "DescentWork", "descend",
           "descend_sampled", "descent_problem", "descent_work", "enclosing_circles",
           "merge_minima"]


@njit(cache=True, error_model="numpy")
def _grown(rows: np.ndarray, n: int) -> np.ndarray:
    """``rows`` if it has at least n rows, else a new array of max(n, 2 len) rows of the
    same width (1-D or 2-D)."""
    if rows.shape[0] >= n:
        return rows
    return np.empty((max(n, 2 * rows.shape[0]),) + rows.shape[1:], dtype=rows.dtype)


#: Points per field evaluation inside ``_evaluate``: the program's work arrays stay in
#: the cache, and a round's thousands of points need no large fresh arrays (their
#: page faults cost more than the evaluation). Each point's result does not depend
#: on the batch it is in.
_CHUNK = 256
#: Starts per block of ``descend`` (rounded down to whole triangles). A block's
#: round buffers stay small: 10,000-triangle queries of a curved field (most starts
#: running several rounds) take 12 % less time in blocks of 8192 to 32768 starts
#: than all at once (blocks of 512: no gain, the rounds' fixed costs add up).
_BLOCK = 8192
#: Triangles per block of ``descend_sampled``'s sampling (a few hundred kB of samples).
_SAMPLE_BLOCK = 512


@structref.register
class _DescentProblemType(PlainFields):
    """Numba's type of ``DescentProblem``."""


class DescentProblem(structref.StructRefProxy):
    """A descent's problem (module docstring) as ``descend`` and ``_rounds`` take it, by
    reference; made by ``descent_problem`` (one maker call per descent), opaque to
    Python.

    kind: int, ``TRIANGLE`` or ``PAIR``; barzilai_borwein: bool, whether the steps use
    the Barzilai-Borwein scale; kd: int, the data width (2 TRIANGLE, 6 PAIR). Fields
    rather than constants, so that the kernels are the same compiled functions as the
    Python-driven loop's (a literal would compile them again, costing seconds at a cold
    start). code (I, 4) int64, consts (F,), program_start (S + 1,) int64, depth,
    nesting (int): the fields' programs (``sdf.program_table.ProgramTable``); prog_a,
    prog_b (L,) int64: pair k's fields a and b, run (L,) int64 its batch (the points of
    consecutive pairs of one run are evaluated together, ``program_table``; TRIANGLE:
    per triangle, its field prog_a[t], with pair_of its owner; one entry: every point's
    field, one batch). rotation (L, 2, 2), offset (L, 2) m: pair k places b in a's frame
    by p_a = R_k p_b + o_k; pair_of (P,) int64: each start's pair (PAIR) or triangle
    (TRIANGLE: its owner). tri (T, 3, 2) m, owner (P,) int64, at_vertex (T, 3) int64,
    n_start (int, starts per triangle), spanning, convex (bool): as
    ``descent._TriangleProblem`` (PAIR: one dummy triangle, owner empty).
    """


PROBLEM_FIELDS = ("kind", "barzilai_borwein", "kd", "code", "consts", "program_start", "depth",
                  "nesting", "prog_a", "prog_b", "run", "rotation", "offset", "pair_of", "tri",
                  "owner", "at_vertex", "n_start", "spanning", "convex")
structref.define_proxy(DescentProblem, _DescentProblemType, list(PROBLEM_FIELDS))


@njit(cache=True)
def _descent_problem(kind, barzilai_borwein, kd, code, consts, program_start, depth, nesting,
                     prog_a, prog_b, run, rotation, offset, pair_of, tri, owner, at_vertex,
                     n_start, spanning, convex):
    return DescentProblem(kind, barzilai_borwein, kd, code, consts, program_start, depth,
                          nesting, prog_a, prog_b, run, rotation, offset, pair_of, tri, owner,
                          at_vertex, n_start, spanning, convex)


def descent_problem(kind: int, barzilai_borwein: bool, kd: int, table: ProgramTable,
                    prog_a: np.ndarray, prog_b: np.ndarray, run: np.ndarray,
                    rotation: np.ndarray, offset: np.ndarray, pair_of: np.ndarray,
                    tri: np.ndarray, owner: np.ndarray, at_vertex: np.ndarray, n_start: int,
                    spanning: bool, convex: bool) -> DescentProblem:
    """``DescentProblem`` of the programs of ``table`` (``sdf.program_table``), pair k's
    fields prog_a[k], prog_b[k] and batch run[k], and the arrays (C-contiguous, of the
    field types of ``PROBLEM``)."""
    return _descent_problem(kind, barzilai_borwein, kd, table.code, table.consts, table.start,
                            table.depth, table.nesting, prog_a, prog_b, run, rotation, offset,
                            pair_of, tri, owner, at_vertex, n_start, spanning, convex)


@structref.register
class _DescentWorkType(PlainFields):
    """Numba's type of ``DescentWork``."""


class DescentWork(structref.StructRefProxy):
    """The compiled descents' work arrays, kept between calls (one set per thread:
    ``descent.work``), by reference; a descent uses their leading rows and grows them
    (a new array in the field) when it needs more. Contents undefined between calls.

    Per start (at least P rows): state (N, N_STATE), flags (N, N_FLAGS) int64, running
    (N,) int64 (``_descent_paths``' columns). The round buffers (at least the
    candidates of a round): cand (C, 5), cand_i (C, 2) int64, candidates (C, 2) m.
    """


WORK_FIELDS = ("state", "flags", "running", "cand", "cand_i", "candidates")
structref.define_proxy(DescentWork, _DescentWorkType, list(WORK_FIELDS))


@njit(cache=True)
def _descent_work(state, flags, running, cand, cand_i, candidates):
    return DescentWork(state, flags, running, cand, cand_i, candidates)


def descent_work(rows: int = 64) -> DescentWork:
    """New work arrays of ``rows`` rows each."""
    return _descent_work(np.empty((rows, N_STATE)), np.empty((rows, N_FLAGS), np.int64),
                         np.empty(rows, np.int64), np.empty((rows, 5)),
                         np.empty((rows, 2), np.int64), np.empty((rows, 2)))


@njit(cache=True, error_model="numpy")
def _evaluate(problem, points: np.ndarray, pair: np.ndarray, n: int, phi: np.ndarray,
              grad: np.ndarray, data: np.ndarray) -> None:
    """The problem at points[:n] (of pairs pair[:n]: PAIR's pairs, TRIANGLE's triangles,
    read where the problem has several): phi, grad phi, data rows.

    The operations are those of ``field_pairs._PairProblem.values`` / ``evaluate``
    (``_times`` writes v @ M as v_x M_0j + v_y M_1j). The points of consecutive pairs of
    one run (all, with one pair) are evaluated in chunks of ``_CHUNK`` points from the
    run's first: the batches a call of that run alone made.
    """
    kind, rotation, offset = problem.kind, problem.rotation, problem.offset
    code, consts, program_start = problem.code, problem.consts, problem.program_start
    prog_a, prog_b, run = problem.prog_a, problem.prog_b, problem.run
    size = min(n, _CHUNK)
    stack, frames, cur = scratch(problem.depth, problem.nesting, size)
    fa, ga = np.empty(size), np.empty((size, 2))
    q, fb, gb = np.empty((size, 2)), np.empty(size), np.empty((size, 2))
    multi = prog_a.shape[0] > 1
    first = 0
    while first < n:
        k = pair[first] if multi else 0
        a, b = prog_a[k], prog_b[k]
        last = first + 1 if multi else n
        while last < n and run[pair[last]] == run[k]:
            last += 1
        code_a = code[program_start[a]:program_start[a + 1]]
        code_b = code[program_start[b]:program_start[b + 1]]
        for lo in range(first, last, _CHUNK):
            m = min(last - lo, _CHUNK)
            run_shared(code_a, consts, points[lo:lo + m], m, stack, frames, cur, fa, ga, 0, 0,
                       0)
            if kind == TRIANGLE:
                for j in range(m):
                    phi[lo + j], grad[lo + j, 0], grad[lo + j, 1] = fa[j], ga[j, 0], ga[j, 1]
                    data[lo + j, 0], data[lo + j, 1] = ga[j, 0], ga[j, 1]
                continue
            for j in range(m):
                k = pair[lo + j]
                px, py = points[lo + j, 0] - offset[k, 0], points[lo + j, 1] - offset[k, 1]
                q[j, 0] = px * rotation[k, 0, 0] + py * rotation[k, 1, 0]
                q[j, 1] = px * rotation[k, 0, 1] + py * rotation[k, 1, 1]
            run_shared(code_b, consts, q, m, stack, frames, cur, fb, gb, 0, 0, 0)
            for j in range(m):
                i = lo + j
                k = pair[i]
                r00, r01, r10, r11 = rotation[k, 0, 0], rotation[k, 0, 1], rotation[k, 1, 0], \
                    rotation[k, 1, 1]
                gax, gay = ga[j, 0], ga[j, 1]
                gbx = gb[j, 0] * r00 + gb[j, 1] * r01                   # times the transpose
                gby = gb[j, 0] * r10 + gb[j, 1] * r11
                data[i, 0], data[i, 1], data[i, 2], data[i, 3], data[i, 4], data[i, 5] = \
                    fa[j], fb[j], gax, gay, gbx, gby
                sign = 1.0 if fa[j] >= fb[j] else -1.0
                phi[i] = 0.5 * (fa[j] + fb[j]) + IMBALANCE * abs(fa[j] - fb[j])
                grad[i, 0] = 0.5 * (gax + gbx) + (IMBALANCE * sign) * (gax - gbx)
                grad[i, 1] = 0.5 * (gay + gby) + (IMBALANCE * sign) * (gay - gby)
        first = last


@njit(cache=True, error_model="numpy")
def descend(problem, points: np.ndarray, sigma: np.ndarray, iterations: int, tol: np.ndarray,
            shape_tol: float, work):
    """``descent._descend`` of a problem given by its fields' programs (module docstring).

    problem: ``DescentProblem``. points (P, 2): the starts, sigma (P,) their first step
    scales, iterations the round budget, tol (P,) (m) the step below which each start
    stops, shape_tol the tolerance of ``triangle_known``. work: ``DescentWork``.

    Returns best (P, 2), phi (P,), data (P, kd) at best, rounds (P,) and the number of
    points evaluated.
    """
    n_points = points.shape[0]
    phi = np.empty(n_points)
    grad = np.empty((n_points, 2))
    data = np.empty((n_points, problem.kd))              # updated in place by accept
    _evaluate(problem, points, problem.pair_of, n_points, phi, grad, data)
    if problem.kind == TRIANGLE:
        corner, shape = triangle_known(problem.tri, problem.at_vertex, points, phi, grad,
                                       problem.n_start, problem.spanning, problem.convex,
                                       shape_tol)
    else:
        corner, shape = np.full((1, 3, 3), np.nan), np.zeros((1, 4))
    return rounds_shared(problem, points, phi, grad, data, corner, shape, sigma, iterations,
                         tol, shape_tol, work)


@njit(cache=True, error_model="numpy")
def _block_ends(bounds: np.ndarray, block: int) -> np.ndarray:
    """The ends of the blocks of starts (B,): whole runs (``bounds`` (R + 1,), the runs'
    first starts, then the count), as many as fit in ``block`` starts, or the next
    ``block`` starts of a longer run (counted from its first start, as a call of that
    run alone)."""
    n_runs = bounds.shape[0] - 1
    ends = np.empty(bounds[n_runs] + 1, np.int64)
    n_blocks = 0
    r = 0
    end = 0
    while end < bounds[n_runs]:
        first = end
        while bounds[r + 1] <= first:
            r += 1
        end = bounds[r + 1]
        if end - first > block:
            end = first + block
        else:
            while r + 1 < n_runs and bounds[r + 2] - first <= block:
                r += 1
                end = bounds[r + 1]
        ends[n_blocks] = end
        n_blocks += 1
    return ends[:n_blocks]


@njit(cache=True, error_model="numpy")
def _rounds(problem, points: np.ndarray, phi: np.ndarray, grad: np.ndarray, data: np.ndarray,
            corner: np.ndarray, shape: np.ndarray, sigma: np.ndarray, iterations: int,
            tol: np.ndarray, shape_tol: float, work):
    """``descend`` once the starts are evaluated (phi, grad, data at points) and what
    they tell of the triangles is known (corner, shape; dummies for PAIR): the
    rounds. Same arguments (problem.n_start: the starts per triangle, in blocks of
    whole triangles) and results."""
    kind, barzilai_borwein, kd = problem.kind, problem.barzilai_borwein, problem.kd
    tri, owner, pair_of, n_start = problem.tri, problem.owner, problem.pair_of, problem.n_start
    n_points = points.shape[0]
    work.state = _grown(work.state, n_points)
    work.flags = _grown(work.flags, n_points)
    work.running = _grown(work.running, n_points)
    state, flags, running = work.state[:n_points], work.flags[:n_points], work.running
    cand, cand_i, candidates = work.cand, work.cand_i, work.candidates
    # Runs of starts: those of consecutive pairs (PAIR) or triangles (TRIANGLE) of one
    # run id, all when the problem has one pair. ``accept`` stops a start that moved
    # less than its run's least tol; where a run's tols differ, each start stops also
    # once it moved less than its own (as a call of that run alone).
    multi = problem.prog_a.shape[0] > 1
    run_of = np.zeros(n_points, np.int64)
    if multi:
        for i in range(n_points):
            run_of[i] = problem.run[pair_of[i]]
    bounds = run_starts(run_of)
    least = np.empty(n_points)
    uneven = np.zeros(n_points, dtype=np.bool_)
    any_uneven = False
    for r in range(bounds.shape[0] - 1):
        low, high = np.inf, -np.inf
        for i in range(bounds[r], bounds[r + 1]):
            low, high = min(low, tol[i]), max(high, tol[i])
        for i in range(bounds[r], bounds[r + 1]):
            least[i], uneven[i] = low, high > low
        any_uneven = any_uneven or high > low
    initialize(points, phi, grad, sigma, state, flags)
    evaluated = n_points
    value = np.empty(0)
    gradient = np.empty((0, 2))
    cand_data = np.empty((0, kd))
    pair = np.empty(0, dtype=np.int64)
    before = np.empty((n_points if any_uneven else 0, 2))
    # The starts descend block by block (whole triangles and runs per block), each
    # block through all its rounds: a start's rounds depend on its own state only (and
    # on its run's ``least``), so the results are those of one batch.
    block = _BLOCK if kind != TRIANGLE else max(1, _BLOCK // max(n_start, 1)) * n_start
    end = 0
    for b_end in _block_ends(bounds, block):
        first, end = end, b_end
        n_running = end - first
        for r in range(n_running):
            running[r] = first + r
        size = bound(kind, owner, shape, state, flags, running[:n_running])
        for _ in range(iterations):
            if size == 0:
                break
            cand = _grown(cand, size)
            cand_i = _grown(cand_i, size)
            candidates = _grown(candidates, size)
            n, n_eval, n_running = propose_shared(
                kind, tri, owner, corner, shape, state, flags, data, barzilai_borwein,
                running[:n_running], cand[:size], cand_i[:size], candidates[:size])
            if n == 0:
                break
            if value.shape[0] < n_eval:
                m = max(n_eval, 2 * value.shape[0])
                value, gradient, cand_data = np.empty(m), np.empty((m, 2)), np.empty((m, kd))
                pair = np.empty(m, dtype=np.int64)
            if kind != TRIANGLE or multi:
                # The pair (triangle) of each evaluated point: the starts wrote their
                # candidates one after the other (flags[i, COUNT] each); a source >= 0
                # is a point's row.
                row = 0
                for r in range(n_running):
                    i = running[r]
                    for _c in range(flags[i, COUNT]):
                        source = cand_i[row, 1]
                        if source > AT_BEST:
                            pair[source] = pair_of[i]
                        row += 1
            _evaluate(problem, candidates, pair, n_eval, value, gradient, cand_data)
            evaluated += n_eval
            if any_uneven:
                for r in range(n_running):
                    i = running[r]
                    before[i, 0], before[i, 1] = state[i, BEST], state[i, BEST + 1]
            n_running, size = accept_shared(
                kind, tri, owner, corner, state, flags, data, cand[:size], cand_i[:size],
                value[:n_eval], gradient[:n_eval], cand_data[:n_eval], least,
                running[:n_running], shape, shape_tol)
            if any_uneven:
                kept = 0
                for r in range(n_running):
                    i = running[r]
                    dx, dy = state[i, BEST] - before[i, 0], state[i, BEST + 1] - before[i, 1]
                    moved = math.sqrt(dx * dx + dy * dy)
                    if not (uneven[i] and flags[i, HAS_PREVIOUS] != 0 and moved < tol[i]):
                        running[kept] = i
                        kept += 1
                if kept < n_running:
                    n_running = kept
                    size = bound(kind, owner, shape, state, flags, running[:n_running])
    work.cand, work.cand_i, work.candidates = cand, cand_i, candidates     # maybe grown
    best, phi, rounds = results(state, flags)
    return best, phi, data, rounds, evaluated


# ``_rounds`` for ``descend`` and ``descend_sampled``: one machine code per process
# (``sdfphys._shared_kernel``), not a copy built into each. Its one signature, with the
# bundles' types as ``descent_problem`` and ``descent_work`` make them:
_INT = types.int64
PROBLEM = _DescentProblemType(list(zip(PROBLEM_FIELDS, (
    _INT, types.boolean, _INT, I2, F1, I1, _INT, _INT, I1, I1, I1, F3, F2, I1, F3, I1, I2,
    _INT, types.boolean, types.boolean))))
WORK = _DescentWorkType(list(zip(WORK_FIELDS, (F2, I2, I1, F2, I2, F2))))
rounds_shared = shared(
    _rounds, (PROBLEM, F2, F1, F2, F2, F3, F2, F1, _INT, F1, types.float64, WORK),
    "sdfphys_collide_descent_rounds", types.Tuple((F2, F1, F2, I1, _INT)))


@njit(cache=True, error_model="numpy")
def descend_sampled(code_a: np.ndarray, consts_a: np.ndarray, depth_a: int, nesting_a: int,
                    tri: np.ndarray, weights: np.ndarray, neighbours: np.ndarray,
                    edges: np.ndarray, spacing: float, k: int, iterations: int, tol: float,
                    shape_tol: float, work):
    """``lattice.triangle_deepest_sampled`` of a field given by its program.

    The field is evaluated at the lattice samples (weights (N, 3), spacing
    1 / degree, edges (E, 2): ``lattice._lattice``, ``lattice._lattice_edges``) of
    each triangle tri (T, 3, 2) and then at its hidden dips (``hidden_dips``,
    ``lattice.HIDDEN_DIPS`` slots: neighbours has N + HIDDEN_DIPS rows, -1 for the
    slots); what the lattice samples tell of each triangle (``triangle_known``, all
    N as starts that span it: vertex values, plane, cone; not the cuts, whose model
    costs O(N^3)) is kept; the k samples or dips ``pick_starts`` chooses descend
    (``_rounds``), tol (m) for all. work: ``DescentWork``.

    Returns best (T k, 2), phi (T k,), rounds (T k,) and the number of points
    evaluated.
    """
    n_sample = weights.shape[0]
    n_dip = neighbours.shape[0] - n_sample
    n_tri = tri.shape[0]
    n_dips = 0
    no_pair = np.empty(0, dtype=np.int64)
    # The triangle problem of field a (no field b, no placements); its starts' owners
    # are set once chosen.
    one = np.zeros(1, dtype=np.int64)
    program_start = np.array([0, code_a.shape[0]], dtype=np.int64)
    problem = DescentProblem(TRIANGLE, False, 2, code_a, consts_a, program_start, depth_a,
                             nesting_a, one, one, one, np.zeros((1, 2, 2)), np.zeros((1, 2)),
                             no_pair, tri, no_pair, np.full((1, 3), -1, np.int64), k, True,
                             False)
    corner = np.empty((n_tri, 3, 3))
    shape = np.empty((n_tri, 4))
    points, phi = np.empty((n_tri * k, 2)), np.empty(n_tri * k)
    grad, sigma = np.empty((n_tri * k, 2)), np.empty(n_tri * k)
    owner = np.empty(n_tri * k, dtype=np.int64)
    # The samples block by block: their arrays stay in the cache (fresh arrays of
    # all samples at once cost their page faults, more than the evaluation).
    n = min(n_tri, _SAMPLE_BLOCK) * n_sample
    sphi, sgrad, sdata = np.empty(n), np.empty((n, 2)), np.empty((n, 2))
    for lo in range(0, n_tri, _SAMPLE_BLOCK):
        hi = min(n_tri, lo + _SAMPLE_BLOCK)
        part = tri[lo:hi]
        spoints, _, ssigma, sat = triangle_starts(part, weights)
        n = spoints.shape[0]
        _evaluate(problem, spoints, no_pair, n, sphi, sgrad, sdata)
        c, sh = triangle_known(part, sat, spoints, sphi, sgrad, n_sample, True, False,
                               shape_tol)
        corner[lo:hi], shape[lo:hi] = c, sh
        dip_points, dip_place = present_dips(hidden_dips(spoints, sphi[:n], sgrad, n_sample,
                                                         edges, n_dip))
        m = dip_points.shape[0]
        dip_phi, dip_grad, dip_data = np.empty(m), np.empty((m, 2)), np.empty((m, 2))
        _evaluate(problem, dip_points, no_pair, m, dip_phi, dip_grad, dip_data)
        n_dips += m
        xpoints, xphi, xgrad, xsigma = with_dips(spoints, sphi[:n], sgrad, ssigma, n_sample,
                                                 n_dip, dip_points, dip_place, dip_phi,
                                                 dip_grad)
        chosen = pick_starts(xphi, xpoints, xsigma, n_sample + n_dip, neighbours, spacing, k,
                             n_sample)
        p, f, g, sg, ow = gather_starts(n_sample + n_dip, chosen, xpoints, xphi, xgrad, xsigma)
        points[lo * k:hi * k], phi[lo * k:hi * k], grad[lo * k:hi * k] = p, f, g
        sigma[lo * k:hi * k], owner[lo * k:hi * k] = sg, ow + lo
    data = grad.copy()
    tols = np.full(points.shape[0], tol)
    problem.owner = owner
    problem.pair_of = owner
    best, phi, data, rounds, evaluated = rounds_shared(
        problem, points, phi, grad, data, corner, shape, sigma, iterations, tols, shape_tol,
        work)
    return best, phi, rounds, evaluated + n_tri * (n_sample - k) + n_dips


# --------------------------------------------------------------------------------------
# Triangle helpers of ``descent`` (their numpy references are in tests/oracles.py)
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def merge_minima(point: np.ndarray, radius: float) -> np.ndarray:
    """``descent.merge_minima``: (T, K) bool, False for a start that ended within
    ``radius`` (m) of a start with a lower id of the same triangle; point (T, K, 2)."""
    n_tri, n_start = point.shape[0], point.shape[1]
    keep = np.ones((n_tri, n_start), dtype=np.bool_)
    r2 = radius * radius
    for t in range(n_tri):
        for k in range(1, n_start):
            for j in range(k):
                dx, dy = point[t, k, 0] - point[t, j, 0], point[t, k, 1] - point[t, j, 1]
                if dx * dx + dy * dy < r2:
                    keep[t, k] = False
                    break
    return keep


@njit(cache=True, error_model="numpy")
def enclosing_circles(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (T, 2) and radii (T,) of the minimal enclosing circles of triangles
    (T, 3, 2): for a triangle with an obtuse or right angle (collinear points included)
    the circle on its longest edge as diameter, otherwise its circumcircle."""
    n = tri.shape[0]
    centre = np.empty((n, 2))
    radius = np.empty(n)
    for t in range(n):
        k = 0
        longest = -np.inf
        for e in range(3):
            f = (e + 1) % 3
            ex, ey = tri[t, f, 0] - tri[t, e, 0], tri[t, f, 1] - tri[t, e, 1]
            length2 = ex * ex + ey * ey
            if length2 > longest:                       # np.argmax: the first of a tie
                k, longest = e, length2
        ax, ay = tri[t, k, 0], tri[t, k, 1]
        bx, by = tri[t, (k + 1) % 3, 0], tri[t, (k + 1) % 3, 1]
        cx, cy = tri[t, (k + 2) % 3, 0], tri[t, (k + 2) % 3, 1]
        px, py, rx, ry = ax - cx, ay - cy, bx - cx, by - cy
        if px * rx + py * ry <= 0.0:                    # obtuse or right: the longest edge
            centre[t, 0], centre[t, 1] = 0.5 * (ax + bx), 0.5 * (ay + by)
            radius[t] = 0.5 * math.sqrt(longest)
            continue
        # Circumcentre o relative to c, with p = a - c and r = b - c: |o|^2 = |o - p|^2
        # = |o - r|^2, i.e. 2 o.p = |p|^2, 2 o.r = |r|^2 (Cramer); an acute triangle is
        # not degenerate, so the determinant is not zero.
        det = 2.0 * (px * ry - py * rx)
        pp, rr = px * px + py * py, rx * rx + ry * ry
        ox, oy = (ry * pp - py * rr) / det, (px * rr - rx * pp) / det
        centre[t, 0], centre[t, 1] = cx + ox, cy + oy
        radius[t] = math.hypot(ox, oy)
    return centre, radius
