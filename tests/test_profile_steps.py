"""tools/profile_steps.py: numba's symbols demangled, its perf map names the kernels of
a process that compiled them, and a profile prints them (where perf can record)."""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from tools_module import load_tool

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "profile_steps.py"


def test_short_name_demangles_numba_symbols():
    tool = load_tool("profile_steps")
    mangled = ("_ZN7sdfphys6solver8substeps6_solveB2v5B42c8tJTIeFIjxB2IKSgI4CrvQClUaPLJ"
               "hwEUSBJgA_3dEN5numba942_SubstepBodiesType")
    assert tool.short_name(mangled) == "sdfphys.solver.substeps._solve"
    assert tool.short_name("_ZN7cpython7sdfphys7islands12island_rootsB2v1") == \
        "cpython:sdfphys.islands.island_roots"
    assert tool.short_name("NRT_incref") == "NRT_incref"


@pytest.mark.slow
def test_the_map_names_the_kernels_the_process_compiled():
    """``--map-only`` on ball_drop: the map's lines are ``START SIZE NAME`` with
    increasing starts, positive sizes, and name the substep kernel and the solve."""
    out = subprocess.run([sys.executable, str(TOOL), str(ROOT / "scenes" / "ball_drop.toml"),
                          "--warm", "5", "--map-only"], capture_output=True, text=True,
                         timeout=600, check=True)
    path = Path(out.stdout.strip().splitlines()[-1])
    try:
        rows = [line.split(maxsplit=2) for line in path.read_text().splitlines()]
    finally:
        path.unlink()
    starts = [int(start, 16) for start, _, _ in rows]
    assert starts == sorted(starts) and all(int(size, 16) > 0 for _, size, _ in rows)
    names = {name for _, _, name in rows}
    assert "sdfphys.solver.substeps._substeps_kernel" in names
    assert "sdfphys.solver.substeps._solve" in names


def _perf_records() -> bool:
    if shutil.which("perf") is None:
        return False
    probe = subprocess.run(["perf", "record", "-e", "cpu-clock", "-o", os.devnull, "--",
                            "true"], capture_output=True, text=True)
    return probe.returncode == 0


@pytest.mark.slow
@pytest.mark.skipif(not _perf_records(), reason="perf cannot record here")
def test_a_profile_names_the_solver():
    out = subprocess.run([sys.executable, str(TOOL), "pyramid20", "--warm", "40", "--steps",
                          "40", "--set", "sleeping=false", "--top", "40"],
                         capture_output=True, text=True, timeout=600, check=True)
    assert "ms a step" in out.stdout
    assert "sdfphys.solver.substeps._solve" in out.stdout


def test_callers_charge_each_return_address_to_the_function_below_it():
    tool = load_tool("profile_steps")
    entries = [(0x1000, "a"), (0x2000, "b"), (0x3000, "NRT_incref")]
    calls = {0x1000: 2, 0x1fff: 3, 0x2004: 5, 0x0fff: 7}
    assert tool.callers(entries, calls) == {"a": 5, "b": 5, "?": 7}


def _gdb_attaches() -> bool:
    if shutil.which("gdb") is None:
        return False
    scope = Path("/proc/sys/kernel/yama/ptrace_scope")
    return not scope.exists() or scope.read_text().strip() == "0" or os.geteuid() == 0


@pytest.mark.slow
@pytest.mark.skipif(not _gdb_attaches(), reason="gdb cannot attach here")
def test_refcounts_are_counted_by_caller():
    """``--refcounts`` on the base-20 pyramid: a step's NRT calls are counted and charged
    to the kernels that made them; the solve's are there, and the box pairs' clipping
    makes none (compiled without reference counts)."""
    out = subprocess.run([sys.executable, str(TOOL), "pyramid20", "--warm", "20",
                          "--refcounts", "--set", "sleeping=false", "--top", "200"],
                         capture_output=True, text=True, timeout=600, check=True)
    lines = out.stdout.strip().splitlines()
    head = next(line for line in lines if "calls a step" in line)
    assert float(head.split()[0].replace(",", "")) > 0
    named = {line.split(maxsplit=1)[1] for line in lines[lines.index(head) + 1:]}
    assert "sdfphys.solver.substeps._solve" in named
    assert not any("clip_pair" in name for name in named)


def test_glue_timers_charge_each_stage_its_own_time(monkeypatch):
    """``--glue``'s accounting on a fake clock: a stage's seconds and kernel seconds
    exclude those of the stages it runs; a kernel called by a kernel is not counted
    twice."""
    tool = load_tool("profile_steps")
    now = [0.0]
    monkeypatch.setattr(tool.time, "perf_counter", lambda: now[0])
    timers = tool._Timers()

    def advance(seconds):
        now[0] += seconds

    inner_kernel = timers.kernel(lambda: advance(0.5), "inner")
    kernel = timers.kernel(lambda: (advance(1.0), inner_kernel()), "kernel")
    nested = timers.stage(lambda: (advance(3.0), kernel()), "nested")
    outer = timers.stage(lambda: (advance(2.0), kernel(), nested()), "outer")
    outer()
    assert timers.stages["outer"] == [1, 2.0 + 1.5, 1.5]
    assert timers.stages["nested"] == [1, 3.0 + 1.5, 1.5]
    assert timers.kernel_total == 3.0
    assert timers.kernels == {"kernel": [2, 3.0]}


@pytest.mark.slow
def test_glue_splits_a_step_into_kernels_and_python():
    """``--glue`` on ball_drop: the step's kernels and Python add up to its time, and
    the table names the collision stage and the substep kernel."""
    out = subprocess.run([sys.executable, str(TOOL), str(ROOT / "scenes" / "ball_drop.toml"),
                          "--warm", "5", "--steps", "20", "--glue"], capture_output=True,
                         text=True, timeout=600, check=True).stdout
    head = next(line for line in out.splitlines() if "ms a step" in line)
    total, kernels, python = (float(x) for x in re.findall(r"(\d+\.\d+)", head)[:3])
    assert kernels > 0.0 and python > 0.0
    assert abs(kernels + python - total) <= 0.002
    assert "world_stages.collide" in out
    assert "sdfphys.solver.substeps._substeps_kernel" in out


def test_the_timed_world_starts_after_the_skipped_steps():
    """``--skip N`` times a phase: the timed world is fresh (not the warming one) and has
    run N steps; without it, none."""
    tool = load_tool("profile_steps")
    scene = str(ROOT / "scenes" / "ball_drop.toml")
    skipped = tool.timed_world(scene, [], 3, 7)
    assert skipped.time == pytest.approx(7 * skipped.settings.dt)
    assert tool.timed_world(scene, [], 3, 0).time == 0.0
