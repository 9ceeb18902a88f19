"""Collision shapes: what a body is made of, in its own frame.

Every shape lives in its BODY frame, whose origin is the shape's centre of mass and
whose axes are the user's (no rotation). Each knows:

- ``kind``: ``"circle"`` (analytic), ``"mesh"`` (triangulated polygon: box or
  polygon) or ``"sdf"`` (any signed distance field); the narrowphase dispatches
  on the pair of kinds;
- ``field``: its signed distance field in the body frame (metres, < 0 inside);
- ``origin`` (2,): where the user's frame origin (a scene body's ``position``)
  sits in the body frame, i.e. minus the centroid in user coordinates. A body at
  user pose (p, a) has its centre of mass at ``p - R(a) origin``;
- ``radius``: bounding radius about the centre of mass (inf for unbounded fields);
- ``bounds()``: body-frame AABB ``[xmin, ymin, xmax, ymax]`` (infinite entries
  for unbounded fields);
- ``area`` (m^2) and ``second_moment`` (polar, about the centre of mass, m^4), per
  unit density: mass = density area, inertia = density second_moment;
- ``spec``: the canonical scene shape dict (``{"type": "circle", "radius": 0.5}``).

``shape_from_spec`` validates a scene shape dict and returns a cached Shape, so
that equal specs share one object: the narrowphase batches all pairs of the same
two Shape objects into one field evaluation (instancing).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from functools import cached_property
from typing import Any

import numpy as np

from .errors import SpecError, check_number, check_points, check_vec2
from .geometry import field_mass_properties, polygon_mass_properties, triangulate, validate_polygon
from .limits import MAX_SIZE, MIN_SIZE
from .sdf import Field, field
from .sdf.build import suggest
from .sdf.gradient import NumericGradientField
from .sdf.grid import GridField

__all__ = ["SHAPE_TYPES", "Circle", "SdfShape", "Shape", "TriangleMesh", "collision_shape",
           "shape_from_spec"]

#: Accepted shape types and their keys (besides ``type``).
SHAPE_TYPES: dict[str, tuple[str, ...]] = {
    "circle": ("radius",),
    "box": ("size",),
    "polygon": ("points",),
    "sdf": ("field", "cell"),
}

#: SdfShape's default quadrature cell is sqrt(area) / SDF_CELLS_PER_ROOT_AREA, the area
#: coming from a coarse first pass (cell = smaller side of the bounds / 20).
#: geometry.field_mass_properties bounds its relative errors by 1.0 (h / sqrt(area))^2
#: for the area and 2 (h / sqrt(area))^2 for the second moment (measured on discs,
#: boxes and L shapes), so 150 keeps both under 9e-5 (target 1e-4); a disc then
#: costs ~3e4 field evaluations.
SDF_CELLS_PER_ROOT_AREA = 150
#: Upper bound on the default quadrature grid (points), which coarsens the cell of
#: very thin or hollow shapes (whose accuracy is then below the target).
SDF_MAX_GRID_POINTS = 4_000_000


class Shape:
    """Base of the collision shapes (see the module docstring for the attributes)."""

    kind: str = ""
    spec: dict
    #: Whether the region f <= 0 is bounded (known without the mass properties).
    bounded: bool = True

    @property
    def field(self) -> Field:
        """Signed distance field (metres, < 0 inside) in the body frame."""
        raise NotImplementedError

    @property
    def origin(self) -> np.ndarray:
        """(2,) position of the user frame's origin in the body frame, metres."""
        raise NotImplementedError

    @property
    def radius(self) -> float:
        """Bounding radius about the centre of mass, metres (inf if unbounded)."""
        raise NotImplementedError

    @property
    def area(self) -> float:
        """Area, m^2 (mass per unit density)."""
        raise NotImplementedError

    @property
    def second_moment(self) -> float:
        """Polar second moment about the centre of mass, m^4 (inertia per unit density)."""
        raise NotImplementedError

    def bounds(self) -> np.ndarray:
        """Body-frame AABB ``[xmin, ymin, xmax, ymax]`` (4,) of the region f <= 0."""
        raise NotImplementedError

    @cached_property
    def core_radius(self) -> float:
        """-f at the centre of mass, metres: the radius of the largest disc about it
        inside the shape (negative when the centre of mass is outside)."""
        return -float(self.field.distance(np.zeros((1, 2)))[0])

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.spec!r})"


