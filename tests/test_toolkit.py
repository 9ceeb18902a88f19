"""The sandbox toolkit (issue 19, docs/toolkit.md): collision filtering, sensors, events,
contact impulses, gravity scale, forces, impulses and explosions.

Tolerances: exact (==) where the answer is one floating-point operation of the API's
own (an impulse), 1e-12 relative where it is the integrator's closed form (forces over
substeps), one step where an event's time is compared with a continuous closed form.
"""

import itertools
import math
import pickle
import subprocess
import sys

import numpy as np
import pymunk
import pytest

from sdfphys.collide.filter import should_collide
from sdfphys.errors import SpecError
from sdfphys.limits import MAX_BITS
from sdfphys.scene import read_scene
from sdfphys.world import World
from sdfphys.world_stages import pair_filter

G = 9.81
BALL = {"type": "circle", "radius": 0.5}
GROUND = {"type": "box", "size": [100.0, 20.0]}       # top face at y = 0 centred at -10


# --------------------------------------------------------------------------------------
# Collision filtering
# --------------------------------------------------------------------------------------


def test_category_and_mask_agree_with_pymunk_shape_filter(rng):
    """Every pair of 3-bit categories and masks, and random 32-bit ones: sdfphys
    collides exactly where pymunk's ShapeFilter does not reject (group 0)."""
    small = list(itertools.product(range(8), range(8)))
    wide = [tuple(int(v) for v in rng.integers(0, 2 ** 32, 2)) for _ in range(200)]
    wide += [(1, pymunk.ShapeFilter.ALL_MASKS()), (2, 1), (1 << 31, 1 << 31)]
    for table in (small, wide):
        a = np.array([p for p, _ in itertools.product(table, table)], np.uint64)
        b = np.array([q for _, q in itertools.product(table, table)], np.uint64)
        ours = should_collide(a[:, 0], a[:, 1], 0, b[:, 0], b[:, 1], 0)
        theirs = [not pymunk.ShapeFilter(categories=int(p[0]), mask=int(p[1]))
                  .rejects_collision(pymunk.ShapeFilter(categories=int(q[0]), mask=int(q[1])))
                  for p, q in zip(a, b)]
        assert ours.tolist() == theirs


def test_group_rule_is_box2ds():
    """Same nonzero group: positive always collides, negative never (whatever the bits);
    different groups (or 0): the category/mask rule."""
    cases = [  # (cat_a, mask_a, group_a, cat_b, mask_b, group_b, expected)
        (1, 0, 3, 1, 0, 3, True),           # same positive group beats the masks
        (1, MAX_BITS, -3, 1, MAX_BITS, -3, False),  # same negative group beats the bits
        (1, MAX_BITS, -3, 1, MAX_BITS, -4, True),   # different groups: the bits
        (1, MAX_BITS, 3, 1, MAX_BITS, -3, True),
        (1, 2, 3, 1, MAX_BITS, 4, False),   # different groups, masks exclude
        (1, MAX_BITS, 0, 1, MAX_BITS, 0, True),     # group 0 is no group
        (1, 2, 0, 1, 2, 0, False),
        (2, 1, 0, 1, 2, 0, True),
        (1 << 63, 1 << 63, 0, 1 << 63, 1 << 63, 0, True),   # the 64th bit
    ]
    got = [bool(should_collide(*case[:6])) for case in cases]
    assert got == [case[6] for case in cases]


def _crossing(filtered: bool) -> World:
    """Two balls of two teams flying at each other, no gravity."""
    world = World(gravity=(0.0, 0.0))
    team = ({"category": 2, "mask": MAX_BITS ^ 4}, {"category": 4, "mask": MAX_BITS ^ 2})
    world.add_body(BALL, position=(-2.0, 0.0), velocity=(3.0, 0.0), **(team[0] if filtered else {}))
    world.add_body(BALL, position=(2.0, 0.1), velocity=(-3.0, 0.0), **(team[1] if filtered else {}))
    return world


