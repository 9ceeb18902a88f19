"""Joints against exact answers: a pendulum's period, a motor's speed, a prismatic limit, a
spring's frequency, a welded cantilever, a loaded chain; pymunk beside them; bad specs.

Conventions as the scenes': SI units, gravity -9.81 m/s^2, dt 1/60 s and the ``balanced``
defaults (4 substeps) unless a test says otherwise.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pymunk
import pytest

import sdfphys
from sdfphys.errors import SpecError
from sdfphys.world import World

ROOT = Path(__file__).resolve().parents[1]
G = 9.81
DT = 1.0 / 60.0


def elliptic_k(m: float) -> float:
    """Complete elliptic integral of the first kind K(m), m = k^2 (arithmetic-geometric mean)."""
    a, b = 1.0, math.sqrt(1.0 - m)
    for _ in range(40):
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    return math.pi / (2.0 * a)


def peaks(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of the local maxima of y(t), refined by a parabola through three samples."""
    i = np.flatnonzero((y[1:-1] >= y[:-2]) & (y[1:-1] > y[2:])) + 1
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    shift = 0.5 * (y0 - y2) / (y0 - 2.0 * y1 + y2)
    return t[i] + shift * (t[1] - t[0]), y1 - 0.25 * (y0 - y2) * shift


def joint_gaps(world: World) -> np.ndarray:
    """(J,) m: the distance between each joint's two anchors (0 for an ideal point joint)."""
    first, second = world.joint_anchors()
    return np.hypot(*(first - second).T)


# ---------------------------------------------------------------------------------------
# Pendulum: period and amplitude against the closed form
# ---------------------------------------------------------------------------------------

LENGTH, BOB = 1.0, 0.05


def pendulum_angles(seconds: float) -> tuple[np.ndarray, np.ndarray]:
    """A 1 kg disc of radius BOB pinned at the origin LENGTH from its centre, released at
    rest from the horizontal (90 degrees); returns t (F,) and its swing angle (F,) rad."""
    world = sdfphys.load_scene({
        "version": 1,
        "body": [{"name": "bob", "shape": {"type": "circle", "radius": BOB},
                  "position": [LENGTH, 0.0], "mass": 1.0}],
        "joint": [{"type": "revolute", "bodies": ["bob", "world"], "anchor": [0.0, 0.0]}]})
    steps = round(seconds / DT)
    xy = np.empty((steps, 2))
    for k in range(steps):
        world.step()
        xy[k] = world.position[0]
    return DT * np.arange(1, steps + 1), np.arctan2(xy[:, 0], -xy[:, 1])


def test_pendulum_keeps_the_elliptic_period_and_its_amplitude():
    t, theta = pendulum_angles(8.0)
    # Physical pendulum: I = m L^2 + m r^2 / 2 about the pivot; T = 4 sqrt(I / (m g L)) K(k^2),
    # k = sin(theta0 / 2).
    inertia = LENGTH ** 2 + 0.5 * BOB ** 2
    exact = 4.0 * math.sqrt(inertia / (G * LENGTH)) * elliptic_k(math.sin(math.pi / 4) ** 2)
    times, amplitudes = peaks(t, theta)
    assert len(times) >= 3
    period = np.diff(times).mean()
    assert abs(period / exact - 1.0) < 0.005, (period, exact)
    assert 1.0 - amplitudes[-1] / (0.5 * math.pi) < 0.02, amplitudes


def test_pendulum_force_is_the_weight_at_rest():
    world = World()
    world.add_body({"type": "circle", "radius": 0.1}, position=(0.0, -1.0), mass=2.0, name="bob")
    j = world.add_joint({"type": "revolute", "bodies": ["bob", "world"], "anchor": [0.0, 0.0]})
    for _ in range(60):
        world.step()
    np.testing.assert_allclose(world.joint_force[j], [0.0, 2.0 * G], atol=1e-6)
    assert world.joint_torque[j] == 0.0


# ---------------------------------------------------------------------------------------
# Motors, limits, springs, welds
# ---------------------------------------------------------------------------------------


