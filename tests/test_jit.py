"""``sdfphys._jit.njit``: kernels compiled without reference counts (``refcounts=False``)."""

from __future__ import annotations

import numpy as np
import pytest
from numba.core.errors import TypingError

from sdfphys._jit import njit
from sdfphys.collide._compiled_field_contacts import _h
from sdfphys.collide._descent_kernels import _most_candidates
from sdfphys.collide.polygons import clip_pair
from sdfphys.sdf.compiled import run
from sdfphys.sdf.primitive_kernels import _shape
from sdfphys.solver.joint_direct import _coupling, _point_pair, _row_geometry
from sdfphys.solver.joints import _joint, _point, _row, solve_joints, stiffen


def _sum_rows(a, rows):
    total = 0.0
    for k in range(rows.shape[0]):
        total += a[rows[k], 0] * a[rows[k], 1]
    return total


def test_a_kernel_without_reference_counts_computes_the_same():
    counted = njit(_sum_rows)
    uncounted = njit(refcounts=False)(_sum_rows)
    a = np.arange(12.0).reshape(6, 2)
    rows = np.array([5, 0, 3, 3], np.int64)
    assert uncounted(a, rows) == counted(a, rows) == _sum_rows(a, rows)


def test_numba_refuses_a_kernel_without_reference_counts_that_allocates():
    @njit(refcounts=False)
    def fresh(n):
        return np.zeros(n)

    with pytest.raises(TypingError):
        fresh(3)


@pytest.mark.parametrize("kernel", [clip_pair, run, _shape, _h, _most_candidates, _row, _point,
                                    _joint, solve_joints, stiffen, _coupling, _point_pair,
                                    _row_geometry])
def test_the_per_pair_and_per_point_kernels_count_no_references(kernel):
    """The kernels called once per polygon pair, per batch of field points, per descent
    start, per joint or joint row of a pass (``sdfphys._jit``, "Reference counts")."""
    assert kernel.targetoptions.get("_nrt") is False
