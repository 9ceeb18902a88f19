"""The joints' equality rows of one joint island solved at once (a sparse Cholesky).

Gauss-Seidel carries an error one joint per pass, and a light link passes on about
m_light / m_heavy of a heavy neighbour's impulse: a bridge of 40 planks of 2 kg under
50 kg crates needed hundreds of passes per phase and still did not converge. The
equality rows of joints (a shared point, a weld's or a
prismatic's angle, an axis's perpendicular, a rod's length: ``joints._joint``) are
linear in the impulses, so every phase solves them together, exactly, per island of
bodies they join (D. Baraff, "Linear-Time Dynamics using Lagrange Multipliers",
SIGGRAPH 1996, for the idea of a direct solve of the joint system; E. Catto, "Soft
Constraints", GDC 2011, for the soft form below).

Soft form. One soft row update of ``joints._row`` (mass_scale ms, impulse_scale is,
bias_rate b, error C, effective mass k = 1 / K) is d_l = -ms (Cdot + b C) / K - is l, the
solution of (K + g) d_l = -(Cdot + b C) - g l with g = K is / ms (ms + is = 1). For the
rows of an island together, with A = J M^-1 J^T (Jacobian J (R, 3 B), inverse masses M^-1):

    (A + G) d_l = -(Cdot + b C) - G l,

G diagonal with g_i = A_ii is_i / ms_i, except that a shared point's two rows take the 2x2
block G = (is / ms) A_block, as its ``joints._point`` update does. So one direct solve is
the fixed point that converged passes of the same rows would reach. Relaxing, the rows
are rigid: G = 0, b = 0, A d_l = -Cdot.

Factor once per phase. Within a phase (solve, relax) of a substep the positions do not
move, so A + G is factored once (``factor``, after the warm start has refilled the
softness) and every later pass (``direct_pass``: the joints' passes and the one after
each extra contact pass, ``substeps._sweeps``) only forms the right-hand side and
substitutes. Rows are numbered in joint order inside an island: a chain listed link by
link gives a band of width 4, and the Cholesky runs over each row's envelope (from its
first nonzero column), so a chain costs O(R) and a ragdoll's small dense block little.

Islands. Equality rows join the dynamic bodies of their joint (static, kinematic and
sleeping bodies, inverse mass 0, and the world split islands). An island with more than
``MAX_ROWS`` rows, or whose factorization meets a pivot below ``PIVOT`` times its
diagonal (redundant rows: a plank pinned at both ends, rigid while relaxing), keeps
Gauss-Seidel for its joints in that phase (``mask`` cleared: ``joints.solve_joints``
then runs those rows).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba.experimental import structref

from .._jit import njit
from .bundles import PlainFields
from .joints import (
    ANGLE_ROW,
    ANGULAR_IMPULSE,
    AXIAL_IMPULSE,
    AXIAL_ROW,
    AXIS_X,
    AXIS_Y,
    BODY_A,
    BODY_B,
    DISTANCE,
    HAS_SPRING,
    KIND,
    LENGTH,
    LINEAR_X,
    LINEAR_Y,
    MAX_LENGTH,
    MIN_LENGTH,
    PERP_IMPULSE,
    PERP_ROW,
    POINT_ROWS,
    PRISMATIC,
    REFERENCE_ANGLE,
    REVOLUTE,
    SOLVE,
    WARM,
    WELD,
    WHEEL,
    Output,
    joint_geometry,
    solve_joints,
    stiffen,
)
from .softness import CONVERGED

__all__ = ["JOINT_FIELDS", "MAX_ROWS", "DirectPlan", "DirectPlanRef", "SubstepJoints",
           "direct_pass", "equality_mask", "factor", "joint_passes", "kernel_plan", "plan",
           "substep_joints"]
#: Row codes (``DirectPlan.row_code``): point x, point y, angle, perpendicular, axial;
#: each the column of its accumulated impulse in the packed impulses (``joints.Packed``).
_X, _Y, _ANGLE, _PERP, _AXIAL = LINEAR_X, LINEAR_Y, ANGULAR_IMPULSE, PERP_IMPULSE, AXIAL_IMPULSE
#: The largest island solved directly, in rows (dense storage R^2, work <= R^3 / 3).
MAX_ROWS = 256
#: A pivot below this fraction of its diagonal entry: the rows are redundant.
PIVOT = 1e-10


class DirectPlan(NamedTuple):
    """The joint islands of one step (``plan``) and the factor of the current phase.

    mask: (J,) int64, the equality rows each joint leaves to the direct solve (bits
    POINT_ROWS .. AXIAL_ROW; 0: all rows by Gauss-Seidel). row_joint, row_code: (R,) int64, the
    rows, island by island, in joint order. start: (C + 1,) int64, each island's first
    row; offset: (C + 1,) int64, where its (n, n) matrix starts in ``matrix``.
    Per phase (``factor``): jac (R, 4) (ux, uy, a1, a2) of each row (``joints._row``);
    error: (R,) C (m or rad); rate: (R,) the bias rate b (1/s; 0 relaxing); scale: (R,)
    is / ms (0 relaxing); first: (R,) int64, each row's first nonzero column in its
    island; matrix: the Cholesky factors L (row-major, lower); ok: (C,) bool;
    soft_diag, soft_off: (R,) g_i A_ii and, for a point's x row, g_i A_i,i+1 (its coupling
    to the y row), the terms of G that ``island_pass`` multiplies by the impulses (0 where
    g_i = 0). work: (R,) scratch of ``island_pass`` (which then allocates nothing).
    """

    mask: np.ndarray
    row_joint: np.ndarray
    row_code: np.ndarray
    start: np.ndarray
    offset: np.ndarray
    jac: np.ndarray
    error: np.ndarray
    rate: np.ndarray
    scale: np.ndarray
    first: np.ndarray
    matrix: np.ndarray
    ok: np.ndarray
    soft_diag: np.ndarray
    soft_off: np.ndarray
    work: np.ndarray


@structref.register
class _DirectPlanType(PlainFields):
    """Numba's type of ``DirectPlanRef``."""


