"""Compiled conservative advancement of ``toi``: every round of a set of traces in one call.

``toi._advance`` steps R traces together in numpy, a round per advancement, and each
round's clearances are a field evaluation per target shape (``toi._distance``): a few
dozen numpy and kernel calls a round. Where every target's field compiles
(``sdf.compiled``), :func:`trace` runs the same rounds in one call: the same
arithmetic in the same order per trace, and each round's points of one target shape
evaluated as one batch of its program (the table of ``sdf.program_table``), in trace
order, as ``toi._distance`` batches them. So the stop times are those of the numpy
rounds, to the bit (tests/test_toi.py).

A trace r follows a point of a fast body over the step, t in [0, 1]:

- a disc trace (``rotating`` False): the centre of mass, p(t) = c0 + t path, its
  clearance f(p) - disc with disc the bounding radius where that clears 2 slop at
  t = 0, else the core radius (``toi._disc_fractions``);
- a vertex trace (``rotating`` True): a polygon's vertex v (body frame),
  p(t) = c0 + t path + R(a0 + t turn) v, its clearance f(p) (``toi._vertex_fractions``).

f is the target body's field at its end pose (centre com, angle given by its cosine
and sine), the point taken into the target's frame as ``toi._distance`` does.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import njit
from .sdf.compiled import run_shared, scratch

__all__ = ["trace"]


@njit(cache=True, error_model="numpy")
def trace(code, consts, start, depth, nesting, program, com, cos_t, sin_t, rotating, c0,
          path, a0, turn, vertex, radius, core, speed, slop, iterations):
    """The stop time (R,) of each of R traces (module docstring), inf for one that
    reaches t = 1 clear; ``toi._advance`` of ``toi._disc_fractions`` (``rotating``
    False) or ``toi._vertex_fractions`` (True) in one call.

    code, consts, start, depth, nesting: a ``ProgramTable``; program (R,) int64 each
    trace's target's program in it; com (R, 2) m, cos_t, sin_t (R,): the target's end
    pose. c0, path (R, 2) m: the traced point's centre at t = 0 and its move over the
    step; a0, turn (R,) rad and vertex (R, 2) m: a vertex trace's start angle, turn
    and body-frame vertex (read only when ``rotating``); radius, core (R,) m: a disc
    trace's bounding and core radius (read only when not); speed (R,) m per unit of t,
    the bound on how fast the clearance shrinks; slop m; iterations: the rounds at most
    (``toi.MAX_ITERATIONS``).

    One function (no compiled helpers: each would be compiled on its own at a cold
    start). Pass 0 measures every trace at t = 0 (a disc trace at c0 itself); each
    later pass advances the running traces and measures those still short of t = 1.
    """
    n_rows = c0.shape[0]
    t = np.zeros(n_rows)
    stop = np.full(n_rows, np.inf)
    gap = np.empty(n_rows)
    disc = np.zeros(n_rows)
    active = np.zeros(n_rows, np.bool_)
    rows = np.arange(n_rows)
    stack, frames, cur = scratch(depth, nesting, n_rows)
    local = np.empty((n_rows, 2))
    value, grad = np.empty(n_rows), np.empty((n_rows, 2))
    group = np.empty(n_rows, np.int64)
    done = np.empty(n_rows, np.bool_)
    for step in range(iterations + 1):
        n = n_rows
        if step > 0:
            n = 0
            for r in range(n_rows):
                if active[r]:
                    t[r] += (gap[r] - slop) / speed[r]
                    if t[r] >= 1.0:
                        active[r] = False
                    else:
                        rows[n] = r
                        n += 1
            if n == 0:
                break
        # The clearances of rows[:n] at their t: the points of one target program one
        # batch, in the order of ``rows`` (``toi._distance``).
        done[:n] = False
        for first in range(n):
            if done[first]:
                continue
            p = program[rows[first]]
            m = 0
            for j in range(first, n):
                r = rows[j]
                if done[j] or program[r] != p:
                    continue
                done[j] = True
                group[m] = r
                if step == 0 and not rotating:
                    x, y = c0[r, 0], c0[r, 1]
                else:
                    x = c0[r, 0] + t[r] * path[r, 0]
                    y = c0[r, 1] + t[r] * path[r, 1]
                    if rotating:
                        a = a0[r] + t[r] * turn[r]
                        c, s = math.cos(a), math.sin(a)
                        x = x + (c * vertex[r, 0] - s * vertex[r, 1])
                        y = y + (s * vertex[r, 0] + c * vertex[r, 1])
                # toi._distance: rel = p - com, local = (c rel_x + s rel_y, -s rel_x + c rel_y)
                rx, ry = x - com[r, 0], y - com[r, 1]
                c, s = cos_t[r], sin_t[r]
                local[m, 0] = c * rx + s * ry
                local[m, 1] = (-s) * rx + c * ry
                m += 1
            run_shared(code[start[p]:start[p + 1]], consts, local, m, stack, frames, cur,
                       value, grad, 0, 0, 0)
            for k in range(m):
                gap[group[k]] = value[k]
        for j in range(n):
            r = rows[j]
            if step == 0:
                if not rotating:
                    disc[r] = radius[r] if gap[r] - radius[r] > 2.0 * slop else core[r]
                    gap[r] = gap[r] - disc[r]
                active[r] = gap[r] > 2.0 * slop and speed[r] > 0.0
                continue
            if not rotating:
                gap[r] = gap[r] - disc[r]
            if gap[r] <= 2.0 * slop:
                stop[r] = t[r]
                active[r] = False
    for r in range(n_rows):
        if active[r]:
            stop[r] = t[r]
    return stop
