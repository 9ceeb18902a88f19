"""Scene queries, batched over arrays: ray casts, point queries and box overlaps.

Every query reads the world as it is (no step), in world coordinates (m), and takes
each body's own shape field (``Shape.field``, as time of impact does; the knobs
``gradient`` / ``field_representation`` do not apply). ``World.ray_cast``,
``ray_cast_all``, ``point_query`` and ``overlap_box`` call the functions here.
Which bodies: those whose collision ``category`` shares a bit with ``mask`` (None: all),
and of those the ones in the index array ``bodies`` (None: all).

Ray casts (``cast``, one numba kernel ``_cast``, no Python loop over rays or bodies).

- Broadphase: the bodies' world AABBs (``collide.broadphase.world_bounds``) are entered
  in a uniform grid (cell: the mean larger side of the finite boxes, at most 256 x 256
  cells), bodies with an infinite or very large box (grounds, walls) are tested by every
  ray. Each ray walks the cells it crosses in order (Amanatides and Woo 1987, "A fast
  voxel traversal algorithm"), testing each body once; the closest-hit cast stops at
  the first cell whose exit lies beyond the closest hit found so far (no later cell can
  hold a closer one). ``ray_cast_all`` walks every cell up to ``max_distance``.
- Circles, closed form: with p the origin and d the unit direction in the body frame,
  |p + t d|^2 = r^2 gives t = -b - sqrt(b^2 - c), b = p.d, c = p.p - r^2, written
  t = c / (-b + sqrt(b^2 - c)) to avoid cancellation (Press et al., Numerical Recipes
  5.6); normal (p + t d) / r.
- Meshes (boxes, polygons, concave too), closed form: each outline edge a -> b with
  outward normal n (counter-clockwise outline: n = (e_y, -e_x) / |e|) is crossed at
  t = (a - p).n / d.n, where the crossing point lies on the edge; the first crossing
  with d.n < 0 (entering) is the hit, normal n. The origin is inside when the first
  crossing at t >= 0 leaves (d.n > 0).
- SDF shapes: sphere tracing (Hart 1996) on the body-frame field through its compiled
  program (``sdf.compiled.run``), from where the ray enters the shape's local AABB:
  t <- t + f(p + t d) never passes the surface for a 1-Lipschitz field (exact, or a
  bound). Once f < ``COARSE`` the root of f along the ray is polished by safeguarded
  Newton steps t <- t - f / (grad f . d) with bisection once a point inside brackets
  it (``rtsafe``, Numerical Recipes 9.4), to ``ROOT_TOLERANCE``: the reported point is
  on the zero set to ~1e-12 m for analytic fields. A ray that comes within ``COARSE``
  of the surface without crossing it (a near miss: f stays above ``TOUCH`` at the
  closest approach) goes on past it. ``MAX_STEPS`` sphere steps per body bound the
  work; a trace still running after them is a miss (grazing rays against bound fields
  whose |f| underestimates the distance a lot). Baked grids (``bake``) are not
  1-Lipschitz: a step may overshoot the surface by up to the grid's error bound, and
  the bracket [last outside, first inside] is then bisected, so the hit is a zero of
  the interpolant; features thinner than the error bound may be stepped over.
- Circle casts (``radius`` r > 0): the same walk and tests on every shape grown by r
  (its Minkowski sum with the disc): circles of radius R + r; meshes by their edges
  moved out by r and circles of radius r about their vertices (``_rounded``); fields
  as f - r. The grid and the boxes are grown by r.
- Inside: a ray whose origin is inside a body (f <= 0; for meshes, the first crossing
  leaves) hits it at distance 0, point = the origin, normal = the normalised field
  gradient at the origin (the outward direction of the nearest boundary for exact
  fields; (1, 0) at a circle's centre, as the fields' convention).

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

from ._jit import njit
from .collide.broadphase import world_bounds
from .errors import SpecError, check_int, check_number
from .limits import MAX_BITS
from .sdf.compiled import compile_field, run
from .sdf.opcodes import POP_T, PUSH_T

__all__ = ["COARSE", "MAX_STEPS", "ROOT_TOLERANCE", "TOUCH", "PointHits", "RayHits",
           "cast", "nearest", "overlapping"]

#: Sphere tracing hands over to the root solve once f < COARSE (m): a ray grazing a
#: surface of curvature radius R takes about sqrt(2 R / COARSE) sphere steps to get
#: there (the steps shrink as the square of the distance to the tangent point).
COARSE = 1e-4
#: Root solve stops when the bracket is this narrow or f this small (m).
ROOT_TOLERANCE = 1e-13
#: A closest approach with f above this (m) is a near miss; at or below, a touch.
TOUCH = 1e-10
#: Over-relaxation of the sphere-tracing steps (Keinert et al. 2014, "Enhanced sphere
#: tracing"): t <- t + OMEGA f while the discs of radius f about consecutive points
#: overlap (then no surface lies between them); the first gap falls back to plain steps.
OMEGA = 1.6
#: Sphere-tracing steps per (ray, body) before the trace gives up (a miss).
MAX_STEPS = 1000
#: Root-solve iterations per hit.
_ROOT_STEPS = 100
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
    """The kernel's tables for ``shapes`` (each field compiled once, cached on it)."""
    kinds, radius, bounds, vstart, vcount, verts = [], [], [], [], [], []
    cstart, ccount, codes, consts, shift = [], [], [], [], []
    nv = nc = nk = 0
    depth = nesting = 1
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
        code = program.code.copy()
        shift.append(_outer_shift(code, program.consts))
        if shift[-1] is not None:
            code = code[1:-1]
        code[:, 1] += nk
        cstart.append(nc)
        ccount.append(len(code))
        codes.append(code)
        consts.append(program.consts)
        nc += len(code)
        nk += len(program.consts)
        depth, nesting = max(depth, program.depth), max(nesting, program.nesting)
    return _Packed(np.array(kinds, np.int64), np.array(radius, np.float64),
                   np.array(bounds, np.float64).reshape(-1, 4), np.array(vstart, np.int64),
                   np.array(vcount, np.int64), np.concatenate(verts + [np.zeros((0, 2))]),
                   np.array(cstart, np.int64), np.array(ccount, np.int64),
                   np.concatenate(codes + [np.zeros((0, 4), np.int64)]),
                   np.concatenate(consts + [np.zeros(1)]),
                   np.array([(0.0, 0.0) if o is None else o for o in shift],
                            np.float64).reshape(-1, 2), depth, nesting)


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
# The ray kernel
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy", inline="always")
def _field(code, consts, x, y, pt, stack, frames, cur, value, grad):
    """(f, df/dx, df/dy) of a program at (x, y), body frame."""
    pt[0, 0], pt[0, 1] = x, y
    run(code, consts, pt, 1, stack, frames, cur, value, grad)
    return value[0], grad[0, 0], grad[0, 1]


