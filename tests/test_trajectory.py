"""Trajectories: record, save/load (validated), compare, and the record/check commands."""

from __future__ import annotations

import dataclasses
import json
import struct
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from sdfphys import __version__
from sdfphys.cli import main
from sdfphys.errors import SpecError
from sdfphys.scene import read_scene
from sdfphys.trajectory import TOLERANCES, Trajectory, compare, load, match_bodies, record

ROOT = Path(__file__).resolve().parents[1]
CRADLE = ROOT / "scenes" / "newtons_cradle.toml"
BULLET = ROOT / "scenes" / "bullet.toml"

#: Two balls over a static floor: the first touches down after 10 steps.
DROP = {
    "version": 1,
    "sim": {"duration": 0.25},
    "body": [
        {"name": "floor", "shape": {"type": "box", "size": [10.0, 1.0]},
         "position": [0.0, -0.5], "static": True},
        {"name": "low", "shape": {"type": "circle", "radius": 0.5}, "position": [-1.0, 0.6],
         "restitution": 0.5},
        {"name": "high", "shape": {"type": "circle", "radius": 0.25}, "position": [1.0, 2.0],
         "angular_velocity": 3.0},
    ],
}


@pytest.fixture(scope="module")
def drop() -> Trajectory:
    return record(DROP)


def test_record_holds_every_step_of_the_world_bit_for_bit(drop):
    scene = read_scene(DROP)
    world = scene.build()
    steps = round(0.25 / scene.settings.dt)
    assert drop.frames == steps + 1 == 16
    assert drop.bodies == 3
    for k in range(drop.frames):
        if k:
            world.step()
        assert np.array_equal(drop.position[k], world.position)
        assert np.array_equal(drop.angle[k], world.angle)
        assert np.array_equal(drop.velocity[k], world.velocity)
        assert np.array_equal(drop.angular_velocity[k], world.angular_velocity)
    assert np.array_equal(drop.t, np.arange(16) * scene.settings.dt)
    assert drop.name.tolist() == ["floor", "low", "high"]
    assert drop.name.dtype.kind == "U"
    # The static floor never moves, and frame 0 is the scene's initial state.
    assert np.all(drop.position[:, 0] == [0.0, -0.5])
    assert drop.position[0, 2].tolist() == [1.0, 2.0]
    assert drop.angular_velocity[0].tolist() == [0.0, 0.0, 3.0]


def test_record_meta_names_the_scene_settings_and_versions(drop):
    scene = read_scene(DROP)
    assert drop.meta == {
        "scene": "<scene>", "scene_digest": scene.digest, "overrides": [], "quality": None,
        "settings": dataclasses.asdict(scene.settings), "sdfphys_version": __version__,
        "numpy_version": np.__version__, "seconds": 0.25, "steps": 15}


def test_record_seconds_and_overrides():
    short = record(DROP, seconds=0.1, overrides=["sim.substeps=8"], quality="fast")
    assert short.frames == 4                                    # 3 steps of the fast 1/30 s
    assert short.meta["settings"]["substeps"] == 8
    assert short.meta["settings"]["descent_starts"] == 4       # from the fast preset
    assert short.meta["overrides"] == ["sim.substeps=8"] and short.meta["quality"] == "fast"
    assert short.meta["scene_digest"] == read_scene(DROP, ["sim.substeps=8"], "fast").digest
    with pytest.raises(ValueError, match="seconds must be a positive number, got -1"):
        record(DROP, seconds=-1.0)


def test_save_load_round_trip_is_exact(drop, tmp_path):
    path = tmp_path / "drop.npz"
    drop.save(path)
    assert sorted(zipfile.ZipFile(path).namelist()) == sorted(
        f"{key}.npy" for key in ("t", "position", "angle", "velocity", "angular_velocity",
                                 "name", "meta"))
    raw = np.load(path, allow_pickle=False)
    assert raw["name"].dtype.kind == "U" and raw["meta"].dtype.kind == "U"
    assert json.loads(str(raw["meta"])) == drop.meta
    loaded = load(path)
    for key, array in drop.arrays().items():
        assert np.array_equal(getattr(loaded, key), array)
        assert getattr(loaded, key).dtype == array.dtype
    assert loaded.meta == drop.meta
    assert [p.name for p in tmp_path.iterdir()] == ["drop.npz"]


def test_failed_save_leaves_the_old_file_and_no_partial_file(drop, tmp_path):
    path = tmp_path / "drop.npz"
    drop.save(path)
    before = path.read_bytes()
    broken = dataclasses.replace(drop, meta={"unserializable": object()})
    with pytest.raises(TypeError):
        broken.save(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["drop.npz"]


def _write(path: Path, drop: Trajectory, **changes) -> Path:
    """``drop`` saved to ``path`` with arrays replaced (a value of None drops the key)."""
    arrays = drop.arrays() | {"meta": np.array(json.dumps(drop.meta))} | changes
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})
    return path


