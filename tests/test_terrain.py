"""Editable terrain in a World (sdfphys/terrain.py), [[carve]] tables, image terrain."""

from __future__ import annotations

import copy
import os
import subprocess
import sys

import numpy as np
import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from sdfphys import World
from sdfphys.errors import SpecError
from sdfphys.render import Camera, Renderer
from sdfphys.scene import read_scene
from sdfphys.sdf import field
from sdfphys.terrain import TerrainShape

GROUND = {"type": "sdf", "field": {"type": "box", "size": [6.0, 1.0]}}
BAKED = {"type": "sdf", "field": {"op": "bake", "cell": 0.04, "of": {"type": "box",
                                                                     "size": [6.0, 1.0]}}}
CRATE = {"type": "box", "size": [0.4, 0.4]}
HOLE = {"type": "circle", "radius": 0.6}


def _two_crates(ground: dict) -> World:
    """Two grounds 10 m apart (top at y = 0.5) with a crate resting on each, asleep."""
    w = World()
    w.add_body(ground, position=(0.0, 0.0), kind="static", name="ground")
    w.add_body(ground, position=(10.0, 0.0), kind="static", name="other")
    w.add_body(CRATE, position=(0.0, 0.7), name="crate")
    w.add_body(CRATE, position=(10.0, 0.7), name="crate2")
    for _ in range(90):
        w.step()
    assert w.asleep[2] and w.asleep[3]
    return w


@pytest.mark.parametrize("ground", [GROUND, BAKED, {"type": "box", "size": [6.0, 1.0]}],
                         ids=["analytic", "baked", "mesh"])
def test_a_crate_falls_into_a_hole_carved_under_it(ground):
    w = _two_crates(ground)
    other_shape = w.shapes[w.shape_id[1]]
    w.carve("ground", HOLE, (0.0, 0.5))
    assert not w.asleep[2] and w.asleep[3]           # the crate on it wakes, not the other
    assert not np.any((w._impulses.body_a == 0) | (w._impulses.body_b == 0))
    assert w.shapes[w.shape_id[1]] is other_shape   # the shared shape is not edited
    for _ in range(90):
        w.step()
    # The hole's floor is at y = -0.1: the crate (half side 0.2) sinks to about 0.13.
    assert w.position[2, 1] < 0.2
    assert abs(w.position[3, 1] - 0.7) < 1e-3
    # Resting in the hole, not in the ground: contacts no deeper than a centimetre.
    assert np.all(w.contacts.depth < 0.01)


@pytest.mark.parametrize("crate", [CRATE, {"type": "circle", "radius": 0.25}],
                         ids=["box", "circle"])
def test_a_deposit_fills_around_a_body_and_buries_none(crate):
    """A mound deposited over a resting body: the new material stops at the body's
    surface (brute force over points on and inside the body), and the body neither
    sinks into it nor is thrown out by it."""
    w = _two_crates(GROUND)
    w.remove_body(2)
    w.add_body(crate, position=(0.0, 0.75 if crate is not CRATE else 0.7), name="crate")
    for _ in range(60):
        w.step()
    rest = w.position[-1].copy()
    w.deposit("ground", {"type": "circle", "radius": 0.8}, (0.0, 0.4))
    grown = w.field("ground")
    # New material keeps a carve cell clear of the body (the grid's bilinear level set
    # rounds the pocket's corners by less): no point of the body reads inside the new
    # field, brute force over points of the body; its contacts are the old ground's.
    body = field(crate)
    u = np.linspace(-0.3, 0.3, 61)
    local = np.stack(np.meshgrid(u, u), -1).reshape(-1, 2)
    depth = -body.distance(local)
    ground = grown.distance(local + rest - w.position[0])
    cell = w.settings.carve_cell
    assert np.sum(depth > 0.0) > 100
    assert np.all(ground[depth > 0.0] > -0.001)
    # ... and no more than that: 2.5 cells beside the body is the mound's inside.
    side = rest + np.array([-body.distance(np.zeros((1, 2)))[0] + 2.5 * cell, 0.0])
    assert grown.distance((side - w.position[0])[None])[0] < 0.0
    # Material was added beside it: the mound's top at x = +-0.6 is above the old ground.
    assert np.all(grown.distance(np.array([[-0.6, 0.55], [0.6, 0.55]])) < 0.0)
    for _ in range(60):
        w.step()
    assert np.linalg.norm(w.position[-1] - rest) < 0.05
    assert np.all(w.contacts.depth < 0.01)


