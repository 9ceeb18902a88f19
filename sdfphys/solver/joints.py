"""Joint rows of the soft-step solver: Box2D v3's joints, as numba loops over arrays.

Every joint is a few constraint rows solved with the contacts in each substep (``substeps``):
warm started with last step's accumulated impulses, solved with soft bias, relaxed
without it (E. Catto, Box2D v3 ``joint.c``, ``revolute_joint.c``, ``prismatic_joint.c``,
``distance_joint.c``, ``weld_joint.c``, ``wheel_joint.c``, ``motor_joint.c``,
``mouse_joint.c``; "Soft Constraints", GDC 2011). Limits and motors are extra rows.

Frames. Internally body a is the joint's second body (the base) and body b its first
(the part that moves relative to it), as Box2D's bodyA and bodyB; a = -1 is the world
(at the origin, angle 0, no mass). ``local_a``, ``local_b``: the anchors relative to
each centre of mass in the body's frame; the arms rA = R(qa) local_a, rB = R(qb) local_b
and the separation d = (xb + rB) - (xa + rA) are measured afresh from the bodies'
positions at every row (no stored delta: positions are float64).

Rows. A row has a Jacobian (u, a1, a2): its velocity is Cdot = u.(vb - va) + a2 wb - a1 wa
and its impulse l pushes b by l u (torque l a2) and a by -l u (torque -l a1); its
effective mass is 1 / (ma + mb |u|^2 + ia a1^2 + ib a2^2) (|u| = 1 or 0). One update, as
the contact rows' (``softness``):
    d_l = -m (mass_scale Cdot + bias) - impulse_scale l,   l clamped to [lo, hi].
- equality rows (a shared point, an axis, a weld's angle, a rod's length) use the joint
  softness (``stiffened_softness``) with bias = mass_scale bias_rate C while solving, and
  are rigid (bias 0, mass_scale 1, impulse_scale 0) while relaxing;
- limits are one-sided (l >= 0): speculative while open (C > 0: bias = C / h, rigid),
  soft as an equality row while violated;
- springs use their own softness (hertz, damping ratio) in both passes: they are the
  physical spring, an implicit spring-damper, not a correction;
- motors: bias = -speed, rigid, |l| <= max force (torque) x h.
A point (revolute, weld, motor joint, mouse) is solved as one 2x2 block,
K = [[ma + mb + ia ry_a^2 + ib ry_b^2, -ia rx_a ry_a - ib rx_b ry_b], [., ma + mb + ia rx_a^2
+ ib rx_b^2]], as Box2D does. Accumulated impulses are per substep (N s), as the
contacts': ``joint_reactions`` divides by h.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._jit import njit
from .softness import soft_coefficients

__all__ = [
    "ANGLE_ROW",
    "AXIAL_ROW",
    "JOINT_DAMPING_RATIO",
    "JOINT_PASSES",
    "PERP_ROW",
    "POINT_ROWS",
    "JointRows",
    "Output",
    "Packed",
    "joint_geometry",
    "joint_reactions",
    "pack",
    "solve_joints",
    "spring_softness",
    "stiffen",
    "stiffened_softness",
    "unpack_impulses",
]

REVOLUTE, PRISMATIC, DISTANCE, WELD, WHEEL, MOTOR, MOUSE = range(7)
#: Damping ratio of rigid joint rows (Box2D v3's ``jointDampingRatio``); their hertz is
#: twice the capped contact hertz (Box2D v3: ``2 * contactHertz``, 60 Hz by default).
JOINT_DAMPING_RATIO = 2.0
#: Joint passes per phase, at most, per ``stiff_iterations`` ("Loaded joints").
JOINT_PASSES = 8
#: Row phases: apply the stored impulse, solve with bias, relax, sum the reaction.
WARM, SOLVE, RELAX, REACTION = range(4)
#: A distance limit beyond this is no limit (joints.py's _FAR).
_NO_LIMIT = 2.0 ** 17
#: A joint's equality rows, as bits (``joint_direct`` solves them per island): the
#: shared point (x and y), the angle, the perpendicular to an axis, the axis (a rigid
#: wheel axis, a rod's length).
POINT_ROWS, ANGLE_ROW, PERP_ROW, AXIAL_ROW = 1, 2, 4, 8


class JointRows(NamedTuple):
    """The joints as the solver sees them (J rows, in ``World.joints`` order).

    kind: (J,) int64, REVOLUTE .. MOUSE. body_a, body_b: (J,) int64, second and first
    body (-1: the world). local_a, local_b: (J, 2) m, anchors in the bodies' frames
    (relative to the centre of mass; for the world, a world point: a mouse's target).
    local_axis: (J, 2) unit, in a's frame. reference_angle: (J,) rad, qb - qa at creation.
    length, min_length, max_length: (J,) m (distance). lower, upper: (J,) rad or m;
    has_limit, has_motor, has_spring, collide_connected: (J,) bool. motor_speed: (J,)
    rad/s or m/s. max_motor: (J,) N m or N, the motor's bound (a motor joint's force).
    max_torque: (J,) N m (motor joint). max_force: (J,) N (mouse; inf: none).
    spring_hertz, spring_damping: (J,) Hz and ratio.
    Accumulated impulses, N s per substep (warm started, updated in place):
    linear_impulse (J, 2) world frame, on b (the point block); angular_impulse (J,);
    perp_impulse (J,) (prismatic, wheel); axial_impulse (J,) (rod, rigid wheel axis);
    spring_impulse, motor_impulse, lower_impulse, upper_impulse (J,).
    """

    kind: np.ndarray
    body_a: np.ndarray
    body_b: np.ndarray
    local_a: np.ndarray
    local_b: np.ndarray
    local_axis: np.ndarray
    reference_angle: np.ndarray
    length: np.ndarray
    min_length: np.ndarray
    max_length: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    has_limit: np.ndarray
    has_motor: np.ndarray
    has_spring: np.ndarray
    collide_connected: np.ndarray
    motor_speed: np.ndarray
    max_motor: np.ndarray
    max_torque: np.ndarray
    max_force: np.ndarray
    spring_hertz: np.ndarray
    spring_damping: np.ndarray
    linear_impulse: np.ndarray
    angular_impulse: np.ndarray
    perp_impulse: np.ndarray
    axial_impulse: np.ndarray
    spring_impulse: np.ndarray
    motor_impulse: np.ndarray
    lower_impulse: np.ndarray
    upper_impulse: np.ndarray

    @classmethod
    def empty(cls) -> JointRows:
        return cls(*(np.zeros((0,) + shape, dtype) for shape, dtype in _FIELDS.values()))

    @classmethod
    def from_spec(cls, spec, com: np.ndarray, angle: np.ndarray) -> JointRows:
        """One row from a validated ``joints.JointSpec`` and the bodies' com (B, 2) m and
        angle (B,) rad now."""
        from ..joints import JOINT_TYPES

        second, first = spec.bodies[1], spec.bodies[0]
        pose = {i: ((0.0, 0.0), 0.0) if i < 0 else (tuple(com[i]), float(angle[i]))
                for i in (first, second)}

        def local(i, point):
            (cx, cy), q = pose[i]
            c, s = math.cos(q), math.sin(q)
            x, y = point[0] - cx, point[1] - cy
            return c * x + s * y, -s * x + c * y

        kind = JOINT_TYPES.index(spec.kind)
        if kind == DISTANCE:
            la, lb = local(second, spec.anchors[1]), local(first, spec.anchors[0])
        elif kind == MOTOR:
            la, lb = local(second, pose[first][0]), (0.0, 0.0)
        else:
            la, lb = local(second, spec.anchor), local(first, spec.anchor)
        qa = pose[second][1]
        c, s = math.cos(qa), math.sin(qa)
        axis = (c * spec.axis[0] + s * spec.axis[1], -s * spec.axis[0] + c * spec.axis[1])
        limits = spec.limits or (0.0, 0.0)
        motor = spec.motor or (0.0, 0.0)
        spring = spec.spring or (0.0, 0.0)
        values = {
            "kind": kind, "body_a": second, "body_b": first, "local_a": la, "local_b": lb,
            "local_axis": axis, "reference_angle": pose[first][1] - qa, "length": spec.length,
            "min_length": spec.min_length, "max_length": spec.max_length, "lower": limits[0],
            "upper": limits[1], "has_limit": spec.limits is not None,
            "has_motor": spec.motor is not None and kind != MOTOR,
            "has_spring": spec.spring is not None and spring[0] > 0.0,
            "collide_connected": spec.collide_connected,
            "motor_speed": 0.0 if kind == MOTOR else motor[0],
            "max_motor": motor[0] if kind == MOTOR else motor[1],
            "max_torque": motor[1] if kind == MOTOR else 0.0, "max_force": spec.max_force,
            "spring_hertz": spring[0], "spring_damping": spring[1]}
        return cls(*(np.full((1,) + shape, values.get(name, 0.0), dtype)
                     for name, (shape, dtype) in _FIELDS.items()))

    @classmethod
    def concatenate(cls, parts: list[JointRows]) -> JointRows:
        """The rows of ``parts`` one after the other."""
        return cls(*(np.concatenate(arrays) for arrays in zip(*parts)))

    def take(self, index: np.ndarray) -> JointRows:
        return JointRows(*(np.ascontiguousarray(x[index]) for x in self))

    def renumbered(self, removed: int) -> JointRows:
        """The rows after body ``removed`` is gone: later bodies' indices down by one."""
        return self._replace(body_a=self.body_a - (self.body_a > removed),
                             body_b=self.body_b - (self.body_b > removed))