def test_revolute_motor_reaches_its_speed():
    world = World(gravity=(0.0, 0.0))
    world.add_body({"type": "box", "size": [1.0, 0.2]}, mass=3.0, name="arm")
    j = world.add_joint({"type": "revolute", "bodies": ["arm", "world"], "anchor": [0.0, 0.0],
                         "motor": {"speed": 2.0, "max_torque": 5.0}})
    for _ in range(60):
        world.step()
    assert world.angular_velocity[0] == pytest.approx(2.0, abs=1e-9)
    assert world.joint_torque[j] == pytest.approx(0.0, abs=1e-6)       # no load at speed


def test_motor_torque_is_bounded():
    """The arm's inertia is 3 (1 + 0.04) / 12 = 0.26 kg m^2; 0.5 N m spins it up at
    0.5 / 0.26 rad/s^2 until the motor's speed."""
    world = World(gravity=(0.0, 0.0))
    world.add_body({"type": "box", "size": [1.0, 0.2]}, mass=3.0, name="arm")
    world.add_joint({"type": "revolute", "bodies": ["arm", "world"], "anchor": [0.0, 0.0],
                     "motor": {"speed": 100.0, "max_torque": 0.5}})
    for _ in range(30):
        world.step()
    inertia = 3.0 * (1.0 + 0.04) / 12.0
    assert world.angular_velocity[0] == pytest.approx(0.5 / inertia * 30 * DT, rel=1e-9)


def test_prismatic_limit_stops_a_falling_body_at_the_limit():
    world = World()
    world.add_body({"type": "box", "size": [0.4, 0.4]}, position=(0.0, 5.0), name="slider")
    world.add_joint({"type": "prismatic", "bodies": ["slider", "world"], "anchor": [0.0, 5.0],
                     "axis": [0.0, 1.0], "limits": [-1.0, 1.0]})
    for _ in range(120):
        world.step()
    assert world.position[0, 0] == pytest.approx(0.0, abs=1e-9)        # on its axis
    assert world.position[0, 1] == pytest.approx(4.0, abs=1e-3)        # at the lower limit
    assert abs(world.velocity[0, 1]) < 1e-3
    assert world.angle[0] == pytest.approx(0.0, abs=1e-9)


def test_prismatic_motor_slides_at_its_speed():
    world = World(gravity=(0.0, 0.0))
    world.add_body({"type": "box", "size": [0.4, 0.4]}, name="slider")
    world.add_joint({"type": "prismatic", "bodies": ["slider", "world"], "axis": [1.0, 1.0],
                     "motor": {"speed": 0.5, "max_force": 100.0}})
    for _ in range(30):
        world.step()
    np.testing.assert_allclose(world.velocity[0], [0.5 / math.sqrt(2)] * 2, atol=1e-9)


def test_undamped_distance_spring_oscillates_at_its_hertz():
    world = World(gravity=(0.0, 0.0))
    world.add_body({"type": "circle", "radius": 0.1}, position=(1.1, 0.0), mass=1.0, name="m")
    world.add_joint({"type": "distance", "bodies": ["m", "world"],
                     "anchors": [[1.1, 0.0], [0.0, 0.0]], "length": 1.0,
                     "spring": {"hertz": 2.0, "damping_ratio": 0.0}})
    steps = 240
    x = np.empty(steps)
    for k in range(steps):
        world.step()
        x[k] = world.position[0, 0]
    times, _ = peaks(DT * np.arange(1, steps + 1), x - 1.0)
    assert 1.0 / np.diff(times).mean() == pytest.approx(2.0, rel=0.005)


