"""The interactive window: ``play(world_factory, render_settings)``.

Keys (``KEYS``; H shows them in the window): P pause / resume, O one step (while
paused), R reset (a new world from the factory), S screenshot (PNG in the current
directory, its name printed), C contacts overlay, F field overlay, B bounds overlay,
H key help, Esc or closing the window quits. The overlays shown have a legend.
Mouse: press the left button on a dynamic body and drag; the grabbed point is
pulled toward the pointer by a soft mouse joint (``DragSpring``, ``grab``). The right button on
any body shows that body's field alone (and turns the field overlay on); on empty
space, the union of all fields again. Hovering shows a readout of the body under the
pointer next to it (``hover_readout``: name, index, kind, mass, velocity and the
pointer's signed distance to it).

Carve tool (K toggles it, docs/terrain.md): a left click carves a disc of the tool's
radius out of the body the disc reaches (``pick_terrain``: the one whose field is
smallest at the pointer; a dynamic body takes the mass left and splits into pieces),
shift + left click deposits one on a static or kinematic body; the wheel sets the
radius (x 1.25 per notch, ``CARVE_RADII``). The pointer shows the disc.

The top line shows frames per second, simulation steps per second, the simulated
time and the state (paused, overlays).

Without a display, ``play`` prints one line saying so and returns 2 (the exit status
for ``sdfphys play``). SDL may silently fall back to its ``offscreen`` or ``dummy``
driver, so the driver in use is checked; tests pass ``allow_headless=True`` together
with a scripted ``events`` source and ``max_frames``.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from .errors import SpecError
from .render import DYNAMIC, Camera, Overlays, Palette, Renderer, body_frames, draw_panel

__all__ = [
    "HEADLESS_DRIVERS",
    "KEYS",
    "DragSpring",
    "RateMeter",
    "RenderSettings",
    "grab",
    "hover_readout",
    "pick_body",
    "play",
]

#: SDL video drivers that have no window a person could see.
HEADLESS_DRIVERS = ("offscreen", "dummy")

#: The keys and mouse buttons, as the help panel (H) lists them.
KEYS = (
    ("P", "pause / resume"),
    ("O", "one step (while paused)"),
    ("R", "reset the scene"),
    ("S", "screenshot (PNG in the current directory)"),
    ("C", "contacts overlay"),
    ("F", "field overlay (union of all bodies)"),
    ("B", "bounding boxes overlay"),
    ("H", "this help"),
    ("Esc", "quit"),
    ("left drag", "pull a dynamic body"),
    ("right click", "a body's own field (empty space: all again)"),
    ("hover", "the body under the pointer: kind, mass, velocity, distance"),
    ("K", "carve tool: click carves a disc, shift+click deposits, wheel: radius"),
)

#: The hover readout shows the nearest body within this many pixels of the pointer.
HOVER_PIXELS = 8.0
#: The carve tool's first radius and its range, m.
CARVE_RADIUS = 0.3
CARVE_RADII = (0.05, 5.0)

CAPTION = "sdfphys   (H: keys)"


class RenderSettings(Protocol):
    """What ``play`` reads from the scene's ``[render]`` table (``scene.RenderSpec``)."""

    size: tuple[int, int]          # window (width, height), px
    center: tuple[float, float]    # world point at the window centre, m
    scale: float                   # px per metre
    fps: int                       # frames per second


@dataclass(frozen=True)
class DragSpring:
    """The mouse joint that pulls a grabbed body (``World.add_joint``, type ``mouse``).

    The grabbed point is pulled toward the pointer by a soft constraint of natural
    frequency ``hertz`` and ``damping_ratio`` (for the body's effective mass at that
    point, so the response does not depend on the mass), solved with the contacts in
    every substep; its force is at most ``weights`` times the body's weight (m |g|,
    with |g| at least 9.81 m/s^2 so that a body can be dragged without gravity): a
    grabbed body pushes others aside but cannot crush a pile under a heavy one.
    """

    hertz: float = 5.0
    """Natural frequency of the pull, Hz (higher: stiffer)."""
    damping_ratio: float = 0.7
    """1 is critical damping; below 1 the body overshoots the pointer."""
    weights: float = 50.0
    """The joint's force bound in the body's weights."""


def grab(world: Any, body: int, point: np.ndarray, spring: DragSpring = DragSpring()) -> int:
    """Add the mouse joint that pulls body ``body``'s material point at world ``point``
    (2,) m (its target: ``point`` until ``World.set_joint_target``); returns its index."""
    weight = float(world.mass[body]) * max(float(np.hypot(*world.gravity)), 9.81)
    return world.add_joint({"type": "mouse", "bodies": [body, "world"],
                            "anchor": [float(point[0]), float(point[1])],
                            "spring": {"hertz": spring.hertz,
                                       "damping_ratio": spring.damping_ratio},
                            "max_force": spring.weights * weight})


