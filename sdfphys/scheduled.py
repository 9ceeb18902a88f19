"""Scheduled events: queues of timed events that run at the start of a step.

A World keeps two such queues: blasts (``World.explode_at``, a scene's ``[[explode]]``
tables: ``blasts``) and terrain edits (a scene's ``[[carve]]`` tables:
``terrain.schedule``). Each is a list of events with a ``time`` (s), sorted by time,
events of equal time in the order they were scheduled (``add``). An event runs at the
start of the first step that begins at or after its time (``due``): before that step's
collisions, so the step already moves the bodies as the event left them. A step begins
at ``world.time``, a sum of dt's whose rounding may leave it a hair under ``k dt``; the
comparison allows a millionth of a step (``SLACK``), so that an event at ``time = k dt``
runs at the start of step k (counted from 0). Within a step, ``World.step`` applies the
edits due first, then the blasts due.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterable, Iterator
from typing import Any

__all__ = ["SLACK", "add", "due"]

#: A step that begins within SLACK * dt before an event's time runs it.
SLACK = 1e-6


def _time(event: Any) -> float:
    return event.time


def add(queue: list, events: Iterable) -> None:
    """Insert ``events`` (each with a ``time``, s) into ``queue`` in place, keeping it
    sorted by time: each goes after the queued events of equal time."""
    for event in events:
        bisect.insort(queue, event, key=_time)


def due(queue: list, time: float, dt: float) -> Iterator:
    """Pop and yield, in order, the events of ``queue`` (sorted by time) due at the step
    about to begin at ``time`` (s) and last ``dt`` (s): those of time at most
    ``time + SLACK dt``. Each is popped as it is yielded: if running one raises, the
    later ones stay queued."""
    limit = time + SLACK * dt
    while queue and queue[0].time <= limit:
        yield queue.pop(0)