def _meta(drop: Trajectory, **changes) -> np.ndarray:
    return np.array(json.dumps(drop.meta | changes))


def _directory(drop: Trajectory, path: Path) -> Path:
    path.mkdir()
    return path


def _text(drop: Trajectory, path: Path) -> Path:
    path.write_text("t,x\n0,1\n")
    return path


def _npy(drop: Trajectory, path: Path) -> Path:
    with open(path, "wb") as stream:
        np.save(stream, drop.position)
    return path


def _truncated(drop: Trajectory, path: Path) -> Path:
    drop.save(path)
    path.write_bytes(path.read_bytes()[:600])
    return path


BAD_FILES = {
    "missing": (lambda d, p: p, "no such trajectory file"),
    "directory": (_directory, "is a directory, not a trajectory file"),
    "text": (_text, "not a trajectory file (.npz): not a zip archive"),
    "npy": (_npy, "not a trajectory file (.npz): not a zip archive"),
    "truncated": (_truncated, "not a readable trajectory file (.npz): File is not a zip file"),
    "pickled names": (lambda d, p: _write(p, d, name=np.array(["a", 1, None], dtype=object)),
                      "name: cannot be read: Object arrays cannot be loaded"),
    "missing key": (lambda d, p: _write(p, d, angle=None), "angle: missing array"),
    "unknown key": (lambda d, p: _write(p, d, extra=np.zeros(3)),
                    "extra: unknown array in a trajectory file"),
    "float32": (lambda d, p: _write(p, d, velocity=d.velocity.astype(np.float32)),
                "velocity: must be float64, got float32"),
    "shape": (lambda d, p: _write(p, d, position=d.position[:, :, 0]),
              "position: must have shape (F, B, 2) = (16, 3, 2), got (16, 3)"),
    "bodies": (lambda d, p: _write(p, d, angle=d.angle[:, :2]),
               "angle: must have shape (F, B) = (16, 3), got (16, 2)"),
    "frames": (lambda d, p: _write(p, d, t=d.t[:-1]),
               "t: has 15 frames, meta.steps = 15 needs 16"),
    "bytes names": (lambda d, p: _write(p, d, name=d.name.astype("S")),
                    "name: must be a non-empty unicode array of shape (B,), got |S5 (3,)"),
    "meta json": (lambda d, p: _write(p, d, meta=np.array("{steps: 15")),
                  "meta: not valid JSON"),
    "meta key": (lambda d, p: _write(p, d, meta=np.array(json.dumps(
        {k: v for k, v in d.meta.items() if k != "scene_digest"}))),
        "meta.scene_digest: is missing"),
    "meta type": (lambda d, p: _write(p, d, meta=_meta(d, steps="15")),
                  "meta.steps: has the wrong type: '15'"),
}


@pytest.mark.parametrize("case", BAD_FILES)
def test_bad_trajectory_files_raise_one_line_naming_file_and_array(case, drop, tmp_path):
    make, message = BAD_FILES[case]
    path = make(drop, tmp_path / "bad.npz")
    with pytest.raises(SpecError) as err:
        load(path)
    text = str(err.value)
    assert text.startswith(f"{path}: {message}"), text
    assert "\n" not in text


def test_corrupt_member_is_refused(drop, tmp_path):
    path = tmp_path / "flipped.npz"
    np.savez(path, **drop.arrays(), meta=np.array(json.dumps(drop.meta)))
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as archive:
        header = archive.getinfo("position.npy").header_offset
    name_length, extra_length = struct.unpack("<HH", data[header + 26:header + 30])
    start = header + 30 + name_length + extra_length + 200     # inside the stored array
    data[start:start + 8] = bytes(b ^ 0xFF for b in data[start:start + 8])
    path.write_bytes(bytes(data))
    with pytest.raises(SpecError, match=r"^.*flipped.npz: position: cannot be read: "
                                        r"Bad CRC-32 for file 'position.npy'$"):
        load(path)


def _perturbed(trajectory: Trajectory, key: str, index: tuple, delta: float) -> Trajectory:
    array = getattr(trajectory, key).copy()
    array[index] += delta
    return dataclasses.replace(trajectory, **{key: array})


def test_compare_identical(drop):
    worst = compare(drop, drop)
    assert worst.identical and worst.ok and worst.value == 0.0
    assert str(worst) == "bit-identical: every frame of every body equals the recording"


