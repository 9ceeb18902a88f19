"""The contact cache: descent pairs that barely moved keep their contacts, carried with
the bodies (``sdfphys.collide.contact_cache``, ``Settings.reuse_distance``).

Oracle: the same query searched afresh (no cache). Bounds from the module docstring:
unmoved, the kept contacts are the found ones to round-off; moved by e <= tau, every
separation is within e of the kept one's and the deepest within 2 e of a new search's;
over tau, or with a larger margin, a changed shape or settings, the pair is searched
again.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from sdfphys import World
from sdfphys.collide import ContactCache, find_contacts
from sdfphys.settings import Settings
from sdfphys.shapes import shape_from_spec

GROUND = {"type": "sdf", "field": {"op": "smooth_union", "k": 0.5, "of": [
    {"type": "box", "size": [12.0, 1.0], "offset": [0.0, -0.5]},
    {"type": "circle", "radius": 1.0, "offset": [3.0, -0.6]}]}}
FLAT = {"type": "sdf", "field": {"type": "box", "size": [12.0, 1.0]}}
SHAPES = [GROUND, {"type": "box", "size": [0.8, 0.8]},
          {"type": "sdf", "field": {"type": "egg", "radius": 0.5, "top_radius": 0.2}},
          {"type": "polygon", "points": [[-0.6, -0.6], [0.6, -0.6], [0.6, -0.2], [-0.2, -0.2],
                                         [-0.2, 0.6], [-0.6, 0.6]]},
          {"type": "circle", "radius": 0.3}]
#: User-frame positions resting on (just into) the ground: box, egg, L polygon,
#: circle, and a second box tilted on the bump.
POSITION = [(0.0, 0.0), (-3.0, 0.399), (-1.5, 0.499), (-4.6, 0.599), (0.5, 0.299),
            (3.0, 0.81)]
ANGLE = [0.0, 0.0, 0.0, 0.0, 0.0, 0.1]
SHAPE_ID = np.array([0, 1, 2, 3, 4, 1])
MOVABLE = np.array([False, True, True, True, True, True])


def _setup():
    """The shapes, centre-of-mass positions (B, 2) and angles (B,) of the bodies."""
    w = World()
    for k, (position, angle) in enumerate(zip(POSITION, ANGLE)):
        w.add_body(SHAPES[SHAPE_ID[k]], position=position, angle=angle,
                   kind="dynamic" if MOVABLE[k] else "static")
    shapes = [w._shapes[i] for i in w._view("shape_id")]
    return shapes, w._view("com").copy(), w._view("angle").copy()


def _query(shapes, position, angle, settings, cache=None, velocity=None, ran=None):
    return find_contacts(shapes, np.arange(len(shapes)), position, angle, MOVABLE, settings,
                         velocity=velocity, ran=ran, cache=cache)


def _deepest(c, n: int) -> dict[int, float]:
    """Per body pair key a * n + b, its deepest contact (m)."""
    out: dict[int, float] = {}
    for a, b, d in zip(c.body_a, c.body_b, c.depth):
        k = int(a) * n + int(b)
        out[k] = max(out.get(k, -np.inf), float(d))
    return out


def test_the_scene_has_descent_pairs_in_contact():
    shapes, position, angle = _setup()
    ran: set = set()
    c = _query(shapes, position, angle, Settings(), ran=ran)
    assert {("mesh", "sdf"), ("sdf", "sdf"), ("circle", "sdf")} <= ran
    assert set(np.unique(c.body_b[c.body_a == 0])) == {1, 2, 3, 4, 5}
    assert np.max(c.depth) > 0.0


def test_unmoved_pairs_keep_their_contacts():
    shapes, position, angle = _setup()
    settings, cache = Settings(), ContactCache()
    first = _query(shapes, position, angle, settings, cache)
    ran: set = set()
    again = _query(shapes, position, angle, settings, cache, ran=ran)
    assert ran == set()                             # no pair searched again
    np.testing.assert_array_equal(again.body_a, first.body_a)
    np.testing.assert_array_equal(again.body_b, first.body_b)
    np.testing.assert_array_equal(again.feature, first.feature)
    for name in ("point", "normal", "depth"):
        np.testing.assert_allclose(getattr(again, name), getattr(first, name), rtol=0,
                                   atol=1e-12)


def test_the_first_search_is_the_search_without_cache():
    """Found with the margin grown by tau, the kept contacts within the pair margin are
    those of a search without cache (same deepest per pair)."""
    shapes, position, angle = _setup()
    settings = Settings()
    plain = _query(shapes, position, angle, settings)
    cached = _query(shapes, position, angle, settings, ContactCache())
    deep_plain, deep_cached = _deepest(plain, 6), _deepest(cached, 6)
    assert deep_plain.keys() == deep_cached.keys()
    for k in deep_plain:
        assert deep_cached[k] == pytest.approx(deep_plain[k], abs=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_small_motions_are_carried_within_the_bound(seed):
    """Twenty moves of up to tau / 8 each, drifting one way: the pairs are kept until
    their motion since the search passes tau, and every step the deepest contact of
    each pair is within 2 e of a new search's (e: that pair's motion since its
    contacts were found)."""
    rng = np.random.default_rng(seed)
    shapes, position, angle = _setup()
    settings, cache = Settings(), ContactCache()
    tau = settings.reuse_distance
    _query(shapes, position, angle, settings, cache)
    searched = 0
    heading = rng.uniform(-np.pi, np.pi, 5)
    direction = np.column_stack([np.cos(heading), np.sin(heading)])
    spin = rng.choice([-1.0, 1.0], 5)
    for _ in range(20):
        position[1:] += direction * rng.uniform(0, tau / 8, (5, 1))
        angle[1:] += spin * rng.uniform(0, tau / 8, 5)
        ran: set = set()
        kept = _query(shapes, position, angle, settings, cache, ran=ran)
        searched += bool(ran)
        fresh = _query(shapes, position, angle, settings)
        deep_kept, deep_fresh = _deepest(kept, 6), _deepest(fresh, 6)
        assert deep_kept.keys() == deep_fresh.keys()
        for k in deep_fresh:
            assert abs(deep_kept[k] - deep_fresh[k]) <= 2 * tau + 1e-12
    assert 0 < searched < 20                        # some steps reused, some searched


def test_a_flat_face_carries_a_sliding_box_exactly():
    """A box sliding and sinking on a flat field by less than tau: the kept contacts
    are the new search's (the module docstring: exact for a flat face)."""
    shapes = [shape_from_spec(FLAT), shape_from_spec(SHAPES[1])]
    shape_id, movable = np.array([0, 1]), np.array([False, True])
    position, angle = np.array([[0.0, 0.0], [0.5, 0.895]]), np.zeros(2)
    settings, cache = Settings(), ContactCache()

    def query(cache=None, ran=None):
        return find_contacts(shapes, shape_id, position, angle, movable, settings, ran=ran,
                             cache=cache)

    query(cache)
    position[1] += [3e-5, -4e-5]
    ran: set = set()
    kept, fresh = query(cache, ran), query()
    assert ran == set()
    np.testing.assert_array_equal(kept.feature, fresh.feature)
    np.testing.assert_allclose(kept.depth, fresh.depth, rtol=0, atol=1e-12)
    np.testing.assert_allclose(kept.point, fresh.point, rtol=0, atol=1e-12)
    np.testing.assert_allclose(kept.normal, fresh.normal, rtol=0, atol=1e-12)


