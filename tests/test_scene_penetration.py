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
    "csg_bodies": "sdf-sdf csg2 / csg6 at t = 0.97 s, 1.02 cm (1.04 cm before the one-sided "
                  "depths; 1.26 cm at the soft rate alone; 4.36 cm before the rounded far "
                  "end fix): depth exact (brute force), contact present from 4 mm five steps "
                  "before while csg6 rolls at 5 rad/s on it: each step's rolling presses a "
                  "new point in about as fast as the split push-out takes the overlap out",
    "sdf_primitives": "sdf-sdf vesica / rounded_cross at t = 2.28 s, 2.6 cm (2.3 cm before "
                      "the one-sided depths, which read deeper and truer at sharp "
                      "features): the contact present and deepening (6.7, 8.4, 12.1, 17.5 "
                      "mm the steps before, one-sided within 10 % of them) while the "
                      "rounded cross falls onto the vesica at 0.3 to 1.0 m/s and the "
                      "contact's normal stays within 16 degrees of horizontal (-0.97, "
                      "0.26): one overlap region, one normal, whose rows barely hold the "
                      "fall; next star / uneven_capsule 1.3 cm at t = 0.72 s: the capsule, "
                      "turning at 5.3 rad/s, sweeps its uneven end over the star's tip "
                      "like a cam, material no row holds (the tip's point at the end "
                      "poses, as collide.predicted gives circles, would hold it); ground / "
                      "ellipse 1.8 cm at t = 1.42 s: the ellipse lands spinning at 7 to 9 "
                      "rad/s and its turning brings new material down faster than the "
                      "split push-out lifts it",
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
