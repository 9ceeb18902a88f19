"""The quadratic Bezier's exact distance for compiled field programs (``primitive_kernels._shape``).

``conics.QuadraticBezier``'s field: the nearest point's parameter is a root of a cubic
(Cardano or Viete), each candidate polished by guarded Newton steps, then the ends.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..vec2 import unit_or

__all__: list[str] = []


@njit(cache=True, error_model="numpy")
def _clip(x: float, lo: float, hi: float) -> float:
    """np.clip for one value (NaN stays NaN)."""
    if math.isnan(x):
        return x
    return min(max(x, lo), hi)


@njit(cache=True, error_model="numpy")
def _polish(t: float, k3: float, k2: float, k1: float, k0: float) -> float:
    """QuadraticBezier's seed clipping and _POLISH guarded Newton steps on the cubic."""
    t = _clip(t if math.isfinite(t) else 0.5, 0.0, 1.0)
    g = ((k3 * t + k2) * t + k1) * t + k0
    for _ in range(3):                                  # QuadraticBezier._POLISH
        dg = (3.0 * k3 * t + 2.0 * k2) * t + k1
        step = g / dg if dg != 0.0 else 0.0
        t_new = _clip(t - step, 0.0, 1.0)
        g_new = ((k3 * t_new + k2) * t_new + k1) * t_new + k0
        if abs(g_new) < abs(g):
            t, g = t_new, g_new
    return t


@njit(cache=True, error_model="numpy")
def _bezier(consts: np.ndarray, o: int, px: float, py: float) -> tuple[float, float, float]:
    """conics.QuadraticBezier: candidates (Cardano / Viete roots, the linear
    root, polished; the ends), the nearest wins (the first of a tie)."""
    ax, ay, cax, cay, cbx, cby = (consts[o], consts[o + 1], consts[o + 2], consts[o + 3],
                                  consts[o + 4], consts[o + 5])
    k3, k2, aa2 = consts[o + 6], consts[o + 7], consts[o + 8]
    apx, apy = ax - px, ay - py
    k1 = aa2 + (apx * cbx + apy * cby)
    k0 = apx * cax + apy * cay
    lin = -k0 / k1 if k1 != 0.0 else 0.0
    best, tb = np.inf, 0.0
    for c in range(6):
        if c < 3:
            if consts[o + 11] == 0.0:
                continue
            # _cubic_roots, root c (all three computed alike per point).
            a2, a1, a0 = k2 / k3, k1 / k3, k0 / k3
            shift = a2 / 3.0
            big_p = a1 - a2 * shift
            big_q = (2.0 * a2 * a2 / 27.0 - a1 / 3.0) * a2 + a0
            hq = big_q / 2.0
            h = hq * hq + math.pow(big_p / 3.0, 3.0)
            if h >= 0.0:
                w = np.cbrt(-big_q / 2.0 - math.copysign(math.sqrt(h), big_q))
                seed = (w - big_p / (3.0 * w) if w != 0.0 else 0.0) - shift
            else:
                m = math.sqrt(max(-big_p / 3.0, 0.0))
                cos3 = _clip(-big_q / 2.0 / math.pow(m, 3.0), -1.0, 1.0)
                phi = math.acos(cos3) / 3.0
                seed = 2.0 * m * math.cos(phi - 2.0 * math.pi * c / 3.0) - shift
            t = _polish(seed, k3, k2, k1, k0)
        elif c == 3:
            t = _polish(lin, k3, k2, k1, k0)
        else:
            t = float(c - 4)
        dx = ax + 2.0 * t * cax + t * t * cbx - px
        dy = ay + 2.0 * t * cay + t * t * cby - py
        d = math.sqrt(dx * dx + dy * dy)
        if d < best:
            best, tb = d, t
    cx = ax + 2.0 * tb * cax + tb * tb * cbx
    cy = ay + 2.0 * tb * cay + tb * tb * cby
    rx, ry = px - cx, py - cy
    tx, ty = cax + tb * cbx, cay + tb * cby
    lx, ly = -ty, tx
    fx, fy = unit_or(rx, ry, 1.0, 0.0)
    nx, ny = unit_or(lx, ly, fx, fy)
    near = best * consts[o + 10] < 2.0 * math.pow(math.hypot(tx, ty), 3.0)
    if tb > 0.0 and tb < 1.0 and near:
        if rx * lx + ry * ly < 0.0:
            return best - consts[o + 9], -nx, -ny
        return best - consts[o + 9], nx, ny
    gx, gy = unit_or(rx, ry, nx, ny)
    return best - consts[o + 9], gx, gy
