"""Deepest contact of each scene over nearby runs: the spread of a chaotic figure.

A scene's deepest contact over its run (``tests/test_scene_penetration.py``, the bound
1 cm) is one sample of a chaotic system: a change anywhere in the contacts or the
solver moves it either way, and one run cannot tell a fix from luck. Per scene (all of
``scenes/*.toml`` unless ``--scenes``), this runs the scene as written and ``--runs``
times more with every dynamic body's start pose moved by a normal random 1e-6 m (x, y)
and 1e-6 rad (``--nudge``; seed = the run's number, so the runs repeat), over the
scene's ``sim.duration``, and prints the deepest contact of each run in mm, their
largest, and each run's mean ms per step (after the first, which may compile): a
chaotic scene's cost moves with its landings as its depth does. ``--json FILE`` also
writes {scene: [mm, ...]}. Compare two trees by running it with ``PYTHONPATH=TREE``
for each.

``--box2d``: also Box2D v3's figure for the scene as written, where Box2D can model it
(circles and polygons, static and dynamic bodies, no joints, blasts, carves, collision
filters, sensors or gravity scales): ``pyb2d3`` at its defaults with 4 substeps,
single thread, sleeping on; a polygon is its triangles (Box2D's polygons are convex)
on one body, densities set so each body has sdfphys' mass; its deepest overlap is
measured as the benchmark measures it (``bench_vs_peers.deepest``: sdfphys'
narrowphase at Box2D's poses after each step).

    python tools/penetration_spread.py --scenes showcase circles_in_box --runs 4
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from sdfphys.scene import read_scene
from sdfphys.summary import RunSummary, simulate, steps_for

ROOT = Path(__file__).resolve().parent.parent


def deepest(path: Path, run: int, nudge: float) -> float:
    """The largest contact depth (m) over ``sim.duration`` of the scene at ``path`` (the
    ``run`` summary's max penetration), its dynamic bodies' start poses moved by
    ``nudge`` (seed ``run``; run 0: as written)."""
    return nudged_run(path, run, nudge).max_penetration


def nudged_run(path: Path, run: int, nudge: float) -> RunSummary:
    """The ``run`` summary (``sdfphys.summary.simulate``) of the scene at ``path`` over
    ``sim.duration``, its dynamic bodies' start poses moved by ``nudge`` (seed ``run``;
    run 0: as written)."""
    scene = read_scene(path)
    world = scene.build()
    if run:
        rng = np.random.default_rng(run)
        position, angle = world.position, world.angle
        for i in range(len(angle)):
            if world.kind[i] == "dynamic":
                world.set_state(i, position=position[i] + nudge * rng.normal(size=2),
                                angle=float(angle[i] + nudge * rng.normal()))
    return simulate(world, steps_for(scene.duration, world.settings.dt))


def box2d_deepest(path: Path) -> float | None:
    """Box2D v3's deepest overlap (m) over the scene at ``path`` (``--box2d`` above), or
    None where it cannot model the scene."""
    import pyb2d3
    from bench_vs_peers import deepest as probe_deepest
    from bench_vs_peers import probe_of

    scene = read_scene(path)
    world = scene.build()
    kinds = {world.shapes[i].kind for i in world.shape_id}
    plain = all(b.category == 1 and b.mask == 2 ** 64 - 1 and b.group == 0
                and not b.sensor and b.gravity_scale == 1.0 for b in scene.bodies)
    if (scene.joints or scene.blasts or scene.carves or not kinds <= {"circle", "mesh"}
            or not set(world.kind) <= {"static", "dynamic"} or not plain):
        return None
    box2d = pyb2d3.World(gravity=tuple(float(g) for g in world.gravity))
    ids = pyb2d3.Bodies()
    for i in range(len(world.angle)):
        shape = world.shapes[world.shape_id[i]]
        static = world.kind[i] == "static"
        create = box2d.create_static_body if static else box2d.create_dynamic_body
        centre = world.center_of_mass[i]
        body = create(position=(float(centre[0]), float(centre[1])),
                      rotation=float(world.angle[i]),
                      linear_velocity=tuple(float(v) for v in world.velocity[i]),
                      angular_velocity=float(world.angular_velocity[i]))
        density = 1.0 if static else float(world.mass[i]) / shape.area
        material = pyb2d3.surface_material(friction=float(world.friction[i]),
                                           restitution=float(world.restitution[i]))
        shape_def = pyb2d3.shape_def(density=density, material=material)
        if shape.kind == "circle":
            body.create_circle_shape(shape_def, pyb2d3.circle(radius=shape.radius))
        else:
            for triangle in shape.triangles:                # frame: the centre of mass
                points = [tuple(float(x) for x in shape.vertices[k]) for k in triangle]
                body.create_polygon_shape(shape_def, pyb2d3.polygon(points=points))
        ids.append(body.id)
    probe = probe_of(world)
    most = 0.0
    for _ in range(steps_for(scene.duration, world.settings.dt)):
        box2d.step(world.settings.dt, 4)
        rotation = ids.get_rotations()
        angle = np.arctan2(rotation[:, 1], rotation[:, 0]).astype(np.float64)
        most = max(most, probe_deepest(probe, ids.get_positions().astype(np.float64), angle))
    return most


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", help="scene names (default: all)")
    parser.add_argument("--runs", type=int, default=4, help="nudged runs per scene")
    parser.add_argument("--nudge", type=float, default=1e-6, help="m and rad")
    parser.add_argument("--json", help="also write {scene: [mm, ...]} here")
    parser.add_argument("--box2d", action="store_true",
                        help="also Box2D v3's figure where it can model the scene")
    args = parser.parse_args()
    names = args.scenes or sorted(p.stem for p in (ROOT / "scenes").glob("*.toml"))
    out = {}
    for name in names:
        runs = [nudged_run(ROOT / "scenes" / f"{name}.toml", run, args.nudge)
                for run in range(args.runs + 1)]
        mm = [round(1000.0 * r.max_penetration, 2) for r in runs]
        out[name] = mm
        peer = ""
        if args.box2d:
            figure = box2d_deepest(ROOT / "scenes" / f"{name}.toml")
            peer = "   Box2D -" if figure is None else f"   Box2D {1000.0 * figure:.2f} mm"
        cost = [round(r.ms_per_step, 2) for r in runs]
        print(f"{name:24s} largest {max(mm):7.2f} mm   runs {mm}   ms per step {cost}{peer}",
              flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
