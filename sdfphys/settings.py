"""Every accuracy knob in one place, with its unit, effect, default and valid range.

The defaults are the ``balanced`` preset (Box2D v3's soft-step defaults, see
docs/solver.md). A scene's ``[sim]`` table and ``--set`` override any knob by name;
``Settings.check(name, value, path)`` validates one value and names the key path
in its error, as the scene loader reports errors. ``Settings.table()`` lists every
knob (the README and ``sdfphys bench`` print it).

Presets (``PRESETS``) were chosen from ``sdfphys bench`` measurements: see
``sdfphys.bench`` for the study and the reasons next to ``PRESETS`` below.
"""

from __future__ import annotations

from dataclasses import Field, dataclass, field, fields, replace
from functools import cache
from typing import Any

from .errors import SpecError, check_int, check_number
from .limits import MIN_DT
from .sdf.gradient import METHODS

__all__ = ["FIELD_REPRESENTATIONS", "GRADIENT_METHODS", "PRESETS", "Settings", "preset"]


@cache
def _knobs(cls: type) -> dict[str, Field]:
    """The knobs of the dataclass ``cls`` by name (``fields`` costs microseconds a call,
    and every derived Settings checks each of its ~40 knobs)."""
    return {f.name: f for f in fields(cls)}


#: Values of ``Settings.gradient``: the fields' own analytic gradients, or a numeric
#: scheme of ``sdfphys.sdf.gradient`` (NumericGradientField) for SDF shapes.
GRADIENT_METHODS = ("analytic",) + METHODS
#: Values of ``Settings.field_representation``: SDF shapes' fields as built, or
#: baked on a grid (``sdfphys.sdf.grid.GridField``, operator ``bake``).
FIELD_REPRESENTATIONS = ("analytic", "grid")


def _knob(default: Any, unit: str, doc: str, *, low: float | None = None,
          low_open: bool = False, least: float | None = None, high: float | None = None,
          choices: tuple[str, ...] = ()) -> Any:
    """A Settings field: default, unit ("" when dimensionless), effect, valid range
    (``least``: the smallest meaningful value above an open ``low``, see ``limits``)."""
    return field(default=default, metadata={"unit": unit, "doc": doc, "low": low,
                                            "low_open": low_open, "least": least,
                                            "high": high, "choices": choices})


