"""tools/penetration_spread.py: nudged runs repeat, and its Box2D figure is Box2D's."""

from __future__ import annotations

from pathlib import Path

import pytest
from tools_module import load_tool

ROOT = Path(__file__).resolve().parents[1]


spread = load_tool("penetration_spread")
HEAD_ON = ROOT / "scenes" / "head_on.toml"


def test_a_nudged_run_repeats_and_differs_from_the_scene_as_written():
    """Run 2 twice: the same final state (seeded); run 0 (as written) ends elsewhere, so
    the nudge acts; head_on's two circles meet exactly in every run (time of impact):
    their deepest contacts within 1e-5 m of each other."""
    first = spread.nudged_run(HEAD_ON, 2, 1e-6)
    again = spread.nudged_run(HEAD_ON, 2, 1e-6)
    written = spread.nudged_run(HEAD_ON, 0, 1e-6)
    assert again.state_hash == first.state_hash != written.state_hash
    assert abs(first.max_penetration - written.max_penetration) < 1e-5
    assert spread.deepest(HEAD_ON, 2, 1e-6) == first.max_penetration


def test_box2d_figure_where_box2d_can_model_the_scene():
    """head_on: two circles closing at 5 m/s (8.3 cm a step) with no time of impact
    between dynamic bodies in Box2D and a 2 cm speculative distance: they overlap by
    more than 2 cm (sdfphys: none); scenes with joints, collision filters or sdf bodies:
    None."""
    pytest.importorskip("pyb2d3")
    assert spread.box2d_deepest(HEAD_ON) > 0.02
    for name in ("pendulum", "filtered_crowd", "showcase"):
        assert spread.box2d_deepest(ROOT / "scenes" / f"{name}.toml") is None
