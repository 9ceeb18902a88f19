"""The sdf body's points inside a mesh: the reverse direction of mesh-sdf pairs, n pairs at once.

``mesh_contacts.mesh_in_field`` finds the mesh's points inside the sdf body: exact
for a mesh vertex or edge pressing on the sdf, but where a corner (any sharp
feature) of the sdf body presses into a flat face of the mesh it only sees the
face's points inside the corner's wedge, whose depth -f_sdf underestimates the
corner's depth (by 1 - cos 45 deg = 29 % for a square corner pressed straight in)
and whose normal follows the corner's side. ``sdf_in_mesh`` finds the sdf body's
points deepest in the mesh instead, for all n pairs of a group:

1. ``field_pairs.field_field_contacts`` on the sdf's field and the mesh's exact polygon
   field (``mesh.field``), solved in the sdf's frame (so an unbounded sdf, a
   half-plane ground, works: the overlap region is bounded by the mesh), over the
   overlap of the two bounds grown by the margin, as ``narrowphase.collide_sdfs``.
   Its points are where the two bodies overlap (flat patches: the patch's two ends);
   its normal, where f_mesh = f_sdf, averages the two gradients, which is wrong for
   a corner pressing into a face, so only its points are kept.
2. ``_deepest_on_sdf``: from each point, a descent of f_mesh over the sdf body's
   boundary (a support search along the mesh face's inward normal): the point is
   projected onto the sdf's surface (z = w - f_sdf(w) grad f_sdf(w), exact in one
   step for an exact field, whose gradient at w is the surface normal at z), then
   moved along the surface's tangent toward -n, n = grad f_mesh(z) the normal of the
   mesh face z is under, and projected back. Past a convex corner of the sdf the
   projection snaps to the corner, so a corner is reached exactly. Depth -f_mesh
   and normal grad f_mesh are those of the final sdf point z: exact for an sdf
   corner or face pressing on a mesh face.
3. ``_far_ends``: the other end of the sdf face leaving z toward the mesh face (the
   incident face, as Box2D's manifolds): a box resting slightly tilted has its
   deeper corner as the only minimum, yet its other bottom corner is a contact too.
   A rounded end (a rounded box, a smooth blend) has no corner: there the end of
   the face's flat part is taken, to 1/16 of the last ladder gap.
   It is measured against the plane of z's mesh face (depth exact), and kept when
   its foot lies on the same mesh outline edge and it is within the margin.

Results: normal n = grad f_mesh(z), unit, outward of the mesh, i.e. from the mesh
toward the sdf body; depth = -f_mesh(z) (> 0 overlapping; a separated pair within
the margin gives -gap); point = z + depth / 2 n, midway between the sdf's point z
and the mesh face above it (z - f_mesh(z) n); the mesh outline edge nearest that
face point and the start id (+ ``FAR_END`` for a far end), for the feature key
(``narrowphase``: source 4).

Where a vertex of the mesh presses into the sdf's face instead, the descent ends
on the mesh's medial axis (the sdf face's point deepest in the mesh's corner
wedge): depth underestimated, normal a mesh side's, whichever side the search
ended on. The forward direction reports that vertex, with the sdf's normal, and
for an exact field deeper within less than its depth, which would shadow this
point in the reduction (``reduce``). Where the sdf's field is a bound (|grad f| < 1:
a smooth union, a grid baked from one), the forward depth -f is short and this
point can be the deeper one: the pair's only contact, with a side's normal that
flips between the corner's two sides from step to step (a box spins up and sinks
into a baked terrain). So such a point (``_on_medial_axis``: equally near two
adjacent outline edges at a convex vertex that lies below the sdf's tangent there)
is dropped, and the vertex's own contact holds the corner.

Cost: one ``field_field_contacts`` call (each of its rounds one evaluation of each
field for all pairs), then ``1 + REFINE_ROUNDS`` evaluations of the mesh field and
``SDF_CALLS`` of the sdf field for all contacts of all pairs; nothing is per pair or
per contact in Python. When both fields compile (``sdf.compiled``), stages 2 and 3
run in one compiled kernel (``_mesh_sdf_kernels._support``: the same batches, the
programs evaluated inside it; one call per shape pair of the batched ``sdf_in_meshes``);
otherwise in numpy
(``_support_numpy``, with ``_deepest_on_sdf``, ``_far_ends`` and ``_nearest_edges``:
the reference the kernel is tested against,
bit for bit, with a field that does not compile: tests/oracles.py).
"""

