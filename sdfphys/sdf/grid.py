"""Baked grids: a field sampled once on a regular grid, then interpolated bilinearly.

``GridField`` (operator ``bake``) samples any bounded field at the nodes of a
square grid of spacing ``cell`` = h covering its bounds plus ``margin``, optionally
clamps the samples to a narrow band and quantizes them to uint8 (after the baked
distance fields of game engines; seed 003). A query interpolates the four nodes
around the point bilinearly; the gradient is that of the interpolant, so value and
gradient are consistent (the gradient is the exact derivative of the value inside
every cell, and jumps across cell edges). Baking costs one evaluation of the
source per node; a query costs four array look-ups, whatever the source.

Error bounds (inside the grid; I is the bilinear interpolant, f the source).

- Smooth cells. Bilinear interpolation is the tensor product of linear ones,
  I = I_x I_y, so f - I f = (f - I_x f) + I_x (f - I_y f). Linear interpolation on
  an interval of length h errs by at most h^2/8 max|f''|, and I_x is a convex
  combination, hence |f - I f| <= h^2/8 (max|f_xx| + max|f_yy|). For an exact SDF
  the Hessian has eigenvalues 0 (along the gradient) and 1/rho, rho being the
  distance from the point to the centre of curvature of its nearest boundary point
  (for a circle, to its centre; for a polygon, to the nearest vertex in a vertex's
  region, infinite along an edge). With rho >= rho_min over the cell,
  ``|f - I f| <= h^2 / (4 rho_min)``: second order, exact where f is linear.
- Kinks (medial axis inside, vertices, blends of kinks): for any 1-Lipschitz f,
  |f(p) - sum w_i f(c_i)| <= sum w_i |p - c_i| <= sqrt(sum w_i |p - c_i|^2)
  = h sqrt(tx (1 - tx) + ty (1 - ty)) <= ``h / sqrt(2)`` (Jensen; w_i the bilinear
  weights): first order.
- Gradient: each difference quotient (v10 - v00) / h is f_x at some point of the
  cell edge, within sqrt(2) h of p, so in smooth cells |grad I f - grad f| <=
  ``2 h / rho_min`` (first order).
- Quantization to uint8 with scale r (the band) stores d at one of 256 levels
  2 r / 255 apart, a value error <= ``r / 255`` at nodes and, by convexity, at every
  interpolated point; the gradient error it adds is <= 2 sqrt(2) r / (255 h).
- Band: values beyond +-band are clamped (by design, not an error of the scheme).

Because interpolation can overestimate the distance (e.g. outside a convex shape,
where f is convex) as well as underestimate it, a baked field is neither exact nor
a strict bound: ``exact = False``, and |f| can exceed the true distance by at most
the bounds above.

Narrow band. With ``band`` = b, node values are clamped to [-b, b]; in a cell whose
four nodes are all clamped the interpolant is flat: the value is +-b and the
gradient is zero (the band carries no direction, callers must treat |f| = b as
"far"); in a partly clamped cell the gradient still points from inside to outside.

Outside the grid (q: the nearest point of the grid box, delta = |p - q|, m = the
margin of the side p lies beyond, the lesser of two beyond a corner; v = the
interpolant at q):
    f(p) = sqrt(max(v, 0)^2 + delta^2 + 2 m delta) + min(v, 0).
This is continuous with the inside and grows like delta + m far away. It stays a
lower bound of the source's distance when v is: the shape lies in the source's
bounds, at least m inside that side of the grid box, so for every shape point s,
|p - s|^2 = |q - s|^2 + delta^2 + 2 (p - q).(q - s) >= |q - s|^2 + delta^2 + 2 m delta
(per axis, q - s has the sign of p - q and magnitude >= m where p - q != 0). It is
exact off a flat side of the shape parallel to the grid's side when v at q is the
true distance and m that side's margin. A baked field has one margin all round; a
carved dynamic body's piece (``sdfphys.pieces``) one per side, [x low, y low, x high,
y high] (``margins``).
With a band the result is clamped to b as inside.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import SpecError, check_number
from .base import REQUIRED, Field, Param, operator
from .build import field as build_field

__all__ = ["MAX_NODES", "GridField", "bilinear_error_bound"]

#: Largest number of grid nodes a bake may allocate (float64: 32 MiB).
MAX_NODES = 1 << 22

_CHUNK = 1 << 16


def bilinear_error_bound(cell: float, radius: float | None = None) -> float:
    """Bound on |f - I f| for bilinear interpolation of a 1-Lipschitz field on cells of size h.

    ``radius``: the smallest radius of curvature rho of the level sets over the
    cell (for an exact SDF: distance to the centre of curvature, see the module
    docstring), giving h^2 / (4 rho); None gives the bound near kinks, h / sqrt(2).
    The smaller of the two applies when both are known.
    """
    kink = cell / math.sqrt(2.0)
    if radius is None:
        return kink
    return min(kink, cell * cell / (4.0 * radius))


@operator("bake",
          Param("of", "field", REQUIRED, "the field to sample (bounded)"),
          Param("cell", "positive", REQUIRED, "node spacing h, m"),
          Param("margin", "nonneg", None, "space kept around the field's bounds, m "
                "(default 2 cells)"),
          Param("band", "positive", None, "narrow band half-width b, m: values clamped "
                "to [-b, b] (default: no band)"),
          Param("quantize", "str", "none", "node storage: none (float64) or uint8",
                choices=("none", "uint8")))
class GridField(Field):
    """A field baked on a grid of spacing ``cell`` (m), bilinearly interpolated.

    ``of``: a bounded Field or a FIELD spec dict (e.g. ``{"type": "polygon",
    "points": ...}``). ``margin`` (m, default 2 cells) is added around
    ``of.bounds()``. ``band`` (m) clamps stored values to [-band, band].
    ``quantize="uint8"`` stores each node as one byte, d = s / 255 * 2 r - r with
    r = band (or, without a band, the largest |d| on the grid): error <= r / 255.
    Error bounds, narrow band and extrapolation outside the grid are described in
    the module docstring. Never exact (``exact = False``).
    """

    exact = False

    def __init__(self, of: Field | Mapping, cell: float, margin: float | None = None,
                 band: float | None = None, quantize: str = "none"):
        source = build_field(of, "of")
        self.cell = h = check_number(cell, "cell", low=0.0, low_open=True)
        self.margin = 2.0 * h if margin is None else check_number(margin, "margin", low=0.0)
        self.margins = np.full(4, self.margin)
        self.band = None if band is None else check_number(band, "band", low=0.0,
                                                            low_open=True)
        if quantize not in ("none", "uint8"):
            raise SpecError("quantize", f"must be one of none, uint8; got {quantize!r}")
        self.quantize = quantize

        box = np.asarray(source.bounds(), dtype=np.float64)
        if not np.all(np.isfinite(box)):
            raise SpecError("of", "is unbounded (infinite bounds); only a bounded field "
                                  "can be baked")
        lo, hi = box[:2] - self.margin, box[2:] + self.margin
        counts = np.ceil((hi - lo) / h) + 1.0
        if not counts[0] * counts[1] <= MAX_NODES:
            raise SpecError("cell", f"{h:g} is too small for a field of size "
                                    f"{hi[0] - lo[0]:g} x {hi[1] - lo[1]:g}: more than "
                                    f"{MAX_NODES} grid nodes")
        self.shape = (max(int(counts[0]), 2), max(int(counts[1]), 2))
        # Centre the grid on the grown box: the spare part of the last cell is split.
        self.origin = lo - 0.5 * ((np.array(self.shape) - 1) * h - (hi - lo))
        values = self._sample(source)
        if self.band is not None:
            values = np.clip(values, -self.band, self.band)
        if quantize == "uint8":
            top = self.band if self.band is not None else float(np.max(np.abs(values)))
            self.scale = top if top > 0.0 else 1.0
            codes = np.rint((values + self.scale) * (255.0 / (2.0 * self.scale)))
            self._codes = np.clip(codes, 0, 255).astype(np.uint8)
            self._values = None
        else:
            self.scale = None
            self._values = values
        self._bounds = self.level_bounds(0.0)

    @classmethod
    def from_values(cls, values: np.ndarray, origin, cell: float, margin: Any = 0.0,
                    band: float | None = None) -> GridField:
        """A float64 grid holding ``values`` (nx, ny), m, node (i, j) at ``origin +
        cell * (i, j)`` (m), with no source field (``spec`` None): terrain from an image
        (``sdf.image``) and the editable grids of ``sdfphys.terrain``. ``margin`` (m, one
        for all sides or (4,) [x low, y low, x high, y high]) enters the extrapolation
        outside the grid (see the module docstring: 0 keeps it a lower bound whatever
        the values); ``band`` clamps as in ``bake``."""
        grid = cls.__new__(cls)
        grid.cell = check_number(cell, "cell", low=0.0, low_open=True)
        sides = np.broadcast_to(np.asarray(margin, dtype=np.float64), (4,))
        grid.margins = np.array([check_number(float(m), f"margin[{k}]", low=0.0)
                                 for k, m in enumerate(sides)])
        grid.margin = float(grid.margins.min())
        grid.band = band
        grid.quantize = "none"
        grid.scale = None
        v = np.array(values, dtype=np.float64)
        if v.ndim != 2 or min(v.shape) < 2:
            raise SpecError("values", f"must be (nx, ny) with nx, ny >= 2, got {v.shape}")
        grid._values = v if band is None else np.clip(v, -band, band)
        grid._codes = None
        grid.shape = v.shape
        grid.origin = np.array(origin, dtype=np.float64)
        grid._bounds = grid.level_bounds(0.0)
        return grid

    # ----------------------------------------------------------------------------------

    def _sample(self, source: Field) -> np.ndarray:
        """Source distances at the nodes, (nx, ny), in chunks of rows to bound memory."""
        nx, ny = self.shape
        xs = self.origin[0] + self.cell * np.arange(nx)
        ys = self.origin[1] + self.cell * np.arange(ny)
        rows = max(1, _CHUNK // ny)
        out = np.empty(self.shape)
        for start in range(0, nx, rows):
            gx, gy = np.meshgrid(xs[start:start + rows], ys, indexing="ij")
            pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
            out[start:start + rows] = source.distance(pts).reshape(gx.shape)
        return out

    @property
    def values(self) -> np.ndarray:
        """Stored node values (nx, ny), m, decoded if quantized; node (i, j) is at
        ``origin + cell * (i, j)``."""
        if self._values is not None:
            return self._values
        return self._decode(self._codes)

    def _decode(self, codes: np.ndarray) -> np.ndarray:
        return codes * (2.0 * self.scale / 255.0) - self.scale

    @property
    def quantization_error(self) -> float:
        """Largest value error added by uint8 storage, m (r / 255; 0 without it)."""
        return 0.0 if self.scale is None else self.scale / 255.0

    # ----------------------------------------------------------------------------------

    def bounds(self):
        return self._bounds.copy()

    def level_bounds(self, level: float) -> np.ndarray:
        """Box of the cells where some node is <= ``level``, grown to cover the outside.

        The interpolant lies between its four node values, so a cell whose nodes all
        exceed the level has none of the region. Outside the grid f <= t needs
        delta <= t - min(v, 0) from a boundary point with v <= t. At or beyond the
        band the region is the whole plane. No such cell: an empty region, given as
        a zero-size box at the grid's centre.
        """
        if self.band is not None and level >= self.band:
            return np.array([-np.inf, -np.inf, np.inf, np.inf])
        v = self.values
        corners = np.minimum(np.minimum(v[:-1, :-1], v[1:, :-1]),
                             np.minimum(v[:-1, 1:], v[1:, 1:]))
        ii, jj = np.nonzero(corners <= level)
        if ii.size == 0:
            centre = self.origin + 0.5 * self.cell * (np.array(self.shape) - 1)
            return np.concatenate([centre, centre])
        box = np.concatenate([self.origin + self.cell * np.array([ii.min(), jj.min()]),
                              self.origin + self.cell * np.array([ii.max(), jj.max()]) + self.cell])
        rim = min(v[0].min(), v[-1].min(), v[:, 0].min(), v[:, -1].min())
        if rim <= level:
            grow = level - min(rim, 0.0)
            box = box + np.array([-grow, -grow, grow, grow])
        return box
