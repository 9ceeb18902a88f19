"""Batched pair functions: one call for all of a query's pairs of a kind, whatever their
shapes, gives the contacts of a call per shape pair, to the bit."""

from __future__ import annotations

import numpy as np
import pytest
from oracles import Opaque

import sdfphys.collide as collide
from sdfphys.collide import _distinct, _narrowphase
from sdfphys.collide.narrowphase import BATCH_FUNCTIONS, collide_sdfs
from sdfphys.collide.shape_fields import ShapeFields
from sdfphys.settings import Settings
from sdfphys.shapes import SdfShape, shape_from_spec

#: Distinct sdf shapes, a bounded one before the unbounded ground (its pairs are solved
#: the other way round and flipped back), a smooth union whose far operand is skipped
#: batch by batch.
SDF_SPECS = [
    {"type": "sdf", "field": {"type": "star", "radius": 0.7, "points": 5, "m": 3.0}},
    {"type": "sdf", "field": {"type": "half_plane", "normal": [0.0, 1.0], "distance": 0.0}},
    {"type": "sdf", "field": {"type": "heart", "scale": 1.0}},
    {"type": "sdf", "field": {"op": "smooth_union", "k": 0.3, "of": [
        {"type": "box", "size": [1.6, 0.4]},
        {"type": "ellipse", "size": [0.6, 0.3], "offset": [1.2, 0.0]}]}},
    {"type": "sdf", "field": {"type": "moon", "radius": 0.6, "bite_radius": 0.5,
                              "distance": 0.35}},
    {"type": "sdf", "field": {"type": "circle", "radius": 0.4}},
]
#: Shapes of the other kinds: circles and meshes (a box, a concave L) meet the sdf shapes
#: in the circle-sdf and mesh-sdf batches.
OTHER_SPECS = [
    {"type": "circle", "radius": 0.25},
    {"type": "circle", "radius": 0.4},
    {"type": "box", "size": [0.6, 0.3]},
    {"type": "polygon", "points": [[-0.5, -0.5], [0.5, -0.5], [0.5, -0.2], [-0.2, -0.2],
                                   [-0.2, 0.5], [-0.5, 0.5]]},
]


def _scene(rng, n_bodies: int, others: bool = False):
    """Shapes, each body's shape (B,) and poses (B, 3): bodies of every shape (two or more
    of most, so that groups hold several pairs), heaped near the ground at y = 0; with
    ``others``, circles and meshes among them."""
    specs = SDF_SPECS + (OTHER_SPECS if others else [])
    shapes = [shape_from_spec(spec, f"shape {k}") for k, spec in enumerate(specs)]
    body_shape = np.r_[1, rng.choice(np.delete(np.arange(len(specs)), 1), n_bodies - 1)]
    pose = np.column_stack([rng.uniform(-1.5, 1.5, n_bodies), rng.uniform(-0.3, 1.2, n_bodies),
                            rng.uniform(-np.pi, np.pi, n_bodies)])
    pose[0] = 0.0
    return shapes, body_shape, pose


def _sorted(c):
    order = np.lexsort((c.feature, c.body_b, c.body_a))
    return [np.asarray(x)[order] for x in (c.body_a, c.body_b, c.point, c.normal, c.depth,
                                           c.feature)]


