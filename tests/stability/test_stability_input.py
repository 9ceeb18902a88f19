"""Stability at the extremes, input: degenerate values are SpecErrors, valid scenes stay finite.

Every sdfphys run of the study goes through ``stability_common.advance``, which checks
after each step that the state is finite; here that checker is itself tested, and every
scene in ``scenes/`` is run through it.
"""

from pathlib import Path

import numpy as np
import pytest
import stability_input as cases
from stability_common import NonFiniteState, advance, ground_world

import sdfphys

pytestmark = pytest.mark.slow

SCENES = sorted((Path(__file__).resolve().parents[2] / "scenes").glob("*.toml"))


@pytest.mark.parametrize("name", cases.DEGENERATE)
def test_degenerate_input_is_a_spec_error_naming_its_key(name):
    """load_scene rejects the bad value with a SpecError whose key path is the value's."""
    assert cases.rejected_naming_key(name), cases.load_outcome(name)


def test_advance_stops_at_the_first_non_finite_state():
    """The checker every run relies on: a NaN velocity set after step 1 is reported at step 2.
    (``set_state`` refuses NaN, so the test writes it into the World's storage.)"""
    world = ground_world()
    ball = world.add_body({"type": "circle", "radius": 0.5}, position=(0.0, 2.0))
    steps = advance(world, 10)
    assert next(steps) == 1
    with pytest.raises(sdfphys.SpecError, match="velocity"):
        world.set_state(ball, velocity=(np.nan, 0.0))
    world._data["velocity"][ball] = (np.nan, 0.0)
    with pytest.raises(NonFiniteState, match="body 1"):
        next(steps)


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_every_scene_stays_finite_for_two_seconds(path):
    """Every scene of scenes/ (valid input) keeps a finite state over 2 s."""
    world = sdfphys.load_scene(path)
    for _ in advance(world, round(2.0 / world.settings.dt)):
        pass
