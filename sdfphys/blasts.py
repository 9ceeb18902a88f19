"""Timed blasts: ``World.explode_at`` and a scene's ``[[explode]]`` tables.

A blast scheduled at ``time`` (s) runs ``World.explode(center, radius, impulse)`` at
the start of the first step that begins at or after ``time``, before that step's
collisions, so the step already moves the bodies with their new velocities: the rule of
every scheduled event (``sdfphys.scheduled``, with its millionth-of-a-step ``SLACK``),
after the terrain edits due at the same step. Blasts due at the same step run in the
order they were scheduled.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from .errors import check_number
from .limits import MAX_DURATION, check_position
from .scheduled import SLACK, due

__all__ = ["SLACK", "Blast", "check_blast", "fire_due"]


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
    time) that are due at the step about to begin at ``world.time`` (``scheduled.due``)."""
    for blast in due(world._blasts, world.time, world.settings.dt):
        world.explode(blast.center, blast.radius, blast.impulse)
