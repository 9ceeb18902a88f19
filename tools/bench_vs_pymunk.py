"""Speed and penetration of sdfphys against pymunk on the same scene, plus start-up cost.

Scene: N circles (radius 0.5 m, density 1, friction 0.5) on a jittered grid, dropped
into a static box (ground and two walls, friction 0.5), gravity -9.81, dt 1/60.
sdfphys runs its default Settings (4 substeps, soft step); pymunk its defaults
(10 iterations, collision_slop 0.1).

Reported per N: median ms per step over the second half of the run (the pile is
forming and settling; the first step, which compiles, is excluded), the ratio
sdfphys / pymunk, and the maximum and mean penetration (over overlapping contacts) in
each engine's final state, both measured the same way (sdfphys.collide.find_contacts
on the final positions). With ``--runs R`` each N is run R times (sdfphys then
pymunk each time, so a ratio compares two runs under the same machine load) and the
medians over the runs are printed (ms of each engine, and the median of the R
ratios).

Python cost (``--python-cost``): per N, cProfile over 20 steps of the settled pile:
contacts per step, Python function calls per step (interpreted and builtin; the
compiled kernels count one call each), and the ms per step spent outside the
compiled (numba) kernels: interpreter plus numpy. The calls per step must not grow
with the number of contacts; the ms outside the kernels shows what per-contact numpy
work is left.

Start-up: wall time of a fresh ``python -c "import sdfphys; <one step>"`` (a circle
bouncing and a box landing on a box: every solver kernel and the circle and mesh pairs
run) with an
empty numba cache (cold: every kernel compiles) and again with that cache filled
(warm). The cache lives in a temporary NUMBA_CACHE_DIR, so the shared
``__pycache__`` of the checkout is left alone.

Usage: python tools/bench_vs_pymunk.py [--sizes 500 2000 5000] [--steps 300] [--runs 1]
    [--no-startup] [--python-cost]
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import subprocess
import sys
import tempfile
import time

import numpy as np
import pymunk

from sdfphys.collide import find_contacts
from sdfphys.settings import Settings
from sdfphys.shapes import shape_from_spec
from sdfphys.world import World

RADIUS = 0.5
FRICTION = 0.5
DT = 1.0 / 60.0
SPACING = 1.1
WALL = 1.0          # thickness of ground and walls, m

STARTUP_SCRIPT = """
import time
t0 = time.perf_counter()
import sdfphys
from sdfphys.world import World
w = World()
w.add_body({"type": "box", "size": [20.0, 1.0]}, position=(0.0, -0.5), kind="static")
w.add_body({"type": "circle", "radius": 0.5}, position=(0.0, 0.51), velocity=(0.0, -3.0),
           restitution=0.5)
