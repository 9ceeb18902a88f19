"""Speed against accuracy: what each preset and each knob costs and buys (``sdfphys bench``).

A suite of small scenes with known answers is run under every quality preset and
under a sweep of each accuracy knob with the others at ``balanced``:

closed form (the exact answer of rigid-body mechanics)
    free_fall      a disc falls 1 s: drop g t^2 / 2
    incline_slide  a box slides down 30 degrees, mu 0.2: a = g (sin - mu cos)
    rolling_disk   a disc rolls down 20 degrees, mu 0.5: a = 2/3 g sin
    bounce         a ball (e 0.8) dropped from 1 m: first apex e^2 h
    bullet         a 0.1 m disc at 100 m/s hits a 0.1 m wall: it must not pass it
    sdf_slide      a box slides on an SDF ramp (mesh-sdf pair): a = g (sin - mu cos)
    sdf_roll       an SDF disc rolls on an SDF ramp (sdf-sdf pair): a = 2/3 g sin
converged reference (the same scene under ``REFERENCE``, far finer than accurate)
    box_settle     a tilted box dropped on the ground settles
    pyramid        a 4-box-base pyramid (10 boxes) stands
    circle_pile    16 discs poured into a bin

Measures per (scene, setting), written as one CSV row (``COLUMNS``):

- ``error``: the scene's headline error, dimensionless: for a closed-form scene the
  relative error of its answer (|measured - exact| / |exact|; the bullet's is how far
  it got past the wall's face, in diameters); for a reference scene the RMS
  position error of the bodies' outline points (corners, or centres of discs) at
  ``SAMPLE_TIMES`` against the reference run, divided by the bodies' size (1 m
  boxes; the discs' diameter);
- ``pos_error_m``: RMS position error (m) at ``SAMPLE_TIMES`` against the closed-form
  trajectory or the reference;
- ``max_penetration_m``: the deepest contact found over the run (m; contacts are
  found at the start of each step);
- ``energy_drift``: for scenes that conserve energy (free fall, rolling) the largest
  |E(t) - E(0)|, otherwise the largest gain max(E(t) - E(0), 0), divided by the
  energy the scene can release (m g times its drop);
- ``depth_error_m``: where the exact contact depth is known from the pose (a disc or
  a box on a plane), the largest |deepest contact's depth - exact depth| (m);
- cost: ``ms_per_step`` (wall time of ``World.step`` per step, mean over the steps
  after the first, median over ``runs`` runs; compilation and one-time setup such as
  baking grids fall in the excluded first step or in an untimed warm-up run) and
  ``ms_per_sim_s`` (per simulated second: ms_per_step / dt, the fair cost when dt
  differs).

A knob is swept only on scenes where it can act, read from the balanced run's
``World.stage_counts``: descent knobs where a mesh pair ran, field-field knobs
where an sdf-sdf pair ran, gradient and field representation where an SDF shape
met anything, restitution passes where restitution ran, time of impact where it
ran, the contact knobs where contacts were solved; dt and substeps everywhere.

Outputs in ``out_dir``: ``bench.csv`` (one row per (scene, setting)), ``bench.md``
(the knob table, the presets per scene, the sweep) and, with matplotlib (the
``plot`` extra), ``bench.png``: error against cost per scene with the presets
marked. ``run_bench(out_dir, quick=True)`` runs a reduced suite for tests.

The scenes run one after the other in this process, or with ``--workers N`` /
``--scheduler ADDRESS`` (``run_bench(client=...)``) as one task each on a Dask
cluster, through the machinery of ``sdfphys sweep`` (``sweep.run_tasks``): the same
rows, in the same order; each cost is still timed within one worker process.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .bench_scenes import SAMPLE_TIMES, SCENES, BenchScene, Trace
from .errors import SpecError
from .interrupt import check as check_interrupt
from .interrupt import deferred
from .settings import PRESETS, Settings, preset
from .sweep import cluster, cluster_options, run_tasks

__all__ = ["COLUMNS", "QUICK_SCENES", "QUICK_SWEEPS", "REFERENCE", "SAMPLE_TIMES", "SCENES",
           "SWEEPS", "BenchResults", "BenchScene", "bench_main", "bench_scene", "markdown",
           "measure", "preset_summary", "relevant_knobs", "run_bench", "run_scene"]

#: Settings of the converged references: 4x finer steps than 60 Hz, 16 substeps
#: (h = 1/3840 s), stiffer contacts (120 Hz, under the 960 Hz cap), 4 relax and 4
#: restitution passes, 64 descent iterations, 16 field-field starts, 8 contacts per
#: pair. ``reference_spread`` in the full bench compares it with twice finer steps.
REFERENCE = Settings(dt=1.0 / 240.0, substeps=16, relax_passes=4, contact_hertz=120.0,
                     restitution_passes=4, descent_iterations=64,
                     field_descent_iterations=64, field_descent_starts=16,
                     contacts_per_pair=8)

#: Swept values of each knob (the others at balanced); grid_cell is swept with
#: field_representation = "grid".
SWEEPS: dict[str, tuple[Any, ...]] = {
    "dt": (1.0 / 30.0, 1.0 / 60.0, 1.0 / 120.0, 1.0 / 240.0),
    "substeps": (1, 2, 4, 8, 16),
    "relax_passes": (0, 1, 2, 4),
    "contact_hertz": (15.0, 30.0, 60.0, 120.0),
    "contact_damping_ratio": (1.0, 3.0, 10.0, 30.0),
    "warm_starting": (False, True),
    "restitution_passes": (1, 2, 4),
    "speculative_distance": (0.005, 0.02, 0.05),
    "contacts_per_pair": (1, 2, 4, 8),
    "descent_iterations": (2, 4, 8, 16, 32),
    "descent_starts": (1, 2, 4, 7),
    "descent_lattice": (0, 3, 4, 5),
    "field_descent_iterations": (4, 8, 16, 32),
    "field_descent_starts": (1, 3, 7, 16),
    "gradient": ("analytic", "central", "three_point", "angle_bisection"),
    "grid_cell": (0.05, 0.02, 0.01),
    "time_of_impact": (False, True),
    "load_stiffening": (False, True),
    "stiff_iterations": (1, 8, 64),
    "impact_iterations": (1, 4, 16),
    "field_tangent_samples": (0, 3, 6),
    "predicted_contacts": (False, True),
    "curvature_anchors": (False, True),
    "stiff_island_limit": (0, 64),
    "large_island_load_cap": (1.0, 2.0, 4.0),
    "soft_depth": (0.0, 0.005, 0.02, 1.0),
    "split_push_out": (0.0, 0.2, 0.5, 1.0),
    "reuse_distance": (0.0, 1e-4, 1e-3),
}

#: Reduced sweeps of the quick bench.
QUICK_SWEEPS: dict[str, tuple[Any, ...]] = {
    "dt": (1.0 / 30.0, 1.0 / 60.0, 1.0 / 120.0),
    "substeps": (1, 2, 4, 8),
    "descent_iterations": (4, 16),
    "gradient": ("analytic", "central"),
    "grid_cell": (0.05,),
}

#: Scenes of the quick bench (the closed-form ones the tests check, and one reference).
QUICK_SCENES = ("free_fall", "incline_slide", "rolling_disk", "bounce", "sdf_slide",
                "box_settle")

#: CSV columns, in order.
COLUMNS = ("scene", "answer", "setting", "group", "knob", "value", "error", "pos_error_m",
           "max_penetration_m", "energy_drift", "depth_error_m", "ms_per_step",
           "ms_per_sim_s", "steps", "runs")

_CONTACT_KNOBS = ("relax_passes", "contact_hertz", "contact_damping_ratio", "warm_starting",
                  "speculative_distance", "contacts_per_pair", "large_island_load_cap",
                  "soft_depth", "split_push_out")
_SDF_PAIRS = ("circle_sdf", "mesh_sdf", "sdf_sdf")


# ---------------------------------------------------------------------------------------
# Running and measuring
# ---------------------------------------------------------------------------------------


def run_scene(scene: BenchScene, settings: Settings) -> Trace:
    """Run ``scene`` for its duration under ``settings``, recording a Trace."""
    world = scene.build(settings)
    n = round(scene.duration / settings.dt)
    b = len(world)
    com, angle = np.empty((n + 1, b, 2)), np.empty((n + 1, b))
    velocity, energy = np.empty((n + 1, b, 2)), np.empty(n + 1)
    depth, step_s = np.full(n, np.nan), np.empty(n)

    def record(k: int) -> None:
        com[k], angle[k], velocity[k] = world.center_of_mass, world.angle, world.velocity
        energy[k] = world.kinetic_energy() + world.potential_energy()

    record(0)
    for k in range(n):
        t0 = time.perf_counter()
        world.step()
        step_s[k] = time.perf_counter() - t0
        check_interrupt()
        d = world.contacts.depth
        if len(d):
            depth[k] = float(np.max(d))
        record(k + 1)
    return Trace(settings.dt, com, angle, velocity, energy, depth, step_s,
                 dict(world.stage_counts))


def _ms_per_step(trace: Trace) -> float:
    """Mean wall ms per step over the steps after the first (one-time work excluded)."""
    times = trace.step_s[1:] if len(trace.step_s) > 1 else trace.step_s
    return 1e3 * float(np.mean(times))


def _reference_error(scene: BenchScene, trace: Trace, reference: Trace
                     ) -> tuple[float, float]:
    """(RMS outline-point error / size, RMS error m) at the sample times."""
    errors = []
    for t in SAMPLE_TIMES:
        if t <= scene.duration + 1e-9:
            diff = scene.points(trace, trace.at(t)) - scene.points(reference, reference.at(t))
            errors.append(np.sum(diff * diff, axis=1))
    rms = float(np.sqrt(np.mean(np.concatenate(errors))))
    return rms / scene.size, rms


def measure(scene: BenchScene, trace: Trace, reference: Trace | None = None
            ) -> dict[str, float]:
    """The error columns of one run (see the module docstring)."""
    if scene.answer == "reference":
        error, pos_error = _reference_error(scene, trace, reference)
    else:
        error, pos_error = scene.evaluate(trace)
    change = (trace.energy - trace.energy[0]) / scene.energy_scale
    drift = float(np.max(np.abs(change)) if scene.conservative else max(np.max(change), 0.0))
    found = trace.depth[np.isfinite(trace.depth)]
    depth_error = math.nan
    if scene.exact_depth is not None and len(found):
        exact = scene.exact_depth(trace)
        seen = np.isfinite(trace.depth)
        depth_error = float(np.max(np.abs(trace.depth[seen] - exact[seen])))
    return {"error": float(error), "pos_error_m": float(pos_error),
            "max_penetration_m": float(max(np.max(found), 0.0)) if len(found) else 0.0,
            "energy_drift": drift, "depth_error_m": depth_error}


def relevant_knobs(counts: dict[str, int], knobs: Sequence[str]) -> list[str]:
    """The knobs of ``knobs`` that can act on a scene whose balanced run counted ``counts``."""
    ran = {k for k, v in counts.items() if v > 0}
    mesh = bool(ran & {"mesh_mesh", "mesh_sdf"})
    fields = bool(ran & {"mesh_sdf", "sdf_sdf"})     # mesh-sdf runs a field-field descent too
    rules = {
        "descent_iterations": mesh, "descent_starts": mesh, "descent_lattice": mesh,
        "field_descent_iterations": fields, "field_descent_starts": fields,
        "field_tangent_samples": "sdf_sdf" in ran,
        "gradient": bool(ran & set(_SDF_PAIRS)), "grid_cell": bool(ran & set(_SDF_PAIRS)),
        "reuse_distance": bool(ran & set(_SDF_PAIRS)),     # kept contacts: descent pairs
        "curvature_anchors": bool(ran & set(_SDF_PAIRS)),  # turning sdf bodies
        "restitution_passes": "restitution" in ran,
        "time_of_impact": "time_of_impact" in ran,
    }
    # Loaded islands (solver.row_softness): these knobs act only where extra passes ran.
    rules.update(dict.fromkeys(("load_stiffening", "stiff_iterations", "stiff_island_limit",
                                "impact_iterations"), "converge" in ran))
    rules.update(dict.fromkeys(_CONTACT_KNOBS, "solve" in ran))
    return [k for k in knobs if rules.get(k, True)]


def _sweep_settings(knob: str, value: Any) -> Settings:
    base = Settings()
    if knob == "grid_cell":
        return base.with_values(field_representation="grid", grid_cell=value)
    return base.with_values(**{knob: value})


def _label(knob: str, value: Any) -> str:
    if knob == "dt":
        return f"dt=1/{round(1.0 / value)}"
    if knob == "grid_cell":
        return f"grid_cell={value:g}"
    return f"{knob}={value:g}" if isinstance(value, float) else f"{knob}={value}"


@dataclass
class BenchResults:
    """Rows (dicts keyed by COLUMNS), output paths, wall seconds, notes."""

    rows: list[dict[str, Any]]
    csv_path: Path
    markdown_path: Path
    png_path: Path | None
    seconds: float
    notes: list[str] = field(default_factory=list)

    def row(self, scene: str, setting: str) -> dict[str, Any]:
        """The row of (scene, setting)."""
        for r in self.rows:
            if r["scene"] == scene and r["setting"] == setting:
                return r
        raise KeyError((scene, setting))

    def sweep(self, scene: str, knob: str) -> list[dict[str, Any]]:
        """Rows of ``knob``'s sweep on ``scene`` in swept order (balanced included)."""
        rows = [r for r in self.rows if r["scene"] == scene and r["knob"] == knob]
        base = Settings()
        default = base.grid_cell if knob == "grid_cell" else getattr(base, knob)
        if knob != "grid_cell" and rows:
            rows.append({**self.row(scene, "balanced"), "knob": knob, "value": default})
        order = {v: i for i, v in enumerate(SWEEPS[knob])}
        return sorted(rows, key=lambda r: order.get(r["value"], -1))


