"""Renderer and camera: pixels land where the camera says, SDF bodies cover their area."""

import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from sdfphys import sdf
from sdfphys.collide.contacts import Contacts
from sdfphys.render import (
    SPRITE_TOLERANCE,
    Camera,
    Overlays,
    Palette,
    Renderer,
    body_frames,
)
from sdfphys.render_field import distance_map

BLACK = (0, 0, 0)
WHITE = (255, 255, 255)


# ------------------------------------------------------------------------------------------
# Stand-ins with the attributes of sdfphys.shapes / sdfphys.world that the renderer reads.
# ------------------------------------------------------------------------------------------

class Ring:
    """Annulus between radii r and R (exact distance)."""

    def __init__(self, outer, inner):
        self.outer, self.inner = outer, inner

    def distance(self, p):
        p = np.asarray(p, dtype=float).reshape(-1, 2)
        mid, half = (self.outer + self.inner) / 2, (self.outer - self.inner) / 2
        return np.abs(np.hypot(p[:, 0], p[:, 1]) - mid) - half

    def bounds(self):
        return np.array([-self.outer, -self.outer, self.outer, self.outer])


class Ground:
    """Half-plane y <= 0 (unbounded)."""

    def distance(self, p):
        return np.asarray(p, dtype=float).reshape(-1, 2)[:, 1].copy()

    def bounds(self):
        return np.array([-np.inf, -np.inf, np.inf, 0.0])


def circle_shape(r):
    return SimpleNamespace(kind="circle", radius=r, origin=np.zeros(2),
                           field=sdf.field({"type": "circle", "radius": r}),
                           bounds=lambda: np.array([-r, -r, r, r]))


