"""Contact reduction: a few well-spread points per body pair.

The narrowphase may report many candidate points for one pair (every triangle,
every descent start). The solver needs few: in 2D, a flat contact patch is held
by its two end points, and each additional face in contact (a box in a V groove, a
concave L on two supports) adds at most two more. Reduction, per pair, after
Box2D's manifolds (two points per face contact) and MuJoCo's multi-contact
reduction (keep the deepest, then points that maximize the spread):

1. start with the deepest candidate (ties broken by the smaller feature key);
2. repeatedly add, among the candidates whose *novelty* with respect to the kept
   set exceeds ``tolerance``, the one with the largest novelty less its gap
   (novelty + min(depth, 0)), while fewer than ``budget`` points are kept: the
   budget goes first to what is touching or nearest to it, and a speculative point
   must be farther from the kept ones than from contact to win over a touching one
   (a spinning star's touching spike tip is not dropped for the most spread gaps);
3. after each addition, drop kept points that have become redundant (their
   novelty with respect to the other kept points is at most ``tolerance``).

Novelty of a candidate c (point p, depth d) with respect to a kept set K is the
smallest, over the "elements" of K (each kept point, and each segment between two
kept points), of ``max(|p - q|, d - d_q)``, q the nearest point of the element
to p and d_q the depth interpolated linearly there. A point lying on the segment
between two kept points (within ``tolerance``), no deeper than the interpolation
of their depths, adds nothing: for a straight edge against a flat surface the
separation is an affine function along the edge, so constraints that hold at the
two end points hold in between. That holds on one plane: where the three normals
do not agree within 0.1 rad (``SAME_PLANE``), a segment covers only a candidate no
deeper than its interpolated depth (the slop's latitude is for one plane). A sharp
corner of a baked piece falling end-on onto the ground had its vertical row (the
corner over the ground's face, 21.9 mm above it, 2.4 mm deeper than the segment)
dropped as lying between a row on the corner's blunted side (tilted 34 degrees,
22.6 mm) and the piece's far end; the tilted row let the corner sink 44 mm within
the step.

Step 3 lets the end points of a flat patch replace a deepest point that happened to
lie in its middle (equal depths), so a box resting flat on a box keeps exactly its
two corners.

Shadowing: a candidate within distance d_q of a kept point q of depth d_q (and
not deeper than it) has novelty 0. Such points describe the same feature seen at
the scale of the penetration: typically the other direction's view of a vertex
pressing into a face (the face's points inside the vertex's wedge, whose depth
and normal the field underestimates, see ``narrowphase``), or a point at the end
of a flat patch where the field's nearest face switches to the side face.

Everything runs in one numba function over all pairs (no Python loop over pairs or
contacts); the input order fixes every tie, so the result is deterministic.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit

__all__ = ["SAME_PLANE", "reduce_contacts"]

#: Cosine of the largest angle (0.1 rad) between the normals of a segment's two kept
#: points and a candidate for the segment to cover it (module docstring).
SAME_PLANE = float(np.cos(0.1))


@njit(cache=True)
def _element_novelty(px: float, py: float, d: float, ax: float, ay: float, da: float,
                     bx: float, by: float, db: float, strict: bool) -> float:
    """max(distance, depth excess) of (p, d) to the segment a-b (a point if a == b).

    A point element a (a == b) shadows (p, d) within its depth: 0 when
    |p - a| <= da and d <= da. ``strict`` (a segment whose ends' normals and p's are
    on no common plane): a p deeper than the segment's interpolated depth is not
    covered (inf).
    """
    ex = bx - ax
    ey = by - ay
    length2 = ex * ex + ey * ey
    t = 0.0
    if length2 > 0.0:
        t = ((px - ax) * ex + (py - ay) * ey) / length2
        t = min(max(t, 0.0), 1.0)
    qx = ax + t * ex - px
    qy = ay + t * ey - py
    distance = np.sqrt(qx * qx + qy * qy)
    excess = d - (da + t * (db - da))
    if length2 == 0.0 and distance <= da and excess <= 0.0:
        return 0.0
    if strict and excess > 0.0:
        return np.inf
    return max(distance, excess)


@njit(cache=True)
def _novelty(c: int, kept: np.ndarray, n_kept: int, skip: int, point: np.ndarray,
             depth: np.ndarray, normal: np.ndarray) -> float:
    """Novelty of candidate ``c`` against ``kept[:n_kept]`` except ``kept[skip]``; a
    segment whose ends' normals do not both agree with c's (``SAME_PLANE``) covers c
    only where c is no deeper than the segment's interpolated depth."""
    best = np.inf
    px, py, d = point[c, 0], point[c, 1], depth[c]
    nx, ny = normal[c, 0], normal[c, 1]
    for u in range(n_kept):
        if u == skip:
            continue
        a = kept[u]
        for v in range(u, n_kept):
            if v == skip:
                continue
            b = kept[v]
            strict = b != a and (nx * normal[a, 0] + ny * normal[a, 1] < SAME_PLANE
                                 or nx * normal[b, 0] + ny * normal[b, 1] < SAME_PLANE)
            best = min(best, _element_novelty(px, py, d, point[a, 0], point[a, 1], depth[a],
                                              point[b, 0], point[b, 1], depth[b], strict))
    return best


