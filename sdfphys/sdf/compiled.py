"""Field trees compiled to a flat stack-machine program that one numba function evaluates.

Why: the descent (``collide.descent``) evaluates a field once per round on a few
hundred points; a numpy ``field.evaluate`` costs ~30 us of fixed overhead per call
(per node of the tree), which dominates small batches. ``compile_field(f)`` turns
the tree of ``f`` into a :class:`Program` (an int64 instruction table and a
float64 constant table) that :func:`run` evaluates on a batch of points inside
njit code (one instruction at a time over the batch), with no Python in the loop: value and analytic gradient, the same numbers as
``f.evaluate`` (the same operations in the same order, so the same bits, except
where numpy's exp or a BLAS dot product rounds differently: within an ulp or so).

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

What compiles: the primitives circle, box, rounded_box, polygon (mesh shapes'
exact fields), half_plane, segment, capsule; the operators transform / translate
/ rotate, scale, union, intersection, difference, xor, smooth_union /
smooth_intersection / smooth_difference (all four blends), round and onion.
Anything else (other primitives, baked grids, numeric gradients, user classes,
subclasses) makes :func:`compile_field` return None: the caller keeps the numpy
path. The program is cached on the field object (``_compiled_program``), so
shared (instanced) fields compile once.

Conventions are those of ``sdfphys.sdf.base``: metres, f < 0 inside, gradients
deterministic unit vectors (a subgradient) where f is not differentiable, with
the same fallback directions as the numpy code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from . import curved, operators, polygonal
from .base import Field, safe_normalize

__all__ = ["Program", "compile_field", "distance", "evaluate", "run", "scratch"]

# Opcodes.
CIRCLE = 0          # consts: r
BOX = 1             # consts: hx, hy
ROUNDED_BOX = 2     # consts: hx, hy, r0, r1, r2, r3
HALF_PLANE = 3      # consts: nx, ny, level
POLYGON = 4         # a = M edges; consts: eps, then per edge ax, ay, ex, ey, by, 1/|e|^2, nx, ny
SEGMENT = 5         # consts: ax, ay, bax, bay, |ba|^2, left x, left y, radius
PUSH_T = 6          # consts: ox, oy, c, s, -s (rotation R = [[c, -s], [s, c]])
POP_T = 7           # consts: as PUSH_T
PUSH_S = 8          # consts: factor
POP_S = 9           # consts: factor
SELECT = 10         # a = n operands, b = 0 min / 1 max / 2 max(a, -b1, -b2, ...)
XOR = 11            # binary fold
SMOOTH = 12         # a = 0 union / 1 intersection / 2 difference, b = blend; consts: k
ROUND = 13          # consts: r
ONION = 14          # consts: thickness

#: Blend kernels by index (``SMOOTH``'s b), as in ``operators.BLENDS``.
BLEND_INDEX = {"polynomial": 0, "cubic": 1, "circular": 2, "exponential": 3}
_EXP_SCALE = operators._EXP_SCALE
_TINY = 1e-300
_POLYGON_EDGE = 8


@dataclass(frozen=True)
class Program:
    """A compiled field: ``code`` (I, 4) int64, ``consts`` (F,) float64, the value
    stack ``depth`` and the point stack ``nesting`` it needs (both >= 1)."""

    code: np.ndarray
    consts: np.ndarray
    depth: int
    nesting: int


class _Builder:
    def __init__(self) -> None:
        self.code: list[tuple[int, int, int, int]] = []
        self.consts: list[float] = []
        self.sp = 0
        self.depth = 0
        self.frames = 0
        self.nesting = 0

    def emit(self, op: int, values=(), a: int = 0, b: int = 0, push: int = 0) -> None:
        self.code.append((op, len(self.consts), a, b))
        self.consts.extend(float(v) for v in values)
        self.sp += push
        self.depth = max(self.depth, self.sp)


class _Unsupported(Exception):
    pass


def _emit(f: Field, out: _Builder) -> None:
    """Append the instructions of ``f`` (postfix); raise _Unsupported for other fields."""
    kind = type(f)
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
        _emit(f.of[0], out)
        for part in f.of[1:]:
            _emit(part, out)
            out.emit(SMOOTH, [f.k], a=mode, b=BLEND_INDEX[f.blend], push=-1)
    elif kind is operators.Round:
        _emit(f.of, out)
        out.emit(ROUND, [f.r])
    elif kind is operators.Onion:
        _emit(f.of, out)
        out.emit(ONION, [f.thickness])
    else:
        raise _Unsupported(kind.__name__)


def compile_field(f: Field) -> Program | None:
    """The program of ``f``, or None when some node of its tree does not compile.

    Cached on ``f`` (attribute ``_compiled_program``; False marks "does not compile").
    """
    cached = f.__dict__.get("_compiled_program") if hasattr(f, "__dict__") else None
    if cached is not None:
        return cached or None
    out = _Builder()
    try:
        _emit(f, out)
        program: Program | bool = Program(np.array(out.code, dtype=np.int64).reshape(-1, 4),
                                          np.array(out.consts + [0.0], dtype=np.float64),
                                          max(out.depth, 1), max(out.nesting, 1))
    except _Unsupported:
        program = False
    try:
        f._compiled_program = program
    except AttributeError:
        pass
    return program or None


# --------------------------------------------------------------------------------------
# The evaluator. Each branch repeats the numpy code of its node operation for
# operation (see the references in the comments), so that both paths round alike.
# --------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def _box(x: float, y: float, hx: float, hy: float) -> tuple[float, float, float]:
    """polygonal._box at one point: value and gradient of the box of half-extents h."""
    wx, wy = abs(x) - hx, abs(y) - hy
    sx = -1.0 if x < 0.0 else 1.0
    sy = -1.0 if y < 0.0 else 1.0
    ox, oy = max(wx, 0.0), max(wy, 0.0)
    out_len = math.hypot(ox, oy)
    inner = min(max(wx, wy), 0.0)
    if out_len > 0.0:
        gx, gy = ox / out_len, oy / out_len
    elif wx >= wy:
        gx, gy = 1.0, 0.0
    else:
        gx, gy = 0.0, 1.0
    return out_len + inner, gx * sx, gy * sy


@njit(cache=True, error_model="numpy")
def _polygon(consts: np.ndarray, o: int, m: int, px: float, py: float
             ) -> tuple[float, float, float]:
    """polygonal.Polygon._evaluate_chunk at one point (edges from consts[o + 1:])."""
    best = np.inf
    k = 0
    tk = 0.0
    inside = False
    e0 = o + 1
    for i in range(m):
        j = e0 + _POLYGON_EDGE * i
        ax, ay, ex, ey, by, inv = (consts[j], consts[j + 1], consts[j + 2], consts[j + 3],
                                   consts[j + 4], consts[j + 5])
        wx = px - ax
        wy = py - ay
        t = wx * ex
        t += wy * ey
        t *= inv
        t = min(max(t, 0.0), 1.0)
        vx = wx - t * ex
        vy = wy - t * ey
        d2 = vx * vx + vy * vy
        if d2 < best:                                   # np.argmin: first of a tie
            best, k, tk = d2, i, t
        below_b = py < by
        if ((py >= ay) == below_b) and (below_b == (ex * wy > ey * wx)):
            inside = not inside
    j = e0 + _POLYGON_EDGE * k
    vx = (px - consts[j]) - tk * consts[j + 2]
    vy = (py - consts[j + 1]) - tk * consts[j + 3]
    nx, ny = consts[j + 6], consts[j + 7]
    s = -1.0 if inside else 1.0
    if tk > 0.0 and tk < 1.0:
        return s * math.sqrt(best), nx, ny
    ux, uy = s * vx, s * vy
    length = math.hypot(ux, uy)
    if length > consts[o]:
        return s * math.sqrt(best), ux / length, uy / length
    return s * math.sqrt(best), nx, ny


@njit(cache=True, error_model="numpy")
def _segment(consts: np.ndarray, o: int, px: float, py: float) -> tuple[float, float, float]:
    """curved._segment_distance at one point, minus the capsule radius."""
    ax, ay, bax, bay, length2 = consts[o], consts[o + 1], consts[o + 2], consts[o + 3], \
        consts[o + 4]
    lx, ly = consts[o + 5], consts[o + 6]
    pax, pay = px - ax, py - ay
    h = 0.0
    if length2 > 0.0:
        h = min(max((pax * bax + pay * bay) / length2, 0.0), 1.0)
    rx, ry = pax - h * bax, pay - h * bay
    dist = math.hypot(rx, ry)
    if h > 0.0 and h < 1.0:
        side = bax * pay - bay * pax
        if side < 0.0:
            return dist - consts[o + 7], -lx, -ly
        return dist - consts[o + 7], lx, ly
    if dist > _TINY:
        return dist - consts[o + 7], rx / dist, ry / dist
    return dist - consts[o + 7], lx, ly


@njit(cache=True, error_model="numpy")
def _blend(gap: float, k: float, blend: int) -> tuple[float, float]:
    """operators.BLENDS kernels: (dip below min, weight of the larger operand)."""
    if blend == 0:
        h = 1.0 - min(gap / k, 1.0)
        return 0.25 * k * h * h, 0.5 * h
    if blend == 1:
        h = 1.0 - min(gap / k, 1.0)
        return k * h * h * h / 6.0, 0.5 * h * h
    if blend == 2:
        x = min(gap / k, 1.0)
        root = math.sqrt(2.0 - x * x)
        return 0.5 * k * (2.0 - x - root), 0.5 * (1.0 - x / root)
    s = k * _EXP_SCALE
    e = math.exp(-gap / s)
    return s * math.log1p(e), e / (1.0 + e)


@njit(cache=True, error_model="numpy")
def _smooth_min(a: float, b: float, k: float, blend: int) -> tuple[float, float]:
    """operators.smooth_min: (value, weight of b)."""
    dip, larger = _blend(abs(a - b), k, blend)
    return min(a, b) - dip, larger if b > a else 1.0 - larger


@njit(cache=True, error_model="numpy")
def scratch(depth: int, nesting: int, n: int
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Work arrays of ``run`` for batches of up to n points: the value stack
    (depth, n, 3), the point stack (nesting, n, 2) and the current points (n, 2)."""
    return np.empty((depth, n, 3)), np.empty((nesting, n, 2)), np.empty((n, 2))


