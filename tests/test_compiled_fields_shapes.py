"""Tests of sdfphys.sdf.compiled for the primitives evaluated point by point
(``_shape``: the curved and polygonal primitives besides circle, box, rounded_box,
polygon, half_plane, segment and capsule, and baked grids): the compiled program
gives the numpy field's value and gradient on thousands of random points and on
degenerate ones (centres, axes, boundary points and their neighbours, vertices,
far away, tiny coordinates), alone and inside CSG trees and placements.

Bit-identical (``assert_array_equal``, which does not tell -0.0 from 0.0) for every
primitive whose numpy code uses only +, -, *, /, sqrt, hypot and comparisons. The
others round differently in a few places, where numpy calls a function that the
compiled code cannot reproduce: BLAS products ``q @ c`` (pie, ring, horseshoe,
quadratic_bezier; OpenBLAS rounds a row depending on its place in the batch) and
numpy's own SIMD arctan2 / cbrt / arccos / power (star, quadratic_bezier), which
differ from libm by an ulp or so. For them the values agree to ``ATOL`` and the
gradients too, except the Bezier's: its closest parameter comes from three guarded
Newton steps whose result depends on the seed's last bits (measured up to 6.2e-9
near the curve's evolute, where convergence is slow), so its gradients are
compared to ``BEZIER_GRAD_ATOL``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import numpy_fields
import pytest
from fieldcheck import FAR_POINTS, boundary_and_sides, bounds_and_axes

from sdfphys.sdf import compiled, field
from sdfphys.sdf.edit import GRID_HEADER
from sdfphys.sdf.gradient import NumericGradientField

ROOT = Path(__file__).resolve().parents[1]
ATOL = 1e-12
BEZIER_GRAD_ATOL = 1e-7

#: Primitive specs, one or more per kind (the variants that change branches: full
#: angles, negative cuts, swapped ellipse axes, short legs, stubby crosses, ...).
PRIMITIVES = {
    "ellipse": {"type": "ellipse", "size": [4.0, 2.0]},
    "ellipse_tall": {"type": "ellipse", "size": [0.5, 3.0]},
    "ellipse_flat": {"type": "ellipse", "size": [10.0, 0.2]},
    "ellipse_circle": {"type": "ellipse", "size": [1.0, 1.0]},
    "ellipse_needle": {"type": "ellipse", "size": [1000.0, 1.0]},
    "arc": {"type": "arc", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3},
    "arc_wide": {"type": "arc", "half_angle": 2.0, "radius": 0.5, "thickness": 0.12},
    "arc_full": {"type": "arc", "half_angle": math.pi, "radius": 1.0, "thickness": 0.6},
    "arc_thick": {"type": "arc", "half_angle": 1.0, "radius": 1.0, "thickness": 2.6},
    "ring": {"type": "ring", "half_angle": 1.0, "radius": 1.0, "thickness": 0.3},
    "ring_wide": {"type": "ring", "half_angle": 2.6, "radius": 1.0, "thickness": 0.5},
    "ring_full": {"type": "ring", "half_angle": math.pi, "radius": 1.0, "thickness": 0.5},
    "pie": {"type": "pie", "half_angle": 0.6, "radius": 1.2},
    "pie_half": {"type": "pie", "half_angle": math.pi / 2, "radius": 1.0},
    "pie_wide": {"type": "pie", "half_angle": 2.3, "radius": 1.0},
    "pie_full": {"type": "pie", "half_angle": math.pi, "radius": 1.0},
    "cut_disk": {"type": "cut_disk", "radius": 1.0, "cut_height": 0.4},
    "cut_disk_half": {"type": "cut_disk", "radius": 1.0, "cut_height": 0.0},
    "cut_disk_low": {"type": "cut_disk", "radius": 1.0, "cut_height": -0.6},
    "horseshoe": {"type": "horseshoe", "half_opening": 1.2, "radius": 1.0, "length": 0.8,
                  "thickness": 0.3},
    "horseshoe_short": {"type": "horseshoe", "half_opening": 0.5, "radius": 1.0,
                        "length": 0.05, "thickness": 0.4},
    "horseshoe_open": {"type": "horseshoe", "half_opening": 2.2, "radius": 0.8,
                       "length": 1.0, "thickness": 0.3},
    "vesica": {"type": "vesica", "radius": 1.0, "distance": 0.6},
    "vesica_disk": {"type": "vesica", "radius": 1.0, "distance": 0.0},
    "moon": {"type": "moon", "radius": 1.0, "bite_radius": 0.8, "distance": 0.5},
    "moon_big_bite": {"type": "moon", "radius": 1.0, "bite_radius": 1.5, "distance": 1.2},
    "moon_far": {"type": "moon", "radius": 1.0, "bite_radius": 0.5, "distance": 1.2},
    "egg": {"type": "egg", "radius": 1.0, "top_radius": 0.3},
    "egg_sharp": {"type": "egg", "radius": 1.0, "top_radius": 0.0},
    "heart": {"type": "heart", "scale": 2.0},
    "uneven_capsule": {"type": "uneven_capsule", "bottom_radius": 0.8, "top_radius": 0.3,
                       "height": 1.5},
    "uneven_capsule_top": {"type": "uneven_capsule", "bottom_radius": 0.2,
                           "top_radius": 0.7, "height": 0.6},
    "quadratic_bezier": {"type": "quadratic_bezier", "a": [-1.0, 0.0], "b": [0.0, 1.0],
                         "c": [1.0, 0.0]},
    "quadratic_bezier_stroke": {"type": "quadratic_bezier", "a": [-1.0, -1.0],
                                "b": [2.0, 1.5], "c": [0.5, -0.2], "radius": 0.015},
    "quadratic_bezier_flat": {"type": "quadratic_bezier", "a": [-1.0, 0.0],
                              "b": [0.0, 1e-9], "c": [1.0, 0.0], "radius": 0.2},
    "quadratic_bezier_line": {"type": "quadratic_bezier", "a": [-1.0, 0.0],
                              "b": [0.0, 0.0], "c": [1.0, 0.0], "radius": 0.1},
    "oriented_box": {"type": "oriented_box", "a": [-1.0, 0.5], "b": [2.0, 1.5],
                     "thickness": 0.8},
    "rhombus": {"type": "rhombus", "size": [4.0, 2.0]},
    "trapezoid": {"type": "trapezoid", "bottom_width": 4.0, "top_width": 2.0, "height": 2.0},
    "trapezoid_inverted": {"type": "trapezoid", "bottom_width": 1.0, "top_width": 3.0,
                           "height": 1.5},
    "trapezoid_pointed": {"type": "trapezoid", "bottom_width": 3.0, "top_width": 0.0,
                          "height": 1.0},
    "parallelogram": {"type": "parallelogram", "width": 2.0, "height": 1.0, "skew": 1.0},
    "parallelogram_steep": {"type": "parallelogram", "width": 0.5, "height": 2.0,
                            "skew": -2.5},
    "triangle": {"type": "triangle", "points": [[0, 0], [4, 0], [0, 3]]},
    "triangle_cw": {"type": "triangle", "points": [[1, 1], [-2, 0.5], [0.5, -3]]},
    "equilateral_triangle": {"type": "equilateral_triangle", "side": 2.0},
    "isosceles_triangle": {"type": "isosceles_triangle", "width": 0.3, "height": 3.0},
    "pentagon": {"type": "pentagon", "radius": 1.0},
    "hexagon": {"type": "hexagon", "radius": 1.0},
    "octagon": {"type": "octagon", "radius": 1.5},
    "hexagram": {"type": "hexagram", "radius": 0.7},
    "star": {"type": "star", "radius": 1.0, "points": 5, "m": 3.0},
    "star_polygon": {"type": "star", "radius": 2.0, "points": 7, "m": 2.0},
    "star_spiky": {"type": "star", "radius": 1.0, "points": 12, "m": 9.0},
    "cross": {"type": "cross", "size": [3.0, 1.0]},
    "cross_stubby": {"type": "cross", "size": [1.8, 2.0]},
    "cross_grown": {"type": "cross", "size": [3.0, 1.0], "rounding": -0.2},
    "cross_thinned": {"type": "cross", "size": [3.0, 1.0], "rounding": 0.2},
    "rounded_cross": {"type": "rounded_cross", "h": 0.5},
    "rounded_cross_scaled": {"type": "rounded_cross", "h": 1.0, "radius": 2.0},
    "grid": {"op": "bake", "cell": 0.1, "band": 1.0, "of": {"type": "ellipse",
                                                            "size": [3.0, 1.0]}},
    "grid_uint8": {"op": "bake", "cell": 0.13, "quantize": "uint8",
                   "of": {"type": "star", "radius": 1.0, "points": 5, "m": 3.0}},
    "grid_no_band": {"op": "bake", "cell": 0.2, "margin": 0.1,
                     "of": {"type": "box", "size": [2.0, 1.0], "angle": 0.3}},
    # scenes/terrain.png (tools/make_terrain_image.py) at 5 mm per pixel: a grid from a
    # distance transform and antialiased edges, run by the same GRID instruction.
    "image": {"type": "image", "path": str(ROOT / "scenes" / "terrain.png"), "cell": 0.005},
}

#: The kinds whose numpy code calls numpy's SIMD transcendental functions (arctan2, cbrt).
ROUNDS_DIFFERENTLY = ("star", "quadratic_bezier")

TERRAIN = {"op": "smooth_union", "k": 0.8, "of": [
    {"type": "box", "size": [26.0, 1.0], "offset": [0.0, -0.5]},
    {"type": "circle", "radius": 2.0, "offset": [-5.0, -1.0]},
    {"type": "ellipse", "size": [5.0, 1.6], "offset": [5.0, 0.0]}]}

#: Trees mixing the new kinds with operators and placements (and the scenes' fields).
TREES = {
    "showcase_terrain": TERRAIN,
    "union_placed": {"op": "union", "of": [
        dict(PRIMITIVES["ellipse"], offset=[0.3, -0.2], angle=0.7),
        dict(PRIMITIVES["star"], offset=[-1.0, 0.5], angle=-0.4),
        dict(PRIMITIVES["heart"], offset=[0.0, -1.5])]},
    "difference_scaled": {"op": "difference", "of": [
        PRIMITIVES["moon"],
        {"op": "scale", "factor": 0.5, "of": PRIMITIVES["egg"]},
        dict(PRIMITIVES["vesica"], offset=[-0.5, 0.0])]},
    "smooth_mix": {"op": "smooth_union", "k": 0.3, "blend": "cubic", "of": [
        PRIMITIVES["ring"], PRIMITIVES["pie"], dict(PRIMITIVES["arc"], angle=math.pi)]},
    "onion_hexagon": {"op": "onion", "thickness": 0.08, "of": {"type": "hexagon",
                                                                "radius": 0.5}},
    "round_star": {"op": "round", "r": 0.1, "of": {"type": "star", "radius": 0.55,
                                                    "points": 4, "m": 2.5}},
    "xor_polygons": {"op": "xor", "of": [PRIMITIVES["rhombus"], PRIMITIVES["octagon"],
                                         dict(PRIMITIVES["trapezoid"], angle=0.2)]},
    "intersection_crosses": {"op": "intersection", "of": [
        PRIMITIVES["cross"], {"op": "rotate", "by": 0.3, "of": PRIMITIVES["rounded_cross"]},
        {"op": "translate", "by": [0.2, 0.1], "of": PRIMITIVES["cut_disk"]}]},
    "marble_track": {"op": "smooth_union", "k": 0.3, "of": [
        {"type": "capsule", "a": [-9.0, 9.0], "b": [-1.0, 6.5], "radius": 0.2},
        {"type": "arc", "half_angle": 1.2, "radius": 1.6, "thickness": 0.2,
         "offset": [8.0, 5.0], "angle": 3.14159},
        {"type": "box", "size": [24.0, 0.6], "offset": [0.0, -0.3]}]},
    "baked_terrain": {"op": "bake", "cell": 0.1, "band": 1.0, "of": {
        "op": "smooth_union", "k": 1.0, "of": [
            {"type": "box", "size": [24.0, 2.0], "offset": [0.0, -1.0]},
            {"type": "circle", "radius": 2.5, "offset": [-6.0, -1.2]},
            {"type": "ellipse", "size": [6.0, 2.0], "offset": [6.5, 0.0]}]},
        "offset": [0.5, 0.2], "angle": 0.1},
    "grid_in_union": {"op": "union", "of": [
        PRIMITIVES["grid_uint8"], dict(PRIMITIVES["horseshoe"], offset=[1.0, 1.0]),
        dict(PRIMITIVES["quadratic_bezier_stroke"], angle=0.5),
        dict(PRIMITIVES["uneven_capsule"], offset=[-1.0, -1.0])]},
    "shapes_in_xor": {"op": "xor", "of": [
        PRIMITIVES["parallelogram"], PRIMITIVES["triangle"], PRIMITIVES["pentagon"],
        PRIMITIVES["hexagram"], PRIMITIVES["equilateral_triangle"],
        PRIMITIVES["oriented_box"]]},
}


def _rounds_differently(spec) -> bool:
    text = repr(spec)
    return any(f"'{kind}'" in text for kind in ROUNDS_DIFFERENTLY)


def degenerate_points(f) -> np.ndarray:
    """Points where branches meet or values vanish, for the field ``f``: the origin,
    the axes and diagonals, the corners, edge midpoints and centre of f's bounds,
    boundary points (random points projected along -f grad f) and points 1e-9 either
    side of them, the vertices of polygonal kinds, far and tiny points."""
    rng = np.random.default_rng(11)
    x0, y0, x1, y1 = np.clip(f.bounds(), -30.0, 30.0)
    box, lines = bounds_and_axes((x0, y0, x1, y1))
    p = rng.uniform([x0 - 0.5, y0 - 0.5], [x1 + 0.5, y1 + 0.5], (400, 2))
    near = np.concatenate(boundary_and_sides(f, p))
    vertices = [np.zeros((0, 2))]
    for name in ("vertices", "_edge", "_edges", "_side"):
        item = getattr(f, name, None)
        if item is None:
            continue
        if name == "vertices":
            vertices.append(np.asarray(item, dtype=float))
        else:
            for seg in (item if isinstance(item, list) else [item]):
                vertices.append(np.array([seg.a, seg.b, -seg.a, -seg.b,
                                          0.5 * (seg.a + seg.b)]))
    return np.concatenate([box, lines, near, *vertices, FAR_POINTS])


POINTS = np.concatenate([np.random.default_rng(5).uniform(-3.0, 3.0, (4000, 2)),
                         np.random.default_rng(6).uniform(-40.0, 40.0, (300, 2))])


def _points(f) -> np.ndarray:
    return np.concatenate([POINTS, degenerate_points(f)])


def _check(spec, points=None):
    """Compiled vs numpy at ``points`` (default ``_points(f)``; they start with POINTS)."""
    f = field(spec)
    assert compiled.compile_field(f) is not None
    p = _points(f) if points is None else points
    value, grad = compiled.evaluate(f, p)
    expected_value, expected_grad = numpy_fields.evaluate(f, p)
    assert np.all(np.isfinite(value)) and np.all(np.isfinite(grad))
    if not _rounds_differently(spec):
        np.testing.assert_array_equal(value, expected_value)
        np.testing.assert_array_equal(grad, expected_grad)
    else:
        grad_atol = BEZIER_GRAD_ATOL if "quadratic_bezier" in repr(spec) else ATOL
        np.testing.assert_allclose(value, expected_value, rtol=0.0, atol=ATOL)
        off = np.abs(grad - expected_grad).max(axis=1) > grad_atol
        assert not np.any(off[:len(POINTS)])            # random points: all within grad_atol
        assert np.all(_ill_conditioned(f, p[off])), p[off][~_ill_conditioned(f, p[off])]
        if f.exact:
            np.testing.assert_allclose(np.hypot(grad[:, 0], grad[:, 1]), 1.0, atol=1e-9)
    np.testing.assert_array_equal(compiled.distance(f, p), value)


def _ill_conditioned(f, p: np.ndarray) -> np.ndarray:
    """Whether numpy's gradient at each point changes by more than 1e-6 within 1e-8 of
    it (16 directions): a kink (medial axis, fold line, the curve of a bare segment)
    or within ~1e-9 of a vertex, where the last bit of an intermediate picks the
    side or turns the direction (numpy's own answer there changes with the point's
    place in the batch, through BLAS)."""
    angle = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    ring = 1e-8 * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    out = np.zeros(len(p), dtype=bool)
    for i, point in enumerate(p):
        g = numpy_fields.evaluate(f, np.concatenate([point[None], point + ring]))[1]
        out[i] = np.abs(g[1:] - g[0]).max() > 1e-6
    return out


@pytest.mark.parametrize("name", sorted(PRIMITIVES))
def test_primitive_matches_numpy(name):
    _check(PRIMITIVES[name])


@pytest.mark.parametrize("name", sorted(PRIMITIVES))
def test_placed_primitive_matches_numpy(name):
    _check(dict(PRIMITIVES[name], offset=[0.25, -0.5], angle=0.9))


@pytest.mark.parametrize("name", sorted(TREES))
def test_tree_matches_numpy(name):
    f = field(TREES[name])
    x0, y0, x1, y1 = np.clip(f.bounds(), -30.0, 30.0)
    inside = np.random.default_rng(7).uniform([x0, y0], [x1, y1], (3000, 2))
    _check(TREES[name], np.concatenate([_points(f), inside]))


def test_exact_kinds_are_bit_identical_on_dense_random_points():
    """20 000 points per kind, no tolerance (all but the differently rounding kinds)."""
    p = np.random.default_rng(8).uniform(-4.0, 4.0, (20000, 2))
    for name, spec in PRIMITIVES.items():
        if _rounds_differently(spec):
            continue
        f = field(spec)
        value, grad = compiled.evaluate(f, p)
        expected_value, expected_grad = numpy_fields.evaluate(f, p)
        np.testing.assert_array_equal(value, expected_value, err_msg=name)
        np.testing.assert_array_equal(grad, expected_grad, err_msg=name)


def test_ellipse_near_its_axes_and_evolute():
    """The ellipse's solver cases: on the axes (closed form, inside and beyond the
    evolute's cusp), y down to 1e-300, points near the evolute, huge aspect ratios."""
    for size in ([4.0, 2.0], [2.0, 4.0], [1000.0, 1.0], [1.0, 1.0]):
        a, b = max(size) / 2.0, min(size) / 2.0
        e = (a * a - b * b) / a                      # cusp of the evolute on the major axis
        t = np.linspace(0.0, 2.0 * a, 101)
        tiny = 10.0 ** -np.arange(0, 301, 20)
        major = np.concatenate([np.stack([t, 0 * t], 1), np.stack([-t, 0 * t], 1),
                                np.stack([np.full_like(tiny, 0.5 * e), tiny], 1),
                                np.stack([np.full_like(tiny, e), -tiny], 1),
                                np.stack([np.full_like(tiny, 2 * a), tiny], 1)])
        if size[1] > size[0]:
            major = major[:, ::-1]
        angle = np.linspace(0.0, 2.0 * np.pi, 97)
        evolute = np.stack([e * np.cos(angle) ** 3, (a * a - b * b) / b * np.sin(angle) ** 3], 1)
        if size[1] > size[0]:
            evolute = evolute[:, ::-1]
        _check({"type": "ellipse", "size": size},
               np.concatenate([POINTS, major, evolute, 1.0001 * evolute, 0.9999 * evolute]))


