"""tools/bench_vs_peers.py on tiny scenes: its figures are sane and its probe sees overlap."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tools_module import load_tool

from sdfphys.errors import SpecError
from sdfphys.settings import Settings

bench = load_tool("bench_vs_peers")
ENGINES = ["sdfphys", "pymunk", "box2d", "box2d-16"]
CONFIG = bench.Config(Settings(), steps=60, every=5)


def _needs(engine: str) -> None:
    if engine.startswith("box2d"):
        pytest.importorskip("pyb2d3")


def _run(engine: str, layout) -> object:
    probe = bench.probe_of(bench.sdfphys_world(layout, CONFIG.settings))
    run = bench.start(engine, layout, CONFIG)
    return bench.measure(run, CONFIG.steps, probe, CONFIG.every, layout.top)


@pytest.mark.parametrize("engine", ENGINES)
def test_pile_figures_are_sane(engine):
    """20 circles dropped into the box for 1 s: times positive and ordered, the total the
    sum of the steps, overlap well under a radius, no top body."""
    _needs(engine)
    f = _run(engine, bench.pile(20))
    assert 0.0 < f.mean_ms <= f.max_ms and 0.0 < f.p95_ms <= f.max_ms
    assert f.total_s == pytest.approx(CONFIG.steps * f.mean_ms / 1e3)
    assert 0.0 <= f.deepest_mm < 0.5 * 1e3 * bench.RADIUS
    assert math.isnan(f.top_mm)


@pytest.mark.parametrize("engine", ENGINES)
def test_small_pyramid_stands(engine):
    """A base-3 pyramid for 1 s: its top box moves less than the stability suite's 5 cm and
    no contact is deeper than 2 cm (tests/stability: STANDS, NOT_SUNK)."""
    _needs(engine)
    f = _run(engine, bench.pyramid(3))
    assert math.isfinite(f.top_mm) and 0.0 <= f.top_mm < 50.0
    assert 0.0 <= f.deepest_mm < 20.0


@pytest.mark.parametrize("engine", ENGINES)
def test_probe_sees_each_engines_overlap(engine):
    """Built overlapping (two circles by 0.6 m, a circle 0.1 m into a box), every engine's
    poses give the probe those depths: layout order and pose conventions agree."""
    _needs(engine)
    circle, box = {"type": "circle", "radius": 0.5}, {"type": "box", "size": [1.0, 1.0]}
    cases = {0.6: [bench.Body(circle, (0.0, 0.0), 0.5), bench.Body(circle, (0.4, 0.0), 0.5)],
             0.1: [bench.Body(box, (0.0, 0.0), 0.5, static=True),
                   bench.Body(circle, (0.0, 0.9), 0.5)]}
    for depth, bodies in cases.items():
        layout = bench.Layout(tuple(bodies))
        probe = bench.probe_of(bench.sdfphys_world(layout, Settings()))
        poses = bench.start(engine, layout, CONFIG).poses()
        assert bench.deepest(probe, *poses) == pytest.approx(depth, abs=1e-5)


def test_bench_scene_interleaves_runs_and_ratios():
    """Two runs of a 20-circle pile: every engine has two runs, each peer two positive
    ratios (sdfphys over it), and the table cells are the medians."""
    engines = bench.available_engines()
    config = bench.Config(Settings(), steps=20, runs=2, every=10)
    rows = bench.bench_scene("pile20", config, engines)
    assert [r.engine for r in rows] == list(engines)
    for row in rows:
        assert row.bodies == 20 and len(row.runs) == 2
        assert len(row.ratios) == (0 if row.engine == "sdfphys" else 2)
        assert all(r > 0.0 and math.isfinite(r) for r in row.ratios)
        assert float(bench.cells(row)[4]) == pytest.approx(row.median("mean_ms"), rel=5e-3)


def test_peers_are_not_applicable_to_the_showcase():
    for engine in ("pymunk", "box2d", "box2d-16"):
        assert bench.start(engine, None, CONFIG) is None
    cells = bench.cells(bench.Row("showcase", 25, "pymunk"))
    assert cells[3:] == ["n/a"] * (len(bench.COLUMNS) - 3)


def test_box2d_sleeping_read_back():
    pytest.importorskip("pyb2d3")
    layout = bench.pyramid(2)
    assert bench.start("box2d", layout, CONFIG).sleeping == "on"
    no_sleep = bench.Config(Settings(), steps=1, sleep=False)
    assert bench.start("box2d-16", layout, no_sleep).sleeping == "off"


def test_settings_overrides():
    s = bench.sdfphys_settings(["substeps=8", "contact_hertz=60"], no_sleep=False)
    assert (s.substeps, s.contact_hertz) == (8, 60.0)
    assert isinstance(s.contact_hertz, float)
    with pytest.raises(KeyError):
        bench.sdfphys_settings(["no_such_knob=1"], no_sleep=False)
    with pytest.raises(SpecError):
        bench.sdfphys_settings(["substeps=0"], no_sleep=False)
    with pytest.raises(SystemExit):
        bench.parse_args(["--set", "substeps=0"])


def test_scene_names():
    assert bench.parse_scene("pile500") == ("pile", 500)
    assert bench.parse_scene("pyramid100") == ("pyramid", 100)
    assert bench.parse_scene("showcase") == ("showcase", 0)
    for bad in ("pile", "pyramid0", "box20"):
        with pytest.raises(ValueError):
            bench.parse_scene(bad)
    assert len(bench.pyramid(100).bodies) == 1 + 5050
    assert len(bench.pile(5000).bodies) == 3 + 5000


def test_main_prints_and_writes_markdown(tmp_path, capsys):
    out = tmp_path / "table.md"
    bench.main(["--scenes", "pyramid3", "--seconds", "0.1", "--markdown", str(out)])
    printed = capsys.readouterr().out
    assert "pyramid3" in printed and "sdfphys/x" in printed
    rows = [line for line in out.read_text().splitlines() if line.startswith("| pyramid3 |")]
    assert len(rows) == len(bench.available_engines())
    figures = [float(v) for v in rows[0].split("|")[5:10]]
    assert np.all(np.isfinite(figures))
