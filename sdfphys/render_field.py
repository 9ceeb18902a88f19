"""The SDF distance-map overlay: signed distance on a screen grid, shaded with iso-lines.

``distance_map`` evaluates one body's field, or the union (minimum) of all bodies'
fields, on a world grid (the centres of screen pixels or of blocks of them), pruning by
each body's bounding circle and by tiles; ``_shade`` turns the map into RGB pixels
through a colour table (``_field_lut``) built from the formula of ``_distance_colours``.
``render.Renderer`` draws it under the bodies when the field overlay is on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from ._jit import njit
from .sdf import compiled
from .sdf.compiled import run_shared, scratch

if TYPE_CHECKING:
    from .render import BodyFrames, Palette

__all__ = ["distance_map"]

def _to_body(points: np.ndarray, com: np.ndarray, angle: float) -> np.ndarray:
    """World ``points`` (..., 2) in the body frame at ``com``, ``angle`` (flattened to (N, 2))."""
    c, s = math.cos(angle), math.sin(angle)
    d = points.reshape(-1, 2) - com
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)



def distance_map(frames: BodyFrames, xs: np.ndarray, ys: np.ndarray,
                 body: int | None = None) -> np.ndarray:
    """Signed distance (W, H) on the world grid ``xs`` (W,) x ``ys`` (H,) (m; ``xs``
    increasing, ``ys`` monotonic): body ``body``'s field, or the union (minimum) of the
    fields of all bodies when ``body`` is None.

    For the union, bodies are taken largest first and a body's field is evaluated only
    at grid points where the lower bound ``|p - com| - radius`` of its distance is
    below the current minimum: the cost grows with the area each body wins, not with
    B x grid. Tiles of ``_TILE`` x ``_TILE`` points whose nearest point is farther than
    their largest minimum plus the radius are skipped whole. Fields that compile
    (``sdf.compiled``) and circles are evaluated in ``_union_body``; others through
    ``compiled.distance`` (numpy). (For fields that are bounds rather than exact
    distances the pruned values could have been smaller: the map is a view, not a
    query.)
    """
    xs, ys = np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64)
    flip = len(ys) > 1 and ys[0] > ys[-1]
    y_up = np.ascontiguousarray(ys[::-1] if flip else ys)
    radius = np.array([float(s.radius) for s in frames.shapes])[frames.shape_id]
    bodies = [body] if body is not None else _union_order(radius)
    best = np.full((len(xs), len(y_up)), np.inf)
    tiles = np.full((-(-len(xs) // _TILE), -(-len(y_up) // _TILE)), np.inf)
    compile_field = getattr(compiled, "compile_field", None)
    for b in bodies:
        shape = frames.shapes[frames.shape_id[b]]
        cx, cy = (float(v) for v in frames.com[b])
        r = float(radius[b])
        if np.isfinite(r):
            reach = r + float(tiles.max())      # tiles bound the minimum from above
            i0, i1 = np.searchsorted(xs, [cx - reach, cx + reach])
            j0, j1 = np.searchsorted(y_up, [cy - reach, cy + reach])
        else:
            i0, i1, j0, j1 = 0, len(xs), 0, len(y_up)
        if i1 <= i0 or j1 <= j0:
            continue
        angle = float(frames.angle[b])
        if shape.kind == "circle":
            program = _CIRCLE_PROGRAM
        else:
            program = compile_field(shape.field) if compile_field is not None else None
        if program is not None:
            _union_body(best, tiles, xs, y_up, int(i0), int(i1), int(j0), int(j1), cx, cy,
                        math.cos(angle), math.sin(angle), r, shape.kind == "circle",
                        program.code, program.consts, program.depth, program.nesting)
            continue
        ii, jj = np.nonzero(_near(best, tiles, xs, y_up, int(i0), int(i1), int(j0), int(j1),
                                  cx, cy, r))
        if not len(ii):
            continue
        points = np.stack([xs[ii], y_up[jj]], axis=1)
        d = compiled.distance(shape.field, _to_body(points, frames.com[b], angle))
        best[ii, jj] = np.minimum(best[ii, jj], d)
        _retile(best, tiles, int(i0), int(i1), int(j0), int(j1))
    return best[:, ::-1] if flip else best


def _union_order(radius: np.ndarray) -> list[int]:
    """The order ``distance_map`` takes bodies in for the union: unbounded ones first,
    then the others in a fixed shuffled order. In scene order a row of bodies would
    each win most of the region beyond the last one, and be evaluated there; shuffled,
    the minimum gets close everywhere after a few bodies (a pyramid's map: 4x fewer
    evaluations)."""
    unbounded = np.flatnonzero(~np.isfinite(radius))
    bounded = np.flatnonzero(np.isfinite(radius))
    shuffled = bounded[np.random.default_rng(0).permutation(len(bounded))]
    return np.concatenate([unbounded, shuffled]).tolist()


#: Tile size (grid points) of ``distance_map``'s pruning.
_TILE = 16
#: Batch of field evaluations in ``_union_body``.
_BATCH = 2048


@dataclass(frozen=True)
class _Program:
    code: np.ndarray
    consts: np.ndarray
    depth: int
    nesting: int


#: Stand-in program for circles, which ``_union_body`` evaluates as |p - c| - r.
_CIRCLE_PROGRAM = _Program(np.zeros((0, 4), np.int64), np.zeros(1), 1, 1)


@njit(cache=True)
def _skip(tiles: np.ndarray, xs: np.ndarray, ys: np.ndarray, ti: int, tj: int, a0: int,
          a1: int, b0: int, b1: int, cx: float, cy: float, r: float) -> bool:
    """True when no point of the tile can pass the test |p - c| - r < minimum: its
    nearest point is as far as its largest minimum plus r (the same rounded
    operations as the test, and monotonic, so no point the test keeps is skipped)."""
    m = tiles[ti, tj] + r
    if not m > 0.0:
        return True
    gx = 0.0
    if cx < xs[a0]:
        gx = xs[a0] - cx
    elif cx > xs[a1 - 1]:
        gx = xs[a1 - 1] - cx
    gy = 0.0
    if cy < ys[b0]:
        gy = ys[b0] - cy
    elif cy > ys[b1 - 1]:
        gy = ys[b1 - 1] - cy
    return gx * gx + gy * gy >= m * m


@njit(cache=True)
def _near(best: np.ndarray, tiles: np.ndarray, xs: np.ndarray, ys: np.ndarray, i0: int,
          i1: int, j0: int, j1: int, cx: float, cy: float, r: float) -> np.ndarray:
    """(W, H) bool: the points of the window [i0, i1) x [j0, j1) where
    |p - c| - r < best (as ``(best + r > 0) & (dx^2 + dy^2 < (best + r)^2)``)."""
    out = np.zeros(best.shape, np.bool_)
    for ti in range(i0 // _TILE, (i1 - 1) // _TILE + 1):
        a0, a1 = max(i0, ti * _TILE), min(i1, (ti + 1) * _TILE)
        for tj in range(j0 // _TILE, (j1 - 1) // _TILE + 1):
            b0, b1 = max(j0, tj * _TILE), min(j1, (tj + 1) * _TILE)
            if _skip(tiles, xs, ys, ti, tj, a0, a1, b0, b1, cx, cy, r):
                continue
            for i in range(a0, a1):
                dx = xs[i] - cx
                for j in range(b0, b1):
                    dy = ys[j] - cy
                    limit = best[i, j] + r
                    out[i, j] = limit > 0.0 and dx * dx + dy * dy < limit * limit
    return out


@njit(cache=True)
def _retile(best: np.ndarray, tiles: np.ndarray, i0: int, i1: int, j0: int, j1: int) -> None:
    """Recompute the largest minimum of the tiles that meet [i0, i1) x [j0, j1)."""
    w, h = best.shape
    for ti in range(i0 // _TILE, (i1 - 1) // _TILE + 1):
        for tj in range(j0 // _TILE, (j1 - 1) // _TILE + 1):
            m = -np.inf
            for i in range(ti * _TILE, min(w, (ti + 1) * _TILE)):
                for j in range(tj * _TILE, min(h, (tj + 1) * _TILE)):
                    m = max(m, best[i, j])
            tiles[ti, tj] = m


@njit(cache=True)
def _union_body(best: np.ndarray, tiles: np.ndarray, xs: np.ndarray, ys: np.ndarray,
                i0: int, i1: int, j0: int, j1: int, cx: float, cy: float, c: float,
                s: float, r: float, circle: bool, code: np.ndarray, consts: np.ndarray,
                depth: int, nesting: int) -> None:
    """One body of ``distance_map``: its field (centre of mass (cx, cy), cos and sin of
    its angle c, s; a circle of radius r, or the compiled program) at the window's
    points that pass the lower-bound test, into ``best``; then the tiles' maxima."""
    near = _near(best, tiles, xs, ys, i0, i1, j0, j1, cx, cy, r)
    ii = np.empty(_BATCH, np.int64)
    jj = np.empty(_BATCH, np.int64)
    points = np.empty((_BATCH, 2))
    value = np.empty(_BATCH)
    grad = np.empty((_BATCH, 2))
    stack, frames, cur = scratch(depth, nesting, _BATCH)
    n = 0
    for i in range(i0, i1):
        for j in range(j0, j1):
            if not near[i, j]:
                continue
            gx, gy = xs[i] - cx, ys[j] - cy
            if circle:
                d = math.hypot(gx, gy) - r
                if d < best[i, j] or math.isnan(d):
                    best[i, j] = d
                continue
            ii[n], jj[n] = i, j
            points[n, 0] = c * gx + s * gy
            points[n, 1] = -s * gx + c * gy
            n += 1
            if n == _BATCH:
                _merge(best, code, consts, points, n, stack, frames, cur, value, grad, ii, jj)
                n = 0
    if n:
        _merge(best, code, consts, points, n, stack, frames, cur, value, grad, ii, jj)
    _retile(best, tiles, i0, i1, j0, j1)


