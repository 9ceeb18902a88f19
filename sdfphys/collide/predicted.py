"""Predicted contacts at the step's end poses: a circle against a body that turns fast,
or that it moves fast against; the corners of a turning sdf body against another; a
concave mesh's elements against the faces they move onto.

A contact row keeps its normal and its two material points for the whole step (the
solver re-measures its separation as the bodies move, ``solver.substeps``). That is
right while the surface under the contact is the same material: a resting box, a
rolling circle. It is wrong when the other body turns fast: a spinning box's corner,
or a turning crescent's horn, sweeps toward a circle through material that no row
holds, and the circle is found inside it at the next step (in scenes/grid_terrain.toml
a box spinning at 28 rad/s met a circle 14 mm from it at the step's start 20 mm deep
at its end; in scenes/showcase.toml the moon's horn, turning at 5.8 rad/s, 23 mm). And
it is wrong when the circle itself moves fast along a curved surface: the surface it
will meet by the step's end faces another way than the one under it now (in
scenes/marble_run.toml marbles at 5 m/s ran into the arc's concave curve, found 13 mm
inside it a step later).

So for each candidate pair of a circle (centre c, radius r, velocity v_c) and a body b
that is not round and turns by more than ``linear_slop`` at its bounding radius this
step (|w_b| R_b dt > slop), or that the circle moves against by more than the slop
(|v_c - v_b| dt > slop), the pair is also measured at its predicted end poses, the
step's start velocities held (x' = x + v dt, angle' = angle + w dt): with
(d', g') = f_b and its unit gradient at c' in b's end frame, b's surface point nearest
the circle at the end is q' = c' - d' n', n' = R(angle'_b) g' (world, out of b). The
material point of b that reaches q' is q0 = x_b + R(-w_b dt) (q' - x'_b). The row is
that material point against the circle, along n':

    normal a -> b: n = -n' (circle toward b), s0 = n . (q0 - c) - r (depth -s0).

The solver moves q0 with b and the circle's point with the circle (a circle's anchor
is not turned), so at the end of the step s = s0 + n . (dq0 - dc) = n . (q' - c') - r
when b moved as predicted: the row forbids what the end pose would overlap, and with
s0 > 0 it is speculative, inert unless the gap closes. A collision that changes b's
spin makes the prediction approximate, no worse than the fixed normal it adds to.

Against a turning body s0 is clamped at 0 and the row's point is on q0, midway across
the gap along n (both surface points on the line through q0): the material point is
what the row must carry. Against a body that does not turn, b's points all move alike,
so the row's point is on the line through the circle's centre along n, as for every
contact of a circle (its normal impulse exerts no torque on it; on q0, v dt ahead of a
rolling ball, it spun the ball), and the row is kept only when speculative (s0 > 0:
a circle already inside the end pose's tangent line is pressed along the current
normal by its own rows).

Kept when within the pair's margin (depth > -(speculative distance + reach_a +
reach_b)); key ``source SOURCE_PREDICTED`` (6), element 0, start 0, one per pair. The
caller drops the rows that only repeat a contact of the pair (``collide._implied``).

Sdf pairs (``predicted_pair_contacts``, ``_field_corners``). A corner of a turning sdf
body sweeps into the other body the same way (scenes/sdf_primitives.toml: a hexagram and a pie
spinning at -3.1 and +3.7 rad/s, touching at one place, met at another 0.4 m away
32 mm deep within a step). For each sdf-sdf pair with a contact and a body turning
more than the slop at its bounding radius this step, the pair's own query runs at the
end poses (x + v dt, angle + w dt, no tangent samples); each end contact's two surface
points, m' = point -+ s' / 2 n' (s' = -depth), are carried back with their bodies,
m = x + R(-w dt) (m' - x'), and the row is s0 = max(n' . (m_b - m_a), 0) along the end
normal n', at the midpoint of m_a and m_b. Only where a turning body touches with a
corner or a flat (no centre of curvature there, ``collide.curvature``): a rolling
curved surface is held by its own rows, anchored at its centre of curvature, and a
row on the material point its end-pose contact is made of, ahead of the current one,
brakes it (an sdf disc rolling down a ramp: acceleration 0.3 % -> 6 % off). Key:
source 6, bit FIELD_PAIR, then the end contact's source, element and start.

Mesh pairs (``predicted_pair_contacts``, ``_new_faces``). A contact of a concave (triangulated) mesh
is an element (a vertex, a triangle's deepest point) measured against the face of the
other body nearest it; its row holds that face only. An element sliding along one face
toward another that rises ahead of it (into a concave corner), or pushed around a
corner, crosses the second face within a step while its row holds the first
(scenes/concave_polygons.toml: an arrow struck sideways slid 20 mm a step along a
star's face into the next, found 10.8 mm inside it; a vertex near the arrow's corner
held against one face sank 11.2 mm through the other). So for each pair with a
contact, a concave mesh and no circle, whose bodies move against each other by more
than the slop this step (|v_a - v_b| dt + (|w_a| R_a + |w_b| R_b) dt > slop), the
pair's query runs at the end poses as for sdf pairs, and an end contact is kept where
its element has no contact now along the same normal (to the bodies' turn in the step
plus ``NEW_FACE_ANGLE``): the face it will meet. Carried back and keyed as the sdf
pairs' rows. Convex pairs (boxes, convex polygons) are clipped as Box2D clips them and
get none. The sdf pairs' and the mesh pairs' end poses are one narrowphase query.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from ..sdf import safe_normalize
from ..settings import Settings
from ..shapes import Shape
from ..vec2 import rotate
from .contacts import Contacts
from .curvature import curvature_radii
from .shape_fields import ShapeFields, evaluate_by_shape

__all__ = ["FIELD_PAIR", "IMPLIED_COSINE", "IMPLIED_ROUND_OFF", "SOURCE_PREDICTED",
           "predicted_contacts", "predicted_pair_contacts", "predicted_pairs"]

#: Feature key source of predicted contacts (``narrowphase``'s key layout).
SOURCE_PREDICTED = 6
#: Key bit of an sdf pair's predicted contact; below it the end-pose contact's source
#: (3 bits from bit 52) and its element and start (under 2^52: triangle, edge and start
#: indices of any real mesh).
FIELD_PAIR = np.int64(1) << np.int64(55)
_LOW = (np.int64(1) << np.int64(52)) - np.int64(1)
#: Angle (rad), beyond the step's turn of the two bodies, by which a mesh pair's end
#: contact's normal must differ from its element's contact now to be on a new face (a
#: polygon's faces meet at tens of degrees; the same face turns with its body).
NEW_FACE_ANGLE = 0.05

#: Separations of a pair's contact and of its predicted contact along one normal that
#: differ by less than this (m) are equal: the two are computed by different paths
#: (a narrowphase, a field at the end pose), whose round-off differs by ~1e-16 m ...
IMPLIED_ROUND_OFF = 1e-9
#: ... and so are two unit normals whose cosine is at least this (``collide._implied``).
IMPLIED_COSINE = 1.0 - 1e-12


def _turns(angular_velocity: np.ndarray, radius: np.ndarray, dt: float,
           slop: float) -> np.ndarray:
    """Whether each body turns by more than ``slop`` (m) at its bounding ``radius`` (m)
    in ``dt`` (s) at ``angular_velocity`` (rad/s): |w| R dt > slop (an unbounded body
    turns if it spins at all)."""
    with np.errstate(invalid="ignore"):
        return np.abs(angular_velocity) * radius * dt > slop


def predicted_contacts(fields: ShapeFields, body_shape: np.ndarray, pairs: np.ndarray,
                       is_circle: np.ndarray, radius: np.ndarray, position: np.ndarray,
                       angle: np.ndarray, velocity: np.ndarray,
                       angular_velocity: np.ndarray, dt: float, slop: float,
                       margin: float, reach: np.ndarray, picked: bool = False) -> Contacts:
    """The predicted contacts (module docstring) of the candidate ``pairs`` (P, 2), i < j.

    fields: the distinct shapes' ``ShapeFields``, body_shape (B,) its rows; is_circle (B,)
    bool; radius (B,) m, bounding radii about the centres of mass (a circle's is its
    radius); position (B, 2) m, angle (B,) rad, velocity (B, 2) m/s, angular_velocity
    (B,) rad/s: the step's start values; dt s; slop m (``Settings.linear_slop``);
    margin m, the speculative distance, and reach (B,) m, the bodies' reach: a pair's
    margin is margin + reach_i + reach_j. Only the pairs of a circle and a body that is
    not one, the body turning or the circle moving against it by more than the slop
    (module docstring), get a row: ``predicted_pairs`` picks them, unless ``picked``
    (the caller's pairs are those already: ``circle_kernels.analytic_contacts``' pass).
    Returns body_a < body_b contacts, sorted by pair, at most one per pair.
    """
    if not picked:
        pairs = pairs[predicted_pairs(pairs, is_circle, radius, velocity, angular_velocity,
                                      dt, slop)]
    if len(pairs) == 0:
        return Contacts.empty()
    i, j = pairs[:, 0], pairs[:, 1]
    c, b = np.where(is_circle[i], i, j), np.where(is_circle[i], j, i)
    turning = _turns(angular_velocity[b], radius[b], dt, slop)
    pair_margin = margin + reach[i] + reach[j]
    turn = angular_velocity[b] * dt
    centre_end = position[c] + velocity[c] * dt
    body_end = position[b] + velocity[b] * dt
    local = rotate(centre_end - body_end, -(angle[b] + turn))
    d, g = evaluate_by_shape(fields, body_shape[b], local)
    out = rotate(safe_normalize(g), angle[b] + turn)                   # n', out of b
    surface_end = centre_end - d[:, None] * out                        # q'
    material = position[b] + rotate(surface_end - body_end, -turn)     # q0
    normal = -out                                                      # circle -> b
    arm = material - position[c]
    gap = normal[:, 0] * arm[:, 0] + normal[:, 1] * arm[:, 1] - radius[c]
    keep = (gap < pair_margin) & (turning | (gap > 0.0))
    gap = np.maximum(gap, 0.0)
    # The row's point: on b's material point q0 against a turning body; otherwise on
    # the line through the circle's centre along n, as every contact of a circle (its
    # normal impulse exerts no torque on it), midway across the gap.
    on_line = position[c] + (radius[c] + 0.5 * gap)[:, None] * normal
    point = np.where(turning[:, None], material - (0.5 * gap)[:, None] * normal,
                     on_line)
    flip = c > b                                    # rows are stored body_a < body_b
    normal = np.where(flip[:, None], -normal, normal)
    keep = np.flatnonzero(keep)
    return Contacts(np.minimum(c, b)[keep], np.maximum(c, b)[keep], point[keep],
                    normal[keep], -gap[keep],
                    np.full(len(keep), np.int64(SOURCE_PREDICTED) << np.int64(56)))


def predicted_pairs(pairs: np.ndarray, is_circle: np.ndarray, radius: np.ndarray,
                    velocity: np.ndarray, angular_velocity: np.ndarray, dt: float,
                    slop: float) -> np.ndarray:
    """The rows (M,) of the candidate ``pairs`` (P, 2) of a circle c and a body b that is
    not one, where b turns by more than ``slop`` at its bounding radius this step
    (``_turns``: |w_b| R_b dt > slop) or c moves against it by more than that
    (|v_c - v_b| dt > slop), in order (numpy; the closed-form contacts' kernel picks the
    same in its pass over the pairs)."""
    i, j = pairs[:, 0], pairs[:, 1]
    b = np.where(is_circle[i], j, i)
    c = i + j - b
    with np.errstate(invalid="ignore"):
        relative = velocity[c] - velocity[b]
        fast = (relative[:, 0] * relative[:, 0] + relative[:, 1] * relative[:, 1]) * dt * dt
    return np.flatnonzero((is_circle[i] != is_circle[j])
                          & (_turns(angular_velocity[b], radius[b], dt, slop)
                             | (fast > slop * slop)))


def predicted_pair_contacts(shapes: Sequence[Shape], fields: ShapeFields,
                            body_shape: np.ndarray, contacts: Contacts,
                            field_pairs: np.ndarray, mesh_pairs: np.ndarray,
                            radius: np.ndarray, position: np.ndarray, angle: np.ndarray,
                            velocity: np.ndarray, angular_velocity: np.ndarray,
                            reach: np.ndarray, settings: Settings) -> Contacts:
    """The predicted contacts of sdf-sdf ``field_pairs`` (P, 2) with a contact, where a
    body turns more than the slop at its bounding radius this step, at its corners
    (module docstring, "Sdf pairs"), and of ``mesh_pairs`` (Q, 2) with a concave mesh and
    a contact (``contacts``, sorted by pair) whose bodies move against each other by more
    than the slop this step, where an element meets a face its contact now is not on
    ("Mesh pairs"): both from one narrowphase query at the end poses (the two sets'
    shape pairs differ, so each pair's contacts are those of a query of its set alone).

    shapes, fields, body_shape, radius, position, angle, velocity, angular_velocity: as
    ``predicted_contacts``; reach (B,) m, the bodies' reach (the pairs keep their
    margins); settings: the world's. Returns body_a < body_b contacts, the sdf pairs'
    then the mesh pairs', each sorted by (pair, feature).
    """
    dt = float(settings.dt)
    turning = _turns(angular_velocity, radius, dt, float(settings.linear_slop))
    field_pairs = field_pairs[turning[field_pairs[:, 0]] | turning[field_pairs[:, 1]]]
    # |w| R, 0 for a body that does not turn (an unbounded one has R = inf).
    with np.errstate(invalid="ignore"):
        sweep = np.where(angular_velocity == 0.0, 0.0, np.abs(angular_velocity) * radius)
    relative = velocity[mesh_pairs[:, 0]] - velocity[mesh_pairs[:, 1]]
    travel = (np.sqrt(relative[:, 0] ** 2 + relative[:, 1] ** 2) + sweep[mesh_pairs[:, 0]]
              + sweep[mesh_pairs[:, 1]]) * dt
    mesh_pairs = mesh_pairs[travel > settings.linear_slop]
    c, end = _end_contacts(shapes, body_shape, np.concatenate([field_pairs, mesh_pairs]),
                           position, angle, velocity, angular_velocity, reach, settings)
    if len(c) == 0:
        return c
    n = np.int64(len(angle))
    of_field = np.isin(c.body_a * n + c.body_b, np.minimum(field_pairs[:, 0], field_pairs[:, 1])
                       * n + np.maximum(field_pairs[:, 0], field_pairs[:, 1]))
    return Contacts.concatenate([
        _field_corners(fields, body_shape, c.take(of_field), end, turning, position,
                       angular_velocity, dt),
        _new_faces(c.take(~of_field), contacts, end, position, angular_velocity, dt)])


def _field_corners(fields: ShapeFields, body_shape: np.ndarray, c: Contacts,
                   end: np.ndarray, turning: np.ndarray, position: np.ndarray,
                   angular_velocity: np.ndarray, dt: float) -> Contacts:
    """Of sdf pairs' end-pose contacts ``c``, those at a turning body's corner or flat (no
    centre of curvature there), carried back to the step's start."""
    if len(c) == 0:
        return c
    rho_a, rho_b = curvature_radii(fields, body_shape, end[:, :2], end[:, 2],
                                   np.ones(len(end), bool), c)
    corner = (turning[c.body_a] & (rho_a == 0.0)) | (turning[c.body_b] & (rho_b == 0.0))
    return _carried_back(c.take(corner), position, end, angular_velocity, dt)


