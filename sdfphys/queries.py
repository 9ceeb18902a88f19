"""Scene queries, batched over arrays: what they share, point queries and box overlaps.

Every query reads the world as it is (no step), in world coordinates (m), and takes
each body's own shape field (``Shape.field``, as time of impact does; the knobs
``gradient`` / ``field_representation`` do not apply). ``World.point_query`` and
``overlap_box`` call the functions here; the ray casts (``sdfphys.rays``) share the
input checks, the result type ``RayHits``, the shapes packed as tables (``_packed``)
and the uniform grid of the bodies' boxes (``_grid``).
Which bodies: those whose collision ``category`` shares a bit with ``mask`` (None: all),
and of those the ones in the index array ``bodies`` (None: all).

Point queries (``nearest``): candidate (point, body) pairs from the broadphase
(``collide.broadphase.candidate_pairs``: point boxes p +- max_distance against the body
AABBs), the field value of each pair (``toi._distance``, compiled programs), the least
per point. Box overlaps (``overlapping``): circles and meshes exactly (closest point of
the box to the centre; separating axes per triangle), SDF shapes by the field's
1-Lipschitz bound (module function's docstring).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .collide.broadphase import world_bounds
from .errors import SpecError, check_int, check_number
from .limits import MAX_BITS
from .sdf.compiled import Program, compile_field
from .sdf.opcodes import POP_T, PUSH_T
from .sdf.program_table import ProgramTable, program_table

__all__ = ["OVERLAP_LEVELS", "PointHits", "RayHits", "nearest", "overlapping"]

#: Grid at most this many cells a side; a body covering more than _BIG_CELLS cells is
#: tested by every ray.
_GRID_SIDE = 256
_BIG_CELLS = 64

_CIRCLE, _MESH, _SDF = 0, 1, 2


@dataclass(frozen=True)
class RayHits:
    """Closest hit of each of N rays. body (N,) int64, -1 for no hit; point (N, 2) m,
    normal (N, 2) unit outward normal of the body hit, distance (N,) m along the ray
    (0 for a ray starting inside); NaN in point, normal and distance where no hit.
    ``ray_cast_all`` adds ray (H,) int64: the ray of each hit, hits sorted by (ray,
    distance), every body a ray enters once (its first entry)."""

    body: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    distance: np.ndarray
    ray: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.body)


@dataclass(frozen=True)
class PointHits:
    """Nearest body to each of N points: body (N,) int64 (-1: none within max_distance),
    distance (N,) m, signed (< 0 inside; inf where none)."""

    body: np.ndarray
    distance: np.ndarray

    def __len__(self) -> int:
        return len(self.body)


# --------------------------------------------------------------------------------------
# Input checks (one line naming the argument, as World.add_body's)
# --------------------------------------------------------------------------------------

def _points(value: Any, name: str) -> np.ndarray:
    """(N, 2) finite float64 array (a single pair becomes (1, 2))."""
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise SpecError(name, f"must be an (N, 2) array of numbers, got {value!r}") from None
    if a.ndim == 1 and a.shape == (2,):
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 2:
        raise SpecError(name, f"must have shape (N, 2), got {a.shape}")
    bad = ~np.isfinite(a)
    if np.any(bad):
        i, j = np.argwhere(bad)[0]
        raise SpecError(f"{name}[{i}][{j}]", f"must be finite, got {a[i, j]}")
    return np.ascontiguousarray(a)


def _bodies(bodies: Any, category: np.ndarray, mask: Any) -> np.ndarray:
    """(B,) bool selection of the world's bodies (category (B,) uint64: their collision
    categories): those whose category shares a bit with ``mask`` (None: all; Box2D's
    query filter), and among them those listed in ``bodies`` (None: all)."""
    n = len(category)
    keep = np.ones(n, np.bool_)
    if mask is not None:
        bits = np.uint64(check_int(mask, "mask", low=0, high=MAX_BITS))
        keep = (category & bits) != 0
    if bodies is None:
        return keep
    idx = np.asarray(bodies)
    if idx.ndim != 1 or not (np.issubdtype(idx.dtype, np.integer) or len(idx) == 0):
        raise SpecError("bodies", f"must be a 1-D array of body indices, got {bodies!r}")
    if len(idx) and (idx.min() < -n or idx.max() >= n):
        raise SpecError("bodies", f"has an index out of range ({n} bodies)")
    listed = np.zeros(n, np.bool_)
    listed[idx.astype(np.int64) % max(n, 1)] = True
    return keep & listed


def _rays(origins: Any, directions: Any, max_distance: Any
          ) -> tuple[np.ndarray, np.ndarray, float]:
    """Checked origins (N, 2), unit directions (N, 2) and max_distance (m, >= 0, inf
    allowed)."""
    o = _points(origins, "origins")
    d = _points(directions, "directions")
    if d.shape != o.shape:
        raise SpecError("directions", f"must have the shape of origins {o.shape}, "
                                      f"got {d.shape}")
    length = np.hypot(d[:, 0], d[:, 1])
    zero = np.flatnonzero(~(length > 0.0))
    if len(zero):
        raise SpecError(f"directions[{zero[0]}]", "must be a nonzero vector, got "
                                                  f"{d[zero[0]].tolist()}")
    if isinstance(max_distance, (int, float, np.floating, np.integer)) and \
            not isinstance(max_distance, bool) and max_distance == math.inf:
        top = math.inf
    else:
        top = check_number(max_distance, "max_distance", low=0.0)
    return o, np.ascontiguousarray(d / length[:, None]), top


# --------------------------------------------------------------------------------------
# The world packed for the kernel
# --------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Packed:
    """Per-shape tables: kind (S,), radius (S,), local AABB (S, 4), vertex rows
    [vstart, vstart + vcount) of ``vertices`` (V, 2), program rows [cstart, cstart +
    ccount) of ``code`` (I, 4) with const offsets shifted into ``consts`` (F,), the
    translation ``shift`` (S, 2) taken out of each program (``_outer_shift``), and the
    largest stack ``depth`` and ``nesting``."""

    kind: np.ndarray
    radius: np.ndarray
    bounds: np.ndarray
    vstart: np.ndarray
    vcount: np.ndarray
    vertices: np.ndarray
    cstart: np.ndarray
    ccount: np.ndarray
    code: np.ndarray
    consts: np.ndarray
    shift: np.ndarray
    depth: int
    nesting: int


def _pack(shapes: list) -> _Packed:
    """The kernel's tables for ``shapes`` (each field compiled once, cached on it; the
    programs, their outer shift taken out, one ``sdf.program_table`` table)."""
    kinds, radius, bounds, vstart, vcount, verts = [], [], [], [], [], []
    programs, shift = [], []
    nv = 0
    for shape in shapes:
        kinds.append({"circle": _CIRCLE, "mesh": _MESH}.get(shape.kind, _SDF))
        radius.append(shape.radius)
        bounds.append(np.asarray(shape.bounds(), np.float64))
        v = getattr(shape, "vertices", None) if shape.kind == "mesh" else None
        v = np.zeros((0, 2)) if v is None else np.asarray(v, np.float64)
        vstart.append(nv)
        vcount.append(len(v))
        verts.append(v)
        nv += len(v)
        program = compile_field(shape.field)
        if program is None:
            raise SpecError("shape", f"{shape!r}: its field does not compile "
                                     "(sdf.compiled), which queries need")
        shift.append(_outer_shift(program.code, program.consts))
        if shift[-1] is not None:
            program = Program(program.code[1:-1], program.consts, program.depth,
                              program.nesting)
        programs.append(program)
    table = (program_table(programs) if programs
             else ProgramTable(np.zeros((0, 4), np.int64), np.zeros(1), np.zeros(1, np.int64),
                               1, 1))
    return _Packed(np.array(kinds, np.int64), np.array(radius, np.float64),
                   np.array(bounds, np.float64).reshape(-1, 4), np.array(vstart, np.int64),
                   np.array(vcount, np.int64), np.concatenate(verts + [np.zeros((0, 2))]),
                   table.start[:-1].copy(), np.diff(table.start), table.code, table.consts,
                   np.array([(0.0, 0.0) if o is None else o for o in shift],
                            np.float64).reshape(-1, 2), table.depth, table.nesting)


def _outer_shift(code: np.ndarray, consts: np.ndarray) -> tuple[float, float] | None:
    """(ox, oy) if the program is one pure translation (PUSH_T ... POP_T with c = 1,
    s = 0: an SDF shape's centroid shift) around the rest, else None. The kernel then
    runs the rest at x - ox, which are the bits PUSH_T computes (c x' + s y' = x' for
    c = 1, s = 0), and the gradient is POP_T's (c gx - s gy = gx): the same numbers,
    two instructions fewer per evaluation."""
    if len(code) < 3 or code[0, 0] != PUSH_T or code[-1, 0] != POP_T:
        return None
    depth = 0
    for op in code[:-1, 0]:
        depth += int(op == PUSH_T) - int(op == POP_T)
        if depth == 0:
            return None                  # the first frame closes before the end
    o = code[0, 1]
    if consts[o + 2] != 1.0 or consts[o + 3] != 0.0:
        return None
    return float(consts[o]), float(consts[o + 1])


def _packed(world) -> _Packed:
    """``_pack`` of the world's shapes, cached on the world until a shape is added."""
    cache = world.__dict__.get("_query_pack")
    if cache is None or cache[0] != len(world._shapes):
        cache = (len(world._shapes), _pack(world._shapes))
        world._query_pack = cache
    return cache[1]


def _grid(box: np.ndarray, keep: np.ndarray) -> tuple[np.ndarray, ...]:
    """Uniform grid of the selected bodies' AABBs ``box`` (B, 4): (origin (2,), cell h,
    shape (2,) int64, CSR start (cells + 1,) and body list, big bodies (G,)). Cell h:
    the mean larger side of the finite boxes, grown so that the grid has at most
    _GRID_SIDE cells a side; a box covering more than _BIG_CELLS cells, or infinite, is
    big (tested by every ray)."""
    ids = np.flatnonzero(keep)
    b = box[ids]
    finite = np.all(np.isfinite(b), axis=1)
    side = np.maximum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1])
    if np.any(finite):
        lo = b[finite, :2].min(axis=0)
        hi = b[finite, 2:].max(axis=0)
        mean = float(np.mean(side[finite]))
        h = max(mean, float(np.max(hi - lo)) / _GRID_SIDE, 1e-9)
    else:
        lo, hi, h = np.zeros(2), np.zeros(2), 1.0
    shape = np.maximum(np.ceil((hi - lo) / h).astype(np.int64), 1)
    c0 = np.clip(np.floor((b[:, :2] - lo) / h), 0, shape - 1)
    c1 = np.clip(np.floor((b[:, 2:] - lo) / h), 0, shape - 1)
    c0 = np.where(finite[:, None], c0, 0).astype(np.int64)
    c1 = np.where(finite[:, None], c1, 0).astype(np.int64)
    wide, tall = c1[:, 0] - c0[:, 0] + 1, c1[:, 1] - c0[:, 1] + 1
    big = ~finite | (wide * tall > _BIG_CELLS)
    small = np.flatnonzero(~big)
    count = (wide * tall)[small]
    entry = np.repeat(small, count)
    k = np.arange(len(entry)) - np.repeat(np.cumsum(count) - count, count)
    cx = c0[entry, 0] + k % wide[entry]
    cy = c0[entry, 1] + k // wide[entry]
    cell = cx * shape[1] + cy
    order = np.argsort(cell, kind="stable")
    start = np.zeros(int(shape[0] * shape[1]) + 1, np.int64)
    np.add.at(start, cell + 1, 1)
    return (lo.astype(np.float64), float(h), shape, np.cumsum(start),
            ids[entry[order]].astype(np.int64), ids[big].astype(np.int64))


