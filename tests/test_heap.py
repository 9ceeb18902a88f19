"""The C heap kept for reuse (sdfphys._heap): a step's large arrays fault no fresh pages.

Each case runs in a fresh interpreter, where the allocator has its default thresholds:
twenty arrays of 320 to 472 kB (a step's contacts and rows of a large scene) allocated,
written and freed twenty times. With glibc's defaults every round maps and faults about
1,900 pages (measured: 1,903 a round); once ``import sdfphys`` has set the thresholds,
the rounds reuse the heap.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from sdfphys import _heap

ROUNDS = """
import resource, sys
if sys.argv[1] == "sdfphys":
    import sdfphys
import numpy as np

def one_round():
    arrays = [np.ones(40_000 + 1_000 * i) for i in range(20)]
    del arrays

one_round()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(20):
    one_round()
print((resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 20)
"""

#: Pages the round's arrays span: 20 arrays of 320 to 472 kB, 4 kB pages.
PAGES = sum(8 * (40_000 + 1_000 * i) for i in range(20)) // 4096


def faults_per_round(first_import: str) -> float:
    done = subprocess.run([sys.executable, "-c", ROUNDS, first_import], capture_output=True,
                          text=True, check=True, timeout=120)
    return float(done.stdout.strip())


@pytest.mark.skipif(not _heap.install(), reason="the C library is not glibc (no mallopt)")
def test_importing_sdfphys_keeps_large_arrays_on_the_heap():
    assert faults_per_round("numpy") > PAGES / 2       # the default: fresh pages each round
    assert faults_per_round("sdfphys") < 10            # reused