def test_rope_holds_at_its_max_length_and_is_slack_below():
    world = World()
    world.add_body({"type": "circle", "radius": 0.1}, position=(0.5, 0.0), name="m")
    world.add_joint({"type": "distance", "bodies": ["m", "world"],
                     "anchors": [[0.5, 0.0], [0.0, 0.0]], "max_length": 1.0})
    for _ in range(10):        # 10 steps of free fall: 14 cm, still slack
        world.step()
    # Semi-implicit Euler over n = 40 substeps of h: y = -g h^2 n (n + 1) / 2.
    h = DT / 4
    assert world.position[0, 1] == pytest.approx(-G * h * h * 40 * 41 / 2, rel=1e-12)
    for _ in range(110):
        world.step()
    assert np.hypot(*world.position[0]) == pytest.approx(1.0, abs=2e-3)


def test_welded_cantilever_sags_less_than_2_cm():
    """Five 1 x 0.2 m boxes of density 10 (2 kg) welded end to end, the first to the world
    (Box2D v3 at its defaults: 12 cm)."""
    world = World()
    prev = "world"
    for i in range(5):
        world.add_body({"type": "box", "size": [1.0, 0.2]}, position=(0.5 + i, 0.0),
                       density=10.0, name=f"b{i}")
        world.add_joint({"type": "weld", "bodies": [f"b{i}", prev], "anchor": [float(i), 0.0]})
        prev = f"b{i}"
    for _ in range(180):
        world.step()
    assert -world.position[4, 1] < 0.02
    assert abs(world.velocity[4, 1]) < 1e-3


def test_wheel_sags_on_its_spring_and_turns_at_its_motor_speed():
    """A 2 kg disc on a vertical wheel joint to the world, spring 4 Hz: it settles
    g / (2 pi 4)^2 = 15.5 mm below its anchor, on its axis, turning at the motor's speed."""
    world = World()
    world.add_body({"type": "circle", "radius": 0.3}, position=(0.0, 1.0), mass=2.0, name="w")
    j = world.add_joint({"type": "wheel", "bodies": ["w", "world"], "anchor": [0.0, 1.0],
                         "axis": [0.0, 1.0], "spring": {"hertz": 4.0, "damping_ratio": 1.0},
                         "motor": {"speed": -3.0, "max_torque": 10.0}})
    for _ in range(180):
        world.step()
    assert world.position[0, 0] == pytest.approx(0.0, abs=1e-9)
    assert 1.0 - world.position[0, 1] == pytest.approx(G / (2 * math.pi * 4.0) ** 2, rel=1e-3)
    assert world.angular_velocity[0] == pytest.approx(-3.0, abs=1e-9)
    np.testing.assert_allclose(world.joint_force[j], [0.0, 2.0 * G], rtol=1e-6, atol=1e-9)


def test_soft_weld_turns_at_its_hertz():
    """A 1 x 0.2 m box welded at its centre to the world by a 2 Hz spring, no damping,
    spun at 2 rad/s: it rocks at 2 Hz (angular effective mass: its inertia)."""
    world = World(gravity=(0.0, 0.0))
    world.add_body({"type": "box", "size": [1.0, 0.2]}, name="b", angular_velocity=2.0)
    world.add_joint({"type": "weld", "bodies": ["b", "world"], "anchor": [0.0, 0.0],
                     "spring": {"hertz": 2.0}})
    steps = 240
    angle = np.empty(steps)
    for k in range(steps):
        world.step()
        angle[k] = world.angle[0]
    times, _ = peaks(DT * np.arange(1, steps + 1), angle)
    assert 1.0 / np.diff(times).mean() == pytest.approx(2.0, rel=0.005)


def test_motor_joint_returns_to_its_pose_with_bounded_force():
    """A 1 kg box held by a motor joint at the pose it was created in, moved 1 m away and
    turned 0.5 rad: the joint pulls it back with at most max_force = 20 N (after 0.25 s it
    has come at most 20 h^2 n (n + 1) / 2 = 0.6354 m, n = 60 substeps of h) and holds it."""
    world = World(gravity=(0.0, 0.0))
    world.add_body({"type": "box", "size": [0.5, 0.5]}, mass=1.0, name="b")
    j = world.add_joint({"type": "motor", "bodies": ["b", "world"],
                         "motor": {"max_force": 20.0, "max_torque": 5.0}})
    world.set_state(0, position=(1.0, 0.0), angle=0.5)
    for _ in range(15):
        world.step()
        assert np.hypot(*world.joint_force[j]) <= 20.0 * (1 + 1e-9)
    assert world.position[0, 0] >= 1.0 - 20.0 * (DT / 4) ** 2 * 60 * 61 / 2 - 1e-12
    for _ in range(105):
        world.step()
    np.testing.assert_allclose(world.position[0], [0.0, 0.0], atol=1e-4)
    assert world.angle[0] == pytest.approx(0.0, abs=1e-4)


