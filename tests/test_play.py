"""The interactive window under SDL's dummy driver, driven by scripted events."""

import math
import os
import sys
from types import SimpleNamespace

import numpy as np
import pytest

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from sdfphys.play import DragSpring, RateMeter, grab, hover_readout, pick_body, play
from sdfphys.render import Camera, Palette
from sdfphys.world import World

SETTINGS = SimpleNamespace(size=(320, 240), center=(0.0, 2.0), scale=50.0, fps=60)
CAMERA = Camera(SETTINGS.center, SETTINGS.scale, SETTINGS.size)


@pytest.fixture(autouse=True)
def dummy_video(monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")


def key(k):
    return pygame.event.Event(pygame.KEYDOWN, key=k, mod=0, unicode="", scancode=0)


def mouse(kind, world_point, button=1):
    pos = tuple(int(v) for v in CAMERA.world_to_screen([world_point])[0])
    if kind == pygame.MOUSEMOTION:
        return pygame.event.Event(kind, pos=pos, rel=(0, 0), buttons=(1, 0, 0))
    return pygame.event.Event(kind, pos=pos, button=button)


def ball_world(gravity=(0.0, 0.0), overlap=False):
    world = World(gravity=gravity)
    world.add_body({"type": "circle", "radius": 0.4}, position=(-1.0, 2.0), name="ball")
    world.add_body({"type": "circle", "radius": 0.5},
                   position=(-0.2 if overlap else 2.0, 2.0), kind="static", name="post")
    return world


class Factory:
    """Builds worlds and remembers them, so tests can look at what play did."""

    def __init__(self, **options):
        self.options = options
        self.worlds = []

    def __call__(self):
        self.worlds.append(ball_world(**self.options))
        return self.worlds[-1]


def run(script, factory=None, **options):
    factory = factory or Factory()
    status = play(factory, SETTINGS, allow_headless=True, events=script, **options)
    assert status == 0
    return factory


def test_without_a_display_says_so_in_one_line_and_returns_2(capsys):
    factory = Factory()
    assert play(factory, SETTINGS) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no display" in err and "dummy" in err
    assert factory.worlds == []


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="X11/Wayland check")
def test_without_any_window_system_says_so_before_sdl_starts(monkeypatch, capfd):
    for name in ("SDL_VIDEODRIVER", "DISPLAY", "WAYLAND_DISPLAY"):
        monkeypatch.delenv(name, raising=False)
    assert play(Factory(), SETTINGS) == 2
    err = capfd.readouterr().err                   # file descriptors: SDL's own noise too
    assert err.count("\n") == 1 and "no display" in err


def test_steps_one_per_frame_at_matching_fps():
    factory = run([[]] * 5)
    assert factory.worlds[0].step_count == 5


def test_pause_and_single_step():
    p, o = key(pygame.K_p), key(pygame.K_o)
    # frames: run, run, pause, -, step, -, step, resume, run  ->  1+1+0+0+1+0+1+1+1
    factory = run([[], [], [p], [], [o], [], [o], [p], []])
    assert factory.worlds[0].step_count == 6


def test_single_step_is_ignored_while_running():
    factory = run([[], [key(pygame.K_o)], []])
    assert factory.worlds[0].step_count == 3


def test_reset_builds_a_new_world():
    factory = run([[], [], [key(pygame.K_r)], []])
    assert len(factory.worlds) == 2
    assert factory.worlds[0].step_count == 2
    assert factory.worlds[1].step_count == 2


@pytest.mark.parametrize("event", [key(pygame.K_ESCAPE), pygame.event.Event(pygame.QUIT)])
def test_escape_or_close_quits(event):
    factory = run([[], [event], [], [], []])
    assert factory.worlds[0].step_count == 1


def test_max_frames_stops_the_session():
    factory = Factory()
    assert play(factory, SETTINGS, allow_headless=True, events=iter(list, None),
                max_frames=4) == 0
    assert factory.worlds[0].step_count == 4


def test_drag_pulls_the_body_to_the_pointer():
    target = (1.0, 3.0)
    script = ([[mouse(pygame.MOUSEBUTTONDOWN, (-1.0, 2.0))],
               [mouse(pygame.MOUSEMOTION, target)]] + [[]] * 90)
    world = run(script).worlds[0]
    np.testing.assert_allclose(world.position[0], target, atol=0.05)
    np.testing.assert_allclose(world.position[1], (2.0, 2.0))        # the static post


def test_release_lets_go_and_empty_space_grabs_nothing():
    script = [[mouse(pygame.MOUSEBUTTONDOWN, (-1.0, 0.5))],            # nothing there
              [mouse(pygame.MOUSEMOTION, (1.0, 0.5))]] + [[]] * 10
    world = run(script).worlds[0]
    np.testing.assert_allclose(world.position[0], (-1.0, 2.0))
    script = [[mouse(pygame.MOUSEBUTTONDOWN, (-1.0, 2.0))],
              [mouse(pygame.MOUSEMOTION, (-1.0, 3.5))], [], [],
              [mouse(pygame.MOUSEBUTTONUP, (-1.0, 3.5))]] + [[]] * 5
    world = run(script).worlds[0]
    velocity = world.velocity[0].copy()
    assert velocity[1] > 0.5                       # thrown upward, then free flight
    world.step()
    np.testing.assert_allclose(world.velocity[0], velocity)


