"""The soft-step contact solver: Box2D v3's design (docs/solver.md), one numba sweep per phase.

One step, as ``World.step`` runs it:

1. collide once (``sdfphys.collide.find_contacts``);
2. ``prepare_contacts``: anchors, base separations, effective masses, the approach speed
   for restitution and last step's impulses matched by feature key (warm start);
3. ``solve_substeps``: for each substep h = dt / substeps, integrate velocities, warm
   start, solve with soft bias, integrate positions, relax without bias; islands where
   heavy loads rest on light bodies get load-stiffened rows and more passes, until
   converged (``row_softness``); overlap deeper than ``Settings.soft_depth`` is pushed
   out through pseudo-velocities that never enter the velocities ("Split push-out");
4. ``apply_restitution``: velocity passes that target vn' = -e vn;
5. ``store_impulses``: the impulses, keyed for the next step's warm start.

References: E. Catto, Box2D v3 (``contact_solver.c``, ``solver.c``: ``b2MakeSoft``,
prepare / warm start / solve / relax / restitution / store), the "Solver2D" post
(soft step versus PGS and TGS) and "SIMD Matters" (substepping with relax);
E. Catto, "Soft Constraints", GDC 2011.

Conventions: SI units; a contact's normal n is a unit vector from body a to body b;
separation s < 0 when overlapping; the tangent is t = (n_y, -n_x) (n turned clockwise);
an impulse lambda along n pushes b by +lambda n and a by -lambda n. Accumulated
impulses are per substep (N s): the warm start applies them once per substep.

The sweeps are sequential Gauss-Seidel loops over the contacts in their given order
(sorted by (body_a, body_b, feature): deterministic), compiled with numba
(``cache=True``); docs/solver.md measures why this beats coloured numpy batches. Static and
kinematic bodies take part through their zero inverse mass and inertia: impulses leave
them unchanged.

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
prepared from the first anchors (docs/solver.md: prepared once); the arms move by the
bodies' relative displacement within one step, which changes the iteration's step size
a little and leaves every impulse pair, hence the momenta, exact.

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from .collide.contacts import Contacts
from .islands import island_roots
from .settings import Settings

__all__ = [
    "BodyState",
    "ContactConstraints",
    "ImpulseCache",
    "Softness",
    "apply_restitution",
    "contact_softness",
    "prepare_contacts",
    "row_softness",
    "soft_coefficients",
    "solve_substeps",
    "store_impulses",
]


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
# ``Settings.rest_island_limit``
# if none of its rows is deeper than ``Settings.soft_depth`` at the start of the step
# (it is not pushing out overlap: "Split push-out"), and two touching bodies whose masses
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


@njit(cache=True)
def _row_softness_kernel(inv_mass, body_a, body_b, pair_start, normal, normal_impulse, stiff,
                         up, weight_impulse, omega, zeta, h, base_bias_rate, base_mass_scale,
                         base_impulse_scale, stiffen, limit, large_cap, bias_rate, mass_scale,
                         impulse_scale, loaded_pairs, small, separation, soft_depth,
                         rest_limit, moving):
    """Fill the per-row coefficients (K,) and the loaded pairs; returns their count.

    weight_impulse: |g| h, the impulse per substep that carries 1 kg (0: no gravity, no
    load stiffening). omega: rad/s, the capped base stiffness (doubled for stiff rows).
    base_*: (2,) contact_softness's coefficients, [movable, static], used where r = 1.
    limit: largest loaded island (dynamic bodies); rest_limit: the same for islands with
    no row deeper than soft_depth (m; separation (K,) at the start of the step);
    large_cap: the most weights counted in larger islands, which get no extra pass.
    small: (P,) bool, filled per loaded pair: its island has at most ``limit`` bodies
    (the others are islands at rest up to rest_limit). moving: (B,) bool, bodies
    faster than REST_SPEED (their islands are not at rest).
    """
    nb = inv_mass.shape[0]
    n_pairs = pair_start.shape[0] - 1
    ratio = np.ones(nb)
    if stiffen and weight_impulse > 0.0:
        for k in range(body_a.shape[0]):
            a = body_a[k]
            b = body_b[k]
            # The impulse pushes b along +n and a along -n; count the push down, from a
            # dynamic body only (the ground's reaction is not a load).
            lift = normal_impulse[k] * (normal[k, 0] * up[0] + normal[k, 1] * up[1])
            if lift < 0.0 and inv_mass[a] > 0.0:
                ratio[b] -= lift * inv_mass[b] / weight_impulse
            elif lift > 0.0 and inv_mass[b] > 0.0:
                ratio[a] += lift * inv_mass[a] / weight_impulse
    root = island_roots(inv_mass, body_a, body_b)
    size = np.zeros(nb, np.int64)
    hot = np.zeros(nb, np.bool_)
    for i in range(nb):
        if inv_mass[i] > 0.0:
            size[root[i]] += 1
            if ratio[i] > LOADED:
                hot[root[i]] = True
    # An island pushing out overlap deeper than soft_depth (split rows), or with a body
    # faster than REST_SPEED, is not at rest.
    largest = np.full(nb, max(limit, rest_limit), np.int64)
    for i in range(nb):
        if inv_mass[i] > 0.0 and moving[i]:
            largest[root[i]] = limit
    for k in range(body_a.shape[0]):
        if separation[k] < -soft_depth:
            for i in (body_a[k], body_b[k]):
                if inv_mass[i] > 0.0:
                    largest[root[i]] = limit
    for p in range(n_pairs):
        a = body_a[pair_start[p]]
        b = body_b[pair_start[p]]
        ma = inv_mass[a]
        mb = inv_mass[b]
        if ma > 0.0 and mb > 0.0 and (ma >= MASS_RATIO * mb or mb >= MASS_RATIO * ma):
            hot[root[a]] = True
    count = 0
    for p in range(n_pairs):
        first = pair_start[p]
        a = body_a[first]
        b = body_b[first]
        hot_a = inv_mass[a] > 0.0 and hot[root[a]] and size[root[a]] <= largest[root[a]]
        hot_b = inv_mass[b] > 0.0 and hot[root[b]] and size[root[b]] <= largest[root[b]]
        r = 1.0
        if inv_mass[a] > 0.0:
            r = ratio[a] if hot_a else min(ratio[a], large_cap)
        if inv_mass[b] > 0.0:
            r = max(r, ratio[b] if hot_b else min(ratio[b], large_cap))
        if hot_a or hot_b:
            loaded_pairs[count] = p
            small[count] = ((not hot_a or size[root[a]] <= limit)
                            and (not hot_b or size[root[b]] <= limit))
            count += 1
        for k in range(first, pair_start[p + 1]):
            j = stiff[k]
            if r == 1.0:
                bias_rate[k] = base_bias_rate[j]
                mass_scale[k] = base_mass_scale[j]
                impulse_scale[k] = base_impulse_scale[j]
            else:
                root_r = math.sqrt(r)
                w = omega * (2.0 if j else 1.0) * root_r
                a1 = 2.0 * zeta * root_r + h * w
                a2 = h * w * a1
                a3 = 1.0 / (1.0 + a2)
                bias_rate[k] = w / a1
                mass_scale[k] = a2 * a3
                impulse_scale[k] = a3
    return count


def row_softness(inv_mass: np.ndarray, constraints: ContactConstraints, gravity: np.ndarray,
                 settings: Settings, moving: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-row soft coefficients and the loaded islands' pairs (see the section above).

    inv_mass: (B,) 1/kg. Returns bias_rate (K,) 1/s, mass_scale (K,), impulse_scale (K,),
    loaded_pairs (L,) int64, indices into ``constraints.pair_start`` in order, and
    small (L,) bool: the pair's loaded island has at most ``stiff_island_limit``
    bodies (else it is at rest, up to ``rest_island_limit``). moving: (B,) bool, the
    bodies faster than REST_SPEED at the start of the step (None: none).
    """
    c = constraints
    k = len(c.feature)
    soft, stiff = contact_softness(settings)
    h = settings.dt / settings.substeps
    g = float(np.hypot(gravity[0], gravity[1]))
    up = -gravity / g if g > 0.0 else np.zeros(2)
    bias_rate, mass_scale, impulse_scale = np.empty(k), np.empty(k), np.empty(k)
    loaded_pairs = np.empty(max(len(c.pair_start) - 1, 0), np.int64)
    small = np.empty(len(loaded_pairs), np.bool_)
    count = _row_softness_kernel(
        inv_mass, c.body_a, c.body_b, c.pair_start, c.normal, c.normal_impulse, c.stiff, up,
        g * h, 2.0 * math.pi * min(settings.contact_hertz, 0.25 / h),
        settings.contact_damping_ratio, h,
        np.array([soft.bias_rate, stiff.bias_rate]), np.array([soft.mass_scale, stiff.mass_scale]),
        np.array([soft.impulse_scale, stiff.impulse_scale]), settings.load_stiffening,
        settings.stiff_island_limit, settings.large_island_load_cap, bias_rate, mass_scale,
        impulse_scale, loaded_pairs, small, c.separation, settings.soft_depth,
        settings.rest_island_limit, np.zeros(len(inv_mass), np.bool_) if moving is None
        else moving)
    return bias_rate, mass_scale, impulse_scale, loaded_pairs[:count], small[:count]


