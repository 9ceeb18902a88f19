"""Loaded islands (``solver.row_softness``): load stiffening and converged passes.

The coefficients are checked against ``soft_coefficients`` of the scaled stiffness and
damping (w sqrt(r), z sqrt(r)) on hand-made rows whose impulses carry known weights;
the island rules (size limit, mass ratio, static bodies not joining islands) on small
graphs; the behaviour on a heavy box resting on a light one, against the sag the
stiffened springs predict; and "elsewhere bit for bit" on a scene with no loaded island.
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest

import sdfphys.world_stages as stages_module
from sdfphys.settings import Settings
from sdfphys.solver import MASS_RATIO, contact_softness, row_softness, soft_coefficients
from sdfphys.solver.softness import IMPACT_HOPS
from sdfphys.world import World

G = np.array([0.0, -9.81])
SETTINGS = Settings(sleeping=False)          # long horizons: the solver at work
H = SETTINGS.dt / SETTINGS.substeps
HERTZ = min(SETTINGS.contact_hertz, 0.25 / H)
ZETA = SETTINGS.contact_damping_ratio


def rows(pairs, inv_mass, weights, normals=None, separation=None, approach=None,
         features=None):
    """Hand-made constraints: one row per (a, b) pair, normal a -> b straight up unless
    given, normal impulse = ``weights`` kg carried (per substep: w |g| h), separation 0
    (touching), relative normal velocity 0 (at rest) and feature key 0 (a circle's
    contact) unless given."""
    a = np.array([p[0] for p in pairs], np.int64)
    b = np.array([p[1] for p in pairs], np.int64)
    inv_mass = np.asarray(inv_mass, np.float64)
    normal = np.tile([0.0, 1.0], (len(pairs), 1)) if normals is None else np.array(normals)
    return inv_mass, SimpleNamespace(
        body_a=a, body_b=b, feature=(np.zeros(len(pairs), np.int64) if features is None
                                     else np.asarray(features, np.int64)),
        pair_start=np.arange(len(pairs) + 1, dtype=np.int64), normal=normal,
        normal_impulse=np.asarray(weights, np.float64) * 9.81 * H,
        separation=np.zeros(len(pairs)) if separation is None else np.asarray(separation),
        relative_velocity=np.zeros(len(pairs)) if approach is None else np.asarray(approach),
        stiff=((inv_mass[a] == 0.0) | (inv_mass[b] == 0.0)).astype(np.int64))


def expected(r, static):
    """soft_coefficients of a row whose spring and damper carry r times its mass."""
    s = soft_coefficients((2.0 if static else 1.0) * HERTZ * math.sqrt(r), ZETA * math.sqrt(r), H)
    return s.bias_rate, s.mass_scale, s.impulse_scale


def test_a_stack_stiffens_each_row_by_the_weights_its_bodies_carry():
    """Ground (static) under boxes of 1, 2 and 3 kg: the rows carry 6, 5 and 3 kg, so the
    boxes carry 6, 2.5 and 1 times their weight (the 1 kg box is pushed down by 5 kg, the
    2 kg one by 3 kg); each row takes its bodies' larger ratio."""
    inv_mass, c = rows([(0, 1), (1, 2), (2, 3)], [0.0, 1.0, 0.5, 1.0 / 3.0], [6.0, 5.0, 3.0])
    bias_rate, mass_scale, impulse_scale, loaded, _ = row_softness(inv_mass, c, G, SETTINGS)
    for k, (r, static) in enumerate([(6.0, True), (6.0, False), (2.5, False)]):
        np.testing.assert_allclose([bias_rate[k], mass_scale[k], impulse_scale[k]],
                                   expected(r, static), rtol=1e-12)
    np.testing.assert_array_equal(loaded, [0, 1, 2])


