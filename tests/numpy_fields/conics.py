"""numpy evaluation of the fields of ``sdfphys.sdf.conics``: a test oracle.

The vectorized numpy code these primitives had before their compiled kernels became
their one implementation (``sdfphys.sdf.compiled``); tests compare the two."""

from __future__ import annotations

import math

import numpy as np

from sdfphys.sdf.base import as_points
from sdfphys.sdf.ellipse_kernel import _BISECTIONS, _FAST_NEWTON, _NEWTON, _SETTLED
from sdfphys.vec2 import rows_dot, rows_unit_or

from .curved import _DOWN, _LEFT, _RIGHT, _UP, _fold_x, _norm, _pick, _unfold


def _cubic_roots(k3: np.ndarray, k2: np.ndarray, k1: np.ndarray, k0: np.ndarray
                 ) -> np.ndarray:
    """Approximate real roots (N, 3) of k3 t^3 + k2 t^2 + k1 t + k0 with k3 > 0.

    Depressed cubic s^3 + P s + Q (t = s - k2 / (3 k3)). One real root when
    h = (Q/2)^2 + (P/3)^3 >= 0 (Cardano, with the cube root taken on the side
    that avoids cancellation; repeated three times), else three (Viète's
    trigonometric form). Callers polish the roots and replace non-finite values.
    """
    a2, a1, a0 = k2 / k3, k1 / k3, k0 / k3
    shift = a2 / 3.0
    big_p = a1 - a2 * shift
    big_q = (2.0 * a2 * a2 / 27.0 - a1 / 3.0) * a2 + a0
    h = (big_q / 2.0) ** 2 + (big_p / 3.0) ** 3
    one = h >= 0.0
    w = np.cbrt(-big_q / 2.0 - np.copysign(np.sqrt(np.where(one, h, 0.0)), big_q))
    single = np.where(w != 0.0, w - big_p / (3.0 * np.where(w != 0.0, w, 1.0)), 0.0)
    m = np.sqrt(np.maximum(-big_p / 3.0, 0.0))
    cos3 = np.clip(-big_q / 2.0 / np.where(one, 1.0, m ** 3), -1.0, 1.0)
    phi = np.arccos(cos3) / 3.0
    three = [2.0 * m * np.cos(phi - 2.0 * math.pi * k / 3.0) for k in range(3)]
    return np.column_stack([np.where(one, single, r) for r in three]) - shift[:, None]


def Vesica_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p = as_points(points)
    sx = np.where(p[:, 0] < 0.0, -1.0, 1.0)
    sy = np.where(p[:, 1] < 0.0, -1.0, 1.0)
    q = np.abs(p)
    r, dc, b = field.radius, field.centre_distance, field.half_height
    # In the quadrant x, y >= 0 the boundary is the arc of the circle centred
    # at (-dc, 0) from (r - dc, 0) to the corner (0, b); the radial projection
    # is on it iff q is not above the ray from (-dc, 0) through the corner.
    rel = q + np.array([dc, 0.0])
    on_arc = rel[:, 0] * b - rel[:, 1] * dc >= 0.0
    rel_c = q - np.array([0.0, b])
    d = np.where(on_arc, _norm(rel) - r, _norm(rel_c))
    g = _pick(on_arc, rows_unit_or(rel, _RIGHT), rows_unit_or(rel_c, _UP))
    return d, _unfold(g, sx, sy)


def Moon_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p = as_points(points)
    sy = np.where(p[:, 1] < 0.0, -1.0, 1.0)
    q = np.column_stack([p[:, 0], np.abs(p[:, 1])])
    ra, rb, dc = field.radius, field.bite_radius, field.centre_distance
    ka, kb = field.horn
    length = _norm(q)
    v = q - np.array([dc, 0.0])
    lv = _norm(v)
    s = np.where((length < ra) & (lv > rb), -1.0, 1.0)
    rel_k = q - field.horn
    d_k = _norm(rel_k)
    g_k = rows_unit_or(s[:, None] * rel_k, field.horn / ra)
    # With y folded to |y| the outer arc runs from the horn to (-ra, 0) and the
    # bitten arc from the horn to (dc - rb, 0); a radial projection lands on an
    # arc iff the direction is past the horn's: cross(horn direction, q) >= 0.
    on_a = ka * q[:, 1] - kb * q[:, 0] >= 0.0
    on_b = (ka - dc) * v[:, 1] - kb * v[:, 0] >= 0.0
    d_a = np.where(on_a, np.abs(length - ra), d_k)
    d_b = np.where(on_b, np.abs(lv - rb), d_k)
    g_a = _pick(on_a, rows_unit_or(q, _LEFT), g_k)
    g_b = _pick(on_b, rows_unit_or(-v, _RIGHT), g_k)
    outer = d_a <= d_b
    d = s * np.where(outer, d_a, d_b)
    return d, _unfold(_pick(outer, g_a, g_b), 1.0, sy)


