"""The soft-step solver core against exact answers, with hand-made contacts.

Every test here drives ``sdfphys.solver`` directly (no collision detection): bodies
as a BodyState, contacts built by hand, so each answer is the solver's own closed
form and the tolerances are round-off.
"""

import math

import numpy as np
import pytest
from numba import njit

from sdfphys.collide.contacts import Contacts
from sdfphys.settings import Settings
from sdfphys.solver import (
    BodyState,
    ImpulseCache,
    apply_restitution,
    contact_softness,
    prepare_contacts,
    soft_coefficients,
    solve_substeps,
    store_impulses,
)
from sdfphys.world import World

G = np.array([0.0, -9.81])


def bodies(com, velocity=None, inv_mass=None, inv_inertia=None, angle=None,
           angular_velocity=None, round_body=None) -> BodyState:
    com = np.array(com, dtype=np.float64).reshape(-1, 2)
    n = len(com)
    return BodyState(
        com=com,
        angle=np.zeros(n) if angle is None else np.array(angle, dtype=np.float64),
        velocity=np.zeros((n, 2)) if velocity is None else np.array(velocity, np.float64),
        angular_velocity=(np.zeros(n) if angular_velocity is None
                          else np.array(angular_velocity, np.float64)),
        inv_mass=np.ones(n) if inv_mass is None else np.array(inv_mass, np.float64),
        inv_inertia=np.ones(n) if inv_inertia is None else np.array(inv_inertia, np.float64),
        linear_damping=np.zeros(n), angular_damping=np.zeros(n),
        round_body=np.zeros(n, bool) if round_body is None else np.array(round_body, bool))


def contact(a, b, point, normal, depth, feature=0) -> Contacts:
    return Contacts(np.array([a], np.int64), np.array([b], np.int64),
                    np.array([point], np.float64), np.array([normal], np.float64),
                    np.array([depth], np.float64), np.array([feature], np.int64))


def step(state: BodyState, contacts: Contacts, settings: Settings, gravity=G,
         friction=None, restitution=None, cache=None) -> ImpulseCache:
    """One step of the solver stages as World.step runs them (collision given)."""
    n = len(state.inv_mass)
    friction = np.zeros(n) if friction is None else np.asarray(friction, np.float64)
    restitution = np.zeros(n) if restitution is None else np.asarray(restitution, np.float64)
    c = prepare_contacts(contacts, state, friction, restitution,
                         cache if cache is not None else ImpulseCache.empty(),
                         settings.warm_starting)
    solve_substeps(state, c, np.asarray(gravity, np.float64), settings,
                   bool(np.any(c.friction > 0)))
    apply_restitution(state, c, settings)
    return store_impulses(c)


# ---------------------------------------------------------------------------------------
# Soft constraint coefficients (docs/solver.md unit values, given to 4 significant digits).
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("hertz, expected", [
    (30.0, (9.069, 0.9423, 0.0577)),
    (60.0, (17.477, 0.9713, 0.0287)),
])
def test_soft_coefficients_match_solver_md(hertz, expected):
    s = soft_coefficients(hertz, 10.0, 1.0 / 240.0)
    assert s.bias_rate == pytest.approx(expected[0], abs=5e-4)
    assert s.mass_scale == pytest.approx(expected[1], abs=5e-5)
    assert s.impulse_scale == pytest.approx(expected[2], abs=5e-5)
    assert s.mass_scale + s.impulse_scale == pytest.approx(1.0, abs=1e-15)


def test_soft_coefficients_closed_form_and_rigid_limit():
    f, z, h = 12.5, 0.7, 1.0 / 120.0
    w = 2 * math.pi * f
    s = soft_coefficients(f, z, h)
    a2 = h * w * (2 * z + h * w)
    assert s.bias_rate == pytest.approx(w / (2 * z + h * w), rel=1e-15)
    assert s.mass_scale == pytest.approx(a2 / (1 + a2), rel=1e-15)
    rigid = soft_coefficients(0.0, z, h)
    assert (rigid.bias_rate, rigid.mass_scale, rigid.impulse_scale) == (0.0, 1.0, 0.0)


