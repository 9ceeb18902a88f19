"""Scene files (TOML, ``version = 1``) and dicts of the same shape -> validated Scene -> World.

The format is the DESIGN.md contract::

    version = 1
    [world]   gravity = [0.0, -9.81]
    [sim]     quality = "balanced", duration = 5.0, and any Settings knob by name
    [render]  size = [960, 540], center = [0.0, 4.0], scale = 50.0, fps = 60
    [[body]]  name, shape, position, angle, velocity, angular_velocity,
              density | mass, friction, restitution, static, kinematic,
              category, mask, group, sensor, gravity_scale (docs/toolkit.md)
    [[joint]] type, name, bodies, anchor | anchors, axis, length, limits, motor,
              spring, collide_connected (``sdfphys.joints``)
    [[explode]] time, center, radius, impulse (``World.explode_at``: a blast at the
              start of the first step at or after ``time``; docs/toolkit.md)
    [[carve]] time, body, field, position, angle, deposit
              (``sdfphys.terrain``, docs/terrain.md)

An image field's ``path`` (``{type = "image", ...}``) is relative to the scene file.

Every problem raises one ``SpecError`` naming the file and the key path
(``scenes/x.toml: body[2].shape.radius: must be > 0, got -1``), with the nearest
known key suggested for a typo. Reading a scene never runs code: TOML is parsed
by ``tomllib`` and every value is checked against a fixed table of keys.
"""

from __future__ import annotations

import hashlib
import json
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, NamedTuple

from .blasts import Blast, check_blast
from .errors import SpecError, check_int, check_number, check_vec2
from .joints import JointSpec, check_joint
from .limits import (
    MAX_BITS,
    MAX_DURATION,
    BodyValues,
    check_angle,
    check_body,
    check_flag,
    check_gravity,
    check_position,
)
from .sdf.build import field as build_field
from .sdf.build import suggest
from .settings import Settings, preset
from .shapes import shape_from_spec
from .terrain import Edit, schedule

__all__ = ["BodySpec", "RenderSpec", "Scene", "apply_overrides", "load_scene", "read_scene",
           "read_scene_file"]

TOP_KEYS = ("version", "world", "sim", "render", "body", "joint", "explode", "carve")
WORLD_KEYS = ("gravity",)
RENDER_KEYS = ("size", "center", "scale", "fps", "hud")
BODY_KEYS = ("name", "shape", "position", "angle", "velocity", "angular_velocity",
             "density", "mass", "friction", "restitution", "static", "kinematic",
             "category", "mask", "group", "sensor", "gravity_scale")
SIM_EXTRA_KEYS = ("quality", "duration")
EXPLODE_KEYS = ("time", "center", "radius", "impulse")
CARVE_KEYS = ("time", "body", "field", "position", "angle", "deposit")


@dataclass(frozen=True)
class RenderSpec:
    """Frame size (px, even), world point at the frame centre (m), px per metre, frames/s,
    and ``hud``: print the simulated time and step count on every video frame."""

    size: tuple[int, int] = (960, 540)
    center: tuple[float, float] = (0.0, 4.0)
    scale: float = 50.0
    fps: int = 60
    hud: bool = False


class BodySpec(NamedTuple):
    """One validated ``[[body]]`` entry (SI units; ``shape`` the Shape built from its dict)."""

    name: str
    shape: Any
    position: tuple[float, float] = (0.0, 0.0)
    angle: float = 0.0
    velocity: tuple[float, float] = (0.0, 0.0)
    angular_velocity: float = 0.0
    density: float = 1.0
    mass: float | None = None
    friction: float = 0.5
    restitution: float = 0.0
    kind: str = "dynamic"
    category: int = 1
    mask: int = MAX_BITS
    group: int = 0
    sensor: bool = False
    gravity_scale: float = 1.0


