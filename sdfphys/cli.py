"""The ``sdfphys`` command line (DESIGN.md): run | play | record | check.

Exit status: 0 ok, 1 a check failed, 2 bad input or usage. Bad input prints one
line ``sdfphys: error: <file>: <key path>: <what is wrong>`` and no traceback;
nothing half-written is left behind (video sinks and trajectory files are written
under a temporary name and renamed when complete).
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .errors import SpecError
from .trajectory import TOLERANCES

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

    record = sub.add_parser("record", help="simulate a scene and write its trajectory (.npz)")
    record.add_argument("scene")
    record.add_argument("-o", "--output", required=True, metavar="TRAJ.npz",
                        help="trajectory file to write (replaced atomically)")
    _scene_options(record)

    check = sub.add_parser("check", help="replay a recorded trajectory and compare (exit 1 "
                           "if it deviates beyond the tolerances)")
    check.add_argument("scene")
    check.add_argument("trajectory", metavar="TRAJ.npz")
    check.add_argument("--atol", type=float, help="one absolute tolerance for every quantity "
                       "(default: " + ", ".join(f"{k} {v:g}" for k, v in TOLERANCES.items())
                       + ")")

    sub.add_parser("bench", help="the speed/accuracy study: CSV, markdown table and plot "
                   "(options: -o DIR, --quick)", add_help=False)

    compare = sub.add_parser("compare", help="the same scene in pymunk: contact and "
                             "trajectory differences (exit 2 if pymunk cannot model it)")
    compare.add_argument("scene")
    compare.add_argument("--seconds", type=float, help="simulated seconds (default: the "
                         "scene's sim.duration)")
    compare.add_argument("--set", dest="overrides", action="append", default=[],
                         metavar="KEY=VALUE", help="override a scene value")
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
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["bench"]:
        from .bench import bench_main

        return bench_main(argv[1:])
    args = _parser().parse_args(argv)
    try:
        commands = {"run": _run, "play": _play, "record": _record, "check": _check,
                    "compare": _compare}
        return commands[args.command](args)
    except (SpecError, UsageError) as err:
        print(f"sdfphys: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("sdfphys: interrupted", file=sys.stderr)
        return 130


def _compare(args) -> int:
    from .reference import compare_main

    return compare_main(args.scene, args.seconds, args.overrides)


def _read(args):
    from .scene import read_scene

    return read_scene(args.scene, args.overrides, quality=args.quality)


def _seconds(args, scene) -> float:
    """``--seconds`` if given (checked > 0 and finite), else the scene's duration."""
    seconds = scene.duration if args.seconds is None else args.seconds
    if not (math.isfinite(seconds) and seconds > 0):
        raise UsageError(f"--seconds: must be a positive number, got {args.seconds}")
    return seconds


def _run(args) -> int:
    scene = _read(args)
    seconds = _seconds(args, scene)
    world = scene.build()
    dt = scene.settings.dt
    steps = max(1, round(seconds / dt))
    frames = round(seconds * scene.render.fps) if args.output else 0
    sink = renderer = surface = None
    if args.output:
        import pygame

        from .render import Camera, Renderer
        from .video import open_sink

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
            while (sink is not None and frame < frames
                   and frame / scene.render.fps <= step * dt + 1e-9):
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


def _record(args) -> int:
    from .trajectory import record

    output = Path(args.output)
    if output.suffix.lower() != ".npz":
        raise UsageError(f"-o: a trajectory file ends in .npz, got {args.output!r}")
    if not output.parent.is_dir():
        raise UsageError(f"{args.output}: no such directory {str(output.parent)!r}")
    seconds = _seconds(args, _read(args))
    start = time.perf_counter()
    trajectory = record(args.scene, seconds, args.overrides, args.quality)
    wall = time.perf_counter() - start
    try:
        trajectory.save(output)
    except OSError as err:
        raise UsageError(f"{args.output}: cannot write: {err.strerror or err}") from None
    steps = trajectory.meta["steps"]
    print(f"steps          {steps}")
    print(f"wall time      {wall:.3f} s")
    print(f"wrote          {args.output} ({trajectory.frames} frames x "
          f"{trajectory.bodies} bodies)")
    return 0


def _check(args) -> int:
    from .scene import read_scene
    from .trajectory import compare, load, match_bodies, record

    if args.atol is not None and not (math.isfinite(args.atol) and args.atol >= 0):
        raise UsageError(f"--atol: must be a finite number >= 0, got {args.atol}")
    reference = load(args.trajectory)
    meta = reference.meta
    scene = read_scene(args.scene, meta["overrides"], quality=meta["quality"])
    if scene.digest != meta["scene_digest"]:
        raise UsageError(f"{args.trajectory}: recorded from another scene: {meta['scene']} "
                         f"(digest {meta['scene_digest'][:12]}), not {args.scene} (digest "
                         f"{scene.digest[:12]})")
    try:
        match_bodies(reference.name, [b.name for b in scene.bodies])
    except SpecError as err:
        raise err.in_file(args.trajectory) from None
    changed = [key for key, value in dataclasses.asdict(scene.settings).items()
               if meta["settings"].get(key) != value]
    if changed:
        print(f"note: settings changed since the recording: {', '.join(changed)}")
    replay = record(args.scene, meta["seconds"], meta["overrides"], meta["quality"])
    tolerances = None if args.atol is None else dict.fromkeys(TOLERANCES, args.atol)
    try:
        deviation = compare(reference, replay, tolerances)
    except SpecError as err:
        raise err.in_file(args.trajectory) from None
    print(f"replayed       {replay.frames} frames x {replay.bodies} bodies")
    print(deviation)
    print("check          " + ("passed" if deviation.ok else "FAILED"))
    return 0 if deviation.ok else 1


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