def pick_body(world: Any, point: np.ndarray, tolerance: float = 0.0,
              dynamic_only: bool = True) -> int | None:
    """The body under world ``point`` (2,) m: the one whose field is smallest there, if
    that value is <= ``tolerance`` m; None if there is none. Only dynamic bodies
    unless ``dynamic_only`` is False."""
    frames = body_frames(world)
    eligible = (frames.motion == DYNAMIC) if dynamic_only else np.ones(len(frames.com), bool)
    return _smallest_field(frames, point, eligible, tolerance)


def _smallest_field(frames: Any, point: np.ndarray, eligible: np.ndarray,
                    tolerance: float) -> int | None:
    """Among the ``eligible`` (B,) bodies of ``frames`` whose bounding circle reaches
    within ``tolerance`` m of ``point``, the one whose field is smallest there, if it
    is <= ``tolerance``."""
    radius = np.array([float(s.radius) for s in frames.shapes])[frames.shape_id]
    gap = np.hypot(*(frames.com - point).T)
    candidates = np.flatnonzero(eligible & (gap <= radius + tolerance))
    best, best_d = None, tolerance
    for b in candidates.tolist():
        c, s = math.cos(frames.angle[b]), math.sin(frames.angle[b])
        dx, dy = point - frames.com[b]
        local = np.array([[c * dx + s * dy, -s * dx + c * dy]])
        d = float(frames.shapes[frames.shape_id[b]].field.distance(local)[0])
        if d <= best_d:
            best, best_d = b, d
    return best


def hover_readout(world: Any, point: np.ndarray, max_distance: float) -> list[str]:
    """Lines describing the body nearest world ``point`` (2,) m if it lies within
    ``max_distance`` m (``World.point_query``; ties to the lower index): its name and
    index, kind, mass (kg; inf for static and kinematic bodies), velocity of its centre
    of mass (m/s) and the signed distance of ``point`` to it (m, < 0 inside). [] if no
    body is that near."""
    near = world.point_query(np.asarray(point, np.float64)[None, :], max_distance)
    body = int(near.body[0])
    if body < 0:
        return []
    vx, vy = (float(v) for v in world.velocity[body])
    return [f"{world.names[body]}  #{body}  {world.kind[body]}",
            f"mass {float(world.mass[body]):.4g} kg",
            f"velocity ({vx:+.3f}, {vy:+.3f}) m/s",
            f"distance {float(near.distance[0]):+.4f} m"]


def pick_terrain(world: Any, point: np.ndarray, reach: float,
                 dynamic: bool = False) -> int | None:
    """The bounded body whose field is smallest at world ``point`` (2,) m, static or
    kinematic (or dynamic too, with ``dynamic``: a carve, not a deposit), if that value
    is <= ``reach`` m (a disc of that radius there reaches it); None if there is none
    (the carve tool's target)."""
    frames = body_frames(world)
    radius = np.array([float(s.radius) for s in frames.shapes])[frames.shape_id]
    return _smallest_field(frames, point, (dynamic | (frames.motion != DYNAMIC))
                           & np.isfinite(radius), reach)


class RateMeter:
    """Events per second over a sliding window of the last ``window`` frames."""

    def __init__(self, window: int = 30):
        self._marks: deque[tuple[float, int]] = deque(maxlen=window + 1)

    def add(self, count: int, now: float) -> None:
        """Record ``count`` events in the frame that ends at ``now`` (s)."""
        self._marks.append((now, count))

    @property
    def rate(self) -> float:
        """Events per second between the oldest and newest frame kept (0 until two)."""
        if len(self._marks) < 2:
            return 0.0
        elapsed = self._marks[-1][0] - self._marks[0][0]
        events = sum(count for _, count in self._marks) - self._marks[0][1]
        return events / elapsed if elapsed > 0 else 0.0


@dataclass
class _Grab:
    body: int
    joint: int            # the mouse joint's index
    target: np.ndarray    # world, m


