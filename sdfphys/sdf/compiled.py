"""Field trees compiled to a flat stack-machine program that one numba function evaluates.

This is the one implementation of every primitive and operator of ``sdfphys.sdf``:
``Field.evaluate`` runs the field's program, and so do the collision, ray and
rendering kernels, which call :func:`run` as ``run_shared``, by name
(``sdfphys._shared_kernel``): one machine code of ``run`` per process, not a copy
built into every caller. ``compile_field(f)`` turns the tree of ``f`` into a
:class:`Program` (an int64 instruction table and a float64 constant table) that
:func:`run` evaluates on a batch of points, one instruction at a time over the
batch, value and analytic gradient, with no Python in the loop (a numpy evaluation
costs ~30 us of fixed overhead per node of the tree, which dominated the descent's
small batches).

Program (postfix). ``code`` (I, 4) int64 rows ``(opcode, offset, a, b)``:
``offset`` indexes ``consts`` (F,) float64 where the instruction's parameters
start, ``a`` and ``b`` are small integer arguments. Two stacks, of one entry
per point of the batch:

- the value stack ``stack`` (depth, n, 3): entries (f, df/dx, df/dy). A
  primitive pushes one; an n-ary operator pops its operands and pushes the result.
- the point stack ``frames`` (nesting, n, 2): a placement (transform, scale)
  pushes the current points and replaces them by the operand's local points; the matching
  POP instruction, after the operand's instructions, restores it and maps the
  operand's gradient back (rotation R for a transform, value times s for a scale).

So ``union(A, transform(B))`` becomes ``A  PUSH_T  B  POP_T  SELECT(2, min)``.
Smooth blends and xor fold from the left as in ``operators.py``: operands
``a, b, c`` give ``a b BLEND c BLEND``.

Far operands. A smooth union a BLEND b with a compact blend (polynomial, cubic,
circular) is exactly min(a, b) = a where b >= a + k: the blend's dip and the weight
of b are 0 there (h = 0, or x = 1 for the circular blend), so its value is a and its
gradient a's (up to the sign of a zero component, 0 grad b added). At a point outside
the finite box of an exact operand b, b is the distance to its region, at least the
distance L to the box. So ``SKIP_FAR(box, k)`` before b's instructions skips them and
the blend, leaving a, when every point of the batch is outside the box with
L >= a + k (with a relative margin of 1e-9 for rounding): the showcase's terrain, a
box and a circle smoothly united with an ellipse, skips the ellipse (117 of its 153
ns a point) wherever the batch is away from it. The other batches evaluate b as
before.

What compiles: every registered primitive and operator. The primitives circle,
box, rounded_box, polygon (mesh shapes' exact fields), half_plane, segment and
capsule have their own loops in :func:`run`, and so has the ellipse (its solver
steps interleave the points); the others go through ``_shape``, one point at a
time: arc, ring, pie, cut_disk, horseshoe, uneven_capsule (curved.py), vesica, moon,
egg, heart, quadratic_bezier (conics.py), oriented_box, rhombus, trapezoid,
parallelogram and triangle (one CONVEX opcode), equilateral_triangle and
isosceles_triangle (SYM_TRIANGLE) (polygonal.py), star, pentagon, hexagon, octagon and
hexagram (MIRRORED), cross, rounded_cross (folded.py) and baked grids (``bake``,
grid.py: the node values, decoded if quantized, are consts). The operators:
transform / translate / rotate, scale, union, intersection, difference, xor,
smooth_union / smooth_intersection / smooth_difference (all four blends), round
and onion. A subclass that keeps the inherited ``evaluate`` takes its parent's
instructions. The program is cached on the field object (``_compiled_program``),
so shared (instanced) fields compile once.

Fields of the user's own. A field with its own ``evaluate`` (a user's class, the
numeric gradients of ``gradient.py``) is an EXTERNAL leaf of the program: from
Python, :func:`evaluate` runs the program up to the leaf, the leaf's ``evaluate``
takes the points in its frame, and the program resumes (``run`` returns and is
called again from the next row), so operators written once serve user fields too.
Kernels cannot call Python: for a tree with externals :func:`compile_field` returns
None and the collision stages take their Python-driven path.

Rounding. The numpy oracle of the tests (tests/numpy_fields: the vectorized code the
fields had before this was their one implementation) gives the same bits for most
kinds (tests/test_compiled_fields*.py and tests/test_sdf_curved_bits.py compare with
``assert_array_equal``). Where the numpy code calls numpy's SIMD arctan2 (star), cbrt /
arccos / power (quadratic_bezier) or exp (the exponential blend), an ulp or a few
from libm's, the results differ in the last bits. Measured on 26 000 points per
kind: values within 1.5e-14, gradients within 1.5e-14, except on kinks and within
~1e-9 of a vertex (where the last bit picks the side or turns the direction) and
the Bezier's gradients, within 6.2e-9 near its evolute (its three Newton steps
amplify the seed's last bits).

Conventions are those of ``sdfphys.sdf.base``: metres, f < 0 inside, gradients
deterministic unit vectors (a subgradient) where f is not differentiable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import types

from .._jit import njit
from .._shared_kernel import F1, F2, F3, I2, shared
from ..vec2 import TINY
from . import conics, curved, folded, grid, operators, polygonal
from .base import _EVALUATOR, Field, safe_normalize
from .blend_kernels import _smooth_min
from .ellipse_kernel import _ellipse
from .opcodes import (
    ARC,
    BLEND_INDEX,
    BOX,
    CIRCLE,
    CONVEX,
    CROSS,
    CUT_DISK,
    EGG,
    ELLIPSE,
    EXTERNAL,
    GRID,
    HALF_PLANE,
    HEART,
    HORSESHOE,
    MIRRORED,
    MOON,
    ONION,
    ORIENTED_BOX,
    PIE,
    POLYGON,
    POP_S,
    POP_T,
    PUSH_S,
    PUSH_T,
    QUADRATIC_BEZIER,
    RHOMBUS,
    RING,
    ROUND,
    ROUNDED_BOX,
    ROUNDED_CROSS,
    SEGMENT,
    SELECT,
    SKIP_FAR,
    SMOOTH,
    STAR,
    SYM_TRIANGLE,
    TRAPEZOID,
    UNEVEN_CAPSULE,
    VESICA,
    XOR,
)
from .primitive_kernels import _box, _polygon, _segment, _shape

__all__ = ["RUN_RESULT", "RUN_TYPES", "Program", "compile_field", "consts_changed",
           "consts_version", "distance", "evaluate", "field_program", "run", "run_shared",
           "scratch"]

@dataclass(frozen=True)
class Program:
    """A compiled field: ``code`` (I, 4) int64, ``consts`` (F,) float64, the value
    stack ``depth`` and the point stack ``nesting`` it needs (both >= 1), and the
    ``externals``: the fields of the tree that do not compile (user classes), in the
    order of their EXTERNAL rows' ``a``. A program with externals runs only from
    Python (:func:`evaluate`); kernels take programs without (:func:`compile_field`).
    """

    code: np.ndarray
    consts: np.ndarray
    depth: int
    nesting: int
    externals: tuple[Field, ...] = ()


#: How many times a program's constants were changed in place (a baked grid's nodes
#: edited, ``sdf.edit``): the tables that hold copies of programs' constants
#: (``sdf.program_table``, ``collide.shape_fields``) are rebuilt when it moved.
_CONSTS_VERSION = [0]


def consts_changed() -> None:
    """Note that some program's constants were changed in place."""
    _CONSTS_VERSION[0] += 1


