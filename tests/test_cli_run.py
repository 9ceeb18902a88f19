"""`sdfphys run`: videos with seconds x fps frames, summaries, and every scene running."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

import sdfphys

ROOT = Path(__file__).resolve().parents[1]
SCENES = sorted((ROOT / "scenes").glob("*.toml"))


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sdfphys.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=ROOT, check=False)


def test_mp4_has_seconds_times_fps_frames(tmp_path):
    out = tmp_path / "drop.mp4"
    result = run_cli("run", "scenes/restitution_row.toml", "-o", out, "--seconds", "0.75",
                     "--set", "render.fps=40", "--set", "render.size=[321, 181]")
    assert result.returncode == 0, result.stderr
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(out))
    assert frames == 30
    assert "steps          45" in result.stdout
    assert "state hash" in result.stdout


def test_png_folder_and_gif(tmp_path):
    folder = tmp_path / "frames"
    result = run_cli("run", "scenes/newtons_cradle.toml", "-o", f"{folder}/", "--seconds", "0.25",
                     "--set", "render.size=[160, 90]")
    assert result.returncode == 0, result.stderr
    assert len(list(folder.glob("*.png"))) == 15
    gif = tmp_path / "cradle.gif"
    result = run_cli("run", "scenes/newtons_cradle.toml", "-o", gif, "--seconds", "0.48",
                     "--set", "render.size=[160, 90]", "--set", "render.fps=25")
    assert result.returncode == 0, result.stderr
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(gif))
    assert frames == 12


def test_unsupported_output_is_exit_2_one_line(tmp_path):
    out = tmp_path / "movie.avi"
    result = run_cli("run", "scenes/newtons_cradle.toml", "-o", out, "--seconds", "0.1")
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize("args, message", [
    (["run", "scenes/missing.toml"], "no such scene file"),
    (["run", "scenes/newtons_cradle.toml", "--seconds", "-1"], "--seconds: must be a positive"),
    (["run", "scenes/newtons_cradle.toml", "--set", "sim.substeps"], "--set: expected KEY=VALUE"),
    (["run", "scenes/newtons_cradle.toml", "--set", "sim.substeps=0"], "sim.substeps: must be >= 1"),
])
def test_bad_arguments_exit_2_one_line(args, message):
    result = run_cli(*args)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_every_scene_loads_and_steps(path):
    world = sdfphys.load_scene(path)
    for _ in range(3):
        world.step()
    assert np.all(np.isfinite(world.position)) and np.all(np.isfinite(world.velocity))


@pytest.mark.slow
@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_every_scene_runs_to_the_end(path):
    """The whole ``sim.duration``: state finite every step, no body ejected far away (a
    piece a carve cut off, ``<name>.<k>``, measured from its body's start)."""
    scene = sdfphys.read_scene(path)
    world = scene.build()
    start = dict(zip(world.names, world.position.copy()))
    for _ in range(round(scene.duration / scene.settings.dt)):
        world.step()
        assert np.all(np.isfinite(world.position)) and np.all(np.isfinite(world.velocity))
    origin = np.array([start[name if name in start else name.rsplit(".", 1)[0]]
                       for name in world.names])
    assert np.max(np.abs(world.position - origin)) < 100.0


def test_compare_reports_and_refuses_what_pymunk_cannot_model():
    result = run_cli("compare", "scenes/ball_drop.toml", "--seconds", "1")
    assert result.returncode == 0, result.stderr
    assert "contacts at sdfphys's poses" in result.stdout
    assert "trajectories from the same initial state" in result.stdout
    result = run_cli("compare", "scenes/csg_bodies.toml")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "pymunk cannot model" in lines[0] and "csg0" in lines[0]


def test_bench_quick_writes_its_outputs(tmp_path):
    result = run_cli("bench", "--quick", "-o", tmp_path / "bench")
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "bench" / "bench.csv").is_file()
    assert (tmp_path / "bench" / "bench.md").is_file()


def test_bench_bad_usage_is_exit_2():
    assert run_cli("bench", "--quik").returncode == 2