class Circle(Shape):
    """Disc of ``radius`` (m) centred on its centre of mass."""

    kind = "circle"

    def __init__(self, radius: float):
        r = check_number(radius, "radius", low=0.0, low_open=True, high=MAX_SIZE)
        self._radius = r
        self._field = field({"type": "circle", "radius": r})
        self.spec = {"type": "circle", "radius": r}

    @property
    def field(self) -> Field:
        return self._field

    @property
    def origin(self) -> np.ndarray:
        return np.zeros(2)

    @property
    def radius(self) -> float:
        return self._radius

    @property
    def area(self) -> float:
        return math.pi * self._radius ** 2

    @property
    def second_moment(self) -> float:
        return 0.5 * math.pi * self._radius ** 4

    @property
    def core_radius(self) -> float:
        return self._radius                 # -(|0| - r), with no field evaluated

    def bounds(self) -> np.ndarray:
        r = self._radius
        return np.array([-r, -r, r, r])


class TriangleMesh(Shape):
    """A simple polygon (concave allowed), triangulated, with its exact polygon field.

    ``TriangleMesh(points)``: points (M, 2) in user coordinates, either winding.
    ``TriangleMesh.box(size)``: a ``[w, h]`` box centred on the user origin, whose
    field is the box primitive. Attributes (body frame, metres):

    vertices: (M, 2) counter-clockwise outline, centroid at the origin.
    triangles: (M - 2, 3) int64 indices into ``vertices``, counter-clockwise.
    outline: (M, 2) the closed boundary in order (the vertices, edge i from vertex
        i to i + 1 mod M), for drawing.
    """

    kind = "mesh"

    def __init__(self, points: Any, path: str = "points"):
        ccw = validate_polygon(points, path)
        _check_extent(np.asarray(points, dtype=np.float64), path)
        area, centroid, second_moment = polygon_mass_properties(ccw, path)
        self.vertices = ccw - centroid
        self.triangles = triangulate(ccw, path)
        self._origin = -centroid
        self._area = area
        self._second_moment = second_moment
        self._field = field({"type": "polygon", "points": self.vertices.tolist()}, path)
        self.spec = {"type": "polygon", "points": [[float(x), float(y)] for x, y in
                                                   np.asarray(points, dtype=np.float64)]}

    @classmethod
    def box(cls, size: Any, path: str = "size") -> TriangleMesh:
        """A ``[w, h]`` (m) box centred at the origin, with the exact box field."""
        w, h = check_vec2(size, path, positive=True)
        for i, side in enumerate((w, h)):
            check_number(side, f"{path}[{i}]", high=MAX_SIZE)
        mesh = cls.__new__(cls)
        mesh.vertices = np.array([[-w, -h], [w, -h], [w, h], [-w, h]]) / 2.0
        mesh.triangles = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
        mesh._origin = np.zeros(2)
        mesh._area = w * h
        mesh._second_moment = w * h * (w * w + h * h) / 12.0
        mesh._field = field({"type": "box", "size": [w, h]}, path)
        mesh.spec = {"type": "box", "size": [w, h]}
        return mesh

    @property
    def outline(self) -> np.ndarray:
        return self.vertices

    @cached_property
    def outline_edges(self) -> np.ndarray:
        """(T, 3) bool: edge k of triangle t (opposite its vertex k) lies on the outline."""
        m = len(self.vertices)
        t = self.triangles
        step = (t[:, [2, 0, 1]] - t[:, [1, 2, 0]]) % m
        return (step == 1) | (step == m - 1)

    @cached_property
    def convex(self) -> bool:
        """Whether the outline is convex (no reflex vertex; collinear ones allowed):
        such pairs collide by separating axes and clipping (``collide.polygons``)."""
        edge = np.roll(self.vertices, -1, axis=0) - self.vertices
        turn = edge[:, 0] * np.roll(edge[:, 1], -1) - edge[:, 1] * np.roll(edge[:, 0], -1)
        scale = float(np.max(np.sum(edge * edge, axis=1)))
        return bool(np.all(turn >= -1e-12 * scale))

    @property
    def field(self) -> Field:
        return self._field

    @property
    def origin(self) -> np.ndarray:
        return self._origin.copy()

    @cached_property
    def radius(self) -> float:
        return float(np.max(np.hypot(self.vertices[:, 0], self.vertices[:, 1])))

    @property
    def area(self) -> float:
        return self._area

    @property
    def second_moment(self) -> float:
        return self._second_moment

    def bounds(self) -> np.ndarray:
        return np.concatenate([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @cached_property
    def core_radius(self) -> float:
        if self.spec["type"] == "box":      # -max(-w/2, -h/2): the box field at its centre
            return float(np.min(self.vertices[2]))
        return super().core_radius


def _check_extent(points: np.ndarray, path: str) -> None:
    """Polygon ``points`` (M, 2), m: within MAX_SIZE of the user origin on both axes, and
    at least MIN_SIZE across on both axes (as a box's sides)."""
    far = np.abs(points) > MAX_SIZE
    if np.any(far):
        i, j = np.argwhere(far)[0]
        raise SpecError(f"{path}[{i}][{j}]", f"must be within {MAX_SIZE:g} m of the body's "
                                             f"origin, got {points[i, j]:g}")
    extent = float(np.min(points.max(axis=0) - points.min(axis=0)))
    if extent < MIN_SIZE:
        raise SpecError(path, f"must be at least {MIN_SIZE:g} m across on both axes, "
                              f"got {extent:g}")


class SdfShape(Shape):
    """Any field as a shape; mass properties by quadrature, computed on first use.

    ``field`` (user frame) may be unbounded (a half-plane): then the shape can only
    be static, its body frame is the user frame (origin (0, 0)), its radius is inf,
    and ``area`` / ``second_moment`` raise SpecError. A bounded field is moved so
    that its centroid (``geometry.field_mass_properties`` with grid spacing ``cell``,
    m) is the body origin. The default cell (see SDF_CELLS_PER_ROOT_AREA) keeps the
    relative error of area and second moment under 1e-4.
    """

    kind = "sdf"

    def __init__(self, user_field: Field, cell: float | None = None, path: str = "field"):
        self.user_field = user_field
        self._path = path
        self._user_bounds = np.asarray(user_field.bounds(), dtype=np.float64)
        finite = self._user_bounds[np.isfinite(self._user_bounds)]
        if len(finite) and np.max(np.abs(finite)) > MAX_SIZE:
            w, h = self._user_bounds[2:] - self._user_bounds[:2]
            raise SpecError(path, f"spans {w:g} x {h:g} m and reaches "
                                  f"{np.max(np.abs(finite)):g} m from the body's origin, "
                                  f"more than {MAX_SIZE:g} m")
        self.bounded = bool(np.all(np.isfinite(self._user_bounds)))
        self.spec = {"type": "sdf",
                     "field": user_field if user_field.spec is None else user_field.spec}
        if cell is not None:
            self.spec["cell"] = cell
        self.cell = cell
        self.variants: dict[tuple[str, str, float], Shape] = {}
        """Field variants built by ``collision_shape``, by (gradient, representation, cell)."""

    @cached_property
    def _mass(self) -> tuple[float, np.ndarray, float]:
        if not self.bounded:
            raise SpecError(self._path, "is unbounded (e.g. a half-plane): it has no mass "
                                        "and may only be used by a static body")
        if self.cell is None:
            self.cell = self._default_cell()
        return field_mass_properties(self.user_field, self.cell, self._path)

    def _default_cell(self) -> float:
        """sqrt(area) / SDF_CELLS_PER_ROOT_AREA, area from a coarse pass (see above)."""
        sides = self._user_bounds[2:] - self._user_bounds[:2]
        coarse = float(np.min(sides) if np.min(sides) > 0.0 else np.max(sides)) / 20.0
        area = field_mass_properties(self.user_field, coarse, self._path)[0]
        budget = math.sqrt(float(np.prod(sides + 2.0 * coarse)) / SDF_MAX_GRID_POINTS)
        return max(math.sqrt(area) / SDF_CELLS_PER_ROOT_AREA, budget)

    @cached_property
    def _centroid(self) -> np.ndarray:
        return self._mass[1] if self.bounded else np.zeros(2)

    @cached_property
    def field(self) -> Field:
        if not self.bounded:
            return self.user_field
        return field({"op": "transform", "of": self.user_field,
                      "offset": (-self._centroid).tolist(), "angle": 0.0})

    @property
    def origin(self) -> np.ndarray:
        return -self._centroid

    @cached_property
    def radius(self) -> float:
        b = self.bounds()
        if not np.all(np.isfinite(b)):
            return math.inf
        return float(np.max(np.hypot(b[[0, 2, 2, 0]], b[[1, 1, 3, 3]])))

    @property
    def area(self) -> float:
        return self._mass[0]

    @property
    def second_moment(self) -> float:
        return self._mass[2]

    def bounds(self) -> np.ndarray:
        if not self.bounded:
            return self._user_bounds.copy()
        return self._user_bounds - np.concatenate([self._centroid, self._centroid])


class _FieldVariant(Shape):
    """An SdfShape seen through another field (baked, numeric gradient): same body
    frame, bounds, radius and mass properties; only ``field`` differs."""

    kind = "sdf"

    def __init__(self, base: SdfShape, variant_field: Field):
        self.base = base
        self.spec = base.spec
        self._field = variant_field

    @property
    def field(self) -> Field:
        return self._field

    @property
    def origin(self) -> np.ndarray:
        return self.base.origin

    @property
    def radius(self) -> float:
        return self.base.radius

    @property
    def area(self) -> float:
        return self.base.area

    @property
    def second_moment(self) -> float:
        return self.base.second_moment

    def bounds(self) -> np.ndarray:
        return self.base.bounds()


def collision_shape(shape: Shape, gradient: str = "analytic",
                    representation: str = "analytic", cell: float = 0.02) -> Shape:
    """The shape collisions use under the ``gradient`` / ``field_representation`` knobs.

    Circles and meshes, and SDF shapes under ("analytic", "analytic"), are returned
    as they are. Otherwise an SDF shape's body-frame field is baked on a grid of
    spacing ``cell`` (m; ``representation="grid"``, bounded fields only: an
    unbounded one stays analytic) and then, for a numeric ``gradient`` (a method
    of ``sdf.gradient.METHODS``), wrapped in ``NumericGradientField``. The variant
    keeps the shape's frame, bounds and mass properties, and is cached, so equal
    knobs give the same object (instancing in the narrowphase is kept).
    """
    if representation == "grid" and isinstance(shape, SdfShape) and not shape.bounded:
        representation = "analytic"
    if not isinstance(shape, SdfShape) or (gradient, representation) == ("analytic",
                                                                          "analytic"):
        return shape
    key = (gradient, representation, float(cell) if representation == "grid" else 0.0)
    variant = shape.variants.get(key)
    if variant is None:
        variant_field = shape.field
        if representation == "grid":
            variant_field = GridField(variant_field, cell)
        if gradient != "analytic":
            variant_field = NumericGradientField(variant_field, gradient)
        variant = shape.variants[key] = _FieldVariant(shape, variant_field)
    return variant


_CACHE: dict[str, Shape] = {}


def shape_from_spec(spec: Any, path: str = "shape") -> Shape:
    """The Shape for a scene shape dict (the same object for equal canonical specs).

    Accepted: ``{type="circle", radius}``, ``{type="box", size=[w, h]}``,
    ``{type="polygon", points=[[x, y], ...]}`` (simple, either winding) and
    ``{type="sdf", field=FIELD, cell=h}`` (``cell`` optional, m, see SdfShape). A
    Shape is returned as is. Bad input raises SpecError naming the key path under
    ``path``, e.g. ``shape.radius: must be > 0, got -1``.
    """
    if isinstance(spec, Shape):
        return spec
    if not isinstance(spec, Mapping):
        raise SpecError(path, f"must be a table with a 'type', got {spec!r}")
    if "type" not in spec:
        raise SpecError(path, "needs a 'type' (one of " + ", ".join(SHAPE_TYPES) + ")")
    kind = spec["type"]
    if not isinstance(kind, str) or kind not in SHAPE_TYPES:
        raise SpecError(f"{path}.type", f"unknown shape type {kind!r}"
                        + (suggest(kind, list(SHAPE_TYPES)) if isinstance(kind, str) else "")
                        + "; known: " + ", ".join(SHAPE_TYPES))
    keys = SHAPE_TYPES[kind]
    for key in spec:
        if key != "type" and key not in keys:
            raise SpecError(f"{path}.{key}", f"unknown key for shape {kind!r}"
                            + suggest(key, list(keys)))
    for key in keys:
        if key not in spec and key != "cell":
            raise SpecError(f"{path}.{key}", f"is required for shape {kind!r}")

    if kind == "circle":
        canonical = {"type": "circle",
                     "radius": check_number(spec["radius"], f"{path}.radius", low=MIN_SIZE,
                                            high=MAX_SIZE)}
    elif kind == "box":
        size = check_vec2(spec["size"], f"{path}.size", positive=True)
        for i, side in enumerate(size):
            check_number(side, f"{path}.size[{i}]", low=MIN_SIZE, high=MAX_SIZE)
        canonical = {"type": "box", "size": list(size)}
    elif kind == "polygon":
        canonical = {"type": "polygon", "points": [
            list(p) for p in check_points(spec["points"], f"{path}.points", minimum=3)]}
    else:
        user_field = field(spec["field"], f"{path}.field")
        canonical = {"type": "sdf", "field": user_field.spec}
        if "cell" in spec:
            canonical["cell"] = check_number(spec["cell"], f"{path}.cell", low=0.0,
                                             low_open=True)
        if user_field.spec is None:
            return SdfShape(user_field, canonical.get("cell"), f"{path}.field")

    key = _cache_key(canonical)
    shape = _CACHE.get(key)
    if shape is None:
        shape = _build(canonical, path)
        _CACHE[key] = shape
    return shape


def _cache_key(canonical: dict) -> Any:
    """The key of ``_CACHE``: equal for equal canonical specs (a tuple for circles and
    boxes, which are most bodies and cheap to key; the sorted JSON otherwise)."""
    if canonical["type"] == "circle":
        return ("circle", canonical["radius"])
    if canonical["type"] == "box":
        return ("box", *canonical["size"])
    return json.dumps(canonical, sort_keys=True)


def _build(canonical: dict, path: str) -> Shape:
    kind = canonical["type"]
    if kind == "circle":
        return Circle(canonical["radius"])
    if kind == "box":
        return TriangleMesh.box(canonical["size"], f"{path}.size")
    if kind == "polygon":
        return TriangleMesh(canonical["points"], f"{path}.points")
    return SdfShape(field(canonical["field"], f"{path}.field"), canonical.get("cell"),
                    f"{path}.field")