class DirectPlanRef(structref.StructRefProxy):
    """DirectPlan as the kernels take it, one reference to the same arrays
    (``kernel_plan``; why: ``solver.bundles``). Opaque to Python."""


structref.define_proxy(DirectPlanRef, _DirectPlanType, list(DirectPlan._fields))


@njit(cache=True)
def _direct_plan_ref(mask, row_joint, row_code, start, offset, jac, error, rate, scale,
                     first, matrix, ok, soft_diag, soft_off, work):
    return DirectPlanRef(mask, row_joint, row_code, start, offset, jac, error, rate, scale,
                         first, matrix, ok, soft_diag, soft_off, work)


def kernel_plan(p: DirectPlan) -> DirectPlanRef:
    """``p`` as the joint kernels take it (``DirectPlanRef``)."""
    return _direct_plan_ref(*p)


@njit(cache=True)
def equality_mask(kind, has_spring, min_length, max_length):
    """The equality rows (bits) of a joint of ``kind`` (``joints._joint``'s rigid rows)."""
    if kind == REVOLUTE:
        return POINT_ROWS
    if kind == WELD:
        return 0 if has_spring else POINT_ROWS | ANGLE_ROW
    if kind == PRISMATIC:
        return PERP_ROW | ANGLE_ROW
    if kind == WHEEL:
        return PERP_ROW if has_spring else PERP_ROW | AXIAL_ROW
    if kind == DISTANCE and min_length == max_length:
        return AXIAL_ROW
    return 0


@njit(cache=True, refcounts=False)
def _joint_mask(ints, reals, j):
    """``equality_mask`` of joint j of the packed rows."""
    return equality_mask(ints[j, KIND], ints[j, HAS_SPRING], reals[j, MIN_LENGTH],
                         reals[j, MAX_LENGTH])