@dataclass
class BodyState:
    """The solver's view of the bodies (B rows; arrays are updated in place).

    com: (B, 2) centre-of-mass world positions, m.  angle: (B,) rad, counter-clockwise.
    velocity: (B, 2) centre-of-mass velocity, m/s.  angular_velocity: (B,) rad/s.
    inv_mass: (B,) 1/kg, inv_inertia: (B,) 1/(kg m^2); both 0 for static and kinematic
    bodies, which therefore never receive impulses or gravity.
    linear_damping, angular_damping: (B,) 1/s; velocities are divided by (1 + h c)
    each substep.
    round_body: (B,) bool, True for circles: their contact point is not a material point
    (a rolling circle touches with whichever point is lowest), so re-measuring a
    separation ignores their rotation (see _update_anchors).
    radius: (B,) m, bounding radius about the centre of mass (inf if unbounded), or
    None: the speed of a body's points, for REST_SPEED (None counts only |v|).
    """

    com: np.ndarray
    angle: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    inv_mass: np.ndarray
    inv_inertia: np.ndarray
    linear_damping: np.ndarray
    angular_damping: np.ndarray
    round_body: np.ndarray
    radius: np.ndarray | None = None


@dataclass
class ImpulseCache:
    """Accumulated impulses of the last step, keyed by (body_a, body_b, feature); (K,) each.

    normal_impulse, tangent_impulse: N s per substep (what the warm start applies).
    anchor: (K, 2) m, each contact point in body a's frame (relative to its centre of
    mass, unrotated by its angle) at the start of that step: the fallback match by
    place (``match``).
    """

    body_a: np.ndarray
    body_b: np.ndarray
    feature: np.ndarray
    normal_impulse: np.ndarray
    tangent_impulse: np.ndarray
    anchor: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @classmethod
    def empty(cls) -> ImpulseCache:
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64),
                   np.zeros(0), np.zeros(0), np.zeros((0, 2)))

    def __len__(self) -> int:
        return len(self.feature)

    def without_body(self, index: int) -> ImpulseCache:
        """The cache after body ``index`` is removed: its rows dropped, later bodies renumbered."""
        c = self.take((self.body_a != index) & (self.body_b != index))
        c.body_a = c.body_a - (c.body_a > index)
        c.body_b = c.body_b - (c.body_b > index)
        return c

    def take(self, index: np.ndarray) -> ImpulseCache:
        """The rows selected by ``index`` (an index or boolean array)."""
        anchor = self.anchor[index] if len(self.anchor) == len(self) else self.anchor
        return ImpulseCache(self.body_a[index], self.body_b[index], self.feature[index],
                            self.normal_impulse[index], self.tangent_impulse[index], anchor)

    @classmethod
    def concatenate(cls, parts: list[ImpulseCache]) -> ImpulseCache:
        """The rows of ``parts`` one after the other."""
        parts = [p for p in parts if len(p)]
        if not parts:
            return cls.empty()
        if any(len(p.anchor) != len(p) for p in parts):
            parts = [ImpulseCache(p.body_a, p.body_b, p.feature, p.normal_impulse,
                                  p.tangent_impulse, np.full((len(p), 2), np.inf))
                     for p in parts]
        return cls(*(np.concatenate([getattr(p, name) for p in parts])
                     for name in ("body_a", "body_b", "feature", "normal_impulse",
                                  "tangent_impulse", "anchor")))

    def sorted(self) -> ImpulseCache:
        """The rows in (body_a, body_b, feature) order (``match``'s merge join)."""
        return self.take(np.lexsort((self.feature, self.body_b, self.body_a)))

    def match(self, body_a: np.ndarray, body_b: np.ndarray, feature: np.ndarray,
              anchor: np.ndarray | None = None, tolerance: float = 0.0
              ) -> tuple[np.ndarray, np.ndarray]:
        """Normal and tangent impulses (K,) for the given keys; 0 where there is no match.

        First by key: when both lists are sorted by (body_a, body_b, feature), as
        ``find_contacts`` returns them, one compiled merge join (O(K)); otherwise,
        vectorized, the features of both sets are ranked together (np.unique), each key
        (a, b, feature) becomes one int64 ((a * nb + b) * nf + rank), and the new keys
        are looked up in the sorted old ones with searchsorted. Valid while
        nb^2 nf < 2^63 (nb bodies, nf distinct features), e.g. 10^5 bodies and 10^8
        contacts.

        Then by place, if ``anchor`` (K, 2) (points in body a's frame, as
        ``ImpulseCache.anchor``) and ``tolerance`` > 0 are given: a new contact that
        matched no key takes the impulses of the nearest old contact of the same body
        pair, not matched by anything yet, within ``tolerance`` (m). A contact patch
        seen from two sides (a corner of b in a's face, a's face end in b's corner)
        yields near-coincident candidates whose keys differ, and which of them the
        reduction keeps may flip from step to step as the bodies rock by micrometres;
        without this the warm start is lost at every flip (measured: a unit box
        on a unit box lost it at three steps out of four).
        """
        k = len(feature)
        normal, tangent = np.zeros(k), np.zeros(k)
        if k == 0 or len(self) == 0:
            return normal, tangent
        nb = int(max(self.body_b.max(), body_b.max(), self.body_a.max(), body_a.max())) + 1
        source = np.full(k, -1, np.int64)
        if _merge_keys(self.body_a, self.body_b, self.feature, body_a, body_b, feature,
                       source):
            pair_order = np.arange(len(self))           # already sorted by pair
        else:
            ranks = np.unique(np.concatenate([self.feature, feature]), return_inverse=True)[1]
            nf = int(ranks.max()) + 1
            old_key = (self.body_a * nb + self.body_b) * nf + ranks[:len(self)]
            new_key = (body_a * nb + body_b) * nf + ranks[len(self):]
            order = np.argsort(old_key, kind="stable")
            sorted_key = old_key[order]
            where = np.minimum(np.searchsorted(sorted_key, new_key), len(sorted_key) - 1)
            hit = sorted_key[where] == new_key
            source[hit] = order[where[hit]]
            pair_order = None
        if anchor is not None and tolerance > 0.0 and len(self.anchor) == len(self) \
                and np.any(source < 0):
            old_pair = self.body_a * nb + self.body_b
            if pair_order is None:
                pair_order = np.argsort(old_pair, kind="stable")
            new_pair = body_a * nb + body_b
            lo = np.searchsorted(old_pair[pair_order], new_pair, side="left")
            hi = np.searchsorted(old_pair[pair_order], new_pair, side="right")
            _match_by_place(source, lo, hi, pair_order,
                            np.ascontiguousarray(self.anchor, dtype=np.float64),
                            np.ascontiguousarray(anchor, dtype=np.float64), tolerance)
        found = source >= 0
        normal[found] = self.normal_impulse[source[found]]
        tangent[found] = self.tangent_impulse[source[found]]
        return normal, tangent