@dataclass
class Scene:
    """A validated scene: what ``build()`` turns into a World, plus run and render settings."""

    source: str
    gravity: tuple[float, float]
    quality: str
    settings: Settings
    duration: float
    render: RenderSpec
    bodies: list[BodySpec]
    joints: list[JointSpec] = field(default_factory=list)
    blasts: list[Blast] = field(default_factory=list)
    carves: list[Edit] = field(default_factory=list)
    """The ``[[carve]]`` tables (``terrain.Edit``, body by index), scheduled by ``build``."""
    data: dict = field(default_factory=dict, repr=False)
    """The scene as read (after overrides), for ``digest``."""

    @cached_property
    def digest(self) -> str:
        """SHA-256 of the scene's canonical JSON form without its ``[render]`` table
        (trajectory files record it; drawing never changes a trajectory)."""
        physics = {key: value for key, value in self.data.items() if key != "render"}
        return hashlib.sha256(
            json.dumps(physics, sort_keys=True, default=str).encode()).hexdigest()

    def build(self):
        """A fresh World with every body added in scene order."""
        from . import _warm
        from .world import World
        from .world_bodies import add

        _warm.start_early(self)     # before the SDF bodies' quadratures compile the fields
        world = World(gravity=self.gravity, settings=self.settings)
        for b in self.bodies:
            values = BodyValues(*b[2:11], 0.0, 0.0, *b[11:])
            try:     # an SDF shape integrates its mass properties on first use, here
                add(world, b.shape, values, b.name)     # values checked by _parse_body
            except SpecError as err:
                raise err.in_file(self.source) from None
        if self.joints:
            world._add_joint(*self.joints)
        for blast in self.blasts:
            world.explode_at(*blast)
        if self.carves:
            schedule(world, self.carves)
        world.scene = self
        return world


def load_scene(scene: str | Path | Mapping, overrides: Sequence[str] = ()):
    """The World of a scene file or dict (DESIGN.md's ``sdfphys.load_scene``)."""
    return read_scene(scene, overrides).build()


def read_scene(scene: str | Path | Mapping, overrides: Sequence[str] = (),
               quality: str | None = None) -> Scene:
    """Parse and validate a scene file or dict; ``overrides`` are ``KEY=VALUE`` strings
    (e.g. ``sim.substeps=8``) applied before validation; ``quality`` overrides the preset."""
    if isinstance(scene, Mapping):     # copied: overrides and quality must not change it
        source = "<scene>"
        data = _deep_copy(scene) if overrides or quality is not None else dict(scene)
    else:
        source = str(scene)
        data = read_scene_file(scene)
    try:
        data = apply_overrides(data, overrides)
        if quality is not None:
            data.setdefault("sim", {})
            if isinstance(data["sim"], dict):
                data["sim"]["quality"] = quality
        parsed = _parse(data, source)
    except SpecError as err:
        raise err.in_file(source) from None
    parsed.data = data
    return parsed


def read_scene_file(path: str | Path) -> dict:
    """The TOML of the scene file at ``path``, not yet validated (a SpecError naming the
    file if it cannot be read or parsed)."""
    source = str(path)
    try:
        with open(path, "rb") as handle:
            return tomllib.load(handle)
    except FileNotFoundError:
        raise SpecError("", "no such scene file", source) from None
    except IsADirectoryError:
        raise SpecError("", "is a directory, not a scene file", source) from None
    except tomllib.TOMLDecodeError as err:
        raise SpecError("", f"not valid TOML: {err}", source) from None
    except (OSError, UnicodeDecodeError) as err:
        raise SpecError("", f"cannot be read: {err}", source) from None


