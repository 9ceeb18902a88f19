"""Editing a baked grid in place: carve (CSG difference) and deposit (union), then re-distance.

A grid ``GridField`` (float64 storage) holds node values v of a field A. Carving a field
C placed at pose (t, a) in the grid's frame sets, on the nodes whose window covers C's
bounds grown by ``REDISTANCE_CELLS`` cells,

    v <- max(v, -c)   (carve: A minus C)        v <- min(v, c)   (deposit: A union C)

with c the distance of C at the node. Where A and C are exact, max(v, -c) is exact
inside the result and only a lower bound outside it (near the rims of the hole, the
nearest point of the new boundary is a corner that neither field sees); min(v, c) is
exact outside and a bound inside. So the window is then re-distanced: every node
within R = ``REDISTANCE_CELLS`` cells of the new boundary gets its distance to it,
with its sign kept. The boundary is the zero level of the nodes, piecewise linear:
marching squares (a node is inside where v <= 0; the zero crossing of each cell edge
by linear interpolation; a saddle cell split by the sign of its centre's mean), and a
node's distance is the distance to the nearest such segment within R (cells searched:
the window grown by R).
Nodes with no segment within R keep sign(v) max(|v|, R): their true distance is at
least R, and the side where max / min was exact already has |v| >= R.

Why a window of reach R suffices: a node p outside it is farther than R from C's
bounds B. If |v(p)| < R, the nearest point of the old boundary is not in B, it is still
on the new boundary, and no new boundary point (all in B) is nearer: v(p) is exact and
unchanged. Otherwise the true distance is >= R and v(p) has the right sign (outside a
carve the distance only grows; inside, the nearest new boundary point is at least R
away): after edits, values are true distances (to the grid's accuracy) within R of the
boundary and have the right sign, with magnitude >= R, everywhere else.

Errors: the marching-squares boundary lies within one cell of the bilinear zero level
(on each edge the linear crossing is exact for the interpolant; inside a cell the two
differ by less than the cell), so re-distanced values are within about one cell of
the exact distance to the analytic CSG result (tests/test_terrain.py checks this
against max(f, -c) and min(f, c) computed exactly).

Cost: the window has (w / h + 2 R)^2 nodes for a shape of width w; each searches
(2 R + 2)^2 cells. It does not depend on the number of earlier edits, nor on the
grid's size: the grid's arrays keep their shape and dtype (no recompilation), and the
edit is clipped to the grid (nodes beyond it do not exist: nothing is carved or
deposited there).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .._jit import njit
from .base import Field
from .compiled import consts_changed
from .grid import GridField
from .opcodes import GRID

__all__ = ["GRID_HEADER", "REDISTANCE_CELLS", "edit_grid", "redistance", "write_window"]

#: Reach R of the re-distancing, in cells (see the module docstring).
REDISTANCE_CELLS = 8

#: A GRID instruction's constants before the node values: origin x, y, cell, the four
#: side margins, band (``compiled._emit``).
GRID_HEADER = 8


def write_window(code: np.ndarray, consts: np.ndarray, row: int, grid: GridField,
                 window: tuple[int, int, int, int]) -> None:
    """Copy ``grid``'s node values on ``window`` (i0, i1, j0, j1) into ``consts``, the
    constants of a program whose instruction ``row`` of ``code`` is that grid's GRID."""
    assert code[row, 0] == GRID
    nx, ny = grid.shape
    i0, i1, j0, j1 = window
    o = int(code[row, 1]) + GRID_HEADER
    consts[o:o + nx * ny].reshape(nx, ny)[i0:i1, j0:j1] = grid._values[i0:i1, j0:j1]


