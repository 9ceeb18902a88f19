"""Settings: every knob documented and validated, presets valid, field knobs reach the engine."""

from __future__ import annotations

import inspect
import math
from dataclasses import fields

import numpy as np
import pytest

from sdfphys.collide import collide
from sdfphys.errors import SpecError
from sdfphys.sdf.gradient import NumericGradientField
from sdfphys.sdf.grid import GridField
from sdfphys.settings import PRESETS, Settings, preset
from sdfphys.shapes import collision_shape, shape_from_spec
from sdfphys.world import World

SDF_DISC = {"type": "sdf", "field": {"type": "circle", "radius": 0.5}}
SDF_BOX = {"type": "sdf", "field": {"type": "box", "size": [1.0, 1.0]}}
GROUND = {"type": "box", "size": [20.0, 1.0]}


# ---------------------------------------------------------------------------------------
# Documentation and validation
# ---------------------------------------------------------------------------------------


def test_every_knob_has_a_doc_line_a_unit_entry_and_a_valid_default():
    for f in fields(Settings):
        meta = f.metadata
        assert {"unit", "doc", "low", "high", "choices"} <= set(meta), f.name
        assert len(meta["doc"]) > 20 and meta["doc"].endswith("."), f.name
        line = Settings.describe(f.name)
        assert line.startswith(f.name) and f"Default {f.default!r}" in line
        assert Settings.check(f.name, f.default) == f.default
    assert Settings.describe("dt").startswith("dt [s]:")
    assert Settings.describe("grid_cell").startswith("grid_cell [m]:")


def test_table_lists_every_knob_with_each_preset_value():
    rows = Settings.table().splitlines()
    assert len(rows) == 2 + len(Settings.names())
    substeps = next(r for r in rows if r.startswith("| substeps |")).split("|")
    assert [c.strip() for c in substeps[3:6]] == [
        str(preset(q).substeps) for q in ("fast", "balanced", "accurate")]


@pytest.mark.parametrize("name, value, message", [
    ("dt", 0.0, "sim.dt: must be > 0, got 0"),
    ("dt", math.inf, "sim.dt: must be finite"),
    ("dt", "fast", "sim.dt: must be a number"),
    ("substeps", 0, "sim.substeps: must be >= 1, got 0"),
    ("substeps", 2.5, "sim.substeps: must be an integer"),
    ("relax_passes", -1, "sim.relax_passes: must be >= 0"),
    ("descent_starts", 8, "sim.descent_starts: must be <= 7, got 8"),
    ("contact_hertz", 0.0, "sim.contact_hertz: must be > 0"),
    ("speculative_distance", -0.01, "sim.speculative_distance: must be >= 0"),
    ("time_of_impact", 1, "sim.time_of_impact: must be true or false"),
    ("gradient", "sobel", "sim.gradient: must be one of analytic, central, three_point"),
    ("field_representation", "mesh", "sim.field_representation: must be one of analytic, grid"),
    ("grid_cell", 0.0, "sim.grid_cell: must be >= 0.0001"),
])
def test_check_rejects_bad_values_naming_the_key_path(name, value, message):
    with pytest.raises(SpecError) as err:
        Settings.check(name, value, f"sim.{name}")
    assert str(err.value).startswith(message)


def test_check_normalizes_and_construction_validates():
    assert Settings.check("dt", 1) == 1.0 and isinstance(Settings.check("dt", 1), float)
    assert Settings.check("substeps", 8) == 8
    assert Settings.check("gradient", "central") == "central"
    with pytest.raises(KeyError):
        Settings.check("substep", 4)
    with pytest.raises(SpecError, match="^substeps: must be >= 1"):
        Settings(substeps=0)
    with pytest.raises(SpecError, match="^gradient: must be one of"):
        Settings().with_values(gradient="numeric")
    with pytest.raises(TypeError):
        Settings().with_values(substep=4)


def test_presets_are_valid_and_balanced_is_the_default():
    assert list(PRESETS) == ["fast", "balanced", "accurate"]
    assert preset("balanced") == Settings()
    for name, overrides in PRESETS.items():
        assert set(overrides) <= set(Settings.names()), name
        s = preset(name)
        for knob, value in overrides.items():
            assert getattr(s, knob) == value
    with pytest.raises(KeyError, match="unknown quality 'best'"):
        preset("best")