def apply_overrides(data: dict, overrides: Sequence[str]) -> dict:
    """``data`` with each ``KEY=VALUE`` set: a dotted key and a TOML value
    (``sim.dt=0.01``). A body is named by its name or its index: ``body.ball.friction=0.1``,
    ``body[1].friction=0.1`` or ``body.1.friction=0.1`` (a body without a name is
    ``body<i>``, as in the World)."""
    for item in overrides:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise SpecError("--set", f"expected KEY=VALUE, got {item!r}")
        try:
            value = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            value = text.strip()           # a bare word: a string such as quality=fast
        parts = _key_parts(key.strip())
        node: Any = data
        for k, part in enumerate(parts[:-1]):
            if isinstance(node, list):
                node = node[_list_index(node, part, ".".join(map(str, parts[:k])))]
            else:
                node = node.setdefault(part, {})
            if not isinstance(node, (dict, list)):
                raise SpecError(key, "cannot set a key inside a non-table value")
        if isinstance(node, list):
            raise SpecError(key, "names a whole [[body]]; set one of its keys, e.g. "
                                 f"{key}.friction=0.5")
        node[parts[-1]] = value
    return data


def _key_parts(key: str) -> list[str]:
    """``body[1].shape.radius`` -> ``["body", "1", "shape", "radius"]``."""
    return [p for p in key.replace("[", ".").replace("]", "").split(".") if p != ""] or [key]


def _list_index(items: list, part: str, where: str) -> int:
    """The index of the entry of ``items`` (a ``[[body]]`` array) named ``part``, or
    numbered ``part``."""
    names = [entry.get("name", f"body{i}") if isinstance(entry, dict) else f"body{i}"
             for i, entry in enumerate(items)]
    if part in names:
        return names.index(part)
    if part.isdigit() and int(part) < len(items):
        return int(part)
    if part.isdigit():
        raise SpecError(f"--set {where}[{part}]", f"no such body: the scene has "
                                                  f"{len(items)}, numbered from 0")
    raise SpecError(f"--set {where}.{part}", f"no body named {part!r}" + suggest(part, names))


