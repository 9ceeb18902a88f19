"""The bodies as the renderer sees them: poses, motion state, material and fill colour.

``body_frames`` reads a World (or any object with the same attributes) into
``BodyFrames``: one row per body with its centre of mass, angle, motion and the state
it is coloured by (ASLEEP for a dynamic body of a sleeping island), and its material
(friction, restitution, density; numbered per state in order of first appearance).
``body_colours`` gives each body's fill from a ``render.Palette``: by state and
material, and bodies of one colour alternate between lighter and darker shades in scene
order, so neighbours in a stack differ.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .render import Palette

__all__ = ["ASLEEP", "DYNAMIC", "KINEMATIC", "STATIC", "BodyFrames", "body_colours",
           "body_frames"]

#: Body state codes used by the renderer (``BodyFrames.state``); the colours of each
#: are ``Palette.fills[state]``. ASLEEP: a dynamic body of a sleeping island.
DYNAMIC, STATIC, KINEMATIC, ASLEEP = 0, 1, 2, 3
_MOTION_NAMES = {"dynamic": DYNAMIC, "static": STATIC, "kinematic": KINEMATIC}
#: Golden ratio conjugate: the shade of the k-th body of a colour is frac(k * this), so
#: consecutive bodies (and most bodies a row apart) get clearly different shades.
_SHADE_STEP = 0.6180339887498949


@dataclass
class BodyFrames:
    """Where each body is, as the renderer needs it (one row per body, scene order).

    com: (B, 2) centre of mass, world m (the origin of the shape's body frame).
    angle: (B,) rad, counter-clockwise. motion: (B,) DYNAMIC | STATIC | KINEMATIC.
    shape_id: (B,) index into ``shapes``. state: (B,) the state a body is coloured by
    (its motion, or ASLEEP for a dynamic body of a sleeping island).
    material: (B,) index of the body's material (friction, restitution, density), in
    order of first appearance.
    """

    com: np.ndarray
    angle: np.ndarray
    motion: np.ndarray
    shape_id: np.ndarray
    shapes: list
    state: np.ndarray | None = None
    material: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.state is None:
            self.state = self.motion
        if self.material is None:
            self.material = np.zeros(len(self.motion), np.int64)


def _materials(world: Any, shape_id: np.ndarray, shapes: list,
               state: np.ndarray) -> np.ndarray:
    """(B,) material index of each body: bodies of one state with equal (friction,
    restitution, density) share one, numbered per state in order of first appearance
    (so the first dynamic material takes ``Palette.dynamic``); zeros for worlds
    without materials."""
    friction = getattr(world, "friction", None)
    if friction is None or not len(shape_id):
        return np.zeros(len(shape_id), np.int64)
    area = np.array([s.area if np.isfinite(s.radius) else np.inf for s in shapes])
    with np.errstate(invalid="ignore", divide="ignore"):
        density = np.asarray(world.mass, np.float64) / area[shape_id]
    mantissa, exponent = np.frexp(np.where(np.isfinite(density), density, 0.0))
    density = np.ldexp(np.round(mantissa, 9), exponent)   # 9 digits: mass / area rounds
    rows = np.column_stack([state.astype(np.float64), np.asarray(friction, np.float64),
                            np.asarray(world.restitution, np.float64), density])
    _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")          # materials by first appearance
    owner = state[first[order]]
    rank = np.empty(len(first), np.int64)
    for code in np.unique(owner).tolist():
        mine = owner == code
        rank[order[mine]] = np.arange(int(mine.sum()))
    return rank[inverse.reshape(-1)]


def body_colours(frames: BodyFrames, palette: Palette) -> np.ndarray:
    """(B, 3) uint8 fill colour of each body (see ``Palette``): by state and material,
    the k-th body of one (state, material) darkened by ``palette.shade`` x frac(k 0.618)."""
    count = len(frames.state)
    out = np.zeros((count, 3), np.uint8)
    if not count:
        return out
    key = frames.state.astype(np.int64) * (int(frames.material.max()) + 1) + frames.material
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    start = np.flatnonzero(np.r_[True, sorted_key[1:] != sorted_key[:-1]])
    rank = np.empty(count, np.int64)
    rank[order] = np.arange(count) - np.repeat(start, np.diff(np.r_[start, count]))
    shade = 1.0 - palette.shade * np.mod(rank * _SHADE_STEP, 1.0)
    for k in np.unique(key).tolist():
        group = key == k
        i = int(np.flatnonzero(group)[0])
        base = palette.material_fill(int(frames.state[i]), int(frames.material[i]))
        out[group] = np.clip(base[None, :] * shade[group, None] + 0.5, 0, 255).astype(np.uint8)
    return out


def body_frames(world: Any) -> BodyFrames:
    """The body frames of ``world`` (a ``sdfphys.world.World`` or an object with the same
    attributes): the centre of mass is ``world.center_of_mass`` when the world has it,
    otherwise ``position - R(angle) @ shape.origin``; materials from its ``friction``,
    ``restitution`` and ``mass`` when it has them."""
    angle = np.asarray(world.angle, dtype=np.float64).reshape(-1)
    shape_id = np.asarray(world.shape_id, dtype=np.int64).reshape(-1)
    shapes = list(world.shapes)
    com = getattr(world, "center_of_mass", None)
    if com is None:
        origin = np.array([np.asarray(s.origin, dtype=np.float64) for s in shapes]).reshape(-1, 2)
        o = origin[shape_id] if len(shape_id) else np.zeros((0, 2))
        c, s = np.cos(angle), np.sin(angle)
        position = np.asarray(world.position, dtype=np.float64).reshape(-1, 2)
        com = position - np.stack([c * o[:, 0] - s * o[:, 1], s * o[:, 0] + c * o[:, 1]], 1)
    com = np.asarray(com, dtype=np.float64).reshape(-1, 2)
    kind = np.asarray(world.kind).reshape(-1)
    if kind.dtype.kind in "US":
        motion = np.array([_MOTION_NAMES[str(k)] for k in kind], dtype=np.int64)
    else:
        motion = kind.astype(np.int64)
    state = motion.copy()
    asleep = getattr(world, "asleep", None)
    if asleep is not None:
        state[np.asarray(asleep, bool).reshape(-1) & (motion == DYNAMIC)] = ASLEEP
    return BodyFrames(com, angle, motion, shape_id, shapes, state,
                      _materials(world, shape_id, shapes, state))