def Egg_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q, sx = _fold_x(as_points(points))
    r = field.core
    apex = np.array([0.0, math.sqrt(3.0) * r])
    side_centre = np.array([-r, 0.0])
    lower = q[:, 1] < 0.0
    # Above the line from (-r, 0) through the apex the nearest core point is the apex.
    above = math.sqrt(3.0) * (q[:, 0] + r) <= q[:, 1]
    d = np.where(lower, _norm(q) - r,
                 np.where(above, _norm(q - apex), _norm(q - side_centre) - 2.0 * r))
    g = _pick(lower, rows_unit_or(q, _DOWN),
              _pick(above, rows_unit_or(q - apex, _UP), rows_unit_or(q - side_centre, _RIGHT)))
    return d - field.top_radius, _unfold(g, sx)


def Heart_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q, sx = _fold_x(as_points(points) / field.scale)
    lobe = q[:, 0] + q[:, 1] > 1.0
    rel_l = q - field._LOBE_CENTRE
    d_lobe = _norm(rel_l) - field._LOBE_RADIUS
    g_lobe = rows_unit_or(rel_l, _UP)
    # Below the line x + y = 1: the segment from the tip along (1, 1) (its
    # projection t stays <= 0.5 there) or the cusp; inside iff x < y.
    s = np.where(q[:, 0] > q[:, 1], 1.0, -1.0)
    t = np.maximum(q[:, 0] + q[:, 1], 0.0) / 2.0
    rel_s = q - t[:, None]
    d_seg = _norm(rel_s)
    g_seg = _pick(t > 0.0, field._EDGE_NORMAL,
                  rows_unit_or(s[:, None] * rel_s, field._EDGE_NORMAL))
    rel_k = q - field._CUSP
    d_cusp = _norm(rel_k)
    g_cusp = rows_unit_or(s[:, None] * rel_k, _UP)
    seg = d_seg <= d_cusp
    d_low = s * np.where(seg, d_seg, d_cusp)
    g_low = _pick(seg, g_seg, g_cusp)
    d = np.where(lobe, d_lobe, d_low) * field.scale
    return d, _unfold(_pick(lobe, g_lobe, g_low), sx)


def Ellipse_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p = as_points(points)
    if field.swap:
        p = p[:, ::-1]
    sx = np.where(p[:, 0] < 0.0, -1.0, 1.0)
    sy = np.where(p[:, 1] < 0.0, -1.0, 1.0)
    x, y = np.abs(p[:, 0]), np.abs(p[:, 1])
    a, b = field.a, field.b
    e = a * a - b * b
    big_a, big_b = a * x, b * y
    general = big_b > 0.0
    # Dummy bracket [1, 1] on the axis rows keeps every division finite.
    lo = np.where(general, np.maximum(big_b, big_a - e), 1.0)
    hi = np.where(general, np.hypot(big_a, big_b), 1.0)
    big_b = np.where(general, big_b, 1.0)
    u = previous = lo
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        for _ in range(_FAST_NEWTON):         # NaN where it overflows: slow
            previous, u = u, Ellipse__newton(big_a, big_b, e, u)
    slow = ~(np.abs(u - previous) <= _SETTLED * u)
    if np.any(slow):
        lo, hi, fa, fb = lo[slow], hi[slow], big_a[slow], big_b[slow]
        for _ in range(_BISECTIONS):
            mid = np.sqrt(lo) * np.sqrt(hi)
            f = (fa / (mid + e)) ** 2 + (fb / mid) ** 2 - 1.0
            lo, hi = np.where(f >= 0.0, mid, lo), np.where(f >= 0.0, hi, mid)
        # A far point's squared terms may overflow, as the same IEEE operations of the
        # kernel (sdfphys/sdf/ellipse_kernel.py) do: the test compares the two results.
        with np.errstate(over="ignore"):
            for _ in range(_NEWTON):
                fx, fy = fa / (lo + e), fb / lo
                n = np.hypot(fx, fy)
                slope = fx * fx / (lo + e) + fy * fy / lo
                lo = lo + n * n * (n - 1.0) / slope
        u = u.copy()
        u[slow] = lo
    xc = np.where(general, a * big_a / (u + e), 0.0)
    yc = np.where(general, b * big_b / u, 0.0)
    interior = big_a < e
    x_axis = np.where(interior, a * big_a / (e if e > 0.0 else 1.0), a)
    y_axis = np.where(interior, b * np.sqrt(np.maximum(1.0 - (x_axis / a) ** 2, 0.0)), 0.0)
    xc, yc = np.where(general, xc, x_axis), np.where(general, yc, y_axis)
    dist = np.hypot(x - xc, y - yc)
    inside = (x / a) ** 2 + (y / b) ** 2 < 1.0
    g = rows_unit_or(np.column_stack([xc / (a * a), yc / (b * b)]), _RIGHT)
    g = _unfold(g, sx, sy)
    if field.swap:
        g = g[:, ::-1]
    return np.where(inside, -dist, dist), g


