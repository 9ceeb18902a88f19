"""numpy evaluation of the fields of ``sdfphys.sdf.folded``: a test oracle.

The vectorized numpy code these primitives had before their compiled kernels became
their one implementation (``sdfphys.sdf.compiled``); tests compare the two."""

from __future__ import annotations

import numpy as np

from sdfphys.sdf.base import as_points
from sdfphys.sdf.polygonal import _DEGENERATE
from sdfphys.vec2 import rows_dot, rows_unit_or

from .polygonal import _nearest, _reflect, _sign, _signed, _unreflect


def _MirrorFolded_evaluate(field, points):
    p = as_points(points)
    s = _sign(p)
    if not field._abs_y:
        s[:, 1] = 1.0
    q = p * s
    moved = []
    for n in field._mirrors:
        q, m = _reflect(q, n)
        moved.append(m)
    dist, v, n, interior = _nearest(q, field._edge)
    d, g = _signed(dist, v, n, interior, q[:, 1] < field.radius, field._eps)
    for n, m in zip(reversed(field._mirrors), reversed(moved)):
        g = _unreflect(g, n, m)
    return d, g * s


def Star_evaluate(field, points):
    p = as_points(points)
    x, y = np.abs(p[:, 0]), p[:, 1]
    theta = np.arctan2(x, y)
    bn = np.mod(theta, 2.0 * field._an) - field._an
    q_hat = np.stack([np.cos(bn), np.abs(np.sin(bn))], axis=1)
    q = np.hypot(x, y)[:, None] * q_hat
    dist, v, n, interior = _nearest(q, field._edge)
    edge = field._edge[0]
    inside = rows_dot(q - edge.b, edge.normal) < 0.0
    d, gq = _signed(dist, v, n, interior, inside, field._eps)
    g_r = gq[:, 0] * q_hat[:, 0] + gq[:, 1] * q_hat[:, 1]
    g_t = np.where(bn >= 0.0, -1.0, 1.0) * (gq[:, 1] * q_hat[:, 0] - gq[:, 0] * q_hat[:, 1])
    st, ct = np.sin(theta), np.cos(theta)
    g = np.stack([(g_r * st - g_t * ct) * _sign(p[:, 0]), g_r * ct + g_t * st], axis=1)
    return d, g


def Cross_evaluate(field, points):
    p = as_points(points)
    s = _sign(p)
    q = np.abs(p)
    swap = (q[:, 1] > q[:, 0])[:, None]
    q = np.where(swap, q[:, ::-1], q)
    dist, v, n, interior = _nearest(q, field._edges)
    inside = (q[:, 0] < field.half[0]) & (q[:, 1] < field.half[1])
    d, g = _signed(dist, v, n, interior, inside, field._eps)
    return d + field.rounding, np.where(swap, g[:, ::-1], g) * s


def RoundedCross_evaluate(field, points):
    p = as_points(points)
    s = _sign(p)
    q = np.abs(p) / field.radius
    h, k = field.h, field._k
    wedge = (q[:, 0] < 1.0) & (q[:, 1] < q[:, 0] * (k - h) + h)
    to_centre = np.array([1.0, k]) - q
    d_arc = k - np.hypot(to_centre[:, 0], to_centre[:, 1])
    g_arc = rows_unit_or(to_centre, np.array([-1.0, 0.0]), _DEGENERATE)
    from_top = q - np.array([0.0, h])
    from_side = q - np.array([1.0, 0.0])
    top = rows_dot(from_top, from_top) <= rows_dot(from_side, from_side)
    w = np.where(top[:, None], from_top, from_side)
    d_tip = np.hypot(w[:, 0], w[:, 1])
    g_tip = rows_unit_or(w, np.where(top[:, None], [0.0, 1.0], [1.0, 0.0]), _DEGENERATE)
    d = np.where(wedge, d_arc, d_tip) * field.radius
    return d, np.where(wedge[:, None], g_arc, g_tip) * s
