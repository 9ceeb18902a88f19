"""sdfphys against pymunk (``sdfphys.reference``).

Contacts: at every frame of a run, a pymunk space is moved to sdfphys's poses and its
``shapes_collide`` must give the contacts of sdfphys's ``find_contacts`` to 1e-9
(both sides are exact formulas; see tests/test_collide_pymunk.py for the
conventions). Trajectories: the four reference scenes run in both engines from the
same initial state; each test states its horizon, its tolerance and where the
tolerance comes from (the differences the module docstring of sdfphys.reference
lists: pymunk has no speculative contacts and no soft contacts, its slop and bias
are not ours, and its step starts at another stage of the same loop).
"""

import functools
import math
import re
from pathlib import Path

import numpy as np
import pymunk
import pytest

from sdfphys.errors import SpecError
from sdfphys.reference import (
    CONTACT_TOLERANCE,
    NotModelledError,
    PymunkWorld,
    check_modelled,
    compare,
    compare_main,
    contact_difference,
    sdfphys_contacts,
)
from sdfphys.scene import load_scene, read_scene
from sdfphys.solver import contact_softness

SCENES = Path(__file__).resolve().parents[1] / "scenes"
G = 9.81
ROUND_OFF = 1e-12


@functools.cache
def comparison(name, seconds=None):
    """compare() of scenes/<name>.toml, run once per test session."""
    return compare(read_scene(SCENES / f"{name}.toml"), seconds)


def during(c, start, end):
    """Frame indices with start <= t <= end (s)."""
    return np.flatnonzero((c.time >= start - 1e-9) & (c.time <= end + 1e-9))


def resting_depth(settings):
    """sdfphys's steady overlap under gravity against a static body (m).

    With the warm-started impulse l = m g h per substep, the biased solve leaves l
    unchanged when m mass_scale bias_rate (-s) = impulse_scale m g h, so
    s = -impulse_scale g h / (mass_scale bias_rate) (docs/solver.md's soft step).
    """
    _, stiff = contact_softness(settings)
    h = settings.dt / settings.substeps
    return stiff.impulse_scale * G * h / (stiff.mass_scale * stiff.bias_rate)


# ---------------------------------------------------------------------------------------
# Contacts at identical poses
# ---------------------------------------------------------------------------------------

def test_head_on_balls_never_overlap():
    """The velocity-aware speculative contact meets the approaching balls at zero gap:
    sdfphys's deepest contact over the whole scene is not an overlap (so there is nothing
    to compare with pymunk at the contact level in this scene)."""
    world = load_scene(SCENES / "head_on.toml")
    deepest = 0.0
    for _ in range(round(world.scene.duration / world.settings.dt)):
        world.step()
        if len(world.contacts):
            deepest = max(deepest, float(world.contacts.depth.max()))
    assert deepest <= 0.0


@pytest.mark.parametrize("name, seconds", [
    ("ball_drop", None), ("newtons_cradle", None),
    ("ball_off_ledge", None), ("restitution_row", None), ("circles_in_box", 1.2)])
def test_contacts_match_pymunk_at_every_frame(name, seconds):
    """Every frame of the scene's horizon (its duration; circles_in_box: 1.2 s, by when
    the pile has ~150 contacts): every pair that either engine finds overlapping by
    more than 1e-9 is found by both, with points, normals and depths within 1e-9.
    (head_on is not here: its balls never overlap, see the next test.)"""
    c = comparison(name, seconds)
    for t, d in zip(c.time, c.contacts):
        assert d.one_sided == 0, f"t = {t:.4f} s"
        assert max(d.point, d.normal, d.depth) <= CONTACT_TOLERANCE, f"t = {t:.4f} s"
    assert sum(d.compared for d in c.contacts) > 0


