"""Straight-edged primitives (and the rounded cross) of sdfphys.sdf.polygonal against exact answers.

References, each independent of the code under test: distances computed by hand;
a brute-force polygon distance written here (min over the edges, sign by
Franklin's crossing-number test) on outlines built here from each shape's
geometry; brute-force distances to the arcs of the rounded box and rounded cross;
pymunk's ``Poly.point_query`` (distance and gradient) for convex shapes; and the
generic exactness checks of ``tests/fieldcheck.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk
import pytest
from fieldcheck import check_field, sample_points

import sdfphys
from sdfphys.sdf import PRIMITIVES, field

S2, S3 = math.sqrt(2.0), math.sqrt(3.0)

NEW_PRIMITIVES = {
    "rounded_box", "oriented_box", "rhombus", "trapezoid", "parallelogram",
    "equilateral_triangle", "isosceles_triangle", "triangle", "pentagon", "hexagon",
    "octagon", "hexagram", "star", "cross", "rounded_cross", "polygon", "half_plane",
}


# --------------------------------------------------------------------------------------
# Reference outlines, built from each shape's geometry (not from the module's code)
# --------------------------------------------------------------------------------------

def regular(n: int, circumradius: float, first_deg: float) -> np.ndarray:
    """Regular n-gon, counter-clockwise, first vertex at ``first_deg`` degrees."""
    a = np.radians(first_deg + 360.0 * np.arange(n) / n)
    return circumradius * np.stack([np.cos(a), np.sin(a)], axis=1)


def star_outline(r: float, n: int, m: float) -> np.ndarray:
    """Quilez's star: tips at r from 90deg every 360/n deg; inner corners between them
    at the radius the law of sines gives in the triangle centre-tip-corner (angles
    pi/n at the centre, pi - pi/m at the corner)."""
    an, en = math.pi / n, math.pi / m
    inner = r * math.sin(en - an) / math.sin(en)
    a = math.pi / 2 + an * np.arange(2 * n)
    rad = np.where(np.arange(2 * n) % 2 == 0, r, inner)
    return np.stack([rad * np.cos(a), rad * np.sin(a)], axis=1)


def hexagram_outline(r: float) -> np.ndarray:
    """Tips at 2r (30deg + k 60deg), inner corners at 2r/sqrt(3) (k 60deg)."""
    a = np.radians(30.0 * np.arange(12))
    rad = np.where(np.arange(12) % 2 == 0, 2 * r / S3, 2 * r)
    return np.stack([rad * np.cos(a), rad * np.sin(a)], axis=1)


def cross_outline(length: float, thickness: float) -> np.ndarray:
    a, b = length / 2, thickness / 2
    return np.array([[a, -b], [a, b], [b, b], [b, a], [-b, a], [-b, b], [-a, b], [-a, -b],
                     [-b, -b], [-b, -a], [b, -a], [b, -b]])


def oriented_box_outline(a, b, thickness) -> np.ndarray:
    a, b = np.asarray(a, float), np.asarray(b, float)
    u = (b - a) / np.linalg.norm(b - a)
    n = np.array([-u[1], u[0]]) * thickness / 2
    return np.array([a - n, b - n, b + n, a + n])


L_SHAPE = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)
U_SHAPE = np.array([[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]], dtype=float)
COMB = np.array([[0, 0], [3.5, 0], [3.5, 4], [3, 4], [3, 1], [2.5, 1], [2.5, 4], [2, 4], [2, 1],
                 [1.5, 1], [1.5, 4], [1, 4], [1, 1], [0.5, 1], [0.5, 4], [0, 4]], dtype=float)


def random_star_polygon(n: int, seed: int) -> np.ndarray:
    """Star-shaped (usually concave) polygon: sorted angles, radii in [0.2, 1], CCW."""
    rng = np.random.default_rng(seed)
    a = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = rng.uniform(0.2, 1.0, n)
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=1)


# name: (spec, outline). Outlines in either winding; all are the exact boundary.
POLYGONAL = {
    "box": ({"type": "box", "size": [3.0, 1.2]},
            [[-1.5, -0.6], [1.5, -0.6], [1.5, 0.6], [-1.5, 0.6]]),
    "oriented_box": ({"type": "oriented_box", "a": [-1.0, 0.5], "b": [2.0, 1.5], "thickness": 0.8},
                     oriented_box_outline([-1.0, 0.5], [2.0, 1.5], 0.8)),
    "rhombus": ({"type": "rhombus", "size": [4.0, 2.0]}, [[2, 0], [0, 1], [-2, 0], [0, -1]]),
    "trapezoid": ({"type": "trapezoid", "bottom_width": 4.0, "top_width": 2.0, "height": 2.0},
                  [[-2, -1], [2, -1], [1, 1], [-1, 1]]),
    "trapezoid_inverted": (
        {"type": "trapezoid", "bottom_width": 0.5, "top_width": 3.0, "height": 1.0},
        [[-0.25, -0.5], [0.25, -0.5], [1.5, 0.5], [-1.5, 0.5]]),
    "trapezoid_pointed": ({"type": "trapezoid", "bottom_width": 3.0, "top_width": 0.0, "height": 1.0},
                          [[-1.5, -0.5], [1.5, -0.5], [0.0, 0.5]]),
    "parallelogram": ({"type": "parallelogram", "width": 2.0, "height": 1.0, "skew": 1.0},
                      [[-1.5, -0.5], [0.5, -0.5], [1.5, 0.5], [-0.5, 0.5]]),
    "parallelogram_steep": (
        {"type": "parallelogram", "width": 0.4, "height": 0.3, "skew": -5.0},
        [[2.3, -0.15], [2.7, -0.15], [-2.3, 0.15], [-2.7, 0.15]]),
    "equilateral_triangle": ({"type": "equilateral_triangle", "side": 2.0},
                             [[0, 2 / S3], [-1, -1 / S3], [1, -1 / S3]]),
    "isosceles_triangle": ({"type": "isosceles_triangle", "width": 2.0, "height": 2.0},
                           [[0, 1], [-1, -1], [1, -1]]),
    "isosceles_thin": ({"type": "isosceles_triangle", "width": 0.3, "height": 3.0},
                       [[0, 1.5], [-0.15, -1.5], [0.15, -1.5]]),
    "triangle_ccw": ({"type": "triangle", "points": [[0, 0], [4, 0], [0, 3]]},
                     [[0, 0], [4, 0], [0, 3]]),
    "triangle_cw": ({"type": "triangle", "points": [[1, 1], [-2, 0.5], [0.5, -3]]},
                    [[1, 1], [-2, 0.5], [0.5, -3]]),
    "pentagon": ({"type": "pentagon", "radius": 1.0},
                 regular(5, 1.0 / math.cos(math.pi / 5), 54.0)),
    "hexagon": ({"type": "hexagon", "radius": 1.0}, regular(6, 2.0 / S3, 0.0)),
    "octagon": ({"type": "octagon", "radius": 1.5},
                regular(8, 1.5 / math.cos(math.pi / 8), 22.5)),
    "hexagram": ({"type": "hexagram", "radius": 0.7}, hexagram_outline(0.7)),
    "star_5_3": ({"type": "star", "radius": 1.0, "points": 5, "m": 3.0}, star_outline(1.0, 5, 3.0)),
    "star_7_2": ({"type": "star", "radius": 2.0, "points": 7, "m": 2.0}, star_outline(2.0, 7, 2.0)),
    "star_3_2.5": ({"type": "star", "radius": 1.0, "points": 3, "m": 2.5},
                   star_outline(1.0, 3, 2.5)),
    "star_12_9": ({"type": "star", "radius": 1.0, "points": 12, "m": 9.0},
                  star_outline(1.0, 12, 9.0)),
    "cross": ({"type": "cross", "size": [3.0, 1.0]}, cross_outline(3.0, 1.0)),
    "cross_stubby": ({"type": "cross", "size": [1.8, 2.0]}, cross_outline(2.0, 1.8)),
    "polygon_l": ({"type": "polygon", "points": L_SHAPE.tolist()}, L_SHAPE),
    "polygon_u_cw": ({"type": "polygon", "points": U_SHAPE[::-1].tolist()}, U_SHAPE),
}

CONVEX = ["box", "oriented_box", "rhombus", "trapezoid", "trapezoid_inverted",
          "trapezoid_pointed", "parallelogram", "parallelogram_steep", "equilateral_triangle",
          "isosceles_triangle", "isosceles_thin", "triangle_ccw", "triangle_cw", "pentagon",
          "hexagon", "octagon", "star_7_2"]

CURVED = {
    "rounded_box": {"type": "rounded_box", "size": [2.0, 1.0], "radii": 0.3},
    "rounded_box_corners": {"type": "rounded_box", "size": [4.0, 2.0],
                            "radii": [0.5, 0.1, 0.0, 1.0]},
    "rounded_box_stadium": {"type": "rounded_box", "size": [3.0, 1.0], "radii": 0.5},
    "rounded_cross": {"type": "rounded_cross", "h": 0.5},
    "rounded_cross_scaled": {"type": "rounded_cross", "h": 1.0, "radius": 2.0},
    "cross_grown": {"type": "cross", "size": [3.0, 1.0], "rounding": -0.2},
    "cross_thinned": {"type": "cross", "size": [3.0, 1.0], "rounding": 0.2},
}

ALL_SPECS = {**{k: v[0] for k, v in POLYGONAL.items()}, **CURVED,
             "polygon_comb_cw": {"type": "polygon", "points": COMB[::-1].tolist()}}


# --------------------------------------------------------------------------------------
# Brute-force references
# --------------------------------------------------------------------------------------

def brute_polygon(vertices, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance and gradient to a polygon outline, one edge at a time.

    Distance: min over the edges of the point-segment distance; sign: W. R.
    Franklin's crossing-number test (pnpoly); gradient: sign (p - c)/|p - c|.
    """
    v = np.asarray(vertices, dtype=float)
    best = np.full(len(p), np.inf)
    closest = np.zeros_like(p)
    inside = np.zeros(len(p), dtype=bool)
    for a, b in zip(v, np.roll(v, -1, axis=0)):
        e = b - a
        t = np.clip(((p - a) @ e) / (e @ e), 0.0, 1.0)
        c = a + t[:, None] * e
        d = np.linalg.norm(p - c, axis=1)
        better = d < best
        best[better], closest[better] = d[better], c[better]
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = (b[0] - a[0]) * (p[:, 1] - a[1]) / (b[1] - a[1]) + a[0]
        inside ^= ((a[1] > p[:, 1]) != (b[1] > p[:, 1])) & (p[:, 0] < x_cross)
    s = np.where(inside, -1.0, 1.0)
    return s * best, s[:, None] * (p - closest) / best[:, None]