@njit(cache=True, error_model="numpy", inline="always")
def _slab(px, py, dx, dy, b, grow, top):
    """[t0, t1] of the ray p + t d, 0 <= t <= top, inside the box b (4,) grown by grow
    all round; t0 > t1: none."""
    t0, t1 = 0.0, top
    for k in range(2):
        o, d, lo, hi = (px, dx, b[0] - grow, b[2] + grow) if k == 0 else (
            py, dy, b[1] - grow, b[3] + grow)
        if d == 0.0:
            if o < lo or o > hi:
                return 1.0, 0.0
        else:
            a, c = (lo - o) / d, (hi - o) / d
            t0, t1 = max(t0, min(a, c)), min(t1, max(a, c))
    return t0, t1


@njit(cache=True, error_model="numpy", inline="always")
def _hit(body, ox, oy, dx, dy, rad, top, com, angle, sid, pk_kind, pk_radius, pk_bounds, vstart,
         vcount, verts, cstart, ccount, code, consts, shift, pt, stack, frames, cur, value, grad):
    """First hit (t, nx, ny) of the ray o + t d (unit d), 0 <= t <= top, on ``body``
    grown by rad (m; the disc of a circle cast); t = inf for none. Normal in world axes.
    See the module docstring."""
    s = sid[body]
    c, sn = math.cos(angle[body]), math.sin(angle[body])
    rx, ry = ox - com[body, 0], oy - com[body, 1]
    px, py = c * rx + sn * ry, -sn * rx + c * ry
    ex, ey = c * dx + sn * dy, -sn * dx + c * dy
    t, nx, ny, inside = math.inf, 1.0, 0.0, False
    kind = pk_kind[s]
    if kind == _CIRCLE:
        r = pk_bounds[s, 2] + rad
        b = px * ex + py * ey
        cc = px * px + py * py - r * r
        if cc <= 0.0:
            inside = True
        else:
            disc = b * b - cc
            if b < 0.0 and disc >= 0.0:
                t = cc / (-b + math.sqrt(disc))
                nx, ny = (px + t * ex) / r, (py + t * ey) / r
    elif kind == _MESH and rad > 0.0:
        t, nx, ny, inside = _rounded(px, py, ex, ey, rad, vstart[s], vcount[s], verts,
                                     code[cstart[s]:cstart[s] + ccount[s]], consts, pt,
                                     stack, frames, cur, value, grad)
    elif kind == _MESH:
        v0, m = vstart[s], vcount[s]
        first, leaving = math.inf, False
        for i in range(m):
            ax, ay, qx, qy, length, enx, eny = _edge(verts, v0, m, i)
            dn = ex * enx + ey * eny
            if dn == 0.0:
                continue
            ti = ((ax - px) * enx + (ay - py) * eny) / dn
            if ti < 0.0:
                continue
            hx, hy = px + ti * ex - ax, py + ti * ey - ay
            u = (hx * qx + hy * qy) / (length * length)
            if u < 0.0 or u > 1.0:
                continue
            # First crossing; an entering one wins a tie (the origin on a vertex).
            if ti < first or (ti == first and dn < 0.0):
                first, leaving = ti, dn > 0.0
                if dn < 0.0:
                    nx, ny = enx, eny
        if leaving:
            inside = True
        elif first < math.inf:
            t = first
    else:
        # The shape's local box and bounding disc (radius R about the centre of mass)
        # clip the stretch traced.
        t0, t1 = _slab(px, py, ex, ey, pk_bounds[s], rad, top)
        big = pk_radius[s] + rad
        if big < math.inf:
            b = px * ex + py * ey
            disc = b * b - (px * px + py * py - big * big)
            if disc < 0.0:
                t1 = -1.0
            else:
                root = math.sqrt(disc)
                t0, t1 = max(t0, -b - root), min(t1, -b + root)
        if t0 <= t1:
            cs = code[cstart[s]:cstart[s] + ccount[s]]
            t, nx, ny, inside = _trace(px, py, ex, ey, shift[s, 0], shift[s, 1], rad, t0,
                                       t1, cs, consts, pt, stack, frames, cur, value, grad)
            if inside:
                return 0.0, c * nx - sn * ny, sn * nx + c * ny
    if inside:
        cs = code[cstart[s]:cstart[s] + ccount[s]]
        _, gx, gy = _field(cs, consts, px - shift[s, 0], py - shift[s, 1], pt, stack,
                           frames, cur, value, grad)
        norm = math.hypot(gx, gy)
        nx, ny = (gx / norm, gy / norm) if norm > 0.0 else (1.0, 0.0)
        t = 0.0
    if t > top:
        return math.inf, 0.0, 0.0
    return t, c * nx - sn * ny, sn * nx + c * ny


