"""Speed and accuracy of triangle-field queries (``collide.descent.triangle_deepest``).

Queries: random triangles of about 0.5 m (centres uniform over the field's bounds
grown by 0.5 m, vertices within +-0.25 m of the centre in x and y) against three
fields: a box 2 m x 1 m turned by 0.3 rad, a circle of radius 0.8 m, and the smooth
union (k = 0.3) of a circle and a turned box (the one of tests/test_descent.py).
One query is one triangle: the local minima of f over it from every start.

For batches of 1,000 and 10,000 triangles, each number of starts (1: the
centroid; 3: the vertices; 4: vertices and centroid; 7: vertices, edge midpoints
and centroid, the default) and each iteration budget (4, 8, 16, 32), the table
gives the following (samples 0). Rows with samples N > 0 (``--lattice`` degrees
d, N = (d + 1)(d + 2) / 2: 3 -> 10, 4 -> 15, 5 -> 21, 6 -> 28, 8 -> 45) choose
their starts by sampling (``lattice.triangle_deepest_sampled``,
settings.descent_lattice): f at the N lattice points of each triangle, then a
descent from ``--sampled-starts`` of them (the lowest discrete local minima
first, none within one lattice spacing of another), ``--sampled-iterations``.

- us/query: CPU time of this process per triangle, median of ``--runs`` runs (less
  sensitive than wall time to other load on the machine; the descent runs on one
  thread). Wall time is printed for the default configuration. A first call per
  field, before timing, loads the numba kernels from their cache; its time is
  printed ("cold") together with the field's own evaluation cost per point, which
  bounds the query cost from below (evals/query x ns/point), numpy's and the
  compiled program's (``sdf.compiled``, which the descent uses when the field
  compiles; ``--python`` forces the Python-driven loop). The compilation
  itself (an empty cache, in a fresh process) is timed once at the end.
- evals/query: points evaluated per triangle (counted through a wrapper field,
  which does not compile, so on the Python-driven loop: the same points; for
  sampled rows the loop evaluates the starts again, K more than compiled).
- depth error: the largest amount by which the deepest point over the starts is
  shallower than an independent reference, and how many triangles exceed 1e-6 m.
  Reference (as in the tests): the minimum over a dense barycentric grid
  (``--grid`` steps per edge), refined from the best grid points by a projected
  pattern search (16 directions, step halved to 1e-13 of the triangle's size).
  With fewer starts a triangle's deepest point may lie in a basin no start
  reaches; that is the accuracy the starts buy.

Usage: python tools/bench_collide.py [--runs 5] [--grid 48] [--batches 1000 10000] [--python]
    [--iterations 4 8 16 32] [--lattice 0 3 4 5 6 8] [--sampled-starts 1 2 3]
    [--sampled-iterations 16] [--fields box circle smooth_union]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from functools import partial

import numpy as np

from sdfphys.collide import descent, lattice
from sdfphys.sdf import compiled, field

FIELDS = {
    "box": {"type": "box", "size": [2.0, 1.0], "angle": 0.3},
    "circle": {"type": "circle", "radius": 0.8},
    "smooth_union": {"op": "smooth_union", "k": 0.3, "of": [
        {"type": "circle", "radius": 0.6, "offset": [-0.5, 0.0]},
        {"type": "box", "size": [1.0, 0.6], "offset": [0.5, 0.1], "angle": 0.5}]},
}
#: Rows of descent.START_BARYCENTRIC used for each number of starts.
STARTS = {1: [6], 3: [0, 1, 2], 4: [0, 1, 2, 6], 7: [0, 1, 2, 3, 4, 5, 6]}
ITERATIONS = (4, 8, 16, 32)


def random_triangles(f, count: int, rng: np.random.Generator) -> np.ndarray:
    """(count, 3, 2) triangles of about 0.5 m around the field's bounds."""
    x0, y0, x1, y1 = f.bounds()
    centre = rng.uniform([x0 - 0.5, y0 - 0.5], [x1 + 0.5, y1 + 0.5], (count, 1, 2))
    return centre + rng.uniform(-0.25, 0.25, (count, 3, 2))


