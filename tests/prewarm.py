"""Compiles, beside a test run on a cold numba cache, the kernels its later tests reach.

The suite's wall time on an empty cache is mostly compilation, one kernel after the
other in the test process, while the machine's second core idles once the first scene
has been stepped (``sdfphys._warm``'s child helps there only). ``conftest.py`` starts
this script in its own process at the start of such a run; it calls, with the argument
types the tests use, the kernels that the later tests compile alone (measured on a cold
default run, ``pytest --durations``: the car's joint substep kernel 12 s, the ray and
shape casts 10 s, the sampled triangle descent 9.5 s, the image terrain's fields 4.7
s), into the same cache. A kernel that both processes reach is compiled once: the
other waits for it and loads it (``sdfphys._compile_lock``). It runs at the lowest
priority (nice 19), on what the tests leave idle: a test that times a subprocess (the
signal tests of test_cli_first_hour) competes with it as little as the scheduler
allows. Nothing here is checked: the tests run as without it, only sooner;
``SDFPHYS_TEST_PREWARM=0`` in the environment turns it off.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

import sdfphys
from sdfphys.collide import lattice
from sdfphys.sdf import field

ROOT = Path(__file__).resolve().parent.parent


def _scene(name: str) -> None:
    """Three steps of scenes/<name>.toml (``test_every_scene_loads_and_steps``)."""
    world = sdfphys.load_scene(ROOT / "scenes" / f"{name}.toml")
    for _ in range(3):
        world.step()


def _sampled_descent() -> None:
    """The lattice-sampled triangle descent (tests/test_descent_sampled.py)."""
    tri = np.array([[[-2.0, 0.9], [2.0, 0.9], [0.0, 3.0]]])
    lattice.triangle_deepest_sampled(field({"type": "circle", "radius": 1.0}), tri, 3, 2)


def _queries() -> None:
    """Ray and circle casts and point queries on static circles, boxes and convex
    polygons (tests/test_queries.py)."""
    world = sdfphys.World()
    world.add_body({"type": "circle", "radius": 0.5}, position=(0.0, 0.0), kind="static")
    world.add_body({"type": "box", "size": [1.0, 0.5]}, position=(3.0, 0.0), kind="static")
    world.add_body({"type": "polygon", "points": [[0.0, 0.0], [1.0, 0.0], [0.3, 0.8]]},
                   position=(-3.0, 0.0), kind="static")
    origins = np.array([[0.0, -5.0], [3.0, -5.0], [-3.0, -5.0]])
    directions = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])
    world.point_query(origins, 1e-6)
    world.ray_cast(origins, directions, 15.0)
    world.circle_cast(origins, directions, 0.25, 15.0)


def main() -> None:
    """In the order the suite meets them (test files run in name order)."""
    _scene("car")
    _scene("image_terrain")
    _sampled_descent()
    _queries()


if __name__ == "__main__":
    if hasattr(os, "nice"):
        os.nice(19)
    main()