# ---------------------------------------------------------------------------------------
# The loaded chain
# ---------------------------------------------------------------------------------------


def heavy_chain(hanging: bool, links: int = 20, weight: float = 100.0) -> World:
    """``links`` 0.5 x 0.1 m boxes of 1 kg joined end to end by revolute joints, the first
    to the world at (0, 20), a circle of radius 0.5 and mass ``weight`` at the end: hanging
    straight down, or laid out horizontally to swing down."""
    world = World()
    prev = "world"
    for i in range(links + 1):
        along = 0.5 * i
        size = 0.5 if i == links else 0.25
        x, y = (0.0, 20.0 - along - size) if hanging else (along + size, 20.0)
        if i < links:
            world.add_body({"type": "box", "size": [0.5, 0.1]}, position=(x, y), mass=1.0,
                           angle=-0.5 * math.pi if hanging else 0.0, name=f"link{i}")
        else:
            world.add_body({"type": "circle", "radius": 0.5}, position=(x, y), mass=weight,
                           name="weight")
        anchor = [0.0, 20.0 - along] if hanging else [along, 20.0]
        world.add_joint({"type": "revolute", "bodies": [world.names[-1], prev],
                         "anchor": anchor})
        prev = world.names[-1]
    return world


def test_hanging_chain_holds_100_kg_within_a_millimetre():
    world = heavy_chain(hanging=True)
    for _ in range(180):
        world.step()
    assert joint_gaps(world).max() < 1e-3


@pytest.mark.slow
def test_swinging_chain_keeps_every_joint_gap_under_1_cm():
    """Released from the horizontal; 6.2 mm measured (Box2D v3: 70 mm in this setup)."""
    world = heavy_chain(hanging=False)
    worst = 0.0
    for step in range(600):
        world.step()
        if step >= 60:      # once it has swung down
            worst = max(worst, joint_gaps(world).max())
    assert worst < 0.01


# ---------------------------------------------------------------------------------------
# Filtering, islands, bookkeeping
# ---------------------------------------------------------------------------------------


def test_jointed_bodies_do_not_collide_unless_asked():
    for connected, expected in ((False, 0), (True, 1)):
        world = World(gravity=(0.0, 0.0))
        world.add_body({"type": "box", "size": [1.0, 1.0]}, name="a")
        world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.9, 0.0), name="b")
        world.add_joint({"type": "weld", "bodies": ["a", "b"], "anchor": [0.45, 0.0],
                         "collide_connected": connected})
        world.step()
        assert len({(a, b) for a, b in zip(world.contacts.body_a, world.contacts.body_b)}) \
            == expected


def test_jointed_bodies_sleep_and_wake_together():
    world = World()
    world.settings = world.settings.with_values(sleeping=True)
    world.add_body({"type": "box", "size": [4.0, 0.2]}, position=(0.0, -0.1), kind="static")
    world.add_body({"type": "box", "size": [0.5, 0.5]}, position=(0.0, 0.25), name="base")
    world.add_body({"type": "box", "size": [0.5, 0.5]}, position=(0.0, 2.0), name="hung")
    world.add_joint({"type": "distance", "bodies": ["hung", "base"],
                     "anchors": [[0.0, 2.0], [0.0, 0.25]]})
    for _ in range(120):
        world.step()
    assert world.asleep[1] and world.asleep[2]
    world.set_state(2, velocity=(1.0, 0.0))
    assert not world.asleep[1] and not world.asleep[2]


