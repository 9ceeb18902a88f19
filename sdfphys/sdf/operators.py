"""Operators on fields: Boolean combinations, smooth blends, offsets and placement.

Every operator is registered with ``@operator``, so a scene FIELD can name it
(``{op = "smooth_union", k = 0.2, of = [FIELD, FIELD]}``); it evaluates value and
gradient analytically (chain rule through its operands), says honestly whether it
is exact, and gives a ``bounds()`` box containing its region ``f <= 0``.

Exactness (``exact`` as defined in ``base.py``). Placement (transform, translate,
rotate) and uniform scale keep an exact operand exact. Every other operator here is
marked ``exact = False`` because, for exact operands, it is exact on one side only
and a bound on the other: union and xor outside, intersection and difference
inside; round and onion away from the operand's medial axis (see their docstrings
for counter-examples); the smooth blends as their hard counterparts outside the
blend zone (compact kernels), and nowhere inside it. All of them are
1-Lipschitz when their operands are (the smooth blend weights are convex), and a
1-Lipschitz function with the right sign never exceeds the distance to its own zero
set, so every result is a valid bound (a safe sphere-tracing step).

Bounds at a level. Growing operators (round, onion, the smooth union) need a box
containing ``{f <= t}`` for some ``t > 0``, not only ``{f <= 0}``: see
:func:`level_bounds`. Every operator here implements ``level_bounds(t)`` from its
operands', so the boxes stay rigorous through any nesting.

Ties. Wherever two operands are equal, the first one listed wins (its gradient is
returned), so results are deterministic.

References: Inigo Quilez, "2D distance functions",
https://iquilezles.org/articles/distfunctions2d/ and "smooth minimum",
https://iquilezles.org/articles/smin/ (kernels, their blend factor and gradients).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import SpecError, check_number
from .base import REQUIRED, Field, Param, operator
from .blend_kernels import smooth_min_arrays
from .opcodes import BLEND_INDEX

__all__ = [
    "BLENDS", "Difference", "Intersection", "Onion", "Rotate", "Round", "Scale",
    "SmoothDifference", "SmoothIntersection", "SmoothUnion", "Transform", "Translate",
    "Union", "Xor", "level_bounds", "smooth_min",
]

_ALL_PLANE = np.array([-np.inf, -np.inf, np.inf, np.inf])


# --------------------------------------------------------------------------------------
# Boxes
# --------------------------------------------------------------------------------------

def level_bounds(field: Field, level: float) -> np.ndarray:
    """A box ``[xmin, ymin, xmax, ymax]`` containing the region ``f <= level``, level >= 0.

    A field with a ``level_bounds`` method (every operator here, baked grids) answers
    itself. Any other field is taken to be exact outside its box, so that
    ``{f <= t}`` is its region grown by a disk of radius ``t``, inside
    ``bounds()`` grown by ``t``. That holds for exact primitives; a non-exact
    primitive that underestimates the distance far outside could reach further, and
    the margins of growing operators built on it are then estimates.
    """
    own = getattr(field, "level_bounds", None)
    if own is not None:
        return own(level)
    return _grow(np.asarray(field.bounds(), dtype=np.float64), level)


def _grow(box: np.ndarray, by: float) -> np.ndarray:
    return box + np.array([-by, -by, by, by])


def _box(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The box ``[lo, hi]``; an empty axis (lo > hi) collapses to its midpoint."""
    empty = lo > hi
    mid = 0.5 * (lo + hi)
    return np.concatenate([np.where(empty, mid, lo), np.where(empty, mid, hi)])


def _hull(boxes: list[np.ndarray]) -> np.ndarray:
    b = np.array(boxes)
    return np.concatenate([b[:, :2].min(axis=0), b[:, 2:].max(axis=0)])


def _overlap(boxes: list[np.ndarray]) -> np.ndarray:
    b = np.array(boxes)
    return _box(b[:, :2].max(axis=0), b[:, 2:].min(axis=0))


