"""Errors raised for bad input, and the small checkers that produce them.

Every message names the key path of the offending value, so that a scene
loader can prefix the file name and print one line:
``body[2].shape.radius: must be > 0, got -1.0``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["SpecError", "check_int", "check_number", "check_points", "check_vec2"]


class SpecError(ValueError):
    """Invalid user input (scene, field spec, shape); ``path`` is the key path."""

    def __init__(self, path: str, message: str, source: str = ""):
        self.path = path
        self.message = message
        self.source = source
        where = ": ".join(s for s in (source, path) if s)
        super().__init__(f"{where}: {message}" if where else message)

    def in_file(self, source: str) -> SpecError:
        """The same error attributed to the file ``source`` (printed first)."""
        return SpecError(self.path, self.message, source)

    def under(self, prefix: str) -> SpecError:
        """The same error with ``prefix`` prepended to its key path."""
        if not prefix:
            return self
        if not self.path:
            path = prefix
        elif self.path.startswith("["):
            path = prefix + self.path
        else:
            path = f"{prefix}.{self.path}"
        return SpecError(path, self.message, self.source)


def _is_number(value: Any) -> bool:
    """An int or float, numpy's included (not a bool)."""
    if type(value) is float or type(value) is int:
        return True
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def check_number(value: Any, path: str, *, low: float | None = None,
                 low_open: bool = False, high: float | None = None) -> float:
    """A finite float, optionally bounded below (``low``, strict if ``low_open``) and above."""
    if not _is_number(value):
        raise SpecError(path, f"must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise SpecError(path, f"must be finite, got {value}")
    if low is not None:
        if low_open and not value > low:
            raise SpecError(path, f"must be > {low:g}, got {value:g}")
        if not low_open and not value >= low:
            raise SpecError(path, f"must be >= {low:g}, got {value:g}")
    if high is not None and value > high:
        raise SpecError(path, f"must be <= {high:g}, got {value:g}")
    return value


def check_int(value: Any, path: str, *, low: int | None = None, high: int | None = None) -> int:
    """An integer (a float with an integral value is not accepted)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise SpecError(path, f"must be an integer, got {value!r}")
    if low is not None and value < low:
        raise SpecError(path, f"must be >= {low}, got {value}")
    if high is not None and value > high:
        raise SpecError(path, f"must be <= {high}, got {value}")
    return int(value)


def check_vec2(value: Any, path: str, *, positive: bool = False) -> tuple[float, float]:
    """A pair of finite floats ``[x, y]`` (both > 0 if ``positive``); a numpy array of
    shape (2,) is accepted too."""
    if isinstance(value, np.ndarray) and value.shape == (2,):
        value = value.tolist()
    pair = type(value) in (list, tuple) or (          # the common case first: fast
        not isinstance(value, (str, bytes)) and isinstance(value, Sequence))
    if not pair or len(value) != 2:
        raise SpecError(path, f"must be a pair [x, y], got {value!r}")
    x = check_number(value[0], f"{path}[0]", low=0.0 if positive else None, low_open=positive)
    y = check_number(value[1], f"{path}[1]", low=0.0 if positive else None, low_open=positive)
    return x, y


def check_points(value: Any, path: str, *, minimum: int = 3) -> list[tuple[float, float]]:
    """A list of at least ``minimum`` finite points ``[[x, y], ...]``."""
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        raise SpecError(path, f"must be a list of [x, y] points, got {value!r}")
    if len(value) < minimum:
        raise SpecError(path, f"needs at least {minimum} points, got {len(value)}")
    return [check_vec2(p, f"{path}[{i}]") for i, p in enumerate(value)]