class _Session:
    """The state of one interactive session (world, toggles, grab, counters)."""

    def __init__(self, world_factory: Callable[[], Any], settings: RenderSettings,
                 spring: DragSpring):
        self.factory = world_factory
        self.camera = Camera(settings.center, settings.scale, settings.size)
        self.renderer = Renderer(self.camera)
        self.fps = int(settings.fps)
        self.spring = spring
        self.world = world_factory()
        self.paused = False
        self.step_once = False
        self.screenshot = False
        self.running = True
        self.help = False
        self.overlays = Overlays(legend=True)
        self.grab: _Grab | None = None
        self.pointer: np.ndarray | None = None      # world, m: where the mouse last moved
        self.step_rate = RateMeter()
        self.carving = False
        self.carve_radius = CARVE_RADIUS

    @property
    def dt(self) -> float:
        return float(self.world.settings.dt)

    def handle(self, event: pygame.event.Event) -> None:
        if event.type == pygame.MOUSEMOTION:
            self.pointer = self.camera.screen_to_world([event.pos])[0]
        if event.type == pygame.QUIT:
            self.running = False
        elif event.type == pygame.KEYDOWN:
            self._key(event.key)
        elif event.type == pygame.MOUSEWHEEL and self.carving:
            low, high = CARVE_RADII
            self.carve_radius = min(max(self.carve_radius * 1.25 ** event.y, low), high)
        elif event.type == pygame.MOUSEBUTTONDOWN and event.button == 1 and self.carving:
            self._carve(event.pos, bool(pygame.key.get_mods() & pygame.KMOD_SHIFT))
        elif event.type == pygame.MOUSEBUTTONDOWN and event.button == 1:
            point = self.camera.screen_to_world([event.pos])[0]
            body = pick_body(self.world, point, tolerance=3.0 / self.camera.scale)
            if body is not None:
                self.grab = _Grab(body, grab(self.world, body, point, self.spring), point)
        elif event.type == pygame.MOUSEMOTION and self.grab is not None:
            self.grab.target = self.camera.screen_to_world([event.pos])[0]
            self.world.set_joint_target(self.grab.joint, self.grab.target)
        elif event.type == pygame.MOUSEBUTTONUP and event.button == 1 and self.grab is not None:
            self.world.remove_joint(self.grab.joint)
            self.grab = None
        elif event.type == pygame.MOUSEBUTTONDOWN and event.button == 3:
            point = self.camera.screen_to_world([event.pos])[0]
            body = pick_body(self.world, point, 3.0 / self.camera.scale, dynamic_only=False)
            self.overlays = replace(self.overlays, field=True, field_body=body)

    def _carve(self, pos: tuple[int, int], deposit: bool) -> None:
        """Carve (or deposit) the tool's disc at screen ``pos`` in the terrain it reaches;
        an edit the body refuses is one line on stderr."""
        point = self.pointer = self.camera.screen_to_world([pos])[0]
        body = pick_terrain(self.world, point, self.carve_radius, dynamic=not deposit)
        if body is None:
            return
        disc = {"type": "circle", "radius": self.carve_radius}
        try:
            (self.world.deposit if deposit else self.world.carve)(body, disc, point)
        except SpecError as err:
            print(f"sdfphys: carve: {err}", file=sys.stderr, flush=True)

    def _key(self, key: int) -> None:
        if key == pygame.K_ESCAPE:
            self.running = False
        elif key == pygame.K_p:
            self.paused = not self.paused
        elif key == pygame.K_o and self.paused:
            self.step_once = True
        elif key == pygame.K_r:
            self.world = self.factory()
            self.grab = None
            self.overlays = replace(self.overlays, field_body=None)
        elif key == pygame.K_s:
            self.screenshot = True
        elif key == pygame.K_c:
            self.overlays = replace(self.overlays, contacts=not self.overlays.contacts)
        elif key == pygame.K_f:
            self.overlays = replace(self.overlays, field=not self.overlays.field)
        elif key == pygame.K_b:
            self.overlays = replace(self.overlays, bounds=not self.overlays.bounds)
        elif key == pygame.K_h:
            self.help = not self.help
        elif key == pygame.K_k:
            self.carving = not self.carving
            if self.grab is not None:
                self.world.remove_joint(self.grab.joint)
                self.grab = None

    def advance(self) -> None:
        """Run this frame's steps: enough to keep pace with ``fps`` (at least one),
        none while paused unless one step was asked for."""
        if self.paused:
            count = 1 if self.step_once else 0
        else:
            count = max(1, round(1.0 / (self.fps * self.dt)))
        self.step_once = False
        for _ in range(count):
            self.world.step()
        self.step_rate.add(count, time.perf_counter())

    def draw(self, screen: pygame.Surface, font: pygame.font.Font, frame_rate: float) -> None:
        self.renderer.draw(screen, self.world, self.overlays)
        palette: Palette = self.renderer.palette
        flags = [name for name, on in (("PAUSED", self.paused),
                                       ("contacts", self.overlays.contacts),
                                       ("field", self.overlays.field),
                                       ("bounds", self.overlays.bounds)) if on]
        if self.carving:
            flags.append(f"carve r = {self.carve_radius:.2f} m")
        flags.append("H: keys")
        line = (f"{frame_rate:5.1f} frames/s   {self.step_rate.rate:6.1f} steps/s   "
                f"t = {float(self.world.time):7.3f} s   {len(self.world.shape_id)} bodies   "
                + "  ".join(flags))
        screen.blit(font.render(line, True, palette.text), (8, 6))
        if self.pointer is not None:
            self._draw_readout(screen, palette)
            if self.carving:
                r_px = max(1, round(self.carve_radius * self.camera.scale))
                at = self.camera.world_to_screen([self.pointer])[0]
                pygame.draw.circle(screen, palette.text, (round(at[0]), round(at[1])), r_px, 1)
        if self.help:
            draw_panel(screen, ["Keys"] + [f"{k}:  {what}" for k, what in KEYS], palette,
                       corner="center", size=22)

    def _draw_readout(self, screen: pygame.Surface, palette: Palette) -> None:
        """``hover_readout`` on a panel below and right of the pointer, kept on screen."""
        lines = hover_readout(self.world, self.pointer, HOVER_PIXELS / self.camera.scale)
        if lines:
            x, y = (int(v) for v in self.camera.world_to_screen([self.pointer])[0])
            draw_panel(screen, lines, palette, corner=(x + 14, y + 14), size=18)

    def save_screenshot(self, screen: pygame.Surface, frame: int) -> Path:
        stem = f"sdfphys-{time.strftime('%Y%m%d-%H%M%S')}-{frame:05d}"
        path, k = Path(f"{stem}.png"), 1
        while path.exists():
            path, k = Path(f"{stem}-{k}.png"), k + 1
        pygame.image.save(screen, str(path))
        print(f"screenshot: {path}", flush=True)
        return path