@njit(cache=True, error_model="numpy", inline="always")
def _edge(verts, v0, m, i):
    """Edge i of the counter-clockwise outline verts[v0:v0 + m]: its start (ax, ay), its
    vector (qx, qy) to the next vertex, its length and its outward unit normal
    (qy, -qx) / length."""
    ax, ay = verts[v0 + i, 0], verts[v0 + i, 1]
    j = v0 + (i + 1) % m
    qx, qy = verts[j, 0] - ax, verts[j, 1] - ay
    length = math.hypot(qx, qy)
    return ax, ay, qx, qy, length, qy / length, -qx / length


@njit(cache=True, error_model="numpy", inline="always")
def _rounded(px, py, ex, ey, rad, v0, m, verts, code, consts, pt, stack, frames, cur, value,
             grad):
    """First hit (t, nx, ny, inside) of p + t e (body frame) on the polygon
    verts[v0:v0 + m] grown by rad > 0 (its Minkowski sum with a disc: edges moved out by
    rad, joined by arcs about the vertices). Inside: f(p) <= rad. From outside, every
    point of a moved edge or an arc is within rad of the polygon, so the first of them
    along the ray is the entry (the distance to the polygon is continuous): the least t
    over the moved edges entered (t = ((a - p).n + rad) / e.n, e.n < 0) and the vertex
    circles (as a circle's closed form)."""
    f, gx, gy = _field(code, consts, px, py, pt, stack, frames, cur, value, grad)
    if f <= rad:
        return _unit(0.0, gx, gy, True)
    t, nx, ny = math.inf, 1.0, 0.0
    for i in range(m):
        ax, ay, qx, qy, length, enx, eny = _edge(verts, v0, m, i)
        dn = ex * enx + ey * eny
        if dn < 0.0:
            ti = ((ax - px) * enx + (ay - py) * eny + rad) / dn
            hx, hy = px + ti * ex - rad * enx - ax, py + ti * ey - rad * eny - ay
            u = (hx * qx + hy * qy) / (length * length)
            if 0.0 <= ti < t and 0.0 <= u <= 1.0:
                t, nx, ny = ti, enx, eny
        rx, ry = px - ax, py - ay
        b = rx * ex + ry * ey
        cc = rx * rx + ry * ry - rad * rad
        disc = b * b - cc
        if b < 0.0 and disc >= 0.0 and cc > 0.0:
            ti = cc / (-b + math.sqrt(disc))
            if ti < t:
                t, nx, ny = ti, (rx + ti * ex) / rad, (ry + ti * ey) / rad
    return t, nx, ny, False


