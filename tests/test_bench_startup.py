"""tools/bench_startup.py: its child mode times numba's compilations; its tables count each
kernel once."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from tools_module import load_tool

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "bench_startup.py"


def child(tmp_path: Path, name: str) -> dict:
    """The tool's child mode on ball_drop (0.2 s) with the cache in tmp_path/cache."""
    out = tmp_path / f"{name}.json"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    subprocess.run([sys.executable, str(TOOL), "--child", str(ROOT / "scenes" / "ball_drop.toml"),
                    str(out), "--seconds", "0.2"], env=env, check=True, capture_output=True,
                   text=True, cwd=tmp_path, timeout=300)
    return json.loads(out.read_text())


@pytest.mark.slow
def test_child_mode_times_the_cold_compilations_and_the_warm_run_compiles_none(tmp_path):
    """About 30 s on 2 cores: a cold compile of ball_drop's kernels, then a warm run."""
    cold = child(tmp_path, "cold")
    assert cold["status"] == 0 and cold["wall_s"] > 0
    ours = [r for r in cold["compiles"] if r["kernel"].startswith("sdfphys.")]
    assert ours
    assert all(0 <= r["self_s"] <= r["total_s"] for r in cold["compiles"])
    # Self times do not overlap: their sum fits in the process's wall time.
    assert sum(r["self_s"] for r in cold["compiles"]) < cold["wall_s"]
    warm = child(tmp_path, "warm")
    assert warm["status"] == 0 and warm["wall_s"] > 0
    assert [r["kernel"] for r in warm["compiles"] if r["kernel"].startswith("sdfphys.")] == []


def record(kernel: str, seconds: float, signature: str = "(float64,)") -> dict:
    return {"kernel": kernel, "signature": signature, "self_s": seconds, "total_s": seconds,
            "failed": False}


def test_tables_count_each_kernel_once_from_the_first_scene_that_compiled_it():
    tool = load_tool("bench_startup")
    runs = {"process_s": 1.0, "compiles": []}
    a = {"process_s": 9.0, "compiles": [record("sdfphys.solver._solve", 2.0),
                                        record("sdfphys.solver._solve", 1.0, "(int64,)"),
                                        record("sdfphys.sdf.compiled.run", 3.5),
                                        record("numba.np.arrayobj.ol_np_empty.<locals>.impl",
                                               0.5)]}
    b = {"process_s": 5.0, "compiles": [record("sdfphys.solver._solve", 2.5),
                                        record("sdfphys.toi.sweep", 0.25)]}
    results = [{"scene": "scenes/a.toml", "cold": a, "warm": runs},
               {"scene": "scenes/b.toml", "cold": b, "warm": runs}]
    assert tool.scene_row("a", a, runs) == [
        "a", "9.0", "1.0", "7.0", "2", "0", "sdf.compiled.run 3.5, solver._solve 3.0, "
        "numba.np.arrayobj.ol_np_empty.<locals>.impl 0.5"]
    rows = tool.kernel_rows(results)
    assert rows[0] == ["sdfphys.sdf.compiled.run", "3.50", "1", "1", "a"]
    assert rows[1] == ["sdfphys.solver._solve", "3.00", "2", "2", "a"]
    assert rows[-2] == ["sdfphys.toi.sweep", "0.25", "1", "1", "b"]
    assert rows[-1][:3] == ["total", "7.25", "5"]
    text = tool.report(results, "header", kernels=True, markdown=True)
    assert text.startswith("header\n\n| scene | cold s |")
    assert "| `sdfphys.toi.sweep` | 0.25 | 1 | 1 | b |" in text
    assert "| a | 9.0 | 1.0 | 7.0 | 2 | 0 | `sdf.compiled.run` 3.5, " in text