def test_two_teams_pass_through_each_other_without_a_narrowphase():
    world = _crossing(True)
    for _ in range(90):
        world.step()
    assert world.velocity.tolist() == [[3.0, 0.0], [-3.0, 0.0]]
    assert world.position[0, 0] > 2.0 and world.position[1, 0] < -2.0
    assert world.stage_counts["circle_circle"] == 0       # the pair never reached it
    control = _crossing(False)
    for _ in range(90):
        control.step()
    assert control.stage_counts["circle_circle"] > 0
    assert control.velocity[0, 0] < 1.0                    # they met


def test_a_crowd_of_two_teams_keeps_its_own_collisions():
    """Bodies of one team still collide with each other, with the ground, not with the
    other team (a negative group: a team that never collides with itself)."""
    world = World(gravity=(0.0, 0.0))
    red = world.add_body(BALL, position=(-2.0, 0.0), velocity=(3.0, 0.0), category=2, mask=3)
    red2 = world.add_body(BALL, position=(2.0, 0.0), velocity=(-3.0, 0.0), category=2, mask=3)
    blue = world.add_body(BALL, position=(0.0, 2.0), velocity=(0.0, -3.0), category=4, mask=5)
    ghost_a = world.add_body(BALL, position=(-2.0, 5.0), velocity=(3.0, 0.0), group=-1)
    ghost_b = world.add_body(BALL, position=(2.0, 5.0), velocity=(-3.0, 0.0), group=-1)
    for _ in range(60):
        world.step()
    v = world.velocity
    assert v[red, 0] < 1.0 and v[red2, 0] > -1.0           # red met red
    assert v[blue].tolist() == [0.0, -3.0]                 # blue met nobody
    assert v[ghost_a].tolist() == [3.0, 0.0] and v[ghost_b].tolist() == [-3.0, 0.0]


def test_time_of_impact_does_not_trace_filtered_pairs():
    """A bullet the wall's mask ignores flies through it in one step; the same bullet
    unfiltered is stopped by time of impact."""
    def bullet(mask: int) -> World:
        world = World(gravity=(0.0, 0.0))
        world.add_body({"type": "box", "size": [0.02, 2.0]}, position=(1.0, 0.0),
                       kind="static", mask=mask)
        world.add_body({"type": "circle", "radius": 0.05}, position=(0.0, 0.0),
                       velocity=(200.0, 0.0))
        world.step()
        return world
    through, stopped = bullet(MAX_BITS ^ 1), bullet(MAX_BITS)
    assert through.position[1, 0] == 200.0 / 60.0
    assert stopped.position[1, 0] < 1.0


def test_gravity_scale_falls_at_the_integrators_closed_form():
    """v = v0 + n h s g and y = y0 + h^2 s g S (S + 1) / 2 per step from rest (S substeps);
    a body of scale 1 beside it moves bit for bit as in a world without scales."""
    world = World()
    world.add_body(BALL, position=(0.0, 10.0), gravity_scale=0.5)
    world.add_body(BALL, position=(5.0, 10.0))
    plain = World()
    plain.add_body(BALL, position=(0.0, 10.0))
    plain.add_body(BALL, position=(5.0, 10.0))
    s = world.settings
    h, S = s.dt / s.substeps, s.substeps
    world.step()
    plain.step()
    a = -0.5 * G
    assert world.velocity[0, 1] == pytest.approx(S * h * a, rel=1e-12)
    assert world.position[0, 1] == pytest.approx(10.0 + h * h * a * S * (S + 1) / 2, rel=1e-12)
    assert world.position[1].tolist() == plain.position[1].tolist()
    assert world.velocity[1].tolist() == plain.velocity[1].tolist()


@pytest.mark.parametrize("key, value, message", [
    ("category", -1, "body[0].category: must be >= 0, got -1"),
    ("mask", 1.5, "body[0].mask: must be an integer, got 1.5"),
    ("mask", 1 << 64, "body[0].mask: must be <= 18446744073709551615"),
    ("group", "red", "body[0].group: must be an integer, got 'red'"),
    ("sensor", "yes", "body[0].sensor: must be true or false, got 'yes'"),
    ("gravity_scale", 1e9, "body[0].gravity_scale: must be <= 1000"),
    ("gravity_scale", float("nan"), "body[0].gravity_scale: must be finite"),
])
def test_bad_toolkit_keys_name_the_key_path(key, value, message):
    scene = {"version": 1, "body": [{"shape": BALL, key: value}]}
    with pytest.raises(SpecError) as err:
        read_scene(scene)
    assert str(err.value).startswith("<scene>: " + message), str(err.value)
    with pytest.raises(SpecError) as err:           # the API says the same
        World().add_body(BALL, **{key: value})
    assert str(err.value).startswith(message.removeprefix("body[0]."))