# ---------------------------------------------------------------------------------------
# Field knobs: gradient, field representation, field-field descent
# ---------------------------------------------------------------------------------------


def test_collision_shape_wraps_only_sdf_shapes_and_is_cached():
    circle, box = shape_from_spec({"type": "circle", "radius": 0.5}), shape_from_spec(GROUND)
    disc = shape_from_spec(SDF_DISC)
    for shape in (circle, box):
        assert collision_shape(shape, "central", "grid", 0.05) is shape
    assert collision_shape(disc) is disc
    numeric = collision_shape(disc, "central")
    assert isinstance(numeric.field, NumericGradientField) and numeric.field.method == "central"
    assert numeric is collision_shape(disc, "central")
    baked = collision_shape(disc, "analytic", "grid", 0.05)
    assert isinstance(baked.field, GridField) and baked.field.cell == 0.05
    both = collision_shape(disc, "three_point", "grid", 0.05)
    assert isinstance(both.field, NumericGradientField)
    assert isinstance(both.field.field, GridField)
    for variant in (numeric, baked, both):
        assert variant.kind == "sdf" and variant.area == disc.area
        np.testing.assert_array_equal(variant.bounds(), disc.bounds())
        assert variant.radius == disc.radius and variant.second_moment == disc.second_moment
        np.testing.assert_array_equal(variant.origin, disc.origin)


def test_unbounded_sdf_shape_stays_analytic_under_grid():
    plane = shape_from_spec({"type": "sdf", "field": {"type": "half_plane", "normal": [0, 1]}})
    assert collision_shape(plane, "analytic", "grid", 0.05) is plane


def _disc_contact(**knobs) -> tuple[float, np.ndarray]:
    """Depth and normal of the deepest contact of an sdf disc (r 0.5) 1 cm deep in the
    ground (the other candidates are speculative ones at the triangles' edges)."""
    world = World(gravity=(0.0, 0.0), settings=Settings(**knobs))
    world.add_body(GROUND, position=(0.0, -0.5), kind="static")
    world.add_body(SDF_DISC, position=(0.1234, 0.49))
    world.step()
    c = world.contacts
    deepest = int(np.argmax(c.depth))
    return float(c.depth[deepest]), c.normal[deepest]


def test_field_knobs_reach_the_world_contacts():
    """The ground's triangles are queried in the disc's field: a baked field moves the
    depth by at most its bound (h^2 / (4 rho) on a circle of radius rho: the bake
    interpolates the disc's distance, curvature 1/r near the rim), and differs; a
    numeric gradient gives the same depth (values are the field's)."""
    depth, normal = _disc_contact()
    assert depth == pytest.approx(0.01, abs=1e-9)
    np.testing.assert_allclose(normal, [0.0, 1.0], atol=1e-9)
    for cell in (0.1, 0.05):
        baked, _ = _disc_contact(field_representation="grid", grid_cell=cell)
        assert baked != depth and abs(baked - depth) <= cell * cell / (4.0 * 0.45)
    numeric, numeric_normal = _disc_contact(gradient="central")
    assert numeric == pytest.approx(depth, abs=1e-9)
    np.testing.assert_allclose(numeric_normal, normal, atol=1e-6)


def test_field_descent_knobs_reach_sdf_pairs(monkeypatch):
    from sdfphys.collide import field_pairs

    seen = []
    real = field_pairs.placed_contacts

    def spy(*args, **kwargs):
        given = inspect.signature(real).bind(*args, **kwargs).arguments
        seen.append((given["n_starts"], given["iterations"]))
        return real(*args, **kwargs)

    monkeypatch.setattr(field_pairs, "placed_contacts", spy)
    settings = Settings(field_descent_starts=3, field_descent_iterations=5,
                        descent_starts=7, descent_iterations=16)
    collide(SDF_BOX, (0.0, 0.0, 0.0), SDF_BOX, (0.0, 0.99, 0.0), margin=0.02,
            settings=settings)
    assert seen == [(3, 5)]