def test_contact_hertz_capped_at_quarter_substep_rate_and_doubled_against_static():
    movable, fixed = contact_softness(Settings())
    assert movable == soft_coefficients(30.0, 10.0, 1 / 240)
    assert fixed == soft_coefficients(60.0, 10.0, 1 / 240)
    # One substep at 60 Hz: the rate is 60 /s, so 30 Hz is capped to 15 Hz (static 30 Hz).
    movable, fixed = contact_softness(Settings(substeps=1))
    assert movable == soft_coefficients(15.0, 10.0, 1 / 60)
    assert fixed == soft_coefficients(30.0, 10.0, 1 / 60)


# ---------------------------------------------------------------------------------------
# Integration: semi-implicit Euler, substepped.
# ---------------------------------------------------------------------------------------


def test_free_fall_matches_substepped_semi_implicit_euler_closed_form():
    """v_k = v0 + k h g, x_k = x0 + k h v0 + h^2 g k (k + 1) / 2 after k substeps.

    Body 0 dynamic, body 1 static, body 2 kinematic (moves with its velocity, no
    gravity). Tolerance: round-off (1e-12 relative to the distances covered).
    """
    settings = Settings()
    h = settings.dt / settings.substeps
    v0 = np.array([[1.5, 4.0], [0.0, 0.0], [-2.0, 0.5]])
    x0 = np.array([[0.0, 10.0], [3.0, -1.0], [5.0, 5.0]])
    state = bodies(x0, velocity=v0, inv_mass=[0.5, 0.0, 0.0], inv_inertia=[2.0, 0.0, 0.0],
                   angular_velocity=[3.0, 0.0, -1.0])
    steps = 90
    for _ in range(steps):
        step(state, Contacts.empty(), settings)
    k = steps * settings.substeps
    expected = x0 + k * h * v0
    expected[0] += h * h * G * k * (k + 1) / 2
    np.testing.assert_allclose(state.com, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(state.velocity[0], v0[0] + k * h * G, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(state.velocity[1:], v0[1:])
    np.testing.assert_allclose(state.angle, k * h * np.array([3.0, 0.0, -1.0]), atol=1e-12)


def test_damping_divides_velocity_each_substep():
    settings = Settings()
    h = settings.dt / settings.substeps
    state = bodies([[0.0, 0.0]], velocity=[[2.0, 0.0]], angular_velocity=[1.0])
    state.linear_damping[:] = 0.5
    state.angular_damping[:] = 2.0
    step(state, Contacts.empty(), settings, gravity=[0.0, 0.0])
    k = settings.substeps
    assert state.velocity[0, 0] == pytest.approx(2.0 / (1 + 0.5 * h) ** k, rel=1e-14)
    assert state.angular_velocity[0] == pytest.approx(1.0 / (1 + 2.0 * h) ** k, rel=1e-14)


def test_speed_clamped_in_position_integration():
    settings = Settings(max_linear_speed=10.0)
    state = bodies([[0.0, 0.0]], velocity=[[30.0, 40.0]])
    step(state, Contacts.empty(), settings, gravity=[0.0, 0.0])
    np.testing.assert_allclose(state.velocity[0], [6.0, 8.0], rtol=1e-14)
    np.testing.assert_allclose(state.com[0], [0.1, 0.4 / 3], rtol=1e-14)


# ---------------------------------------------------------------------------------------
# Contact rows.
# ---------------------------------------------------------------------------------------


def test_speculative_contact_closes_the_gap_exactly_without_impact():
    """A body 1 cm above a static one, approaching at 2 m/s, no gravity: the speculative
    row (bias = s / h) lets it travel exactly the gap and stop: s = 0 and v = 0 after
    the step (round-off)."""
    state = bodies([[0.0, -1.0], [0.0, 0.51]], velocity=[[0, 0], [0, -2.0]],
                   inv_mass=[0.0, 1.0], inv_inertia=[0.0, 4.0])
    c = contact(0, 1, [0.0, 0.005], [0.0, 1.0], -0.01)
    step(state, c, Settings(), gravity=[0.0, 0.0])
    assert state.com[1, 1] == pytest.approx(0.50, abs=1e-12)
    np.testing.assert_allclose(state.velocity[1], [0.0, 0.0], atol=1e-12)


def test_separation_follows_each_body_s_own_surface_point_across_a_wide_gap():
    """A body spinning clockwise by pi/6 in one step carries a corner at local (1, 0)
    from 1 m above the ground (y = 0) down to 1 - sin(pi/6) = 0.5 m. The speculative
    contact found 1 m early is re-measured from the corner itself, not from the point
    midway across the gap (which would turn with the body to report 0.567 m)."""
    settings = Settings()
    turn = -math.pi / 6.0
    state = bodies([[0.0, -1.0], [0.0, 1.0]], inv_mass=[0.0, 1.0], inv_inertia=[0.0, 1.0],
                   angular_velocity=[0.0, turn / settings.dt])
    c = prepare_contacts(contact(0, 1, [1.0, 0.5], [0.0, 1.0], -1.0), state, np.zeros(2),
                         np.zeros(2), ImpulseCache.empty(), True)
    solve_substeps(state, c, np.zeros(2), settings, False)
    assert state.angle[1] == pytest.approx(turn, abs=1e-12)
    assert c.separation[0] == pytest.approx(1.0 + math.sin(turn), abs=1e-12)
    assert c.total_normal_impulse[0] == 0.0


def test_coulomb_friction_decelerates_a_sliding_body_by_mu_g():
    """A body resting on static ground (s = 0), sliding at 3 m/s, rotation locked: each
    substep the normal impulse is m g h and friction its mu-multiple, so the speed
    drops by mu g per second exactly while it slides."""
    settings = Settings()
    state = bodies([[0.0, -1.0], [0.0, 0.5]], velocity=[[0, 0], [3.0, 0.0]],
                   inv_mass=[0.0, 0.5], inv_inertia=[0.0, 0.0])
    mu = 0.4
    cache = ImpulseCache.empty()
    steps = 30
    for _ in range(steps):
        point = [state.com[1, 0], 0.0]
        c = contact(0, 1, point, [0.0, 1.0], -(state.com[1, 1] - 0.5))
        cache = step(state, c, settings, friction=[mu, mu], cache=cache)
    expected = 3.0 - mu * 9.81 * steps * settings.dt
    assert state.velocity[1, 0] == pytest.approx(expected, abs=1e-12)
    assert abs(state.velocity[1, 1]) < 1e-12


def test_friction_holds_below_the_cone():
    """A tangential push smaller than mu times the normal load is cancelled entirely."""
    settings = Settings()
    state = bodies([[0.0, -1.0], [0.0, 0.5]], inv_mass=[0.0, 1.0], inv_inertia=[0.0, 0.0])
    gravity = [0.3 * 9.81, -9.81]   # tan(slope) = 0.3 < mu = 0.5
    cache = ImpulseCache.empty()
    for _ in range(60):
        c = contact(0, 1, [state.com[1, 0], 0.0], [0.0, 1.0], -(state.com[1, 1] - 0.5))
        cache = step(state, c, settings, gravity=gravity, friction=[0.5, 0.5], cache=cache)
    assert abs(state.com[1, 0]) < 1e-12
    assert abs(state.velocity[1, 0]) < 1e-12


@pytest.mark.parametrize("approach, e, expected", [
    (-5.0, 0.5, 2.5),     # above the threshold: vn' = -e vn
    (-5.0, 1.0, 5.0),
    (-0.5, 0.8, 0.0),     # below the 1 m/s threshold: no bounce
])
def test_restitution_against_static(approach, e, expected):
    state = bodies([[0.0, -1.0], [0.0, 0.505]], velocity=[[0, 0], [0.0, approach]],
                   inv_mass=[0.0, 1.0], inv_inertia=[0.0, 4.0])
    c = contact(0, 1, [0.0, 0.0025], [0.0, 1.0], -0.005)
    step(state, c, Settings(), gravity=[0.0, 0.0], restitution=[0.0, e])
    assert state.velocity[1, 1] == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize("e", [0.0, 0.6, 1.0])
def test_two_body_collision_closed_form(e):
    """Head-on, m1 = 1, m2 = 3, v1 = 2, v2 = -1, no gravity, touching:
    v1' = (m1 v1 + m2 v2 + m2 e (v2 - v1)) / (m1 + m2), v2' likewise (round-off)."""
    m1, m2, v1, v2 = 1.0, 3.0, 2.0, -1.0
    state = bodies([[0.0, 0.0], [1.0, 0.0]], velocity=[[v1, 0], [v2, 0]],
                   inv_mass=[1 / m1, 1 / m2], inv_inertia=[1.0, 1.0])
    c = contact(0, 1, [0.5, 0.0], [1.0, 0.0], 0.0)
    step(state, c, Settings(), gravity=[0.0, 0.0], restitution=[e, e])
    p = m1 * v1 + m2 * v2
    np.testing.assert_allclose(state.velocity[:, 0],
                               [(p + m2 * e * (v2 - v1)) / (m1 + m2),
                                (p + m1 * e * (v1 - v2)) / (m1 + m2)], rtol=0, atol=1e-12)


def test_impulses_conserve_linear_and_angular_momentum():
    """Two free bodies hit off-centre with friction while sliding, both rows soft
    (soft_depth above their overlap): every impulse pair acts at one common point, so
    momentum and angular momentum about the origin are unchanged to round-off even
    though the bodies move and spin during the step. (Deeper rows are split and move
    positions without velocity: tests/test_split_push_out.py.)"""
    state = bodies([[0.0, 0.0], [0.3, 0.9]], velocity=[[1.0, 0.5], [-2.0, -3.0]],
                   inv_mass=[1.0, 0.5], inv_inertia=[3.0, 1.0],
                   angular_velocity=[2.0, -1.0])
    mass, inertia = 1 / state.inv_mass, 1 / state.inv_inertia

    def momenta():
        p = mass @ state.velocity
        cross = state.com[:, 0] * state.velocity[:, 1] - state.com[:, 1] * state.velocity[:, 0]
        return p, float(mass @ cross + inertia @ state.angular_velocity)

    p0, l0 = momenta()
    n = np.array([0.6, 0.8])
    c = Contacts(np.array([0, 0]), np.array([1, 1]), np.array([[0.1, 0.5], [0.3, 0.4]]),
                 np.array([n, n]), np.array([0.01, 0.004]), np.array([0, 1]))
    v_before = state.velocity.copy()
    step(state, c, Settings(soft_depth=0.02), gravity=[0.0, 0.0], friction=[0.8, 0.8],
         restitution=[0.5, 0.5])
    dv = state.velocity - v_before
    assert dv[1] @ n > 1.0 and abs(dv[1] @ [-n[1], n[0]]) > 0.1   # a hit, with friction
    p1, l1 = momenta()
    np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-13)
    assert l1 == pytest.approx(l0, abs=1e-13)


@pytest.mark.parametrize("speed", [100.0, 300.0])
@pytest.mark.parametrize("offset", [0.06, 0.09])
def test_a_disc_struck_off_centre_at_speed_gains_no_energy(speed, offset):
    """A disc (r 0.05 m, density 1: inverse inertia 1.0e5 1/(kg m^2)) struck off centre
    by another at 100 or 300 m/s with the time of impact off: the pair moves 0.4 to
    1.2 m within a substep, so the re-based arms swing across the normal and the
    prepared effective masses would over-relax the rows past 2 (before the rows took
    their current arms' masses, solver/substeps.py, "Effective masses", the kinetic
    energy grew 3.6 to 15 times in three of these four cases). No restitution: the
    kinetic energy (linear and spin) never rises, and momentum is kept to round-off.
    (Angular momentum is not: the discs spin up to the substep's rotation cap, and the
    split push-out moves them without velocity.)"""
    world = World(gravity=(0.0, 0.0), settings=Settings(sleeping=False, time_of_impact=False))
    world.add_body({"type": "circle", "radius": 0.05}, position=(0.0, 0.0),
                   velocity=(speed, 0.0))
    world.add_body({"type": "circle", "radius": 0.05}, position=(0.15, offset))
    mass, inertia = 1.0 / world._view("inv_mass"), 1.0 / world._view("inv_inertia")

    def state():
        v, w = world.velocity, world.angular_velocity
        energy = float(mass @ (0.5 * (v * v).sum(axis=1)) + inertia @ (0.5 * w * w))
        return energy, mass @ v

    e0, p0 = state()
    met = False
    for _ in range(3):
        world.step()
        met |= len(world.contacts.depth) > 0
        e, p = state()
        assert e <= e0
        np.testing.assert_allclose(p, p0, rtol=0, atol=1e-12 * mass[0] * speed)
    assert met and world.velocity[1, 0] > 0.1 * speed          # they did collide

# ---------------------------------------------------------------------------------------
# Warm starting.
# ---------------------------------------------------------------------------------------


def test_impulse_cache_matches_by_body_pair_and_feature():
    big = (3 << 56) | (7 << 8) | 2
    old = ImpulseCache(np.array([0, 0, 2, 5]), np.array([1, 1, 3, 9]),
                       np.array([big, 4, 4, -1]), np.array([1.0, 2.0, 3.0, 4.0]),
                       np.array([-1.0, -2.0, -3.0, -4.0]))
    normal, tangent = old.match(np.array([2, 0, 0, 5, 0]), np.array([3, 1, 1, 9, 2]),
                                np.array([4, 4, big, 7, 4]))
    np.testing.assert_array_equal(normal, [3.0, 2.0, 1.0, 0.0, 0.0])
    np.testing.assert_array_equal(tangent, [-3.0, -2.0, -1.0, 0.0, 0.0])


def test_sorted_key_match_equals_the_general_one():
    """Lists sorted by (body_a, body_b, feature) take a merge join; the same rows in a
    shuffled order take the ranked searchsorted path: the same impulses per row."""
    rng = np.random.default_rng(5)

    def keys(n):
        k = np.unique(rng.integers(0, 6, (n, 3)), axis=0)       # sorted, distinct rows
        return k[:, 0], k[:, 0] + 1 + k[:, 1], k[:, 2] << np.int64(50)

    a, b, f = keys(120)
    old = ImpulseCache(a, b, f, rng.uniform(0, 1, len(f)), rng.uniform(-1, 1, len(f)))
    na, nb, nf = keys(120)
    sorted_n, sorted_t = old.match(na, nb, nf)
    perm = rng.permutation(len(nf))
    shuffled = ImpulseCache(a[::-1], b[::-1], f[::-1], old.normal_impulse[::-1],
                            old.tangent_impulse[::-1])
    n, t = shuffled.match(na[perm], nb[perm], nf[perm])
    assert np.count_nonzero(sorted_n) > 10
    np.testing.assert_array_equal(n, sorted_n[perm])
    np.testing.assert_array_equal(t, sorted_t[perm])


def test_impulse_cache_falls_back_to_the_nearest_unused_contact_of_the_pair():
    """Keys first; an unmatched key takes the nearest old contact of its pair within the
    tolerance that no other contact took; other pairs and farther points never match."""
    old = ImpulseCache(np.array([0, 0, 0, 1]), np.array([1, 1, 1, 2]),
                       np.array([10, 11, 12, 10]), np.array([1.0, 2.0, 3.0, 4.0]),
                       np.array([-1.0, -2.0, -3.0, -4.0]),
                       np.array([[0.0, 0.0], [1.0, 0.0], [1.003, 0.0], [0.0, 0.0]]))
    anchor = np.array([[1.0, 0.001], [1.001, 0.0], [0.004, 0.0], [2.0, 0.0], [0.0, 0.001]])
    normal, tangent = old.match(np.array([0, 0, 0, 0, 1]), np.array([1, 1, 1, 1, 2]),
                                np.array([12, 20, 21, 22, 23]), anchor, 0.005)
    # Row 0 keeps its key (old row 2), so row 1 gets the other near one (old row 1);
    # row 2 is 4 mm from old row 0; row 3 is 1 m from everything; row 4 is another pair's.
    np.testing.assert_array_equal(normal, [3.0, 2.0, 1.0, 0.0, 4.0])
    np.testing.assert_array_equal(tangent, [-3.0, -2.0, -1.0, 0.0, -4.0])
    by_key = old.match(np.array([0, 0, 0, 0, 1]), np.array([1, 1, 1, 1, 2]),
                       np.array([12, 20, 21, 22, 23]))[0]
    np.testing.assert_array_equal(by_key, [3.0, 0.0, 0.0, 0.0, 0.0])


def test_the_sorted_match_equals_a_brute_force_one_with_places():
    """The one-pass match of sorted lists (``warm_start._match_sorted``: key merge, pair
    ranges, match by place, gather) against a brute force: keys by a dict, then each
    unmatched new contact in order takes the nearest unused old contact of its pair
    within the tolerance (the last of equal distances, as the kernel's <=)."""
    rng = np.random.default_rng(11)
    for trial in range(20):
        def keys(n):
            k = np.unique(rng.integers(0, 4, (n, 3)), axis=0)
            return k[:, 0], k[:, 0] + 1 + k[:, 1], k[:, 2] - 1
        a, b, f = keys(40)
        old = ImpulseCache(a, b, f, rng.uniform(0, 1, len(f)), rng.uniform(-1, 1, len(f)),
                           rng.uniform(0, 0.01, (len(f), 2)))
        na, nb, nf = keys(40)
        anchor = rng.uniform(0, 0.01, (len(nf), 2))
        normal, tangent = old.match(na, nb, nf, anchor, 0.004)
        index = {(x, y, z): r for r, (x, y, z) in enumerate(zip(a, b, f))}
        source = [index.get(key, -1) for key in zip(na, nb, nf)]
        used = {r for r in source if r >= 0}
        for j, r in enumerate(source):
            if r >= 0:
                continue
            best, best_d2 = -1, 0.004 ** 2
            for q in range(len(f)):
                if (a[q], b[q]) == (na[j], nb[j]) and q not in used:
                    d2 = float(np.sum((old.anchor[q] - anchor[j]) ** 2))
                    if d2 <= best_d2:
                        best, best_d2 = q, d2
            if best >= 0:
                source[j] = best
                used.add(best)
        source = np.array(source)
        found = source >= 0
        assert found.any() and not found.all()
        np.testing.assert_array_equal(normal, np.where(found, old.normal_impulse[source], 0.0))
        np.testing.assert_array_equal(tangent,
                                      np.where(found, old.tangent_impulse[source], 0.0))


def test_a_box_resting_on_a_box_keeps_its_warm_start_every_step(monkeypatch):
    """The patch between two unit boxes is seen from both sides (a's corners in b, b's
    corners in a: near-coincident candidates with different keys), and which of them
    the reduction keeps flips as a heavy box rocks. With the match by place every
    touching contact after the first 10 steps starts from last step's impulse;
    matching by key alone, 4 of 436 started cold here (49 of 440 at 100:1)."""
    import sdfphys.world_stages as stages_module

    warm = []
    real = stages_module.solve_substeps

    def spy(bodies, constraints, *args):
        touching = constraints.separation < 0.0
        warm.append(constraints.normal_impulse[touching].copy())
        return real(bodies, constraints, *args)

    monkeypatch.setattr(stages_module, "solve_substeps", spy)
    world = World(gravity=(0.0, -9.81), settings=Settings(sleeping=False))
    world.add_body({"type": "box", "size": [20.0, 2.0]}, position=(0.0, -1.0), kind="static")
    world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 0.5), mass=1.0)
    world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 1.5), mass=30.0)
    for _ in range(120):
        world.step()
    settled = np.concatenate(warm[10:])
    assert len(settled) >= 4 * 100
    assert np.all(settled > 0.0)


