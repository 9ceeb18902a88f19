"""Time of impact (conservative advancement on the fields) against exact answers."""

import math

import numpy as np
import pytest

from sdfphys import toi
from sdfphys.settings import Settings
from sdfphys.shapes import shape_from_spec
from sdfphys.toi import fast_bodies, time_of_impact, vertex_time_of_impact
from sdfphys.world import World

SLOP = 0.005


def trace(shapes, start, end, angle=None, fast=(1,)):
    """time_of_impact over bodies using ``shapes`` (one per body, body frame = field frame)."""
    shapes = [shape_from_spec(s) for s in shapes]
    start, end = np.array(start, float), np.array(end, float)
    radius = np.array([s.radius for s in shapes])
    core = np.array([max(-float(s.field.distance(np.zeros((1, 2)))[0]), 0.02) for s in shapes])
    return time_of_impact([s.field for s in shapes], np.arange(len(shapes)), start, end,
                          np.zeros(len(shapes)) if angle is None else np.array(angle, float),
                          radius, core, np.array(fast), SLOP)


WALL = {"type": "box", "size": [0.1, 4.0]}          # faces at x = -0.05 and 0.05
BALL = {"type": "circle", "radius": 0.1}


def test_head_on_circle_stops_one_slop_before_a_flat_wall():
    """Flat face, straight path: one advancement lands exactly at gap = slop, so
    t = (d0 - r - slop) / L (round-off)."""
    start, end = [[0.0, 0.0], [-3.0, 0.3]], [[0.0, 0.0], [0.4, 0.3]]
    t = trace([WALL, BALL], start, end)
    assert t[0] == pytest.approx((3.0 - 0.05 - 0.1 - SLOP) / 3.4, abs=1e-14)


def test_curved_obstacle_stop_is_conservative_and_close():
    """Against a disc of radius 1 (oblique path), the stop is never past the first
    contact and within [slop, 2 slop] of it: compare with the exact line-circle time."""
    start, end = [[0.0, 0.0], [-4.0, 0.7]], [[0.0, 0.0], [4.0, 0.7]]
    t = trace([{"type": "circle", "radius": 1.0}, BALL], start, end)[0]
    # |(-4 + 8 t, 0.7)| = 1.1 + gap: exact contact (gap 0) at t*.
    t_star = (4.0 - math.sqrt(1.1 ** 2 - 0.7 ** 2)) / 8.0
    gap = math.hypot(-4.0 + 8.0 * t, 0.7) - 1.1
    assert t < t_star
    assert SLOP - 1e-12 <= gap <= 2 * SLOP


def test_path_that_misses_gives_one():
    t = trace([WALL, BALL], [[0.0, 0.0], [-3.0, 2.5]], [[0.0, 0.0], [3.0, 2.5]])
    assert t[0] == 1.0


def test_ball_touching_the_ground_slides_on_unstopped():
    """A fast ball resting on the ground (bounding disc already touching) is traced
    with its core disc, which stays clear along the ground: no impact."""
    ground = {"type": "box", "size": [100.0, 1.0]}     # top face y = 0.5
    t = trace([ground, BALL], [[0.0, 0.0], [0.0, 0.6]], [[0.0, 0.0], [5.0, 0.6]])
    assert t[0] == 1.0


def test_box_stops_on_bounding_disc_then_core_disc_face_first():
    """A 0.2 x 0.2 box (bounding radius 0.1414, core 0.1) flying face-first at a wall:
    the first trace stops its bounding disc a slop short; from there the bounding disc
    touches, so the second trace uses the core disc and stops the face a slop short."""
    box = {"type": "box", "size": [0.2, 0.2]}
    r = math.sqrt(2) * 0.1
    t1 = trace([WALL, box], [[0, 0], [-3.0, 0.0]], [[0, 0], [0.4, 0.0]])[0]
    x1 = -3.0 + 3.4 * t1
    assert x1 == pytest.approx(-0.05 - r - SLOP, abs=1e-12)
    t2 = trace([WALL, box], [[0, 0], [x1, 0.0]], [[0, 0], [x1 + 3.4, 0.0]])[0]
    assert x1 + 3.4 * t2 == pytest.approx(-0.05 - 0.1 - SLOP, abs=1e-12)


def test_fast_means_moving_more_than_half_the_core_radius():
    start = np.zeros((3, 2))
    end = np.array([[0.0501, 0.0], [0.0499, 0.0], [1.0, 0.0]])
    core = np.array([0.1, 0.1, 0.1])
    movable = np.array([True, True, False])
    np.testing.assert_array_equal(fast_bodies(start, end, core, movable), [0])