# --------------------------------------------------------------------------------------
# Point queries and box overlaps (numpy over pairs; the broadphase's and fields' kernels)
# --------------------------------------------------------------------------------------

def _world_boxes(world, keep: np.ndarray) -> np.ndarray:
    """World AABBs (B, 4) of all bodies, NaN rows for those not in ``keep`` (NaN
    overlaps nothing in the broadphase)."""
    pk = _packed(world)
    sid = world._view("shape_id")
    box = world_bounds(pk.bounds[sid], pk.radius[sid], world._view("com"),
                       world._view("angle"))
    box[~keep] = np.nan
    return box


def _point_pairs(box: np.ndarray, keep: np.ndarray, p: np.ndarray, top: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(point, body) candidate pairs, each once: the bodies of the grid cells (``_grid``)
    that the boxes p +- top cover, and every big body, whose AABB meets the box (every
    body when a point's box covers more cells than there are bodies)."""
    g_lo, h, g_shape, g_start, g_list, big = _grid(box, keep)
    if (2.0 * top / h + 2.0) ** 2 >= np.count_nonzero(keep):
        # Boxes over more cells than there are bodies: every point with every body.
        g_start, g_list, big = np.zeros_like(g_start), g_list[:0], np.flatnonzero(keep)
    c0 = np.clip(np.floor((p - top - g_lo) / h), 0, g_shape - 1).astype(np.int64)
    c1 = np.clip(np.floor((p + top - g_lo) / h), 0, g_shape - 1).astype(np.int64)
    wide, tall = c1[:, 0] - c0[:, 0] + 1, c1[:, 1] - c0[:, 1] + 1
    cells = wide * tall
    row = np.repeat(np.arange(len(p)), cells)
    k = np.arange(len(row)) - np.repeat(np.cumsum(cells) - cells, cells)
    cell = (c0[row, 0] + k % wide[row]) * g_shape[1] + c0[row, 1] + k // wide[row]
    count = g_start[cell + 1] - g_start[cell]
    point = np.repeat(row, count)
    k = np.arange(len(point)) - np.repeat(np.cumsum(count) - count, count)
    body = g_list[np.repeat(g_start[cell], count) + k]
    point = np.r_[point, np.repeat(np.arange(len(p)), len(big))]
    body = np.r_[body, np.tile(big, len(p))]
    b = box[body]
    q = p[point]
    meets = (b[:, 0] <= q[:, 0] + top) & (q[:, 0] - top <= b[:, 2]) \
        & (b[:, 1] <= q[:, 1] + top) & (q[:, 1] - top <= b[:, 3])
    key = np.unique(point[meets] * np.int64(len(box)) + body[meets])
    return key // len(box), key % len(box)


def nearest(world, points: Any, max_distance: Any, mask: Any = None,
            bodies: Any = None) -> PointHits:
    """Nearest body within ``max_distance`` (m, finite, >= 0) of each point (N, 2), m.

    Candidates: bodies entered in the grid cells that the point's box p +- max_distance
    covers (``_grid``, as the ray casts'), and the big bodies. Each candidate's field
    at the point (``toi._distance``: compiled programs, one batch per distinct shape);
    the least per point, ties to the lowest body index; values above max_distance are
    dropped. Distances are exact for exact fields (circles, meshes, most primitives) and
    a lower bound for the fields marked inexact (``Field.exact``), within the grid's
    error bound for baked grids.
    """
    from .toi import _distance

    p = _points(points, "points")
    top = check_number(max_distance, "max_distance", low=0.0)
    keep = _bodies(bodies, world._view("category"), mask)
    box = _world_boxes(world, keep)
    point, body = _point_pairs(box, keep, p, top)
    d = _distance([s.field for s in world._shapes], world._view("shape_id"),
                  world._view("com"), world._view("angle"), body, p[point])
    near = d <= top
    body, point, d = body[near], point[near], d[near]
    order = np.lexsort((body, d, point))
    point, first = np.unique(point[order], return_index=True)
    out_body = np.full(len(p), -1, np.int64)
    out_d = np.full(len(p), np.inf)
    out_body[point] = body[order][first]
    out_d[point] = d[order][first]
    return PointHits(out_body, out_d)


#: Halvings of the query box in ``overlapping``'s field test.
OVERLAP_LEVELS = 8


def overlapping(world, lo: Any, hi: Any, mask: Any = None, bodies: Any = None) -> np.ndarray:
    """Indices (K,) int64, increasing, of the bodies whose shape meets the closed box
    [lo, hi] (m, world axes; lo <= hi on both axes).

    Circles: the closest point of the box to the centre is within the radius (exact).
    Meshes (boxes, polygons): some triangle of the body and the box have no separating
    axis among the box's two axes and the triangle's three edge normals (exact;
    touching counts). SDF shapes, by the field f (1-Lipschitz) at box centres c with
    half-diagonal r: f(c) <= 0 overlaps; f(c) > r cannot (every point of the box is
    outside); otherwise the box is split in four and each part tested again, up to
    OVERLAP_LEVELS halvings, after which an undecided part counts as overlapping: the
    rule reports every body that meets the box, and those that come within
    r / 2^OVERLAP_LEVELS of it (r: the query box's half-diagonal). Baked grids within
    their error bound.
    """
    from .errors import check_vec2
    from .toi import _distance

    a = np.array(check_vec2(lo, "lo"))
    b = np.array(check_vec2(hi, "hi"))
    for k in range(2):
        if b[k] < a[k]:
            raise SpecError(f"hi[{k}]", f"must be >= lo[{k}] = {a[k]:g}, got {b[k]:g}")
    n = len(world)
    keep = _bodies(bodies, world._view("category"), mask)
    box = _world_boxes(world, keep)
    cand = np.flatnonzero((box[:, 0] <= b[0]) & (a[0] <= box[:, 2])
                          & (box[:, 1] <= b[1]) & (a[1] <= box[:, 3]))
    pk = _packed(world)
    sid = world._view("shape_id")
    com, angle = world._view("com"), world._view("angle")
    kind = pk.kind[sid[cand]]
    hit = np.zeros(n, np.bool_)
    # Circles: clamp the centre into the box.
    c = cand[kind == _CIRCLE]
    gap = com[c] - np.clip(com[c], a, b)
    hit[c] = np.sum(gap * gap, axis=1) <= pk.radius[sid[c]] ** 2
    # Meshes: separating axes, per (body, triangle).
    m = cand[kind == _MESH]
    if len(m):
        shapes = world._shapes
        tri = [shape.vertices[shape.triangles] if shape.kind == "mesh" else np.zeros((0, 3, 2))
               for shape in shapes]
        count = np.array([len(t) for t in tri])
        table = np.concatenate(tri)
        offset = np.cumsum(count) - count
        n_tri = count[sid[m]]
        row_body = np.repeat(m, n_tri)
        within = np.arange(len(row_body)) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)
        local = table[offset[sid[row_body]] + within]                       # (R, 3, 2)
        cs, sn = np.cos(angle[row_body])[:, None], np.sin(angle[row_body])[:, None]
        v = np.stack([cs * local[..., 0] - sn * local[..., 1],
                      sn * local[..., 0] + cs * local[..., 1]], axis=-1) + com[row_body, None]
        apart = (v[..., 0].min(1) > b[0]) | (v[..., 0].max(1) < a[0]) \
            | (v[..., 1].min(1) > b[1]) | (v[..., 1].max(1) < a[1])
        corners = np.array([[a[0], a[1]], [b[0], a[1]], [b[0], b[1]], [a[0], b[1]]])
        for k in range(3):
            e = v[:, (k + 1) % 3] - v[:, k]
            normal = np.column_stack([e[:, 1], -e[:, 0]])
            proj = np.einsum("rjc,rc->rj", v, normal)
            box_proj = corners @ normal.T                                  # (4, R)
            apart |= (box_proj.min(0) > proj.max(1)) | (box_proj.max(0) < proj.min(1))
        np.logical_or.at(hit, row_body, ~apart)
    # SDF shapes: the Lipschitz bound, halving undecided parts.
    rows = cand[kind == _SDF]
    centre = np.broadcast_to(0.5 * (a + b), (len(rows), 2))
    half = 0.5 * (b - a)
    fields = [s.field for s in world._shapes]
    for level in range(OVERLAP_LEVELS + 1):
        if len(rows) == 0:
            break
        f = _distance(fields, sid, com, angle, rows, np.ascontiguousarray(centre))
        radius = float(np.hypot(*half))
        hit[rows[f <= 0.0]] = True
        open_ = (f > 0.0) & (f <= radius) & ~hit[rows]
        if level == OVERLAP_LEVELS:
            hit[rows[open_]] = True
            break
        rows, centre = rows[open_], centre[open_]
        half = 0.5 * half
        quarter = np.array([[-1, -1], [1, -1], [-1, 1], [1, 1]]) * half
        rows = np.repeat(rows, 4)
        centre = (centre[:, None, :] + quarter[None]).reshape(-1, 2)
    return np.flatnonzero(hit)
