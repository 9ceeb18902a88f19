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

import math

import numpy as np

from .._jit import njit
from ..settings import Settings
from .broadphase import PairCache
from .contacts import Contacts

__all__ = ["BODIES", "KEPT", "ContactCache", "body_turns"]

_SHIFT = np.int64(32)


def _keys(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Pair keys (P,) int64 of bodies lo < hi."""
    return (lo.astype(np.int64) << _SHIFT) | hi.astype(np.int64)


def _offsets(count: np.ndarray) -> np.ndarray:
    """(N + 1,) int64: where each of N consecutive runs of ``count`` rows starts, and
    the total."""
    first = np.zeros(len(count) + 1, np.int64)
    np.cumsum(count, out=first[1:])
    return first


def _ranges(start: np.ndarray, stop: np.ndarray) -> np.ndarray:
    """The concatenated integer ranges [start_i, stop_i), without a Python loop."""
    count = stop - start
    total = int(count.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    offset = np.repeat(start - np.cumsum(count) + count, count)
    return offset + np.arange(total, dtype=np.int64)


#: The kept arrays' order in ``ContactCache.kept`` (the class docstring gives them).
KEPT = ("key", "shape", "ref_is_lo", "relative", "margin", "first", "on_ref", "on_other",
        "normal", "feature")
#: The bodies' arrays the kernels take, in order: pose (B, 3), cos, sin, cos_neg, sin_neg
#: (B,) (``body_turns``), radius (B,) m, round_ (B,) bool, body_shape (B,) int64.
BODIES = ("pose", "cos", "sin", "cos_neg", "sin_neg", "radius", "round_", "body_shape")


class ContactCache:
    """One world's kept contacts of the descent pairs (module docstring).

    Per kept pair (N, sorted by key): key (N,) int64 (lo << 32 | hi, lo < hi body
    indices), shape (N, 2) the two bodies' shape numbers, ref_is_lo (N,) bool,
    relative (N, 3) the other body's centre of mass in the reference's frame and the
    angle of the other minus the reference's, when found, margin (N,) m the margin
    they were found with, first (N + 1,) the pair's rows in the contact arrays; per
    kept contact (K,): on_ref, on_other (K, 2) the surface points of the reference
    body and of the other in their body frames (m), normal (K, 2) unit in the
    reference's frame from lo toward hi, feature (K,) int64. The loops over pairs and
    contacts are compiled (``_carry``, ``_merged``), which take these ten arrays as one
    tuple, ``kept`` (``KEPT``: the order), and the bodies' arrays as another,
    ``bodies`` (``BODIES``). broadphase: the world's kept broadphase pairs
    (``broadphase.PairCache``).
    """

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """Forget every pair (body indices changed)."""
        self.settings: Settings | None = None
        self.broadphase = PairCache()
        self._set(np.zeros(0, np.int64), np.zeros((0, 2), np.int64), np.zeros(0, bool),
                  np.zeros((0, 3)), np.zeros(0), np.zeros(1, np.int64), np.zeros((0, 2)),
                  np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, np.int64))

    def _set(self, key, shape, ref_is_lo, relative, margin, first, on_ref, on_other,
             normal, feature) -> None:
        self.key, self.shape, self.ref_is_lo, self.relative = key, shape, ref_is_lo, relative
        self.margin, self.first = margin, first
        self.on_ref, self.on_other, self.normal, self.feature = on_ref, on_other, normal, \
            feature

    @property
    def kept(self) -> tuple[np.ndarray, ...]:
        """The kept arrays as the kernels take them, in ``KEPT`` order (a plain tuple:
        numba types it in its C fast path, a named tuple through Python)."""
        return (self.key, self.shape, self.ref_is_lo, self.relative, self.margin, self.first,
                self.on_ref, self.on_other, self.normal, self.feature)

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

    def reuse(self, pairs: np.ndarray, pose: np.ndarray, turns: tuple[np.ndarray, ...],
              radius: np.ndarray, round_: np.ndarray, body_shape: np.ndarray,
              margin: np.ndarray, tau: float, settings: Settings
              ) -> tuple[np.ndarray, Contacts]:
        """Which of ``pairs`` keep their contacts this step, and those contacts.

        pairs (P, 2) body indices; pose (B, 3) centre-of-mass poses (x, y, angle);
        turns: ``body_turns(pose)``, computed once for the step's reuse and store;
        radius (B,) bounding radii (m, inf if unbounded); round_ (B,) bool, circles;
        body_shape (B,) shape numbers; margin (P,) m, each pair's margin now; tau m.
        Returns reused (P,) bool and their contacts (body_a < body_b, ``Contacts``
        conventions; rows in no particular order). The kept pairs are narrowed to the
        reused ones: the others are stored again by ``store`` or dropped.
        """
        if self.settings is None or self.settings != settings:
            self.clear()
            self.settings = settings
        reused, kept, lo, hi, point, normal, depth = _carry(
            self.kept, np.ascontiguousarray(pairs, np.int64),
            (pose, *turns, radius, round_, body_shape), margin, float(tau))
        self._keep(kept)
        return reused, Contacts(lo, hi, point, normal, depth, self.feature.copy())

    def store(self, pairs: np.ndarray, found_margin: np.ndarray, contacts: Contacts,
              pose: np.ndarray, turns: tuple[np.ndarray, ...], radius: np.ndarray,
              round_: np.ndarray, body_shape: np.ndarray) -> None:
        """Keep the contacts just found for ``pairs`` (P, 2), found with margins
        ``found_margin`` (P,) m; contacts: theirs, body_a < body_b, every row's pair
        among ``pairs`` (pairs without contacts are kept too: nothing within
        their margin). pose, turns, radius, round_, body_shape: as ``reuse``."""
        lo, hi = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
        key = _keys(lo, hi)
        by_key = np.argsort(key, kind="stable")
        row_key = _keys(contacts.body_a, contacts.body_b)
        rows = np.argsort(row_key, kind="stable")
        c = contacts.take(rows)
        self._set(*_merged(
            self.kept, (key[by_key], lo[by_key], hi[by_key], found_margin[by_key]),
            (row_key[rows], c.point, c.normal, c.depth, c.feature),
            (pose, *turns, radius, round_, body_shape)))


def body_turns(pose: np.ndarray) -> tuple[np.ndarray, ...]:
    """cos and sin (B,) of the bodies' angles and of their negatives (numpy's, as the
    rest of the narrowphase: ``vec2.rotate``)."""
    angle = np.ascontiguousarray(pose[:, 2])
    return np.cos(angle), np.sin(angle), np.cos(-angle), np.sin(-angle)


@njit(cache=True, error_model="numpy")
def _reference(lo: int, hi: int, radius: np.ndarray, round_: np.ndarray) -> bool:
    """Whether the pair's reference body is lo (module docstring): the one that is
    not round, else the one of larger bounding radius (lo on a tie)."""
    if round_[lo] != round_[hi]:
        return bool(round_[hi])
    return radius[lo] >= radius[hi]


@njit(cache=True, error_model="numpy")
def _carry(kept, pairs, bodies, pair_margin, tau):
    """``ContactCache.reuse`` over the kept arrays.

    kept: ``ContactCache.kept`` (``KEPT``); pairs (P, 2); bodies: ``BODIES``; pair_margin
    (P,), tau: as ``reuse``. Returns reused (P,), kept (N,) bool (the kept pairs
    reused), and per contact of those, in the kept order: lo, hi (K,), point, normal
    (K, 2), depth (K,).
    """
    key, shape, ref_is_lo, relative, margin, first, on_ref, on_other, normal, _ = kept
    pose, cos, sin, cos_neg, sin_neg, radius, round_, body_shape = bodies
    n_kept = key.shape[0]
    reused = np.zeros(pairs.shape[0], dtype=np.bool_)
    kept = np.zeros(n_kept, dtype=np.bool_)
    for p in range(pairs.shape[0]):
        lo, hi = min(pairs[p, 0], pairs[p, 1]), max(pairs[p, 0], pairs[p, 1])
        k = (lo << 32) | hi
        left, right = 0, n_kept                          # the first key >= k
        while left < right:
            mid = (left + right) // 2
            if key[mid] < k:
                left = mid + 1
            else:
                right = mid
        at = left
        if at == n_kept or key[at] != k or shape[at, 0] != body_shape[lo] \
                or shape[at, 1] != body_shape[hi]:
            continue
        ref, other = (lo, hi) if ref_is_lo[at] else (hi, lo)
        dx, dy = pose[other, 0] - pose[ref, 0], pose[other, 1] - pose[ref, 1]
        c, s = cos_neg[ref], sin_neg[ref]
        change_x = (c * dx - s * dy) - relative[at, 0]
        change_y = (s * dx + c * dy) - relative[at, 1]
        turn = abs((pose[other, 2] - pose[ref, 2]) - relative[at, 2])
        swing = turn * radius[other] if turn > 0.0 and not round_[other] else 0.0
        e = math.hypot(change_x, change_y) + swing
        if e <= tau and pair_margin[p] + e <= margin[at]:
            reused[p] = True
            kept[at] = True
    n = 0
    for at in range(n_kept):
        if kept[at]:
            n += first[at + 1] - first[at]
    lo_out, hi_out = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    point, normal_out, depth = np.empty((n, 2)), np.empty((n, 2)), np.empty(n)
    r = 0
    for at in range(n_kept):
        if not kept[at]:
            continue
        lo, hi = key[at] >> 32, key[at] & 0xFFFFFFFF
        ref, other = (lo, hi) if ref_is_lo[at] else (hi, lo)
        sign = 1.0 if ref_is_lo[at] else -1.0
        c, s = cos[ref], sin[ref]
        # A circle's point turns with the reference (module docstring).
        co, so = (cos[ref], sin[ref]) if round_[other] else (cos[other], sin[other])
        for i in range(first[at], first[at + 1]):
            fx = pose[ref, 0] + (c * on_ref[i, 0] - s * on_ref[i, 1])
            fy = pose[ref, 1] + (s * on_ref[i, 0] + c * on_ref[i, 1])
            ox = pose[other, 0] + (co * on_other[i, 0] - so * on_other[i, 1])
            oy = pose[other, 1] + (so * on_other[i, 0] + co * on_other[i, 1])
            nx = c * normal[i, 0] - s * normal[i, 1]
            ny = s * normal[i, 0] + c * normal[i, 1]
            # n points from lo to hi: d = n . (p_lo - p_hi) = sign n . (p_ref - p_other).
            d = sign * (nx * (fx - ox) + ny * (fy - oy))
            half = 0.5 * sign * d
            lo_out[r], hi_out[r] = lo, hi
            point[r, 0], point[r, 1] = ox + half * nx, oy + half * ny
            normal_out[r, 0], normal_out[r, 1] = nx, ny
            depth[r] = d
            r += 1
    return reused, kept, lo_out, hi_out, point, normal_out, depth


@njit(cache=True, error_model="numpy")
def _merged(kept, searched, found, bodies):
    """``ContactCache.store``: the kept arrays (``kept``: ``KEPT``) merged with the pairs
    just searched, ``searched`` = (new_key, new_lo, new_hi, new_margin) (P,) sorted by
    key, and their contacts, ``found`` = (row_key (K,), point, row_normal (K, 2), depth,
    row_feature (K,)) sorted by pair key (body_a < body_b). bodies: ``BODIES``. Returns
    the arrays of ``ContactCache._set``."""
    key, shape, ref_is_lo, relative, margin, first, on_ref, on_other, normal, feature = kept
    new_key, new_lo, new_hi, new_margin = searched
    row_key, point, row_normal, depth, row_feature = found
    pose, cos, sin, cos_neg, sin_neg, radius, round_, body_shape = bodies
    n_old, n_new, n_rows = key.shape[0], new_key.shape[0], row_key.shape[0]
    n_all = n_old + n_new
    k_all = on_ref.shape[0] + n_rows
    out_key, out_shape = np.empty(n_all, dtype=np.int64), np.empty((n_all, 2), dtype=np.int64)
    out_ref, out_relative = np.empty(n_all, dtype=np.bool_), np.empty((n_all, 3))
    out_margin, out_first = np.empty(n_all), np.empty(n_all + 1, dtype=np.int64)
    out_on_ref, out_on_other = np.empty((k_all, 2)), np.empty((k_all, 2))
    out_normal, out_feature = np.empty((k_all, 2)), np.empty(k_all, dtype=np.int64)
    i = j = row = r = 0
    out_first[0] = 0
    for m in range(n_all):
        if j == n_new or (i < n_old and key[i] < new_key[j]):      # a kept pair
            out_key[m], out_ref[m], out_margin[m] = key[i], ref_is_lo[i], margin[i]
            out_shape[m, 0], out_shape[m, 1] = shape[i, 0], shape[i, 1]
            for c in range(3):
                out_relative[m, c] = relative[i, c]
            for q in range(first[i], first[i + 1]):
                out_on_ref[r, 0], out_on_ref[r, 1] = on_ref[q, 0], on_ref[q, 1]
                out_on_other[r, 0], out_on_other[r, 1] = on_other[q, 0], on_other[q, 1]
                out_normal[r, 0], out_normal[r, 1] = normal[q, 0], normal[q, 1]
                out_feature[r] = feature[q]
                r += 1
            i += 1
        else:                                                       # a pair just searched
            lo, hi = new_lo[j], new_hi[j]
            is_lo = _reference(lo, hi, radius, round_)
            ref, other = (lo, hi) if is_lo else (hi, lo)
            out_key[m], out_ref[m], out_margin[m] = new_key[j], is_lo, new_margin[j]
            out_shape[m, 0], out_shape[m, 1] = body_shape[lo], body_shape[hi]
            dx, dy = pose[other, 0] - pose[ref, 0], pose[other, 1] - pose[ref, 1]
            c, s = cos_neg[ref], sin_neg[ref]
            out_relative[m, 0], out_relative[m, 1] = c * dx - s * dy, s * dx + c * dy
            out_relative[m, 2] = pose[other, 2] - pose[ref, 2]
            # This pair's rows: the run of row_key equal to its key.
            while row < n_rows and row_key[row] < new_key[j]:
                row += 1
            # p_lo = p + n d / 2, p_hi = p - n d / 2: the reference's side is +-.
            side = 0.5 if is_lo else -0.5
            co, so = (cos_neg[ref], sin_neg[ref]) if round_[other] \
                else (cos_neg[other], sin_neg[other])
            while row < n_rows and row_key[row] == new_key[j]:
                hx = side * depth[row] * row_normal[row, 0]
                hy = side * depth[row] * row_normal[row, 1]
                px, py = point[row, 0] + hx - pose[ref, 0], point[row, 1] + hy - pose[ref, 1]
                out_on_ref[r, 0], out_on_ref[r, 1] = c * px - s * py, s * px + c * py
                px, py = point[row, 0] - hx - pose[other, 0], point[row, 1] - hy - pose[other, 1]
                out_on_other[r, 0], out_on_other[r, 1] = co * px - so * py, so * px + co * py
                nx, ny = row_normal[row, 0], row_normal[row, 1]
                out_normal[r, 0], out_normal[r, 1] = c * nx - s * ny, s * nx + c * ny
                out_feature[r] = row_feature[row]
                r += 1
                row += 1
            j += 1
        out_first[m + 1] = r
    return (out_key, out_shape, out_ref, out_relative, out_margin, out_first, out_on_ref,
            out_on_other, out_normal, out_feature)
