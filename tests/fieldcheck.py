"""Generic checks that a field is what it claims (used by the primitive and operator tests).

An exact SDF has three properties that can be checked without knowing its formula:

1. |grad f| = 1 wherever it is evaluated (and never NaN);
2. the closest-point projection q = p - f(p) grad f(p) lands on the boundary,
   f(q) = 0, and |p - q| = |f(p)|;
3. no boundary point is nearer to p than |f(p)|: with boundary samples q_i
   (gathered by property 2 from many points), |f(p)| <= min_i |p - q_i|, and with
   dense samples the two agree to within the sample spacing.

A bound (exact = False) only promises |f(p)| <= the true distance, i.e. property 3's
inequality, and the correct sign.
"""

from __future__ import annotations

import numpy as np

from sdfphys.sdf import Field


def sample_points(field: Field, n: int, rng: np.random.Generator, pad: float = 0.5) -> np.ndarray:
    """``n`` random points in the field's bounds grown by ``pad`` times their size."""
    x0, y0, x1, y1 = field.bounds()
    w, h = x1 - x0, y1 - y0
    lo = np.array([x0 - pad * w, y0 - pad * h])
    hi = np.array([x1 + pad * w, y1 + pad * h])
    return lo + (hi - lo) * rng.random((n, 2))


def boundary_samples(field: Field, rng: np.random.Generator, n: int = 20000) -> np.ndarray:
    """Boundary points (M, 2) found by projecting random points (verified f(q) ~ 0)."""
    p = sample_points(field, n, rng, pad=0.3)
    d, g = field.evaluate(p)
    q = p - d[:, None] * g
    dq = field.distance(q)
    return q[np.abs(dq) < 1e-9]


def check_field(field: Field, rng: np.random.Generator, n: int = 2000,
                fd_tol: float = 1e-5, spacing_tol: float | None = None) -> None:
    """Assert the properties above (exact ones only if ``field.exact``)."""
    p = sample_points(field, n, rng)
    d, g = field.evaluate(p)
    assert d.shape == (n,) and g.shape == (n, 2)
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(g))
    np.testing.assert_allclose(field.distance(p), d, rtol=0, atol=1e-12)

    # Gradient against central differences where f is smooth at that scale.
    h = 1e-6
    fx = (field.distance(p + [h, 0]) - field.distance(p - [h, 0])) / (2 * h)
    fy = (field.distance(p + [0, h]) - field.distance(p - [0, h])) / (2 * h)
    fd = np.stack([fx, fy], axis=1)
    fd2 = np.stack([
        (field.distance(p + [2 * h, 0]) - field.distance(p - [2 * h, 0])) / (4 * h),
        (field.distance(p + [0, 2 * h]) - field.distance(p - [0, 2 * h])) / (4 * h)], axis=1)
    smooth = np.linalg.norm(fd - fd2, axis=1) < 1e-7   # no kink within 2h
    assert smooth.mean() > 0.9, "too few smooth sample points"
    err = np.linalg.norm(g[smooth] - fd[smooth], axis=1)
    assert err.max() < fd_tol, f"gradient differs from finite differences by {err.max():.3g}"

    if not field.exact:
        return
    np.testing.assert_allclose(np.linalg.norm(g, axis=1), 1.0, atol=1e-9)
    q = p - d[:, None] * g
    np.testing.assert_allclose(field.distance(q), 0.0, atol=1e-9)

    samples = boundary_samples(field, rng)
    assert len(samples) > 1000, "too few boundary samples"
    probe = p[:400]
    nearest = np.min(np.linalg.norm(probe[:, None, :] - samples[None, :, :], axis=2), axis=1)
    dp = np.abs(d[:400])
    assert np.all(dp <= nearest + 1e-9), "a boundary point is nearer than |f|"
    if spacing_tol is None:
        x0, y0, x1, y1 = field.bounds()
        spacing_tol = 0.02 * max(x1 - x0, y1 - y0)
    assert np.all(nearest - dp < spacing_tol), \
        f"|f| underestimates the distance by {np.max(nearest - dp):.3g}"


#: Far, tiny, signed-zero and subnormal points: where a field's branches overflow,
#: underflow or divide by zero.
FAR_POINTS = np.array([[1e3, 1e3], [-1e3, 2e3], [1e6, -1e6], [0.0, -1e6], [1e-300, 0.0],
                       [0.0, 1e-300], [-1e-300, -1e-300], [-0.0, 1.0], [-0.0, -0.0],
                       [5e-324, 5e-324]])


def bounds_and_axes(bounds) -> tuple[np.ndarray, np.ndarray]:
    """(box, lines): the corners, edge midpoints and centre of ``bounds`` (x0, y0, x1, y1)
    crossed with the axis (16 points), and 61 points on each axis and diagonal in
    [-3, 3] (244 points), where branches of a field typically meet."""
    x0, y0, x1, y1 = bounds
    xs = np.array([x0, 0.5 * (x0 + x1), x1, 0.0])
    ys = np.array([y0, 0.5 * (y0 + y1), y1, 0.0])
    box = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    s = np.linspace(-3.0, 3.0, 61)
    zero = np.zeros_like(s)
    lines = np.concatenate([np.stack([s, zero], 1), np.stack([zero, s], 1),
                            np.stack([s, s], 1), np.stack([s, -s], 1)])
    return box, lines


def boundary_and_sides(field: Field, p: np.ndarray) -> tuple[np.ndarray, ...]:
    """(on, outer, inner): the points ``p`` projected onto the boundary along -f grad f,
    and those moved 1e-9 along +grad f and -grad f."""
    d, g = field.evaluate(p)
    on = p - d[:, None] * g
    return on, on + 1e-9 * g, on - 1e-9 * g