def arc_distance(p: np.ndarray, centre, radius: float, a0: float, a1: float) -> np.ndarray:
    """Distance from p to the arc of a circle between polar angles a0 < a1 (radians)."""
    w = p - centre
    ang = np.arctan2(w[:, 1], w[:, 0])
    ang = a0 + np.mod(ang - a0, 2 * np.pi)
    on_arc = ang <= a1
    ends = [np.asarray(centre) + radius * np.array([math.cos(a), math.sin(a)]) for a in (a0, a1)]
    to_ends = np.minimum(np.linalg.norm(p - ends[0], axis=1), np.linalg.norm(p - ends[1], axis=1))
    return np.where(on_arc, np.abs(np.linalg.norm(w, axis=1) - radius), to_ends)


def segment_distance(p: np.ndarray, a, b) -> np.ndarray:
    a, b = np.asarray(a, float), np.asarray(b, float)
    e = b - a
    if not e @ e > 0:   # a straight side of length 0 (the ends of a stadium)
        return np.linalg.norm(p - a, axis=1)
    t = np.clip(((p - a) @ e) / (e @ e), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * e), axis=1)


def brute_rounded_box(size, radii, p: np.ndarray) -> np.ndarray:
    """Signed distance to a box with corner radii [top-right, top-left, bottom-left,
    bottom-right]: four edges and four quarter arcs; inside = in the box and not in a
    corner square beyond its arc."""
    hx, hy = size[0] / 2, size[1] / 2
    r_tr, r_tl, r_bl, r_br = radii
    parts = [
        segment_distance(p, [hx, -hy + r_br], [hx, hy - r_tr]),
        segment_distance(p, [hx - r_tr, hy], [-hx + r_tl, hy]),
        segment_distance(p, [-hx, hy - r_tl], [-hx, -hy + r_bl]),
        segment_distance(p, [-hx + r_bl, -hy], [hx - r_br, -hy]),
    ]
    inside = (np.abs(p[:, 0]) <= hx) & (np.abs(p[:, 1]) <= hy)
    corners = [((hx - r_tr, hy - r_tr), r_tr, 0.0, 1, 1), ((-hx + r_tl, hy - r_tl), r_tl, 0.5, -1, 1),
               ((-hx + r_bl, -hy + r_bl), r_bl, 1.0, -1, -1),
               ((hx - r_br, -hy + r_br), r_br, 1.5, 1, -1)]
    for c, r, start, sx, sy in corners:
        if r > 0:
            parts.append(arc_distance(p, c, r, start * np.pi, (start + 0.5) * np.pi))
            w = p - c
            beyond = (w[:, 0] * sx > 0) & (w[:, 1] * sy > 0) & (np.linalg.norm(w, axis=1) > r)
            inside &= ~beyond
    d = np.min(parts, axis=0)
    return np.where(inside, -d, d)


