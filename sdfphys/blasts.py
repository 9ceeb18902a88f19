"""Timed blasts: ``World.explode_at`` and a scene's ``[[explode]]`` tables.

A blast scheduled at ``time`` (s) runs ``World.explode(center, radius, impulse)`` at
the start of the first step that begins at or after ``time``: before that step's
collisions, so the step already moves the bodies with their new velocities. A step
begins at ``world.time``, a sum of dt's whose rounding may leave it a hair under
``k dt``; the comparison allows a millionth of a step (``SLACK``), so that a blast at
``time = k dt`` runs at the start of step k (counted from 0). Blasts due at the same
step run in the order they were scheduled.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from .errors import check_number
from .limits import MAX_DURATION, check_position

__all__ = ["SLACK", "Blast", "check_blast", "fire_due"]

#: A step that begins within SLACK * dt before a blast's time runs it.
SLACK = 1e-6


class Blast(NamedTuple):
    """One scheduled blast: time s (>= 0), center (2,) m, radius m (> 0), impulse N s
    per metre of the width facing the blast (>= 0; ``World.explode``)."""

    time: float
    center: tuple[float, float]
    radius: float
    impulse: float


def check_blast(prefix: str = "", *, time: Any, center: Any, radius: Any,
                impulse: Any) -> Blast:
    """The validated blast; a bad value raises one SpecError naming ``prefix.key``
    (``explode[0].radius: must be > 0, got -1``)."""
    def path(key: str) -> str:
        return f"{prefix}.{key}" if prefix else key

    return Blast(check_number(time, path("time"), low=0.0, high=MAX_DURATION),
                 check_position(center, path("center")),
                 check_number(radius, path("radius"), low=0.0, low_open=True),
                 check_number(impulse, path("impulse"), low=0.0))


def fire_due(world) -> None:
    """Run (``world.explode``) and drop the blasts of ``world._blasts`` (sorted by
    time) that are due at the step about to begin at ``world.time``."""
    due = world.time + SLACK * world.settings.dt
    while world._blasts and world._blasts[0].time <= due:
        blast = world._blasts.pop(0)
        world.explode(blast.center, blast.radius, blast.impulse)
