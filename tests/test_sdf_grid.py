"""Baked grids: the stated error bounds and convergence orders against analytic fields,
narrow band, uint8 quantization, extrapolation outside the grid, bounds and specs."""

import math

import numpy as np
import numpy_fields
import pytest
from fieldcheck import check_field, sample_points

import sdfphys
from sdfphys.sdf import OPERATORS, PRIMITIVES, Field, field
from sdfphys.sdf.grid import GridField, bilinear_error_bound
from sdfphys.sdf.operators import level_bounds

CENTRE = np.array([0.013, -0.021])        # off the node lattice, so no symmetry helps


def circle():
    return field({"type": "circle", "radius": 1.0, "offset": CENTRE.tolist()})


def rounded_box():
    return field({"op": "round", "r": 0.3, "of": {"type": "box", "size": [1.2, 0.6]},
                  "angle": 0.4, "offset": [0.05, 0.02]})


def tilted_box():
    return field({"type": "box", "size": [1.3, 0.7], "angle": 0.3})


def in_grid(g, p):
    hi = g.origin + g.cell * (np.array(g.shape) - 1)
    return np.all((p >= g.origin) & (p <= hi), axis=1)


def grid_points(g, rng, n=200000):
    hi = g.origin + g.cell * (np.array(g.shape) - 1)
    return g.origin + (hi - g.origin) * rng.random((n, 2))


def order(coarse, fine):
    return math.log2(coarse / fine)


# --------------------------------------------------------------------------------------
# Interpolation error against the analytic field.
# --------------------------------------------------------------------------------------

def test_circle_value_error_respects_h2_over_4rho_and_is_second_order(rng):
    # Exact SDF of a circle: the Hessian's eigenvalue is 1/|p - c|; keep points whose
    # whole cell (within sqrt(2) h) is at least rho0 from the centre.
    rho0, src, errors, grad_errors = 0.25, circle(), [], []
    for h in (0.04, 0.02):
        g = GridField(src, h)
        p = grid_points(g, rng)
        p = p[np.linalg.norm(p - CENTRE, axis=1) >= rho0 + math.sqrt(2) * h]
        d, grad = g.evaluate(p)
        d0, grad0 = src.evaluate(p)
        errors.append(np.max(np.abs(d - d0)))
        grad_errors.append(np.max(np.linalg.norm(grad - grad0, axis=1)))
        assert errors[-1] <= bilinear_error_bound(h, rho0) == h * h / (4 * rho0)
        assert grad_errors[-1] <= 2 * h / rho0
    # Measured: 6.5e-4 and 1.8e-4 (bounds 1.6e-3, 4e-4): order 1.87; gradient 0.064,
    # 0.035 (bounds 0.32, 0.16): order 0.9.
    assert 1.7 <= order(*errors) <= 2.3
    assert 0.7 <= order(*grad_errors) <= 1.3


def test_rounded_box_outside_is_second_order(rng):
    # Outside a box rounded by r = 0.3 the level sets are straight or arcs of radius
    # >= 0.3 around the corner centres: rho >= 0.3 wherever the whole cell is outside.
    src, errors = rounded_box(), []
    for h in (0.04, 0.02):
        g = GridField(src, h)
        p = grid_points(g, rng)
        d0 = src.distance(p)
        p, d0 = p[d0 >= math.sqrt(2) * h], d0[d0 >= math.sqrt(2) * h]
        errors.append(np.max(np.abs(g.distance(p) - d0)))
        assert errors[-1] <= bilinear_error_bound(h, 0.3)
    assert 1.7 <= order(*errors) <= 2.3


def test_kinks_are_first_order_and_within_h_over_sqrt2(rng):
    # The medial axis of a box (inside) is a set of kinks: O(h) there, and never more
    # than h / sqrt(2) anywhere. Measured: 0.0198, 0.0095 (bounds 0.028, 0.014).
    src, errors = tilted_box(), []
    for h in (0.04, 0.02):
        g = GridField(src, h)
        p = grid_points(g, rng)
        errors.append(np.max(np.abs(g.distance(p) - src.distance(p))))
        assert errors[-1] <= bilinear_error_bound(h) == h / math.sqrt(2)
    assert 0.7 <= order(*errors) <= 1.3