def test_motion_over_tau_or_a_wider_margin_searches_again():
    shapes, position, angle = _setup()
    settings, cache = Settings(), ContactCache()
    tau = settings.reuse_distance
    _query(shapes, position, angle, settings, cache)
    position[2] += [0.0, 1.5 * tau]                 # the egg moves over tau
    ran: set = set()
    _query(shapes, position, angle, settings, cache, ran=ran)
    assert ran == {("sdf", "sdf")}
    # The egg turns by dq: its points move by up to dq r, over tau; the rest stay.
    angle[2] += 1.5 * tau / shapes[2].radius
    ran = set()
    _query(shapes, position, angle, settings, cache, ran=ran)
    assert ran == {("sdf", "sdf")}
    # The circle starts moving: its pair's margin grows by its reach.
    velocity = np.zeros((6, 2))
    velocity[4] = [0.0, -0.3]
    ran = set()
    _query(shapes, position, angle, settings, cache, velocity=velocity, ran=ran)
    assert ran == {("circle", "sdf")}


def test_other_settings_or_no_reuse_search_again():
    shapes, position, angle = _setup()
    cache = ContactCache()
    _query(shapes, position, angle, Settings(), cache)
    ran: set = set()
    _query(shapes, position, angle, Settings(descent_iterations=17), cache, ran=ran)
    assert {("mesh", "sdf"), ("sdf", "sdf"), ("circle", "sdf")} <= ran
    off = Settings(reuse_distance=0.0)
    _query(shapes, position, angle, off, cache)
    ran = set()
    _query(shapes, position, angle, off, cache, ran=ran)
    assert {("mesh", "sdf"), ("sdf", "sdf"), ("circle", "sdf")} <= ran


def _resting_world(**settings) -> World:
    w = World(settings=Settings(sleeping=False, **settings))
    w.add_body(GROUND, kind="static", name="ground")
    w.add_body(SHAPES[1], position=(-3.0, 0.4), name="box")
    w.add_body(SHAPES[2], position=(-1.5, 0.6), name="egg")
    w.add_body(SHAPES[4], position=(0.5, 0.3), name="ball")
    return w


def test_a_resting_world_stops_searching_its_pairs():
    w = _resting_world()
    for _ in range(120):
        w.step()
    before = dict(w.stage_counts)
    for _ in range(60):
        w.step()
    runs = {k: w.stage_counts.get(k, 0) - before.get(k, 0)
            for k in ("mesh_sdf", "sdf_sdf", "circle_sdf")}
    assert all(v < 10 for v in runs.values()), runs
    off = _resting_world(reuse_distance=0.0)
    for _ in range(180):
        off.step()
    # Same rest within the bound's order (mm), searched every step without reuse.
    np.testing.assert_allclose(w.position, off.position, atol=1e-3)
    assert off.stage_counts["mesh_sdf"] == 180


def test_copies_step_on_as_the_original_and_edits_forget():
    w = _resting_world()
    for _ in range(60):
        w.step()
    assert len(w._contact_cache) > 0
    twin = copy.deepcopy(w)
    for _ in range(30):
        w.step()
        twin.step()
    np.testing.assert_array_equal(twin.position, w.position)
    w.carve("ground", {"type": "circle", "radius": 0.3}, (5.0, 0.0))
    keys = w._contact_cache.key
    assert not np.any(((keys >> 32) == 0) | ((keys & 0xFFFFFFFF) == 0))
    w.step()
    w.remove_body(3)
    assert len(w._contact_cache) == 0
    w.step()
    assert w.contacts.body_b.max() <= 2


def test_the_kernels_take_the_kept_arrays_in_their_named_order():
    """``ContactCache.kept`` is the kept arrays themselves, in ``KEPT`` order."""
    from sdfphys.collide.contact_cache import KEPT, ContactCache

    cache = ContactCache()
    cache._set(*(np.full(3, float(i)) for i in range(len(KEPT))))
    assert len(cache.kept) == len(KEPT)
    for name, array in zip(KEPT, cache.kept):
        assert array is getattr(cache, name)
