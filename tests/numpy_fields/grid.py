"""numpy evaluation of the fields of ``sdfphys.sdf.grid``: a test oracle.

The vectorized numpy code these primitives had before their compiled kernels became
their one implementation (``sdfphys.sdf.compiled``); tests compare the two."""

from __future__ import annotations

import numpy as np

from sdfphys.sdf.base import as_points


def GridField__nodes(field, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    if field._values is not None:
        return field._values[i, j]
    return field._decode(field._codes[i, j])


def GridField_evaluate(field, points):
    p = as_points(points)
    h, sides = field.cell, field.margins
    top = np.array(field.shape) - 1
    u = (p - field.origin) / h                       # node coordinates
    uc = np.clip(u, 0.0, top)                       # the nearest point of the grid box
    cell = np.minimum(np.floor(uc), top - 1).astype(np.intp)
    t = uc - cell
    i, j = cell[:, 0], cell[:, 1]
    v00, v10 = GridField__nodes(field, i, j), GridField__nodes(field, i + 1, j)
    v01, v11 = GridField__nodes(field, i, j + 1), GridField__nodes(field, i + 1, j + 1)
    tx, ty = t[:, 0], t[:, 1]
    value = ((1 - tx) * (1 - ty) * v00 + tx * (1 - ty) * v10
             + (1 - tx) * ty * v01 + tx * ty * v11)
    grad = np.stack([(1 - ty) * (v10 - v00) + ty * (v11 - v01),
                     (1 - tx) * (v01 - v00) + tx * (v11 - v10)], axis=1) / h

    delta = (u - uc) * h                            # p - q, zero inside the grid
    dist = np.hypot(delta[:, 0], delta[:, 1])
    out = dist > 0.0
    if np.any(out):
        v, gq = value[out], grad[out] * (u[out] == uc[out])   # clamped axes: no slope
        dq, dd = delta[out], dist[out]
        m = np.minimum(np.where(dq[:, 0] < 0.0, sides[0],
                                np.where(dq[:, 0] > 0.0, sides[2], np.inf)),
                       np.where(dq[:, 1] < 0.0, sides[1],
                                np.where(dq[:, 1] > 0.0, sides[3], np.inf)))
        pos = np.maximum(v, 0.0)
        root = np.sqrt(pos * pos + dd * dd + 2.0 * m * dd)
        value[out] = root + np.minimum(v, 0.0)
        grad[out] = ((pos[:, None] * gq + ((dd + m) / dd)[:, None] * dq) / root[:, None]
                     + (v < 0.0)[:, None] * gq)
    if field.band is not None:
        beyond = np.abs(value) > field.band
        value = np.clip(value, -field.band, field.band)
        grad[beyond] = 0.0
    return value, grad
