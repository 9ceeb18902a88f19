"""One validation for scenes and the API (``sdfphys.limits``): the same ranges, the same
one-line SpecError naming the scene key or the argument; read-only state arrays."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import sdfphys
from sdfphys import limits
from sdfphys.errors import SpecError
from sdfphys.settings import Settings
from sdfphys.world import World

BALL = {"type": "circle", "radius": 0.5}

#: (add_body keyword, bad value, what the message says after the key path); each is a
#: scene body key too.
BAD_BODY_VALUES = [
    ("position", (math.nan, 1.0), "position[0]: must be finite, got nan"),
    ("position", (0.0, 1e308), "position[1]: must be within 131072 m of the origin"),
    ("position", (2e5, 0.0), "position[0]: must be within 131072 m of the origin"),
    ("angle", math.inf, "angle: must be finite, got inf"),
    ("angle", 1e9, "angle: must be within +-131072 rad"),
    ("velocity", (math.nan, 0.0), "velocity[0]: must be finite"),
    ("velocity", (1e308, 0.0), "velocity: speed must be <= 10000 m/s"),
    ("angular_velocity", -1e5, "angular_velocity: must be within +-10000 rad/s"),
    ("density", 1e308, "density: must be <= 1e+06"),
    ("density", 1e-300, "density: must be >= 1e-06 kg/m^2"),
    ("density", math.nan, "density: must be finite"),
    ("mass", 1e300, "mass: must be <= 1e+12"),
    ("mass", 1e-30, "mass: must be >= 1e-09 kg"),
    ("friction", math.nan, "friction: must be finite"),
    ("friction", 1e6, "friction: must be <= 100"),
    ("restitution", -0.5, "restitution: must be >= 0"),
]


@pytest.mark.parametrize("key, value, message", BAD_BODY_VALUES,
                         ids=[f"{k}-{v}" for k, v, _ in BAD_BODY_VALUES])
def test_add_body_and_scene_reject_the_same_values_with_the_same_line(key, value, message):
    world = World()
    with pytest.raises(SpecError) as api:
        world.add_body(BALL, **{key: value})
    assert str(api.value).startswith(message) and "\n" not in str(api.value)
    assert len(world) == 0
    scene = {"version": 1, "body": [{"shape": BALL, key: list(value)
                                     if isinstance(value, tuple) else value}]}
    with pytest.raises(SpecError) as loaded:
        sdfphys.load_scene(scene)
    assert str(loaded.value).startswith(f"<scene>: body[0].{message}")
    assert str(loaded.value).split(": ", 2)[2] == str(api.value).split(": ", 1)[1]


def test_a_world_of_bad_input_is_never_built():
    """The issue's case: a NaN body made every body NaN after one step."""
    world = World()
    world.add_body({"type": "box", "size": [10.0, 1.0]}, kind="static")
    for bad in ({"position": (math.nan, 1.0)}, {"friction": math.nan},
                {"velocity": (0.0, math.inf)}, {"linear_damping": -1.0},
                {"angular_damping": math.nan}):
        with pytest.raises(SpecError):
            world.add_body(BALL, **bad)
    world.add_body(BALL, position=(0.0, 2.0))
    world.step()
    assert np.all(np.isfinite(world.position)) and len(world) == 2


@pytest.mark.parametrize("shape, message", [
    ({"type": "circle", "radius": 1e9}, "shape.radius: must be <= 10000"),
    ({"type": "box", "size": [1.0, 2e4]}, "shape.size[1]: must be <= 10000"),
    ({"type": "polygon", "points": [[0, 0], [1, 0], [0, 3e4]]},
     "shape.points[2][1]: must be within 10000 m of the body's origin"),
    ({"type": "polygon", "points": [[0, 0], [1e-4, 0], [0, 1e-4]]},
     "shape.points: must be at least 0.001 m across"),
    ({"type": "sdf", "field": {"type": "circle", "radius": 2e4}},
     "shape.field: spans 40000 x 40000 m and reaches 20000 m"),
])
def test_sizes_are_bounded(shape, message):
    with pytest.raises(SpecError) as err:
        World().add_body(shape)
    assert str(err.value).startswith(message)
    with pytest.raises(SpecError) as err:
        sdfphys.load_scene({"version": 1, "body": [{"shape": shape}]})
    assert str(err.value).startswith(f"<scene>: body[0].{message}")