def _check_operands(of: list[Field]) -> list[Field]:
    if not isinstance(of, (list, tuple)) or len(of) < 2:
        raise SpecError("of", f"must be a list of at least two FIELDs, got {of!r}")
    return list(of)


# --------------------------------------------------------------------------------------
# Placement and scale: exact operands stay exact (rigid motions and uniform scaling
# multiply every distance by the same factor).
# --------------------------------------------------------------------------------------

class _Leveled(Field):
    """An operator that knows ``level_bounds(t)``; its ``bounds()`` is the level 0 box."""

    def level_bounds(self, level: float) -> np.ndarray:
        raise NotImplementedError

    def bounds(self):
        return self.level_bounds(0.0)


@operator("transform", Param("of", "field", REQUIRED, "the field to place"))
class Transform(_Leveled):
    """``of`` rotated by ``angle`` (radians, counter-clockwise) then moved by ``offset`` (m).

    f(p) = g(R^T (p - t)); gradient R grad g. Exact when ``of`` is. In a spec,
    ``offset`` and ``angle`` are the placement keys every FIELD accepts (the spec
    builder applies them once), so ``{op = "transform", of = F, offset = [1, 0]}``
    and ``F`` with ``offset = [1, 0]`` are the same field.
    """

    def __init__(self, of: Field, offset=(0.0, 0.0), angle: float = 0.0):
        self.of = of
        self.offset = np.array(offset, dtype=np.float64)
        self.angle = float(angle)
        self.exact = of.exact
        c, s = math.cos(self.angle), math.sin(self.angle)
        self.rotation = np.array([[c, -s], [s, c]])


    def level_bounds(self, level: float) -> np.ndarray:
        """The box of the rotated and moved operand box at ``level``."""
        x0, y0, x1, y1 = level_bounds(self.of, level)
        if not np.all(np.isfinite([x0, y0, x1, y1])):
            return _ALL_PLANE.copy()
        corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) @ self.rotation.T
        return np.concatenate([corners.min(axis=0), corners.max(axis=0)]) + np.tile(
            self.offset, 2)


@operator("translate", Param("of", "field", REQUIRED, "the field to move"),
          Param("by", "vec2", REQUIRED, "displacement [x, y], m"))
class Translate(Transform):
    """``of`` moved by ``by`` = [x, y] (m): f(p) = g(p - by); exact when ``of`` is.

    The displacement is named ``by``, not ``offset``: ``offset`` and ``angle`` are
    placement keys of every FIELD, which the spec builder applies on top.
    """

    def __init__(self, of: Field, by=(0.0, 0.0)):
        super().__init__(of, offset=by)


@operator("rotate", Param("of", "field", REQUIRED, "the field to rotate"),
          Param("by", "real", REQUIRED, "angle, radians, counter-clockwise"))
class Rotate(Transform):
    """``of`` rotated about the origin by ``by`` radians, counter-clockwise.

    f(p) = g(R^T p), gradient R grad g; exact when ``of`` is. Named ``by`` for the
    same reason as ``translate``.
    """

    def __init__(self, of: Field, by: float = 0.0):
        super().__init__(of, angle=by)


@operator("scale", Param("of", "field", REQUIRED, "the field to scale"),
          Param("factor", "positive", REQUIRED, "uniform scale factor s > 0"))
class Scale(_Leveled):
    """``of`` scaled by ``factor`` s > 0 about the origin: f(p) = s g(p / s).

    Gradient: grad f(p) = s (1/s) grad g(p / s) = grad g(p / s). Uniform scaling
    multiplies every distance by s, so the result is exact when ``of`` is.
    """

    def __init__(self, of: Field, factor: float):
        self.of = of
        self.factor = check_number(factor, "factor", low=0.0, low_open=True)
        self.exact = of.exact


    def level_bounds(self, level: float) -> np.ndarray:
        """f <= t  <=>  g(p / s) <= t / s."""
        return self.factor * level_bounds(self.of, level / self.factor)


