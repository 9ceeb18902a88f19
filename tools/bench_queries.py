"""Speed of batched ray casts (``World.ray_cast``, ``sdfphys.rays``): 100,000 rays in
one call against a 200-body scene; target <= 100 ms per call (issue #19).

Scene (seeded): 200 static bodies over a 60 m x 30 m field, a third each circles
(radius 0.3-1 m), boxes (0.4-2 m sides, any angle) and SDF shapes (a ring, a box with a
round notch, a smooth union of a disc and a bar, a star: CSG and primitives through
their compiled programs), plus the ground (a half-plane under the field). Rays: origins
uniform over the field grown by 5 m, directions uniform, max_distance ``--length``
(default 20 m); a third of them start inside or hit nothing.

Printed: the first call (loads the kernels from the numba cache, or compiles them),
then the mean, min, 95th percentile and max of ``--runs`` timed calls after it (wall
time, one thread, and CPU time, less sensitive to other load on the machine; the load
average is printed), hits per call, and the ``ray_cast_all`` and ``point_query`` times on the same
input. ``--cold`` also times the compilation with an empty cache, in a fresh process
(NUMBA_CACHE_DIR a new temporary directory): all kernels a ray cast needs (the query
kernel, ``sdf.compiled.run`` and the broadphase's ``world_bounds``), and the query
kernels alone (a cache holding every other kernel, the query module's entries removed).

Usage: python tools/bench_queries.py [--rays 100000] [--bodies 200] [--runs 10]
    [--length 20] [--cold]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

SDF_FIELDS = [
    {"op": "difference", "of": [{"type": "circle", "radius": 1.0},
                                {"type": "circle", "radius": 0.5}]},
    {"op": "difference", "of": [{"type": "box", "size": [2.0, 1.2]},
                                {"op": "translate", "of": {"type": "circle", "radius": 0.4},
                                 "by": [0.6, 0.6]}]},
    {"op": "smooth_union", "k": 0.2, "of": [{"type": "circle", "radius": 0.6},
                                            {"type": "box", "size": [1.6, 0.5]}]},
    {"type": "star", "radius": 0.9, "points": 5, "m": 3.0},
]


def scene(bodies: int, seed: int = 0):
    """The benchmark world (module docstring)."""
    sys.path.insert(0, str(ROOT))
    from sdfphys.world import World

    rng = np.random.default_rng(seed)
    world = World()
    world.add_body({"type": "sdf", "field": {"type": "half_plane", "normal": [0, 1],
                                             "distance": -16.0}}, kind="static")
    for i in range(bodies):
        pos = rng.uniform([-30, -15], [30, 15])
        angle = float(rng.uniform(-np.pi, np.pi))
        kind = i % 3
        if kind == 0:
            shape = {"type": "circle", "radius": float(rng.uniform(0.3, 1.0))}
        elif kind == 1:
            shape = {"type": "box", "size": rng.uniform(0.4, 2.0, 2).tolist()}
        else:
            shape = {"type": "sdf", "field": SDF_FIELDS[i // 3 % len(SDF_FIELDS)]}
        world.add_body(shape, position=pos, angle=angle, kind="static")
    return world


def rays(count: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    origins = rng.uniform([-35, -20], [35, 20], (count, 2))
    a = rng.uniform(0, 2 * np.pi, count)
    return origins, np.column_stack([np.cos(a), np.sin(a)])


def timed(call, runs: int) -> tuple[np.ndarray, np.ndarray]:
    """Wall and CPU seconds (runs,) of ``runs`` calls."""
    wall, cpu = [], []
    for _ in range(runs):
        t, c = time.perf_counter(), time.process_time()
        call()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return np.array(wall), np.array(cpu)


_FIRST_CALL = """
import time, sys
sys.path.insert(0, {root!r})
sys.path.insert(0, {tools!r})
import bench_queries as b
w = b.scene(200)
o, d = b.rays(1000)
t = time.perf_counter()
w.ray_cast(o, d, 20.0)
print(time.perf_counter() - t)
"""


def first_call_seconds(cache: str) -> float:
    """Seconds of the first ray cast in a fresh process with NUMBA_CACHE_DIR = cache."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, SDFPHYS_COMPILE_NOTICE="0")
    code = _FIRST_CALL.format(root=str(ROOT), tools=str(ROOT / "tools"))
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True,
                         capture_output=True, text=True)
    return float(out.stdout.split()[-1])


def cold() -> None:
    """Compilation times with an empty cache, and with only the query kernels missing."""
    with tempfile.TemporaryDirectory() as cache:
        empty = first_call_seconds(cache)
        warm = first_call_seconds(cache)
        removed = 0
        for path in Path(cache).rglob("*"):
            if path.is_file() and path.name.startswith("rays."):
                path.unlink()
                removed += 1
        queries_only = first_call_seconds(cache)
    print(f"cold, empty cache (query kernel + sdf.compiled.run + world_bounds): "
          f"{empty:.1f} s")
    print(f"cold, query kernels only ({removed} cache files removed): {queries_only:.1f} s")
    print(f"warm first call (kernels loaded from the cache): {warm:.2f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rays", type=int, default=100_000)
    parser.add_argument("--bodies", type=int, default=200)
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--length", type=float, default=20.0)
    parser.add_argument("--cold", action="store_true")
    args = parser.parse_args()
    world = scene(args.bodies)
    origins, directions = rays(args.rays)
    t = time.perf_counter()
    hits = world.ray_cast(origins, directions, args.length)
    print(f"first call: {time.perf_counter() - t:.2f} s")
    times, cpu = timed(lambda: world.ray_cast(origins, directions, args.length), args.runs)
    inside = int(np.sum(hits.distance == 0.0))
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print(f"ray_cast, {args.rays} rays, {len(world)} bodies, max_distance {args.length:g} m: "
          f"mean {1e3 * times.mean():.1f} ms (min {1e3 * times.min():.1f}, p95 "
          f"{1e3 * np.percentile(times, 95):.1f}, max {1e3 * times.max():.1f}; CPU mean "
          f"{1e3 * cpu.mean():.1f}, min "
          f"{1e3 * cpu.min():.1f}) over {args.runs} calls; {int(np.sum(hits.body >= 0))} "
          f"hits, {inside} from inside")
    every, every_cpu = timed(lambda: world.ray_cast_all(origins, directions, args.length), 3)
    print(f"ray_cast_all: mean {1e3 * every.mean():.1f} ms (CPU {1e3 * every_cpu.mean():.1f})")
    world.point_query(origins, 1.0)
    near, near_cpu = timed(lambda: world.point_query(origins, 1.0), 3)
    print(f"point_query ({args.rays} points, max_distance 1 m): mean "
          f"{1e3 * near.mean():.1f} ms (CPU {1e3 * near_cpu.mean():.1f})")
    if args.cold:
        cold()


if __name__ == "__main__":
    main()