def test_ellipse_newton_from_the_bracket_agrees_with_the_bracketed_solver(monkeypatch):
    """Most points skip the bisections: Newton steps from the bracket's low end that
    settle (``ellipse_kernel._SETTLED``) have reached the root; their distances agree
    with the bracketed solver's (every point forced through it, ``_SETTLED = -1``, in
    the numpy oracle, whose answers ``_check`` holds the compiled kernel to) to 4 ulps
    (measured 3), the gradients to 1e-10 (measured 6e-13, near the evolute's cusps);
    the points that do not settle (near the major axis inside, y down to 1e-300) run
    the bracketed solver, compiled as in numpy."""
    rng = np.random.default_rng(5)
    for aspect in (1.0, 1.5, 3.0, 10.0, 100.0, 1000.0):
        a, b = 1.0, 1.0 / aspect
        turn = rng.uniform(0.0, 2.0 * np.pi, 4000)
        p = np.concatenate([
            rng.uniform(-3.0, 3.0, (4000, 2)) * [a, b],
            np.stack([a * np.cos(turn), b * np.sin(turn)], 1) * rng.uniform(0.0, 1.05, (4000, 1)),
            np.stack([rng.uniform(-a, a, 4000), b * 10.0 ** rng.uniform(-300, -1, 4000)], 1),
            rng.uniform(-30.0, 30.0, (4000, 2))])
        f = field({"type": "ellipse", "size": [2.0 * a, 2.0 * b]})
        value, grad = numpy_fields.evaluate(f, p)
        _check({"type": "ellipse", "size": [2.0 * a, 2.0 * b]}, p)
        with monkeypatch.context() as m:
            m.setattr(numpy_fields.conics, "_SETTLED", -1.0)
            reference, reference_grad = numpy_fields.evaluate(f, p)
        scale = np.maximum(1.0, np.abs(reference))
        assert np.max(np.abs(value - reference) / scale) <= 4 * np.finfo(float).eps, aspect
        assert np.max(np.abs(grad - reference_grad)) <= 1e-10, aspect