@njit(cache=True)
def _merge(best, code, consts, points, n, stack, frames, cur, value, grad, ii, jj) -> None:
    """Evaluate the program at points[:n] and keep the minimum at (ii, jj) in best."""
    run_shared(code, consts, points, n, stack, frames, cur, value, grad, 0, 0, 0)
    for k in range(n):
        d = value[k]
        if d < best[ii[k], jj[k]] or math.isnan(d):
            best[ii[k], jj[k]] = d


@lru_cache(maxsize=8)
def _field_lut(pal: Palette, scale: float, spacing: float) -> tuple[np.ndarray, float, float]:
    """The field overlay's colours as a table: (2, N, 3) uint8, row 0 inside (f = -a),
    row 1 outside (f = a), for a = 0, q, 2q, ... up to ``far`` + ``spacing``, with q a
    32nd of a pixel (colours within 4 of the formula's across the iso-lines). Beyond
    ``far`` = 16 spacings the shading has saturated (to 3e-4) and the colours repeat
    every spacing (``_shade`` folds |f| back)."""
    q = 1.0 / (32.0 * scale)
    far = 16.0 * spacing
    a = np.arange(int((far + spacing) / q) + 2) * q
    table = _distance_colours(np.stack([-a, a]), scale, spacing, pal)
    return np.ascontiguousarray(table), q, far