def test_scene_keys_reach_the_world():
    scene = {"version": 1, "body": [
        {"shape": BALL, "category": 6, "mask": 9, "group": -2, "gravity_scale": 0.0},
        {"shape": BALL, "position": [3, 0], "sensor": True, "static": True}]}
    world = read_scene(scene).build()
    f = pair_filter(world)
    assert (f.category.tolist(), f.mask.tolist(), f.group.tolist(), f.sensor.tolist()) == (
        [6, 1], [9, MAX_BITS], [-2, 0], [False, True])
    world.step()
    assert world.velocity[0].tolist() == [0.0, 0.0]        # gravity_scale 0
    assert pair_filter(World()) is None


# --------------------------------------------------------------------------------------
# Sensors and events
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["static", "kinematic", "dynamic"])
def test_ball_through_a_sensor_begins_and_ends_at_closed_form_times(kind):
    """A ball dropped from rest through a 1 m tall sensor: sensor_begin in the step whose
    start is the first after its bottom reaches the sensor's top (t1 = sqrt(2 d1 / g)),
    sensor_end after its top leaves the bottom (t2), within a step; no contact row, and
    the ball falls bit for bit as without the sensor."""
    def world(sensor: bool) -> World:
        w = World()
        if sensor:
            w.add_body({"type": "box", "size": [4.0, 1.0]}, position=(0.0, 0.0), kind=kind,
                       sensor=True, gravity_scale=0.0)
        w.add_body(BALL, position=(0.0, 3.0))
        return w
    w, free = world(True), world(False)
    dt = w.settings.dt
    t1, t2 = math.sqrt(2 * 2.0 / G), math.sqrt(2 * 4.0 / G)     # bottom at 0.5, top at -0.5
    begun = ended = None
    for _ in range(60):
        w.step()
        free.step()
        assert w.position[1].tolist() == free.position[0].tolist()
        assert w.velocity[1].tolist() == free.velocity[0].tolist()
        e = w.events
        if len(e.sensor_begin):
            assert e.sensor_begin.tolist() == [[0, 1]] and begun is None
            begun = w.time - dt              # the contacts were found at the step's start
        if len(e.sensor_end):
            assert e.sensor_end.tolist() == [[0, 1]] and ended is None
            ended = w.time - dt
        assert len(e.begin) == len(e.end) == len(e.hit) == 0
        assert len(w.contacts) == 0
        assert w.sensor_overlaps.tolist() == ([[0, 1]] if begun is not None and ended is None
                                              else [])
    assert 0.0 <= begun - t1 <= dt and 0.0 <= ended - t2 <= dt
    assert w.stage_counts["prepare"] == 0                 # no row ever reached the solver


def test_sensors_ignore_each_other_and_report_sleeping_visitors():
    w = World()
    w.add_body(GROUND, position=(0.0, -10.0), kind="static")
    w.add_body({"type": "box", "size": [4.0, 4.0]}, position=(0.0, 1.0), kind="static",
               sensor=True)
    w.add_body({"type": "box", "size": [4.0, 4.0]}, position=(0.5, 1.0), kind="static",
               sensor=True)
    w.add_body(BALL, position=(0.0, 0.6))
    for _ in range(120):
        w.step()
    assert w.asleep[3]                                    # at rest on the ground, inside both
    assert w.sensor_overlaps.tolist() == [[1, 3], [2, 3]]
    assert len(w.events.sensor_end) == 0


