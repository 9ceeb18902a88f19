"""numpy evaluation of the operators of ``sdfphys.sdf.operators``: a test oracle.

The vectorized numpy code the operators had before the compiled program
(``sdfphys.sdf.compiled``) became their one implementation; tests compare the two.
Operands are evaluated by this package's oracle too (``numpy_fields.evaluate``). The
blend kernels follow the derivation above ``operators.BLENDS``.
"""

from __future__ import annotations

import math

import numpy as np

from sdfphys.sdf.base import as_points
from sdfphys.sdf.operators import Difference, Union

_EXP_SCALE = 1.0 / (4.0 * math.log(2.0))


def _operand(f, points):
    from . import evaluate  # the package's dispatcher imports this module
    return evaluate(f, points)


def _polynomial(gap: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray]:
    h = 1.0 - np.minimum(gap / k, 1.0)
    return 0.25 * k * h * h, 0.5 * h


def _cubic(gap: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray]:
    h = 1.0 - np.minimum(gap / k, 1.0)
    return k * h * h * h / 6.0, 0.5 * h * h


def _circular(gap: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray]:
    x = np.minimum(gap / k, 1.0)
    root = np.sqrt(2.0 - x * x)
    return 0.5 * k * (2.0 - x - root), 0.5 * (1.0 - x / root)


def _exponential(gap: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray]:
    s = k * _EXP_SCALE
    e = np.exp(-gap / s)
    return s * np.log1p(e), e / (1.0 + e)


#: blend name -> kernel: (|a - b|, k) -> (dip below min, weight m of the larger operand).
KERNELS = {"polynomial": _polynomial, "cubic": _cubic, "circular": _circular,
           "exponential": _exponential}


def smooth_min(a: np.ndarray, b: np.ndarray, k: float,
               blend: str) -> tuple[np.ndarray, np.ndarray]:
    """Smooth minimum of ``a`` and ``b`` (N,): (value, weight of b), as
    ``operators.smooth_min``."""
    dip, larger = KERNELS[blend](np.abs(a - b), k)
    return np.minimum(a, b) - dip, np.where(b > a, larger, 1.0 - larger)


def Transform_evaluate(field, points):
    d, g = _operand(field.of, Transform__to_local(field, points))
    return d, Transform__to_outer(field, g)


def Transform__to_local(field, points) -> np.ndarray:
    """R^T (p - t) for points (N, 2)."""
    p = as_points(points) - field.offset
    (c, ms), (s, _) = field.rotation
    return np.stack([c * p[:, 0] + s * p[:, 1], ms * p[:, 0] + c * p[:, 1]], axis=1)


def Transform__to_outer(field, v: np.ndarray) -> np.ndarray:
    """R v for vectors (N, 2)."""
    (c, ms), (s, _) = field.rotation
    return np.stack([c * v[:, 0] + ms * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)


def Scale_evaluate(field, points):
    d, g = _operand(field.of, as_points(points) / field.factor)
    return field.factor * d, g


def _Select_evaluate(field, points):
    p = as_points(points)
    values, grads = zip(*(_operand(f, p) for f in field.of))
    signs = np.ones(len(field.of))
    if isinstance(field, Difference):
        signs[1:] = -1.0
    d = np.array(values) * signs[:, None]
    g = np.array(grads) * signs[:, None, None]
    pick = (np.argmin if isinstance(field, Union) else np.argmax)(d, axis=0)
    rows = np.arange(p.shape[0])
    return d[pick, rows], g[pick, rows]


def Xor_evaluate(field, points):
    p = as_points(points)
    d, g = _operand(field.of[0], p)
    for f in field.of[1:]:
        b, gb = _operand(f, p)
        low, high = np.minimum(d, b), np.maximum(d, b)
        g_low = np.where((d <= b)[:, None], g, gb)
        g_high = np.where((d >= b)[:, None], g, gb)
        d = np.maximum(low, -high)
        g = np.where((low >= -high)[:, None], g_low, -g_high)
    return d, g


def SmoothUnion_evaluate(field, points):
    p = as_points(points)
    d, g = _operand(field.of[0], p)
    for f in field.of[1:]:
        b, gb = _operand(f, p)
        d, w = smooth_min(d, b, field.k, field.blend)
        g = (1.0 - w)[:, None] * g + w[:, None] * gb
    return d, g


def SmoothIntersection_evaluate(field, points):
    p = as_points(points)
    d, g = _operand(field.of[0], p)
    for f in field.of[1:]:
        b, gb = _operand(f, p)
        d, w = smooth_min(-d, -b, field.k, field.blend)
        d = -d
        g = (1.0 - w)[:, None] * g + w[:, None] * gb
    return d, g


def SmoothDifference_evaluate(field, points):
    p = as_points(points)
    d, g = _operand(field.of[0], p)
    for f in field.of[1:]:
        b, gb = _operand(f, p)
        d, w = smooth_min(-d, b, field.k, field.blend)
        d = -d
        g = (1.0 - w)[:, None] * g - w[:, None] * gb
    return d, g


def Round_evaluate(field, points):
    d, g = _operand(field.of, as_points(points))
    return d - field.r, g


def Onion_evaluate(field, points):
    d, g = _operand(field.of, as_points(points))
    sign = np.where(d < 0.0, -1.0, 1.0)
    return np.abs(d) - field.thickness, sign[:, None] * g
