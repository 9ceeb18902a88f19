"""Stability study, input: degenerate and non-finite scene values must be SpecErrors.

Every entry of DEGENERATE is a scene dict with one bad value and the key path the
error must name; ``load_outcome`` says what ``sdfphys.load_scene`` answers.
"""

from __future__ import annotations

import math

from stability_common import Bound

import sdfphys

#: Every bad input is rejected.
ALL_REJECTED = Bound(0.0, "", "the issue: each is a SpecError naming its key")


def _scene(shape: dict | None = None, **body) -> dict:
    """A scene dict: a static ground and one body (a ball unless ``shape``) with ``body`` keys."""
    entry = {"shape": shape or {"type": "circle", "radius": 0.5}, "position": [0.0, 1.0]}
    entry.update(body)
    return {"version": 1, "body": [{"shape": {"type": "box", "size": [10.0, 1.0]},
                                    "position": [0.0, -0.5], "static": True}, entry]}


#: The bad inputs the issue names: name -> (scene dict, key path the SpecError names).
DEGENERATE = {
    "zero-area triangle": (_scene({"type": "polygon", "points": [[0, 0], [1, 1], [2, 2]]}),
                           "body[1].shape.points"),
    "collinear polygon": (_scene({"type": "polygon",
                                  "points": [[0, 0], [1, 0], [2, 0], [3, 0]]}),
                          "body[1].shape.points"),
    "self-intersecting polygon": (_scene({"type": "polygon",
                                          "points": [[0, 0], [1, 1], [1, 0], [0, 1]]}),
                                  "body[1].shape.points"),
    "radius 1e-9": (_scene({"type": "circle", "radius": 1e-9}), "body[1].shape.radius"),
    "NaN radius": (_scene({"type": "circle", "radius": math.nan}), "body[1].shape.radius"),
    "NaN polygon point": (_scene({"type": "polygon",
                                  "points": [[0, 0], [1, 0], [math.nan, 1]]}),
                          "body[1].shape.points[2][0]"),
    "infinite box size": (_scene({"type": "box", "size": [math.inf, 1.0]}),
                          "body[1].shape.size[0]"),
    "NaN position": (_scene(position=[math.nan, 0.0]), "body[1].position[0]"),
    "infinite velocity": (_scene(velocity=[math.inf, 0.0]), "body[1].velocity[0]"),
    "NaN angle": (_scene(angle=math.nan), "body[1].angle"),
    "infinite mass": (_scene(mass=math.inf), "body[1].mass"),
    "NaN friction": (_scene(friction=math.nan), "body[1].friction"),
    "NaN field parameter": (_scene({"type": "sdf", "field": {"type": "circle",
                                                             "radius": math.nan}}),
                            "body[1].shape.field.radius"),
    "NaN gravity": ({**_scene(), "world": {"gravity": [0.0, math.nan]}}, "world.gravity[1]"),
    "infinite dt": ({**_scene(), "sim": {"dt": math.inf}}, "sim.dt"),
}


def load_outcome(name: str) -> str:
    """What ``sdfphys.load_scene`` answers to DEGENERATE[name]: the SpecError's text, or
    ``"accepted"``."""
    scene, _ = DEGENERATE[name]
    try:
        sdfphys.load_scene(scene)
    except sdfphys.SpecError as err:
        return str(err)
    return "accepted"


def rejected_naming_key(name: str) -> bool:
    """DEGENERATE[name] is rejected with a SpecError naming its key path."""
    return load_outcome(name).startswith(f"<scene>: {DEGENERATE[name][1]}: ")


def ours_degenerate() -> dict[str, float]:
    """accepted: how many DEGENERATE inputs were not rejected with a SpecError naming
    their key."""
    return {"accepted": float(sum(not rejected_naming_key(name) for name in DEGENERATE))}