@dataclass(frozen=True)
class Settings:
    """Simulation settings (SI units). Frozen: derive variants with ``with_values``.

    Every value is validated on construction (``check``): an invalid value raises
    SpecError naming the knob.
    """

    dt: float = _knob(
        1.0 / 60.0, "s", "Seconds per step. Smaller: more accurate, proportionally more "
        "steps per simulated second.", low=0.0, low_open=True, least=MIN_DT, high=1.0)
    substeps: int = _knob(
        4, "", "Solver substeps per step (h = dt / substeps). More: stiffer contacts, "
        "smaller integration error; cost grows with the solver's share of a step.",
        low=1, high=256)
    relax_passes: int = _knob(
        1, "", "Rigid (bias-free) velocity passes per substep after the biased solve; "
        "they remove the energy the soft bias added.", low=0, high=64)
    warm_starting: bool = _knob(
        True, "", "Start each step from last step's contact impulses (matched by "
        "feature key): steadier stacks at no cost.")
    contact_hertz: float = _knob(
        30.0, "Hz", "Soft contact stiffness (capped at 0.25 x substep rate; doubled "
        "against static bodies). Higher: less overlap, more bounce.", low=0.0,
        low_open=True)
    contact_damping_ratio: float = _knob(
        10.0, "", "Soft contact damping ratio. Higher: overlap removed without "
        "oscillation, more slowly (at 1000 it takes minutes).", low=0.0, high=1e3)
    max_push_out: float = _knob(
        3.0, "m/s", "Cap on the speed at which overlap is removed (no popping).",
        low=0.0, low_open=True)
    soft_depth: float = _knob(
        0.005, "m", "Overlap a contact takes as a soft spring. A contact deeper than this "
        "(re-measured every substep) is rigid and its overlap is pushed out without "
        "entering the velocities (split push-out): packed or jammed bodies separate at most at "
        "max_push_out and are not ejected. 0: every overlap split; a large value: "
        "every contact soft (Box2D v3).", low=0.0)
    split_push_out: float = _knob(
        0.5, "", "Fraction of a split contact's overlap (deeper than soft_depth) pushed out "
        "per substep, at least, capped by max_push_out (a Baumgarte factor on the "
        "pseudo-velocities). 0: at the soft contact's rate alone (0.14 of it a step).",
        low=0.0, high=1.0)
    load_stiffening: bool = _knob(
        True, "", "Stiffen the contacts of a body that carries more than its own weight "
        "in proportion to that load (in islands over stiff_island_limit bodies, up to "
        "large_island_load_cap weights): a heavy box does not sink into a light one, "
        "tall stacks do not buckle.")
    stiff_iterations: int = _knob(
        64, "", "Solver passes per substep, at most, over islands with a mass ratio >= 4 "
        "or a loaded body (they stop once converged); 1: one pass, as elsewhere.",
        low=1, high=1024)
    rest_iterations: int = _knob(
        16, "", "Solver passes per substep, at most, over loaded islands larger than "
        "stiff_island_limit that are at rest (rest_island_limit); after them the smaller "
        "loaded islands go on alone up to stiff_iterations. A base-20 pyramid: 16 moves "
        "its top 4.08 mm in 5 s at 15.7 extra passes a step, 64 4.09 mm at 29.2.",
        low=1, high=1024)
    impact_iterations: int = _knob(
        4, "", "Solver passes per substep, at most, over the exact pairs (circles, "
        "clipped convex polygons) within 4 exact contacts of an impact (a pair that "
        "would close more than soft_depth beyond its gap this step) and the static rows "
        "of the bodies they touch, in islands up to rest_island_limit; they stop once "
        "converged. 150 circles poured into a box: deepest contact 23 mm at 1, 5.1 mm at "
        "4; three boxes struck at 8 m/s: 23.5 mm at 1, 4.9 mm at 4.",
        low=1, high=1024)
    stiff_island_limit: int = _knob(
        64, "", "Largest island (dynamic bodies in contact) that load stiffening and "
        "the extra passes treat (islands at rest: rest_island_limit); larger ones keep "
        "one pass per substep.", low=0,
        high=1_000_000_000)
    rest_island_limit: int = _knob(
        1024, "", "Largest island that load stiffening and the extra passes treat when "
        "none of its contacts is deeper than soft_depth (at rest, no overlap to push "
        "out); islands pushing out overlap keep stiff_island_limit. A base-40 pyramid "
        "(820 boxes) stands with it (top 8.7 mm, 6.3 cm with one pass). Larger islands "
        "are swept in mirrored order (forward, backward, backward, forward): a base-50 "
        "pyramid leaned 33 mm in 3 s in one direction, 1.0 mm mirrored.", low=0,
        high=1_000_000_000)
    large_island_load_cap: float = _knob(
        2.0, "", "Islands over their limit (stiff_island_limit, rest_island_limit; one pass "
        "per substep): load stiffening counts at most this many weights (1: none); stiffer rows "
        "there would need the converged passes.", low=1.0, high=1e6)
    linear_slop: float = _knob(
        0.005, "m", "Length tolerance: contact reduction's merge distance; time of "
        "impact stops a fast body between 1 and 2 slop short of the obstacle.",
        low=0.0, low_open=True, high=1.0)
    speculative_distance: float = _knob(
        0.02, "m", "Contacts are kept while separation < this (plus the pair's reach "
        "at its speed). Larger: fewer late contacts, more contact rows.", low=0.0,
        high=10.0)
    restitution_threshold: float = _knob(
        1.0, "m/s", "Approach speed below which restitution is ignored.", low=0.0)
    hit_speed: float = _knob(
        1.0, "m/s", "Approach speed above which a contact that carried impulse is "
        "reported as a hit (World.events; Box2D v3's hit event threshold). No effect "
        "on the motion.", low=0.0)
    restitution_passes: int = _knob(
        2, "", "Restitution velocity passes after the substeps (one overshoots at "
        "e = 1; 0 disables restitution).", low=0, high=64)
    descent_iterations: int = _knob(
        16, "", "Triangle-field queries (mesh-mesh, mesh-sdf): maximum descent "
        "iterations per start. More: deeper points found exactly, more field "
        "evaluations.", low=1, high=1024)
    descent_starts: int = _knob(
        7, "", "Triangle-field queries: starts per triangle, taken in the order "
        "centroid, 3 edge midpoints, 3 vertices (or the lowest lattice samples, with "
        "descent_lattice). Fewer: cheaper, may miss a second local minimum.",
        low=1, high=7)
    descent_lattice: int = _knob(
        0, "", "Triangle-field queries: 0 takes the descent_starts fixed starts; a "
        "degree d >= 1 samples f at the (d+1)(d+2)/2 points of each triangle's "
        "barycentric lattice (3: 10, 4: 15, 5: 21 points, vertices included), "
        "evaluates up to 2 hidden dips (a minimum between two neighbouring samples that "
        "their values and slopes reveal) and descends from the descent_starts lowest "
        "samples or dips not within one lattice spacing of each other (keys by rank: "
        "less stable under motion than the fixed starts' ids). Costs one field "
        "evaluation per sample; finds separate dips better than as many fixed starts "
        "(4 with 2 starts: every smooth-union query of tools/bench_collide.py under "
        "2 us).", low=0, high=16)
    field_descent_iterations: int = _knob(
        16, "", "Field-field queries (sdf-sdf): maximum descent iterations per start.",
        low=1, high=1024)
    field_descent_starts: int = _knob(
        7, "", "Field-field queries: Halton starts over the overlap region per pair. "
        "More: more separate contact regions found.", low=1, high=1024)
    curvature_anchors: bool = _knob(
        True, "", "A turning sdf body's contact rows are anchored at the centre of "
        "curvature of its surface there, not at its surface point, which rises as the "
        "body turns and lets a rolling or spinning curved body sink by rho dq^2 / 2 a "
        "step (as a circle's rows are: round bodies).")
    predicted_contacts: bool = _knob(
        True, "", "A circle near a body that turns more than linear_slop a step, or that "
        "it moves against by more than that, gets one more speculative row, measured at "
        "the step's end poses, and so do the corners of a turning sdf body touching "
        "another and a concave polygon's vertices moving onto another face: a spinning "
        "corner or a turning horn no longer sweeps through material no row holds, a fast "
        "marble meets a curve ahead of it (deepest contact over each scene's run: "
        "grid_terrain 19.6 -> 6.2 mm, marble_run 12.9 -> 4.1, sdf_primitives 13.1 -> 3.7, "
        "concave_polygons 26.8 -> 10.3, showcase 7.5 -> 6.5). The end-pose queries of sdf "
        "and concave pairs are about a quarter of the showcase's step (6.4-6.9 against "
        "4.9-5.0 ms over 5 s); a pile of 2,000 circles, about 0.1 ms.")
    field_tangent_samples: int = _knob(
        3, "", "Field-field queries: speculative points per side along each contact's "
        "tangent, out to the smaller body's bounding radius, kept where within the "
        "margin: a tilted or rolling sdf body's far side has rows before it lands. "
        "0: none.", low=0, high=64)
    contacts_per_pair: int = _knob(
        4, "", "Contacts kept per body pair after reduction (the deepest plus the "
        "most spread).", low=1, high=64)
    reuse_distance: float = _knob(
        1e-4, "m", "A descent pair's contacts (mesh-sdf, sdf-sdf, circle-sdf, concave "
        "meshes) are kept, carried with the bodies, while the pair has moved less than "
        "this relative to itself since they were found (depth exact to first order, off "
        "by at most twice this); 0: searched anew every step.", low=0.0, high=1.0)
    time_of_impact: bool = _knob(
        True, "", "Conservative advancement for bodies moving more than half their "
        "extent per step, against static and kinematic bodies (no tunnelling through "
        "the ground, walls and platforms; dynamic pairs keep their contact rows).")
    sleeping: bool = _knob(
        True, "", "Islands (bodies in contact) whose every body stays slower than "
        "sleep_speed for time_to_sleep fall asleep: they cost nothing until an awake or "
        "moving body comes within contact range, set_state or remove_body touches them, "
        "or gravity changes (Box2D v3). false: every body is stepped every step.")
    sleep_speed: float = _knob(
        0.05, "m/s", "A body rests while its speed and its bounding radius times its "
        "angular speed stay under this (Box2D v3's sleep threshold).", low=0.0)
    time_to_sleep: float = _knob(
        0.5, "s", "How long every body of an island must rest before it falls asleep.",
        low=0.0)
    max_linear_speed: float = _knob(
        400.0, "m/s", "Speeds above this are clamped in position integration.",
        low=0.0, low_open=True)
    gradient: str = _knob(
        "analytic", "", "Gradient of SDF shapes' fields: their analytic gradient, or "
        "a numeric one (central: 4 extra evaluations, O(h^2); three_point: 2, O(h); "
        "angle_bisection: 19, the seed report's). Circles and meshes stay analytic.",
        choices=GRADIENT_METHODS)
    field_representation: str = _knob(
        "analytic", "", "SDF shapes' fields as built (analytic), or baked on a grid of "
        "grid_cell and interpolated bilinearly (grid: 4 look-ups per query, value "
        "error up to cell / sqrt(2) at kinks). Unbounded fields stay analytic; time "
        "of impact always traces the analytic field.",
        choices=FIELD_REPRESENTATIONS)
    grid_cell: float = _knob(
        0.02, "m", "Node spacing of baked fields (field_representation = grid).",
        low=1e-4, high=1.0)
    carve_cell: float = _knob(
        0.05, "m", "Node spacing of the grid an analytic field is baked on at its first "
        "carve or deposit (World.carve, docs/terrain.md).", low=1e-3, high=1.0)

    def __post_init__(self) -> None:
        for f in fields(self):
            self.check(f.name, getattr(self, f.name))

    def with_values(self, **values: Any) -> Settings:
        """A copy with the given knobs replaced (unknown names raise TypeError)."""
        return replace(self, **values)

    @classmethod
    def names(cls) -> list[str]:
        """Knob names, in declaration order."""
        return [f.name for f in fields(cls)]

    @classmethod
    def check(cls, name: str, value: Any, path: str | None = None) -> Any:
        """``value`` validated for knob ``name`` (ints stay ints, numbers become floats).

        Raises SpecError naming ``path`` (default: the knob's name), e.g.
        ``sim.substeps: must be >= 1, got 0``, for a wrong type, a value out of the
        knob's range or an unknown choice; KeyError for an unknown knob.
        """
        spec = _knobs(cls)
        if name not in spec:
            raise KeyError(f"unknown setting {name!r}")
        f = spec[name]
        meta, path = f.metadata, name if path is None else path
        kind = f.type if isinstance(f.type, str) else f.type.__name__
        if kind == "bool":
            if not isinstance(value, bool):
                raise SpecError(path, f"must be true or false, got {value!r}")
            return value
        if kind == "str":
            if not isinstance(value, str) or value not in meta["choices"]:
                raise SpecError(path, f"must be one of {', '.join(meta['choices'])}; "
                                      f"got {value!r}")
            return value
        if kind == "int":
            return check_int(value, path, low=meta["low"], high=meta["high"])
        value = check_number(value, path, low=meta["low"], low_open=meta["low_open"],
                             high=meta["high"])
        if meta["least"] is not None and value < meta["least"]:
            raise SpecError(path, f"must be >= {meta['least']:g}"
                            + (f" {meta['unit']}" if meta["unit"] else "") + f", got {value:g}")
        return value

    @classmethod
    def describe(cls, name: str) -> str:
        """One line for knob ``name``: unit, effect, default and range."""
        f = {f.name: f for f in fields(cls)}[name]
        meta = f.metadata
        unit = f" [{meta['unit']}]" if meta["unit"] else ""
        if meta["choices"]:
            valid = " | ".join(meta["choices"])
        elif meta["low"] is not None or meta["high"] is not None:
            low = "" if meta["low"] is None else (
                f"{meta['low']:g} {'<' if meta['low_open'] else '<='} ")
            if meta["least"] is not None:
                low = f"{meta['least']:g} <= "
            high = "" if meta["high"] is None else f" <= {meta['high']:g}"
            valid = f"{low}{name}{high}"
        else:
            valid = "true | false"
        return f"{name}{unit}: {meta['doc']} Default {f.default!r}; valid: {valid}."

    @classmethod
    def table(cls) -> str:
        """A markdown table of every knob: name, unit, default, balanced/fast/accurate
        values, effect."""
        rows = ["| knob | unit | fast | balanced (default) | accurate | effect |",
                "|---|---|---|---|---|---|"]
        for f in fields(cls):
            values = [PRESETS[q].get(f.name, f.default) for q in ("fast", "balanced",
                                                                     "accurate")]
            shown = [f"{v:.6g}" if isinstance(v, float) else str(v) for v in values]
            rows.append(f"| {f.name} | {f.metadata['unit'] or '-'} | "
                        + " | ".join(shown) + f" | {f.metadata['doc']} |")
        return "\n".join(rows)


