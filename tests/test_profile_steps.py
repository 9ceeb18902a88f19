"""tools/profile_steps.py: numba's symbols demangled, its perf map names the kernels of
a process that compiled them, and a profile prints them (where perf can record)."""

import os
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
