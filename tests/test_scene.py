"""Scene validation: every kind of bad scene gives one line naming the file and key path."""

from __future__ import annotations

import copy
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import sdfphys
from sdfphys.errors import SpecError
from sdfphys.scene import apply_overrides, read_scene

GOOD = {
    "version": 1,
    "world": {"gravity": [0.0, -9.81]},
    "sim": {"dt": 1 / 60, "substeps": 4, "duration": 1.0},
    "render": {"size": [320, 240], "center": [0.0, 2.0], "scale": 40.0, "fps": 30},
    "body": [
        {"name": "ground", "shape": {"type": "box", "size": [20.0, 1.0]},
         "position": [0.0, -0.5], "static": True},
        {"name": "ball", "shape": {"type": "circle", "radius": 0.5}, "position": [0.0, 2.0]},
        {"name": "blob", "shape": {"type": "sdf", "field": {
            "op": "smooth_union", "k": 0.2,
            "of": [{"type": "circle", "radius": 0.4}, {"type": "box", "size": [1.0, 0.4]}]}},
         "position": [2.0, 2.0]},
    ],
}


def mutated(path: str, value, delete: bool = False) -> dict:
    """GOOD with the dotted ``path`` (list indices as numbers) set to ``value`` or deleted."""
    scene = copy.deepcopy(GOOD)
    parts = [int(p) if p.isdigit() else p for p in path.split(".")]
    node = scene
    for part in parts[:-1]:
        node = node[part]
    if delete:
        del node[parts[-1]]
    else:
        node[parts[-1]] = value
    return scene


BAD = [
    (mutated("version", 2), "version: must be 1"),
    (mutated("version", None, delete=True), "version: is required"),
    (mutated("wrld", {}), "wrld: unknown key (did you mean 'world'?)"),
    (mutated("world.gravity", [0.0]), "world.gravity: must be a pair"),
    (mutated("world.gravity", [0.0, float("nan")]), "world.gravity[1]: must be finite"),
    (mutated("sim.dt", 0.0), "sim.dt: must be > 0"),
    (mutated("sim.substeps", 0), "sim.substeps: must be >= 1"),
    (mutated("sim.substeps", 2.5), "sim.substeps: must be an integer"),
    (mutated("sim.substep", 4), "sim.substep: unknown key (did you mean 'substeps'?)"),
    (mutated("sim.quality", "best"), "sim.quality: unknown quality 'best'"),
    (mutated("sim.duration", -1.0), "sim.duration: must be > 0"),
    (mutated("render.size", [320]), "render.size: must be [width, height]"),
    (mutated("render.fps", 0), "render.fps: must be >= 1"),
    (mutated("render.scale", float("inf")), "render.scale: must be finite"),
    (mutated("body", []), "body: a scene needs at least one [[body]]"),
    (mutated("body.1.shape.radius", -1.0), "body[1].shape.radius: must be >= 0.001, got -1"),
    (mutated("body.1.shape.type", "circel"), "body[1].shape.type: unknown"),
    (mutated("body.1.shape", None, delete=True), "body[1].shape: is required"),
    (mutated("body.1.positon", [0, 0]), "body[1].positon: unknown key (did you mean 'position'?)"),
    (mutated("body.1.position", "here"), "body[1].position: must be a pair"),
    (mutated("body.1.velocity", [1e400, 0.0]), "body[1].velocity[0]: must be finite"),
    (mutated("body.1.density", 0.0), "body[1].density: must be > 0"),
    (mutated("body.1.shape", {"type": "circle", "radius": 0.5}) | {
        "body": [*GOOD["body"][:1], dict(GOOD["body"][1], density=2.0, mass=1.0),
                 GOOD["body"][2]]}, "body[1].mass: give density or mass, not both"),
    (mutated("body.1.mass", -1.0), "body[1].mass: must be > 0"),
    (mutated("body.1.friction", -0.1), "body[1].friction: must be >= 0"),
    (mutated("body.1.restitution", 1.5), "body[1].restitution: must be <= 1"),
    (mutated("body.1.static", "yes"), "body[1].static: must be true or false"),
    (mutated("body.1.name", "ground"), "body[1].name: duplicate name 'ground'"),
    (mutated("body.0.velocity", [1.0, 0.0]), "body[0].velocity: a static body cannot move"),
    (mutated("body.1.shape", {"type": "polygon", "points": [[0, 0], [1, 1], [2, 2]]}),
     "body[1].shape.points"),
    (mutated("body.1.shape", {"type": "polygon", "points": [[0, 0], [1, 1], [1, 0], [0, 1]]}),
     "body[1].shape.points"),
    (mutated("body.2.shape.field.of.1.size", [1.0, -0.4]),
     "body[2].shape.field.of[1].size[1]: must be > 0"),
    (mutated("body.2.shape.field.op", "smooth_onion"), "body[2].shape.field.op: unknown operator"),
    (mutated("body.2.shape", {"type": "sdf", "field": {"type": "half_plane", "normal": [0, 1]}}),
     "body[2].shape: an unbounded shape"),
]


@pytest.mark.parametrize("scene, message", BAD, ids=[m.split(":")[0] + f"-{i}"
                                                     for i, (_, m) in enumerate(BAD)])
def test_bad_scene_names_the_key_path(scene, message):
    with pytest.raises(SpecError) as err:
        read_scene(scene)
    text = str(err.value)
    assert text.startswith("<scene>: " + message), text
    assert "\n" not in text


