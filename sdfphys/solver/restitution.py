"""Restitution: velocity passes after the substeps toward vn' = -e vn0.

Box2D v3's ``b2ApplyRestitution``: a contact point bounces if it approached faster than
``Settings.restitution_threshold`` at the start of the step and carried normal impulse
during it; ``Settings.restitution_passes`` Gauss-Seidel passes over those points.
"""

from __future__ import annotations

from .._jit import njit
from ..settings import Settings
from .pair_rows import (
    along,
    apply_impulse,
    cross,
    load_pair,
    pair_bodies,
    pair_count,
    store_pair,
    unsigned,
)
from .rows import BodyState, ContactConstraints

__all__ = ["apply_restitution"]


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
    body_a, body_b, pair_start = unsigned(body_a), unsigned(body_b), unsigned(pair_start)
    for _ in range(passes):
        for p in range(pair_count(pair_start)):
            first, last, a, b, ma, ia, mb, ib = pair_bodies(p, pair_start, body_a, body_b,
                                                            inv_mass, inv_inertia)
            vax, vay, wa, vbx, vby, wb = load_pair(velocity, angular_velocity, a, b)
            for k in range(first, last):
                e = restitution[k]
                if e == 0.0 or relative_velocity[k] > -threshold or total_normal_impulse[k] == 0.0:
                    continue
                nx = normal[k, 0]
                ny = normal[k, 1]
                rna = cross(anchor_a[k, 0], anchor_a[k, 1], nx, ny)
                rnb = cross(anchor_b[k, 0], anchor_b[k, 1], nx, ny)
                old = normal_impulse[k]
                vn = along(vax, vay, wa, vbx, vby, wb, nx, ny, rna, rnb)
                accumulated = max(old - normal_mass[k] * (vn + e * relative_velocity[k]), 0.0)
                impulse = accumulated - old
                normal_impulse[k] = accumulated
                total_normal_impulse[k] += impulse
                vax, vay, wa, vbx, vby, wb = apply_impulse(
                    vax, vay, wa, vbx, vby, wb, ma, ia, mb, ib, nx, ny, rna, rnb, impulse)
            store_pair(velocity, angular_velocity, a, b, vax, vay, wa, vbx, vby, wb)


def apply_restitution(bodies: BodyState, constraints: ContactConstraints,
                      settings: Settings) -> None:
    """``settings.restitution_passes`` restitution passes in place (one compiled call)."""
    c = constraints
    _restitution_kernel(
        bodies.velocity, bodies.angular_velocity, bodies.inv_mass, bodies.inv_inertia,
        c.body_a, c.body_b, c.pair_start, c.normal, c.anchor_a, c.anchor_b, c.normal_mass,
        c.restitution, c.relative_velocity, c.normal_impulse, c.total_normal_impulse,
        settings.restitution_threshold, settings.restitution_passes)