def test_fast_also_means_turning_the_outline_more_than_half_the_core_radius():
    """A body spinning in place is fast when a point at its bounding radius moves more
    than half the core radius (0.05 m here: a turn of 0.0501 rad at radius 1)."""
    start = np.zeros((2, 2))
    core, radius = np.array([0.1, 0.1]), np.array([1.0, 1.0])
    movable = np.array([True, True])
    turn = np.array([0.0501, -0.0499])
    assert len(fast_bodies(start, start, core, movable)) == 0
    np.testing.assert_array_equal(fast_bodies(start, start, core, movable, turn, radius), [0])


PLANK = {"type": "box", "size": [2.0, 0.02]}
GROUND = {"type": "sdf", "field": {"type": "half_plane", "normal": [0.0, 1.0]}}


def spin(turn: float, centre=(0.0, 0.5), start: float = 0.0):
    """vertex_time_of_impact of PLANK turning from angle ``start`` by ``turn`` about a
    fixed centre above the ground y = 0; returns the fraction and the lowest vertex
    height at that fraction."""
    shapes = [shape_from_spec(GROUND), shape_from_spec(PLANK)]
    pos = np.array([[0.0, 0.0], centre])
    t = vertex_time_of_impact([s.field for s in shapes], [None, shapes[1].vertices],
                              np.arange(2), pos, pos, np.array([0.0, start]),
                              np.array([0.0, start + turn]),
                              np.array([np.inf, shapes[1].radius]), np.array([1]), SLOP)
    a = start + turn * t[0]
    v = shapes[1].vertices
    lowest = centre[1] + np.min(np.sin(a) * v[:, 0] + np.cos(a) * v[:, 1])
    return t[0], lowest


def test_a_spinning_plank_stops_where_its_corner_reaches_the_ground():
    """Turning by -pi/3 about a centre 0.5 m up, the corner (1, -0.01) reaches y = 0 at
    sin(a) - 0.01 cos(a) = -0.5; the trace stops it inside the [slop, 2 slop] band, before
    that angle (the translation trace, about the centre, sees nothing)."""
    turn = -math.pi / 3.0
    t, lowest = spin(turn)
    exact = (-math.asin(0.5 / math.hypot(1.0, 0.01)) - math.atan2(0.01, 1.0)) / turn
    assert SLOP <= lowest <= 2.0 * SLOP
    assert 0.0 < t < exact
    assert spin(-0.4)[0] == 1.0                    # a smaller turn clears the ground


def test_a_vertex_already_on_the_ground_is_left_to_the_solver():
    """A plank tilted by 0.3 rad resting on its corner (-1, -0.01) (at y = 0) turns flat:
    the resting vertex is not traced (it would stop the turn at t = 0), the others come
    down to 0.29 m and stay clear."""
    centre = (0.0, math.sin(0.3) + 0.01 * math.cos(0.3))
    t, lowest = spin(-0.3, centre=centre, start=0.3)
    assert t == 1.0
    assert lowest == pytest.approx(centre[1] - 0.01, abs=1e-12)


def bullets(time_of_impact: bool, lanes: int = 200) -> float:
    """Circles r = 0.1 at 200 m/s at a static wall 0.1 m thick, one lane per start phase
    (the start offset sweeps one step's travel, 200/60 m, in ``lanes`` steps); returns
    the largest x reached by any ball's right edge over the run (the wall's near face
    is x = -0.05)."""
    world = World(gravity=(0.0, 0.0), settings=Settings(time_of_impact=time_of_impact))
    world.add_body({"type": "box", "size": [0.1, lanes + 2.0]}, kind="static")
    travel = 200.0 / 60.0
    for k in range(lanes):
        x = -0.05 - 0.1 - 2.0 - travel * k / lanes
        world.add_body(BALL, position=(x, k - lanes / 2 + 0.5), velocity=(200.0, 0.0))
    reach = -math.inf
    for _ in range(6):
        world.step()
        reach = max(reach, float(np.max(world.position[1:, 0])) + 0.1)
    return reach


def test_bullets_never_pass_a_thin_wall_over_200_phases():
    """With time of impact every ball stops at the face (to 1e-9 m); without it, the
    same balls tunnel through (which shows the sweep exercises the failure)."""
    assert bullets(True) <= -0.05 + 1e-9
    assert bullets(False) > 10.0