def test_a_baked_grid_keeps_its_nodes_at_its_first_edit():
    w = _two_crates(BAKED)
    w.carve(0, {"type": "circle", "radius": 0.1}, (2.0, 0.5))
    assert w.shapes[w.shape_id[0]].field.cell == 0.04
    points = np.array([[-2.0, 0.3], [0.0, 0.45], [1.0, -0.2]])      # far from the edit
    np.testing.assert_allclose(w.field("ground").distance(points),
                               w.field("other").distance(points), atol=1e-12)


def test_an_analytic_ground_is_baked_at_carve_cell():
    w = _two_crates(GROUND)
    w.settings = w.settings.with_values(carve_cell=0.1)
    body = w.body("ground")
    w.carve(body, {"type": "box", "size": [0.4, 0.4]}, (1.0, 0.5), angle=0.3)
    shape = w.shapes[w.shape_id[0]]
    assert isinstance(shape, TerrainShape) and shape.field.cell == 0.1
    f = w.field(body)
    assert f.distance(np.array([[1.0, 0.45]]))[0] > 0.0             # carved
    assert f.distance(np.array([[-1.0, 0.45]]))[0] < 0.0            # untouched
    w.deposit(body, {"type": "circle", "radius": 0.3}, (-2.0, 0.6))
    assert w.field(body).distance(np.array([[-2.0, 0.8]]))[0] < 0.0


def test_carving_a_moved_and_turned_body_uses_world_coordinates():
    w = World()
    w.add_body(GROUND, position=(3.0, 1.0), angle=np.pi / 2, kind="kinematic", name="wall")
    # The wall's user x axis points up: its face y = +0.5 is at world x = 2.5.
    w.carve("wall", {"type": "circle", "radius": 0.2}, (2.5, 1.0))
    f = w.field("wall")
    assert f.distance(np.array([[0.0, 0.45]]))[0] > 0.0
    assert f.distance(np.array([[1.0, 0.45]]))[0] < 0.0


@pytest.mark.parametrize("call, match", [
    (lambda w: w.carve("grund", HOLE, (0, 0)), "body: no body named 'grund'.*'ground'"),
    (lambda w: w.carve(7, HOLE, (0, 0)), "body: body index 7 out of range"),
    (lambda w: w.deposit("crate", HOLE, (0, 0)), "body: body 'crate' is dynamic"),
    (lambda w: w.carve("plane", HOLE, (0, 0)), "body: body 'plane' is unbounded"),
    (lambda w: w.carve("ground", HOLE, (np.nan, 0)), r"position\[0\]: must be finite"),
    (lambda w: w.carve("ground", {"type": "circle", "radius": -1}, (0, 0)),
     "field.radius: must be > 0"),
    (lambda w: w.deposit("ground", HOLE, (0, 0), angle=np.inf), "angle: must be finite"),
])
def test_bad_edits_raise_one_spec_error_naming_the_input(call, match):
    w = World()
    w.add_body(GROUND, kind="static", name="ground")
    w.add_body(CRATE, position=(0.0, 2.0), name="crate")
    w.add_body({"type": "sdf", "field": {"type": "half_plane", "normal": [0, 1]}},
               kind="static", name="plane")
    with pytest.raises(SpecError, match=match):
        call(w)
    assert isinstance(w.shapes[w.shape_id[0]], type(w.shapes[0]))   # nothing changed


def test_a_too_fine_carve_cell_is_named():
    w = World()
    w.add_body({"type": "box", "size": [90.0, 90.0]}, kind="static", name="ground")
    w.settings = w.settings.with_values(carve_cell=0.001)
    with pytest.raises(SpecError, match="settings.carve_cell: body 'ground'"):
        w.carve("ground", HOLE, (0, 0))


def test_edited_worlds_copy_and_step_bit_for_bit():
    w = _two_crates(GROUND)
    w.carve("ground", HOLE, (0.0, 0.5))
    twin = copy.deepcopy(w)
    for _ in range(20):
        w.step()
        twin.step()
    np.testing.assert_array_equal(w.position, twin.position)


def test_only_the_edited_body_sprite_is_redrawn():
    w = _two_crates(GROUND)
    camera = Camera((5.0, 0.0), 40.0, (640, 160))
    surface = pygame.Surface(camera.size)
    renderer = Renderer(camera)
    renderer.draw(surface, w)
    before = dict(renderer._sprites)
    renderer.draw(surface, w)
    assert renderer._sprites[0] is before[0] and renderer._sprites[1] is before[1]
    w.carve("ground", HOLE, (0.0, 0.5))
    renderer.draw(surface, w)
    assert renderer._sprites[0] is not before[0] and renderer._sprites[1] is before[1]
    # The hole is drawn: the pixel at the hole's centre is now background.
    x, y = camera.world_to_screen(np.array([[0.0, 0.2]]))[0].astype(int)
    assert tuple(surface.get_at((x, y)))[:3] == tuple(renderer.palette.background)[:3]