# --------------------------------------------------------------------------------------
# Boolean combinations (n-ary; the first operand wins ties).
# --------------------------------------------------------------------------------------

class _Select(_Leveled):
    """Common part of union / intersection / difference: pick one operand per point
    (the first one on a tie)."""

    exact = False

    def __init__(self, of: list[Field]):
        self.of = _check_operands(of)


@operator("union", Param("of", "fields", REQUIRED, "two or more FIELDs"))
class Union(_Select):
    """Union of two or more fields: f = min_i f_i; gradient of the smallest (first on ties).

    Exact outside (the distance to a union is the smallest distance) but a bound
    inside: where operands overlap, the depth below the union's boundary can exceed
    every |f_i|. Hence ``exact = False``. Bounds: the hull of the operands' boxes.
    """

    def level_bounds(self, level: float) -> np.ndarray:
        """min_i f_i <= t when some f_i <= t."""
        return _hull([level_bounds(f, level) for f in self.of])


@operator("intersection", Param("of", "fields", REQUIRED, "two or more FIELDs"))
class Intersection(_Select):
    """Intersection of two or more fields: f = max_i f_i; gradient of the largest.

    Exact inside (the depth in an intersection is the smallest depth), a bound
    outside, hence ``exact = False``. Bounds: the overlap of the operands' boxes
    (a zero-size box where they do not overlap).
    """

    def level_bounds(self, level: float) -> np.ndarray:
        """max_i f_i <= t when every f_i <= t."""
        return _overlap([level_bounds(f, level) for f in self.of])


@operator("difference", Param("of", "fields", REQUIRED, "[A, B, ...]: A minus the rest"))
class Difference(_Select):
    """The first field minus all the others: f = max(a, -b_1, -b_2, ...).

    Gradient: that of the largest term (negated for a subtracted field; ``a`` wins
    ties). Exact inside, a bound outside, hence ``exact = False``. Bounds: those
    of the first field.
    """

    def level_bounds(self, level: float) -> np.ndarray:
        """max(a, ...) <= t implies a <= t."""
        return level_bounds(self.of[0], level)


@operator("xor", Param("of", "fields", REQUIRED, "two or more FIELDs"))
class Xor(_Leveled):
    """Points inside an odd number of the fields: xor(a, b) = max(min(a, b), -max(a, b)).

    More than two operands fold from the left: xor(xor(a, b), c). Gradient by
    branch: min and max take ``a`` on a tie, the outer max takes the ``min`` term.
    For exact operands it is exact outside the region (there it equals min(a, b)
    outside both fields and -max(a, b) inside both) and a bound inside, hence
    ``exact = False``. Bounds: the hull of the operands' boxes.
    """

    exact = False

    def __init__(self, of: list[Field]):
        self.of = _check_operands(of)


    def level_bounds(self, level: float) -> np.ndarray:
        """xor <= t implies min(a, b) <= t."""
        return _hull([level_bounds(f, level) for f in self.of])


# --------------------------------------------------------------------------------------
# Smooth blends.
#
# Every compact kernel is written with x = |a - b| / k in [0, 1] and h = 1 - x:
#     smin(a, b) = min(a, b) - k w(h),   w(0) = w'(0) = 0,   w'(1) = 1/2,
# so smin = min wherever |a - b| >= k (k is the width of the blend zone). With a
# the smaller operand, d smin / da = 1 - w'(h) and d smin / db = w'(h): the
# gradient is the blend of the two gradients with weight m = w'(h) on the larger
# operand, m in [0, 1/2], m = 1/2 on a tie for every kernel (so ties are
# symmetric, hence deterministic). The weights are convex, so |grad| <= 1 and the
# blend is a bound (see the module docstring). The largest dip, at a = b, is
# k w(1): the region f <= 0 can grow by that much (``level_bounds``).
#
#   polynomial  w = h^2 / 4,  m = h / 2                (C1; Quilez's quadratic)
#   cubic       w = h^3 / 6,  m = h^2 / 2              (C2)
#   circular    w = (1 + h - sqrt(2 - x^2)) / 2,  m = (1 - x / sqrt(2 - x^2)) / 2
#               (C1; the level sets of smin in the (a, b) plane are quarter circles
#               of radius k tangent to the two branches of min: with u = a - smin,
#               v = b - smin one checks (u - k)^2 + (v - k)^2 = k^2)
#   exponential smin = -s ln(exp(-a/s) + exp(-b/s)) = min - s ln(1 + exp(-|a-b|/s)),
#               m = 1 / (1 + exp(|a - b| / s)) (C-infinity, infinite support). We set
#               s = k / (4 ln 2) so that the dip at a = b is k / 4, as for the
#               polynomial kernel; beyond |a - b| = k it differs from min by less
#               than s ln(1 + e^-2.77) = 0.022 k.
# Kernels as in Quilez's "smooth minimum" article, renormalized so that k is the
# blend width of every compact kernel.
# --------------------------------------------------------------------------------------

