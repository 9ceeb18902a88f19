"""The C heap kept for reuse: a step's large arrays without fresh pages every step.

A step allocates its arrays afresh: the contacts, the solver's rows, the substep
kernel's copies (numpy and numba's runtime both allocate with ``malloc``). glibc serves
an allocation over its mmap threshold with freshly mapped pages, each of which faults
on its first write, and gives a free stretch at the top of its heap back to the system
once it exceeds the trim threshold; both thresholds start at 128 kB and glibc raises
them as large blocks are freed, but a step's many arrays of different sizes keep
crossing them. Measured on the base-100 pyramid (5,050 boxes, 30,000 contact rows,
sleeping off): 492 page faults a step, about 2 MB of pages mapped, zeroed and unmapped
again, 15.3 -> 14.4 ms a step once they stop (``tools/bench_vs_peers.py --scenes
pyramid100``, alternated; the same trajectory; the peak resident memory unchanged,
177 MB); the 5,000-circle pile 1.5 % faster; the showcase and the 2,000-circle pile,
whose arrays are smaller, the same.

``install`` sets the two thresholds where glibc's own adjustment stops (an mmap
threshold of 32 MB, its largest; a trim threshold of twice that): blocks up to 32 MB
come from the heap, and up to 64 MB of freed heap is kept for the next step. This is
a setting of the process's allocator, so it applies to everything the process
allocates; a freed block larger than 32 MB still goes back to the system at once.
Other C libraries (musl, macOS) have no ``mallopt``: nothing is changed there.
"""

from __future__ import annotations

import ctypes

__all__ = ["MMAP_THRESHOLD", "TRIM_THRESHOLD", "install"]

#: glibc's ``mallopt`` parameters (malloc.h).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Bytes: blocks this large or larger are mapped on their own (glibc's largest
#: automatic value, DEFAULT_MMAP_THRESHOLD_MAX on 64-bit systems).
MMAP_THRESHOLD = 32 * 1024 * 1024
#: Bytes of free memory at the top of the heap kept before it is given back.
TRIM_THRESHOLD = 2 * MMAP_THRESHOLD


def install() -> bool:
    """Set glibc's mmap and trim thresholds (module docstring); whether they were set
    (False where the C library is not glibc)."""
    try:
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
        libc.gnu_get_libc_version      # glibc's, absent from other C libraries
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
                and mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))
