"""Golden trajectories and determinism, for every scene in scenes/.

Another process records every scene with ``sdfphys record`` over a short horizon (in
reverse order, with another hash seed); this process replays each with ``sdfphys
check``: bit-identical (so record then check passes for every scene, and the engine
is deterministic across processes and whatever ran before in a process). The same
recordings are compared with the golden ``tests/golden/<scene>.npz`` within the
default tolerances (trajectory.TOLERANCES; bit-identical on the machine that wrote
the files). After a deliberate change of the physics, ``pytest --regen-golden``
rewrites the golden files from the recordings: review the deviations the old ones
reported, then commit them.

Horizons are steps of the scene's dt (1/60 s in every scene): long enough for the
first collisions, or for some steps of resting contact where a scene starts in
contact, short enough that a replay of every scene takes about 10 s and the files
stay small (the largest, pyramid, 211 bodies x 6 frames, and circles_in_box, 153
bodies x 51 frames, are under 80 kB).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from sdfphys.cli import main
from sdfphys.scene import read_scene
from sdfphys.trajectory import compare, load

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = Path(__file__).resolve().parent / "golden"

#: scene -> (horizon in steps, why that horizon).
HORIZONS: dict[str, tuple[int, str]] = {
    "ball_drop": (60, "lands at step 44 (2.5 m of free fall) and bounces"),
    "ball_off_ledge": (160, "rolls over the ledge's corner at step 105, lands at 150"),
    "car": (40, "wheels touch the SDF terrain at step 16, springs take the load, motors drive"),
    "chain_bridge": (45, "the crates land on the 40-plank bridge at step 37"),
    "cradle_strings": (60, "the pulled ball strikes the row at step 45, the last one leaves"),
    "destructible_terrain": (40, "a hole and a blast under the first crates at step 15: "
                             "they fly and fall into the carved ground"),
    "double_pendulum": (60, "both bars swing down past the vertical (revolute joints)"),
    "blast": (70, "resting pyramid; [[explode]] at t = 1 s (step 61) throws it, hits from 63"),
    "box_stack": (12, "ten boxes in resting contact from step 1: warm-started stacking"),
    "bullet": (15, "hits the wall by time of impact at step 3-5, then stops"),
    "circles_in_box": (50, "first circles reach the floor at step 36 and start piling"),
    "concave_polygons": (35, "first triangle-field contacts at step 25"),
    "csg_bodies": (35, "first CSG bodies land at step 25"),
    "fracture": (75, "the beam is sawn through at step 60 and splits in two (a body "
                 "appears); the halves tip off the piers"),
    "filtered_crowd": (65, "teams pass through each other at steps 28-50, land at 59, pile"),
    "grid_terrain": (55, "bodies reach the baked terrain at step 43"),
    "head_on": (75, "the balls meet at step 64 and separate"),
    "image_terrain": (40, "bodies land on the image's hills at step 12-20 and roll"),
    "kinematic_platform": (20, "crates land on the moving platform at step 7 and ride it"),
    "marble_run": (40, "marbles touch the track at step 12 and roll"),
    "mixed_pairs": (20, "every pair kind in contact from step 10"),
    "newtons_cradle": (60, "the striker hits the row at step 45 (3 m at 4 m/s), ball4 leaves"),
    "pendulum": (60, "swings from 90 degrees through the bottom at step 35"),
    "pyramid": (5, "210 boxes in resting contact from step 1; the slowest scene per step"),
    "ragdoll": (60, "limbs touch each other from step 2, lands on the first step by step 40"),
    "ramp_friction": (20, "boxes on the ramp from step 1: sliding and sticking begin"),
    "restitution_row": (80, "the six balls land at step 65 (5.6 m of free fall) and bounce"),
    "sdf_primitives": (36, "field-field and triangle-field contacts from step 26"),
    "sensor_gate": (50, "funnel hit at step 37, ball0 through the sensor at 39-48, balls meet"),
    "showcase": (12, "every pair kind; terrain and pyramid in contact from step 1"),
}

SCENES = sorted(HORIZONS)


def _seconds(name: str) -> str:
    """The horizon of ``name`` as a ``--seconds`` argument (exactly HORIZONS steps)."""
    return repr(HORIZONS[name][0] * read_scene(ROOT / "scenes" / f"{name}.toml").settings.dt)


_RECORD = """
import contextlib, io, sys
from sdfphys.cli import main

