"""Carved dynamic bodies: the mass of a baked grid, and the pieces it falls into.

``terrain.edit`` carves a dynamic body's grid as a static one's (``sdf.edit``); then
``split`` (this module) gives the body what is left: its new mass, centre of mass and
moment of inertia, and, where the carve cut it through, one new body per further piece.
docs/terrain.md, "Carving dynamic bodies".

Mass of a grid. Node (i, j) at x_ij = origin + h (i, j) stands for the square cell of
side h around it, of which the fraction phi = clip(1/2 - v / h, 0, 1) is inside (v the
node's signed distance, m; exact for a boundary through the cell parallel to a side, and
the errors of slanted and curved boundaries cancel to first order along a smooth
boundary). Then

    A = h^2 sum phi,   c = sum phi x' / sum phi,
    J = h^2 sum phi (|x' - c|^2 + ((phi h)^2 + h^2) / 12),

the area (m^2), centroid (m) and polar second moment about c (m^4), where a cut cell's
material is taken as the strip between its inner side and the boundary: centred at
x' = x + (clip(-v, -h/2, h/2) - h/2) / 2 n (n = grad v / |grad v|, the outward normal;
x' = x for a full cell), with its own moment ((phi h)^2 + h^2) / 12 per unit area.
The body's new mass and inertia are its old ones scaled by the grid's ratios,
m' = m A' / A and I' = I J' / J with A, J the grid's before the edit: a carve that
removes nothing changes nothing, and the grid's bias (a polygon's corner rounded by the
bilinear level set) cancels to first order. The mass moves with the material: the
body's frame moves to the new centroid (its user frame stays where it was), its
velocity becomes the old motion's at that point, v + w x d.

Pieces. The parts of the material are the 4-connected components of the nodes with
phi > 0 (v < h / 2): parts less than about a cell apart stay one body (the grid cannot
tell them apart; neither can its level set). The largest part stays the body; each
further part becomes a new dynamic body with the body's material, filter and damping,
moving as that part moved (v + w x d, the same w), named ``<name>.<k>``; the body's
joints stay with it, at the same material points. A part with
less than ``DUST_CELLS`` cells of area is dropped with the carved material; a body left
with none is removed. Each part's grid is its own: the nodes of its bounding box grown by
``_PAD`` nodes (within the old grid), the other parts' nodes set outside and the window
re-distanced (``sdf.edit.redistance``), so that its values are distances to its own
boundary only, and the part's body gets its own shape (``terrain.TerrainShape``).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ._jit import njit
from .limits import check_body
from .sdf.edit import REDISTANCE_CELLS, redistance
from .sdf.grid import GridField
from .world_bodies import add, shape_number

__all__ = ["DUST_CELLS", "GridMass", "grid_mass", "parts", "split"]

#: Parts with less area than this many cells are dropped (dust).
DUST_CELLS = 4.0
#: Nodes kept around a part's nodes in its own grid: within the re-distance reach, so
#: that the rim holds true distances (``_part_grid``).
_PAD = REDISTANCE_CELLS - 1


class GridMass(NamedTuple):
    """A grid's (or part's) area (m^2), centroid (2,) m in the grid's frame, and polar
    second moment about the centroid (m^4); module docstring."""

    area: float
    centroid: np.ndarray
    second_moment: float


def _occupancy(values: np.ndarray, cell: float) -> np.ndarray:
    """(nx, ny) inside fraction of each node's cell, clip(1/2 - v / h, 0, 1)."""
    return np.clip(0.5 - values / cell, 0.0, 1.0)