def test_remove_joint_and_body_keep_the_table_consistent():
    world = World()
    for i in range(3):
        world.add_body({"type": "circle", "radius": 0.1}, position=(i, 0.0), name=f"c{i}")
    world.add_joint({"type": "revolute", "bodies": ["c0", "world"], "anchor": [0, 0]})
    world.add_joint({"type": "distance", "bodies": ["c2", "c1"], "name": "rod"})
    world.remove_body(0)
    assert [j["name"] for j in world.joints] == ["rod"]
    assert world.joint_force.shape == (1, 2) and world.joint_torque.shape == (1,)
    world.step()
    assert np.hypot(*(world.position[1] - world.position[0])) == pytest.approx(1.0, abs=1e-3)
    world.remove_joint(0)
    assert world.joints == []


def test_mouse_joint_pulls_its_anchor_to_the_target():
    world = World(gravity=(0.0, 0.0))
    world.add_body({"type": "box", "size": [1.0, 1.0]}, name="box")
    j = world.add_joint({"type": "mouse", "bodies": ["box", "world"], "anchor": [0.0, 0.0],
                         "max_force": 1000.0})
    world.set_joint_target(j, (1.0, 0.5))
    for _ in range(180):
        world.step()
    np.testing.assert_allclose(world.position[0], [1.0, 0.5], atol=1e-3)


# ---------------------------------------------------------------------------------------
# Bad input: one SpecError naming the key path; the CLI exits 2 with one line
# ---------------------------------------------------------------------------------------

TWO = [{"name": "a", "shape": {"type": "circle", "radius": 0.1}},
       {"name": "b", "shape": {"type": "circle", "radius": 0.1}, "position": [1.0, 0.0]}]


@pytest.mark.parametrize("joint, path, message", [
    ({"type": "revolute", "bodies": ["a", "nobody"]}, "joint[0].bodies[1]", "no body named"),
    ({"type": "prismatic", "bodies": ["a", "b"], "axis": [0.0, 0.0]}, "joint[0].axis",
     "must not be zero"),
    ({"type": "revolute", "bodies": ["a", "b"], "limits": [1.0, -1.0]}, "joint[0].limits",
     "lower must be <= upper"),
    ({"type": "distance", "bodies": ["a", "b"], "spring": {"hertz": -1.0}},
     "joint[0].spring.hertz", "must be >= 0"),
    ({"type": "weld", "bodies": ["a", "b"], "anchor": [float("nan"), 0.0]},
     "joint[0].anchor[0]", "must be finite"),
    ({"type": "hinge", "bodies": ["a", "b"]}, "joint[0].type", "unknown joint type"),
    ({"type": "revolute", "bodies": ["a", "b"], "axis": [1, 0]}, "joint[0].axis",
     "not used by a revolute joint"),
    ({"type": "revolute", "bodies": ["a", "a"]}, "joint[0].bodies", "two different bodies"),
    ({"type": "revolute", "bodies": ["a", "b"], "motor": {"speed": 1.0}},
     "joint[0].motor.max_torque", "is required"),
])
def test_bad_joint_is_one_spec_error_naming_the_key(joint, path, message):
    with pytest.raises(SpecError) as err:
        sdfphys.load_scene({"version": 1, "body": TWO, "joint": [joint]})
    assert err.value.path == path and message in err.value.message
    world = World()
    world.add_body({"type": "circle", "radius": 0.1}, name="a")
    world.add_body({"type": "circle", "radius": 0.1}, position=(1.0, 0.0), name="b")
    with pytest.raises(SpecError) as err:
        world.add_joint(joint)
    assert err.value.path == path.removeprefix("joint[0].")


