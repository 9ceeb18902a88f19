"""The smooth blends of compiled field programs (``compiled.run``'s smooth union,
intersection and difference): ``operators.BLENDS`` and ``operators.smooth_min``
operation for operation."""

from __future__ import annotations

import math

from .._jit import njit
from .opcodes import _EXP_SCALE

__all__: list[str] = []


@njit(cache=True, error_model="numpy")
def _blend(gap: float, k: float, blend: int) -> tuple[float, float]:
    """operators.BLENDS kernels: (dip below min, weight of the larger operand)."""
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
    s = k * _EXP_SCALE
    e = math.exp(-gap / s)
    return s * math.log1p(e), e / (1.0 + e)


@njit(cache=True, error_model="numpy")
def _smooth_min(a: float, b: float, k: float, blend: int) -> tuple[float, float]:
    """operators.smooth_min: (value, weight of b)."""
    dip, larger = _blend(abs(a - b), k, blend)
    return min(a, b) - dip, larger if b > a else 1.0 - larger
