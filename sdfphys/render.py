"""Drawing a World onto any pygame Surface (headless-safe: no ``pygame.display`` calls).

Frames and units:

- World: metres, y up. Screen: pixels, y down, origin at the top-left corner;
  pixel ``(i, j)`` covers ``[i, i + 1) x [j, j + 1)`` and its centre is
  ``(i + 0.5, j + 0.5)``. The y-flip lives on the ``Camera``, nowhere else.
- Bodies are drawn from their shapes (``sdfphys.shapes``): circles and
  triangulated polygons with ``pygame.draw``; SDF bodies as their true filled
  region ``f <= 0``, rasterized by evaluating the field at the pixel centres of
  the body's screen bounding box in one batch (``sdf.compiled.distance``: the
  compiled program, or ``field.distance`` for fields that do not compile), with
  a one-pixel antialiased edge taken from the distance value (coverage
  ``0.5 - f * scale`` clipped to ``[0, 1]``). Unbounded fields (a half-plane
  ground) are evaluated over the visible screen, bounded ones with a narrow band (see
  ``Renderer._field_pixels``). Sprites of bodies that moved less than
  ``SPRITE_TOLERANCE`` px since the last frame (static bodies, bodies at rest) are
  reused.
- Colours (``Palette``; ``body_colours`` in ``render_bodies``): by body state
  (``body_frames``: dynamic, static, kinematic, asleep) and material. Dynamic bodies
  take a hue per material
  (friction, restitution, density; in order of first appearance), asleep ones the same
  hue faded toward grey, static ones a grey and kinematic ones an amber per material,
  and bodies of one colour alternate between lighter and darker shades in scene order,
  so neighbours in a stack differ.
- Joints (``render_joints``): anchors, links from the centres of mass, axes, springs,
  drawn over the bodies in ``Palette.joint`` and ``Palette.spring``.
- Overlays (``Overlays``): contact points and normals, the SDF distance map
  with iso-lines at screen resolution (one body's field or the union of all; kept
  while no body moves), body bounds, and a legend of those shown. ``hud`` prints the
  simulated time and step on the frame (``render.hud`` in a scene, for videos).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from .collide.broadphase import world_bounds
from .render_bodies import (
    ASLEEP,
    DYNAMIC,
    KINEMATIC,
    STATIC,
    BodyFrames,
    body_colours,
    body_frames,
)
from .render_field import _field_lut, _shade, distance_map
from .render_joints import draw_joints
from .sdf import compiled

__all__ = ["ASLEEP", "DYNAMIC", "KINEMATIC", "SPRITE_TOLERANCE", "STATIC", "BodyFrames", "Camera",
           "Overlays", "Palette", "Renderer", "body_colours", "body_frames", "draw_panel",
           "font"]

Color = tuple[int, int, int]



@dataclass(frozen=True)
class Camera:
    """A view of the world: ``center`` (m) is the world point at the middle of the frame,
    ``scale`` is pixels per metre, ``size`` the frame ``(width, height)`` in pixels.

    World y points up, screen y points down: ``world_to_screen`` flips it.
    """

    center: tuple[float, float] = (0.0, 4.0)
    scale: float = 50.0
    size: tuple[int, int] = (960, 540)

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", (float(self.center[0]), float(self.center[1])))
        object.__setattr__(self, "scale", float(self.scale))
        object.__setattr__(self, "size", (int(self.size[0]), int(self.size[1])))
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"camera scale must be a positive number of px/m, got {self.scale}")
        if self.size[0] < 1 or self.size[1] < 1:
            raise ValueError(f"camera size must be positive pixels, got {self.size}")

    def world_to_screen(self, points: Any) -> np.ndarray:
        """Screen pixel coordinates (N, 2) (float, y down) of world ``points`` (N, 2) in m."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        out = np.empty_like(p)
        out[:, 0] = 0.5 * self.size[0] + (p[:, 0] - self.center[0]) * self.scale
        out[:, 1] = 0.5 * self.size[1] - (p[:, 1] - self.center[1]) * self.scale
        return out

    def screen_to_world(self, pixels: Any) -> np.ndarray:
        """World points (N, 2) in m of screen ``pixels`` (N, 2) (y down); inverse of
        ``world_to_screen``."""
        q = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        out = np.empty_like(q)
        out[:, 0] = self.center[0] + (q[:, 0] - 0.5 * self.size[0]) / self.scale
        out[:, 1] = self.center[1] - (q[:, 1] - 0.5 * self.size[1]) / self.scale
        return out

    def pixel_centers(self, x0: int, y0: int, width: int, height: int,
                      step: int = 1) -> np.ndarray:
        """World points (width, height, 2), indexed ``[i, j]`` like ``pygame.surfarray``,
        of the centres of the ``step`` x ``step`` pixel blocks of the screen rectangle
        whose top-left pixel is ``(x0, y0)`` (``step = 1``: the pixel centres)."""
        sx = x0 + (np.arange(width) + 0.5) * step
        sy = y0 + (np.arange(height) + 0.5) * step
        out = np.empty((width, height, 2))
        out[:, :, 0] = (self.center[0] + (sx - 0.5 * self.size[0]) / self.scale)[:, None]
        out[:, :, 1] = (self.center[1] - (sy - 0.5 * self.size[1]) / self.scale)[None, :]
        return out