out, *jobs = sys.argv[1:]
for name, seconds in zip(jobs[::2], jobs[1::2]):
    with contextlib.redirect_stdout(io.StringIO()):
        status = main(["record", f"scenes/{name}.toml", "-o", f"{out}/{name}.npz",
                       "--seconds", seconds])
    if status:
        sys.exit(f"recording {name} failed")
"""


def _run_all(commands: list[tuple[list[str], dict[str, str]]]) -> list[str]:
    """Run the commands at once in ROOT with extra environment variables; their stdouts."""
    processes = [subprocess.Popen(argv, cwd=ROOT, env=os.environ | env, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True) for argv, env in commands]
    outputs = []
    for process in processes:
        out, err = process.communicate()
        assert process.returncode == 0, err
        outputs.append(out)
    return outputs


@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> Path:
    """A directory of every scene recorded over its horizon by ``sdfphys record`` in
    another process, in reverse SCENES order, with another PYTHONHASHSEED."""
    root = tmp_path_factory.mktemp("recordings")
    seed = "1" if os.environ.get("PYTHONHASHSEED") == "0" else "0"
    jobs = [item for name in SCENES[::-1] for item in (name, _seconds(name))]
    _run_all([([sys.executable, "-c", _RECORD, str(root), *jobs], {"PYTHONHASHSEED": seed})])
    return root


@pytest.mark.parametrize("name", SCENES)
def test_record_then_check_is_bit_identical_across_processes(name, recordings, monkeypatch,
                                                             capsys):
    monkeypatch.chdir(ROOT)
    status = main(["check", f"scenes/{name}.toml", str(recordings / f"{name}.npz")])
    out, err = capsys.readouterr()
    assert (status, err) == (0, ""), out + err
    assert "bit-identical: every frame of every body equals the recording" in out.splitlines()


@pytest.mark.parametrize("name", SCENES)
def test_golden(name, recordings, regen_golden):
    replay, golden = load(recordings / f"{name}.npz"), GOLDEN / f"{name}.npz"
    if regen_golden:
        replay.save(golden)
    reference = load(golden)
    assert reference.meta["scene_digest"] == replay.meta["scene_digest"], \
        "the scene changed: run pytest --regen-golden"
    assert reference.meta["steps"] == HORIZONS[name][0], "run pytest --regen-golden"
    deviation = compare(reference, replay)
    assert deviation.ok, f"{golden.name}: {deviation} (a deliberate change? --regen-golden)"


# After test_golden, which writes the files under --regen-golden.
def test_every_scene_has_a_horizon_and_a_golden_file():
    scenes = sorted(path.stem for path in (ROOT / "scenes").glob("*.toml"))
    assert SCENES == scenes, "add the scene to HORIZONS and run pytest --regen-golden"
    assert sorted(path.stem for path in GOLDEN.glob("*.npz")) == scenes


_BUILD_HASHES = """
import hashlib, json, sys
from sdfphys.scene import read_scene

hashes = {}
for name in sys.argv[1:]:
    w = read_scene(f"scenes/{name}.toml").build()
    state = (w.mass, w.inertia, w.center_of_mass, w.position, w.angle)
    hashes[name] = hashlib.sha256(b"".join(a.tobytes() for a in state)).hexdigest()
print(json.dumps(hashes))
"""

_CPUS = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


@pytest.fixture(scope="module")
def built_on_one_and_two_blas_threads() -> tuple[dict, dict]:
    """scene -> hash of the built world (masses, inertias, centres of mass, poses), built
    with BLAS on 1 and on 2 threads."""
    outputs = _run_all([([sys.executable, "-c", _BUILD_HASHES, *SCENES],
                         dict.fromkeys(("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS",
                                        "MKL_NUM_THREADS"), threads))
                        for threads in ("1", "2")])
    return json.loads(outputs[0]), json.loads(outputs[1])


@pytest.mark.skipif(_CPUS < 2, reason="BLAS runs on one thread whatever is asked")
@pytest.mark.parametrize("name", SCENES)
def test_built_world_does_not_depend_on_blas_threads(name, built_on_one_and_two_blas_threads):
    """geometry.field_mass_properties sums in numpy's own order, not with BLAS dot
    products (OpenBLAS splits those across threads, changing the rounding)."""
    one, two = built_on_one_and_two_blas_threads
    assert one[name] == two[name]
