"""Warm starting: last step's accumulated impulses, matched to this step's contacts.

A contact keeps its impulse from one step to the next when its key (body_a, body_b,
feature) matches (a compiled merge join of the two sorted lists), or, failing that,
the nearest unmatched contact of the same pair within the linear slop (``match``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._jit import njit

__all__ = ["ImpulseCache"]


@dataclass
class ImpulseCache:
    """Accumulated impulses of the last step, keyed by (body_a, body_b, feature); (K,) each.

    normal_impulse, tangent_impulse: N s per substep (what the warm start applies).
    anchor: (K, 2) m, each contact point in body a's frame (relative to its centre of
    mass, unrotated by its angle) at the start of that step: the fallback match by
    place (``match``).
    """

    body_a: np.ndarray
    body_b: np.ndarray
    feature: np.ndarray
    normal_impulse: np.ndarray
    tangent_impulse: np.ndarray
    anchor: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @classmethod
    def empty(cls) -> ImpulseCache:
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64),
                   np.zeros(0), np.zeros(0), np.zeros((0, 2)))

    def __len__(self) -> int:
        return len(self.feature)

    def without_body(self, index: int) -> ImpulseCache:
        """The cache after body ``index`` is removed: its rows dropped, later bodies renumbered."""
        c = self.take((self.body_a != index) & (self.body_b != index))
        c.body_a = c.body_a - (c.body_a > index)
        c.body_b = c.body_b - (c.body_b > index)
        return c

    def take(self, index: np.ndarray) -> ImpulseCache:
        """The rows selected by ``index`` (an index or boolean array)."""
        anchor = self.anchor[index] if len(self.anchor) == len(self) else self.anchor
        return ImpulseCache(self.body_a[index], self.body_b[index], self.feature[index],
                            self.normal_impulse[index], self.tangent_impulse[index], anchor)

    @classmethod
    def concatenate(cls, parts: list[ImpulseCache]) -> ImpulseCache:
        """The rows of ``parts`` one after the other."""
        parts = [p for p in parts if len(p)]
        if not parts:
            return cls.empty()
        if any(len(p.anchor) != len(p) for p in parts):
            parts = [ImpulseCache(p.body_a, p.body_b, p.feature, p.normal_impulse,
                                  p.tangent_impulse, np.full((len(p), 2), np.inf))
                     for p in parts]
        return cls(*(np.concatenate([getattr(p, name) for p in parts])
                     for name in ("body_a", "body_b", "feature", "normal_impulse",
                                  "tangent_impulse", "anchor")))

    def sorted(self) -> ImpulseCache:
        """The rows in (body_a, body_b, feature) order (``match``'s merge join)."""
        return self.take(np.lexsort((self.feature, self.body_b, self.body_a)))

    def match(self, body_a: np.ndarray, body_b: np.ndarray, feature: np.ndarray,
              anchor: np.ndarray | None = None, tolerance: float = 0.0
              ) -> tuple[np.ndarray, np.ndarray]:
        """Normal and tangent impulses (K,) for the given keys; 0 where there is no match.

        First by key: when both lists are sorted by (body_a, body_b, feature), as
        ``find_contacts`` returns them, one compiled merge join (O(K)); otherwise,
        vectorized, the features of both sets are ranked together (np.unique), each key
        (a, b, feature) becomes one int64 ((a * nb + b) * nf + rank), and the new keys
        are looked up in the sorted old ones with searchsorted. Valid while
        nb^2 nf < 2^63 (nb bodies, nf distinct features), e.g. 10^5 bodies and 10^8
        contacts.

        Then by place, if ``anchor`` (K, 2) (points in body a's frame, as
        ``ImpulseCache.anchor``) and ``tolerance`` > 0 are given: a new contact that
        matched no key takes the impulses of the nearest old contact of the same body
        pair, not matched by anything yet, within ``tolerance`` (m). A contact patch
        seen from two sides (a corner of b in a's face, a's face end in b's corner)
        yields near-coincident candidates whose keys differ, and which of them the
        reduction keeps may flip from step to step as the bodies rock by micrometres;
        without this the warm start is lost at every flip (measured: a unit box
        on a unit box lost it at three steps out of four).
        """
        k = len(feature)
        normal, tangent = np.zeros(k), np.zeros(k)
        if k == 0 or len(self) == 0:
            return normal, tangent
        by_place = anchor is not None and tolerance > 0.0 and len(self.anchor) == len(self)
        if by_place:
            old_anchor = np.ascontiguousarray(self.anchor, dtype=np.float64)
            new_anchor = np.ascontiguousarray(anchor, dtype=np.float64)
        else:
            old_anchor = new_anchor = _NO_ANCHOR
        if _match_sorted(self.body_a, self.body_b, self.feature, self.normal_impulse,
                         self.tangent_impulse, old_anchor, body_a, body_b, feature,
                         new_anchor, tolerance if by_place else 0.0, normal, tangent):
            return normal, tangent
        # Not both sorted: the vectorized lookup.
        source = np.full(k, -1, np.int64)
        nb = int(max(self.body_b.max(), body_b.max(), self.body_a.max(),
                     body_a.max())) + 1
        ranks = np.unique(np.concatenate([self.feature, feature]), return_inverse=True)[1]
        nf = int(ranks.max()) + 1
        old_key = (self.body_a * nb + self.body_b) * nf + ranks[:len(self)]
        new_key = (body_a * nb + body_b) * nf + ranks[len(self):]
        order = np.argsort(old_key, kind="stable")
        sorted_key = old_key[order]
        where = np.minimum(np.searchsorted(sorted_key, new_key), len(sorted_key) - 1)
        hit = sorted_key[where] == new_key
        source[hit] = order[where[hit]]
        if by_place and (source < 0).any():
            old_pair = self.body_a * nb + self.body_b
            pair_order = np.argsort(old_pair, kind="stable")
            new_pair = body_a * nb + body_b
            lo = np.searchsorted(old_pair[pair_order], new_pair, side="left")
            hi = np.searchsorted(old_pair[pair_order], new_pair, side="right")
            _match_by_place(source, lo, hi, pair_order, old_anchor, new_anchor, tolerance)
        found = source >= 0
        normal[found] = self.normal_impulse[source[found]]
        tangent[found] = self.tangent_impulse[source[found]]
        return normal, tangent


#: The anchors' placeholder when there is no match by place.
_NO_ANCHOR = np.zeros((0, 2))


@njit(cache=True)
def _match_sorted(old_a, old_b, old_f, old_normal, old_tangent, old_anchor, new_a, new_b,
                  new_f, new_anchor, tolerance, normal, tangent):
    """``ImpulseCache.match`` when both lists are sorted by (body_a, body_b, feature)
    (``find_contacts``' order), in one pass: the key match as a merge join (O(K)), each
    new row's pair's old rows [lo, hi) found by the same merge, then, if tolerance > 0,
    the match by place (``_match_by_place``), and the impulses gathered into normal and
    tangent (K,), zeros where unmatched. Returns False, leaving them untouched, if either
    list is not sorted.

    A pair (a, b) is compared as the one integer (a << 32) | b (body indices < 2^31)."""
    n_old, k = old_a.shape[0], new_a.shape[0]
    if not (_sorted(old_a, old_b, old_f) and _sorted(new_a, new_b, new_f)):
        return False
    source = np.empty(k, np.int64)
    lo, hi = np.empty(k, np.int64), np.empty(k, np.int64)
    unmatched = False
    first = 0                               # the first old row of new row j's pair or after
    u = 0                                   # the first old row of key >= new row j's
    for j in range(k):
        source[j] = -1
        pair, f = (new_a[j] << _HIGH) | new_b[j], new_f[j]
        while first < n_old and (old_a[first] << _HIGH) | old_b[first] < pair:
            first += 1
        if u < first:
            u = first
        while u < n_old and (old_a[u] << _HIGH) | old_b[u] == pair and old_f[u] < f:
            u += 1
        if u < n_old and (old_a[u] << _HIGH) | old_b[u] == pair and old_f[u] == f:
            source[j] = u
        else:
            unmatched = True
        last = u
        while last < n_old and (old_a[last] << _HIGH) | old_b[last] == pair:
            last += 1
        lo[j], hi[j] = first, last
    if unmatched and tolerance > 0.0:
        _match_by_place(source, lo, hi, np.arange(n_old), old_anchor, new_anchor, tolerance)
    for j in range(k):
        if source[j] >= 0:
            normal[j], tangent[j] = old_normal[source[j]], old_tangent[source[j]]
    return True


#: The shift that packs a pair (a, b) into one int64 key, (a << 32) | b.
_HIGH = np.int64(32)


@njit(cache=True)
def _sorted(a, b, f):
    """Whether the rows (a, b, f) are in lexicographic order."""
    for u in range(1, a.shape[0]):
        if a[u] != a[u - 1]:
            if a[u] < a[u - 1]:
                return False
        elif b[u] != b[u - 1]:
            if b[u] < b[u - 1]:
                return False
        elif f[u] < f[u - 1]:
            return False
    return True


@njit(cache=True)
def _match_by_place(source, lo, hi, pair_order, old_anchor, new_anchor, tolerance):
    """Fill source[k] < 0 with the nearest unused old row of the same pair within
    ``tolerance`` (rows pair_order[lo[k]:hi[k]]); in contact order, deterministic."""
    used = np.zeros(old_anchor.shape[0], np.bool_)
    for k in range(source.shape[0]):
        if source[k] >= 0:
            used[source[k]] = True
    for k in range(source.shape[0]):
        if source[k] >= 0:
            continue
        best = -1
        best_d2 = tolerance * tolerance
        for j in range(lo[k], hi[k]):
            r = pair_order[j]
            if used[r]:
                continue
            dx = old_anchor[r, 0] - new_anchor[k, 0]
            dy = old_anchor[r, 1] - new_anchor[k, 1]
            d2 = dx * dx + dy * dy
            if d2 <= best_d2:
                best = r
                best_d2 = d2
        if best >= 0:
            source[k] = best
            used[best] = True