# --------------------------------------------------------------------------------------
# [[carve]] tables
# --------------------------------------------------------------------------------------

def _scene(carve: dict, explode: list | None = None) -> dict:
    return {"version": 1, "body": [
        {"name": "ground", "shape": GROUND, "static": True},
        {"name": "crate", "shape": CRATE, "position": [0.0, 0.7]},
        {"name": "crate2", "shape": CRATE, "position": [2.0, 0.7]}],
        "carve": [carve], "explode": explode or []}


def test_a_scheduled_carve_applies_at_the_first_step_at_or_after_its_time():
    """The carve and an [[explode]] table at the same time run at the start of the same
    step, the edit first."""
    carve = {"time": 0.5, "body": "ground", "field": HOLE, "position": [0.0, 0.5]}
    blast = {"time": 0.5, "center": [0.0, 0.5], "radius": 3.0, "impulse": 1.0}
    w = read_scene(_scene(carve, [blast])).build()
    steps = round(0.5 / w.settings.dt)
    for _ in range(steps):
        w.step()
    assert not isinstance(w.shapes[w.shape_id[0]], TerrainShape)
    assert abs(w.velocity[2, 0]) < 1e-6
    w.step()                                        # starts at t = 0.5: the carve applies
    assert isinstance(w.shapes[w.shape_id[0]], TerrainShape)
    assert w.velocity[2, 0] > 0.1                   # the blast pushed crate2 away
    assert w._scheduled == []


@pytest.mark.parametrize("change, message", [
    ({"body": "grond"}, "carve[0].body: no body named 'grond' (did you mean 'ground'?)"),
    ({"body": 1, "deposit": True}, "carve[0].body: body 'crate' is dynamic"),
    ({"body": 3}, "carve[0].body: must be <= 2, got 3"),
    ({"time": -1.0}, "carve[0].time: must be >= 0, got -1"),
    ({"position": [0.0, float("nan")]}, "carve[0].position[1]: must be finite, got nan"),
    ({"field": {"type": "circle"}}, "carve[0].field.radius: is required for 'circle'"),
    ({"deposit": 1}, "carve[0].deposit: must be true or false"),
    ({"blast": {"radius": 1.0, "impulse": 1.0}}, "carve[0].blast: unknown key"),
    ({"tme": 1.0}, "carve[0].tme: unknown key (did you mean 'time'?)"),
])
def test_bad_carve_tables_name_the_key(change, message):
    carve = {"time": 0.5, "body": "ground", "field": HOLE, "position": [0.0, 0.5]}
    with pytest.raises(SpecError) as err:
        read_scene(_scene(carve | change))
    assert str(err.value).startswith(f"<scene>: {message}")


# --------------------------------------------------------------------------------------
# Image terrain
# --------------------------------------------------------------------------------------

def _disc_png(path, width: int = 40, size: int = 64) -> None:
    """A white disc ``width`` px across, centred, on black (pixel centres within width/2)."""
    c = np.arange(size) + 0.5 - size / 2
    inside = np.hypot(*np.meshgrid(c, c, indexing="ij")) <= width / 2
    surface = pygame.Surface((size, size))
    pygame.surfarray.blit_array(surface, np.repeat(inside[..., None] * 255, 3, axis=2))
    pygame.image.save(surface, str(path))


def test_an_image_of_a_disc_is_the_disc_within_one_cell(tmp_path):
    _disc_png(tmp_path / "disc.png")
    f = field({"type": "image", "path": str(tmp_path / "disc.png"), "cell": 0.02})
    r = np.linspace(0.3, 0.5, 41)                    # five cells either side
    a = np.linspace(0.0, 2.0 * np.pi, 90, endpoint=False)
    rr, aa = np.meshgrid(r, a)
    points = np.column_stack([(rr * np.cos(aa)).ravel(), (rr * np.sin(aa)).ravel()])
    assert np.max(np.abs(f.distance(points) - (rr.ravel() - 0.4))) <= 0.02
    inner = 0.5 * points[np.isclose(rr.ravel(), 0.3)]         # r = 0.15: deep inside
    assert np.all(f.distance(inner) < 0.0) and f.distance(np.array([[0.7, 0.0]]))[0] > 0.0
    box = f.bounds()
    np.testing.assert_allclose(box, [-0.41, -0.41, 0.41, 0.41], atol=0.02)


