"""Per shape, what the batched pair functions read: fields' programs and mesh outlines in tables.

A batched pair function (``narrowphase.BATCH_FUNCTIONS``) takes all of a query's pairs of
one kind pair, whatever their shapes, in one pass of kernel calls: each pair names its
shapes by index into a ``ShapeFields``, built once per list of distinct shapes (the
world's, ``collide._ShapeTables.fields``). The fields' programs are one
``ProgramTable`` (``sdf.program_table``); the meshes' outlines, triangles and outline
edges are concatenated, each shape's rows from its start to the next's (none for a
shape that is not a mesh).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..sdf import compiled
from ..sdf.operators import Scale, Transform
from ..sdf.polygonal import HalfPlane
from ..sdf.program_table import ProgramTable, evaluate_runs, program_table
from ..shapes import Shape
from .descent import field_convex

__all__ = ["ShapeFields", "evaluate_by_shape", "flat_field", "pair_fields"]


def flat_field(shape: Shape) -> bool:
    """True when the shape's solid is a half-plane (through rigid motions and scaling).

    A half-plane has no corner and no bulge that could press into a mesh face: the
    mesh's vertices in it are the exact deepest points, so the reverse view of a
    mesh-sdf pair adds nothing and is skipped (the ground of most scenes).
    """
    field = shape.field
    while isinstance(field, (Transform, Scale)):
        field = field.of
    return isinstance(field, HalfPlane)


@dataclass(frozen=True)
class ShapeFields:
    """Per distinct shape (S,): ``table``, the ``ProgramTable`` of the shapes' fields that
    compile (None if none does); ``program`` (S,) int64, each shape's program in it (-1:
    its field does not compile, ``sdf.compiled.compile_field``); ``bounds`` (S, 4)
    body-frame AABBs; ``radius`` (S,) bounding radii (m, inf if unbounded); ``flat``
    (S,) bool (``flat_field``); ``convex`` (S,) bool, the field convex by construction
    (``descent.field_convex``); ``sdf`` (S,) bool, the sdf shapes. Meshes: ``vertices``
    (V, 2) their counter-clockwise outlines (body frame, m), shape s's rows
    ``vertex_start[s]:vertex_start[s + 1]`` (S + 1,); ``triangles`` (T, 3) int64 their
    triangles (indices into the shape's own outline), ``outline_edges`` (T, 3) bool,
    shape s's rows
    ``triangle_start[s]:triangle_start[s + 1]``; ``convex_mesh`` (S,) bool, convex
    meshes. ``shape_of``: the shapes (S,), for the paths that run per shape pair."""

    table: ProgramTable | None
    program: np.ndarray
    bounds: np.ndarray
    radius: np.ndarray
    flat: np.ndarray
    convex: np.ndarray
    sdf: np.ndarray
    vertices: np.ndarray
    vertex_start: np.ndarray
    triangles: np.ndarray
    outline_edges: np.ndarray
    triangle_start: np.ndarray
    convex_mesh: np.ndarray
    shape_of: tuple

    @classmethod
    def of(cls, shapes: Sequence[Shape]) -> ShapeFields:
        built = [compiled.compile_field(s.field) for s in shapes]
        kept = [p for p in built if p is not None]
        program = np.cumsum([p is not None for p in built], dtype=np.int64) - 1
        program[np.array([p is None for p in built], bool)] = -1
        meshes = [s if s.kind == "mesh" else None for s in shapes]
        vertices = [np.zeros((0, 2)) if m is None else m.vertices for m in meshes]
        triangles = [np.zeros((0, 3), np.int64) if m is None else m.triangles for m in meshes]
        edges = [np.zeros((0, 3), bool) if m is None else m.outline_edges for m in meshes]
        return cls(program_table(kept) if kept else None, program,
                   np.array([s.bounds() for s in shapes], np.float64).reshape(-1, 4),
                   np.array([s.radius for s in shapes], np.float64),
                   np.array([flat_field(s) for s in shapes], bool),
                   np.array([field_convex(s.field) for s in shapes], bool),
                   np.array([s.kind == "sdf" for s in shapes], bool),
                   np.ascontiguousarray(np.concatenate(vertices), np.float64),
                   np.cumsum([0] + [len(v) for v in vertices]).astype(np.int64),
                   np.ascontiguousarray(np.concatenate(triangles), np.int64),
                   np.ascontiguousarray(np.concatenate(edges), bool),
                   np.cumsum([0] + [len(t) for t in triangles]).astype(np.int64),
                   np.array([m is not None and bool(m.convex) for m in meshes], bool),
                   tuple(shapes))


#: (id(a), id(b)) -> (a, b, constants' version, their ShapeFields): the tables of one
#: shape pair's calls.
_PAIRS: dict[tuple[int, int], tuple[Shape, Shape, int, ShapeFields]] = {}
_PAIRS_KEPT = 256


def pair_fields(a: Shape, b: Shape) -> ShapeFields:
    """``ShapeFields.of([a, b])``, cached by the shapes' identities (the shapes are kept
    with it, so an identity is never reused while cached) until some program's
    constants change in place (an edited terrain's grid: ``sdf.compiled.consts_changed``)."""
    key = (id(a), id(b))
    hit = _PAIRS.get(key)
    if hit is None or hit[2] != compiled.consts_version():
        if len(_PAIRS) >= _PAIRS_KEPT:
            _PAIRS.pop(next(iter(_PAIRS)))
        hit = _PAIRS[key] = (a, b, compiled.consts_version(), ShapeFields.of([a, b]))
    return hit[3]


def evaluate_by_shape(fields: ShapeFields, shape: np.ndarray, points: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Value (N,) and gradient (N, 2) of shape shape[i]'s field (rows of ``fields``) at
    points[i] (N, 2) of its frame (m): each shape's points one batch, in their order,
    as a ``compiled.evaluate`` call per shape (the same bits) in one kernel call; a call
    per shape where some field does not compile."""
    n = len(shape)
    if n == 0:
        return np.zeros(0), np.zeros((0, 2))
    if np.any(fields.program[shape] < 0):
        f, g = np.empty(n), np.empty((n, 2))
        for s in np.unique(shape):
            at = np.flatnonzero(shape == s)
            f[at], g[at] = compiled.evaluate(fields.shape_of[s].field, points[at])
        return f, g
    order = np.argsort(shape, kind="stable")
    t = fields.table
    f_sorted, g_sorted = evaluate_runs(t.code, t.consts, t.start, t.depth, t.nesting,
                                       fields.program, np.arange(len(fields.program)),
                                       np.ascontiguousarray(shape[order]),
                                       np.ascontiguousarray(points[order], np.float64), n)
    f, g = np.empty(n), np.empty((n, 2))
    f[order], g[order] = f_sorted, g_sorted
    return f, g