def test_impulse_cache_renumbers_after_removal():
    old = ImpulseCache(np.array([0, 1, 2]), np.array([1, 3, 3]), np.array([5, 6, 7]),
                       np.array([1.0, 2.0, 3.0]), np.zeros(3))
    new = old.without_body(1)
    np.testing.assert_array_equal(new.body_a, [1])
    np.testing.assert_array_equal(new.body_b, [2])
    np.testing.assert_array_equal(new.feature, [7])


def test_warm_start_reapplies_last_impulses_only_when_enabled():
    """A resting body: with warm starting the stored impulse (m g h per substep) comes
    back on the next step; without it the next step starts from zero."""
    for warm, expected in [(True, 9.81 / 240), (False, 0.0)]:
        settings = Settings(warm_starting=warm)
        state = bodies([[0.0, -1.0], [0.0, 0.5]], inv_mass=[0.0, 1.0], inv_inertia=[0, 0])
        c = contact(0, 1, [0.0, 0.0], [0.0, 1.0], 0.0)
        cache = step(state, c, settings)
        assert cache.normal_impulse[0] == pytest.approx(9.81 / 240, rel=1e-9)
        prepared = prepare_contacts(c, state, np.zeros(2), np.zeros(2), cache, warm)
        assert prepared.normal_impulse[0] == pytest.approx(expected, rel=1e-9)