def test_positions_up_to_the_far_origin_test_are_accepted():
    """The far-origin stability test puts a pyramid at (1e5, 1e5) m: that, with its
    ground and boxes around it, must stay within the limit."""
    world = World()
    world.add_body(BALL, position=(1e5 + 30.0, -1e5 - 30.0))
    world.add_body(BALL, position=(limits.FAR, -limits.FAR))
    assert limits.FAR == 2.0 ** 17 and np.spacing(limits.FAR / 2) == np.spacing(1e5)


def test_set_state_validates_and_changes_nothing_on_a_bad_value():
    world = World()
    i = world.add_body(BALL, position=(1.0, 2.0), velocity=(0.5, 0.0))
    before = (world.position.copy(), world.velocity.copy(), world.angle.copy())
    for bad, message in [({"position": (math.nan, 0.0)}, "position[0]: must be finite"),
                         ({"position": (0.0, 0.0), "velocity": (math.inf, 0.0)},
                          "velocity[0]: must be finite"),
                         ({"angle": 1e300}, "angle: must be within"),
                         ({"angular_velocity": math.nan}, "angular_velocity: must be finite")]:
        with pytest.raises(SpecError, match=f"^{re.escape(message)}"):
            world.set_state(i, **bad)
    after = (world.position, world.velocity, world.angle)
    for a, b in zip(before, after):
        np.testing.assert_array_equal(a, b)
    ground = world.add_body(BALL, kind="static", position=(5.0, 0.0))
    with pytest.raises(SpecError, match="static body cannot move"):
        world.set_state(ground, velocity=(1.0, 0.0))
    world.set_state(i, position=np.array([3.0, 4.0]), velocity=[1.0, 1.0])
    np.testing.assert_array_equal(world.position[i], [3.0, 4.0])


def test_gravity_and_settings_setters_validate():
    world = World()
    with pytest.raises(SpecError, match=r"^gravity\[1\]: must be finite"):
        world.gravity = (0.0, math.nan)
    with pytest.raises(SpecError, match="^gravity: magnitude must be <= 10000"):
        world.gravity = (0.0, -1e308)
    with pytest.raises(SpecError, match="^gravity: must be a pair"):
        World(gravity=(0.0,))
    with pytest.raises(SpecError, match="^settings: must be a Settings"):
        world.settings = {"dt": 0.01}
    world.gravity = np.array([0.0, -1.62])
    np.testing.assert_array_equal(world.gravity, [0.0, -1.62])
    with pytest.raises(ValueError, match="read-only"):
        world.gravity[1] = 5.0
    with pytest.raises(SpecError, match="^<scene>: world.gravity: magnitude"):
        sdfphys.read_scene({"version": 1, "world": {"gravity": [1e5, 0.0]},
                            "body": [{"shape": BALL}]}).build()


@pytest.mark.parametrize("key, value, message", [
    ("dt", 1e-300, "sim.dt: must be >= 1e-06 s, got 1e-300"),
    ("dt", 2.0, "sim.dt: must be <= 1"),
    ("duration", 1e12, "sim.duration: must be <= 1e+07"),
    ("duration", math.inf, "sim.duration: must be finite"),
])
def test_time_ranges(key, value, message):
    with pytest.raises(SpecError) as err:
        sdfphys.read_scene({"version": 1, "sim": {key: value}, "body": [{"shape": BALL}]})
    assert str(err.value).startswith(f"<scene>: {message}")
    if key == "dt":
        with pytest.raises(SpecError, match=f"^dt: {re.escape(message.split(': ')[1])}"):
            Settings(dt=value)
    assert "1e-06 <= dt <= 1" in Settings.describe("dt")


@pytest.mark.parametrize("name", ["position", "center_of_mass", "angle", "velocity",
                                  "angular_velocity", "mass", "inertia", "kind", "friction",
                                  "restitution", "shape_id"])
def test_state_arrays_are_read_only(name):
    world = World()
    world.add_body(BALL, position=(0.0, 1.0))
    world.add_body(BALL, position=(2.0, 1.0))
    array = getattr(world, name)
    with pytest.raises(ValueError, match="assignment destination is read-only"):
        array[1] = array[0]
    assert not array.flags.writeable
    np.testing.assert_array_equal(getattr(world, name), array)   # nothing written