def consts_version() -> int:
    """The count of in-place changes of programs' constants so far."""
    return _CONSTS_VERSION[0]


class _Builder:
    def __init__(self) -> None:
        self.code: list[tuple[int, int, int, int]] = []
        self.consts: list[np.ndarray] = []
        self.size = 0
        self.sp = 0
        self.depth = 0
        self.frames = 0
        self.nesting = 0
        self.externals: list[Field] = []

    def emit(self, op: int, values=(), a: int = 0, b: int = 0, push: int = 0) -> None:
        block = np.array(values, dtype=np.float64).ravel()
        self.code.append((op, self.size, a, b))
        self.consts.append(block)
        self.size += block.size
        self.sp += push
        self.depth = max(self.depth, self.sp)


def _edge_consts(segments) -> list[float]:
    """The 7 consts of each ``polygonal._Segment`` (see the opcode table): a, e = b - a,
    e.e = e_x e_x + e_y e_y and the outward normal."""
    out: list[float] = []
    for seg in segments:
        e = seg.b - seg.a
        out += [seg.a[0], seg.a[1], e[0], e[1], e[0] * e[0] + e[1] * e[1],
                seg.normal[0], seg.normal[1]]
    return out


def _kind(f: Field, inherited: bool = False) -> type:
    """The class whose instructions ``f`` takes: its own; or, for a subclass that keeps
    the inherited ``evaluate`` (or whose own calls the inherited one: ``inherited``),
    its nearest compiled ancestor (``_COMPILED``)."""
    kind = type(f)
    if kind in _COMPILED or not inherited and getattr(kind, "evaluate", None) is not \
            Field.evaluate:
        return kind
    for ancestor in kind.__mro__:
        if ancestor in _COMPILED:
            return ancestor
    raise NotImplementedError(f"{kind.__name__} is a Field without evaluate(); a field of "
                              "your own must define evaluate(points) -> (value, gradient)")