def test_distances_are_the_numpy_fields_bit_for_bit_and_fall_back():
    """_distance runs the compiled programs: the numpy fields' values exactly (kinds
    that round alike), and the numpy path for fields that do not compile."""
    from sdfphys.sdf import field
    from sdfphys.sdf.gradient import NumericGradientField
    from sdfphys.toi import _distance

    specs = [{"type": "box", "size": [1.0, 0.5]}, {"type": "circle", "radius": 0.3},
             {"type": "capsule", "a": [-0.5, 0.0], "b": [0.5, 0.2], "radius": 0.1},
             {"type": "ring", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3},
             {"op": "smooth_union", "k": 0.8, "of": [
                 {"type": "box", "size": [26.0, 1.0], "offset": [0.0, -0.5]},
                 {"type": "ellipse", "size": [5.0, 1.6], "offset": [5.0, 0.0]}]}]
    fields = [field(s) for s in specs]
    fields.append(NumericGradientField(field({"type": "heart", "scale": 1.0})))
    rng = np.random.default_rng(4)
    n_bodies = 9
    shape_id = np.arange(n_bodies) % len(fields)
    com = rng.uniform(-2.0, 2.0, (n_bodies, 2))
    angle = rng.uniform(-3.0, 3.0, n_bodies)
    target = rng.integers(0, n_bodies, 4000)
    points = rng.uniform(-4.0, 4.0, (4000, 2))
    d = _distance(fields, shape_id, com, angle, target, points)
    rel = points - com[target]
    c, s = np.cos(angle[target]), np.sin(angle[target])
    local = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]])
    for k in range(n_bodies):
        rows = target == k
        np.testing.assert_array_equal(d[rows], fields[shape_id[k]].distance(local[rows]))


def brute_force_pairs(fast, start, end, radius):
    """Every (fast slot, non-fast body) whose boxes overlap, by comparing all of them."""
    found = []
    others = [j for j in range(len(radius)) if j not in set(fast.tolist())]
    for slot, i in enumerate(fast):
        lo = np.minimum(start[i], end[i]) - radius[i]
        hi = np.maximum(start[i], end[i]) + radius[i]
        for j in others:
            with np.errstate(invalid="ignore"):
                olo, ohi = end[j] - radius[j], end[j] + radius[j]
            if np.all(lo <= ohi) and np.all(olo <= hi):
                found.append((slot, j))
    return found


