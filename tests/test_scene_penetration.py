"""No contact missed: every scene keeps its deepest contact under 1 cm over its duration.

The measure is the one ``sdfphys run`` prints as "max penetration": the largest
``world.contacts.depth`` (m, > 0 overlapping) over every step of ``sim.duration``.
Scenes still over the bound are strict xfails naming the cause found (pair, time,
figures): they pass the day the cause is fixed, and then the mark must go.
About a minute for all scenes once the kernels are compiled: marked ``slow``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sdfphys.scene import read_scene

ROOT = Path(__file__).resolve().parent.parent
SCENES = sorted(p.stem for p in (ROOT / "scenes").glob("*.toml"))
#: Deepest contact allowed over a scene's duration, m.
BOUND = 0.01

#: Scenes over the bound, with the cause found (deepest pair, time, figures).
OPEN: dict[str, str] = {
    "concave_polygons": "poly11 / poly12 at t = 2.10 s, 1.3 cm (1.9 cm at the soft rate "
                        "alone, split_push_out 0; after the kink-face fix: poly7 / poly12 "
                        "4.4 cm -> under 0.8 cm): the L's reflex corner in the arrow, depth "
                        "exact (brute force) and present the steps before, 0.7, 0.8, 1.1 cm, "
                        "while the normal speed at the contact after each step is within "
                        "0.02 m/s (the L pivots about it, its centre falling at 2.6 m/s): "
                        "not narrowphase, solver side; next poly10 / poly15 1.45 cm at "
                        "t = 1.25 s: a vertex near the arrow's corner measured against one "
                        "face (normal (0.79, 0.62), +0.3 mm) sinks 1.4 cm through the other "
                        "face (-0.24, 0.97) in one step: found too late, no speculative "
                        "contact on the second face",
}


def deepest_contact(name: str) -> float:
    """The largest contact depth (m) over ``sim.duration`` of scenes/<name>.toml."""
    scene = read_scene(ROOT / "scenes" / f"{name}.toml")
    world = scene.build()
    deepest = 0.0
    for _ in range(round(scene.duration / world.settings.dt)):
        world.step()
        if len(world.contacts):
            deepest = max(deepest, float(np.max(world.contacts.depth)))
    return deepest


@pytest.mark.slow
@pytest.mark.parametrize("name", [
    pytest.param(name, marks=pytest.mark.xfail(strict=True, reason=OPEN[name]))
    if name in OPEN else name for name in SCENES])
def test_deepest_contact_of_every_scene_is_under_a_centimetre(name):
    assert deepest_contact(name) < BOUND
