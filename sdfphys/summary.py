"""What ``sdfphys run`` reports of a run, and the loop that measures it.

``simulate`` steps a world and returns a ``RunSummary``: steps, wall time, the deepest
contact, the energy at the start and the end and ``state_hash`` of the final state.
``sdfphys run`` prints it; ``sdfphys sweep`` writes it as a CSV row, so a sweep's hash
of a setting is the one ``run`` prints for it.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import _warm, interrupt

__all__ = ["RunSummary", "simulate", "state_hash", "steps_for"]


def state_hash(world) -> str:
    """SHA-256 (first 16 hex digits) of the bodies' positions, angles and velocities."""
    digest = hashlib.sha256()
    for array in (world.position, world.angle, world.velocity, world.angular_velocity):
        digest.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
    return digest.hexdigest()[:16]


def steps_for(seconds: float, dt: float) -> int:
    """The steps of a run of ``seconds`` simulated seconds at ``dt``: at least one."""
    return max(1, round(seconds / dt))


@dataclass(frozen=True)
class RunSummary:
    """One run: ``wall_s`` the whole loop, ``first_step_s`` its first step (which loads
    or compiles the kernels), ``max_penetration`` the deepest contact found (m), the
    total energy (J) at the start and the end, and ``state_hash`` of the final state."""

    steps: int
    wall_s: float
    first_step_s: float
    max_penetration: float
    energy_start: float
    energy_end: float
    state_hash: str

    @property
    def ms_per_step(self) -> float:
        """Mean wall ms of the steps after the first (of the only one if there is one)."""
        if self.steps == 1:
            return 1e3 * self.wall_s
        return 1e3 * (self.wall_s - self.first_step_s) / (self.steps - 1)


def _energy(world) -> float:
    return world.kinetic_energy() + world.potential_energy()


def simulate(world, steps: int, before_step: Callable[[int], None] | None = None,
             progress: Callable[[int], None] | None = None) -> RunSummary:
    """Step ``world`` ``steps`` times. ``before_step(k)`` runs before step k and once
    more after the last (k = steps), inside the timed loop (``run`` draws its frames
    there); ``progress(k)`` after step k (1-based)."""
    _warm.start(world)      # before the first frame: its field evaluator compiles too
    energy_start = _energy(world)
    max_depth = 0.0
    first = 0.0
    start = time.perf_counter()
    for step in range(steps):
        if before_step is not None:
            before_step(step)
        world.step()
        if step == 0:
            first = time.perf_counter() - start
        interrupt.check()
        if len(world.contacts):
            max_depth = max(max_depth, float(world.contacts.depth.max()))
        if progress is not None:
            progress(step + 1)
    if before_step is not None:
        before_step(steps)
    wall = time.perf_counter() - start
    return RunSummary(steps, wall, first, max_depth, energy_start, _energy(world),
                      state_hash(world))