def test_unloaded_rows_keep_contact_softness_bit_for_bit():
    """Boxes side by side on the ground, each carrying its own weight: no loaded island."""
    inv_mass, c = rows([(0, 1), (0, 2), (1, 2)], [0.0, 1.0, 1.0], [1.0, 1.0, 0.0],
                       normals=[[0.0, 1.0], [0.0, 1.0], [1.0, 0.0]])
    bias_rate, mass_scale, impulse_scale, loaded, _ = row_softness(inv_mass, c, G, SETTINGS)
    soft, stiff = contact_softness(SETTINGS)
    assert list(bias_rate) == [stiff.bias_rate, stiff.bias_rate, soft.bias_rate]
    assert list(mass_scale) == [stiff.mass_scale, stiff.mass_scale, soft.mass_scale]
    assert list(impulse_scale) == [stiff.impulse_scale, stiff.impulse_scale, soft.impulse_scale]
    assert len(loaded) == 0


def test_islands_larger_than_the_limit_get_no_extra_pass_and_capped_stiffening():
    """A 3-box stack (the bottom box carries 3 weights): within the limit its pairs are
    loaded; above it none is, and its rows count at most large_island_load_cap weights."""
    inv_mass, c = rows([(0, 1), (1, 2), (2, 3)], [0.0, 1.0, 1.0, 1.0], [3.0, 2.0, 1.0])

    def ground_row(**knobs):
        bias_rate, mass_scale, impulse_scale, loaded, _ = row_softness(
            inv_mass, c, G, SETTINGS.with_values(**knobs))
        return [bias_rate[0], mass_scale[0], impulse_scale[0]], len(loaded)

    small, n_small = ground_row(stiff_island_limit=3, rest_island_limit=0)
    large, n_large = ground_row(stiff_island_limit=2, rest_island_limit=0)
    above_cap, _ = ground_row(stiff_island_limit=2, rest_island_limit=0,
                              large_island_load_cap=4.0)
    plain, _ = ground_row(stiff_island_limit=2, rest_island_limit=0, large_island_load_cap=1.0)
    assert n_small == 3 and n_large == 0
    np.testing.assert_allclose(small, expected(3.0, True), rtol=1e-12)
    np.testing.assert_allclose(large, expected(2.0, True), rtol=1e-12)     # default cap 2
    np.testing.assert_allclose(above_cap, expected(3.0, True), rtol=1e-12)  # 3 < cap 4
    stiff = contact_softness(SETTINGS)[1]
    assert plain == [stiff.bias_rate, stiff.mass_scale, stiff.impulse_scale]


def test_islands_at_rest_are_treated_up_to_the_rest_limit():
    """The 3-box stack over stiff_island_limit (2): at rest (no row deeper than
    soft_depth) it is loaded while rest_island_limit >= 3; with one row 1 cm deep (it is
    pushing out overlap, solver "Split push-out") it is not, and its rows are capped."""
    def ground_row(separation, **knobs):
        inv_mass, c = rows([(0, 1), (1, 2), (2, 3)], [0.0, 1.0, 1.0, 1.0], [3.0, 2.0, 1.0],
                           separation=separation)
        bias_rate, mass_scale, impulse_scale, loaded, _ = row_softness(
            inv_mass, c, G, SETTINGS.with_values(stiff_island_limit=2, **knobs))
        return [bias_rate[0], mass_scale[0], impulse_scale[0]], len(loaded)

    rest, n_rest = ground_row([0.0, -0.004, 0.0])                  # 4 mm: still soft
    too_large, n_too_large = ground_row([0.0, -0.004, 0.0], rest_island_limit=2)
    deep, n_deep = ground_row([0.0, -0.01, 0.0])
    assert SETTINGS.rest_island_limit >= 3 and SETTINGS.soft_depth == 0.005
    assert (n_rest, n_too_large, n_deep) == (3, 0, 0)
    np.testing.assert_allclose(rest, expected(3.0, True), rtol=1e-12)
    np.testing.assert_allclose(too_large, expected(2.0, True), rtol=1e-12)
    np.testing.assert_allclose(deep, expected(2.0, True), rtol=1e-12)


