"""The smooth blends of compiled field programs (``compiled.run``'s smooth union,
intersection and difference), the kernels derived above ``operators._Smooth``.

Blend indices: 0 polynomial, 1 cubic, 2 circular, 3 exponential (the order of
``operators.BLENDS`` and ``opcodes.BLEND_INDEX``).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit

__all__ = ["EXP_SCALE", "smooth_min_arrays"]

#: The exponential kernel's s over k: s = k / (4 ln 2) makes its dip at a = b k / 4.
EXP_SCALE = 1.0 / (4.0 * math.log(2.0))


@njit(cache=True, error_model="numpy")
def _blend(gap: float, k: float, blend: int) -> tuple[float, float]:
    """Kernel ``blend`` at gap |a - b| (m), width k (m): (dip below min, weight of the
    larger operand)."""
    if blend == 0:
        h = 1.0 - min(gap / k, 1.0)
        return 0.25 * k * h * h, 0.5 * h
    if blend == 1:
        h = 1.0 - min(gap / k, 1.0)
        return k * h * h * h / 6.0, 0.5 * h * h
    if blend == 2:
        x = min(gap / k, 1.0)
        root = math.sqrt(2.0 - x * x)
        return 0.5 * k * (2.0 - x - root), 0.5 * (1.0 - x / root)
    s = k * EXP_SCALE
    e = math.exp(-gap / s)
    return s * math.log1p(e), e / (1.0 + e)


@njit(cache=True, error_model="numpy")
def _smooth_min(a: float, b: float, k: float, blend: int) -> tuple[float, float]:
    """Smooth minimum of a and b: (value, weight of b = d value / d b)."""
    dip, larger = _blend(abs(a - b), k, blend)
    return min(a, b) - dip, larger if b > a else 1.0 - larger


@njit(cache=True, error_model="numpy")
def smooth_min_arrays(a: np.ndarray, b: np.ndarray, k: float, blend: int, value: np.ndarray,
                      weight: np.ndarray) -> None:
    """``_smooth_min`` over arrays a, b (N,) into value, weight (N,) (``operators.smooth_min``)."""
    for i in range(len(a)):
        value[i], weight[i] = _smooth_min(a[i], b[i], k, blend)
