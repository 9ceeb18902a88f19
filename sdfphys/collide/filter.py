"""Collision filtering: which body pairs may collide (category, mask, group; sensors).

Box2D's rule (``b2ShouldShapesCollide``), per body pair (a, b):

- same nonzero ``group``: collide if the group is positive, never if negative;
- otherwise both ``category_a & mask_b`` and ``category_b & mask_a`` must be nonzero.

``category`` and ``mask`` are 64-bit fields (``uint64``; defaults 1 and all bits, as
Box2D v3, ``limits.MAX_BITS``; pymunk's ``ShapeFilter`` is the same rule on 32 bits);
``group`` is a signed integer (default 0: no group). Two sensors never pair (Box2D
v3: a sensor does not detect another sensor).

The rule is applied to the broadphase's candidate pairs, vectorized (one numpy
expression over the pair arrays): filtered pairs never reach the narrowphase, and time
of impact never traces them (``PairFilter.allows``). A world whose bodies all have the
defaults and no sensor passes no filter at all: nothing is computed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PairFilter", "should_collide"]


def should_collide(category_a: np.ndarray, mask_a: np.ndarray, group_a: np.ndarray,
                   category_b: np.ndarray, mask_b: np.ndarray,
                   group_b: np.ndarray) -> np.ndarray:
    """(P,) bool: Box2D's filter rule (module docstring) over arrays of pairs.

    category, mask: (P,) uint64 bit fields; group: (P,) int64. Scalars broadcast.
    """
    category_a, mask_a = np.asarray(category_a, np.uint64), np.asarray(mask_a, np.uint64)
    category_b, mask_b = np.asarray(category_b, np.uint64), np.asarray(mask_b, np.uint64)
    group_a, group_b = np.asarray(group_a, np.int64), np.asarray(group_b, np.int64)
    same = (group_a == group_b) & (group_a != 0)
    bits = ((category_a & mask_b) != 0) & ((category_b & mask_a) != 0)
    return np.where(same, group_a > 0, bits)


@dataclass
class PairFilter:
    """Per body (B,): category, mask (uint64), group (int64), sensor (bool).

    ``allows(a, b)`` says which pairs (body index arrays) may collide: the filter rule
    and not two sensors. ``solid`` (with ``allows(a, b, solid=True)``) also drops
    every pair with a sensor: what time of impact traces.
    """

    category: np.ndarray
    mask: np.ndarray
    group: np.ndarray
    sensor: np.ndarray

    def __post_init__(self) -> None:
        self.has_sensors = bool(np.any(self.sensor))

    def allows(self, a: np.ndarray, b: np.ndarray, solid: bool = False) -> np.ndarray:
        """(P,) bool for the pairs (a[k], b[k]); solid: also False where either is a
        sensor (else only where both are)."""
        keep = should_collide(self.category[a], self.mask[a], self.group[a],
                              self.category[b], self.mask[b], self.group[b])
        sa, sb = self.sensor[a], self.sensor[b]
        return keep & ~((sa | sb) if solid else (sa & sb))

    def pairs(self, pairs: np.ndarray) -> np.ndarray:
        """The rows of ``pairs`` (P, 2) int64 that may collide."""
        if len(pairs) == 0:
            return pairs
        return pairs[self.allows(pairs[:, 0], pairs[:, 1])]