def closest_on_triangles(tri: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Closest points (T, M, 2) of triangles tri (T, 3, 2) to points x (T, M, 2)."""
    a, b, c = (tri[:, k, None, :] for k in range(3))
    det = ((b - a)[..., 0] * (c - a)[..., 1] - (b - a)[..., 1] * (c - a)[..., 0])
    rel = x - a
    with np.errstate(divide="ignore", invalid="ignore"):
        u = (rel[..., 0] * (c - a)[..., 1] - rel[..., 1] * (c - a)[..., 0]) / det
        v = ((b - a)[..., 0] * rel[..., 1] - (b - a)[..., 1] * rel[..., 0]) / det
    inside = (u >= 0) & (v >= 0) & (u + v <= 1) & (det != 0)
    best = np.full(x.shape[:2], np.inf)
    out = x.copy()
    for p, q in ((a, b), (b, c), (c, a)):
        e = q - p
        t = np.clip(np.sum((x - p) * e, axis=-1) / np.maximum(np.sum(e * e, axis=-1), 1e-300),
                    0.0, 1.0)
        foot = p + t[..., None] * e
        d = np.sum((x - foot) ** 2, axis=-1)
        out = np.where((d < best)[..., None], foot, out)
        best = np.minimum(best, d)
    return np.where(inside[..., None], x, out)


def reference_minimum(f, tri: np.ndarray, grid: int, seeds: int = 4) -> np.ndarray:
    """(T,) minimum of f over each triangle: grid, then projected pattern search."""
    i, j = np.meshgrid(np.arange(grid + 1), np.arange(grid + 1), indexing="ij")
    ok = i + j <= grid
    w = np.stack([i[ok], j[ok]], axis=1) / grid
    n_tri = len(tri)
    best_x = np.empty((n_tri, seeds, 2))
    for lo in range(0, n_tri, 500):
        part = tri[lo:lo + 500]
        points = (part[:, None, 0] + w[None, :, :1] * (part[:, None, 1] - part[:, None, 0])
                  + w[None, :, 1:] * (part[:, None, 2] - part[:, None, 0]))
        d = f.distance(points.reshape(-1, 2)).reshape(len(part), -1)
        order = np.argsort(d, axis=1)[:, :seeds]
        best_x[lo:lo + 500] = np.take_along_axis(points, order[..., None], axis=1)
    value = f.distance(best_x.reshape(-1, 2)).reshape(n_tri, seeds)
    size = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    step = np.repeat((2.0 * size / grid)[:, None], seeds, axis=1)
    angle = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    ring = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    active = step > 1e-13 * size[:, None]
    while np.any(active):
        rows, cols = np.nonzero(active)
        trial = best_x[rows, cols, None, :] + step[rows, cols, None, None] * ring[None]
        trial = closest_on_triangles(tri[rows], trial)
        v = f.distance(trial.reshape(-1, 2)).reshape(len(rows), -1)
        k = np.argmin(v, axis=1)
        pick = v[np.arange(len(rows)), k]
        better = pick < value[rows, cols]
        best_x[rows[better], cols[better]] = trial[better, k[better]]
        value[rows[better], cols[better]] = pick[better]
        step[rows[~better], cols[~better]] *= 0.5
        active = step > 1e-13 * size[:, None]
    return value.min(axis=1)


class _Counting:
    """A field wrapper counting the points evaluated."""

    def __init__(self, f):
        self.f, self.points, self.spec = f, 0, f.spec

    def evaluate(self, points):
        self.points += len(points)
        return self.f.evaluate(points)


_FIRST_CALL = """
import time, numpy as np
from sdfphys.collide import descent
from sdfphys.sdf import field
f = field({"type": "box", "size": [2.0, 1.0]})
start = time.perf_counter()
descent.triangle_deepest(f, np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]]))
print(time.perf_counter() - start)
"""


def compile_seconds() -> float:
    """Wall time of the first query in a fresh process with an empty numba cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        out = subprocess.run([sys.executable, "-c", _FIRST_CALL], env=env, check=True,
                             capture_output=True, text=True)
    return float(out.stdout.split()[-1])