#: JointRows' fields: name -> (trailing shape, dtype).
_FIELDS = {name: ((2,) if name in ("local_a", "local_b", "local_axis", "linear_impulse")
                  else (), np.int64 if name in ("kind", "body_a", "body_b")
                  else np.bool_ if name.startswith("has_") or name == "collide_connected"
                  else np.float64)
           for name in JointRows._fields}


# --------------------------------------------------------------------------------------
# Packed rows: the kernels' view of JointRows.
#
# The kernels take the rows as three arrays, one row per joint, a column per field
# (``pack``; the accumulated impulses go back to the NamedTuple after the step,
# ``unpack_impulses``). A NamedTuple of the 30 arrays is passed by value, each array as
# seven arguments, through every function that takes it, and a StructRef holding them
# takes and drops a reference count at every field read in a kernel that counts them
# (in the ragdoll a quarter of its time). Three arrays indexed by constant columns cost
# neither, so the per-joint kernels compile without reference counts (figures:
# docs/performance.md, "2026-11-29").
# --------------------------------------------------------------------------------------

#: Columns of the packed ints (J, INTS) int64: JointRows' kind, body_a, body_b and flags.
KIND, BODY_A, BODY_B, HAS_LIMIT, HAS_MOTOR, HAS_SPRING = range(6)
INTS = 6
#: Columns of the packed reals (J, REALS) float64, JointRows' fields of those names
#: (local_a, local_b, local_axis as x, y).
(LOCAL_AX, LOCAL_AY, LOCAL_BX, LOCAL_BY, AXIS_X, AXIS_Y, REFERENCE_ANGLE, LENGTH,
 MIN_LENGTH, MAX_LENGTH, LOWER, UPPER, MOTOR_SPEED, MAX_MOTOR, MAX_TORQUE, MAX_FORCE) = \
    range(16)
