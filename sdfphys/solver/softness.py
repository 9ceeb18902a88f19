"""Soft contact rows and loaded islands: the coefficients each contact row is solved with.

``soft_coefficients`` / ``contact_softness``: Box2D v3's soft step (Catto, "Soft
Constraints", GDC 2011; ``b2MakeSoft``), derived below. ``row_softness``: the per-row
coefficients with load stiffening, and which islands get converged passes ("Loaded
islands" below).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numba.experimental import structref

from .._jit import njit
from ..islands import join, root_of
from ..settings import Settings
from .bundles import PlainFields, SubstepRows
from .pair_rows import ONE, pair_count, unsigned

if TYPE_CHECKING:
    from .rows import ContactConstraints

__all__ = ["CONVERGED", "IMPACT_HOPS", "LOADED", "MASS_RATIO", "REST_SPEED", "SOFTNESS_PARAMS",
           "RowSoftnessParams", "Softness", "SoftnessRows", "contact_softness", "loaded_rows",
           "row_softness", "row_softness_params", "soft_coefficients"]


# --------------------------------------------------------------------------------------
# Soft constraint coefficients (Catto, "Soft Constraints" GDC 2011; Box2D v3 b2MakeSoft).
#
# Treat a constraint C (here the separation s) as a spring-damper of the effective mass
# m: stiffness k = m w^2, damping c = 2 m z w, w = 2 pi f. One implicit Euler substep h,
# with C2 = C1 + h v2 and impulse lambda = m (v2 - v1):
#     m (v2 - v1) = -h k (C1 + h v2) - h c v2.
# Divide by m, write a1 = 2 z + h w and a2 = h w a1 = 2 h z w + h^2 w^2:
#     (v2 - v1) (1 + a2) = -a2 v1 - h w^2 C1
#     v2 - v1 = -(a2 / (1 + a2)) (v1 + (w / a1) C1).
# So with bias_rate = w / a1, mass_scale = a2 a3 and a3 = 1 / (1 + a2):
#     lambda = -m mass_scale (v1 + bias_rate C1).
# In an iterative solver v is the velocity that already contains the accumulated
# impulse lambda_0 of this row; the free velocity is v - lambda_0 / m, and the increment
# that makes the total equal the formula above is
#     d_lambda = -m mass_scale (vn + bias_rate C) - (1 - mass_scale) lambda_0,
# where 1 - mass_scale = a3 = impulse_scale. As in Box2D the position part is capped:
#     bias = max(mass_scale bias_rate s, -max_push_out),
#     d_lambda = -m (mass_scale vn + bias) - impulse_scale lambda_0.
# Unit values (docs/solver.md): f=30, z=10, h=1/240 -> 9.069 /s, 0.9423, 0.0577.
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Softness:
    """Coefficients of a soft constraint for one substep (see the derivation above).

    bias_rate: 1/s, the fraction of the separation removed per second of velocity bias.
    mass_scale, impulse_scale: dimensionless, mass_scale + impulse_scale = 1.
    """

    bias_rate: float
    mass_scale: float
    impulse_scale: float


def soft_coefficients(hertz: float, damping_ratio: float, h: float) -> Softness:
    """The soft constraint of stiffness ``hertz`` (Hz) and ``damping_ratio`` for substep ``h`` (s).

    ``hertz == 0`` gives a rigid constraint (no bias, mass_scale 1, impulse_scale 0).
    """
    if hertz == 0.0:
        return Softness(0.0, 1.0, 0.0)
    omega = 2.0 * math.pi * hertz
    a1 = 2.0 * damping_ratio + h * omega
    a2 = h * omega * a1
    a3 = 1.0 / (1.0 + a2)
    return Softness(omega / a1, a2 * a3, a3)


def contact_softness(settings: Settings) -> tuple[Softness, Softness]:
    """(between two movable bodies, against a static or kinematic body) for ``settings``.

    The contact hertz is capped at 0.25 x the substep rate (a stiffer spring than the
    substep can resolve would ring); contacts against an infinite mass use twice the
    capped hertz, so that piles are not pushed into the ground (Box2D v3).
    """
    h = settings.dt / settings.substeps
    hertz = min(settings.contact_hertz, 0.25 / h)
    return (soft_coefficients(hertz, settings.contact_damping_ratio, h),
            soft_coefficients(2.0 * hertz, settings.contact_damping_ratio, h))


# --------------------------------------------------------------------------------------
# Loaded islands: heavy loads on light bodies.
#
# The soft row above is a spring of stiffness m w^2 for the row's effective mass m, whatever
# it carries, so a load F sinks F / (m w^2): a 1 kg unit box under a 100 kg one sags
# 43.5 mm at rest (30 Hz), under 1000 kg it is crushed, and a 20-box stack, whose
# interfaces are rotational springs of the same stiffness, buckles (Greenhill). Stiffer
# rows alone do not help: Gauss-Seidel on a light body between a heavy one and the ground
# removes only about m / M of the heavy body's error per pass, and stiff rows that are not
# converged squeeze the light body out sideways (measured: 100:1 and the 300:1 pyramid
# collapse with stiffened rows and one pass). So, only in islands that need it, both:
#
# 1. Load stiffening (``Settings.load_stiffening``). Body i's load P_i is the sum of the
#    downward (along gravity) components of the normal impulses other dynamic bodies
#    push it with, from the warm start (last step's accumulated impulses, per substep),
#    and r_i = 1 + P_i / (m_i |g| h) the weights it carries (1: its own; the ground's
#    reaction does not count, so a box that lands alone is not loaded by its impact).
#    A row of a pair in a loaded island uses
#    r = max(r_a, r_b) (dynamic bodies) and the spring and damper of effective mass r m:
#    k' = r m w^2 and c' = 2 r m z w, that is the soft coefficients for w' = w sqrt(r)
#    and z' = z sqrt(r) (divide the implicit update by m). Every loaded body then sags
#    as much as under its own weight alone.
# 2. Convergence (``Settings.stiff_iterations``): after the solve and after the relax
#    passes of each substep, the pairs of loaded islands get more passes, until the
#    largest normal impulse change of a pass is at most CONVERGED times the largest
#    accumulated normal impulse.
#
# An island is the set of dynamic bodies connected by contacts between dynamic bodies
# (``islands``: static, kinematic and sleeping bodies do not join). It is loaded if it
# has at most ``Settings.stiff_island_limit`` dynamic bodies, or at most
# ``Settings.rest_island_limit`` if none of its rows is deeper than
# ``Settings.soft_depth`` at the start of the step (it is not pushing out overlap:
# ``substeps``, "Split push-out"), and two touching bodies whose masses
# differ by MASS_RATIO or more, or (with load stiffening) a body carrying more than
# LOADED times its weight. Larger islands (piles of thousands of circles) and large
# islands pushing out overlap keep one pass per substep, so their cost does not grow,
# and load stiffening counts at most ``Settings.large_island_load_cap`` weights there:
# rows stiffer than that need the converged passes. Why two limits (measured, default
# settings): a base-40 pyramid (820 boxes) with one pass sags under its 40 layers, the
# top 6.3 cm in 2 s; converged it moves 8.7 mm, at the same step time (58 ms, most of it
# collision). 625 circles packed 0.2 m deep (one island of split rows) converged are
# pushed out at 6.6 m/s instead of 1.6, at 12 times the cost: stiffened, converged rows
# in a jam store what the split push-out keeps out of the velocities. The cap, measured
# (before rest_island_limit) on a base-20 pyramid of 210 unit boxes with exact box
# contacts and one pass per substep (tests/test_solver.py), top box moved in 20 s:
# 3.3 cm unstiffened, 1.8 cm with a cap of 2, 1.2 cm with 3, 8.3 cm and drifting with
# 4; with sdfphys' own contacts 41 cm uncapped. The cap is 2, half the unstable value.
# The 5,000-circle pile of tools/bench_vs_peers.py: deepest overlap 0.114 -> 0.050 m
# with it. Bodies
# carrying only their own weight keep contact_softness's coefficients, bit for bit,
# and no extra pass runs.
#
# Measured (tools/stability_report.py, default settings): heavy box sink 100:1
# 62 -> 1.3 mm, 1000:1 crushed -> 15 mm, 400 kg dropped on two 1 kg boxes 218 -> 1.7 mm,
# base-5 pyramid under a 300 kg top box 113 -> 1.1 mm, a 20-box stack stands 30 s
# (top 1.3 cm; it buckled before).
# --------------------------------------------------------------------------------------

#: Touching dynamic bodies whose masses differ by this factor make their island loaded.
MASS_RATIO = 4.0
#: A body carrying more than this many times its own weight makes its island loaded.
LOADED = 1.25
#: Extra passes stop when the largest impulse change is this fraction of the largest impulse.
CONVERGED = 1e-4
#: An island with a body faster than this (m/s; |v|^2 + |w r|^2 at the start of the step,
#: r its bounding radius) is not at rest: rest_island_limit does not apply to it.
REST_SPEED = 0.5
#: Contacts from an impact that take its extra passes (``_impact_region``). In
#: scenes/circles_in_box.toml (150 circles poured in rows), impact_iterations 4, the
#: deepest contact over the scene: 1 hop 10.9 mm, 2 hops 7.0, 4 hops 5.1, 6 hops 5.8.
IMPACT_HOPS = 4


# --------------------------------------------------------------------------------------
# Impacts: a column struck at once.
#
# Circles poured in rows land on a pile: the lowest of a falling column stops on it, and
# the ones above it, which fell with it (no relative speed, so their gaps stay open),
# must stop within the same step. One Gauss-Seidel pass per substep passes a velocity
# change about one contact up the column per pass, so the bodies above press into the
# stopped ones: in scenes/circles_in_box.toml (150 circles, one island above
# stiff_island_limit) a pair 2.1 mm apart at the start of a step ended it 23.4 mm deep
# (t = 1.1 s); with converged passes over the whole island, 1.7 mm. So a row that would
# close, at the relative normal speed vn the step began with, more than soft_depth
# beyond its gap (max(s, 0) + dt vn < -soft_depth) marks an impact, and the exact pairs
# (below) of the bodies within IMPACT_HOPS exact contacts of it (dynamic bodies, in
# islands of 2 to rest_island_limit bodies) get up to ``Settings.impact_iterations``
# passes per phase, stopping once converged as the loaded islands' do. Their rows keep
# their softness (an impact is no load). Piles over rest_island_limit (thousands of
# circles) keep one pass, so their cost does not grow; jammed islands, with a row
# deeper than one step's capped push-out clears (soft_depth + max_push_out dt, 55 mm
# at the defaults), keep it too: 625 circles packed 0.2 m deep (tests/stability)
# separated at 6.9 m/s with the passes, over the 3 m/s push-out cap (converged jammed
# rows store what the split push-out keeps out of the velocities, "Loaded islands"
# above). A row just past soft_depth is no jam: it is what an impact leaves, and with
# that as the rule one such row anywhere in the box of scenes/circles_in_box.toml
# turned the passes off for all its circles (deepest contact over five runs of the
# scene, start poses moved by 1e-6 m: 5.0-11.4 mm; 5.0-5.4 mm with the jam depth).
# Exact pairs only: pairs whose rows all come from closed forms (a circle's contacts and
# predicted rows, each through its centre; a clipped manifold of two convex polygons,
# one normal: ``_closed_form``). A concave polygon's or an sdf body's rows are per
# feature, each along its own face, from a descent;
# with them in the region the concave polygons' scene went from 13.1 mm deepest to 14,
# 17, 32 and 160 mm (2, 3, 4 and 8 passes; 43 mm with its end-pose rows): converging
# them turns a landing into a spin whose far vertices no row sees, and packs bodies
# into configurations the descent misreads (a contact read 198 mm deep where the bodies
# had moved millimetres). Boxes were left out with them until 2026-11-27: a column of three
# boxes struck at 8 m/s pressed 23.5 mm deep with one pass, 4.9 mm with the passes, and
# the ragdoll's limbs, struck through its joints, 5.6-12.1 mm over five nearby runs,
# 7.6-8.0 mm with them. A body that a region's body touches through a pair that is not
# exact gets its rows against static bodies into the passes, as the region's bodies
# do (a circle landing at 10 m/s on a triangle drove its tip 1.06 cm into the terrain,
# scenes/grid_terrain.toml; 6.2 mm with them), and so do the two bodies of an impact
# in such a pair (a U-shaped polygon struck an L resting on the ground, whose row
# against it, the last one solved, drove the L's corner 12.2 mm into the ground in one
# step, scenes/concave_polygons.toml). Figures: docs/solver.md, "Impacts".
# --------------------------------------------------------------------------------------


@njit(cache=True)
def _impact_region(inv_mass, body_a, body_b, separation, relative_velocity, dt, soft_depth,
                   root, size, rest_limit, exact, jammed):
    """(B,) bool: the dynamic bodies within IMPACT_HOPS exact contacts (``exact`` (K,)
    bool: the row's pair is exact, ``_closed_form``) of an impact in an exact pair
    (section above), in islands (``root``, ``size`` (B,): dynamic bodies per root) of 2
    to ``rest_limit`` bodies (a body alone has no column to stop) not ``jammed`` (per
    root: a row deeper than one step's push-out clears, a jam, not an impact).
    separation, relative_velocity: (K,) m and m/s at the start of the step; dt: s;
    soft_depth: m."""
    region = np.zeros(inv_mass.shape[0], np.bool_)
    seeds = False
    for k in range(body_a.shape[0]):
        if exact[k] and max(separation[k], 0.0) + dt * relative_velocity[k] < -soft_depth:
            for i in (body_a[k], body_b[k]):
                if (inv_mass[i] > 0.0 and not jammed[root[i]]
                        and 1 < size[root[i]] <= rest_limit):
                    region[i] = True
                    seeds = True
    if not seeds:
        return region
    for _ in range(IMPACT_HOPS):
        grown = region.copy()
        for k in range(body_a.shape[0]):
            if not exact[k]:
                continue
            a = body_a[k]
            b = body_b[k]
            if region[a] and inv_mass[b] > 0.0:
                grown[b] = True
            if region[b] and inv_mass[a] > 0.0:
                grown[a] = True
        region = grown
    return region


@njit(cache=True, inline="always")
def _closed_form(key):
    """Whether a row of feature ``key`` comes from a closed form (sources 0, a circle's
    contact; 5, a clipped manifold of two convex polygons; 6 without FIELD_PAIR, a
    circle's predicted row), not from a descent. A pair is exact when all its rows
    are."""
    source = key >> 52                  # the source (3 bits) and FIELD_PAIR's bit
    return source == 0 or source == 5 << 4 or source == 6 << 4


class SoftnessRows(NamedTuple):
    """The rows' arrays ``row_softness`` reads and fills, as ``bundles.SubstepRows`` holds
    them (the fields of ``rows.ContactConstraints`` of these names, and the coefficients
    (K,) it fills: bias_rate 1/s, mass_scale, impulse_scale). The substep solve passes
    its ``SubstepRows`` instead (``loaded_rows``), one reference for both kernels."""

    body_a: np.ndarray
    body_b: np.ndarray
    pair_start: np.ndarray
    normal: np.ndarray
    normal_impulse: np.ndarray
    stiff: np.ndarray
    separation: np.ndarray
    relative_velocity: np.ndarray
    feature: np.ndarray
    bias_rate: np.ndarray
    mass_scale: np.ndarray
    impulse_scale: np.ndarray


@structref.register
class _RowSoftnessParamsType(PlainFields):
    """Numba's type of ``RowSoftnessParams``."""


class RowSoftnessParams(structref.StructRefProxy):
    """What ``row_softness`` takes from the settings and gravity, by reference (made by
    ``_row_softness_params``, once per settings and gravity; opaque to Python).

    up: (2,) unit, against gravity (zero without gravity). weight_impulse: N s / kg,
    |g| h, the impulse per substep that carries 1 kg (0: no gravity, no load
    stiffening). omega: rad/s, the capped base stiffness (doubled for stiff rows);
    zeta: its damping ratio; h: s, the substep. base_bias_rate (1/s), base_mass_scale,
    base_impulse_scale: (2,) ``contact_softness``' coefficients, [movable, static],
    used where r = 1. stiffen: bool, ``load_stiffening``. limit: the largest loaded
    island (dynamic bodies); rest_limit: the same for islands with no row deeper than
    soft_depth (m); large_cap: the most weights counted in larger islands, which get no
    extra pass. dt: s, the step. stiff_passes, impact_passes, rest_passes: int, the
    extra passes per phase of a loaded pair, at most (stiff, impact, rest; each at most
    ``stiff_iterations - 1``). jam_depth: m, a row deeper marks its island jammed (no
    impact passes).
    """


SOFTNESS_PARAMS = ("up", "weight_impulse", "omega", "zeta", "h", "base_bias_rate",
                   "base_mass_scale", "base_impulse_scale", "stiffen", "limit", "rest_limit",
                   "large_cap", "soft_depth", "dt", "stiff_passes", "impact_passes",
                   "rest_passes", "jam_depth")
structref.define_proxy(RowSoftnessParams, _RowSoftnessParamsType, list(SOFTNESS_PARAMS))


@njit(cache=True)
def _row_softness_params(up, weight_impulse, omega, zeta, h, base_bias_rate, base_mass_scale,
                         base_impulse_scale, stiffen, limit, rest_limit, large_cap,
                         soft_depth, dt, stiff_passes, impact_passes, rest_passes,
                         jam_depth):
    return RowSoftnessParams(up, weight_impulse, omega, zeta, h, base_bias_rate,
                             base_mass_scale, base_impulse_scale, stiffen, limit, rest_limit,
                             large_cap, soft_depth, dt, stiff_passes, impact_passes,
                             rest_passes, jam_depth)


#: The last ``row_softness_params``: (settings, gravity x, gravity y, the bundle).
_LAST_PARAMS: list = [None]


def row_softness_params(settings: Settings, gravity: np.ndarray) -> RowSoftnessParams:
    """``RowSoftnessParams`` of ``settings`` under ``gravity`` (2,) m/s^2; the last one
    made is kept (a world steps with the same settings and gravity)."""
    gx, gy = float(gravity[0]), float(gravity[1])
    last = _LAST_PARAMS[0]
    if last is not None and last[0] is settings and last[1] == gx and last[2] == gy:
        return last[3]
    soft, stiff = contact_softness(settings)
    h = settings.dt / settings.substeps
    g = float(np.hypot(gx, gy))
    up = -np.asarray(gravity, np.float64) / g if g > 0.0 else np.zeros(2)
    most = settings.stiff_iterations - 1
    params = _row_softness_params(
        up, g * h, 2.0 * math.pi * min(settings.contact_hertz, 0.25 / h),
        float(settings.contact_damping_ratio), h, np.array([soft.bias_rate, stiff.bias_rate]),
        np.array([soft.mass_scale, stiff.mass_scale]),
        np.array([soft.impulse_scale, stiff.impulse_scale]), bool(settings.load_stiffening),
        int(settings.stiff_island_limit), int(settings.rest_island_limit),
        float(settings.large_island_load_cap), float(settings.soft_depth),
        float(settings.dt), int(most), int(min(settings.impact_iterations - 1, most)),
        int(min(settings.rest_iterations - 1, most)),
        float(settings.soft_depth + settings.max_push_out * settings.dt))
    _LAST_PARAMS[0] = (settings, gx, gy, params)
    return params


@njit(cache=True)
def _row_softness_kernel(inv_mass, moving, rows, params):
    """Fill the rows' coefficients bias_rate, mass_scale, impulse_scale (K,); returns
    the loaded pairs (L,) int64 (indices into pair_start, in order), their extra
    passes per phase, at most (L,) int64, whether each pair (P,) bool belongs to an
    island of more than rest_limit dynamic bodies (one pass per phase, whatever else
    holds: ``substeps``, "Sweep order"), and the contacts' islands (B,) int64
    (``islands.island_roots``; falling asleep reuses them: ``solve_substeps``).

    inv_mass: (B,) 1/kg. moving: (B,) bool, bodies faster than REST_SPEED (their islands
    are not at rest). rows: ``bundles.SubstepRows`` (separation (K,) m at the start of
    the step, relative_velocity (K,) m/s, feature (K,) int64 keys: ``_closed_form``).
    params: ``RowSoftnessParams``. A pair's passes are the largest that applies of:
    stiff_passes (islands of at most ``limit`` bodies), impact_passes (the pairs of an
    impact's region (``_impact_region``) and the static rows of its bodies and of the
    bodies they touch through pairs that are not exact, or of an impact in such a pair),
    rest_passes (the islands at rest up to rest_limit).
    """
    # Indices through unsigned views (``pair_rows.unsigned``): no wraparound select at
    # each access.
    body_a, body_b = unsigned(rows.body_a), unsigned(rows.body_b)
    pair_start, normal = unsigned(rows.pair_start), rows.normal
    normal_impulse, stiff, separation = rows.normal_impulse, rows.stiff, rows.separation
    relative_velocity, feature = rows.relative_velocity, rows.feature
    bias_rate, mass_scale, impulse_scale = rows.bias_rate, rows.mass_scale, rows.impulse_scale
    up, weight_impulse, omega, zeta, h = (params.up, params.weight_impulse, params.omega,
                                          params.zeta, params.h)
    base_bias_rate, base_mass_scale, base_impulse_scale = (
        params.base_bias_rate, params.base_mass_scale, params.base_impulse_scale)
    stiffen, limit, rest_limit, large_cap = (params.stiffen, params.limit, params.rest_limit,
                                             params.large_cap)
    soft_depth, dt, jam_depth = params.soft_depth, params.dt, params.jam_depth
    extra_passes = (params.stiff_passes, params.impact_passes, params.rest_passes)
    loaded_pairs = np.empty(max(pair_start.shape[0] - 1, 0), np.int64)
    passes = np.empty(loaded_pairs.shape[0], np.int64)
    nb = inv_mass.shape[0]
    n_pairs = pair_count(pair_start)
    # One pass over the pairs and their rows, then one over the bodies (each island's
    # facts gathered at its root once the roots are known).
    ratio = np.ones(nb)
    weigh = stiffen and weight_impulse > 0.0
    parent = np.arange(nb)                       # union-find (``islands``)
    signed_a, signed_b = rows.body_a, rows.body_b
    exact = np.empty(feature.shape[0], np.bool_)   # each row's pair exact
    heavy = np.zeros(nb, np.bool_)      # body a of a pair of dynamic bodies of mass ratio
    deep = np.zeros(nb, np.bool_)       # a dynamic body of a row deeper than soft_depth
    jam = np.zeros(nb, np.bool_)        # ... than jam_depth
    for p in range(n_pairs):
        first, last = pair_start[p], pair_start[p + ONE]
        a = body_a[first]
        b = body_b[first]
        ma = inv_mass[a]
        mb = inv_mass[b]
        if ma > 0.0 and mb > 0.0 and (ma >= MASS_RATIO * mb or mb >= MASS_RATIO * ma):
            heavy[a] = True
        same = True
        for k in range(first, last):
            a = body_a[k]
            b = body_b[k]
            if weigh:
                # The impulse pushes b along +n and a along -n; count the push down,
                # from a dynamic body only (the ground's reaction is not a load).
                lift = normal_impulse[k] * (normal[k, 0] * up[0] + normal[k, 1] * up[1])
                if lift < 0.0 and inv_mass[a] > 0.0:
                    ratio[b] -= lift * inv_mass[b] / weight_impulse
                elif lift > 0.0 and inv_mass[b] > 0.0:
                    ratio[a] += lift * inv_mass[a] / weight_impulse
            join(parent, inv_mass, signed_a[k], signed_b[k])     # signed: int64 roots
            # An island pushing out overlap deeper than soft_depth (split rows), or with
            # a body faster than REST_SPEED, is not at rest. One deeper than jam_depth,
            # more than a step's capped push-out clears, is jammed.
            if separation[k] < -soft_depth:
                for i in (a, b):
                    if inv_mass[i] > 0.0:
                        deep[i] = True
                        if separation[k] < -jam_depth:
                            jam[i] = True
            same = same and _closed_form(feature[k])
        for k in range(first, last):
            exact[k] = same
    islands = np.empty(nb, np.int64)
    root = unsigned(islands)
    size = np.zeros(nb, np.int64)
    hot = np.zeros(nb, np.bool_)
    pushing = np.zeros(nb, np.bool_)
    jammed = np.zeros(nb, np.bool_)
    largest = np.full(nb, max(limit, rest_limit), np.int64)
    for i in range(nb):
        r = root_of(parent, i)
        islands[i] = r
        if inv_mass[i] > 0.0:
            size[r] += 1
            if ratio[i] > LOADED or heavy[i]:
                hot[r] = True
            if deep[i]:
                pushing[r] = True
            if jam[i]:
                jammed[r] = True
            if moving[i] or deep[i]:
                largest[r] = limit
    region = _impact_region(inv_mass, body_a, body_b, separation, relative_velocity, dt,
                            soft_depth, root, size, rest_limit, exact, jammed)
    stiff_passes, impact_passes, rest_passes = extra_passes
    # The other bodies a region's body touches through a pair that is not exact, and
    # the two bodies of an impact in such a pair: their rows against static bodies too
    # (the blow goes through them into the ground), not their rows with each other.
    touched = np.zeros(nb, np.bool_)
    for k in range(body_a.shape[0]):
        if exact[k]:
            continue
        a = body_a[k]
        b = body_b[k]
        if (max(separation[k], 0.0) + dt * relative_velocity[k] < -soft_depth
                and inv_mass[a] > 0.0 and inv_mass[b] > 0.0 and not jammed[root[a]]
                and 1 < size[root[a]] <= rest_limit):
            touched[a] = True
            touched[b] = True
        if region[a] and inv_mass[b] > 0.0:
            touched[b] = True
        if region[b] and inv_mass[a] > 0.0:
            touched[a] = True
    count = 0
    loaded = np.empty((2, 3))
    # The stiffness r whose coefficients ``loaded[j]`` hold (NaN: none yet); piles cap
    # most bodies' r at large_cap, so most pairs find theirs computed.
    loaded_r = np.full(2, np.nan)
    large = np.zeros(n_pairs, np.bool_)
    for p in range(n_pairs):
        first = pair_start[p]
        a = body_a[first]
        b = body_b[first]
        large[p] = size[root[b] if inv_mass[a] == 0.0 else root[a]] > rest_limit
        hot_a = inv_mass[a] > 0.0 and hot[root[a]] and size[root[a]] <= largest[root[a]]
        hot_b = inv_mass[b] > 0.0 and hot[root[b]] and size[root[b]] <= largest[root[b]]
        r = 1.0
        if inv_mass[a] > 0.0:
            r = ratio[a] if hot_a else min(ratio[a], large_cap)
        if inv_mass[b] > 0.0:
            r = max(r, ratio[b] if hot_b else min(ratio[b], large_cap))
        cap = 0
        if (((region[a] or region[b]) and exact[first])
                or ((region[a] or touched[a]) and inv_mass[b] == 0.0)
                or ((region[b] or touched[b]) and inv_mass[a] == 0.0)):
            cap = impact_passes
        if hot_a or hot_b:
            small = ((not hot_a or size[root[a]] <= limit)
                     and (not hot_b or size[root[b]] <= limit))
            cap = max(cap, stiff_passes if small else rest_passes)
        if cap > 0:
            loaded_pairs[count] = p
            passes[count] = cap
            count += 1
        # A loaded pair's coefficients for its plain and its stiff rows (base stiffness
        # omega, doubled), computed where r differs from the last r of that kind of row.
        for k in range(first, pair_start[p + ONE]):
            j = stiff[k]
            if r == 1.0:
                bias_rate[k] = base_bias_rate[j]
                mass_scale[k] = base_mass_scale[j]
                impulse_scale[k] = base_impulse_scale[j]
                continue
            if r != loaded_r[j]:
                root_r = math.sqrt(r)
                w = omega * (2.0 if j else 1.0) * root_r
                a1 = 2.0 * zeta * root_r + h * w
                a2 = h * w * a1
                a3 = 1.0 / (1.0 + a2)
                loaded[j, 0], loaded[j, 1], loaded[j, 2] = w / a1, a2 * a3, a3
                loaded_r[j] = r
            bias_rate[k], mass_scale[k], impulse_scale[k] = \
                loaded[j, 0], loaded[j, 1], loaded[j, 2]
    return loaded_pairs[:count], passes[:count], large, islands


def row_softness(inv_mass: np.ndarray, constraints: ContactConstraints, gravity: np.ndarray,
                 settings: Settings, moving: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-row soft coefficients and the pairs that get extra passes: the loaded
    islands' and the impacts' (the sections above).

    inv_mass: (B,) 1/kg. Returns bias_rate (K,) 1/s, mass_scale (K,), impulse_scale (K,),
    loaded_pairs (L,) int64, indices into ``constraints.pair_start`` in order, and
    passes (L,) int64: the extra passes per phase each may take, at most
    ``stiff_iterations - 1`` (a loaded island of at most ``stiff_island_limit`` bodies),
    ``rest_iterations - 1`` (a larger one at rest, up to ``rest_island_limit``) or
    ``impact_iterations - 1`` (near an impact), the largest that applies, each at most
    ``stiff_iterations - 1``. moving: (B,) bool, the bodies faster than REST_SPEED at the
    start of the step (None: none).
    """
    c = constraints
    k = len(c.feature)
    bias_rate, mass_scale, impulse_scale = np.empty(k), np.empty(k), np.empty(k)
    loaded_pairs, passes, _, _ = loaded_rows(
        inv_mass, SoftnessRows(c.body_a, c.body_b, c.pair_start, c.normal, c.normal_impulse,
                               c.stiff, c.separation, c.relative_velocity, c.feature,
                               bias_rate, mass_scale, impulse_scale),
        row_softness_params(settings, gravity), moving)
    return bias_rate, mass_scale, impulse_scale, loaded_pairs, passes


def loaded_rows(inv_mass: np.ndarray, rows: SubstepRows | SoftnessRows,
                params: RowSoftnessParams, moving: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``row_softness`` into the coefficient arrays of ``rows``; returns loaded_pairs,
    passes, the pairs of islands over rest_island_limit ((P,) bool) and the islands of
    the rows' contacts ((B,) int64 roots, ``islands.island_roots``). rows: the
    step's ``bundles.substep_rows`` (the bundle the substep kernel then
    takes; ``solve_substeps``), or a ``SoftnessRows`` (``row_softness``: any object with
    the constraints' arrays it reads). params: ``row_softness_params(settings, gravity)``."""
    return _row_softness_kernel(inv_mass, np.zeros(len(inv_mass), np.bool_) if moving is None
                                else moving, rows, params)


