"""Broadphase: world AABBs contain the shapes, and sort-and-sweep equals brute force."""

import time

import numpy as np
import pytest

from sdfphys.collide.broadphase import _dense_pairs, candidate_pairs, world_bounds


def brute_force(bounds: np.ndarray, movable: np.ndarray) -> np.ndarray:
    """All pairs i < j with overlapping closed boxes and one movable body, O(n^2)."""
    lo, hi = bounds[:, None, :2], bounds[:, None, 2:]
    overlap = np.all((bounds[None, :, :2] <= hi) & (lo <= bounds[None, :, 2:]), axis=2)
    either = movable[:, None] | movable[None, :]
    i, j = np.nonzero(np.triu(overlap & either, k=1))
    return np.stack([i, j], axis=1).astype(np.int64)


def random_boxes(rng, n, world=20.0, size=1.0):
    lo = rng.uniform(0, world, (n, 2))
    return np.concatenate([lo, lo + rng.uniform(0.01, size, (n, 2))], axis=1)


@pytest.mark.parametrize("n", [0, 1, 2, 50, 700])
def test_sweep_equals_brute_force(rng, n):
    bounds = random_boxes(rng, n)
    movable = rng.random(n) < 0.7
    pairs = candidate_pairs(bounds, movable)
    assert pairs.dtype == np.int64 and pairs.shape[1] == 2
    np.testing.assert_array_equal(pairs, brute_force(bounds, movable))


def test_sweep_with_touching_and_duplicate_boxes(rng):
    base = np.array([[0.0, 0.0, 1.0, 1.0], [1.0, 1.0, 2.0, 2.0], [0.0, 0.0, 1.0, 1.0],
                     [2.0, 0.0, 3.0, 0.5], [1.0 + 1e-12, 0.0, 3.0, 1.0]])
    movable = np.array([True, False, True, True, False])
    np.testing.assert_array_equal(candidate_pairs(base, movable), brute_force(base, movable))


def test_unbounded_ground_pairs_with_every_crossing_movable_body(rng):
    n = 500
    bounds = random_boxes(rng, n, world=10.0)
    bounds[:, 1] -= 5.0
    bounds[:, 3] -= 5.0
    inf = np.inf
    ground = np.array([[-inf, -inf, inf, 0.0],      # half-plane y <= 0
                       [2.0, -inf, inf, inf],       # half-plane x >= 2
                       [-inf, -inf, inf, inf]])     # rotated half-plane: everything
    bounds = np.concatenate([bounds[:200], ground, bounds[200:]])
    movable = np.ones(len(bounds), bool)
    movable[200:203] = False
    movable[::7] = False
    pairs = candidate_pairs(bounds, movable)
    np.testing.assert_array_equal(pairs, brute_force(bounds, movable))
    with_floor = pairs[(pairs[:, 0] == 200) | (pairs[:, 1] == 200)]
    expected = np.nonzero(movable & (bounds[:, 1] <= 0.0))[0]
    np.testing.assert_array_equal(np.sort(with_floor.ravel()[with_floor.ravel() != 200]),
                                  expected)


def test_world_bounds_are_exact_for_rotated_boxes_and_circles(rng):
    n = 300
    half = rng.uniform(0.1, 2.0, (n, 2))
    local = np.concatenate([-half, half], axis=1)
    radius = np.hypot(half[:, 0], half[:, 1])
    position = rng.uniform(-10, 10, (n, 2))
    angle = rng.uniform(-7, 7, n)
    box = world_bounds(local, radius, position, angle, margin=0.01)
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])[None] * half[:, None, :]
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    world = np.stack([c * corners[..., 0] - s * corners[..., 1],
                      s * corners[..., 0] + c * corners[..., 1]], axis=2) + position[:, None]
    expected = np.concatenate([world.min(axis=1) - 0.01, world.max(axis=1) + 0.01], axis=1)
    np.testing.assert_allclose(box, expected, rtol=0, atol=1e-12)

    r = rng.uniform(0.1, 2.0, n)
    circle = world_bounds(np.stack([-r, -r, r, r], axis=1), r, position, angle)
    np.testing.assert_allclose(circle, np.concatenate([position - r[:, None],
                                                       position + r[:, None]], axis=1),
                               rtol=0, atol=1e-12)


def test_world_bounds_of_unbounded_fields():
    inf = np.inf
    local = np.array([[-inf, -inf, inf, 0.0]] * 4)
    radius = np.full(4, inf)
    position = np.array([[0.0, 1.0], [0.0, 1.0], [3.0, 0.0], [0.0, 0.0]])
    angle = np.array([0.0, np.pi, 0.5, -0.5 * np.pi])
    box = world_bounds(local, radius, position, angle)
    np.testing.assert_array_equal(box[0], [-inf, -inf, inf, 1.0])
    assert box[1, 1] == pytest.approx(1.0) and box[1, 3] == inf
    assert np.all(np.isinf(box[2]))
    assert box[3, 0] == -inf and box[3, 2] == pytest.approx(0.0)      # x <= 0
    assert not np.any(np.isnan(box))