#: blend name -> the largest dip below min, over k (at a = b: k w(1)). The kernels are
#: ``blend_kernels._blend`` (index ``opcodes.BLEND_INDEX``).
BLENDS: dict[str, float] = {
    "polynomial": 0.25,
    "cubic": 1.0 / 6.0,
    "circular": 1.0 - math.sqrt(0.5),
    "exponential": 0.25,
}


def smooth_min(a: np.ndarray, b: np.ndarray, k: float,
               blend: str) -> tuple[np.ndarray, np.ndarray]:
    """Smooth minimum of ``a`` and ``b`` (N,) with blend width ``k`` (m) and kernel ``blend``.

    Returns ``(value, weight_b)`` where ``weight_b`` = d value / d b in [0, 1] and
    d value / d a = 1 - weight_b (see the derivation above): the compiled kernels'
    ``blend_kernels.smooth_min_arrays``.
    """
    a = np.ascontiguousarray(a, dtype=np.float64).ravel()
    b = np.ascontiguousarray(b, dtype=np.float64).ravel()
    value, weight = np.empty(len(a)), np.empty(len(a))
    smooth_min_arrays(a, b, float(k), BLEND_INDEX[blend], value, weight)
    return value, weight


_SMOOTH_PARAMS = (
    Param("k", "positive", REQUIRED, "blend width, m (the blend acts where |a - b| < k)"),
    Param("blend", "str", "polynomial", "kernel: " + ", ".join(BLENDS), choices=tuple(BLENDS)),
)


class _Smooth(_Leveled):
    """Common part of the smooth blends: operands, width ``k`` and kernel ``blend``."""

    exact = False

    def __init__(self, of: list[Field], k: float, blend: str = "polynomial"):
        self.of = _check_operands(of)
        self.k = check_number(k, "k", low=0.0, low_open=True)
        if blend not in BLENDS:
            raise SpecError("blend", f"must be one of {', '.join(BLENDS)}; got {blend!r}")
        self.blend = blend
        self.dip = BLENDS[blend] * self.k


@operator("smooth_union", Param("of", "fields", REQUIRED, "two or more FIELDs"),
          *_SMOOTH_PARAMS)
class SmoothUnion(_Smooth):
    """Smooth union: f = smin(a, b) (see ``smooth_min``); more operands fold from the left.

    Equals the union wherever |a - b| >= k (compact kernels); in the blend zone each
    fold lies below min(a, b) by at most ``dip`` = k w(1) (k/4 polynomial, k/6
    cubic, 0.293 k circular, k/4 exponential), so the shape grows there. Gradient:
    (1 - m) grad a + m grad b. A bound (``exact = False``). Bounds: smin <= t
    implies min(a, b) <= t + dip, so each fold grows the hull by ``dip``.
    """


    def level_bounds(self, level: float) -> np.ndarray:
        """Fold i (of n - 1) needs its operands at level t + (n - i) dip."""
        box = level_bounds(self.of[0], level + (len(self.of) - 1) * self.dip)
        for i, f in enumerate(self.of[1:], start=1):
            box = _hull([box, level_bounds(f, level + (len(self.of) - i) * self.dip)])
        return box


