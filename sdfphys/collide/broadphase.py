"""Broadphase: world bounding boxes of every body and candidate pairs on a hashed grid.

World AABB of one body (``body_box``; ``world_bounds`` runs it over all bodies in one
compiled pass, as the circle fast path's ``reach_and_boxes`` does): the shape's
body-frame AABB ``[x0, y0, x1, y1]`` rotated by the body angle ``a`` and moved to its
centre of mass ``c``, by interval arithmetic,

    x-extent = c_x + cos(a) [x0, x1] - sin(a) [y0, y1]
    y-extent = c_y + sin(a) [x0, x1] + cos(a) [y0, y1]

(``k [lo, hi]`` is ``[k lo, k hi]`` for k > 0, ``[k hi, k lo]`` for k < 0 and
``[0, 0]`` for k = 0, so infinite bounds of unbounded fields stay meaningful: a
half-plane ``y <= 0`` at angle 0 keeps ``y1 = 0``). Multiplying an infinite end,
|k| < 1e-12 counts as 0, so that angle = pi (whose sine is 1.2e-16, not 0) keeps
a flipped ground bounded on one side; the bound is then off by |k| L at distance
L along the boundary, under 1e-6 m for L < 1e6 m. The box is then intersected
with the disc box
``c +- radius`` (radius: bounding radius about the centre of mass). The result is
exact for circles and boxes (the rotated box is its own tightest bound) and
conservative for polygons and fields.

Pairs, beyond ``SWEEP_BODIES`` bodies: a uniform grid, all in numba functions
(``cache=True``), with no comparison sort. Two layouts, the same pairs:

Dense grid (``_dense_pairs``), for boxes of similar size in a compact region (a
pile, a pyramid): the cell side h is just over the largest side among the boxes
at most ``_DENSE_SPREAD`` times the mean side; each box is entered once, in the
cell of its lower corner, and the cells are one row-major array over the occupied
rectangle (counting sort, boxes in id order within a cell). Two boxes that overlap
have sides below h, so their lower-corner cells are equal or neighbours; each box
is tested against the rest of its own cell, the next cell of its row and the three
cells of the next row: one contiguous run of entries each, every pair met once.
Boxes larger than h, infinite, inverted or NaN are "big" (brute force, below). The
layout is used when at most ``_DENSE_BIG`` boxes are big and the rectangle holds
at most ``_DENSE_CELLS`` cells per box (plus ``_DENSE_CELLS_EXTRA``); otherwise the
hashed grid below. h carries a relative slack of ``_DENSE_SLACK``, and cells are
only computed for coordinates under ``_DENSE_REACH`` cells from the origin, so that
the rounding of x / h cannot put the lower corners of two overlapping boxes two
cells apart. For a pile it replaces a hashed table of 64 k buckets for 20 k entries
with 6,400 cells for 5,000 boxes (figures: docs/performance.md, 2026-11-27).

Hashed grid (``_grid_pairs``; Teschner et al. 2003, "Optimized spatial hashing"),
for the rest (mixed sizes, sparse worlds):

1. cell size h = the mean larger side of the finite boxes, leaving out boxes over 4x
   that mean (walls, grounds), so that a typical box covers 2 x 2 cells;
2. each box is entered in every cell (floor(x / h), floor(y / h)) it covers; boxes
   covering more than ``_BIG_CELLS`` cells, with an infinite side or inverted
   (lower > upper: never an AABB, but no memory is written out of bounds), are "big";
3. the entries are counting-sorted by bucket (hash of the cell), boxes in id order;
   within a bucket, two entries of the same cell are tested (closed overlap, one
   body movable) only if that cell holds the low corner of the two boxes'
   intersection, (max lower x, max lower y): both boxes cover it, so each pair is
   found exactly once, and hash collisions of different cells are skipped.

Big boxes (the ground and walls of a scene): the hashed grid tests each against every
other box (O(n) per big box, ``_big_pairs``); the dense grid tests a wall, a ground or
a half-plane only against the boxes of the cells its extent reaches
(``_dense_big_pairs``). Both then sort the pairs by their first body (counting sort)
and by the second within it (insertion sort): (i, j) order, deterministic, O(n + P).

Scenes of at most ``SWEEP_BODIES`` bodies use the sort-and-sweep on x instead
(Baraff 1992: boxes sorted by lower x, each tested against the following ones
while their lower x does not pass its upper x): the same pairs, a kernel that
compiles in a fraction of a second instead of ~2 s on a cold start.

Cost O(n + P) for bounded boxes of similar size (against 1.6-6 ms for the
5000-circle pile with the sort-and-sweep on x, whose inner loop scanned a whole
column of the pile). In the hashed grid, boxes much larger than h are entered in
up to ``_BIG_CELLS`` cells, then tested by brute force: many such boxes degrade
gracefully to O(n) each.

Kept pairs (``PairCache``, a world's, held by its ``ContactCache``): Verlet's neighbour
list (Verlet 1967) as Box2D's fat AABBs use it. The pairs are searched with every box
grown by a skin (``_SKIN_FRACTION`` of its larger side, at most ``_SKIN_MAX``), and
while every body's box stays inside its grown box and no body became movable, the
pairs of the boxes now are those kept pairs whose boxes overlap now with a movable
body: two boxes that overlap now have grown boxes that overlapped, so the kept pairs
hold every pair the search would find. The filter keeps their order: the same pairs,
in the same order, as ``candidate_pairs``, for one compiled pass over the bodies and
the kept pairs (the boxes of a pyramid or a settled pile at rest stay put: no search).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit

__all__ = ["SWEEP_BODIES", "PairCache", "candidate_pairs", "world_bounds"]

#: Rotation coefficients below this count as 0 against infinite bounds (see above).
_TINY_COEFFICIENT = 1e-12


@njit(cache=True)
def _scaled(k: float, lo: float, hi: float) -> tuple[float, float]:
    """Interval ``k * [lo, hi]``; ``k ~ 0`` gives ``[0, 0]`` for infinite ends."""
    if k == 0.0 or (abs(k) < _TINY_COEFFICIENT
                    and not (math.isfinite(lo) and math.isfinite(hi))):
        return 0.0, 0.0
    a = k * lo
    b = k * hi
    return min(a, b), max(a, b)


@njit(cache=True)
def body_box(bounds: np.ndarray, row: int, radius: float, x: float, y: float, angle: float,
             grow: float, out: np.ndarray, at: int) -> None:
    """Write one body's world AABB ``[xmin, ymin, xmax, ymax]`` (m) into ``out[at]``
    (``out`` (B, 4)).

    bounds[row]: (4,) body-frame AABB (may be infinite; ``bounds`` (S, 4)); radius:
    bounding radius about the centre of mass (inf if unbounded); (x, y), angle: the
    pose; grow: m added all round. Where the bounds hold the disc's box (a circle's),
    the disc's box is the answer at every angle (the turned bounds hold the disc), so
    no rotation is computed. Tables and rows, not row views: a view made per body in
    a loop costs numba an atomic reference count (docs/performance.md).
    """
    x0, y0, x1, y1 = bounds[row, 0], bounds[row, 1], bounds[row, 2], bounds[row, 3]
    if x0 <= -radius and y0 <= -radius and x1 >= radius and y1 >= radius:
        out[at, 0] = -radius + x - grow
        out[at, 1] = -radius + y - grow
        out[at, 2] = radius + x + grow
        out[at, 3] = radius + y + grow
        return
    c = math.cos(angle)
    s = math.sin(angle)
    ax_lo, ax_hi = _scaled(c, x0, x1)
    bx_lo, bx_hi = _scaled(-s, y0, y1)
    ay_lo, ay_hi = _scaled(s, x0, x1)
    by_lo, by_hi = _scaled(c, y0, y1)
    out[at, 0] = max(ax_lo + bx_lo, -radius) + x - grow
    out[at, 1] = max(ay_lo + by_lo, -radius) + y - grow
    out[at, 2] = min(ax_hi + bx_hi, radius) + x + grow
    out[at, 3] = min(ay_hi + by_hi, radius) + y + grow


@njit(cache=True)
def _world_bounds(local_bounds, radius, position, angle, margin, out):
    for i in range(angle.shape[0]):
        body_box(local_bounds, i, radius[i], position[i, 0], position[i, 1], angle[i],
                 margin[i], out, i)


def world_bounds(local_bounds: np.ndarray, radius: np.ndarray, position: np.ndarray,
                 angle: np.ndarray, margin: float | np.ndarray = 0.0) -> np.ndarray:
    """World AABBs (B, 4) ``[xmin, ymin, xmax, ymax]`` of B bodies, grown by ``margin`` (m).

    margin: one growth for all bodies, or (B,) one per body (``find_contacts`` grows a
    moving body's box by the distance its points may travel in a step).

    local_bounds: (B, 4) body-frame AABBs (centre of mass at the origin; entries may
        be infinite for unbounded fields). radius: (B,) bounding radius about the
        centre of mass (inf if unbounded). position: (B, 2) centres of mass, world.
        angle: (B,) radians, counter-clockwise. One compiled pass (``body_box``).
    """
    n = len(angle)
    out = np.empty((n, 4))
    _world_bounds(np.ascontiguousarray(local_bounds, np.float64).reshape(-1, 4),
                  np.ascontiguousarray(radius, np.float64).reshape(-1),
                  np.ascontiguousarray(position, np.float64).reshape(-1, 2),
                  np.ascontiguousarray(angle, np.float64).reshape(-1),
                  np.ascontiguousarray(np.broadcast_to(np.asarray(margin, np.float64), (n,))),
                  out)
    return out


#: Scenes of up to this many bodies take the sort-and-sweep (see candidate_pairs).
SWEEP_BODIES = 256
#: A box covering more grid cells than this is paired by brute force (see above).
_BIG_CELLS = 64
#: Cell indices are clamped to +-this (coordinates beyond share the edge cells), so
#: that a cell packs into one int64 key.
_CELL_CLAMP = float(2 ** 30)
_CELL_OFFSET = 2 ** 30


@njit(cache=True)
def _cell(x: float, inv_h: float) -> int:
    """Grid column (or row) of coordinate ``x`` (m): floor(x / h), clamped; monotone in x."""
    return int(min(max(np.floor(x * inv_h), -_CELL_CLAMP), _CELL_CLAMP))


@njit(cache=True)
def _hash(cx: int, cy: int, mask: int) -> int:
    """Bucket of cell (cx, cy) in a table of mask + 1 (a power of two) buckets."""
    return (((cx * 73856093) ^ (cy * 19349663)) & mask)


@njit(cache=True)
def _overlap(box: np.ndarray, i: int, j: int) -> bool:
    """Closed boxes i and j of ``box`` (B, 4) overlap (NaN overlaps nothing); ``&``, not
    ``and``: no branch per comparison (``_grid_pairs``)."""
    return ((box[j, 0] <= box[i, 2]) & (box[i, 0] <= box[j, 2])
            & (box[j, 1] <= box[i, 3]) & (box[i, 1] <= box[j, 3]))


@njit(cache=True)
def _cell_size(box: np.ndarray) -> float:
    """Grid cell (m): the mean larger side of the finite boxes, outliers (sides over 4x
    the mean: walls, grounds) left out; 1 if no box has a positive finite side."""
    total, count = 0.0, 0
    for i in range(box.shape[0]):
        side = max(box[i, 2] - box[i, 0], box[i, 3] - box[i, 1])
        if math.isfinite(side) and side > 0.0:
            total += side
            count += 1
    if count == 0:
        return 1.0
    mean = total / count
    total, count = 0.0, 0
    for i in range(box.shape[0]):
        side = max(box[i, 2] - box[i, 0], box[i, 3] - box[i, 1])
        if math.isfinite(side) and 0.0 < side <= 4.0 * mean:
            total += side
            count += 1
    return total / count


@njit(cache=True)
def _cursors(start: np.ndarray) -> np.ndarray:
    """A counting sort's bucket starts, in place: ``start`` (N + 1,) holding bucket b's
    count at b + 1 becomes each bucket's first slot (a prefix sum); returns a copy of
    its first N entries, the buckets' fill cursors."""
    n = start.shape[0] - 1
    for b in range(n):
        start[b + 1] += start[b]
    fill = np.empty(n, np.int64)
    for b in range(n):
        fill[b] = start[b]
    return fill


@njit(cache=True)
def _sorted_pairs(first: np.ndarray, second: np.ndarray, count: int, n: int) -> np.ndarray:
    """Pairs (count, 2) sorted by (first, second): counting sort on first, then an
    insertion sort of each first's few partners."""
    start = np.zeros(n + 1, np.int64)
    for k in range(count):
        start[first[k] + 1] += 1
    fill = _cursors(start)
    out = np.empty((count, 2), np.int64)
    for k in range(count):
        p = fill[first[k]]
        fill[first[k]] = p + 1
        out[p, 0] = first[k]
        out[p, 1] = second[k]
    for i in range(n):
        for p in range(start[i] + 1, start[i + 1]):
            value = out[p, 1]
            q = p - 1
            while q >= start[i] and out[q, 1] > value:
                out[q + 1, 1] = out[q, 1]
                q -= 1
            out[q + 1, 1] = value
    return out


@njit(cache=True)
def _grid_pairs(box: np.ndarray, movable: np.ndarray) -> np.ndarray:
    """Pairs (P, 2) int64 (i < j) of overlapping closed boxes (B, 4) with a movable
    body, sorted by (i, j); see the module docstring (hashed uniform grid)."""
    n = box.shape[0]
    inv_h = 1.0 / _cell_size(box)
    cx0 = np.empty(n, np.int64)
    cy0 = np.empty(n, np.int64)
    cx1 = np.empty(n, np.int64)
    cy1 = np.empty(n, np.int64)
    big = np.zeros(n, np.bool_)
    n_entries = 0
    for i in range(n):
        finite = True
        for c in range(4):
            finite = finite and math.isfinite(box[i, c])
        if finite:
            cx0[i] = _cell(box[i, 0], inv_h)
            cy0[i] = _cell(box[i, 1], inv_h)
            cx1[i] = _cell(box[i, 2], inv_h)
            cy1[i] = _cell(box[i, 3], inv_h)
            wide = cx1[i] - cx0[i] + 1
            tall = cy1[i] - cy0[i] + 1
            if 0 < wide <= _BIG_CELLS and 0 < tall <= _BIG_CELLS and wide * tall <= _BIG_CELLS:
                n_entries += wide * tall
                continue
        big[i] = True
    table = 16
    while table < 2 * n_entries:
        table *= 2
    mask = table - 1
    # Counting sort of the (box, cell) entries by bucket; boxes in id order, so each
    # bucket lists its boxes by increasing id.
    start = np.zeros(table + 1, np.int64)
    for i in range(n):
        if not big[i]:
            for cx in range(cx0[i], cx1[i] + 1):
                for cy in range(cy0[i], cy1[i] + 1):
                    start[_hash(cx, cy, mask) + 1] += 1
    fill = _cursors(start)
    entry_box = np.empty(n_entries, np.int64)
    entry_cell = np.empty(n_entries, np.int64)
    entry_home = np.empty(n_entries, np.int64)
    for i in range(n):
        if not big[i]:
            for cx in range(cx0[i], cx1[i] + 1):
                for cy in range(cy0[i], cy1[i] + 1):
                    b = _hash(cx, cy, mask)
                    p = fill[b]
                    fill[b] = p + 1
                    entry_box[p] = i
                    entry_cell[p] = ((cx + _CELL_OFFSET) << 32) | (cy + _CELL_OFFSET)
                    entry_home[p] = (cx == cx0[i]) | ((cy == cy0[i]) << 1)
    # Every candidate of a bucket takes a row, kept or not: the buckets' candidate
    # counts (which the loop below visits anyway) bound the rows.
    rows = 4 * n + 16
    for b in range(table):
        size = start[b + 1] - start[b]
        rows += size * (size - 1) // 2
    first = np.empty(rows, np.int64)
    second = np.empty(rows, np.int64)
    count = 0
    for b in range(table):
        for p in range(start[b], start[b + 1]):
            i = entry_box[p]
            cell = entry_cell[p]
            home = entry_home[p]
            for q in range(p + 1, start[b + 1]):
                # Same cell (not a hash collision), and the cell is the one holding the
                # low corner of the two boxes' intersection, max(lower x), max(lower y):
                # both boxes cover it, so each pair is reported once. Without branches:
                # which candidates pass is unpredictable (the 2,000-circle pile's grid
                # took 445 us with them, 340 without).
                j = entry_box[q]
                first[count] = i
                second[count] = j
                count += ((entry_cell[q] == cell) & ((home | entry_home[q]) == 3)
                          & (movable[i] | movable[j]) & _overlap(box, i, j))
    first, second, count = _big_pairs(box, movable, big, first, second, count)
    return _sorted_pairs(first, second, count, n)


@njit(cache=True)
def _big_pairs(box: np.ndarray, movable: np.ndarray, big: np.ndarray, first: np.ndarray,
               second: np.ndarray, count: int):
    """Append the pairs of each big box (``big`` (B,) bool) with every other box, by
    brute force, each pair once; returns (first, second, count) as ``_append``."""
    for g in np.flatnonzero(big):
        first, second, count = _brute_pairs(box, movable, big, g, first, second, count)
    return first, second, count


@njit(cache=True)
def _brute_pairs(box: np.ndarray, movable: np.ndarray, big: np.ndarray, g: int,
                 first: np.ndarray, second: np.ndarray, count: int):
    """Append the pairs of big box g with every other box but the big ones before it
    (``_big_pairs``' rule: each pair once). Room for every box is made first and the
    loop writes each candidate's row, kept or not (as ``_dense_pairs``): a call that may
    grow the arrays inside the loop makes numba count the arrays' references every
    iteration, which cost more than the overlap tests.
    Returns (first, second, count) as ``_append``."""
    n = box.shape[0]
    if count + n > first.shape[0]:
        first = _grown(first, 2 * (count + n))
        second = _grown(second, 2 * (count + n))
    for k in range(n):
        first[count] = min(g, k)
        second[count] = max(g, k)
        count += ((k != g) & (not (big[k] and k < g)) & (movable[g] | movable[k])
                  & _overlap(box, g, k))
    return first, second, count


#: The dense grid's cell is just over the largest box side up to this many mean sides;
#: larger boxes are big (see above).
_DENSE_SPREAD = 2.0
#: At most this many big boxes, and this many cells per box (plus the extra), for
#: the dense grid; beyond, the hashed grid.
_DENSE_BIG = 32
_DENSE_CELLS = 4
_DENSE_CELLS_EXTRA = 4096
#: Relative slack of the dense cell over the largest side, and the largest |x| / h
#: for which a box gets a dense cell: x / h is then rounded by under 2e-8, far
#: within the slack, so that overlapping boxes sit in neighbouring cells.
_DENSE_SLACK = 1e-6
_DENSE_REACH = 1e8


@njit(cache=True)
def _dense_pairs(box: np.ndarray, movable: np.ndarray):
    """(True, pairs (P, 2) int64 sorted by (i, j)) of overlapping closed boxes (B, 4)
    with a movable body, on the dense grid (module docstring); (False, an empty
    array) when the boxes do not suit it (too many big ones, too sparse)."""
    n = box.shape[0]
    none = np.empty((0, 2), np.int64)
    limit = _DENSE_SPREAD * _cell_size(box)
    side = 0.0
    for i in range(n):
        s = max(box[i, 2] - box[i, 0], box[i, 3] - box[i, 1])
        if s <= limit:         # False for NaN and infinite sides
            side = max(side, s)
    h = side * (1.0 + _DENSE_SLACK) if side > 0.0 else 1.0
    inv_h = 1.0 / h
    cx = np.empty(n, np.int64)
    cy = np.empty(n, np.int64)
    big = np.zeros(n, np.bool_)
    n_big = 0
    gx0, gy0, gx1, gy1 = 0, 0, -1, -1
    for i in range(n):
        x, y = box[i, 0] * inv_h, box[i, 1] * inv_h
        wide = box[i, 2] - box[i, 0]
        tall = box[i, 3] - box[i, 1]
        if (0.0 <= wide <= side and 0.0 <= tall <= side and abs(x) < _DENSE_REACH
                and abs(y) < _DENSE_REACH):
            cx[i] = int(math.floor(x))
            cy[i] = int(math.floor(y))
            if gx1 < gx0:
                gx0, gy0, gx1, gy1 = cx[i], cy[i], cx[i], cy[i]
            gx0, gy0 = min(gx0, cx[i]), min(gy0, cy[i])
            gx1, gy1 = max(gx1, cx[i]), max(gy1, cy[i])
        else:
            big[i] = True
            n_big += 1
    # One empty column either side and one empty row above: every entry's runs below
    # stay in the table.
    width = gx1 - gx0 + 3
    height = gy1 - gy0 + 2
    if n_big > _DENSE_BIG or width * height > _DENSE_CELLS * n + _DENSE_CELLS_EXTRA:
        return False, none
    cells = width * height
    cell = np.empty(n, np.int64)
    start = np.zeros(cells + 1, np.int64)
    for i in range(n):
        if not big[i]:
            cell[i] = (cy[i] - gy0) * width + (cx[i] - gx0 + 1)
            start[cell[i] + 1] += 1
    fill = _cursors(start)
    entry = np.empty(n - n_big, np.int64)
    for i in range(n):
        if not big[i]:
            entry[fill[cell[i]]] = i
            fill[cell[i]] += 1
    # Candidates of entry p: the rest of its cell and the next cell (one run), then the
    # three cells of the next row (another); each takes a row, kept or not (branchless,
    # as in ``_grid_pairs``). Their number first, so that the rows are allocated once
    # (an array rebound in the loop costs its reference counts every pass).
    capacity = 16
    for p in range(n - n_big):
        c = cell[entry[p]]
        capacity += (start[c + 2] - p - 1) + (start[c + width + 2] - start[c + width - 1])
    first = np.empty(capacity, np.int64)
    second = np.empty(capacity, np.int64)
    count = 0
    for p in range(n - n_big):
        i = entry[p]
        c = cell[i]
        run, end = p + 1, start[c + 2]
        above, above_end = start[c + width - 1], start[c + width + 2]
        for q in range(run, end):
            j = entry[q]
            first[count] = min(i, j)
            second[count] = max(i, j)
            count += (movable[i] | movable[j]) & _overlap(box, i, j)
        for q in range(above, above_end):
            j = entry[q]
            first[count] = min(i, j)
            second[count] = max(i, j)
            count += (movable[i] | movable[j]) & _overlap(box, i, j)
    grid = (inv_h, gx0, gy0, gx1, gy1, width)
    first, second, count = _dense_big_pairs(box, movable, big, grid, start, entry, first,
                                            second, count)
    return True, _sorted_pairs(first, second, count, n)


@njit(cache=True)
def _clamped_cell(x: float, lo: int, hi: int) -> int:
    """floor(x) for x in cell units, clamped to [lo - 3, hi + 3] first (x may be
    infinite)."""
    return int(math.floor(min(max(x, lo - 3.0), hi + 3.0)))


@njit(cache=True)
def _dense_big_pairs(box: np.ndarray, movable: np.ndarray, big: np.ndarray, grid, start,
                     entry, first: np.ndarray, second: np.ndarray, count: int):
    """``_big_pairs`` on the dense grid: a big box with no NaN side and lower <= upper
    (a wall, a ground, a half-plane) is tested against the boxes of the cells its
    extent reaches, not against every box: another box overlaps it only if that box's
    lower corner, in its cell, lies within [lower - h, upper] of it (its sides are
    under h), and floor(x / h) is monotone in x, so the cells from floor(lower / h) - 2
    to floor(upper / h) + 1, clipped to the occupied rectangle, hold every such box.
    Big boxes are tested against each other, and a big box with a NaN or inverted
    side against every box, by brute force (``_big_pairs``' rule: each pair once).
    grid: (1 / h, the rectangle's lowest and highest cell columns and rows, its
    width in cells), start and entry: the cells' runs of boxes (``_dense_pairs``).
    Returns (first, second, count) as ``_append``."""
    inv_h, gx0, gy0, gx1, gy1, width = grid
    bigs = np.flatnonzero(big)
    for g in bigs:
        regular = (box[g, 0] <= box[g, 2]) and (box[g, 1] <= box[g, 3])
        if not regular:                      # a NaN side or an inverted box
            first, second, count = _brute_pairs(box, movable, big, g, first, second, count)
            continue
        for k in bigs:
            if k > g and (movable[g] or movable[k]) and _overlap(box, g, k):
                first, second, count = _append(first, second, count, g, k)
        if gx1 < gx0:                        # no box in the grid
            continue
        x0 = max(_clamped_cell(box[g, 0] * inv_h, gx0, gx1) - 2, gx0)
        x1 = min(_clamped_cell(box[g, 2] * inv_h, gx0, gx1) + 1, gx1)
        y0 = max(_clamped_cell(box[g, 1] * inv_h, gy0, gy1) - 2, gy0)
        y1 = min(_clamped_cell(box[g, 3] * inv_h, gy0, gy1) + 1, gy1)
        for cy in range(y0, y1 + 1):
            row = (cy - gy0) * width - gx0 + 1
            run, end = start[row + x0], start[row + x1 + 1]
            if count + (end - run) > first.shape[0]:
                first = _grown(first, 2 * (count + end - run))
                second = _grown(second, 2 * (count + end - run))
            for q in range(run, end):
                j = entry[q]
                first[count] = min(g, j)
                second[count] = max(g, j)
                count += (movable[g] | movable[j]) & _overlap(box, g, j)
    return first, second, count


@njit(cache=True)
def _append(first: np.ndarray, second: np.ndarray, count: int, i: int, j: int):
    """The pair lists with (i, j) at row ``count``, doubled first when full; returns
    (first, second, count + 1)."""
    if count == first.shape[0]:
        first = _grown(first, 2 * count)
        second = _grown(second, 2 * count)
    first[count] = i
    second[count] = j
    return first, second, count + 1


@njit(cache=True)
def _grown(a: np.ndarray, capacity: int) -> np.ndarray:
    """``a`` copied into a new array of ``capacity`` entries (a loop: a slice
    assignment costs seconds of compilation on a cold start)."""
    out = np.empty(capacity, np.int64)
    for k in range(a.shape[0]):
        out[k] = a[k]
    return out


@njit(cache=True)
def _sweep(order: np.ndarray, box: np.ndarray, movable: np.ndarray, out: np.ndarray) -> int:
    """Sort-and-sweep on x: overlapping pairs (lo, hi) of body ids into ``out`` (C, 2);
    returns their count (pairs beyond ``out``'s capacity are counted, not written).

    ``box`` (B, 4) and ``movable`` (B,) are already sorted by lower x; ``order`` maps
    back to body ids. Each box is tested against the following ones while their
    lower x does not pass its upper x.
    """
    n = order.shape[0]
    capacity = out.shape[0]
    count = 0
    for i in range(n):
        hi_x = box[i, 2]
        lo_y = box[i, 1]
        hi_y = box[i, 3]
        for j in range(i + 1, n):
            if box[j, 0] > hi_x:
                break
            if not (movable[i] or movable[j]):
                continue
            if not (box[j, 1] <= hi_y and lo_y <= box[j, 3]):     # NaN overlaps nothing
                continue
            if count < capacity:
                out[count, 0] = min(order[i], order[j])
                out[count, 1] = max(order[i], order[j])
            count += 1
    return count


def candidate_pairs(bounds: np.ndarray, movable: np.ndarray) -> np.ndarray:
    """Pairs (P, 2) int64 ``(i, j)``, i < j, whose boxes overlap and one of which can move.

    bounds: (B, 4) world AABBs (closed boxes: touching boxes pair).
    movable: (B,) bool. Output sorted by (i, j), deterministic.

    Up to ``SWEEP_BODIES`` bodies: sort-and-sweep on x (``_sweep``); beyond, the dense
    grid (``_dense_pairs``) or, where it does not suit the boxes, the hashed grid
    (``_grid_pairs``). Same pairs either way; the sweep compiles in a fraction of a
    second, so a small scene's cold start does not pay the grid's ~2 s compilation.
    """
    bounds = np.ascontiguousarray(bounds, dtype=np.float64)
    movable = np.ascontiguousarray(movable, dtype=np.bool_)
    if len(bounds) > SWEEP_BODIES:
        dense, pairs = _dense_pairs(bounds, movable)
        return pairs if dense else _grid_pairs(bounds, movable)
    order = np.argsort(bounds[:, 0], kind="stable")
    box = np.ascontiguousarray(bounds[order])
    moving = movable[order]
    pairs = np.empty((4 * len(order) + 16, 2), np.int64)
    count = _sweep(order, box, moving, pairs)
    if count > len(pairs):
        pairs = np.empty((count, 2), np.int64)
        _sweep(order, box, moving, pairs)
    n = np.int64(len(order))
    keys = np.sort(pairs[:count, 0] * n + pairs[:count, 1])
    return np.stack([keys // n, keys % n], axis=1)


#: The kept pairs' skin: each box is grown by this fraction of its larger side on every
#: side, at most ``_SKIN_MAX`` m (a 1 m box by 0.1 m; Box2D v3's aabbMargin is 0.1 m).
_SKIN_FRACTION = 0.1
_SKIN_MAX = 0.1


@njit(cache=True)
def _kept_pairs(pairs: np.ndarray, grown: np.ndarray, grown_movable: np.ndarray,
                box: np.ndarray, movable: np.ndarray):
    """(True, the rows of ``pairs`` (P, 2) whose boxes (B, 4) overlap with a movable
    body) while every box lies inside its ``grown`` box (B, 4) and ``movable`` (B,)
    bool holds no body that ``grown_movable`` did not; (False, no pairs) otherwise
    (another body count, a box outside, NaN, a body that became movable)."""
    none = np.empty((0, 2), np.int64)
    n = box.shape[0]
    if grown.shape[0] != n:
        return False, none
    for i in range(n):
        inside = ((box[i, 0] >= grown[i, 0]) & (box[i, 1] >= grown[i, 1])
                  & (box[i, 2] <= grown[i, 2]) & (box[i, 3] <= grown[i, 3]))
        if not inside or (movable[i] and not grown_movable[i]):
            return False, none
    out = np.empty((pairs.shape[0], 2), np.int64)
    count = 0
    for p in range(pairs.shape[0]):
        i = pairs[p, 0]
        j = pairs[p, 1]
        out[count, 0] = i
        out[count, 1] = j
        count += (movable[i] | movable[j]) & _overlap(box, i, j)
    return True, out[:count]


class PairCache:
    """A world's broadphase pairs, kept from step to step (module docstring, "Kept
    pairs"): the grown boxes (B, 4), which bodies were movable (B,) bool, and the pairs
    (P, 2) of the grown boxes. Plain arrays: a copied or pickled world steps on as the
    original (and an empty cache gives the same pairs, by a search)."""

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """Keep nothing: the next query searches."""
        self.grown = np.zeros((0, 4))
        self.movable = np.zeros(0, bool)
        self.pairs = np.zeros((0, 2), np.int64)

    def candidate_pairs(self, bounds: np.ndarray, movable: np.ndarray) -> np.ndarray:
        """``candidate_pairs(bounds, movable)``, from the kept pairs while they hold
        them, else by a search of grown boxes, which are kept."""
        bounds = np.ascontiguousarray(bounds, dtype=np.float64)
        movable = np.ascontiguousarray(movable, dtype=np.bool_)
        kept, pairs = _kept_pairs(self.pairs, self.grown, self.movable, bounds, movable)
        if kept:
            return pairs
        side = np.maximum(bounds[:, 2] - bounds[:, 0], bounds[:, 3] - bounds[:, 1])
        with np.errstate(invalid="ignore"):
            skin = np.minimum(_SKIN_FRACTION * side, _SKIN_MAX)
        skin = np.where(skin > 0.0, skin, 0.0)                 # NaN, inverted: none
        self.grown = bounds + np.column_stack([-skin, -skin, skin, skin])
        self.movable = movable.copy()
        self.pairs = candidate_pairs(self.grown, movable)
        kept, pairs = _kept_pairs(self.pairs, self.grown, self.movable, bounds, movable)
        if kept:
            return pairs
        self.clear()                        # a NaN box is inside nothing: keep nothing
        return candidate_pairs(bounds, movable)
