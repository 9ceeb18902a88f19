"""What a step reports beyond the state: contacts with their impulses, and events.

``WorldContacts``: the step's contacts (``collide.Contacts``) with the impulses the
solver applied at each point over the step (``World.contacts``).

``Events`` (``World.events``, docs/toolkit.md): body pairs that started or stopped
touching, bodies that entered or left a sensor, and hits (pairs that struck each other
faster than ``Settings.hit_speed``). Each is computed from the step's contacts with a
few vectorized numpy operations over the contact and pair arrays (no Python loop), and
only when ``World.events`` is read: a step costs nothing more for it.

Touching: a body pair touches after a step when one of the contacts found in that
step (at its start) is deeper than ``-Settings.linear_slop`` (a resting contact
hovers about zero depth: the slop keeps it from flickering) or carried a normal
impulse during the step (a speculative contact the bodies closed: they met within the
step, as its hit says). A sensor overlaps a visitor when a contact found at the start
of the step is deeper than 0 (true overlap; sensors take no impulse).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .collide.contacts import Contacts

__all__ = ["Events", "Hits", "StepReport", "WorldContacts", "pair_keys", "pairs_of",
           "sensor_overlaps"]


@dataclass
class WorldContacts(Contacts):
    """``Contacts`` (K rows) with the impulses of the step that found them.

    normal_impulse: (K,) N s, the normal impulse the solver applied at the point over
    the whole step (every substep's, and restitution's): b was pushed by
    +normal_impulse * normal, a by the opposite. A box of mass m resting on the ground
    carries m g dt over its contacts.
    tangent_impulse: (K,) N s, the friction impulse over the step along the tangent
    t = (normal_y, -normal_x) (the normal turned clockwise), on b (a: the opposite).
    Contacts of sleeping islands keep the impulses of the step they fell asleep in.
    """

    normal_impulse: np.ndarray = None        # type: ignore[assignment]
    tangent_impulse: np.ndarray = None       # type: ignore[assignment]

    @classmethod
    def empty(cls) -> WorldContacts:
        return cls.of(Contacts.empty(), np.zeros(0), np.zeros(0))

    @classmethod
    def of(cls, contacts: Contacts, normal_impulse: np.ndarray,
           tangent_impulse: np.ndarray) -> WorldContacts:
        """``contacts`` with the given impulses (K,) each."""
        return cls(contacts.body_a, contacts.body_b, contacts.point, contacts.normal,
                   contacts.depth, contacts.feature, normal_impulse, tangent_impulse)


@dataclass
class Hits:
    """H hits of one step, one per body pair: body_a, body_b (H,) int64 (a < b); point
    (H, 2) m, the contact point that approached fastest; normal (H, 2) unit, a -> b;
    speed (H,) m/s, its approach speed (> ``Settings.hit_speed``)."""

    body_a: np.ndarray
    body_b: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    speed: np.ndarray

    def __len__(self) -> int:
        return len(self.speed)


@dataclass
class Events:
    """The events of one step (``World.events``).

    begin, end: (K, 2) int64 body index pairs (lower index first) that started or
    stopped touching in the step. sensor_begin, sensor_end: (K, 2) int64 rows
    (sensor, visitor): a body that started or stopped overlapping a sensor. hit:
    ``Hits``. Rows are sorted by their pair.
    """

    begin: np.ndarray
    end: np.ndarray
    sensor_begin: np.ndarray
    sensor_end: np.ndarray
    hit: Hits


def pair_keys(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """Sorted distinct int64 keys a * n + b of the pairs (a[k], b[k]) (``n`` bodies)."""
    return np.unique(np.asarray(a, np.int64) * np.int64(n) + b)


def pairs_of(keys: np.ndarray, n: int) -> np.ndarray:
    """(K, 2) int64 pairs of ``pair_keys``' keys."""
    return np.stack([keys // n, keys % n], axis=1).reshape(-1, 2)


def touching_keys(parts: list[WorldContacts], n: int, slop: float) -> np.ndarray:
    """Sorted keys of the pairs (a < b) touching in ``parts`` (module docstring: a
    contact deeper than -slop, or one that carried a normal impulse)."""
    if not parts:
        return np.zeros(0, np.int64)
    touch = [(c.depth > -slop) | (c.normal_impulse > 0.0) for c in parts]
    a = np.concatenate([c.body_a[t] for c, t in zip(parts, touch)])
    b = np.concatenate([c.body_b[t] for c, t in zip(parts, touch)])
    return pair_keys(a, b, n)


def difference(new: np.ndarray, old: np.ndarray) -> np.ndarray:
    """The sorted keys of ``new`` not in ``old`` (both sorted, distinct)."""
    if len(old) == 0 or len(new) == 0:
        return new
    where = np.minimum(np.searchsorted(old, new), len(old) - 1)
    return new[old[where] != new]


def hits(contacts: Contacts, relative_velocity: np.ndarray, normal_impulse: np.ndarray,
         threshold: float) -> Hits:
    """Per body pair, the contact that approached fastest, if faster than ``threshold``
    (m/s) and it carried a normal impulse (a speculative point that never touched did
    not hit; Box2D v3's rule). contacts: the step's rows, sorted by pair;
    relative_velocity: (K,) m/s, n.(v_b - v_a) at the start of the step (< 0 approaching,
    ``solver.ContactConstraints``); normal_impulse: (K,) N s over the step."""
    speed = -np.asarray(relative_velocity)
    rows = np.flatnonzero((speed > threshold) & (normal_impulse > 0.0))
    if len(rows):
        a, b = contacts.body_a[rows], contacts.body_b[rows]
        order = np.lexsort((speed[rows], b, a))         # fastest last within a pair
        rows, a, b = rows[order], a[order], b[order]
        last = np.r_[(a[1:] != a[:-1]) | (b[1:] != b[:-1]), True]
        rows = rows[last]
    return Hits(contacts.body_a[rows], contacts.body_b[rows], contacts.point[rows],
                contacts.normal[rows], speed[rows])


def _renumbered(pairs: np.ndarray, index: int) -> np.ndarray:
    """(K, 2) body pairs after body ``index`` is removed: its rows dropped, later bodies
    renumbered."""
    pairs = pairs[np.all(pairs != index, axis=1)]
    return pairs - (pairs > index)


_NO_PAIRS = np.zeros((0, 2), np.int64)


class StepReport:
    """What one step leaves for ``World.events``, mostly references (a step pays for
    none of the events' work; ``events`` computes them on first request).

    touching: the Contacts parts whose pairs touch after the step (the awake contacts
    and the sleeping islands'); previous: the previous report's parts (None: no
    events, an idle step or none before); sensors: (K, 2) (sensor, visitor) pairs
    overlapping after the step, and previous_sensors before it; rows, relative_velocity:
    the step's contact rows (WorldContacts) and their approach speeds for the hits;
    slop, hit_speed: the settings' values at the step.
    """

    def __init__(self, touching: list[Contacts] | None = None,
                 previous: list[Contacts] | None = None,
                 sensors: np.ndarray = _NO_PAIRS, previous_sensors: np.ndarray = _NO_PAIRS,
                 rows: WorldContacts | None = None, relative_velocity: np.ndarray | None = None,
                 slop: float = 0.0, hit_speed: float = np.inf):
        self.touching = touching if touching is not None else []
        self.previous = previous
        self.sensors, self.previous_sensors = sensors, previous_sensors
        self.rows, self.relative_velocity = rows, relative_velocity
        self.slop, self.hit_speed = slop, hit_speed
        self._events: Events | None = None

    def idle(self) -> StepReport:
        """The report of a step that moved nothing: the same touching pairs and
        overlaps, no events."""
        return StepReport(self.touching, None, self.sensors, self.sensors)

    def without_body(self, index: int) -> StepReport:
        """This report after body ``index`` is removed (its pairs dropped, later bodies
        renumbered; events recomputed on request)."""
        def parts(contacts: list[Contacts] | None) -> list[Contacts] | None:
            return None if contacts is None else [c.without_body(index) for c in contacts]
        rows = velocity = None
        if self.rows is not None:
            keep = (self.rows.body_a != index) & (self.rows.body_b != index)
            rows, velocity = self.rows.without_body(index), self.relative_velocity[keep]
        return StepReport(parts(self.touching), parts(self.previous),
                          _renumbered(self.sensors, index),
                          _renumbered(self.previous_sensors, index), rows, velocity,
                          self.slop, self.hit_speed)

    def events(self, n: int) -> Events:
        """The step's events (``n`` bodies), computed once."""
        if self._events is None:
            self._events = self._compute(n)
        return self._events

    def _compute(self, n: int) -> Events:
        none = _NO_PAIRS
        if self.previous is None:
            return Events(none, none, none, none, hits(WorldContacts.empty(), np.zeros(0),
                                                       np.zeros(0), np.inf))
        now = touching_keys(self.touching, n, self.slop)
        before = touching_keys(self.previous, n, self.slop)
        inside = pair_keys(self.sensors[:, 0], self.sensors[:, 1], n)
        outside = pair_keys(self.previous_sensors[:, 0], self.previous_sensors[:, 1], n)
        rows = self.rows if self.rows is not None else WorldContacts.empty()
        velocity = self.relative_velocity if self.rows is not None else np.zeros(0)
        return Events(pairs_of(difference(now, before), n), pairs_of(difference(before, now), n),
                      pairs_of(difference(inside, outside), n),
                      pairs_of(difference(outside, inside), n),
                      hits(rows, velocity, rows.normal_impulse, self.hit_speed))


def sensor_overlaps(contacts: Contacts, sensor: np.ndarray, previous: np.ndarray,
                    movable: np.ndarray) -> np.ndarray:
    """(K, 2) (sensor, visitor) pairs overlapping after a step, sorted: the overlapping
    (depth > 0) sensor contacts found, and the ``previous`` overlaps (K', 2) of pairs
    the step did not test (neither body ``movable`` (B,): sleeping or fixed)."""
    c = contacts.take(contacts.depth > 0.0)
    first = sensor[c.body_a]
    found = np.column_stack([np.where(first, c.body_a, c.body_b),
                             np.where(first, c.body_b, c.body_a)]).reshape(-1, 2)
    kept = previous[~(movable[previous[:, 0]] | movable[previous[:, 1]])]
    pairs = np.concatenate([found, kept])
    if len(pairs) == 0:
        return _NO_PAIRS
    n = np.int64(max(len(movable), 1))
    return pairs_of(pair_keys(pairs[:, 0], pairs[:, 1], n), n)