# ---------------------------------------------------------------------------------------
# Stacking with exact contacts (a private box-on-box collision, independent of collide).
# ---------------------------------------------------------------------------------------


def stack_contacts(com: np.ndarray, angle: np.ndarray, half: float) -> Contacts:
    """Contacts of a vertical stack: body 0 is the static ground (top face y = 0), body
    i >= 1 a square of half-extent ``half`` resting on body i - 1. Each box's two bottom
    vertices against the top face of the body below (its normal), kept while closer
    than the speculative distance; feature = vertex (0 left, 1 right)."""
    i = np.arange(1, len(com))
    c, s = np.cos(angle[i]), np.sin(angle[i])
    local = np.array([[-half, -half], [half, -half]])
    vertices = com[i, None, :] + np.stack(
        [c[:, None] * local[:, 0] - s[:, None] * local[:, 1],
         s[:, None] * local[:, 0] + c[:, None] * local[:, 1]], axis=2)
    below = angle[i - 1]
    normal = np.column_stack([-np.sin(below), np.cos(below)])
    face = np.where(i == 1, 0.0, np.einsum("ij,ij->i", com[i - 1], normal) + half)
    gap = np.einsum("ikj,ij->ik", vertices, normal) - face[:, None]
    keep = gap < Settings().speculative_distance
    rows, vertex = np.nonzero(keep)
    g = gap[rows, vertex]
    n = normal[rows]
    return Contacts(i[rows] - 1, i[rows], vertices[rows, vertex] - 0.5 * g[:, None] * n, n, -g,
                    vertex.astype(np.int64))


