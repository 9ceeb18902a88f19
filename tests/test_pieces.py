"""Carving dynamic bodies (sdfphys.pieces): the mass left, the frame moved with it, the
pieces cut off as new bodies, and the trajectory of a scene in which bodies appear."""

import copy
import math

import numpy as np
import pytest

from sdfphys import Settings, World
from sdfphys.errors import SpecError
from sdfphys.pieces import DUST_CELLS, grid_mass, parts
from sdfphys.sdf.build import field as build_field
from sdfphys.sdf.grid import GridField
from sdfphys.trajectory import compare, record

#: A 2 m x 0.5 m bar of density 2 (mass 2 kg, inertia m (w^2 + h^2) / 12).
BAR = {"type": "sdf", "field": {"type": "box", "size": [2.0, 0.5]}}
CELL = 0.02


def _bar(cell: float = CELL, **body) -> World:
    w = World(settings=Settings(carve_cell=cell))
    w.add_body(BAR, name="bar", density=2.0, **body)
    return w


def _relative_errors(cell: float) -> np.ndarray:
    """grid_mass's relative errors (area, moment) for a 0.5 m disc and for a 1.2 x 0.4 m
    box off the origin, baked at ``cell``, and the box centroid's error (m)."""
    disc = GridField(build_field({"type": "circle", "radius": 0.5}), cell, margin=0.2)
    a = grid_mass(disc.values, disc.origin, cell)
    box = GridField(build_field({"op": "translate", "by": [0.3, -0.1],
                                 "of": {"type": "box", "size": [1.2, 0.4]}}), cell, margin=0.2)
    b = grid_mass(box.values, box.origin, cell)
    return np.abs([a.area / (math.pi * 0.25) - 1, a.second_moment / (math.pi / 32) - 1,
                   b.area / 0.48 - 1, b.second_moment / (0.48 * 1.6 / 12) - 1,
                   np.hypot(*(b.centroid - [0.3, -0.1]))])


def test_grid_mass_converges_to_the_closed_forms_at_second_order():
    """Area, centroid and polar moment from the nodes' occupancy (module docstring): a
    disc and a box within 0.5 % at 2 cm, every error at least three times smaller at
    1 cm (second order: the box's corners, the disc's curvature within a cell)."""
    coarse, fine = _relative_errors(0.02), _relative_errors(0.01)
    assert np.all(coarse[:4] < 5e-3) and coarse[4] < 1e-9
    assert np.all(fine[:4] < coarse[:4] / 3)


def test_parts_are_four_connected_and_numbered_in_order():
    v = np.ones((6, 6))
    v[1, 1] = v[1, 2] = v[2, 2] = -1.0          # one part
    v[3, 3] = -1.0                              # touches it only diagonally: another
    v[4:6, 0] = -1.0                            # a third, on the edge
    labels, count = parts(v, 1.0)
    assert count == 3
    assert labels[1, 1] == labels[2, 2] == 1 and labels[3, 3] == 2 and labels[5, 0] == 3
    assert np.count_nonzero(labels) == 6


def test_a_carved_bar_takes_the_mass_centre_and_inertia_of_what_is_left():
    """A 0.2 m hole 0.5 m right of the middle of a moving, spinning bar: mass, centre of
    mass and inertia of the bar minus the disc (parallel axis theorem), its user frame
    where it was, its velocity the old motion's at the new centre of mass."""
    w = _bar(position=(0.0, 2.0), velocity=(1.0, -0.5), angular_velocity=0.7, angle=0.3)
    com0, v0 = w.center_of_mass[0].copy(), w.velocity[0].copy()
    user0 = w.position[0].copy()
    w.carve("bar", {"type": "circle", "radius": 0.2},
            com0 + 0.5 * np.array([math.cos(0.3), math.sin(0.3)]))
    hole = math.pi * 0.04
    area = 1.0 - hole
    shift = -hole * 0.5 / area                  # along the bar's axis
    inertia = 2.0 * ((4.25 / 12 + shift ** 2)
                     - (hole * 0.04 / 2 / 1.0 + hole * (0.5 - shift) ** 2))
    assert len(w) == 1 and w.names == ["bar"]
    assert w.mass[0] == pytest.approx(2.0 * area, rel=2e-3)
    assert w.inertia[0] == pytest.approx(inertia, rel=2e-3)
    arm = shift * np.array([math.cos(0.3), math.sin(0.3)])
    np.testing.assert_allclose(w.center_of_mass[0], com0 + arm, atol=5e-4)
    np.testing.assert_allclose(w.position[0], user0, atol=1e-12)
    d = w.center_of_mass[0] - com0
    np.testing.assert_allclose(w.velocity[0], v0 + 0.7 * np.array([-d[1], d[0]]), atol=1e-12)
    assert w.angular_velocity[0] == 0.7
    # The field keeps the hole where it was carved, in the body's own frame: its
    # centre 0.2 m from material (within a cell: the grid interpolates the cone's tip).
    assert w.field("bar").distance(np.array([[0.5, 0.0]]))[0] == pytest.approx(0.2, abs=CELL)


