"""Primitives with straight edges (Quilez, "2D distance functions").

Each primitive is centred at its local origin as in Quilez's list. Gradients
are analytic (his ``sdg*`` forms where published, else derived from the
closest-point branch); see ``base.py`` for the conventions. Sizes given as
``size`` are full widths and heights; Quilez's half-extents are ``size / 2``.

References: Inigo Quilez, https://iquilezles.org/articles/distfunctions2d/ and
https://iquilezles.org/articles/distgradfunctions2d/
"""

from __future__ import annotations

import numpy as np

from .base import REQUIRED, Field, Param, as_points, primitive


@primitive("box", Param("size", "size2", REQUIRED, "full width and height [w, h], m"))
class Box(Field):
    """Axis-aligned box of full ``size`` [w, h] centred at the origin, exact.

    Quilez's sdgBox: with q = |p| - b (b the half-extents), outside the
    gradient is sign(p) * max(q, 0) / |max(q, 0)|, inside it is the axis of
    the nearest face (x wins a tie, so the medial axis is deterministic).
    """

    def __init__(self, size):
        self.half = np.array(size, dtype=np.float64) / 2.0

    def evaluate(self, points):
        p = as_points(points)
        w = np.abs(p) - self.half
        s = np.where(p < 0.0, -1.0, 1.0)
        outside = np.maximum(w, 0.0)
        out_len = np.hypot(outside[:, 0], outside[:, 1])
        inner = np.minimum(np.maximum(w[:, 0], w[:, 1]), 0.0)
        x_face = w[:, 0] >= w[:, 1]
        g_in = np.where(x_face[:, None], [1.0, 0.0], [0.0, 1.0])
        g_out = outside / np.where(out_len > 0.0, out_len, 1.0)[:, None]
        g = np.where((out_len > 0.0)[:, None], g_out, g_in) * s
        return out_len + inner, g

    def bounds(self):
        hx, hy = self.half
        return np.array([-hx, -hy, hx, hy])
