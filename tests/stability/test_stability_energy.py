"""Stability at the extremes, energy: extreme time steps, deep initial overlap, restitution 1.

Each test asserts a bound of ``stability_energy`` on the figure its case measures.
Failing cases are strict xfails whose reason is the measured cause.
"""

import pytest
import stability_energy as cases

pytestmark = pytest.mark.slow

PILE_EJECTION = (
    "the push-out velocities of a column of overlapping circles add up (each of 25 rows "
    "separates from the one below at up to 3 m/s) and the single relax pass "
    "(relax_passes = 1: one Gauss-Seidel sweep of solver._solve over the contacts sorted "
    "by body) removes them only in part along a 25-contact chain; the rest is kept as "
    "kinetic energy, and warm starting re-applies the bias-inflated impulses next step: "
    "top circles leave at 24 m/s, 25 kJ after 10 steps (491 kg). Without warm starting "
    "13 m/s, with 16 relax passes 9 m/s, with both 4.5 m/s. A split push-out (velocities "
    "restored after the biased solve, positions kept, as Chipmunk's bias velocities) still "
    "measured 18 m/s, the fastest circles then in the bottom rows, squeezed sideways "
    "under the 25-row load. Since the loaded islands (solver.row_softness): this 625-body "
    "island is over stiff_island_limit, its rows count up to large_island_load_cap = 2 "
    "weights and push out faster: 23 m/s separation, 41 m/s ejection (18 and 25 with the "
    "cap 1); the converged passes over the whole island (stiff_island_limit 1024) 63 m/s")


@pytest.mark.parametrize(("dt", "seconds"), [(1e-4, 0.5), (0.1, 10.0)])
def test_extreme_time_steps_do_not_explode(dt, seconds):
    """A box stack with a ball dropped on it, a tilted box and a bouncing ball dropped
    on the ground: the energy never exceeds its start by more than 1 %."""
    assert cases.ours_time_step(dt, seconds)["gain"] <= cases.ENERGY_MARGIN.limit


def test_boxes_overlapping_by_a_quarter_separate_at_most_at_the_push_out_cap():
    """No pair's overlap shrinks faster than 3 m/s."""
    assert cases.ours_overlapping_boxes()["separation"] <= cases.PUSH_OUT.limit


def test_boxes_overlapping_by_a_quarter_are_not_ejected():
    """No box ends a step faster than the 3 m/s push-out cap."""
    assert cases.ours_overlapping_boxes()["speed"] <= cases.PUSH_OUT.limit


def test_boxes_overlapping_by_a_quarter_come_to_rest():
    """Kinetic energy over the last of 5 s below 1 % of its peak."""
    assert cases.ours_overlapping_boxes()["decay"] <= cases.DECAYS.limit


@pytest.mark.xfail(strict=True, reason=PILE_EJECTION)
def test_packed_circles_separate_at_most_at_the_push_out_cap():
    """No pair's overlap shrinks faster than 3 m/s."""
    assert cases.ours_packed_circles()["separation"] <= cases.PUSH_OUT.limit


@pytest.mark.xfail(strict=True, reason=PILE_EJECTION)
def test_packed_circles_are_not_ejected():
    """No circle ends a step faster than the 3 m/s push-out cap."""
    assert cases.ours_packed_circles()["speed"] <= cases.PUSH_OUT.limit


@pytest.mark.xfail(strict=True, reason=PILE_EJECTION + "; still bouncing after 4 s")
def test_packed_circles_come_to_rest():
    """Kinetic energy over the last of 5 s below 1 % of its peak."""
    assert cases.ours_packed_circles()["decay"] <= cases.DECAYS.limit


def test_perfectly_elastic_balls_never_bounce_above_their_drop_height():
    """Ten drop heights, 10,000 steps each (pymunk at elasticity 1 rises above)."""
    assert cases.ours_elastic_balls()["above"] <= cases.NO_HIGHER.limit


def test_perfectly_elastic_balls_never_gain_energy():
    """Ten drop heights, 10,000 steps: E never above E0."""
    assert cases.ours_elastic_balls()["gain"] <= cases.NO_GAIN.limit