w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(2.0, 0.6))
w.step()
assert w.stage_counts["restitution"] > 0 and w.stage_counts["friction"] > 0
print(time.perf_counter() - t0)
"""


def scene(n: int, seed: int = 1) -> tuple[np.ndarray, float, list[tuple[float, float, float, float]]]:
    """Circle centres (N, 2), box inner width, and static boxes (cx, cy, w, h)."""
    columns = int(np.ceil(np.sqrt(n)))
    width = columns * SPACING + 1.0
    rng = np.random.default_rng(seed)
    i = np.arange(n)
    centres = np.column_stack([(i % columns - (columns - 1) / 2) * SPACING,
                               RADIUS + 0.5 + (i // columns) * SPACING])
    centres[:, 0] += rng.uniform(-0.04, 0.04, n)
    height = centres[:, 1].max() + 2.0
    walls = [(0.0, -WALL / 2, width + 2 * WALL, WALL),
             (-(width + WALL) / 2, height / 2, WALL, height),
             ((width + WALL) / 2, height / 2, WALL, height)]
    return centres, width, walls


def build_sdfphys(centres: np.ndarray, walls: list) -> World:
    world = World(gravity=(0.0, -9.81), settings=Settings(dt=DT))
    for cx, cy, w, h in walls:
        world.add_body({"type": "box", "size": [w, h]}, position=(cx, cy), kind="static",
                       friction=FRICTION)
    circle = {"type": "circle", "radius": RADIUS}
    for x, y in centres:
        world.add_body(circle, position=(x, y), density=1.0, friction=FRICTION)
    return world


def build_pymunk(centres: np.ndarray, walls: list) -> tuple[pymunk.Space, list[pymunk.Body]]:
    space = pymunk.Space()
    space.gravity = (0.0, -9.81)
    for cx, cy, w, h in walls:
        box = pymunk.Poly.create_box(space.static_body, (w, h))
        box.unsafe_set_vertices(box.get_vertices(), pymunk.Transform.translation(cx, cy))
        box.friction = FRICTION
        space.add(box)
    bodies = []
    for x, y in centres:
        body = pymunk.Body()
        body.position = (float(x), float(y))
        shape = pymunk.Circle(body, RADIUS)
        shape.density = 1.0
        shape.friction = FRICTION
        space.add(body, shape)
        bodies.append(body)
    return space, bodies


def penetration(centres: np.ndarray, walls: list) -> tuple[float, float]:
    """(deepest, mean) overlap (m) over the overlapping contacts of circles at ``centres``."""
    shapes = [shape_from_spec({"type": "box", "size": [w, h]}) for _, _, w, h in walls]
    shapes.append(shape_from_spec({"type": "circle", "radius": RADIUS}))
    position = np.vstack([np.array([[cx, cy] for cx, cy, _, _ in walls]), centres])
    shape_id = np.r_[np.arange(len(walls)), np.full(len(centres), len(walls))]
    movable = np.r_[np.zeros(len(walls), bool), np.ones(len(centres), bool)]
    c = find_contacts(shapes, shape_id, position, np.zeros(len(position)), movable, Settings())
    overlap = c.depth[c.depth > 0.0]
    return float(overlap.max(initial=0.0)), float(overlap.mean()) if len(overlap) else 0.0


def time_steps(step, steps: int) -> np.ndarray:
    times = np.empty(steps)
    for k in range(steps):
        t0 = time.perf_counter()
        step()
        times[k] = time.perf_counter() - t0
    return times


def compare(n: int, steps: int) -> dict[str, float]:
    centres, _, walls = scene(n)
    world = build_sdfphys(centres, walls)
    ours = time_steps(world.step, steps)
    ours_final = world.center_of_mass[len(walls):]
    space, bodies = build_pymunk(centres, walls)
    theirs = time_steps(lambda: space.step(DT), steps)
    theirs_final = np.array([b.position for b in bodies])
    half = slice(steps // 2, steps)
    result = {
        "n": n,
        "sdfphys_ms": 1e3 * float(np.median(ours[half])),
        "pymunk_ms": 1e3 * float(np.median(theirs[half])),
        "first_step_s": float(ours[0]),
    }
    result["sdfphys_pen"], result["sdfphys_mean_pen"] = penetration(ours_final, walls)
    result["pymunk_pen"], result["pymunk_mean_pen"] = penetration(theirs_final, walls)
    result["ratio"] = result["sdfphys_ms"] / result["pymunk_ms"]
    return result


def compare_runs(n: int, steps: int, runs: int) -> dict[str, float]:
    """``compare`` repeated: medians over ``runs`` of each figure (ratio: the median of
    the per-run ratios, each of two runs under the same load)."""
    results = [compare(n, steps) for _ in range(runs)]
    return {key: float(np.median([r[key] for r in results])) for key in results[0]}


def _compiled_functions() -> set[tuple[str, int, str]]:
    """cProfile keys (file, first line, name) of every numba dispatcher in sdfphys."""
    keys = set()
    for name, module in list(sys.modules.items()):
        if not name.startswith("sdfphys"):
            continue
        for value in vars(module).values():
            code = getattr(getattr(value, "py_func", None), "__code__", None)
            if code is not None and hasattr(value, "signatures"):
                keys.add((code.co_filename, code.co_firstlineno, code.co_name))
    return keys


def python_cost(n: int, warmup: int = 200, steps: int = 20) -> dict[str, float]:
    """Contacts, Python calls and ms outside compiled kernels per step (module doc)."""
    centres, _, walls = scene(n)
    world = build_sdfphys(centres, walls)
    for _ in range(warmup):
        world.step()
    profile = cProfile.Profile()
    contacts = []
    t0 = time.perf_counter()
    for _ in range(steps):
        profile.enable()
        world.step()
        profile.disable()
        contacts.append(len(world.contacts))
    wall = (time.perf_counter() - t0) / steps
    stats = pstats.Stats(profile).stats
    compiled = _compiled_functions()
    calls = sum(primitive for primitive, *_ in stats.values())
    inside = sum(row[2] for key, row in stats.items() if key in compiled)
    total = sum(row[2] for row in stats.values())
    return {"n": n, "contacts": float(np.median(contacts)), "calls": calls / steps,
            "outside_ms": 1e3 * (total - inside) / steps, "step_ms": 1e3 * wall}


def startup() -> tuple[float, float]:
    """(cold, warm) wall seconds of a fresh process importing sdfphys and stepping once."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        walls = []
        for _ in range(2):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-c", STARTUP_SCRIPT], env=env, check=True,
                           capture_output=True)
            walls.append(time.perf_counter() - t0)
    return walls[0], walls[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[500, 2000, 5000])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--no-startup", action="store_true")
    parser.add_argument("--python-cost", action="store_true")
    args = parser.parse_args()
    if not args.no_startup:
        cold, warm = startup()
        print(f"start-up (import + one step): cold {cold:.2f} s, warm {warm:.2f} s")
    if args.python_cost:
        print(f"{'N':>6} {'contacts':>9} {'calls/step':>11} {'ms outside kernels':>19} "
              f"{'ms/step (profiled)':>19}")
        for n in args.sizes:
            r = python_cost(n)
            print(f"{n:>6} {r['contacts']:>9.0f} {r['calls']:>11.0f} {r['outside_ms']:>19.3f} "
                  f"{r['step_ms']:>19.3f}", flush=True)
        return
    print(f"{'N':>6} {'sdfphys ms':>11} {'pymunk ms':>10} {'ratio':>6} "
          f"{'pen max (sdfphys / pymunk)':>27} {'pen mean (sdfphys / pymunk)':>28}")
    for n in args.sizes:
        r = compare_runs(n, args.steps, args.runs)
        print(f"{r['n']:>6.0f} {r['sdfphys_ms']:>11.2f} {r['pymunk_ms']:>10.2f} {r['ratio']:>6.2f} "
              f"{r['sdfphys_pen']:>18.4f} / {r['pymunk_pen']:.4f} "
              f"{r['sdfphys_mean_pen']:>19.4f} / {r['pymunk_mean_pen']:.4f}", flush=True)


if __name__ == "__main__":
    main()