KINDS_SCENE = {
    "version": 1,
    "body": [
        {"name": "ground", "shape": {"type": "box", "size": [20.0, 1.0]},
         "position": [0.0, -0.5], "static": True},
        {"name": "ramp", "shape": {"type": "sdf", "field": {
            "type": "capsule", "a": [-1.5, 0.6], "b": [1.5, -0.6], "radius": 0.15,
            "offset": [-3.0, 2.0], "angle": 0.1}}, "static": True},
        {"name": "rail", "shape": {"type": "sdf", "field": {
            "type": "segment", "a": [4.5, 1.0], "b": [6.5, 0.6]}}, "static": True},
        {"name": "wedge", "shape": {"type": "polygon", "points": [
            [0.0, 0.0], [1.6, 0.0], [1.2, 0.9], [0.3, 1.1]]},
         "position": [0.4, 0.0], "angle": 0.2, "static": True},
        {"name": "bumper", "shape": {"type": "circle", "radius": 0.4},
         "position": [-1.0, 0.4], "static": True},
        {"name": "platform", "shape": {"type": "box", "size": [2.0, 0.3]},
         "position": [3.0, 2.0], "angle": 0.1, "velocity": [-0.5, 0.0],
         "angular_velocity": 0.2, "kinematic": True},
        {"name": "on_ramp", "shape": {"type": "circle", "radius": 0.3},
         "position": [-4.2, 3.4]},
        {"name": "on_wedge", "shape": {"type": "circle", "radius": 0.25},
         "position": [1.3, 2.0]},
        {"name": "on_platform", "shape": {"type": "circle", "radius": 0.3},
         "position": [3.2, 2.8]},
        {"name": "on_rail", "shape": {"type": "circle", "radius": 0.2},
         "position": [5.0, 1.6]},
        {"name": "on_bumper", "shape": {"type": "circle", "radius": 0.3},   # comes to
         "position": [-1.0, 1.6]},                                          # rest on top
    ],
}


def test_contacts_match_pymunk_for_every_modelled_shape():
    """Circles against a capsule and a segment field (pymunk.Segment), an off-centre
    convex polygon turned by 0.2 rad, a static circle and a moving, turning kinematic
    box: 1e-9 at every frame of 2 s, and every one of those bodies touched."""
    scene = read_scene(KINDS_SCENE)
    world = scene.build()
    probe = PymunkWorld(scene)
    touched = set()
    for step in range(121):
        if step:
            world.step()
        probe.set_poses(world.center_of_mass, world.angle)
        ours, theirs = sdfphys_contacts(world), probe.contacts()
        d = contact_difference(ours, theirs)
        assert d.one_sided == 0, step
        assert max(d.point, d.normal, d.depth) <= CONTACT_TOLERANCE, step
        touched |= {world.names[a] for a in theirs.body_a}
    assert touched >= {"ground", "ramp", "rail", "wedge", "bumper", "platform"}


# ---------------------------------------------------------------------------------------
# Trajectories
# ---------------------------------------------------------------------------------------