REALS = 16
#: Columns of the packed impulses (J, IMPULSES) float64, N s per substep: JointRows'
#: linear_impulse (x, y), angular, perp, axial, spring, motor, lower and upper impulses.
(LINEAR_X, LINEAR_Y, ANGULAR_IMPULSE, PERP_IMPULSE, AXIAL_IMPULSE, SPRING_IMPULSE,
 MOTOR_IMPULSE, LOWER_IMPULSE, UPPER_IMPULSE) = range(9)
IMPULSES = 9
_INT_FIELDS = ("kind", "body_a", "body_b", "has_limit", "has_motor", "has_spring")
_REAL_FIELDS = (("local_a", 0), ("local_a", 1), ("local_b", 0), ("local_b", 1),
                ("local_axis", 0), ("local_axis", 1), ("reference_angle", None),
                ("length", None), ("min_length", None), ("max_length", None),
                ("lower", None), ("upper", None), ("motor_speed", None), ("max_motor", None),
                ("max_torque", None), ("max_force", None))
_IMPULSE_FIELDS = (("linear_impulse", 0), ("linear_impulse", 1), ("angular_impulse", None),
                   ("perp_impulse", None), ("axial_impulse", None), ("spring_impulse", None),
                   ("motor_impulse", None), ("lower_impulse", None), ("upper_impulse", None))


class Packed(NamedTuple):
    """JointRows as the kernels take them (``pack``): ints (J, INTS) int64, reals
    (J, REALS), impulses (J, IMPULSES) (the columns above)."""

    ints: np.ndarray
    reals: np.ndarray
    impulses: np.ndarray


def _columns(rows: JointRows, fields, dtype) -> np.ndarray:
    """The (J, len(fields)) array of ``rows``' fields (name, column or None)."""
    out = np.empty((len(rows.kind), len(fields)), dtype)
    for c, (name, column) in enumerate(fields):
        values = getattr(rows, name)
        out[:, c] = values if column is None else values[:, column]
    return out


def pack(rows: JointRows) -> Packed:
    """``rows`` packed for the kernels (a copy: ``unpack_impulses`` brings the impulses
    back)."""
    return Packed(_columns(rows, [(name, None) for name in _INT_FIELDS], np.int64),
                  _columns(rows, _REAL_FIELDS, np.float64),
                  _columns(rows, _IMPULSE_FIELDS, np.float64))


def unpack_impulses(packed: Packed, rows: JointRows) -> None:
    """The packed impulses written back into ``rows``' impulse arrays, in place."""
    for c, (name, column) in enumerate(_IMPULSE_FIELDS):
        target = getattr(rows, name)
        if column is None:
            target[:] = packed.impulses[:, c]
        else:
            target[:, column] = packed.impulses[:, c]