def test_linear_regions_are_reproduced_exactly(rng):
    # Bilinear interpolation reproduces linear functions: where f = x - 1 (x >= |y|,
    # |y| <= 1) on whole cells, around the box's right edge, the error is rounding only.
    src = field({"type": "box", "size": [2.0, 2.0]})
    g = GridField(src, 0.05)
    p = np.column_stack([rng.uniform(0.6, 1.05, 2000), rng.uniform(-0.4, 0.4, 2000)])
    np.testing.assert_allclose(g.distance(p), src.distance(p), rtol=0, atol=1e-12)


# --------------------------------------------------------------------------------------
# Consistency, bounds, outside.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs", [{}, {"band": 0.15}, {"quantize": "uint8"},
                                    {"band": 0.2, "quantize": "uint8", "margin": 0.0}])
def test_gradient_is_the_derivative_of_the_interpolant(kwargs, rng):
    g = GridField(rounded_box(), 0.05, **kwargs)
    assert not g.exact
    check_field(g, rng)


@pytest.mark.parametrize("level", [0.0, 0.1])
@pytest.mark.parametrize("kwargs", [{}, {"band": 0.3, "quantize": "uint8"}, {"margin": 0.0}])
def test_bounds_contain_the_region(kwargs, level, rng):
    g = GridField(rounded_box(), 0.05, **kwargs)
    x0, y0, x1, y1 = box = level_bounds(g, level)
    p = sample_points(g, 40000, rng, pad=1.0)
    region = p[g.distance(p) <= level]
    assert len(region) > 1000
    assert np.all(region >= [x0, y0]) and np.all(region <= [x1, y1])
    # Not loose: inside the source's box grown by a cell (and, where the rim of a
    # margin-free grid is below the level, by the level).
    outer = level_bounds(rounded_box(), level + g.quantization_error) + np.array(
        [-1, -1, 1, 1]) * (0.05 + level + 1e-12)
    assert np.all(box[:2] >= outer[:2]) and np.all(box[2:] <= outer[2:])


def test_band_level_bounds_are_the_plane_at_the_band():
    g = GridField(circle(), 0.05, band=0.2)
    assert np.all(np.isinf(g.level_bounds(0.2)))


def test_outside_the_grid_is_continuous_and_a_lower_bound(rng):
    # For a convex exact source the nodes on the rim are at least m from the shape, so
    # rho >= m there: f_grid <= f + h^2 / (4 m) beyond the grid (measured 1.2e-4).
    for src in (circle(), tilted_box()):
        h = 0.04
        g = GridField(src, h)
        p = rng.uniform(-6, 6, (40000, 2))
        out = ~in_grid(g, p)
        assert out.sum() > 30000
        excess = g.distance(p[out]) - src.distance(p[out])
        assert np.max(excess) <= h * h / (4 * g.margin)
        assert np.all(g.distance(p[out]) > 0)
    # Continuity across the rim: just inside and just outside agree to O(eps).
    g = GridField(circle(), 0.04)
    hi = g.origin + g.cell * (np.array(g.shape) - 1)
    y = rng.uniform(g.origin[1], hi[1], 500)
    inner = np.column_stack([np.full(500, hi[0] - 1e-9), y])
    outer = np.column_stack([np.full(500, hi[0] + 1e-9), y])
    np.testing.assert_allclose(g.distance(inner), g.distance(outer), rtol=0, atol=1e-8)
    # Far away it grows like the distance.
    far = np.array([[1e3, 0.0], [0.0, -1e6]])
    np.testing.assert_allclose(g.distance(far), src.distance(far), rtol=1e-3)


