"""numpy evaluation of every sdfphys.sdf primitive and operator: a test oracle.

The package evaluates its fields with one implementation, the compiled program
(``sdfphys.sdf.compiled``: ``Field.evaluate`` runs it). The vectorized numpy code the
fields had before (Quilez's formulas written with numpy arrays, the closest-point
gradients, the same fallback directions) lives here, one module per package module,
so that tests can compare the two point by point: most kinds agree bit for bit; where
numpy's SIMD transcendentals round differently (star's arctan2, the Bezier's cbrt and
arccos, the exponential blend's exp and log1p) within a few ulps
(tests/test_compiled_fields*.py give the bounds).

``evaluate(field, points)`` -> (value (N,), gradient (N, 2)), operands of operators
evaluated by this oracle too; a field of another class (a user's own) by its own
``evaluate``.
"""

from __future__ import annotations

import numpy as np

from sdfphys.sdf import conics as _conics
from sdfphys.sdf import curved as _curved
from sdfphys.sdf import folded as _folded
from sdfphys.sdf import grid as _grid
from sdfphys.sdf import operators as _operators
from sdfphys.sdf import polygonal as _polygonal
from sdfphys.sdf.base import as_points

from . import conics, curved, folded, grid, operators, polygonal

__all__ = ["ORACLES", "evaluate"]

#: Field class -> its numpy evaluation (subclasses resolve through their MRO).
ORACLES = {
    getattr(package, name): getattr(oracle, f"{name}_evaluate")
    for package, oracle in ((_polygonal, polygonal), (_curved, curved), (_conics, conics),
                            (_folded, folded), (_grid, grid), (_operators, operators))
    for name in dir(oracle)
    if name.endswith("_evaluate") and not name.startswith("__")
    for name in [name[: -len("_evaluate")]]
}


def evaluate(field, points) -> tuple[np.ndarray, np.ndarray]:
    """Value (N,) and gradient (N, 2) of ``field`` at ``points`` (N, 2), in numpy."""
    p = as_points(points)
    for kind in type(field).__mro__:
        oracle = ORACLES.get(kind)
        if oracle is not None:
            return oracle(field, p)
    return field.evaluate(p)