@njit(cache=True)
def _root(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True)
def plan(rows, inv_mass, inv_inertia):
    """The islands of the joints' equality rows (``joints.Packed``) for bodies with
    inv_mass, inv_inertia (B,) now (``DirectPlan``; the per-phase arrays allocated, not
    yet filled)."""
    ints, reals, _ = rows
    count = ints.shape[0]
    bodies = inv_mass.shape[0]
    parent = np.arange(bodies)
    mask = np.zeros(count, np.int64)
    anchor = np.full(count, -1)
    for j in range(count):
        a, b = ints[j, BODY_A], ints[j, BODY_B]
        live_a = a >= 0 and (inv_mass[a] > 0.0 or inv_inertia[a] > 0.0)
        live_b = b >= 0 and (inv_mass[b] > 0.0 or inv_inertia[b] > 0.0)
        if not (live_a or live_b):
            continue
        mask[j] = _joint_mask(ints, reals, j)
        if mask[j] == 0:
            continue
        anchor[j] = a if live_a else b
        if live_a and live_b:
            ra, rb = _root(parent, a), _root(parent, b)
            parent[max(ra, rb)] = min(ra, rb)
    # Rows per island, islands numbered by their first joint.
    island = np.full(bodies, -1)
    of_joint = np.full(count, -1)
    sizes = np.zeros(count + 1, np.int64)
    islands = 0
    for j in range(count):
        if mask[j] == 0:
            continue
        r = _root(parent, anchor[j])
        if island[r] < 0:
            island[r] = islands
            islands += 1
        of_joint[j] = island[r]
        m = mask[j]
        sizes[island[r]] += (2 * (m & POINT_ROWS > 0) + (m & ANGLE_ROW > 0)
                             + (m & PERP_ROW > 0) + (m & AXIAL_ROW > 0))
    for j in range(count):
        if of_joint[j] >= 0 and sizes[of_joint[j]] > MAX_ROWS:
            mask[j] = 0
            of_joint[j] = -1
    kept = np.zeros(islands, np.int64)   # new island number + 1, 0: dropped
    kept_count = 0
    for c in range(islands):
        if sizes[c] <= MAX_ROWS:
            kept_count += 1
            kept[c] = kept_count
    start = np.zeros(kept_count + 1, np.int64)
    offset = np.zeros(kept_count + 1, np.int64)
    for c in range(islands):
        if kept[c]:
            start[kept[c]] = sizes[c]
            offset[kept[c]] = sizes[c] * sizes[c]
    start = np.cumsum(start)
    offset = np.cumsum(offset)
    total = start[-1]
    row_joint = np.empty(total, np.int64)
    row_code = np.empty(total, np.int64)
    fill = start[:-1].copy()
    for j in range(count):
        if of_joint[j] < 0:
            continue
        c = kept[of_joint[j]] - 1
        m = mask[j]
        for bit, codes in ((POINT_ROWS, (_X, _Y)), (ANGLE_ROW, (_ANGLE, -1)),
                           (PERP_ROW, (_PERP, -1)), (AXIAL_ROW, (_AXIAL, -1))):
            if m & bit:
                for code in codes:
                    if code >= 0:
                        row_joint[fill[c]] = j
                        row_code[fill[c]] = code
                        fill[c] += 1
    return DirectPlan(mask, row_joint, row_code, start, offset, np.zeros((total, 4)),
                      np.zeros(total), np.zeros(total), np.zeros(total),
                      np.zeros(total, np.int64), np.zeros(offset[-1]),
                      np.zeros(kept_count, np.bool_), np.zeros(total), np.zeros(total),
                      np.zeros(total))


@njit(cache=True, refcounts=False)
def _row_geometry(com, angle, ints, reals, j, code):
    """(ux, uy, a1, a2, C) of equality row ``code`` of joint j (the packed ints and reals)
    at the positions now, the Jacobian as ``joints._row``'s (Cdot = u.(vb - va) + a2 wb -
    a1 wa)."""
    a, b = ints[j, BODY_A], ints[j, BODY_B]
    cax = cay = qa = cbx = cby = qb = 0.0
    if a >= 0:
        cax, cay, qa = com[a, 0], com[a, 1], angle[a]
    if b >= 0:
        cbx, cby, qb = com[b, 0], com[b, 1], angle[b]
    rax, ray, rbx, rby, dx, dy, qa, qb = joint_geometry(cax, cay, qa, cbx, cby, qb, reals, j)
    if code == _X:
        return 1.0, 0.0, -ray, -rby, dx
    if code == _Y:
        return 0.0, 1.0, rax, rbx, dy
    if code == _ANGLE:
        return 0.0, 0.0, 1.0, 1.0, qb - qa - reals[j, REFERENCE_ANGLE]
    if ints[j, KIND] == DISTANCE:
        length = math.hypot(dx, dy)
        if length < 1e-9:
            return 0.0, 0.0, 0.0, 0.0, 0.0
        ux, uy = dx / length, dy / length
        return ux, uy, rax * uy - ray * ux, rbx * uy - rby * ux, length - reals[j, LENGTH]
    c, s = math.cos(qa), math.sin(qa)
    ux = c * reals[j, AXIS_X] - s * reals[j, AXIS_Y]
    uy = s * reals[j, AXIS_X] + c * reals[j, AXIS_Y]
    if code == _PERP:
        ux, uy = -uy, ux
    return ux, uy, (dx + rax) * uy - (dy + ray) * ux, rbx * uy - rby * ux, ux * dx + uy * dy


