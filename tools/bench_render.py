"""Frames per second of simulation + rendering (+ encoding) of a 200-body scene.

Scene: a static ground (a half-plane SDF) and two static walls; 200 bodies in all,
dropped from a jittered grid: circles and boxes (triangle meshes) in equal parts
and a few SDF bodies (a ring and a smooth union of a circle and a box, one of each
every 40 bodies). Gravity -9.81 m/s^2, default Settings (dt 1/60 s), camera
centred at (0, 4) m, 50 px/m, 960 x 540 px, 60 frames/s: one step per frame.

Two runs of the same frames from the same initial state:
  1. simulate + render onto an off-screen Surface;
  2. simulate + render + encode to H.264 .mp4 (sdfphys.video; ffmpeg runs in its own
     process, so on two or more cores encoding overlaps the simulation).
Reported: the median frames per second of each run (per-frame wall time) and the
same without the simulation step (the renderer's and encoder's own budget), the
median milliseconds spent per frame in step(), draw() and the sink's write(), and
the median CPU time of this process per frame (less sensitive than wall time to
other load on the machine; ffmpeg's own CPU time is not in it).
The target is >= 60 frames/s including the simulation. The first step (numba
compilation, mass properties) is run before timing starts.

Usage: python tools/bench_render.py [--bodies 200] [--frames 300] [--output out.mp4]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from sdfphys.render import Camera, Renderer
from sdfphys.video import open_sink
from sdfphys.world import World

SIZE = (960, 540)
FPS = 60
TARGET_FPS = 60.0

GROUND = {"type": "sdf", "field": {"type": "half_plane", "normal": [0.0, 1.0],
                                   "distance": 0.0}}
WALL = {"type": "box", "size": [0.5, 9.0]}
RING = {"type": "sdf", "field": {"op": "onion", "thickness": 0.08,
                                 "of": {"type": "circle", "radius": 0.3}}}
BLOB = {"type": "sdf", "field": {"op": "smooth_union", "k": 0.1, "of": [
    {"type": "circle", "radius": 0.22, "offset": [-0.18, 0.0]},
    {"type": "box", "size": [0.4, 0.3], "offset": [0.18, 0.0]}]}}
BOX = {"type": "box", "size": [0.5, 0.4]}
CIRCLE = {"type": "circle", "radius": 0.25}


def build_scene(bodies: int = 200, seed: int = 7) -> World:
    """The benchmark world: ground, two walls and ``bodies - 3`` falling bodies."""
    rng = np.random.default_rng(seed)
    world = World(gravity=(0.0, -9.81))
    world.add_body(GROUND, kind="static", name="ground")
    world.add_body(WALL, position=(-9.35, 4.5), kind="static", name="left")
    world.add_body(WALL, position=(9.35, 4.5), kind="static", name="right")
    columns = 22
    for i in range(bodies - 3):
        kind = RING if i % 40 == 13 else BLOB if i % 40 == 33 else BOX if i % 2 else CIRCLE
        x = -8.4 + (i % columns) * 0.8 + rng.uniform(-0.1, 0.1)
        y = 0.6 + (i // columns) * 0.8
        world.add_body(kind, position=(x, y), angle=rng.uniform(0.0, np.pi))
    return world


def run(bodies: int, frames: int, output: Path | None) -> dict[str, np.ndarray]:
    """Per-frame wall times (s) of step, draw, write and the whole frame, and the
    process CPU time (s) of the frame."""
    world = build_scene(bodies)
    world.step()
    renderer = Renderer(Camera((0.0, 4.0), 50.0, SIZE))
    surface = pygame.Surface(SIZE)
    renderer.draw(surface, world)
    times = {name: np.zeros(frames) for name in ("step", "draw", "write", "frame", "cpu")}
    sink = open_sink(output, SIZE, FPS) if output is not None else None
    try:
        for k in range(frames):
            cpu = time.process_time()
            t0 = time.perf_counter()
            world.step()
            t1 = time.perf_counter()
            renderer.draw(surface, world)
            t2 = time.perf_counter()
            if sink is not None:
                sink.write(surface)
            t3 = time.perf_counter()
            times["step"][k], times["draw"][k] = t1 - t0, t2 - t1
            times["write"][k], times["frame"][k] = t3 - t2, t3 - t0
            times["cpu"][k] = time.process_time() - cpu
        if sink is not None:
            sink.close()
    except BaseException:
        if sink is not None:
            sink.abort()
        raise
    return times


def report(name: str, times: dict[str, np.ndarray]) -> float:
    fps = 1.0 / float(np.median(times["frame"]))
    parts = "   ".join(f"{part} {1000 * np.median(times[part]):6.2f} ms"
                       for part in ("step", "draw", "write", "cpu"))
    verdict = "ok" if fps >= TARGET_FPS else f"below the {TARGET_FPS:.0f} frames/s target"
    alone = 1.0 / float(np.median(times["draw"] + times["write"]))
    print(f"{name:<28} {fps:7.1f} frames/s (median)   {parts}   {verdict}\n"
          f"{'':<28} {alone:7.1f} frames/s without the step")
    return fps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bodies", type=int, default=200)
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--output", type=Path, default=None,
                        help="keep the video here (default: a temporary file)")
    args = parser.parse_args()
    print(f"{args.bodies} bodies, {args.frames} frames at {SIZE[0]}x{SIZE[1]}, "
          f"{os.cpu_count()} cores")
    report("simulate + render", run(args.bodies, args.frames, None))
    with tempfile.TemporaryDirectory() as scratch:
        output = args.output or Path(scratch) / "bench.mp4"
        report("simulate + render + encode", run(args.bodies, args.frames, output))


if __name__ == "__main__":
    main()
