"""Editable terrain: carving fields out of bodies; deposits on static and kinematic ones.

``World.carve(body, field, position, angle)`` removes a FIELD placed at a world pose
from a body, ``World.deposit`` adds one (docs/terrain.md). The body's field becomes a
float64 baked grid in its body frame (``TerrainShape``) at its first edit, and every
edit changes that grid's node values in place (``sdf.edit.edit_grid``): the array's
shape and dtype never change, so no kernel recompiles and a step costs the same after
one edit or a thousand.

First edit of a body:

- a top-level baked grid (``{op = "bake"}`` or an image, no ``offset``/``angle``) keeps
  its nodes, cell, margin and band, decoded to float64 if quantized;
- any other bounded field (an analytic SDF, a box, a polygon, a circle) is baked at
  ``Settings.carve_cell`` over its bounds plus ``MARGIN_CELLS`` cells, with no band;
- unbounded fields (a half-plane), and deposits on dynamic bodies, are refused
  (SpecError).

A carved dynamic body then takes the mass, centre of mass and inertia of what is left,
and each further piece the carve cut off becomes a new body (``pieces.split``): its
grid moves with its centre of mass, so each of its edits gives it a new shape.

The edited body gets its own shape (bodies that shared its shape keep theirs). What is
refreshed, for that body only: its contacts and warm-start impulses (dropped: the next
step finds them anew), the sleeping islands it touches (woken, so bodies resting on it
fall into a hole), its core radius, its sprite (``TerrainShape.revision``, which the
renderer compares) and its constants in the queries' tables (``queries._packed``).
The collision tables see the new shape once, at the first edit; later edits keep the
grid's bounds (its whole box, grown where a rim node is inside), so nothing cached by
shape needs rebuilding.

Scheduled edits (a scene's ``[[carve]]`` tables, ``schedule``) are applied at the start
of the first step whose time is at or after theirs (``sdfphys.scheduled``: the rule of
the ``[[explode]]`` tables, which run after the edits due at the same step), in time
order then scene order.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from .errors import SpecError
from .limits import check_angle, check_position
from .pieces import grid_mass, split
from .scheduled import add, due
from .sdf.base import Field
from .sdf.build import field as build_field
from .sdf.build import suggest
from .sdf.edit import edit_grid, write_window
from .sdf.grid import GridField
from .shapes import SdfShape, Shape
from .vec2 import rotate
from .world_bodies import Body, shape_number

__all__ = ["MARGIN_CELLS", "Edit", "TerrainShape", "apply_due", "edit", "schedule",
           "user_field"]

#: Space baked around an analytic field's bounds at its first edit, in cells: where a
#: deposit can grow (edits beyond the grid are clipped).
MARGIN_CELLS = 10

#: Kind codes of ``limits.KINDS`` that may be edited.
_DYNAMIC = 0


class TerrainShape(Shape):
    """An edited body's shape: ``field`` is a float64 ``GridField`` in the body frame.

    ``origin`` is the body's (unchanged by edits of static and kinematic bodies);
    ``bounds()`` the grid's box, grown by the depth of its most negative rim node (edits
    never lower a rim node below min(value, 0)); ``revision`` counts the edits (the
    renderer redraws the body's sprite when it changes). ``area`` (m^2) and
    ``second_moment`` (m^4, about the frame's origin, the centroid) are a carved dynamic
    body's (``pieces``); inf, not tracked, for static and kinematic bodies.
    """

    kind = "sdf"

    def __init__(self, grid: GridField, origin: np.ndarray, area: float = math.inf,
                 second_moment: float = math.inf):
        self.grid = grid
        self._origin = np.array(origin, dtype=np.float64)
        self._area = float(area)
        self._second_moment = float(second_moment)
        v = grid.values
        rim = min(v[0].min(), v[-1].min(), v[:, 0].min(), v[:, -1].min())
        grow = max(0.0, -float(rim))
        top = grid.origin + grid.cell * (np.array(grid.shape, dtype=np.float64) - 1.0)
        self._box = np.concatenate([grid.origin - grow, top + grow])
        grid._bounds = self._box.copy()
        corners = self._box[[[0, 1], [2, 1], [2, 3], [0, 3]]]
        self._radius = float(np.max(np.hypot(corners[:, 0], corners[:, 1])))
        self.spec = {"type": "sdf", "field": grid}
        self.revision = 0

    @property
    def field(self) -> Field:
        return self.grid

    @property
    def origin(self) -> np.ndarray:
        return self._origin

    @property
    def radius(self) -> float:
        return self._radius

    @property
    def area(self) -> float:
        """m^2: a carved dynamic body's; inf for static and kinematic bodies (infinite
        mass; as for unbounded shapes, the renderer's density is then 0)."""
        return self._area

    @property
    def second_moment(self) -> float:
        """m^4 about the centroid: a carved dynamic body's; inf otherwise."""
        return self._second_moment

    def bounds(self) -> np.ndarray:
        return self._box.copy()


class Edit(NamedTuple):
    """One scheduled edit (a ``[[carve]]`` table): time (s), body (index or name), the
    FIELD (a Field), world position (2,) m, angle rad and deposit."""

    time: float
    body: Any
    field: Field
    position: tuple[float, float]
    angle: float = 0.0
    deposit: bool = False


def body_index(world: Any, body: Any, path: str = "body") -> int:
    """The index of ``body`` (an index, a name or a Body handle); SpecError naming
    ``path`` if there is no such body."""
    if isinstance(body, str):
        if body not in world._name_set:
            raise SpecError(path, f"no body named {body!r}" + suggest(body, world._names))
        return world._names.index(body)
    try:
        index = operator.index(body)
    except TypeError:
        raise SpecError(path, f"must be a body index, name or handle, got {body!r}") from None
    except IndexError as err:                   # a handle of a removed body
        raise SpecError(path, str(err)) from None
    if not -len(world) <= index < len(world):
        raise SpecError(path, f"body index {index} out of range ({len(world)} bodies)")
    return index % len(world)


def _terrain(world: Any, i: int, path: str, deposit: bool) -> TerrainShape:
    """Body ``i``'s TerrainShape, made at its first edit (module docstring)."""
    shape = world._shapes[int(world._data["shape_id"][i])]
    name = world._names[i]
    if deposit and int(world._data["kind"][i]) == _DYNAMIC:
        raise SpecError(path, f"body {name!r} is dynamic: only static and kinematic "
                              "bodies take deposits (dynamic ones can be carved)")
    if isinstance(shape, TerrainShape):
        return shape
    if not math.isfinite(shape.radius):
        raise SpecError(path, f"body {name!r} is unbounded (e.g. a half-plane): only a "
                              "bounded field can be carved (use a box)")
    user = shape.user_field if isinstance(shape, SdfShape) else None
    if type(user) is GridField:
        # Keep the nodes; the body frame is the user frame moved by ``origin``.
        grid = GridField.from_values(user.values, user.origin + shape.origin, user.cell,
                                     user.margins, user.band)
    else:
        cell = world.settings.carve_cell
        try:
            baked = GridField(shape.field, cell, margin=MARGIN_CELLS * cell)
        except SpecError as err:
            raise SpecError("settings.carve_cell", f"body {name!r}: {err.message}") from None
        grid = GridField.from_values(baked.values, baked.origin, cell, baked.margin)
    terrain = TerrainShape(grid, shape.origin)
    d = world._data
    d["shape_id"][i] = shape_number(world, terrain)
    d["radius"][i] = terrain.radius
    return terrain


def edit(world: Any, body: Any, spec: Any, position: Any, angle: float = 0.0,
         deposit: bool = False) -> None:
    """Carve ``spec`` (a FIELD dict or Field) placed at world ``position`` (2,) m and
    ``angle`` rad out of ``body`` (or deposit it); see the module docstring."""
    i = body_index(world, body)
    shape = build_field(spec, "field")
    position = np.array(check_position(position, "position"))
    angle = check_angle(angle, "angle")
    terrain = _terrain(world, i, "body", deposit)
    d = world._data
    dynamic = int(d["kind"][i]) == _DYNAMIC
    grid = terrain.grid
    before = grid_mass(grid.values, grid.origin, grid.cell) if dynamic else None
    com, turn = d["com"][i], float(d["angle"][i])
    c, s = math.cos(turn), math.sin(turn)
    dx, dy = position - com
    local = (c * dx + s * dy, c * dy - s * dx)          # R(-turn) (position - com)
    clear = _clear_of_bodies(world, i, shape, position, angle) if deposit else None
    window = edit_grid(terrain.grid, shape, local, angle - turn, deposit, clear)
    if window is None:
        return
    # The ray and overlap queries pack a copy of every program's constants (cached on
    # the world until a shape is added, ``queries._packed``): the window goes there too.
    packed = world.__dict__.get("_query_pack")
    if packed is not None and packed[0] == len(world._shapes):
        tables = packed[1]
        number = int(d["shape_id"][i])
        write_window(tables.code, tables.consts, int(tables.cstart[number]), terrain.grid,
                     window)
    terrain.revision += 1
    d["core_radius"][i] = -float(terrain.grid.distance(np.zeros((1, 2)))[0])
    world._wake_touching(i)
    kept = world._impulses
    world._impulses = kept.take((kept.body_a != i) & (kept.body_b != i))
    contacts = world._contacts
    world._contacts = contacts.take((contacts.body_a != i) & (contacts.body_b != i))
    world._contact_cache.forget(i)
    if dynamic:
        split(world, i, grid, before)


def _clear_of_bodies(world: Any, i: int, shape: Field, position: np.ndarray,
                     angle: float) -> Callable[[np.ndarray], np.ndarray] | None:
    """What a deposit of ``shape`` at world ``position``, ``angle`` on body ``i`` must
    leave clear: the dynamic bodies whose bounding circles meet the placed shape's
    bounding circle, as a function of points (N, 2) in body i's frame giving the
    distance (N,) m to the nearest of them (the minimum of their fields, negative
    inside); None when no body is that near (``sdf.edit.edit_grid``)."""
    d = world._data
    box = np.asarray(shape.bounds(), dtype=np.float64)
    if not np.all(np.isfinite(box)):
        return None
    c, s = math.cos(angle), math.sin(angle)
    middle = 0.5 * (box[:2] + box[2:])
    centre = position + np.array([c * middle[0] - s * middle[1],
                                  s * middle[0] + c * middle[1]])
    reach = 0.5 * float(np.hypot(box[2] - box[0], box[3] - box[1]))
    gap = np.hypot(*(d["com"] - centre).T) - d["radius"] - reach
    near = np.flatnonzero((d["kind"] == _DYNAMIC) & (gap < 0.0))
    if len(near) == 0:
        return None
    com, turn = d["com"][i].copy(), float(d["angle"][i])
    bodies = [(d["com"][j].copy(), float(d["angle"][j]),
               world._shapes[int(d["shape_id"][j])].field) for j in near]

    def clear(points: np.ndarray) -> np.ndarray:
        world_points = com + rotate(points, turn)
        return np.min([field.distance(rotate(world_points - at, -turned))
                       for at, turned, field in bodies], axis=0)

    return clear


def user_field(world: Any, body: Any) -> Field:
    """Body ``body``'s current field in its user frame (the frame of its scene
    ``position``): the body-frame field moved by ``-origin``."""
    i = body_index(world, body)
    shape = world._shapes[int(world._data["shape_id"][i])]
    if isinstance(shape, SdfShape) and not isinstance(shape, TerrainShape):
        return shape.user_field
    origin = np.asarray(shape.origin, dtype=np.float64)
    if origin[0] == 0.0 and origin[1] == 0.0:
        return shape.field
    return build_field({"op": "translate", "by": (-origin).tolist(), "of": shape.field})


def schedule(world: Any, edits: list[Edit]) -> None:
    """Queue ``edits`` (applied by ``apply_due`` at the start of each step; equal times
    in the order given: scene order). Their bodies are held by handle: a carve may
    remove a body (carved to nothing) and move the later ones' indices."""
    handles = []
    for e in edits:
        i = body_index(world, e.body)
        handles.append(e._replace(body=Body(world, int(world._data["uid"][i]))))
    add(world._scheduled, handles)


def apply_due(world: Any) -> None:
    """Apply the queued edits due at the step about to begin at ``world.time``
    (``scheduled.due``); an edit of a body removed since is dropped."""
    for e in due(world._scheduled, world.time, world.settings.dt):
        try:
            body = e.body.index
        except IndexError:
            continue
        edit(world, body, e.field, e.position, e.angle, e.deposit)
