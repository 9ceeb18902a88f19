"""Benchmark: the cost of a carve and of a step after 20 carves and after 1,000.

A static ground (a 40 m x 2 m box, baked at Settings.carve_cell at its first carve)
carries a row of crates at rest; holes of radius 8 cm are carved at random in its lower
half (under the crates' contacts, which they never reach), and the world is stepped
between carves so that the crates keep colliding with the edited body. The claim of
docs/terrain.md: after 1,000 carves a carve and a step cost no more than 1.5x what they
cost after 20 (the grid is edited in place: its arrays keep their shape and dtype, and
a carve touches only the nodes its bounds cover).

Prints the first carve's time (with a cold numba cache, ``NUMBA_CACHE_DIR=$(mktemp -d)``,
it includes compiling the re-distancing kernel, and the image terrain's first load the
distance transform's), then the medians over each block of carves and of steps.

    python tools/bench_carve.py [--carves 1000] [--steps 50]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

from sdfphys import World
from sdfphys.sdf import field

HOLE = {"type": "circle", "radius": 0.08}


def _world() -> World:
    w = World()
    w.add_body({"type": "sdf", "field": {"type": "box", "size": [40.0, 2.0]}},
               kind="static", name="ground")
    for x in np.arange(-18.0, 18.5, 1.5):
        w.add_body({"type": "box", "size": [0.5, 0.5]}, position=(float(x), 1.25))
    w.settings = w.settings.with_values(sleeping=False)   # every step collides every crate
    return w


def _steps(w: World, count: int) -> float:
    """Median seconds per step over ``count`` steps."""
    times = []
    for _ in range(count):
        t = time.perf_counter()
        w.step()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def _first_image_load() -> float:
    """Seconds to build a 400 x 200 px image terrain (first load: compiles the EDT)."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    with tempfile.TemporaryDirectory() as tmp:
        surface = pygame.Surface((400, 200))
        surface.fill((255, 255, 255), pygame.Rect(0, 100, 400, 100))
        path = os.path.join(tmp, "ground.png")
        pygame.image.save(surface, path)
        t = time.perf_counter()
        field({"type": "image", "path": path, "cell": 0.02})
        return time.perf_counter() - t


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--carves", type=int, default=1000)
    parser.add_argument("--steps", type=int, default=50, help="steps timed per block")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    w = _world()
    for _ in range(30):                                   # compile the step, settle
        w.step()
    t = time.perf_counter()
    w.carve("ground", HOLE, (0.0, -0.5))
    first = time.perf_counter() - t
    t = time.perf_counter()
    w.carve("ground", HOLE, (1.0, -0.5))
    second = time.perf_counter() - t
    print(f"first carve {first * 1e3:.1f} ms (bakes the ground; a cold cache compiles), "
          f"second {second * 1e3:.2f} ms")
    print(f"first image terrain load (400 x 200 px) {_first_image_load() * 1e3:.1f} ms")

    def block(count: int) -> tuple[float, float]:
        carve_times = []
        for _ in range(count):
            x, y = rng.uniform([-19.5, -0.95], [19.5, -0.2])
            t = time.perf_counter()
            w.carve("ground", HOLE, (float(x), float(y)))
            carve_times.append(time.perf_counter() - t)
            w.step()
        return float(np.median(carve_times)), _steps(w, args.steps)

    carve_20, step_20 = block(18)                       # carves 3..20
    block(args.carves - 40)
    carve_n, step_n = block(20)                         # the last 20
    print(f"after 20 carves:    carve {carve_20 * 1e3:.3f} ms, step {step_20 * 1e3:.3f} ms")
    print(f"after {args.carves} carves: carve {carve_n * 1e3:.3f} ms, "
          f"step {step_n * 1e3:.3f} ms")
    print(f"ratios: carve {carve_n / carve_20:.2f}x, step {step_n / step_20:.2f}x "
          "(claim: <= 1.5x)")
    return 0 if carve_n <= 1.5 * carve_20 and step_n <= 1.5 * step_20 else 1


if __name__ == "__main__":
    sys.exit(main())