def _median_time(run, runs: int, clock) -> float:
    times = []
    for _ in range(runs):
        start = clock()
        run()
        times.append(clock() - start)
    return float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--grid", type=int, default=48)
    parser.add_argument("--batches", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--iterations", type=int, nargs="+", default=list(ITERATIONS),
                        help="iteration budgets of the fixed-start rows")
    parser.add_argument("--lattice", type=int, nargs="+", default=[0, 3, 4, 5, 6, 8],
                        help="lattice degrees of the sampled rows (0: the fixed-start rows)")
    parser.add_argument("--sampled-starts", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--sampled-iterations", type=int, nargs="+", default=[16])
    parser.add_argument("--fields", nargs="+", default=list(FIELDS))
    parser.add_argument("--python", action="store_true",
                        help="the Python-driven descent loop even for fields that compile")
    args = parser.parse_args()
    descent.USE_COMPILED = not args.python
    largest = max(args.batches)
    rows = []
    notes = []
    for name, spec in FIELDS.items():
        if name not in args.fields:
            continue
        f = field(spec)
        tri = random_triangles(f, largest, np.random.default_rng(sorted(FIELDS).index(name)))
        start = time.perf_counter()
        descent.triangle_deepest(f, tri[:4])
        cold = time.perf_counter() - start
        probe = tri.reshape(-1, 2).repeat(3, axis=0)[:70000]
        per_point = _median_time(partial(f.evaluate, probe), args.runs,
                                 time.process_time) / len(probe)
        compiled.evaluate(f, probe[:10])
        per_point_compiled = _median_time(partial(compiled.evaluate, f, probe), args.runs,
                                          time.process_time) / len(probe)
        reference = reference_minimum(f, tri, args.grid)
        notes.append(f"{name}: cold first call {cold:.2f} s; field.evaluate "
                     f"{per_point * 1e9:.0f} ns/point, compiled "
                     f"{per_point_compiled * 1e9:.0f} ns/point (CPU, batch of {len(probe)})")
        configs = []
        if 0 in args.lattice:
            configs += [(0, n, it) for n in STARTS for it in args.iterations]
        configs += [(d, n, it) for d in args.lattice if d > 0 for n in args.sampled_starts
                    for it in args.sampled_iterations]
        for degree, n_starts, iterations in configs:
            if degree == 0:
                query_of = partial(descent.triangle_deepest, iterations=iterations,
                                   starts=descent.START_BARYCENTRIC[STARTS[n_starts]])
            else:
                query_of = partial(lattice.triangle_deepest_sampled, degree=degree,
                                   n_starts=n_starts, iterations=iterations)
            row = [name, str(lattice.lattice_size(degree) if degree else 0), str(n_starts),
                   str(iterations)]
            for batch in args.batches:
                part = tri[:batch]
                query_of(f, part)                                            # warm-up
                cpu = _median_time(partial(query_of, f, part), args.runs, time.process_time)
                row.append(f"{cpu / batch * 1e6:.2f}")
            counting = _Counting(f)
            part = tri[:largest]
            _, value = query_of(counting, part)
            error = value.min(axis=1) - reference[:largest]
            row.append(f"{counting.points / largest:.1f}")
            row.append(f"{max(error.max(), 0.0):.1e}")
            row.append(str(int(np.sum(error > 1e-6))))
            if degree == 0 and n_starts == 7 and iterations == 16:
                wall = _median_time(partial(descent.triangle_deepest, f, part),
                                    args.runs, time.perf_counter)
                notes.append(f"{name}: default (7 starts, 16 iterations), batch "
                             f"{largest}: {wall / largest * 1e6:.2f} us/query wall time")
            rows.append(row)
    head = (["field", "samples", "starts", "iterations"]
            + [f"us/query @{b}" for b in args.batches]
            + [f"evals/query @{largest}", "max depth error (m)", f"> 1e-6 (of {largest})"])
    print("| " + " | ".join(head) + " |")
    print("|" + "|".join("---" for _ in head) + "|")
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print()
    for note in notes:
        print(f"- {note}")
    print(f"- descent path: {'Python-driven loop' if args.python else 'compiled'}")
    print(f"- first query in a fresh process, numba cache empty (compilation): "
          f"{compile_seconds():.1f} s")


if __name__ == "__main__":
    main()