@njit(cache=True)
def _merge_keys(old_a, old_b, old_f, new_a, new_b, new_f, source):
    """Key match as a merge join when both lists are sorted by (body_a, body_b, feature)
    (``find_contacts``' order): source[k] = the old row with new row k's key. Returns
    False, leaving ``source`` untouched, if either list is not sorted."""
    for k in range(1, old_a.shape[0]):
        if (old_a[k], old_b[k], old_f[k]) < (old_a[k - 1], old_b[k - 1], old_f[k - 1]):
            return False
    for k in range(1, new_a.shape[0]):
        if (new_a[k], new_b[k], new_f[k]) < (new_a[k - 1], new_b[k - 1], new_f[k - 1]):
            return False
    u = 0
    n_old = old_a.shape[0]
    for k in range(new_a.shape[0]):
        key = (new_a[k], new_b[k], new_f[k])
        while u < n_old and (old_a[u], old_b[u], old_f[u]) < key:
            u += 1
        if u < n_old and (old_a[u], old_b[u], old_f[u]) == key:
            source[k] = u
    return True


@njit(cache=True)
def _match_by_place(source, lo, hi, pair_order, old_anchor, new_anchor, tolerance):
    """Fill source[k] < 0 with the nearest unused old row of the same pair within
    ``tolerance`` (rows pair_order[lo[k]:hi[k]]); in contact order, deterministic."""
    used = np.zeros(old_anchor.shape[0], np.bool_)
    for k in range(source.shape[0]):
        if source[k] >= 0:
            used[source[k]] = True
    for k in range(source.shape[0]):
        if source[k] >= 0:
            continue
        best = -1
        best_d2 = tolerance * tolerance
        for j in range(lo[k], hi[k]):
            r = pair_order[j]
            if used[r]:
                continue
            dx = old_anchor[r, 0] - new_anchor[k, 0]
            dy = old_anchor[r, 1] - new_anchor[k, 1]
            d2 = dx * dx + dy * dy
            if d2 <= best_d2:
                best = r
                best_d2 = d2
        if best >= 0:
            source[k] = best
            used[best] = True


