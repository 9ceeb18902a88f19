"""Contacts kept while a pair barely moves: the narrowphase's persistent manifolds.

A resting pair's descent (mesh-sdf, sdf-sdf, circle-sdf, concave meshes, circles on
polygons) finds the same contacts step after step, at about 0.7 ms a pair in the
showcase. The cache keeps each such pair's contacts in the pair's own frames and,
while the pair's relative motion since they were found stays within
tau = ``Settings.reuse_distance``, carries them with the bodies instead of searching
again (the persistent contact manifolds of Bullet and PhysX keep contact points
across frames the same way). The closed-form pairs of the fast path (circles, boxes,
convex polygons) never come here: they cost less than a lookup.

Frames. A contact (point p midway, normal n from a to b, depth d > 0 overlapping) has
its surface points p_a = p + n d / 2 on a and p_b = p - n d / 2 on b, so that
n . (p_b - p_a) = -d. The pair's *reference* body f, taken to carry the face (the
ground under a crate), is the one that is not a circle, else the one of larger
bounding radius; o is the other, taken to carry the vertex. The cache stores f's
surface point and the normal in f's frame, and o's surface point in o's frame (a
circle's about its centre in f's frame: turning a circle moves none of its surface).
Reused, each moves with its body; the depth is measured along the normal,
d = n . (p_f - p_o) (signed from a to b), and f's point is placed on its face under
o's, p_f = p_o + n d (signed likewise), so that the point follows a vertex sliding
along a face as a new search finds it. Unmoved, this gives back the contact (to
round-off).

Bound. Let r_o be o's bounding radius about its centre of mass. In f's frame o's
centre moved by dc and the relative angle by dq since the contacts were found, so no
point of o moved more than e = |dc| + |dq| r_o there (e = |dc| for a circle), and no
point of f moved at all: every separation between the two bodies changed by at most
e, and the depth measured along the kept normal is exact to first order in e (exact
for a flat face of f). A pair is reused only while e <= tau.

Nothing missed. Contacts are found with the pair's margin m (speculative distance
plus reach, ``collide`` module doc) plus tau. A pair reused with margin m' and
m' + e <= m + tau as found holds every contact within m' of the pair now: a
separation within m' now was within m' + e then. Contacts stay as complete as the
descent found them; the deepest point can differ from a new search's by at most 2 e.

Invalidation: body indices shift when a body is removed (``clear``), an edited field
drops its body's pairs (``forget``), and a change of the settings or of a body's shape
is seen here (both are stored and compared). Everything is plain arrays, so a pickled
or copied world steps on bit for bit as the original.
"""

from __future__ import annotations

import numpy as np

from ..settings import Settings
from ..vec2 import rotate, rows_dot
from .contacts import Contacts

__all__ = ["ContactCache"]

_SHIFT = np.int64(32)


