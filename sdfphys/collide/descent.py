"""Local minimisation of signed distance fields: over triangles, and over two fields' overlap.

Pure functions serve the narrowphase (all arrays float64, metres, each
field's own frame; sign convention of ``sdfphys.sdf``: f < 0 inside):

- ``triangle_deepest``: for each triangle, the local minima of f restricted to the
  triangle, one per start (3 vertices, 3 edge midpoints, centroid);
  ``merge_minima`` keeps one start per distinct minimum.
- ``triangle_cull``: which triangles may reach f < margin (enclosing-circle test).
- ``_descend``, the descent engine below, which ``field_pairs.field_field_contacts``
  also runs (contact points between two fields, by descent on max(f_a, f_b) from
  starts spread over the overlap of their bounds).

The fields are Python objects, so every descent round gathers the candidate
points of ALL running starts into ONE ``field.evaluate`` call, between two
compiled kernels (``_descent_kernels.propose`` writes the candidates, ``accept``
takes their values): a round costs a constant number of Python calls whatever
the batch, and a start leaves the batch as soon as it has converged. A candidate
whose value is already known (b itself, a triangle vertex where a start was
placed, the same point on another rung) is not evaluated again. When the
fields compile to stack-machine programs (``sdfphys.sdf.compiled``: the
primitives and operators that mesh and scene shapes use), the whole loop runs
inside ONE compiled call instead (``_compiled_descent``: the same kernels in
the same order, the programs evaluated in between), as do everything of
field-field contacts after their descent (merges and patch search:
``_compiled_field_contacts.field_contacts``). A field that does not compile (a user's
class) keeps the Python-driven loop, which the tests compare the compiled one with
(tests/oracles.py wraps a field so that it does not compile: the same results, to the
bit where the programs round as numpy does). ``merge_minima`` and the enclosing
circles of ``triangle_cull`` need no field and are always compiled.

The descent (shared by the triangle and the field-field problems)
-----------------------------------------------------------------
Both minimise a piecewise smooth, 1-Lipschitz function phi: f over a triangle,
or a balance of f_a and f_b over the plane (see ``_PairProblem``). From the
current best point b, a *path* q(s), s >= 0, leaves b downhill. It is the
proximal path of two linear models (``_descent_paths._proximal_step``): while
one model is clearly larger, steepest descent of it; from where they balance
on, along the line where they are equal. With the linearisation of phi at b as
both models it is plain steepest descent. For a triangle the path is projected
onto it: Proj_T(b + delta(s)) runs straight, slides along an edge, may stop at a
vertex (Bertsekas' projection arc, equivalent to projected descent in
barycentric coordinates with the Euclidean metric). Along a path phi is a 1D
function whose slope phi'(s) = grad phi(q) . dq/ds is known at every sample, so
each round evaluates, in one batch:

1. a geometric ladder s = scale * (1/16, 1/4, 1, 4) on the steepest path from b,
   on a triangle ended by the path's end when that is within 16 scales (the
   vertex, or the point of an edge, where the projected ray stops: a slide that
   still descends there reaches it in one round);
2. the same ladder on the *bundle* path, whose second model is the plane of a
   point seen nearby with a clearly different gradient (cosine < 1 - KINK),
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
   both kept a fraction ``GUARD`` of the bracket away from its ends;
4. for a field pair, once b has a prior point, the *osculating point*
   (``_descent_paths._osculating_point``): each field modelled by its osculating
   circle, the centre where its gradient lines at b and at the prior point cross
   (by its tangent plane where they do not turn), and the models' deepest balanced
   point, on the line through the two centres. At a smooth contact this is a
   secant Newton step on both the balance f_a = f_b and the tangent slope of
   f_a + f_b, converging superlinearly where the ladders creep along a curved
   ridge (a polygon's corner near a smooth surface: the ridge f_a = f_b bends
   with the corner's distance field, and a straight step along its tangent
   leaves it). A round whose winner is the osculating point proposes the next
   one alone (one evaluation); the ladders come back when it fails to lower phi,
   which does not count as a round without decrease.

On a triangle, a line search whose bracket lies on one straight piece of its
path (a slide along an edge, a straight gradient line), with b at an end of it
and the steepest path from b along the same line, is continued with its two
model points only (no ladders) until a round fails to halve its bracket.

On each ladder only the first valley counts (samples up to the first one where
phi rises or its slope turns >= 0; the path's end only if phi still falls into
it): a start finds the minimum of its own basin rather than jumping over a hill
into a deeper one, which is what lets several starts report several minima. The
best candidate replaces b when it lowers phi; the bracket is then rebuilt from
the winner's ladder neighbours, or shrunk by the model samples. The scale is
that of the accepted step (16 times larger when the last ladder sample still
descends); for the field pair it is the Barzilai-Borwein step s.s / s.y of the
last two iterations, which makes the slide along a contact's tangent converge
superlinearly. A round without decrease divides the scale by 64 and brackets
the first ladder step, so the next round searches finely around b; a second
such round ends the descent, as does a zero projected gradient (b is a vertex
whose normal cone contains -grad f, or the two fields' gradients are
antiparallel and balanced; for a field pair, one shorter than
``_descent_paths.STATIONARY_PAIR``) or an accepted step shorter than ``tol``. phi never
increases: whatever the budget, the returned point is the best one seen.

What the starts of a triangle tell
----------------------------------
All starts of a triangle are evaluated before the first round; when they span
it (``_descent_starts.triangle_known``):

- all on one plane (same gradient, values on it): f is taken as linear over the
  triangle, and each start's first rounds evaluate only the end of its steepest
  path (the lowest vertex, or its foot on an edge normal to the gradient);
- all on one cone (gradient lines through one point c, f = |x - c| + const: a
  circle, a polygon's corner seen from outside): every start first tries the
  point of the triangle closest to c, and stops there if f has the value the
  cone predicts;
- for a field convex by construction (its spec: a convex primitive, placed,
  rounded, scaled or intersected; see ``_convex``): the maximum of the starts'
  tangent planes is a lower bound of f (Kelley's cutting-plane model); every
  start first tries the model's minimiser p* over the triangle, and stops there
  if f(p*) equals the bound, which proves p* the minimum over the triangle
  (exact where f is the max of planes: a convex polygon's interior near its
  medial axis, where descent would follow ridges for dozens of rounds).

The plane and cone readings rest on the starts alone: a feature of f between
them that none of them sees is missed (as it can be by the descent). On them all
starts of a triangle report the same, single minimum.

Limits: a start that reaches an interior vertex of a polygon's medial axis
where three faces are equally near, but which is not a minimum, can stop there
(a bundle of two planes cannot describe three; about 1 start in 1000 on random
triangles deep inside a pentagon); the other starts of the triangle usually
reach the deeper point. In non-convex fields whose medial axis winds (a
difference of shapes, an L-shaped polygon's inside), some 1% of starts on
random triangles do not converge within 16 rounds; 32 suffice.

References: M. Macklin et al., "Local Optimization for Robust Signed Distance
Field Collision", Proc. ACM Comput. Graph. Interact. Tech. 3(1), 2020 (projected
descent over a triangle's barycentric coordinates, several starts); D. P.
Bertsekas, "Nonlinear Programming", sec. 2.3 (projection arc); P. Liu, Y. Zhang
et al., "Real-time Collision Detection between General SDFs", 2024, and MuJoCo's
SDF-SDF collision (descent on max(f_a, f_b) from low-discrepancy starts over the
intersection of the bounding boxes, normal from grad f_a - grad f_b).
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

import numpy as np

from ..sdf import Field
from ..sdf.compiled import Program, compile_field
from ..sdf.compiled import distance as compiled_distance
from ..sdf.program_table import ProgramTable, pair_table
from . import _descent_kernels as kernels
from . import _descent_paths as paths
from . import _descent_starts as start_kernels
from ._compiled_descent import (
    DescentWork,
    descend,
    descent_problem,
    descent_work,
    enclosing_circles,
)
from ._compiled_descent import merge_minima as compiled_merge_minima

if TYPE_CHECKING:
    from . import field_pairs

__all__ = [
    "START_BARYCENTRIC",
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

#: Tolerance of the plane and cone fits of ``_descent_starts.triangle_known``
#: (unit gradients; values relative to the coordinates' and values' size).
SHAPE_TOL = 1e-12

# --------------------------------------------------------------------------------------
# Triangle geometry
# --------------------------------------------------------------------------------------

def triangle_cull(field: Field, triangles: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """(T,) bool: False only for triangles on which f >= margin everywhere.

    triangles: (T, 3, 2) in the field's frame (m); margin: m. With c, R the
    minimal enclosing circle of a triangle, the triangle is kept iff
    f(c) < R + margin. One ``field.distance`` call on T points (compiled when the
    field compiles, ``sdf.compiled``).

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
    centre, radius = enclosing_circles(np.ascontiguousarray(tri))
    return compiled_distance(field, centre) < radius + margin