@njit(cache=True, refcounts=False)
def _coupling(row_joint, jac, i, k, ints, inv_mass, inv_inertia):
    """A_ik = J_i M^-1 J_k^T of rows i, k of a plan (its row_joint and jac; their shared
    bodies' terms); ints: the packed ints."""
    ji, jk = row_joint[i], row_joint[k]
    total = 0.0
    for side_i in range(2):
        body = ints[ji, BODY_A] if side_i == 0 else ints[ji, BODY_B]
        if body < 0:
            continue
        for side_k in range(2):
            if body != (ints[jk, BODY_A] if side_k == 0 else ints[jk, BODY_B]):
                continue
            sign = 1.0 if side_i == side_k else -1.0
            wi = jac[i, 2] if side_i == 0 else jac[i, 3]
            wk = jac[k, 2] if side_k == 0 else jac[k, 3]
            total += sign * (inv_mass[body] * (jac[i, 0] * jac[k, 0] + jac[i, 1] * jac[k, 1])
                             + inv_inertia[body] * wi * wk)
    return total


@njit(cache=True, refcounts=False)
def _point_pair(row_code, row_joint, i):
    """Whether row i of a plan is a point's x row followed by its y row (one island)."""
    return (row_code[i] == _X and i + 1 < row_code.shape[0] and row_code[i + 1] == _Y
            and row_joint[i + 1] == row_joint[i])


@njit(cache=True)
def factor(p, com, angle, inv_mass, inv_inertia, rows, soft, phase):
    """Fill p's per-phase arrays for ``phase`` (SOLVE: soft rows, soft (J, 2, 3) the
    joints' linear [:, 0] and angular [:, 1] (bias_rate, mass_scale, impulse_scale);
    RELAX: rigid) at the positions now, and factor each island's A + G (module
    docstring). An island whose pivot fails goes back to Gauss-Seidel (mask cleared).
    rows: ``joints.Packed``."""
    # The plan's fields read once: each read of a StructRef's field in a loop is a
    # reference count taken and dropped.
    ints, reals, _ = rows
    row_joint, row_code, jac, error, rate, scale = (p.row_joint, p.row_code, p.jac, p.error,
                                                    p.rate, p.scale)
    soft_diag, soft_off, start, offset, first = (p.soft_diag, p.soft_off, p.start, p.offset,
                                                 p.first)
    matrix, ok, mask = p.matrix, p.ok, p.mask
    total = row_joint.shape[0]
    for i in range(total):
        j, code = row_joint[i], row_code[i]
        ux, uy, a1, a2, c = _row_geometry(com, angle, ints, reals, j, code)
        jac[i, 0], jac[i, 1], jac[i, 2], jac[i, 3] = ux, uy, a1, a2
        error[i] = c
        k = soft[j, 1] if code == _ANGLE else soft[j, 0]
        if phase == SOLVE:
            rate[i] = k[0]
            scale[i] = k[2] / k[1]
        else:
            rate[i] = 0.0
            scale[i] = 0.0
    for i in range(total):
        g = scale[i]
        soft_diag[i] = 0.0
        soft_off[i] = 0.0
        if g == 0.0:
            continue
        soft_diag[i] = g * _coupling(row_joint, jac, i, i, ints, inv_mass, inv_inertia)
        if _point_pair(row_code, row_joint, i):
            soft_off[i] = g * _coupling(row_joint, jac, i, i + 1, ints, inv_mass, inv_inertia)
    for c in range(ok.shape[0]):
        s, e = start[c], start[c + 1]
        n = e - s
        m = matrix[offset[c]:offset[c + 1]].reshape((n, n))
        for i in range(n):
            first[s + i] = i
            for k in range(i + 1):
                a = _coupling(row_joint, jac, s + i, s + k, ints, inv_mass, inv_inertia)
                m[i, k] = a
                if a != 0.0 and k < first[s + i]:
                    first[s + i] = k
        # G: the point's 2x2 block (rows x, y of one joint, adjacent) or the diagonal.
        for i in range(n):
            g = scale[s + i]
            if g == 0.0:
                continue
            m[i, i] *= 1.0 + g
            if (row_code[s + i] == _Y and i > 0 and row_code[s + i - 1] == _X
                    and row_joint[s + i - 1] == row_joint[s + i]):
                m[i, i - 1] *= 1.0 + g
        ok[c] = _cholesky(m, first[s:e])
        for i in range(s, e):
            j = row_joint[i]
            mask[j] = _joint_mask(ints, reals, j) if ok[c] else 0