@dataclass(frozen=True)
class Palette:
    """Every colour the renderer uses (RGB 0-255); body edges are the fill times ``edge_shade``.

    Bodies (``body_colours``): ``dynamic`` is the first material's hue, ``materials``
    the next ones; ``static`` and ``kinematic`` are lightened or darkened by
    ``material_shade`` per further material; an asleep body takes its material's dynamic
    hue mixed ``asleep_fade`` of the way toward ``asleep``; the k-th body of a colour is
    darkened by ``shade`` times frac(k 0.618) (0 for the first).
    """

    background: Color = (22, 24, 30)
    dynamic: Color = (88, 156, 226)
    static: Color = (128, 132, 140)
    kinematic: Color = (226, 172, 72)
    asleep: Color = (104, 108, 120)
    asleep_fade: float = 0.6
    materials: tuple[Color, ...] = ((222, 104, 118), (172, 126, 224), (86, 200, 200),
                                    (206, 196, 96), (226, 136, 196), (200, 160, 124),
                                    (120, 190, 110))
    shade: float = 0.24
    material_shade: float = 0.18
    edge_shade: float = 0.55
    mark: Color = (236, 236, 236)
    contact: Color = (240, 64, 64)
    speculative: Color = (240, 200, 60)
    bounds: Color = (90, 220, 120)
    field_inside: Color = (70, 130, 230)
    field_outside: Color = (232, 150, 80)
    iso: Color = (250, 250, 250)
    joint: Color = (236, 226, 150)
    spring: Color = (120, 220, 150)
    text: Color = (232, 232, 232)
    panel: Color = (44, 48, 58)

    @cached_property
    def fills(self) -> tuple[Color, Color, Color, Color]:
        """Base fill colours indexed by state (``DYNAMIC``, ``STATIC``, ``KINEMATIC``,
        ``ASLEEP``: the first material's asleep colour)."""
        return (self.dynamic, self.static, self.kinematic,
                tuple(int(c) for c in self.material_fill(ASLEEP, 0)))

    @cached_property
    def edges(self) -> tuple[Color, ...]:
        """Outline colours indexed by state: the fills darkened by ``edge_shade``."""
        return tuple(tuple(int(c * self.edge_shade) for c in fill) for fill in self.fills)

    def material_fill(self, state: int, material: int) -> np.ndarray:
        """(3,) float RGB of the first body of ``state`` with the ``material``-th material."""
        if state in (DYNAMIC, ASLEEP):
            hues = (self.dynamic, *self.materials)
            hue = np.array(hues[material % len(hues)], np.float64)
            if state == DYNAMIC:
                return hue
            return hue + (np.array(self.asleep, np.float64) - hue) * self.asleep_fade
        base = np.array(self.fills[state], np.float64)
        if material == 0:
            return base
        step = self.material_shade * (1 + (material - 1) // 2)
        towards = 255.0 if material % 2 else 0.0         # lighter, darker, lighter, ...
        return base + (towards - base) * min(step, 0.7)


@dataclass(frozen=True)
class Overlays:
    """Optional layers drawn over the bodies.

    contacts: contact points (red: overlapping, yellow: speculative) and normals
        (``normal_length`` m, from body a toward body b).
    field: the SDF distance map, inside blue and outside orange, darker near the
        surface, antialiased iso-lines every ``iso_spacing`` m and the zero line in
        white; evaluated at every pixel centre (no moire) and kept while no body moves.
    field_body: the body whose field is shown; None shows the union of all bodies.
    bounds: each body's world-space AABB.
    legend: a panel in the bottom-left corner naming the colours of the overlays shown.
    """

    contacts: bool = False
    field: bool = False
    field_body: int | None = None
    bounds: bool = False
    legend: bool = False
    normal_length: float = 0.3
    iso_spacing: float = 0.25
    field_alpha: int = 170


#: Narrow-band block size (px) of SDF rasterization, and the largest distance from a
#: block's centre to one of its pixel centres (px).
_BLOCK = 4
_BLOCK_REACH = (_BLOCK - 1) / 2 * math.sqrt(2.0)


#: Block size (px) at which the field overlay is evaluated while bodies move.
FIELD_STEP = 4

#: How far (px) an SDF body may move, at its centre of mass and at its bounding radius
#: by rotation, before its sprite is rasterized again.
SPRITE_TOLERANCE = 0.125


def _close(centre0: np.ndarray, centre1: np.ndarray, angle0: float, angle1: float,
           radius_px: float) -> bool:
    """Two poses (screen centre px, angle rad) of a body of bounding radius ``radius_px``
    are within ``SPRITE_TOLERANCE`` (an unbounded body: only the same angle)."""
    if abs(centre1[0] - centre0[0]) > SPRITE_TOLERANCE:
        return False
    if abs(centre1[1] - centre0[1]) > SPRITE_TOLERANCE:
        return False
    if angle0 == angle1:
        return True
    return math.isfinite(radius_px) and abs(angle1 - angle0) * radius_px <= SPRITE_TOLERANCE


def _draw_coords(camera: Camera, points: np.ndarray) -> np.ndarray:
    """``pygame.draw`` coordinates (N, 2) (float) of world ``points``: pygame puts
    integer coordinates at pixel centres, the camera at pixel corners."""
    return camera.world_to_screen(points) - 0.5


def _draw_pixels(camera: Camera, points: np.ndarray) -> np.ndarray:
    """``_draw_coords`` rounded to the nearest pixel centre (N, 2) int, for the
    ``pygame.draw`` functions that truncate float coordinates."""
    return np.round(_draw_coords(camera, points)).astype(np.int64)


def _rotate(points: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Body-frame ``points`` (V, 2) rotated by each of ``angle`` (n,): (n, V, 2)."""
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    x, y = points[None, :, 0], points[None, :, 1]
    return np.stack([c * x - s * y, s * x + c * y], axis=-1)


class Renderer:
    """Draws worlds through ``camera`` with colours from ``palette``.

    ``draw(surface, world, overlays)`` clears ``surface`` (which should have the
    camera's size) and draws every body and the requested overlays. The renderer
    keeps the SDF sprites of the last frame, by body index, to reuse those of bodies
    that did not move (see ``SPRITE_TOLERANCE``), and the last field overlay while
    nothing it shows changed; it holds no other state.
    """

    def __init__(self, camera: Camera, palette: Palette = Palette()):
        self.camera = camera
        self.palette = palette
        self._sprites: dict[int, tuple] = {}
        self._field_layer: tuple | None = None

    def draw(self, surface: pygame.Surface, world: Any, overlays: Overlays = Overlays(),
             hud: bool = False) -> None:
        """Clear ``surface`` and draw ``world`` (bodies, then the chosen ``overlays``, their
        legend, and with ``hud`` the world's ``time`` and ``step_count`` top left)."""
        surface.fill(self.palette.background)
        frames = body_frames(world)
        fills = body_colours(frames, self.palette)
        edges = (fills * self.palette.edge_shade).astype(np.uint8)
        colours = (fills, edges)
        kinds = np.array([s.kind for s in frames.shapes], dtype=object)
        body_kind = kinds[frames.shape_id] if len(frames.shape_id) else np.zeros(0, object)
        visible = self._visible(frames)
        self._draw_sdf_bodies(surface, frames, np.flatnonzero(visible & (body_kind == "sdf")),
                              colours)
        self._draw_meshes(surface, frames, np.flatnonzero(visible & (body_kind == "mesh")),
                          colours)
        self._draw_circles(surface, frames, np.flatnonzero(visible & (body_kind == "circle")),
                           colours)
        if len(getattr(world, "joints", ())):
            draw_joints(surface, self.camera, world, self.palette)
        if overlays.field:
            self._draw_field(surface, frames, overlays)
        if overlays.bounds:
            self._draw_bounds(surface, frames, np.flatnonzero(visible))
        if overlays.contacts:
            self._draw_contacts(surface, world.contacts, overlays.normal_length)
        if overlays.legend:
            self._draw_legend(surface, overlays)
        if hud:
            self._draw_hud(surface, world)

    # ----------------------------------------------------------------------------------
    # Bodies
    # ----------------------------------------------------------------------------------

    def _visible(self, frames: BodyFrames) -> np.ndarray:
        """(B,) bool: the body's bounding circle reaches the screen."""
        radius = np.array([float(s.radius) for s in frames.shapes])[frames.shape_id]
        centre = self.camera.world_to_screen(frames.com)
        r = radius * self.camera.scale + 2.0
        w, h = self.camera.size
        with np.errstate(invalid="ignore"):
            return ~np.isfinite(r) | ((centre[:, 0] + r >= 0) & (centre[:, 0] - r <= w)
                                      & (centre[:, 1] + r >= 0) & (centre[:, 1] - r <= h))

    def _draw_circles(self, surface: pygame.Surface, frames: BodyFrames, index: np.ndarray,
                      colours: tuple[np.ndarray, np.ndarray]) -> None:
        if not len(index):
            return
        cam, pal = self.camera, self.palette
        radius = np.array([float(getattr(s, "radius", 0.0)) for s in frames.shapes])
        r_m = radius[frames.shape_id[index]]
        angle = frames.angle[index]
        mark = frames.com[index] + r_m[:, None] * np.stack([np.cos(angle), np.sin(angle)], 1)
        centre = _draw_coords(cam, frames.com[index])
        tip = _draw_coords(cam, mark).tolist()
        # The antialiased edge ring covers the pixels within radius + 0.5 of a pixel
        # centre (ints): centre and radius are rounded so that it spans [x - r, x + r].
        # The aliased fill inside it is one pixel narrower on one side; a ring two
        # pixels wide leaves no gap (and costs a third of an antialiased fill).
        pixel = np.round(centre).astype(np.int64).tolist()
        r_px = np.maximum(np.round(r_m * cam.scale - 0.5), 0).astype(np.int64).tolist()
        centre = centre.tolist()
        fills, edges = colours[0][index].tolist(), colours[1][index].tolist()
        for k in range(len(index)):
            pygame.draw.circle(surface, fills[k], pixel[k], r_px[k])
            pygame.draw.aacircle(surface, edges[k], pixel[k], r_px[k], 2)
            pygame.draw.aaline(surface, pal.mark, centre[k], tip[k])

    def _draw_meshes(self, surface: pygame.Surface, frames: BodyFrames, index: np.ndarray,
                     colours: tuple[np.ndarray, np.ndarray]) -> None:
        cam = self.camera
        sid = frames.shape_id[index]
        for shape_id in np.unique(sid):
            bodies = index[sid == shape_id]
            outline = np.asarray(frames.shapes[shape_id].outline, dtype=np.float64)
            world = _rotate(outline, frames.angle[bodies]) + frames.com[bodies, None, :]
            screen = _draw_coords(cam, world).reshape(len(bodies), -1, 2)
            pixel = np.round(screen).astype(np.int64).tolist()
            screen = screen.tolist()
            fills, edges = colours[0][bodies].tolist(), colours[1][bodies].tolist()
            for k in range(len(bodies)):
                pygame.draw.polygon(surface, fills[k], pixel[k])
                pygame.draw.aalines(surface, edges[k], True, screen[k])

    def _draw_sdf_bodies(self, surface: pygame.Surface, frames: BodyFrames, index: np.ndarray,
                         colours: tuple[np.ndarray, np.ndarray]) -> None:
        """Blit the sprite of every SDF body of ``index``.

        A body's sprite from the last frame is reused while the body has the same shape
        (and shape ``revision``: an edited terrain's sprite is redrawn), colour and
        camera and has moved less than ``SPRITE_TOLERANCE`` px (centre of mass, and
        rotation at its bounding radius), so bodies at rest cost one blit.
        The others are rasterized with one batch of field evaluations per shape for all
        the bodies that share it (instancing).
        """
        cam = self.camera
        centre = cam.world_to_screen(frames.com[index]) if len(index) else np.zeros((0, 2))
        sprites: dict[int, tuple] = {}
        missing: dict[int, list[int]] = {}
        fills, edges = colours[0].tolist(), colours[1].tolist()
        for k, b in enumerate(index.tolist()):
            shape = frames.shapes[frames.shape_id[b]]
            colour, angle = (tuple(fills[b]), tuple(edges[b])), float(frames.angle[b])
            look = (colour, cam, getattr(shape, "revision", 0))     # edited terrain: redraw
            old = self._sprites.get(b)
            if (old is not None and old[0] is shape and old[1] == look
                    and _close(old[2], centre[k], old[3], angle, float(shape.radius) * cam.scale)):
                sprites[b] = old
            else:
                missing.setdefault(int(frames.shape_id[b]), []).append(b)
        for shape_id, bodies in missing.items():
            shape = frames.shapes[shape_id]
            rects = [self._screen_rect(shape, frames.com[b], float(frames.angle[b]))
                     for b in bodies]
            fields = self._field_pixels(shape.field, frames.com[bodies], frames.angle[bodies],
                                        rects)
            for b, rect, d_px in zip(bodies, rects, fields):
                colour = (tuple(fills[b]), tuple(edges[b]))
                sprites[b] = (shape, (colour, cam, getattr(shape, "revision", 0)),
                              cam.world_to_screen(frames.com[b])[0], float(frames.angle[b]),
                              *self._sprite(d_px, rect, colour))
        for b in index.tolist():
            sprite, place = sprites[b][4:]
            if sprite is not None:
                surface.blit(sprite, place)
        self._sprites = sprites

    def _screen_rect(self, shape: Any, com: np.ndarray, angle: float) -> pygame.Rect:
        """Screen rectangle (clipped to the frame, 1 px margin for the edge) that holds
        the body's region f <= 0; the whole frame for unbounded shapes."""
        w, h = self.camera.size
        frame = pygame.Rect(0, 0, w, h)
        box = np.asarray(shape.bounds(), dtype=np.float64)
        if not np.all(np.isfinite(box)):
            return frame
        corners = np.array([[box[0], box[1]], [box[2], box[1]], [box[2], box[3]],
                            [box[0], box[3]]])
        px = self.camera.world_to_screen(_rotate(corners, np.array([angle]))[0] + com)
        x0, y0 = np.floor(px.min(axis=0)) - 1
        x1, y1 = np.ceil(px.max(axis=0)) + 1
        return pygame.Rect(int(x0), int(y0), int(x1 - x0), int(y1 - y0)).clip(frame)

    def _sprite(self, d_px: np.ndarray | None, rect: pygame.Rect,
                colour: tuple[Color, Color]) -> tuple[pygame.Surface | None, tuple[int, int]]:
        """An RGBA sprite of the region f <= 0 from the field ``d_px`` (w, h) (px) at the
        pixel centres of ``rect``, filled and edged with ``colour``, and its screen position.

        Coverage of a pixel is ``clip(0.5 - f * scale, 0, 1)`` (the one-pixel
        antialiased edge); pixels within 1.5 px inside the surface blend to the edge
        colour. The sprite is cropped to its non-transparent pixels.
        """
        if d_px is None:
            return None, (0, 0)
        coverage = np.clip(0.5 - d_px, 0.0, 1.0)
        columns = np.flatnonzero(coverage.any(axis=1))
        rows = np.flatnonzero(coverage.any(axis=0))
        if not len(columns):
            return None, (0, 0)
        i0, i1, j0, j1 = columns[0], columns[-1] + 1, rows[0], rows[-1] + 1
        coverage, d_px = coverage[i0:i1, j0:j1], d_px[i0:i1, j0:j1]
        fill = np.array(colour[0], dtype=np.float64)
        edge = np.array(colour[1], dtype=np.float64)
        sprite = pygame.Surface((i1 - i0, j1 - j0), pygame.SRCALPHA, 32)
        sprite.fill(colour[0])
        rgb = pygame.surfarray.pixels3d(sprite)
        i, j = np.nonzero((d_px > -1.5) & (d_px < 0.5))     # the visible edge band
        weight = np.clip(d_px[i, j] + 1.5, 0.0, 1.0)[:, None]
        rgb[i, j] = (fill + (edge - fill) * weight + 0.5).astype(np.uint8)
        del rgb
        alpha = pygame.surfarray.pixels_alpha(sprite)
        alpha[...] = (coverage * 255.0 + 0.5).astype(np.uint8)
        del alpha
        return sprite, (rect.x + int(i0), rect.y + int(j0))

    def _field_pixels(self, field: Any, com: np.ndarray, angle: np.ndarray,
                      rects: list[pygame.Rect]) -> list[np.ndarray | None]:
        """For each body (centre of mass ``com`` (n, 2), ``angle`` (n,)) of one shape, its
        ``field`` in pixels (w, h) at the pixel centres of its screen rectangle (None if
        the rectangle is empty): exact where the sprite needs it (|f| < 1.5 px).

        Narrow band: the field is first evaluated at the centres of 4 x 4 pixel blocks.
        The pixel centres of a block lie within 1.5 sqrt(2) px of its centre, and |f|
        never exceeds the distance to the surface (exact fields and bounds alike), so a
        block whose |f| exceeds that reach + 1.5 px is uniformly far inside or outside
        and takes its centre's value. Only the other blocks are evaluated per pixel, so
        the cost grows with the perimeter, not the area. Each pass is one field call
        for all the bodies.
        """
        cam, step = self.camera, _BLOCK
        live = [k for k, r in enumerate(rects) if r.width > 0 and r.height > 0]
        out: list[np.ndarray | None] = [None] * len(rects)
        if not live:
            return out
        blocks = [(-(-rects[k].width // step), -(-rects[k].height // step)) for k in live]
        coarse = [cam.pixel_centers(rects[k].x, rects[k].y, cw, ch, step).reshape(-1, 2)
                  for k, (cw, ch) in zip(live, blocks)]
        d_coarse = self._evaluate(field, com[live], angle[live], coarse)
        band_points, band_index = [], []
        for k, (cw, ch), d in zip(live, blocks, d_coarse):
            rect = rects[k]
            d_block = d.reshape(cw, ch)
            near = np.abs(d_block) <= _BLOCK_REACH + 1.5
            d_px = np.repeat(np.repeat(d_block, step, axis=0), step, axis=1)
            out[k] = d_px[:rect.width, :rect.height]
            i, j = np.nonzero(np.repeat(np.repeat(near, step, axis=0), step,
                                        axis=1)[:rect.width, :rect.height])
            points = np.empty((len(i), 2))
            points[:, 0] = cam.center[0] + (rect.x + i + 0.5 - 0.5 * cam.size[0]) / cam.scale
            points[:, 1] = cam.center[1] - (rect.y + j + 0.5 - 0.5 * cam.size[1]) / cam.scale
            band_points.append(points)
            band_index.append((i, j))
        d_band = self._evaluate(field, com[live], angle[live], band_points)
        for k, (i, j), d in zip(live, band_index, d_band):
            out[k][i, j] = d
        return out

    def _evaluate(self, field: Any, com: np.ndarray, angle: np.ndarray,
                  points: list[np.ndarray]) -> list[np.ndarray]:
        """``field`` in pixels at each body's world ``points`` (n_k, 2): one call for all."""
        counts = [len(p) for p in points]
        if sum(counts) == 0:
            return [np.zeros(0) for _ in points]
        owner = np.repeat(np.arange(len(points)), counts)
        gap = np.concatenate(points) - com[owner]
        c, s = np.cos(angle)[owner], np.sin(angle)[owner]
        local = np.stack([c * gap[:, 0] + s * gap[:, 1], -s * gap[:, 0] + c * gap[:, 1]], 1)
        d = compiled.distance(field, local) * self.camera.scale
        return np.split(d, np.cumsum(counts)[:-1])

    # ----------------------------------------------------------------------------------
    # Overlays
    # ----------------------------------------------------------------------------------

    def world_bounds(self, frames: BodyFrames, index: np.ndarray) -> np.ndarray:
        """World AABBs (n, 4) ``[xmin, ymin, xmax, ymax]`` (m) of bodies ``index``, as the
        broadphase computes them (``collide.broadphase.world_bounds``: the body-frame
        ``bounds()`` box rotated into the world, cut by the bounding disc; unbounded
        shapes give infinite components)."""
        sid = frames.shape_id[index]
        local = np.array([s.bounds() for s in frames.shapes], np.float64).reshape(-1, 4)
        radius = np.array([getattr(s, "radius", np.inf) for s in frames.shapes], np.float64)
        return world_bounds(local[sid], radius[sid], frames.com[index], frames.angle[index])

    def _draw_bounds(self, surface: pygame.Surface, frames: BodyFrames,
                     index: np.ndarray) -> None:
        boxes = self.world_bounds(frames, index)
        boxes = boxes[np.all(np.isfinite(boxes), axis=1)]
        lo = self.camera.world_to_screen(boxes[:, [0, 3]])
        hi = self.camera.world_to_screen(boxes[:, [2, 1]])
        for (x0, y0), (x1, y1) in zip(lo.tolist(), hi.tolist()):
            pygame.draw.rect(surface, self.palette.bounds,
                             pygame.Rect(round(x0), round(y0), max(1, round(x1 - x0)),
                                         max(1, round(y1 - y0))), 1)

    def _draw_contacts(self, surface: pygame.Surface, contacts: Any, length: float) -> None:
        if contacts is None or not len(contacts.depth):
            return
        point = np.asarray(contacts.point, dtype=np.float64)
        normal = np.asarray(contacts.normal, dtype=np.float64)
        start = _draw_pixels(self.camera, point).tolist()
        end = _draw_pixels(self.camera, point + length * normal).tolist()
        for k, depth in enumerate(np.asarray(contacts.depth).tolist()):
            colour = self.palette.contact if depth > 0 else self.palette.speculative
            pygame.draw.line(surface, colour, start[k], end[k], 2)
            pygame.draw.circle(surface, colour, start[k], 3)

    def _draw_field(self, surface: pygame.Surface, frames: BodyFrames,
                    overlays: Overlays) -> None:
        """The distance map blended over the frame, coloured per pixel (``_shade``).

        While bodies move, the map is evaluated at the centres of ``FIELD_STEP`` px
        blocks and interpolated bilinearly to every pixel before colouring (the
        iso-lines stay one pixel wide and smooth: no moire); once nothing changed
        since the last frame it is evaluated at every pixel centre and kept, and a
        paused or resting scene costs one blit per frame.
        """
        key = (self.camera, self.palette, overlays.field_body, overlays.iso_spacing,
               overlays.field_alpha,
               tuple((id(s), getattr(s, "revision", 0)) for s in frames.shapes),
               frames.shape_id.tobytes(), frames.com.tobytes(), frames.angle.tobytes())
        cached = self._field_layer
        if cached is None or cached[0] != key or not cached[2]:
            exact = cached is not None and cached[0] == key
            step = 1 if exact else FIELD_STEP
            cam = self.camera
            cw, ch = -(-cam.size[0] // step), -(-cam.size[1] // step)
            centres = cam.pixel_centers(0, 0, cw, ch, step)
            d = distance_map(frames, centres[:, 0, 0], centres[0, :, 1], overlays.field_body)
            lut, q, far = _field_lut(self.palette, cam.scale, overlays.iso_spacing)
            image = _shade(d, step, cam.size[0], cam.size[1], lut, q, far,
                           overlays.iso_spacing)
            layer = pygame.surfarray.make_surface(image)
            layer.set_alpha(int(overlays.field_alpha))
            self._field_layer = (key, layer, exact)
        surface.blit(self._field_layer[1], (0, 0))

    def _draw_legend(self, surface: pygame.Surface, overlays: Overlays) -> None:
        """A panel in the bottom-left corner: a swatch and a name per colour of the
        overlays shown (nothing if none is)."""
        pal = self.palette
        rows: list[tuple[Color, str]] = []
        if overlays.field:
            which = "union of all" if overlays.field_body is None else (
                f"body {overlays.field_body}")
            rows += [(pal.field_inside, f"field ({which}): inside, f < 0"),
                     (pal.field_outside, "field: outside, f > 0"),
                     (pal.iso, f"surface f = 0; lines every {overlays.iso_spacing:g} m")]
        if overlays.contacts:
            rows += [(pal.contact, "contact, overlapping (line: normal a -> b)"),
                     (pal.speculative, "contact, speculative (not touching yet)")]
        if overlays.bounds:
            rows += [(pal.bounds, "bounding box (broadphase)")]
        if rows:
            draw_panel(surface, [text for _, text in rows], pal, corner="bottom-left",
                   swatches=[colour for colour, _ in rows])

    def _draw_hud(self, surface: pygame.Surface, world: Any) -> None:
        """The simulated time and step count, top left."""
        text = (f"t = {float(getattr(world, 'time', 0.0)):.3f} s   "
                f"step {int(getattr(world, 'step_count', 0))}")
        draw_panel(surface, [text], self.palette, corner="top-left")


_FONTS: dict[int, pygame.font.Font] = {}


def font(size: int = 18) -> pygame.font.Font:
    """pygame's default font at ``size`` px (initialised on first use, kept)."""
    if size not in _FONTS:
        if not pygame.font.get_init():
            pygame.font.init()
        _FONTS[size] = pygame.font.Font(None, size)
    return _FONTS[size]


def draw_panel(surface: pygame.Surface, lines: list[str], pal: Palette,
               corner: str | tuple[int, int], swatches: list[Color] | None = None,
               size: int = 18) -> pygame.Rect:
    """Lines of text on a translucent panel in a ``corner`` of ``surface``
    ("top-left", "bottom-left", "center") or with its top-left corner at the pixel
    ``corner`` (x, y), moved in to fit on the surface; each line after a colour swatch
    if ``swatches``. Returns the panel's rectangle."""
    face = font(size)
    pad, gap, line = 6, 4, face.get_linesize()
    swatch = line - 4 if swatches else 0
    rendered = [face.render(text, True, pal.text) for text in lines]
    width = max(r.get_width() for r in rendered) + 2 * pad + (swatch + gap if swatch else 0)
    height = len(lines) * line + 2 * pad
    w, h = surface.get_size()
    if isinstance(corner, tuple):
        x, y = min(max(corner[0], 0), w - width), min(max(corner[1], 0), h - height)
    else:
        x, y = {"top-left": (6, 6), "bottom-left": (6, h - height - 6),
                "center": ((w - width) // 2, (h - height) // 2)}[corner]
    panel = pygame.Surface((width, height), pygame.SRCALPHA)
    panel.fill((*pal.panel, 215))
    surface.blit(panel, (x, y))
    for k, text in enumerate(rendered):
        top = y + pad + k * line
        left = x + pad
        if swatches:
            pygame.draw.rect(surface, swatches[k], pygame.Rect(left, top + 2, swatch, swatch))
            left += swatch + gap
        surface.blit(text, (left, top))
    return pygame.Rect(x, y, width, height)