def Ellipse__newton(big_a: np.ndarray, big_b: np.ndarray, e: float, u: np.ndarray) -> np.ndarray:
    """One Newton step on psi(u) = 1 / |(A / (u + e), B / u)| - 1 (above): with
    F = (f_x, f_y) = (A / (u + e), B / u), u + |F|^2 (|F| - 1) / (f_x^2 / (u + e)
    + f_y^2 / u), in two divisions and a square root. The bracketed solver's steps
    divide and take hypot instead: near the largest doubles 1 / (u + e) is
    subnormal (a NaN here, so such a point does not settle and goes there)."""
    inner, outer = 1.0 / (u + e), 1.0 / u
    fx, fy = big_a * inner, big_b * outer
    square = fx * fx + fy * fy
    slope = fx * fx * inner + fy * fy * outer
    return u + square * (np.sqrt(square) - 1.0) / slope


def QuadraticBezier_evaluate(field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p = as_points(points)
    n = len(p)
    A, B = field.A, field.B
    ap = field.a - p
    k3 = np.full(n, B @ B)
    k2 = np.full(n, 3.0 * (A @ B))
    k1 = 2.0 * (A @ A) + rows_dot(ap, B)
    k0 = rows_dot(ap, A)
    lin = np.where(k1 != 0.0, -k0 / np.where(k1 != 0.0, k1, 1.0), 0.0)[:, None]
    if field.cubic:
        with np.errstate(over="ignore", invalid="ignore"):
            seeds = np.concatenate([_cubic_roots(k3, k2, k1, k0), lin], axis=1)
    else:
        seeds = lin
    t = np.clip(np.where(np.isfinite(seeds), seeds, 0.5), 0.0, 1.0)
    k3, k2, k1, k0 = k3[:, None], k2[:, None], k1[:, None], k0[:, None]
    g = ((k3 * t + k2) * t + k1) * t + k0
    for _ in range(field._POLISH):
        dg = (3.0 * k3 * t + 2.0 * k2) * t + k1
        step = np.where(dg != 0.0, g / np.where(dg != 0.0, dg, 1.0), 0.0)
        t_new = np.clip(t - step, 0.0, 1.0)
        g_new = ((k3 * t_new + k2) * t_new + k1) * t_new + k0
        better = np.abs(g_new) < np.abs(g)
        t, g = np.where(better, t_new, t), np.where(better, g_new, g)
    t = np.concatenate([t, np.zeros((n, 1)), np.ones((n, 1))], axis=1)
    dist = np.linalg.norm(field._curve(t) - p[:, None, :], axis=2)
    best = np.argmin(dist, axis=1)
    rows = np.arange(n)
    t, dist = t[rows, best], dist[rows, best]
    # Gradient: at an interior t it is the curve's normal on p's side; an error e
    # in t turns the normal by e |q'| / rho but the direction p - q only by
    # e |q'| / |p - q|, so the normal is used within the local radius of
    # curvature rho(t) = 2 |A + t B|^3 / |A x B| (always on the curve itself)
    # and p - q beyond it (near a sharp turn).
    rel = p - field._curve(t)
    tangent = A + t[:, None] * B
    left = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    normal = rows_unit_or(left, rows_unit_or(rel, _RIGHT))
    side = np.where(rows_dot(rel, left) < 0.0, -1.0, 1.0)
    near = dist * field.cross < 2.0 * _norm(tangent) ** 3
    interior = (t > 0.0) & (t < 1.0) & near
    g = _pick(interior, side[:, None] * normal, rows_unit_or(rel, normal))
    return dist - field.radius, g
