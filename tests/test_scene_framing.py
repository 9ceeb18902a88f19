"""Every scene in scenes/ frames what its header says to watch: each moving body inside
the picture (its ``[render]`` view) from the start and, in the long study, to the end."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import sdfphys
from sdfphys.collide.broadphase import world_bounds
from sdfphys.render import body_frames

ROOT = Path(__file__).resolve().parents[1]
SCENES = sorted((ROOT / "scenes").glob("*.toml"))

#: Bodies allowed to leave the picture after their part is played: scene -> {body:
#: (from time s, why)}.
LEAVES = {
    "newtons_cradle": {"ball4": (2.0, ("leaves with the striker's 4 m/s, as the header "
                                       "says; the picture shows it go"))},
}


def view(scene) -> np.ndarray:
    """[xmin, ymin, xmax, ymax] (m) of the scene's picture."""
    r = scene.render
    half = np.array(r.size) / 2.0 / r.scale
    return np.concatenate([np.array(r.center) - half, np.array(r.center) + half])


def bounds(world) -> np.ndarray:
    """(B, 4) world AABBs of the bodies, as the renderer and broadphase compute them."""
    frames = body_frames(world)
    local = np.array([s.bounds() for s in frames.shapes], np.float64).reshape(-1, 4)
    radius = np.array([s.radius for s in frames.shapes], np.float64)
    return world_bounds(local[frames.shape_id], radius[frames.shape_id], frames.com,
                        frames.angle)


def outside(boxes: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """(B,) how far (m) each box reaches out of ``frame`` (<= 0: inside)."""
    return np.max([frame[0] - boxes[:, 0], frame[1] - boxes[:, 1], boxes[:, 2] - frame[2],
                   boxes[:, 3] - frame[3]], axis=0)


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_every_body_is_in_the_picture_at_the_start(path):
    """Moving bodies whole (the pyramid's top box was cut off), static ones at least in
    part."""
    scene = sdfphys.read_scene(path)
    world = scene.build()
    frame, boxes = view(scene), bounds(world)
    moving = np.asarray(world.kind) != "static"
    out = outside(boxes, frame)
    names = np.array(world.names)
    assert not np.any(out[moving] > 0), f"cut off: {names[moving][out[moving] > 0]}"
    with np.errstate(invalid="ignore"):
        seen = ((boxes[:, 0] < frame[2]) & (boxes[:, 2] > frame[0])
                & (boxes[:, 1] < frame[3]) & (boxes[:, 3] > frame[1]))
    assert np.all(seen[~moving]), f"static bodies out of the picture: {names[~seen]}"


@pytest.mark.slow
@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_moving_bodies_stay_in_the_picture_to_the_end(path):
    """Every 0.1 s of ``sim.duration``: no moving body out of the picture (LEAVES aside)."""
    scene = sdfphys.read_scene(path)
    world = scene.build()
    frame = view(scene)
    allowed = LEAVES.get(path.stem, {})
    steps = round(scene.duration / scene.settings.dt)
    every = max(1, round(0.1 / scene.settings.dt))
    for k in range(steps + 1):
        if k:
            world.step()
        if k % every:
            continue
        out = outside(bounds(world), frame)
        moving = np.asarray(world.kind) != "static"     # pieces of a carve join in
        for i in np.flatnonzero(moving & (out > 0)):
            name = world.names[i]
            assert name in allowed and world.time >= allowed[name][0], (
                f"{name} out of the picture by {out[i]:.2f} m at t = {world.time:.2f} s")