def test_begin_end_and_hit_of_a_bouncing_ball():
    """A ball dropped 2.5 m (bottom) onto the ground with restitution: begin and a hit at
    the landing, speed close to sqrt(2 g h) (the approach at the step's start, plus less
    than a step of gravity), normal up; end as it leaves."""
    w = World()
    w.add_body(GROUND, position=(0.0, -10.0), kind="static", restitution=0.8)
    w.add_body(BALL, position=(0.0, 3.0), restitution=0.8)
    log = []
    for _ in range(90):
        w.step()
        e = w.events
        log += [("begin", w.step_count, p) for p in e.begin.tolist()]
        log += [("end", w.step_count, p) for p in e.end.tolist()]
        for k in range(len(e.hit)):
            log.append(("hit", w.step_count, [int(e.hit.body_a[k]), int(e.hit.body_b[k])]))
            if log[0][0] == "begin" and len([x for x in log if x[0] == "hit"]) == 1:
                speed = math.sqrt(2 * G * 2.5)
                assert abs(e.hit.speed[k] - speed) < G * w.settings.dt
                assert e.hit.normal[k].tolist() == [0.0, 1.0]
                assert abs(e.hit.point[k, 1]) < 0.1
    kinds = [x[0] for x in log]
    assert kinds[:2] == ["begin", "hit"] and "end" in kinds
    assert all(x[2] == [0, 1] for x in log)
    first = log[0][1]
    assert first == math.ceil(math.sqrt(2 * 2.5 / G) * 60) or first == math.ceil(
        math.sqrt(2 * 2.5 / G) * 60) + 1


def test_events_before_a_step_and_after_an_idle_step_are_empty():
    w = World()
    w.add_body(GROUND, position=(0.0, -10.0), kind="static")
    assert len(w.events.begin) == 0
    w.step()                                              # nothing moves
    e = w.events
    assert len(e.begin) == len(e.end) == len(e.hit) == len(e.sensor_begin) == 0


# --------------------------------------------------------------------------------------
# Contact impulses
# --------------------------------------------------------------------------------------


def test_a_resting_box_carries_m_g_dt():
    w = World()
    w.add_body(GROUND, position=(0.0, -10.0), kind="static")
    w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 0.5), mass=2.0)
    w.settings = w.settings.with_values(sleeping=False)
    for _ in range(120):
        w.step()
    c = w.contacts
    assert len(c) == 2
    assert np.sum(c.normal_impulse) == pytest.approx(2.0 * G * w.settings.dt, rel=1e-6)
    assert abs(np.sum(c.tangent_impulse)) < 1e-12


def test_a_sliding_box_carries_friction_mu_times_the_normal_impulse():
    """Sliding, every substep's friction impulse is at its cone: the step's tangent
    impulse is -mu times its normal impulse (t = (n_y, -n_x) = +x on the ground; the
    box slides toward +x, so friction on it points to -x)."""
    w = World()
    w.add_body(GROUND, position=(0.0, -10.0), kind="static", friction=0.5)
    w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 0.5), velocity=(5.0, 0.0),
               mass=2.0, friction=0.5)
    for _ in range(10):
        w.step()
    c = w.contacts
    assert w.velocity[1, 0] > 0.5
    assert np.sum(c.tangent_impulse) == pytest.approx(-0.5 * np.sum(c.normal_impulse),
                                                      rel=1e-9)


# --------------------------------------------------------------------------------------
# Forces, impulses, explosions
# --------------------------------------------------------------------------------------


def _free(count: int = 1) -> World:
    w = World(gravity=(0.0, 0.0))
    for k in range(count):
        w.add_body({"type": "box", "size": [1.0, 0.5]}, position=(3.0 * k, 0.0),
                   velocity=(0.5, -0.25), mass=2.0)
    return w


def test_a_force_held_for_one_step_follows_the_integrator():
    """v1 = v0 + dt F / m; x1 = x0 + dt v0 + h^2 (F / m) S (S + 1) / 2; w1 = dt (r x F) / I;
    the force is released after the step."""
    w = _free()
    s = w.settings
    h, S, m, inertia = s.dt / s.substeps, s.substeps, 2.0, w.inertia[0]
    F = np.array([3.0, 4.0])
    r = np.array([0.0, 0.25])                                  # the box's top middle
    w.apply_force(0, F, point=w.center_of_mass[0] + r)
    w.step()
    a = F / m
    assert w.velocity[0] == pytest.approx(np.array([0.5, -0.25]) + s.dt * a, rel=1e-12)
    x = np.array([0.0, 0.0]) + s.dt * np.array([0.5, -0.25]) + h * h * a * S * (S + 1) / 2
    assert w.center_of_mass[0] == pytest.approx(x, rel=1e-12)
    torque = r[0] * F[1] - r[1] * F[0]
    assert w.angular_velocity[0] == pytest.approx(s.dt * torque / inertia, rel=1e-12)
    v, spin = w.velocity[0].copy(), w.angular_velocity[0]
    w.step()                                                   # released
    assert w.velocity[0].tolist() == v.tolist() and w.angular_velocity[0] == spin