@dataclass
class ContactConstraints:
    """The prepared contact rows of one step (K rows, P pairs).

    body_a, body_b, feature: (K,) int64, from the Contacts (body_a < body_b).
    normal: (K, 2) unit, a -> b.  separation: (K,) m, current s (< 0 overlapping).
    anchor_a0, anchor_b0: (K, 2) m, each body's own surface point (point -+ n s0 / 2)
        relative to its centre of mass at the start of the step (the separation carries
        them with the bodies' moves; module docstring).
    anchor_a, anchor_b: (K, 2) m, the lever arms the impulses use, re-based after each
        position update so that x_a + anchor_a = x_b + anchor_b (module docstring).
    base_separation: (K,) m, s0 - n.(anchor_b0 - anchor_a0).
    normal_mass, tangent_mass: (K,) kg, effective masses (0 if both bodies are fixed).
    friction, restitution: (K,) mixed coefficients (sqrt(a b), max(a, b)).
    relative_velocity: (K,) m/s, n.(v_b - v_a) at the point at the start of the step;
        for a speculative point approaching (s0 > 0, vn0 < 0), the speed at which it
        reaches the gap under gravity alone, -sqrt(max(vn0^2 - 2 n.(g_b - g_a) s0, 0))
        (g of dynamic bodies): a contact found a step early (velocity-aware margin,
        ``sdfphys.collide``) bounces with its impact speed, not the start-of-step one.
    stiff: (K,) int64, 1 if a body is static or kinematic (stiffer softness), else 0.
    normal_impulse, tangent_impulse: (K,) N s, accumulated per substep.
    total_normal_impulse: (K,) N s, sum of the normal impulses applied this step.
    pair_start: (P + 1,) int64, rows pair_start[p]:pair_start[p+1] share one body pair.
    local_anchor: (K, 2) m, the contact point in body a's frame at the start of the
        step (stored for the next step's match by place, ``ImpulseCache.match``).
    """

    body_a: np.ndarray
    body_b: np.ndarray
    feature: np.ndarray
    normal: np.ndarray
    separation: np.ndarray
    anchor_a0: np.ndarray
    anchor_b0: np.ndarray
    anchor_a: np.ndarray
    anchor_b: np.ndarray
    base_separation: np.ndarray
    normal_mass: np.ndarray
    tangent_mass: np.ndarray
    friction: np.ndarray
    restitution: np.ndarray
    relative_velocity: np.ndarray
    stiff: np.ndarray
    normal_impulse: np.ndarray
    tangent_impulse: np.ndarray
    total_normal_impulse: np.ndarray
    pair_start: np.ndarray
    local_anchor: np.ndarray

    def __len__(self) -> int:
        return len(self.feature)


# --------------------------------------------------------------------------------------
# Prepare (once per step).
# --------------------------------------------------------------------------------------


@njit(cache=True)
def _effective_mass(ma: float, ia: float, mb: float, ib: float, rax: float, ray: float,
                    rbx: float, rby: float, dx: float, dy: float) -> float:
    """1 / (ma + mb + ia (ra x d)^2 + ib (rb x d)^2), or 0 when both bodies are fixed."""
    rna = rax * dy - ray * dx
    rnb = rbx * dy - rby * dx
    k = ma + mb + ia * rna * rna + ib * rnb * rnb
    return 1.0 / k if k > 0.0 else 0.0


@njit(cache=True)
def _prepare_kernel(com, velocity, angular_velocity, inv_mass, inv_inertia, body_friction,
                    body_restitution, body_a, body_b, point, normal, depth,
                    anchor_a, anchor_b, arm_a, arm_b, base_separation, normal_mass,
                    tangent_mass, friction, restitution, relative_velocity, stiff, pair_start,
                    gravity):
    """Fill the per-contact arrays (see ContactConstraints); returns the number of pairs."""
    n_pairs = 0
    for k in range(depth.shape[0]):
        a = body_a[k]
        b = body_b[k]
        if k == 0 or a != body_a[k - 1] or b != body_b[k - 1]:
            pair_start[n_pairs] = k
            n_pairs += 1
        nx = normal[k, 0]
        ny = normal[k, 1]
        ma = inv_mass[a]
        mb = inv_mass[b]
        ia = inv_inertia[a]
        ib = inv_inertia[b]
        # Surface points p_a, p_b = point -+ n s0 / 2 (s0 = -depth) relative to the
        # centres (anchor_a, anchor_b: what the separation re-measure turns; module
        # docstring), and the lever arms to the contact point (arm_a, arm_b).
        half = 0.5 * depth[k]
        sax = point[k, 0] + half * nx - com[a, 0]
        say = point[k, 1] + half * ny - com[a, 1]
        sbx = point[k, 0] - half * nx - com[b, 0]
        sby = point[k, 1] - half * ny - com[b, 1]
        anchor_a[k, 0] = sax
        anchor_a[k, 1] = say
        anchor_b[k, 0] = sbx
        anchor_b[k, 1] = sby
        base_separation[k] = -depth[k] - ((sbx - sax) * nx + (sby - say) * ny)
        rax = point[k, 0] - com[a, 0]
        ray = point[k, 1] - com[a, 1]
        rbx = point[k, 0] - com[b, 0]
        rby = point[k, 1] - com[b, 1]
        arm_a[k, 0] = rax
        arm_a[k, 1] = ray
        arm_b[k, 0] = rbx
        arm_b[k, 1] = rby
        normal_mass[k] = _effective_mass(ma, ia, mb, ib, rax, ray, rbx, rby, nx, ny)
        tangent_mass[k] = _effective_mass(ma, ia, mb, ib, rax, ray, rbx, rby, ny, -nx)
        friction[k] = math.sqrt(body_friction[a] * body_friction[b])
        restitution[k] = max(body_restitution[a], body_restitution[b])
        wa = angular_velocity[a]
        wb = angular_velocity[b]
        dvx = velocity[b, 0] - wb * rby - velocity[a, 0] + wa * ray
        dvy = velocity[b, 1] + wb * rbx - velocity[a, 1] - wa * rax
        vn0 = dvx * nx + dvy * ny
        if depth[k] < 0.0 and vn0 < 0.0:
            # Speculative: the approach speed once gravity has carried it across the gap
            # s0 = -depth, vn^2 = vn0^2 - 2 c s0 with c = n.(g_b - g_a) (g of dynamic bodies).
            c = ((mb > 0.0) - (ma > 0.0)) * (gravity[0] * nx + gravity[1] * ny)
            vn0 = -math.sqrt(max(vn0 * vn0 + 2.0 * c * depth[k], 0.0))
        relative_velocity[k] = vn0
        stiff[k] = 1 if (ma == 0.0 or mb == 0.0) else 0
    pair_start[n_pairs] = depth.shape[0]
    return n_pairs


