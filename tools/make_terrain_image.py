"""Writes scenes/terrain.png, the image of scenes/image_terrain.toml (python tools/make_terrain_image.py).

1200 x 400 px; at the scene's cell of 0.02 m per pixel, 24 m x 8 m centred on the body's
origin. White (inside): rolling hills, a cave under the middle one and a floating
island; black: outside; grey on the edges: each pixel's level is the fraction of its 4 x 4
sub-pixel centres inside (antialiasing), which the image field uses to place the edge
inside the pixel (sdf/image.py). Computed with numpy alone: the same bytes on every
machine.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

OUT = Path(__file__).resolve().parents[1] / "scenes" / "terrain.png"
WIDTH, HEIGHT, CELL = 1200, 400, 0.02


def inside(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The terrain at points (m, image frame: origin at the centre, y up)."""
    ground = y < -1.6 + 0.8 * np.sin(x / 2.5) + 0.35 * np.sin(x / 1.1 + 1.0)
    cave = np.hypot((x - 1.0) / 1.6, (y + 2.9) / 0.7) < 1.0
    island = (np.hypot((x - 5.5) / 2.2, (y - 1.6) / 0.45) < 1.0) | (
        np.hypot((x - 4.6) / 0.9, (y - 1.2) / 0.6) < 1.0)
    return (ground & ~cave) | island


#: Sub-pixel samples per side for the antialiased edge.
SAMPLES = 4


def main() -> None:
    sub = (np.arange(SAMPLES) + 0.5) / SAMPLES - 0.5                # offsets in a pixel
    columns = (np.arange(WIDTH) + 0.5 - WIDTH / 2) * CELL
    rows = (HEIGHT / 2 - 0.5 - np.arange(HEIGHT)) * CELL           # top row first: +y
    x, y = np.meshgrid(columns, rows, indexing="ij")               # (W, H), as surfarray
    cover = np.zeros((WIDTH, HEIGHT))
    for dx in sub:
        for dy in sub:
            cover += inside(x + dx * CELL, y - dy * CELL)
    level = np.rint(cover / SAMPLES**2 * 255.0).astype(np.uint8)
    white = np.repeat(level[..., None], 3, axis=2)
    surface = pygame.Surface((WIDTH, HEIGHT))
    pygame.surfarray.blit_array(surface, white)
    pygame.image.save(surface, str(OUT))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