from __future__ import annotations

import numpy as np

from ..sdf import Field, compiled, safe_normalize
from ..settings import Settings
from ..shapes import Shape
from ..vec2 import rotate_cs
from . import field_pairs
from ._mesh_sdf_kernels import (
    _ANCHOR,
    _FACE_NORMAL,
    _FACING,
    _FALL,
    _FINE,
    _LADDER,
    _MEDIAL,
    _MIN_FLAT,
    _MIN_STEP,
    _ON_LINE,
    _PARALLEL,
    _PROBE,
    _RUNGS,
    _SHRINK,
    _SMOOTH,
    FAR_END,
    REFINE_ROUNDS,
    _support,
)
from ._runs import run_starts
from .shape_fields import ShapeFields, pair_fields

__all__ = ["FAR_END", "REFINE_ROUNDS", "SDF_CALLS", "sdf_in_mesh", "sdf_in_meshes"]

#: Evaluations of the sdf field after the field-field descent: the projection of
#: the starts, one per support-search round, the far ends' probes, anchors and two
#: ladders.
SDF_CALLS = REFINE_ROUNDS + 5


class _MeshInSdfFrame:
    """The mesh's field seen from the sdf's frame, for P placements (one call per batch).

    Pair k places the mesh by angle[k] and offset[k] (2,): p_sdf = R p_mesh + offset.
    """

    def __init__(self, field: Field, angle: np.ndarray, offset: np.ndarray):
        self.field = field
        self.cos, self.sin, self.offset = np.cos(angle), np.sin(angle), offset

    def to_mesh(self, points: np.ndarray, pair: np.ndarray) -> np.ndarray:
        """Points (N, 2) of the sdf's frame into the mesh's frame of pairs (N,)."""
        return rotate_cs(points - self.offset[pair], self.cos[pair], -self.sin[pair])

    def evaluate(self, points: np.ndarray, pair: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """f_mesh (N,) and its unit gradient (N, 2) (sdf frame) at points (N, 2), pairs (N,)."""
        f, g = compiled.evaluate(self.field, self.to_mesh(points, pair))
        return f, rotate_cs(safe_normalize(g), self.cos[pair], self.sin[pair])


def _project(sdf: Field, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points w (N, 2) onto the sdf's surface: z = w - f(w) g(w), and the unit normal g.

    Exact for an exact field (its gradient at w is the normal at w's closest surface
    point); for a bound, one Newton step toward the surface.
    """
    f, g = compiled.evaluate(sdf, w)
    g = safe_normalize(g)
    return w - f[:, None] * g, g


def _deepest_on_sdf(sdf: Field, mesh: _MeshInSdfFrame, pair: np.ndarray, start: np.ndarray,
                    step: np.ndarray, min_step: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Local minimum of f_mesh over the sdf's surface from K starts (sdf frame).

    pair: (K,) pair of each start; start: (K, 2) points near the sdf's surface;
    step: (K,) initial step scale (m); min_step: (K,) m, the search of a contact
    ends when its step scale falls below it. Returns (z (K, 2) on the sdf's
    surface, f_mesh(z) (K,), n = unit grad f_mesh(z) (K, 2), g = the sdf's unit
    normal at z (K, 2)).

    Each round, for every running contact at z (sdf normal g): the direction
    t = -n + (n.g) g (the tangent of the sdf's surface along which the mesh's
    linearisation decreases; |t| <= ``_PARALLEL``: the surface is parallel to the
    face, done), the ladder z + step * ``_LADDER`` t projected onto the surface
    (one sdf evaluation), f_mesh there (one mesh evaluation). Only the first valley
    of the ladder counts (rungs while f_mesh keeps falling), so a start stays in
    its own basin; its deepest rung is accepted and the scale becomes that rung's
    step (times 4 when it is the last rung); a round without decrease divides the
    scale by ``_SHRINK``. f_mesh never increases.
    """
    z, g = _project(sdf, start)
    phi, n = mesh.evaluate(z, pair)
    step = step.copy()
    active = np.ones(len(z), bool)
    rungs = len(_LADDER)
    for _ in range(REFINE_ROUNDS):
        rows = np.flatnonzero(active)
        t = -n[rows] + np.einsum("kd,kd->k", n[rows], g[rows])[:, None] * g[rows]
        length = np.hypot(t[:, 0], t[:, 1])
        moving = length > _PARALLEL
        active[rows[~moving]] = False
        rows, t = rows[moving], t[moving] / length[moving, None]
        if len(rows) == 0:
            break
        w = z[rows, None, :] + (step[rows, None] * _LADDER)[:, :, None] * t[:, None, :]
        zc, gc = _project(sdf, w.reshape(-1, 2))
        fc, nc = mesh.evaluate(zc, np.repeat(pair[rows], rungs))
        fc = fc.reshape(-1, rungs)
        before = np.column_stack([phi[rows], fc[:, :-1]])
        tol = _FALL * np.maximum(1.0, np.abs(before))
        falling = np.cumprod(fc < before - tol, axis=1).astype(bool)
        count = falling.sum(axis=1)
        better = count > 0
        best = np.maximum(count - 1, 0)
        flat = np.arange(len(rows)) * rungs + best
        won = rows[better]
        z[won], g[won] = zc[flat[better]], gc[flat[better]]
        phi[won], n[won] = fc[better, best[better]], nc[flat[better]]
        grow = np.where(best == rungs - 1, 4.0, 1.0)
        step[won] = (step[rows] * _LADDER[best] * grow)[better]
        lost = rows[~better]
        step[lost] /= _SHRINK
        active[lost] = step[lost] >= min_step[lost]
    return z, phi, n, g


def _far_ends(sdf: Field, z: np.ndarray, n: np.ndarray, diagonal: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """The other end of the sdf's face through each deepest point (Box2D's incident face).

    z: (K, 2) the sdf's deepest points (sdf frame), n: (K, 2) the mesh face normals
    there, diagonal: (K,) m, the pair's overlap diagonal. A box resting slightly
    tilted on a face has its deeper corner as the only local minimum of f_mesh (and
    of the field-field descent: it reports the deepest end of a tilted patch); its
    other bottom corner is a contact too (Box2D keeps both ends of the incident face
    and measures them against the reference face).

    Two probes z +- h t (t = perp(n), h = ``_PROBE`` diagonal) projected onto the
    sdf's surface give the normals g of the faces leaving z either way; the incident
    face is the one whose g is most anti-parallel to n, used when (-n).g >=
    ``_FACING``; where the two normals agree (``_SMOOTH``: z is no corner), the side
    toward the body's centre (the sdf frame's origin). Along its direction u (perp(g),
    away from z), the ladder z + L_k u (``_RUNGS`` rungs up to the diagonal) is
    projected onto the surface in one
    evaluation: rungs on the face stay where they are; the first rung past the
    face's end projects, for an exact field and a convex corner, exactly onto that
    corner, which is accepted when it lies on the face's line beyond the last rung
    still on the face. A rounded end (the face runs into a curve: a rounded box, a
    smooth blend) projects off the line instead; then a second ladder of ``_FINE``
    rungs, evenly spaced between the last rung on the face and the first off it,
    finds the flat part's end to within 1/``_FINE`` of that gap (the end is the last
    of them still on the face, so a point of the surface), reported when the flat
    part is longer than ``_MIN_FLAT`` diagonals (a curved surface with no flat part
    stays on its tangent line for a few 1e-5 diagonals only): a rounded box landing
    nearly flat has its far end as a contact. Returns (found (K,) bool, end (K, 2)
    sdf frame). A curved surface gives no end. Three evaluations of the sdf field for
    all K (four at a smooth z).
    """
    k = len(z)
    tangent = np.column_stack([-n[:, 1], n[:, 0]])
    h = (_PROBE * diagonal)[:, None]
    _, g = _project(sdf, np.concatenate([z + h * tangent, z - h * tangent]))
    facing = -np.einsum("kd,kd->k", g, np.concatenate([n, n])).reshape(2, k)
    side = np.argmax(facing, axis=0)                                     # 0: +t, 1: -t
    pair_g = g.reshape(2, k, 2)
    smooth = np.einsum("kd,kd->k", pair_g[0], pair_g[1]) >= 1.0 - _SMOOTH
    centre_side = np.where(np.einsum("kd,kd->k", z, tangent) < 0.0, 0, 1)
    side = np.where(smooth, centre_side, side)
    rows = np.arange(k)
    g = g.reshape(2, k, 2)[side, rows]
    sign = np.where(side == 0, 1.0, -1.0)
    u = np.column_stack([-g[:, 1], g[:, 0]])
    u *= np.where(np.einsum("kd,kd->k", u, tangent) * sign >= 0.0, 1.0, -1.0)[:, None]
    facing = facing[side, rows]
    # At a smooth point the face's line is not z's tangent (z lies on the rounding):
    # the ladders start from the surface point _ANCHOR diagonals toward the centre.
    anchor, g_anchor = _project(sdf, z + (_ANCHOR * diagonal)[:, None] * u)
    u_anchor = np.column_stack([-g_anchor[:, 1], g_anchor[:, 0]])
    u_anchor *= np.where(np.einsum("kd,kd->k", u_anchor, u) >= 0.0, 1.0, -1.0)[:, None]
    origin = np.where(smooth[:, None], anchor, z)
    g = np.where(smooth[:, None], g_anchor, g)
    u = np.where(smooth[:, None], u_anchor, u)
    facing = np.where(smooth, -np.einsum("kd,kd->k", g_anchor, n), facing)
    length = diagonal[:, None] * 2.0 ** (np.arange(_RUNGS) - _RUNGS + 1)   # (K, R)
    rung = origin[:, None, :] + length[:, :, None] * u[:, None, :]
    projected = _project(sdf, rung.reshape(-1, 2))[0].reshape(k, _RUNGS, 2)
    tol = (_ON_LINE * diagonal)[:, None]
    on_face = np.linalg.norm(projected - rung, axis=2) <= tol
    first_off = np.argmin(np.cumprod(on_face, axis=1), axis=1)         # first rung off it
    reached = np.where(first_off > 0, length[rows, np.maximum(first_off - 1, 0)], 0.0)
    end = projected[rows, first_off]
    along = np.einsum("kd,kd->k", end - origin, u)
    off_line = np.abs(np.einsum("kd,kd->k", end - origin, g))
    found = ((facing >= _FACING) & ~on_face[rows, first_off]
             & (off_line <= tol[:, 0]) & (along > reached) & (along <= length[rows, first_off]))
    # Rounded ends: the flat part's end between the last rung on the face and the first off.
    gap = length[rows, first_off] - reached
    fine = reached[:, None] + gap[:, None] * (np.arange(1, _FINE) / _FINE)[None, :]
    rung = origin[:, None, :] + fine[:, :, None] * u[:, None, :]
    projected = _project(sdf, rung.reshape(-1, 2))[0].reshape(k, _FINE - 1, 2)
    on_fine = np.linalg.norm(projected - rung, axis=2) <= tol
    count = np.sum(np.cumprod(on_fine, axis=1), axis=1)
    flat = np.where(count > 0, fine[rows, np.maximum(count - 1, 0)], reached)
    rounded = ((facing >= _FACING) & ~found & (first_off > 0)
               & ~on_face[rows, first_off] & (flat > _MIN_FLAT * diagonal))
    end = np.where(rounded[:, None], origin + flat[:, None] * u, end)
    return found | rounded, end


def _nearest_edges(vertices: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Index (K,) of the outline edge (i: vertex i to i + 1 mod M) nearest each point.

    vertices: (M, 2) the mesh's outline; points: (K, 2) in the mesh's frame. Ties
    (a point equally near two edges, at their shared vertex) go to the lower index.
    """
    a = vertices[None, :, :]
    e = np.roll(vertices, -1, axis=0)[None, :, :] - a                    # (1, M, 2)
    rel = points[:, None, :] - a                                          # (K, M, 2)
    t = np.clip(np.sum(rel * e, axis=2) / np.sum(e * e, axis=2), 0.0, 1.0)
    gap = rel - t[:, :, None] * e
    return np.argmin(np.sum(gap * gap, axis=2), axis=1)


def _on_medial_axis(vertices: np.ndarray, z: np.ndarray, depth: np.ndarray, g: np.ndarray
                    ) -> np.ndarray:
    """True (K,) where the sdf's deepest point z lies on the mesh's medial axis at a corner.

    vertices: (M, 2) the mesh's outline (counter-clockwise); z: (K, 2) the sdf's
    points in the mesh's frame, depth: (K,) m, -f_mesh(z) (> 0 inside the mesh);
    g: (K, 2) the sdf's unit outward normal at z, in the mesh's frame. True where z is
    inside the mesh, its two nearest outline edges are adjacent at a convex vertex v
    and equally near (within ``_MEDIAL`` of the depth: the support search converges
    onto the kink of f_mesh from one side), and v lies below the sdf's tangent at z
    by at least z's depth ((z - v).g >= depth): a mesh corner pressing into the sdf's
    face. Such a point's normal is one of the corner's sides', whichever the search
    ended on, and the forward view reports the vertex itself with the sdf's normal.
    """
    m = len(vertices)
    a = vertices[None, :, :]
    e = np.roll(vertices, -1, axis=0)[None, :, :] - a                    # (1, M, 2)
    rel = z[:, None, :] - a                                               # (K, M, 2)
    t = np.clip(np.sum(rel * e, axis=2) / np.sum(e * e, axis=2), 0.0, 1.0)
    gap = rel - t[:, :, None] * e
    distance = np.sqrt(np.sum(gap * gap, axis=2))                        # (K, M)
    rows = np.arange(len(z))
    first = np.argmin(distance, axis=1)
    d1 = distance[rows, first]
    distance[rows, first] = np.inf
    second = np.argmin(distance, axis=1)
    d2 = distance[rows, second]
    vertex = np.where(second == (first + 1) % m, second, first)          # the shared one
    adjacent = (second == (first + 1) % m) | (first == (second + 1) % m)
    before, after = vertices[(vertex - 1) % m], vertices[(vertex + 1) % m]
    v = vertices[vertex]
    turn = ((v[:, 0] - before[:, 0]) * (after[:, 1] - v[:, 1])
            - (v[:, 1] - before[:, 1]) * (after[:, 0] - v[:, 0]))
    below = np.einsum("kd,kd->k", z - v, g)
    return ((depth > 0.0) & adjacent & (turn > 0.0) & (d2 - d1 <= _MEDIAL * depth)
            & (below >= depth))


def sdf_in_mesh(mesh: Shape, sdf: Shape, pose_mesh: np.ndarray, pose_sdf: np.ndarray,
                margin: float, settings: Settings
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                           np.ndarray]:
    """Contacts of the sdf body's points inside ``mesh`` for n pairs (see the module doc).

    pose_mesh, pose_sdf: (n, 3) centre-of-mass poses (x, y, angle), world (m, rad).
    margin: m, contacts with depth > -margin are returned. The search runs over the
    overlap of the two bounds in the SDF's body frame, grown by the margin
    (``_placed_fields.overlap_regions``). Field-field starts and
    iterations: ``settings.field_descent_starts`` / ``field_descent_iterations``.
    Returns pair index (C,), midway point (C, 2) world, normal (C, 2) world (unit,
    outward of the mesh: from the mesh toward the sdf body), depth (C,) m, the mesh
    outline edge pressed on (C,) and the field-field start id (C,) (< 3
    ``field_descent_starts``; + ``FAR_END`` for the far end of its incident face),
    pair by pair.
    """
    fields = pair_fields(mesh, sdf)
    if fields.program[0] >= 0 and fields.program[1] >= 0:
        n = len(pose_mesh)
        zero = np.zeros(n, np.int64)
        return sdf_in_meshes(fields, zero, zero + 1, pose_mesh, pose_sdf, np.full(n, margin),
                             zero, settings)
    angle = pose_mesh[:, 2] - pose_sdf[:, 2]
    co, so = np.cos(pose_sdf[:, 2]), np.sin(pose_sdf[:, 2])
    offset = rotate_cs(pose_mesh[:, :2] - pose_sdf[:, :2], co, -so)      # mesh in sdf frame
    region, pair, point, depth, _, start = field_pairs.placed_field_contacts(
        sdf.field, mesh.field, offset, angle, sdf.bounds(), mesh.bounds(), margin,
        settings.field_descent_starts, settings.field_descent_iterations)
    if len(pair) == 0:
        return _no_contacts()
    return _support_numpy(mesh, sdf, pose_sdf, angle, offset, co, so, region, margin, pair,
                          point, depth, start)


def sdf_in_meshes(fields: ShapeFields, mesh_of: np.ndarray, sdf_of: np.ndarray,
                  pose_mesh: np.ndarray, pose_sdf: np.ndarray, margin: np.ndarray,
                  run: np.ndarray, settings: Settings
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                             np.ndarray]:
    """``sdf_in_mesh`` of n pairs of any meshes and sdf shapes whose fields compile: pair
    k's mesh is shape mesh_of[k], its sdf shape sdf_of[k] (n,) of ``fields``, its margin
    margin[k] (n,) m, its run run[k] (n,) (the pairs of one shape pair: consecutive, one
    run id, one margin). The field-field contacts of all pairs in one pass
    (``field_pairs.placed_contacts``), then the support search and the far ends a
    ``_mesh_sdf_kernels._support`` call per run (a kernel looping over the runs compiled
    seconds longer at a cold start): the same contacts, to the bit, as an
    ``sdf_in_mesh`` call per shape pair. Returns its six arrays, pairs into the n."""
    angle = pose_mesh[:, 2] - pose_sdf[:, 2]
    co, so = np.cos(pose_sdf[:, 2]), np.sin(pose_sdf[:, 2])
    offset = rotate_cs(pose_mesh[:, :2] - pose_sdf[:, :2], co, -so)      # mesh in sdf frame
    programs = field_pairs.PairPrograms(fields.table, fields.program[sdf_of],
                                        fields.program[mesh_of], run)
    region, pair, point, depth, _, start = field_pairs.placed_contacts(
        programs, offset, angle, fields.bounds[sdf_of], fields.bounds[mesh_of], margin,
        settings.field_descent_starts, settings.field_descent_iterations)
    if len(pair) == 0:
        return _no_contacts()
    t = fields.table
    cos, sin = np.cos(angle), np.sin(angle)
    offset = np.ascontiguousarray(offset)
    pose_sdf = np.ascontiguousarray(pose_sdf, dtype=np.float64)
    bounds = run_starts(run)
    at = np.searchsorted(pair, bounds).tolist()       # each run's contacts (in pair order)
    parts = []
    for r, (lo, hi) in enumerate(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True)):
        c0, c1 = at[r], at[r + 1]
        if c0 == c1:
            continue
        s, a, b = mesh_of[lo], programs.prog_a[lo], programs.prog_b[lo]
        got = _support(t.code[t.start[a]:t.start[a + 1]], t.consts, t.depth, t.nesting,
                       t.code[t.start[b]:t.start[b + 1]], t.consts, t.depth, t.nesting,
                       fields.vertices[fields.vertex_start[s]:fields.vertex_start[s + 1]],
                       cos[lo:hi], sin[lo:hi], offset[lo:hi], co[lo:hi], so[lo:hi],
                       pose_sdf[lo:hi], region[lo:hi], float(margin[lo]), pair[c0:c1] - lo,
                       point[c0:c1], depth[c0:c1], start[c0:c1])
        parts.append((got[0] + lo, *got[1:]))
    if not parts:
        return _no_contacts()
    return tuple(np.concatenate(column) for column in zip(*parts, strict=True))


def _no_contacts() -> tuple[np.ndarray, ...]:
    """``sdf_in_mesh``'s six arrays, empty."""
    none = np.zeros(0, np.int64)
    return none, np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), none.copy(), none.copy()


def _support_numpy(mesh: Shape, sdf: Shape, pose_sdf: np.ndarray, angle: np.ndarray,
                   offset: np.ndarray, co: np.ndarray, so: np.ndarray, region: np.ndarray,
                   margin: float, pair: np.ndarray, point: np.ndarray, depth: np.ndarray,
                   start: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                              np.ndarray]:
    """Stages 2 and 3 of ``sdf_in_mesh`` in numpy from the field-field contacts (pair,
    point, depth, start), for fields that do not compile; the reference of the
    compiled ``_support`` (same results, bit for bit). angle (n,): the mesh's angle
    in the sdf's frame, offset (n, 2) its position there; co, so (n,): cos and sin
    of the sdf's angle."""
    in_sdf = _MeshInSdfFrame(mesh.field, angle, offset)
    extent = region[pair, 2:] - region[pair, :2]
    diagonal = np.hypot(extent[:, 0], extent[:, 1])
    z, phi, n, g = _deepest_on_sdf(sdf.field, in_sdf, pair, point,
                                   np.abs(depth) + 1e-3 * diagonal, _MIN_STEP * diagonal)
    depth = -phi
    medial = _on_medial_axis(mesh.vertices, in_sdf.to_mesh(z, pair), depth,
                             in_sdf.to_mesh(g + in_sdf.offset[pair], pair))   # rotation only
    keep = (depth > -margin) & ~medial
    pair, z, depth, n, start = pair[keep], z[keep], depth[keep], n[keep], start[keep]
    face = in_sdf.to_mesh(z + depth[:, None] * n, pair)                  # mesh surface point
    edge = _nearest_edges(mesh.vertices, face)

    # The incident face's far end, measured against the same mesh face (its plane
    # through the deepest point's face point, normal n), kept when n is that outline
    # edge's normal (not a vertex's: a point outside the mesh near its corner), the
    # far end's foot lies on the edge, it is within the margin and no deeper than the
    # deepest point (deeper: the descent stopped on the mesh's medial axis, the sdf
    # body pierces the mesh and the face runs on through it).
    found, end = _far_ends(sdf.field, z, n, diagonal[keep])
    end_depth = depth + np.einsum("kd,kd->k", z - end, n)
    foot = in_sdf.to_mesh(end + end_depth[:, None] * n, pair)
    v0 = mesh.vertices[edge]
    e = mesh.vertices[(edge + 1) % len(mesh.vertices)] - v0
    e_length2 = np.einsum("kd,kd->k", e, e)
    t = np.einsum("kd,kd->k", foot - v0, e) / e_length2
    n_mesh = in_sdf.to_mesh(n + in_sdf.offset[pair], pair)               # rotation only
    face_normal = np.abs(np.einsum("kd,kd->k", n_mesh, e)) <= _FACE_NORMAL * np.sqrt(e_length2)
    far = (found & face_normal & (t >= -_ON_LINE) & (t <= 1.0 + _ON_LINE)
           & (end_depth > -margin) & (end_depth <= depth + _ON_LINE * diagonal[keep]))
    pair = np.concatenate([pair, pair[far]])
    z = np.concatenate([z, end[far]])
    depth = np.concatenate([depth, end_depth[far]])
    n = np.concatenate([n, n[far]])
    edge = np.concatenate([edge, edge[far]])
    start = np.concatenate([start, start[far] + FAR_END])
    order = np.argsort(pair, kind="stable")
    pair, z, depth, n, edge, start = (pair[order], z[order], depth[order], n[order],
                                      edge[order], start[order])
    mid = z + (0.5 * depth)[:, None] * n
    co, so = co[pair], so[pair]
    world_mid = rotate_cs(mid, co, so) + pose_sdf[pair, :2]
    return pair, world_mid, rotate_cs(n, co, so), depth, edge, start