def _evaluate(scene: BenchScene, settings: Settings, runs: int,
              reference: Trace | None) -> tuple[dict[str, float], Trace]:
    """Errors from the first run, cost as the median over ``runs`` runs."""
    trace = run_scene(scene, settings)
    costs = [_ms_per_step(trace)]
    for _ in range(runs - 1):
        costs.append(_ms_per_step(run_scene(scene, settings)))
    row = measure(scene, trace, reference)
    ms = statistics.median(costs)
    row.update(ms_per_step=ms, ms_per_sim_s=ms / settings.dt, steps=len(trace.step_s),
               runs=runs)
    return row, trace


def bench_scene(name: str, sweeps: dict[str, tuple[Any, ...]], preset_runs: int,
                sweep_runs: int, notes: list[str] | None = None) -> list[dict[str, Any]]:
    """The rows of one scene: each preset (cost the median of ``preset_runs`` runs),
    then each relevant knob of ``sweeps`` (``sweep_runs``); a reference scene first
    runs its reference, and with ``notes`` also two finer variants of it, whose
    distance from the reference is noted (the reference's own uncertainty)."""
    scene = SCENES[name]
    reference = None
    if scene.answer == "reference":
        reference = run_scene(scene, REFERENCE)
        if notes is not None:
            spread = [_reference_error(scene, run_scene(scene, variant), reference)[0]
                      for variant in (REFERENCE.with_values(dt=REFERENCE.dt / 2.0),
                                      REFERENCE.with_values(contact_hertz=240.0))]
            notes.append(f"{name}: the reference moves by {spread[0]:.2e} with dt / 2 and "
                         f"by {spread[1]:.2e} with 240 Hz contacts (error units)")
    run_scene(scene, Settings())                    # warm-up: compile, bake
    rows = []
    counts: dict[str, int] = {}
    for quality in PRESETS:
        row, trace = _evaluate(scene, preset(quality), preset_runs, reference)
        rows.append({"scene": name, "answer": scene.answer, "setting": quality,
                     "group": "preset", "knob": "", "value": "", **row})
        if quality == "balanced":
            counts = trace.stage_counts
    for knob in relevant_knobs(counts, list(sweeps)):
        for value in sweeps[knob]:
            settings = _sweep_settings(knob, value)
            if settings == Settings():
                continue
            row, _ = _evaluate(scene, settings, sweep_runs, reference)
            rows.append({"scene": name, "answer": scene.answer,
                         "setting": _label(knob, value), "group": "sweep", "knob": knob,
                         "value": value, **row})
    return rows


