"""Contacts between two fields: descent on max(f_a, f_b) over their overlap, then merges.

``field_field_contacts`` finds the contact points between two signed distance fields
for a batch of placements of one in the other's frame (sdf-sdf pairs, and the
sdf-in-mesh direction of mesh-sdf pairs with the mesh's polygon field);
``field_field_contacts_single`` for one placement. The descent is ``descent._descend``
on ``_PairProblem`` (see ``descent``'s docstring for the engine); when both fields
compile (``sdf.compiled``) the descent and everything after it (merges of starts that
met, flat patches measured along their tangent) run compiled
(``_compiled_descent.descend`` and ``field_contacts``); otherwise the numpy path runs,
the reference the tests compare with (tests/oracles.py).

Method: P. Liu, Y. Zhang et al., "Real-time Collision Detection between General SDFs",
2024, and MuJoCo's SDF-SDF collision (descent on max(f_a, f_b) from low-discrepancy
starts over the intersection of the bounding boxes, normal from grad f_a - grad f_b).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..sdf import Field, compiled, safe_normalize
from ..sdf.compiled import Program, compile_field
from ..sdf.program_table import ProgramTable, pair_table
from ..vec2 import TINY
from . import _descent_paths as paths
from . import descent
from ._compiled_field_contacts import field_contacts, patch_ends
from ._compiled_samples import one_sided, tangent_points
from ._placed_fields import overlap_regions, placed_starts

__all__ = ["PairPrograms", "field_field_contacts", "field_field_contacts_single",
           "one_sided_depths", "one_sided_programs", "placed_contacts", "placed_field_contacts",
           "tangent_programs", "tangent_samples"]

#: Contacts of two fields closer than this fraction of the region's diagonal are one.
_MERGE = 1e-3
#: Thickness of the sliver measuring a flat patch, as a fraction of the region's diagonal.
_SLIVER = 1e-9


@dataclass(frozen=True)
class PairPrograms:
    """The fields of L pairs as the compiled kernels take them: pair k's fields a and b
    are programs prog_a[k], prog_b[k] (L,) int64 of ``table``, its points evaluated in
    batches by run[k] (L,) int64 (``sdf.program_table``: the pairs of one shape pair
    share a run, so that the batches are those of a call of that shape pair alone)."""

    table: ProgramTable
    prog_a: np.ndarray
    prog_b: np.ndarray
    run: np.ndarray

    @classmethod
    def of(cls, a: Program, b: Program, n: int) -> PairPrograms:
        """n pairs of fields a and b, one run."""
        first = np.zeros(n, np.int64)
        return cls(pair_table(a, b), first, np.ones(n, np.int64), first)

    def take(self, rows: np.ndarray) -> PairPrograms:
        """The pairs ``rows``, in that order."""
        return PairPrograms(self.table, self.prog_a[rows], self.prog_b[rows], self.run[rows])

    def args(self) -> tuple:
        """(code, consts, start, depth, nesting, prog_a, prog_b): the kernels' leading
        arguments (``run`` follows where a kernel evaluates batches of several pairs)."""
        t = self.table
        return t.code, t.consts, t.start, t.depth, t.nesting, self.prog_a, self.prog_b


def _rotations(angle: np.ndarray) -> np.ndarray:
    """(P, 2, 2) counter-clockwise rotation matrices by angle (P,) rad."""
    c, s = np.cos(angle), np.sin(angle)
    m = np.empty((len(angle), 2, 2))
    m[:, 0, 0], m[:, 0, 1], m[:, 1, 0], m[:, 1, 1] = c, -s, s, c
    return m


def _times(v: np.ndarray, m: np.ndarray) -> np.ndarray:
    """(N, 2) rows v (N, 2) times matrices m (N, 2, 2): v[n] @ m[n].

    Written out (v_x m_0j + v_y m_1j) rather than ``np.matmul``: BLAS may fuse the
    multiply-adds, and the compiled descent (``_compiled_descent``) computes the
    same expression, so that both paths give the same bits.
    """
    return np.stack([v[:, 0] * m[:, 0, 0] + v[:, 1] * m[:, 1, 0],
                     v[:, 0] * m[:, 0, 1] + v[:, 1] * m[:, 1, 1]], axis=1)


class _PairProblem:
    """phi = max(f_a, f_b) over the plane, for P placements of b in a's frame.

    Pair k places b by (rotation[k] (2, 2), offset[k] (2,)): p_a = R p_b + offset
    (``inverse``: the transposes, contiguous);
    start i belongs to pair ``pair_of[i]`` (S,). Both fields are the same objects
    for every pair, so one round evaluates each field once on the points of all
    pairs. Point data: f_a, f_b, grad f_a, grad f_b (6 columns, a's frame). Path
    parameters: origin and its data; the path is the proximal min-max path of
    the two fields' linearisations (``_descent_paths._proximal_step``): steepest descent of the
    larger field until the linear models balance, then along the line where they
    are equal, down the min-norm element of {grad f_a, grad f_b} - the contact's
    tangent, where the sum f_a + f_b (minus the depth) decreases.
    """

    kind = paths.PAIR
    barzilai_borwein = True
    per_start = True

    def __init__(self, field_a: Field, field_b: Field, rotation: np.ndarray,
                 offset: np.ndarray, pair_of: np.ndarray):
        self.field_a, self.field_b = field_a, field_b
        self.rotation, self.offset = rotation, offset
        self.pair_of = pair_of
        self.triangles = descent.NO_TRIANGLE           # no triangle: paths are not projected
        self.owner = descent.NO_OWNER

    @cached_property
    def inverse(self) -> np.ndarray:
        """(P, 2, 2) the rotations' transposes, contiguous (the numpy path's)."""
        return np.ascontiguousarray(self.rotation.transpose(0, 2, 1))

    def known(self, points: np.ndarray, phi: np.ndarray, grad: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """No triangle: no vertex values (1, 3, 3) NaN, no known shape (1, 4)."""
        return np.full((1, 3, 3), np.nan), np.zeros((1, 4))

    def programs(self) -> tuple[Program, Program] | None:
        """Both fields' compiled programs, None unless both compile."""
        a, b = compile_field(self.field_a), compile_field(self.field_b)
        return None if a is None or b is None else (a, b)

    def values(self, points: np.ndarray, pair: np.ndarray) -> np.ndarray:
        """(N, 6): f_a, f_b, grad f_a, grad f_b at points (N, 2) of a's frame, of pairs (N,)."""
        fa, ga = self.field_a.evaluate(points)
        fb, gb = self.field_b.evaluate(_times(points - self.offset[pair], self.rotation[pair]))
        return np.column_stack([fa, fb, ga, _times(gb, self.inverse[pair])])

    def evaluate(self, points: np.ndarray, start: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """phi (N,), grad phi (N, 2), data (N, 6) at points (N, 2) of starts (N,)."""
        data = self.values(points, self.pair_of[start])
        fa, fb, ga, gb = data[:, 0], data[:, 1], data[:, 2:4], data[:, 4:6]
        sign = np.where(fa >= fb, 1.0, -1.0)
        phi = 0.5 * (fa + fb) + paths.IMBALANCE * np.abs(fa - fb)
        grad = 0.5 * (ga + gb) + (paths.IMBALANCE * sign)[:, None] * (ga - gb)
        return phi, grad, data

    def stationarity(self, data: np.ndarray) -> np.ndarray:
        """(N,) >= 0 at data (N, 6): zero at a balanced minimum (see the kernels)."""
        return paths.stationarity(paths.PAIR, data)


_STARTS: dict[int, np.ndarray] = {}


def _starts(n_starts: int) -> np.ndarray:
    """The Halton (2, 3) points 1..n_starts (n_starts, 2) in the unit square (cached)."""
    if n_starts not in _STARTS:
        index = np.arange(1, n_starts + 1)
        _STARTS[n_starts] = np.column_stack([_halton(index, 2), _halton(index, 3)])
    return _STARTS[n_starts]


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


def _clusters(group: np.ndarray, point: np.ndarray, key: np.ndarray, score: np.ndarray,
              tiebreak: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge points of one group closer than radius: (head (C,), best (C,)) indices into K.

    group (K,): the points' groups (pairs), each group's points contiguous;
    point (K, 2); key (K,) int; score, tiebreak, radius (K,) (radius: the
    group's, m). Within its group, each point joins the lowest-key point within
    radius of it (itself if none is lower); per cluster, ``head`` is that
    lowest-key point (its key names the cluster) and ``best`` the member to
    report: lowest score, and among scores equal to rounding, lowest tiebreak.
    Clusters come group by group, in the order of their heads. The groups are
    padded to the largest, (G, W, W) pairwise tests in all.
    """
    n = len(point)
    first = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])      # (G,) run starts
    count = np.diff(np.r_[first, n])
    run = np.repeat(np.arange(len(first)), count)
    width = int(count.max())
    index = np.full((len(first), width), -1, dtype=np.int64)           # (G, W) -> point
    index[run, np.arange(n) - first[run]] = np.arange(n)
    valid = index >= 0
    at = np.maximum(index, 0)
    p = point[at]
    gap = p[:, :, None, :] - p[:, None, :, :]                          # (G, W, W, 2)
    r = radius[first]
    near = np.einsum("gkjd,gkjd->gkj", gap, gap) < (r * r)[:, None, None]
    near &= valid[:, None, :]
    leader = np.argmin(np.where(near, key[at][:, None, :], np.iinfo(np.int64).max), axis=2)
    slot = np.arange(width)
    is_head = valid & (leader == slot)
    member = (leader[:, None, :] == slot[None, :, None]) & valid[:, None, :]   # (G, W, W)
    lowest = np.min(np.where(member, score[at][:, None, :], np.inf), axis=2, keepdims=True)
    rounding = 4.0 * paths.EPS * np.maximum(1.0, np.abs(lowest))
    member &= score[at][:, None, :] <= lowest + rounding
    best = np.argmin(np.where(member, tiebreak[at][:, None, :], np.inf), axis=2)
    g, h = np.nonzero(is_head)
    return index[g, h], index[g, best[g, h]]


def _patch_ends(problem: _PairProblem, pair: np.ndarray, centre: np.ndarray,
                normal: np.ndarray, depth: np.ndarray, sliver: np.ndarray, reach: np.ndarray,
                iterations: int, tol: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Extent of each contact's patch along its tangent: (s (K, 2), found (K, 2)).

    pair (K,): each contact's pair of the problem; centre: (K, 2) midway points,
    normal (K, 2), depth (K,); sliver, reach, tol (K,): m, per contact (its
    pair's scale). Shifting b by (depth - sliver) along the normal leaves an
    overlap only where the two surfaces are within ``sliver`` of the full depth
    of each other: a sliver of thickness ``sliver`` just inside a's surface,
    over the flat part of the contact patch (two parallel faces), a point-like
    lens where a surface is curved. Its ends along t = perp(n) are the roots of
    h(s) = max(f_a(x(s)), f_b(x(s) - shift)), x(s) = m + s t, m in the middle of
    the sliver, found by a safeguarded Newton / regula falsi / bisection search
    on [0, reach] (h(0) < 0 < h(reach)) in both directions of every contact at
    once (each iteration one evaluation of each field). Column 0 is the -t end,
    column 1 the +t end (s >= 0 along its direction); ``found`` is False where
    the sliver is empty at m (depth overestimated).
    """
    programs = problem.programs()
    if programs is not None:                          # the same search, compiled
        c = np.ascontiguousarray
        return patch_ends(*PairPrograms.of(*programs, len(problem.offset)).args(),
                          c(problem.rotation), c(problem.offset), c(pair), c(centre),
                          c(normal), c(depth), c(sliver), c(reach), iterations, c(tol))
    n_contacts = len(depth)
    tangent = np.column_stack([-normal[:, 1], normal[:, 0]])
    direction = np.concatenate([-tangent, tangent])                     # (2K, 2)
    middle = centre + (0.5 * depth - 0.5 * sliver)[:, None] * normal
    origin = np.concatenate([middle, middle])
    shift = np.concatenate([(depth - sliver)[:, None] * normal] * 2)
    of = np.concatenate([pair, pair])

    def h(s: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = origin[rows] + s[:, None] * direction[rows]
        pair_rows = of[rows]
        fa, ga = problem.field_a.evaluate(x)
        fb, gb = problem.field_b.evaluate(
            _times(x - shift[rows] - problem.offset[pair_rows], problem.rotation[pair_rows]))
        slope = np.where(fa >= fb, np.einsum("nd,nd->n", ga, direction[rows]),
                         np.einsum("nd,nd->n", _times(gb, problem.inverse[pair_rows]),
                                   direction[rows]))
        return np.maximum(fa, fb), slope

    everything = np.arange(2 * n_contacts)
    h_lo = h(np.zeros(2 * n_contacts), everything)[0]
    lo = np.zeros(2 * n_contacts)
    hi = np.concatenate([reach, reach])
    tol = np.concatenate([tol, tol])
    h_hi, d_hi = h(hi, everything)
    found = h_lo < 0.0
    active = found & (h_hi > 0.0)
    lo[found & ~active] = hi[found & ~active]
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


def field_field_contacts(field_a: Field, field_b: Field, poses_b_in_a: np.ndarray,
                         regions: np.ndarray, n_starts: int = 16, iterations: int = 24,
                         margin: float = 0.0
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Contacts between two fields, for P placements of b in a's frame at once.

    Returns (pair (K,), point (K, 2), depth (K,), normal (K, 2), start_id (K,)):
    contact k belongs to row pair[k] of the inputs, in a's frame; the contacts
    come pair by pair, in ascending pair order. Each pair's contacts are exactly
    those of a batch of that pair alone (``field_field_contacts_single``).

    poses_b_in_a: (P, 3) rows (x, y, angle) placing b's frame in a's
    (p_a = R(angle) p_b + (x, y), m, rad). regions: (P, 4) finite boxes
    (xmin, ymin, xmax, ymax) in a's frame where the bodies may overlap (the
    overlap of their bounds; grown by the margin for speculative contacts); an
    empty box (xmax < xmin or ymax < ymin) gives no contact. n_starts: starts
    over each region, the Halton (2, 3) points 1..n_starts (a fixed pattern:
    start id k is always the same relative place). iterations: descent
    iterations. margin: m, contacts with depth > -margin are reported. Cost: the
    fields are the same objects for every pair, so each descent iteration (and
    each iteration of the patch search) is ONE ``evaluate`` call of each field
    over the points of all pairs, whatever P.

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

    Contacts of different starts of a pair within 1e-3 of its region's diagonal
    are one (the lowest start id is kept). Then each contact's patch is measured
    along its tangent (``_patch_ends``): where the two surfaces stay parallel at
    the full depth (a box resting on a box) the contact is replaced by the two
    ends of that flat patch, with the same depth and normal, ids n_starts + 2k
    (the -t end, t = perp(n)) and n_starts + 2k + 1 (the +t end) for start k;
    merged again by distance. Ids are < n_starts * 3.

    Limits: a start may stop at a local minimum of max(f_a, f_b) that is not a
    contact (it is then dropped); two contacts closer than the merge distance are
    one; a slightly tilted flat contact reports its deepest end only.
    """
    poses = np.asarray(poses_b_in_a, dtype=np.float64).reshape(-1, 3)
    regions = np.asarray(regions, dtype=np.float64).reshape(-1, 4)
    if len(poses) != len(regions):
        raise ValueError(f"{len(poses)} poses but {len(regions)} regions")
    if not np.all(np.isfinite(regions)):
        raise ValueError(f"regions must be finite, got {regions}")
    live = np.flatnonzero(np.all(regions[:, 2:] >= regions[:, :2], axis=1))
    if len(live) == 0 or n_starts < 1:
        return _no_contacts()
    lo, hi = regions[live, :2], regions[live, 2:]
    pair_of = np.repeat(np.arange(len(live)), n_starts)                 # (S,) start -> pair
    problem = _PairProblem(field_a, field_b, _rotations(poses[live, 2]), poses[live, :2],
                           pair_of)
    extent = hi - lo
    scale = np.maximum(np.hypot(extent[:, 0], extent[:, 1]), TINY)    # (L,) diagonals

    # Starts and descent.
    unit = _starts(n_starts)
    starts = (lo[:, None, :] + extent[:, None, :] * unit[None, :, :]).reshape(-1, 2)
    scale_of = scale[pair_of]
    programs = problem.programs()
    if programs is not None:                          # compiled, the same operations
        pair, point, depth, normal, start_id = _compiled_contacts(
            PairPrograms.of(*programs, len(live)), problem.rotation, problem.offset, pair_of,
            starts, 0.25 * scale_of, 1e-12 * scale_of, scale, n_starts,
            np.full(len(live), float(margin)), iterations)
        return live[pair], point, depth, normal, start_id
    best, phi, data, _ = descent._descend(problem, starts, iterations, 0.25 * scale_of,
                                          1e-12 * scale_of)
    fa, fb, ga, gb = data[:, 0], data[:, 1], data[:, 2:4], data[:, 4:6]
    hit = phi < 0.5 * margin
    balanced = np.abs(fa - fb) <= 1e-9 * scale_of
    normal = np.where(balanced[:, None], ga - gb, np.where((fa > fb)[:, None], -gb, ga))
    normal = safe_normalize(normal)
    depth = -(fa + fb)
    point = best + (0.5 * (fb - fa))[:, None] * normal
    start_id = np.tile(np.arange(n_starts), len(live))
    hits = np.flatnonzero(hit)
    if len(hits) == 0:
        return _no_contacts()
    head, chosen = _clusters(pair_of[hits], best[hits], start_id[hits], phi[hits],
                             problem.stationarity(data[hits]), _MERGE * scale_of[hits])
    take = hits[chosen]
    pair = pair_of[take]
    point, depth, normal, start_id = point[take], depth[take], normal[take], start_id[hits[head]]

    # Flat patches: replace a contact by the two ends of its patch when either is far.
    radius = _MERGE * scale[pair]
    ends, found = _patch_ends(problem, pair, point, normal, depth, _SLIVER * scale[pair],
                              2.0 * scale[pair], iterations, 1e-12 * scale[pair])
    flat = np.any(found & (ends > radius[:, None]), axis=1)
    tangent = np.column_stack([-normal[:, 1], normal[:, 0]])
    end_point = np.concatenate([point - ends[:, :1] * tangent, point + ends[:, 1:] * tangent])
    end_id = np.concatenate([n_starts + 2 * start_id, n_starts + 2 * start_id + 1])
    two = np.concatenate([flat, flat])
    # Per pair: its contacts kept as they are, then the -t ends, then the +t ends.
    pair = np.concatenate([pair[~flat], np.concatenate([pair, pair])[two]])
    order = np.argsort(pair, kind="stable")
    pair = pair[order]
    point = np.concatenate([point[~flat], end_point[two]])[order]
    depth = np.concatenate([depth[~flat], np.concatenate([depth, depth])[two]])[order]
    normal = np.concatenate([normal[~flat], np.concatenate([normal, normal])[two]])[order]
    start_id = np.concatenate([start_id[~flat], end_id[two]])[order]
    head, chosen = _clusters(pair, point, start_id, -depth, start_id.astype(np.float64),
                             _MERGE * scale[pair])
    return live[pair[chosen]], point[chosen], depth[chosen], normal[chosen], start_id[head]


def placed_field_contacts(field_a: Field, field_b: Field, offset: np.ndarray, angle: np.ndarray,
                          bounds_a: np.ndarray, bounds_b: np.ndarray, margin: float,
                          n_starts: int, iterations: int
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                     np.ndarray]:
    """``field_field_contacts`` of b placed in a's frame, over the overlap of the bounds.

    offset (n, 2), angle (n,): b's origin and angle in a's frame (m, rad); bounds_a,
    bounds_b (4,): the body-frame AABBs (a's may be infinite, b's finite); margin:
    m, the regions are grown by it and contacts with depth > -margin reported.
    Returns the regions (n, 4) (``_placed_fields.overlap_regions``) and
    ``field_field_contacts``' five results for those regions. When both fields
    compile, ``placed_contacts`` (the same bits).
    """
    n = len(angle)
    bounds_a = np.tile(np.asarray(bounds_a, np.float64), (n, 1))
    bounds_b = np.tile(np.asarray(bounds_b, np.float64), (n, 1))
    margins = np.full(n, float(margin))
    a, b = ((compile_field(field_a), compile_field(field_b)) if n_starts >= 1 else (None, None))
    if a is None or b is None:
        region = overlap_regions(bounds_a, bounds_b, np.ascontiguousarray(offset, np.float64),
                                 np.cos(angle), np.sin(angle), margins)
        return (region, *field_field_contacts(field_a, field_b,
                                              np.column_stack([offset, angle]), region,
                                              n_starts=n_starts, iterations=iterations,
                                              margin=margin))
    return placed_contacts(PairPrograms.of(a, b, n), offset, angle, bounds_a, bounds_b,
                           margins, n_starts, iterations)


def placed_contacts(programs: PairPrograms, offset: np.ndarray, angle: np.ndarray,
                    bounds_a: np.ndarray, bounds_b: np.ndarray, margin: np.ndarray,
                    n_starts: int, iterations: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                               np.ndarray]:
    """``placed_field_contacts`` of n pairs of compiled fields (``programs``), each its
    own bounds_a, bounds_b (n, 4) and margin (n,) m: three compiled calls
    (``_placed_fields.placed_starts``, the descent, the merges) with the operations of
    the numpy glue, so the same bits as a call per pair's fields. Returns the regions
    (n, 4), then pair (K,) into the n pairs, point (K, 2), depth (K,), normal (K, 2),
    start id (K,) in a's frames, in pair order."""
    region, live, rotation, placed, scale, pair_of, points, sigma, tol = placed_starts(
        bounds_a, bounds_b, np.ascontiguousarray(offset, np.float64), np.cos(angle),
        np.sin(angle), margin, _starts(n_starts))
    pair, point, depth, normal, start_id = _compiled_contacts(
        programs.take(live), rotation, placed, pair_of, points, sigma, tol, scale, n_starts,
        margin[live], iterations)
    return region, live[pair], point, depth, normal, start_id


def _compiled_contacts(programs: PairPrograms, rotation: np.ndarray, offset: np.ndarray,
                       pair_of: np.ndarray, starts: np.ndarray, sigma: np.ndarray,
                       tol: np.ndarray, scale: np.ndarray, n_starts: int, margin: np.ndarray,
                       iterations: int
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``field_field_contacts`` from its starts on, compiled: the descent
    (``descent.descend_pairs``), then the merges and the patch search
    (``field_contacts``). programs: the L pairs' fields; rotation (L, 2, 2), offset (L,
    2): b's placements; pair_of (S,), starts (S, 2), sigma, tol (S,): the starts, their
    pairs, first step scales and tolerances (m); scale (L,): the regions' diagonals;
    margin (L,) m. Returns pair (K,) into the L placements, point (K, 2), depth (K,),
    normal (K, 2), start id (K,)."""
    best, phi, data, _ = descent.descend_pairs(
        programs.table, programs.prog_a, programs.prog_b, programs.run, rotation, offset,
        pair_of, starts, sigma, np.array(tol, dtype=np.float64), iterations)
    rotation, offset = np.ascontiguousarray(rotation), np.ascontiguousarray(offset)
    return field_contacts(*programs.args(), rotation, offset, pair_of, best, phi, data, scale,
                          n_starts, margin, iterations, _MERGE, _SLIVER)


def _in_b(field_b: Field, offset: np.ndarray, angle: np.ndarray, placed: np.ndarray,
          q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """f_b and grad f_b (a's frame) at points q (N, 2) of a's frame, b placed by
    ``offset``, ``angle`` rows ``placed`` (N,)."""
    c, s = np.cos(angle[placed]), np.sin(angle[placed])
    rel = q - offset[placed]
    f, g = compiled.evaluate(field_b, np.column_stack([c * rel[:, 0] + s * rel[:, 1],
                                                       c * rel[:, 1] - s * rel[:, 0]]))
    return f, np.column_stack([c * g[:, 0] - s * g[:, 1], s * g[:, 0] + c * g[:, 1]])


def tangent_samples(field_a: Field, field_b: Field, offset: np.ndarray, angle: np.ndarray,
                    pair: np.ndarray, point: np.ndarray, depth: np.ndarray, normal: np.ndarray,
                    start: np.ndarray, margin: float, extent: float, per_side: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                               np.ndarray]:
    """The contacts of ``placed_field_contacts`` with speculative points along each one's
    tangent: the far side of a tilted or rolling body.

    A contact is one minimum of max(f_a, f_b). A body resting tilted on another, or
    rolling on it, touches at one point, and its far side, where the gap grows away
    from the contact without another minimum, has no contact: when the body turns that
    side down within a step, it is found only once inside (scenes/showcase.toml: the
    heart rolling at 3.3 rad/s on the terrain, its other lobe 18 mm above the ground
    0.7 m away, 20 mm deep a step later). So from each contact (point p, normal n,
    a's frame) the points q = p + t (-n_y, n_x), t = +-k extent / per_side for
    k = 1 .. per_side, are measured: where f_a(q), f_b(q) and the gap f_a + f_b are
    below the margin and the gap is not negative (where the bodies already overlap, the
    descent's contacts hold them), q is a contact of depth -(f_a + f_b), normal
    normalize(grad f_a - grad f_b), point midway between the surfaces
    q + (f_b - f_a) / 2 n (as ``field_field_contacts``). The solver's speculative rows
    then hold that side as the body turns; the reduction keeps the deepest and most
    spread points.

    offset (n, 2), angle (n,): b's placements in a's frame; pair (K,) into them;
    point, normal (K, 2), depth, start (K,): the contacts; margin: m; extent: m, how
    far along the tangent (the smaller body's bounding radius); per_side: samples per
    side. Returns (pair, point, depth, normal, start, element) with the samples after
    their pair's contacts, element 0 for a contact and 1 .. 2 per_side for its samples
    (a key: with the contact's start id, unique within the pair). When both fields
    compile, ``_compiled_samples.tangent_points`` does the same operations (same bits).
    """
    k = len(pair)
    element = np.zeros(k, np.int64)
    if k == 0 or per_side < 1 or not np.isfinite(extent):
        return pair, point, depth, normal, start, element
    a, b = compile_field(field_a), compile_field(field_b)
    if a is not None and b is not None:
        n = len(angle)
        return tangent_programs(PairPrograms.of(a, b, n), offset, angle, pair, point, depth,
                                normal, start, np.full(n, float(margin)),
                                np.full(n, float(extent)), per_side)
    steps = np.arange(1, per_side + 1) * (extent / per_side)
    t = np.concatenate([steps, -steps])                                    # (2 per_side,)
    tangent = np.column_stack([-normal[:, 1], normal[:, 0]])
    owner = np.repeat(np.arange(k), len(t))
    q = point[owner] + np.tile(t, k)[:, None] * tangent[owner]
    placed = pair[owner]
    f_a, g_a = compiled.evaluate(field_a, q)
    f_b, g_b = _in_b(field_b, offset, angle, placed, q)
    gap = f_a + f_b
    rows = np.flatnonzero((gap >= 0.0) & (gap < margin) & (f_a < margin) & (f_b < margin))
    n_q = safe_normalize(g_a[rows] - g_b[rows])
    all_pair = np.concatenate([pair, placed[rows]])
    midway = q[rows] + (0.5 * (f_b[rows] - f_a[rows]))[:, None] * n_q
    order = np.argsort(all_pair, kind="stable")
    return (all_pair[order],
            np.concatenate([point, midway])[order],
            np.concatenate([depth, -gap[rows]])[order],
            np.concatenate([normal, n_q])[order],
            np.concatenate([start, start[owner[rows]]])[order],
            np.concatenate([element, np.tile(np.arange(1, len(t) + 1), k)[rows]])[order])


def tangent_programs(programs: PairPrograms, offset: np.ndarray, angle: np.ndarray,
                     pair: np.ndarray, point: np.ndarray, depth: np.ndarray,
                     normal: np.ndarray, start: np.ndarray, margin: np.ndarray,
                     extent: np.ndarray, per_side: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                np.ndarray]:
    """``tangent_samples`` of n pairs of compiled fields (``programs``), contacts in pair
    order, each pair its own margin and extent (n,) m (finite where a pair has
    contacts): ``_compiled_samples.tangent_points``, the same bits as a call per pair's
    fields."""
    k = len(pair)
    if k == 0 or per_side < 1:
        return pair, point, depth, normal, start, np.zeros(k, np.int64)
    return tangent_points(*programs.args(), programs.run, np.cos(angle), np.sin(angle),
                          np.ascontiguousarray(offset, np.float64), pair, point, depth, normal,
                          start, margin, extent, int(per_side))


#: Directions of the samples around a contact for its one-sided depths.
_RING = np.exp(2j * np.pi * np.arange(8) / 8)
#: A contact is re-measured one-sided when that depth exceeds the balance depth by
#: this fraction of it (and by _FEATURE_ABSOLUTE m). Small: the star's tip pressed into
#: the arc's round end in scenes/showcase.toml read only 7.6 % deeper from the tip,
#: along the end's own normal, than at the balance, whose normal, 40 degrees off the
#: end's, took the arc's slow rocking for a separation of 3.5 mm a step while the tip
#: went in by 2.5 mm a step (17.5 mm at 10 %).
_FEATURE_RELATIVE = 0.01
_FEATURE_ABSOLUTE = 1e-4
#: The samples' offsets from the contact point per unit radius (9, 2): the point itself,
#: then _RING (``_compiled_samples.one_sided``).
_RING_POINTS = np.column_stack([np.r_[0.0, _RING.real], np.r_[0.0, _RING.imag]])


def one_sided_programs(programs: PairPrograms, offset: np.ndarray, angle: np.ndarray,
                       pair: np.ndarray, point: np.ndarray, depth: np.ndarray,
                       normal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``one_sided_depths`` of n pairs of compiled fields (``programs``), contacts in pair
    order: ``_compiled_samples.one_sided``, the same bits as a call per pair's fields."""
    if not np.any(depth > 0.0):
        return point, depth, normal
    return one_sided(*programs.args(), programs.run, np.cos(angle), np.sin(angle),
                     np.ascontiguousarray(offset, np.float64), pair, point, depth, normal,
                     _RING_POINTS, _FEATURE_RELATIVE, _FEATURE_ABSOLUTE)


def one_sided_depths(field_a: Field, field_b: Field, offset: np.ndarray, angle: np.ndarray,
                     pair: np.ndarray, point: np.ndarray, depth: np.ndarray,
                     normal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The overlapping contacts of ``placed_field_contacts`` re-measured at a sharp
    feature: (point, depth, normal), a's frame, as given where nothing changes.

    The descent's contact is the minimum of max(f_a, f_b), where f_a = f_b: a point
    balanced between the two surfaces, with depth -(f_a + f_b) and normal
    normalize(grad f_a - grad f_b). Between smooth surfaces that is the overlap along
    the line of centres. At a sharp feature it is not: a tip of half-angle alpha
    pressed a depth D into a flat face balances at the overlap triangle's incentre,
    depth 2 D sin(alpha) / (1 + sin(alpha)) (0.83 D at 45 degrees) and a normal
    tilted toward the tip's face, and the tip, pushed along that normal, goes on
    sinking (scenes/showcase.toml: the heart's tip under a push, 16.5 mm deep in the
    terrain while its contact read 12.3 mm along a normal 22 degrees off the ground's).
    So each overlapping contact is also measured from each side: b's surface points
    nearest to samples around it (the contact point and 8 points on a circle of
    twice its depth, each moved by -f_b grad f_b: a point of a tip's normal cone lands
    on the tip itself) give the deepest point of b in a, -min f_a, and the same with
    a and b exchanged. Where the deeper of these exceeds the balance depth by
    _FEATURE_RELATIVE of it and by _FEATURE_ABSOLUTE, the contact becomes that point:
    depth -f_a there, normal grad f_a (or -grad f_b for a's point in b), point midway
    between the two surfaces; unless that normal is against the balance normal (their
    dot product <= 0): a depth measured to the nearest face of a thin part the other
    body has passed through, which pushes it the wrong way (scenes/sdf_primitives.toml:
    a vesica's tip in the rounded cross, its normal flipping from step to step, 10.0 mm
    deep; 9.6 mm without those readings). Contacts of smooth surfaces, where the three
    agree, keep their bits. When both fields compile, ``_compiled_samples.one_sided``
    does the same operations (same bits).
    """
    a, b = compile_field(field_a), compile_field(field_b)
    if a is not None and b is not None:
        return one_sided_programs(PairPrograms.of(a, b, len(angle)), offset, angle, pair,
                                  point, depth, normal)
    rows = np.flatnonzero(depth > 0.0)
    if len(rows) == 0:
        return point, depth, normal
    m = len(_RING) + 1
    ring = np.concatenate([[0.0], _RING])
    owner = np.repeat(rows, m)
    radius = np.repeat(2.0 * depth[rows], m)
    q = point[owner] + radius[:, None] * np.column_stack([np.tile(ring.real, len(rows)),
                                                          np.tile(ring.imag, len(rows))])
    placed = pair[owner]
    # b's surface near q, measured in a; a's surface near q, measured in b.
    f_b, g_b = _in_b(field_b, offset, angle, placed, q)
    on_b = q - f_b[:, None] * g_b
    f_a_on_b, g_a_on_b = compiled.evaluate(field_a, on_b)
    f_a, g_a = compiled.evaluate(field_a, q)
    on_a = q - f_a[:, None] * g_a
    f_b_on_a, g_b_on_a = _in_b(field_b, offset, angle, placed, on_a)
    in_a = -f_a_on_b.reshape(-1, m)
    in_b = -f_b_on_a.reshape(-1, m)
    best_a, best_b = in_a.argmax(axis=1), in_b.argmax(axis=1)
    deep_a = in_a[np.arange(len(rows)), best_a]
    deep_b = in_b[np.arange(len(rows)), best_b]
    deeper = np.maximum(deep_a, deep_b)
    change = deeper > np.maximum(depth[rows] * (1.0 + _FEATURE_RELATIVE),
                                 depth[rows] + _FEATURE_ABSOLUTE)
    if not np.any(change):
        return point, depth, normal
    use_a = deep_a >= deep_b
    at_a = np.arange(len(rows)) * m + best_a
    at_b = np.arange(len(rows)) * m + best_b
    n_a = safe_normalize(g_a_on_b[at_a])
    n_b = -safe_normalize(g_b_on_a[at_b])
    side = use_a[:, None]
    new_normal = np.where(side, n_a, n_b)
    new_depth = np.where(use_a, deep_a, deep_b)
    # Midway between the two surfaces: b's point x plus half the depth along n (into
    # a's surface), or a's point x minus it.
    new_point = np.where(side, on_b[at_a], on_a[at_b]) + np.where(side, 0.5, -0.5) \
        * new_depth[:, None] * new_normal
    change &= np.einsum("ij,ij->i", new_normal, normal[rows]) > 0.0
    point, depth, normal = point.copy(), depth.copy(), normal.copy()
    changed = rows[change]
    point[changed] = new_point[change]
    depth[changed] = new_depth[change]
    normal[changed] = new_normal[change]
    return point, depth, normal


def _no_contacts() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``field_field_contacts``' five results for no contact."""
    return (np.zeros(0, dtype=np.int64), np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)),
            np.zeros(0, dtype=np.int64))


def field_field_contacts_single(field_a: Field, field_b: Field, pose_b_in_a: Sequence[float],
                                region: Sequence[float], n_starts: int = 16,
                                iterations: int = 24, margin: float = 0.0
                                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``field_field_contacts`` for one pose (3,) and region (4,).

    Returns (point (K, 2), depth (K,), normal (K, 2), start_id (K,)).
    """
    _, point, depth, normal, start_id = field_field_contacts(
        field_a, field_b, np.reshape(pose_b_in_a, (1, 3)), np.reshape(region, (1, 4)),
        n_starts=n_starts, iterations=iterations, margin=margin)
    return point, depth, normal, start_id

