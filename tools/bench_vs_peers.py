"""Speed and accuracy of sdfphys against pymunk and Box2D v3 on the same scenes, in one process.

Engines: sdfphys at its default Settings (``--set KNOB=VALUE`` overrides any knob); pymunk
(Chipmunk2D) at its defaults (10 iterations, collision_slop 0.1); Box2D v3 through pyb2d3,
single thread, at its defaults with 4 substeps ("box2d") and again with 16 substeps and
contact hertz 120 (``set_contact_tuning(120, 10, 3)``: "box2d-16", the row of about equal
accuracy). Box2D's sleeping stays at its default (on) unless ``--no-sleep``, which turns it
off and sets sdfphys's ``sleeping`` knob to false where Settings has one; pymunk's sleeping
is off by default. The ``sleep`` column reads each engine's setting back ("none": the
engine has no sleeping). Without pyb2d3 the Box2D rows are left out.

Scenes (gravity -9.81 m/s^2; every engine steps the sdfphys Settings' dt, 1/60 s by
default; ``--seconds``, 5 by default, of simulated time):

- ``pileN``: N circles (radius 0.5 m, density 1, friction 0.5) on a jittered grid, dropped
  into a static box (ground and two walls); by default N = 500, 2000, 5000.
- ``pyramidB``: a pyramid of unit boxes (density 1, friction 0.6, as the stability suite's
  pyramids in tests/stability) with B boxes in its bottom row on a static ground whose top
  face is y = 0; by default B = 20 (210 boxes) and 100 (5,050 boxes).
- ``showcase``: scenes/showcase.toml, whose SDF bodies the peers cannot model: sdfphys only
  (n/a for the peers). The scene's own [sim] table is replaced by the tool's Settings.

The contact sees the same friction in every engine: sdfphys and Box2D mix two shapes'
coefficients as sqrt(a b), pymunk as a b, so pymunk's shapes get sqrt(mu).

Speed: time.perf_counter around each step call of a fresh world, from step 0. Reported:
mean, p95 and max ms per step over the timed run, and its total seconds (the sum over its
steps). Compilation is not timed: before a scene's runs, sdfphys steps the scene once
(kernels chosen by the body count) and then a small world of the same kinds (20 circles; a
base-3 pyramid; the showcase itself) as many steps as a run, with a copy of each moving
shape falling into it at 50 m/s (time of impact), so that every numba kernel is compiled or
loaded from the cache; a warning is printed if one still is during a timed run.

Accuracy, measured the same way for every engine: every K steps (``--every``) and after the
last step, outside the timed calls, the engine's poses are put into
sdfphys.collide.find_contacts (default Settings) with the scene's shapes; the deepest
overlap over the run is reported (mm). For the pyramids also the top box's displacement
from its start after the run (mm).

Runs: with ``--runs R`` each scene is run R times, the engines back to back within a run
(sdfphys, pymunk, box2d, box2d-16), so that a ratio compares runs under the same machine
load. Each figure is the median over the runs; "sdfphys/x" is the median of the per-run
ratios of sdfphys's mean ms per step to that engine's.

Usage: python tools/bench_vs_peers.py [--scenes pile500 pile2000 pile5000 pyramid20
    pyramid100 showcase] [--seconds 5] [--runs 1] [--every 10] [--set KNOB=VALUE ...]
    [--no-sleep] [--markdown FILE]
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import platform
import re
import statistics
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from importlib import metadata
from pathlib import Path
from typing import NamedTuple, Protocol

import numpy as np
import pymunk
from numba.core.event import install_recorder

from sdfphys.collide import find_contacts
from sdfphys.errors import SpecError
from sdfphys.scene import apply_overrides, read_scene
from sdfphys.settings import Settings
from sdfphys.shapes import Shape
from sdfphys.world import World

try:
    import pyb2d3
except ImportError:
    pyb2d3 = None

SHOWCASE = Path(__file__).resolve().parents[1] / "scenes" / "showcase.toml"
DEFAULT_SCENES = ["pile500", "pile2000", "pile5000", "pyramid20", "pyramid100", "showcase"]
#: Size of the small world of each scene kind that compiles the kernels (module doc).
WARM_UP_SIZE = {"pile": 20, "pyramid": 3, "showcase": 0}
#: Speed (m/s) of the warm-up's fast bodies: more than any body reaches in the scenes (the
#: top row of the 5,000-circle pile lands at about 39 m/s), so that time of impact runs.
FAST = 50.0
ENGINES = ("sdfphys", "pymunk", "box2d", "box2d-16")
#: Box2D rows: substeps and contact tuning (hertz, damping ratio, push-out m/s; None: defaults).
BOX2D = {"box2d": (4, None), "box2d-16": (16, (120.0, 10.0, 3.0))}
PROBE_SETTINGS = Settings()

GRAVITY = -9.81
DENSITY = 1.0
RADIUS = 0.5              # pile circles, m
PILE_FRICTION = 0.5       # the pile of the former tools/bench_vs_pymunk.py
SPACING = 1.1             # pile grid pitch, m
WALL = 1.0                # pile ground and wall thickness, m
BOX_FRICTION = 0.6        # stability_common.MU
GROUND = 20.0             # pyramid ground thickness, m (stability_common.ground_world)

COLUMNS = ("scene", "bodies", "engine", "sleep", "mean ms", "p95 ms", "max ms", "total s",
           "deepest mm", "top mm", "sdfphys/x")


# ---------------------------------------------------------------------------------------
# Scenes
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Body:
    """A body every engine can build: a circle or a box centred on the body's origin."""

    shape: dict                      # sdfphys spec: circle (radius) or box (size)
    position: tuple[float, float]
    friction: float                  # the coefficient a contact of two such bodies sees
    static: bool = False