def test_a_cut_bar_falls_apart_into_two_bodies_moving_as_it_moved():
    """A 10 cm slot across a spinning bar: two bodies, 'bar' (the larger part) and
    'bar.1', their masses the parts' areas, each moving as its part of the rigid bar
    moved, the momentum of the material left conserved."""
    w = _bar(position=(0.0, 2.0), velocity=(0.5, 1.0), angular_velocity=-1.3)
    com0, v0 = w.center_of_mass[0].copy(), w.velocity[0].copy()
    w.carve("bar", {"type": "box", "size": [0.1, 2.0]}, (-0.3, 2.0))
    assert w.names == ["bar", "bar.1"]
    right, left = 0.5 * 1.25, 0.5 * 0.65         # x in [-0.25, 1] and [-1, -0.35]
    np.testing.assert_allclose(w.mass, [2 * right, 2 * left], rtol=3e-3)
    np.testing.assert_allclose(w.center_of_mass[:, 0], [0.375, -0.675], atol=1e-3)
    np.testing.assert_allclose(w.inertia, [2 * right * (1.25 ** 2 + 0.25) / 12,
                                           2 * left * (0.65 ** 2 + 0.25) / 12], rtol=5e-3)
    for k in range(2):
        d = w.center_of_mass[k] - com0
        np.testing.assert_allclose(w.velocity[k], v0 - 1.3 * np.array([-d[1], d[0]]),
                                   atol=1e-12)
    np.testing.assert_array_equal(w.angular_velocity, [-1.3, -1.3])
    momentum = (w.mass[:, None] * w.velocity).sum(axis=0)
    moment = (w.mass[:, None] * (w.center_of_mass - com0)).sum(axis=0)      # sum m_k d_k
    np.testing.assert_allclose(momentum, w.mass.sum() * v0
                               - 1.3 * np.array([-moment[1], moment[0]]), atol=1e-12)
    # Each piece's field is its own: no trace of the other part.
    assert w.field(1).distance(np.array([[0.6 + 0.675, 0.0]]))[0] > 0.5


def test_pieces_of_a_bar_on_the_ground_come_to_rest_apart():
    w = World(settings=Settings(carve_cell=0.04))
    w.add_body({"type": "box", "size": [8.0, 1.0]}, position=(0.0, -0.5), kind="static",
               name="ground")
    w.add_body(BAR, position=(0.0, 0.25), name="bar")
    for _ in range(30):
        w.step()
    w.carve("bar", {"type": "box", "size": [0.2, 1.0]}, (0.0, 0.25))
    assert len(w) == 3
    for _ in range(90):
        w.step()
    np.testing.assert_allclose(w.center_of_mass[1:, 1], 0.25, atol=3e-3)       # resting, not sunk
    assert np.abs(w.velocity[1:]).max() < 1e-2
    x = np.sort(w.center_of_mass[1:, 0])
    assert x[0] < -0.1 < 0.1 < x[1]


def test_dust_is_dropped_and_a_body_carved_to_nothing_is_removed():
    """A carve that leaves a 3 cm disc (under DUST_CELLS cells at 5 cm) of a bar drops it
    with the carve; the bar, left with nothing, leaves the world and later bodies move
    down one index."""
    w = _bar(cell=0.05)
    w.add_body({"type": "circle", "radius": 0.2}, position=(5.0, 0.0), name="ball")
    leave = {"op": "difference", "of": [{"type": "box", "size": [4.0, 2.0]},
                                        {"type": "circle", "radius": 0.03}]}
    assert math.pi * 0.03 ** 2 < DUST_CELLS * 0.05 ** 2
    w.carve("bar", leave, (0.3, 0.0))
    assert w.names == ["ball"]


def test_deposits_on_dynamic_bodies_are_refused():
    w = _bar()
    with pytest.raises(SpecError, match="body: body 'bar' is dynamic: only static and "
                                        "kinematic bodies take deposits"):
        w.deposit("bar", {"type": "circle", "radius": 0.2}, (0.0, 0.0))
    assert w.mass[0] == pytest.approx(2.0, rel=1e-15)