@pytest.mark.parametrize("key, index, unit", [
    ("position", (7, 2, 1), "m"), ("angle", (3, 1), "rad"), ("velocity", (15, 1, 0), "m/s"),
    ("angular_velocity", (9, 2), "rad/s")])
def test_compare_finds_a_perturbation_exactly(drop, key, index, unit):
    replay = _perturbed(drop, key, index, 1e-6)
    worst = compare(drop, replay)
    expected = abs(getattr(replay, key)[index] - getattr(drop, key)[index])
    assert (worst.quantity, worst.frame, worst.body) == (key, index[0], index[1])
    assert worst.name == drop.name[index[1]]
    assert worst.time == drop.t[index[0]]
    assert worst.value == expected
    assert worst.tolerance == TOLERANCES[key]
    assert not worst.ok and not worst.identical
    body = drop.name[index[1]]
    assert str(worst) == (
        f"worst deviation: {key} of body {index[1]} '{body}' at frame {index[0]} "
        f"(t = {drop.t[index[0]]:.6f} s): {expected:.3e} {unit} exceeds the tolerance "
        f"{TOLERANCES[key]:.1e} {unit}")
    assert compare(drop, replay, {key: 1e-5}).ok


def test_compare_ranks_quantities_by_deviation_over_tolerance(drop):
    replay = _perturbed(_perturbed(drop, "position", (4, 1, 0), 5e-10),
                        "velocity", (6, 2, 1), 2e-8)
    worst = compare(drop, replay)
    assert (worst.quantity, worst.frame, worst.body, worst.ok) == ("velocity", 6, 2, False)
    worst = compare(drop, replay, {"velocity": 1e-6})
    assert (worst.quantity, worst.frame, worst.body, worst.ok) == ("position", 4, 1, True)


def test_compare_vector_deviation_is_the_euclidean_norm(drop):
    replay = _perturbed(_perturbed(drop, "position", (5, 1, 0), 3e-3), "position", (5, 1, 1),
                        -4e-3)
    dx = replay.position[5, 1] - drop.position[5, 1]
    assert compare(drop, replay).value == np.hypot(dx[0], dx[1])


def test_compare_nan(drop):
    nan_in_both = _perturbed(drop, "angle", (8, 2), np.nan)
    assert compare(nan_in_both, nan_in_both).identical
    worst = compare(drop, nan_in_both)
    assert (worst.quantity, worst.frame, worst.body, worst.value) == ("angle", 8, 2, np.inf)


def test_compare_refuses_other_bodies_or_frames(drop):
    with pytest.raises(SpecError, match=r"^name: 3 bodies recorded, the scene has 2$"):
        compare(drop, dataclasses.replace(drop, name=drop.name[:2]))
    renamed = dataclasses.replace(drop, name=np.array(["floor", "low", "top"]))
    with pytest.raises(SpecError, match=r"^name\[2\]: body 'high' recorded, the scene has 'top'"):
        compare(drop, renamed)
    with pytest.raises(SpecError, match=r"^t: 16 frames recorded, 15 replayed$"):
        compare(drop, dataclasses.replace(drop, t=drop.t[:-1]))
    with pytest.raises(ValueError, match="unknown quantity 'speed'"):
        compare(drop, drop, {"speed": 1.0})
    match_bodies(["a", "b"], ("a", "b"))


# ------------------------------------------------------------------------------------------
# Command line
# ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cradle(tmp_path_factory) -> Path:
    """Newton's cradle recorded over 1 s (the striker hits the row at 0.75 s)."""
    path = tmp_path_factory.mktemp("cradle") / "cradle.npz"
    assert main(["record", str(CRADLE), "-o", str(path), "--seconds", "1"]) == 0
    return path


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def test_record_then_check_is_bit_identical(cradle, capsys):
    assert load(cradle).frames == 61
    status, out, err = _run(capsys, "check", CRADLE, cradle)
    assert (status, err) == (0, "")
    assert out.splitlines() == [
        "replayed       61 frames x 7 bodies",
        "bit-identical: every frame of every body equals the recording",
        "check          passed"]


def test_check_fails_on_a_perturbed_body_and_names_it(cradle, tmp_path, capsys):
    path = tmp_path / "perturbed.npz"
    _perturbed(load(cradle), "position", (50, 4, 0), 1e-6).save(path)
    status, out, err = _run(capsys, "check", CRADLE, path)
    assert (status, err) == (1, "")
    lines = out.splitlines()
    assert lines[1].startswith("worst deviation: position of body 4 'ball3' at frame 50 "
                               "(t = 0.833333 s): 1.000e-06 m exceeds the tolerance 1.0e-09 m")
    assert lines[2] == "check          FAILED"
    status, out, _ = _run(capsys, "check", CRADLE, path, "--atol", "2e-6")
    assert status == 0 and "within the tolerance 2.0e-06 m" in out


