"""``njit`` for this package's kernels: numba's, without the C-callable wrapper; and
``interpreted``, a kernel run by the interpreter for inputs too small to repay its compile.

Numba compiles three entry points for every njit function: the native function, a
CPython wrapper (what a call from Python runs) and a C wrapper (what a ``cfunc`` or a
first-class function value calls). No kernel here is used as a first-class function, so
the C wrapper is dead code that numba lowers, optimises and caches anyway; leaving it
out (numba's ``no_cfunc_wrapper`` target option) cut the CPU time of box_stack's cold
start by 11 % (tools/bench_startup.py, docs/performance.md). The CPython wrapper stays:
any kernel may be called from Python (a function compiled without it crashes the
interpreter when called from Python, so that option is not used).

A kernel that a cold start calls once on a few numbers (a scene's polygons, checked
and triangulated as it loads) costs its compile, seconds, for microseconds of work.
``interpreted(kernel)`` is the same code run by Python: the kernel's Python function
with the kernels it calls by global name interpreted too. Numba compiles without
fast-math (no reassociation, no fused multiply-add), so both run the same IEEE double
operations in the same order and give the same bits (tests/test_geometry.py compares
them); integers keep Python's semantics in both (numba implements ``%`` and ``//`` as
Python does), for values within int64.

Reference counts. A numba function takes every array it is given (and every array it
reads from a tuple, a view or a structref) as a new reference: NRT_incref on the way
in, NRT_decref on the way out, each a call into numba's runtime and an atomic
operation that drains the store buffer. LLVM removes such pairs only within simple
control flow, so a helper called once per pair or per point with a few arrays pays
them every call: 269,100 calls a step in the base-100 pyramid from
``polygons.clip_pair`` alone (counted with a gdb breakpoint), 12 % of its time. A
kernel that allocates nothing (no array made, none returned) needs no counts while
its caller holds the arrays: ``njit(..., refcounts=False)`` compiles it without them
(numba's ``_nrt`` flag; numba refuses to compile such a kernel if it allocates).
"""

from __future__ import annotations

import functools
import types
from typing import Any

import numba
from numba.core.registry import CPUDispatcher

__all__ = ["interpreted", "njit"]


def njit(*args: Any, refcounts: bool = True, **options: Any) -> Any:
    """``numba.njit`` with ``no_cfunc_wrapper=True`` unless given (same signature);
    ``refcounts=False``: compiled without reference counts (module docstring)."""
    options.setdefault("no_cfunc_wrapper", True)
    if not refcounts:
        options["_nrt"] = False
    return numba.njit(*args, **options)


@functools.cache
def interpreted(kernel: CPUDispatcher) -> types.FunctionType:
    """``kernel``'s Python function (module docstring) whose calls of njit kernels by
    global name go to their ``interpreted`` functions: nothing is compiled. For kernels
    that do not call themselves (directly or through others)."""
    function = kernel.py_func
    names = dict(function.__globals__)
    for name in function.__code__.co_names:
        callee = names.get(name)
        if isinstance(callee, CPUDispatcher):
            names[name] = interpreted(callee)
    return types.FunctionType(function.__code__, names, function.__name__,
                              function.__defaults__, function.__closure__)
