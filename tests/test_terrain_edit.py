"""Editing baked grids in place (sdf/edit.py): carve and deposit against the exact CSG.

The exact distance to a CSG result is computed by brute force: dense samples of every
operand's boundary, kept where the result's field (max(f, -c...) or min(f, c...),
exact in sign) vanishes, and the distance to the nearest sample (spacing 1 mm).
"""

from __future__ import annotations

import numpy as np
import numpy_fields
import pytest

from sdfphys.sdf import compiled, field
from sdfphys.sdf.edit import REDISTANCE_CELLS, edit_grid
from sdfphys.sdf.grid import GridField

BOX = field({"type": "box", "size": [4.0, 2.0]})
RADIUS = 0.3
DISC = field({"type": "circle", "radius": RADIUS})


def _grid(cell: float, margin: float = 0.5) -> GridField:
    baked = GridField(BOX, cell, margin=margin)
    return GridField.from_values(baked.values, baked.origin, cell, baked.margin)


def _nodes(grid: GridField) -> np.ndarray:
    nx, ny = grid.shape
    gx, gy = np.meshgrid(grid.origin[0] + grid.cell * np.arange(nx),
                         grid.origin[1] + grid.cell * np.arange(ny), indexing="ij")
    return np.column_stack([gx.ravel(), gy.ravel()])


def _csg(points: np.ndarray, centres: list, deposit: bool, radius: float = RADIUS
         ) -> np.ndarray:
    """max(f, -c_1, -c_2, ...) (carve) or min(f, c_1, ...) (deposit) at points (N, 2),
    c_k the discs of ``radius`` about ``centres``."""
    out = BOX.distance(points)
    for c in centres:
        d = np.hypot(*(points - c).T) - radius
        out = np.minimum(out, d) if deposit else np.maximum(out, -d)
    return out


def _exact(points: np.ndarray, centres: list, deposit: bool) -> np.ndarray:
    """The exact signed distance to the CSG result at points (N, 2), by brute force."""
    step = 1e-3
    t, s = np.arange(-2.0, 2.0, step), np.arange(-1.0, 1.0, step)
    samples = [np.column_stack([t, np.full_like(t, 1.0)]),
               np.column_stack([t, np.full_like(t, -1.0)]),
               np.column_stack([np.full_like(s, 2.0), s]),
               np.column_stack([np.full_like(s, -2.0), s])]
    a = np.arange(0.0, 2.0 * np.pi, step / RADIUS)
    samples += [c + RADIUS * np.column_stack([np.cos(a), np.sin(a)]) for c in centres]
    boundary = np.concatenate(samples)
    boundary = boundary[np.abs(_csg(boundary, centres, deposit)) < 1e-9]
    distance = np.array([np.min(np.hypot(*(boundary - p).T)) for p in points])
    return np.sign(_csg(points, centres, deposit)) * distance


@pytest.mark.parametrize("deposit", [False, True])
@pytest.mark.parametrize("cell", [0.05, 0.037])
def test_edits_match_the_exact_csg_distance_within_one_cell(cell, deposit):
    # Holes and bumps apart or overlapping, none tangent to the box or another (a neck
    # or sliver thinner than a cell is below the grid's resolution).
    y, low = (1.15, -1.1) if deposit else (1.0, 0.2)
    centres = [np.array([x, y]) for x in (-1.5, -0.5, 0.5, 1.5)] + [
        np.array([-1.0, low]), np.array([-0.8, low])]
    grid = _grid(cell)
    for c in centres:
        assert edit_grid(grid, DISC, c, 0.0, deposit) is not None
    points = _nodes(grid)
    lower = _csg(points, centres, deposit)
    near = np.abs(lower) < 2.0 * REDISTANCE_CELLS * cell
    exact = _exact(points[near], centres, deposit)
    value = grid.values.ravel()[near]
    error = np.abs(value - exact)
    # Near the surface (two cells): within one cell. Within the reach: within a cell's
    # diagonal (the marching-squares boundary stays in the cells the true one crosses;
    # a concave notch, where a bump meets the ground, is filled in up to ~1.01 cells).
    assert np.max(error[np.abs(exact) < 2.0 * cell]) <= cell
    assert np.max(error[np.abs(exact) < REDISTANCE_CELLS * cell]) <= np.sqrt(2.0) * cell
    # Everywhere: the right sign (max / min of the node values is exact in sign), but
    # on the boundary: up to rounding (1e-16: the grid's distances and these differ
    # there), and a node on the grid's boundary polyline (value 0) within a cell of it.
    value = grid.values.ravel()
    on = (np.abs(lower) < 1e-12) | ((value == 0.0) & (np.abs(lower) < cell))
    assert np.all((np.sign(value) == np.sign(lower)) | on)