def _emit(f: Field, out: _Builder, inherited: bool = False) -> None:
    """Append the instructions of ``f`` (postfix); a field that does not compile is an
    EXTERNAL leaf (``out.externals``). ``inherited``: see ``_kind``."""
    kind = _kind(f, inherited)
    if kind is curved.Circle:
        out.emit(CIRCLE, [f.radius], push=1)
    elif kind is polygonal.Box:
        out.emit(BOX, f.half, push=1)
    elif kind is polygonal.RoundedBox:
        out.emit(ROUNDED_BOX, list(f.half) + list(f.radii), push=1)
    elif kind is polygonal.HalfPlane:
        out.emit(HALF_PLANE, [f.normal[0], f.normal[1], f.level], push=1)
    elif kind is polygonal.Polygon:
        edges = np.column_stack([f._ax, f._ay, f._ex, f._ey, f._by, f._inv_ee,
                                 f._normals[:, 0], f._normals[:, 1]])
        out.emit(POLYGON, [f._eps] + edges.ravel().tolist(), a=len(edges), push=1)
    elif kind in (curved.Segment, curved.Capsule):
        ba = f.b - f.a
        left = safe_normalize(np.array([[-ba[1], ba[0]]]))[0]
        radius = f.radius if kind is curved.Capsule else 0.0
        out.emit(SEGMENT, [f.a[0], f.a[1], ba[0], ba[1], float(ba @ ba), left[0], left[1],
                           radius], push=1)
    elif kind is conics.Ellipse:
        out.emit(ELLIPSE, [f.a, f.b], a=int(f.swap), push=1)
    elif kind is curved.Arc:
        out.emit(ARC, [f.c[0], f.c[1], f.radius, f.half_width], push=1)
    elif kind is curved.Ring:
        out.emit(RING, [f.c[0], f.c[1], f.radius, f.half_width], a=int(f.full), push=1)
    elif kind is curved.Pie:
        out.emit(PIE, [f.c[0], f.c[1], f.radius], a=int(f.full), push=1)
    elif kind is curved.CutDisk:
        out.emit(CUT_DISK, [f.radius, f.h, f.half_chord], push=1)
    elif kind is curved.Horseshoe:
        out.emit(HORSESHOE, [f.radius, f.half_width, f.length, f.n[0], f.n[1], f.d[0],
                             f.d[1]], push=1)
    elif kind is conics.Vesica:
        out.emit(VESICA, [f.radius, f.centre_distance, f.half_height], push=1)
    elif kind is conics.Moon:
        unit = f.horn / f.radius
        out.emit(MOON, [f.radius, f.bite_radius, f.centre_distance, f.horn[0], f.horn[1],
                        unit[0], unit[1]], push=1)
    elif kind is conics.Egg:
        r = f.core
        out.emit(EGG, [r, math.sqrt(3.0) * r, 2.0 * r, f.top_radius, math.sqrt(3.0)], push=1)
    elif kind is conics.Heart:
        out.emit(HEART, [f.scale, f._LOBE_CENTRE[0], f._LOBE_CENTRE[1], f._LOBE_RADIUS,
                         f._EDGE_NORMAL[0], f._EDGE_NORMAL[1]], push=1)
    elif kind is curved.UnevenCapsule:
        out.emit(UNEVEN_CAPSULE, [f.r1, f.r2, f.height, f.sin_t, f.cos_t,
                                  f.cos_t * f.height], push=1)
    elif kind is folded.Star:
        out.emit(STAR, [f._an, 2.0 * f._an, f._eps, f._edge[0].b[0], f._edge[0].b[1]]
                 + _edge_consts(f._edge), push=1)
    elif kind is polygonal.OrientedBox:
        out.emit(ORIENTED_BOX, [f.centre[0], f.centre[1], f.axis[0], f.axis[1], f.half[0],
                                f.half[1]], push=1)
    elif kind is polygonal.Rhombus:
        bx, by = f.half
        out.emit(RHOMBUS, [bx, by, bx * by, f._eps] + _edge_consts(f._edge), push=1)
    elif kind is polygonal.Trapezoid:
        side = f._side
        out.emit(TRAPEZOID, [f.he, f._eps, side.a[0], side.a[1], side.normal[0],
                             side.normal[1]] + _edge_consts(f._edges), a=len(f._edges), push=1)
    elif kind in (polygonal.Parallelogram, polygonal.Triangle):
        out.emit(CONVEX, [f._eps] + _edge_consts(f._edges), a=len(f._edges), push=1)
    elif kind in (polygonal.EquilateralTriangle, polygonal.IsoscelesTriangle):
        side = f._side
        out.emit(SYM_TRIANGLE, [f.y_base, f._eps, side.a[0], side.a[1], side.normal[0],
                                side.normal[1]] + _edge_consts(f._edges), push=1)
    elif kind in (folded.Pentagon, folded.Hexagon, folded.Octagon,
                  folded.Hexagram):
        mirrors = [float(c) for n in kind._mirrors for c in n]
        out.emit(MIRRORED, [f.radius, f._eps] + mirrors + _edge_consts(f._edge),
                 a=len(kind._mirrors), b=int(kind._abs_y), push=1)
    elif kind is folded.Cross:
        out.emit(CROSS, [f.half[0], f.half[1], f.rounding, f._eps] + _edge_consts(f._edges),
                 a=len(f._edges), push=1)
    elif kind is folded.RoundedCross:
        out.emit(ROUNDED_CROSS, [f.h, f._k, f.radius, f._k - f.h], push=1)
    elif kind is grid.GridField:
        band = math.inf if f.band is None else f.band
        out.emit(GRID, np.concatenate([[f.origin[0], f.origin[1], f.cell], f.margins, [band],
                                       np.asarray(f.values, dtype=np.float64).ravel()]),
                 a=f.shape[0], b=f.shape[1], push=1)
    elif kind is conics.QuadraticBezier:
        A, B = f.A, f.B
        out.emit(QUADRATIC_BEZIER, [f.a[0], f.a[1], A[0], A[1], B[0], B[1], B @ B,
                                    3.0 * (A @ B), 2.0 * (A @ A), f.radius, f.cross,
                                    float(f.cubic)], push=1)
    elif kind in (operators.Transform, operators.Translate, operators.Rotate):
        (c, ms), (s, _) = f.rotation
        frame = [f.offset[0], f.offset[1], c, s, ms]
        out.frames += 1
        out.nesting = max(out.nesting, out.frames)
        out.emit(PUSH_T, frame)
        _emit(f.of, out)
        out.emit(POP_T, frame)
        out.frames -= 1
    elif kind is operators.Scale:
        out.frames += 1
        out.nesting = max(out.nesting, out.frames)
        out.emit(PUSH_S, [f.factor])
        _emit(f.of, out)
        out.emit(POP_S, [f.factor])
        out.frames -= 1
    elif kind in (operators.Union, operators.Intersection, operators.Difference):
        for part in f.of:
            _emit(part, out)
        mode = {operators.Union: 0, operators.Intersection: 1, operators.Difference: 2}[kind]
        out.emit(SELECT, a=len(f.of), b=mode, push=1 - len(f.of))
    elif kind is operators.Xor:
        _emit(f.of[0], out)
        for part in f.of[1:]:
            _emit(part, out)
            out.emit(XOR, push=-1)
    elif kind in (operators.SmoothUnion, operators.SmoothIntersection,
                  operators.SmoothDifference):
        mode = {operators.SmoothUnion: 0, operators.SmoothIntersection: 1,
                operators.SmoothDifference: 2}[kind]
        blend = BLEND_INDEX[f.blend]
        _emit(f.of[0], out)
        for part in f.of[1:]:
            guard = None
            box = np.asarray(part.bounds(), dtype=np.float64)
            if mode == 0 and blend != BLEND_INDEX["exponential"] and part.exact and bool(
                    np.all(np.isfinite(box))):
                guard = len(out.code)
                out.emit(SKIP_FAR, list(box) + [f.k])
            _emit(part, out)
            out.emit(SMOOTH, [f.k], a=mode, b=blend, push=-1)
            if guard is not None:
                op, offset, _, b = out.code[guard]
                out.code[guard] = (op, offset, len(out.code) - guard, b)
    elif kind is operators.Round:
        _emit(f.of, out)
        out.emit(ROUND, [f.r])
    elif kind is operators.Onion:
        _emit(f.of, out)
        out.emit(ONION, [f.thickness])
    else:
        out.emit(EXTERNAL, a=len(out.externals), push=1)
        out.externals.append(f)