@dataclass(frozen=True)
class Layout:
    """The bodies of a scene in build order; ``top``: the body whose displacement counts."""

    bodies: tuple[Body, ...]
    top: int | None = None


def parse_scene(name: str) -> tuple[str, int]:
    """(kind, size) of a scene name: ``pile<N>``, ``pyramid<B>`` or ``showcase`` (size 0)."""
    if name == "showcase":
        return "showcase", 0
    match = re.fullmatch(r"(pile|pyramid)([1-9][0-9]*)", name)
    if match is None:
        raise ValueError(f"unknown scene {name!r}: pile<N>, pyramid<B> or showcase")
    return match[1], int(match[2])


def make_layout(kind: str, size: int) -> Layout | None:
    """The Layout of a scene kind at ``size``; None for the showcase (sdfphys only)."""
    if kind == "pile":
        return pile(size)
    if kind == "pyramid":
        return pyramid(size)
    return None


def pile(n: int, seed: int = 1) -> Layout:
    """``n`` circles on a jittered grid above the ground of a static box (module doc)."""
    columns = math.ceil(math.sqrt(n))
    width = columns * SPACING + 1.0
    rng = np.random.default_rng(seed)
    i = np.arange(n)
    x = (i % columns - (columns - 1) / 2) * SPACING + rng.uniform(-0.04, 0.04, n)
    y = RADIUS + 0.5 + (i // columns) * SPACING
    height = float(y.max()) + 2.0
    walls = [(0.0, -WALL / 2, width + 2 * WALL, WALL),
             (-(width + WALL) / 2, height / 2, WALL, height),
             ((width + WALL) / 2, height / 2, WALL, height)]
    statics = [Body({"type": "box", "size": [w, h]}, (cx, cy), PILE_FRICTION, static=True)
               for cx, cy, w, h in walls]
    circle = {"type": "circle", "radius": RADIUS}
    circles = [Body(circle, (float(a), float(b)), PILE_FRICTION) for a, b in zip(x, y)]
    return Layout(tuple(statics + circles))


def pyramid(base: int) -> Layout:
    """Unit boxes in rows of base, base - 1, ..., 1 on the ground (stability_common's
    pyramid_cells and ground_world); the top box is the last body."""
    ground = Body({"type": "box", "size": [4.0 * base + 20.0, GROUND]}, (0.0, -GROUND / 2),
                  BOX_FRICTION, static=True)
    unit = {"type": "box", "size": [1.0, 1.0]}
    boxes = [Body(unit, (i - (base - 1 - row) / 2, 0.5 + row), BOX_FRICTION)
             for row in range(base) for i in range(base - row)]
    return Layout((ground, *boxes), top=len(boxes))


# ---------------------------------------------------------------------------------------
# Engines
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Config:
    """What every run of the benchmark shares."""

    settings: Settings
    steps: int
    runs: int = 1
    every: int = 10
    sleep: bool = True


class Run(Protocol):
    """A fresh world of one engine: ``step`` advances it by dt; ``poses`` gives every body's
    centre (B, 2) and angle (B,) in layout order; ``sleeping``: its sleeping setting as
    read back from the engine ("on", "off"; "none": the engine has no sleeping)."""

    sleeping: str

    def step(self) -> None: ...

    def poses(self) -> tuple[np.ndarray, np.ndarray]: ...


def on_off(flag: bool | None) -> str:
    """A sleeping setting as the table prints it (None: the engine has none)."""
    return "none" if flag is None else "on" if flag else "off"


def sdfphys_world(layout: Layout | None, settings: Settings) -> World:
    """A World of ``layout`` (None: the showcase scene) with ``settings``."""
    if layout is None:
        return replace(read_scene(SHOWCASE), settings=settings).build()
    world = World(gravity=(0.0, GRAVITY), settings=settings)
    for b in layout.bodies:
        world.add_body(b.shape, position=b.position, kind="static" if b.static else "dynamic",
                       density=DENSITY, friction=b.friction)
    return world


class SdfphysRun:
    """An sdfphys World as a Run."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.sleeping = on_off(getattr(world.settings, "sleeping", None))

    def step(self) -> None:
        self.world.step()

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        return self.world.center_of_mass, self.world.angle


def pymunk_body(space: pymunk.Space, spec: Body) -> pymunk.Body:
    """``spec`` added to ``space`` (friction sqrt(mu): pymunk multiplies the two shapes')."""
    body = pymunk.Body(body_type=pymunk.Body.STATIC if spec.static else pymunk.Body.DYNAMIC)
    body.position = spec.position
    if spec.shape["type"] == "circle":
        shape = pymunk.Circle(body, spec.shape["radius"])
    else:
        shape = pymunk.Poly.create_box(body, tuple(spec.shape["size"]), radius=0.0)
    if not spec.static:
        shape.density = DENSITY
    shape.friction = math.sqrt(spec.friction)
    space.add(body, shape)
    return body


class PymunkRun:
    """A layout in a pymunk Space at its defaults."""

    def __init__(self, layout: Layout, dt: float) -> None:
        self.space = pymunk.Space()
        self.space.gravity = (0.0, GRAVITY)
        self.bodies = [pymunk_body(self.space, b) for b in layout.bodies]
        self.dt = dt
        self.sleeping = on_off(math.isfinite(self.space.sleep_time_threshold))

    def step(self) -> None:
        self.space.step(self.dt)

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([tuple(b.position) for b in self.bodies]),
                np.array([b.angle for b in self.bodies]))


def box2d_body(world: pyb2d3.World, spec: Body) -> pyb2d3.Body:
    """``spec`` created in ``world`` (Box2D mixes friction as sqrt(a b), as sdfphys)."""
    create = world.create_static_body if spec.static else world.create_dynamic_body
    body = create(position=spec.position)
    shape_def = pyb2d3.shape_def(density=DENSITY,
                                 material=pyb2d3.surface_material(friction=spec.friction))
    if spec.shape["type"] == "circle":
        body.create_circle_shape(shape_def, pyb2d3.circle(radius=spec.shape["radius"]))
    else:
        w, h = spec.shape["size"]
        body.create_polygon_shape(shape_def, pyb2d3.box(w / 2, h / 2))
    return body


class Box2dRun:
    """A layout in a single-threaded Box2D world at its defaults but for ``engine``'s
    substeps and contact tuning (BOX2D); sleeping turned off unless ``sleep``. The world
    destroys its bodies when collected: it lives as long as this Run."""

    def __init__(self, layout: Layout, dt: float, engine: str, sleep: bool) -> None:
        self.substeps, tuning = BOX2D[engine]
        self.world = pyb2d3.World(gravity=(0.0, GRAVITY))
        if tuning is not None:
            self.world.set_contact_tuning(*tuning)
        if not sleep:
            self.world.sleeping_enabled = False
        self.bodies = pyb2d3.Bodies()
        for spec in layout.bodies:
            self.bodies.append(box2d_body(self.world, spec).id)
        self.dt = dt
        self.sleeping = on_off(self.world.sleeping_enabled)

    def step(self) -> None:
        self.world.step(self.dt, self.substeps)

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        rotation = self.bodies.get_rotations()        # (cos, sin) per body, float32
        return (self.bodies.get_positions().astype(np.float64),
                np.arctan2(rotation[:, 1], rotation[:, 0]).astype(np.float64))


def start(engine: str, layout: Layout | None, config: Config) -> Run | None:
    """A fresh Run of ``engine`` on ``layout``; None if the engine cannot model the scene."""
    if engine == "sdfphys":
        return SdfphysRun(sdfphys_world(layout, config.settings))
    if layout is None:
        return None
    if engine == "pymunk":
        return PymunkRun(layout, config.settings.dt)
    return Box2dRun(layout, config.settings.dt, engine, config.sleep)


def available_engines() -> tuple[str, ...]:
    """ENGINES without the Box2D rows when pyb2d3 is missing."""
    return ENGINES if pyb2d3 is not None else ENGINES[:2]


# ---------------------------------------------------------------------------------------
# Measuring
# ---------------------------------------------------------------------------------------


class Probe(NamedTuple):
    """A scene's shapes for sdfphys.collide.find_contacts, in layout order."""

    shapes: list[Shape]
    shape_id: np.ndarray
    movable: np.ndarray


def probe_of(world: World) -> Probe:
    """The Probe of ``world``'s bodies."""
    return Probe(world.shapes, world.shape_id, world.kind == "dynamic")


def deepest(probe: Probe, centre: np.ndarray, angle: np.ndarray) -> float:
    """The deepest overlap (m) of the bodies at these poses, 0 if none overlap."""
    contacts = find_contacts(probe.shapes, probe.shape_id, centre, angle, probe.movable,
                             PROBE_SETTINGS)
    return float(contacts.depth.max(initial=0.0))


@dataclass(frozen=True)
class Figures:
    """One timed run: ms per step, total s, deepest overlap and top displacement (mm; nan
    without a top body)."""

    mean_ms: float
    p95_ms: float
    max_ms: float
    total_s: float
    deepest_mm: float
    top_mm: float


def measure(run: Run, steps: int, probe: Probe, every: int, top: int | None,
            label: str = "") -> Figures:
    """Step ``run`` ``steps`` times, timing each step and probing every ``every`` steps;
    warns (naming ``label``) if numba compiled or loaded a kernel meanwhile."""
    start_centre = run.poses()[0]
    times = np.empty(steps)
    worst = 0.0
    with install_recorder("numba:compiler_lock") as compiles:
        for k in range(1, steps + 1):
            t0 = time.perf_counter()
            run.step()
            times[k - 1] = time.perf_counter() - t0
            if k % every == 0 or k == steps:
                worst = max(worst, deepest(probe, *run.poses()))
    if compiles.buffer:
        print(f"warning: numba compiled or loaded kernels during the timed run ({label})",
              file=sys.stderr, flush=True)
    top_mm = math.nan
    if top is not None:
        top_mm = 1e3 * float(np.linalg.norm(run.poses()[0][top] - start_centre[top]))
    return Figures(1e3 * float(times.mean()), 1e3 * float(np.percentile(times, 95)),
                   1e3 * float(times.max()), float(times.sum()), 1e3 * worst, top_mm)


def warm_up(kind: str, size: int, config: Config) -> None:
    """Compile or load every sdfphys kernel the scene needs, untimed (module doc): the scene
    stepped once (kernels chosen by the body count, e.g. the grid broadphase), then a small
    world of the same kinds, with a fast copy of each moving shape falling into it (time of
    impact), stepped ``config.steps`` times (pairs that meet later)."""
    sdfphys_world(make_layout(kind, size), config.settings).step()
    small = make_layout(kind, WARM_UP_SIZE[kind])
    world = sdfphys_world(small, config.settings)
    moving = [] if small is None else [b.shape for b in small.bodies if not b.static]
    for k, shape in enumerate(s for i, s in enumerate(moving) if s not in moving[:i]):
        world.add_body(shape, position=(0.0, 10.0 + 2.0 * k), velocity=(0.0, -FAST))
    for _ in range(config.steps):
        world.step()
    deepest(probe_of(world), world.center_of_mass, world.angle)


@dataclass
class Row:
    """One engine on one scene: its Figures per run and, per run, the ratio of sdfphys's
    mean ms per step to its own (none for sdfphys)."""

    scene: str
    bodies: int
    engine: str
    sleeping: str = "n/a"
    runs: list[Figures] = field(default_factory=list)
    ratios: list[float] = field(default_factory=list)

    def median(self, name: str) -> float:
        """The median over the runs of the Figures field ``name``."""
        return statistics.median(getattr(f, name) for f in self.runs)


def bench_scene(name: str, config: Config, engines: Sequence[str]) -> list[Row]:
    """Every engine of ``engines`` on scene ``name``, ``config.runs`` times interleaved."""
    kind, size = parse_scene(name)
    layout = make_layout(kind, size)
    warm_up(kind, size, config)
    probe = probe_of(sdfphys_world(layout, config.settings))
    top = None if layout is None else layout.top
    rows = {e: Row(name, int(probe.movable.sum()), e) for e in engines}
    for _ in range(config.runs):
        for engine, row in rows.items():
            run = start(engine, layout, config)
            if run is None:
                continue
            gc.collect()
            row.sleeping = run.sleeping
            row.runs.append(measure(run, config.steps, probe, config.every, top,
                                    f"{name}, {engine}"))
        ours = rows["sdfphys"].runs[-1].mean_ms
        for row in rows.values():
            if row.engine != "sdfphys" and row.runs:
                row.ratios.append(ours / row.runs[-1].mean_ms)
    return list(rows.values())


# ---------------------------------------------------------------------------------------
# Report
# ---------------------------------------------------------------------------------------


def number(value: float) -> str:
    """Three significant figures below 1000, whole numbers from 1000; "-" for nan."""
    if math.isnan(value):
        return "-"
    return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"


def cells(row: Row) -> list[str]:
    """The table cells of ``row`` (COLUMNS)."""
    head = [row.scene, str(row.bodies), row.engine, row.sleeping]
    if not row.runs:
        return head + ["n/a"] * (len(COLUMNS) - len(head))
    names = ("mean_ms", "p95_ms", "max_ms", "total_s", "deepest_mm", "top_mm")
    ratio = number(statistics.median(row.ratios)) if row.ratios else "-"
    return head + [number(row.median(n)) for n in names] + [ratio]


def text_line(values: Sequence[str]) -> str:
    """A row of the console table."""
    widths = (10, 6, 8, 5, 8, 8, 8, 8, 10, 8, 9)
    first = f"{values[0]:<{widths[0]}} {values[1]:>{widths[1]}} {values[2]:<{widths[2]}} "
    return first + " ".join(f"{v:>{w}}" for v, w in zip(values[3:], widths[3:]))


def markdown(rows: Sequence[Row], header: Sequence[str]) -> str:
    """The header lines and the table as markdown."""
    lines = [line + "  " for line in header] + ["", "| " + " | ".join(COLUMNS) + " |",
                                                 "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(cells(row)) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def version(package: str) -> str:
    """Installed version of ``package``."""
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "not installed"


def header(config: Config) -> list[str]:
    """What the run was: versions, machine, scene length, the engines' settings."""
    default = Settings()
    changed = [f"{n}={getattr(config.settings, n)}" for n in Settings.names()
               if getattr(config.settings, n) != getattr(default, n)]
    box2d = ("Box2D v3 (pyb2d3): single thread, defaults (4 substeps, contact 30 Hz); "
             "box2d-16: 16 substeps, contact 120 Hz" if pyb2d3 is not None
             else "box2d: not installed (pip install pyb2d3)")
    box2d_version = version("pyb2d3") if pyb2d3 is not None else "not installed"
    versions = (f"sdfphys {version('sdfphys')}, numba {version('numba')}, pymunk "
                f"{version('pymunk')}, pyb2d3 {box2d_version}; Python "
                f"{platform.python_version()}, {platform.system()} {platform.machine()}, "
                f"{os.cpu_count()} CPUs")
    length = (f"dt {config.settings.dt:.6g} s, {config.steps} steps per run, {config.runs} "
              f"run(s), overlap probed every {config.every} steps; medians over runs")
    ours = "sdfphys: default Settings" + (f" with {', '.join(changed)}" if changed else "")
    return [versions, length, ours,
            box2d + ("; sleeping off (--no-sleep)" if not config.sleep else "")]


def sdfphys_settings(items: Sequence[str], no_sleep: bool) -> Settings:
    """Default Settings with ``KNOB=VALUE`` items (TOML values) and ``--no-sleep`` applied."""
    values = apply_overrides({}, items)
    if no_sleep and "sleeping" in Settings.names():
        values["sleeping"] = False
    return Settings().with_values(**{k: Settings.check(k, v, f"--set {k}")
                                     for k, v in values.items()})


def parse_args(argv: Sequence[str] | None) -> tuple[argparse.Namespace, Config]:
    """Command line -> (arguments, Config); exits with a message on a bad value."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=DEFAULT_SCENES,
                        help="pile<N>, pyramid<B>, showcase (default: %(default)s)")
    parser.add_argument("--seconds", type=float, default=5.0, help="simulated s per run")
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--every", type=int, default=10, help="steps between overlap probes")
    parser.add_argument("--set", action="append", default=[], metavar="KNOB=VALUE",
                        help="override an sdfphys Settings knob (repeatable)")
    parser.add_argument("--no-sleep", action="store_true",
                        help="sleeping off in Box2D (and in sdfphys once it has the knob)")
    parser.add_argument("--markdown", type=Path, metavar="FILE",
                        help="also write the table as markdown")
    args = parser.parse_args(argv)
    try:
        settings = sdfphys_settings(args.set, args.no_sleep)
        for name in args.scenes:
            parse_scene(name)
    except (SpecError, KeyError, ValueError) as err:
        parser.error(str(err))
    if args.seconds <= 0 or args.runs < 1 or args.every < 1:
        parser.error("--seconds must be > 0, --runs and --every >= 1")
    steps = max(1, round(args.seconds / settings.dt))
    return args, Config(settings, steps, args.runs, args.every, not args.no_sleep)


def main(argv: Sequence[str] | None = None) -> None:
    """Run the benchmark and print (and optionally write) the table."""
    args, config = parse_args(argv)
    lines = header(config)
    print("\n".join(lines))
    print(text_line(COLUMNS), flush=True)
    rows: list[Row] = []
    for name in args.scenes:
        for row in bench_scene(name, config, available_engines()):
            print(text_line(cells(row)), flush=True)
            rows.append(row)
    if args.markdown is not None:
        args.markdown.write_text(markdown(rows, lines))


if __name__ == "__main__":
    main()