@njit(cache=True)
def _shade(d: np.ndarray, step: int, width: int, height: int, lut: np.ndarray, q: float,
           far: float, spacing: float) -> np.ndarray:
    """RGB (width, height, 3) uint8 of the distance map ``d`` (m) given at the centres of
    ``step`` px blocks (step 1: at every pixel), interpolated bilinearly at each pixel
    centre and looked up in ``lut`` (``_field_lut``)."""
    out = np.empty((width, height, 3), np.uint8)
    cw, ch = d.shape
    for i in range(width):
        u = min(max((i + 0.5) / step - 0.5, 0.0), cw - 1.0)
        i0 = min(int(u), cw - 2) if cw > 1 else 0
        fu = u - i0 if cw > 1 else 0.0
        i1 = i0 + 1 if cw > 1 else 0
        for j in range(height):
            v = min(max((j + 0.5) / step - 0.5, 0.0), ch - 1.0)
            j0 = min(int(v), ch - 2) if ch > 1 else 0
            fv = v - j0 if ch > 1 else 0.0
            j1 = j0 + 1 if ch > 1 else 0
            f = ((1.0 - fu) * ((1.0 - fv) * d[i0, j0] + fv * d[i0, j1])
                 + fu * ((1.0 - fv) * d[i1, j0] + fv * d[i1, j1]))
            if not math.isfinite(f):
                f = 1e6
            a = abs(f)
            if a > far:
                a = far + (a - far) % spacing
            k = int(a / q + 0.5)
            row = 0 if f <= 0.0 else 1
            for c in range(3):
                out[i, j, c] = lut[row, k, c]
    return out


def _distance_colours(d: np.ndarray, scale: float, spacing: float, pal: Palette) -> np.ndarray:
    """RGB (W, H, 3) uint8 of the distance map ``d`` (m) sampled at ``scale`` samples per
    metre: inside/outside colour, darker near the surface, bands with a line every
    ``spacing`` m, the zero line in ``pal.iso``."""
    base = np.where((d <= 0)[:, :, None], np.array(pal.field_inside, float),
                    np.array(pal.field_outside, float))
    shade = 0.4 + 0.6 * (1.0 - np.exp(-np.abs(d) / (2.0 * spacing)))
    band = 0.82 + 0.18 * np.cos(2.0 * np.pi * d / spacing)
    colour = base * (shade * band)[:, :, None]
    off = np.abs(d - spacing * np.round(d / spacing)) * scale
    line = 0.5 * np.clip(1.0 - off, 0.0, 1.0)[:, :, None]
    zero = np.clip(1.5 - np.abs(d) * scale, 0.0, 1.0)[:, :, None]
    iso = np.array(pal.iso, float)
    colour = colour + (iso - colour) * line
    colour = colour + (iso - colour) * zero
    return np.clip(colour + 0.5, 0, 255).astype(np.uint8)
