"""Primitives with curved boundaries (Quilez, "2D distance functions").

Each primitive is centred at its local origin as in Quilez's list. Gradients
are analytic (his ``sdg*`` forms where published, else derived from the
closest-point branch); see ``base.py`` for the conventions.

References: Inigo Quilez, https://iquilezles.org/articles/distfunctions2d/ and
https://iquilezles.org/articles/distgradfunctions2d/
"""

from __future__ import annotations

import numpy as np

from .base import REQUIRED, Field, Param, as_points, primitive, safe_normalize


@primitive("circle", Param("radius", "positive", REQUIRED, "radius, m"))
class Circle(Field):
    """Disk of ``radius`` centred at the origin: f = |p| - r, exact.

    Gradient p / |p|; at the centre the fallback direction (1, 0).
    """

    def __init__(self, radius: float):
        self.radius = float(radius)

    def evaluate(self, points):
        p = as_points(points)
        length = np.hypot(p[:, 0], p[:, 1])
        return length - self.radius, safe_normalize(p)

    def distance(self, points):
        p = as_points(points)
        return np.hypot(p[:, 0], p[:, 1]) - self.radius

    def bounds(self):
        r = self.radius
        return np.array([-r, -r, r, r])