def _new_faces(c: Contacts, contacts: Contacts, end: np.ndarray, position: np.ndarray,
               angular_velocity: np.ndarray, dt: float) -> Contacts:
    """Of mesh pairs' end-pose contacts ``c``, those whose element (feature key) has no
    contact now (``contacts``, sorted by pair) along its normal, up to the bodies' turn in
    the step, carried back to the step's start."""
    if len(c) == 0:
        return c
    owner, row = contacts.pair_rows(c, np.int64(len(end)))
    turn = (np.abs(angular_velocity[c.body_a]) + np.abs(angular_velocity[c.body_b])) * dt
    aligned = ((contacts.feature[row] == c.feature[owner])
               & (np.einsum("ij,ij->i", contacts.normal[row], c.normal[owner])
                  >= np.cos(turn[owner] + NEW_FACE_ANGLE)))
    seen = np.zeros(len(c), bool)
    np.logical_or.at(seen, owner, aligned)
    return _carried_back(c.take(~seen), position, end, angular_velocity, dt)


def _end_contacts(shapes: Sequence[Shape], body_shape: np.ndarray, pairs: np.ndarray,
                  position: np.ndarray, angle: np.ndarray, velocity: np.ndarray,
                  angular_velocity: np.ndarray, reach: np.ndarray,
                  settings: Settings) -> tuple[Contacts, np.ndarray]:
    """The pairs' (P, 2) contacts at their end poses (x + v dt, angle + w dt, no tangent
    samples), and those poses (B, 3)."""
    from . import _narrowphase

    dt = float(settings.dt)
    end = np.column_stack([position + velocity * dt, angle + angular_velocity * dt])
    if len(pairs) == 0:
        return Contacts.empty(), end
    return _narrowphase(shapes, body_shape, pairs, end, settings.speculative_distance,
                        reach, _without_tangent_samples(settings)), end


