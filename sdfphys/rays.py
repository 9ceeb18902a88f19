"""Ray casts and circle casts, batched over arrays: ``cast`` and its numba kernel.

``World.ray_cast``, ``ray_cast_all`` and ``circle_cast`` call ``cast``: one numba
kernel (``_cast``) for all the rays, no Python loop over rays or bodies, on the tables
and grid of ``sdfphys.queries`` (``_packed``, ``_grid``), which also holds the input
checks, the result type ``RayHits``, the point queries and the box overlaps.

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
  program (``sdf.compiled.run``), from where the ray enters the shape's local AABB and
  bounding disc: t <- t + f(p + t d) never passes the surface for a 1-Lipschitz field
  (exact, or a bound). Once f < ``COARSE`` the root of f along the ray is polished by
  safeguarded Newton steps t <- t - f / (grad f . d), each from the latest point
  (outside or inside), with bisection once a point inside brackets the root and a
  Newton step would leave the bracket (``rtsafe``, Numerical Recipes 9.4), to
  ``ROOT_TOLERANCE``; the end of the bracket with the smaller |f| is reported: on the
  zero set to ~1e-12 m for analytic fields. A ray that comes within ``COARSE``
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
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba.experimental import structref

from ._bundles import PlainFields
from ._jit import njit
from .collide.broadphase import world_bounds
from .errors import check_number
from .queries import _CIRCLE, _MESH, _SDF, RayHits, _bodies, _grid, _Packed, _packed, _rays
from .sdf.compiled import run_shared

__all__ = ["COARSE", "MAX_STEPS", "OMEGA", "ROOT_TOLERANCE", "TOUCH", "cast"]

#: Sphere tracing hands over to the root solve once f < COARSE (m): a ray grazing a
#: surface of curvature radius R takes about sqrt(2 R / COARSE) sphere steps to get
#: there (the steps shrink as the square of the distance to the tangent point).
COARSE = 1e-4
#: Root solve stops when the bracket is this narrow or |f| at one of its ends this
#: small (m).
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


@structref.register
class _ShapeTablesType(PlainFields):
    """Numba's type of ``ShapeTables``."""


class ShapeTables(structref.StructRefProxy):
    """The world's per-shape tables (``queries._Packed``, S shapes) as the ray kernel
    takes them, by reference; made once per packing (``_shape_tables``), opaque to
    Python.

    kind: (S,) int64, ``_CIRCLE``, ``_MESH`` or ``_SDF``. radius: (S,) m, the bounding
    radius about the centre of mass (inf: unbounded). bounds: (S, 4) m, the local AABB
    (x0, y0, x1, y1). vstart, vcount: (S,) int64, the outline's rows of vertices (V, 2)
    m, counter-clockwise. cstart, ccount: (S,) int64, the program's rows of code (I, 4)
    int64, its constants in consts (F,). shift: (S, 2) m, the translation taken out of
    each program (``queries._outer_shift``). depth, nesting: int, the largest stack
    depth and nesting of the programs.
    """


SHAPE_FIELDS = ("kind", "radius", "bounds", "vstart", "vcount", "vertices", "cstart",
                "ccount", "code", "consts", "shift", "depth", "nesting")
structref.define_proxy(ShapeTables, _ShapeTablesType, list(SHAPE_FIELDS))


@njit(cache=True)
def _shape_tables_of(kind, radius, bounds, vstart, vcount, vertices, cstart, ccount, code,
                     consts, shift, depth, nesting):
    return ShapeTables(kind, radius, bounds, vstart, vcount, vertices, cstart, ccount, code,
                       consts, shift, depth, nesting)


def _shape_tables(world, pk: _Packed) -> ShapeTables:
    """``pk``'s arrays by reference (``pk``: ``_packed(world)``), kept on the world with
    the packing they were made of."""
    cache = world.__dict__.get("_ray_tables")
    if cache is None or cache[0] is not pk:
        cache = (pk, _shape_tables_of(*(getattr(pk, name) for name in SHAPE_FIELDS)))
        world._ray_tables = cache
    return cache[1]


class _Shapes(NamedTuple):
    """``ShapeTables``' arrays as ``_hit`` takes them: a tuple of the same arrays, made
    once per cast in ``_cast_into`` (njit), so that the tests of every (ray, body) read
    them from registers, not through the bundle's pointer."""

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


class _ProgramWork(NamedTuple):
    """One point's work arrays for the field programs (``sdf.compiled.run``): the point
    pt (1, 2) m, the program's stack (depth, 1, 3), frames (nesting, 1, 2) and cur
    (1, 2), and its results value (1,) m and grad (1, 2). Made in ``_cast`` (njit), passed
    to ``_hit``."""

    pt: np.ndarray
    stack: np.ndarray
    frames: np.ndarray
    cur: np.ndarray
    value: np.ndarray
    grad: np.ndarray


