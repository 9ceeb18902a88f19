"""The solver's view of the bodies and the prepared contact rows of one step.

``prepare_contacts`` turns the step's Contacts into rows (docs/solver.md, "One step",
2: prepare once): anchors and base separations, effective masses, mixed materials, the
approach speed for restitution and last step's impulses (``warm_start``).
``store_impulses`` keeps this step's impulses for the next.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .._jit import njit
from ..collide.contacts import Contacts
from .pair_rows import unsigned
from .warm_start import ImpulseCache

__all__ = ["BodyState", "ContactConstraints", "prepare_contacts", "store_impulses"]


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
class ContactConstraints:
    """The prepared contact rows of one step (K rows, P pairs).

    body_a, body_b, feature: (K,) int64, from the Contacts (body_a < body_b).
    normal: (K, 2) unit, a -> b.  separation: (K,) m, current s (< 0 overlapping).
    anchor_a0, anchor_b0: (K, 2) m, each body's own surface point (point -+ n s0 / 2),
        or for a turning sdf body its centre of curvature there (``prepare_contacts``'
        curvature), relative to its centre of mass at the start of the step (the
        separation carries them with the bodies' moves; module docstring).
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
    total_tangent_impulse: (K,) N s, sum of the friction impulses applied this step
        (along t = (n_y, -n_x)).
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
    total_tangent_impulse: np.ndarray
    pair_start: np.ndarray
    local_anchor: np.ndarray

    @classmethod
    def empty(cls) -> ContactConstraints:
        """No rows, each array of ``prepare_contacts``' dtype and rank."""
        ints = ("body_a", "body_b", "feature", "stiff")
        pairs = ("normal", "anchor_a0", "anchor_b0", "anchor_a", "anchor_b", "local_anchor")
        return cls(**{f.name: np.zeros((1,) if f.name == "pair_start" else (0, 2)
                                       if f.name in pairs else 0,
                                       np.int64 if f.name in ints + ("pair_start",)
                                       else np.float64)
                      for f in dataclasses.fields(cls)})

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
def _prepare_kernel(com, angle, velocity, angular_velocity, inv_mass, inv_inertia,
                    body_friction, body_restitution, body_a, body_b, point, normal, depth,
                    gravity):
    """The per-contact arrays of ``ContactConstraints`` for K contacts (body_a, body_b
    (K,) int64, point, normal (K, 2), depth (K,) m) of bodies with com .. inv_inertia
    (``BodyState``'s) and per-body body_friction, body_restitution (B,); gravity (2,).

    Returns (anchor_a0, anchor_b0, anchor_a, anchor_b, local_anchor (K, 2),
    base_separation, normal_mass, tangent_mass, friction, restitution,
    relative_velocity (K,), stiff (K,) int64, pair_start (P + 1,) int64): the fields of
    ``ContactConstraints`` of those names (anchor_a0, anchor_b0 before the curvature's
    shift), local_anchor the contact point in body a's frame, R(-angle_a) (point - com_a).
    """
    n = depth.shape[0]
    anchor_a, anchor_b = np.empty((n, 2)), np.empty((n, 2))
    arm_a, arm_b, local_anchor = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 2))
    base_separation, normal_mass, tangent_mass = np.empty(n), np.empty(n), np.empty(n)
    friction, restitution, relative_velocity = np.empty(n), np.empty(n), np.empty(n)
    stiff = np.empty(n, np.int64)
    pair_start = np.empty(n + 1, np.int64)
    n_pairs = 0
    # Body a's cosine and sine, computed where body_a changes from the row before (the
    # rows come sorted by body_a: once per body; the trigonometry was most of a row's
    # time).
    cos_a, sin_a = 1.0, 0.0
    rows_a, rows_b = unsigned(body_a), unsigned(body_b)
    for k in range(depth.shape[0]):
        a = rows_a[k]
        b = rows_b[k]
        if k == 0 or a != rows_a[k - 1] or b != rows_b[k - 1]:
            pair_start[n_pairs] = k
            n_pairs += 1
            if k == 0 or a != rows_a[k - 1]:
                cos_a = math.cos(angle[a])
                sin_a = math.sin(angle[a])
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
        local_anchor[k, 0] = cos_a * rax + sin_a * ray
        local_anchor[k, 1] = cos_a * ray - sin_a * rax
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
    return (anchor_a, anchor_b, arm_a, arm_b, local_anchor, base_separation, normal_mass,
            tangent_mass, friction, restitution, relative_velocity, stiff,
            pair_start[:n_pairs + 1])


def prepare_contacts(contacts: Contacts, bodies: BodyState, friction: np.ndarray,
                     restitution: np.ndarray, cache: ImpulseCache,
                     warm_starting: bool, gravity: np.ndarray | None = None,
                     match_tolerance: float = 0.0,
                     curvature: tuple[np.ndarray, np.ndarray] | None = None
                     ) -> ContactConstraints:
    """Contact rows for this step from ``contacts`` and the bodies at the start of the step.

    friction, restitution: (B,) per-body coefficients, mixed per contact as
    sqrt(f_a f_b) and max(e_a, e_b). ``cache``: last step's impulses, applied again
    if ``warm_starting`` where (body_a, body_b, feature) matches, else where a
    contact of the same pair lies within ``match_tolerance`` (m) in body a's frame
    (``ImpulseCache.match``; the world passes the linear slop). gravity: (2,)
    m/s^2 (None: zero), which speeds up a speculative point's approach before it
    touches. curvature: None, or (rho_a, rho_b) (K,) m, the radii of curvature of each
    body's surface at each contact (``collide.curvature``): a body's anchor is then its
    centre of curvature, p_a - rho_a n and p_b + rho_b n, and the base separation less
    rho_a + rho_b, the same separation now, turning as a round body's.
    """
    k = len(contacts)
    normal = np.ascontiguousarray(contacts.normal, dtype=np.float64)
    (anchor_a, anchor_b, arm_a, arm_b, local_anchor, base_separation, normal_mass, tangent_mass,
     mixed_friction, mixed_restitution, relative_velocity, stiff, pair_start) = _prepare_kernel(
        bodies.com, bodies.angle, bodies.velocity, bodies.angular_velocity, bodies.inv_mass,
        bodies.inv_inertia, friction, restitution, contacts.body_a, contacts.body_b,
        np.ascontiguousarray(contacts.point, dtype=np.float64), normal,
        np.ascontiguousarray(contacts.depth, dtype=np.float64),
        np.zeros(2) if gravity is None else np.asarray(gravity, np.float64))
    if curvature is not None:
        rho_a, rho_b = curvature
        anchor_a -= rho_a[:, None] * normal
        anchor_b += rho_b[:, None] * normal
        base_separation -= rho_a + rho_b
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
        total_normal_impulse=np.zeros(k), total_tangent_impulse=np.zeros(k),
        pair_start=pair_start,
        local_anchor=local_anchor)




def store_impulses(constraints: ContactConstraints) -> ImpulseCache:
    """The accumulated impulses of this step, keyed for the next step's warm start."""
    c = constraints
    return ImpulseCache(c.body_a, c.body_b, c.feature, c.normal_impulse, c.tangent_impulse,
                        c.local_anchor)