def test_torques_and_forces_on_index_arrays_add_up():
    w = _free(3)
    dt = w.settings.dt
    w.apply_force([0, 2, 2], np.array([[1.0, 0.0], [0.0, 2.0], [0.0, 2.0]]))
    w.apply_torque(np.array([1, 1]), [0.5, 0.25])
    w.step()
    v0 = np.array([0.5, -0.25])
    assert w.velocity[0] == pytest.approx(v0 + dt * np.array([0.5, 0.0]), rel=1e-12)
    assert w.velocity[2] == pytest.approx(v0 + dt * np.array([0.0, 2.0]), rel=1e-12)
    assert w.velocity[1].tolist() == v0.tolist()
    assert w.angular_velocity[1] == pytest.approx(dt * 0.75 / w.inertia[1], rel=1e-12)


def test_an_impulse_changes_the_velocities_at_once():
    w = _free(2)
    J, r = np.array([1.0, -2.0]), np.array([0.5, 0.0])
    w.apply_impulse(1, J, point=w.center_of_mass[1] + r)
    assert w.velocity[1].tolist() == (np.array([0.5, -0.25]) + J * (1 / 2.0)).tolist()
    assert w.angular_velocity[1] == (r[0] * J[1] - r[1] * J[0]) * (1.0 / w.inertia[1])
    assert w.velocity[0].tolist() == [0.5, -0.25]
    w.apply_impulse([0, 1], [[2.0, 0.0], [2.0, 0.0]])
    assert w.velocity[0].tolist() == [1.5, -0.25]


def test_forces_wake_sleepers_and_ignore_fixed_bodies():
    w = World()
    ground = w.add_body(GROUND, position=(0.0, -10.0), kind="static")
    box = w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 0.5))
    for _ in range(120):
        w.step()
    assert w.asleep[box]
    w.apply_impulse(ground, (5.0, 0.0))
    assert w.velocity[ground].tolist() == [0.0, 0.0] and w.asleep[box]
    w.apply_force(box, (50.0, 0.0))
    assert not w.asleep[box]


@pytest.mark.parametrize("call, message", [
    (lambda w: w.apply_force(0, (1.0, float("nan"))), "force: must be finite"),
    (lambda w: w.apply_force(0, (1.0, 2.0, 3.0)), "force: must be (2,) or (N, 2)"),
    (lambda w: w.apply_impulse([0, 0], np.ones((3, 2))), "impulse: must be (2,) or (N, 2)"),
    (lambda w: w.apply_torque(0, "x"), "torque: must be numbers"),
    (lambda w: w.explode((0, 0), -1.0, 1.0), "radius: must be > 0"),
])
def test_bad_forces_raise_one_spec_error(call, message):
    with pytest.raises(SpecError, match=message.replace("(", r"\(").replace(")", r"\)")):
        call(_free())
    with pytest.raises(IndexError):
        _free().apply_force(5, (1.0, 0.0))


def test_explode_pushes_by_the_width_facing_the_blast():
    """A circle r at distance d < radius: impulse 2 r I along its centre's direction at
    its nearest point (no spin); a box face-on: its face width; beyond the radius and
    static bodies: nothing."""
    w = World(gravity=(0.0, 0.0))
    ball = w.add_body({"type": "circle", "radius": 0.5}, position=(3.0, 4.0), mass=2.0)
    box = w.add_body({"type": "box", "size": [1.0, 2.0]}, position=(-2.0, 0.0), mass=4.0)
    far = w.add_body(BALL, position=(20.0, 0.0))
    w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, -2.0), kind="static")
    pushed = w.explode((0.0, 0.0), 6.0, 3.0)
    assert pushed.tolist() == [ball, box]
    assert w.velocity[ball] == pytest.approx(np.array([0.6, 0.8]) * 3.0 * 1.0 / 2.0,
                                             rel=1e-12)
    assert w.angular_velocity[ball] == pytest.approx(0.0, abs=1e-12)
    assert w.velocity[box] == pytest.approx(np.array([-1.0, 0.0]) * 3.0 * 2.0 / 4.0,
                                            rel=1e-12)
    assert w.angular_velocity[box] == pytest.approx(0.0, abs=1e-12)
    assert w.velocity[far].tolist() == [0.0, 0.0]