@pytest.mark.parametrize("n", [50, 3000])
def test_candidate_pairs_are_the_brute_force_ones_from_the_broadphase(n, monkeypatch):
    """The time-of-impact candidates come from the broadphase (grid beyond SWEEP_BODIES
    bodies), in (fast slot, body) order, and equal the all-pairs comparison."""
    rng = np.random.default_rng(n)
    side = np.sqrt(n) * 2.0
    end = rng.uniform(-side, side, (n, 2))
    start = end - rng.normal(scale=3.0, size=(n, 2))
    radius = rng.uniform(0.1, 1.0, n)
    radius[0] = np.inf                                  # an unbounded ground
    fast = np.sort(rng.choice(np.arange(1, n), n // 10, replace=False))
    calls = []
    original = toi.candidate_pairs
    monkeypatch.setattr(toi, "candidate_pairs",
                        lambda *args: calls.append(1) or original(*args))
    slot, other = toi._candidate_pairs(fast, start, end, radius)
    assert calls == [1]
    expected = brute_force_pairs(fast, start, end, radius) if n <= 50 else None
    if expected is not None:
        assert list(zip(slot.tolist(), other.tolist())) == expected
    else:
        # Spot-check a sample of fast bodies against the brute force.
        pick = fast[:25]
        sub = brute_force_pairs(pick, start, end, radius)
        keep = slot < 25
        got = list(zip(slot[keep].tolist(), other[keep].tolist()))
        assert got == [(s, j) for s, j in sub if j not in set(fast.tolist())]
    assert np.all(np.diff(slot * n + other) > 0)


def test_a_jointed_body_is_not_traced_against_an_obstacle_that_moved():
    """The trace uses the obstacle's end pose, and a jointed body stops its whole group: a
    bridge plank rising into a crate falling onto it stopped the bridge under the crate.
    A fast ball and a wall that moved 2 slop this step: the ball alone is stopped as
    before; the ball joined to a third body (its group has two members) is not; against
    a wall that stayed put, both are stopped."""
    shapes = [shape_from_spec(s) for s in (WALL, BALL, BALL)]
    fields = [s.field for s in shapes]
    radius = np.array([s.radius for s in shapes])
    core = np.array([0.05, 0.1, 0.1])
    end = np.array([[0.0, 0.0], [0.4, 0.3], [9.0, 9.0]])
    angle = np.zeros(3)
    alone, joined = np.array([0, 1, 2]), np.array([0, 1, 1])
    for wall_start, group, stopped in (([2.0 * SLOP, 0.0], alone, True),
                                       ([2.0 * SLOP, 0.0], joined, False),
                                       ([0.0, 0.0], joined, True)):
        start = np.array([wall_start, [-3.0, 0.3], [9.0, 9.0]])
        t = toi.step_fractions(fields, [None] * 3, np.arange(3), start, end, angle, angle,
                               radius, core, np.array([1]), SLOP, group)
        assert (t[0] < 1.0) == stopped


def test_a_circle_with_a_row_against_the_obstacle_is_left_to_the_rows():
    """A fast ball that ends its step beside the wall is stopped short of it, unless it
    had a contact row with the wall this step (the row bounds its approach; rewinding
    it would push it back into what followed it); a box with such a row is still
    traced (its bounding disc is not its outline, its vertices turn)."""
    box = {"type": "box", "size": [0.2, 0.2]}
    shapes = [shape_from_spec(s) for s in (WALL, BALL, box)]
    fields = [s.field for s in shapes]
    radius = np.array([s.radius for s in shapes])
    core = np.array([0.05, 0.1, 0.1])
    start = np.array([[0.0, 0.0], [-3.0, 0.3], [-3.0, -1.0]])
    end = np.array([[0.0, 0.0], [-0.15, 0.3], [-0.15, -1.0]])
    angle = np.zeros(3)
    for rows, stopped in ((None, [True, True]), (np.array([[0, 1]]), [False, True]),
                          (np.array([[2, 0], [0, 1]]), [False, True]),
                          (np.array([[0, 2]]), [True, True])):
        t = toi.step_fractions(fields, [None, None, shapes[2].vertices], np.arange(3), start,
                               end, angle, angle, radius, core, np.array([1, 2]), SLOP,
                               contact_pairs=rows)
        assert list(t < 1.0) == stopped



def test_a_fast_body_is_stopped_against_obstacles_only():
    """``obstacles``: the bodies a fast body may be stopped against (the world passes its
    static and kinematic ones, as Box2D v3 traces its non-bullet bodies). The same fast
    ball and wall as above: stopped short of the wall when the wall is an obstacle,
    not when it is not (a dynamic wall's pair is left to its contact rows), unless the
    ball is a bullet (``bullets``: it moved beyond its rows' reach)."""
    shapes = [shape_from_spec(s) for s in (WALL, BALL)]
    fields = [s.field for s in shapes]
    radius = np.array([s.radius for s in shapes])
    core = np.array([0.05, 0.1])
    start = np.array([[0.0, 0.0], [-3.0, 0.3]])
    end = np.array([[0.0, 0.0], [0.4, 0.3]])
    angle = np.zeros(2)
    for obstacles, bullet, stopped in ((None, False, True),
                                       (np.array([True, False]), False, True),
                                       (np.array([False, True]), False, False),
                                       (np.array([False, True]), True, True)):
        t = toi.step_fractions(fields, [None] * 2, np.arange(2), start, end, angle, angle,
                               radius, core, np.array([1]), SLOP, obstacles=obstacles,
                               bullets=np.array([bullet]))
        assert (t[0] < 1.0) == stopped


def test_a_fast_column_stops_together_on_the_ground():
    """Two 0.4 m boxes falling at 60 m/s, 2 mm apart, the lower one 0.3 m above the
    ground: the time of impact traces the lower one against the ground and puts it
    back short of it (its bounding disc one to two slop from the ground, 88 mm above
    it). The upper one touches it (a row within the speculative distance) and stops
    with it at the same fraction of its step (``world_stages._stop_groups``): the pair
    stays apart. Stopped alone, the lower box was put back under the upper one, which
    ended 81 mm inside it."""
    world = World()
    world.add_body({"type": "box", "size": [10.0, 1.0]}, position=(0.0, -0.5), kind="static")
    h = 0.4
    for y in (0.3 + h / 2, 0.3 + h + 0.002 + h / 2):
        world.add_body({"type": "box", "size": [h, h]}, position=(0.0, y),
                       velocity=(0.0, -60.0))
    world.step()
    assert world.stage_counts["time_of_impact"] == 1
    com = world.position
    assert com[1][1] - h / 2 > SLOP                        # stopped short of the ground
    assert com[2][1] - com[1][1] - h >= 0.0               # and the upper box on it

def scattered_traces(seed: int, n_bodies: int = 60):
    """A crowd of shapes of every kind (boxes, polygons concave and convex, circles,
    exact, CSG and smooth sdf fields, an unbounded ground), half of them fast, moving
    and turning: step_fractions' arguments (programs left out)."""
    specs = [GROUND, {"type": "box", "size": [0.6, 0.3]}, BALL, PLANK,
             {"type": "polygon", "points": [[-0.4, -0.4], [0.4, -0.4], [0.4, -0.1],
                                            [-0.1, -0.1], [-0.1, 0.4], [-0.4, 0.4]]},
             {"type": "sdf", "field": {"type": "star", "radius": 0.5, "points": 5, "m": 3.0}},
             {"type": "sdf", "field": {"op": "smooth_union", "k": 0.4, "of": [
                 {"type": "box", "size": [3.0, 0.4]},
                 {"type": "ellipse", "size": [0.8, 0.5], "offset": [1.0, 0.2]}]}},
             {"type": "sdf", "field": {"type": "moon", "radius": 0.4, "bite_radius": 0.35,
                                       "distance": 0.25}}]
    shapes = [shape_from_spec(s) for s in specs]
    rng = np.random.default_rng(seed)
    shape_id = np.r_[0, rng.integers(1, len(shapes), n_bodies - 1)]
    start = np.r_[[[0.0, -0.5]], rng.uniform(-4.0, 4.0, (n_bodies - 1, 2))]
    end = start + np.r_[[[0.0, 0.0]], rng.normal(scale=1.0, size=(n_bodies - 1, 2))]
    start_angle = rng.uniform(-3.0, 3.0, n_bodies)
    end_angle = start_angle + rng.normal(scale=1.0, size=n_bodies)
    end_angle[0] = start_angle[0] = 0.0
    radius = np.array([shapes[s].radius for s in shape_id])
    core = np.maximum(np.array([max(-float(shapes[s].field.distance(np.zeros((1, 2)))[0]),
                                    0.0) for s in shape_id]), 0.02)
    fast = np.flatnonzero(rng.random(n_bodies) < 0.5)
    fast = fast[fast > 0]
    args = ([s.field for s in shapes], [getattr(s, "vertices", None) for s in shapes],
            shape_id, start, end, start_angle, end_angle, radius, core, fast, SLOP)
    return shapes, args


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_traces_stop_where_the_numpy_rounds_do(seed, monkeypatch):
    """With the shapes' programs (``collide.shape_fields``, as the world's stage passes
    them) the disc and vertex traces run in one compiled call each
    (``_toi_kernels.trace``) and stop at the numpy rounds' times, bit for bit; with a
    field that does not compile among the targets, the numpy rounds run."""
    from sdfphys.collide import shape_fields
    from sdfphys.sdf.gradient import NumericGradientField

    shapes, args = scattered_traces(seed)
    fields, canonical = shape_fields(shapes)
    programs = (fields.table, fields.program[canonical])
    calls, rounds = [], []
    original, distance = toi.trace, toi._distance
    monkeypatch.setattr(toi, "trace", lambda *a: calls.append(a[9]) or original(*a))
    monkeypatch.setattr(toi, "_distance", lambda *a: rounds.append(1) or distance(*a))
    expected = toi.step_fractions(*args)
    assert calls == [] and len(rounds) > 2
    rounds.clear()
    got = toi.step_fractions(*args, programs=programs)
    assert sorted(calls) == [False, True]                    # disc and vertex traces
    assert rounds == []                                      # no numpy round
    np.testing.assert_array_equal(got, expected)
    assert np.any(expected < 1.0) and np.any(expected == 1.0)
    # A target's field that does not compile (the ground's, every trace's target): the
    # numpy rounds, the same fractions.
    calls.clear()
    user = list(args[0])
    user[0] = NumericGradientField(user[0])
    no_program = (fields.table, np.where(np.arange(len(shapes)) == 0, -1,
                                         fields.program[canonical]))
    with_user = toi.step_fractions(user, *args[1:], programs=no_program)
    assert calls == []
    np.testing.assert_array_equal(with_user, toi.step_fractions(user, *args[1:]))
