"""A mesh's points in a field for a pair group, in one compiled call.

``mesh_contacts.mesh_in_field`` runs, per group of pairs sharing a mesh and a field:
the mesh placed in the field's frame and its triangles culled (``_place``), the
descent minima of the kept triangles (``descent.triangle_deepest``: starts, then
``_compiled_descent.descend``), the merge of minima that met
(``descent.merge_minima``) and the stages after them (``_finish``). Driven from Python
the glue between those kernels cost about as much as the kernels for the few pairs
of a showcase group; :func:`triangle_contacts` runs the same kernels on the same
arguments in one call, so the contacts are the same bits.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit
from ._compiled_descent import descend, merge_minima
from ._descent_paths import N_FLAGS, N_STATE
from ._descent_starts import triangle_starts
from .mesh_contacts import _finish, _place

__all__ = ["triangle_contacts"]


@njit(cache=True, error_model="numpy")
def triangle_contacts(kind: int, barzilai_borwein: bool, kd: int, mesh_vertices: np.ndarray,
                      triangles: np.ndarray, outline_edges: np.ndarray, cos: np.ndarray,
                      sin: np.ndarray, co: np.ndarray, so: np.ndarray, pose_mesh: np.ndarray,
                      pose_other: np.ndarray, code: np.ndarray, consts: np.ndarray, depth: int,
                      nesting: int, margin: float, weights: np.ndarray, start_ids: np.ndarray,
                      spanning: bool, convex: bool, iterations: int, tol: float,
                      shape_tol: float, merge_radius: float, polygon_pair: bool, slop: float,
                      no_rotation: np.ndarray, no_offset: np.ndarray, cand: np.ndarray,
                      cand_i: np.ndarray, candidates: np.ndarray):
    """``mesh_in_field``'s compiled path for n pairs (its docstring), descent starts
    at ``weights`` (K, 3) with ids ``start_ids`` (K,).

    kind, barzilai_borwein, kd: ``TRIANGLE``, False, 2 (``descend``'s arguments).
    mesh_vertices (V, 2), triangles (T, 3), outline_edges (T, 3): the mesh; cos,
    sin (n,): of its angle relative to the other body, co, so (n,): of the other's
    angle (numpy's); pose_mesh, pose_other (n, 3); code, consts, depth, nesting:
    the other field's program; margin: m. spanning, convex: the triangle problem's
    (``descent._TriangleProblem``); iterations, tol (m): the descent's; shape_tol:
    ``descent.SHAPE_TOL``; merge_radius: ``mesh_contacts._MERGE_RADIUS``;
    polygon_pair, slop: ``_finish``'s. no_rotation (1, 2, 2), no_offset (1, 2):
    placeholders of a triangle problem. cand, cand_i, candidates: the descent's
    round buffers (returned, possibly grown).

    Returns ``_finish``'s six arrays, then the three buffers.
    """
    vertices, _, kept, tri = _place(mesh_vertices, triangles, cos, sin, co, so, pose_mesh,
                                    pose_other, code, consts, depth, nesting, margin)
    n_tri, n_start = tri.shape[0], weights.shape[0]
    if n_tri == 0:
        point, value = np.zeros((0, n_start, 2)), np.zeros((0, n_start))
    else:
        points, owner, sigma, at_vertex = triangle_starts(tri, weights)
        n_points = points.shape[0]
        state = np.empty((n_points, N_STATE))
        flags = np.empty((n_points, N_FLAGS), dtype=np.int64)
        running = np.empty(n_points, dtype=np.int64)
        best, phi, _, _, _, cand, cand_i, candidates = descend(
            kind, barzilai_borwein, kd, code, consts, depth, nesting, code, consts, depth,
            nesting, no_rotation, no_offset, owner, tri, owner, at_vertex, n_start, spanning,
            convex, points, sigma, iterations, np.full(n_points, tol), shape_tol, state,
            flags, running, cand, cand_i, candidates)
        point, value = best.reshape(n_tri, n_start, 2), phi.reshape(n_tri, n_start)
    distinct = merge_minima(point, merge_radius)
    pair, mid, normal, depth_out, element, start = _finish(
        triangles, outline_edges, vertices, kept, point, value, distinct, start_ids, code,
        consts, depth, nesting, margin, polygon_pair, slop, co, so, pose_other)
    return pair, mid, normal, depth_out, element, start, cand, cand_i, candidates