def _bench_task(job: tuple[str, bool]) -> tuple[list[dict[str, Any]], list[str]]:
    """The rows and notes of one scene (a task of ``run_bench``): ``job`` is its name and
    whether the bench is the quick one."""
    name, quick = job
    notes: list[str] = []
    rows = bench_scene(name, QUICK_SWEEPS if quick else SWEEPS, 1 if quick else 5,
                       1 if quick else 3, None if quick else notes)
    return rows, notes


def run_bench(out_dir: str | Path, quick: bool = False,
              progress: Callable[[str], None] | None = None,
              client: Any = None) -> BenchResults:
    """Run the study and write ``bench.csv``, ``bench.md`` and ``bench.png`` in ``out_dir``.

    quick: the QUICK_SCENES with QUICK_SWEEPS and one timed run per setting (for
    tests); otherwise every scene, every sweep, presets timed as the median of 5
    runs and sweep settings of 3, and the references checked against finer ones.
    progress: called with one line per scene as it finishes. client: a Dask client
    (``sweep.cluster``) to run the scenes on as tasks; None: in this process.
    """
    start = time.perf_counter()
    out = _output_directory(out_dir)
    names = QUICK_SCENES if quick else tuple(SCENES)
    scenes: dict[str, tuple[list[dict[str, Any]], list[str]]] = {}
    for (name, _), (rows, notes) in run_tasks(_bench_task, [(n, quick) for n in names],
                                               client):
        scenes[name] = rows, notes
        if progress is not None:
            progress(f"{name}: {len(rows)} settings, {time.perf_counter() - start:.0f} s")
    rows = [r for name in names for r in scenes[name][0]]
    notes = [n for name in names for n in scenes[name][1]]
    csv_path, md_path = out / "bench.csv", out / "bench.md"
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    try:
        _write_new(csv_path, lambda path: _write_csv(rows, path), written)
        png_path = out / "bench.png"
        if not _write_new(png_path, lambda path: _plot(rows, path, notes) is not None,
                          written):
            png_path = None
        results = BenchResults(rows, csv_path, md_path, png_path, 0.0, notes)
        results.seconds = time.perf_counter() - start
        _write_new(md_path, lambda path: path.write_text(markdown(results)), written)
    except BaseException:
        with deferred():
            for path in written:
                path.unlink(missing_ok=True)
            if created and not any(out.iterdir()):
                out.rmdir()
        raise
    return results