@njit(cache=True, error_model="numpy", inline="always")
def _field(code, consts, x, y, pt, stack, frames, cur, value, grad):
    """(f, df/dx, df/dy) of a program at (x, y), body frame."""
    pt[0, 0], pt[0, 1] = x, y
    run_shared(code, consts, pt, 1, stack, frames, cur, value, grad, 0, 0, 0)
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
def _hit(body, ox, oy, dx, dy, rad, top, com, cosine, sine, sid, shapes, work):
    """First hit (t, nx, ny) of the ray o + t d (unit d), 0 <= t <= top, on ``body``
    grown by rad (m; the disc of a circle cast); t = inf for none. Normal in world axes.
    com (B, 2) m; cosine, sine (B,): of the bodies' angles; sid (B,) int64, their shapes
    in ``shapes`` (``_Shapes``). work: ``_ProgramWork``. See the module docstring."""
    pk_kind, pk_radius, pk_bounds, vstart, vcount, verts, cstart, ccount, code, consts, \
        shift = shapes
    pt, stack, frames, cur, value, grad = work
    s = sid[body]
    c, sn = cosine[body], sine[body]
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
def _cast(origin, direction, rad, top, every, com, angle, sid, box, shapes, grid):
    """Closest hit per ray (every = False) or every hit (every = True) of the rays
    origin + t direction (N, 2) (unit directions), 0 <= t <= top, of discs of radius rad
    (m; 0: rays), on the bodies (com (B, 2) m, angle (B,) rad, sid (B,) int64 their shapes
    in ``shapes``, a ``ShapeTables``, box (B, 4) m their world AABBs grown by rad) of
    ``grid`` (``queries._grid``'s tuple: origin, cell, shape, start, list, big).

    Returns (body (H,) int64, t (H,) m, normal (H, 2) unit, ray (H,) int64, count):
    closest: one row per ray (body -1 and t nan for none), ray empty; every: the first
    ``count`` rows, one per hit. See the module docstring.
    """
    if not every:
        n = origin.shape[0]
        out_body, out_t, out_n = np.empty(n, np.int64), np.empty(n), np.empty((n, 2))
        out_ray = np.empty(0, np.int64)
        count = _cast_into(origin, direction, rad, top, False, com, angle, sid, box, shapes,
                           grid, out_body, out_t, out_n, out_ray)
        return out_body, out_t, out_n, out_ray, count
    size = 4 * origin.shape[0] + 16
    while True:
        out_body, out_t = np.empty(size, np.int64), np.empty(size)
        out_n, out_ray = np.empty((size, 2)), np.empty(size, np.int64)
        count = _cast_into(origin, direction, rad, top, True, com, angle, sid, box, shapes,
                           grid, out_body, out_t, out_n, out_ray)
        if count <= size:
            return out_body, out_t, out_n, out_ray, count
        size = count


@njit(cache=True, error_model="numpy")
def _cast_into(origin, direction, rad, top, every, com, angle, sid, box, shapes, grid,
               out_body, out_t, out_n, out_ray):
    """``_cast`` into out_body (N,), out_t (N,), out_n (N, 2) (every = False; out_ray
    unused) or into their rows and out_ray's (every = True; returns the count, rows
    beyond the capacity counted, not written)."""
    g_lo, h, g_shape, g_start, g_list, big = grid
    pk_kind = shapes.kind
    tables = _Shapes(shapes.kind, shapes.radius, shapes.bounds, shapes.vstart, shapes.vcount,
                     shapes.vertices, shapes.cstart, shapes.ccount, shapes.code, shapes.consts,
                     shapes.shift)
    n_bodies = com.shape[0]
    stamp = np.full(n_bodies, -1, np.int64)
    cosine, sine = np.empty(n_bodies), np.empty(n_bodies)
    for b in range(n_bodies):              # once per body, not per (ray, body) test
        cosine[b], sine[b] = math.cos(angle[b]), math.sin(angle[b])
    work = _ProgramWork(np.empty((1, 2)), np.empty((shapes.depth, 1, 3)),
                        np.empty((shapes.nesting, 1, 2)), np.empty((1, 2)), np.empty(1),
                        np.empty((1, 2)))
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
                                 cosine, sine, sid, tables, work)
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
    body, t, normal, ray, count = _cast(o, d, rad, top, every, com, angle, sid, box,
                                       _shape_tables(world, pk), _grid(box, keep))
    if not every:
        point = o + t[:, None] * d
        if rad > 0.0:
            point -= rad * normal
        return RayHits(body, point, normal, t)
    order = np.lexsort((body[:count], t[:count], ray[:count]))
    body, t, normal, ray = body[order], t[order], normal[order], ray[order]
    point = o[ray] + t[:, None] * d[ray]
    if rad > 0.0:
        point -= rad * normal
    return RayHits(body, point, normal, t, ray)