#: The classes ``_emit`` writes instructions for (``_kind`` resolves subclasses).
_COMPILED = frozenset([
    curved.Circle, curved.Segment, curved.Capsule, curved.Arc, curved.Ring, curved.Pie,
    curved.CutDisk, curved.Horseshoe, curved.UnevenCapsule, conics.Ellipse, conics.Vesica,
    conics.Moon, conics.Egg, conics.Heart, conics.QuadraticBezier, polygonal.Box,
    polygonal.RoundedBox, polygonal.HalfPlane, polygonal.Polygon, polygonal.OrientedBox,
    polygonal.Rhombus, polygonal.Trapezoid, polygonal.Parallelogram, polygonal.Triangle,
    polygonal.EquilateralTriangle, polygonal.IsoscelesTriangle, folded.Star,
    folded.Pentagon, folded.Hexagon, folded.Octagon, folded.Hexagram, folded.Cross,
    folded.RoundedCross, grid.GridField, operators.Transform, operators.Translate,
    operators.Rotate, operators.Scale, operators.Union, operators.Intersection,
    operators.Difference, operators.Xor, operators.SmoothUnion,
    operators.SmoothIntersection, operators.SmoothDifference, operators.Round,
    operators.Onion])


def field_program(f: Field, inherited: bool = False) -> Program:
    """The program of ``f``, its fields that do not compile as EXTERNAL leaves.

    ``inherited``: the program of the nearest compiled ancestor's ``evaluate`` (what
    ``Field.evaluate`` runs when a subclass's own ``evaluate`` calls it). Cached on
    ``f`` (attributes ``_compiled_program``, ``_inherited_program``), so shared fields
    compile once.
    """
    kind = type(f)                      # the inherited program differs for an override
    inherited = inherited and kind not in _COMPILED and kind.evaluate is not Field.evaluate
    name = "_inherited_program" if inherited else "_compiled_program"
    cached = f.__dict__.get(name) if hasattr(f, "__dict__") else None
    if cached is not None:
        return cached
    out = _Builder()
    _emit(f, out, inherited)
    built = Program(np.array(out.code, dtype=np.int64).reshape(-1, 4),
                    np.concatenate(out.consts + [np.zeros(1)]), max(out.depth, 1),
                    max(out.nesting, 1), tuple(out.externals))
    try:
        setattr(f, name, built)
    except AttributeError:
        pass
    return built


