"""The ``sdfphys`` command line (DESIGN.md): run | play.

Exit status: 0 ok, 1 a check failed, 2 bad input or usage. Bad input prints one
line ``sdfphys: error: <file>: <key path>: <what is wrong>`` and no traceback;
nothing half-written is left behind (video sinks write to a temporary name).
"""

from __future__ import annotations

import argparse
import hashlib
import math
import os
import sys
import time
from collections.abc import Sequence

import numpy as np

from .errors import SpecError

__all__ = ["main", "state_hash"]


class UsageError(Exception):
    """Bad command-line usage that argparse cannot see (exit 2)."""


def state_hash(world) -> str:
    """SHA-256 (first 16 hex digits) of the bodies' positions, angles and velocities."""
    digest = hashlib.sha256()
    for array in (world.position, world.angle, world.velocity, world.angular_velocity):
        digest.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
    return digest.hexdigest()[:16]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sdfphys", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="simulate a scene, optionally to a video")
    run.add_argument("scene")
    run.add_argument("-o", "--output", help="OUT.mp4, OUT.gif or DIR/ (numbered PNG frames)")
    _scene_options(run)

    play = sub.add_parser("play", help="interactive window (needs a display)")
    play.add_argument("scene")
    _scene_options(play, seconds=False)
    return parser


def _scene_options(parser: argparse.ArgumentParser, seconds: bool = True) -> None:
    if seconds:
        parser.add_argument("--seconds", type=float, help="simulated seconds (default: the "
                            "scene's sim.duration)")
    parser.add_argument("--quality", choices=("fast", "balanced", "accurate"),
                        help="quality preset (overrides the scene's sim.quality)")
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="KEY=VALUE", help="override a scene value, e.g. sim.substeps=8")


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return {"run": _run, "play": _play}[args.command](args)
    except (SpecError, UsageError) as err:
        print(f"sdfphys: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("sdfphys: interrupted", file=sys.stderr)
        return 130


def _read(args):
    from .scene import read_scene

    return read_scene(args.scene, args.overrides, quality=args.quality)


def _run(args) -> int:
    scene = _read(args)
    seconds = scene.duration if args.seconds is None else args.seconds
    if not (math.isfinite(seconds) and seconds > 0):
        raise UsageError(f"--seconds: must be a positive number, got {args.seconds}")
    world = scene.build()
    dt = scene.settings.dt
    steps = max(1, round(seconds / dt))
    frames = round(seconds * scene.render.fps) if args.output else 0
    sink = renderer = surface = None
    if args.output:
        from .render import Camera, Renderer
        from .video import open_sink

        import pygame

        size = scene.render.size
        sink = open_sink(args.output, size, scene.render.fps)
        renderer = Renderer(Camera(scene.render.center, scene.render.scale, size))
        surface = pygame.Surface(size)

    progress = _Progress(steps) if sys.stderr.isatty() else None
    energy0 = world.kinetic_energy() + world.potential_energy()
    max_depth = 0.0
    frame = 0
    start = time.perf_counter()
    try:
        for step in range(steps + 1):
            # Frame k shows the state at time k / fps: draw every frame due by now.
            while sink is not None and frame < frames and frame / scene.render.fps <= step * dt + 1e-9:
                renderer.draw(surface, world)
                sink.write(surface)
                frame += 1
            if step == steps:
                break
            world.step()
            if len(world.contacts):
                max_depth = max(max_depth, float(world.contacts.depth.max()))
            if progress:
                progress.update(step + 1)
        if sink is not None:
            while frame < frames:     # rounding: the last frames show the final state
                renderer.draw(surface, world)
                sink.write(surface)
                frame += 1
            sink.close()
    except BaseException:
        if sink is not None:
            sink.abort()
        raise
    wall = time.perf_counter() - start
    if progress:
        progress.done()
    energy1 = world.kinetic_energy() + world.potential_energy()
    print(f"steps          {steps}")
    print(f"wall time      {wall:.3f} s")
    print(f"steps/s        {steps / wall:.1f}")
    print(f"max penetration {max_depth:.6f} m")
    print(f"energy         {energy0:.6g} J -> {energy1:.6g} J")
    print(f"state hash     {state_hash(world)}")
    if args.output:
        print(f"wrote          {args.output} ({frames} frames at {scene.render.fps} fps)")
    return 0


def _play(args) -> int:
    scene = _read(args)
    from .play import play

    return play(scene.build, scene.render)


class _Progress:
    """A one-line progress bar on stderr (only when stderr is a terminal)."""

    def __init__(self, total: int):
        self.total = total
        self.last = -1

    def update(self, done: int) -> None:
        percent = 100 * done // self.total
        if percent != self.last:
            self.last = percent
            bar = "#" * (percent // 4)
            sys.stderr.write(f"\r[{bar:<25}] {percent:3d}% ({done}/{self.total} steps)")
            sys.stderr.flush()

    def done(self) -> None:
        sys.stderr.write("\n")


if __name__ == "__main__":
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    sys.exit(main())