@njit(cache=True, error_model="numpy")
def run(code: np.ndarray, consts: np.ndarray, points: np.ndarray, n: int, stack: np.ndarray,
        frames: np.ndarray, cur: np.ndarray, value: np.ndarray, grad: np.ndarray) -> None:
    """Value (n,) and gradient (n, 2) of the program at points[:n] (m), into value, grad.

    One instruction at a time over the whole batch (the dispatch costs once per
    batch, the inner loops are tight). stack, frames, cur: ``scratch`` arrays of at
    least the program's depth and nesting and n points.
    """
    for j in range(n):
        cur[j, 0], cur[j, 1] = points[j, 0], points[j, 1]
    sp = 0
    fp = 0
    for i in range(code.shape[0]):
        op, o, a, b = code[i, 0], code[i, 1], code[i, 2], code[i, 3]
        if op == CIRCLE:
            out = stack[sp]
            r = consts[o]
            for j in range(n):
                x, y = cur[j, 0], cur[j, 1]
                length = math.hypot(x, y)
                if length > _TINY:
                    out[j, 0], out[j, 1], out[j, 2] = length - r, x / length, y / length
                else:
                    out[j, 0], out[j, 1], out[j, 2] = length - r, 1.0, 0.0
            sp += 1
        elif op == BOX:
            out = stack[sp]
            hx, hy = consts[o], consts[o + 1]
            for j in range(n):
                out[j, 0], out[j, 1], out[j, 2] = _box(cur[j, 0], cur[j, 1], hx, hy)
            sp += 1
        elif op == ROUNDED_BOX:
            out = stack[sp]
            hx, hy = consts[o], consts[o + 1]
            for j in range(n):
                x, y = cur[j, 0], cur[j, 1]
                if y >= 0.0:
                    r = consts[o + 2] if x >= 0.0 else consts[o + 3]
                else:
                    r = consts[o + 5] if x >= 0.0 else consts[o + 4]
                v, gx, gy = _box(x, y, hx - r, hy - r)
                out[j, 0], out[j, 1], out[j, 2] = v - r, gx, gy
            sp += 1
        elif op == HALF_PLANE:
            out = stack[sp]
            nx, ny, level = consts[o], consts[o + 1], consts[o + 2]
            for j in range(n):
                out[j, 0] = (cur[j, 0] * nx + cur[j, 1] * ny) - level
                out[j, 1], out[j, 2] = nx, ny
            sp += 1
        elif op == POLYGON:
            out = stack[sp]
            for j in range(n):
                out[j, 0], out[j, 1], out[j, 2] = _polygon(consts, o, a, cur[j, 0], cur[j, 1])
            sp += 1
        elif op == SEGMENT:
            out = stack[sp]
            for j in range(n):
                out[j, 0], out[j, 1], out[j, 2] = _segment(consts, o, cur[j, 0], cur[j, 1])
            sp += 1
        elif op == PUSH_T:
            saved = frames[fp]
            fp += 1
            ox, oy, c, s, ms = consts[o], consts[o + 1], consts[o + 2], consts[o + 3], \
                consts[o + 4]
            for j in range(n):
                x, y = cur[j, 0], cur[j, 1]
                saved[j, 0], saved[j, 1] = x, y
                px, py = x - ox, y - oy
                cur[j, 0], cur[j, 1] = c * px + s * py, ms * px + c * py
        elif op == POP_T:
            fp -= 1
            saved = frames[fp]
            top = stack[sp - 1]
            c, s, ms = consts[o + 2], consts[o + 3], consts[o + 4]
            for j in range(n):
                cur[j, 0], cur[j, 1] = saved[j, 0], saved[j, 1]
                gx, gy = top[j, 1], top[j, 2]
                top[j, 1], top[j, 2] = c * gx + ms * gy, s * gx + c * gy
        elif op == PUSH_S:
            saved = frames[fp]
            fp += 1
            factor = consts[o]
            for j in range(n):
                x, y = cur[j, 0], cur[j, 1]
                saved[j, 0], saved[j, 1] = x, y
                cur[j, 0], cur[j, 1] = x / factor, y / factor
        elif op == POP_S:
            fp -= 1
            saved = frames[fp]
            top = stack[sp - 1]
            factor = consts[o]
            for j in range(n):
                cur[j, 0], cur[j, 1] = saved[j, 0], saved[j, 1]
                top[j, 0] = factor * top[j, 0]
        elif op == SELECT:
            # min (union), max (intersection) or max(a, -b1, -b2, ...) (difference)
            # of the a operands on top; the first one wins a tie (numpy's arg-min/max).
            first = sp - a
            out = stack[first]
            for j in range(n):
                pick = first
                best = stack[first, j, 0]
                for k in range(first + 1, sp):
                    d = stack[k, j, 0] if b != 2 else -stack[k, j, 0]
                    if (d < best) if b == 0 else (d > best):
                        pick, best = k, d
                if pick != first:
                    sign = -1.0 if b == 2 else 1.0
                    out[j, 0] = sign * stack[pick, j, 0]
                    out[j, 1] = sign * stack[pick, j, 1]
                    out[j, 2] = sign * stack[pick, j, 2]
            sp = first + 1
        elif op == XOR:
            left, right = stack[sp - 2], stack[sp - 1]
            for j in range(n):
                d, g0x, g0y = left[j, 0], left[j, 1], left[j, 2]
                e, g1x, g1y = right[j, 0], right[j, 1], right[j, 2]
                low, high = min(d, e), max(d, e)
                if d <= e:
                    lx, ly = g0x, g0y
                else:
                    lx, ly = g1x, g1y
                if d >= e:
                    hx, hy = g0x, g0y
                else:
                    hx, hy = g1x, g1y
                left[j, 0] = max(low, -high)
                if low >= -high:
                    left[j, 1], left[j, 2] = lx, ly
                else:
                    left[j, 1], left[j, 2] = -hx, -hy
            sp -= 1
        elif op == SMOOTH:
            left, right = stack[sp - 2], stack[sp - 1]
            k = consts[o]
            for j in range(n):
                d, g0x, g0y = left[j, 0], left[j, 1], left[j, 2]
                e, g1x, g1y = right[j, 0], right[j, 1], right[j, 2]
                if a == 0:
                    v, w = _smooth_min(d, e, k, b)
                    left[j, 0] = v
                    left[j, 1] = (1.0 - w) * g0x + w * g1x
                    left[j, 2] = (1.0 - w) * g0y + w * g1y
                elif a == 1:
                    v, w = _smooth_min(-d, -e, k, b)
                    left[j, 0] = -v
                    left[j, 1] = (1.0 - w) * g0x + w * g1x
                    left[j, 2] = (1.0 - w) * g0y + w * g1y
                else:
                    v, w = _smooth_min(-d, e, k, b)
                    left[j, 0] = -v
                    left[j, 1] = (1.0 - w) * g0x - w * g1x
                    left[j, 2] = (1.0 - w) * g0y - w * g1y
            sp -= 1
        elif op == ROUND:
            top = stack[sp - 1]
            r = consts[o]
            for j in range(n):
                top[j, 0] = top[j, 0] - r
        elif op == ONION:
            top = stack[sp - 1]
            thickness = consts[o]
            for j in range(n):
                v = top[j, 0]
                if v < 0.0:
                    top[j, 1], top[j, 2] = -top[j, 1], -top[j, 2]
                top[j, 0] = abs(v) - thickness
    result = stack[0]
    for j in range(n):
        value[j], grad[j, 0], grad[j, 1] = result[j, 0], result[j, 1], result[j, 2]


def evaluate(f: Field, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``f.evaluate(points)`` through the compiled program when ``f`` compiles.

    points (N, 2) in f's frame (m); returns value (N,) and gradient (N, 2).
    """
    program = compile_field(f)
    if program is None:
        return f.evaluate(points)
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    value = np.empty(len(p))
    grad = np.empty((len(p), 2))
    stack, frames, cur = scratch(program.depth, program.nesting, len(p))
    run(program.code, program.consts, p, len(p), stack, frames, cur, value, grad)
    return value, grad


def distance(f: Field, points: np.ndarray) -> np.ndarray:
    """``f.distance(points)`` (N,) through the compiled program when ``f`` compiles."""
    if compile_field(f) is None:
        return f.distance(points)
    return evaluate(f, points)[0]
