"""The world's body table: per-body arrays, ``Body`` handles, adding and removing bodies.

Body state is a struct of arrays (``ARRAYS``), split hot and cold as in Box2D v3: the
solver reads and writes the centre-of-mass position, angle, velocities and inverse
masses; shapes, materials, kinds and names are bookkeeping. Each array lives in
``World._data`` with a capacity that grows by doubling (``reserve``), so adding B bodies
costs O(B); ``World._view(name)`` is its first ``len(world)`` rows. Body indices are the
order of ``add`` calls (scene order); ``remove`` shifts the later bodies down by one, in
every array and in every table indexed by body (contacts, impulses, joints, events).
``uid`` counts every body ever added (never reused), so it increases with the index and
a ``Body`` handle finds its body's current index by one binary search (``index_of``).

Distinct Shape objects are numbered once (``shape_number``: ``World.shapes``,
``shape_id``) and their constants computed once (``shape_row``).
"""

from __future__ import annotations

import math
import operator
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import SpecError
from .limits import KINDS, BodyValues
from .shapes import Shape

if TYPE_CHECKING:
    from .world import World

__all__ = ["ARRAYS", "DYNAMIC", "KINEMATIC", "STATIC", "Body", "add", "check_index",
           "index_of", "read_only", "remove", "reserve", "rotate_one", "shape_number",
           "shape_row"]

#: Body kinds, in the order of their integer codes (``limits.KINDS``).
DYNAMIC, STATIC, KINEMATIC = range(3)

#: Per-body arrays: name -> (trailing shape, dtype). Capacity grows by doubling.
ARRAYS: dict[str, tuple[tuple[int, ...], Any]] = {
    "com": ((2,), np.float64),
    "angle": ((), np.float64),
    "velocity": ((2,), np.float64),
    "angular_velocity": ((), np.float64),
    "inv_mass": ((), np.float64),
    "inv_inertia": ((), np.float64),
    "linear_damping": ((), np.float64),
    "angular_damping": ((), np.float64),
    "round": ((), np.bool_),
    "mass": ((), np.float64),
    "inertia": ((), np.float64),
    "friction": ((), np.float64),
    "restitution": ((), np.float64),
    "origin": ((2,), np.float64),
    "radius": ((), np.float64),
    "core_radius": ((), np.float64),
    "shape_id": ((), np.int64),
    "kind": ((), np.int8),
    "sleep_time": ((), np.float64),
    "asleep": ((), np.bool_),
    "island": ((), np.int64),
    "category": ((), np.uint64),
    "mask": ((), np.uint64),
    "group": ((), np.int64),
    "sensor": ((), np.bool_),
    "gravity_scale": ((), np.float64),
    "force": ((2,), np.float64),
    "torque": ((), np.float64),
    "uid": ((), np.int64),
}


def rotate_one(v: np.ndarray, angle: float) -> np.ndarray:
    """(2,) ``v`` rotated counter-clockwise by ``angle`` rad (numpy's cos and sin, as
    ``vec2.rotate``: the same bits)."""
    a = np.array([angle], dtype=np.float64)
    c, s = float(np.cos(a)[0]), float(np.sin(a)[0])
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def read_only(array: np.ndarray) -> np.ndarray:
    """``array`` (a fresh copy) marked read-only: writing to it raises numpy's
    "assignment destination is read-only"."""
    array.flags.writeable = False
    return array


class Body:
    """A stable handle on one body of a World (``World.add_body``, ``World.body``).

    ``id``: the body's creation number in its world (the k of its default name
    ``body<k>``), never reused. The handle stands for the body's current index wherever
    an index goes (``__index__``, ``__array__``: numpy indexing, also by lists of
    handles, ``set_state``, ``remove_body``, ``apply_force``, ...), so it stays valid
    while other bodies are removed; after its
    own body is removed, using it raises IndexError. It equals its current index and the
    handles of the same body, orders as its index, and hashes by ``id``.
    """

    __slots__ = ("_world", "id")

    def __init__(self, world: World, uid: int):
        self._world = world
        self.id = uid

    @property
    def index(self) -> int:
        """The body's current index (scene order); IndexError once it is removed."""
        return index_of(self._world, self.id)

    def __index__(self) -> int:
        return self.index

    __int__ = __index__

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        """The index as a 0-d int64 array: numpy takes lists of handles as indices."""
        return np.array(self.index, dtype=np.int64 if dtype is None else dtype)

    @property
    def name(self) -> str:
        return self._world._names[self.index]

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Body):
            return self._world is other._world and self.id == other.id
        if isinstance(other, (int, np.integer)) and not isinstance(other, bool):
            try:
                return self.index == other
            except IndexError:
                return False
        return NotImplemented

    def __lt__(self, other: object) -> bool:
        """Handles order as their current indices (``sorted`` of handles: scene order)."""
        if isinstance(other, (Body, int, np.integer)) and not isinstance(other, bool):
            return self.index < int(other)
        return NotImplemented

    def __gt__(self, other: object) -> bool:
        if isinstance(other, (Body, int, np.integer)) and not isinstance(other, bool):
            return self.index > int(other)
        return NotImplemented

    def __hash__(self) -> int:
        return hash(("Body", self.id))

    def __repr__(self) -> str:
        try:
            return f"Body(id={self.id}, index={self.index}, name={self.name!r})"
        except IndexError:
            return f"Body(id={self.id}, removed)"