def prepare_contacts(contacts: Contacts, bodies: BodyState, friction: np.ndarray,
                     restitution: np.ndarray, cache: ImpulseCache,
                     warm_starting: bool, gravity: np.ndarray | None = None,
                     match_tolerance: float = 0.0) -> ContactConstraints:
    """Contact rows for this step from ``contacts`` and the bodies at the start of the step.

    friction, restitution: (B,) per-body coefficients, mixed per contact as
    sqrt(f_a f_b) and max(e_a, e_b). ``cache``: last step's impulses, applied again
    if ``warm_starting`` where (body_a, body_b, feature) matches, else where a
    contact of the same pair lies within ``match_tolerance`` (m) in body a's frame
    (``ImpulseCache.match``; the world passes the linear slop). gravity: (2,)
    m/s^2 (None: zero), which speeds up a speculative point's approach before it
    touches.
    """
    k = len(contacts)
    anchor_a, anchor_b = np.empty((k, 2)), np.empty((k, 2))
    arm_a, arm_b = np.empty((k, 2)), np.empty((k, 2))
    base_separation, normal_mass, tangent_mass = np.empty(k), np.empty(k), np.empty(k)
    mixed_friction, mixed_restitution, relative_velocity = np.empty(k), np.empty(k), np.empty(k)
    stiff = np.empty(k, np.int64)
    pair_start = np.empty(k + 1, np.int64)
    normal = np.ascontiguousarray(contacts.normal, dtype=np.float64)
    n_pairs = _prepare_kernel(
        bodies.com, bodies.velocity, bodies.angular_velocity, bodies.inv_mass,
        bodies.inv_inertia, friction, restitution, contacts.body_a, contacts.body_b,
        np.ascontiguousarray(contacts.point, dtype=np.float64), normal,
        np.ascontiguousarray(contacts.depth, dtype=np.float64),
        anchor_a, anchor_b, arm_a, arm_b, base_separation, normal_mass, tangent_mass,
        mixed_friction,
        mixed_restitution, relative_velocity, stiff, pair_start,
        np.zeros(2) if gravity is None else np.asarray(gravity, np.float64))
    # Contact points in body a's frame: R(-angle_a) (point - com_a).
    angle_a = bodies.angle[contacts.body_a]
    cos_a, sin_a = np.cos(angle_a), np.sin(angle_a)
    local_anchor = np.column_stack([cos_a * arm_a[:, 0] + sin_a * arm_a[:, 1],
                                    cos_a * arm_a[:, 1] - sin_a * arm_a[:, 0]])
    if warm_starting:
        normal_impulse, tangent_impulse = cache.match(contacts.body_a, contacts.body_b,
                                                      contacts.feature, local_anchor,
                                                      match_tolerance)
    else:
        normal_impulse, tangent_impulse = np.zeros(k), np.zeros(k)
    return ContactConstraints(
        body_a=contacts.body_a, body_b=contacts.body_b, feature=contacts.feature,
        normal=normal, separation=-np.asarray(contacts.depth, dtype=np.float64),
        anchor_a0=anchor_a, anchor_b0=anchor_b,
        anchor_a=arm_a, anchor_b=arm_b, base_separation=base_separation,
        normal_mass=normal_mass, tangent_mass=tangent_mass, friction=mixed_friction,
        restitution=mixed_restitution, relative_velocity=relative_velocity, stiff=stiff,
        normal_impulse=normal_impulse, tangent_impulse=tangent_impulse,
        total_normal_impulse=np.zeros(k), pair_start=pair_start[:n_pairs + 1],
        local_anchor=local_anchor)


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


#: Largest rotation of a body in one substep, rad (Box2D v3's B2_MAX_ROTATION).
MAX_ROTATION = 0.25 * math.pi


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
def _update_anchors(com, com0, angle, angle0, round_body, cos_d, sin_d, inv_mass, body_a,
                    body_b, normal, anchor_a0, anchor_b0, base_separation, arm_a0, arm_b0,
                    anchor_a, anchor_b, separation):
    """Re-measure every separation from the accumulated moves; re-base the anchors.

    s = base + n.(dp_b + R(dq_b) sb0 - dp_a - R(dq_a) sa0), no collision query, sa0, sb0
    the bodies' surface points (anchor_a0, anchor_b0).
    Lever arms: with D = dp_b - dp_a and inverse masses ma, mb, ra = ra0 + mb / (ma + mb) D
    and rb = rb0 - ma / (ma + mb) D (ra0, rb0: arm_a0, arm_b0, the arms to the contact
    point at the start of the step), so x_a + ra = x_b + rb (one common point; module
    docstring). Against a static or kinematic body the movable body keeps its anchor.
    cos_d, sin_d: (B,) scratch for the rotation of each body since the start of the step.
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


@njit(cache=True)
def _load(velocity, angular_velocity, a, b):
    """(vax, vay, wa, vbx, vby, wb): the velocities of a pair's two bodies."""
    return (velocity[a, 0], velocity[a, 1], angular_velocity[a],
            velocity[b, 0], velocity[b, 1], angular_velocity[b])


@njit(cache=True)
def _store(velocity, angular_velocity, a, b, vax, vay, wa, vbx, vby, wb):
    """Write a pair's velocities back (``_load``'s inverse)."""
    velocity[a, 0] = vax
    velocity[a, 1] = vay
    angular_velocity[a] = wa
    velocity[b, 0] = vbx
    velocity[b, 1] = vby
    angular_velocity[b] = wb


@njit(cache=True)
def _point_velocity(vax, vay, wa, vbx, vby, wb, rax, ray, rbx, rby):
    """(dvx, dvy) = v_b + w_b x rb - v_a - w_a x ra: b's point against a's, m/s."""
    return vbx - wb * rby - vax + wa * ray, vby + wb * rbx - vay - wa * rax