def brute_rounded_cross(h: float, radius: float, p: np.ndarray) -> np.ndarray:
    """Signed distance to the box [-1, 1] x [-h, h] minus four disks of radius k centred
    (+-1, +-k): the four arcs between neighbouring tips (scaled by ``radius``)."""
    k = 0.5 * (h + 1 / h)
    q = p / radius
    parts = []
    inside = (np.abs(q[:, 0]) <= 1) & (np.abs(q[:, 1]) <= h)
    for sx in (1, -1):
        for sy in (1, -1):
            c = np.array([sx, sy * k])
            tip_x, tip_y = np.array([sx, 0.0]), np.array([0.0, sy * h])
            a_x = math.atan2(*(tip_x - c)[::-1])
            a_y = math.atan2(*(tip_y - c)[::-1])
            a0, a1 = sorted([a_x, a_y])
            if a1 - a0 > np.pi:
                a0, a1 = a1, a0 + 2 * np.pi
            parts.append(arc_distance(q, c, k, a0, a1))
            inside &= np.linalg.norm(q - c, axis=1) >= k
    d = np.min(parts, axis=0) * radius
    return np.where(inside, -d, d)


def near_boundary_points(outline, rng: np.random.Generator, per_edge: int = 20) -> np.ndarray:
    """Points on, just inside and just outside each edge, and around each vertex."""
    v = np.asarray(outline, float)
    pts = [v + rng.normal(scale=1e-3, size=v.shape)]
    for a, b in zip(v, np.roll(v, -1, axis=0)):
        e = b - a
        n = np.array([e[1], -e[0]]) / np.linalg.norm(e)
        t = rng.random(per_edge)[:, None]
        off = rng.choice([-1e-3, -1e-7, 1e-7, 1e-3, 0.1], size=per_edge)[:, None]
        pts.append(a + t * e + off * n)
    return np.concatenate(pts)


# --------------------------------------------------------------------------------------
# Registry
# --------------------------------------------------------------------------------------

#: The primitives evaluated on one folded edge (``sdf.folded``); the others of
#: NEW_PRIMITIVES and box live in ``sdf.polygonal``.
FOLDED = {"pentagon", "hexagon", "octagon", "hexagram", "star", "cross", "rounded_cross"}


def test_all_primitives_are_registered():
    assert NEW_PRIMITIVES | {"box"} <= set(PRIMITIVES)
    for name in NEW_PRIMITIVES | {"box"}:
        module = "folded" if name in FOLDED else "polygonal"
        assert PRIMITIVES[name].__module__ == f"sdfphys.sdf.{module}", name


# --------------------------------------------------------------------------------------
# Generic exactness (fieldcheck), for every primitive
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(ALL_SPECS))
def test_field_is_what_it_claims(name, rng):
    f = field(ALL_SPECS[name])
    assert f.exact == (name != "cross_grown" and name != "cross_thinned")
    check_field(f, rng)