def test_good_scene_builds_a_world():
    scene = read_scene(GOOD)
    assert [b.name for b in scene.bodies] == ["ground", "ball", "blob"]
    world = scene.build()
    np.testing.assert_allclose(world.position[1], [0.0, 2.0])
    assert world.kind[0] == "static"


def test_overrides_set_dotted_keys():
    data = apply_overrides(copy.deepcopy(GOOD), ["sim.substeps=8", "world.gravity=[0, -1]",
                                                 "sim.quality=fast"])
    scene = read_scene(data)
    assert scene.settings.substeps == 8
    assert scene.gravity == (0.0, -1.0)
    assert scene.quality == "fast"


def test_overrides_name_a_body_by_name_or_index():
    """The issue: ``--set 'body[1].friction=0.1'`` could not override a body."""
    for key in ("body.ball.friction", "body[1].friction", "body.1.friction"):
        scene = read_scene(GOOD, [f"{key}=0.1", "body.blob.shape.field.k=0.3"])
        assert [b.friction for b in scene.bodies] == [0.5, 0.1, 0.5], key
    unnamed = copy.deepcopy(GOOD)
    del unnamed["body"][1]["name"]
    assert read_scene(unnamed, ["body.body1.restitution=0.5"]).bodies[1].restitution == 0.5
    assert GOOD["body"][1].get("friction") is None                  # the dict is untouched
    for key, message in [("body.bal.friction", ("--set body.bal: no body named 'bal' "
                                                 "(did you mean 'ball'?)")),
                         ("body[7].friction", "--set body[7]: no such body: the scene has 3"),
                         ("body.ball", "body.ball: names a whole [[body]]"),
                         ("body.ball.frction", ("body[1].frction: unknown key (did you mean "
                                                "'friction'?)"))]:
        with pytest.raises(SpecError) as err:
            read_scene(GOOD, [f"{key}=0.1"])
        assert str(err.value).startswith(f"<scene>: {message}"), str(err.value)


@pytest.mark.parametrize("section, hint", [("simulation", "sim"), ("bodies", "body"),
                                           ("rendering", "render"), ("World", "world")])
def test_misspelt_sections_get_a_suggestion(section, hint):
    with pytest.raises(SpecError) as err:
        read_scene(mutated(section, {}))
    assert str(err.value).startswith(f"<scene>: {section}: unknown key (did you mean "
                                     f"'{hint}'?); a scene has version, [world], [sim]")


def test_render_hud_is_a_flag():
    assert read_scene(GOOD).render.hud is False
    assert read_scene(mutated("render.hud", True)).render.hud is True
    with pytest.raises(SpecError, match="render.hud: must be true or false"):
        read_scene(mutated("render.hud", "yes"))


def test_scene_file_errors_name_the_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("version = 1\n[[body]]\nshape = { type = 'circle', radius = 0 }\n")
    with pytest.raises(SpecError) as err:
        read_scene(path)
    assert str(err.value) == f"{path}: body[0].shape.radius: must be >= 0.001, got 0"
    path.write_text("version = = 1")
    with pytest.raises(SpecError, match="not valid TOML"):
        read_scene(path)
    with pytest.raises(SpecError, match="no such scene file"):
        read_scene(tmp_path / "missing.toml")


def test_cli_bad_scene_exit_2_one_line_no_output(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("version = 1\n[[body]]\nshape = { type = 'circle', radius = -1.0 }\n")
    out = tmp_path / "out.mp4"
    result = subprocess.run([sys.executable, "-m", "sdfphys.cli", "run", str(path), "-o", str(out)],
                            capture_output=True, text=True, check=False)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        f"sdfphys: error: {path}: body[0].shape.radius: must be >= 0.001, got -1"]
    assert "Traceback" not in result.stderr
    assert not out.exists()


_leaf = st.one_of(st.none(), st.booleans(), st.integers(-3, 3), st.floats(allow_nan=True),
                  st.text(max_size=6), st.lists(st.floats(-2, 2), max_size=3))


def _paths(node, prefix=()):
    if isinstance(node, dict):
        for k, v in node.items():
            yield prefix + (k,)
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield prefix + (i,)
            yield from _paths(v, prefix + (i,))


ALL_PATHS = list(_paths(GOOD))


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.sampled_from(ALL_PATHS), _leaf), min_size=1, max_size=3))
def test_mutated_scenes_never_raise_anything_but_spec_error(mutations):
    scene = copy.deepcopy(GOOD)
    for path, value in mutations:
        node = scene
        try:
            for part in path[:-1]:
                node = node[part]
            node[path[-1]] = value
        except (KeyError, IndexError, TypeError):
            continue
    try:
        read_scene(scene).build()
    except SpecError as err:
        assert "\n" not in str(err)


def test_load_scene_is_the_public_entry_point():
    world = sdfphys.load_scene(GOOD)
    assert world.position.shape == (3, 2)


def test_a_field_too_large_to_integrate_is_one_line_naming_the_body():
    """Found by the mutation test: a 1.6e10 m box inside a smooth union asked for
    trillions of quadrature cells (a 2 TiB allocation)."""
    scene = mutated("body.2.shape.field.of.1.size", [1.6e10, 0.4])
    with pytest.raises(SpecError) as err:
        read_scene(scene).build()
    assert str(err.value).startswith("<scene>: body[2].shape.field: spans 1.6e+10")