def index_of(world: World, uid: int) -> int:
    """The current index of the body created as number ``uid`` (ids increase with
    the index: one binary search); IndexError if it was removed."""
    uids = world._view("uid")
    k = int(np.searchsorted(uids, uid))
    if k == len(uids) or uids[k] != uid:
        raise IndexError(f"body {uid} was removed from this world")
    return k


def check_index(world: World, index: int | Body) -> int:
    """``index`` (an int or a Body; negative counts from the end) as an index in
    [0, len(world)); IndexError if out of range."""
    index = operator.index(index)
    if not -world._n <= index < world._n:
        raise IndexError(f"body index {index} out of range ({world._n} bodies)")
    return index % world._n


def add(world: World, shape: Shape, values: BodyValues, name: str | None) -> int:
    """Add a body whose values ``limits.check_body`` validated (``Scene.build`` calls
    this directly, as ``World._add``: the scene was checked when read); its index."""
    if name is None:
        name = f"body{world._created}"
    if name in world._name_set:
        raise SpecError("name", f"duplicate body name {name!r}")
    number, origin, radius, core_radius, area, second_moment = shape_row(world, shape)
    code = KINDS.index(values.kind)
    if code == DYNAMIC:
        m = values.mass if values.mass is not None else values.density * area
        inertia = m / area * second_moment
    else:
        m = inertia = math.inf

    i = world._n
    reserve(world, i + 1)
    world._n = i + 1
    d = world._data
    if origin[0] == 0.0 and origin[1] == 0.0:     # circles and boxes
        d["com"][i] = values.position
    else:
        d["com"][i] = np.asarray(values.position) - rotate_one(origin, values.angle)
    d["angle"][i] = values.angle
    d["velocity"][i] = values.velocity
    d["angular_velocity"][i] = values.angular_velocity
    d["mass"][i] = m
    d["inertia"][i] = inertia
    d["inv_mass"][i] = 1.0 / m
    d["inv_inertia"][i] = 1.0 / inertia if inertia > 0.0 else 0.0
    d["linear_damping"][i] = values.linear_damping
    d["angular_damping"][i] = values.angular_damping
    d["round"][i] = shape.kind == "circle"
    d["friction"][i] = values.friction
    d["restitution"][i] = values.restitution
    d["origin"][i] = origin
    d["radius"][i] = radius
    d["core_radius"][i] = core_radius
    d["shape_id"][i] = number
    d["kind"][i] = code
    d["sleep_time"][i] = 0.0
    d["asleep"][i] = False
    d["island"][i] = 0
    d["category"][i] = values.category
    d["mask"][i] = values.mask
    d["group"][i] = values.group
    d["sensor"][i] = values.sensor
    d["gravity_scale"][i] = values.gravity_scale
    d["force"][i] = 0.0
    d["torque"][i] = 0.0
    d["uid"][i] = world._created
    world._filter_stale = True
    world._names.append(name)
    world._name_set.add(name)
    world._created += 1
    return i


def shape_row(world: World, shape: Shape) -> tuple:
    """(shape number, origin (2,), radius, core radius, area, second moment) of
    ``shape``, computed once per distinct shape (area and second moment None for an
    unbounded one). The core radius is -f(centre of mass): the deepest inside."""
    row = world._shape_rows.get(id(shape))
    if row is None:
        bounded = math.isfinite(shape.radius)
        row = (shape_number(world, shape), np.asarray(shape.origin, dtype=np.float64),
               shape.radius, shape.core_radius,
               shape.area if bounded else None,
               shape.second_moment if bounded else None)
        world._shape_rows[id(shape)] = row
    return row


def shape_number(world: World, shape: Shape) -> int:
    """``shape``'s index in ``world._shapes``, appended at its first use (``World.shapes``;
    ``terrain`` numbers an edited body's new shape here)."""
    number = world._shape_index.get(id(shape))
    if number is None:
        number = len(world._shapes)
        world._shapes.append(shape)
        world._shape_index[id(shape)] = number
    return number


def reserve(world: World, count: int) -> None:
    """Grow every array of ``world._data`` to hold ``count`` bodies (capacity doubles)."""
    capacity = len(world._data["angle"])
    if count <= capacity:
        return
    while capacity < count:
        capacity *= 2
    for name, array in world._data.items():
        grown = np.zeros((capacity,) + array.shape[1:], array.dtype)
        grown[:world._n] = array[:world._n]
        world._data[name] = grown


def remove(world: World, i: int) -> None:
    """Remove body ``i`` (checked, its islands woken: ``World.remove_body``) from the
    arrays and names; the later bodies move down one index, in the contacts, impulses,
    joints and events too."""
    n = world._n
    for array in world._data.values():
        array[i:n - 1] = array[i + 1:n]
    world._n = n - 1
    world._name_set.discard(world._names[i])
    del world._names[i]
    world._impulses = world._impulses.without_body(i)
    world._sleep_impulses = world._sleep_impulses.without_body(i)
    world._contacts = world._contacts.without_body(i)
    world._sleep_contacts = world._sleep_contacts.without_body(i)
    world._contact_cache.clear()
    world._joints.without_body(i)
    world._report = world._report.without_body(i)
    world._filter_stale = True
