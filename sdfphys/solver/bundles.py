"""Bundles of arrays handed to the solver's kernels by reference (numba StructRefs).

Numba passes a tuple by value, each of its arrays as seven arguments, through every
function that takes it; a kernel of 40 positional arrays is as long to type, lower and
call. A StructRef is one pointer to the same arrays: a kernel reads ``rows.normal[k, 0]``
as from a NamedTuple, and a write is the caller's array's. Each bundle here is a
StructRef type (``PlainFields``: its fields take their values' plain types), a proxy
class Python holds opaquely, and a maker compiled once into the disk cache (the proxy's
own constructor would compile again in every process). The joints' bundles (a step's
joints, the direct solve's plan) are in ``joint_direct``; the joint rows themselves are
three packed arrays (``joints.pack``), which kernels without reference counts read. The
substep kernel's bundles here gained no speed over tuples (unpacked once a pass), only
a signature of 16 arguments instead of 43. A StructRef's field read takes and drops a
reference count, so a kernel that takes one cannot be compiled without them: the
kernels read the fields once, at their top.
"""

from __future__ import annotations

from numba.experimental import structref

from .._bundles import PlainFields
from .._jit import njit

__all__ = ["PlainFields", "SubstepBodies", "SubstepRows", "substep_bodies", "substep_rows"]


@structref.register
class _SubstepBodiesType(PlainFields):
    """Numba's type of ``SubstepBodies``."""


class SubstepBodies(structref.StructRefProxy):
    """The bodies as the substep kernel takes them (``rows.BodyState``'s arrays but
    ``radius``); made by ``substep_bodies``."""


BODY_FIELDS = ("com", "angle", "velocity", "angular_velocity", "inv_mass", "inv_inertia",
               "linear_damping", "angular_damping", "round_body")
structref.define_proxy(SubstepBodies, _SubstepBodiesType, list(BODY_FIELDS))


@njit(cache=True)
def _substep_bodies(com, angle, velocity, angular_velocity, inv_mass, inv_inertia,
                    linear_damping, angular_damping, round_body):
    return SubstepBodies(com, angle, velocity, angular_velocity, inv_mass, inv_inertia,
                         linear_damping, angular_damping, round_body)


def substep_bodies(bodies) -> SubstepBodies:
    """A ``rows.BodyState``'s arrays by reference."""
    return _substep_bodies(*(getattr(bodies, name) for name in BODY_FIELDS))


@structref.register
class _SubstepRowsType(PlainFields):
    """Numba's type of ``SubstepRows``."""


class SubstepRows(structref.StructRefProxy):
    """The contact rows as the substep kernel and ``softness.row_softness`` take them:
    ``rows.ContactConstraints``' arrays (but restitution and local_anchor) and the row
    coefficients (K,) that ``row_softness`` fills (bias_rate 1/s, mass_scale,
    impulse_scale); made by ``substep_rows``."""


ROW_FIELDS = ("body_a", "body_b", "pair_start", "normal", "anchor_a0", "anchor_b0",
              "anchor_a", "anchor_b", "base_separation", "separation", "normal_mass",
              "tangent_mass", "friction", "bias_rate", "mass_scale", "impulse_scale",
              "normal_impulse", "tangent_impulse", "total_normal_impulse",
              "total_tangent_impulse", "stiff", "relative_velocity", "feature")
structref.define_proxy(SubstepRows, _SubstepRowsType, list(ROW_FIELDS))


@njit(cache=True)
def _substep_rows(body_a, body_b, pair_start, normal, anchor_a0, anchor_b0, anchor_a,
                  anchor_b, base_separation, separation, normal_mass, tangent_mass, friction,
                  bias_rate, mass_scale, impulse_scale, normal_impulse, tangent_impulse,
                  total_normal_impulse, total_tangent_impulse, stiff, relative_velocity,
                  feature):
    return SubstepRows(body_a, body_b, pair_start, normal, anchor_a0, anchor_b0, anchor_a,
                       anchor_b, base_separation, separation, normal_mass, tangent_mass,
                       friction, bias_rate, mass_scale, impulse_scale, normal_impulse,
                       tangent_impulse, total_normal_impulse, total_tangent_impulse, stiff,
                       relative_velocity, feature)


def substep_rows(constraints, bias_rate, mass_scale, impulse_scale) -> SubstepRows:
    """A ``rows.ContactConstraints``' arrays and the row coefficients (K,) by reference."""
    coefficients = {"bias_rate": bias_rate, "mass_scale": mass_scale,
                    "impulse_scale": impulse_scale}
    return _substep_rows(*(coefficients[name] if name in coefficients
                           else getattr(constraints, name) for name in ROW_FIELDS))