def _keys(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Pair keys (P,) int64 of bodies lo < hi."""
    return (lo.astype(np.int64) << _SHIFT) | hi.astype(np.int64)


def _relative(pose: np.ndarray, ref: np.ndarray, other: np.ndarray) -> np.ndarray:
    """(P, 3): the other body's centre of mass in the reference body's frame, and the
    angle of the other minus the reference's (pose (B, 3) x, y, angle)."""
    centre = rotate(pose[other, :2] - pose[ref, :2], -pose[ref, 2])
    return np.column_stack([centre, pose[other, 2] - pose[ref, 2]])


def _offsets(count: np.ndarray) -> np.ndarray:
    """(N + 1,) int64: where each of N consecutive runs of ``count`` rows starts, and
    the total."""
    first = np.zeros(len(count) + 1, np.int64)
    np.cumsum(count, out=first[1:])
    return first


def _reference_is_lo(lo: np.ndarray, hi: np.ndarray, radius: np.ndarray,
                     round_: np.ndarray) -> np.ndarray:
    """(P,) bool: the pair's reference body is lo (module docstring): the one that is
    not round, else the one of larger bounding radius (lo on a tie)."""
    return np.where(round_[lo] != round_[hi], round_[hi], radius[lo] >= radius[hi])


def _ranges(start: np.ndarray, stop: np.ndarray) -> np.ndarray:
    """The concatenated integer ranges [start_i, stop_i), without a Python loop."""
    count = stop - start
    total = int(count.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    offset = np.repeat(start - np.cumsum(count) + count, count)
    return offset + np.arange(total, dtype=np.int64)


class ContactCache:
    """One world's kept contacts of the descent pairs (module docstring).

    Per kept pair (N, sorted by key): key (N,) int64 (lo << 32 | hi, lo < hi body
    indices), shape (N, 2) the two bodies' shape numbers, ref_is_lo (N,) bool,
    relative (N, 3) the other body's pose in the reference's frame when found
    (``_relative``), margin (N,) m the margin they were found with, first (N + 1,)
    the pair's rows in the contact arrays; per kept contact (K,): on_ref, on_other
    (K, 2) the surface points of the reference body and of the other in their body
    frames (m), normal (K, 2) unit in the reference's frame from lo toward hi, feature
    (K,) int64.
    """

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """Forget every pair (body indices changed)."""
        self.settings: Settings | None = None
        self._set(np.zeros(0, np.int64), np.zeros((0, 2), np.int64), np.zeros(0, bool),
                  np.zeros((0, 3)), np.zeros(0), np.zeros(1, np.int64), np.zeros((0, 2)),
                  np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, np.int64))

    def _set(self, key, shape, ref_is_lo, relative, margin, first, on_ref, on_other,
             normal, feature) -> None:
        self.key, self.shape, self.ref_is_lo, self.relative = key, shape, ref_is_lo, relative
        self.margin, self.first = margin, first
        self.on_ref, self.on_other, self.normal, self.feature = on_ref, on_other, normal, \
            feature

    def __len__(self) -> int:
        return len(self.key)

    def forget(self, body: int) -> None:
        """Drop the pairs of body ``body`` (its field changed)."""
        keep = ((self.key >> _SHIFT) != body) & ((self.key & 0xFFFFFFFF) != body)
        self._keep(keep)

    def _keep(self, keep: np.ndarray) -> None:
        """Keep the pairs where ``keep`` (N,) is true, with their contacts."""
        rows = _ranges(self.first[:-1][keep], self.first[1:][keep])
        count = np.diff(self.first)[keep]
        self._set(self.key[keep], self.shape[keep], self.ref_is_lo[keep],
                  self.relative[keep], self.margin[keep], _offsets(count),
                  self.on_ref[rows], self.on_other[rows], self.normal[rows], self.feature[rows])

    def reuse(self, pairs: np.ndarray, pose: np.ndarray, radius: np.ndarray,
              round_: np.ndarray, body_shape: np.ndarray, margin: np.ndarray, tau: float,
              settings: Settings) -> tuple[np.ndarray, Contacts]:
        """Which of ``pairs`` keep their contacts this step, and those contacts.

        pairs (P, 2) body indices; pose (B, 3) centre-of-mass poses (x, y, angle);
        radius (B,) bounding radii (m, inf if unbounded); round_ (B,) bool, circles;
        body_shape (B,) shape numbers; margin (P,) m, each pair's margin now; tau m.
        Returns reused (P,) bool and their contacts (body_a < body_b, ``Contacts``
        conventions; rows in no particular order). The kept pairs are narrowed to the
        reused ones: the others are stored again by ``store`` or dropped.
        """
        if self.settings is None or self.settings != settings:
            self.clear()
            self.settings = settings
        lo, hi = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
        key = _keys(lo, hi)
        at = np.minimum(np.searchsorted(self.key, key), max(len(self.key) - 1, 0))
        reused = np.zeros(len(pairs), bool)
        if len(self.key):
            known = ((self.key[at] == key) & (self.shape[at, 0] == body_shape[lo])
                     & (self.shape[at, 1] == body_shape[hi]))
            ref_lo = self.ref_is_lo[at]
            ref, other = np.where(ref_lo, lo, hi), np.where(ref_lo, hi, lo)
            change = _relative(pose, ref, other) - self.relative[at]
            turn = np.abs(change[:, 2])
            swing = np.where((turn > 0.0) & ~round_[other], turn * radius[other], 0.0)
            e = np.hypot(change[:, 0], change[:, 1]) + swing
            reused = known & (e <= tau) & (margin + e <= self.margin[at])
        keep = np.zeros(len(self.key), bool)
        keep[at[reused]] = True
        self._keep(keep)
        return reused, self._contacts(pose, round_)

    def _contacts(self, pose: np.ndarray, round_: np.ndarray) -> Contacts:
        """The kept contacts carried to the bodies' poses (module docstring)."""
        count = np.diff(self.first)
        key = np.repeat(self.key, count)
        lo, hi = key >> _SHIFT, key & 0xFFFFFFFF
        ref_lo = np.repeat(self.ref_is_lo, count)
        ref, other = np.where(ref_lo, lo, hi), np.where(ref_lo, hi, lo)
        on_ref = pose[ref, :2] + rotate(self.on_ref, pose[ref, 2])
        turn = np.where(round_[other], pose[ref, 2], pose[other, 2])
        on_other = pose[other, :2] + rotate(self.on_other, turn)
        normal = rotate(self.normal, pose[ref, 2])
        # n points from lo to hi: d = n . (p_lo - p_hi) = sign n . (p_ref - p_other).
        sign = np.where(ref_lo, 1.0, -1.0)
        depth = sign * rows_dot(normal, on_ref - on_other)
        point = on_other + (0.5 * sign * depth)[:, None] * normal
        return Contacts(lo, hi, point, normal, depth, self.feature.copy())

    def store(self, pairs: np.ndarray, found_margin: np.ndarray, contacts: Contacts,
              pose: np.ndarray, radius: np.ndarray, round_: np.ndarray,
              body_shape: np.ndarray) -> None:
        """Keep the contacts just found for ``pairs`` (P, 2), found with margins
        ``found_margin`` (P,) m; contacts: theirs, body_a < body_b, every row's pair
        among ``pairs`` (pairs without contacts are kept too: nothing within
        their margin). pose, radius, round_, body_shape: as ``reuse``."""
        lo, hi = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
        key = _keys(lo, hi)
        by_key = np.argsort(key, kind="stable")
        key, lo, hi, found_margin = key[by_key], lo[by_key], hi[by_key], found_margin[by_key]
        ref_is_lo = _reference_is_lo(lo, hi, radius, round_)
        ref, other = np.where(ref_is_lo, lo, hi), np.where(ref_is_lo, hi, lo)
        relative = _relative(pose, ref, other)
        row_key = _keys(contacts.body_a, contacts.body_b)
        rows = np.argsort(row_key, kind="stable")
        row_key = row_key[rows]
        c = contacts.take(rows)
        first = np.append(np.searchsorted(row_key, key), len(row_key))
        half = 0.5 * c.depth[:, None] * c.normal
        a, b = c.body_a, c.body_b
        ref_a = _reference_is_lo(a, b, radius, round_)
        ref, other = np.where(ref_a, a, b), np.where(ref_a, b, a)
        side = np.where(ref_a, 1.0, -1.0)[:, None] * half     # p_a = p + half, p_b = p - half
        on_ref = rotate(c.point + side - pose[ref, :2], -pose[ref, 2])
        turn = np.where(round_[other], pose[ref, 2], pose[other, 2])
        on_other = rotate(c.point - side - pose[other, :2], -turn)
        normal = rotate(c.normal, -pose[ref, 2])
        shape = np.column_stack([body_shape[lo], body_shape[hi]])
        # Merge with the reused pairs (disjoint keys), sorted by key.
        join = np.concatenate
        all_key = join([self.key, key])
        order = np.argsort(all_key, kind="stable")
        count = join([np.diff(self.first), np.diff(first)])[order]
        start = join([self.first[:-1], first[:-1] + len(self.feature)])[order]
        rows = _ranges(start, start + count)
        self._set(all_key[order], join([self.shape, shape])[order],
                  join([self.ref_is_lo, ref_is_lo])[order],
                  join([self.relative, relative])[order],
                  join([self.margin, found_margin])[order], _offsets(count),
                  join([self.on_ref, on_ref])[rows], join([self.on_other, on_other])[rows],
                  join([self.normal, normal])[rows], join([self.feature, c.feature])[rows])