def test_ball_drop_free_fall_agrees_to_round_off():
    """Horizon 0-0.70 s: the ball's bottom is 2.5 m up, reached at sqrt(2 x 2.5 / g) =
    0.714 s, so neither engine has a contact yet. Both integrate semi-implicit Euler
    with h = dt / 4 (pymunk after its priming step): positions equal the closed form
    y0 - g h^2 n (n + 1) / 2 after n substeps to round-off, and after the first step
    (which primes pymunk) pymunk's velocity is sdfphys's plus one more kick, -g h."""
    c = comparison("ball_drop")
    frames = during(c, 0.0, 0.70)
    h = 1.0 / 240.0
    n = 4 * frames
    exact = 3.0 - G * h * h * n * (n + 1) / 2
    np.testing.assert_allclose(c.ours_com[frames, 1, 1], exact, rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(c.theirs_com[frames], c.ours_com[frames], rtol=0,
                               atol=ROUND_OFF)
    stepped = frames[1:]
    np.testing.assert_allclose(c.theirs_velocity[stepped, 1, 1],
                               c.ours_velocity[stepped, 1, 1] - G * h, rtol=0, atol=ROUND_OFF)


def test_ball_drop_bounces_agree_within_the_impact_delay():
    """Horizon 0.70-2.0 s (three bounces). Tolerance 2 (1 + e) v dt = 0.35 m with the
    impact speed v = sqrt(2 g 2.5) = 7.0 m/s: sdfphys collides once per step and keeps
    contacts within 0.02 m, while the ball falls v dt = 0.12 m per step, so it sees the
    impact up to a step late and resolves it in the next step (restitution after the
    substeps); pymunk resolves it within a substep. A bounce is up to 2 dt later in
    sdfphys, which offsets the ball by at most its velocity change times 2 dt."""
    c = comparison("ball_drop")
    frames = during(c, 0.70, 2.0)
    bound = 2 * 1.5 * math.sqrt(2 * G * 2.5) / 60.0
    assert c.position_difference()[frames].max() <= bound


def test_ball_drop_comes_to_rest_in_both_engines():
    """Horizon 2.5-3.0 s: both balls rest. pymunk's sits where its last landing left
    it, 0 to collision_slop (= linear_slop) deep; sdfphys's sinks toward its soft
    contact's steady depth under gravity (resting_depth, 6.9e-5 m) from above: heights
    within the sum of the two."""
    c = comparison("ball_drop")
    scene = read_scene(SCENES / "ball_drop.toml")
    frames = during(c, 2.5, 3.0)
    ours_depth = 0.5 - c.ours_com[frames, 1, 1]
    assert np.all((ours_depth >= 0.0) & (ours_depth <= resting_depth(scene.settings)))
    theirs_depth = 0.5 - c.theirs_com[frames, 1, 1]
    assert np.all((theirs_depth >= 0.0) & (theirs_depth <= scene.settings.linear_slop))
    assert np.abs(c.ours_velocity[frames]).max() <= ROUND_OFF
    assert np.abs(c.theirs_velocity[frames]).max() <= ROUND_OFF


HEAD_ON_MASS = (math.pi * 0.5**2, math.pi * 0.3**2)


def head_on_exact():
    """(B, 2) velocities of the head-on balls after the impact (1D, e = 0.8)."""
    (m1, m2), (v1, v2), e = HEAD_ON_MASS, (2.0, -3.0), 0.8
    after = (v1 + (1 + e) * m2 / (m1 + m2) * (v2 - v1), v2 + (1 + e) * m1 / (m1 + m2) * (v1 - v2))
    return np.array([[after[0], 0.0], [after[1], 0.0]])


def test_head_on_agrees_to_round_off_before_the_impact():
    """Horizon 0-1.0 s: the 5.2 m gap closes at 5 m/s at 1.04 s (sdfphys may see the
    contact 0.02 m, 4 ms, early). Without gravity both engines add h v every substep:
    equal to round-off, velocities unchanged."""
    c = comparison("head_on")
    frames = during(c, 0.0, 1.0)
    np.testing.assert_allclose(c.theirs_com[frames], c.ours_com[frames], rtol=0,
                               atol=ROUND_OFF)
    for v in (c.ours_velocity[frames], c.theirs_velocity[frames]):
        np.testing.assert_array_equal(v, np.broadcast_to([[2.0, 0.0], [-3.0, 0.0]], v.shape))


def test_head_on_conserves_the_centre_of_mass_in_both_engines():
    """Whole run (3 s): contact impulses, biased or not, act in equal and opposite
    pairs, so the centre of mass moves at the initial momentum / mass in both engines:
    equal to each other and to the straight line, to round-off."""
    c = comparison("head_on")
    m = np.array(HEAD_ON_MASS)
    exact = (m @ np.array([-3.0, 3.0]) + (m @ np.array([2.0, -3.0])) * c.time) / m.sum()
    for com in (c.ours_com, c.theirs_com):
        np.testing.assert_allclose(com[:, :, 0] @ m / m.sum(), exact, rtol=0, atol=ROUND_OFF)
        np.testing.assert_array_equal(com[:, :, 1], 0.0)


def test_head_on_after_the_impact_velocities_are_exact_and_positions_within_the_delay():
    """Horizon 1.1-3.0 s (sdfphys resolves the impact by 1.04 s + 2 dt = 1.073 s).
    Both engines give the relative velocity -e times the approach speed (no gravity:
    the approach speed at the start of the step is the impact speed) and conserve
    momentum, so velocities equal the 1D collision's to round-off. Positions: each
    ball is offset by at most its velocity change times 2 dt (the impact delay of
    test_ball_drop_bounces_agree_within_the_impact_delay)."""
    c = comparison("head_on")
    frames = during(c, 1.1, 3.0)
    exact = head_on_exact()
    for v in (c.ours_velocity[frames], c.theirs_velocity[frames]):
        np.testing.assert_allclose(v, np.broadcast_to(exact, v.shape), rtol=0, atol=ROUND_OFF)
    change = np.abs(exact[:, 0] - np.array([2.0, -3.0]))
    assert np.all(c.position_difference()[frames] <= change * 2.0 / 60.0)


def test_newtons_cradle_before_the_impact():
    """Horizon 0-0.70 s: the striker's 3 m gap closes at 4 m/s at 0.75 s. The striker's
    x agrees to round-off; every ball rests on the ground, pymunk's exactly touching
    (it started so, and pymunk's slop leaves it there), sdfphys's sunk to its soft
    contact's steady depth (resting_depth): heights within that depth."""
    c = comparison("newtons_cradle")
    scene = read_scene(SCENES / "newtons_cradle.toml")
    frames = during(c, 0.0, 0.70)
    np.testing.assert_allclose(c.ours_com[frames, :, 0], c.theirs_com[frames, :, 0], rtol=0,
                               atol=ROUND_OFF)
    np.testing.assert_array_equal(c.theirs_com[frames, 1:, 1], 0.5)
    sunk = c.theirs_com[frames, 1:, 1] - c.ours_com[frames, 1:, 1]
    assert np.all((sunk >= 0.0) & (sunk <= resting_depth(scene.settings) + ROUND_OFF))


def test_newtons_cradle_conserves_horizontal_momentum_in_both_engines():
    """Horizon 0-3.0 s (pymunk's last ball reaches the end of the 30 m ground at about
    3.5 s and then meets its corner). The ground is frictionless and its normal
    vertical, and contact impulses come in equal and opposite pairs: both engines
    keep the horizontal momentum 4 m and move the balls' centre of mass at 4 / 6 m/s,
    to round-off, however differently they share the momentum out."""
    c = comparison("newtons_cradle")
    frames = during(c, 0.0, 3.0)
    x0 = np.array([b.position[0] for b in read_scene(SCENES / "newtons_cradle.toml").bodies[1:]])
    for com in (c.ours_com, c.theirs_com):
        mean_x = com[frames, 1:, 0].mean(axis=1)
        np.testing.assert_allclose(mean_x, x0.mean() + 4.0 / 6.0 * c.time[frames], rtol=0,
                                   atol=1e-9)
    for v in (c.ours_velocity, c.theirs_velocity):
        np.testing.assert_allclose(v[frames, 1:, 0].sum(axis=1), 4.0, rtol=0, atol=ROUND_OFF)


def test_newtons_cradle_last_ball_leaves_with_the_strikers_speed():
    """At 1.5 s (after the impacts, which end by 0.8 s): the textbook cradle, which pymunk
    reproduces exactly: the last ball at the striker's 4 m/s, the others at rest, to 1% of
    4 m/s. The scene's balls are 5 cm apart so the impacts come one at a time (touching
    balls would be simultaneous impacts, which a sequential impulse solver with a
    restitution threshold on the approach speed resolves partly inelastically)."""
    c = comparison("newtons_cradle")
    frame = during(c, 1.5, 1.5)[0]
    exact = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 4.0, 0.0])
    np.testing.assert_allclose(c.theirs_velocity[frame, :, 0], exact, rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(c.ours_velocity[frame, :, 0], exact, rtol=0, atol=0.04)


def test_ball_off_ledge_rolls_on_the_ledge_within_the_length_tolerance():
    """Horizon 0-1.7 s (the centre reaches the corner at x = -1 at 1.75 s). pymunk rolls
    exactly (v = 2 m/s, w = -v / r, on the surface). Tolerance linear_slop = 5 mm, the
    engines' length tolerance: sdfphys's rolling ball sinks about 1 mm and, with its
    contact anchored midway between the surfaces, rolls on radius r - depth / 2,
    drifting 1.2 mm/s behind."""
    c = comparison("ball_off_ledge")
    scene = read_scene(SCENES / "ball_off_ledge.toml")
    frames = during(c, 0.0, 1.7)
    np.testing.assert_allclose(c.theirs_com[frames, 2, 0], -4.5 + 2.0 * c.time[frames],
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(c.theirs_com[frames, 2, 1], 2.8, rtol=0, atol=1e-9)
    np.testing.assert_allclose(c.theirs_angle[frames, 2], -2.0 / 0.3 * c.time[frames],
                               rtol=0, atol=1e-9)
    assert c.position_difference()[frames, 2].max() <= scene.settings.linear_slop


def test_ball_off_ledge_falls_within_one_step_of_support():
    """Horizon 1.75-2.4 s, from the corner to just before landing (the ball's bottom
    reaches the ground at about 2.46 s). At 2 m/s on a 0.3 m ball, v^2 / r > g: the
    ball leaves the corner at once; sdfphys, colliding once per step with speculative
    contacts, may hold it up to one step longer, a vertical velocity difference of up to
    g dt. Tolerance: linear_slop (on the ledge) + g dt (t - 1.75 s)."""
    c = comparison("ball_off_ledge")
    scene = read_scene(SCENES / "ball_off_ledge.toml")
    frames = during(c, 1.75, 2.4)
    bound = scene.settings.linear_slop + G / 60.0 * (c.time[frames] - 1.75)
    assert np.all(c.position_difference()[frames, 2] <= bound)


def test_ball_off_ledge_rolls_on_the_ground_in_both_engines():
    """Horizon 2.8-3.0 s, after landing: each engine keeps the ball's overlap within its
    own tolerance, pymunk within collision_slop (it landed inside it and is not pushed
    out), sdfphys within linear_slop (rolling sink, about 1 mm)."""
    c = comparison("ball_off_ledge")
    slop = read_scene(SCENES / "ball_off_ledge.toml").settings.linear_slop
    frames = during(c, 2.8, 3.0)
    for com in (c.ours_com, c.theirs_com):
        overlap = 0.3 - com[frames, 2, 1]
        assert np.all((overlap >= 0.0) & (overlap <= slop))


# ---------------------------------------------------------------------------------------
# How the pymunk scene is built
# ---------------------------------------------------------------------------------------

def test_masses_and_moments_match_sdfphys():
    """pymunk.moment_for_circle(m, 0, r) = m r^2 / 2: sdfphys's inertia, for density
    and for mass given."""
    scene = read_scene({"version": 1, "body": [
        {"shape": {"type": "circle", "radius": 0.7}, "density": 2.5},
        {"shape": {"type": "circle", "radius": 0.2}, "mass": 3.0, "position": [2.0, 0.0]}]})
    world, reference = scene.build(), PymunkWorld(scene)
    np.testing.assert_allclose([b.mass for b in reference.bodies], world.mass, rtol=1e-15)
    np.testing.assert_allclose([b.moment for b in reference.bodies], world.inertia, rtol=1e-15)


def sliding_scene(velocity, gravity=(0.0, -G)):
    """A ball (friction 0.1, restitution 0) touching a static box (friction 0.9,
    restitution 0.5) with the given velocity."""
    return read_scene({"version": 1, "world": {"gravity": list(gravity)}, "body": [
        {"shape": {"type": "box", "size": [20.0, 1.0]}, "position": [0.0, -0.5],
         "static": True, "friction": 0.9, "restitution": 0.5},
        {"shape": {"type": "circle", "radius": 0.5}, "position": [-5.0, 0.5],
         "velocity": list(velocity), "friction": 0.1}]})


def test_friction_mixes_as_the_square_root_of_the_product():
    """A ball sliding at 3 m/s on the ground: every substep friction takes mu g h off
    its speed, mu = sqrt(0.1 x 0.9) = 0.3 (pymunk's own mixing would give 0.09).
    First 5 steps, while it slides: sdfphys's speed 3 - 4 k mu g h after k steps,
    pymunk's one substep's friction further (it is one kick ahead), to round-off."""
    scene = sliding_scene((3.0, 0.0))
    world, reference = scene.build(), PymunkWorld(scene)
    h = scene.settings.dt / 4
    for k in range(1, 6):
        world.step()
        reference.step()
        assert world.velocity[1, 0] == pytest.approx(3.0 - 4 * k * 0.3 * G * h, abs=ROUND_OFF)
        assert reference.bodies[1].velocity.x == pytest.approx(3.0 - (4 * k + 1) * 0.3 * G * h,
                                                                abs=ROUND_OFF)


@pytest.mark.parametrize("speed, rebound", [(3.0, 1.5), (0.5, 0.0)])
def test_restitution_mixes_as_the_max_with_the_threshold(speed, rebound):
    """Without gravity, a ball (e = 0) thrown at a box (e = 0.5): above the 1 m/s
    threshold it leaves at max(0, 0.5) x 3 m/s (pymunk's product would give 0), below
    it it stops; both engines, to round-off, 0.2 s after the throw."""
    scene = sliding_scene((0.0, -speed), gravity=(0.0, 0.0))
    world, reference = scene.build(), PymunkWorld(scene)
    for _ in range(12):
        world.step()
        reference.step()
    assert world.velocity[1] == pytest.approx([0.0, rebound], abs=ROUND_OFF)
    assert tuple(reference.bodies[1].velocity) == pytest.approx((0.0, rebound), abs=ROUND_OFF)


def test_settings_follow_sdfphys():
    """iterations 1 + relax_passes, collision_slop = linear_slop, collision_bias =
    exp(-mass_scale bias_rate) (sdfphys's push-out rate against static bodies)."""
    scene = read_scene(SCENES / "ball_drop.toml", ["sim.relax_passes=3", "sim.linear_slop=0.01"])
    space = PymunkWorld(scene).space
    _, stiff = contact_softness(scene.settings)
    assert space.iterations == 4
    assert space.collision_slop == 0.01
    assert space.collision_bias == pytest.approx(math.exp(-stiff.mass_scale * stiff.bias_rate),
                                                 rel=1e-12)
    assert tuple(space.gravity) == (0.0, -9.81)
    assert isinstance(PymunkWorld(read_scene(KINDS_SCENE)).shapes[1], pymunk.Segment)


# ---------------------------------------------------------------------------------------
# What is not modelled, and the command
# ---------------------------------------------------------------------------------------

def test_check_modelled_names_every_body_it_cannot_build():
    scene = read_scene({"version": 1, "body": [
        {"name": "ball", "shape": {"type": "circle", "radius": 0.5}},
        {"name": "crate", "shape": {"type": "box", "size": [1.0, 1.0]}, "position": [3.0, 0.0]},
        {"name": "ell", "static": True, "position": [0.0, -3.0], "shape": {
            "type": "polygon", "points": [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]}},
        {"name": "blob", "position": [6.0, 0.0], "shape": {
            "type": "sdf", "field": {"type": "ellipse", "size": [1.0, 0.5]}}},
        {"name": "floor", "static": True, "position": [0.0, -6.0],
         "shape": {"type": "box", "size": [10.0, 1.0]}}]})
    with pytest.raises(NotModelledError) as err:
        check_modelled(scene)
    message = str(err.value)
    assert isinstance(err.value, SpecError) and "\n" not in message
    assert "body[3] 'blob' (dynamic sdf)" in message
    for modelled in ("'ball'", "'floor'", "'crate'", "'ell'"):    # boxes and polygons are
        assert modelled not in message                            # modelled, of any kind


SHIPPED = sorted(SCENES.glob("*.toml"))


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_every_shipped_scene_without_sdf_bodies_is_modelled(path):
    """The issue: compare refused 11 of the 18 scenes (box_stack among them). Now it
    refuses only scenes with SDF bodies (other than static capsules and segments), and
    names exactly those bodies."""
    scene = read_scene(path)
    sdf = [(i, b.name) for i, b in enumerate(scene.bodies) if b.shape.kind == "sdf"
           and (b.kind == "dynamic" or b.shape.spec["field"].get("type")
                not in ("capsule", "segment"))]
    if not sdf:
        PymunkWorld(scene)
        check_modelled(scene)
        return
    with pytest.raises(NotModelledError) as err:
        check_modelled(scene)
    named = re.findall(r"body\[(\d+)\] '([^']*)'", str(err.value))
    assert [(int(i), name) for i, name in named] == sdf[:10]


def test_polygons_of_any_kind_match_sdfphys_masses_and_moments():
    scene = read_scene({"version": 1, "body": [
        {"name": "crate", "shape": {"type": "box", "size": [1.5, 0.5]}, "density": 2.0},
        {"name": "ell", "position": [4.0, 0.0], "mass": 3.0, "shape": {
            "type": "polygon", "points": [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]}},
        {"name": "star", "position": [8.0, 0.0], "shape": {"type": "polygon", "points": [
            [np.cos(a) * r, np.sin(a) * r] for a, r in zip(np.linspace(0, 2 * np.pi, 10,
                                                                        endpoint=False),
                                                            [1.0, 0.4] * 5)]}}]})
    world, pm = scene.build(), PymunkWorld(scene)
    assert [len(p) for p in pm.parts][:2] == [1, 2] and list(pm.exact) == [1, 0, 0]
    for i, body in enumerate(pm.bodies):
        assert body.mass == pytest.approx(world.mass[i], rel=1e-12)
        assert body.moment == pytest.approx(world.inertia[i], rel=1e-12)
        np.testing.assert_allclose(body.position, world.center_of_mass[i], atol=1e-12)


def test_convex_parts_cover_a_concave_polygon_exactly(rng):
    from sdfphys.reference import convex_parts
    from sdfphys.shapes import shape_from_spec

    shape = shape_from_spec({"type": "polygon", "points": [
        [0, 0], [3, 0], [3, 1], [1, 1], [1, 1.5], [2.5, 1.5], [2.5, 3], [0, 3]]})
    parts = convex_parts(shape.vertices)
    assert len(parts) >= 2
    points = rng.uniform(-0.5, 3.5, (4000, 2)) + shape.vertices.min(axis=0)
    inside = shape.field.distance(points) < -1e-9
    outside = shape.field.distance(points) > 1e-9
    in_part = np.zeros(len(points), bool)
    for part in parts:
        edge = np.roll(part, -1, axis=0) - part
        rel = points[:, None, :] - part[None, :, :]
        cross = edge[None, :, 0] * rel[:, :, 1] - edge[None, :, 1] * rel[:, :, 0]
        in_part |= np.all(cross >= 0.0, axis=1)
    assert np.all(in_part[inside]) and not np.any(in_part[outside])


def test_box_stack_compares_face_contacts():
    """Boxes face to face: each pair's deepest depth agrees to round-off at sdfphys's
    poses; the normals differ by the faces' relative tilt (pymunk takes one face's
    normal, sdfphys the other's field gradient at the deepest corner), under 1e-4 rad in
    a stack. Points and counts are each engine's own."""
    c = comparison("box_stack", 0.5)
    assert c.contact_failures() == 0
    assert sum(d.manifolds for d in c.contacts) > 100
    assert max(d.manifold_depth for d in c.contacts) < CONTACT_TOLERANCE
    assert max(d.manifold_normal for d in c.contacts) < 1e-4


SDF_SCENE = """version = 1
[[body]]
name = "terrain"
shape = { type = "sdf", field = { op = "round", r = 0.1, of = { type = "box", size = [8.0, 1.0] } } }
static = true
[[body]]
name = "blob"
shape = { type = "sdf", field = { type = "ellipse", size = [1.0, 0.6] } }
position = [0.0, 2.0]
[[body]]
name = "ball"
shape = { type = "circle", radius = 0.3 }
position = [2.0, 2.0]
"""


def test_compare_main_refuses_sdf_bodies_in_one_line(tmp_path, capsys):
    path = tmp_path / "sdf.toml"
    path.write_text(SDF_SCENE)
    assert compare_main(path) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1
    assert err.startswith(f"sdfphys: error: {path}: pymunk cannot model ")
    assert "body[0] 'terrain' (sdf)" in err and "body[1] 'blob' (dynamic sdf)" in err
    assert "'ball'" not in err


@pytest.mark.parametrize("args, expected", [
    (("missing.toml",), "no such scene file"),
    ((SCENES / "head_on.toml", 0.0), "--seconds: must be a positive number"),
    ((SCENES / "head_on.toml", None, ["sim.substeps=0"]), "sim.substeps: must be >= 1")])
def test_compare_main_bad_input(args, expected, capsys):
    assert compare_main(*args) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and expected in err


def test_compare_main_prints_the_settings_and_both_tables(capsys):
    """head_on for 1.5 s: three 0.5 s windows per table; exit 0 (contacts agree)."""
    assert compare_main(SCENES / "head_on.toml", seconds=1.5) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"pymunk {pymunk.version}: 4 x Space.step(0.00416667 s)")
    contacts = lines.index(next(line for line in lines if line.startswith("contacts at")))
    trajectories = lines.index(next(line for line in lines if line.startswith("trajectories")))
    assert [line.split()[0] for line in lines[contacts + 2:contacts + 5]] == [
        "0.00-0.48", "0.50-0.98", "1.00-1.50"]
    assert len(lines) == trajectories + 5
    assert lines[-1].split()[2] == "small"        # the light ball moves most after impact