def test_check_notes_settings_that_changed_since_the_recording(cradle, tmp_path, capsys):
    full = load(cradle)
    settings = full.meta["settings"] | {"substeps": 8, "contact_hertz": 60.0}
    path = tmp_path / "old.npz"
    dataclasses.replace(full, meta=full.meta | {"settings": settings}).save(path)
    status, out, err = _run(capsys, "check", CRADLE, path)
    assert (status, err) == (0, "")
    assert out.splitlines()[0] == "note: settings changed since the recording: substeps, " \
                                  "contact_hertz"


def test_check_refuses_another_scene(cradle, capsys):
    status, out, err = _run(capsys, "check", BULLET, cradle)
    assert (status, out) == (2, "")
    recorded, scene = load(cradle).meta["scene_digest"][:12], read_scene(BULLET).digest[:12]
    assert err == (f"sdfphys: error: {cradle}: recorded from another scene: {CRADLE} (digest "
                   f"{recorded}), not {BULLET} (digest {scene})\n")


def test_check_refuses_a_body_count_mismatch(cradle, tmp_path, capsys):
    full = load(cradle)
    fewer = dataclasses.replace(full, position=full.position[:, :6], angle=full.angle[:, :6],
                                velocity=full.velocity[:, :6],
                                angular_velocity=full.angular_velocity[:, :6],
                                name=full.name[:6])
    path = tmp_path / "fewer.npz"
    fewer.save(path)
    status, out, err = _run(capsys, "check", CRADLE, path)
    assert (status, out) == (2, "")
    assert err == f"sdfphys: error: {path}: name: 6 bodies recorded, the scene has 7\n"
    renamed = dataclasses.replace(full, name=np.array([*full.name[:6], "hammer"]))
    renamed.save(path)
    status, out, err = _run(capsys, "check", CRADLE, path)
    assert (status, out) == (2, "")
    assert err == (f"sdfphys: error: {path}: name[6]: body 'hammer' recorded, the scene has "
                   "'striker'\n")


def test_check_corrupt_file_exits_2_with_one_line(cradle, tmp_path):
    path = tmp_path / "corrupt.npz"
    path.write_bytes(cradle.read_bytes()[:1000])
    result = subprocess.run([sys.executable, "-m", "sdfphys.cli", "check", str(CRADLE),
                             str(path)], check=False, capture_output=True, text=True)
    assert (result.returncode, result.stdout) == (2, "")
    assert result.stderr.splitlines() == [
        f"sdfphys: error: {path}: not a readable trajectory file (.npz): File is not a zip file"]


def test_check_replays_the_recorded_overrides(tmp_path, capsys):
    path = tmp_path / "bullet.npz"
    status, _, _ = _run(capsys, "record", BULLET, "-o", path, "--seconds", "0.1",
                        "--quality", "fast", "--set", "sim.substeps=3")
    assert status == 0
    meta = load(path).meta
    assert meta["settings"]["substeps"] == 3 and meta["quality"] == "fast"
    status, out, err = _run(capsys, "check", BULLET, path)
    assert (status, err) == (0, "")
    assert "bit-identical" in out


@pytest.mark.parametrize("argv, message", [
    (["record", BULLET, "-o", "{tmp}/b.txt"],
     "-o: a trajectory file ends in .npz, got '{tmp}/b.txt'"),
    (["record", BULLET, "-o", "{tmp}/no/b.npz"], "{tmp}/no/b.npz: no such directory '{tmp}/no'"),
    (["record", BULLET, "-o", "{tmp}/b.npz", "--seconds", "0"],
     "--seconds: must be a positive number, got 0.0"),
    (["record", "{tmp}/none.toml", "-o", "{tmp}/b.npz"], "{tmp}/none.toml: no such scene file"),
    (["record", BULLET, "-o", "{tmp}/b.npz", "--set", "sim.dt=-1"],
     f"{BULLET}: sim.dt: must be > 0, got -1"),
    (["check", BULLET, "{tmp}/b.npz", "--atol", "nan"],
     "--atol: must be a finite number >= 0, got nan"),
])
def test_bad_usage_exits_2_and_writes_nothing(argv, message, tmp_path, capsys):
    argv = [str(a).replace("{tmp}", str(tmp_path)) for a in argv]
    status, out, err = _run(capsys, *argv)
    assert (status, out) == (2, "")
    assert err == f"sdfphys: error: {message.replace('{tmp}', str(tmp_path))}\n"
    assert list(tmp_path.iterdir()) == []
