"""The sweeps' index helpers (``sdfphys.solver.pair_rows``): unsigned views and counts."""

from __future__ import annotations

import numpy as np

from sdfphys.solver.pair_rows import pair_bodies, pair_count, unsigned


def test_unsigned_is_a_view_of_the_same_indices():
    indices = np.array([0, 3, 7, 2**40], np.int64)
    view = unsigned(indices)
    assert view.dtype == np.uint64
    np.testing.assert_array_equal(view, indices.astype(np.uint64))
    indices[1] = 5                                   # the same memory
    assert view[1] == 5


def test_pair_count_of_no_rows_is_zero_not_a_wrapped_minus_one():
    assert pair_count(np.zeros(0, np.int64)) == 0    # no pair_start at all
    assert pair_count(np.zeros(1, np.int64)) == 0    # [0]: no pairs
    assert pair_count(np.array([0, 2, 3], np.int64)) == 2


def test_pair_bodies_reads_a_pairs_rows_bodies_and_masses():
    pair_start = np.array([0, 2, 3], np.int64)
    body_a = np.array([0, 0, 1], np.int64)
    body_b = np.array([2, 2, 2], np.int64)
    inv_mass = np.array([1.0, 0.5, 0.0])
    inv_inertia = np.array([3.0, 2.0, 0.0])
    got = pair_bodies(np.uint64(1), unsigned(pair_start), unsigned(body_a),
                      unsigned(body_b), inv_mass, inv_inertia)
    assert got == (2, 3, 1, 2, 0.5, 2.0, 0.0, 0.0)
    assert pair_bodies(np.uint64(0), unsigned(pair_start), unsigned(body_a),
                       unsigned(body_b), inv_mass, inv_inertia)[:4] == (0, 2, 0, 2)