def test_static_bodies_do_not_join_islands():
    """Two 3-box stacks on one ground: two islands of 3 (limit 3 treats both), not one of 6."""
    inv_mass, c = rows([(0, 1), (0, 4), (1, 2), (2, 3), (4, 5), (5, 6)],
                       [0.0] + [1.0] * 6, [3.0, 3.0, 2.0, 1.0, 2.0, 1.0])
    loaded = row_softness(inv_mass, c, G, SETTINGS.with_values(stiff_island_limit=3))[3]
    np.testing.assert_array_equal(loaded, np.arange(6))


def test_a_mass_ratio_loads_its_island_even_without_gravity():
    """No gravity, no load: the coefficients stay contact_softness's, but an island with
    touching masses MASS_RATIO apart gets the extra passes; one below it does not."""
    for ratio, is_loaded in [(MASS_RATIO, True), (0.99 * MASS_RATIO, False)]:
        inv_mass, c = rows([(0, 1), (1, 2)], [1.0, 1.0, 1.0 / ratio], [0.0, 0.0],
                           normals=[[1.0, 0.0], [1.0, 0.0]])
        bias_rate, _, _, loaded, _ = row_softness(inv_mass, c, np.zeros(2), SETTINGS)
        assert list(bias_rate) == [contact_softness(SETTINGS)[0].bias_rate] * 2
        assert len(loaded) == (2 if is_loaded else 0)


def test_load_stiffening_off_keeps_the_plain_coefficients():
    inv_mass, c = rows([(0, 1), (1, 2), (2, 3)], [0.0, 1.0, 0.5, 1.0 / 3.0], [6.0, 5.0, 3.0])
    off = SETTINGS.with_values(load_stiffening=False)
    bias_rate, _, _, loaded, _ = row_softness(inv_mass, c, G, off)
    soft, stiff = contact_softness(off)
    assert list(bias_rate) == [stiff.bias_rate, soft.bias_rate, soft.bias_rate]
    assert len(loaded) == 0         # masses 1, 2, 3: no neighbours MASS_RATIO apart


def column(n_bodies: int, impact_at: int, deep_at: int | None = None, deep: float = 0.06,
           source: int = 0, **knobs):
    """row_softness of a vertical column of n unit bodies on the ground (rows (0, 1),
    (1, 2), ...), all at rest but row ``impact_at``, which closes at 1 m/s from 1 mm
    apart: 1.7 cm in a step, past soft_depth beyond its gap, and row ``deep_at``,
    ``deep`` m deep if given; rows keyed with feature ``source`` (narrowphase's key
    layout: 0 a circle's contact, 5 a clipped manifold, 1 a mesh's point in a field).
    Returns (loaded pairs, their caps)."""
    pairs = [(i, i + 1) for i in range(n_bodies)]
    approach = np.zeros(n_bodies)
    approach[impact_at] = -1.0
    separation = np.zeros(n_bodies)
    separation[impact_at] = 0.001
    if deep_at is not None:
        separation[deep_at] = -deep
    inv_mass, c = rows(pairs, [0.0] + [1.0] * n_bodies, [1.0] * n_bodies,
                       separation=separation, approach=approach,
                       features=np.full(n_bodies, source << 56))
    settings = SETTINGS.with_values(load_stiffening=False, **knobs)
    return row_softness(inv_mass, c, G, settings)[3:]


def test_an_impact_gives_the_contacts_within_impact_hops_its_extra_passes():
    """Row 10 of a 30-circle column (one island, over stiff_island_limit 8) approaches
    past soft_depth: the pairs touching a body within IMPACT_HOPS contacts of its two
    bodies get impact_iterations - 1 extra passes, the rest none; the ground row
    (static-dynamic) counts as a contact of its dynamic body."""
    loaded, caps = column(30, 10, stiff_island_limit=8)
    near = np.arange(10 - IMPACT_HOPS - 1, 10 + IMPACT_HOPS + 2)
    np.testing.assert_array_equal(loaded, near)
    assert set(caps) == {SETTINGS.impact_iterations - 1}
    loaded, caps = column(3, 2, stiff_island_limit=8, impact_iterations=7)
    np.testing.assert_array_equal(loaded, [0, 1, 2])
    np.testing.assert_array_equal(caps, [6, 6, 6])