@functools.lru_cache(maxsize=4)
def _without_tangent_samples(settings: Settings) -> Settings:
    """``settings`` with no tangent samples (end-pose queries), made once per Settings."""
    return settings.with_values(field_tangent_samples=0)


def _carried_back(c: Contacts, position: np.ndarray, end: np.ndarray,
                  angular_velocity: np.ndarray, dt: float) -> Contacts:
    """End-pose contacts ``c`` carried back to the step's start with their bodies: rows
    on the two surface points' start positions, along the end normals (module
    docstring, "Sdf pairs")."""
    a, b = c.body_a, c.body_b
    s_end = -c.depth
    m_a = c.point - (0.5 * s_end)[:, None] * c.normal
    m_b = c.point + (0.5 * s_end)[:, None] * c.normal
    back_a = position[a] + rotate(m_a - end[a, :2], -angular_velocity[a] * dt)
    back_b = position[b] + rotate(m_b - end[b, :2], -angular_velocity[b] * dt)
    arm = back_b - back_a
    gap = np.maximum(c.normal[:, 0] * arm[:, 0] + c.normal[:, 1] * arm[:, 1], 0.0)
    source = c.feature >> np.int64(56)
    return Contacts(a, b, 0.5 * (back_a + back_b), c.normal, -gap,
                    (np.int64(SOURCE_PREDICTED) << np.int64(56)) | FIELD_PAIR
                    | (source << np.int64(52)) | (c.feature & _LOW))
