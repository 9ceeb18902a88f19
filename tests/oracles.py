"""References for the compiled collision stages: fields that do not compile, numpy helpers.

The package runs a collision query through its compiled kernels when the fields compile
(``sdf.compiled.compile_field``) and through its numpy / Python-driven stages otherwise
(a user's own field class). ``Opaque(f)`` is ``f`` behind such a class: the same values,
gradients, bounds, spec and exactness, no program, so a query on it takes the numpy
stages; the tests compare the two paths on the same field bit for bit. ``opaque_shape``
does the same for a collision shape's field. ``enclosing_circles`` and ``merge_minima``
are numpy references of two compiled triangle helpers that need no field.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sdfphys.sdf import Field


class Opaque(Field):
    """``of`` behind a user class: ``compile_field`` knows no user classes."""

    def __init__(self, of: Field):
        self.of, self.exact, self.spec = of, of.exact, of.spec

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.of.evaluate(points)

    def distance(self, points: np.ndarray) -> np.ndarray:
        return self.of.distance(points)

    def bounds(self) -> np.ndarray:
        return self.of.bounds()


class _OpaqueShape:
    """A collision shape whose field is ``Opaque``; everything else is the shape's."""

    def __init__(self, shape: Any):
        self._shape, self._field = shape, Opaque(shape.field)

    @property
    def field(self) -> Opaque:
        return self._field

    def __getattr__(self, name: str) -> Any:
        return getattr(self._shape, name)


def opaque_shape(shape: Any) -> Any:
    """``shape`` with its field behind ``Opaque``: its queries take the numpy stages."""
    return _OpaqueShape(shape)


def enclosing_circles(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Minimal enclosing circles (centre (T, 2), radius (T,)) of triangles (T, 3, 2):
    the circle on the longest edge for an obtuse or right angle, else the circumcircle."""
    edge = np.roll(tri, -1, axis=1) - tri                          # edge k: v_k -> v_k+1
    length2 = edge[:, :, 0] * edge[:, :, 0] + edge[:, :, 1] * edge[:, :, 1]
    k = np.argmax(length2, axis=1)
    rows = np.arange(len(tri))
    a, b = tri[rows, k], tri[rows, (k + 1) % 3]
    c = tri[rows, (k + 2) % 3]                                     # opposite the longest edge
    ac, bc = a - c, b - c
    obtuse = ac[:, 0] * bc[:, 0] + ac[:, 1] * bc[:, 1] <= 0.0
    centre = 0.5 * (a + b)
    radius = 0.5 * np.sqrt(length2[rows, k])
    acute = ~obtuse
    p, r = ac[acute], bc[acute]
    det = 2.0 * (p[:, 0] * r[:, 1] - p[:, 1] * r[:, 0])
    pp = p[:, 0] * p[:, 0] + p[:, 1] * p[:, 1]
    rr = r[:, 0] * r[:, 0] + r[:, 1] * r[:, 1]
    off = np.stack([r[:, 1] * pp - p[:, 1] * rr, p[:, 0] * rr - r[:, 0] * pp], axis=1)
    off /= det[:, None]
    centre[acute] = c[acute] + off
    radius[acute] = np.hypot(off[:, 0], off[:, 1])
    return centre, radius


def merge_minima(point: np.ndarray, radius: float) -> np.ndarray:
    """(T, K) bool: False for a start that ended within ``radius`` of a start with a lower
    id of the same triangle; point (T, K, 2)."""
    gap = point[:, :, None, :] - point[:, None, :, :]             # (T, K, K, 2): k - j
    near = gap[..., 0] * gap[..., 0] + gap[..., 1] * gap[..., 1] < radius * radius
    earlier = np.tril(np.ones(near.shape[1:], dtype=bool), k=-1)   # j < k
    return ~np.any(near & earlier, axis=2)