def test_cli_exits_2_with_one_line_for_a_bad_joint(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text('version = 1\n[[body]]\nname = "a"\nshape = {type = "circle", radius = 0.1}\n'
                     '[[joint]]\ntype = "prismatic"\nbodies = ["a", "world"]\naxis = [0, 0]\n')
    result = subprocess.run([sys.executable, "-m", "sdfphys.cli", "run", str(scene)],
                            capture_output=True, text=True, cwd=ROOT, check=False)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "joint[0].axis: must not be zero" in lines[0]


# ---------------------------------------------------------------------------------------
# pymunk beside sdfphys (PivotJoint, SlideJoint, DampedSpring), over 4 s
# ---------------------------------------------------------------------------------------


def pymunk_bob(space: pymunk.Space, position, mass=1.0, radius=BOB) -> pymunk.Body:
    body = pymunk.Body(mass, pymunk.moment_for_circle(mass, 0.0, radius))
    body.position = position
    space.add(body, pymunk.Circle(body, radius))
    return body


def test_pendulum_period_beside_pymunk_pivot_joint():
    """The 90-degree pendulum in both engines over 8 s, periods against the elliptic
    integral: pymunk's PivotJoint (10 iterations) runs 3.2 % fast, sdfphys within 0.5 %."""
    space = pymunk.Space()
    space.gravity = (0.0, -G)
    bob = pymunk_bob(space, (LENGTH, 0.0))
    space.add(pymunk.PivotJoint(space.static_body, bob, (0.0, 0.0)))
    steps = round(8.0 / DT)
    theta = np.empty(steps)
    for k in range(steps):
        space.step(DT)
        theta[k] = math.atan2(bob.position.x, -bob.position.y)
    t = DT * np.arange(1, steps + 1)
    exact = 4.0 * math.sqrt((LENGTH ** 2 + 0.5 * BOB ** 2) / (G * LENGTH)) * elliptic_k(0.5)
    theirs = np.diff(peaks(t, theta)[0]).mean() / exact - 1.0
    ours = np.diff(peaks(*pendulum_angles(8.0))[0]).mean() / exact - 1.0
    assert abs(theirs) < 0.05          # the same pendulum
    assert abs(ours) < 0.005 and abs(ours) < abs(theirs)


def test_rope_matches_pymunk_slide_joint():
    """A 1 kg bob on a 1 m rope, dropped from 0.5 m beside its anchor: after 4 s ours is on
    the rope's circle within 2 mm (pymunk's SlideJoint stretches by 7.6 mm) and both swing
    through the same heights (the lowest point of the last second within 5 cm)."""
    space = pymunk.Space()
    space.gravity = (0.0, -G)
    bob = pymunk_bob(space, (0.5, 0.0))
    space.add(pymunk.SlideJoint(space.static_body, bob, (0.0, 0.0), (0.0, 0.0), 0.0, 1.0))
    world = World()
    world.add_body({"type": "circle", "radius": BOB}, position=(0.5, 0.0), mass=1.0, name="m")
    world.add_joint({"type": "distance", "bodies": ["m", "world"],
                     "anchors": [[0.5, 0.0], [0.0, 0.0]], "max_length": 1.0})
    lows = [[], []]
    for k in range(round(4.0 / DT)):
        space.step(DT)
        world.step()
        if k >= round(3.0 / DT):
            lows[0].append(bob.position.y)
            lows[1].append(world.position[0, 1])
    assert np.hypot(*world.position[0]) == pytest.approx(1.0, abs=2e-3)
    assert min(lows[1]) == pytest.approx(min(lows[0]), abs=0.05)


def test_spring_frequency_matches_pymunk_damped_spring():
    """A 1 kg mass on a 2 Hz spring (k = m (2 pi f)^2), no damping, no gravity, pulled
    10 cm: both engines' frequencies over 4 s within 0.5 % of 2 Hz and of each other."""
    space = pymunk.Space()
    bob = pymunk_bob(space, (1.1, 0.0))
    k = (2.0 * math.pi * 2.0) ** 2
    space.add(pymunk.DampedSpring(space.static_body, bob, (0.0, 0.0), (0.0, 0.0), 1.0, k, 0.0))
    world = World(gravity=(0.0, 0.0))
    world.add_body({"type": "circle", "radius": BOB}, position=(1.1, 0.0), mass=1.0, name="m")
    world.add_joint({"type": "distance", "bodies": ["m", "world"],
                     "anchors": [[1.1, 0.0], [0.0, 0.0]], "length": 1.0,
                     "spring": {"hertz": 2.0}})
    steps = round(4.0 / DT)
    x = np.empty((steps, 2))
    for i in range(steps):
        space.step(DT)
        world.step()
        x[i] = bob.position.x, world.position[0, 0]
    t = DT * np.arange(1, steps + 1)
    theirs = 1.0 / np.diff(peaks(t, x[:, 0] - 1.0)[0]).mean()
    ours = 1.0 / np.diff(peaks(t, x[:, 1] - 1.0)[0]).mean()
    assert theirs == pytest.approx(2.0, rel=0.005)
    assert ours == pytest.approx(2.0, rel=0.005)


# ---------------------------------------------------------------------------------------
# Drawing
# ---------------------------------------------------------------------------------------


def test_renderer_draws_anchors_links_and_springs():
    """A spring between two discs 2 m apart, seen at 50 px/m: the spring's colour lies on
    the segment between them, the joint colour on the anchor dots at the discs' centres."""
    import pygame

    from sdfphys.render import Camera, Palette, Renderer

    world = World(gravity=(0.0, 0.0))
    world.add_body({"type": "circle", "radius": 0.2}, position=(-1.0, 0.0), name="a")
    world.add_body({"type": "circle", "radius": 0.2}, position=(1.0, 0.0), name="b")
    surface = pygame.Surface((200, 100))
    renderer = Renderer(Camera((0.0, 0.0), 50.0, (200, 100)))
    renderer.draw(surface, world)
    plain = pygame.surfarray.array3d(surface).copy()
    world.add_joint({"type": "distance", "bodies": ["a", "b"], "spring": {"hertz": 1.0}})
    renderer.draw(surface, world)
    drawn = pygame.surfarray.array3d(surface)
    palette = Palette()
    spring = np.all(drawn == np.array(palette.spring), axis=2)
    joint = np.all(drawn == np.array(palette.joint), axis=2)
    assert spring[60:140, 40:60].sum() > 40 and not np.any(spring[:45]) and not np.any(spring[155:])
    assert joint[48:53, 48:53].any() and joint[148:153, 48:53].any()
    assert not np.any(np.all(plain == np.array(palette.spring), axis=2))


def test_a_world_without_joints_compiles_no_joint_code():
    """The substep kernel takes None for "no joints" (a type to numba), so a scene without
    joints compiles (or loads) a kernel whose joint argument is none, its joint passes
    pruned; a joint adds the second specialization."""
    probe = """
import sdfphys
from sdfphys.solver import substeps
w = sdfphys.World()
w.add_body({"type": "box", "size": [4.0, 1.0]}, kind="static")
w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 1.0))
w.step()
print([str(sig[-1]) for sig in substeps._substeps_kernel.signatures])
w.add_joint({"type": "revolute", "bodies": [1, "world"], "anchor": [0.0, 2.0]})
w.step()
print(len(substeps._substeps_kernel.signatures))
"""
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, timeout=300).stdout.split()
    assert out == ["['none']", "2"]


def test_joint_passes_are_counted_in_the_stage_counts():
    """``stage_counts["joints"]`` counts the solve and relax passes over the joints: at
    least one of each per substep where a joint acts, none without joints."""
    world = World(gravity=(0.0, -G))
    world.add_body({"type": "circle", "radius": 0.1}, position=(1.0, 0.0), mass=1.0)
    world.add_joint({"type": "revolute", "bodies": [0, "world"], "anchor": [0.0, 0.0]})
    free = World(gravity=(0.0, -G))
    free.add_body({"type": "circle", "radius": 0.1}, position=(1.0, 0.0), mass=1.0)
    for _ in range(10):
        world.step()
        free.step()
    assert world.stage_counts["joints"] >= 2 * world.settings.substeps * 10
    assert free.stage_counts["joints"] == 0