def grid_mass(values: np.ndarray, origin: np.ndarray, cell: float,
              phi: np.ndarray | None = None) -> GridMass:
    """The area, centroid and second moment of the material of node ``values`` (nx, ny)
    (m, < 0 inside; node (i, j) at ``origin`` (2,) + ``cell`` (i, j), m), or of the
    occupancy ``phi`` (nx, ny) of those nodes if given; module docstring. Zero area:
    centroid 0."""
    h = cell
    if phi is None:
        phi = _occupancy(values, h)
    total = float(phi.sum())
    if total == 0.0:
        return GridMass(0.0, np.zeros(2), 0.0)
    nx, ny = phi.shape
    x = origin[0] + h * np.arange(nx)[:, None] + np.zeros((1, ny))
    y = origin[1] + h * np.arange(ny)[None, :] + np.zeros((nx, 1))
    # A cut cell's material is the strip from its inner side to the boundary: its
    # centre lies (clip(-v, -h/2, h/2) - h/2) / 2 along the outward normal grad v.
    gx, gy = np.gradient(values, h) if min(nx, ny) > 1 else (np.zeros_like(values),) * 2
    norm = np.hypot(gx, gy)
    norm[norm == 0.0] = 1.0
    shift = 0.5 * (np.clip(-values, -0.5 * h, 0.5 * h) - 0.5 * h) / norm
    x, y = x + shift * gx, y + shift * gy
    centroid = np.array([(phi * x).sum(), (phi * y).sum()]) / total
    spread = (phi * ((x - centroid[0]) ** 2 + (y - centroid[1]) ** 2)).sum()
    strips = (phi * ((phi * h) ** 2 + h * h)).sum() / 12.0      # each strip's own moment
    return GridMass(h * h * total, centroid, h * h * float(spread + strips))


@njit(cache=True)
def _label(occupied: np.ndarray, labels: np.ndarray) -> int:
    """Number the 4-connected components of ``occupied`` (nx, ny) bool into ``labels``
    (nx, ny) int64 (1, 2, ... in order of their first node, row-major; 0 elsewhere), by
    a depth-first fill with an explicit stack; returns their count."""
    nx, ny = occupied.shape
    stack = np.empty(nx * ny, np.int64)
    count = 0
    for start in range(nx * ny):
        i0, j0 = start // ny, start % ny
        if not occupied[i0, j0] or labels[i0, j0] != 0:
            continue
        count += 1
        labels[i0, j0] = count
        top = 0
        stack[top] = start
        top += 1
        while top > 0:
            top -= 1
            node = stack[top]
            i, j = node // ny, node % ny
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                a, b = i + di, j + dj
                if 0 <= a < nx and 0 <= b < ny and occupied[a, b] and labels[a, b] == 0:
                    labels[a, b] = count
                    stack[top] = a * ny + b
                    top += 1
    return count


def parts(values: np.ndarray, cell: float) -> tuple[np.ndarray, int]:
    """(labels (nx, ny) int64, count): the 4-connected parts of the nodes with
    v < cell / 2 (module docstring), numbered from 1; 0 elsewhere."""
    labels = np.zeros(values.shape, np.int64)
    count = _label(np.asarray(values < 0.5 * cell), labels)
    return labels, count


def _material_box(values: np.ndarray, cell: float) -> np.ndarray:
    """[x0, y0, x1, y1] in node units: the box of the region where the bilinear
    interpolant of ``values`` (nx, ny) is <= 0 (the inside nodes, and the crossings
    along cell edges: within a cell the region's extremes lie on its edges, the
    interpolant being linear along each). No inside node: an empty box (inf, -inf)."""
    box = np.array([np.inf, np.inf, -np.inf, -np.inf])
    inside = values <= 0.0
    indices = np.indices(values.shape).astype(float)
    for axis in (0, 1):
        index = indices[axis]
        a = np.take(values, np.arange(values.shape[axis] - 1), axis=axis)
        b = np.take(values, np.arange(1, values.shape[axis]), axis=axis)
        cut = (a <= 0.0) != (b <= 0.0)
        where = np.take(index, np.arange(values.shape[axis] - 1), axis=axis)
        at = where[cut] + a[cut] / (a[cut] - b[cut])
        points = np.concatenate([index[inside], at])
        if len(points):
            box[axis], box[axis + 2] = points.min(), points.max()
    return box