def box_shape(w, h):
    v = np.array([[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
    return SimpleNamespace(kind="mesh", radius=float(np.hypot(w, h) / 2), origin=np.zeros(2),
                           vertices=v, outline=v, triangles=np.array([[0, 1, 2], [0, 2, 3]]),
                           field=sdf.field({"type": "box", "size": [w, h]}),
                           bounds=lambda: np.array([-w / 2, -h / 2, w / 2, h / 2]))


def sdf_shape(field, radius):
    return SimpleNamespace(kind="sdf", radius=radius, origin=np.zeros(2), field=field,
                           bounds=field.bounds)


def make_world(bodies, contacts=None):
    """bodies: list of (shape, (x, y), angle, kind)."""
    shapes = [b[0] for b in bodies]
    return SimpleNamespace(
        shapes=shapes, shape_id=np.arange(len(bodies)),
        position=np.array([b[1] for b in bodies], dtype=float).reshape(-1, 2),
        angle=np.array([b[2] for b in bodies], dtype=float),
        kind=np.array([b[3] for b in bodies]),
        contacts=contacts if contacts is not None else Contacts.empty())


def render(world, camera, palette=None, overlays=None):
    surface = pygame.Surface(camera.size)
    Renderer(camera, palette or Palette()).draw(surface, world, overlays or Overlays())
    return pygame.surfarray.array3d(surface)


def painted_box(image, background):
    """(x0, y0, x1, y1) screen extent of the pixels at least half-way from ``background``
    to full colour (antialiased fringes below half coverage do not count): pixel i spans
    [i, i + 1)."""
    gap = np.abs(image.astype(float) - np.array(background, dtype=float)).max(axis=2)
    xs, ys = np.nonzero(gap >= 0.5 * gap.max()) if gap.max() > 0 else ((), ())
    assert len(xs), "nothing was drawn"
    return xs.min(), ys.min(), xs.max() + 1, ys.max() + 1


def expected_box(camera, corners):
    """Screen extent (x0, y0, x1, y1) of world ``corners``."""
    px = camera.world_to_screen(corners)
    return px[:, 0].min(), px[:, 1].min(), px[:, 0].max(), px[:, 1].max()


PLAIN = Palette(background=BLACK, dynamic=WHITE, edge_shade=1.0)


# ------------------------------------------------------------------------------------------
# Camera
# ------------------------------------------------------------------------------------------

def test_camera_maps_centre_to_frame_middle_and_flips_y():
    cam = Camera((1.0, 2.0), 10.0, (200, 100))
    np.testing.assert_allclose(cam.world_to_screen([[1.0, 2.0]]), [[100.0, 50.0]])
    np.testing.assert_allclose(cam.world_to_screen([[2.0, 3.0]]), [[110.0, 40.0]])


def test_camera_round_trip(rng):
    cam = Camera((0.3, -4.0), 37.5, (640, 360))
    points = rng.normal(size=(50, 2)) * 5
    np.testing.assert_allclose(cam.screen_to_world(cam.world_to_screen(points)), points,
                               atol=1e-12)


def test_camera_pixel_centers_are_screen_to_world_of_half_pixels():
    cam = Camera((0.0, 4.0), 50.0, (40, 30))
    grid = cam.pixel_centers(3, 5, 4, 2)
    np.testing.assert_allclose(grid[2, 1], cam.screen_to_world([[3 + 2.5, 5 + 1.5]])[0])


def test_camera_rejects_bad_scale():
    with pytest.raises(ValueError, match="scale"):
        Camera((0, 0), 0.0, (10, 10))


# ------------------------------------------------------------------------------------------
# Bodies land where the camera says
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("angle", [0.0, 0.4])
def test_box_pixels_match_projected_corners(angle):
    cam = Camera((0.0, 4.0), 50.0, (320, 240))
    shape = box_shape(2.0, 1.0)
    world = make_world([(shape, (0.7, 3.4), angle, "dynamic")])
    image = render(world, cam, PLAIN)
    c, s = np.cos(angle), np.sin(angle)
    corners = shape.outline @ np.array([[c, s], [-s, c]]) + np.array([0.7, 3.4])
    np.testing.assert_allclose(painted_box(image, BLACK), expected_box(cam, corners), atol=1.0)


def marked(image, x, y, pal):
    """The antialiased mark line passes by pixel (x, y): some pixel of the 2x2 block at
    (x - 1, y - 1) is at least half-way from the fill colour to the mark colour."""
    block = image[x - 1:x + 1, y - 1:y + 1].reshape(-1, 3).astype(float)
    fill, mark = np.array(pal.dynamic, float), np.array(pal.mark, float)
    progress = (block - fill) @ (mark - fill) / np.dot(mark - fill, mark - fill)
    return progress.max() >= 0.5


def test_circle_has_its_extent_and_a_rotation_mark():
    cam = Camera((0.0, 0.0), 40.0, (200, 200))
    pal = Palette(background=BLACK)
    world = make_world([(circle_shape(1.0), (0.5, -0.25), 0.0, "dynamic")])
    image = render(world, cam, pal)
    expected = expected_box(cam, np.array([[-0.5, -1.25], [1.5, 0.75]]))
    np.testing.assert_allclose(painted_box(image, BLACK), expected, atol=1.0)
    cx, cy = cam.world_to_screen([[0.5, -0.25]])[0].astype(int)
    assert marked(image, cx + 24, cy, pal)               # the mark points along angle 0 ...
    assert not marked(image, cx - 24, cy, pal)
    assert not marked(image, cx, cy - 24, pal)
    turned = render(make_world([(circle_shape(1.0), (0.5, -0.25), np.pi / 2, "dynamic")]),
                    cam, pal)
    assert marked(turned, cx, cy - 24, pal)              # ... y up: angle pi/2 points up
    assert not marked(turned, cx + 24, cy, pal)


def test_static_and_kinematic_bodies_have_their_own_colours():
    cam = Camera((0.0, 0.0), 20.0, (300, 100))
    pal = Palette()
    box = box_shape(1.0, 1.0)
    world = make_world([(box, (-4.0, 0.0), 0.0, "dynamic"), (box, (0.0, 0.0), 0.0, "static"),
                        (box, (4.0, 0.0), 0.0, "kinematic")])
    image = render(world, cam, pal)
    centres = cam.world_to_screen([[-4.0, 0.0], [0.0, 0.0], [4.0, 0.0]]).astype(int)
    got = [tuple(image[x, y]) for x, y in centres]
    assert got == [pal.dynamic, pal.static, pal.kinematic]
    assert len(set(got)) == 3


def test_body_frames_use_shape_origin_when_world_has_no_center_of_mass():
    shape = box_shape(1.0, 1.0)
    shape.origin = np.array([0.5, 0.0])       # user origin 0.5 m right of the centre of mass
    world = make_world([(shape, (2.0, 1.0), np.pi / 2, "dynamic")])
    np.testing.assert_allclose(body_frames(world).com, [[2.0, 0.5]], atol=1e-12)
    world.center_of_mass = np.array([[7.0, 7.0]])
    np.testing.assert_allclose(body_frames(world).com, [[7.0, 7.0]])


# ------------------------------------------------------------------------------------------
# SDF bodies: the true filled shape, rasterized from the field
# ------------------------------------------------------------------------------------------

def test_sdf_ring_area_and_position():
    cam = Camera((0.0, 0.0), 50.0, (240, 240))
    ring = Ring(1.0, 0.6)
    world = make_world([(sdf_shape(ring, 1.0), (0.3, -0.2), 0.7, "dynamic")])
    image = render(world, cam, PLAIN)[:, :, 0].astype(float) / 255.0
    area = np.pi * (1.0 ** 2 - 0.6 ** 2)
    assert abs(np.count_nonzero(image >= 0.5) / cam.scale ** 2 - area) < 0.01 * area
    assert abs(image.sum() / cam.scale ** 2 - area) < 0.01 * area
    assert image[cam.world_to_screen([[0.3, -0.2]]).astype(int)[0][0], 120] == 0.0  # the hole
    expected = expected_box(cam, np.array([[-0.7, -1.2], [1.3, 0.8]]))
    np.testing.assert_allclose(painted_box(np.repeat(image[:, :, None], 3, 2), 0.0), expected,
                               atol=1.0)


def test_sdf_edge_is_antialiased_over_one_pixel():
    cam = Camera((0.0, 0.0), 50.0, (240, 240))
    world = make_world([(sdf_shape(Ring(1.0, 0.6), 1.0), (0.0, 0.0), 0.0, "dynamic")])
    image = render(world, cam, PLAIN)[:, :, 0]
    partial = (image > 0) & (image < 255)
    assert np.count_nonzero(partial) > 0.5 * 2 * np.pi * 1.6 * cam.scale   # on the edges ...
    d = Ring(1.0, 0.6).distance(cam.pixel_centers(0, 0, 240, 240).reshape(-1, 2)) * cam.scale
    assert np.all(np.abs(d.reshape(240, 240)[partial]) <= 0.5 + 1e-9)        # ... and only there


def test_sdf_rotated_box_area():
    cam = Camera((0.0, 0.0), 40.0, (200, 200))
    field = sdf.field({"type": "box", "size": [2.0, 1.0]})
    world = make_world([(sdf_shape(field, float(np.hypot(1.0, 0.5))), (0.1, 0.2), 0.5,
                         "dynamic")])
    image = render(world, cam, PLAIN)[:, :, 0].astype(float) / 255.0
    assert abs(image.sum() / cam.scale ** 2 - 2.0) < 0.01 * 2.0


def test_unbounded_ground_fills_below_its_surface():
    cam = Camera((0.0, 1.0), 50.0, (160, 120))
    pal = Palette()
    world = make_world([(sdf_shape(Ground(), np.inf), (0.0, 0.0), 0.0, "static")])
    image = render(world, cam, pal)
    surface_row = cam.world_to_screen([[0.0, 0.0]])[0, 1]                # y = 0 on screen
    column = image[80]
    static = np.all(column == np.array(pal.static), axis=1)
    background = np.all(column == np.array(pal.background), axis=1)
    assert np.all(background[: int(surface_row) - 1]) and np.all(static[int(surface_row) + 2:])


def test_sdf_sprite_follows_the_body_when_it_moves():
    cam = Camera((0.0, 0.0), 50.0, (300, 200))
    world = make_world([(sdf_shape(Ring(0.5, 0.3), 0.5), (-1.0, 0.0), 0.0, "static")])
    renderer = Renderer(cam, PLAIN)
    surface = pygame.Surface(cam.size)
    renderer.draw(surface, world)
    first = painted_box(pygame.surfarray.array3d(surface), BLACK)
    renderer.draw(surface, world)
    assert painted_box(pygame.surfarray.array3d(surface), BLACK) == first
    world.position[0] = (1.0, 0.5)
    renderer.draw(surface, world)
    moved = painted_box(pygame.surfarray.array3d(surface), BLACK)
    np.testing.assert_array_equal(np.subtract(moved, first), [100, -25, 100, -25])


def test_sdf_sprite_is_reused_only_within_the_tolerance():
    cam = Camera((0.0, 0.0), 50.0, (200, 200))
    world = make_world([(sdf_shape(sdf.field({"type": "box", "size": [1.0, 0.6]}), 0.6),
                         (0.013, 0.0), 0.0, "dynamic")])
    renderer = Renderer(cam, PLAIN)
    surface = pygame.Surface(cam.size)

    def image():
        renderer.draw(surface, world)
        return pygame.surfarray.array3d(surface)

    first = image()
    world.position[0, 0] += 0.5 * SPRITE_TOLERANCE / cam.scale          # a jitter
    world.angle[0] += 0.5 * SPRITE_TOLERANCE / (0.6 * cam.scale)
    np.testing.assert_array_equal(image(), first)
    world.angle[0] += 4 * SPRITE_TOLERANCE / (0.6 * cam.scale)          # a real turn
    turned = image()
    assert np.any(turned != first)
    fresh = pygame.Surface(cam.size)
    Renderer(cam, PLAIN).draw(fresh, world)
    np.testing.assert_array_equal(turned, pygame.surfarray.array3d(fresh))


def test_bodies_off_screen_draw_nothing():
    cam = Camera((0.0, 0.0), 50.0, (100, 100))
    world = make_world([(circle_shape(0.5), (30.0, 0.0), 0.0, "dynamic"),
                        (box_shape(1.0, 1.0), (0.0, -30.0), 0.0, "dynamic"),
                        (sdf_shape(Ring(0.5, 0.3), 0.5), (-30.0, 0.0), 0.0, "dynamic")])
    assert not np.any(render(world, cam, PLAIN))


# ------------------------------------------------------------------------------------------
# Overlays
# ------------------------------------------------------------------------------------------

def test_contact_overlay_draws_at_contact_points():
    cam = Camera((0.0, 0.0), 50.0, (200, 200))
    pal = Palette(background=BLACK)
    contacts = Contacts(np.array([0, 0]), np.array([1, 1]), np.array([[1.0, 1.0], [-1.0, -1.0]]),
                        np.array([[0.0, 1.0], [1.0, 0.0]]), np.array([0.01, -0.01]),
                        np.array([0, 1]))
    world = make_world([], contacts)
    assert not np.any(render(world, cam, pal))
    image = render(world, cam, pal, Overlays(contacts=True))
    (x0, y0), (x1, y1) = cam.world_to_screen([[1.0, 1.0], [-1.0, -1.0]]).astype(int)
    assert tuple(image[x0, y0]) == pal.contact
    assert tuple(image[x1, y1]) == pal.speculative
    nx, ny = cam.world_to_screen([[1.0, 1.25]])[0].astype(int)   # along the normal (0, 1)
    assert tuple(image[nx, ny]) == pal.contact
    assert np.count_nonzero(np.any(image != 0, axis=2)) < 200     # only near the contacts


def test_bounds_overlay_outlines_the_world_aabb():
    cam = Camera((0.0, 0.0), 50.0, (200, 200))
    pal = Palette(background=BLACK)
    world = make_world([(box_shape(1.0, 1.0), (0.0, 0.0), np.pi / 4, "dynamic")])
    image = render(world, cam, pal, Overlays(bounds=True))
    half = np.sqrt(0.5)
    bound = np.all(image == np.array(pal.bounds), axis=2)
    x0, y0, x1, y1 = painted_box(np.where(bound[:, :, None], 255, 0), 0)
    np.testing.assert_allclose((x0, y0, x1, y1),
                               expected_box(cam, np.array([[-half, -half], [half, half]])),
                               atol=1.0)


def test_field_overlay_shades_the_screen_with_a_zero_line():
    cam = Camera((0.0, 0.0), 50.0, (200, 200))
    pal = Palette(background=BLACK)
    world = make_world([(circle_shape(1.0), (0.0, 0.0), 0.0, "dynamic")])
    plain = render(world, cam, pal)
    shaded = render(world, cam, pal, Overlays(field=True))
    assert np.all(np.any(shaded[:, :10] != 0, axis=2))             # far from the body too
    assert np.any(shaded != plain)
    # The zero iso-line is the brightest ring: at r = 1 m brighter than at r = 0.75 m.
    x_edge, y = cam.world_to_screen([[1.0, 0.0]])[0].astype(int)
    x_in = cam.world_to_screen([[1.0 - 0.15, 0.0]])[0].astype(int)[0]
    assert shaded[x_edge, y].sum() > shaded[x_in, y].sum() + 60


def test_distance_map_union_is_the_minimum_over_bodies(rng):
    bodies = [(sdf_shape(Ground(), np.inf), (0.0, 0.0), 0.0, "static")]
    for k in range(12):
        shape = [circle_shape(0.3), box_shape(0.6, 0.4), sdf_shape(Ring(0.4, 0.2), 0.4)][k % 3]
        bodies.append((shape, tuple(rng.uniform(-3, 3, 2) + (0, 3)), rng.uniform(0, 6),
                       "dynamic"))
    frames = body_frames(make_world(bodies))
    xs, ys = np.linspace(-5, 5, 41), np.linspace(7, -1, 33)
    got = distance_map(frames, xs, ys)
    grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
    brute = np.full(len(grid), np.inf)
    for b in range(len(bodies)):
        c, s = np.cos(frames.angle[b]), np.sin(frames.angle[b])
        local = (grid - frames.com[b]) @ np.array([[c, -s], [s, c]])
        brute = np.minimum(brute, frames.shapes[b].field.distance(local))
    np.testing.assert_allclose(got, brute.reshape(41, 33), atol=1e-12)
    one = distance_map(frames, xs, ys, body=2)
    np.testing.assert_allclose(one.reshape(-1), frames.shapes[2].field.distance(
        (grid - frames.com[2]) @ np.array([[np.cos(frames.angle[2]), -np.sin(frames.angle[2])],
                                           [np.sin(frames.angle[2]), np.cos(frames.angle[2])]])))


def test_compiled_fields_rasterize_as_the_numpy_fields(monkeypatch):
    """Sprites and the distance map evaluate fields through ``sdf.compiled.distance``:
    for kinds that round alike the pixels' distances are the numpy fields' bit for bit."""
    import sdfphys.render as render_module

    specs = [{"op": "smooth_union", "k": 0.8, "of": [
                 {"type": "box", "size": [6.0, 1.0], "offset": [0.0, -0.5]},
                 {"type": "circle", "radius": 1.0, "offset": [-2.0, -1.0]},
                 {"type": "ellipse", "size": [2.5, 0.8], "offset": [2.0, 0.0]}]},
             {"type": "ring", "half_angle": 2.0, "radius": 0.6, "thickness": 0.2},
             {"type": "capsule", "a": [-0.5, 0.0], "b": [0.6, 0.3], "radius": 0.2},
             {"type": "heart", "scale": 1.0, "offset": [0.1, -0.4], "angle": 0.3}]
    bodies = []
    for k, spec in enumerate(specs):
        f = sdf.field(spec)
        radius = float(np.max(np.abs(f.bounds()))) * 1.5
        bodies.append((sdf_shape(f, radius), (-3.0 + 2.0 * k, 1.0 + 0.5 * k), 0.4 * k,
                       "dynamic"))
    frames = body_frames(make_world(bodies))
    cam = Camera((0.0, 1.5), 40.0, (400, 240))
    xs, ys = np.linspace(-6, 6, 97), np.linspace(4, -1, 51)

    def pixels():
        r = Renderer(cam)
        out = []
        for b in range(len(bodies)):
            shape = frames.shapes[b]
            rect = r._screen_rect(shape, frames.com[b], float(frames.angle[b]))
            out += r._field_pixels(shape.field, frames.com[[b]], frames.angle[[b]], [rect])
        return out, distance_map(frames, xs, ys)

    got, got_map = pixels()
    assert all(d is not None and d.size for d in got)
    assert all(sdf.compiled.compile_field(shape.field) for shape, *_ in bodies)
    monkeypatch.setattr(render_module, "compiled",
                        SimpleNamespace(distance=lambda f, p: f.distance(p)))
    expected, expected_map = pixels()
    for a, b in zip(got, expected):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(got_map, expected_map)


def test_import_sdfphys_does_not_import_pygame():
    code = "import sys, sdfphys; assert 'pygame' not in sys.modules, 'pygame imported'"
    subprocess.run([sys.executable, "-c", code], check=True)


# ------------------------------------------------------------------------------------------
# The real shapes (sdfphys.shapes): origins, meshes, fields built from scene specs
# ------------------------------------------------------------------------------------------

def test_real_sdf_shapes_cover_their_area():
    from sdfphys.shapes import shape_from_spec

    cam = Camera((0.0, 0.0), 50.0, (300, 300))
    specs = [
        {"op": "smooth_union", "k": 0.2,
         "of": [{"type": "circle", "radius": 0.6, "offset": [-0.5, 0.0]},
                {"type": "box", "size": [1.2, 0.5], "offset": [0.4, 0.3]}]},
        {"op": "onion", "thickness": 0.15, "of": {"type": "circle", "radius": 0.9}},
    ]
    for spec in specs:
        shape = shape_from_spec({"type": "sdf", "field": spec})
        world = make_world([(shape, (0.2, -0.1), 0.6, "dynamic")])
        image = render(world, cam, PLAIN)[:, :, 0].astype(float) / 255.0
        pixel_area = 1.0 / cam.scale ** 2
        assert abs(np.count_nonzero(image >= 0.5) * pixel_area - shape.area) < 0.01 * shape.area
        assert abs(image.sum() * pixel_area - shape.area) < 0.01 * shape.area


def test_real_polygon_is_placed_by_its_user_origin():
    from sdfphys.shapes import shape_from_spec

    cam = Camera((0.0, 0.0), 50.0, (300, 300))
    # Concave, with the user origin at a corner (not the centroid).
    points = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 0.4], [0.0, 1.0]]
    shape = shape_from_spec({"type": "polygon", "points": points})
    world = make_world([(shape, (-1.0, -0.5), 0.0, "dynamic")])
    image = render(world, cam, PLAIN)
    expected = expected_box(cam, np.array([[-1.0, -0.5], [1.0, 0.5]]))
    np.testing.assert_allclose(painted_box(image, BLACK), expected, atol=1.0)
    notch = cam.world_to_screen([[0.0, 0.3]]).astype(int)[0]            # above the dent
    assert tuple(image[notch[0], notch[1]]) == BLACK


# ------------------------------------------------------------------------------------------
# Colours by state and material, the HUD, the legend, the field overlay's cache
# ------------------------------------------------------------------------------------------

def scene_colours(name):
    """The fill colour of each body of scenes/<name>.toml, by body name."""
    from sdfphys import read_scene
    from sdfphys.render import body_colours

    world = read_scene(f"{ROOT}/scenes/{name}.toml").build()
    colours = body_colours(body_frames(world), Palette())
    return dict(zip(world.names, map(tuple, colours.tolist())))


ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_bodies_of_other_materials_differ_and_neighbours_too():
    ramp = scene_colours("ramp_friction")
    boxes = [ramp[f"box_mu_{mu}"] for mu in ("0.05", "0.3", "0.6")]
    assert len({*boxes, ramp["ramp"], ramp["ground"]}) == 5    # three materials; two statics
    pyramid = scene_colours("pyramid")
    assert pyramid["box_0_0"] == Palette().dynamic                 # the first body: the hue
    for row in range(19):
        for i in range(19 - row):
            here = pyramid[f"box_{row}_{i}"]
            assert here != pyramid[f"box_{row}_{i + 1}"]            # beside
            assert here != pyramid[f"box_{row + 1}_{i}"] or i == 19 - row - 1  # above
    assert pyramid["ground"] == Palette().static


def test_colours_follow_a_per_body_state():
    """The colouring reads ``BodyFrames.state``, not the body kind."""
    from sdfphys.render import STATIC, body_colours

    box = box_shape(1.0, 1.0)
    world = make_world([(box, (0.0, 0.0), 0.0, "dynamic"), (box, (2.0, 0.0), 0.0, "dynamic")])
    frames = body_frames(world)
    np.testing.assert_array_equal(frames.state, frames.motion)
    frames.state = np.array([0, STATIC])
    colours = body_colours(frames, Palette())
    assert tuple(colours[0]) == Palette().dynamic and tuple(colours[1]) == Palette().static


def test_hud_prints_time_and_step_in_the_top_left_corner():
    cam = Camera((0.0, 0.0), 50.0, (320, 200))
    world = make_world([(box_shape(1.0, 1.0), (0.0, 0.0), 0.0, "dynamic")])
    world.time, world.step_count = 1.25, 75
    plain = pygame.Surface(cam.size)
    with_hud = pygame.Surface(cam.size)
    Renderer(cam).draw(plain, world)
    Renderer(cam).draw(with_hud, world, hud=True)
    a, b = pygame.surfarray.array3d(plain), pygame.surfarray.array3d(with_hud)
    changed = np.argwhere(np.any(a != b, axis=2))
    assert len(changed) > 100 and changed[:, 0].max() < 160 and changed[:, 1].max() < 40
    assert np.any(np.all(b == np.array(Palette().text), axis=2))


def test_legend_names_the_overlays_shown():
    cam = Camera((0.0, 0.0), 50.0, (400, 300))
    world = make_world([(circle_shape(1.0), (0.0, 0.0), 0.0, "dynamic")])
    without = render(world, cam, overlays=Overlays(contacts=True))
    legend = render(world, cam, overlays=Overlays(contacts=True, legend=True))
    changed = np.argwhere(np.any(without != legend, axis=2))
    assert len(changed) > 100 and changed[:, 1].min() > 200 and changed[:, 0].min() < 20
    swatch = np.all(legend == np.array(Palette().speculative), axis=2)
    assert np.any(swatch[:, 200:]) and not np.any(swatch[:, :200])
    nothing = render(world, cam, overlays=Overlays(legend=True))
    np.testing.assert_array_equal(nothing, render(world, cam))    # no overlay: no legend


def test_field_overlay_is_coarse_while_moving_exact_when_still_then_kept(monkeypatch):
    import sdfphys.render as render_module
    from sdfphys.render import FIELD_STEP

    calls = []
    original = render_module.distance_map

    def counted(frames, xs, ys, body=None):
        calls.append(len(xs))
        return original(frames, xs, ys, body)

    monkeypatch.setattr(render_module, "distance_map", counted)
    cam = Camera((0.0, 0.0), 50.0, (200, 120))
    world = make_world([(circle_shape(1.0), (0.0, 0.0), 0.0, "dynamic")])
    renderer = Renderer(cam)
    surface = pygame.Surface(cam.size)
    overlays = Overlays(field=True)
    for _ in range(4):
        renderer.draw(surface, world, overlays)
    assert calls == [200 // FIELD_STEP, 200]          # coarse, then every pixel, then kept
    world.position[0] = (0.5, 0.0)
    renderer.draw(surface, world, overlays)
    assert calls[-1] == 200 // FIELD_STEP


def test_field_colours_per_pixel_match_the_formula():
    """The table lookup (``_shade``) gives the colours of ``_distance_colours`` to within
    its 1/32 px steps, at every pixel; blocks interpolate a linear field exactly."""
    from sdfphys.render_field import _distance_colours, _field_lut, _shade

    pal, scale, spacing = Palette(), 50.0, 0.25
    xs = (np.arange(300) + 0.5) / scale - 3.0
    d = np.add.outer(xs, 0.37 * xs[:200]) * 1.3 + 0.01       # linear: the same slope everywhere
    lut, q, far = _field_lut(pal, scale, spacing)
    exact = _distance_colours(d, scale, spacing, pal).astype(int)
    assert np.abs(_shade(d, 1, 300, 200, lut, q, far, spacing) - exact).max() <= 4
    coarse = d[1::4, 1::4] + (d[1, 0] - d[0, 0]) * 0.5 + (d[0, 1] - d[0, 0]) * 0.5
    assert np.abs(_shade(coarse, 4, 300, 200, lut, q, far, spacing)[4:-4, 4:-4]
                  - exact[4:-4, 4:-4]).max() <= 6


def test_asleep_bodies_take_their_material_hue_faded():
    """A World's sleeping bodies are drawn ASLEEP: their dynamic hue mixed toward the
    palette's asleep grey; awake ones keep the hue (a real World, settled to sleep)."""
    from sdfphys.render import ASLEEP, DYNAMIC, body_colours
    from sdfphys.world import World

    world = World()
    world.add_body({"type": "box", "size": [20.0, 1.0]}, position=(0.0, -0.5), kind="static")
    world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(-2.0, 0.5))
    world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(2.0, 0.5))
    for _ in range(60):
        world.step()
    assert world.asleep[1:].all()
    world.set_state(2, velocity=(0.0, 0.0))             # wakes the second box only
    frames = body_frames(world)
    assert frames.state.tolist() == [1, ASLEEP, DYNAMIC]
    pal = Palette()
    colours = body_colours(frames, pal)
    hue, grey = np.array(pal.dynamic, float), np.array(pal.asleep, float)
    np.testing.assert_allclose(colours[1], hue + (grey - hue) * pal.asleep_fade, atol=0.5)
    assert tuple(colours[2]) != tuple(colours[1])
    assert pal.fills[ASLEEP] == tuple(int(c) for c in hue + (grey - hue) * pal.asleep_fade)