def run_stack(count: int, steps: int, warm_starting: bool) -> tuple[BodyState, list[float]]:
    """A stack of ``count`` unit boxes (mass 1, inertia 1/6), friction 0.6, on the ground;
    returns the final state and the mean |v| of the boxes after each step."""
    settings = Settings(warm_starting=warm_starting)
    com = np.array([[0.0, -10.0]] + [[0.0, 0.5 + k] for k in range(count)])
    state = bodies(com, inv_mass=np.r_[0.0, np.ones(count)],
                   inv_inertia=np.r_[0.0, np.full(count, 6.0)])
    friction = np.full(count + 1, 0.6)
    cache, jitter = ImpulseCache.empty(), []
    for _ in range(steps):
        cache = step(state, stack_contacts(state.com, state.angle, 0.5), settings,
                     friction=friction, cache=cache)
        jitter.append(float(np.abs(state.velocity[1:]).mean()))
    return state, jitter


def test_ten_box_stack_stands_ten_seconds_with_exact_contacts():
    """600 steps: every box within 5 cm of its start (the soft contacts compress the
    stack by about 3 cm in all), angles < 0.01 rad."""
    state, _ = run_stack(10, 600, True)
    start = np.array([[0.0, 0.5 + k] for k in range(10)])
    assert np.max(np.abs(state.com[1:] - start)) < 0.05
    assert np.max(np.abs(state.angle[1:])) < 0.01


