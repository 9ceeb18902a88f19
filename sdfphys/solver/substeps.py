"""Substeps: integration, warm start, the solve and relax sweeps, the split push-out.

``solve_substeps`` runs every substep of a step in one compiled call
(``_substeps_kernel``): integrate velocities, warm start, solve with soft bias (the
loaded islands' converged passes, the split push-out), integrate positions, re-measure
the separations, relax. The restitution passes after them: ``restitution``; a pair's
velocities and one row's algebra: ``pair_rows``.

Anchors. Box2D v3 keeps each contact's anchors ra, rb (the contact point relative to
each centre of mass, in world orientation) fixed over the step, which is right for the
body the contact point travels with (a circle rolling on the ground keeps its contact
under its centre) but lets an impulse pair act at two world points that drift apart by
the bodies' relative displacement D = dp_b - dp_a, changing the total angular momentum
by D x P per impulse. Here, after each position update, the anchors are re-based to
one common world point, p = x_a + ra0 + mb / (ma + mb) D (ma, mb inverse masses): every
impulse pair is then equal, opposite and collinear, so linear and angular momentum are
conserved to round-off. Against a static or kinematic body (ma = 0) the movable body
keeps Box2D's fixed anchor exactly (the immovable arm does no work); between two
dynamic bodies the lighter keeps its anchor best. The effective masses stay those
prepared from the first anchors while the arms' move changes the iteration's step size
a little; every impulse pair, hence the momenta, stays exact.

Effective masses. A row's update d_l = -m (vn + bias) with the prepared mass m where the
arms now give 1/k is Gauss-Seidel over-relaxed by w = m k, which converges for
0 < w < 2 on the rows' symmetric positive definite system (the Ostrowski-Reich theorem
of successive over-relaxation) and diverges beyond. A light, small body whose arm
swings across its normal breaks that: a disc r 0.05 m struck off-centre at 100 m/s with
the time of impact off moves 0.4 m within the step; its arm's share of D turns r x n
from 0 to 0.03 m and k grows 3 to 100 times, and the relax passes multiplied the pair's
kinetic energy by up to 30 (a slug volley into box stacks went to NaN in a step). So
each substep, after re-basing, a row whose mass would over-relax by more than
``OVER_RELAXATION`` takes the mass of its current arms (normal and friction rows
alike), checked only in the rows of bodies that moved apart far enough for that to be
possible (``_safe_moves``: a bound, so skipping the others changes nothing). No shipped
scene meets it (their trajectories are the same to the bit).

Separation. docs/solver.md re-measures s from anchors carried by the bodies' rotations and
translations. Box2D turns the contact point (midway between the surfaces) with each
body, which is exact while the gap is small (its speculative distance is 2 cm). Here a
fast body's speculative contacts reach up to two bounding radii (``sdfphys.collide``),
and a point half a metre outside a spinning body does not move as the body's surface
does. So each body carries its own surface point, p_a = point - n s0 / 2 and
p_b = point + n s0 / 2 (s0 = -depth), and s = n.(p_b - p_a) as they turn and move:
exact for a material point (a corner), whatever the gap. Measured on 1 x 0.02 m planks
falling at 100 m/s and spinning up to 85 rad/s as their near end strikes: the lowest
far end ended a step 13 cm under the ground with the midpoint, 6 cm with surface
points. The lever arms stay at the contact point: arms at the surface points gave a
heavy box on a light one 2 to 4 times more rocking, through the friction rows' torque.

Sweep order. A Gauss-Seidel pass visits the pairs in the order the contacts come
(sorted by body), so a pair sees the impulses of the pairs before it and not of those
after: in a pyramid built row by row that is left to right, every pass, and an island
that never converges (over ``Settings.rest_island_limit``: one pass per phase whatever
its load) is pushed to one side. A pyramid of base 50 (1,275 unit boxes) leaned 33 mm
to the right on average in 3 s and kept rocking at 0.10 m/s (Box2D v3, which sweeps
by graph colour: 0.9 mm, at rest). So those islands' pairs are swept in reverse in the
second and third substep of every four (forward, backward, backward, forward: each
step's sweeps mirror each other), the others always forward: 1.0 mm, 0.032 m/s, asleep
before 5 s (tests/stability). An island of at most rest_island_limit bodies is
swept as before: its own pairs keep their order, and its results do not depend on
where other islands' pairs come (islands share no movable body, and the large
islands' pairs never count in the extra passes' stop), so every shipped scene runs bit
for bit as before. Tried for every island (figures in docs/stability.md): the relax
pass reversed (the rest sag under a 100:1 load left the soft step's closed form),
hashed blocks of pairs and the mirrored order itself (a concave polygon scene sank 196
and 32 mm through a narrowphase miss the forward order never met), directions
alternated every substep (6.3 mm). The 2,000-
and 5,000-circle piles of tools/bench_vs_peers.py: deepest overlap 24.0 -> 25.1 mm and
45.9 -> 44.6 mm, the same time per step.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..settings import Settings
from .bundles import substep_bodies, substep_rows
from .joint_direct import joint_passes, kernel_plan, plan, substep_joints
from .joints import (
    JOINT_PASSES,
    RELAX,
    SOLVE,
    WARM,
    JointRows,
    pack,
    spring_softness,
    stiffened_softness,
    unpack_impulses,
)
from .pair_rows import (
    along,
    apply_impulse,
    apply_vector,
    cross,
    load_pair,
    pair_bodies,
    pair_count,
    store_pair,
    unsigned,
)
from .rows import BodyState, ContactConstraints
from .softness import CONVERGED, REST_SPEED, loaded_rows, row_softness_params

__all__ = ["MAX_ROTATION", "solve_substeps"]


# --------------------------------------------------------------------------------------
# Substeps (one compiled call per step).
# --------------------------------------------------------------------------------------


@njit(cache=True)
def _integrate_velocities(velocity, angular_velocity, inv_mass, linear_damping,
                          angular_damping, gravity, h):
    """v <- v / (1 + h c) + h g for dynamic bodies (Box2D v3 order); others untouched."""
    for i in range(inv_mass.shape[0]):
        if inv_mass[i] == 0.0:
            continue
        lin = 1.0 / (1.0 + h * linear_damping[i])
        velocity[i, 0] = velocity[i, 0] * lin + h * gravity[0]
        velocity[i, 1] = velocity[i, 1] * lin + h * gravity[1]
        angular_velocity[i] = angular_velocity[i] / (1.0 + h * angular_damping[i])


@njit(cache=True)
def _integrate_accelerations(velocity, angular_velocity, inv_mass, linear_damping,
                             angular_damping, linear, angular, h):
    """``_integrate_velocities`` with a per-body acceleration in place of gravity:
    v <- v / (1 + h c) + h a_i, w <- w / (1 + h c_w) + h alpha_i (dynamic bodies)."""
    for i in range(inv_mass.shape[0]):
        if inv_mass[i] == 0.0:
            continue
        lin = 1.0 / (1.0 + h * linear_damping[i])
        velocity[i, 0] = velocity[i, 0] * lin + h * linear[i, 0]
        velocity[i, 1] = velocity[i, 1] * lin + h * linear[i, 1]
        angular_velocity[i] = angular_velocity[i] / (1.0 + h * angular_damping[i]) + h * angular[i]


#: Largest rotation of a body in one substep, rad (Box2D v3's B2_MAX_ROTATION).
MAX_ROTATION = 0.25 * math.pi
#: Largest over-relaxation m k a row's prepared effective mass m may reach as its arms
#: move (1/k: the mass of the current arms; module docstring, "Effective masses"): half
#: way from Gauss-Seidel's 1 to the divergence at 2.
OVER_RELAXATION = 1.5


@njit(cache=True)
def _integrate_positions(com, angle, velocity, angular_velocity, max_speed, h):
    """x <- x + h v, angle <- angle + h w (semi-implicit Euler); |v| clamped to max_speed,
    |w| h clamped to MAX_ROTATION (Box2D v3's cap: a contact's anchors are turned by each
    substep's rotation, which stops meaning anything when a body spins by a large
    fraction of a turn in one substep; a 2 cm circle spun up by friction at 300 m/s
    reached 27 rad per substep and slipped through a thin wall)."""
    limit = max_speed * max_speed
    max_w = MAX_ROTATION / h
    for i in range(angle.shape[0]):
        if angular_velocity[i] > max_w:
            angular_velocity[i] = max_w
        elif angular_velocity[i] < -max_w:
            angular_velocity[i] = -max_w
        vx = velocity[i, 0]
        vy = velocity[i, 1]
        speed2 = vx * vx + vy * vy
        if speed2 > limit:
            scale = max_speed / math.sqrt(speed2)
            vx *= scale
            vy *= scale
            velocity[i, 0] = vx
            velocity[i, 1] = vy
        com[i, 0] += h * vx
        com[i, 1] += h * vy
        angle[i] += h * angular_velocity[i]


@njit(cache=True)
def _any_below(values, limit):
    """Whether some value is below limit (no temporary array)."""
    for v in values:
        if v < limit:
            return True
    return False


@njit(cache=True)
def _integrate_pseudo(com, angle, pseudo_velocity, pseudo_angular, pseudo_impulse, h):
    """x <- x + h v', angle <- angle + h w' (v', w': the pseudo-velocities the split rows
    gave this substep); then v', w' and the pseudo-impulses are reset to 0."""
    for i in range(angle.shape[0]):
        com[i, 0] += h * pseudo_velocity[i, 0]
        com[i, 1] += h * pseudo_velocity[i, 1]
        angle[i] += h * pseudo_angular[i]
        pseudo_velocity[i, 0] = 0.0
        pseudo_velocity[i, 1] = 0.0
        pseudo_angular[i] = 0.0
    pseudo_impulse[:] = 0.0


@njit(cache=True)
def _safe_moves(body_a, body_b, arm_a, arm_b, inv_mass, inv_inertia):
    """(B,) m^2, the square of how far each body's rows may let their bodies move apart
    in the step before an effective mass could over-relax its row past
    ``OVER_RELAXATION``, and the least of them, m^2. Rows (K,) of bodies body_a, body_b
    with arms arm_a, arm_b (K, 2); inv_mass, inv_inertia (B,).

    A row's arms move with the pair's relative displacement D (``_update_anchors``), so
    an arm of length at most R (the body's longest) turns (r x n)^2 by at most
    (2 R + u) u for |D| <= u, and k = ma + mb + ia (ra x n)^2 + ib (rb x n)^2 grows by at
    most the sum of ia (2 R + u) u over its two bodies. Each term stays within
    (OVER_RELAXATION - 1) times its body's inverse mass, so k within OVER_RELAXATION
    times the prepared k (which is at least ma + mb), while u is at most the root
    u* = c / (R + sqrt(R^2 + c)), c = (OVER_RELAXATION - 1) m / i (inf for a body that
    cannot turn)."""
    n = inv_mass.shape[0]
    reach = np.zeros(n)
    body_a, body_b = unsigned(body_a), unsigned(body_b)
    for k in range(body_a.shape[0]):
        a = body_a[k]
        b = body_b[k]
        reach[a] = max(reach[a], arm_a[k, 0] * arm_a[k, 0] + arm_a[k, 1] * arm_a[k, 1])
        reach[b] = max(reach[b], arm_b[k, 0] * arm_b[k, 0] + arm_b[k, 1] * arm_b[k, 1])
    safe = np.full(n, np.inf)
    safest = np.inf
    for i in range(n):
        if inv_inertia[i] > 0.0:
            r = math.sqrt(reach[i])
            c = (OVER_RELAXATION - 1.0) * inv_mass[i] / inv_inertia[i]
            u = c / (r + math.sqrt(r * r + c))
            safe[i] = u * u
            safest = min(safest, safe[i])
    return safe, safest


@njit(cache=True)
def _update_anchors(com, com0, angle, angle0, round_body, cos_d, sin_d, inv_mass, body_a,
                    body_b, normal, anchor_a0, anchor_b0, base_separation, arm_a0, arm_b0,
                    anchor_a, anchor_b, separation, inv_inertia, safe, safest,
                    normal_mass, tangent_mass):
    """Re-measure every separation from the accumulated moves; re-base the anchors.

    s = base + n.(dp_b + R(dq_b) sb0 - dp_a - R(dq_a) sa0), no collision query, sa0, sb0
    the bodies' surface points (anchor_a0, anchor_b0).
    Lever arms: with D = dp_b - dp_a and inverse masses ma, mb, ra = ra0 + mb / (ma + mb) D
    and rb = rb0 - ma / (ma + mb) D (ra0, rb0: arm_a0, arm_b0, the arms to the contact
    point at the start of the step), so x_a + ra = x_b + rb (one common point; module
    docstring). Against a static or kinematic body the movable body keeps its anchor.
    cos_d, sin_d: (B,) scratch for the rotation of each body since the start of the step.
    normal_mass, tangent_mass (K,) kg: replaced by the current arms' effective masses
    where they are over ``OVER_RELAXATION`` times those (module docstring, "Effective
    masses"), checked only in the rows whose bodies moved apart farther than both's safe
    moves (inv_inertia (B,) 1/(kg m^2); safe (B,) m^2 and their least, safest m^2:
    ``_safe_moves``).
    A circle's anchor is not turned (round_body): its surface is the same in every
    orientation, so its rotation moves no surface point along the normal; turning the
    anchor would lift it by r (1 - cos dq) and let a rolling circle sink and bounce
    (measured before: a 0.3 m ball rolling at 1.3 m/s reported -0.054 m/s vertically).
    """
    for i in range(angle.shape[0]):
        if round_body[i]:
            cos_d[i] = 1.0
            sin_d[i] = 0.0
        else:
            cos_d[i] = math.cos(angle[i] - angle0[i])
            sin_d[i] = math.sin(angle[i] - angle0[i])
    body_a, body_b = unsigned(body_a), unsigned(body_b)
    for k in range(body_a.shape[0]):
        a = body_a[k]
        b = body_b[k]
        ra0x = anchor_a0[k, 0]
        ra0y = anchor_a0[k, 1]
        rb0x = anchor_b0[k, 0]
        rb0y = anchor_b0[k, 1]
        rax = cos_d[a] * ra0x - sin_d[a] * ra0y
        ray = sin_d[a] * ra0x + cos_d[a] * ra0y
        rbx = cos_d[b] * rb0x - sin_d[b] * rb0y
        rby = sin_d[b] * rb0x + cos_d[b] * rb0y
        nx = normal[k, 0]
        ny = normal[k, 1]
        dx = (com[b, 0] - com0[b, 0]) - (com[a, 0] - com0[a, 0])
        dy = (com[b, 1] - com0[b, 1]) - (com[a, 1] - com0[a, 1])
        separation[k] = base_separation[k] + (dx + rbx - rax) * nx + (dy + rby - ray) * ny
        ma = inv_mass[a]
        mb = inv_mass[b]
        share_b = mb / (ma + mb)
        share_a = 1.0 - share_b
        anchor_a[k, 0] = arm_a0[k, 0] + share_b * dx
        anchor_a[k, 1] = arm_a0[k, 1] + share_b * dy
        anchor_b[k, 0] = arm_b0[k, 0] - share_a * dx
        anchor_b[k, 1] = arm_b0[k, 1] - share_a * dy
        moved = dx * dx + dy * dy
        if moved <= safest or moved <= min(safe[a], safe[b]):
            continue
        # The over-relaxation m k of each row with the moved arms (no division unless a
        # mass is replaced).
        ia = inv_inertia[a]
        ib = inv_inertia[b]
        rna = anchor_a[k, 0] * ny - anchor_a[k, 1] * nx
        rnb = anchor_b[k, 0] * ny - anchor_b[k, 1] * nx
        rta = -anchor_a[k, 0] * nx - anchor_a[k, 1] * ny
        rtb = -anchor_b[k, 0] * nx - anchor_b[k, 1] * ny
        k_n = ma + mb + ia * rna * rna + ib * rnb * rnb
        k_t = ma + mb + ia * rta * rta + ib * rtb * rtb
        if normal_mass[k] * k_n > OVER_RELAXATION:
            normal_mass[k] = 1.0 / k_n
        if tangent_mass[k] * k_t > OVER_RELAXATION:
            tangent_mass[k] = 1.0 / k_t


@njit(cache=True)
def _warm_start(velocity, angular_velocity, inv_mass, inv_inertia, body_a, body_b, pair_start,
                normal, anchor_a, anchor_b, normal_impulse, tangent_impulse, total_normal_impulse,
                total_tangent_impulse):
    """Apply the accumulated impulses P = l_n n + l_t t at the current anchors; add them to
    the step's totals (the tangent total is completed at the end of ``_substeps_kernel``)."""
    body_a, body_b, pair_start = unsigned(body_a), unsigned(body_b), unsigned(pair_start)
    for p in range(pair_count(pair_start)):
        first, last, a, b, ma, ia, mb, ib = pair_bodies(p, pair_start, body_a, body_b,
                                                        inv_mass, inv_inertia)
        vax, vay, wa, vbx, vby, wb = load_pair(velocity, angular_velocity, a, b)
        for k in range(first, last):
            nx = normal[k, 0]
            ny = normal[k, 1]
            px = normal_impulse[k] * nx + tangent_impulse[k] * ny
            py = normal_impulse[k] * ny - tangent_impulse[k] * nx
            total_normal_impulse[k] += normal_impulse[k]
            total_tangent_impulse[k] += tangent_impulse[k]
            vax, vay, wa, vbx, vby, wb = apply_vector(
                vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib, anchor_a[k, 0], anchor_a[k, 1],
                anchor_b[k, 0], anchor_b[k, 1], px, py)
        store_pair(velocity, angular_velocity, a, b, vax, vay, wa, vbx, vby, wb)


# --------------------------------------------------------------------------------------
# Split push-out: deep overlap leaves without entering the velocities.
#
# The soft row pushes an overlap out through the velocities, and the relax pass is meant
# to take that bias velocity back out (Box2D v3's soft step). Two cases defeat it:
# - a column: each contact of a column of N overlapping bodies separates at up to
#   max_push_out, so the top body is pushed at N times that; one relax pass undoes it
#   only near the bottom of the column (Gauss-Seidel spreads a correction one contact
#   per pass). 25 circles r 0.5 overlapping by 0.2 m in a 1.02 m wide shaft: they left
#   at up to 22 m/s (tests/test_split_push_out.py).
# - a jam: bodies that overlap and cannot move apart (25 circles side by side in a
#   20 m box) keep vn = 0, so the soft row's impulse grows to m_n bias / impulse_scale
#   (the spring's force at its capped bias: 4.9 kN between two 0.79 kg circles at
#   3 m/s), the relax cannot see it (vn is already 0) and the warm start carries it
#   over; the first body that slips out of line takes that force as velocity. 625 such
#   circles: 41 m/s, 41 kJ after ten steps.
# So a row whose overlap exceeds ``Settings.soft_depth`` is split (Catto's split
# impulses; Chipmunk's bias velocities, which pymunk runs):
# - in the velocities it is rigid (bias 0, mass_scale 1, impulse_scale 0): it stops
#   the approach and holds the load, its accumulated impulse warm-starts as any other;
# - its push-out bias = max(min(mass_scale bias_rate s, beta (s + soft_depth) / h),
#   -(max_push_out - max(vn, 0))), the faster of the soft row's own and a Baumgarte
#   fraction beta (``Settings.split_push_out``) of the overlap beyond soft_depth per
#   substep, capped so that with the pair's own separating speed vn (after its rigid
#   row) it stays within max_push_out, is a target for the pair's pseudo-velocities v'
#   (per body, zero at the start of every substep):
#   d_p = -m_n (n.(v'_b - v'_a at the contact) + bias), p >= 0;
# - the positions move by h (v + v') and v' is then dropped: the overlap goes no faster
#   than max_push_out per contact, and no kinetic energy is made. A jam's push-out
#   impulses are bounded by the passes of one substep and never stored.
# Why beta: the soft rate (bias_rate ~ 9/s at the defaults, 14 % of an overlap a step)
# is slower than a rolling or spinning body presses new overlap in (a body rolling on a
# curved field, a circle squeezed by a turning horn). beta = 0.5 takes 94 % of the
# excess out in a step's four substeps (Box2D v2's position solver: 0.2 per iteration,
# 3 iterations); pushing out only the excess over soft_depth leaves the last 5 mm to
# the soft row, so a column settling from deep overlap onto its soft rows never sinks
# back. Figures: docs/solver.md, "Split push-out".
# Shallower rows stay soft: resting contacts sag by a fraction of a millimetre
# (impulse_scale g h / (mass_scale bias_rate) = 0.07 mm for a body on the ground at
# the defaults; a body under n others about n times that, less with load stiffening),
# so stacks, piles and the loaded islands keep the soft step's behaviour; the split
# only takes over where overlap is deeper than 5 mm (pushed into place, dropped into a
# pile, squeezed). Each pseudo impulse pair is equal and opposite, so the
# mass-weighted centre of a free pair does not move.
# Measured (tests/stability, tools/stability_report.py), 625 circles packed 0.2 m deep
# in a 20 m box: separation 23 -> 1.62 m/s, fastest body 41 -> 0.54 m/s, kinetic
# energy over the last second / peak 0.21 -> 0.00035 (pymunk: 1.17, 0.87, 0.00082).
# soft_depth from 1 to 10 mm gives decay 0.00015-0.0054 there; 20 mm lets the jammed
# springs store enough to keep the pile churning (decay 0.26); 0 (every overlap split,
# as pymunk) lets a 20-box stack lean 12.8 cm in 30 s (1.3 cm at 5 mm).
# --------------------------------------------------------------------------------------


@njit(cache=True)
def _pseudo_push(pseudo_velocity, pseudo_angular, pseudo_impulse, k, a, b, ma, ia, mb, ib,
                 nx, ny, rna, rnb, normal_mass, bias):
    """Split row k: the impulse that makes the pair's pseudo-velocities separate at -bias
    (m/s, bias <= 0) along n, accumulated >= 0 in pseudo_impulse[k], applied to the
    pseudo-velocities (rigid: the pseudo-velocities start from 0 every substep)."""
    qax, qay, qa, qbx, qby, qb = load_pair(pseudo_velocity, pseudo_angular, a, b)
    vn = along(qax, qay, qa, qbx, qby, qb, nx, ny, rna, rnb)
    accumulated = max(pseudo_impulse[k] - normal_mass * (vn + bias), 0.0)
    impulse = accumulated - pseudo_impulse[k]
    pseudo_impulse[k] = accumulated
    qax, qay, qa, qbx, qby, qb = apply_impulse(
        qax, qay, qa, qbx, qby, qb, ma, ia, mb, ib, nx, ny, rna, rnb, impulse)
    store_pair(pseudo_velocity, pseudo_angular, a, b, qax, qay, qa, qbx, qby, qb)


@njit(cache=True)
def _solve(bodies, rows, pseudo, pairs, measured, inv_h, max_push_out, soft_depth,
           split_rate, use_bias, use_friction):
    """One Gauss-Seidel pass over the pairs ``pairs`` (indices into pair_start, in order):
    normal rows of the pair, then its friction rows.

    bodies: ``bundles.SubstepBodies``; rows: ``bundles.SubstepRows`` (ContactConstraints'
    arrays plus the row coefficients of ``row_softness``); pseudo: (pseudo_velocity,
    pseudo_angular, pseudo_impulse).

    Normal row k: s > 0 (speculative): bias = s / h, rigid (the gap may close, no more);
    else with ``use_bias`` soft, with row k's coefficients (``row_softness``):
    bias = max(mass_scale bias_rate s, -max_push_out),
    d_l = -m_n (mass_scale vn + bias) - impulse_scale l; without it rigid, bias 0.
    Accumulated l_n >= 0. Friction row: d_l = -m_t vt, accumulated |l_t| <= mu l_n.
    A row deeper than ``soft_depth`` (s < -soft_depth, see "Split push-out") is rigid in
    the velocities and, with ``use_bias``, pushes its pair apart in the pseudo-velocities
    instead: d_p = -m_n (vn' + bias) on the pair's pseudo-velocities vn', accumulated
    p >= 0 (``pseudo_impulse``, reset every substep), with bias = max(min(mass_scale
    bias_rate s, split_rate (s + soft_depth) / h), -(max_push_out - max(vn, 0))), vn the
    row's relative normal velocity after its rigid impulse ("Split push-out").

    Returns (largest |d_l_n|, largest accumulated l_n) over the pass's pairs p with
    ``measured[p]`` (the loaded islands' pairs), N s: how far the pass was from converged
    (``_sweeps``' extra passes stop on their ratio).
    """
    velocity, angular_velocity = bodies.velocity, bodies.angular_velocity
    inv_mass, inv_inertia = bodies.inv_mass, bodies.inv_inertia
    body_a, body_b = unsigned(rows.body_a), unsigned(rows.body_b)
    pair_start, normal = unsigned(rows.pair_start), rows.normal
    anchor_a, anchor_b, separation = rows.anchor_a, rows.anchor_b, rows.separation
    normal_mass, tangent_mass, friction = rows.normal_mass, rows.tangent_mass, rows.friction
    bias_rate, mass_scale, impulse_scale = rows.bias_rate, rows.mass_scale, rows.impulse_scale
    normal_impulse, tangent_impulse = rows.normal_impulse, rows.tangent_impulse
    total_normal_impulse = rows.total_normal_impulse
    pseudo_velocity, pseudo_angular, pseudo_impulse = pseudo
    largest_change = 0.0
    largest_impulse = 0.0
    for p in unsigned(pairs):
        first, last, a, b, ma, ia, mb, ib = pair_bodies(p, pair_start, body_a, body_b,
                                                        inv_mass, inv_inertia)
        vax, vay, wa, vbx, vby, wb = load_pair(velocity, angular_velocity, a, b)
        for k in range(first, last):
            nx = normal[k, 0]
            ny = normal[k, 1]
            s = separation[k]
            bias = 0.0
            m_scale = 1.0
            i_scale = 0.0
            rna = cross(anchor_a[k, 0], anchor_a[k, 1], nx, ny)
            rnb = cross(anchor_b[k, 0], anchor_b[k, 1], nx, ny)
            split = False
            if s > 0.0:
                bias = s * inv_h
            elif use_bias and s < -soft_depth:
                split = True
            elif use_bias:
                bias = max(mass_scale[k] * bias_rate[k] * s, -max_push_out)
                m_scale = mass_scale[k]
                i_scale = impulse_scale[k]
            # d_l = -m_n (m_scale vn + bias) - i_scale l, grouped so that only the product
            # with vn waits on the sweep's velocities (``along``).
            m_n = normal_mass[k]
            old = normal_impulse[k]
            vn = along(vax, vay, wa, vbx, vby, wb, nx, ny, rna, rnb)
            accumulated = max((old - m_n * bias - i_scale * old) - (m_n * m_scale) * vn, 0.0)
            impulse = accumulated - old
            normal_impulse[k] = accumulated
            total_normal_impulse[k] += impulse
            if measured[p]:
                largest_change = max(largest_change, abs(impulse))
                largest_impulse = max(largest_impulse, accumulated)
            vax, vay, wa, vbx, vby, wb = apply_impulse(
                vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib, nx, ny, rna, rnb, impulse)
            if split:
                # The push-out's cap counts the pair's own separating speed (vn >= 0 after
                # the rigid row): together they stay within max_push_out.
                vn = along(vax, vay, wa, vbx, vby, wb, nx, ny, rna, rnb)
                cap = max(max_push_out - max(vn, 0.0), 0.0)
                push = min(mass_scale[k] * bias_rate[k] * s,
                           split_rate * inv_h * (s + soft_depth))
                _pseudo_push(pseudo_velocity, pseudo_angular, pseudo_impulse, k, a, b, ma, ia,
                             mb, ib, nx, ny, rna, rnb, normal_mass[k], max(push, -cap))
        if use_friction:
            for k in range(first, last):
                mu = friction[k]
                if mu == 0.0:
                    continue
                tx = normal[k, 1]
                ty = -normal[k, 0]
                rta = cross(anchor_a[k, 0], anchor_a[k, 1], tx, ty)
                rtb = cross(anchor_b[k, 0], anchor_b[k, 1], tx, ty)
                old = tangent_impulse[k]
                limit = mu * normal_impulse[k]
                vt = along(vax, vay, wa, vbx, vby, wb, tx, ty, rta, rtb)
                accumulated = min(max(old - tangent_mass[k] * vt, -limit), limit)
                impulse = accumulated - old
                tangent_impulse[k] = accumulated
                vax, vay, wa, vbx, vby, wb = apply_impulse(
                    vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib, tx, ty, rta, rtb, impulse)
        store_pair(velocity, angular_velocity, a, b, vax, vay, wa, vbx, vby, wb)
    return largest_change, largest_impulse


@njit(cache=True)
def _still_within(pairs, caps, n):
    """The pairs (and their caps) whose cap of extra passes exceeds n, in order."""
    count = 0
    for i in range(pairs.shape[0]):
        count += caps[i] > n
    kept = np.empty(count, np.int64)
    kept_caps = np.empty(count, np.int64)
    count = 0
    for i in range(pairs.shape[0]):
        if caps[i] > n:
            kept[count] = pairs[i]
            kept_caps[count] = caps[i]
            count += 1
    return kept, kept_caps


@njit(cache=True)
def _lowest(caps, none):
    """The smallest cap, ``none`` if there is none."""
    lowest = none
    for cap in caps:
        lowest = min(lowest, cap)
    return lowest


@njit(cache=True)
def _sweeps(bodies, rows, pseudo, all_pairs, loaded, inv_h, max_push_out, soft_depth,
            split_rate, use_bias, use_friction, passes, joints):
    """One phase of a substep: ``passes`` ``_solve`` passes over every pair, then, if any
    ran, extra passes over the loaded islands' and the impacts' pairs, stopping after a
    pass whose largest normal impulse change is at most CONVERGED times the largest
    accumulated normal impulse, measured over those pairs; none when the last of
    the ``passes`` already meets it (without joints: their passes converge apart).
    loaded: (those pairs (L,), their caps (L,): pair i takes part in the first caps[i]
    extra passes (``row_softness``), (P,) bool: whether pair p is one of them).
    Returns the number of extra passes run.

    joints: None, or ``joint_direct.SubstepJoints`` (``_substeps_kernel``): with
    joints, each extra pass is followed by one pass over the joints, and convergence
    asks it of both (contacts converged alone push jointed bodies apart: a crate on a
    bridge of planks 25 times lighter opened its joints by 19 cm). None is a type, not
    a value, to numba: a scene without joints compiles no joint code.
    """
    pairs, caps, measured = loaded
    change = 0.0
    impulse = 0.0
    for _ in range(passes):
        change, impulse = _solve(bodies, rows, pseudo, all_pairs, measured, inv_h,
                                 max_push_out, soft_depth, split_rate, use_bias, use_friction)
    if passes == 0 or pairs.shape[0] == 0:
        return 0
    if joints is None and change <= CONVERGED * impulse:
        return 0
    highest = 0
    for cap in caps:
        highest = max(highest, cap)
    lowest = _lowest(caps, highest)
    for n in range(highest):
        if n >= lowest:
            pairs, caps = _still_within(pairs, caps, n)
            lowest = _lowest(caps, highest)
        change, impulse = _solve(bodies, rows, pseudo, pairs, measured, inv_h, max_push_out,
                                 soft_depth, split_rate, use_bias, use_friction)
        joints_converged = True
        if joints is not None:
            joint_passes(joints, SOLVE if use_bias else RELAX, inv_h, 1, False)
            progress = joints.out.progress
            joints_converged = progress[0] <= CONVERGED * progress[1]
        if change <= CONVERGED * impulse and joints_converged:
            return n + 1
    return highest


@njit(cache=True)
def _mirrored_order(large):
    """The pairs (P,) int64 in the order of the backward sweeps ("Sweep order"): the pairs
    of islands over rest_island_limit (``large`` (P,) bool) last, in reverse, the others
    first, in order (each island's pairs keep their order, so only the large islands'
    sweeps change)."""
    order = np.empty(large.shape[0], np.int64)
    count = 0
    for p in range(large.shape[0]):
        if not large[p]:
            order[count] = p
            count += 1
    for p in range(large.shape[0] - 1, -1, -1):
        if large[p]:
            order[count] = p
            count += 1
    return order


@njit(cache=True)
def _substeps_kernel(bodies, rows, gravity, loaded, large, h, substeps, relax_passes,
                     max_push_out, max_speed, use_friction, extra_passes, soft_depth,
                     split_rate, joints, accel):
    """All substeps of one step: integrate v, warm start, solve, integrate x, relax.

    bodies: the bodies (``bundles.SubstepBodies``), rows: the contact rows and their
    coefficients (``bundles.SubstepRows``), both updated in place. loaded: (the pairs
    with extra passes, their caps, (P,) bool: whether pair p is one), as ``_sweeps``;
    large: (P,) bool, the pairs of islands over rest_island_limit, swept in reverse in
    the second and third substep of every four ("Sweep order"); extra_passes: the most
    any pair takes (the joints' passes are bounded by it).

    joints: None (no joints: no joint code is compiled, numba prunes the branches on the
    None type), or the joints by reference (``joint_direct.SubstepJoints``: the rows,
    their softness, the islands' plan, the bodies' arrays they act on). The joint
    rows are warm started, solved and relaxed before the contacts in each phase (Box2D
    v3's order), each phase in passes until converged (``joint_direct.joint_passes``), and
    once more after the contacts when there are both: a contact's single pass must not
    open a loaded joint (a folding chain's links touching each other).

    After the solve and after the relax passes, the pairs of loaded islands and of
    impacts get up to their caps of extra passes (``_sweeps``).
    Rows deeper than ``soft_depth`` (m) are split: their overlap moves the positions
    through pseudo-velocities, integrated after the velocities and then discarded
    (``_integrate_pseudo``; see "Split push-out").
    accel: None (gravity alone), or per-body accelerations (linear (B, 2) m/s^2,
    angular (B,) rad/s^2) that replace gravity in the velocity integration
    (``_integrate_accelerations``: gravity scales, applied forces and torques).
    Returns (the number of those extra passes run, the number of substeps that had a
    split row, the number of solve and relax passes over the joints).
    """
    com, angle, velocity = bodies.com, bodies.angle, bodies.velocity
    angular_velocity, inv_mass, inv_inertia = (bodies.angular_velocity, bodies.inv_mass,
                                               bodies.inv_inertia)
    linear_damping, angular_damping = bodies.linear_damping, bodies.angular_damping
    round_body = bodies.round_body
    body_a, body_b, pair_start, normal = rows.body_a, rows.body_b, rows.pair_start, rows.normal
    anchor_a0, anchor_b0, anchor_a, anchor_b = (rows.anchor_a0, rows.anchor_b0, rows.anchor_a,
                                                rows.anchor_b)
    base_separation, separation = rows.base_separation, rows.separation
    normal_impulse, tangent_impulse = rows.normal_impulse, rows.tangent_impulse
    total_normal_impulse, total_tangent_impulse = (rows.total_normal_impulse,
                                                   rows.total_tangent_impulse)
    com0 = com.copy()
    angle0 = angle.copy()
    start_tangent = tangent_impulse.copy()
    arm_a0 = anchor_a.copy()
    arm_b0 = anchor_b.copy()
    cos_d = np.empty_like(angle)
    sin_d = np.empty_like(angle)
    safe, safest = _safe_moves(body_a, body_b, arm_a0, arm_b0, inv_mass, inv_inertia)
    inv_h = 1.0 / h
    has_contacts = body_a.shape[0] > 0
    forward = np.arange(pair_start.shape[0] - 1)
    mirrored = _mirrored_order(large)
    pseudo_velocity = np.zeros_like(velocity)
    pseudo_angular = np.zeros_like(angular_velocity)
    pseudo_impulse = np.zeros_like(separation)
    pseudo = (pseudo_velocity, pseudo_angular, pseudo_impulse)
    joint_passes_max = JOINT_PASSES * (extra_passes + 1)
    passes_run = 0
    push_outs = 0
    joint_runs = 0
    for i in range(substeps):
        all_pairs = mirrored if i % 4 == 1 or i % 4 == 2 else forward
        split = has_contacts and _any_below(separation, -soft_depth)
        push_outs += split
        if accel is None:
            _integrate_velocities(velocity, angular_velocity, inv_mass, linear_damping,
                                  angular_damping, gravity, h)
        else:
            _integrate_accelerations(velocity, angular_velocity, inv_mass, linear_damping,
                                     angular_damping, accel[0], accel[1], h)
        if joints is not None:
            joint_passes(joints, WARM, inv_h, 1, False)
        if has_contacts:
            _warm_start(velocity, angular_velocity, inv_mass, inv_inertia, body_a, body_b,
                        pair_start, normal, anchor_a, anchor_b, normal_impulse, tangent_impulse,
                        total_normal_impulse, total_tangent_impulse)
        if joints is not None:
            joint_runs += joint_passes(joints, SOLVE, inv_h, joint_passes_max, False)
        if has_contacts:
            extra = _sweeps(bodies, rows, pseudo, all_pairs, loaded, inv_h, max_push_out,
                            soft_depth, split_rate, True, use_friction, 1, joints)
            passes_run += extra
            if joints is not None:
                joint_runs += extra          # each extra pass ends with one joint pass
        _integrate_positions(com, angle, velocity, angular_velocity, max_speed, h)
        if split:
            _integrate_pseudo(com, angle, pseudo_velocity, pseudo_angular, pseudo_impulse, h)
        if has_contacts:
            _update_anchors(com, com0, angle, angle0, round_body, cos_d, sin_d, inv_mass,
                            body_a, body_b, normal, anchor_a0, anchor_b0, base_separation,
                            arm_a0, arm_b0, anchor_a, anchor_b, separation, inv_inertia,
                            safe, safest, rows.normal_mass, rows.tangent_mass)
        if joints is not None and relax_passes > 0:
            joint_runs += joint_passes(joints, RELAX, inv_h, max(relax_passes,
                                                                 joint_passes_max), True)
        if has_contacts:
            extra = _sweeps(bodies, rows, pseudo, all_pairs, loaded, inv_h, max_push_out,
                            soft_depth, split_rate, False, use_friction, relax_passes, joints)
            passes_run += extra
            if joints is not None:
                joint_runs += extra
    # Friction applied in substep s is its accumulated value at the substep's end, l_s:
    # the warm starts added l_0 .. l_(S-1), and l_S - l_0 completes the sum l_1 .. l_S
    # (no extra work in the friction rows' passes).
    for k in range(tangent_impulse.shape[0]):
        total_tangent_impulse[k] += tangent_impulse[k] - start_tangent[k]
    return passes_run, push_outs, joint_runs


def solve_substeps(bodies: BodyState, constraints: ContactConstraints, gravity: np.ndarray,
                   settings: Settings, use_friction: bool,
                   joints: tuple[JointRows, np.ndarray] | None = None,
                   accel: tuple[np.ndarray, np.ndarray] | None = None,
                   kernel_only: bool = False
                   ) -> tuple[int, int, int, np.ndarray | None]:
    """Run every substep of one step in place (one compiled call).

    accel: None, or (linear (B, 2) m/s^2, angular (B,) rad/s^2): each dynamic body's
    acceleration, integrated every substep in place of gravity (the world's gravity
    scales, forces and torques; ``World.apply_force``).

    joints: (the joint rows, the cap on their load stiffening (1,)) (``solver.joints``),
    solved with the contacts; the rows' accumulated impulses and the cap are updated in
    place (None: no joints).

    gravity: (2,) m/s^2, applied to dynamic bodies. ``use_friction`` False skips the
    friction rows (the caller passes False when every contact's friction is 0).
    Returns (the number of extra passes run over loaded islands, ``row_softness``; the
    number of substeps with a row deeper than ``soft_depth``, "Split push-out"; the
    number of solve and relax passes over the joints, ``joint_direct.joint_passes``; the
    islands of the contacts, (B,) int64 roots as ``islands.island_roots`` gives them for
    ``bodies.inv_mass`` and the rows' bodies, found by the row softness kernel (falling
    asleep takes them when no joint links islands: ``world_sleep.islands_falling``), or
    None with ``kernel_only``).

    kernel_only: for ``constraints`` with no rows only (the compiling child of a cold
    start, ``world_stages.compile_ahead``): the substep kernel without the row softness
    kernel before it, with no loaded pairs, which are the softness kernel's to find; the
    child compiles the substep kernel first while the parent, which meets the softness
    kernel first in its step, compiles that one.
    """
    c = constraints
    h = settings.dt / settings.substeps
    gravity = np.asarray(gravity, dtype=np.float64)
    if joints is not None and len(joints[0].kind) > 0:
        rows, cap = joints
        packed = pack(rows)
        joint_soft, stiffening = stiffened_softness(bodies.inv_mass, bodies.inv_inertia, rows,
                                                    settings, gravity, float(cap[0]), packed)
        islands = kernel_plan(plan(packed, bodies.inv_mass, bodies.inv_inertia))
        joint_args = substep_joints(bodies, packed, joint_soft, spring_softness(rows, h),
                                    stiffening, islands)
    else:
        joint_args = None
    k = len(c.feature)
    row_ref = substep_rows(c, np.empty(k), np.empty(k), np.empty(k))  # filled by loaded_rows
    if kernel_only:
        if k:
            raise ValueError("kernel_only: only for constraints with no rows")
        loaded_pairs, caps = np.zeros(0, np.int64), np.zeros(0, np.int64)
        large = np.zeros(max(len(c.pair_start) - 1, 0), np.bool_)
        root = None
    else:
        v, w = bodies.velocity, bodies.angular_velocity
        spin = 0.0 if bodies.radius is None else w * np.where(bodies.inv_mass > 0.0,
                                                              bodies.radius, 0.0)
        moving = v[:, 0] ** 2 + v[:, 1] ** 2 + spin * spin > REST_SPEED ** 2
        loaded_pairs, caps, large, root = loaded_rows(
            bodies.inv_mass, row_ref, row_softness_params(settings, gravity), moving)
    measured = np.zeros(max(len(c.pair_start) - 1, 0), np.bool_)
    measured[loaded_pairs] = True
    passes, push_outs, joint_runs = _substeps_kernel(
        substep_bodies(bodies), row_ref,
        gravity, (loaded_pairs, caps, measured), large,
        h, settings.substeps, settings.relax_passes, settings.max_push_out,
        settings.max_linear_speed, use_friction, settings.stiff_iterations - 1,
        settings.soft_depth, settings.split_push_out, joint_args,
        accel)
    if joint_args is not None:
        cap[0] = stiffening[4]
        unpack_impulses(packed, rows)
    return int(passes), int(push_outs), int(joint_runs), root