@njit(cache=True, error_model="numpy", inline="always")
def _unit(t, gx, gy, inside):
    """(t, unit gradient, inside); (1, 0) for a zero gradient (the fields' fallback)."""
    norm = math.hypot(gx, gy)
    if norm > 0.0:
        return t, gx / norm, gy / norm, inside
    return t, 1.0, 0.0, inside


@njit(cache=True, error_model="numpy", inline="always")
def _trace(px, py, ex, ey, ox, oy, rad, t0, t1, code, consts, pt, stack, frames, cur,
           value, grad):
    """Sphere trace then root solve (module docstring) of p + t e on [t0, t1]; returns
    (t, nx, ny, inside) in the body frame, t = inf for a miss. The program runs at
    p + t e - (ox, oy) (``_outer_shift``); the field traced is f - rad (the shape grown
    by rad)."""
    miss = (math.inf, 0.0, 0.0, False)
    t = t0
    last, f_last, step = t0, 0.0, 0.0      # the last point known outside, f there, step
    omega = OMEGA
    for _ in range(MAX_STEPS):
        f, gx, gy = _field(code, consts, px + t * ex - ox, py + t * ey - oy, pt, stack,
                           frames, cur, value, grad)
        f -= rad
        if f <= 0.0 and t == 0.0:
            return _unit(0.0, gx, gy, True)
        if step > f_last and f + f_last < step:
            # The over-relaxed step left a gap between the two empty discs: take the
            # plain step from the last point instead, and plain steps from now on.
            omega = 1.0
            t, step = last + f_last, 0.0
            continue
        if f >= COARSE:
            if t + f > t1:
                return miss
            last, f_last, step = t, f, omega * f
            t = min(t + step, t1)
            continue
        # Root solve on [lo, hi]: lo outside (f > 0), hi inside (f <= 0) once found;
        # Newton steps from the latest point x, whichever side it lies on.
        if f <= 0.0 and t == last:     # inside where the ray enters the shape's box
            return _unit(t, gx, gy, False)
        if f > 0.0:
            lo, flo, glx, gly = t, f, gx, gy
            hi, fhi, ghx, ghy = math.inf, -math.inf, 0.0, 0.0
        else:
            lo, hi, fhi, ghx, ghy = last, t, f, gx, gy
            flo, glx, gly = _field(code, consts, px + lo * ex - ox, py + lo * ey - oy, pt,
                                   stack, frames, cur, value, grad)
            flo -= rad
        x, fx, slope = t, f, gx * ex + gy * ey
        for _ in range(_ROOT_STEPS):
            if flo <= ROOT_TOLERANCE or -fhi <= ROOT_TOLERANCE or hi - lo <= ROOT_TOLERANCE:
                break
            newton = -fx / slope if slope < 0.0 else math.inf
            x = x + newton
            if not (lo < x < hi) or abs(newton) > 1e3 * COARSE:
                if hi == math.inf:
                    break              # no inside point near: a near miss or a graze
                x = 0.5 * (lo + hi)
            fx, g1, g2 = _field(code, consts, px + x * ex - ox, py + x * ey - oy, pt, stack,
                                frames, cur, value, grad)
            fx -= rad
            slope = g1 * ex + g2 * ey
            if fx > 0.0:
                lo, flo, glx, gly = x, fx, g1, g2
            else:
                hi, fhi, ghx, ghy = x, fx, g1, g2
                if fx == 0.0:
                    lo, flo, glx, gly = x, 0.0, g1, g2
        if hi < math.inf and -fhi < flo:
            return _unit(hi, ghx, ghy, False)
        if hi < math.inf or flo <= TOUCH:
            return _unit(lo, glx, gly, False)
        # A near miss: go on past the closest approach, with plain steps.
        last, f_last, step = lo, flo, 0.0
        t = lo + max(flo, COARSE)
        if t > t1:
            return miss
    return miss