def test_warm_starting_reduces_the_jitter_of_a_resting_stack():
    """Five boxes, mean |v| over the second and third seconds: with warm starting more
    than 100 times smaller than without."""
    _, warm = run_stack(5, 180, True)
    _, cold = run_stack(5, 180, False)
    assert np.mean(warm[60:]) < 0.01 * np.mean(cold[60:])


class ExactBoxContacts:
    """Box-box contacts from Chipmunk (pymunk's ``shapes_collide``: SAT and clipping),
    a reference collision for solver tests. Boxes are inflated by half the speculative
    distance each (rounded corners), so pairs closer than that distance report points;
    depth = -(distance + speculative distance). Feature = the direction of the point
    from each centre, in that box's frame, in sectors of half a radian (16 a + b):
    corners and edge midpoints sit mid-sector, so keys hold while boxes barely turn."""

    def __init__(self, half_extents: np.ndarray, static: np.ndarray):
        import pymunk

        self.margin = Settings().speculative_distance
        self.bodies = [pymunk.Body(body_type=pymunk.Body.KINEMATIC) for _ in half_extents]
        self.shapes = [pymunk.Poly.create_box(b, (2 * hx, 2 * hy), radius=self.margin / 2)
                       for b, (hx, hy) in zip(self.bodies, half_extents)]
        self.reach = np.hypot(half_extents[:, 0], half_extents[:, 1]) + self.margin
        self.static = static

    def __call__(self, com: np.ndarray, angle: np.ndarray) -> Contacts:
        for body, shape, x, a in zip(self.bodies, self.shapes, com, angle):
            body.position, body.angle = (float(x[0]), float(x[1])), float(a)
            shape.cache_bb()
        near = (np.linalg.norm(com[:, None] - com[None], axis=2)
                < self.reach[:, None] + self.reach[None])
        near &= ~(self.static[:, None] & self.static[None])
        rows = []
        for i, j in zip(*np.nonzero(np.triu(near, 1))):
            try:
                found = self.shapes[i].shapes_collide(self.shapes[j])
            except AssertionError:   # pymunk 7 asserts on an empty point set
                continue
            for p in found.points:
                point = 0.5 * (np.array(p.point_a) + np.array(p.point_b))
                key = 16 * self._sector(point, com[i], angle[i]) + self._sector(
                    point, com[j], angle[j])
                rows.append((i, j, point, tuple(found.normal), -(p.distance + self.margin), key))
        a, b, point, normal, depth, feature = zip(*rows)
        return Contacts(np.array(a), np.array(b), np.array(point), np.array(normal),
                        np.array(depth), np.array(feature, np.int64))

    @staticmethod
    def _sector(point: np.ndarray, centre: np.ndarray, angle: float) -> int:
        c, s = math.cos(angle), math.sin(angle)
        d = point - centre
        return round(2.0 * math.atan2(-s * d[0] + c * d[1], c * d[0] + s * d[1])) + 6


