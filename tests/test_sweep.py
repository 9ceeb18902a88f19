"""`sdfphys sweep` on Dask: a local cluster, a cluster started by hand, a worker killed
mid-sweep, ``--resume``, bad input; and ``sdfphys bench`` through the same machinery.

Runs are short (0.5 s of box_stack and ball_drop, whose kernels other tests compile
anyway) so that the clusters' start-up dominates: about 10 s for a local cluster of 2
workers, a few seconds for a hand-made one.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sdfphys import cli
from sdfphys.sweep import Run, run_one, split_values

ROOT = Path(__file__).resolve().parents[1]
SCENES = ["scenes/box_stack.toml", "scenes/ball_drop.toml"]
SWEEP = [*SCENES, "--set", "sim.substeps=2,4", "--seconds", "0.5"]
#: 12 runs of 2 s: a sweep to interrupt.
LONGER = [*SCENES, "--set", "sim.substeps=2,4", "--seconds", "2", "--repeat", "3"]
#: Columns that depend on the machine's load, not on the physics.
TIMINGS = ("wall_s", "ms_per_step")
BIN = Path(sys.executable).parent


def sweep(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sdfphys", "sweep", *map(str, args)],
                          capture_output=True, text=True, cwd=ROOT, check=False, timeout=300)


def start_sweep(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "sdfphys", "sweep", *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=ROOT)


def wait_for_a_row(out: Path, process: subprocess.Popen) -> None:
    """Until the sweep ``process`` has written its first row to ``out``."""
    deadline = time.monotonic() + 120
    while not out.exists() or len(out.read_text().splitlines()) < 2:
        assert time.monotonic() < deadline and process.poll() is None
        time.sleep(0.05)


def table(path: Path) -> list[dict[str, str]]:
    """The rows without their timings, in plan order (rows are written as they finish)."""
    with open(path, newline="") as handle:
        rows = [{k: v for k, v in r.items() if k not in TIMINGS} for r in csv.DictReader(handle)]
    return sorted(rows, key=lambda r: (SCENES.index(r["scene"]) if r["scene"] in SCENES
                                       else len(SCENES), r["scene"], list(r.values())))


def run_hash(capsys, scene: str, *args: str) -> str:
    """The state hash `sdfphys run` prints."""
    assert cli.main(["run", scene, *args]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("state hash"))
    return line.split()[-1]


class HandCluster:
    """A scheduler and workers started as `dask scheduler` and `dask worker` processes
    (one thread each, no nanny: a killed worker stays dead)."""

    def __init__(self, folder: Path):
        self.file = folder / "scheduler.json"
        self.scheduler = subprocess.Popen(
            [BIN / "dask", "scheduler", "--host", "127.0.0.1", "--port", "0",
             "--no-dashboard", "--scheduler-file", self.file],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.workers: list[subprocess.Popen] = []
        deadline = time.monotonic() + 60
        while not self.file.exists() or not self.file.read_text().strip():
            assert time.monotonic() < deadline, "the scheduler did not start"
            time.sleep(0.2)
        self.address = json.loads(self.file.read_text())["address"]

    def add_worker(self) -> subprocess.Popen:
        worker = subprocess.Popen(
            [BIN / "dask", "worker", "--scheduler-file", self.file, "--nthreads", "1",
             "--no-nanny", "--no-dashboard", "--host", "127.0.0.1"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
        self.workers.append(worker)
        return worker

    def wait_for_workers(self, count: int) -> None:
        from dask.distributed import Client

        with Client(self.address, timeout=30) as client:
            client.wait_for_workers(count, timeout=60)

    def close(self) -> None:
        for process in [*self.workers, self.scheduler]:
            process.send_signal(signal.SIGTERM)
        for process in [*self.workers, self.scheduler]:
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


@pytest.fixture(scope="module")
def local_table(tmp_path_factory) -> Path:
    """2 scenes x 2 settings on a local cluster of 2 workers."""
    out = tmp_path_factory.mktemp("sweep") / "results.csv"
    result = sweep(*SWEEP, "--workers", "2", "-o", out)
    assert result.returncode == 0, result.stderr
    assert "4 runs on 2 workers" in result.stdout
    return out


@pytest.fixture(scope="module")
def hand_cluster(tmp_path_factory):
    cluster = HandCluster(tmp_path_factory.mktemp("cluster"))
    try:
        cluster.add_worker()
        cluster.add_worker()
        cluster.wait_for_workers(2)
        yield cluster
    finally:
        cluster.close()


def test_local_cluster_rows_have_the_hashes_of_sdfphys_run(local_table, capsys):
    with open(local_table, newline="") as handle:
        reader = csv.DictReader(handle)
        rows = list(reader)
    assert reader.fieldnames == [
        "scene", "sim.substeps", "quality", "repeat", "steps", "wall_s", "ms_per_step",
        "max_penetration", "energy_start", "energy_end", "state_hash", "error"]
    assert sorted((r["scene"], r["sim.substeps"]) for r in rows) == sorted(
        (s, v) for s in SCENES for v in ("2", "4"))
    for r in rows:
        assert r["error"] == "" and r["repeat"] == "1" and r["quality"] == ""
        assert int(r["steps"]) == 30 and float(r["wall_s"]) > 0.0
        assert float(r["max_penetration"]) >= 0.0
        assert r["state_hash"] == run_hash(capsys, r["scene"], "--seconds", "0.5", "--set",
                                           f"sim.substeps={r['sim.substeps']}")


def test_resume_of_a_complete_file_runs_nothing(local_table, capsys):
    before = local_table.read_bytes()
    status = cli.main(["sweep", *SWEEP, "-o", str(local_table), "--resume",
                       "--scheduler", "tcp://127.0.0.1:1"])    # nothing listens: unused
    assert status == 0
    assert "ran            0 runs" in capsys.readouterr().out
    assert local_table.read_bytes() == before


@pytest.mark.slow
def test_resume_runs_only_the_missing_rows(local_table, tmp_path):
    out = tmp_path / "part.csv"
    lines = local_table.read_text().splitlines(keepends=True)
    out.write_text("".join(lines[:3]))                          # the header and 2 rows
    result = sweep(*SWEEP, "--workers", "1", "-o", out, "--resume")
    assert result.returncode == 0, result.stderr
    assert "ran            2 runs on 1 worker " in result.stdout
    assert table(out) == table(local_table)


@pytest.mark.slow
def test_a_cluster_started_by_hand_gives_the_same_table(local_table, hand_cluster,
                                                        tmp_path):
    out = tmp_path / "hand.csv"
    result = sweep(*SWEEP, "--scheduler", hand_cluster.address, "-o", out)
    assert result.returncode == 0, result.stderr
    assert "4 runs on 2 workers" in result.stdout
    assert table(out) == table(local_table)


@pytest.mark.slow
def test_bad_scenes_and_settings_are_rows_with_their_error(hand_cluster, tmp_path):
    out = tmp_path / "bad.csv"
    result = sweep("scenes/ball_drop.toml", "scenes/missing.toml", "--set",
                   "sim.substeps=4,-1,eight", "--seconds", "0.5", "--scheduler",
                   hand_cluster.address, "-o", out)
    assert result.returncode == 1, result.stderr
    assert "errors         5 of 6 rows" in result.stdout
    errors = {(r["scene"], r["sim.substeps"]): r["error"] for r in table(out)}
    assert errors[("scenes/ball_drop.toml", "4")] == ""
    assert errors[("scenes/ball_drop.toml", "-1")] == (
        "scenes/ball_drop.toml: sim.substeps: must be >= 1, got -1")
    assert errors[("scenes/ball_drop.toml", "eight")] == (
        "scenes/ball_drop.toml: sim.substeps: must be an integer, got 'eight'")
    for value in ("4", "-1", "eight"):
        assert errors[("scenes/missing.toml", value)] == (
            "scenes/missing.toml: no such scene file")


@pytest.mark.slow
def test_a_worker_killed_mid_sweep_loses_no_row(tmp_path):
    """One worker runs the sweep until its first row is written, a second is started
    and the first killed (SIGKILL) while it runs the next task: that task and the rest
    run on the second, and the table is complete."""
    cluster = HandCluster(tmp_path)
    out = tmp_path / "killed.csv"
    try:
        first = cluster.add_worker()
        cluster.wait_for_workers(1)
        process = start_sweep(*LONGER, "--scheduler", cluster.address, "-o", out)
        wait_for_a_row(out, process)
        cluster.add_worker()
        first.kill()
        first.wait()
        written = len(out.read_text().splitlines()) - 1
        stdout, stderr = process.communicate(timeout=300)
    finally:
        cluster.close()
    assert process.returncode == 0, stderr
    assert written < 12
    rows = table(out)
    assert len(rows) == 12 and all(r["error"] == "" for r in rows)
    identities = [(r["scene"], r["sim.substeps"], r["repeat"]) for r in rows]
    assert len(set(identities)) == 12
    for scene in SCENES:
        for value in ("2", "4"):      # every repeat of a setting: the same final state
            hashes = {r["state_hash"] for r in rows
                      if (r["scene"], r["sim.substeps"]) == (scene, value)}
            assert len(hashes) == 1


@pytest.mark.slow
def test_an_interrupted_sweep_keeps_its_rows_and_resumes(tmp_path):
    out = tmp_path / "interrupted.csv"
    process = start_sweep(*LONGER, "--workers", "1", "-o", out)
    wait_for_a_row(out, process)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    assert "sdfphys: interrupted (SIGINT)" in stderr
    kept = table(out)
    assert 1 <= len(kept) < 12 and all(r["state_hash"] for r in kept)
    result = sweep(*LONGER, "--workers", "1", "-o", out, "--resume")
    assert result.returncode == 0, result.stderr
    rows = table(out)
    assert len(rows) == 12 and len({tuple(r.values()) for r in rows}) == 12
    assert all(r in rows for r in kept)


@pytest.mark.slow
def test_bench_on_a_cluster_writes_the_rows_of_bench_in_one_process(hand_cluster, tmp_path,
                                                                    monkeypatch, capsys):
    """Two scenes of the quick bench: the same rows in the same order, timings aside."""
    from sdfphys import bench

    monkeypatch.setattr(bench, "QUICK_SCENES", ("free_fall", "bounce"))
    outputs = []
    for where in ([], ["--scheduler", hand_cluster.address]):
        out = tmp_path / f"bench{len(outputs)}"
        assert bench.bench_main(["--quick", "-o", str(out), *where]) == 0
        assert "free_fall: " in capsys.readouterr().out
        with open(out / "bench.csv", newline="") as handle:
            outputs.append([{k: v for k, v in r.items() if not k.startswith("ms_")}
                            for r in csv.DictReader(handle)])
    assert outputs[0] == outputs[1]
    assert [r["scene"] for r in outputs[1]][:3] == ["free_fall"] * 3


@pytest.mark.parametrize("args, message", [
    (["--set", "sim.substeps"], "--set: expected KEY=V1,V2,..."),
    (["--set", "sim.substeps=2,"], "--set: expected KEY=V1,V2,..."),
    (["--set", "sim.substeps=2", "--set", "sim.substeps=4"], "sim.substeps is swept twice"),
    (["--set", "repeat=2"], "'repeat' is a column of the results"),
    (["--quality", "fast,turbo"], "--quality: expected presets from fast, balanced, "
                                  "accurate, got 'turbo'"),
    (["--repeat", "0"], "--repeat: must be >= 1, got 0"),
    (["--seconds", "-1"], "--seconds: must be a positive number"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "not allowed with argument"),
])
def test_bad_usage_is_exit_2_one_line_and_no_file(tmp_path, capsys, args, message):
    out = tmp_path / "r.csv"
    try:
        status = cli.main(["sweep", "scenes/box_stack.toml", *args, "-o", str(out)])
    except SystemExit as exit_:                     # argparse's own usage errors
        status = exit_.code
    err = capsys.readouterr().err
    assert status == 2
    assert message in err
    assert len(err.strip().splitlines()) == 1 or "usage:" in err
    assert not out.exists()


def test_an_existing_file_or_another_sweeps_file_is_refused(tmp_path, capsys):
    out = tmp_path / "r.csv"
    out.write_text("scene,sim.dt,quality\n")
    args = ["sweep", "scenes/box_stack.toml", "--set", "sim.substeps=2", "-o", str(out)]
    assert cli.main(args) == 2
    assert "exists: --resume continues it" in capsys.readouterr().err
    assert cli.main([*args, "--resume"]) == 2
    err = capsys.readouterr().err
    assert "has the columns 'scene,sim.dt,quality', not this sweep's" in err
    assert len(err.strip().splitlines()) == 1
    assert out.read_text() == "scene,sim.dt,quality\n"


def test_a_scheduler_that_does_not_answer_is_exit_2_and_no_file(tmp_path, capsys,
                                                                monkeypatch):
    from sdfphys import sweep as module

    monkeypatch.setattr(module, "CONNECT_SECONDS", 1)
    out = tmp_path / "r.csv"
    assert cli.main(["sweep", "scenes/box_stack.toml", "--scheduler", "tcp://127.0.0.1:1",
                     "-o", str(out)]) == 2
    assert "--scheduler: cannot connect to tcp://127.0.0.1:1" in capsys.readouterr().err
    assert not out.exists()


def test_missing_scenes_are_rows_with_their_error_without_a_cluster(tmp_path, capsys):
    out = tmp_path / "r.csv"
    status = cli.main(["sweep", "scenes/missing.toml", "--repeat", "2", "-o", str(out),
                       "--scheduler", "tcp://127.0.0.1:1"])       # no run: never asked
    assert status == 1
    assert "errors         2 of 2 rows" in capsys.readouterr().out
    rows = table(out)
    assert [r["repeat"] for r in rows] == ["1", "2"]
    assert {r["error"] for r in rows} == {"scenes/missing.toml: no such scene file"}


def test_an_unknown_key_is_the_rows_error():
    from sdfphys.scene import read_scene_file

    data = read_scene_file(ROOT / "scenes/ball_drop.toml")
    run = Run("scenes/ball_drop.toml", ("8",), "", 1)
    result = run_one((run, data, ["sim.substepz=8"], 0.1, None))
    assert result == {"error": "scenes/ball_drop.toml: sim.substepz: unknown key "
                               "(did you mean 'substeps'?)"}


def test_without_dask_sweep_and_bench_on_a_cluster_exit_2_saying_so(monkeypatch, tmp_path,
                                                                     capsys):
    for name in ("dask", "dask.distributed", "distributed"):
        monkeypatch.setitem(sys.modules, name, None)     # import fails: not installed
    out = tmp_path / "r.csv"
    assert cli.main(["sweep", "scenes/box_stack.toml", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sdfphys: error: Dask is not installed: pip install")
    assert "[cluster]" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
    assert cli.main(["bench", "--quick", "--workers", "2", "-o", str(tmp_path / "b")]) == 2
    assert "sdfphys bench: error: Dask is not installed" in capsys.readouterr().err


def test_split_values_keeps_arrays_and_strings_whole():
    assert split_values("4, 8") == ["4", "8"]
    assert split_values("[0,-1.62],[0, -9.81]") == ["[0,-1.62]", "[0, -9.81]"]
    assert split_values('"a,b",c') == ['"a,b"', "c"]
    assert split_values("{x = 1, y = 2}") == ["{x = 1, y = 2}"]


def test_the_worker_tasks_run_without_the_compiling_child(monkeypatch):
    from sdfphys.sweep import _task

    monkeypatch.setenv("SDFPHYS_WARM", "1")
    assert _task(os.environ.get, "SDFPHYS_WARM") == "0"
