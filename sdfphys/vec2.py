"""Small 2D vector helpers shared by the package: rows of numpy arrays, compiled scalars.

Row helpers write their products out (v_x c - v_y s, a_x b_x + a_y b_y) rather than
calling ``np.matmul`` or ``@``: BLAS may fuse or reorder the multiply-adds depending
on a row's place in the batch, and a field or a contact must give a point the same
bits alone or among others; the compiled kernels compute the same expressions.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import njit

__all__ = ["TINY", "rotate", "rotate_cs", "rows_dot", "rows_unit_or", "unit_or"]

#: Vectors not longer than this have no direction (they take a fallback when normalized).
TINY = 1e-300


def rotate(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rows of ``v`` (N, 2) rotated counter-clockwise by ``angle`` (N,) rad."""
    return rotate_cs(v, np.cos(angle), np.sin(angle))


def rotate_cs(v: np.ndarray, cos: np.ndarray, sin: np.ndarray) -> np.ndarray:
    """Rows of ``v`` (N, 2) rotated counter-clockwise by the angles of ``cos``, ``sin`` (N,)."""
    x, y = v[:, 0], v[:, 1]
    out = np.empty((len(v), 2))
    out[:, 0] = cos * x - sin * y
    out[:, 1] = sin * x + cos * y
    return out


def rows_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of (N, 2) arrays (either may be a broadcast (2,))."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]


def rows_unit_or(v: np.ndarray, fallback: np.ndarray, eps: float = TINY) -> np.ndarray:
    """Rows of ``v`` (N, 2) scaled to unit length; rows not longer than ``eps`` take the
    matching row of ``fallback`` ((N, 2) or (2,))."""
    n = np.hypot(v[:, 0], v[:, 1])
    ok = n > eps
    return np.where(ok[:, None], v / np.where(ok, n, 1.0)[:, None], fallback)


@njit(cache=True, error_model="numpy")
def unit_or(x: float, y: float, fx: float, fy: float) -> tuple[float, float]:
    """(x, y) / |(x, y)|, or the fallback (fx, fy) when |(x, y)| <= TINY (compiled)."""
    length = math.hypot(x, y)
    if length > TINY:
        return x / length, y / length
    return fx, fy
