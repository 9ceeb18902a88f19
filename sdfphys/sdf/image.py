"""Terrain from an image: ``{type = "image", path = "terrain.png", cell = 0.02, threshold = 0.5}``.

The image (any format pygame-ce reads: PNG, BMP, ...) is centred on the field's origin,
one pixel is ``cell`` metres, its rows run from +y (top) to -y (bottom) and its columns
from -x to +x. A pixel is inside where its luminance (0.299 R + 0.587 G + 0.114 B, in
[0, 1]) is >= ``threshold``; where the image has an alpha channel, the alpha decides
instead. The field is a baked grid (``GridField``, bilinear) whose nodes are the pixel
centres, holding the signed Euclidean distance transform of the inside pixels:

    outside pixel p:  f = (|p - q_in| - 1/2) cell,   q_in the nearest inside pixel
    inside pixel p:   f = -(|p - q_out| - 1/2) cell, q_out the nearest outside pixel

so the boundary lies half way between neighbouring inside and outside pixel centres,
and beyond the image everything is outside (an inside pixel on the image's edge is half
a pixel from the boundary). The squared transform is exact: Felzenszwalb and
Huttenlocher's lower envelope of parabolas, "Distance Transforms of Sampled
Functions", Theory of Computing 8 (2012), one pass along the columns and one along the
rows.

Antialiased edges. A pixel on the boundary (a 4-neighbour on the other side) holds
instead (t - level) / max(t, 1 - t) / 2 pixels, t the threshold: +-1/2 for a pure
black or white pixel (as above), and for a grey one the edge moves into the pixel in
proportion to its level (for t = 1/2, a pixel whose level is its covered fraction gets
1/2 - coverage: exact for an edge along a pixel row or column). Then the nodes within
``SMOOTH_CELLS`` cells of the boundary are re-distanced from its polyline
(``edit.redistance``): the distance to the edge through these sub-pixel points, where
the transform of a binary image is the distance to a pixel staircase, whose gradient
turns at every step (boxes and triangles sliding on a slope drawn in black and white
at 2 cm per pixel sank 1-3 cm into it; drawn antialiased, under 1 cm:
scenes/image_terrain.toml). A shape drawn d pixels wide is that wide within about a
pixel (a binary edge wanders by up to half a pixel); tests/test_terrain.py checks a
disc 40 px wide is a 0.8 m disc within one cell.

A missing or unreadable image raises SpecError naming ``path``; an image with no
inside pixel one naming ``threshold``. Relative paths are taken from the current
directory here; a scene file's image paths are relative to the scene file (``scene.py``
resolves them).
"""

from __future__ import annotations

import math
import os

import numpy as np

from .._jit import njit
from ..errors import SpecError
from .base import REQUIRED, Param, primitive
from .edit import redistance
from .grid import MAX_NODES, GridField

__all__ = ["SMOOTH_CELLS", "image_field", "pixel_levels", "signed_distance_transform"]

#: Nodes within this many cells of the boundary get their distance to its polyline
#: (``edit.redistance``), which runs through the sub-pixel edge points.
SMOOTH_CELLS = 3

#: Stands for "no feature pixel yet" in the squared transform (1e20 px^2, finite so
#: that differences of it stay finite).
_FAR = 1e20