# --------------------------------------------------------------------------------------
# The line-search descent engine
# --------------------------------------------------------------------------------------

#: Primitives whose exact field is a convex function (the signed distance to a
#: convex set); a polygon also when its points turn one way only.
_CONVEX_PRIMITIVES = frozenset({
    "box", "capsule", "circle", "cut_disk", "ellipse", "equilateral_triangle", "half_plane",
    "hexagon", "isosceles_triangle", "octagon", "oriented_box", "parallelogram", "pentagon",
    "rhombus", "rounded_box", "segment", "trapezoid", "triangle", "uneven_capsule", "vesica"})
#: Operators that keep convex fields convex: placements, uniform scaling, f - r, max.
_CONVEX_OPERATORS = frozenset({"rotate", "round", "scale", "transform", "translate",
                               "intersection"})


def _convex(spec: dict | None) -> bool:
    """True when a field spec (``Field.spec``) describes a convex function of the point.

    Conservative: unknown fields (no spec), primitives not in
    ``_CONVEX_PRIMITIVES`` (bounds, non-convex shapes) and operators not in
    ``_CONVEX_OPERATORS`` (union, difference, smooth blends, onion) give False.
    """
    if not isinstance(spec, dict):
        return False
    if "type" in spec:
        if spec["type"] == "polygon":
            p = np.asarray(spec["points"], dtype=np.float64)
            e = np.roll(p, -1, axis=0) - p
            turn = e[:, 0] * np.roll(e, -1, axis=0)[:, 1] - e[:, 1] * np.roll(e, -1, axis=0)[:, 0]
            return bool(np.all(turn >= 0.0) or np.all(turn <= 0.0))
        return spec["type"] in _CONVEX_PRIMITIVES
    if spec.get("op") not in _CONVEX_OPERATORS:
        return False
    parts = spec["of"] if isinstance(spec["of"], list) else [spec["of"]]
    return all(_convex(part) for part in parts)