@operator("smooth_intersection", Param("of", "fields", REQUIRED, "two or more FIELDs"),
          *_SMOOTH_PARAMS)
class SmoothIntersection(_Smooth):
    """Smooth intersection: f = smax(a, b) = -smin(-a, -b); more operands fold from the left.

    Equals the intersection where |a - b| >= k; in the blend zone it lies above
    max(a, b), so the shape only shrinks. Gradient (1 - m) grad a + m grad b with m
    the smooth-min weight of -b. A bound (``exact = False``). Bounds: smax >= max,
    so the overlap of the operands' boxes.
    """


    def level_bounds(self, level: float) -> np.ndarray:
        """smax <= t implies every operand <= t."""
        return _overlap([level_bounds(f, level) for f in self.of])


@operator("smooth_difference", Param("of", "fields", REQUIRED, "[A, B, ...]: A minus the rest"),
          *_SMOOTH_PARAMS)
class SmoothDifference(_Smooth):
    """Smooth difference: f = smax(a, -b) = -smin(-a, b), folded over b_1, b_2, ...

    Equals max(a, -b) where |a + b| >= k; in the blend zone it lies above it, so
    the cut is rounded by removing material. Gradient (1 - m) grad a - m grad b. A
    bound (``exact = False``). Bounds: smax(a, .) >= a, so those of the first field.
    """


    def level_bounds(self, level: float) -> np.ndarray:
        """smax(a, .) <= t implies a <= t."""
        return level_bounds(self.of[0], level)


# --------------------------------------------------------------------------------------
# Offsets.
# --------------------------------------------------------------------------------------

@operator("round", Param("of", "field", REQUIRED, "the field to round"),
          Param("r", "nonneg", REQUIRED, "rounding radius, m"))
class Round(_Leveled):
    """``of`` grown by ``r`` (m): f = g - r, gradient grad g (corners become arcs of radius r).

    For an exact ``of`` the result is exact where g >= r (outside: walking from p
    to its nearest point lowers g at unit rate) and, when the shape is convex,
    everywhere (the support function of the grown set is h + r). Inside a
    non-convex shape it is only a bound: rounding the annulus ``onion(circle R=1,
    t=0.2)`` by r = 0.9 closes the hole, yet f(0) = -0.1 while the depth is 2.1.
    Convexity is not known here, hence ``exact = False``. Bounds: those of ``of``
    at level r.
    """

    exact = False

    def __init__(self, of: Field, r: float):
        self.of = of
        self.r = check_number(r, "r", low=0.0)


    def level_bounds(self, level: float) -> np.ndarray:
        """g - r <= t  <=>  g <= t + r."""
        return level_bounds(self.of, level + self.r)


@operator("onion", Param("of", "field", REQUIRED, "the field to hollow"),
          Param("thickness", "positive", REQUIRED, "half-thickness t of the shell, m"))
class Onion(_Leveled):
    """A shell of half-thickness t around the boundary of ``of``: f = |g| - t.

    Gradient sign(g) grad g, with sign(0) = +1. For an exact ``of`` the result is
    exact outside the shell (|g| >= t: walk to the nearest boundary point) but only
    a bound inside it, where the depth t - |g| is reached only if one can move away
    from the boundary at unit rate. Counter-examples: a circle of radius 1 with
    t = 1.2 (no hole: at r = 0.5 the formula gives -0.7, the depth is 1.7); a 2 x 2
    box with t = 0.3 at (0.8, 0.75) near its medial axis (formula -0.1, depth
    0.112). Hence ``exact = False``. Bounds: those of ``of`` at level t.
    """

    exact = False

    def __init__(self, of: Field, thickness: float):
        self.of = of
        self.thickness = check_number(thickness, "thickness", low=0.0, low_open=True)


    def level_bounds(self, level: float) -> np.ndarray:
        """|g| - t <= s implies g <= s + t."""
        return level_bounds(self.of, level + self.thickness)