def test_ten_thousand_bodies_build_pairs_in_a_few_ms(rng):
    n = 10_000
    bounds = random_boxes(rng, n, world=100.0)
    movable = np.ones(n, bool)
    candidate_pairs(bounds[:10], movable[:10])      # compile / load the cache
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        pairs = candidate_pairs(bounds, movable)
        best = min(best, time.perf_counter() - t0)
    print(f"\n10,000 bodies: {len(pairs)} pairs in {best * 1e3:.2f} ms")
    assert best < 0.02


def test_dense_cluster_overflows_the_first_guess(rng):
    bounds = random_boxes(rng, 120, world=1.0, size=2.0)      # nearly all overlap
    movable = rng.random(120) < 0.5
    pairs = candidate_pairs(bounds, movable)
    assert len(pairs) > 4 * 120 + 16
    np.testing.assert_array_equal(pairs, brute_force(bounds, movable))


def test_grid_with_crowded_cells_and_nan_boxes_equals_brute_force(rng):
    """Over SWEEP_BODIES bodies (the grid): a crowded corner where many boxes share
    cells (most candidates of a bucket rejected), mixed sizes, and NaN boxes, which
    overlap nothing."""
    bounds = np.concatenate([random_boxes(rng, 600, world=40.0),
                             random_boxes(rng, 300, world=3.0, size=0.3),
                             random_boxes(rng, 100, world=40.0, size=6.0)])
    bounds[rng.random(len(bounds)) < 0.02] = np.nan
    movable = rng.random(len(bounds)) < 0.8
    np.testing.assert_array_equal(candidate_pairs(bounds, movable),
                                  brute_force(bounds, movable))


def lattice(rng, rows, columns, side=1.0, origin=(0.0, 0.0), jitter=0.0):
    """Boxes of one side on a lattice of that pitch: neighbours touch along edges and
    at corners (closed boxes pair), as a settled pile's boxes nearly do."""
    y, x = np.mgrid[0:rows, 0:columns].astype(float)
    lo = np.stack([x.ravel(), y.ravel()], axis=1) * side + np.asarray(origin)
    lo += rng.uniform(-jitter, jitter, lo.shape)
    return np.concatenate([lo, lo + side], axis=1)


@pytest.mark.parametrize("origin", [(0.0, 0.0), (-3.7e5, 2.2e6)])
def test_dense_grid_finds_touching_lattice_pairs(rng, origin):
    """Boxes whose sides equal the largest side, touching at edges and corners on cell
    boundaries, near the origin and 10^6 m from it (the rounding of x / h): the dense
    grid takes them and finds every pair, including the walls and NaN boxes."""
    bounds = lattice(rng, 20, 30, origin=origin)
    inf = np.inf
    walls = np.array([[-inf, -inf, inf, origin[1] + 0.5], [np.nan] * 4,
                      [origin[0] + 29.5, -inf, inf, inf]])
    bounds = np.concatenate([bounds[:100], walls, bounds[100:]])
    movable = rng.random(len(bounds)) < 0.8
    dense, pairs = _dense_pairs(bounds, movable)
    assert dense
    np.testing.assert_array_equal(pairs, brute_force(bounds, movable))
    np.testing.assert_array_equal(candidate_pairs(bounds, movable), pairs)


def test_dense_grid_of_a_jittered_pile_equals_brute_force(rng):
    bounds = lattice(rng, 40, 25, side=1.04, jitter=0.3)
    bounds[:, 2:] -= rng.uniform(0.0, 0.1, (len(bounds), 2))
    movable = np.ones(len(bounds), bool)
    movable[:25] = False
    dense, pairs = _dense_pairs(bounds, movable)
    assert dense
    np.testing.assert_array_equal(pairs, brute_force(bounds, movable))


