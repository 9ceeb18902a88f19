"""Deepest contact of each scene over nearby runs: the spread of a chaotic figure.

A scene's deepest contact over its run (``tests/test_scene_penetration.py``, the bound
1 cm) is one sample of a chaotic system: a change anywhere in the contacts or the
solver moves it either way, and one run cannot tell a fix from luck. Per scene (all of
``scenes/*.toml`` unless ``--scenes``), this runs the scene as written and ``--runs``
times more with every dynamic body's start pose moved by a normal random 1e-6 m (x, y)
and 1e-6 rad (``--nudge``; seed = the run's number, so the runs repeat), over the
scene's ``sim.duration``, and prints the deepest contact of each run in mm and their
largest. ``--json FILE`` also writes {scene: [mm, ...]}. Compare two trees by running
it with ``PYTHONPATH=TREE`` for each.

    python tools/penetration_spread.py --scenes showcase circles_in_box --runs 4
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from sdfphys.scene import read_scene
from sdfphys.summary import simulate, steps_for

ROOT = Path(__file__).resolve().parent.parent


def deepest(path: Path, run: int, nudge: float) -> float:
    """The largest contact depth (m) over ``sim.duration`` of the scene at ``path`` (the
    ``run`` summary's max penetration), its dynamic bodies' start poses moved by
    ``nudge`` (seed ``run``; run 0: as written)."""
    scene = read_scene(path)
    world = scene.build()
    if run:
        rng = np.random.default_rng(run)
        position, angle = world.position, world.angle
        for i in range(len(angle)):
            if world.kind[i] == "dynamic":
                world.set_state(i, position=position[i] + nudge * rng.normal(size=2),
                                angle=float(angle[i] + nudge * rng.normal()))
    return simulate(world, steps_for(scene.duration, world.settings.dt)).max_penetration


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", help="scene names (default: all)")
    parser.add_argument("--runs", type=int, default=4, help="nudged runs per scene")
    parser.add_argument("--nudge", type=float, default=1e-6, help="m and rad")
    parser.add_argument("--json", help="also write {scene: [mm, ...]} here")
    args = parser.parse_args()
    names = args.scenes or sorted(p.stem for p in (ROOT / "scenes").glob("*.toml"))
    out = {}
    for name in names:
        mm = [round(1000.0 * deepest(ROOT / "scenes" / f"{name}.toml", run, args.nudge), 2)
              for run in range(args.runs + 1)]
        out[name] = mm
        print(f"{name:24s} largest {max(mm):7.2f} mm   runs {mm}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