def test_a_world_with_pieces_copies_and_steps_on_bit_for_bit():
    w = _bar(position=(0.0, 2.0), angular_velocity=1.0)
    w.carve("bar", {"type": "box", "size": [0.1, 2.0]}, (0.2, 2.0))
    twin = copy.deepcopy(w)
    for _ in range(20):
        w.step()
        twin.step()
    np.testing.assert_array_equal(w.center_of_mass, twin.center_of_mass)


SCENE = {"version": 1, "sim": {"duration": 1.0}, "body": [
    {"name": "ground", "shape": {"type": "box", "size": [8.0, 1.0]}, "position": [0, -0.5],
     "static": True},
    {"name": "bar", "shape": BAR, "position": [0.0, 0.5]},
    {"name": "ball", "shape": {"type": "circle", "radius": 0.2}, "position": [3.0, 0.2]}],
    "carve": [{"time": 0.5, "body": "bar", "field": {"type": "box", "size": [0.2, 2.0]},
               "position": [0.0, 0.5]},
              {"time": 0.6, "body": "ball", "field": {"type": "circle", "radius": 1.0},
               "position": [3.0, 0.2]},
              {"time": 0.7, "body": 1,
               "field": {"type": "circle", "radius": 0.05}, "position": [0.5, 0.25]}]}


def test_a_scene_whose_bodies_split_and_vanish_records_a_column_per_body():
    """The [[carve]] tables split the bar at 0.5 s and carve the ball away at 0.6 s: the
    trajectory holds the scene's bodies then the piece, NaN before the piece appears and
    after the ball is gone; the 0.7 s carve still reaches the bar by its handle; a
    replay compares equal."""
    run = record(SCENE)
    assert list(run.name) == ["ground", "bar", "ball", "bar.1"]
    split = round(0.5 / (1 / 60))
    assert np.all(np.isnan(run.position[:split + 1, 3]))
    assert np.all(np.isfinite(run.position[split + 1:, 3]))
    gone = round(0.6 / (1 / 60))
    assert np.all(np.isfinite(run.position[:gone + 1, 2]))
    assert np.all(np.isnan(run.position[gone + 1:, 2]))
    assert np.all(np.isfinite(run.position[:, :2]))
    assert compare(run, record(SCENE)).identical


def test_a_piece_reads_true_distances_beyond_its_own_grid():
    """Above a piece's flat top, past its grid (7 nodes of room), the extrapolation
    with the piece's margin (its material's distance to the grid's side) is the true
    distance: a 0.3 m ball resting on a cut beam stays resting (a margin a cell short
    read it 8 mm deep)."""
    w = _bar(position=(0.0, 0.0))
    w.carve("bar", {"type": "box", "size": [0.1, 2.0]}, (-0.3, 0.0))
    for k in range(2):
        top = 0.25 - w.center_of_mass[k, 1]
        grid = w.shapes[w.shape_id[k]].grid
        assert grid.origin[1] + grid.cell * (grid.shape[1] - 1) < top + 0.15
        heights = np.array([0.05, 0.2, 0.3, 1.0])
        local = np.stack([np.full(4, w.center_of_mass[k, 0] - w.position[k, 0]), top + heights],
                         axis=1)
        np.testing.assert_allclose(w.field(k).distance(local), heights, atol=2e-3)


def test_a_carved_body_keeps_its_joints_at_the_same_material_points():
    """A bar hinged to the world at its left end, carved near its right end: its centre
    of mass moves, the hinge does not (both anchors where they were, to 1e-12 m), and it
    swings from there; a carved circle is no longer a round body."""
    w = _bar(position=(0.0, 2.0), angle=0.4)
    w.add_joint({"type": "revolute", "bodies": ["bar", "world"], "anchor": [-0.9, 1.64]})
    before = w.joint_anchors()
    com0 = w.center_of_mass[0].copy()
    w.carve("bar", {"type": "circle", "radius": 0.2}, com0 + 0.6 * np.array(
        [math.cos(0.4), math.sin(0.4)]))
    assert np.hypot(*(w.center_of_mass[0] - com0)) > 0.03
    for old, new in zip(before, w.joint_anchors()):
        np.testing.assert_allclose(new, old, rtol=0, atol=1e-12)
    for _ in range(30):
        w.step()
    first, second = w.joint_anchors()
    assert np.hypot(*(first - second)[0]) < 1e-3
    ball = World(settings=Settings(carve_cell=0.02))
    ball.add_body({"type": "circle", "radius": 0.5}, name="ball")
    ball.carve("ball", {"type": "circle", "radius": 0.2}, (0.4, 0.0))
    assert not ball._data["round"][0]