class _TriangleProblem:
    """f restricted to triangles (T, 3, 2); start i belongs to triangle ``owner[i]``.

    Point data: the gradient of f. The paths are projected onto the start's
    triangle. ``at_vertex`` (T, 3): the start placed at each vertex, -1 if none
    (its value is reused wherever a path reaches that vertex). ``spanning``: the
    starts' weights have rank 3 (they can show f to be a plane or a cone).
    ``convex``: f is convex by construction (``_convex`` of its spec).
    """

    kind = paths.TRIANGLE
    barzilai_borwein = False
    per_start = False

    def __init__(self, field: Field, triangles: np.ndarray, owner: np.ndarray,
                 at_vertex: np.ndarray, n_start: int, spanning: bool):
        self.field = field
        self.convex = field_convex(field)
        self.triangles = triangles
        self.owner = owner
        self.at_vertex = at_vertex
        self.n_start = n_start
        self.spanning = spanning

    def programs(self) -> tuple[Program, Program] | None:
        """The field's compiled program (twice: no second field), None if it does not compile."""
        program = compile_field(self.field)
        return None if program is None else (program, program)

    def evaluate(self, points: np.ndarray, start: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """f, grad f, grad f at points (N, 2); start (N,): not needed (one field for all)."""
        d, g = self.field.evaluate(points)
        return d, g, g

    def known(self, points: np.ndarray, phi: np.ndarray, grad: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """What the starts (P, 2) with values (P,), gradients (P, 2) tell of each triangle.

        corner (T, 3, 3): value and gradient at each vertex, NaN where no start is
        there. shape (T, 4): with starts spanning the triangle (``spanning``),
        whether f is a plane or a cone over it, or (for a field known convex) the
        minimum of its cutting-plane model, and the model's minimiser (see
        ``_descent_starts.triangle_known``). On a plane the steepest path needs no
        ladder: it runs straight to its end (the minimising vertex, or the foot on
        an edge normal to the gradient), where f is lowest. On a cone every start
        first tries the point closest to its apex.
        """
        return start_kernels.triangle_known(self.triangles, self.at_vertex, points, phi, grad,
                                      self.n_start, self.spanning, self.convex, SHAPE_TOL)


class _Workspace(threading.local):
    """Work arrays kept between calls, grown geometrically; a call uses leading rows.

    Fresh arrays of tens of megabytes (10^4 triangles) cost their page faults on
    every call, as much time as the descent itself; the physics step and the
    benchmarks query again and again. One set per thread (a descent fills them
    from start to end of a call; nothing is read that the call did not write): the
    Python loop's (``rows``) and the compiled descents' bundle (``work``), which
    they grow themselves.
    """

    def __init__(self) -> None:
        self._arrays: dict[str, np.ndarray] = {}
        self.descent_work: DescentWork | None = None

    def rows(self, name: str, n: int, width: int, dtype: type = np.float64) -> np.ndarray:
        """(n, width) C-contiguous rows of the array ``name``, contents undefined."""
        array = self._arrays.get(name)
        if array is None or len(array) < n:
            size = max(n, 2 * len(array) if array is not None else n, 64)
            array = self._arrays[name] = np.empty((size, width), dtype=dtype)
        return array[:n]


_WORK = _Workspace()


def work() -> DescentWork:
    """The compiled descents' work arrays (``_compiled_descent.DescentWork``), this
    thread's, kept between calls (the descents grow them)."""
    bundle = _WORK.descent_work
    if bundle is None:
        bundle = _WORK.descent_work = descent_work()
    return bundle


def _point_starts(cand_i: np.ndarray, flags: np.ndarray, proposing: np.ndarray, n: int,
                  n_eval: int) -> np.ndarray:
    """(U,) the start each evaluated point of a round belongs to.

    ``propose`` writes the candidates of the starts ``proposing`` (R,) one start
    after the other (``flags[i, COUNT]`` each); cand_i (C, 2): a candidate whose
    source is >= 0 added that row of the n_eval points.
    """
    owner = np.repeat(proposing, flags[proposing, paths.COUNT])
    source = cand_i[:n, 1]
    added = source >= 0
    start = np.empty(n_eval, dtype=np.int64)
    start[source[added]] = owner[added]
    return start


def _descend(problem: _TriangleProblem | field_pairs._PairProblem, points: np.ndarray,
             iterations: int, sigma: np.ndarray, tol: float | np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Minimise the problem's objective from each start (P, 2) (see the module docstring).

    sigma: (P,) initial step scale (path units); tol: scalar or (P,), a start
    stops when its accepted step is shorter (m). At most ``iterations`` rounds,
    each ONE ``problem.evaluate`` call over the candidates of all running starts
    between two compiled kernels (``_descent_kernels.propose`` and ``accept``).
    ``accept`` takes the smallest tol for every start; the starts whose own tol is
    larger and whose accepted step is shorter than it are then stopped here.
    Returns the best point (P, 2), its objective (P,), its data (P, kd) and the
    number of rounds each start ran (P,).
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    n_points = len(points)
    programs = problem.programs()
    if programs is not None:
        tol = (np.full(n_points, tol, dtype=np.float64) if np.ndim(tol) == 0
               else np.array(tol, dtype=np.float64))               # a copy: writable
        return _descend_compiled(problem, programs, points, iterations, sigma, tol)
    tol = np.broadcast_to(np.asarray(tol, dtype=np.float64), (n_points,))
    least = float(tol.min()) if n_points else 0.0
    uneven = n_points > 0 and bool(tol.max() > least)
    phi, grad, data = problem.evaluate(points, np.arange(n_points))
    phi, grad = np.ascontiguousarray(phi, np.float64), np.ascontiguousarray(grad, np.float64)
    data = np.array(data, dtype=np.float64, order="C")              # updated in place
    state = _WORK.rows("state", n_points, paths.N_STATE)
    flags = _WORK.rows("flags", n_points, paths.N_FLAGS, np.int64)
    start_kernels.initialize(points, phi, grad, np.ascontiguousarray(sigma, dtype=np.float64),
                       state, flags)
    corner, shape = problem.known(points, phi, grad)
    running = _WORK.rows("running", n_points, 1, np.int64)[:, 0]
    running[:] = np.arange(n_points)
    n_running = n_points
    size = kernels.bound(problem.kind, problem.owner, shape, state, flags, running)
    for _ in range(iterations):
        if size == 0:
            break
        cand = _WORK.rows("cand", size, 5)
        cand_i = _WORK.rows("cand_i", size, 2, np.int64)
        candidates = _WORK.rows("points", size, 2)
        n, n_eval, n_running = kernels.propose(
            problem.kind, problem.triangles, problem.owner, corner, shape, state, flags, data,
            problem.barzilai_borwein, running[:n_running], cand, cand_i, candidates)
        if n == 0:
            break
        start = (_point_starts(cand_i, flags, running[:n_running], n, n_eval)
                 if problem.per_start else None)
        value, gradient, cand_data = (np.ascontiguousarray(a, dtype=np.float64)
                                      for a in problem.evaluate(candidates[:n_eval], start))
        before = state[:, paths.BEST:paths.BEST + 2].copy() if uneven else None
        n_running, size = kernels.accept(problem.kind, problem.triangles, problem.owner, corner,
                                         state, flags, data, cand, cand_i, value, gradient,
                                         cand_data, np.full(n_points, least),
                                         running[:n_running], shape, SHAPE_TOL)
        if uneven:
            kept = running[:n_running]
            step = state[kept, paths.BEST:paths.BEST + 2] - before[kept]
            moved = np.sqrt(step[:, 0] * step[:, 0] + step[:, 1] * step[:, 1])
            stop = (flags[kept, paths.HAS_PREVIOUS] != 0) & (moved < tol[kept])
            if stop.any():
                kept = kept[~stop]
                n_running = len(kept)
                running[:n_running] = kept
                size = kernels.bound(problem.kind, problem.owner, shape, state, flags,
                                     running[:n_running])
    best, phi, rounds = start_kernels.results(state, flags)
    return best, phi, data, rounds


# --------------------------------------------------------------------------------------
# Deepest points of triangles
# --------------------------------------------------------------------------------------

def _descend_compiled(problem: _TriangleProblem | field_pairs._PairProblem,
                      programs: tuple[Program, Program], points: np.ndarray, iterations: int,
                      sigma: np.ndarray, tol: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``_descend`` in one compiled call (``_compiled_descent.descend``): the same
    arguments (tol: (P,) float64, writable, as the kernel is compiled for) and results,
    the problem's fields given by their ``programs`` (a, b)."""
    table = pair_table(*programs)
    if problem.kind == paths.PAIR:
        n = len(problem.offset)
        return descend_pairs(table, np.zeros(n, np.int64), np.ones(n, np.int64),
                             np.zeros(n, np.int64), problem.rotation, problem.offset,
                             problem.pair_of, points, sigma, tol, iterations)
    best, phi, data, rounds, _ = descend(
        descent_problem(problem.kind, problem.barzilai_borwein, 2, table, _FIRST, _FIRST,
                        _FIRST, _NO_ROTATION, _NO_OFFSET, problem.owner, problem.triangles,
                        problem.owner, problem.at_vertex, problem.n_start, problem.spanning,
                        problem.convex),
        points, np.ascontiguousarray(sigma, dtype=np.float64), iterations, tol, SHAPE_TOL,
        work())
    return best, phi, data, rounds


def descend_pairs(table: ProgramTable, prog_a: np.ndarray, prog_b: np.ndarray, run: np.ndarray,
                  rotation: np.ndarray, offset: np.ndarray, pair_of: np.ndarray,
                  points: np.ndarray, sigma: np.ndarray, tol: np.ndarray, iterations: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The compiled descent of a pair problem (``field_pairs._PairProblem``) over L pairs:
    pair k's fields a and b are programs prog_a[k], prog_b[k] (L,) of ``table``, its
    points evaluated in batches by run[k] (L,) (``sdf.program_table``), b placed by
    rotation (L, 2, 2) and offset (L, 2); start i of pair pair_of[i] from points (P, 2),
    first step scales sigma (P,), tolerances tol (P,) float64 (m, writable);
    ``_descend``'s results: best (P, 2), phi (P,), data (P, 6), rounds (P,)."""
    best, phi, data, rounds, _ = descend(
        descent_problem(paths.PAIR, True, 6, table, prog_a, prog_b, run,
                        np.ascontiguousarray(rotation), np.ascontiguousarray(offset), pair_of,
                        NO_TRIANGLE, NO_OWNER, NO_CORNERS, 0, False, False),
        np.ascontiguousarray(points, dtype=np.float64),
        np.ascontiguousarray(sigma, dtype=np.float64), iterations, tol, SHAPE_TOL, work())
    return best, phi, data, rounds


# Placeholders of the arguments a triangle problem does not use (placements of b,
# (1, 2, 2) and (1, 2)) and of those a pair problem does not use (its triangle
# (1, 3, 2), owners (0,) and vertex starts (1, 3)); read only.
_NO_ROTATION = np.zeros((1, 2, 2))
_NO_OFFSET = np.zeros((1, 2))
#: A triangle problem's field: program 0 of its table, its one batch.
_FIRST = np.zeros(1, dtype=np.int64)
NO_TRIANGLE = np.zeros((1, 3, 2))
NO_OWNER = np.zeros(0, dtype=np.int64)
NO_CORNERS = np.zeros((1, 3), dtype=np.int64)


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
    tri = np.ascontiguousarray(tri)
    points, owner, sigma, at_vertex = start_kernels.triangle_starts(
        tri, np.ascontiguousarray(weights))
    problem = _TriangleProblem(field, tri, owner, at_vertex, n_start, _spanning(weights))
    best, value, _, rounds = _descend(problem, points, iterations, sigma, tol)
    return (best.reshape(n_tri, n_start, 2), value.reshape(n_tri, n_start),
            rounds.reshape(n_tri, n_start))


_SPANNING: dict[bytes, bool] = {}


def _spanning(weights: np.ndarray) -> bool:
    """The start weights (K, 3) have rank 3 (cached: a few sets are used over and over)."""
    key = weights.tobytes()
    if key not in _SPANNING:
        _SPANNING[key] = bool(np.linalg.matrix_rank(weights) == 3)
    return _SPANNING[key]


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
    may reach the same minimum: ``merge_minima`` keeps one. Where the starts show f
    to be a plane, a cone or (for a field convex by construction) a max of planes
    over the triangle, every start reports the triangle's one minimum.
    """
    point, value, _ = _triangle_minima(field, triangles, iterations, starts, tol)
    return point, value


def triangle_deepest_programs(table: ProgramTable, program: np.ndarray, run: np.ndarray,
                              convex: np.ndarray, triangles: np.ndarray, iterations: int,
                              starts: np.ndarray, tol: float = 1e-12
                              ) -> tuple[np.ndarray, np.ndarray]:
    """``triangle_deepest`` of triangles (T, 3, 2) in many fields, compiled: triangle t in
    field program[t] (T,) of ``table``, its points evaluated in batches by run[t] (T,)
    (``sdf.program_table``; the triangles of a run are consecutive and share one field),
    convex[t] (T,) bool that field's ``field_convex``. One descent call per convexity
    present; the same minima, to the bit, as a ``triangle_deepest`` call per run.
    starts: (K, 3) barycentric weights. Returns point (T, K, 2), value (T, K)."""
    tri = np.ascontiguousarray(triangles, dtype=np.float64).reshape(-1, 3, 2)
    weights = np.ascontiguousarray(starts, dtype=np.float64).reshape(-1, 3)
    n_tri, n_start = len(tri), len(weights)
    point, value = np.empty((n_tri, n_start, 2)), np.empty((n_tri, n_start))
    for kind in (False, True):
        rows = np.flatnonzero(convex == kind)
        if len(rows) == 0:
            continue
        part = np.ascontiguousarray(tri[rows])
        points, owner, sigma, at_vertex = start_kernels.triangle_starts(part, weights)
        prog = np.ascontiguousarray(program[rows])
        best, phi, _, _, _ = descend(
            descent_problem(paths.TRIANGLE, False, 2, table, prog, prog,
                            np.ascontiguousarray(run[rows]), _NO_ROTATION, _NO_OFFSET, owner,
                            part, owner, at_vertex, n_start, _spanning(weights), bool(kind)),
            points, sigma, iterations, np.full(len(points), float(tol)), SHAPE_TOL, work())
        point[rows], value[rows] = best.reshape(-1, n_start, 2), phi.reshape(-1, n_start)
    return point, value


def merge_minima(point: np.ndarray, radius: float) -> np.ndarray:
    """(T, K) bool: True for the starts to keep, one per distinct minimum of each triangle.

    point: (T, K, 2) from ``triangle_deepest``; radius: m. Start k is dropped when
    a start with a lower id (same triangle) ended within ``radius`` of it, so the
    lowest start id of each cluster is kept (a stable feature key).
    """
    return compiled_merge_minima(np.ascontiguousarray(point, dtype=np.float64), float(radius))


def field_convex(field: Field) -> bool:
    """``_convex`` of the field's spec, cached on the field object."""
    cached = getattr(field, "_descent_convex", None)
    if cached is None:
        cached = _convex(getattr(field, "spec", None))
        try:
            field._descent_convex = cached
        except AttributeError:
            pass
    return cached