def test_margins_per_side_are_exact_off_flat_sides_and_compile_alike(rng):
    """A box's grid cut unevenly (its material 0.1, 0.2, 0.3, 0.4 m inside the four
    sides): with those margins the field beyond each side is the box's exact distance
    straight off its faces, a lower bound everywhere, and the compiled program
    (``sdf.compiled``) gives the numpy values; one margin, the least, underestimates."""
    from sdfphys.sdf import compiled

    box = field({"type": "box", "size": [1.0, 0.6]})
    h = 0.05
    lo = np.array([-0.6, -0.5])                     # material 0.1 and 0.2 inside
    shape = (int(round((0.5 + 0.3 - lo[0]) / h)) + 1, int(round((0.3 + 0.4 - lo[1]) / h)) + 1)
    nodes = lo + h * np.stack(np.meshgrid(np.arange(shape[0]), np.arange(shape[1]),
                                          indexing="ij"), axis=-1)
    values = box.distance(nodes.reshape(-1, 2)).reshape(shape)
    sides = [0.1, 0.2, 0.3, 0.4]
    g = GridField.from_values(values, lo, h, sides)
    off = np.array([[-0.5 - 0.1 - d, 0.05] for d in (0.05, 0.5)]
                   + [[0.1, -0.3 - 0.2 - d] for d in (0.05, 0.5)]
                   + [[0.5 + 0.3 + d, -0.1] for d in (0.05, 0.5)]
                   + [[-0.2, 0.3 + 0.4 + d] for d in (0.05, 0.5)])
    np.testing.assert_allclose(g.distance(off), box.distance(off), rtol=0, atol=1e-12)
    least = GridField.from_values(values, lo, h, 0.1)
    assert np.all(least.distance(off[2:]) < box.distance(off[2:]) - 1e-3)
    p = rng.uniform(-3, 3, (5000, 2))
    value, grad = numpy_fields.evaluate(g, p)
    out = ~in_grid(g, p)
    assert np.all(value[out] <= box.distance(p[out]) + h * h / (4 * 0.1))
    compiled_value, compiled_grad = compiled.evaluate(g, p)
    np.testing.assert_allclose(compiled_value, value, rtol=0, atol=1e-12)
    np.testing.assert_allclose(compiled_grad, grad, rtol=0, atol=1e-9)


# --------------------------------------------------------------------------------------
# Narrow band and quantization.
# --------------------------------------------------------------------------------------

def test_band_clamps_values_and_zeroes_gradients_where_flat(rng):
    band, h = 0.15, 0.04
    plain, banded = GridField(circle(), h), GridField(circle(), h, band=band)
    assert np.max(np.abs(banded.values)) == band
    p = sample_points(banded, 50000, rng, pad=0.5)
    d, grad = banded.evaluate(p)
    assert np.all(np.abs(d) <= band)
    flat = np.abs(d) >= band - 1e-12          # four clamped nodes (up to rounding)
    assert flat.sum() > 1000
    np.testing.assert_array_equal(grad[flat], 0.0)
    # Where the four nodes are inside the band, the banded grid is the plain one.
    near = np.abs(circle().distance(p)) < band - 2 * h
    np.testing.assert_array_equal(d[near], plain.distance(p[near]))
    # Partly clamped cells still point outward.
    partly = ~flat & (np.abs(d) > band - 2 * h)
    outward = np.sum(grad[partly] * (p[partly] - CENTRE), axis=1)
    assert partly.sum() > 100 and np.all(outward > 0)


@pytest.mark.parametrize("band", [0.25, None])
def test_uint8_error_is_at_most_scale_over_255(band, rng):
    h = 0.02
    exact_nodes = GridField(circle(), h, band=band)
    packed = GridField(circle(), h, band=band, quantize="uint8")
    scale = band if band is not None else np.max(np.abs(exact_nodes.values))
    assert packed.quantization_error == scale / 255 and exact_nodes.quantization_error == 0
    node_error = np.abs(packed.values - exact_nodes.values)
    assert np.max(node_error) <= scale / 255 + 1e-15
    assert np.max(node_error) > 0.95 * scale / 255              # the bound is attained
    p = grid_points(packed, rng)
    assert np.max(np.abs(packed.distance(p) - exact_nodes.distance(p))) <= scale / 255 + 1e-15
    # Against the analytic field in smooth cells: interpolation + quantization bounds.
    d0 = circle().distance(p)
    if band is not None:
        d0 = np.clip(d0, -band, band)
    smooth = np.linalg.norm(p - CENTRE, axis=1) >= 0.25 + math.sqrt(2) * h
    if band is not None:
        smooth &= np.abs(circle().distance(p)) < band - 2 * h
    err = np.abs(packed.distance(p) - d0)[smooth]
    assert np.max(err) <= bilinear_error_bound(h, 0.25) + scale / 255


# --------------------------------------------------------------------------------------
# Specs and construction.
# --------------------------------------------------------------------------------------