@njit(cache=True)
def _cholesky(m, first):
    """In place: the lower Cholesky factor of the symmetric m (n, n), lower triangle
    given, over each row's envelope (columns from ``first``); False at a pivot below
    PIVOT times its diagonal."""
    n = m.shape[0]
    for i in range(n):
        for k in range(first[i], i + 1):
            total = m[i, k]
            for q in range(max(first[i], first[k]), k):
                total -= m[i, q] * m[k, q]
            if k == i:
                if not total > PIVOT * m[i, i] or total <= 0.0:
                    return False
                m[i, i] = math.sqrt(total)
            else:
                m[i, k] = total / m[k, k]
    return True


@njit(cache=True)
def direct_pass(p, velocity, angular_velocity, inv_mass, inv_inertia, rows, out: Output):
    """One exact solve of every factored island's rows (the phase ``factor`` prepared) at
    the velocities now (B, 2) m/s, (B,) rad/s, updated in place with the impulses, which
    are added to the rows' accumulated ones (``joints.Packed``); out.progress is raised
    to (largest |d_l|, largest |l|) as a Gauss-Seidel pass's."""
    for c in range(p.ok.shape[0]):
        island_pass(p, c, velocity, angular_velocity, inv_mass, inv_inertia, rows,
                    out.progress)


@njit(cache=True)
def island_pass(p, c, velocity, angular_velocity, inv_mass, inv_inertia, rows, progress):
    """``direct_pass`` of island c alone; progress (2,) raised as out.progress there."""
    if not p.ok[c]:
        return
    # The plan's fields read once (``factor``).
    row_joint, row_code, jac, error, rate, scale = (p.row_joint, p.row_code, p.jac, p.error,
                                                    p.rate, p.scale)
    soft_diag, soft_off, first = p.soft_diag, p.soft_off, p.first
    s, e = p.start[c], p.start[c + 1]
    n = e - s
    m = p.matrix[p.offset[c]:p.offset[c + 1]].reshape((n, n))
    ints, _, impulses = rows
    x = p.work[s:e]
    for i in range(n):
        r = s + i
        j = row_joint[r]
        a, b = ints[j, BODY_A], ints[j, BODY_B]
        cdot = 0.0
        if a >= 0:
            cdot -= (jac[r, 0] * velocity[a, 0] + jac[r, 1] * velocity[a, 1]
                     + jac[r, 2] * angular_velocity[a])
        if b >= 0:
            cdot += (jac[r, 0] * velocity[b, 0] + jac[r, 1] * velocity[b, 1]
                     + jac[r, 3] * angular_velocity[b])
        x[i] = -(cdot + rate[r] * error[r])
    # - G l: the diagonal (or the point block) of A scaled by is / ms, times l.
    for i in range(n):
        r = s + i
        if scale[r] == 0.0:
            continue
        j, code = row_joint[r], row_code[r]
        x[i] -= soft_diag[r] * impulses[j, code]
        if _point_pair(row_code, row_joint, r):
            off = soft_off[r]
            x[i] -= off * impulses[j, _Y]
            x[i + 1] -= off * impulses[j, _X]
    # L y = x, then L^T d = y, over the envelopes.
    for i in range(n):
        total = x[i]
        for q in range(first[s + i], i):
            total -= m[i, q] * x[q]
        x[i] = total / m[i, i]
    for i in range(n - 1, -1, -1):
        x[i] /= m[i, i]
        for q in range(first[s + i], i):
            x[q] -= m[i, q] * x[i]
    for i in range(n):
        r = s + i
        j, code = row_joint[r], row_code[r]
        d = x[i]
        impulses[j, code] += d
        progress[0] = max(progress[0], abs(d))
        progress[1] = max(progress[1], abs(impulses[j, code]))
        a, b = ints[j, BODY_A], ints[j, BODY_B]
        if a >= 0:
            velocity[a, 0] -= inv_mass[a] * d * jac[r, 0]
            velocity[a, 1] -= inv_mass[a] * d * jac[r, 1]
            angular_velocity[a] -= inv_inertia[a] * d * jac[r, 2]
        if b >= 0:
            velocity[b, 0] += inv_mass[b] * d * jac[r, 0]
            velocity[b, 1] += inv_mass[b] * d * jac[r, 1]
            angular_velocity[b] += inv_inertia[b] * d * jac[r, 3]


