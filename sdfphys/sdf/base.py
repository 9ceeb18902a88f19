"""The Field interface, parameter declarations and the registries of primitives and operators.

Conventions (every field in ``sdfphys.sdf`` follows them):

- Units are metres; points are float64 arrays of shape ``(N, 2)`` in the field's
  own (local) frame.
- Sign: ``f(p) < 0`` inside, ``> 0`` outside, ``0`` on the boundary.
- ``evaluate(p)`` returns ``(d, g)``: ``d`` of shape ``(N,)`` and ``g`` of shape
  ``(N, 2)``, the gradient of ``d``. For an exact field ``|g| = 1`` everywhere;
  where the gradient is not defined (a circle's centre, a medial axis, a vertex)
  ``g`` is a deterministic unit vector taken from one side (a subgradient), never
  NaN. Gradients are analytic (Quilez's ``sdg*`` forms, or the closest-point
  branch); numeric schemes live in ``gradient.py`` for studies only.
- ``exact``: True when ``|f|`` is the Euclidean distance to the boundary. False
  marks a *bound*: ``|f|`` never exceeds the true distance, so ``|f|`` is still a
  safe sphere-tracing step, but depths read from it may be underestimated.
- ``bounds()``: a local axis-aligned box ``(xmin, ymin, xmax, ymax)`` that contains
  the region ``f <= 0`` (infinite components for unbounded fields such as a
  half-plane).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import SpecError, check_int, check_number, check_points, check_vec2
from ..vec2 import TINY

__all__ = [
    "FALLBACK_DIRECTION",
    "OPERATORS",
    "PRIMITIVES",
    "Field",
    "Param",
    "as_points",
    "operator",
    "primitive",
    "safe_normalize",
]

#: Direction used wherever a gradient or normal is undefined (a zero vector).
FALLBACK_DIRECTION = np.array([1.0, 0.0])

#: ``compiled.evaluate``, which ``sdf.compiled`` registers when imported (``sdfphys.sdf``
#: imports it with the primitives, before any field exists). Not imported here: the
#: kernels' cache stamps follow import statements (``_numba_cache``), and every module
#: importing this one would then recompile at each edit of the field compiler.
_EVALUATOR: list[Callable[..., tuple[np.ndarray, np.ndarray]]] = []


def as_points(points: Any) -> np.ndarray:
    """``points`` as a float64 array of shape (N, 2) (a single point becomes (1, 2))."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim == 1 and p.shape[0] == 2:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"points must have shape (N, 2), got {p.shape}")
    return p


def safe_normalize(v: np.ndarray, fallback: np.ndarray = FALLBACK_DIRECTION) -> np.ndarray:
    """Rows of ``v`` (N, 2) scaled to unit length; zero rows become ``fallback``."""
    n = np.hypot(v[:, 0], v[:, 1])
    ok = n > TINY
    if ok.all() and v.dtype == np.float64:            # the common case, without masks
        return v / n[:, None]
    out = np.empty_like(v)
    out[ok] = v[ok] / n[ok, None]
    out[~ok] = fallback
    return out


class Field:
    """A 2D signed distance field (see the module docstring for the conventions)."""

    #: True: |f| is the Euclidean distance. False: |f| is a lower bound of it.
    exact: bool = True
    #: The canonical spec dict this field was built from (set by ``sdf.field``).
    spec: dict | None = None

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance (N,) and gradient (N, 2) at ``points`` (N, 2), local frame.

        Every primitive and operator of ``sdfphys.sdf`` runs its compiled program
        (``compiled.evaluate``); a field of your own overrides this method.
        """
        return _EVALUATOR[0](self, as_points(points), inherited=True)

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Distance (N,) at ``points`` (N, 2); cheaper than ``evaluate`` where overridden."""
        return self.evaluate(as_points(points))[0]

    def bounds(self) -> np.ndarray:
        """Local AABB ``[xmin, ymin, xmax, ymax]`` containing the region f <= 0."""
        raise NotImplementedError

    def normal(self, points: np.ndarray) -> np.ndarray:
        """Unit outward normals (N, 2): the gradient, normalized (bounds may not be unit)."""
        return safe_normalize(self.evaluate(as_points(points))[1])

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.spec!r})" if self.spec else type(self).__name__