# Why these presets (``sdfphys bench``, full run; see its report for the numbers).
# - A step's cost is almost all collision (one query per step, per pair kind);
#   substeps and relax passes run in one compiled sweep and are nearly free in the
#   suite's scenes, and since the descent kernels the descent knobs save little. So
#   only dt moves the cost per simulated second much, and a 60 Hz preset with fewer
#   substeps would lose accuracy without saving time (it is dominated).
# - fast: 30 Hz with 4 substeps keeps the substep of the old fast (1/60 s, 2
#   substeps: the same solver error, stacks stand the same) at half the cost per
#   simulated second; fewer descent iterations and starts (converged in every bench
#   scene; box-on-box contacts identical, tests/test_narrowphase.py).
# - accurate: 120 Hz with 8 substeps (h = 1/960 s) and 2 relax passes: closed-form
#   errors under 0.2 %, about twice balanced's cost; 32 descent iterations cost
#   nothing measurable (starts stop when converged) and guard fields where 16 are
#   not enough; contacts searched every step (reuse_distance 0: the reference, not
#   the first-order carried contacts). fast costs about a quarter of accurate per
#   simulated second.
#: Quality presets: knob overrides of the defaults (``balanced`` is the defaults).
PRESETS: dict[str, dict[str, Any]] = {
    "fast": {"dt": 1.0 / 30.0, "descent_iterations": 8, "descent_starts": 4,
             "field_descent_iterations": 8},
    "balanced": {},
    "accurate": {"dt": 1.0 / 120.0, "substeps": 8, "relax_passes": 2,
                 "descent_iterations": 32, "reuse_distance": 0.0},
}


def preset(name: str) -> Settings:
    """The Settings of the quality preset ``name`` (fast | balanced | accurate)."""
    if name not in PRESETS:
        raise KeyError(f"unknown quality {name!r}; expected one of {', '.join(PRESETS)}")
    return Settings().with_values(**PRESETS[name])