@njit(cache=True)
def _push(vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib, rax, ray, rbx, rby, px, py):
    """The two bodies' velocities after the impulse P = (px, py) (N s) on b at arm rb and
    -P on a at arm ra (ma, mb inverse masses; ia, ib inverse inertias)."""
    return (vax - ma * px, vay - ma * py, wa - ia * (rax * py - ray * px),
            vbx + mb * px, vby + mb * py, wb + ib * (rbx * py - rby * px))


@njit(cache=True)
def _warm_start(velocity, angular_velocity, inv_mass, inv_inertia, body_a, body_b, pair_start,
                normal, anchor_a, anchor_b, normal_impulse, tangent_impulse, total_normal_impulse):
    """Apply the accumulated impulses P = l_n n + l_t t at the current anchors."""
    for p in range(pair_start.shape[0] - 1):
        first = pair_start[p]
        a = body_a[first]
        b = body_b[first]
        ma = inv_mass[a]
        mb = inv_mass[b]
        ia = inv_inertia[a]
        ib = inv_inertia[b]
        vax, vay, wa, vbx, vby, wb = _load(velocity, angular_velocity, a, b)
        for k in range(first, pair_start[p + 1]):
            nx = normal[k, 0]
            ny = normal[k, 1]
            px = normal_impulse[k] * nx + tangent_impulse[k] * ny
            py = normal_impulse[k] * ny - tangent_impulse[k] * nx
            total_normal_impulse[k] += normal_impulse[k]
            vax, vay, wa, vbx, vby, wb = _push(vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib,
                                               anchor_a[k, 0], anchor_a[k, 1],
                                               anchor_b[k, 0], anchor_b[k, 1], px, py)
        _store(velocity, angular_velocity, a, b, vax, vay, wa, vbx, vby, wb)


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
# - its push-out bias = max(mass_scale bias_rate s, -max_push_out), the soft row's
#   own, is a target for the pair's pseudo-velocities v' (per body, zero at the start
#   of every substep): d_p = -m_n (n.(v'_b - v'_a at the contact) + bias), p >= 0;
# - the positions move by h (v + v') and v' is then dropped: the overlap goes at the
#   soft row's rate, no faster than max_push_out per contact, and no kinetic energy is
#   made. A jam's push-out impulses are bounded by the passes of one substep and never
#   stored.
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
                 nx, ny, rax, ray, rbx, rby, normal_mass, bias):
    """Split row k: the impulse that makes the pair's pseudo-velocities separate at -bias
    (m/s, bias <= 0) along n, accumulated >= 0 in pseudo_impulse[k], applied to the
    pseudo-velocities (rigid: the pseudo-velocities start from 0 every substep)."""
    qax, qay, qa, qbx, qby, qb = _load(pseudo_velocity, pseudo_angular, a, b)
    dvx, dvy = _point_velocity(qax, qay, qa, qbx, qby, qb, rax, ray, rbx, rby)
    impulse = -normal_mass * (dvx * nx + dvy * ny + bias)
    accumulated = max(pseudo_impulse[k] + impulse, 0.0)
    impulse = accumulated - pseudo_impulse[k]
    pseudo_impulse[k] = accumulated
    qax, qay, qa, qbx, qby, qb = _push(qax, qay, qa, qbx, qby, qb, ma, ia, mb, ib, rax, ray,
                                       rbx, rby, impulse * nx, impulse * ny)
    _store(pseudo_velocity, pseudo_angular, a, b, qax, qay, qa, qbx, qby, qb)


@njit(cache=True)
def _solve(bodies, rows, pseudo, pairs, inv_h, max_push_out, soft_depth, use_bias,
           use_friction):
    """One Gauss-Seidel pass over the pairs ``pairs`` (indices into pair_start, in order):
    normal rows of the pair, then its friction rows.

    bodies: (velocity, angular_velocity, inv_mass, inv_inertia); rows: the contact rows
    (``_substeps_kernel``'s tuple, ContactConstraints' arrays plus the row coefficients of
    ``row_softness``); pseudo: (pseudo_velocity, pseudo_angular, pseudo_impulse).

    Normal row k: s > 0 (speculative): bias = s / h, rigid (the gap may close, no more);
    else with ``use_bias`` soft, with row k's coefficients (``row_softness``):
    bias = max(mass_scale bias_rate s, -max_push_out),
    d_l = -m_n (mass_scale vn + bias) - impulse_scale l; without it rigid, bias 0.
    Accumulated l_n >= 0. Friction row: d_l = -m_t vt, accumulated |l_t| <= mu l_n.
    A row deeper than ``soft_depth`` (s < -soft_depth, see "Split push-out") is rigid in
    the velocities and, with ``use_bias``, pushes its pair apart in the pseudo-velocities
    instead:
    d_p = -m_n (vn' + bias) on the pair's pseudo-velocities vn', accumulated p >= 0
    (``pseudo_impulse``, reset every substep).

    Returns (largest |d_l_n|, largest accumulated l_n) over the pass, N s: how far the
    pass was from converged (``_sweeps``' extra passes stop on their ratio).
    """
    velocity, angular_velocity, inv_mass, inv_inertia = bodies
    (body_a, body_b, pair_start, normal, anchor_a, anchor_b, separation, normal_mass,
     tangent_mass, friction, bias_rate, mass_scale, impulse_scale, normal_impulse,
     tangent_impulse, total_normal_impulse) = rows
    pseudo_velocity, pseudo_angular, pseudo_impulse = pseudo
    largest_change = 0.0
    largest_impulse = 0.0
    for p in pairs:
        first = pair_start[p]
        last = pair_start[p + 1]
        a = body_a[first]
        b = body_b[first]
        ma = inv_mass[a]
        mb = inv_mass[b]
        ia = inv_inertia[a]
        ib = inv_inertia[b]
        vax, vay, wa, vbx, vby, wb = _load(velocity, angular_velocity, a, b)
        for k in range(first, last):
            nx = normal[k, 0]
            ny = normal[k, 1]
            s = separation[k]
            bias = 0.0
            m_scale = 1.0
            i_scale = 0.0
            rax = anchor_a[k, 0]
            ray = anchor_a[k, 1]
            rbx = anchor_b[k, 0]
            rby = anchor_b[k, 1]
            if s > 0.0:
                bias = s * inv_h
            elif use_bias and s < -soft_depth:
                _pseudo_push(pseudo_velocity, pseudo_angular, pseudo_impulse, k, a, b, ma, ia,
                             mb, ib, nx, ny, rax, ray, rbx, rby, normal_mass[k],
                             max(mass_scale[k] * bias_rate[k] * s, -max_push_out))
            elif use_bias:
                bias = max(mass_scale[k] * bias_rate[k] * s, -max_push_out)
                m_scale = mass_scale[k]
                i_scale = impulse_scale[k]
            dvx, dvy = _point_velocity(vax, vay, wa, vbx, vby, wb, rax, ray, rbx, rby)
            vn = dvx * nx + dvy * ny
            impulse = -normal_mass[k] * (m_scale * vn + bias) - i_scale * normal_impulse[k]
            accumulated = max(normal_impulse[k] + impulse, 0.0)
            impulse = accumulated - normal_impulse[k]
            normal_impulse[k] = accumulated
            total_normal_impulse[k] += impulse
            largest_change = max(largest_change, abs(impulse))
            largest_impulse = max(largest_impulse, accumulated)
            px = impulse * nx
            py = impulse * ny
            vax, vay, wa, vbx, vby, wb = _push(vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib,
                                               rax, ray, rbx, rby, px, py)
        if use_friction:
            for k in range(first, last):
                mu = friction[k]
                if mu == 0.0:
                    continue
                tx = normal[k, 1]
                ty = -normal[k, 0]
                rax = anchor_a[k, 0]
                ray = anchor_a[k, 1]
                rbx = anchor_b[k, 0]
                rby = anchor_b[k, 1]
                dvx, dvy = _point_velocity(vax, vay, wa, vbx, vby, wb, rax, ray, rbx, rby)
                vt = dvx * tx + dvy * ty
                limit = mu * normal_impulse[k]
                accumulated = min(max(tangent_impulse[k] - tangent_mass[k] * vt, -limit), limit)
                impulse = accumulated - tangent_impulse[k]
                tangent_impulse[k] = accumulated
                px = impulse * tx
                py = impulse * ty
                vax, vay, wa, vbx, vby, wb = _push(vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib,
                                                   rax, ray, rbx, rby, px, py)
        _store(velocity, angular_velocity, a, b, vax, vay, wa, vbx, vby, wb)
    return largest_change, largest_impulse


