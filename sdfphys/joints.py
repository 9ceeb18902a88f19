"""Joints: the ``[[joint]]`` spec, its validation, and the world's table of joints.

A joint ties two bodies, ``bodies = [first, second]`` by name (or index, from Python);
``"world"`` is a fixed frame. World points given at creation (``anchor``, ``anchors``,
``axis``) are turned into each body's frame then, and the joint keeps them there: the
first body moves relative to the second (an axis is carried by the second body, a motor
turns or slides the first body relative to the second, a revolute joint's angle is the
first body's angle minus the second's, zero at creation).

Kinds (docs/joints.md): ``revolute`` (a shared point; ``limits`` in rad, ``motor``
{speed rad/s, max_torque N m}), ``prismatic`` (slides along ``axis``, no relative
rotation; ``limits`` in m, ``motor`` {speed m/s, max_force N}), ``distance`` (two
anchors at ``length``, or free between ``min_length`` and ``max_length`` (a rope), or a
``spring`` {hertz, damping_ratio} toward ``length``), ``weld`` (no relative motion;
``spring`` makes it soft), ``wheel`` (slides along ``axis`` on a ``spring``, turns
freely; ``limits`` in m, ``motor`` {speed rad/s, max_torque N m} turns the wheel),
``motor`` (drives the relative pose back to the one at creation with force and torque
at most ``motor`` {max_force N, max_torque N m}, on a ``spring``, by default 4 Hz
critically damped; Box2D v3.1's motor joint), and ``mouse`` (Python only: pulls an anchor of the
first body toward a target point, ``world.set_joint_target``, on a ``spring`` with
force at most ``max_force``).

Every problem raises one SpecError naming the key path (``joint[2].axis: must not be
zero``), as for bodies.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from .errors import SpecError, check_number, check_vec2
from .islands import island_roots
from .sdf.build import suggest

__all__ = ["JOINT_TYPES", "WORLD", "JointSpec", "JointTable", "check_joint"]

#: Joint kinds, in the order of their integer codes (``solver.joints``).
JOINT_TYPES = ("revolute", "prismatic", "distance", "weld", "wheel", "motor", "mouse")
#: The name of the fixed world frame in ``bodies``; its index is -1.
WORLD = "world"

#: Keys each kind accepts beside type, name, bodies and collide_connected.
_KEYS = {
    "revolute": ("anchor", "limits", "motor"),
    "prismatic": ("anchor", "axis", "limits", "motor"),
    "distance": ("anchors", "length", "min_length", "max_length", "spring"),
    "weld": ("anchor", "spring"),
    "wheel": ("anchor", "axis", "limits", "motor", "spring"),
    "motor": ("motor", "spring"),
    "mouse": ("anchor", "spring", "max_force"),
}
_COMMON = ("type", "name", "bodies", "collide_connected")
#: motor keys per kind: (speed unit, the bound's key)
_MOTOR = {"revolute": ("speed", "max_torque"), "prismatic": ("speed", "max_force"),
          "wheel": ("speed", "max_torque"), "motor": ("max_force", "max_torque")}
#: Largest joint length or limit magnitude, m (limits.FAR's order: a world's extent).
_FAR = 2.0 ** 17
#: Largest spring stiffness, Hz (far above any substep rate: stiffer is rigid).
_MAX_HERTZ = 1e6
#: Largest motor speed (rad/s or m/s), torque and force bounds (N m, N).
_MAX_SPEED = 1e4
_MAX_FORCE = 1e12
#: Springs of the kinds that always have one: the mouse joint's is Box2D v3's samples'
#: (5 Hz, damping ratio 0.7); a motor joint's is critically damped (a rigid one would
#: move its body only by its bias velocity, which each substep's relax pass removes).
DEFAULT_SPRING = {"mouse": (5.0, 0.7), "motor": (4.0, 1.0)}


class JointSpec(NamedTuple):
    """One validated joint (SI units; world points and directions at creation).

    bodies: (first, second) body indices, -1 for the world. anchor: (2,) m, the shared
    world point (revolute, prismatic, weld, wheel, mouse; the first body's centre of
    mass for motor). anchors: ((2,), (2,)) m, distance joint's points on first and
    second body. axis: unit (2,) (prismatic, wheel). length, min_length, max_length: m
    (distance; min == max is a rod). limits: (lower, upper) rad or m, or None.
    motor: (speed, bound) or (max_force, max_torque) for a motor joint, or None.
    spring: (hertz, damping_ratio) or None (rigid). max_force: N (mouse).
    data: the dict as given (``World.joints`` returns it).
    """

    kind: str
    name: str
    bodies: tuple[int, int]
    anchor: tuple[float, float] = (0.0, 0.0)
    anchors: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))
    axis: tuple[float, float] = (1.0, 0.0)
    length: float = 0.0
    min_length: float = 0.0
    max_length: float = 0.0
    limits: tuple[float, float] | None = None
    motor: tuple[float, float] | None = None
    spring: tuple[float, float] | None = None
    max_force: float = math.inf
    collide_connected: bool = False
    data: Mapping | None = None


def _body(value: Any, path: str, index_of: Callable[[str], int | None], count: int) -> int:
    if value == WORLD:
        return -1
    if isinstance(value, str):
        i = index_of(value)
        if i is None:
            raise SpecError(path, f"no body named {value!r}")
        return i
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
        if not 0 <= value < count:
            raise SpecError(path, f"no body {value}: there are {count}, numbered from 0")
        return int(value)
    raise SpecError(path, f"must be a body name or {WORLD!r}, got {value!r}")


def _pair(value: Any, path: str) -> tuple[float, float]:
    """An ordered pair [lower, upper] of finite numbers, lower <= upper."""
    lower, upper = check_vec2(value, path)
    if lower > upper:
        raise SpecError(path, f"lower must be <= upper, got [{lower:g}, {upper:g}]")
    if max(abs(lower), abs(upper)) > _FAR:
        raise SpecError(path, f"must be within +-{_FAR:g}, got [{lower:g}, {upper:g}]")
    return lower, upper


def _dot(path: str) -> str:
    """``path`` as the prefix of a key below it (empty at the top)."""
    return f"{path}." if path else ""


def _table(value: Any, path: str, keys: Sequence[str]) -> dict:
    if not isinstance(value, Mapping):
        raise SpecError(path or "joint", f"must be a table, got {value!r}")
    path = _dot(path)
    for key in value:
        if key not in keys:
            raise SpecError(f"{path}{key}", "unknown key" + suggest(str(key), list(keys)))
    return dict(value)


def _spring(value: Any, path: str) -> tuple[float, float]:
    spring = _table(value, path, ("hertz", "damping_ratio"))
    path = _dot(path)
    if "hertz" not in spring:
        raise SpecError(f"{path}hertz", "is required")
    hertz = check_number(spring["hertz"], f"{path}hertz", low=0.0, high=_MAX_HERTZ)
    zeta = check_number(spring.get("damping_ratio", 0.0), f"{path}damping_ratio", low=0.0,
                        high=1e6)
    return hertz, zeta


def _motor(value: Any, path: str, kind: str) -> tuple[float, float]:
    first, second = _MOTOR[kind]
    motor = _table(value, path, (first, second))
    path = _dot(path)
    for key in (first, second):
        if key not in motor:
            raise SpecError(f"{path}{key}", "is required")
    if first == "speed":
        speed = check_number(motor["speed"], f"{path}speed", low=-_MAX_SPEED, high=_MAX_SPEED)
    else:
        speed = check_number(motor[first], f"{path}{first}", low=0.0, high=_MAX_FORCE)
    return speed, check_number(motor[second], f"{path}{second}", low=0.0, high=_MAX_FORCE)


def _point(value: Any, path: str) -> tuple[float, float]:
    x, y = check_vec2(value, path)
    if max(abs(x), abs(y)) > _FAR:
        raise SpecError(path, f"must be within +-{_FAR:g} m, got [{x:g}, {y:g}]")
    return x, y


def check_joint(data: Any, path: str, index_of: Callable[[str], int | None], count: int,
                centers: np.ndarray) -> JointSpec:
    """A validated JointSpec from a scene table or dict; ``path`` prefixes key paths.

    index_of: body name -> index or None; count: the number of bodies; centers: (B, 2)
    m, their positions (user frame origins): the default ``anchor`` is the second
    body's, or the first's against the world; a distance joint's default ``anchors``
    are both bodies'.
    """
    table = _table(data, path, _COMMON + tuple({k for keys in _KEYS.values() for k in keys}))
    path = _dot(path)
    kind = table.get("type")
    if kind is None:
        raise SpecError(f"{path}type", "is required (" + " | ".join(JOINT_TYPES[:-1]) + ")")
    if kind not in JOINT_TYPES:
        raise SpecError(f"{path}type", f"unknown joint type {kind!r}"
                        + suggest(str(kind), list(JOINT_TYPES)))
    for key in table:
        if key not in _COMMON and key not in _KEYS[kind]:
            raise SpecError(f"{path}{key}", f"not used by a {kind} joint (it takes "
                            + ", ".join(_KEYS[kind]) + ")")
    name = table.get("name", "")
    if not isinstance(name, str):
        raise SpecError(f"{path}name", f"must be a string, got {name!r}")
    pair = table.get("bodies")
    if pair is None:
        raise SpecError(f"{path}bodies", "is required: [first, second]")
    if isinstance(pair, (str, bytes)) or not isinstance(pair, Sequence) or len(pair) != 2:
        raise SpecError(f"{path}bodies", f"must be two bodies [first, second], got {pair!r}")
    bodies = (_body(pair[0], f"{path}bodies[0]", index_of, count),
              _body(pair[1], f"{path}bodies[1]", index_of, count))
    if bodies[0] == bodies[1]:
        raise SpecError(f"{path}bodies", "a joint needs two different bodies")
    if kind == "mouse" and (bodies[0] < 0 or bodies[1] >= 0):
        raise SpecError(f"{path}bodies", f"a mouse joint takes [body, {WORLD!r}]")
    collide = table.get("collide_connected", False)
    if not isinstance(collide, bool):
        raise SpecError(f"{path}collide_connected", f"must be true or false, got {collide!r}")
    values: dict[str, Any] = {}
    if "anchor" in _KEYS[kind]:
        default = centers[bodies[1]] if bodies[1] >= 0 else centers[bodies[0]]
        values["anchor"] = _point(table.get("anchor", tuple(default)), f"{path}anchor")
    elif kind == "motor":
        values["anchor"] = tuple(float(x) for x in centers[bodies[0]]) if bodies[0] >= 0 \
            else (0.0, 0.0)
    if "axis" in _KEYS[kind]:
        if "axis" not in table:
            raise SpecError(f"{path}axis", f"is required for a {kind} joint")
        ax, ay = check_vec2(table["axis"], f"{path}axis")
        norm = math.hypot(ax, ay)
        if not norm > 1e-9:
            raise SpecError(f"{path}axis", f"must not be zero, got [{ax:g}, {ay:g}]")
        values["axis"] = (ax / norm, ay / norm)
    if "limits" in table:
        values["limits"] = _pair(table["limits"], f"{path}limits")
    if "motor" in table:
        values["motor"] = _motor(table["motor"], f"{path}motor", kind)
    elif kind == "motor":
        raise SpecError(f"{path}motor", "is required: {max_force = ..., max_torque = ...}")
    if "spring" in table:
        values["spring"] = _spring(table["spring"], f"{path}spring")
    elif kind in DEFAULT_SPRING:
        values["spring"] = DEFAULT_SPRING[kind]
    if "max_force" in table:
        values["max_force"] = check_number(table["max_force"], f"{path}max_force", low=0.0,
                                           high=_MAX_FORCE)
    if kind == "distance":
        values.update(_distance(table, path, centers, bodies, "spring" in values))
    return JointSpec(kind, name, bodies, collide_connected=collide, data=dict(data), **values)


def _distance(table: dict, path: str, centers: np.ndarray, bodies: tuple[int, int],
              spring: bool) -> dict:
    """anchors, length, min_length, max_length of a distance joint (module docstring);
    ``path``: the joint's key path with its trailing dot."""
    if "anchors" in table:
        raw = table["anchors"]
        if isinstance(raw, (str, bytes)) or not isinstance(raw, Sequence) or len(raw) != 2:
            raise SpecError(f"{path}anchors", f"must be two points [[x, y], [x, y]], got {raw!r}")
        anchors = (_point(raw[0], f"{path}anchors[0]"), _point(raw[1], f"{path}anchors[1]"))
    else:
        anchors = tuple(tuple(float(x) for x in centers[b]) if b >= 0 else (0.0, 0.0)
                        for b in bodies)
    span = math.dist(anchors[0], anchors[1])
    length = check_number(table.get("length", span), f"{path}length", low=0.0, high=_FAR)
    free = spring or "min_length" in table or "max_length" in table
    low = check_number(table.get("min_length", 0.0 if free else length), f"{path}min_length",
                       low=0.0, high=_FAR)
    high = check_number(table.get("max_length", _FAR if free else length),
                        f"{path}max_length", low=0.0, high=_FAR)
    if low > high:
        raise SpecError(f"{path}min_length", f"must be <= max_length ({high:g}), got {low:g}")
    if not spring and "length" in table and not low <= length <= high:
        raise SpecError(f"{path}length", f"must lie in [min_length, max_length] = "
                        f"[{low:g}, {high:g}], got {length:g}")
    if not (spring or low < high) and length < 1e-6:
        raise SpecError(f"{path}length", "a rigid distance joint needs length > 0 "
                        "(use a revolute joint to pin two points together)")
    return {"anchors": anchors, "length": length, "min_length": low, "max_length": high}


