"""The compiled evaluation of each primitive of a field program, point by point.

``compiled.run`` evaluates a program instruction by instruction over a batch of
points; the primitives that are not a line of arithmetic are the kernels here: one
point's value and gradient (``_shape`` dispatches on the opcode); the ellipse's solver
over the batch is in ``ellipse_kernel``, the quadratic Bezier's cubic in
``bezier_kernel``, the smooth blends in ``blend_kernels``. They are the primitives' one
implementation (``Field.evaluate`` runs the program); the classes in ``sdf.curved``,
``conics``, ``polygonal``, ``folded`` and ``grid`` keep the parameters, validation,
bounds and the formulas' references. The numpy oracle the tests compare them with is
tests/numpy_fields, operation for operation the same except where numpy's SIMD
transcendentals round differently.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..vec2 import TINY, unit_or
from .bezier_kernel import _bezier
from .opcodes import (
    _POLYGON_EDGE,
    ARC,
    CONVEX,
    CROSS,
    CUT_DISK,
    EGG,
    GRID,
    HEART,
    HORSESHOE,
    MIRRORED,
    MOON,
    ORIENTED_BOX,
    PIE,
    RHOMBUS,
    RING,
    ROUNDED_CROSS,
    STAR,
    SYM_TRIANGLE,
    TRAPEZOID,
    UNEVEN_CAPSULE,
    VESICA,
)

# --------------------------------------------------------------------------------------
# The primitives with their own loops in ``compiled.run``.
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy", refcounts=False)
def _box(x: float, y: float, hx: float, hy: float) -> tuple[float, float, float]:
    """Quilez's sdgBox at one point: value and gradient of the box of half-extents h.

    With w = |p| - h: outside the value is |max(w, 0)| and the gradient
    sign(p) max(w, 0) / |max(w, 0)|; inside the value is max(w_x, w_y) and the
    gradient the axis of the nearest face (x wins a tie, so the medial axis is
    deterministic), times sign(p) (sign(0) = +1).
    """
    wx, wy = abs(x) - hx, abs(y) - hy
    sx = -1.0 if x < 0.0 else 1.0
    sy = -1.0 if y < 0.0 else 1.0
    ox, oy = max(wx, 0.0), max(wy, 0.0)
    out_len = math.hypot(ox, oy)
    inner = min(max(wx, wy), 0.0)
    if out_len > 0.0:
        gx, gy = ox / out_len, oy / out_len
    elif wx >= wy:
        gx, gy = 1.0, 0.0
    else:
        gx, gy = 0.0, 1.0
    return out_len + inner, gx * sx, gy * sy


@njit(cache=True, error_model="numpy", refcounts=False)
def _polygon(consts: np.ndarray, o: int, m: int, px: float, py: float
             ) -> tuple[float, float, float]:
    """polygonal.Polygon at one point (edges from consts[o + 1:])."""
    best = np.inf
    k = 0
    tk = 0.0
    inside = False
    e0 = o + 1
    for i in range(m):
        j = e0 + _POLYGON_EDGE * i
        ax, ay, ex, ey, by, inv = (consts[j], consts[j + 1], consts[j + 2], consts[j + 3],
                                   consts[j + 4], consts[j + 5])
        wx = px - ax
        wy = py - ay
        t = wx * ex
        t += wy * ey
        t *= inv
        t = min(max(t, 0.0), 1.0)
        vx = wx - t * ex
        vy = wy - t * ey
        d2 = vx * vx + vy * vy
        if d2 < best:                                   # np.argmin: first of a tie
            best, k, tk = d2, i, t
        below_b = py < by
        if ((py >= ay) == below_b) and (below_b == (ex * wy > ey * wx)):
            inside = not inside
    j = e0 + _POLYGON_EDGE * k
    vx = (px - consts[j]) - tk * consts[j + 2]
    vy = (py - consts[j + 1]) - tk * consts[j + 3]
    nx, ny = consts[j + 6], consts[j + 7]
    s = -1.0 if inside else 1.0
    if tk > 0.0 and tk < 1.0:
        return s * math.sqrt(best), nx, ny
    ux, uy = s * vx, s * vy
    length = math.hypot(ux, uy)
    if length > consts[o]:
        return s * math.sqrt(best), ux / length, uy / length
    return s * math.sqrt(best), nx, ny


@njit(cache=True, error_model="numpy", refcounts=False)
def _segment(consts: np.ndarray, o: int, px: float, py: float) -> tuple[float, float, float]:
    """Distance to the segment a -> a + ba (Quilez's sdSegment) minus the capsule radius.

    h = clamp((p - a).ba / |ba|^2, 0, 1); for 0 < h < 1 the gradient is the unit
    normal of ab on p's side (the left normal on the segment); at a clamped end
    (p - end) / |p - end|; a == b is a point (left normal (1, 0)).
    """
    ax, ay, bax, bay, length2 = consts[o], consts[o + 1], consts[o + 2], consts[o + 3], \
        consts[o + 4]
    lx, ly = consts[o + 5], consts[o + 6]
    pax, pay = px - ax, py - ay
    h = 0.0
    if length2 > 0.0:
        h = min(max((pax * bax + pay * bay) / length2, 0.0), 1.0)
    rx, ry = pax - h * bax, pay - h * bay
    dist = math.hypot(rx, ry)
    if h > 0.0 and h < 1.0:
        side = bax * pay - bay * pax
        if side < 0.0:
            return dist - consts[o + 7], -lx, -ly
        return dist - consts[o + 7], lx, ly
    if dist > TINY:
        return dist - consts[o + 7], rx / dist, ry / dist
    return dist - consts[o + 7], lx, ly


# --------------------------------------------------------------------------------------
# The primitives that ``_shape`` evaluates point by point. Conventions: a fold of x
# takes sign(0) = +1; a unit vector of a zero vector is the primitive's fallback
# (``vec2.unit_or``); products are written out, so a point's bits never depend on
# its place in the batch.
# --------------------------------------------------------------------------------------

_EDGE = 7


@njit(cache=True, error_model="numpy", refcounts=False)
def _nearest(consts: np.ndarray, e0: int, m: int, qx: float, qy: float
             ) -> tuple[float, float, float, float, float, bool]:
    """Nearest of the m edges at consts[e0:] to q (Quilez's sdSegment): distance,
    v = q - closest, the edge's outward normal and whether the closest point is
    strictly inside the edge. Ties go to the earlier edge."""
    best, bvx, bvy, bnx, bny, binterior = 0.0, 0.0, 0.0, 0.0, 0.0, False
    for i in range(m):
        j = e0 + _EDGE * i
        ex, ey = consts[j + 2], consts[j + 3]
        wx = qx - consts[j]
        wy = qy - consts[j + 1]
        t = min(max((wx * ex + wy * ey) / consts[j + 4], 0.0), 1.0)
        vx = wx - t * ex
        vy = wy - t * ey
        d2 = vx * vx + vy * vy
        if i == 0 or d2 < best:                         # ties: the earlier edge
            best, bvx, bvy = d2, vx, vy
            bnx, bny = consts[j + 5], consts[j + 6]
            binterior = t > 0.0 and t < 1.0
    return math.sqrt(best), bvx, bvy, bnx, bny, binterior


@njit(cache=True, error_model="numpy", refcounts=False)
def _signed(dist: float, vx: float, vy: float, nx: float, ny: float, interior: bool,
            inside: bool, eps: float) -> tuple[float, float, float]:
    """Value and gradient from ``_nearest``'s data (polygonal's module docstring):
    f = s dist, grad f = the edge normal where the closest point is inside an edge,
    else s v / |v|, the edge normal if |v| < eps."""
    s = -1.0 if inside else 1.0
    if interior:
        return s * dist, nx, ny
    ux, uy = s * vx, s * vy
    length = math.hypot(ux, uy)
    if length > eps:
        return s * dist, ux / length, uy / length
    return s * dist, nx, ny


@njit(cache=True, error_model="numpy", refcounts=False)
def _sign(x: float) -> float:
    return -1.0 if x < 0.0 else 1.0


@njit(cache=True, error_model="numpy", refcounts=False)
def _ring(consts: np.ndarray, o: int, full: int, px: float, py: float
          ) -> tuple[float, float, float]:
    """curved.Ring."""
    cx, cy, r, w = consts[o], consts[o + 1], consts[o + 2], consts[o + 3]
    sx = _sign(px)
    qx, qy = abs(px), py
    length = math.hypot(qx, qy)
    d_ring = abs(length - r) - w
    ux, uy = unit_or(qx, qy, 0.0, 1.0)
    if length < r:
        ux, uy = -ux, -uy
    if full:
        return d_ring, ux * sx, uy
    nx, ny = cy, -cx
    u = qx * nx + qy * ny
    v = qx * cx + qy * cy
    s = 1.0 if u > 0.0 else -1.0
    rx, ry = u, v - min(max(v, r - w), r + w)
    d_face = s * math.hypot(rx, ry)
    if v > r - w and v < r + w:
        lx, ly = 1.0, 0.0
    else:
        lx, ly = unit_or(s * rx, s * ry, 1.0, 0.0)
    if d_ring >= d_face:
        return d_ring, ux * sx, uy
    return d_face, (lx * nx + ly * cx) * sx, lx * ny + ly * cy


@njit(cache=True, error_model="numpy", refcounts=False)
def _pie(consts: np.ndarray, o: int, full: int, px: float, py: float
         ) -> tuple[float, float, float]:
    """curved.Pie."""
    cx, cy, r = consts[o], consts[o + 1], consts[o + 2]
    sx = _sign(px)
    qx, qy = abs(px), py
    d_arc = math.hypot(qx, qy) - r
    ax, ay = unit_or(qx, qy, 0.0, 1.0)
    if full:
        return d_arc, ax * sx, ay
    nx, ny = cy, -cx
    s = 1.0 if qx * nx + qy * ny > 0.0 else -1.0
    h = min(max(qx * cx + qy * cy, 0.0), r)
    rx, ry = qx - h * cx, qy - h * cy
    d_edge = s * math.hypot(rx, ry)
    if d_arc >= d_edge:
        return d_arc, ax * sx, ay
    if h > 0.0 and h < r:
        return d_edge, nx * sx, ny
    gx, gy = unit_or(s * rx, s * ry, nx, ny)
    return d_edge, gx * sx, gy


@njit(cache=True, error_model="numpy", refcounts=False)
def _horseshoe(consts: np.ndarray, o: int, px: float, py: float
               ) -> tuple[float, float, float]:
    """curved.Horseshoe."""
    r, w, L = consts[o], consts[o + 1], consts[o + 2]
    nx, ny, dx, dy = consts[o + 3], consts[o + 4], consts[o + 5], consts[o + 6]
    sx = _sign(px)
    qx, qy = abs(px), py
    u = qx * dx + qy * dy
    v = qx * nx + qy * ny
    if u > 0.0:                                         # the leg
        sv = 1.0 if v >= r else -1.0
        bx, by = u - L, abs(v - r) - w
        ox, oy = max(bx, 0.0), max(by, 0.0)
        out = math.hypot(ox, oy)
        d_leg = out + min(max(bx, by), 0.0)
        if out > 0.0:
            lx, ly = ox / out, oy * sv / out
        elif bx >= by:
            lx, ly = 1.0, 0.0
        else:
            lx, ly = 0.0 * sv, sv
        return d_leg, (lx * dx + ly * nx) * sx, lx * dy + ly * ny
    length = math.hypot(qx, qy)
    d_ann = abs(length - r) - w
    tx, ty = u - L, v - min(max(v, r - w), r + w)
    d_tip = -math.hypot(tx, ty)
    if d_ann < 0.0 and d_tip > d_ann:
        lx, ly = unit_or(-tx, -ty, 1.0, 0.0)
        return d_tip, (lx * dx + ly * nx) * sx, lx * dy + ly * ny
    gx, gy = unit_or(qx, qy, 0.0, -1.0)
    if length < r:
        gx, gy = -gx, -gy
    return d_ann, gx * sx, gy


@njit(cache=True, error_model="numpy", refcounts=False)
def _moon(consts: np.ndarray, o: int, px: float, py: float) -> tuple[float, float, float]:
    """conics.Moon."""
    ra, rb, dc = consts[o], consts[o + 1], consts[o + 2]
    ka, kb = consts[o + 3], consts[o + 4]
    sy = _sign(py)
    qx, qy = px, abs(py)
    length = math.hypot(qx, qy)
    vx, vy = qx - dc, qy - 0.0
    lv = math.hypot(vx, vy)
    s = -1.0 if (length < ra and lv > rb) else 1.0
    kx, ky = qx - ka, qy - kb
    d_k = math.hypot(kx, ky)
    if ka * qy - kb * qx >= 0.0:
        d_a = abs(length - ra)
        gax, gay = unit_or(qx, qy, -1.0, 0.0)
    else:
        d_a = d_k
        gax, gay = unit_or(s * kx, s * ky, consts[o + 5], consts[o + 6])
    if (ka - dc) * vy - kb * vx >= 0.0:
        d_b = abs(lv - rb)
        gbx, gby = unit_or(-vx, -vy, 1.0, 0.0)
    else:
        d_b = d_k
        gbx, gby = unit_or(s * kx, s * ky, consts[o + 5], consts[o + 6])
    if d_a <= d_b:
        return s * d_a, gax, gay * sy
    return s * d_b, gbx, gby * sy


@njit(cache=True, error_model="numpy", refcounts=False)
def _heart(consts: np.ndarray, o: int, px: float, py: float) -> tuple[float, float, float]:
    """conics.Heart (unit heart at p / scale, value times scale)."""
    scale = consts[o]
    px, py = px / scale, py / scale
    sx = _sign(px)
    qx, qy = abs(px), py
    enx, eny = consts[o + 4], consts[o + 5]
    if qx + qy > 1.0:                                   # a lobe
        lx, ly = qx - consts[o + 1], qy - consts[o + 2]
        gx, gy = unit_or(lx, ly, 0.0, 1.0)
        return (math.hypot(lx, ly) - consts[o + 3]) * scale, gx * sx, gy
    s = 1.0 if qx > qy else -1.0
    t = max(qx + qy, 0.0) / 2.0
    rx, ry = qx - t, qy - t
    d_seg = math.hypot(rx, ry)
    kx, ky = qx - 0.0, qy - 1.0
    d_cusp = math.hypot(kx, ky)
    if d_seg <= d_cusp:
        if t > 0.0:
            gx, gy = enx, eny
        else:
            gx, gy = unit_or(s * rx, s * ry, enx, eny)
        return s * d_seg * scale, gx * sx, gy
    gx, gy = unit_or(s * kx, s * ky, 0.0, 1.0)
    return s * d_cusp * scale, gx * sx, gy


@njit(cache=True, error_model="numpy", refcounts=False)
def _star(consts: np.ndarray, o: int, px: float, py: float) -> tuple[float, float, float]:
    """folded.Star: polar reduction to one sector and back."""
    an, period, eps = consts[o], consts[o + 1], consts[o + 2]
    x, y = abs(px), py
    theta = math.atan2(x, y)
    bn = np.fmod(theta, period)                         # np.mod for theta >= 0, period > 0
    if bn == 0.0:
        bn = 0.0
    bn = bn - an
    hx, hy = math.cos(bn), abs(math.sin(bn))
    length = math.hypot(x, y)
    qx, qy = length * hx, length * hy
    dist, vx, vy, nx, ny, interior = _nearest(consts, o + 5, 1, qx, qy)
    inside = (qx - consts[o + 3]) * nx + (qy - consts[o + 4]) * ny < 0.0
    d, gqx, gqy = _signed(dist, vx, vy, nx, ny, interior, inside, eps)
    g_r = gqx * hx + gqy * hy
    g_t = (-1.0 if bn >= 0.0 else 1.0) * (gqy * hx - gqx * hy)
    st, ct = math.sin(theta), math.cos(theta)
    return d, (g_r * st - g_t * ct) * _sign(px), g_r * ct + g_t * st


@njit(cache=True, error_model="numpy", refcounts=False)
def _mirrored(consts: np.ndarray, o: int, k: int, abs_y: int, px: float, py: float
              ) -> tuple[float, float, float]:
    """folded._MirrorFolded: |p|, k mirrors, one edge on y = radius."""
    sx = _sign(px)
    sy = _sign(py) if abs_y else 1.0
    qx, qy = px * sx, py * sy
    moved = 0
    for i in range(k):
        nx, ny = consts[o + 2 + 2 * i], consts[o + 3 + 2 * i]
        dot = qx * nx + qy * ny
        m = 2.0 * min(dot, 0.0)
        qx, qy = qx - m * nx, qy - m * ny
        if dot < 0.0:
            moved |= 1 << i
    e0 = o + 2 + 2 * k
    dist, vx, vy, nx, ny, interior = _nearest(consts, e0, 1, qx, qy)
    d, gx, gy = _signed(dist, vx, vy, nx, ny, interior, qy < consts[o], consts[o + 1])
    for i in range(k - 1, -1, -1):
        if moved & (1 << i):
            nx, ny = consts[o + 2 + 2 * i], consts[o + 3 + 2 * i]
            m = 2.0 * (gx * nx + gy * ny)
            gx, gy = gx - m * nx, gy - m * ny
    return d, gx * sx, gy * sy


@njit(cache=True, error_model="numpy", refcounts=False)
def _grid(consts: np.ndarray, o: int, nx: int, ny: int, px: float, py: float
          ) -> tuple[float, float, float]:
    """grid.GridField: bilinear inside the grid, the extension outside (with the
    margin of the side beyond which the point lies), the band."""
    h, band = consts[o + 2], consts[o + 7]
    ux = (px - consts[o]) / h
    uy = (py - consts[o + 1]) / h
    cx = min(max(ux, 0.0), float(nx - 1))
    cy = min(max(uy, 0.0), float(ny - 1))
    i = int(min(math.floor(cx), float(nx - 2)))
    j = int(min(math.floor(cy), float(ny - 2)))
    tx, ty = cx - i, cy - j
    base = o + 8 + i * ny + j
    v00, v01 = consts[base], consts[base + 1]
    v10, v11 = consts[base + ny], consts[base + ny + 1]
    value = ((1.0 - tx) * (1.0 - ty) * v00 + tx * (1.0 - ty) * v10
             + (1.0 - tx) * ty * v01 + tx * ty * v11)
    gx = ((1.0 - ty) * (v10 - v00) + ty * (v11 - v01)) / h
    gy = ((1.0 - tx) * (v01 - v00) + tx * (v11 - v10)) / h
    dqx, dqy = (ux - cx) * h, (uy - cy) * h
    dd = math.hypot(dqx, dqy)
    if dd > 0.0:
        mx = consts[o + 3] if dqx < 0.0 else (consts[o + 5] if dqx > 0.0 else math.inf)
        my = consts[o + 4] if dqy < 0.0 else (consts[o + 6] if dqy > 0.0 else math.inf)
        margin = min(mx, my)
        gqx = gx * (1.0 if ux == cx else 0.0)          # clamped axes: no slope
        gqy = gy * (1.0 if uy == cy else 0.0)
        v = value
        pos = max(v, 0.0)
        root = math.sqrt(pos * pos + dd * dd + 2.0 * margin * dd)
        value = root + min(v, 0.0)
        ratio = (dd + margin) / dd
        neg = 1.0 if v < 0.0 else 0.0
        gx = (pos * gqx + ratio * dqx) / root + neg * gqx
        gy = (pos * gqy + ratio * dqy) / root + neg * gqy
    if abs(value) > band:
        return min(max(value, -band), band), 0.0, 0.0
    return value, gx, gy


@njit(cache=True, error_model="numpy", refcounts=False)
def _shape(op: int, consts: np.ndarray, o: int, a: int, b: int, px: float, py: float
           ) -> tuple[float, float, float]:
    """Value and gradient at one point of the primitive instruction (op, o, a, b)."""
    if op == ARC:
        cx, cy, r = consts[o], consts[o + 1], consts[o + 2]
        sx = _sign(px)
        qx, qy = abs(px), py
        length = math.hypot(qx, qy)
        if cy * qx - cx * qy <= 0.0:                    # on the arc
            gx, gy = unit_or(qx, qy, 0.0, 1.0)
            if length < r:
                gx, gy = -gx, -gy
            return abs(length - r) - consts[o + 3], gx * sx, gy
        rx, ry = qx - r * cx, qy - r * cy
        gx, gy = unit_or(rx, ry, cx, cy)
        return math.hypot(rx, ry) - consts[o + 3], gx * sx, gy
    if op == RING:
        return _ring(consts, o, a, px, py)
    if op == PIE:
        return _pie(consts, o, a, px, py)
    if op == CUT_DISK:
        r, h, w = consts[o], consts[o + 1], consts[o + 2]
        sx = _sign(px)
        qx, qy = abs(px), py
        length = math.hypot(qx, qy)
        s = -1.0 if (length < r and qy > h) else 1.0
        cx, cy = qx - w, qy - h
        d_c = math.hypot(cx, cy)
        if h * qx - w * qy <= 0.0:
            d_arc = abs(length - r)
        else:
            d_arc = d_c
        d_chord = abs(qy - h) if qx < w else d_c
        if d_arc <= d_chord:
            if h * qx - w * qy <= 0.0:
                gx, gy = unit_or(qx, qy, 0.0, 1.0)
            else:
                gx, gy = unit_or(s * cx, s * cy, 0.0, -1.0)
            return s * d_arc, gx * sx, gy
        if qx < w:
            return s * d_chord, 0.0 * sx, -1.0
        gx, gy = unit_or(s * cx, s * cy, 0.0, -1.0)
        return s * d_chord, gx * sx, gy
    if op == HORSESHOE:
        return _horseshoe(consts, o, px, py)
    if op == VESICA:
        r, dc, hb = consts[o], consts[o + 1], consts[o + 2]
        sx, sy = _sign(px), _sign(py)
        qx, qy = abs(px), abs(py)
        rx, ry = qx + dc, qy + 0.0
        if rx * hb - ry * dc >= 0.0:
            gx, gy = unit_or(rx, ry, 1.0, 0.0)
            return math.hypot(rx, ry) - r, gx * sx, gy * sy
        cx, cy = qx - 0.0, qy - hb
        gx, gy = unit_or(cx, cy, 0.0, 1.0)
        return math.hypot(cx, cy), gx * sx, gy * sy
    if op == MOON:
        return _moon(consts, o, px, py)
    if op == EGG:
        r, apex, top = consts[o], consts[o + 1], consts[o + 3]
        sx = _sign(px)
        qx, qy = abs(px), py
        if qy < 0.0:
            gx, gy = unit_or(qx, qy, 0.0, -1.0)
            return math.hypot(qx, qy) - r - top, gx * sx, gy
        if consts[o + 4] * (qx + r) <= qy:              # nearest core point: the apex
            cx, cy = qx - 0.0, qy - apex
            gx, gy = unit_or(cx, cy, 0.0, 1.0)
            return math.hypot(cx, cy) - top, gx * sx, gy
        cx, cy = qx - (-r), qy - 0.0
        gx, gy = unit_or(cx, cy, 1.0, 0.0)
        return math.hypot(cx, cy) - consts[o + 2] - top, gx * sx, gy
    if op == HEART:
        return _heart(consts, o, px, py)
    if op == UNEVEN_CAPSULE:
        r1, r2, hh, s, c = consts[o], consts[o + 1], consts[o + 2], consts[o + 3], consts[o + 4]
        sx = _sign(px)
        qx, qy = abs(px), py
        k = -s * qx + c * qy
        if k < 0.0:
            gx, gy = unit_or(qx, qy, 0.0, -1.0)
            return math.hypot(qx, qy) - r1, gx * sx, gy
        if k > consts[o + 5]:
            tx, ty = qx - 0.0, qy - hh
            gx, gy = unit_or(tx, ty, 0.0, 1.0)
            return math.hypot(tx, ty) - r2, gx * sx, gy
        return c * qx + s * qy - r1, c * sx, s
    if op == STAR:
        return _star(consts, o, px, py)
    if op == ORIENTED_BOX:
        rx, ry = px - consts[o], py - consts[o + 1]
        ux, uy = consts[o + 2], consts[o + 3]
        v, lx, ly = _box(rx * ux + ry * uy, ry * ux - rx * uy, consts[o + 4], consts[o + 5])
        return v, lx * ux - ly * uy, lx * uy + ly * ux
    if op == RHOMBUS:
        bx, by = consts[o], consts[o + 1]
        qx, qy = abs(px), abs(py)
        dist, vx, vy, nx, ny, interior = _nearest(consts, o + 4, 1, qx, qy)
        inside = qx * by + qy * bx < consts[o + 2]
        d, gx, gy = _signed(dist, vx, vy, nx, ny, interior, inside, consts[o + 3])
        return d, gx * _sign(px), gy * _sign(py)
    if op == TRAPEZOID or op == SYM_TRIANGLE:
        qx, qy = abs(px), py
        m = a if op == TRAPEZOID else 2
        dist, vx, vy, nx, ny, interior = _nearest(consts, o + 6, m, qx, qy)
        y0 = consts[o]
        inner = abs(qy) < y0 if op == TRAPEZOID else qy > y0
        inside = inner and ((qx - consts[o + 2]) * consts[o + 4]
                            + (qy - consts[o + 3]) * consts[o + 5] < 0.0)
        d, gx, gy = _signed(dist, vx, vy, nx, ny, interior, inside, consts[o + 1])
        return d, gx * _sign(px), gy
    if op == CONVEX:
        dist, vx, vy, nx, ny, interior = _nearest(consts, o + 1, a, px, py)
        inside = True
        for i in range(a):
            j = o + 1 + _EDGE * i
            if not ((px - consts[j]) * consts[j + 5] + (py - consts[j + 1]) * consts[j + 6]
                    < 0.0):
                inside = False
        return _signed(dist, vx, vy, nx, ny, interior, inside, consts[o])
    if op == MIRRORED:
        return _mirrored(consts, o, a, b, px, py)
    if op == CROSS:
        sx, sy = _sign(px), _sign(py)
        qx, qy = abs(px), abs(py)
        swap = qy > qx
        if swap:
            qx, qy = qy, qx
        dist, vx, vy, nx, ny, interior = _nearest(consts, o + 4, a, qx, qy)
        inside = qx < consts[o] and qy < consts[o + 1]
        d, gx, gy = _signed(dist, vx, vy, nx, ny, interior, inside, consts[o + 3])
        if swap:
            gx, gy = gy, gx
        return d + consts[o + 2], gx * sx, gy * sy
    if op == ROUNDED_CROSS:
        h, k, radius = consts[o], consts[o + 1], consts[o + 2]
        sx, sy = _sign(px), _sign(py)
        qx, qy = abs(px) / radius, abs(py) / radius
        if qx < 1.0 and qy < qx * consts[o + 3] + h:     # the arc's wedge
            cx, cy = 1.0 - qx, k - qy
            n = math.hypot(cx, cy)
            if n > 1e-12:                               # polygonal._DEGENERATE
                gx, gy = cx / n, cy / n
            else:
                gx, gy = -1.0, 0.0
            return (k - n) * radius, gx * sx, gy * sy
        tx, ty = qx - 0.0, qy - h
        fx, fy = qx - 1.0, qy - 0.0
        if tx * tx + ty * ty <= fx * fx + fy * fy:
            wx, wy, fbx, fby = tx, ty, 0.0, 1.0
        else:
            wx, wy, fbx, fby = fx, fy, 1.0, 0.0
        n = math.hypot(wx, wy)
        if n > 1e-12:
            gx, gy = wx / n, wy / n
        else:
            gx, gy = fbx, fby
        return n * radius, gx * sx, gy * sy
    if op == GRID:
        return _grid(consts, o, a, b, px, py)
    return _bezier(consts, o, px, py)