def _deep_copy(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _deep_copy(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_deep_copy(v) for v in value]
    return value


def _table(data: Any, path: str) -> dict:
    if not isinstance(data, Mapping):
        raise SpecError(path, f"must be a table, got {data!r}")
    return dict(data)


def _known(table: Mapping, keys: Sequence[str], path: str) -> None:
    for key in table:
        if key not in keys:
            where = f"{path}.{key}" if path else str(key)
            raise SpecError(where, "unknown key" + suggest(str(key), list(keys)))


def _event_tables(items: Any, name: str, keys: Sequence[str], required: Sequence[str]
                  ) -> list[tuple[str, dict]]:
    """The tables of a scene's ``[[name]]`` array, each as (its key path ``name[i]``, the
    table) once its keys are known and the ``required`` ones present."""
    if not isinstance(items, list):
        raise SpecError(name, f"must be an array of tables ([[{name}]])")
    out = []
    for i, data in enumerate(items):
        path = f"{name}[{i}]"
        table = _table(data, path)
        _known(table, keys, path)
        for key in required:
            if key not in table:
                raise SpecError(f"{path}.{key}", "is required")
        out.append((path, table))
    return out


def _known_sections(data: Mapping) -> None:
    """Every top-level key is a known section or ``version``; a misspelt one gets the
    nearest, also a longer or shorter word (``[simulation]``: did you mean 'sim'?)."""
    for key in data:
        if key in TOP_KEYS:
            continue
        word = str(key).lower()
        hint = suggest(word, list(TOP_KEYS))
        stem = [k for k in TOP_KEYS if len(k) >= 3 and (word.startswith(k) or k.startswith(word))]
        if not hint and stem:
            hint = f" (did you mean {stem[0]!r}?)"
        raise SpecError(str(key), f"unknown key{hint}; a scene has version, [world], [sim], "
                                  "[render], [[body]], [[joint]], [[explode]] and "
                                  "[[carve]]")


def _parse(data: Any, source: str) -> Scene:
    data = _table(data, "")
    _known_sections(data)
    if "version" not in data:
        raise SpecError("version", "is required (version = 1)")
    if data["version"] != 1 or isinstance(data["version"], bool):
        raise SpecError("version", f"must be 1, got {data['version']!r}")

    world = _table(data.get("world", {}), "world")
    _known(world, WORLD_KEYS, "world")
    gravity = check_gravity(world.get("gravity", (0.0, -9.81)), "world.gravity")

    quality, settings, duration = _parse_sim(_table(data.get("sim", {}), "sim"))
    render = _parse_render(_table(data.get("render", {}), "render"))

    bodies_data = data.get("body", [])
    if not isinstance(bodies_data, list):
        raise SpecError("body", "must be an array of tables ([[body]])")
    if not bodies_data:
        raise SpecError("body", "a scene needs at least one [[body]]")
    base = None if source == "<scene>" else Path(source).parent
    bodies = [_parse_body(b, i, base) for i, b in enumerate(bodies_data)]
    seen: dict[str, int] = {}
    for i, b in enumerate(bodies):
        if b.name in seen:
            raise SpecError(f"body[{i}].name",
                            f"duplicate name {b.name!r} (also body[{seen[b.name]}])")
        seen[b.name] = i
    return Scene(source, gravity, quality, settings, duration, render, bodies,
                 _parse_joints(data.get("joint", []), bodies, seen),
                 _parse_blasts(data.get("explode", [])),
                 _parse_carves(data.get("carve", []), bodies, seen, base))


def _parse_blasts(blasts: Any) -> list[Blast]:
    """The ``[[explode]]`` tables (``blasts.check_blast``); every key is required."""
    return [check_blast(path, **table)
            for path, table in _event_tables(blasts, "explode", EXPLODE_KEYS, EXPLODE_KEYS)]


def _image_paths(spec: Any, base: Path | None) -> Any:
    """A copy of the FIELD ``spec`` whose image paths are joined to the directory ``base``
    (the scene file's; None: left relative to the current directory)."""
    if base is None:
        return spec
    if isinstance(spec, Mapping):
        out = {key: _image_paths(value, base) for key, value in spec.items()}
        if out.get("type") == "image" and isinstance(out.get("path"), str):
            out["path"] = str(base / out["path"])
        return out
    if isinstance(spec, list):
        return [_image_paths(value, base) for value in spec]
    return spec


def _parse_carves(carves: Any, bodies: list[BodySpec], index: dict[str, int],
                  base: Path | None) -> list[Edit]:
    """The ``[[carve]]`` tables (``terrain.Edit``): time (s, >= 0), body (a name or an
    index of a bounded body; static or kinematic for a deposit), field (FIELD),
    position (world, m), optional angle (rad) and deposit (bool); a blast there is an
    ``[[explode]]`` table."""
    edits = []
    for path, table in _event_tables(carves, "carve", CARVE_KEYS,
                                     ("time", "body", "field", "position")):
        time = check_number(table["time"], f"{path}.time", low=0.0, high=MAX_DURATION)
        body = table["body"]
        if isinstance(body, str):
            if body not in index:
                raise SpecError(f"{path}.body", f"no body named {body!r}"
                                + suggest(body, list(index)))
            number = index[body]
        else:
            number = check_int(body, f"{path}.body", low=0, high=len(bodies) - 1)
        target = bodies[number]
        deposit = _flag(table, "deposit", path)
        if target.kind == "dynamic" and deposit:
            raise SpecError(f"{path}.body", f"body {target.name!r} is dynamic: only static "
                                            "and kinematic bodies take deposits")
        if not target.shape.bounded:
            raise SpecError(f"{path}.body", f"body {target.name!r} is unbounded (e.g. a "
                                            "half-plane): only a bounded field can be carved")
        carved = build_field(_image_paths(table["field"], base), f"{path}.field")
        position = check_position(table["position"], f"{path}.position")
        angle = check_angle(table.get("angle", 0.0), f"{path}.angle")
        edits.append(Edit(time, number, carved, position, angle, deposit))
    return edits


def _parse_joints(joints: Any, bodies: list[BodySpec], index: dict[str, int]
                  ) -> list[JointSpec]:
    """The ``[[joint]]`` tables, validated against the bodies (``joints.check_joint``)."""
    if not isinstance(joints, list):
        raise SpecError("joint", "must be an array of tables ([[joint]])")
    positions = [b.position for b in bodies]
    specs = [check_joint(j, f"joint[{i}]", index.get, len(bodies), positions)
             for i, j in enumerate(joints)]
    named: dict[str, int] = {}
    for i, spec in enumerate(specs):
        if spec.name and spec.name in named:
            raise SpecError(f"joint[{i}].name",
                            f"duplicate name {spec.name!r} (also joint[{named[spec.name]}])")
        named[spec.name] = i
    return specs


def _parse_sim(sim: dict) -> tuple[str, Settings, float]:
    knobs = Settings.names()
    _known(sim, list(SIM_EXTRA_KEYS) + knobs, "sim")
    quality = sim.get("quality", "balanced")
    try:
        base = preset(quality)
    except KeyError as err:
        raise SpecError("sim.quality", str(err.args[0])) from None
    values = {key: Settings.check(key, value, f"sim.{key}")
              for key, value in sim.items() if key not in SIM_EXTRA_KEYS}
    duration = check_number(sim.get("duration", 5.0), "sim.duration", low=0.0, low_open=True,
                            high=MAX_DURATION)
    return quality, base.with_values(**values), duration


def _parse_render(render: dict) -> RenderSpec:
    _known(render, RENDER_KEYS, "render")
    default = RenderSpec()
    size = render.get("size", default.size)
    if not isinstance(size, (list, tuple)) or len(size) != 2:
        raise SpecError("render.size", f"must be [width, height] in pixels, got {size!r}")
    w = check_int(size[0], "render.size[0]", low=2, high=8192)
    h = check_int(size[1], "render.size[1]", low=2, high=8192)
    center = check_vec2(render.get("center", default.center), "render.center")
    scale = check_number(render.get("scale", default.scale), "render.scale",
                         low=0.0, low_open=True)
    fps = check_int(render.get("fps", default.fps), "render.fps", low=1, high=1000)
    hud = _flag(render, "hud", "render")
    return RenderSpec((w + w % 2, h + h % 2), center, scale, fps, hud)


def _parse_body(data: Any, i: int, base: Path | None = None) -> BodySpec:
    path = f"body[{i}]"
    body = _table(data, path)
    _known(body, BODY_KEYS, path)
    name = body.get("name", f"body{i}")
    if not isinstance(name, str) or not name:
        raise SpecError(f"{path}.name", f"must be a non-empty string, got {name!r}")
    if "shape" not in body:
        raise SpecError(f"{path}.shape", "is required")
    static = _flag(body, "static", path)
    kinematic = _flag(body, "kinematic", path)
    if static and kinematic:
        raise SpecError(f"{path}.kinematic", "a body cannot be both static and kinematic")
    kind = "static" if static else "kinematic" if kinematic else "dynamic"

    shape = body["shape"]
    if isinstance(shape, Mapping) and shape.get("type") == "sdf":     # may hold an image
        shape = _image_paths(shape, base)
    shape = shape_from_spec(shape, f"{path}.shape")
    if kind == "dynamic" and not shape.bounded:       # (no quadrature while parsing)
        raise SpecError(f"{path}.shape", "an unbounded shape (e.g. a half-plane) must be static")
    if "density" in body and "mass" in body:
        raise SpecError(f"{path}.mass", "give density or mass, not both")
    values = check_body(path, kind=kind, **{key: body[key] for key in _VALUE_KEYS
                                            if key in body})
    return BodySpec(name, shape, *values[:9], *values[11:])


#: Body keys whose values ``limits.check_body`` validates.
_VALUE_KEYS = ("position", "angle", "velocity", "angular_velocity", "density", "mass",
               "friction", "restitution", "category", "mask", "group", "sensor",
               "gravity_scale")


def _flag(body: dict, key: str, path: str) -> bool:
    return check_flag(body.get(key, False), f"{path}.{key}")