def test_bake_from_a_spec_matches_the_python_constructor(rng):
    spec = {"op": "bake", "cell": 0.05, "band": 0.3, "quantize": "uint8",
            "of": {"op": "smooth_union", "k": 0.2, "of": [
                {"type": "circle", "radius": 0.5}, {"type": "box", "size": [1.0, 0.4],
                                                     "offset": [0.6, 0.0]}]}}
    f = field(spec)
    assert isinstance(f, GridField) and f.spec["cell"] == 0.05
    direct = GridField(spec["of"], 0.05, band=0.3, quantize="uint8")
    p = sample_points(f, 2000, rng)
    np.testing.assert_array_equal(f.distance(p), direct.distance(p))
    placed = field(dict(spec, offset=[1.0, 2.0]))
    np.testing.assert_allclose(placed.distance(p + [1.0, 2.0]), f.distance(p), atol=1e-12)


@pytest.mark.skipif("polygon" not in PRIMITIVES, reason="the polygon primitive is not there yet")
def test_bake_a_polygon_from_its_points(rng):
    points = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 0.4], [0.0, 1.0]]   # concave
    src = field({"type": "polygon", "points": points})
    g = field({"op": "bake", "cell": 0.02, "of": {"type": "polygon", "points": points}})
    p = grid_points(g, rng)
    assert np.max(np.abs(g.distance(p) - src.distance(p))) <= bilinear_error_bound(0.02)


class HalfPlane(Field):
    exact = True

    def evaluate(self, points):
        p = np.asarray(points, dtype=float)
        return p[:, 1], np.tile([0.0, 1.0], (len(p), 1))

    def bounds(self):
        return np.array([-np.inf, -np.inf, np.inf, 0.0])


def test_unbounded_and_oversized_bakes_are_refused():
    with pytest.raises(sdfphys.SpecError, match="^of: is unbounded"):
        GridField(HalfPlane(), 0.1)
    with pytest.raises(sdfphys.SpecError, match="^field.cell: 1e-05 is too small"):
        field({"op": "bake", "cell": 1e-5, "of": {"type": "circle", "radius": 1.0}})


@pytest.mark.parametrize("spec, message", [
    ({"op": "bake", "cell": 0.0, "of": {"type": "circle", "radius": 1.0}},
     "field.cell: must be > 0, got 0"),
    ({"op": "bake", "of": {"type": "circle", "radius": 1.0}}, "field.cell: is required"),
    ({"op": "bake", "cell": 0.1, "margin": -1, "of": {"type": "circle", "radius": 1.0}},
     "field.margin: must be >= 0, got -1"),
    ({"op": "bake", "cell": 0.1, "band": 0, "of": {"type": "circle", "radius": 1.0}},
     "field.band: must be > 0, got 0"),
    ({"op": "bake", "cell": 0.1, "quantize": "uint16", "of": {"type": "circle", "radius": 1.0}},
     "field.quantize: must be one of none, uint8; got 'uint16'"),
    ({"op": "bake", "cell": 0.1, "of": {"op": "union", "of": [
        {"type": "circle", "radius": 1.0}, {"type": "circle", "radius": -2.0}]}},
     "field.of.of[1].radius: must be > 0, got -2"),
])
def test_bad_bake_specs_name_the_key_path(spec, message):
    with pytest.raises(sdfphys.SpecError) as err:
        field(spec)
    assert str(err.value).startswith(message)


def test_no_nan_on_nodes_rims_corners_and_far_away():
    for kwargs in ({}, {"band": 0.1, "quantize": "uint8"}, {"margin": 0.0}):
        g = GridField(field({"type": "box", "size": [1.0, 1.0]}), 0.1, **kwargs)
        hi = g.origin + g.cell * (np.array(g.shape) - 1)
        p = np.array([g.origin, hi, [g.origin[0], hi[1]], [0.0, 0.0], [0.5, 0.5],
                      g.origin + g.cell, [1e9, -1e9], [hi[0] + 1.0, 0.0], [0.0, 0.5]])
        d, grad = g.evaluate(p)
        assert np.all(np.isfinite(d)) and np.all(np.isfinite(grad))


def test_smooth_union_with_a_bake_covers_its_blend(rng):
    baked = GridField(circle(), 0.05)
    f = OPERATORS["smooth_union"]([baked, field({"type": "circle", "radius": 0.4,
                                                 "offset": [1.6, 0.0]})], k=0.6)
    x0, y0, x1, y1 = f.bounds()
    p = sample_points(f, 40000, rng, pad=0.5)
    region = p[f.distance(p) <= 0]
    assert np.all(region >= [x0, y0]) and np.all(region <= [x1, y1])