def test_scenes_fields_now_compile():
    """The fields of scenes/showcase.toml, csg_bodies, marble_run, grid_terrain and
    sdf_primitives, which used to leave the compiled path."""
    for spec in (TERRAIN, TREES["onion_hexagon"], TREES["round_star"], TREES["marble_track"],
                 TREES["baked_terrain"], {"type": "heart", "scale": 1.0},
                 {"type": "moon", "radius": 0.6, "bite_radius": 0.5, "distance": 0.35},
                 {"type": "egg", "radius": 0.5, "top_radius": 0.2},
                 {"type": "star", "radius": 0.7, "points": 5, "m": 3.0},
                 {"type": "arc", "half_angle": 2.0, "radius": 0.5, "thickness": 0.12},
                 {"type": "vesica", "radius": 0.5, "distance": 0.3}):
        assert compiled.compile_field(field(spec)) is not None, spec


def test_numeric_gradients_fall_back_and_subclasses_take_their_parents_program():
    """A field with its own evaluate (numeric gradients, a user's subclass) is left to
    it; a subclass that keeps the inherited evaluate runs its parent's program."""
    numeric = NumericGradientField(field(PRIMITIVES["ellipse"]))
    assert compiled.compile_field(numeric) is None
    assert compiled.compile_field(field({"op": "union", "of": [
        {"type": "circle", "radius": 1.0}, {"type": "box", "size": [1.0, 1.0]}]})) is not None
    heart = type(field(PRIMITIVES["heart"]))

    class Squashed(heart):
        pass

    class Shifted(heart):
        def evaluate(self, points):
            d, g = super().evaluate(points)
            return d + 0.5, g

    p = POINTS[:20]
    assert compiled.compile_field(Squashed(2.0)) is not None
    np.testing.assert_array_equal(Squashed(2.0).evaluate(p)[0], heart(2.0).evaluate(p)[0])
    assert compiled.compile_field(Shifted(2.0)) is None
    np.testing.assert_array_equal(compiled.evaluate(Shifted(2.0), p)[0],
                                  heart(2.0).evaluate(p)[0] + 0.5)
    np.testing.assert_array_equal(compiled.evaluate(numeric, p)[0], numeric.evaluate(p)[0])