def test_no_impact_passes_at_rest_alone_or_above_the_rest_limit():
    """A column at rest (even 1 cm deep: overlap to push out is no approach), one body
    alone landing on the ground, an impact in an island over rest_island_limit, a jammed
    island (a row 6 cm deep, more than a step's capped push-out clears: soft_depth +
    max_push_out dt = 5.5 cm), and a column of concave polygons (rows from a descent:
    not exact; such an impact gives only rows on static bodies passes, and the struck
    bodies have none): no extra pass; impact_iterations 1 turns them off."""
    loaded, _ = column(30, 10, stiff_island_limit=8, rest_island_limit=29)
    assert len(loaded) == 0
    loaded, _ = column(30, 10, deep_at=25, stiff_island_limit=8)
    assert len(loaded) == 0
    loaded, _ = column(30, 10, source=1, stiff_island_limit=8)
    assert len(loaded) == 0
    loaded, _ = column(30, 10, stiff_island_limit=8, impact_iterations=1)
    assert len(loaded) == 0
    loaded, _ = column(1, 0)
    assert len(loaded) == 0
    inv_mass, c = rows([(i, i + 1) for i in range(30)], [0.0] + [1.0] * 30, [1.0] * 30,
                       separation=np.full(30, -0.01))
    assert len(row_softness(inv_mass, c, G, SETTINGS.with_values(
        load_stiffening=False, stiff_island_limit=8))[3]) == 0


def test_a_row_just_past_soft_depth_is_no_jam():
    """A row 1 cm deep (past soft_depth, which an impact leaves) or 5 cm (within one
    step's capped push-out, 5.5 cm) elsewhere in the column does not turn the impact's
    passes off (it did: in scenes/circles_in_box.toml one such row anywhere left every
    circle with one pass, deepest contact over five nearby runs 5.0-11.4 mm; 5.0-5.4 mm
    now)."""
    plain = column(30, 10, stiff_island_limit=8)
    for deep in (0.01, 0.05):
        loaded, caps = column(30, 10, deep_at=25, deep=deep, stiff_island_limit=8)
        np.testing.assert_array_equal(loaded, plain[0])
        np.testing.assert_array_equal(caps, plain[1])


def test_exact_pairs_of_boxes_take_the_impact_passes_as_circles_do():
    """A column of boxes whose rows are clipped manifolds (source 5) gets the circles'
    passes (rows of source 0), pair for pair; rows of a mesh's point in a field
    (source 1, a descent's) do not, and a pair is exact only if all its rows are."""
    circles = column(30, 10, stiff_island_limit=8)
    for source in (5,):
        boxes = column(30, 10, source=source, stiff_island_limit=8)
        np.testing.assert_array_equal(boxes[0], circles[0])
        np.testing.assert_array_equal(boxes[1], circles[1])
    assert len(column(30, 10, source=1, stiff_island_limit=8)[0]) == 0
    # Box 2 falls on box 1 (on the ground): a pair of a clipped row and a circle's
    # predicted row is exact; a clipped row with a descent's, or a predicted row of an
    # sdf pair (FIELD_PAIR), is not: only the ground row (the impact's body's).
    predicted, field_pair = 6 << 56, (6 << 56) | (1 << 55)
    for second, exact in ((predicted, True), (1 << 56, False), (field_pair, False)):
        inv_mass, c = rows([(0, 1), (1, 2), (1, 2)], [0.0, 1.0, 1.0], [1.0, 1.0, 1.0],
                           separation=[0.0, 0.001, 0.001], approach=[0.0, -1.0, -1.0],
                           features=[5 << 56, 5 << 56, second])
        c.pair_start = np.array([0, 1, 3], np.int64)
        loaded = row_softness(inv_mass, c, G, SETTINGS.with_values(load_stiffening=False))[3]
        np.testing.assert_array_equal(loaded, [0, 1] if exact else [0])


