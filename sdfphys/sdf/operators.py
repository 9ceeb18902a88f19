"""Operators on fields, each with its gradient and its exactness.

Placement (translate, rotate, uniform scale) keeps a field exact; Boolean
combinations are bounds in general (exact outside for a union, inside for an
intersection); see each operator's docstring. Reference: Quilez,
https://iquilezles.org/articles/distfunctions2d/ and
https://iquilezles.org/articles/smin/
"""

from __future__ import annotations

import math

import numpy as np

from .base import REQUIRED, Field, Param, as_points, operator


@operator("transform", Param("of", "field", REQUIRED), Param("offset", "vec2", (0.0, 0.0)),
          Param("angle", "real", 0.0))
class Transform(Field):
    """``of`` rotated by ``angle`` (radians, counter-clockwise) then moved by ``offset``.

    f(p) = g(R^T (p - t)); gradient R grad g. Exact when ``of`` is.
    """

    def __init__(self, of: Field, offset=(0.0, 0.0), angle: float = 0.0):
        self.of = of
        self.offset = np.array(offset, dtype=np.float64)
        self.angle = float(angle)
        self.exact = of.exact
        c, s = math.cos(self.angle), math.sin(self.angle)
        self.rotation = np.array([[c, -s], [s, c]])

    def evaluate(self, points):
        local = (as_points(points) - self.offset) @ self.rotation
        d, g = self.of.evaluate(local)
        return d, g @ self.rotation.T

    def distance(self, points):
        return self.of.distance((as_points(points) - self.offset) @ self.rotation)

    def bounds(self):
        x0, y0, x1, y1 = self.of.bounds()
        if not np.all(np.isfinite([x0, y0, x1, y1])):
            return np.array([-np.inf, -np.inf, np.inf, np.inf])
        corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) @ self.rotation.T
        lo = corners.min(axis=0) + self.offset
        hi = corners.max(axis=0) + self.offset
        return np.concatenate([lo, hi])