def test_big_grid_consts_are_the_node_values():
    f = field(PRIMITIVES["grid_uint8"])
    program = compiled.compile_field(f)
    i = int(np.flatnonzero(program.code[:, 0] == compiled.GRID)[0])
    _, o, a, b = program.code[i]
    assert (a, b) == f.shape
    start = o + GRID_HEADER                 # origin, cell, four margins, band
    np.testing.assert_array_equal(program.consts[start:start + a * b], f.values.ravel())
    np.testing.assert_array_equal(program.consts[o + 3:o + 7], np.full(4, f.margin))


@pytest.mark.parametrize("name", ["ellipse", "heart", "moon", "egg", "arc", "vesica", "star",
                                  "grid", "hexagram", "trapezoid", "ring", "horseshoe",
                                  "quadratic_bezier_stroke"])
def test_compiled_descent_equals_the_python_loop(name):
    """The triangle descent over these fields (now inside one compiled call) finds the
    same minima as the Python-driven loop over the numpy fields. For the kinds that
    round differently only the minimum values are compared (measured within 3e-10,
    the Bezier's within 3e-7 on a degenerate triangle, where the compiled run ends
    nearer the true minimum): the descent amplifies last-bit differences into other
    points of a flat or kinked minimum (up to 0.1 m along a horseshoe's straight
    side, same value)."""
    from test_compiled_descent import both_paths
    from test_descent import random_triangles

    f = field(dict(PRIMITIVES[name], offset=[0.2, -0.1], angle=0.4))
    tri = random_triangles(f, 200, np.random.default_rng(sorted(PRIMITIVES).index(name)))
    tri[:5, 2] = 0.5 * (tri[:5, 0] + tri[:5, 1])                    # degenerate
    for iterations in (1, 16):
        (p1, v1, r1), (p2, v2, r2) = both_paths(f, tri, iterations, None)
        if _rounds_differently(PRIMITIVES[name]):
            atol = 1e-6 if name.startswith("quadratic_bezier") else 1e-9
            np.testing.assert_allclose(v1, v2, rtol=0.0, atol=atol)
            continue
        np.testing.assert_array_equal(p1, p2)
        np.testing.assert_array_equal(v1, v2)
        np.testing.assert_array_equal(r1, r2)


def test_every_registered_primitive_is_tested_here_or_in_test_compiled_fields():
    from sdfphys.sdf.base import PRIMITIVES as REGISTERED

    own_loops = {"circle", "box", "rounded_box", "polygon", "half_plane", "segment", "capsule"}
    here = {spec["type"] for spec in PRIMITIVES.values() if "type" in spec}
    assert set(REGISTERED) == own_loops | here


@pytest.mark.parametrize("name", sorted(PRIMITIVES))
def test_a_point_gets_the_same_answer_alone_or_in_a_batch(name):
    """Also batches of 0 and 1 points (the ellipse runs its solver over the batch)."""
    f = field(PRIMITIVES[name])
    p = np.concatenate([POINTS[:40], degenerate_points(f)[::25]])
    value, grad = compiled.evaluate(f, p)
    for i in range(len(p)):
        v, g = compiled.evaluate(f, p[i])
        assert v.shape == (1,) and g.shape == (1, 2)
        np.testing.assert_array_equal(v[0], value[i])
        np.testing.assert_array_equal(g[0], grad[i])
    v, g = compiled.evaluate(f, np.zeros((0, 2)))
    assert v.shape == (0,) and g.shape == (0, 2)