@pytest.mark.parametrize("seed", [3, 11, 29])
def test_pairs_of_a_kind_in_one_call_equal_a_call_per_shape_pair(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    shapes, body_shape, pose = _scene(rng, 24, others=True)
    distinct, canonical = _distinct(shapes)
    i, j = np.triu_indices(len(body_shape), 1)
    pairs = np.column_stack([i, j])
    reach = rng.uniform(0.0, 0.05, len(body_shape))
    settings = Settings()
    calls = {kinds: [] for kinds in BATCH_FUNCTIONS}
    for kinds, batch in list(BATCH_FUNCTIONS.items()):
        monkeypatch.setitem(BATCH_FUNCTIONS, kinds,
                            lambda *args, _k=kinds, _f=batch: calls[_k].append(len(args[1]))
                            or _f(*args))
    together = _narrowphase(distinct, canonical[body_shape], pairs, pose, 0.02, reach, settings)
    for kinds, made in calls.items():               # all of a kind's pairs in one call
        assert len(made) == 1 and made[0] >= 2, kinds
    monkeypatch.setattr(collide, "_HAS_BATCH", np.zeros_like(collide._HAS_BATCH))
    apart = _narrowphase(distinct, canonical[body_shape], pairs, pose, 0.02, reach, settings)
    assert len(together) > 40 and len(np.unique(together.body_a * 100 + together.body_b)) > 20
    for mine, theirs in zip(_sorted(together), _sorted(apart), strict=True):
        np.testing.assert_array_equal(mine, theirs)


def test_a_group_of_pairs_equals_the_numpy_path():
    """The compiled batch of one shape pair against the numpy path of every stage
    (fields that do not compile): the same contacts, to round-off."""
    rng = np.random.default_rng(5)
    shapes, _, _ = _scene(rng, 2)
    settings = Settings()
    for a, b in ((0, 2), (2, 3), (0, 1), (4, 5)):
        n = 6
        pose_a = np.column_stack([rng.uniform(-0.2, 0.2, (n, 2)), rng.uniform(-3, 3, n)])
        pose_b = pose_a + np.column_stack([rng.uniform(-0.9, 0.9, (n, 2)), rng.uniform(-3, 3, n)])
        if a == 1 or b == 1:
            pose_b[:, 1] = rng.uniform(-0.2, 0.6, n)
        body_a, body_b = np.arange(n), np.arange(n, 2 * n)
        fast = collide_sdfs(shapes[a], shapes[b], body_a, body_b, pose_a, pose_b, 0.02, settings)
        slow_shapes = [SdfShape(Opaque(shapes[k].user_field)) for k in (a, b)]
        slow = collide_sdfs(*slow_shapes, body_a, body_b, pose_a, pose_b, 0.02, settings)
        assert len(fast) > 0
        for mine, theirs in zip(_sorted(fast), _sorted(slow), strict=True):
            np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-12)


def test_shape_fields_mark_the_fields_that_do_not_compile():
    shapes = [shape_from_spec(spec, "s") for spec in SDF_SPECS[:3]]
    shapes[1] = SdfShape(Opaque(shapes[1].user_field))
    fields = ShapeFields.of(shapes)
    np.testing.assert_array_equal(fields.program, [0, -1, 1])
    assert len(fields.table.start) == 3
    np.testing.assert_array_equal(fields.radius, [s.radius for s in shapes])


def test_descent_blocks_hold_whole_runs():
    """The compiled descent's blocks (``_compiled_descent._block_ends``): whole runs as
    many as fit, a run longer than a block cut from its own first start."""
    from sdfphys.collide._compiled_descent import _block_ends

    bounds = np.array([0, 3, 5, 12, 13], np.int64)              # runs of 3, 2, 7, 1 starts
    assert _block_ends(bounds, 4).tolist() == [3, 5, 9, 13]     # run 2: 5..9, then 9..13
    assert _block_ends(bounds, 5).tolist() == [5, 10, 13]
    assert _block_ends(np.array([0, 10], np.int64), 4).tolist() == [4, 8, 10]
    assert _block_ends(np.array([0], np.int64), 4).tolist() == []


def test_fields_evaluated_by_shape_equal_a_call_per_shape():
    """``shape_fields.evaluate_by_shape``: points of interleaved shapes, each shape's in
    one batch of the table, as ``compiled.evaluate`` per shape (the same bits); a shape
    whose field does not compile takes the call per shape."""
    from sdfphys.collide.shape_fields import evaluate_by_shape
    from sdfphys.sdf import compiled

    rng = np.random.default_rng(4)
    shapes = [shape_from_spec(spec, "s") for spec in SDF_SPECS + OTHER_SPECS]
    shape = rng.integers(0, len(shapes), 300)
    points = rng.uniform(-1.5, 1.5, (300, 2))
    for fields in (ShapeFields.of(shapes),
                   ShapeFields.of(shapes[:2] + [SdfShape(Opaque(shapes[2].user_field))]
                                  + shapes[3:])):
        f, g = evaluate_by_shape(fields, shape, points)
        for s in range(len(shapes)):
            at = np.flatnonzero(shape == s)
            expected = compiled.evaluate(fields.shape_of[s].field, points[at])
            np.testing.assert_array_equal(f[at], expected[0])
            np.testing.assert_array_equal(g[at], expected[1])