def _output_directory(out_dir: str | Path) -> Path:
    """``out_dir`` as a Path, or a SpecError if it cannot be the output directory (an
    existing file, or under one); checked before the study runs."""
    out = Path(out_dir)
    for parent in (out, *out.parents):
        if parent.exists():
            if not parent.is_dir():
                where = "is" if parent == out else f"is under {str(parent)!r}, which is"
                raise SpecError("", f"{where} a file, not a directory: bench writes "
                                "bench.csv, bench.md and bench.png into a directory "
                                "(existing ones are replaced)", str(out_dir))
            if not os.access(parent, os.W_OK):
                raise SpecError("", f"cannot write in {str(parent)!r}", str(out_dir))
            break
    return out


def _write_new(path: Path, write: Callable[[Path], Any], written: list[Path]) -> bool:
    """``write(temporary)`` to a hidden temporary file beside ``path``, renamed onto
    ``path`` (replacing it) once complete and appended to ``written``. A ``write`` that
    returns False wrote nothing (no matplotlib: no PNG): then so does this."""
    with deferred():
        handle, name = tempfile.mkstemp(prefix=f".{path.stem}.",
                                        suffix=f".partial{path.suffix}", dir=path.parent)
        os.close(handle)
    temporary = Path(name)
    try:
        if write(temporary) is False:
            temporary.unlink()
            return False
        with deferred():
            os.replace(temporary, path)
            written.append(path)
    except BaseException:
        with deferred():
            temporary.unlink(missing_ok=True)
        raise
    return True