def pixel_levels(path: str) -> np.ndarray:
    """(W, H) float in [0, 1], indexed [column, row from the top]: each pixel's alpha if
    the image has an alpha channel, else its luminance (see module)."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    try:
        surface = pygame.image.load(path)
    except (pygame.error, OSError, ValueError) as err:
        raise SpecError("path", f"cannot read image {path!r}: {err}") from None
    w, h = surface.get_size()
    if w * h > MAX_NODES or min(w, h) < 2:
        raise SpecError("path", f"image {path!r} is {w} x {h} px: it needs at least 2 x 2 "
                                f"and at most {MAX_NODES} pixels")
    if surface.get_masks()[3] != 0 or surface.get_flags() & pygame.SRCALPHA:
        level = pygame.surfarray.array_alpha(surface).astype(np.float64) / 255.0
    else:
        rgb = pygame.surfarray.array3d(surface).astype(np.float64) / 255.0
        level = rgb[..., 0] * 0.299 + rgb[..., 1] * 0.587 + rgb[..., 2] * 0.114
    return level


def signed_distance_transform(inside: np.ndarray) -> np.ndarray:
    """Signed distance (px) at the pixel centres of ``inside`` (W, H) bool (module doc):
    < 0 inside; the image is surrounded by outside pixels."""
    padded = np.zeros((inside.shape[0] + 2, inside.shape[1] + 2), dtype=bool)
    padded[1:-1, 1:-1] = inside
    to_inside = np.sqrt(_squared_transform(np.where(padded, 0.0, _FAR)))
    to_outside = np.sqrt(_squared_transform(np.where(padded, _FAR, 0.0)))
    signed = np.where(padded, 0.5 - to_outside, to_inside - 0.5)
    return signed[1:-1, 1:-1]


@njit(cache=True, error_model="numpy")
def _squared_transform(f: np.ndarray) -> np.ndarray:
    """min over pixels q of |p - q|^2 + f(q), for every pixel p of f (W, H): columns,
    then rows, each by the lower envelope of parabolas (Felzenszwalb, Huttenlocher)."""
    out = f.copy()
    n = max(f.shape[0], f.shape[1])
    line, result = np.empty(n), np.empty(n)
    v = np.empty(n, np.int64)
    z = np.empty(n + 1)
    for axis in range(2):
        count, lines = (out.shape[1], out.shape[0]) if axis == 0 else (out.shape[0],
                                                                       out.shape[1])
        for a in range(lines):
            for q in range(count):
                line[q] = out[a, q] if axis == 0 else out[q, a]
            k = 0
            v[0], z[0], z[1] = 0, -math.inf, math.inf
            for q in range(1, count):
                s = ((line[q] + q * q) - (line[v[k]] + v[k] * v[k])) / (2.0 * (q - v[k]))
                while s <= z[k]:
                    k -= 1
                    s = ((line[q] + q * q) - (line[v[k]] + v[k] * v[k])) / (2.0 * (q - v[k]))
                k += 1
                v[k], z[k], z[k + 1] = q, s, math.inf
            k = 0
            for q in range(count):
                while z[k + 1] < q:
                    k += 1
                result[q] = (q - v[k]) * (q - v[k]) + line[v[k]]
            for q in range(count):
                if axis == 0:
                    out[a, q] = result[q]
                else:
                    out[q, a] = result[q]
    return out


@primitive("image",
           Param("path", "str", REQUIRED, "image file (PNG, BMP, ...); in a scene, relative "
                 "to the scene file"),
           Param("cell", "positive", REQUIRED, "metres per pixel"),
           Param("threshold", "unit", 0.5, "inside where luminance (or alpha) >= this"))
def image_field(path: str, cell: float, threshold: float = 0.5) -> GridField:
    """The baked grid of an image (module docstring): nodes at the pixel centres, the
    image centred on the origin, ``cell`` m per pixel, rows from +y down."""
    level = pixel_levels(path)
    inside = level >= threshold
    if not np.any(inside):
        raise SpecError("threshold", f"no pixel of {path!r} is inside (luminance or alpha "
                                     f">= {threshold:g})")
    signed = signed_distance_transform(inside)
    # Pixels on the boundary (a 4-neighbour on the other side, |signed| = 1/2): the
    # level's distance to the threshold places the edge inside the pixel.
    edge = np.abs(signed) == 0.5
    signed[edge] = (threshold - level[edge]) / max(threshold, 1.0 - threshold) * 0.5
    values = signed[:, ::-1] * cell                               # rows: +y first
    redistance(values, 0, values.shape[0], 0, values.shape[1], SMOOTH_CELLS, cell)
    origin = -0.5 * cell * (np.array(values.shape, dtype=np.float64) - 1.0)
    return GridField.from_values(values, origin, cell)