def test_dense_grid_big_boxes_of_every_kind_equal_brute_force(rng):
    """The dense grid's big boxes, tested against the cells their extent reaches
    (``_dense_big_pairs``): finite walls and a ground overlapping the pile's edge
    cells, a slab across its middle, big boxes wholly outside the occupied cells and
    overlapping each other, half-planes, an infinite box, inverted and NaN boxes
    (brute force), some of them immovable."""
    bounds = lattice(rng, 30, 30, side=1.02, jitter=0.2)
    inf, nan = np.inf, np.nan
    big = np.array([[-1.5, -1.5, 31.0, 0.3],          # ground, overlapping the first row
                    [-1.5, -1.5, -0.1, 40.0],         # left wall
                    [30.2, -1.5, 31.5, 40.0],         # right wall, touching the last column
                    [10.0, 14.7, 20.0, 15.3],         # a slab across the middle
                    [50.0, 50.0, 60.0, 60.0],         # outside, overlapping the next one
                    [55.0, 55.0, 70.0, 70.0],
                    [-inf, -inf, inf, -1.0],          # half-planes
                    [29.9, -inf, inf, inf],
                    [-inf, -inf, inf, inf],           # everything
                    [inf, inf, inf, inf],             # a box at infinity
                    [12.0, 5.0, 3.0, 9.0],            # inverted (x), pairs by the formula
                    [nan, 0.0, 5.0, 5.0]])
    bounds = np.concatenate([bounds[:200], big, bounds[200:]])
    movable = rng.random(len(bounds)) < 0.8
    movable[200:204] = False
    dense, pairs = _dense_pairs(bounds, movable)
    assert dense
    np.testing.assert_array_equal(pairs, brute_force(bounds, movable))


def test_sparse_or_mixed_boxes_take_the_hashed_grid(rng):
    """Boxes strewn over a world much larger than their cells, or many boxes far
    larger than the mean: the dense grid declines and the hashed grid gives the pairs."""
    sparse = random_boxes(rng, 400, world=5000.0, size=1.0)
    sparse[:100] = random_boxes(rng, 100, world=5.0, size=1.0)
    mixed = np.concatenate([random_boxes(rng, 300, world=20.0, size=0.5),
                            random_boxes(rng, 60, world=20.0, size=5.0)])
    for bounds in (sparse, mixed):
        movable = rng.random(len(bounds)) < 0.7
        assert not _dense_pairs(bounds, movable)[0]
        np.testing.assert_array_equal(candidate_pairs(bounds, movable),
                                      brute_force(bounds, movable))


@pytest.mark.parametrize("n", [40, 700])
def test_kept_pairs_equal_a_search_every_step(rng, n):
    """``PairCache`` over 60 steps of jittering, drifting and jumping boxes (sweep and
    grid sizes): each step's pairs equal ``candidate_pairs`` of that step's boxes, in
    order, whether the kept pairs served or a new search ran; bodies that become
    movable, NaN and infinite boxes and a change of body count among them."""
    from sdfphys.collide.broadphase import PairCache

    cache = PairCache()
    bounds = random_boxes(rng, n, world=15.0 if n > 100 else 6.0)
    movable = rng.random(n) < 0.7
    served = 0
    for step in range(60):
        moved = rng.random((len(bounds), 1)) < 0.9
        bounds = bounds + rng.normal(0.0, 0.0005, (len(bounds), 4)) * moved
        if step % 7 == 3:
            jump = rng.choice([-0.5, 0.5], 2)                  # one box jumps
            bounds[rng.integers(len(bounds))] += np.tile(jump, 2)
        if step % 11 == 5:
            movable[rng.integers(len(bounds))] = True          # a body wakes
        if step == 20:
            bounds[3] = np.nan
        if step == 25:
            bounds[3] = [-np.inf, -np.inf, np.inf, 0.2]
        if step == 40:
            bounds, movable = bounds[:-1], movable[:-1]        # a body removed
        before = cache.pairs
        pairs = cache.candidate_pairs(bounds, movable)
        served += cache.pairs is before
        np.testing.assert_array_equal(pairs, candidate_pairs(bounds, movable))
        np.testing.assert_array_equal(pairs, brute_force(bounds, movable))
    assert served > 20          # the kept pairs did serve most jitter-only steps


@pytest.mark.parametrize("side", [(1.3, 0.0), (-1.3, 0.0), (0.0, 1.3), (0.0, -1.3)])
@pytest.mark.parametrize("n", [2, 300])
def test_kept_pairs_see_a_box_leave_its_grown_box(side, n):
    """A box 0.3 m from another (beyond the 0.1 m skin) moves 0.35 m toward it, from
    each side: it leaves its grown box through that side, and the pair is found (the
    other boxes, if any, far away)."""
    from sdfphys.collide.broadphase import PairCache

    bounds = np.array([[0.0, 0.0, 1.0, 1.0], [side[0], side[1], side[0] + 1.0,
                                                 side[1] + 1.0]])
    far = np.array([[100.0 + 2.0 * k, 100.0, 101.0 + 2.0 * k, 101.0] for k in range(n - 2)])
    bounds = np.concatenate([bounds, far.reshape(-1, 4)])
    movable = np.ones(n, bool)
    cache = PairCache()
    assert len(cache.candidate_pairs(bounds, movable)) == 0
    bounds[1] -= 0.35 * np.sign(np.array(side + side))
    np.testing.assert_array_equal(cache.candidate_pairs(bounds, movable), [[0, 1]])
