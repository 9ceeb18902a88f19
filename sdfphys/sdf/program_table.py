"""Several fields' programs in one table: one kernel call evaluates many shapes' fields.

A scene's narrowphase meets many pairs of distinct fields (every sdf body of a scene
file is its own shape): a kernel per pair of fields would cost its Python and its fixed
work once per pair. A ``ProgramTable`` holds the programs (``sdf.compiled.Program``) of
S fields one after the other: ``code`` (I, 4) int64 all their rows, each row's
constant offset (column 1) moved to its place in ``consts`` (F,), the programs'
constants concatenated; program s is ``code[start[s]:start[s + 1]]`` (a row slice:
the jumps of ``SKIP_FAR`` are relative, so a program runs from its slice as from its
own array, to the same bits); ``depth`` and ``nesting`` the largest of the programs'
(scratch arrays large enough for any of them).

A kernel that evaluates points of several pairs takes, per pair, the programs of its
fields and a *run* id, and evaluates each maximal run of consecutive points of equal
run id as one batch (:func:`evaluate_runs`): callers give the pairs of one shape pair
one run id, so that every batch holds the points the shape pair's own call evaluated
together before, and the far-operand skips (``SKIP_FAR``, which look at the whole
batch) decide as they did: the same bits as a call per shape pair.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._jit import njit
from .compiled import Program, consts_version, run_shared, scratch

__all__ = ["ProgramTable", "evaluate_runs", "pair_table", "program_table"]


@dataclass(frozen=True)
class ProgramTable:
    """Programs of S fields in one table (module docstring): code (I, 4) int64, consts
    (F,) float64, start (S + 1,) int64, depth and nesting (>= 1)."""

    code: np.ndarray
    consts: np.ndarray
    start: np.ndarray
    depth: int
    nesting: int


def program_table(programs: Sequence[Program]) -> ProgramTable:
    """The table of ``programs`` (at least one, none with EXTERNAL leaves), in order."""
    rows = np.cumsum([0] + [len(p.code) for p in programs])
    base = np.cumsum([0] + [len(p.consts) for p in programs])
    code = np.concatenate([p.code for p in programs]).astype(np.int64, copy=True)
    code[:, 1] += np.repeat(base[:-1], np.diff(rows))
    return ProgramTable(np.ascontiguousarray(code), np.concatenate([p.consts for p in programs]),
                        rows.astype(np.int64), max(p.depth for p in programs),
                        max(p.nesting for p in programs))


#: (id(a), id(b)) -> (a, b, constants' version, their table): the tables of one field
#: pair's calls.
_PAIRS: dict[tuple[int, int], tuple[Program, Program, int, ProgramTable]] = {}
_PAIRS_KEPT = 256


def pair_table(a: Program, b: Program) -> ProgramTable:
    """The table of programs a (0) and b (1), cached by the programs' identities (the
    programs are kept with it, so an identity is never reused while cached) until some
    program's constants change in place (``sdf.compiled.consts_changed``)."""
    key = (id(a), id(b))
    hit = _PAIRS.get(key)
    if hit is None or hit[2] != consts_version():
        if len(_PAIRS) >= _PAIRS_KEPT:
            _PAIRS.pop(next(iter(_PAIRS)))
        hit = _PAIRS[key] = (a, b, consts_version(), program_table([a, b]))
    return hit[3]


@njit(cache=True, error_model="numpy")
def evaluate_runs(code: np.ndarray, consts: np.ndarray, start: np.ndarray, depth: int,
                  nesting: int, program: np.ndarray, run: np.ndarray, pair: np.ndarray,
                  points: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Value (n,) and gradient (n, 2) at points[:n] (m, each in its field's frame),
    point j of pair pair[j] by that pair's program ``program[pair[j]]`` of the table
    (code, consts, start, depth, nesting: ``ProgramTable``), each maximal run of points
    of equal ``run[pair[j]]`` one batch (one program per run)."""
    stack, frames, cur = scratch(depth, nesting, n)
    value, grad = np.empty(n), np.empty((n, 2))
    lo = 0
    while lo < n:
        hi = lo + 1
        while hi < n and run[pair[hi]] == run[pair[lo]]:
            hi += 1
        p = program[pair[lo]]
        run_shared(code[start[p]:start[p + 1]], consts, points[lo:hi], hi - lo, stack, frames,
                   cur, value[lo:hi], grad[lo:hi], 0, 0, 0)
        lo = hi
    return value, grad