def test_boxes_struck_through_a_concave_pair_get_their_rows_on_static_bodies():
    """Box 3 strikes box 2 through rows of a descent (source 1: not exact), box 2 rests
    on box 1 on the ground (0), box 4 on box 1 too. The struck pair's rows on static
    bodies get the impact passes (none: box 1, not box 2, is on the ground), its own
    row and the others do not (converging such rows turned landings into spins). Box 2
    on the ground instead: its ground row gets them."""
    settings = SETTINGS.with_values(load_stiffening=False)
    for pairs, expected in (([(0, 1), (1, 2), (1, 4), (2, 3)], []),
                            ([(0, 1), (0, 2), (1, 4), (2, 3)], [1])):
        inv_mass, c = rows(pairs, [0.0, 1.0, 1.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0],
                           separation=[0.0, 0.0, 0.0, 0.001], approach=[0.0, 0.0, 0.0, -1.0],
                           features=[1 << 56] * 4)
        loaded, caps = row_softness(inv_mass, c, G, settings)[3:]
        np.testing.assert_array_equal(loaded, expected)
        assert set(caps) <= {SETTINGS.impact_iterations - 1}


def test_a_body_a_struck_circle_rests_on_gets_its_ground_rows_too():
    """Circle 3 strikes circle 2, which rests on concave polygon 1 on the ground (0);
    polygon 4 also rests on polygon 1. The circles' rows and the circle's single
    contact with polygon 1 get the impact passes, and so does polygon 1's row on the
    ground, a descent's (the blow goes through it: scenes/grid_terrain.toml, a
    triangle's tip driven 1.06 cm into the terrain by a circle landing on it at
    10 m/s); the polygons' row, a descent's, does not (converging such rows turned
    landings into spins)."""
    descent = 1 << 56
    inv_mass, c = rows([(0, 1), (1, 2), (1, 4), (2, 3)], [0.0, 1.0, 1.0, 1.0, 1.0],
                       [1.0, 1.0, 1.0, 1.0], separation=[0.0, 0.0, 0.0, 0.001],
                       approach=[0.0, 0.0, 0.0, -1.0], features=[descent, 0, descent, 0])
    loaded, caps = row_softness(inv_mass, c, G,
                                SETTINGS.with_values(load_stiffening=False))[3:]
    np.testing.assert_array_equal(loaded, [0, 1, 3])
    assert set(caps) == {SETTINGS.impact_iterations - 1}


def test_a_loaded_pair_near_an_impact_keeps_the_larger_cap():
    """A 3-circle column within stiff_island_limit whose bottom circle is 4 times
    lighter (loaded island, stiff_iterations - 1 extra passes) hit at row 1: its caps
    stay stiff_iterations - 1."""
    inv_mass, c = rows([(0, 1), (1, 2), (2, 3)], [0.0, 4.0, 1.0, 1.0], [1.0, 1.0, 1.0],
                       separation=[0.0, 0.001, 0.0], approach=[0.0, -1.0, 0.0])
    loaded, caps = row_softness(inv_mass, c, G, SETTINGS)[3:]
    np.testing.assert_array_equal(loaded, [0, 1, 2])
    assert set(caps) == {SETTINGS.stiff_iterations - 1}


def poured_rows(settings: Settings) -> tuple[float, World]:
    """Deepest contact (m) over 2.5 s of 96 circles (r 0.25, 12 columns of 8 rows, 0.6 m
    apart) falling together from 3 to 7.2 m onto the ground between two walls: each
    column's lowest circle stops on the ground, or on the pile, while the ones above
    still fall (one island of up to 96 bodies, over stiff_island_limit)."""
    world = World(gravity=tuple(G), settings=settings)
    world.add_body({"type": "box", "size": [20.0, 2.0]}, position=(0.0, -1.0), kind="static")
    for x in (-3.9, 3.9):
        world.add_body({"type": "box", "size": [0.5, 12.0]}, position=(x, 6.0),
                       kind="static")
    for row in range(8):
        for col in range(12):
            world.add_body({"type": "circle", "radius": 0.25},
                           position=(-3.3 + 0.6 * col + 0.05 * (row % 2), 3.0 + 0.6 * row),
                           friction=0.5)
    deepest = 0.0
    for _ in range(round(2.5 / settings.dt)):
        world.step()
        if len(world.contacts):
            deepest = max(deepest, float(np.max(world.contacts.depth)))
    return deepest, world