def compile_field(f: Field) -> Program | None:
    """The program of ``f`` for kernels, or None when some node of its tree does not
    compile (the caller keeps its Python-driven path)."""
    built = field_program(f)
    return None if built.externals else built


@njit(cache=True, error_model="numpy")
def scratch(depth: int, nesting: int, n: int
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Work arrays of ``run`` for batches of up to n points: the value stack
    (depth, n, 3), the point stack (nesting, n, 2) and the current points (n, 2)."""
    return np.empty((depth, n, 3)), np.empty((nesting, n, 2)), np.empty((n, 2))


@njit(cache=True, error_model="numpy", refcounts=False)
def run(code: np.ndarray, consts: np.ndarray, points: np.ndarray, n: int, stack: np.ndarray,
        frames: np.ndarray, cur: np.ndarray, value: np.ndarray, grad: np.ndarray, start: int,
        sp: int, fp: int) -> tuple[int, int, int]:
    """Value (n,) and gradient (n, 2) of the program at points[:n] (m), into value, grad.

    One instruction at a time over the whole batch (the dispatch costs once per
    batch, the inner loops are tight). The stacks are read and written by index
    (stack[sp, j, 0]), never through row views (stack[sp]): numba counts a view's
    references with atomic operations, and the descents run programs on a few points
    at a time. stack, frames, cur: ``scratch`` arrays of at
    least the program's depth and nesting and n points. Kernels call it with start,
    sp, fp = 0, 0, 0. Returns (i, sp, fp): i = len(code) once the program has run to
    its end and written value and grad; otherwise i is the row of an EXTERNAL leaf
    (``evaluate`` resumes with i + 1, sp + 1, fp once the leaf's value and gradient
    at cur[:n] are in stack[sp]).
    """
    if start == 0:
        for j in range(n):
            cur[j, 0], cur[j, 1] = points[j, 0], points[j, 1]
    i = start - 1
    while i + 1 < code.shape[0]:
        i += 1
        op, o, a, b = code[i, 0], code[i, 1], code[i, 2], code[i, 3]
        if op == SKIP_FAR:
            # Skip the guarded operand and its blend when every point is at least k
            # beyond the current value from the operand's box (module docstring).
            top = sp - 1
            x0, y0, x1, y1, k = consts[o], consts[o + 1], consts[o + 2], consts[o + 3], \
                consts[o + 4]
            far = n > 0
            for j in range(n):
                dx = max(x0 - cur[j, 0], cur[j, 0] - x1, 0.0)
                dy = max(y0 - cur[j, 1], cur[j, 1] - y1, 0.0)
                lower = math.sqrt(dx * dx + dy * dy)
                # Outside the box b is the distance to its region, at least lower; inside
                # it b may be anything down to minus its inradius.
                if not (lower > 0.0
                        and lower * (1.0 - 1e-9) >= stack[top, j, 0] + k * (1.0 + 1e-9) + 1e-12):
                    far = False
                    break
            if far:
                i += a - 1                    # the next row is the one after the blend
        elif op == EXTERNAL:
            return i, sp, fp
        elif op == CIRCLE:
            at = sp
            r = consts[o]
            for j in range(n):
                x, y = cur[j, 0], cur[j, 1]
                length = math.hypot(x, y)
                stack[at, j, 0] = length - r
                if length > TINY:
                    stack[at, j, 1], stack[at, j, 2] = x / length, y / length
                else:
                    stack[at, j, 1], stack[at, j, 2] = 1.0, 0.0
            sp += 1
        elif op == BOX:
            at = sp
            hx, hy = consts[o], consts[o + 1]
            for j in range(n):
                v, gx, gy = _box(cur[j, 0], cur[j, 1], hx, hy)
                stack[at, j, 0], stack[at, j, 1], stack[at, j, 2] = v, gx, gy
            sp += 1
        elif op == ROUNDED_BOX:
            at = sp
            hx, hy = consts[o], consts[o + 1]
            for j in range(n):
                x, y = cur[j, 0], cur[j, 1]
                if y >= 0.0:
                    r = consts[o + 2] if x >= 0.0 else consts[o + 3]
                else:
                    r = consts[o + 5] if x >= 0.0 else consts[o + 4]
                v, gx, gy = _box(x, y, hx - r, hy - r)
                stack[at, j, 0], stack[at, j, 1], stack[at, j, 2] = v - r, gx, gy
            sp += 1
        elif op == HALF_PLANE:
            at = sp
            nx, ny, level = consts[o], consts[o + 1], consts[o + 2]
            for j in range(n):
                stack[at, j, 0] = (cur[j, 0] * nx + cur[j, 1] * ny) - level
                stack[at, j, 1], stack[at, j, 2] = nx, ny
            sp += 1
        elif op == POLYGON:
            at = sp
            for j in range(n):
                v, gx, gy = _polygon(consts, o, a, cur[j, 0], cur[j, 1])
                stack[at, j, 0], stack[at, j, 1], stack[at, j, 2] = v, gx, gy
            sp += 1
        elif op == SEGMENT:
            at = sp
            for j in range(n):
                v, gx, gy = _segment(consts, o, cur[j, 0], cur[j, 1])
                stack[at, j, 0], stack[at, j, 1], stack[at, j, 2] = v, gx, gy
            sp += 1
        elif op == ELLIPSE:
            _ellipse(consts[o], consts[o + 1], a, cur, n, stack, sp)
            sp += 1
        elif op > ELLIPSE:
            at = sp
            for j in range(n):
                v, gx, gy = _shape(op, consts, o, a, b, cur[j, 0], cur[j, 1])
                stack[at, j, 0], stack[at, j, 1], stack[at, j, 2] = v, gx, gy
            sp += 1
        elif op == PUSH_T:
            saved = fp
            fp += 1
            ox, oy, c, s, ms = consts[o], consts[o + 1], consts[o + 2], consts[o + 3], \
                consts[o + 4]
            for j in range(n):
                x, y = cur[j, 0], cur[j, 1]
                frames[saved, j, 0], frames[saved, j, 1] = x, y
                px, py = x - ox, y - oy
                cur[j, 0], cur[j, 1] = c * px + s * py, ms * px + c * py
        elif op == POP_T:
            fp -= 1
            saved = fp
            top = sp - 1
            c, s, ms = consts[o + 2], consts[o + 3], consts[o + 4]
            for j in range(n):
                cur[j, 0], cur[j, 1] = frames[saved, j, 0], frames[saved, j, 1]
                gx, gy = stack[top, j, 1], stack[top, j, 2]
                stack[top, j, 1], stack[top, j, 2] = c * gx + ms * gy, s * gx + c * gy
        elif op == PUSH_S:
            saved = fp
            fp += 1
            factor = consts[o]
            for j in range(n):
                x, y = cur[j, 0], cur[j, 1]
                frames[saved, j, 0], frames[saved, j, 1] = x, y
                cur[j, 0], cur[j, 1] = x / factor, y / factor
        elif op == POP_S:
            fp -= 1
            saved = fp
            top = sp - 1
            factor = consts[o]
            for j in range(n):
                cur[j, 0], cur[j, 1] = frames[saved, j, 0], frames[saved, j, 1]
                stack[top, j, 0] = factor * stack[top, j, 0]
        elif op == SELECT:
            # min (union), max (intersection) or max(a, -b1, -b2, ...) (difference)
            # of the a operands on top; the first one wins a tie.
            first = sp - a
            for j in range(n):
                pick = first
                best = stack[first, j, 0]
                for k in range(first + 1, sp):
                    d = stack[k, j, 0] if b != 2 else -stack[k, j, 0]
                    if (d < best) if b == 0 else (d > best):
                        pick, best = k, d
                if pick != first:
                    sign = -1.0 if b == 2 else 1.0
                    stack[first, j, 0] = sign * stack[pick, j, 0]
                    stack[first, j, 1] = sign * stack[pick, j, 1]
                    stack[first, j, 2] = sign * stack[pick, j, 2]
            sp = first + 1
        elif op == XOR:
            left, right = sp - 2, sp - 1
            for j in range(n):
                d, g0x, g0y = stack[left, j, 0], stack[left, j, 1], stack[left, j, 2]
                e, g1x, g1y = stack[right, j, 0], stack[right, j, 1], stack[right, j, 2]
                low, high = min(d, e), max(d, e)
                if d <= e:
                    lx, ly = g0x, g0y
                else:
                    lx, ly = g1x, g1y
                if d >= e:
                    hx, hy = g0x, g0y
                else:
                    hx, hy = g1x, g1y
                stack[left, j, 0] = max(low, -high)
                if low >= -high:
                    stack[left, j, 1], stack[left, j, 2] = lx, ly
                else:
                    stack[left, j, 1], stack[left, j, 2] = -hx, -hy
            sp -= 1
        elif op == SMOOTH:
            left, right = sp - 2, sp - 1
            k = consts[o]
            for j in range(n):
                d, g0x, g0y = stack[left, j, 0], stack[left, j, 1], stack[left, j, 2]
                e, g1x, g1y = stack[right, j, 0], stack[right, j, 1], stack[right, j, 2]
                if a == 0:
                    v, w = _smooth_min(d, e, k, b)
                    stack[left, j, 0] = v
                    stack[left, j, 1] = (1.0 - w) * g0x + w * g1x
                    stack[left, j, 2] = (1.0 - w) * g0y + w * g1y
                elif a == 1:
                    v, w = _smooth_min(-d, -e, k, b)
                    stack[left, j, 0] = -v
                    stack[left, j, 1] = (1.0 - w) * g0x + w * g1x
                    stack[left, j, 2] = (1.0 - w) * g0y + w * g1y
                else:
                    v, w = _smooth_min(-d, e, k, b)
                    stack[left, j, 0] = -v
                    stack[left, j, 1] = (1.0 - w) * g0x - w * g1x
                    stack[left, j, 2] = (1.0 - w) * g0y - w * g1y
            sp -= 1
        elif op == ROUND:
            top = sp - 1
            r = consts[o]
            for j in range(n):
                stack[top, j, 0] = stack[top, j, 0] - r
        elif op == ONION:
            top = sp - 1
            thickness = consts[o]
            for j in range(n):
                v = stack[top, j, 0]
                if v < 0.0:
                    stack[top, j, 1], stack[top, j, 2] = -stack[top, j, 1], -stack[top, j, 2]
                stack[top, j, 0] = abs(v) - thickness
    for j in range(n):
        value[j], grad[j, 0], grad[j, 1] = stack[0, j, 0], stack[0, j, 1], stack[0, j, 2]
    return code.shape[0], sp, fp


#: ``run``'s argument and result types: the one signature every kernel calls it with.
RUN_TYPES = (I2, F1, F2, types.int64, F3, F3, F2, F1, F2, types.int64, types.int64,
             types.int64)
RUN_RESULT = types.UniTuple(types.int64, 3)

#: ``run`` for njit callers: one machine code per process, called by name
#: (``sdfphys._shared_kernel``), not built into each caller.
run_shared = shared(run, RUN_TYPES, "sdfphys_sdf_compiled_run", RUN_RESULT)


def evaluate(f: Field, points: np.ndarray, inherited: bool = False
             ) -> tuple[np.ndarray, np.ndarray]:
    """Value (N,) and gradient (N, 2) of ``f`` at ``points`` (N, 2), f's frame (m).

    The program runs; at each EXTERNAL leaf (a field of the user's own) it stops, the
    leaf's ``evaluate`` takes the points in the leaf's frame, and the program resumes.
    ``inherited``: ``Field.evaluate``'s call (see ``field_program``).
    """
    built = field_program(f, inherited)
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    if len(built.code) == 1 and built.externals:         # f is itself a user's field
        return f.evaluate(p)
    n = len(p)
    value = np.empty(n)
    grad = np.empty((n, 2))
    stack, frames, cur = scratch(built.depth, built.nesting, n)
    i, sp, fp = run(built.code, built.consts, p, n, stack, frames, cur, value, grad, 0, 0, 0)
    while i < len(built.code):
        leaf_value, leaf_grad = built.externals[built.code[i, 2]].evaluate(cur.copy())
        stack[sp, :, 0] = leaf_value
        stack[sp, :, 1:] = leaf_grad
        i, sp, fp = run(built.code, built.consts, p, n, stack, frames, cur, value, grad,
                        i + 1, sp + 1, fp)
    return value, grad


def distance(f: Field, points: np.ndarray) -> np.ndarray:
    """Value (N,) of ``f`` at ``points`` (N, 2): ``evaluate``'s first result, or a user's
    field's own ``distance`` when ``f`` is one."""
    built = field_program(f)
    if len(built.code) == 1 and built.externals:
        return f.distance(points)
    return evaluate(f, points)[0]


_EVALUATOR.append(evaluate)