def _blast_world(gravity=(0.0, 0.0)) -> World:
    w = World(gravity=gravity)
    w.add_body({"type": "circle", "radius": 0.5}, position=(3.0, 4.0), mass=2.0)
    return w


#: The ball's velocity after the blast: impulse 3 N s/m times its width 1 m, along its
#: centre's direction (0.6, 0.8), over its 2 kg.
_KICK = np.array([0.6, 0.8]) * 3.0 * 1.0 / 2.0


@pytest.mark.parametrize("steps, time", [(3, 3 / 60), (60, 1.0), (3, 2.5 / 60), (0, 0.0)])
def test_explode_at_runs_at_the_start_of_the_first_step_at_or_after_its_time(steps, time):
    """The blast runs at the start of step ``steps`` (the first beginning at or after
    ``time``, the sum of dt's rounding aside): before it the ball rests, after it the
    ball has the closed-form velocity, and the run is bit for bit the one that calls
    ``explode`` by hand before that step (copies carry the pending blast)."""
    w, by_hand = _blast_world(), _blast_world()
    w.explode_at(time, (0.0, 0.0), 6.0, 3.0)
    for _ in range(steps):
        w.step()
        by_hand.step()
    assert w.velocity[0].tolist() == [0.0, 0.0]
    copy = pickle.loads(pickle.dumps(w))
    by_hand.explode((0.0, 0.0), 6.0, 3.0)
    for world in (w, by_hand, copy):
        world.step()
        world.step()
    assert w.velocity[0] == pytest.approx(_KICK, rel=1e-12)
    assert w.position[0].tolist() == by_hand.position[0].tolist() == copy.position[0].tolist()
    assert w.velocity[0].tolist() == by_hand.velocity[0].tolist()
    assert w._blasts == []


def test_explode_tables_of_a_scene_schedule_blasts_in_time_order():
    """Two [[explode]] tables, listed late first: each runs once at its step, and the
    ball's velocity is the sum of the closed-form kicks."""
    scene = {"version": 1, "world": {"gravity": [0.0, 0.0]},
             "body": [{"shape": BALL, "position": [3.0, 4.0], "mass": 2.0}],
             "explode": [{"time": 0.1, "center": [3.0, 0.0], "radius": 6.0, "impulse": 2.0},
                         {"time": 0.05, "center": [0.0, 0.0], "radius": 6.0,
                          "impulse": 3.0}]}
    w = read_scene(scene).build()
    seen = []
    for _ in range(8):
        w.step()
        seen.append(w.velocity[0].copy())
    assert seen[2].tolist() == [0.0, 0.0]                          # after steps 0-2
    assert seen[3] == pytest.approx(_KICK, rel=1e-12)              # step 3: t = 3 dt
    assert seen[5] == pytest.approx(_KICK, rel=1e-12)
    # Step 6: the second blast from below the ball (which has moved by 3 dt of the
    # first kick): 2 N s/m times its 1 m width along the direction to its centre.
    centre = np.array([3.0, 4.0]) + _KICK * 3.0 / 60.0
    away = (centre - (3.0, 0.0)) / np.hypot(*(centre - (3.0, 0.0)))
    assert seen[6] == pytest.approx(_KICK + away * 2.0 * 1.0 / 2.0, rel=1e-12)
    assert seen[7].tolist() == seen[6].tolist()