def test_rows_of_circles_landing_at_once_stay_under_a_centimetre():
    """The impact passes stop a column within its step: deepest contact under 1 cm
    (3.3 mm when written); with impact_iterations 1 (one pass per substep) over it
    (13.9 mm)."""
    deepest, world = poured_rows(SETTINGS)
    plain, _ = poured_rows(SETTINGS.with_values(impact_iterations=1))
    assert deepest < 0.01 < plain
    assert world.stage_counts["converge"] > 0


def struck_box_column(settings: Settings) -> float:
    """Deepest contact (m) over 40 steps: box C (1.2 x 0.4 m) resting on the ground,
    box B 1 cm over it falling at 8 m/s, box A 3 mm over B falling with it: B stops on
    C within a step while A, with no speed against B, must stop with it."""
    world = World(gravity=tuple(G), settings=settings)
    world.add_body({"type": "box", "size": [20.0, 1.0]}, position=(0.0, -0.5), kind="static")
    box = {"type": "box", "size": [1.2, 0.4]}
    world.add_body(box, position=(0.0, 0.2))
    world.add_body(box, position=(0.0, 0.61), velocity=(0.0, -8.0))
    world.add_body(box, position=(0.0, 1.013), velocity=(0.0, -8.0))
    deepest = 0.0
    for _ in range(40):
        world.step()
        if len(world.contacts):
            deepest = max(deepest, float(np.max(world.contacts.depth)))
    return deepest


def test_a_column_of_boxes_struck_at_once_stays_under_a_centimetre():
    """Clipped box manifolds are exact pairs: the impact passes stop the column as they
    stop circles (4.9 mm when written; one pass per substep, as concave polygons still
    get: 23.5 mm)."""
    deepest = struck_box_column(SETTINGS)
    plain = struck_box_column(SETTINGS.with_values(impact_iterations=1))
    assert deepest < 0.01 < plain


def heavy_on_light(ratio: float, settings: Settings, seconds: float = 2.0) -> tuple[float, World]:
    """The heavy box's sink (m) after ``seconds`` s: a unit box of ``ratio`` kg on a
    1 kg unit box on the ground, both starting at rest, touching."""
    world = World(gravity=tuple(G), settings=settings)
    world.add_body({"type": "box", "size": [20.0, 2.0]}, position=(0.0, -1.0), kind="static")
    world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 0.5), mass=1.0,
                   friction=0.6)
    heavy = world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 1.5),
                           mass=float(ratio), friction=0.6)
    for _ in range(round(seconds / settings.dt)):
        world.step()
    return 1.5 - float(world.position[heavy, 1]), world


def soft_sag(ratio: float) -> float:
    """The plain soft step's resting sag of the heavy box (tests/stability's soft_sink):
    two corners per interface, a unit box corner's effective mass 1 / (2.5 / m), the
    ground's springs at twice the hertz."""
    w = 2.0 * math.pi * HERTZ
    upper = 2.0 / (2.5 / 1.0 + 2.5 / ratio) * w * w
    lower = 2.0 / 2.5 * (2.0 * w) ** 2
    return ratio * 9.81 / upper + (ratio + 1.0) * 9.81 / lower


def test_a_heavy_box_on_a_light_one_sags_as_under_its_own_weight():
    """100:1: the light box carries 101 times its weight, so both interfaces' springs are
    101 times stiffer and the sag is the plain soft sag / 101 (0.43 mm instead of 43.6),
    within 2 % (the prediction takes the undeformed stack's lever arms)."""
    sink, world = heavy_on_light(100.0, SETTINGS)
    assert sink == pytest.approx(soft_sag(100.0) / 101.0, rel=0.02)
    assert world.stage_counts["converge"] > 0


