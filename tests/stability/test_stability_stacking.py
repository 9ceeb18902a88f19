"""Stability at the extremes, stacking: mass ratios, a tall stack, scale, distance, rest.

Each test asserts a bound of ``stability_stacking`` (its value and source are stated
there) on the figure its case measures. Failing cases are strict xfails whose reason
is the measured cause.
"""

import pytest
import stability_stacking as cases

pytestmark = pytest.mark.slow

SOFT_SINK = (
    "solver._solve's soft rows (solver.contact_softness: 30 Hz, 60 Hz against the ground) "
    "settle where each contact point carries its load as a spring of stiffness "
    "m_eff (2 pi f)^2, m_eff about 0.4 kg (a corner of the 1 kg box) whatever the load, so "
    "a heavy box sinks M g / k: stability_stacking.soft_sink(1, 100) predicts 43.6 mm at "
    "rest, measured 43.5 mm (6.2 cm while it settles); substeps do not change k. Tried: "
    "stiffening each row (or each pair) by its load, k' = max(m_eff w^2, F / 5 mm): the "
    "stiffness then follows the rocking load and pumps energy (100:1: the light box "
    "squeezed out sideways; 1000:1 still crushed)")


def test_light_box_under_a_10_times_heavier_box_is_not_crushed():
    """The heavy box never sinks more than 2 cm in 5 s."""
    assert cases.ours_mass_ratio(10)["sink"] <= cases.NOT_CRUSHED.limit


@pytest.mark.xfail(strict=True, reason=SOFT_SINK)
def test_light_box_under_a_100_times_heavier_box_is_not_crushed():
    """The heavy box never sinks more than 2 cm in 5 s."""
    assert cases.ours_mass_ratio(100)["sink"] <= cases.NOT_CRUSHED.limit


@pytest.mark.xfail(strict=True, reason=(
    SOFT_SINK + "; at 1000:1 soft_sink predicts 0.43 m"))
def test_light_box_under_a_1000_times_heavier_box_is_not_crushed():
    """The heavy box never sinks more than 2 cm in 5 s."""
    assert cases.ours_mass_ratio(1000)["sink"] <= cases.NOT_CRUSHED.limit


@pytest.mark.xfail(strict=True, reason=(
    SOFT_SINK + "; each 1 kg box under the 400 kg box carries 200 kg: soft_sink(1, 200) = "
    "8.7 cm at rest, 20 cm with the 3.1 m/s impact"))
def test_big_box_dropped_on_two_small_boxes_does_not_crush_them():
    """The big box never sinks more than 2 cm below its height on intact boxes."""
    assert cases.ours_big_box_drop()["sink"] <= cases.NOT_CRUSHED.limit


@pytest.mark.parametrize("ratio", [10, 100])
def test_resting_sink_is_the_soft_contact_spring_sag(ratio):
    """The mechanism of the mass-ratio failures: the heavy box's sink at rest (after 5 s)
    is ``soft_sink``, the sag of the soft contact springs, within 2 % (the prediction
    takes the lever arms of the undeformed stack)."""
    assert cases.ours_mass_ratio(ratio)["rest_sink"] == pytest.approx(
        cases.soft_sink(1.0, ratio), rel=0.02)


def test_pyramid_with_a_100_times_heavier_top_box_stands():
    """Base-5 pyramid of 1 kg boxes, top box 100 kg: it moves less than 5 cm in 10 s."""
    assert cases.ours_heavy_top_pyramid(100)["top"] <= cases.STANDS.limit


@pytest.mark.xfail(strict=True, reason=(
    SOFT_SINK + "; the 300 kg top box on two 1 kg boxes sinks 11.0 cm in 10 s (pymunk 25 cm)"))
def test_pyramid_with_a_300_times_heavier_top_box_stands():
    """Base-5 pyramid of 1 kg boxes, top box 300 kg: it moves less than 5 cm in 10 s."""
    assert cases.ours_heavy_top_pyramid(300)["top"] <= cases.STANDS.limit


@pytest.mark.xfail(strict=True, reason=(
    "buckling: the soft contacts make each box-on-box interface a rotational spring "
    "k = 2 (0.5 m)^2 m_eff (2 pi 30 Hz)^2 = 3.6 kN m/rad (m_eff 0.2 kg at a corner between "
    "two 1 kg boxes), and a column on such joints buckles under its own weight above "
    "Greenhill's height (7.84 k a / (m g))^(1/3) = 14 m: measured, 14 boxes stand, 16, 18 "
    "and 20 lean over exponentially (20: 0.5 m off at 10 s, fallen by 15 s); 8 substeps "
    "do not help, contact_hertz 60 does (k x 4: 20 boxes stand, swaying 3 to 6 cm; with 8 "
    "substeps too, 3.3 cm and still); 4 relax passes or damping ratio 2 do not"))
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