def test_position_writes_raise_instead_of_writing_into_a_copy():
    """The issue: ``w.position[1] = (0, 5)`` wrote into a copy and did nothing."""
    world = World()
    world.add_body(BALL)
    world.add_body(BALL, position=(3.0, 0.0))
    with pytest.raises(ValueError, match="read-only"):
        world.position[1] = (0, 5)
    world.set_state(1, position=(0.0, 5.0))
    np.testing.assert_array_equal(world.position[1], [0.0, 5.0])


def test_check_steps_asks_for_max_steps():
    limits.check_steps(limits.MAX_STEPS, "steps", None)
    with pytest.raises(SpecError, match="pass --max-steps to allow it"):
        limits.check_steps(limits.MAX_STEPS + 1, "steps", None)
    limits.check_steps(limits.MAX_STEPS + 1, "steps", limits.MAX_STEPS + 1)
    with pytest.raises(SpecError, match="raise --max-steps"):
        limits.check_steps(101, "frames", 100)


def _extreme(meta) -> list[float]:
    """The largest value a numeric knob accepts (1e300 where unbounded) and its smallest."""
    high = 1e300 if meta["high"] is None else meta["high"]
    low = meta["least"] if meta["least"] is not None else meta["low"]
    return [high] + ([] if low is None or meta["low_open"] and low == meta["low"] else [low])


def test_every_accepted_knob_value_keeps_a_world_finite():
    """Each numeric Settings knob at the ends of its range (1e300 if it has no upper
    bound): 20 steps of a box and a ball bouncing on the ground stay finite
    (contact_damping_ratio = 1e308 turned it to NaN before it had a bound)."""
    from dataclasses import fields

    with pytest.raises(SpecError, match="^contact_damping_ratio: must be <= 1000"):
        Settings(contact_damping_ratio=1e308)
    for f in fields(Settings):
        if f.type not in ("float", "int"):
            continue
        for value in _extreme(f.metadata):
            value = int(value) if f.type == "int" else float(value)
            if f.name == "dt" or (f.type == "int" and value > 1024):
                continue                    # dt: test_time_ranges; island limits: counts
            world = World(settings=Settings().with_values(**{f.name: value}))
            world.add_body({"type": "box", "size": [10.0, 1.0]}, kind="static",
                           position=(0.0, -0.5))
            world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 0.45),
                           restitution=0.5)
            world.add_body(BALL, position=(2.0, 0.6), velocity=(0.0, -5.0), restitution=0.5)
            for _ in range(20):
                world.step()
            assert np.all(np.isfinite(world.position)), (f.name, value)
            assert np.all(np.isfinite(world.velocity)), (f.name, value)


def _circles(n: int) -> dict:
    side = int(n ** 0.5) + 1
    bodies = [{"shape": {"type": "box", "size": [4000.0, 1.0]}, "position": [0.0, -0.5],
               "static": True}]
    bodies += [{"shape": BALL, "position": [1.1 * (i % side), 0.6 + 1.1 * (i // side)]}
               for i in range(n)]
    return {"version": 1, "body": bodies}


def _load_seconds(n: int) -> float:
    import time

    scene = _circles(n)
    start = time.perf_counter()
    world = sdfphys.load_scene(scene)
    assert len(world) == n + 1
    return time.perf_counter() - start


def test_loading_grows_linearly_with_the_bodies():
    """Names were checked against a list (quadratic: 118 s for 100,000 circles) and each
    body evaluated its shape's field: four times the bodies must take well under 16
    times as long (best of 2, to ride out a busy machine)."""
    small = min(_load_seconds(5_000) for _ in range(2))
    large = min(_load_seconds(20_000) for _ in range(2))
    assert large < 8.0 * small, (small, large)


@pytest.mark.slow
def test_100000_circles_load_in_under_5_seconds():
    assert _load_seconds(100_000) < 5.0


def test_the_digest_ignores_render_only():
    scene = _circles(3)
    digest = sdfphys.read_scene(scene).digest
    assert sdfphys.read_scene(scene, ["render.scale=10", "render.fps=30"]).digest == digest
    assert sdfphys.read_scene(scene, ["sim.substeps=8"]).digest != digest
