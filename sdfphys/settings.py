"""Every accuracy knob in one place, with its unit, effect and default.

The defaults are the ``balanced`` preset (Box2D v3's soft-step defaults, see
SOLVER.md). A scene's ``[sim]`` table and ``--set`` override any knob by name.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

__all__ = ["PRESETS", "Settings", "preset"]


@dataclass(frozen=True)
class Settings:
    """Simulation settings (SI units). Frozen: derive variants with ``replace``."""

    dt: float = 1.0 / 60.0
    """Seconds per step. Smaller: more accurate, proportionally slower."""
    substeps: int = 4
    """Solver substeps per step (h = dt / substeps). More: stiffer, more accurate contacts."""
    relax_passes: int = 1
    """Rigid (bias-free) velocity passes per substep after the biased solve."""
    warm_starting: bool = True
    """Start each step from last step's contact impulses (matched by feature key)."""
    contact_hertz: float = 30.0
    """Soft contact stiffness, Hz (capped at 0.25 x substep rate; doubled against static)."""
    contact_damping_ratio: float = 10.0
    """Soft contact damping ratio (dimensionless)."""
    max_push_out: float = 3.0
    """Cap on the speed at which overlap is removed, m/s."""
    linear_slop: float = 0.005
    """Length tolerance, m: contact reduction's merge distance; time of impact stops a fast
    body between 1 and 2 slop short of the obstacle. (The soft solver pushes out to s = 0.)"""
    speculative_distance: float = 0.02
    """Contacts are kept while separation < this, m (4 x slop)."""
    restitution_threshold: float = 1.0
    """Approach speed below which restitution is ignored, m/s."""
    restitution_passes: int = 2
    """Restitution velocity passes after the substeps (one overshoots at e = 1)."""
    descent_iterations: int = 16
    """Maximum descent iterations per start in triangle-field and field-field queries."""
    descent_starts: int = 7
    """Starts per triangle (3 vertices, 3 edge midpoints, centroid) or per field pair."""
    contacts_per_pair: int = 4
    """Contacts kept per body pair after reduction (the deepest plus the most spread)."""
    time_of_impact: bool = True
    """Conservative advancement for bodies moving more than half their extent per step."""
    max_linear_speed: float = 400.0
    """Speeds above this (m/s) are clamped in position integration."""

    def with_values(self, **values) -> Settings:
        """A copy with the given knobs replaced (unknown names raise TypeError)."""
        return replace(self, **values)

    @classmethod
    def names(cls) -> list[str]:
        return [f.name for f in fields(cls)]


#: Quality presets: knob overrides of the defaults (``balanced`` is the defaults).
PRESETS: dict[str, dict[str, float | int | bool]] = {
    "fast": {"substeps": 2, "descent_iterations": 8, "descent_starts": 4},
    "balanced": {},
    "accurate": {"substeps": 8, "relax_passes": 2, "descent_iterations": 32},
}


def preset(name: str) -> Settings:
    """The Settings of the quality preset ``name`` (fast | balanced | accurate)."""
    if name not in PRESETS:
        raise KeyError(f"unknown quality {name!r}; expected one of {', '.join(PRESETS)}")
    return Settings().with_values(**PRESETS[name])