# --------------------------------------------------------------------------------------
# Parameter declarations: one table drives validation of specs from scene files.
# --------------------------------------------------------------------------------------

_KINDS: dict[str, Callable[[Any, str], Any]] = {
    "real": lambda v, p: check_number(v, p),
    "positive": lambda v, p: check_number(v, p, low=0.0, low_open=True),
    "nonneg": lambda v, p: check_number(v, p, low=0.0),
    "unit": lambda v, p: check_number(v, p, low=0.0, high=1.0),
    "vec2": lambda v, p: check_vec2(v, p),
    "size2": lambda v, p: check_vec2(v, p, positive=True),
    "points": lambda v, p: check_points(v, p, minimum=2),
    "polygon": lambda v, p: check_points(v, p, minimum=3),
    "int": lambda v, p: check_int(v, p),
    "count": lambda v, p: check_int(v, p, low=2, high=1000),
    "radii4": lambda v, p: _check_radii4(v, p),
    "str": lambda v, p: _check_str(v, p),
}


def _check_radii4(value: Any, path: str) -> tuple[float, ...]:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        r = check_number(value, path, low=0.0)
        return (r, r, r, r)
    if not isinstance(value, (list, tuple)) or len(value) != 4:
        raise SpecError(path, f"must be a number or 4 corner radii, got {value!r}")
    return tuple(check_number(r, f"{path}[{i}]", low=0.0) for i, r in enumerate(value))


def _check_str(value: Any, path: str) -> str:
    if not isinstance(value, str):
        raise SpecError(path, f"must be a string, got {value!r}")
    return value


@dataclass(frozen=True)
class Param:
    """One constructor parameter of a primitive or operator.

    ``kind`` is one of: real, positive, nonneg, unit, vec2, size2 (two positive
    numbers), points (>= 2 points), polygon (>= 3 points), int, count (2..1000),
    radii4 (a number or four non-negative corner radii), str, field (one nested
    FIELD), fields (a list of at least two FIELDs). ``default`` of ``REQUIRED``
    makes the parameter mandatory. ``choices`` restricts a str parameter.
    """

    name: str
    kind: str
    default: Any = None
    doc: str = ""
    choices: tuple[str, ...] = ()

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def check(self, value: Any, path: str) -> Any:
        value = _KINDS[self.kind](value, path)
        if self.choices and value not in self.choices:
            raise SpecError(path, f"must be one of {', '.join(self.choices)}; got {value!r}")
        return value


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED = _Required()


@dataclass(frozen=True)
class Entry:
    """A registered primitive or operator: its constructor and declared parameters."""

    name: str
    cls: type
    params: tuple[Param, ...]
    doc: str


#: name -> constructor of every primitive, e.g. ``PRIMITIVES["circle"](radius=1.0)``.
PRIMITIVES: dict[str, type] = {}
#: name -> constructor of every operator, e.g. ``OPERATORS["union"](a, b)``.
OPERATORS: dict[str, type] = {}
_PRIMITIVE_ENTRIES: dict[str, Entry] = {}
_OPERATOR_ENTRIES: dict[str, Entry] = {}


def primitive(name: str, *params: Param) -> Callable[[type], type]:
    """Class decorator registering a primitive under ``name`` with its parameters.

    The class is constructed with keyword arguments named as the params.
    """
    def register(cls: type) -> type:
        if name in PRIMITIVES:
            raise RuntimeError(f"primitive {name!r} registered twice")
        PRIMITIVES[name] = cls
        _PRIMITIVE_ENTRIES[name] = Entry(name, cls, params, (cls.__doc__ or "").strip())
        return cls
    return register


def operator(name: str, *params: Param) -> Callable[[type], type]:
    """Class decorator registering an operator (``{op = name, ...}`` in a spec)."""
    def register(cls: type) -> type:
        if name in OPERATORS:
            raise RuntimeError(f"operator {name!r} registered twice")
        OPERATORS[name] = cls
        _OPERATOR_ENTRIES[name] = Entry(name, cls, params, (cls.__doc__ or "").strip())
        return cls
    return register