class JointTable:
    """The world's joints, in ``add_joint`` order: specs, names, and the solver's rows.

    ``specs``: the validated JointSpecs; ``rows``: ``solver.joints.JointRows`` (the same
    order), rebuilt by ``add``/``remove``/``without_body`` (rare); the solver updates
    the rows' impulses in place every step, and ``stiffness_cap`` (1,), the cap on the
    joints' load stiffening (``solver.joints``, "Loaded joints"; inf: none yet).
    """

    def __init__(self) -> None:
        from .solver.joints import JointRows

        self.specs: list[JointSpec] = []
        self.rows = JointRows.empty()
        self.stiffness_cap = np.full(1, np.inf)

    def __len__(self) -> int:
        return len(self.specs)

    def add(self, specs: list[JointSpec], com: np.ndarray, angle: np.ndarray) -> int:
        """Append ``specs`` (one concatenation however many), their frames taken from the
        bodies' com (B, 2) m and angle (B,) rad; returns the index of the last."""
        from .solver.joints import JointRows

        names = {s.name for s in self.specs}
        for spec in specs:
            if spec.name and spec.name in names:
                raise SpecError("name", f"duplicate joint name {spec.name!r}")
            names.add(spec.name)
        self.specs.extend(specs)
        self.rows = JointRows.concatenate(
            [self.rows] + [JointRows.from_spec(spec, com, angle) for spec in specs])
        return len(self.specs) - 1

    def remove(self, j: int) -> JointSpec:
        """Remove joint ``j`` (later joints move down one index); returns its spec."""
        if not -len(self) <= j < len(self):
            raise IndexError(f"joint index {j} out of range ({len(self)} joints)")
        j %= len(self)
        keep = np.arange(len(self)) != j
        self.rows = self.rows.take(keep)
        return self.specs.pop(j)

    def without_body(self, index: int) -> None:
        """Drop the joints of body ``index``; later bodies' indices move down one."""
        keep = np.array([index not in s.bodies for s in self.specs], bool)
        self.specs = [s._replace(bodies=tuple(b - (b > index) for b in s.bodies))
                      for s, k in zip(self.specs, keep) if k]
        self.rows = self.rows.take(keep).renumbered(index)

    def moved_frame(self, index: int, shift: np.ndarray) -> None:
        """Body ``index``'s centre of mass moved by ``shift`` (2,) m in its own frame (a
        carve, ``sdfphys.pieces``): its joints' anchors, held relative to it, move by
        -shift, so they stay at the same material points."""
        r = self.rows
        r.local_a[r.body_a == index] -= shift
        r.local_b[r.body_b == index] -= shift

    def excluded_pairs(self, count: int) -> np.ndarray | None:
        """Sorted int64 keys lo * count + hi of the body pairs whose contacts a joint
        turns off (collide_connected false, two bodies), or None if there are none."""
        r = self.rows
        off = ~r.collide_connected & (r.body_a >= 0) & (r.body_b >= 0)
        if not off.any():
            return None
        lo = np.minimum(r.body_a[off], r.body_b[off])
        hi = np.maximum(r.body_a[off], r.body_b[off])
        return np.unique(lo * np.int64(count) + hi)

    def groups(self, count: int) -> np.ndarray | None:
        """(B,) int64: for each of the ``count`` bodies the lowest index of the bodies it is
        joined to through joints between bodies (itself if none); None without such joints."""
        r = self.rows
        both = (r.body_a >= 0) & (r.body_b >= 0)
        if not both.any():
            return None
        return island_roots(np.ones(count), r.body_a[both], r.body_b[both])

    @staticmethod
    def spread_fractions(group: np.ndarray | None, fast: np.ndarray, fraction: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
        """Time of impact for jointed bodies: every body of the ``group`` (``groups``) of a
        fast body stopped at ``fraction`` (F,) of its step takes the least fraction of its
        group, so the group stops together and its joints stay closed (a forearm rewound
        alone opened its elbow by 4 cm). Returns (bodies, fractions) to apply."""
        if group is None or len(fast) == 0:
            return fast, fraction
        least = np.ones(len(group))
        np.minimum.at(least, group[fast], fraction)
        bodies = np.union1d(fast, np.flatnonzero(least[group] < 1.0))
        return bodies, least[group[bodies]]

    def linked(self, body_a: np.ndarray, body_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The body pairs (body_a, body_b) (K,) of the contacts followed by those of the
        joints between two bodies: what ties bodies into islands (``islands``)."""
        r = self.rows
        both = (r.body_a >= 0) & (r.body_b >= 0)
        if not both.any():
            return body_a, body_b
        return np.r_[body_a, r.body_a[both]], np.r_[body_b, r.body_b[both]]


class WorldJoints:
    """The World's joint methods (``World`` inherits them; its state is ``_joints``)."""

    def add_joint(self, spec: Mapping) -> int:
        """Add a joint from a dict shaped like a scene's ``[[joint]]`` table (bodies by
        name, index, or "world"); returns its index. Bad input raises SpecError naming
        the key (``axis: must not be zero, got [0, 0]``). The bodies' islands wake."""
        def index_of(name: str) -> int | None:
            return self._names.index(name) if name in self._name_set else None

        joint = check_joint(spec, "", index_of, len(self), self.position)
        return self._add_joint(joint)

    def _add_joint(self, *joints: JointSpec) -> int:
        """Add validated JointSpecs (``Scene.build`` passes all of a scene's at once);
        returns the index of the last."""
        j = self._joints.add(list(joints), self._view("com"), self._view("angle"))
        for body in {b for joint in joints for b in joint.bodies if b >= 0}:
            self._wake_touching(body)
        return j

    def remove_joint(self, j: int) -> None:
        """Remove joint ``j``; later joints move down one index. Its bodies' islands wake."""
        spec = self._joints.remove(j)
        for body in spec.bodies:
            if body >= 0:
                self._wake_touching(body)

    @property
    def joints(self) -> list[dict]:
        """The joints' specs as given to ``add_joint`` or in the scene, in index order."""
        return [dict(s.data) for s in self._joints.specs]

    def _reactions(self) -> tuple[np.ndarray, np.ndarray]:
        from .solver.joints import joint_reactions

        return joint_reactions(self._view("com"), self._view("angle"), self._joints.rows,
                               self.settings.dt / self.settings.substeps)

    @property
    def joint_force(self) -> np.ndarray:
        """(J, 2) N: the force each joint applied to its first body in the last substep of
        the last step (the second body feels the opposite)."""
        return self._reactions()[0]

    @property
    def joint_torque(self) -> np.ndarray:
        """(J,) N m, counter-clockwise: the torque each joint's angular rows (motor, limits,
        a weld's or prismatic's angle) applied to its first body in the last substep."""
        return self._reactions()[1]

    def joint_anchors(self) -> tuple[np.ndarray, np.ndarray]:
        """(first, second): (J, 2) m each, the world points where each joint holds its first
        and second body now (equal for an ideal revolute or weld joint; a mouse joint's
        second point is its target; a motor joint's are the first body's centre of mass
        and where the second body wants it)."""
        rows = self._joints.rows
        com, angle = self._view("com"), self._view("angle")

        def anchor(body: np.ndarray, local: np.ndarray) -> np.ndarray:
            out = local.copy()
            on = body >= 0
            c, s = np.cos(angle[body[on]]), np.sin(angle[body[on]])
            out[on] = com[body[on]] + np.column_stack([c * local[on, 0] - s * local[on, 1],
                                                       s * local[on, 0] + c * local[on, 1]])
            return out

        return anchor(rows.body_b, rows.local_b), anchor(rows.body_a, rows.local_a)

    def set_joint_target(self, j: int, target: Sequence[float]) -> None:
        """Move mouse joint ``j``'s target to the world point ``target`` (m); its body wakes."""
        from .solver.joints import MOUSE

        rows = self._joints.rows
        if not -len(rows) <= j < len(rows) or rows.kind[j] != MOUSE:
            raise SpecError("joint", f"{j} is not a mouse joint")
        rows.local_a[j] = _point(target, "target")
        self._wake_touching(int(rows.body_b[j]))
