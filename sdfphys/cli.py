"""The ``sdfphys`` command line (DESIGN.md): run | play | record | check | bench | compare |
sweep.

Exit status: 0 ok, 1 a check failed, 2 bad input or usage, 130 after SIGINT (Ctrl-C)
and 143 after SIGTERM. Bad input prints one line ``sdfphys: error: <file>: <key
path>: <what is wrong>`` and no traceback, a signal one line ``sdfphys: interrupted
(SIGTERM)``; nothing half-written is left behind (video sinks, trajectory files and
bench outputs are written under a temporary name and renamed when complete; a sweep's
results file keeps the rows of the runs that finished, for ``--resume``).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import signal
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from . import __version__, interrupt
from .errors import SpecError
from .limits import MAX_DURATION, MAX_STEPS, check_steps
from .progress import Progress
from .summary import simulate, state_hash, steps_for
from .trajectory import TOLERANCES

# pygame prints a banner when imported unless this is set; the commands import it late.
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

__all__ = ["main", "state_hash"]


class UsageError(Exception):
    """Bad command-line usage that argparse cannot see (exit 2)."""


def _parser() -> argparse.ArgumentParser:
    from .sweep import cluster_options

    parser = argparse.ArgumentParser(prog="sdfphys", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"sdfphys {__version__}")
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
                   "(options: -o DIR, --quick, --workers N | --scheduler ADDRESS)", add_help=False)

    compare = sub.add_parser("compare", help="the same scene in pymunk: contact and "
                             "trajectory differences (exit 2 if pymunk cannot model it)")
    compare.add_argument("scene")
    compare.add_argument("--seconds", type=float, help="simulated seconds (default: the "
                         "scene's sim.duration)")
    compare.add_argument("--set", dest="overrides", action="append", default=[],
                         metavar="KEY=VALUE", help="override a scene value")
    _max_steps_option(compare)

    sweep = sub.add_parser("sweep", help="scenes x settings x repeats on a Dask cluster, "
                           "one CSV row per run (needs the cluster extra)")
    sweep.add_argument("scenes", nargs="+", metavar="SCENE")
    sweep.add_argument("--set", dest="sets", action="append", default=[],
                       metavar="KEY=V1,V2,...", help="a swept scene value, e.g. "
                       "sim.substeps=4,8 (one column per key; the cross product is run)")
    sweep.add_argument("--quality", metavar="Q1,Q2", help="quality presets to sweep "
                       "(default: each scene's own)")
    sweep.add_argument("--seconds", type=float, help="simulated seconds (default: each "
                       "scene's sim.duration)")
    _max_steps_option(sweep)
    sweep.add_argument("--repeat", type=int, default=1, metavar="R",
                       help="runs of each setting (default 1)")
    sweep.add_argument("-o", "--output", required=True, metavar="RESULTS.csv",
                       help="CSV written row by row as runs finish")
    sweep.add_argument("--resume", action="store_true",
                       help="continue RESULTS.csv: skip the runs it already has")
    cluster_options(sweep)
    return parser


def _max_steps_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--max-steps", type=int, metavar="N",
                        help=f"allow a run of up to N steps or frames (default {MAX_STEPS:,})")


def _scene_options(parser: argparse.ArgumentParser, seconds: bool = True) -> None:
    if seconds:
        parser.add_argument("--seconds", type=float, help="simulated seconds (default: the "
                            "scene's sim.duration)")
        _max_steps_option(parser)
    parser.add_argument("--quality", choices=("fast", "balanced", "accurate"),
                        help="quality preset (overrides the scene's sim.quality)")
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="KEY=VALUE", help="override a scene value, e.g. sim.substeps=8")


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; return its exit status (see the module docstring)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    with interrupt.handled():
        try:
            return _dispatch(argv)
        except BaseException as err:
            signum = interrupt.received()
            if signum is None:
                if isinstance(err, KeyboardInterrupt):   # outside handled(): a thread
                    signum = signal.SIGINT
                else:
                    raise
            sys.stdout.flush()
            print(f"sdfphys: interrupted ({signal.Signals(signum).name})", file=sys.stderr)
            interrupt.quiet_finalizers()
            return interrupt.exit_status(signum)


def _dispatch(argv: list[str]) -> int:
    if argv[:1] == ["bench"]:
        from .bench import bench_main

        return bench_main(argv[1:])
    args = _parser().parse_args(argv)
    try:
        commands = {"run": _run, "play": _play, "record": _record, "check": _check,
                    "compare": _compare, "sweep": _sweep}
        return commands[args.command](args)
    except (SpecError, UsageError) as err:
        print(f"sdfphys: error: {err}", file=sys.stderr)
        return 2


def _compare(args) -> int:
    from .reference import compare_main

    return compare_main(args.scene, args.seconds, args.overrides, args.max_steps)


def _read(args):
    from .scene import read_scene

    return read_scene(args.scene, args.overrides, quality=args.quality)


def _check_seconds(args) -> None:
    """``--seconds`` if given: > 0, finite, at most ``MAX_DURATION``; ``--max-steps`` if
    given: >= 1 (a scene's own duration is checked when it is read)."""
    if args.seconds is not None:
        if not (math.isfinite(args.seconds) and args.seconds > 0):
            raise UsageError(f"--seconds: must be a positive number, got {args.seconds}")
        if args.seconds > MAX_DURATION:
            raise UsageError(f"--seconds: must be <= {MAX_DURATION:g}, got {args.seconds:g}")
    if args.max_steps is not None and args.max_steps < 1:
        raise UsageError(f"--max-steps: must be >= 1, got {args.max_steps}")


def _seconds(args, scene) -> float:
    """``--seconds`` if given (checked), else the scene's duration."""
    _check_seconds(args)
    return scene.duration if args.seconds is None else args.seconds


def _run(args) -> int:
    if args.output:
        from .video import output_error

        problem = output_error(args.output)
        if problem:
            raise SpecError("", problem, args.output)
    scene = _read(args)
    seconds = _seconds(args, scene)
    dt, fps = scene.settings.dt, scene.render.fps
    steps = steps_for(seconds, dt)
    frames = round(seconds * fps) if args.output else 0
    check_steps(steps, "steps", args.max_steps)
    check_steps(frames, "frames", args.max_steps)
    world = scene.build()
    sink = renderer = surface = None
    progress = Progress(steps, "steps", "sdfphys run")
    frame = 0

    def draw_due(step: int) -> None:
        """Frame k shows the state at time k / fps: draw every frame due by now (after
        the last step, the rest: rounding leaves them showing the final state)."""
        nonlocal frame
        while sink is not None and frame < frames and (
                step == steps or frame / fps <= step * dt + 1e-9):
            renderer.draw(surface, world, hud=scene.render.hud)
            sink.write(surface)
            frame += 1

    try:
        if args.output:
            import pygame

            from .render import Camera, Renderer
            from .video import open_sink

            size = scene.render.size
            renderer = Renderer(Camera(scene.render.center, scene.render.scale, size))
            surface = pygame.Surface(size)
            sink = open_sink(args.output, size, fps)
        summary = simulate(world, steps, draw_due, progress.update)
        if sink is not None:
            sink.close()
    except BaseException:
        progress.close()
        if sink is not None:
            sink.abort()
        raise
    progress.close()
    print(f"steps          {steps}")
    print(f"wall time      {summary.wall_s:.3f} s")
    print(f"steps/s        {steps / summary.wall_s:.1f}")
    print(f"max penetration {summary.max_penetration:.6f} m")
    print(f"energy         {summary.energy_start:.6g} J -> {summary.energy_end:.6g} J")
    print(f"state hash     {summary.state_hash}")
    if sink is not None:
        print(f"wrote          {args.output} ({sink.frames_written} frames at "
              f"{sink.fps_written:g} fps)")
    return 0


def _sweep(args) -> int:
    _check_seconds(args)
    from .sweep import sweep_main

    return sweep_main(args.scenes, args.sets, args.quality, args.seconds, args.repeat,
                      args.output, resume=args.resume, workers=args.workers,
                      scheduler=args.scheduler, max_steps=args.max_steps)


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
    scene = _read(args)
    seconds = _seconds(args, scene)
    steps = steps_for(seconds, scene.settings.dt)
    check_steps(steps, "steps", args.max_steps)
    start = time.perf_counter()
    progress = Progress(steps, "steps", "sdfphys record")
    try:
        trajectory = record(args.scene, seconds, args.overrides, args.quality,
                            max_steps=steps, progress=progress.update)
    finally:
        progress.close()
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
        match_bodies(reference.name, [b.name for b in scene.bodies], appended=True)
    except SpecError as err:
        raise err.in_file(args.trajectory) from None
    changed = [key for key, value in dataclasses.asdict(scene.settings).items()
               if meta["settings"].get(key) != value]
    if changed:
        print(f"note: settings changed since the recording: {', '.join(changed)}")
    progress = Progress(meta["steps"], "steps", "sdfphys check")
    try:      # as many steps as the file holds frames: its own --max-steps
        replay = record(args.scene, meta["seconds"], meta["overrides"], meta["quality"],
                        max_steps=reference.frames - 1, progress=progress.update)
    finally:
        progress.close()
    tolerances = None if args.atol is None else dict.fromkeys(TOLERANCES, args.atol)
    try:
        deviation = compare(reference, replay, tolerances)
    except SpecError as err:
        raise err.in_file(args.trajectory) from None
    print(f"replayed       {replay.frames} frames x {replay.bodies} bodies")
    print(deviation)
    print("check          " + ("passed" if deviation.ok else "FAILED"))
    return 0 if deviation.ok else 1


if __name__ == "__main__":
    sys.exit(main())