def test_screenshot_is_written_and_named(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    run([[], [key(pygame.K_s)]])
    shots = sorted(tmp_path.glob("*.png"))
    assert len(shots) == 1
    assert f"screenshot: {shots[0].name}" in capsys.readouterr().out
    image = pygame.image.load(str(shots[0]))
    assert image.get_size() == SETTINGS.size
    hud = pygame.surfarray.array3d(image)[:200, :20]
    assert np.any(np.all(hud == np.array(Palette().text), axis=2))    # the heads-up line


def shots(tmp_path, script, factory=None):
    run(script, factory)
    return [pygame.surfarray.array3d(pygame.image.load(str(p)))
            for p in sorted(tmp_path.glob("*.png"), key=lambda p: p.stat().st_mtime_ns)]


def test_field_toggle_shades_the_screen(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    s = key(pygame.K_s)
    plain, field, off = shots(tmp_path, [[s], [key(pygame.K_f), s], [key(pygame.K_f), s]])
    background = np.all(plain == np.array(Palette().background), axis=2)
    assert np.mean(np.all(field == np.array(Palette().background), axis=2)) < 0.01
    assert np.mean(background) > 0.5
    np.testing.assert_array_equal(off[:, 40:], plain[:, 40:])     # below the heads-up line


def test_right_click_shows_one_body_field(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    s = key(pygame.K_s)
    union, ball, again = shots(tmp_path, [
        [key(pygame.K_f), s],
        [mouse(pygame.MOUSEBUTTONDOWN, (-1.0, 2.0), button=3), s],
        [mouse(pygame.MOUSEBUTTONDOWN, (0.5, 0.5), button=3), s]])
    post = tuple(CAMERA.world_to_screen([[2.0 + 0.5, 2.0]]).astype(int)[0])  # its edge
    iso = np.array(Palette().iso, dtype=float)
    assert np.abs(union[post] - iso).max() < np.abs(ball[post] - iso).max()  # zero line gone
    np.testing.assert_array_equal(again[:, 40:], union[:, 40:])              # union again


def test_contacts_toggle_draws_contacts(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    s = key(pygame.K_s)
    plain, marked = shots(tmp_path, [[s], [key(pygame.K_c), s]], Factory(overlap=True))
    colour = np.array(Palette().contact)
    assert not np.any(np.all(plain == colour, axis=2))
    assert np.any(np.all(marked == colour, axis=2))


def test_grab_is_a_mouse_joint_whose_force_is_bounded_by_the_weight():
    """A 1 kg box grabbed at its centre and pulled 1 m up: with the default bound (50
    weights) it reaches the pointer; with 0.5 weights the joint cannot lift it (its
    force, N, never exceeds half its weight)."""
    for weights, lifted in ((50.0, True), (0.5, False)):
        world = World()
        world.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, -0.5),
                       kind="static")
        world.add_body({"type": "box", "size": [0.5, 0.5]}, position=(0.0, 0.25), mass=1.0)
        j = grab(world, 1, np.array([0.0, 0.25]), DragSpring(weights=weights))
        world.set_joint_target(j, (0.0, 1.25))
        force = 0.0
        for _ in range(120):
            world.step()
            force = max(force, float(np.hypot(*world.joint_force[j])))
        assert force <= weights * 9.81 * (1 + 1e-9)
        assert (abs(world.position[1, 1] - 1.25) < 0.01) == lifted
        assert (world.position[1, 1] < 0.26) == (not lifted)


def test_pick_body_finds_dynamic_bodies_only():
    world = ball_world()
    assert pick_body(world, np.array([-1.0, 2.3])) == 0
    assert pick_body(world, np.array([2.0, 2.0])) is None              # static post
    assert pick_body(world, np.array([2.0, 2.0]), dynamic_only=False) == 1
    assert pick_body(world, np.array([0.0, 0.0])) is None
    assert pick_body(world, np.array([-1.0, 2.45]), tolerance=0.1) == 0


def test_rate_meter_counts_steps_per_second_over_its_window():
    meter = RateMeter(window=4)
    assert meter.rate == 0.0
    for k in range(10):
        meter.add(2, 0.1 * k)                     # 2 steps every 0.1 s
    assert meter.rate == pytest.approx(20.0)
    meter.add(0, 1.0)
    assert meter.rate == pytest.approx(6 / 0.4)   # the window now holds a paused frame


def test_h_shows_and_hides_the_key_help(tmp_path, monkeypatch):
    from sdfphys.play import KEYS

    monkeypatch.chdir(tmp_path)
    s, h, p = key(pygame.K_s), key(pygame.K_h), key(pygame.K_p)
    plain, helped, hidden = shots(tmp_path, [[p, s], [h, s], [h, s]])
    changed = np.any(helped != plain, axis=2)
    assert changed[100:220, 60:180].mean() > 0.9                 # a panel over the centre
    text = np.all(helped[100:220, 60:180] == np.array(Palette().text), axis=2)
    assert text.sum() > 200                                      # with lines of text on it
    np.testing.assert_array_equal(hidden[:, 30:], plain[:, 30:])
    assert {k for k, _ in KEYS} >= {"P", "O", "R", "S", "C", "F", "B", "H", "Esc"}


def test_overlays_in_play_have_a_legend(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    s = key(pygame.K_s)
    plain, field = shots(tmp_path, [[s], [key(pygame.K_f), s]])
    inside = np.all(field == np.array(Palette().field_inside), axis=2)   # the legend's swatch
    assert np.any(inside[:, 160:]) and not np.any(np.all(plain == np.array(
        Palette().field_inside), axis=2))


def test_hover_readout_names_the_body_under_the_pointer_and_its_signed_distance():
    """Inside the ball 0.1 m from its centre: -0.3 m; 5 cm above the static post:
    +0.05 m; nothing within max_distance: no lines."""
    world = ball_world()
    world.set_state(0, velocity=(1.5, -2.0))
    assert hover_readout(world, np.array([-1.0, 2.1]), 0.1) == [
        "ball  #0  dynamic", f"mass {math.pi * 0.4 ** 2:.4g} kg",
        "velocity (+1.500, -2.000) m/s", "distance -0.3000 m"]
    assert hover_readout(world, np.array([2.0, 2.55]), 0.1) == [
        "post  #1  static", "mass inf kg", "velocity (+0.000, +0.000) m/s",
        "distance +0.0500 m"]
    assert hover_readout(world, np.array([2.0, 2.65]), 0.1) == []


def test_hovering_shows_the_readout_next_to_the_pointer(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    s = key(pygame.K_s)
    plain, hovered, away = shots(tmp_path, [
        [key(pygame.K_p), s], [mouse(pygame.MOUSEMOTION, (-1.0, 2.1)), s],
        [mouse(pygame.MOUSEMOTION, (0.5, 0.0)), s]])            # nothing within 8 px
    x, y = (int(v) for v in CAMERA.world_to_screen([(-1.0, 2.1)])[0])
    region = (slice(x + 14, x + 100), slice(y + 14, y + 60))   # below right of the pointer
    assert np.any(hovered != plain, axis=2)[region].mean() > 0.9
    assert np.all(hovered[region] == np.array(Palette().text), axis=2).sum() > 50
    np.testing.assert_array_equal(away[:, 30:], plain[:, 30:])


def ground_world():
    world = World()
    world.add_body({"type": "sdf", "field": {"type": "box", "size": [6.0, 1.0]}},
                   position=(0.0, 0.5), kind="static", name="ground")
    world.add_body({"type": "circle", "radius": 0.3}, position=(2.5, 3.0), name="ball")
    return world


def test_the_carve_tool_carves_deposits_and_sizes_its_disc(capsys):
    worlds = []

    def factory():
        worlds.append(ground_world())
        return worlds[-1]

    def script():
        yield [mouse(pygame.MOUSEBUTTONDOWN, (1.0, 1.0))]        # tool off: grabs nothing
        yield [key(pygame.K_k)]
        yield [mouse(pygame.MOUSEBUTTONDOWN, (1.0, 1.0))]        # carve r = 0.3
        yield [pygame.event.Event(pygame.MOUSEWHEEL, x=0, y=1, flipped=False)]
        pygame.key.set_mods(pygame.KMOD_SHIFT)
        yield [mouse(pygame.MOUSEBUTTONDOWN, (-1.0, 1.2))]       # deposit r = 0.375
        yield [mouse(pygame.MOUSEBUTTONDOWN, (2.5, 3.0))]        # no deposit on the ball
        pygame.key.set_mods(0)
        yield [mouse(pygame.MOUSEBUTTONDOWN, (0.0, 4.0))]        # empty space: nothing
        assert worlds[0].names == ["ground", "ball"]
        assert worlds[0].shapes[worlds[0].shape_id[1]].kind == "circle"
        yield [mouse(pygame.MOUSEBUTTONDOWN, (2.5, 3.0))]        # carves the ball away
        yield [mouse(pygame.MOUSEMOTION, (0.0, 2.0))]

    assert play(factory, SETTINGS, allow_headless=True, events=script()) == 0
    world = worlds[0]
    f = world.field("ground")            # user frame: the ground's top at y = 0.5
    d = f.distance(np.array([[1.0, 0.3], [1.0, 0.15], [-1.0, 0.9], [-1.0, 1.1], [0.0, 0.4]]))
    assert d[0] > 0.0 and d[1] < 0.0                             # a 0.3 m hole from y = 1.0
    assert d[2] < 0.0 and d[3] > 0.0                             # a 0.375 m mound at y = 1.2
    assert d[4] < 0.0
    assert world.names == ["ground"]                            # the whole ball carved
    assert capsys.readouterr().err == ""
