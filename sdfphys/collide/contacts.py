"""The Contacts bundle: every contact point of one step as a struct of arrays."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

__all__ = ["Contacts"]


@dataclass
class Contacts:
    """K contact points, one row each (world frame, metres).

    body_a, body_b: (K,) int64 body indices (scene order), body_a < body_b
        for contacts produced by the world; ``collide()`` keeps a = first shape.
    point: (K, 2) midway between the two surfaces (as pymunk's (point_a + point_b) / 2).
    normal: (K, 2) unit, pointing from a toward b.
    depth: (K,) penetration; > 0 overlapping, < 0 separated (speculative contact).
    feature: (K,) int64 key, unique within a pair and stable from step to step while
        the contact persists (the solver matches warm-start impulses on
        (body_a, body_b, feature)).
    """

    body_a: np.ndarray
    body_b: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    feature: np.ndarray

    @classmethod
    def empty(cls) -> Contacts:
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)),
                   np.zeros((0, 2)), np.zeros(0), np.zeros(0, np.int64))

    def __len__(self) -> int:
        return len(self.depth)

    def take(self, index: np.ndarray) -> Contacts:
        """The rows selected by ``index`` (an index or boolean array)."""
        return type(self)(*(getattr(self, name)[index] for name in _names(type(self))))

    @classmethod
    def concatenate(cls, parts: list[Contacts]) -> Contacts:
        """The rows of ``parts`` one after the other (the one non-empty part itself)."""
        parts = [p for p in parts if len(p)]
        if not parts:
            return cls.empty()
        if len(parts) == 1:
            return parts[0]
        return cls(*(np.concatenate([getattr(p, name) for p in parts]) for name in _names(cls)))

    def without_body(self, index: int) -> Contacts:
        """The rows after body ``index`` is removed: its rows dropped, later bodies
        renumbered."""
        c = self.take((self.body_a != index) & (self.body_b != index))
        c.body_a = c.body_a - (c.body_a > index)
        c.body_b = c.body_b - (c.body_b > index)
        return c

    def pair_rows(self, other: Contacts, n: np.int64) -> tuple[np.ndarray, np.ndarray]:
        """Every (row of ``other``, row of ``self`` of the same body pair), as two
        index arrays (M,) (owner into ``other``, row into ``self``); ``self`` sorted by
        pair (key body_a n + body_b, n the body count)."""
        keys = self.body_a * n + self.body_b
        wanted = other.body_a * n + other.body_b
        lo = np.searchsorted(keys, wanted, "left")
        count = np.searchsorted(keys, wanted, "right") - lo
        owner = np.repeat(np.arange(len(other)), count)
        row = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(int(count.sum()))
        return owner, row


_NAMES: dict[type, tuple[str, ...]] = {}


def _names(cls: type) -> tuple[str, ...]:
    """The dataclass field names of ``cls`` in order (``dataclasses.fields`` costs
    microseconds a call, and the narrowphase takes and joins bundles per pair group)."""
    names = _NAMES.get(cls)
    if names is None:
        names = _NAMES[cls] = tuple(f.name for f in fields(cls))
    return names