@njit(cache=True, error_model="numpy")
def _cast(origin, direction, rad, top, every, com, angle, sid, box, pk_kind, pk_radius, pk_bounds,
          vstart, vcount, verts, cstart, ccount, code, consts, shift, depth, nesting, g_lo, h,
          g_shape, g_start, g_list, big, out_body, out_t, out_n, out_ray):
    """Closest hit per ray (every = False: into out_body (N,), out_t (N,), out_n (N, 2),
    out_ray unused) or every hit (every = True: rows of out_*, out_ray the ray; returns
    the count, rows beyond the capacity counted, not written). See the module docstring.
    """
    n_bodies = com.shape[0]
    stamp = np.full(n_bodies, -1, np.int64)
    pt = np.empty((1, 2))
    stack = np.empty((depth, 1, 3))
    frames = np.empty((nesting, 1, 2))
    cur = np.empty((1, 2))
    value = np.empty(1)
    grad = np.empty((1, 2))
    capacity = out_t.shape[0]
    count = 0
    nx_cells, ny_cells = g_shape[0], g_shape[1]
    grid_box = np.array([g_lo[0], g_lo[1], g_lo[0] + nx_cells * h, g_lo[1] + ny_cells * h])
    for r in range(origin.shape[0]):
        ox, oy, dx, dy = origin[r, 0], origin[r, 1], direction[r, 0], direction[r, 1]
        best, bb, bnx, bny = top, -1, math.nan, math.nan
        # The bodies every ray tests, then the grid's cells in the ray's order.
        k = -1
        t0, t1 = _slab(ox, oy, dx, dy, grid_box, 0.0, top)
        walking = t0 <= t1 and g_list.shape[0] > 0
        ix = iy = 0
        sx = sy = 0
        tx = ty = ddx = ddy = math.inf
        if walking:
            ex = min(max(ox + t0 * dx, grid_box[0]), grid_box[2])
            ey = min(max(oy + t0 * dy, grid_box[1]), grid_box[3])
            ix = min(max(math.floor((ex - g_lo[0]) / h), 0), nx_cells - 1)
            iy = min(max(math.floor((ey - g_lo[1]) / h), 0), ny_cells - 1)
            if dx > 0.0:
                sx, tx, ddx = 1, (g_lo[0] + (ix + 1) * h - ox) / dx, h / dx
            elif dx < 0.0:
                sx, tx, ddx = -1, (g_lo[0] + ix * h - ox) / dx, -h / dx
            if dy > 0.0:
                sy, ty, ddy = 1, (g_lo[1] + (iy + 1) * h - oy) / dy, h / dy
            elif dy < 0.0:
                sy, ty, ddy = -1, (g_lo[1] + iy * h - oy) / dy, -h / dy
        while True:
            if k < big.shape[0] - 1:
                k += 1
                lo_i, hi_i, source = k, k + 1, 0
            elif walking:
                cell = ix * ny_cells + iy
                lo_i, hi_i, source = g_start[cell], g_start[cell + 1], 1
            else:
                break
            # Two passes over the cell: closed-form shapes first, whose hits then prune
            # the (costlier) traces of the SDF shapes behind them.
            for q in range(lo_i, hi_i + (hi_i - lo_i)):
                body = q if q < hi_i else q - (hi_i - lo_i)
                body = big[body] if source == 0 else g_list[body]
                if stamp[body] == r or (pk_kind[sid[body]] == _SDF) == (q < hi_i):
                    continue
                stamp[body] = r
                a0, a1 = _slab(ox, oy, dx, dy, box[body], 0.0, best if not every else top)
                if a0 > a1:
                    continue
                t, nx, ny = _hit(body, ox, oy, dx, dy, rad, best if not every else top, com,
                                 angle, sid, pk_kind, pk_radius, pk_bounds, vstart, vcount, verts,
                                 cstart, ccount, code, consts, shift, pt, stack, frames, cur,
                                 value, grad)
                if t == math.inf:
                    continue
                if every:
                    if count < capacity:
                        out_body[count], out_t[count] = body, t
                        out_n[count, 0], out_n[count, 1] = nx, ny
                        out_ray[count] = r
                    count += 1
                elif t < best or (t == best and (bb < 0 or body < bb)):
                    best, bb, bnx, bny = t, body, nx, ny
            if source == 1:
                exit_t = min(tx, ty)
                if exit_t > t1 or (not every and bb >= 0 and best <= exit_t):
                    break
                if tx < ty:
                    ix += sx
                    tx += ddx
                    if ix < 0 or ix >= nx_cells:
                        break
                else:
                    iy += sy
                    ty += ddy
                    if iy < 0 or iy >= ny_cells:
                        break
        if not every:
            out_body[r] = bb
            out_t[r] = best if bb >= 0 else math.nan
            out_n[r, 0], out_n[r, 1] = bnx, bny
    return count