@njit(cache=True)
def _sweeps(bodies, rows, pseudo, all_pairs, loaded, inv_h, max_push_out, soft_depth,
            use_bias, use_friction, passes, extra_passes, rest_passes):
    """One phase of a substep: ``passes`` ``_solve`` passes over every pair, then, if any
    ran, up to ``extra_passes`` more over the loaded islands' pairs, stopping after a
    pass whose largest normal impulse change is at most CONVERGED times the largest
    accumulated normal impulse. loaded: (every loaded pair, the small islands' ones);
    islands at rest over the small limit take part in the first ``rest_passes`` extra
    passes only. Returns the number of extra passes run."""
    loaded_pairs, small_pairs = loaded
    for _ in range(passes):
        _solve(bodies, rows, pseudo, all_pairs, inv_h, max_push_out, soft_depth, use_bias,
               use_friction)
    if passes == 0 or loaded_pairs.shape[0] == 0:
        return 0
    for n in range(extra_passes):
        pairs = loaded_pairs if n < rest_passes else small_pairs
        if pairs.shape[0] == 0:
            return n
        change, impulse = _solve(bodies, rows, pseudo, pairs, inv_h, max_push_out,
                                 soft_depth, use_bias, use_friction)
        if change <= CONVERGED * impulse:
            return n + 1
    return extra_passes


@njit(cache=True)
def _substeps_kernel(com, angle, velocity, angular_velocity, inv_mass, inv_inertia,
                     linear_damping, angular_damping, round_body, gravity, body_a, body_b,
                     pair_start, loaded, normal, anchor_a0, anchor_b0, anchor_a, anchor_b,
                     base_separation, separation, normal_mass, tangent_mass, friction,
                     bias_rate, mass_scale, impulse_scale, normal_impulse, tangent_impulse,
                     total_normal_impulse, h, substeps, relax_passes, max_push_out, max_speed,
                     use_friction, extra_passes, rest_passes, soft_depth):
    """All substeps of one step: integrate v, warm start, solve, integrate x, relax.

    After the solve and after the relax passes, the pairs of loaded islands
    (``loaded_pairs``) get up to ``extra_passes`` more passes each (``_sweeps``).
    Rows deeper than ``soft_depth`` (m) are split: their overlap moves the positions
    through pseudo-velocities, integrated after the velocities and then discarded
    (``_integrate_pseudo``; see "Split push-out").
    Returns (the number of those extra passes run, the number of substeps that had a
    split row).
    """
    com0 = com.copy()
    angle0 = angle.copy()
    arm_a0 = anchor_a.copy()
    arm_b0 = anchor_b.copy()
    cos_d = np.empty_like(angle)
    sin_d = np.empty_like(angle)
    inv_h = 1.0 / h
    has_contacts = body_a.shape[0] > 0
    all_pairs = np.arange(pair_start.shape[0] - 1)
    pseudo_velocity = np.zeros_like(velocity)
    pseudo_angular = np.zeros_like(angular_velocity)
    pseudo_impulse = np.zeros_like(separation)
    bodies = (velocity, angular_velocity, inv_mass, inv_inertia)
    rows = (body_a, body_b, pair_start, normal, anchor_a, anchor_b, separation, normal_mass,
            tangent_mass, friction, bias_rate, mass_scale, impulse_scale, normal_impulse,
            tangent_impulse, total_normal_impulse)
    pseudo = (pseudo_velocity, pseudo_angular, pseudo_impulse)
    passes_run = 0
    push_outs = 0
    for _ in range(substeps):
        split = has_contacts and _any_below(separation, -soft_depth)
        push_outs += split
        _integrate_velocities(velocity, angular_velocity, inv_mass, linear_damping,
                              angular_damping, gravity, h)
        if has_contacts:
            _warm_start(velocity, angular_velocity, inv_mass, inv_inertia, body_a, body_b,
                        pair_start, normal, anchor_a, anchor_b, normal_impulse, tangent_impulse,
                        total_normal_impulse)
            passes_run += _sweeps(bodies, rows, pseudo, all_pairs, loaded, inv_h,
                                  max_push_out, soft_depth, True, use_friction, 1, extra_passes,
                                  rest_passes)
        _integrate_positions(com, angle, velocity, angular_velocity, max_speed, h)
        if split:
            _integrate_pseudo(com, angle, pseudo_velocity, pseudo_angular, pseudo_impulse, h)
        if has_contacts:
            _update_anchors(com, com0, angle, angle0, round_body, cos_d, sin_d, inv_mass,
                            body_a, body_b, normal, anchor_a0, anchor_b0, base_separation,
                            arm_a0, arm_b0, anchor_a, anchor_b, separation)
            passes_run += _sweeps(bodies, rows, pseudo, all_pairs, loaded, inv_h,
                                  max_push_out, soft_depth, False, use_friction, relax_passes,
                                  extra_passes, rest_passes)
    return passes_run, push_outs