def edit_grid(grid: GridField, shape: Field, position, angle: float, deposit: bool,
              clear: Callable[[np.ndarray], np.ndarray] | None = None
              ) -> tuple[int, int, int, int] | None:
    """Carve ``shape`` from ``grid`` (or deposit it, ``deposit`` True), in place.

    grid: a float64 GridField (``GridField.from_values``); shape: any Field, placed with
    its origin at ``position`` (2,) m and turned by ``angle`` rad in the grid's frame.
    Edits the node values (and, if the grid was compiled, its program's constants) on
    the window ``[i0, i1) x [j0, j1)`` of node indices, which it returns (None when the
    shape's bounds, grown by the reach, miss the grid). Nodes on the grid's rim never
    go below min(their value, 0), so the grid's bounds stay valid (a deposit is
    clipped at the grid's edge). clear: for a deposit, the distance (m, negative
    inside) from points (N, 2) of the grid's frame to what must stay clear of it
    (dynamic bodies): the deposited field becomes max(c, cell - clear), so new
    material fills around them one cell away (the grid's bilinear level set rounds
    a pocket's corners by less than a cell) and buries none; old material is kept.
    """
    h = grid.cell
    nx, ny = grid.shape
    position = np.asarray(position, dtype=np.float64)
    c, s = math.cos(angle), math.sin(angle)
    box = np.asarray(shape.bounds(), dtype=np.float64)
    if np.all(np.isfinite(box)):
        corners = np.array([[box[0], box[1]], [box[2], box[1]], [box[0], box[3]],
                            [box[2], box[3]]])
        placed = corners @ np.array([[c, s], [-s, c]]) + position
        lo = np.floor((placed.min(axis=0) - grid.origin) / h).astype(np.int64)
        hi = np.ceil((placed.max(axis=0) - grid.origin) / h).astype(np.int64) + 1
    else:
        lo, hi = np.zeros(2, np.int64), np.array([nx, ny], np.int64)
    reach = REDISTANCE_CELLS
    i0, j0 = max(int(lo[0]) - reach, 0), max(int(lo[1]) - reach, 0)
    i1, j1 = min(int(hi[0]) + reach, nx), min(int(hi[1]) + reach, ny)
    if i0 >= i1 or j0 >= j1:
        return None
    gx, gy = np.meshgrid(grid.origin[0] + h * np.arange(i0, i1),
                         grid.origin[1] + h * np.arange(j0, j1), indexing="ij")
    dx, dy = gx.ravel() - position[0], gy.ravel() - position[1]
    local = np.column_stack([c * dx + s * dy, c * dy - s * dx])    # R(-angle) (p - t)
    d = shape.distance(local).reshape(gx.shape)
    if deposit and clear is not None:
        points = np.column_stack([gx.ravel(), gy.ravel()])
        d = np.maximum(d, h - clear(points).reshape(gx.shape))
    values = grid._values
    window = values[i0:i1, j0:j1]
    old = window.copy()
    window[...] = np.minimum(old, d) if deposit else np.maximum(old, -d)
    redistance(values, i0, i1, j0, j1, reach, h)
    if grid.band is not None:
        np.clip(window, -grid.band, grid.band, out=window)
    rim = np.zeros(window.shape, dtype=bool)        # the window's nodes on the grid's rim
    rim[0, :] |= i0 == 0
    rim[-1, :] |= i1 == nx
    rim[:, 0] |= j0 == 0
    rim[:, -1] |= j1 == ny
    window[rim] = np.maximum(window[rim], np.minimum(old[rim], 0.0))
    program = grid.__dict__.get("_compiled_program")
    if program:
        write_window(program.code, program.consts, 0, grid, (i0, i1, j0, j1))
    consts_changed()
    return i0, i1, j0, j1


def redistance(values: np.ndarray, i0: int, i1: int, j0: int, j1: int, reach: int,
               cell: float) -> None:
    """Re-distance the nodes ``[i0, i1) x [j0, j1)`` of ``values`` (nx, ny), m, in place.

    Each gets sign(v) times its distance (m; ``cell`` m per node step) to the nearest
    marching-squares segment of the zero level within ``reach`` cells, or sign(v)
    max(|v|, reach cell) if none is that near (module docstring). Segments are read
    from the values before any is changed.
    """
    nx, ny = values.shape
    c0, c1 = max(i0 - reach - 1, 0), min(i1 + reach, nx - 1)    # cells [c0, c1)
    d0, d1 = max(j0 - reach - 1, 0), min(j1 + reach, ny - 1)
    seg = np.empty((max(c1 - c0, 0), max(d1 - d0, 0), 8))
    count = np.empty(seg.shape[:2], np.int64)
    _segments(values, c0, c1, d0, d1, seg, count)
    squared = np.empty((i1 - i0, j1 - j0))
    _nearest(seg, count, c0, d0, i0, i1, j0, j1, reach, squared)
    v = values[i0:i1, j0:j1]
    sign = np.where(v < 0.0, -1.0, 1.0)
    v[...] = np.where(squared <= reach * reach, sign * np.sqrt(squared) * cell,
                      sign * np.maximum(np.abs(v), reach * cell))