@pytest.mark.parametrize("key, value, message", [
    ("time", -1, "explode[0].time: must be >= 0, got -1"),
    ("radius", 0, "explode[0].radius: must be > 0, got 0"),
    ("center", [1.0], "explode[0].center: must be a pair [x, y], got [1.0]"),
    ("impulse", "big", "explode[0].impulse: must be a number, got 'big'"),
    ("impulse", None, "explode[0].impulse: is required"),
    ("radios", 1.0, "explode[0].radios: unknown key (did you mean 'radius'?)"),
])
def test_bad_explode_tables_name_the_key_path(key, value, message):
    blast = {"time": 0.5, "center": [0.0, 0.0], "radius": 1.0, "impulse": 1.0}
    if value is None:
        del blast[key]
    else:
        blast[key] = value
    with pytest.raises(SpecError) as err:
        read_scene({"version": 1, "body": [{"shape": BALL}], "explode": [blast]})
    assert str(err.value) == "<scene>: " + message
    if key in ("time", "radius", "impulse") and value is not None:   # the API alike
        with pytest.raises(SpecError, match=message.removeprefix("explode[0].")):
            World().explode_at(**blast)


def test_bad_explode_table_exits_2_with_one_line(tmp_path):
    path = tmp_path / "blast.toml"
    path.write_text("version = 1\n[[body]]\nshape = { type = 'circle', radius = 1.0 }\n"
                    "[[explode]]\ntime = 1.0\ncenter = [0, 0]\nradius = -2\nimpulse = 1\n")
    result = subprocess.run([sys.executable, "-m", "sdfphys.cli", "run", str(path), "-o",
                             str(tmp_path / "out.mp4")], capture_output=True, text=True,
                            check=False)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        f"sdfphys: error: {path}: explode[0].radius: must be > 0, got -2"]


# --------------------------------------------------------------------------------------
# Stable handles, copies and pickles
# --------------------------------------------------------------------------------------


def test_handles_follow_their_bodies_through_removals():
    w = World()
    a = w.add_body(BALL, position=(0.0, 0.0), name="a")
    b = w.add_body(BALL, position=(2.0, 0.0), name="b")
    c = w.add_body(BALL, position=(4.0, 0.0))
    assert (a, b, c) == (0, 1, 2) and w.position[c].tolist() == [4.0, 0.0]
    w.remove_body(a)
    assert (b.index, c.index) == (0, 1) and b == 0 and c == 1
    assert w.position[c].tolist() == [4.0, 0.0] and c.name == "body2"
    w.set_state(c, position=(5.0, 1.0))
    w.apply_impulse([b, c], (1.0, 0.0))
    assert w.position[1].tolist() == [5.0, 1.0] and w.velocity[c, 0] > 0.0
    assert w.position[[c, b]].tolist() == [[5.0, 1.0], [2.0, 0.0]]     # lists of handles
    assert w.body("b") == b and hash(w.body("b")) == hash(b) and w.body("b").id == 1
    with pytest.raises(IndexError, match="was removed"):
        w.set_state(a, angle=1.0)
    with pytest.raises(IndexError):
        w.velocity[a]
    with pytest.raises(KeyError, match="no body named 'bb'"):
        w.body("bb")
    d = w.add_body(BALL)
    assert d.id == 3 and d == 2 and a != d
    assert sorted([d, c, b]) == [b, c, d] and b < 1 < d and d > c      # ordered as indices


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_a_copied_world_steps_on_bit_for_bit(how):
    """Mid-run (contacts, warm starts, sleeping islands, joints, a sensor, a held
    force), the copy and the original take the same next steps."""
    import copy
    import pickle

    from sdfphys.scene import load_scene

    w = load_scene("scenes/ragdoll.toml")
    w.add_body({"type": "box", "size": [3.0, 3.0]}, position=(0.0, 1.0), kind="static",
               sensor=True)
    for _ in range(30):
        w.step()
    w.apply_force(1, (20.0, 0.0))
    twin = copy.deepcopy(w) if how == "deepcopy" else pickle.loads(pickle.dumps(w))
    for _ in range(30):
        w.step()
        twin.step()
        assert w.position.tobytes() == twin.position.tobytes()
        assert w.velocity.tobytes() == twin.velocity.tobytes()
        assert w.angle.tobytes() == twin.angle.tobytes()
        assert w.events.begin.tolist() == twin.events.begin.tolist()
    twin.add_body(BALL, position=(0.0, 8.0))
    assert len(twin) == len(w) + 1 and len(twin.shapes) >= len(w.shapes)