@pytest.mark.slow
def test_twenty_base_pyramid_stands_twenty_seconds_with_exact_contacts():
    """210 unit boxes (rows of 20, 19, ..., 1), friction 0.6, Chipmunk's box contacts:
    after 1200 steps the top box has moved < 5 cm (the soft contacts compress the 20
    rows by about 3 cm)."""
    com = [[0.0, -10.0]] + [[i - (19 - row) / 2, 0.5 + row]
                            for row in range(20) for i in range(20 - row)]
    com = np.array(com)
    n = len(com)
    half = np.array([[50.0, 10.0]] + [[0.5, 0.5]] * (n - 1))
    collide = ExactBoxContacts(half, np.arange(n) == 0)
    state = bodies(com.copy(), inv_mass=np.r_[0.0, np.ones(n - 1)],
                   inv_inertia=np.r_[0.0, np.full(n - 1, 6.0)])
    friction, cache, settings = np.full(n, 0.6), ImpulseCache.empty(), Settings()
    for _ in range(1200):
        cache = step(state, collide(state.com, state.angle), settings, friction=friction,
                     cache=cache)
    assert np.linalg.norm(state.com[-1] - com[-1]) < 0.05


def test_rotation_per_substep_is_capped_at_a_quarter_turn():
    """Box2D v3's cap: |w| h <= pi / 4 (a faster spin is clamped, slower ones untouched)."""
    from sdfphys.solver.substeps import MAX_ROTATION, _integrate_positions

    h = 1.0 / 240.0
    com = np.zeros((3, 2))
    angle = np.zeros(3)
    velocity = np.zeros((3, 2))
    w = np.array([10.0, 1e4, -1e4])
    _integrate_positions(com, angle, velocity, w, 400.0, h)
    np.testing.assert_array_equal(w, [10.0, MAX_ROTATION / h, -MAX_ROTATION / h])
    np.testing.assert_allclose(angle, [10.0 * h, MAX_ROTATION, -MAX_ROTATION], rtol=1e-15)


