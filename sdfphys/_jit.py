"""``njit`` for this package's kernels: numba's, without the C-callable wrapper.

Numba compiles three entry points for every njit function: the native function, a
CPython wrapper (what a call from Python runs) and a C wrapper (what a ``cfunc`` or a
first-class function value calls). No kernel here is used as a first-class function, so
the C wrapper is dead code that numba lowers, optimises and caches anyway; leaving it
out (numba's ``no_cfunc_wrapper`` target option) cut the CPU time of box_stack's cold
start by 11 % (tools/bench_startup.py, docs/performance.md). The CPython wrapper stays:
any kernel may be called from Python (a function compiled without it crashes the
interpreter when called from Python, so that option is not used).
"""

from __future__ import annotations

from typing import Any

import numba

__all__ = ["njit"]


def njit(*args: Any, **options: Any) -> Any:
    """``numba.njit`` with ``no_cfunc_wrapper=True`` unless given (same signature)."""
    options.setdefault("no_cfunc_wrapper", True)
    return numba.njit(*args, **options)