def stiffened_softness(inv_mass: np.ndarray, inv_inertia: np.ndarray, rows: JointRows,
                       settings, gravity: np.ndarray, cap: float,
                       packed: Packed | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(soft (J, 2, 3), params (6,)): bias_rate 1/s, mass_scale, impulse_scale of each
    joint's rigid rows, linear [:, 0] and angular [:, 1] ("Loaded joints" below), from
    the accumulated impulses now; ``joint_passes`` refills them every substep from
    params = (omega rad/s, damping ratio, h s, |g| h m/s, cap, largest r), and lowers
    or raises the cap on r (``cap``: where the last step left it; inf: none).

    inv_mass, inv_inertia: (B,); gravity: (2,) m/s^2 (zero, or
    ``settings.load_stiffening`` false: no stiffening); packed: ``pack(rows)`` if the
    caller has it already.
    """
    h = settings.dt / settings.substeps
    g = float(np.hypot(gravity[0], gravity[1])) if settings.load_stiffening else 0.0
    params = np.array([2.0 * math.pi * 2.0 * min(settings.contact_hertz, 0.25 / h),
                       JOINT_DAMPING_RATIO, h, g * h, cap, 1.0])
    soft = np.empty((rows.kind.shape[0], 2, 3))
    stiffen(inv_mass, inv_inertia, pack(rows) if packed is None else packed, params, soft)
    return soft, params


# --------------------------------------------------------------------------------------
# Loaded joints: a 100 kg weight on a chain of 1 kg links.
#
# A rigid joint row is soft with the joint softness: a spring of stiffness m w^2 for the
# row's effective mass m (``softness``), so a load F opens it by F / (m w^2): 4.5 mm
# per joint for a 1 kg pair (m = 0.5 kg) under a 100 kg weight at rest at 60 Hz, and
# several times that while it swings (Box2D v3 at its defaults: 56 mm). As the contacts'
# load stiffening (``softness``, "Loaded islands"), a row that carried r - 1 times the
# weight of its effective mass in the last step (its accumulated impulse |l| against
# m |g| h; for angular rows m is the angular effective mass and the weight is taken at
# an arm of 1 m) uses the spring and damper of mass r m: w' = w sqrt(r), z' = z sqrt(r),
# and so opens under its load as under its own weight, g / w^2 (0.07 mm at 60 Hz).
# r is taken afresh every substep, after the warm start: a whipping chain's tension
# grows twentyfold within one step, and rows stiffened for last step's load open by
# F / (r m w^2) under it (tens of centimetres).
# Rows that stiff need converged passes: the joints get up to JOINT_PASSES x
# ``stiff_iterations`` passes in each phase of a substep, stopping after a pass whose
# largest impulse change is at most CONVERGED times the largest accumulated impulse
# (one pass when nothing is loaded; a joint against the world converges in one).
# Unconverged stiffened rows ring: a 20-link chain hanging a 100 kg weight at rest
# needs about 100 passes (Gauss-Seidel moves an error one joint per pass and a light
# link passes on ~1/100 of a heavy neighbour's), and at 64 it oscillated and blew up.
# So r is capped where the passes cannot keep up: a solve that does not converge
# halves the cap (below the largest r it met), one that converges in a quarter of its
# passes doubles it; the cap carries over from step to step (``JointTable``).
# --------------------------------------------------------------------------------------


@njit(cache=True, refcounts=False)
def stiffen(inv_mass, inv_inertia, rows, params, out):
    """Fill out (J, 2, 3) (``stiffened_softness``) for the ``Packed`` rows; params: omega
    rad/s and zeta of the joint softness, h s, weight_impulse |g| h m/s (0: no
    stiffening), the cap on r; params[5] receives the largest r before the cap."""
    ints, _, impulses = rows
    omega, zeta, h, weight_impulse = params[0], params[1], params[2], params[3]
    params[5] = 1.0
    for j in range(ints.shape[0]):
        a = ints[j, BODY_A]
        b = ints[j, BODY_B]
        m_lin = (inv_mass[a] if a >= 0 else 0.0) + (inv_mass[b] if b >= 0 else 0.0)
        m_ang = (inv_inertia[a] if a >= 0 else 0.0) + (inv_inertia[b] if b >= 0 else 0.0)
        limit = max(impulses[j, LOWER_IMPULSE], impulses[j, UPPER_IMPULSE])
        angular = abs(impulses[j, ANGULAR_IMPULSE])
        linear = max(math.hypot(impulses[j, LINEAR_X], impulses[j, LINEAR_Y]),
                     abs(impulses[j, PERP_IMPULSE]), abs(impulses[j, AXIAL_IMPULSE]))
        if ints[j, KIND] == REVOLUTE:
            angular = max(angular, limit)
        else:
            linear = max(linear, limit)
        for k, (load, inverse) in enumerate(((linear, m_lin), (angular, m_ang))):
            r = 1.0
            if weight_impulse > 0.0:
                r = 1.0 + load * inverse / weight_impulse
                params[5] = max(params[5], r)
                r = min(r, params[4])
            root = math.sqrt(r)
            w = omega * root
            a1 = 2.0 * zeta * root + h * w
            a2 = h * w * a1
            a3 = 1.0 / (1.0 + a2)
            out[j, k, 0] = w / a1
            out[j, k, 1] = a2 * a3
            out[j, k, 2] = a3


def spring_softness(rows: JointRows, h: float) -> np.ndarray:
    """(J, 3) the springs' bias_rate, mass_scale, impulse_scale for substep h (s): one
    ``soft_coefficients`` per distinct (hertz, damping ratio)."""
    out = np.zeros((rows.kind.shape[0], 3))
    out[:, 1] = 1.0
    springs = np.column_stack([rows.spring_hertz, rows.spring_damping])
    distinct, which = np.unique(springs, axis=0, return_inverse=True)
    for k, (hertz, zeta) in enumerate(distinct):
        soft = soft_coefficients(float(hertz), float(zeta), h)
        out[which.reshape(-1) == k] = (soft.bias_rate, soft.mass_scale, soft.impulse_scale)
    return out


# --------------------------------------------------------------------------------------
# Rows (one function per shape of row, shared by every kind and phase).
# --------------------------------------------------------------------------------------


class Output(NamedTuple):
    """What a pass reports. force (J, 2), torque (J,): REACTION's sums (N s on b);
    progress (2,): the largest |impulse change| and |accumulated impulse| (N s or
    N m s) of a SOLVE or RELAX pass."""

    force: np.ndarray
    torque: np.ndarray
    progress: np.ndarray


@njit(cache=True, refcounts=False)
def _progress(progress, change, total):
    progress[0] = max(progress[0], change)
    progress[1] = max(progress[1], total)


@njit(cache=True, refcounts=False)
def _apply(v, m, ux, uy, a1, a2, impulse):
    """Velocities (vax, vay, wa, vbx, vby, wb) after the row impulse (module docstring)."""
    vax, vay, wa, vbx, vby, wb = v
    ma, ia, mb, ib = m
    return (vax - ma * impulse * ux, vay - ma * impulse * uy, wa - ia * impulse * a1,
            vbx + mb * impulse * ux, vby + mb * impulse * uy, wb + ib * impulse * a2)


@njit(cache=True, refcounts=False)
def _row(v, m, ux, uy, a1, a2, impulses, j, c, phase, bias, m_scale, i_scale, lo, hi, out):
    """One row with Jacobian (u, a1, a2) and accumulated impulse impulses[j, c] (module
    docstring; the packed impulses, column c).

    phase WARM applies it; SOLVE and RELAX update it with the given bias (m/s or rad/s),
    mass_scale, impulse_scale, clamped to [lo, hi], and raise out.progress to (|change|,
    |impulse|); REACTION adds its linear impulse on b to out.force[j] and, for an angular
    row (u = 0), its torque to out.torque[j].
    """
    acc = impulses[j, c]
    if phase == WARM:
        return _apply(v, m, ux, uy, a1, a2, acc)
    if phase == REACTION:
        out.force[j, 0] += acc * ux
        out.force[j, 1] += acc * uy
        if ux == 0.0 and uy == 0.0:
            out.torque[j] += acc * a2
        return v
    vax, vay, wa, vbx, vby, wb = v
    ma, ia, mb, ib = m
    k = (ma + mb) * (ux * ux + uy * uy) + ia * a1 * a1 + ib * a2 * a2
    if k <= 0.0:
        return v
    cdot = ux * (vbx - vax) + uy * (vby - vay) + a2 * wb - a1 * wa
    impulse = -(m_scale * cdot + bias) / k - i_scale * acc
    total = min(max(acc + impulse, lo), hi)
    impulse = total - acc
    impulses[j, c] = total
    _progress(out.progress, abs(impulse), abs(total))
    return _apply(v, m, ux, uy, a1, a2, impulse)


@njit(cache=True, refcounts=False)
def _point(v, m, rax, ray, rbx, rby, impulses, j, phase, bx, by, m_scale, i_scale, largest,
           out):
    """The 2x2 block of a shared point, accumulated impulse (impulses[j, LINEAR_X],
    impulses[j, LINEAR_Y]) on b, of length at most largest (N s). bias (bx, by) m/s as
    in ``_row``; REACTION adds the impulse to out.force[j]."""
    vax, vay, wa, vbx, vby, wb = v
    ma, ia, mb, ib = m
    if phase == REACTION:
        out.force[j, 0] += impulses[j, LINEAR_X]
        out.force[j, 1] += impulses[j, LINEAR_Y]
        return v
    if phase == WARM:
        px, py = impulses[j, LINEAR_X], impulses[j, LINEAR_Y]
    else:
        k11 = ma + mb + ia * ray * ray + ib * rby * rby
        k12 = -ia * rax * ray - ib * rbx * rby
        k22 = ma + mb + ia * rax * rax + ib * rbx * rbx
        det = k11 * k22 - k12 * k12
        if det <= 0.0:
            return v
        cx = m_scale * (vbx - wb * rby - vax + wa * ray) + bx
        cy = m_scale * (vby + wb * rbx - vay - wa * rax) + by
        ox, oy = impulses[j, LINEAR_X], impulses[j, LINEAR_Y]
        tx = ox - (k22 * cx - k12 * cy) / det - i_scale * ox
        ty = oy - (k11 * cy - k12 * cx) / det - i_scale * oy
        size = math.hypot(tx, ty)
        if size > largest:
            tx *= largest / size
            ty *= largest / size
        impulses[j, LINEAR_X], impulses[j, LINEAR_Y] = tx, ty
        px, py = tx - ox, ty - oy
        _progress(out.progress, math.hypot(px, py), math.hypot(tx, ty))
    return (vax - ma * px, vay - ma * py, wa - ia * (rax * py - ray * px),
            vbx + mb * px, vby + mb * py, wb + ib * (rbx * py - rby * px))


@njit(cache=True, refcounts=False)
def _equality(c, soft, phase):
    """(bias, mass_scale, impulse_scale) of an equality row at error c: soft with the joint
    softness while solving, rigid while relaxing."""
    if phase == SOLVE:
        return soft[1] * soft[0] * c, soft[1], soft[2]
    return 0.0, 1.0, 0.0


@njit(cache=True, refcounts=False)
def _limit(c, soft, phase, inv_h):
    """(bias, mass_scale, impulse_scale) of a one-sided row at error c (>= 0 allowed)."""
    if c > 0.0:
        return c * inv_h, 1.0, 0.0
    return _equality(c, soft, phase)


@njit(cache=True, refcounts=False)
def _spring(c, spring):
    """(bias, mass_scale, impulse_scale) of a spring row at stretch c (both passes)."""
    return spring[1] * spring[0] * c, spring[1], spring[2]


@njit(cache=True, refcounts=False)
def _limits(v, m, r, j, phase, value, ux, uy, a1, a2, soft, inv_h, out):
    """The lower and upper rows of a limited coordinate ``value`` (rad or m); r: the
    ``Packed`` rows."""
    ints, reals, impulses = r
    if not ints[j, HAS_LIMIT]:
        return v
    bias, ms, isc = _limit(value - reals[j, LOWER], soft, phase, inv_h)
    v = _row(v, m, ux, uy, a1, a2, impulses, j, LOWER_IMPULSE, phase, bias, ms, isc, 0.0,
             np.inf, out)
    bias, ms, isc = _limit(reals[j, UPPER] - value, soft, phase, inv_h)
    return _row(v, m, -ux, -uy, -a1, -a2, impulses, j, UPPER_IMPULSE, phase, bias, ms, isc,
                0.0, np.inf, out)


@njit(cache=True, refcounts=False)
def _motor(v, m, r, j, phase, ux, uy, a1, a2, h, out):
    """A motor row driving Cdot toward motor_speed, |impulse| <= max_motor h."""
    ints, reals, impulses = r
    if not ints[j, HAS_MOTOR]:
        return v
    bound = reals[j, MAX_MOTOR] * h
    return _row(v, m, ux, uy, a1, a2, impulses, j, MOTOR_IMPULSE, phase,
                -reals[j, MOTOR_SPEED], 1.0, 0.0, -bound, bound, out)


# --------------------------------------------------------------------------------------
# One joint, every kind.
# --------------------------------------------------------------------------------------


@njit(cache=True, refcounts=False)
def _joint(v, m, g, r, j, phase, soft, spring, inv_h, out, direct):
    """Joint j's rows in Box2D v3's order (springs, motors, limits, then the rigid rows).

    r: the ``Packed`` rows. g: (rax, ray, rbx, rby, dx, dy, qa, qb) the arms, the
    separation d = pB - pA (m) and the angles (rad) now. soft: (J, 2, 3) the rigid rows'
    coefficients, linear and angular (``stiffened_softness``). direct: the equality rows
    (bits POINT_ROWS, ANGLE_ROW, PERP_ROW, AXIAL_ROW) this pass leaves to the island's
    direct solve (``joint_direct``). Returns the new velocities."""
    rax, ray, rbx, rby, dx, dy, qa, qb = g
    ints, reals, impulses = r
    kind = ints[j, KIND]
    lin = soft[j, 0]
    ang = soft[j, 1]
    h = 1.0 / inv_h
    angle = qb - qa - reals[j, REFERENCE_ANGLE]
    if kind == REVOLUTE or kind == WELD or kind == MOTOR:
        if kind == REVOLUTE:
            v = _motor(v, m, r, j, phase, 0.0, 0.0, 1.0, 1.0, h, out)
            v = _limits(v, m, r, j, phase, angle, 0.0, 0.0, 1.0, 1.0, ang, inv_h, out)
            bias, ms, isc = _equality(1.0, lin, phase)
            largest = np.inf
        elif kind == WELD:
            if ints[j, HAS_SPRING]:
                bias, ms, isc = _spring(angle, spring[j])
            else:
                bias, ms, isc = _equality(angle, ang, phase)
            if not direct & ANGLE_ROW:
                v = _row(v, m, 0.0, 0.0, 1.0, 1.0, impulses, j, ANGULAR_IMPULSE, phase, bias, ms,
                         isc, -np.inf, np.inf, out)
            bias, ms, isc = _spring(1.0, spring[j]) if ints[j, HAS_SPRING] else _equality(
                1.0, lin, phase)
            largest = np.inf
        else:
            bound = reals[j, MAX_TORQUE] * h
            if ints[j, HAS_SPRING]:
                bias, ms, isc = _spring(angle, spring[j])
            else:
                bias, ms, isc = _equality(angle, ang, phase)
            v = _row(v, m, 0.0, 0.0, 1.0, 1.0, impulses, j, ANGULAR_IMPULSE, phase, bias, ms, isc,
                     -bound, bound, out)
            bias, ms, isc = _spring(1.0, spring[j]) if ints[j, HAS_SPRING] else _equality(
                1.0, lin, phase)
            largest = reals[j, MAX_MOTOR] * h
        if direct & POINT_ROWS:
            return v
        # bias above is per metre of separation: the point's bias is (bias dx, bias dy).
        return _point(v, m, rax, ray, rbx, rby, impulses, j, phase, bias * dx,
                      bias * dy, ms, isc, largest, out)
    if kind == MOUSE:
        spring_j = spring[j]
        return _point(v, m, rax, ray, rbx, rby, impulses, j, phase,
                      spring_j[1] * spring_j[0] * dx, spring_j[1] * spring_j[0] * dy,
                      spring_j[1], spring_j[2], reals[j, MAX_FORCE] * h, out)
    if kind == DISTANCE:
        length = math.hypot(dx, dy)
        if length < 1e-9:
            return v
        ux, uy = dx / length, dy / length
        a1 = rax * uy - ray * ux
        a2 = rbx * uy - rby * ux
        if reals[j, MIN_LENGTH] == reals[j, MAX_LENGTH]:
            if direct & AXIAL_ROW:
                return v
            bias, ms, isc = _equality(length - reals[j, LENGTH], lin, phase)
            return _row(v, m, ux, uy, a1, a2, impulses, j, AXIAL_IMPULSE, phase, bias, ms, isc,
                        -np.inf, np.inf, out)
        if ints[j, HAS_SPRING]:
            bias, ms, isc = _spring(length - reals[j, LENGTH], spring[j])
            v = _row(v, m, ux, uy, a1, a2, impulses, j, SPRING_IMPULSE, phase, bias, ms, isc,
                     -np.inf, np.inf, out)
        if reals[j, MIN_LENGTH] > 0.0:
            bias, ms, isc = _limit(length - reals[j, MIN_LENGTH], lin, phase, inv_h)
            v = _row(v, m, ux, uy, a1, a2, impulses, j, LOWER_IMPULSE, phase, bias, ms, isc, 0.0,
                     np.inf, out)
        if reals[j, MAX_LENGTH] < _NO_LIMIT:
            bias, ms, isc = _limit(reals[j, MAX_LENGTH] - length, lin, phase, inv_h)
            v = _row(v, m, -ux, -uy, -a1, -a2, impulses, j, UPPER_IMPULSE, phase, bias, ms,
                     isc, 0.0, np.inf, out)
        return v
    # PRISMATIC and WHEEL: an axis carried by a, along which b slides.
    ca, sa = math.cos(qa), math.sin(qa)
    ux = ca * reals[j, AXIS_X] - sa * reals[j, AXIS_Y]
    uy = sa * reals[j, AXIS_X] + ca * reals[j, AXIS_Y]
    translation = ux * dx + uy * dy
    a1 = (dx + rax) * uy - (dy + ray) * ux
    a2 = rbx * uy - rby * ux
    if kind == PRISMATIC:
        v = _motor(v, m, r, j, phase, ux, uy, a1, a2, h, out)
    else:
        v = _motor(v, m, r, j, phase, 0.0, 0.0, 1.0, 1.0, h, out)
        if ints[j, HAS_SPRING]:
            bias, ms, isc = _spring(translation, spring[j])
            v = _row(v, m, ux, uy, a1, a2, impulses, j, SPRING_IMPULSE, phase, bias, ms, isc,
                     -np.inf, np.inf, out)
        elif not direct & AXIAL_ROW:
            bias, ms, isc = _equality(translation, lin, phase)
            v = _row(v, m, ux, uy, a1, a2, impulses, j, AXIAL_IMPULSE, phase, bias, ms, isc,
                     -np.inf, np.inf, out)
    v = _limits(v, m, r, j, phase, translation, ux, uy, a1, a2, lin, inv_h, out)
    px, py = -uy, ux
    if not direct & PERP_ROW:
        bias, ms, isc = _equality(px * dx + py * dy, lin, phase)
        v = _row(v, m, px, py, (dx + rax) * py - (dy + ray) * px, rbx * py - rby * px,
                 impulses, j, PERP_IMPULSE, phase, bias, ms, isc, -np.inf, np.inf, out)
    if kind == PRISMATIC and not direct & ANGLE_ROW:
        bias, ms, isc = _equality(angle, ang, phase)
        v = _row(v, m, 0.0, 0.0, 1.0, 1.0, impulses, j, ANGULAR_IMPULSE, phase, bias, ms, isc,
                 -np.inf, np.inf, out)
    return v


@njit(cache=True, refcounts=False)
def joint_geometry(cax, cay, qa, cbx, cby, qb, reals, j):
    """(rax, ray, rbx, rby, dx, dy, qa, qb) of joint j with body a at (cax, cay) m, angle qa
    rad and body b at (cbx, cby), qb (zeros for the world): the arms rA = R(qa) local_a,
    rB = R(qb) local_b, the separation d = (xb + rB) - (xa + rA) (m) and the angles.
    reals: the packed reals (``Packed``)."""
    c, s = math.cos(qa), math.sin(qa)
    rax = c * reals[j, LOCAL_AX] - s * reals[j, LOCAL_AY]
    ray = s * reals[j, LOCAL_AX] + c * reals[j, LOCAL_AY]
    c, s = math.cos(qb), math.sin(qb)
    rbx = c * reals[j, LOCAL_BX] - s * reals[j, LOCAL_BY]
    rby = s * reals[j, LOCAL_BX] + c * reals[j, LOCAL_BY]
    return rax, ray, rbx, rby, cbx + rbx - cax - rax, cby + rby - cay - ray, qa, qb


@njit(cache=True, refcounts=False)
def _all_direct(ints, j, direct):
    """Whether ``_joint`` has no row of joint j to solve when the direct solve takes its
    equality rows ``direct`` (bits): no motor, no limit, no spring row, every rigid row
    direct. Such a joint is skipped by a SOLVE or RELAX pass (its velocities unchanged).
    ints: the packed ints (``Packed``)."""
    if ints[j, HAS_MOTOR] or ints[j, HAS_LIMIT]:
        return False
    kind = ints[j, KIND]
    if kind == REVOLUTE:
        return direct == POINT_ROWS
    if kind == WELD:
        return direct == POINT_ROWS | ANGLE_ROW
    if kind == PRISMATIC:
        return direct == PERP_ROW | ANGLE_ROW
    if kind == WHEEL:
        return direct == PERP_ROW | AXIAL_ROW
    if kind == DISTANCE:
        return direct == AXIAL_ROW
    return False


@njit(cache=True, refcounts=False)
def solve_joints(com, angle, velocity, angular_velocity, inv_mass, inv_inertia, rows, phase,
                 soft, spring, inv_h, out, direct):
    """One pass of ``phase`` (WARM, SOLVE, RELAX, REACTION) over every joint, in order.

    com (B, 2) m, angle (B,) rad: the bodies now; velocity, angular_velocity updated in
    place; inv_mass, inv_inertia: (B,) (0: static, kinematic, asleep). rows: ``Packed``.
    soft: (J, 2, 3) ``stiffened_softness``; spring: (J, 3) ``spring_softness``;
    inv_h: 1/s. out: Output, what REACTION adds to and SOLVE, RELAX report progress in.
    direct: (J,) int64, the equality rows SOLVE and RELAX leave to ``joint_direct``
    (bits; zeros: every row here).
    """
    ints, reals, _ = rows
    for j in range(ints.shape[0]):
        if (phase == SOLVE or phase == RELAX) and _all_direct(ints, j, direct[j]):
            continue
        a = ints[j, BODY_A]
        b = ints[j, BODY_B]
        cax = cay = qa = vax = vay = wa = ma = ia = 0.0
        cbx = cby = qb = vbx = vby = wb = mb = ib = 0.0
        if a >= 0:
            cax, cay, qa = com[a, 0], com[a, 1], angle[a]
            vax, vay, wa = velocity[a, 0], velocity[a, 1], angular_velocity[a]
            ma, ia = inv_mass[a], inv_inertia[a]
        if b >= 0:
            cbx, cby, qb = com[b, 0], com[b, 1], angle[b]
            vbx, vby, wb = velocity[b, 0], velocity[b, 1], angular_velocity[b]
            mb, ib = inv_mass[b], inv_inertia[b]
        if ma == 0.0 and ia == 0.0 and mb == 0.0 and ib == 0.0 and phase != REACTION:
            continue
        g = joint_geometry(cax, cay, qa, cbx, cby, qb, reals, j)
        v = _joint((vax, vay, wa, vbx, vby, wb), (ma, ia, mb, ib), g, rows, j, phase, soft,
                   spring, inv_h, out,
                   direct[j] if phase == SOLVE or phase == RELAX else 0)
        if a >= 0:
            velocity[a, 0], velocity[a, 1], angular_velocity[a] = v[0], v[1], v[2]
        if b >= 0:
            velocity[b, 0], velocity[b, 1], angular_velocity[b] = v[3], v[4], v[5]


def joint_reactions(com: np.ndarray, angle: np.ndarray, rows: JointRows,
                    h: float) -> tuple[np.ndarray, np.ndarray]:
    """(force (J, 2) N, torque (J,) N m): what each joint's rows applied to its first body
    over the last substep's accumulated impulses / h. The torque counts the angular rows
    only (motor, limits, a weld's or prismatic's angle), as Box2D's constraint torque."""
    count = rows.kind.shape[0]
    out = Output(np.zeros((count, 2)), np.zeros(count), np.zeros(2))
    if count:
        zero = np.zeros(len(angle))
        solve_joints(com, angle, np.zeros_like(com), zero, zero, zero, pack(rows), REACTION,
                     np.zeros((count, 2, 3)), np.zeros((count, 3)), 1.0 / h, out,
                     np.zeros(count, np.int64))
    return out.force / h, out.torque / h
