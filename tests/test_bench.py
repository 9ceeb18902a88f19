"""The speed/accuracy bench: outputs, trends on the closed-form scenes, and the presets.

The quick bench (``run_bench(quick=True)``, about 10 s) runs once per module. Its
errors are deterministic; its costs come from one run per setting, too noisy for
cost comparisons, which are made in the slow test from medians of five runs.
"""

from __future__ import annotations

import csv
import itertools
import math

import pytest

from sdfphys.bench import (
    COLUMNS,
    QUICK_SCENES,
    QUICK_SWEEPS,
    SCENES,
    bench_main,
    bench_scene,
    preset_summary,
    relevant_knobs,
    run_bench,
)
from sdfphys.settings import PRESETS

CLOSED_FORM = [s for s in QUICK_SCENES if SCENES[s].answer == "closed form"]

#: How much finer dt or more substeps may raise a closed-form error (in units of the
#: answer), per scene, and why:
NOISE = {
    # the drop's error is exactly g h t / 2 (semi-implicit Euler): strictly decreasing
    "free_fall": 1e-12,
    # the sliding acceleration is met to ~1e-9 (settling transients before 0.5 s)
    "incline_slide": 1e-6,
    "sdf_slide": 1e-6,
    # the apex is sampled at step ends: up to g dt^2 / 8 / (e^2 h) = 0.2 % at dt 1/30
    "bounce": 2e-3,
    # the rolling disc's along-slope acceleration has 1-4 % glitches lasting a few
    # steps (its normal row acts at the anchor the disc carried round, not at its
    # lowest point), which land in the measuring window at some substep counts: 1
    # substep measures 0.03 %, 2 measure 0.37 %
    "rolling_disk": 5e-3,
}


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    return run_bench(tmp_path_factory.mktemp("bench"), quick=True)


def test_outputs_have_one_row_per_scene_and_setting(quick):
    with open(quick.csv_path, newline="") as handle:
        reader = csv.DictReader(handle)
        assert tuple(reader.fieldnames) == COLUMNS
        rows = list(reader)
    assert len(rows) == len(quick.rows)
    keys = [(r["scene"], r["setting"]) for r in rows]
    assert len(set(keys)) == len(keys)
    assert list(dict.fromkeys(r["scene"] for r in rows)) == list(QUICK_SCENES)
    for scene in QUICK_SCENES:
        mine = [r for r in rows if r["scene"] == scene]
        assert [r["setting"] for r in mine[:3]] == list(PRESETS)
        for r in mine:
            assert float(r["ms_per_step"]) > 0.0 and int(r["steps"]) > 0
            assert math.isfinite(float(r["error"])) and float(r["error"]) >= 0.0
            assert float(r["ms_per_sim_s"]) == pytest.approx(
                float(r["ms_per_step"]) * int(r["steps"]) / SCENES[scene].duration)
    text = quick.markdown_path.read_text()
    assert "| scene | answer | error | pen. m | ms per 1/60 s |" in text
    assert all(f"| {s} |" in text for s in QUICK_SCENES)
    assert "| substeps |" in text                                # the knob table
    if quick.png_path is None:
        assert any("matplotlib" in n for n in quick.notes)
    else:
        assert quick.png_path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_each_scene_sweeps_only_the_knobs_that_can_act_on_it(quick):
    swept = {s: {r["knob"] for r in quick.rows if r["scene"] == s and r["group"] == "sweep"}
             for s in QUICK_SCENES}
    assert swept["free_fall"] == {"dt", "substeps"}              # no contact at all
    assert swept["rolling_disk"] == {"dt", "substeps"}           # circle-mesh only
    assert swept["incline_slide"] == {"dt", "substeps", "descent_iterations"}
    assert swept["sdf_slide"] == set(QUICK_SWEEPS)               # mesh-sdf: every knob
    counts = {"collide": 5, "circle_circle": 5, "solve": 20, "restitution": 2}
    assert relevant_knobs(counts, ["descent_starts", "gradient", "restitution_passes",
                                   "contact_hertz", "field_descent_starts", "dt"]) == [
        "restitution_passes", "contact_hertz", "dt"]
    # mesh-sdf pairs run a field-field descent for the sdf's view of the mesh.
    assert relevant_knobs({"mesh_sdf": 3, "solve": 12}, ["field_descent_starts"]) == [
        "field_descent_starts"]


@pytest.mark.parametrize("knob", ["dt", "substeps"])
@pytest.mark.parametrize("scene", CLOSED_FORM)
def test_finer_steps_never_raise_a_closed_form_error_beyond_noise(quick, scene, knob):
    """Sweeps in order coarse to fine (dt 1/30, 1/60, 1/120; substeps 1, 2, 4, 8): each
    step, and the finest against the coarsest, within the scene's NOISE."""
    rows = quick.sweep(scene, knob)
    assert [r["value"] for r in rows] == list(QUICK_SWEEPS[knob])
    errors = [r["error"] for r in rows]
    for coarse, fine in itertools.pairwise(errors):
        assert fine <= coarse + NOISE[scene], (knob, errors)
    assert errors[-1] <= errors[0] + NOISE[scene], (knob, errors)


def test_accurate_is_within_one_percent_of_every_closed_form_answer(quick):
    for scene in CLOSED_FORM:
        assert quick.row(scene, "accurate")["error"] < 0.01, scene


def test_presets_are_ordered_in_error(quick):
    """Deterministic half of 'no preset dominated': suite error strictly falls from
    fast to balanced to accurate (the cost half is the slow test below)."""
    error = preset_summary(quick)["error"]
    assert error["fast"] > error["balanced"] > error["accurate"]


def test_bench_main_rejects_bad_usage(capsys):
    assert bench_main(["--frobnicate"]) == 2
    assert "usage: sdfphys bench" in capsys.readouterr().err


@pytest.mark.slow
def test_fast_costs_at_most_a_third_of_accurate_and_no_preset_is_dominated():
    """Every scene under the three presets, cost the median of 5 runs per preset."""
    from sdfphys.bench import BenchResults

    rows = [r for name in SCENES for r in bench_scene(name, {}, 5, 1)]
    summary = preset_summary(BenchResults(rows, None, None, None, 0.0))
    assert summary["fast_over_accurate"] <= 1.0 / 3.0, summary
    assert summary["dominated"] == [], summary
    assert summary["cost"]["fast"] < summary["cost"]["balanced"] < summary["cost"]["accurate"]
    assert summary["accurate_closed_form"] < 0.01, summary