@njit(cache=True)
def _reduce(start: np.ndarray, point: np.ndarray, depth: np.ndarray, normal: np.ndarray,
            budget: int, tolerance: float, keep: np.ndarray) -> None:
    kept = np.empty(budget, np.int64)
    for g in range(start.shape[0] - 1):
        s, e = start[g], start[g + 1]
        kept[0] = s
        n_kept = 1
        for _ in range(e - s):
            if n_kept >= budget:
                break
            best, best_score = -1, -np.inf
            for c in range(s, e):
                is_kept = False
                for u in range(n_kept):
                    is_kept = is_kept or kept[u] == c
                if is_kept:
                    continue
                novelty = _novelty(c, kept, n_kept, -1, point, depth, normal)
                if not novelty > tolerance:
                    continue
                score = novelty + min(depth[c], 0.0)
                if score > best_score:
                    best, best_score = c, score
            if best < 0:
                break
            kept[n_kept] = best
            n_kept += 1
            u = 0
            while u < n_kept - 1:
                if _novelty(kept[u], kept, n_kept, u, point, depth, normal) <= tolerance:
                    # A loop, not kept[u:n - 1] = kept[u + 1:n]: the slice assignment
                    # costs seconds of compilation on a cold start.
                    for v in range(u, n_kept - 1):
                        kept[v] = kept[v + 1]
                    n_kept -= 1
                else:
                    u += 1
        for u in range(n_kept):
            keep[kept[u]] = True


def reduce_contacts(pair_start: np.ndarray, point: np.ndarray, depth: np.ndarray,
                    normal: np.ndarray, budget: int, tolerance: float) -> np.ndarray:
    """Mask (K,) bool of the candidates kept, at most ``budget`` per pair.

    pair_start: (G + 1,) int64 offsets: pair g owns candidates
        ``pair_start[g]:pair_start[g + 1]``, sorted by depth (deepest first), then
        by feature key. point: (K, 2) contact points (m, any common frame).
    depth: (K,) penetration (m, > 0 overlapping). normal: (K, 2) unit contact normals.
    budget: >= 1 points per pair.
    tolerance: m, novelty at or below which a point adds nothing (the solver's
        linear slop is a natural choice).
    """
    keep = np.zeros(len(depth), np.bool_)
    _reduce(np.ascontiguousarray(pair_start, dtype=np.int64),
            np.ascontiguousarray(point, dtype=np.float64),
            np.ascontiguousarray(depth, dtype=np.float64),
            np.ascontiguousarray(normal, dtype=np.float64), int(max(budget, 1)),
            float(tolerance), keep)
    return keep