def play(world_factory: Callable[[], Any], render_settings: RenderSettings, *,
         allow_headless: bool = False,
         events: Iterable[Sequence[pygame.event.Event]] | None = None,
         max_frames: int | None = None, spring: DragSpring = DragSpring()) -> int:
    """Run the interactive window until the user quits; return the exit status.

    world_factory: builds a fresh World (called at start and on R), e.g. ``Scene.build``.
    render_settings: window size (px), view centre (m), scale (px/m) and fps.
    allow_headless: accept SDL's offscreen/dummy drivers (tests); otherwise, without a
        display, print one line on stderr and return 2.
    events: a script, one sequence of pygame events per frame, read instead of the
        event queue (tests); the session ends when it runs out. Frames are then not
        paced to ``fps``.
    max_frames: stop after this many frames.
    Returns 0 when the session ends normally, 2 when there is no display.
    """
    if not allow_headless and _no_window_system():
        return _no_display("neither DISPLAY nor WAYLAND_DISPLAY is set")
    try:
        pygame.display.init()
    except pygame.error as err:
        return _no_display(str(err))
    driver = pygame.display.get_driver()
    if driver in HEADLESS_DRIVERS and not allow_headless:
        pygame.display.quit()
        return _no_display(f"SDL video driver is {driver!r}")
    try:
        return _run(world_factory, render_settings, events, max_frames, spring)
    finally:
        pygame.display.quit()


def _no_window_system() -> bool:
    """True on X11/Wayland systems (not Windows or macOS) with neither server named in
    the environment and no SDL driver chosen: checked before SDL starts, whose
    fallback probes print their own noise."""
    if sys.platform.startswith(("win", "darwin", "emscripten")):
        return False
    return not any(os.environ.get(name) for name in ("DISPLAY", "WAYLAND_DISPLAY",
                                                       "SDL_VIDEODRIVER"))


def _no_display(reason: str) -> int:
    print(f"sdfphys play: no display available ({reason}); "
          "render to a file instead: sdfphys run SCENE -o out.mp4", file=sys.stderr)
    return 2


def _run(world_factory: Callable[[], Any], settings: RenderSettings,
         events: Iterable[Sequence[pygame.event.Event]] | None, max_frames: int | None,
         spring: DragSpring) -> int:
    session = _Session(world_factory, settings, spring)
    screen = pygame.display.set_mode(session.camera.size)
    pygame.display.set_caption(CAPTION)
    pygame.font.init()
    font = pygame.font.Font(None, 22)
    clock = pygame.time.Clock()
    script: Iterator[Sequence[pygame.event.Event]] | None = (
        iter(events) if events is not None else None)
    frame = 0
    while session.running and (max_frames is None or frame < max_frames):
        if script is None:
            batch: Sequence[pygame.event.Event] = pygame.event.get()
        else:
            batch = next(script, None)
            if batch is None:
                break
            pygame.event.pump()
        for event in batch:
            session.handle(event)
        if not session.running:
            break
        session.advance()
        session.draw(screen, font, clock.get_fps())
        if session.screenshot:
            session.save_screenshot(screen, frame)
            session.screenshot = False
        pygame.display.flip()
        clock.tick(session.fps if script is None else 0)
        frame += 1
    return 0