# --------------------------------------------------------------------------------------
# Against brute force on the outline, pymunk for convex shapes
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(POLYGONAL))
def test_matches_brute_force_polygon(name, rng):
    spec, outline = POLYGONAL[name]
    f = field(spec)
    p = np.concatenate([sample_points(f, 3000, rng), near_boundary_points(outline, rng)])
    d, g = f.evaluate(p)
    d_ref, g_ref = brute_polygon(outline, p)
    scale = np.ptp(np.asarray(outline), axis=0).max()
    np.testing.assert_allclose(d, d_ref, rtol=0, atol=1e-12 * scale)
    far = np.abs(d_ref) > 1e-6 * scale   # the direction p - c is well conditioned
    np.testing.assert_allclose(g[far], g_ref[far], rtol=0, atol=1e-8)
    np.testing.assert_allclose(np.linalg.norm(g, axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("name", CONVEX)
def test_matches_pymunk_point_query(name, rng):
    spec, outline = POLYGONAL[name]
    f = field(spec)
    poly = pymunk.Poly(None, [tuple(v) for v in np.asarray(outline, float)])
    poly.update(pymunk.Transform.identity())
    p = sample_points(f, 400, rng)
    d, g = f.evaluate(p)
    infos = [poly.point_query(tuple(q)) for q in p]
    np.testing.assert_allclose(d, [i.distance for i in infos], rtol=0, atol=1e-9)
    np.testing.assert_allclose(g, [tuple(i.gradient) for i in infos], rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", ["rounded_box", "rounded_box_corners", "rounded_box_stadium"])
def test_rounded_box_matches_brute_force(name, rng):
    spec = CURVED[name]
    f = field(spec)
    radii = np.broadcast_to(spec["radii"], (4,))
    p = sample_points(f, 4000, rng)
    np.testing.assert_allclose(f.distance(p), brute_rounded_box(spec["size"], radii, p),
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ["rounded_cross", "rounded_cross_scaled"])
def test_rounded_cross_matches_brute_force(name, rng):
    spec = CURVED[name]
    f = field(spec)
    p = sample_points(f, 4000, rng)
    ref = brute_rounded_cross(spec["h"], spec.get("radius", 1.0), p)
    np.testing.assert_allclose(f.distance(p), ref, rtol=0, atol=1e-12)


@pytest.mark.parametrize("outline", [L_SHAPE, U_SHAPE, COMB, random_star_polygon(40, 1),
                                     random_star_polygon(300, 2)],
                         ids=["L", "U", "comb", "star40", "star300"])
@pytest.mark.parametrize("winding", ["ccw", "cw"])
def test_polygon_matches_brute_force_concave(outline, winding, rng):
    pts = outline if winding == "ccw" else outline[::-1]
    f = field({"type": "polygon", "points": pts.tolist()})
    p = np.concatenate([sample_points(f, 3000, rng), near_boundary_points(outline, rng, 5)])
    d, g = f.evaluate(p)
    d_ref, g_ref = brute_polygon(pts, p)
    np.testing.assert_allclose(d, d_ref, rtol=0, atol=1e-12)
    far = np.abs(d_ref) > 1e-6
    np.testing.assert_allclose(g[far], g_ref[far], rtol=0, atol=1e-8)
    # Chunking (300 edges: 54 points per chunk) does not change any row.
    d_single = np.array([f.distance(q[None])[0] for q in p[:50]])
    np.testing.assert_array_equal(d_single, d[:50])


# --------------------------------------------------------------------------------------
# Signs, hand-computed values, degenerate points, bounds
# --------------------------------------------------------------------------------------

SIGNS = [
    ({"type": "rounded_box", "size": [2.0, 1.0], "radii": 0.4}, [[0, 0], [0.9, 0.0], [0.0, 0.45]],
     [[0.99, 0.49], [1.1, 0], [0, 0.6]]),
    ({"type": "oriented_box", "a": [0, 0], "b": [2, 2], "thickness": 0.5},
     [[1, 1], [0.1, 0.1], [1.9, 1.9]], [[0, 2], [-0.1, -0.1], [2.1, 2.1]]),
    ({"type": "rhombus", "size": [4.0, 2.0]}, [[1.9, 0], [0, 0.9], [-1, 0.4]], [[1.1, 0.5], [0, 1.1]]),
    ({"type": "trapezoid", "bottom_width": 4.0, "top_width": 2.0, "height": 2.0},
     [[1.9, -0.9], [-0.9, 0.9]], [[1.9, 0.9], [0, 1.1], [0, -1.1]]),
    ({"type": "parallelogram", "width": 2.0, "height": 1.0, "skew": 1.0},
     [[1.4, 0.45], [-1.4, -0.45]], [[-1.4, 0.45], [1.4, -0.45]]),
    ({"type": "equilateral_triangle", "side": 2.0}, [[0, 1.1], [0.9, -0.5]], [[0, 1.2], [0.6, 0.5]]),
    ({"type": "isosceles_triangle", "width": 2.0, "height": 2.0}, [[0, 0.9], [0.9, -0.9]],
     [[0.2, 0.8], [0, -1.1]]),
    ({"type": "triangle", "points": [[0, 0], [0, 3], [4, 0]]}, [[1, 1], [3.9, 0.01]],
     [[2.1, 1.5], [-0.01, 1]]),
    ({"type": "pentagon", "radius": 1.0}, [[0, 0.99], [0, -1.2]], [[0, 1.01], [0, -1.25]]),
    ({"type": "hexagon", "radius": 1.0}, [[1.15, 0], [0, 0.99]], [[1.16, 0], [0, 1.01]]),
    ({"type": "octagon", "radius": 1.0}, [[0.99, 0], [0.7, 0.7]], [[1.01, 0], [0.72, 0.72]]),
    ({"type": "hexagram", "radius": 1.0}, [[0, 1.99], [1.0, 0.0]], [[0, 2.01], [1.2, 0.0]]),
    ({"type": "star", "radius": 1.0, "points": 5, "m": 3.0}, [[0, 0.99], [0, -0.3]],
     [[0, 1.01], [0, -0.5]]),
    ({"type": "cross", "size": [3.0, 1.0]}, [[1.4, 0.4], [0.4, 1.4], [-1.4, -0.4]],
     [[0.6, 0.6], [1.6, 0], [-0.6, -0.6]]),
    ({"type": "rounded_cross", "h": 0.5}, [[0.95, 0.0], [0.0, 0.45], [0.2, 0.2]],
     [[1.05, 0.0], [0.5, 0.3], [-0.5, -0.3]]),
    ({"type": "polygon", "points": U_SHAPE.tolist()}, [[0.5, 2.5], [2.5, 2.5], [1.5, 0.5]],
     [[1.5, 2.0], [3.5, 1.0], [1.5, 1.01]]),
    ({"type": "half_plane", "normal": [0.0, 2.0], "distance": 1.0}, [[5, 0.9], [-9, -3]],
     [[5, 1.1], [0, 3]]),
]


@pytest.mark.parametrize("spec, inside, outside", SIGNS, ids=[s[0]["type"] for s in SIGNS])
def test_sign_at_known_points(spec, inside, outside):
    f = field(spec)
    assert np.all(f.distance(np.array(inside, float)) < 0)
    assert np.all(f.distance(np.array(outside, float)) > 0)


K_RC = 0.5 * (0.5 + 2.0)   # rounded cross h = 0.5: circle radius and centre height
VALUES = [
    # spec, point, distance, gradient (None: not a single well-defined direction)
    ({"type": "rounded_box", "size": [4.0, 2.0], "radii": [0.5, 0.2, 0.0, 1.0]},
     [3.0, 0.0], 1.0, [1, 0]),
    ({"type": "rounded_box", "size": [4.0, 2.0], "radii": [0.5, 0.2, 0.0, 1.0]},
     [2.5, 1.5], S2 - 0.5, [1 / S2, 1 / S2]),
    ({"type": "rounded_box", "size": [4.0, 2.0], "radii": [0.5, 0.2, 0.0, 1.0]},
     [-3.0, -2.0], S2, [-1 / S2, -1 / S2]),
    ({"type": "rounded_box", "size": [4.0, 2.0], "radii": [0.5, 0.2, 0.0, 1.0]},
     [2.0, -1.0], S2 - 1.0, [1 / S2, -1 / S2]),
    ({"type": "oriented_box", "a": [0, 0], "b": [2, 2], "thickness": 1.0},
     [0.0, 2.0], S2 - 0.5, [-1 / S2, 1 / S2]),
    ({"type": "oriented_box", "a": [0, 0], "b": [2, 2], "thickness": 1.0},
     [-1.0, -1.0], S2, [-1 / S2, -1 / S2]),
    ({"type": "rhombus", "size": [4.0, 2.0]}, [0.0, 0.0], -2 / math.sqrt(5), [1 / 5 ** 0.5, 2 / 5 ** 0.5]),
    ({"type": "rhombus", "size": [4.0, 2.0]}, [3.0, 0.0], 1.0, [1, 0]),
    ({"type": "rhombus", "size": [4.0, 2.0]}, [-2.0, -1.0], 2 / math.sqrt(5),
     [-1 / 5 ** 0.5, -2 / 5 ** 0.5]),
    ({"type": "trapezoid", "bottom_width": 4.0, "top_width": 2.0, "height": 2.0},
     [0.0, 0.2], -0.8, [0, 1]),
    ({"type": "trapezoid", "bottom_width": 4.0, "top_width": 2.0, "height": 2.0},
     [3.0, -1.0], 1.0, [1, 0]),
    ({"type": "parallelogram", "width": 2.0, "height": 1.0, "skew": 1.0},
     [0.0, 0.0], -0.5, None),
    ({"type": "parallelogram", "width": 2.0, "height": 1.0, "skew": 1.0},
     [2.0, 1.0], math.sqrt(0.5), [1 / S2, 1 / S2]),
    ({"type": "equilateral_triangle", "side": 2.0}, [0.0, 0.0], -1 / S3, None),
    ({"type": "equilateral_triangle", "side": 2.0}, [0.0, 2 / S3 + 1], 1.0, [0, 1]),
    ({"type": "isosceles_triangle", "width": 2.0, "height": 2.0}, [0.0, 0.0], -1 / math.sqrt(5),
     None),
    ({"type": "isosceles_triangle", "width": 2.0, "height": 2.0}, [0.0, -2.0], 1.0, [0, -1]),
    ({"type": "triangle", "points": [[0, 0], [4, 0], [0, 3]]}, [1.0, 1.0], -1.0, None),
    ({"type": "triangle", "points": [[0, 0], [0, 3], [4, 0]]}, [-1.0, -1.0], S2,
     [-1 / S2, -1 / S2]),
    ({"type": "triangle", "points": [[0, 0], [0, 3], [4, 0]]}, [4.0, 3.0], 12 / 5, [0.6, 0.8]),
    ({"type": "pentagon", "radius": 1.0}, [0.0, 2.0], 1.0, [0, 1]),
    ({"type": "pentagon", "radius": 1.0}, [0.0, -1 / math.cos(math.pi / 5) - 1.0], 1.0, [0, -1]),
    ({"type": "hexagon", "radius": 1.0}, [3.0, 0.0], 3.0 - 2 / S3, [1, 0]),
    ({"type": "hexagon", "radius": 1.0}, [0.0, -0.25], -0.75, [0, -1]),
    ({"type": "octagon", "radius": 1.0}, [2.0, 2.0], 2 * S2 - 1, [1 / S2, 1 / S2]),
    ({"type": "octagon", "radius": 1.0}, [-0.5, 0.0], -0.5, [-1, 0]),
    # The centre's nearest boundary points are the six inner corners (the feet of the
    # perpendiculars to the edge lines, at distance 1, lie inside the other triangle).
    ({"type": "hexagram", "radius": 1.0}, [0.0, 0.0], -2 / S3, None),
    ({"type": "hexagram", "radius": 1.0}, [0.0, 3.0], 1.0, [0, 1]),
    # 0.5 beyond an inner corner on its bisector; the edges leave it at +-60 degrees.
    ({"type": "hexagram", "radius": 1.0}, [2 / S3 + 0.5, 0.0], 0.25 * S3, None),
    ({"type": "hexagram", "radius": 1.0}, [S3, 1.5], 0.5, [0, 1]),
    # For m > 2 the centre is nearest the inner corners, at r sin(pi/m - pi/n) / sin(pi/m).
    ({"type": "star", "radius": 1.0, "points": 5, "m": 3.0}, [0.0, 0.0],
     -math.sin(math.pi / 3 - math.pi / 5) / math.sin(math.pi / 3), None),
    ({"type": "star", "radius": 1.0, "points": 5, "m": 3.0}, [0.0, 2.0], 1.0, [0, 1]),
    ({"type": "star", "radius": 2.0, "points": 4, "m": 2.0}, [0.5, 0.5], -(S2 - 0.5 * S2),
     [1 / S2, 1 / S2]),
    ({"type": "cross", "size": [4.0, 1.0]}, [0.0, 0.0], -math.sqrt(0.5), None),
    ({"type": "cross", "size": [4.0, 1.0]}, [1.0, 0.1], -0.4, [0, 1]),
    ({"type": "cross", "size": [4.0, 1.0]}, [3.0, 0.0], 1.0, [1, 0]),
    ({"type": "cross", "size": [4.0, 1.0]}, [1.0, 2.0], 0.5, [1, 0]),
    # A stubby cross: the end face (0.15 away) is nearer than the inner corner; this is
    # where Quilez's sdCross would give sqrt(0.05^2 + 0.15^2).
    ({"type": "cross", "size": [2.0, 1.8]}, [0.85, 0.1], -0.15, [1, 0]),
    ({"type": "cross", "size": [4.0, 1.0], "rounding": -0.1}, [3.0, 0.0], 0.9, [1, 0]),
    ({"type": "rounded_cross", "h": 0.5}, [0.0, 0.0], K_RC - math.hypot(1.0, K_RC), None),
    ({"type": "rounded_cross", "h": 0.5}, [2.0, 0.0], 1.0, [1, 0]),
    ({"type": "rounded_cross", "h": 0.5}, [0.0, -1.5], 1.0, [0, -1]),
    ({"type": "rounded_cross", "h": 0.5, "radius": 3.0}, [0.0, 0.0],
     3.0 * (K_RC - math.hypot(1.0, K_RC)), None),
    ({"type": "polygon", "points": L_SHAPE.tolist()}, [1.6, 1.2], 0.2, [0, 1]),
    ({"type": "polygon", "points": L_SHAPE[::-1].tolist()}, [0.9, 0.9], -0.1 * S2,
     [1 / S2, 1 / S2]),
    ({"type": "polygon", "points": L_SHAPE.tolist()}, [3.0, 0.5], 1.0, [1, 0]),
    ({"type": "half_plane", "normal": [3.0, 4.0], "distance": 2.0}, [3.0, 4.0], 3.0, [0.6, 0.8]),
]


@pytest.mark.parametrize("spec, point, value, grad", VALUES,
                         ids=[f"{v[0]['type']}-{i}" for i, v in enumerate(VALUES)])
def test_exact_values(spec, point, value, grad):
    d, g = field(spec).evaluate(np.array([point], dtype=float))
    np.testing.assert_allclose(d, [value], rtol=0, atol=1e-12)
    if grad is not None:
        np.testing.assert_allclose(g[0], grad, rtol=0, atol=1e-12)


def star_corners(r, n, m):
    outline = star_outline(r, n, m)
    return outline[::2], outline[1::2]


# spec, points inside on a medial axis (centres, diagonals, bisectors), convex vertices,
# reflex vertices.
DEGENERATE = [
    ({"type": "rounded_box", "size": [2.0, 2.0], "radii": 0.5}, [[0, 0], [0.5, 0.5], [0.2, -0.2]],
     [], []),
    ({"type": "rounded_box", "size": [3.0, 1.0], "radii": 0.5}, [[0, 0], [1.0, 0.0], [-1.0, 0.0]],
     [], []),
    ({"type": "oriented_box", "a": [0, 0], "b": [2, 2], "thickness": 1.0}, [[1, 1]],
     oriented_box_outline([0, 0], [2, 2], 1.0), []),
    ({"type": "rhombus", "size": [4.0, 2.0]}, [[0, 0], [1.0, 0.0], [0.0, -0.3]],
     [[2, 0], [0, 1], [-2, 0], [0, -1]], []),
    ({"type": "trapezoid", "bottom_width": 4.0, "top_width": 2.0, "height": 2.0}, [[0, 0]],
     [[-2, -1], [2, -1], [1, 1], [-1, 1]], []),
    ({"type": "parallelogram", "width": 2.0, "height": 1.0, "skew": 1.0}, [[0, 0]],
     [[-1.5, -0.5], [0.5, -0.5], [1.5, 0.5], [-0.5, 0.5]], []),
    ({"type": "equilateral_triangle", "side": 2.0}, [[0, 0], [0, 0.5]],
     [[0, 2 / S3], [-1, -1 / S3], [1, -1 / S3]], []),
    ({"type": "isosceles_triangle", "width": 2.0, "height": 2.0}, [[0, 0]],
     [[0, 1], [-1, -1], [1, -1]], []),
    ({"type": "triangle", "points": [[0, 0], [0, 3], [4, 0]]}, [[1, 1]],
     [[0, 0], [0, 3], [4, 0]], []),
    ({"type": "pentagon", "radius": 1.0}, [[0, 0], [0, -0.5]],
     regular(5, 1 / math.cos(math.pi / 5), 54.0), []),
    ({"type": "hexagon", "radius": 1.0}, [[0, 0], [0.3, 0.0]], regular(6, 2 / S3, 0.0), []),
    ({"type": "octagon", "radius": 1.0}, [[0, 0], [0.3, 0.3]],
     regular(8, 1 / math.cos(math.pi / 8), 22.5), []),
    ({"type": "hexagram", "radius": 1.0}, [[0, 0], [0.5, 0.0]], hexagram_outline(1.0)[1::2],
     hexagram_outline(1.0)[::2]),
    ({"type": "star", "radius": 1.0, "points": 5, "m": 3.0}, [[0, 0], [0, 0.3]],
     *star_corners(1.0, 5, 3.0)),
    ({"type": "star", "radius": 1.0, "points": 6, "m": 2.0}, [[0, 0]],
     star_corners(1.0, 6, 2.0)[0], []),
    ({"type": "cross", "size": [4.0, 1.0]}, [[0, 0], [1.0, 0.0], [0.0, -1.0]],
     cross_outline(4.0, 1.0)[[0, 1, 3, 4, 6, 7, 9, 10]],
     cross_outline(4.0, 1.0)[[2, 5, 8, 11]]),
    ({"type": "rounded_cross", "h": 0.5}, [[0, 0], [0.3, 0.0], [0.0, 0.2]],
     [[1, 0], [0, 0.5], [-1, 0], [0, -0.5]], []),
    ({"type": "polygon", "points": U_SHAPE[::-1].tolist()}, [[0.5, 1.5], [1.5, 0.5], [0.5, 0.5]],
     U_SHAPE[[0, 1, 2, 3, 6, 7]], U_SHAPE[[4, 5]]),
]


@pytest.mark.parametrize("spec, medial, convex, reflex", DEGENERATE,
                         ids=[s[0]["type"] for s in DEGENERATE])
def test_degenerate_points_give_deterministic_unit_gradients(spec, medial, convex, reflex, rng):
    f = field(spec)
    p = np.concatenate([np.reshape(np.asarray(x, float), (-1, 2)) for x in (medial, convex, reflex)])
    d, g = f.evaluate(p)
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(g))
    np.testing.assert_allclose(np.linalg.norm(g, axis=1), 1.0, atol=1e-12)
    # The same point gives the same answer alone, repeated, or among others.
    noise = sample_points(f, 7, rng)
    batch = np.concatenate([noise, p[::-1], noise, p])
    d2, g2 = f.evaluate(batch)
    np.testing.assert_array_equal(d2[-len(p):], d)
    np.testing.assert_array_equal(g2[-len(p):], g)
    np.testing.assert_array_equal(d2[7:7 + len(p)], d[::-1])
    np.testing.assert_array_equal(g2[7:7 + len(p)], g[::-1])
    for q in p:
        dq, gq = f.evaluate(q[None])
        row = np.flatnonzero(np.all(p == q, axis=1))[0]
        assert dq[0] == d[row] and np.array_equal(gq[0], g[row])
    # g is the gradient of one branch: moving eps along it raises f by exactly eps from
    # a medial point inside and from a convex vertex; at a reflex vertex g lies between
    # the two edge normals: forward does not enter the shape, backward does.
    eps = 1e-4
    n_med, n_cvx = len(medial), len(convex)
    step = f.distance(p + eps * g) - d
    np.testing.assert_allclose(step[:n_med + n_cvx], eps, rtol=0, atol=1e-10)
    np.testing.assert_allclose(d[n_med:], 0.0, atol=1e-12)
    reflex_p, reflex_g = p[n_med + n_cvx:], g[n_med + n_cvx:]
    assert np.all(f.distance(reflex_p + eps * reflex_g) >= -1e-12)
    assert np.all(f.distance(reflex_p - eps * reflex_g) < -0.1 * eps)


@pytest.mark.parametrize("name", list(ALL_SPECS))
def test_bounds_contain_the_shape_and_touch_it(name):
    f = field(ALL_SPECS[name])
    x0, y0, x1, y1 = f.bounds()
    assert x0 < x1 and y0 < y1
    n = 20001
    t = np.linspace(0.0, 1.0, n)
    sides = [np.stack([np.full(n, x), y0 + t * (y1 - y0)], axis=1) for x in (x0, x1)]
    sides += [np.stack([x0 + t * (x1 - x0), np.full(n, y)], axis=1) for y in (y0, y1)]
    spacing = max(x1 - x0, y1 - y0) / (n - 1)
    for side in sides:
        d = f.distance(side)
        assert d.min() >= -1e-12, "part of the shape lies outside its bounds"
        assert d.min() <= spacing, "the bounds are not tight"


def test_half_plane_values_gradient_and_bounds(rng):
    p = rng.normal(scale=5.0, size=(1000, 2))
    f = field({"type": "half_plane", "normal": [-1.0, 2.0], "distance": 0.5})
    n = np.array([-1.0, 2.0]) / math.sqrt(5.0)
    d, g = f.evaluate(p)
    np.testing.assert_allclose(d, p @ n - 0.5, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(g, np.broadcast_to(n, p.shape))
    assert f.exact
    np.testing.assert_array_equal(f.bounds(), [-np.inf, -np.inf, np.inf, np.inf])
    ground = field({"type": "half_plane", "normal": [0.0, 1.0], "distance": -2.0})
    np.testing.assert_array_equal(ground.bounds(), [-np.inf, -np.inf, np.inf, -2.0])
    wall = field({"type": "half_plane", "normal": [-3.0, 0.0], "distance": 1.0})
    np.testing.assert_array_equal(wall.bounds(), [-1.0, -np.inf, np.inf, np.inf])
    np.testing.assert_allclose(wall.distance(np.array([[-1.0, 7.0], [-4.0, 0.0]])), [0.0, 3.0])


# --------------------------------------------------------------------------------------
# The rounded cross (cross with rounding != 0) is a bound, not exact
# --------------------------------------------------------------------------------------

def offset_curve_samples(outline: np.ndarray, level: float, per_unit: int = 400) -> np.ndarray:
    """Points where the exact polygon SDF equals ``level``: candidates offset from every
    edge along its normal and on circles around every vertex, kept when on the level."""
    exact = field({"type": "polygon", "points": outline.tolist()})
    cands = []
    for a, b in zip(outline, np.roll(outline, -1, axis=0)):
        e = b - a
        n = np.array([e[1], -e[0]]) / np.linalg.norm(e)
        t = np.linspace(0, 1, int(per_unit * np.linalg.norm(e)) + 2)[:, None]
        cands += [a + t * e + level * n, a + t * e - level * n]
    ang = np.linspace(0, 2 * np.pi, int(per_unit * 2 * np.pi * abs(level)) + 2)
    circle = abs(level) * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    cands += [v + circle for v in outline]
    cands = np.concatenate(cands)
    return cands[np.abs(exact.distance(cands) - level) < 1e-12]


@pytest.mark.parametrize("rounding", [-0.2, 0.2])
def test_cross_with_rounding_is_a_bound(rounding, rng):
    outline = cross_outline(3.0, 1.0)
    f = field({"type": "cross", "size": [3.0, 1.0], "rounding": rounding})
    assert not f.exact
    zero_set = offset_curve_samples(outline, -rounding)
    p = sample_points(f, 600, rng)
    d = f.distance(p)
    nearest = np.min(np.linalg.norm(p[:, None] - zero_set[None], axis=2), axis=1)
    assert np.all(np.abs(d) <= nearest + 1e-12), "|f| exceeds the distance to the shape"
    # The sign is the shape's: inside iff within -rounding of the sharp cross.
    exact = field({"type": "cross", "size": [3.0, 1.0]})
    np.testing.assert_array_equal(d < 0, exact.distance(p) < -rounding)


def test_cross_rounding_underestimates_where_expected():
    # Grown by 0.1: inside, near an inner corner, the true distance is to the grown
    # shape's sharp inner corner (0.6, 0.6); f says |f| = delta sqrt(2) + 0.1 only.
    grown = field({"type": "cross", "size": [3.0, 1.0], "rounding": -0.1})
    delta = 0.1
    p = np.array([[0.5 - delta, 0.5 - delta]])
    np.testing.assert_allclose(grown.distance(p), [-(delta * S2 + 0.1)], atol=1e-12)
    assert (delta + 0.1) * S2 > delta * S2 + 0.1
    # Thinned by 0.1: outside an outer corner the true distance is to the sharp corner
    # (1.4, 0.4) of the thinned bar; f says delta sqrt(2) + 0.1.
    thinned = field({"type": "cross", "size": [3.0, 1.0], "rounding": 0.1})
    p = np.array([[1.5 + delta, 0.5 + delta]])
    np.testing.assert_allclose(thinned.distance(p), [delta * S2 + 0.1], atol=1e-12)


# --------------------------------------------------------------------------------------
# Bad parameters: one SpecError naming the key path
# --------------------------------------------------------------------------------------

BAD = [
    ({"type": "rounded_box", "size": [2.0, 1.0], "radii": [0.1, 0.6, 0.0, 0.0]},
     "field.radii[1]: must be between 0 and 0.5 (half the smaller side), got 0.6"),
    ({"type": "rounded_box", "size": [2.0, 1.0], "radii": 0.7},
     "field.radii: must be between 0 and 0.5"),
    ({"type": "rounded_box", "size": [2.0, 1.0], "radii": [0.1, 0.2]},
     "field.radii: must be a number or 4 corner radii"),
    ({"type": "rounded_box", "size": [2.0, 1.0], "radii": [0.1, -0.2, 0, 0]},
     "field.radii[1]: must be >= 0, got -0.2"),
    ({"type": "rounded_box", "size": [2.0, 1.0]}, "field.radii: is required for 'rounded_box'"),
    ({"type": "oriented_box", "a": [1, 1], "b": [1, 1], "thickness": 0.5},
     "field.b: must differ from a = [1.0, 1.0] (zero length)"),
    ({"type": "oriented_box", "a": [0, 0], "b": [1, 1], "thickness": 0.0},
     "field.thickness: must be > 0, got 0"),
    ({"type": "rhombus", "size": [2.0, -1.0]}, "field.size[1]: must be > 0, got -1"),
    ({"type": "trapezoid", "bottom_width": 0.0, "top_width": 0.0, "height": 1.0},
     "field.top_width: bottom_width and top_width cannot both be 0"),
    ({"type": "trapezoid", "bottom_width": -1.0, "top_width": 1.0, "height": 1.0},
     "field.bottom_width: must be >= 0, got -1"),
    ({"type": "parallelogram", "width": 1.0, "height": 1.0, "skew": float("inf")},
     "field.skew: must be finite, got inf"),
    ({"type": "equilateral_triangle", "radius": 1.0},
     "field.radius: unknown key for 'equilateral_triangle'"),
    ({"type": "triangle", "points": [[0, 0], [1, 1], [2, 2]]},
     "field.points: all points are collinear (zero area)"),
    ({"type": "triangle", "points": [[0, 0], [1, 0], [1, 0]]}, "field.points[2]: repeats"),
    ({"type": "triangle", "points": [[0, 0], [1, 0], [1, 1], [0, 1]]},
     "field.points: needs exactly 3 points, got 4"),
    ({"type": "triangle", "points": [[0, 0], [1, 0]]}, "field.points: needs at least 3 points"),
    ({"type": "pentagon", "radius": 0}, "field.radius: must be > 0, got 0"),
    ({"type": "hexagram", "radius": "1"}, "field.radius: must be a number, got '1'"),
    ({"type": "star", "radius": 1.0, "points": 2, "m": 2.0}, "field.points: must be >= 3, got 2"),
    ({"type": "star", "radius": 1.0, "points": 5.0, "m": 2.0},
     "field.points: must be an integer, got 5.0"),
    ({"type": "star", "radius": 1.0, "points": 5, "m": 5.0},
     "field.m: must satisfy 2 <= m < points = 5, got 5"),
    ({"type": "star", "radius": 1.0, "points": 5, "m": 1.5},
     "field.m: must satisfy 2 <= m < points = 5, got 1.5"),
    ({"type": "cross", "size": [3.0, 1.0], "rounding": 0.5},
     "field.rounding: must be < 0.5 (half the thickness), got 0.5"),
    ({"type": "rounded_cross", "h": 1.5}, "field.h: must be <= 1, got 1.5"),
    ({"type": "rounded_cross", "h": 0.0}, "field.h: must be > 0, got 0"),
    ({"type": "polygon", "points": [[0, 0], [2, 0], [0, 2], [2, 2]]},
     "field.points: edges 1 and 3 cross (self-intersecting polygon)"),
    ({"type": "polygon", "points": [[0, 0], [1, 0], [float("nan"), 1]]},
     "field.points[2][0]: must be finite, got nan"),
    ({"type": "half_plane", "normal": [0.0, 0.0]},
     "field.normal: must not be the zero vector, got [0.0, 0.0]"),
    ({"type": "half_plane", "normal": [0.0, 1.0], "distnace": 1.0},
     "field.distnace: unknown key for 'half_plane' (did you mean 'distance'?)"),
]


@pytest.mark.parametrize("spec, message", BAD, ids=[f"{b[0]['type']}-{i}" for i, b in enumerate(BAD)])
def test_bad_parameters_name_the_key_path(spec, message):
    with pytest.raises(sdfphys.SpecError) as err:
        field(spec)
    assert str(err.value).startswith(message), str(err.value)


def test_errors_are_value_errors_when_constructed_directly():
    with pytest.raises(ValueError):
        PRIMITIVES["triangle"](points=[[0, 0], [1, 1], [3, 3]])
    with pytest.raises(ValueError):
        PRIMITIVES["half_plane"](normal=[0.0, 0.0])