@structref.register
class _SubstepJointsType(PlainFields):
    """Numba's type of ``SubstepJoints``."""


class SubstepJoints(structref.StructRefProxy):
    """The joints as the substep kernel takes them (``substep_joints``): the bodies'
    arrays (B, 2) or (B,) the rows act on, the rows (``joints.Packed``), their
    softness soft (J, 2, 3) and spring (J, 3), the stiffening parameters (6,), the
    islands' plan (``kernel_plan``) and what the passes report (``joints.Output``).
    One reference: numba types a tuple holding references by its Python ``typeof`` at
    every call (0.2 ms a step, a third of a pendulum's), a reference at once."""


JOINT_FIELDS = ("com", "angle", "velocity", "angular_velocity", "inv_mass", "inv_inertia",
                "rows", "soft", "spring", "stiffening", "plan", "out")
structref.define_proxy(SubstepJoints, _SubstepJointsType, list(JOINT_FIELDS))


@njit(cache=True)
def _substep_joints(com, angle, velocity, angular_velocity, inv_mass, inv_inertia, rows, soft,
                    spring, stiffening, plan, force, torque, progress):
    return SubstepJoints(com, angle, velocity, angular_velocity, inv_mass, inv_inertia, rows,
                         soft, spring, stiffening, plan, Output(force, torque, progress))


def substep_joints(bodies, rows, soft: np.ndarray, spring: np.ndarray,
                   stiffening: np.ndarray, islands: DirectPlanRef) -> SubstepJoints:
    """The joints of one step by reference: ``bodies`` (a ``rows.BodyState``), the rows
    (``joints.Packed``), ``stiffened_softness``' soft and stiffening, the springs'
    softness and the islands' plan (``kernel_plan``); an empty Output."""
    return _substep_joints(bodies.com, bodies.angle, bodies.velocity, bodies.angular_velocity,
                           bodies.inv_mass, bodies.inv_inertia, rows, soft, spring, stiffening,
                           islands, np.empty((0, 2)), np.empty(0), np.zeros(2))


@njit(cache=True)
def joint_passes(joints, phase, inv_h, passes, moved):
    """Up to ``passes`` passes of ``phase`` (SOLVE or RELAX) over the joints, each a
    Gauss-Seidel pass over the rows the direct solve does not take (``solve_joints``)
    and a ``direct_pass``, stopping after one whose largest impulse change is at most
    CONVERGED times the largest accumulated impulse ("Loaded joints"); WARM runs once and
    prepares the SOLVE phase's factor. moved: the positions moved since the last factor
    (a new phase): factor first. Returns the passes run.

    joints: ``SubstepJoints``; WARM refills its soft from the impulses it applied, the
    passes report in its out. A SOLVE phase that does not converge halves the cap on r
    (stiffening[4]) for the next substeps, one that converges within a quarter of
    ``passes`` doubles it.
    """
    com, angle, velocity = joints.com, joints.angle, joints.velocity
    angular_velocity, inv_mass, inv_inertia = (joints.angular_velocity, joints.inv_mass,
                                               joints.inv_inertia)
    rows, soft, spring, params, p = (joints.rows, joints.soft, joints.spring,
                                     joints.stiffening, joints.plan)
    out = joints.out
    if phase == WARM:
        solve_joints(com, angle, velocity, angular_velocity, inv_mass, inv_inertia, rows,
                     phase, soft, spring, inv_h, out, p.mask)
        stiffen(inv_mass, inv_inertia, rows, params, soft)
        factor(p, com, angle, inv_mass, inv_inertia, rows, soft, SOLVE)
        return 1
    if moved:
        factor(p, com, angle, inv_mass, inv_inertia, rows, soft, phase)
    for n in range(passes):
        out.progress[:] = 0.0
        solve_joints(com, angle, velocity, angular_velocity, inv_mass, inv_inertia, rows,
                     phase, soft, spring, inv_h, out, p.mask)
        direct_pass(p, velocity, angular_velocity, inv_mass, inv_inertia, rows, out)
        if out.progress[0] <= CONVERGED * out.progress[1]:
            if phase == SOLVE and 4 * (n + 1) <= passes:
                params[4] *= 2.0
            return n + 1
    if phase == SOLVE:
        params[4] = max(1.0, 0.5 * min(params[4], params[5]))
    return passes
