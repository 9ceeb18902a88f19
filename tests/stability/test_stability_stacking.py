"""Stability at the extremes, stacking: mass ratios, a tall stack, big pyramids, scale,
distance, rest.

Each test asserts a bound of ``stability_stacking`` (its value and source are stated
there) on the figure its case measures. The mass ratios, the heavy-top pyramids and
the tall stack pass through the loaded islands of ``sdfphys.solver`` (load stiffening
and converged passes; before them the heavy boxes sank 4.4 to 100 cm and the 20-box
stack buckled).
"""

import pytest
import stability_stacking as cases

pytestmark = pytest.mark.slow


def test_light_box_under_a_10_times_heavier_box_is_not_crushed():
    """The heavy box never sinks more than 2 cm in 5 s."""
    assert cases.ours_mass_ratio(10)["sink"] <= cases.NOT_CRUSHED.limit


def test_light_box_under_a_100_times_heavier_box_is_not_crushed():
    """The heavy box never sinks more than 2 cm in 5 s."""
    assert cases.ours_mass_ratio(100)["sink"] <= cases.NOT_CRUSHED.limit


def test_light_box_under_a_1000_times_heavier_box_is_not_crushed():
    """The heavy box never sinks more than 2 cm in 5 s."""
    assert cases.ours_mass_ratio(1000)["sink"] <= cases.NOT_CRUSHED.limit


def test_big_box_dropped_on_two_small_boxes_does_not_crush_them():
    """The big box never sinks more than 2 cm below its height on intact boxes."""
    assert cases.ours_big_box_drop()["sink"] <= cases.NOT_CRUSHED.limit


@pytest.mark.parametrize("ratio", [10, 100])
def test_resting_sink_is_the_sag_of_the_load_stiffened_springs(ratio):
    """The mechanism: the light box carries ratio + 1 times its weight, so load stiffening
    (solver.row_softness) makes both interfaces' springs ratio + 1 times stiffer than the
    plain soft step's, and the heavy box's sink at rest (after 5 s) is
    ``soft_sink / (ratio + 1)`` within 2 % (the prediction takes the lever arms of the
    undeformed stack): 0.43 mm at 10:1 and 100:1, against 4.7 and 43.6 mm."""
    assert cases.ours_mass_ratio(ratio)["rest_sink"] == pytest.approx(
        cases.soft_sink(1.0, ratio) / (ratio + 1.0), rel=0.02)


def test_pyramid_with_a_100_times_heavier_top_box_stands():
    """Base-5 pyramid of 1 kg boxes, top box 100 kg: it moves less than 5 cm in 10 s."""
    assert cases.ours_heavy_top_pyramid(100)["top"] <= cases.STANDS.limit


def test_pyramid_with_a_300_times_heavier_top_box_stands():
    """Base-5 pyramid of 1 kg boxes, top box 300 kg: it moves less than 5 cm in 10 s."""
    assert cases.ours_heavy_top_pyramid(300)["top"] <= cases.STANDS.limit


def test_pyramid_of_base_20_stands():
    """210 unit boxes: the top box moves less than 5 cm in 5 s."""
    assert cases.ours_pyramid(20)["top"] <= cases.STANDS.limit


def test_pyramid_of_base_40_stands():
    """820 unit boxes: the top box moves less than 5 cm in 5 s (one island at rest, so
    it gets the converged passes up to rest_island_limit; with one pass per substep its
    40 layers sag and the top moves 6.3 cm)."""
    assert cases.ours_pyramid(40)["top"] <= cases.STANDS.limit


def test_a_big_pyramid_stays_symmetric_and_settles():
    """Base-50 pyramid of unit boxes, 3 s: the mean horizontal displacement of its boxes
    stays under one linear slop and its fastest box ends under the sleep speed (1,275
    boxes, over rest_island_limit: one pass per phase, swept in mirrored order,
    solver.substeps "Sweep order"; in body order alone it leaned 33 mm and still moved
    at 0.10 m/s; Box2D v3 0.9 mm, at rest)."""
    case = cases.ours_pyramid_symmetry()
    assert case["lean"] <= cases.SYMMETRIC.limit
    assert case["speed"] <= cases.SETTLED.limit


@pytest.mark.parametrize("base", [20, 40])
def test_big_pyramids_do_not_sink_into_themselves(base):
    """No contact of the pyramid is ever deeper than 2 cm in 5 s."""
    assert cases.ours_pyramid(base)["penetration"] <= cases.NOT_SUNK.limit


def test_twenty_box_stack_stands_thirty_seconds():
    """The top box moves less than 5 cm in 30 s."""
    assert cases.ours_tall_stack()["top"] <= cases.STANDS.limit


@pytest.mark.parametrize("side", [0.05, 20.0])
def test_small_pyramid_stands_at_any_scale(side):
    """Base 5, boxes of 5 cm and of 20 m, g = 9.81: no box moves more than 5 % of its
    side in 10 s."""
    assert cases.ours_scaled_pyramid(side)["relative"] <= cases.STANDS_RELATIVE.limit


def test_pyramid_far_from_the_origin_moves_as_at_the_origin():
    """Base-5 pyramid at (1e5, 1e5) m: box positions relative to its origin stay within 1e-3 m of
    the same pyramid's at the origin over 10 s.
    """
    assert cases.ours_far_pyramid()["difference"] <= cases.SAME_FAR_AWAY.limit


def test_resting_stacks_come_to_rest_and_stay():
    """A 5-box stack and a base-5 pyramid: after 2 s no box point moves faster than
    1 mm/s, up to 10 s."""
    assert cases.ours_resting_stacks()["speed"] <= cases.AT_REST.limit