def _part_grid(grid: GridField, labels: np.ndarray, k: int) -> GridField:
    """Part ``k``'s own grid, in the grid's frame: the nodes of its window (its nodes'
    box grown by ``_PAD`` nodes, within the grid), the other parts' nodes set outside,
    re-distanced (module docstring).

    The window's rim nodes are then true distances (within the re-distance reach), and
    its margins are the material's distances to each side (``_material_box``): the
    field outside the window (``sdf.grid``: sqrt(v^2 + d^2 + 2 m d) at distance d from
    a rim value v, margin m of that side) stays a lower bound, exact off a flat side
    parallel to the window's. One margin for all sides, the least, read a ball resting
    on a piece, its centre outside the window, 5 mm deep; a cell less, 8 mm."""
    h = grid.cell
    inside = np.argwhere(labels == k)
    lo, hi = inside.min(axis=0), inside.max(axis=0)
    start = np.maximum(lo - _PAD, 0)
    stop = np.minimum(hi + _PAD + 1, labels.shape)
    values = grid.values[start[0]:stop[0], start[1]:stop[1]].copy()
    others = labels[start[0]:stop[0], start[1]:stop[1]]
    foreign = (others != k) & (others != 0)
    values[foreign] = np.maximum(values[foreign], h)
    redistance(values, 0, values.shape[0], 0, values.shape[1], REDISTANCE_CELLS, h)
    box = _material_box(values, h)
    last = np.array(values.shape, dtype=float) - 1.0
    margins = np.maximum(np.concatenate([box[:2], last - box[2:]]) * h, 0.0)
    return GridField.from_values(values, grid.origin + h * start, h, margins)


def split(world: Any, i: int, grid: GridField, before: GridMass) -> None:
    """Give dynamic body ``i``, whose grid ``grid`` (its body frame) was just carved, the
    mass, frame and pieces of what is left (module docstring); ``before``: the grid's
    ``grid_mass`` before the carve. Removes the body if nothing is left."""
    from .terrain import TerrainShape  # here: terrain imports this module

    h = grid.cell
    labels, count = parts(grid.values, h)
    phi = _occupancy(grid.values, h)
    masses = [grid_mass(grid.values, grid.origin, h, np.where(labels == k, phi, 0.0))
              for k in range(1, count + 1)]
    kept = sorted((k for k in range(count) if masses[k].area >= DUST_CELLS * h * h),
                  key=lambda k: (-masses[k].area, k))
    if not kept:
        world.remove_body(i)
        return
    d = world._data
    com, turn = d["com"][i].copy(), float(d["angle"][i])
    velocity, spin = d["velocity"][i].copy(), float(d["angular_velocity"][i])
    mass_per_area = float(d["mass"][i]) / before.area
    inertia_per_moment = float(d["inertia"][i]) / before.second_moment
    c, s = math.cos(turn), math.sin(turn)
    name = world._names[i]
    for number, k in enumerate(kept):
        part = masses[k]
        own = _part_grid(grid, labels, k + 1)
        origin = d["origin"][i] - part.centroid if number == 0 else np.zeros(2)
        shape = TerrainShape(GridField.from_values(own.values, own.origin - part.centroid, h,
                                                   own.margins), origin,
                             part.area, part.second_moment)
        arm = np.array([c * part.centroid[0] - s * part.centroid[1],
                        s * part.centroid[0] + c * part.centroid[1]])
        moving = velocity + spin * np.array([-arm[1], arm[0]])
        mass = mass_per_area * part.area
        inertia = inertia_per_moment * part.second_moment
        if number == 0:
            d["shape_id"][i] = shape_number(world, shape)
            d["origin"][i] = origin
            d["com"][i] = com + arm
            d["velocity"][i] = moving
            d["round"][i] = False                # a carved circle is a field now
            world._joints.moved_frame(i, part.centroid)
            j = i
        else:
            j = add(world, shape, check_body(
                position=tuple(com + arm), angle=turn, velocity=tuple(moving),
                angular_velocity=spin, mass=mass, friction=float(d["friction"][i]),
                restitution=float(d["restitution"][i]), kind="dynamic",
                linear_damping=float(d["linear_damping"][i]),
                angular_damping=float(d["angular_damping"][i]),
                category=int(d["category"][i]), mask=int(d["mask"][i]),
                group=int(d["group"][i]), sensor=bool(d["sensor"][i]),
                gravity_scale=float(d["gravity_scale"][i])), _piece_name(world, name))
            d = world._data                      # ``add`` may have grown the arrays
        # The scaled moment, not the shape's own mass / area * J (module docstring).
        d["mass"][j], d["inertia"][j] = mass, inertia
        d["inv_mass"][j], d["inv_inertia"][j] = 1.0 / mass, 1.0 / inertia
        d["radius"][j] = shape.radius
        d["core_radius"][j] = shape.core_radius


def _piece_name(world: Any, name: str) -> str:
    """``<name>.<k>`` with the smallest k >= 1 not taken."""
    k = 1
    while f"{name}.{k}" in world._name_set:
        k += 1
    return f"{name}.{k}"