# ---------------------------------------------------------------------------------------
# Summaries and outputs
# ---------------------------------------------------------------------------------------


def preset_summary(results: BenchResults) -> dict[str, Any]:
    """Suite-level comparison of the presets.

    cost[q]: ms per 1/60 s of simulated time (ms_per_sim_s / 60) summed over the
    scenes, the fair unit when presets differ in dt (per step when dt = 1/60);
    error[q]: geometric mean over the scenes of max(error, 1e-6) (the floor keeps an
    answer met to round-off from deciding the mean); dominated: presets that some
    other preset matches or beats on both; fast_over_accurate: cost ratio;
    accurate_closed_form: the largest closed-form error under accurate.
    """
    scenes = list(dict.fromkeys(r["scene"] for r in results.rows))
    cost = {q: sum(results.row(s, q)["ms_per_sim_s"] / 60.0 for s in scenes) for q in PRESETS}
    error = {q: float(np.exp(np.mean([math.log(max(results.row(s, q)["error"], 1e-6))
                                      for s in scenes]))) for q in PRESETS}
    dominated = {q for q in PRESETS for p in PRESETS
                 if p != q and cost[p] <= cost[q] and error[p] <= error[q]}
    closed = [results.row(s, "accurate")["error"] for s in scenes
              if results.row(s, "accurate")["answer"] == "closed form"]
    return {"cost": cost, "error": error, "dominated": sorted(dominated),
            "fast_over_accurate": cost["fast"] / cost["accurate"],
            "accurate_closed_form": max(closed) if closed else math.nan}


