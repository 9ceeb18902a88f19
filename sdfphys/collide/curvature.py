"""Curvature radii of the surfaces at the contacts: where a turning body's row is anchored.

A contact row re-measures its separation from two anchors carried by the bodies
(``solver.substeps``, "Separation"): each body's surface point at the contact, turned
and moved with it. That is exact for a material point (a corner), but a rolling or
spinning curved body touches with whichever of its points is lowest: its surface point
at the contact rises by rho (1 - cos dq) as the body turns by dq (rho the radius of
curvature there), while the surface under the row stays where it was, so the row
reads a gap that is not there and lets the body sink by about rho dq^2 / 2 a step
(an ellipse landing at 8 rad/s, its end's rho 0.18 m: 1.2 mm a step, pressed in faster
than the push-out takes it out). A circle's row is therefore not turned at all
(``round_body``: its centre of curvature is its centre of mass).

The same holds, to second order in dq, for any smooth convex surface about its centre
of curvature C = p - rho n_out (p the surface point, n_out its outward normal): the
row's anchor becomes C, carried with the body, and the separation the distance from
C less rho (the first-order change, n . (dq x (p - x)), is the same for both anchors;
the second-order one is the circle's). ``curvature_radii`` measures rho for each
contact side on a turning sdf body from its field: the tangential derivative of the
unit gradient, kappa = (t . g(p + e t) - t . g(p - e t)) / (2 e), e = CURVATURE_STEP
of the body's bounding radius R, rho = 1 / kappa, where the body turns enough to
matter (``turning_bodies``), the contact is on its surface (ON_SURFACE) with the
row's normal its own (ALIGNED). Where the surface is flat, concave or nearly flat
(rho > FLAT R), and for every other shape (a polygon's faces are flat, its corners
material points; circles are round bodies), rho is 0: the surface point, as before.
Knob: ``Settings.curvature_anchors``.
"""

from __future__ import annotations

import numpy as np

from ..sdf import safe_normalize
from ..vec2 import rotate
from .contacts import Contacts
from .shape_fields import ShapeFields, evaluate_by_shape

__all__ = ["ALIGNED", "CURVATURE_STEP", "FLAT", "ON_SURFACE", "RISE", "curvature_radii",
           "turning_bodies"]

#: Finite-difference step of the curvature, as a fraction of the body's bounding radius.
CURVATURE_STEP = 1e-3
#: A contact's surface point is measured where the body's field there is within this
#: fraction of its bounding radius of 0 (a touching or overlapping contact, not a
#: speculative point out along a tangent) ...
ON_SURFACE = 1e-2
#: ... and the body's outward normal there is the row's normal to this cosine (the
#: centre of curvature is along the body's own normal).
ALIGNED = 0.999
#: Surfaces curved more gently than this many bounding radii keep the surface point:
#: a flat face's support jumps to its ends as it turns, which no circle follows. Below
#: it the gentler the curve, the more the anchor matters (an ellipse of semi-axes 0.7
#: and 0.35 m spinning at 8 rad/s onto its flat side, rho = 1.4 m = 1.8 R: 12 mm a
#: step; scenes/sdf_primitives.toml's ellipse landing 16.7 -> 10.9 mm with 10 rather
#: than 1).
FLAT = 10.0
#: Bodies whose turn this step lifts a point at their bounding radius by less than this
#: (m) keep their surface points: the error left, rho (w dt)^2 / 2, is below it (a
#: fiftieth of the default 5 mm slop; 0.31 rad/s for R = 0.7 m at dt 1/60).
RISE = 1e-4


def curvature_radii(fields: ShapeFields, shape_id: np.ndarray, com: np.ndarray,
                    angle: np.ndarray, turning: np.ndarray,
                    contacts: Contacts) -> tuple[np.ndarray, np.ndarray]:
    """(rho_a, rho_b) (K,) m: the radius of curvature of body a's and body b's surface at
    each contact (module docstring), 0 where not measured.

    fields: the collision shapes' ``ShapeFields``, shape_id (B,) its rows; com (B, 2) m,
    angle (B,) rad: the bodies' poses; turning (B,) bool: the bodies whose anchors move
    by turning (``turning_bodies``); contacts: point midway between the surfaces, normal
    a -> b, depth. Each shape's field evaluated once, at both sides' points
    (``shape_fields.evaluate_by_shape``)."""
    k = len(contacts)
    radii = np.zeros(2 * k)                                 # rho_a then rho_b
    curved_shape = fields.sdf & np.isfinite(fields.radius)
    body = np.concatenate([contacts.body_a, contacts.body_b])
    rows = np.flatnonzero(turning[body] & curved_shape[shape_id[body]])
    if len(rows) == 0:
        return radii[:k], radii[k:]
    b, contact = body[rows], rows % k
    sign = np.where(rows < k, 1.0, -1.0)           # a's outward normal is n, b's -n
    n = contacts.normal[contact]
    # Each side's surface point, point + (depth / 2) n for a, - for b, and a unit
    # tangent, in the body's frame.
    surface = contacts.point[contact] + (sign * 0.5 * contacts.depth[contact])[:, None] * n
    local = rotate(surface - com[b], -angle[b])
    tangent = rotate(np.column_stack([-n[:, 1], n[:, 0]]), -angle[b])
    reach = np.where(curved_shape, fields.radius, 0.0)[shape_id[b]]
    step = (CURVATURE_STEP * reach)[:, None] * tangent
    points = np.concatenate([local + step, local - step])
    f, g = evaluate_by_shape(fields, np.tile(shape_id[b], 2), points)
    g = safe_normalize(g)
    ahead, behind = g[:len(rows)], g[len(rows):]
    kappa = np.einsum("ij,ij->i", ahead - behind, tangent) / (2.0 * CURVATURE_STEP * reach)
    # The point on the surface (|f| within ON_SURFACE of R) with the row's normal as its
    # own (to ALIGNED): f and the unit gradient there are the means of the two samples'
    # to second order in the step.
    outward = safe_normalize(ahead + behind)
    facing = np.einsum("ij,ij->i", outward, np.column_stack([tangent[:, 1], -tangent[:, 0]]))
    on_surface = np.abs(0.5 * (f[:len(rows)] + f[len(rows):])) <= ON_SURFACE * reach
    curved = (kappa * reach * FLAT > 1.0) & on_surface & (sign * facing >= ALIGNED)
    radii[rows[curved]] = 1.0 / kappa[curved]
    return radii[:k], radii[k:]


def turning_bodies(kind_static: np.ndarray, angular_velocity: np.ndarray,
                   radius: np.ndarray, dt: float) -> np.ndarray:
    """(B,) bool: the bodies whose anchors a turn moves enough to measure: not static,
    and turning so fast that a surface point at their bounding radius R rises by more
    than RISE this step, R (w dt)^2 / 2 > RISE."""
    with np.errstate(invalid="ignore"):
        rise = 0.5 * radius * (angular_velocity * dt) ** 2
    return ~kind_static & (rise > RISE)