def test_alpha_decides_where_the_image_has_it(tmp_path):
    surface = pygame.Surface((8, 4), pygame.SRCALPHA)
    surface.fill((0, 0, 0, 255))                     # black but opaque: inside
    surface.fill((255, 255, 255, 0), pygame.Rect(0, 0, 8, 2))   # top rows clear
    pygame.image.save(surface, str(tmp_path / "a.png"))
    f = field({"type": "image", "path": str(tmp_path / "a.png"), "cell": 1.0})
    d = f.distance(np.array([[0.0, 1.0], [0.0, -1.0]]))      # top half, bottom half
    assert d[0] > 0.0 and d[1] < 0.0


@pytest.mark.parametrize("grey, edge", [(0, 0.0), (64, 0.5 / (0.5 + 0.5 - 64 / 255) - 0.5)])
def test_a_grey_edge_pixel_moves_the_edge_into_it(tmp_path, grey, edge):
    """Columns 0-3 white, column 4 grey (or black), 5-7 black; threshold 0.5: the edge
    nodes hold 0.5 - level (px), so the zero level crosses between the centres of
    columns 3 (-0.5) and 4 (0.5 - 64/255) by linear interpolation."""
    surface = pygame.Surface((8, 4))
    surface.fill((255, 255, 255), pygame.Rect(0, 0, 4, 4))
    surface.fill((grey, grey, grey), pygame.Rect(4, 0, 1, 4))
    pygame.image.save(surface, str(tmp_path / "edge.png"))
    f = field({"type": "image", "path": str(tmp_path / "edge.png"), "cell": 1.0})
    assert abs(f.distance(np.array([[edge, 0.5]]))[0]) < 1e-12
    d = f.distance(np.array([[edge - 0.2, 0.5], [edge + 0.2, 0.5]]))
    np.testing.assert_allclose(d, [-0.2, 0.2], atol=1e-12)


def test_a_ball_dropped_on_an_image_disc_rests_on_top(tmp_path):
    _disc_png(tmp_path / "disc.png")
    scene = tmp_path / "scene.toml"
    scene.write_text(
        'version = 1\n[[body]]\nname = "hill"\nstatic = true\nshape = { type = "sdf", '
        'field = { type = "image", path = "disc.png", cell = 0.02 } }\n'
        '[[body]]\nname = "ball"\nposition = [0.0, 1.5]\n'
        'shape = { type = "circle", radius = 0.1 }\n')
    w = read_scene(scene).build()
    for _ in range(150):
        w.step()
    assert abs(w.position[1, 1] - 0.5) < 0.02               # on top: 0.4 + 0.1
    assert abs(w.position[1, 0]) < 1e-6 and np.hypot(*w.velocity[1]) < 0.05


def test_a_missing_image_exits_2_naming_the_key(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text('version = 1\n[[body]]\nstatic = true\nshape = { type = "sdf", '
                     'field = { type = "image", path = "nope.png", cell = 0.02 } }\n')
    result = subprocess.run([sys.executable, "-m", "sdfphys.cli", "record", str(scene), "-o",
                             str(tmp_path / "t.npz")], capture_output=True, text=True,
                            check=False)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr
    assert lines[0].startswith(f"sdfphys: error: {scene}: body[0].shape.field.path: cannot "
                               f"read image '{tmp_path / 'nope.png'}'")


def test_ray_casts_see_every_edit():
    w = _two_crates(GROUND)
    down = np.array([[0.0, -1.0], [0.0, -1.0]])
    origins = np.array([[2.0, 3.0], [-2.0, 3.0]])
    hit = w.ray_cast(origins, down, bodies=np.array([0]))
    np.testing.assert_allclose(hit.point[:, 1], [0.5, 0.5], atol=1e-9)
    w.carve("ground", {"type": "circle", "radius": 0.3}, (2.0, 0.5))   # the first edit
    assert w.ray_cast(origins, down, bodies=np.array([0])).point[0, 1] < 0.25
    w.carve("ground", {"type": "circle", "radius": 0.3}, (-2.0, 0.5))  # tables cached now
    hit = w.ray_cast(origins, down, bodies=np.array([0]))
    np.testing.assert_allclose(hit.point[:, 1], [0.2, 0.2], atol=0.05 / np.sqrt(2))


def test_contacts_see_every_edit():
    """The collision tables hold copies of the fields' constants (``collide.shape_fields``,
    built at the first step after the first edit): a later edit reaches them too, and a
    crate falls into the hole a second edit carves under it."""
    w = _two_crates(GROUND)
    w.carve("ground", {"type": "circle", "radius": 0.3}, (2.0, 0.5))   # the first edit
    for _ in range(5):
        w.step()
    w.carve("ground", HOLE, (0.0, 0.5))                                 # tables cached now
    for _ in range(90):
        w.step()
    assert w.position[2, 1] < 0.2
    assert np.all(w.contacts.depth < 0.01)