def test_the_substep_bundles_hold_their_fields_in_order_and_share_the_arrays():
    """``solver.bundles``' makers list the fields by hand (compiled, cached): they follow
    BODY_FIELDS and ROW_FIELDS, which name BodyState's and ContactConstraints' arrays
    (and the three row coefficients); a kernel's write through the reference is the
    caller's array's."""
    import dataclasses
    import inspect

    from sdfphys.solver import bundles, rows

    assert tuple(inspect.signature(bundles._substep_bodies.py_func).parameters) == \
        bundles.BODY_FIELDS
    assert tuple(inspect.signature(bundles._substep_rows.py_func).parameters) == \
        bundles.ROW_FIELDS
    body_fields = {f.name for f in dataclasses.fields(rows.BodyState)}
    row_fields = {f.name for f in dataclasses.fields(rows.ContactConstraints)}
    assert set(bundles.BODY_FIELDS) <= body_fields
    assert set(bundles.ROW_FIELDS) - row_fields == {"bias_rate", "mass_scale",
                                                      "impulse_scale"}
    n = 3
    state = rows.BodyState(np.zeros((n, 2)), np.zeros(n), np.zeros((n, 2)), np.zeros(n),
                           np.ones(n), np.ones(n), np.zeros(n), np.zeros(n),
                           np.zeros(n, bool))
    ref = bundles.substep_bodies(state)
    _bump_first_velocity(ref)
    assert state.velocity[0, 0] == 1.0


@njit
def _bump_first_velocity(bodies):
    bodies.velocity[0, 0] += 1.0