def test_the_plain_soft_step_sags_under_the_load():
    """The same stack with load_stiffening off, one pass per substep and every contact
    soft (soft_depth above the sag: the plain soft step): the springs keep m w^2 and the
    heavy box sinks the plain soft sag (30 Hz: 43.6 mm), within 2 %."""
    plain = SETTINGS.with_values(load_stiffening=False, stiff_iterations=1, soft_depth=1.0)
    sink, _ = heavy_on_light(100.0, plain, seconds=5.0)
    assert sink == pytest.approx(soft_sag(100.0), rel=0.02)


def test_a_scene_without_loaded_islands_runs_bit_for_bit_as_the_plain_soft_step():
    """Balls bouncing apart on the ground and boxes side by side: nothing carries more
    than its weight, no masses MASS_RATIO apart touch, so turning the feature off changes
    no bit of the trajectory and no extra pass runs."""
    def run(settings):
        world = World(gravity=tuple(G), settings=settings)
        world.add_body({"type": "box", "size": [40.0, 2.0]}, position=(0.0, -1.0), kind="static")
        for i in range(6):
            world.add_body({"type": "circle", "radius": 0.4}, position=(-20.0 + 3.0 * i, 2.0 + i),
                           restitution=0.5, friction=0.4)
            world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(2.0 + 1.5 * i, 0.6),
                           mass=1.0 + 0.5 * i, friction=0.6)
        for _ in range(180):
            world.step()
        return world

    on = run(SETTINGS)
    off = run(SETTINGS.with_values(load_stiffening=False, stiff_iterations=1))
    np.testing.assert_array_equal(on.position, off.position)
    np.testing.assert_array_equal(on.angle, off.angle)
    assert on.stage_counts["converge"] == 0


def test_stiff_iterations_one_runs_no_extra_pass(monkeypatch):
    calls = []
    real = stages_module.solve_substeps

    def spy(*args):
        calls.append(real(*args))
        return calls[-1]

    monkeypatch.setattr(stages_module, "solve_substeps", spy)
    _, world = heavy_on_light(100.0, SETTINGS.with_values(stiff_iterations=1), seconds=0.5)
    assert world.stage_counts["converge"] == 0 and {call[0] for call in calls} == {0}


def test_the_softness_bundles_hold_their_fields_in_order_and_share_the_arrays():
    """The params' maker lists SOFTNESS_PARAMS by hand (compiled, cached); SoftnessRows
    holds fields of bundles.SubstepRows (the substep solve passes that bundle to the same
    kernel); a step's params are kept for the same settings and gravity, made anew for
    others; the rows' coefficients are filled in the caller's arrays."""
    import inspect

    from sdfphys.solver import bundles, softness

    assert tuple(inspect.signature(softness._row_softness_params.py_func).parameters) == \
        softness.SOFTNESS_PARAMS
    assert set(softness.SoftnessRows._fields) <= set(bundles.ROW_FIELDS)
    params = softness.row_softness_params(SETTINGS, G)
    assert softness.row_softness_params(SETTINGS, G.copy()) is params
    assert softness.row_softness_params(SETTINGS, 2.0 * G) is not params
    assert softness.row_softness_params(SETTINGS.with_values(stiff_island_limit=3), G) \
        is not params
    inv_mass, c = rows([(0, 1), (1, 2)], [0.0, 1.0, 1.0], [2.0, 1.0])
    k = len(c.feature)
    coefficients = np.full(k, np.nan), np.full(k, np.nan), np.full(k, np.nan)
    ref = bundles._substep_rows(*(
        coefficients[("bias_rate", "mass_scale", "impulse_scale").index(name)]
        if name in ("bias_rate", "mass_scale", "impulse_scale")
        else getattr(c, name, np.zeros((k, 2)) if name.startswith("anchor") else np.zeros(k))
        for name in bundles.ROW_FIELDS))
    loaded, _, _, _ = softness.loaded_rows(inv_mass, ref,
                                           softness.row_softness_params(SETTINGS, G))
    expected_rows = row_softness(inv_mass, c, G, SETTINGS)
    for mine, theirs in zip(coefficients, expected_rows[:3]):
        np.testing.assert_array_equal(mine, theirs)
    np.testing.assert_array_equal(loaded, expected_rows[3])
