"""Forces, impulses and blasts on a world's bodies: what ``World.apply_force``,
``apply_torque``, ``apply_impulse`` and ``explode`` compute.

``targets`` checks their body indices and values (one value for every body, or one per
body), ``lever`` gives the torque of a vector applied at a world point, and ``explode``
finds the bodies a blast reaches and the impulse each gets (``World.explode``'s
docstring has the rule). Held forces and torques live in the body arrays ``force`` and
``torque`` until the step that uses them (``world_stages.accelerations``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import SpecError, check_number
from .limits import check_position
from .shapes import Shape
from .toi import _distance
from .vec2 import rotate
from .world_bodies import DYNAMIC

if TYPE_CHECKING:
    from .world import World

__all__ = ["explode", "lever", "targets"]


def targets(world: World, index: Any, vectors: Any, name: str,
            width: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """(bodies (N,), values (N, width) or (N,)): ``index`` an int or index array
    (negative counts from the end), ``vectors`` one value or one per body; checked
    (SpecError naming ``name``, IndexError for a bad index)."""
    idx = np.atleast_1d(np.asarray(index))          # Body handles: their __array__
    if idx.ndim != 1 or not (np.issubdtype(idx.dtype, np.integer) or len(idx) == 0):
        raise SpecError("i", f"must be a body index or an array of them, got {index!r}")
    idx = idx.astype(np.int64)
    if np.any((idx < -world._n) | (idx >= world._n)):
        bad = idx[(idx < -world._n) | (idx >= world._n)][0]
        raise IndexError(f"body index {bad} out of range ({world._n} bodies)")
    idx = idx % max(world._n, 1)
    try:
        values = np.asarray(vectors, dtype=np.float64)
    except (TypeError, ValueError):
        raise SpecError(name, f"must be numbers, got {vectors!r}") from None
    shape = (width,) if width > 1 else ()
    if values.shape not in (shape, (len(idx),) + shape):
        want = "(2,) or (N, 2)" if width > 1 else "a number or (N,)"
        raise SpecError(name, f"must be {want} for N = {len(idx)} bodies, "
                              f"got shape {values.shape}")
    if not np.all(np.isfinite(values)):
        raise SpecError(name, "must be finite")
    return idx, np.broadcast_to(values, (len(idx),) + shape)


def lever(world: World, idx: np.ndarray, vectors: np.ndarray, point: Any) -> np.ndarray:
    """(N,) the torque arm cross product (point - com) x vector, 0 without a point."""
    if point is None:
        return np.zeros(len(idx))
    _, p = targets(world, idx, point, "point")
    r = p - world._view("com")[idx]
    return r[:, 0] * vectors[:, 1] - r[:, 1] * vectors[:, 0]


def _width(shape: Shape, across: np.ndarray) -> np.ndarray:
    """(N,) m: ``shape``'s extent along the body-frame unit directions ``across`` (N, 2):
    2 r for a circle, the vertices' spread for a polygon, the body-frame bounding box's
    corners' spread otherwise."""
    if shape.kind == "circle":
        return np.full(len(across), 2.0 * shape.radius)
    points = getattr(shape, "vertices", None)
    if points is None:
        x0, y0, x1, y1 = shape.bounds()
        points = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    projection = across @ np.asarray(points, np.float64).T
    return projection.max(axis=1) - projection.min(axis=1)


def explode(world: World, center: Any, radius: float, impulse: float) -> np.ndarray:
    """``World.explode`` (its docstring): the indices (K,) of the bodies pushed, after
    ``world.apply_impulse`` gave each its impulse at its surface point nearest
    ``center``."""
    c = np.array(check_position(center, "center"))
    radius = check_number(radius, "radius", low=0.0, low_open=True)
    impulse = check_number(impulse, "impulse", low=0.0)
    body = np.flatnonzero(world._view("kind") == DYNAMIC)
    if len(body) == 0:
        return body
    com, angle = world._view("com"), world._view("angle")
    shape_id = world._view("shape_id")
    d, g = _distance([shape.field for shape in world._shapes], shape_id, com, angle, body,
                     np.broadcast_to(c, (len(body), 2)), gradient=True)
    near = d < radius
    body, d, g = body[near], d[near], g[near]
    inside = d <= 0.0
    point = np.where(inside[:, None], com[body], c - d[:, None] * g)
    away = point - c
    length = np.hypot(away[:, 0], away[:, 1])
    away = np.where(length[:, None] > 0.0, away / np.where(length > 0.0, length, 1.0)[:, None],
                    np.array([1.0, 0.0]))
    # Width across the blast: the body's extent along the perpendicular, in its frame.
    across = rotate(np.column_stack([-away[:, 1], away[:, 0]]), -angle[body])
    width = np.empty(len(body))
    for sid in np.unique(shape_id[body]):
        rows = np.flatnonzero(shape_id[body] == sid)
        width[rows] = _width(world._shapes[sid], across[rows])
    world.apply_impulse(body, (impulse * width)[:, None] * away, point)
    return body
