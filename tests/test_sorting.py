"""``sorting.stable_argsort`` against numpy's stable argsort."""

from __future__ import annotations

import numpy as np
import pytest

from sdfphys.sorting import RUN, stable_argsort


@pytest.mark.parametrize("n", [0, 1, 2, RUN - 1, RUN, RUN + 1, 2 * RUN + 1, 100, 1000, 4097])
def test_stable_argsort_is_numpys_stable_argsort(n):
    rng = np.random.default_rng(n)
    keys = [rng.integers(0, n // 3 + 2, n).astype(np.int64),      # many ties
            rng.normal(size=n),
            np.round(rng.normal(size=n), 1),                        # ties among floats
            np.where(rng.random(n) < 0.2, np.nan, rng.normal(size=n)),   # NaN last
            np.arange(n, 0, -1).astype(np.float64)]                 # reversed
    for k in keys:
        np.testing.assert_array_equal(stable_argsort(k), np.argsort(k, kind="stable"))