def test_a_thousand_random_carves_keep_every_sign():
    rng = np.random.default_rng(7)
    grid = _grid(0.05)
    centres = list(rng.uniform([-2.2, -1.2], [2.2, 1.2], size=(1000, 2)))
    small = field({"type": "circle", "radius": 0.06})
    for c in centres:
        edit_grid(grid, small, c, 0.0, False)
    lower = _csg(_nodes(grid), centres, False, 0.06)
    exact_sign = np.sign(lower)
    value = grid.values.ravel()
    on = (np.abs(lower) < 1e-12) | ((value == 0.0) & (np.abs(lower) < 0.05))
    assert np.all((np.sign(value) == exact_sign) | on)
    assert np.any(value < 0.0) and np.any(value > 0.0)


def test_the_compiled_program_follows_the_edits():
    grid = _grid(0.05)
    compiled.compile_field(grid)                        # consts copied now
    edit_grid(grid, field({"type": "box", "size": [0.5, 0.3]}), (0.3, 1.0), 0.4, False)
    points = np.random.default_rng(1).uniform(-2.6, 2.6, size=(4000, 2))
    value, gradient = compiled.evaluate(grid, points)
    expected = numpy_fields.evaluate(grid, points)
    np.testing.assert_array_equal(value, expected[0])
    np.testing.assert_array_equal(gradient, expected[1])
    assert np.min(value) < 0.0


def test_a_turned_shape_is_carved_turned():
    grid = _grid(0.05)
    slot = field({"type": "box", "size": [1.0, 0.1]})
    edit_grid(grid, slot, (0.0, 1.0), np.pi / 2, False)     # a vertical slot from the top
    d = grid.distance(np.array([[0.0, 0.7], [0.3, 0.7]]))
    assert d[0] > 0.0 and d[1] < 0.0


def test_edits_beyond_the_grid_are_clipped():
    grid = _grid(0.05)
    before = grid.values.copy()
    assert edit_grid(grid, DISC, (40.0, 0.0), 0.0, False) is None
    np.testing.assert_array_equal(grid.values, before)
    # A deposit across the grid's edge: the rim stays outside (>= 0), the bounds valid.
    window = edit_grid(grid, DISC, (2.5, 0.0), 0.0, True)
    assert window is not None and window[1] == grid.shape[0]
    assert np.all(grid.values[-1] >= 0.0)
    assert grid.distance(np.array([[2.45, 0.0]]))[0] < 0.0


def test_a_carve_touches_only_the_window_it_returns():
    grid = _grid(0.05)
    before = grid.values.copy()
    i0, i1, j0, j1 = edit_grid(grid, DISC, (0.0, 1.0), 0.0, False)
    changed = np.argwhere(grid.values != before)
    assert len(changed)
    assert changed[:, 0].min() >= i0 and changed[:, 0].max() < i1
    assert changed[:, 1].min() >= j0 and changed[:, 1].max() < j1
    cells = 2 * RADIUS / 0.05 + 2 * REDISTANCE_CELLS + 2
    assert (i1 - i0) <= cells and (j1 - j0) <= cells