def _write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        for r in rows:
            writer.writerow({k: r[k] for k in COLUMNS})


def _fmt(x: Any) -> str:
    if isinstance(x, float):
        if math.isnan(x):
            return "-"
        return f"{x:.2e}" if x != 0.0 and (abs(x) < 1e-2 or abs(x) >= 1e4) else f"{x:.3g}"
    return str(x)


def markdown(results: BenchResults) -> str:
    """The report: presets per scene, the suite summary, the sweep, the knob table."""
    scenes = list(dict.fromkeys(r["scene"] for r in results.rows))
    qualities = " / ".join(PRESETS)
    lines = [f"# sdfphys bench ({results.seconds:.0f} s)", "",
             ("error: relative error of the closed-form answer, or RMS outline error "
              "against the reference / body size; pen.: deepest contact, m; cost: ms of "
              "wall time per 1/60 s simulated (= ms per step at dt = 1/60). Definitions: "
              "`sdfphys.bench`."), "",
             f"## Presets ({qualities})", "",
             "| scene | answer | error | pen. m | ms per 1/60 s |", "|---|---|---|---|---|"]
    for s in scenes:
        rows = [results.row(s, q) for q in PRESETS]
        cells = [" / ".join(_fmt(r[key] / (60.0 if key == "ms_per_sim_s" else 1.0))
                            for r in rows)
                 for key in ("error", "max_penetration_m", "ms_per_sim_s")]
        lines.append(f"| {s} | {rows[0]['answer']} | " + " | ".join(cells) + " |")
    summary = preset_summary(results)
    lines += ["", "Suite: " + "; ".join(
        f"{q} {summary['cost'][q]:.1f} ms per 1/60 s, error {summary['error'][q]:.2e}"
        for q in PRESETS) + f". fast / accurate cost {summary['fast_over_accurate']:.2f}; "
        f"dominated: {', '.join(summary['dominated']) or 'none'}; largest closed-form "
        f"error under accurate {summary['accurate_closed_form']:.2e}.", "",
        "## Sweep (others at balanced): error / ms per 1/60 s", "",
        "| setting | " + " | ".join(scenes) + " |", "|---|" + "---|" * len(scenes)]
    settings = list(dict.fromkeys(r["setting"] for r in results.rows if r["group"] == "sweep"))
    for label in ["balanced"] + settings:
        cells = []
        for s in scenes:
            try:
                r = results.row(s, label)
                cells.append(f"{_fmt(r['error'])} / {_fmt(r['ms_per_sim_s'] / 60.0)}")
            except KeyError:
                cells.append("")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += ["", "Empty cells: the knob cannot act on that scene (not run).", "",
              "## Scenes", ""] + [f"- {s}: {SCENES[s].description} ({SCENES[s].answer}, "
                                  f"{SCENES[s].duration:g} s)" for s in scenes] + [
              "", "## Notes", ""] + [f"- {n}" for n in results.notes] + [
              f"- reference settings: {REFERENCE}", "", "## Knobs", "", Settings.table(), ""]
    return "\n".join(lines)


