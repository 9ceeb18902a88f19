"""Signed distance fields with analytic gradients, vectorized over (N, 2) points.

``field(spec)`` builds a field from the nested dicts a scene file uses;
``PRIMITIVES`` and ``OPERATORS`` map names to constructors. Conventions (signs,
shapes, exactness) are in ``sdfphys.sdf.base``.
"""

from . import (  # noqa: F401  (the primitives register; compiled registers the evaluator)
    compiled,
    conics,
    curved,
    folded,
    gradient,
    grid,
    image,
    operators,
    polygonal,
)
from .base import FALLBACK_DIRECTION, OPERATORS, PRIMITIVES, Field, Param, safe_normalize
from .build import field

__all__ = [
           "FALLBACK_DIRECTION",
           "OPERATORS",
           "PRIMITIVES",
           "Field",
           "Param",
           "field",
           "safe_normalize",
]