def cast(world, origins: Any, directions: Any, max_distance: Any = math.inf,
         every: bool = False, mask: Any = None, bodies: Any = None,
         radius: Any = 0.0) -> RayHits:
    """Ray casts against ``world`` (``World.ray_cast`` / ``ray_cast_all`` /
    ``circle_cast``; module docstring). origins, directions: (N, 2) m and any nonzero
    length (normalised here); max_distance: m, >= 0 (inf allowed). every: all hits
    (``RayHits.ray`` set) instead of the closest per ray. mask: category bits (None: all). bodies:
    index array or None (all). radius: m, >= 0, a disc of that radius swept along each
    ray (every shape grown by it): ``distance`` is how far its centre travels, ``point``
    the contact on the body's surface (centre - radius normal)."""
    o, d, top = _rays(origins, directions, max_distance)
    rad = check_number(radius, "radius", low=0.0)
    keep = _bodies(bodies, world._view("category"), mask)
    pk = _packed(world)
    com = np.ascontiguousarray(world._view("com"))
    angle = np.ascontiguousarray(world._view("angle"))
    sid = np.ascontiguousarray(world._view("shape_id"))
    box = world_bounds(pk.bounds[sid], pk.radius[sid], com, angle, rad)
    g_lo, h, g_shape, g_start, g_list, big = _grid(box, keep)
    args = (com, angle, sid, box, pk.kind, pk.radius, pk.bounds, pk.vstart, pk.vcount,
            pk.vertices, pk.cstart, pk.ccount, pk.code, pk.consts, pk.shift, pk.depth,
            pk.nesting, g_lo, h, g_shape, g_start, g_list, big)
    if not every:
        body = np.empty(len(o), np.int64)
        t = np.empty(len(o))
        normal = np.empty((len(o), 2))
        _cast(o, d, rad, top, False, *args, body, t, normal, np.empty(0, np.int64))
        point = o + t[:, None] * d
        if rad > 0.0:
            point -= rad * normal
        return RayHits(body, point, normal, t)
    size = 4 * len(o) + 16
    while True:
        body, t = np.empty(size, np.int64), np.empty(size)
        normal, ray = np.empty((size, 2)), np.empty(size, np.int64)
        count = _cast(o, d, rad, top, True, *args, body, t, normal, ray)
        if count <= size:
            break
        size = count
    order = np.lexsort((body[:count], t[:count], ray[:count]))
    body, t, normal, ray = body[order], t[order], normal[order], ray[order]
    point = o[ray] + t[:, None] * d[ray]
    if rad > 0.0:
        point -= rad * normal
    return RayHits(body, point, normal, t, ray)


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
