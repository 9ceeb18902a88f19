"""One contact pair's velocities and the algebra of one row, for the compiled sweeps.

A pair's rows and bodies (``pair_bodies``); its six velocities are loaded once
(``load_pair``), updated row by row in registers and stored back (``store_pair``). A row
along a unit direction n (the normal, or the tangent t = (n_y, -n_x)) with lever arms
r_a, r_b: ``cross`` gives r x n, ``along`` the relative speed of b's point against a's
along n, ``apply_impulse`` the velocities after an impulse along n; ``apply_vector``
applies a general impulse vector (the warm start's l_n n + l_t t). Conventions:
``sdfphys.solver``'s docstring.

Unsigned indices. Numba wraps a signed index around when it is negative: every access
``x[i]`` with an int64 i that LLVM cannot prove non-negative (any index read from an
array: a pair's rows, its bodies) carries a compare and a select. The sweeps read a
dozen arrays per row through such indices, so they take the index arrays as uint64
views (``unsigned``; the same memory, the values are never negative) and count pairs
in uint64 (``pair_count``): the substep kernel on a recorded step of the 2,000-circle
pile 1.25 -> 1.05 ms, of the base-100 pyramid 8.07 -> 7.27 ms, the same bits.
Mixing the two is a trap: numba types uint64 + int64 as float64 (and uint64 + a
literal as int64), so the index arithmetic adds ``ONE``.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit

__all__ = ["ONE", "along", "apply_impulse", "apply_vector", "cross", "load_pair",
           "pair_bodies", "pair_count", "store_pair", "unsigned"]

#: 1 as uint64, for index arithmetic on unsigned indices.
ONE = np.uint64(1)


@njit(cache=True)
def unsigned(indices):
    """A uint64 view of an int64 index array (no copy; its values are >= 0)."""
    return indices.view(np.uint64)


@njit(cache=True)
def pair_count(pair_start):
    """The number of pairs P of ``pair_start`` (P + 1,) (0 when empty), as uint64."""
    return np.uint64(max(pair_start.shape[0] - 1, 0))


@njit(cache=True)
def pair_bodies(p, pair_start, body_a, body_b, inv_mass, inv_inertia):
    """(first, last, a, b, ma, ia, mb, ib) of pair p: its rows first..last - 1 (one
    body pair, ``pair_start`` (P + 1,)), its bodies, their inverse masses and
    inertias. p and the three index arrays unsigned (``unsigned``), so are the
    returned indices."""
    first = pair_start[p]
    a = body_a[first]
    b = body_b[first]
    return (first, pair_start[p + ONE], a, b, inv_mass[a], inv_inertia[a], inv_mass[b],
            inv_inertia[b])


@njit(cache=True)
def load_pair(velocity, angular_velocity, a, b):
    """(vax, vay, wa, vbx, vby, wb): the velocities of a pair's two bodies."""
    return (velocity[a, 0], velocity[a, 1], angular_velocity[a],
            velocity[b, 0], velocity[b, 1], angular_velocity[b])


@njit(cache=True)
def store_pair(velocity, angular_velocity, a, b, vax, vay, wa, vbx, vby, wb):
    """Write a pair's velocities back (``load_pair``'s inverse)."""
    velocity[a, 0] = vax
    velocity[a, 1] = vay
    angular_velocity[a] = wa
    velocity[b, 0] = vbx
    velocity[b, 1] = vby
    angular_velocity[b] = wb


@njit(cache=True)
def cross(rx, ry, nx, ny):
    """r x n = rx ny - ry nx (2D cross product, scalar)."""
    return rx * ny - ry * nx


@njit(cache=True)
def along(vax, vay, wa, vbx, vby, wb, nx, ny, rna, rnb):
    """n.(v_b + w_b x r_b - v_a - w_a x r_a), m/s: b's point against a's along n, with
    rna = r_a x n and rnb = r_b x n (``cross``; n.(w x r) = w (r x n)).

    Written as a sum of independent products: a Gauss-Seidel sweep is one chain of
    dependent row updates, and this form is about half as long a chain as the point
    velocities' components dotted with n (a pass over the 210-box pyramid: 57 to 38 us)."""
    return ((vbx - vax) * nx + (vby - vay) * ny) + (wb * rnb - wa * rna)


@njit(cache=True)
def apply_impulse(vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib, nx, ny, rna, rnb, impulse):
    """The pair's velocities after ``impulse`` (N s) along n on b and its opposite on a
    (ma, mb inverse masses; ia, ib inverse inertias; rna, rnb as in ``along``:
    r x (impulse n) = impulse (r x n))."""
    return (vax - (ma * nx) * impulse, vay - (ma * ny) * impulse, wa - (ia * rna) * impulse,
            vbx + (mb * nx) * impulse, vby + (mb * ny) * impulse, wb + (ib * rnb) * impulse)


@njit(cache=True)
def apply_vector(vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib, rax, ray, rbx, rby, px, py):
    """The two bodies' velocities after the impulse P = (px, py) (N s) on b at arm rb and
    -P on a at arm ra (ma, mb inverse masses; ia, ib inverse inertias)."""
    return (vax - ma * px, vay - ma * py, wa - ia * (rax * py - ray * px),
            vbx + mb * px, vby + mb * py, wb + ib * (rbx * py - rby * px))