def solve_substeps(bodies: BodyState, constraints: ContactConstraints, gravity: np.ndarray,
                   settings: Settings, use_friction: bool) -> tuple[int, int]:
    """Run every substep of one step in place (one compiled call).

    gravity: (2,) m/s^2, applied to dynamic bodies. ``use_friction`` False skips the
    friction rows (the caller passes False when every contact's friction is 0).
    Returns (the number of extra passes run over loaded islands, ``row_softness``; the
    number of substeps with a row deeper than ``soft_depth``, "Split push-out").
    """
    c = constraints
    h = settings.dt / settings.substeps
    gravity = np.asarray(gravity, dtype=np.float64)
    v, w = bodies.velocity, bodies.angular_velocity
    spin = 0.0 if bodies.radius is None else w * np.where(bodies.inv_mass > 0.0,
                                                          bodies.radius, 0.0)
    moving = v[:, 0] ** 2 + v[:, 1] ** 2 + spin * spin > REST_SPEED ** 2
    bias_rate, mass_scale, impulse_scale, loaded_pairs, small = row_softness(
        bodies.inv_mass, c, gravity, settings, moving)
    passes, push_outs = _substeps_kernel(
        bodies.com, bodies.angle, bodies.velocity, bodies.angular_velocity, bodies.inv_mass,
        bodies.inv_inertia, bodies.linear_damping, bodies.angular_damping, bodies.round_body,
        gravity, c.body_a, c.body_b, c.pair_start, (loaded_pairs, loaded_pairs[small]),
        c.normal,
        c.anchor_a0, c.anchor_b0, c.anchor_a, c.anchor_b, c.base_separation, c.separation,
        c.normal_mass, c.tangent_mass, c.friction, bias_rate, mass_scale, impulse_scale,
        c.normal_impulse, c.tangent_impulse, c.total_normal_impulse,
        h, settings.substeps, settings.relax_passes, settings.max_push_out,
        settings.max_linear_speed, use_friction, settings.stiff_iterations - 1,
        settings.rest_iterations - 1, settings.soft_depth)
    return int(passes), int(push_outs)


# --------------------------------------------------------------------------------------
# Restitution (after the substeps) and storage.
# --------------------------------------------------------------------------------------


@njit(cache=True)
def _restitution_kernel(velocity, angular_velocity, inv_mass, inv_inertia, body_a, body_b,
                        pair_start, normal, anchor_a, anchor_b, normal_mass, restitution,
                        relative_velocity, normal_impulse, total_normal_impulse, threshold,
                        passes):
    """Velocity passes toward vn' = -e vn0 for points that approached and carried impulse.

    A point takes part if it approached faster than ``threshold`` at the start of the
    step (vn0 < -threshold) and received normal impulse during the step (a speculative
    point that never touched did not collide). d_l = -m_n (vn + e vn0), l_n >= 0.
    """
    for _ in range(passes):
        for p in range(pair_start.shape[0] - 1):
            first = pair_start[p]
            last = pair_start[p + 1]
            a = body_a[first]
            b = body_b[first]
            ma = inv_mass[a]
            mb = inv_mass[b]
            ia = inv_inertia[a]
            ib = inv_inertia[b]
            vax, vay, wa, vbx, vby, wb = _load(velocity, angular_velocity, a, b)
            for k in range(first, last):
                e = restitution[k]
                if e == 0.0 or relative_velocity[k] > -threshold or total_normal_impulse[k] == 0.0:
                    continue
                nx = normal[k, 0]
                ny = normal[k, 1]
                rax = anchor_a[k, 0]
                ray = anchor_a[k, 1]
                rbx = anchor_b[k, 0]
                rby = anchor_b[k, 1]
                dvx, dvy = _point_velocity(vax, vay, wa, vbx, vby, wb, rax, ray, rbx, rby)
                vn = dvx * nx + dvy * ny
                impulse = -normal_mass[k] * (vn + e * relative_velocity[k])
                accumulated = max(normal_impulse[k] + impulse, 0.0)
                impulse = accumulated - normal_impulse[k]
                normal_impulse[k] = accumulated
                total_normal_impulse[k] += impulse
                px = impulse * nx
                py = impulse * ny
                vax, vay, wa, vbx, vby, wb = _push(vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib,
                                                   rax, ray, rbx, rby, px, py)
            _store(velocity, angular_velocity, a, b, vax, vay, wa, vbx, vby, wb)


def apply_restitution(bodies: BodyState, constraints: ContactConstraints,
                      settings: Settings) -> None:
    """``settings.restitution_passes`` restitution passes in place (one compiled call)."""
    c = constraints
    _restitution_kernel(
        bodies.velocity, bodies.angular_velocity, bodies.inv_mass, bodies.inv_inertia,
        c.body_a, c.body_b, c.pair_start, c.normal, c.anchor_a, c.anchor_b, c.normal_mass,
        c.restitution, c.relative_velocity, c.normal_impulse, c.total_normal_impulse,
        settings.restitution_threshold, settings.restitution_passes)


def store_impulses(constraints: ContactConstraints) -> ImpulseCache:
    """The accumulated impulses of this step, keyed for the next step's warm start."""
    c = constraints
    return ImpulseCache(c.body_a, c.body_b, c.feature, c.normal_impulse, c.tangent_impulse,
                        c.local_anchor)