# Two small kernels of scalar statements (no tuple stores into arrays, no nested
# helpers): numba types and lowers them in about a second together, where one kernel
# doing both took 7-15 s (docs/terrain.md, "Compile time").

@njit(cache=True, error_model="numpy")
def _segments(values: np.ndarray, c0: int, c1: int, d0: int, d1: int, seg: np.ndarray,
              count: np.ndarray) -> None:
    """Marching squares on the cells [c0, c1) x [d0, d1) of ``values`` (node units):
    seg[a, b] (8,) holds up to two segments (x0, y0, x1, y1) of cell (c0 + a, d0 + b),
    count[a, b] how many. A node is inside where v <= 0; crossings by linear
    interpolation along the edges; a saddle is split by the sign of the mean."""
    px = np.empty(4)
    py = np.empty(4)
    for i in range(c0, c1):
        for j in range(d0, d1):
            v00 = values[i, j]
            v10 = values[i + 1, j]
            v01 = values[i, j + 1]
            v11 = values[i + 1, j + 1]
            m = 0                   # crossings: bottom, right, top, left edge, in order
            if (v00 <= 0.0) != (v10 <= 0.0):
                px[m] = i + v00 / (v00 - v10)
                py[m] = j
                m += 1
            if (v10 <= 0.0) != (v11 <= 0.0):
                px[m] = i + 1.0
                py[m] = j + v10 / (v10 - v11)
                m += 1
            if (v01 <= 0.0) != (v11 <= 0.0):
                px[m] = i + v01 / (v01 - v11)
                py[m] = j + 1.0
                m += 1
            if (v00 <= 0.0) != (v01 <= 0.0):
                px[m] = i
                py[m] = j + v00 / (v00 - v01)
                m += 1
            a = i - c0
            b = j - d0
            # A saddle: if the centre is on the side of corners 00 and 11, they join and
            # the segments cut off corners 10 (bottom-right) and 01 (top-left); otherwise
            # corners 00 (bottom-left) and 11 (right-top).
            first = 1
            second = 3
            if (0.25 * (v00 + v10 + v01 + v11) <= 0.0) != (v00 <= 0.0):
                first = 3
                second = 1
            if m == 2:
                first = 1
            count[a, b] = m // 2
            if m >= 2:
                seg[a, b, 0] = px[0]
                seg[a, b, 1] = py[0]
                seg[a, b, 2] = px[first]
                seg[a, b, 3] = py[first]
            if m == 4:
                seg[a, b, 4] = px[2]
                seg[a, b, 5] = py[2]
                seg[a, b, 6] = px[second]
                seg[a, b, 7] = py[second]


@njit(cache=True, error_model="numpy")
def _nearest(seg: np.ndarray, count: np.ndarray, c0: int, d0: int, i0: int, i1: int,
             j0: int, j1: int, reach: int, out: np.ndarray) -> None:
    """out[i - i0, j - j0]: the squared distance (node units) from node (i, j) to the
    nearest segment of ``_segments`` within ``reach`` cells, reach^2 + 1 if none."""
    mx = seg.shape[0]
    my = seg.shape[1]
    for i in range(i0, i1):
        alo = max(i - reach - 1 - c0, 0)
        ahi = min(i + reach + 1 - c0, mx)
        for j in range(j0, j1):
            blo = max(j - reach - 1 - d0, 0)
            bhi = min(j + reach + 1 - d0, my)
            best = reach * reach + 1.0
            for a in range(alo, ahi):
                for b in range(blo, bhi):
                    for k in range(count[a, b]):
                        ax = seg[a, b, 4 * k] - i
                        ay = seg[a, b, 4 * k + 1] - j
                        ex = seg[a, b, 4 * k + 2] - seg[a, b, 4 * k]
                        ey = seg[a, b, 4 * k + 3] - seg[a, b, 4 * k + 1]
                        ee = ex * ex + ey * ey
                        t = 0.0
                        if ee > 0.0:
                            t = min(max(-(ax * ex + ay * ey) / ee, 0.0), 1.0)
                        qx = ax + t * ex
                        qy = ay + t * ey
                        dd = qx * qx + qy * qy
                        best = min(best, dd)
            out[i - i0, j - j0] = best