def _plot(rows: list[dict[str, Any]], path: Path, notes: list[str]) -> Path | None:
    """Error against ms per simulated second, one panel per scene; None (and a note)
    without matplotlib."""
    try:
        from matplotlib import colormaps
        from matplotlib.figure import Figure
        from matplotlib.ticker import FormatStrFormatter, LogLocator
    except ImportError:
        notes.append("matplotlib is not installed (pip install 'sdfphys[plot]'): no PNG")
        return None
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    columns = min(4, len(scenes))
    n_rows = math.ceil(len(scenes) / columns)
    fig = Figure(figsize=(4.2 * columns, 3.6 * n_rows))
    axes = fig.subplots(n_rows, columns, squeeze=False)
    knobs = list(SWEEPS)
    colours = colormaps["tab20"](np.linspace(0.0, 1.0, len(knobs)))
    for ax, s in zip(axes.flat, scenes, strict=False):
        mine = [r for r in rows if r["scene"] == s]
        for r in mine:
            y = max(r["error"], 1e-9)
            if r["group"] == "preset":
                ax.scatter(r["ms_per_sim_s"], y, s=90, marker="*", color="black", zorder=3)
                ax.annotate(r["setting"], (r["ms_per_sim_s"], y), fontsize=8,
                            xytext=(4, 4), textcoords="offset points")
            else:
                ax.scatter(r["ms_per_sim_s"], y, s=14,
                           color=colours[knobs.index(r["knob"])], label=r["knob"])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
        ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(FormatStrFormatter("%g"))
        ax.set_title(s, fontsize=10)
        ax.set_xlabel("ms per simulated second")
        ax.set_ylabel("error")
    for ax in list(axes.flat)[len(scenes):]:
        ax.axis("off")
    handles, labels = [], []
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    fig.legend(handles, labels, loc="lower center", ncol=min(8, len(labels)), fontsize=8)
    fig.tight_layout(rect=(0.0, 0.06, 1.0, 1.0))
    fig.savefig(path, dpi=110)
    return path


def bench_main(argv: Sequence[str] | None = None) -> int:
    """``sdfphys bench [-o DIR] [--quick] [--workers N | --scheduler ADDRESS]``: run the
    study (on a Dask cluster with either option), print the markdown report.

    Exit 0, or 2 for bad usage (argparse), an output directory that cannot be one (an
    existing file: one line saying so, before the study runs) or a cluster that cannot
    be had (no Dask, a scheduler that does not answer). bench.csv, bench.md and
    bench.png in an existing directory are replaced.
    """
    parser = argparse.ArgumentParser(prog="sdfphys bench", description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default="bench-out", metavar="DIR",
                        help="directory for bench.csv, bench.md and bench.png")
    parser.add_argument("--quick", action="store_true", help="the reduced suite (~1 min)")
    cluster_options(parser)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    try:
        _output_directory(args.output)
    except SpecError as err:
        print(f"sdfphys bench: error: -o {err}", file=sys.stderr)
        return 2
    with ExitStack() as stack:
        client = None
        if args.workers is not None or args.scheduler is not None:
            try:
                client = stack.enter_context(cluster(args.workers, args.scheduler))
            except SpecError as err:
                print(f"sdfphys bench: error: {err}", file=sys.stderr)
                return 2
        results = run_bench(args.output, quick=args.quick,
                            progress=lambda line: print(line, flush=True), client=client)
    print(results.markdown_path.read_text())
    print(f"wrote {results.csv_path}, {results.markdown_path}"
          + (f", {results.png_path}" if results.png_path else " (no PNG: see Details)"))
    return 0


if __name__ == "__main__":
    raise SystemExit(bench_main())
