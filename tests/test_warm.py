"""The compiling child of a cold first step (``sdfphys._warm``)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROBE = """
import os, time
import sdfphys
from sdfphys import _warm
from sdfphys.solver import substeps

w = sdfphys.World()
w.add_body({"type": "box", "size": [4.0, 1.0]}, kind="static")
w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 1.0))
cold = _warm._cold()
pid = _warm.start(w)
again = _warm.start(w)
deadline = time.monotonic() + 600
while pid is not None and _warm._cold() and time.monotonic() < deadline:
    time.sleep(0.2)
w.step()
stats = substeps._substeps_kernel.stats
print(cold, pid is not None, again is None, len(stats.cache_hits), len(stats.cache_misses))
"""


def _probe(**env: str) -> list[str]:
    return subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                          check=True, timeout=900,
                          env={**os.environ, "SDFPHYS_COMPILE_NOTICE": "0", **env}
                          ).stdout.split()


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "fork") or (os.cpu_count() or 1) < 2,
                    reason="the child is forked on machines with two cores or more")
def test_a_cold_first_step_forks_a_child_that_fills_the_cache_for_the_parent(tmp_path):
    """On an empty cache the first start forks (the second does not), the child saves the
    substep kernel, and the parent's first step loads it instead of compiling it."""
    assert _probe(NUMBA_CACHE_DIR=str(tmp_path)) == ["True", "True", "True", "1", "0"]


def test_no_child_when_turned_off():
    """SDFPHYS_WARM=0: no fork, whatever the cache holds."""
    out = _probe(SDFPHYS_WARM="0")
    assert out[1:3] == ["False", "True"]


EARLY = """
import sdfphys
from sdfphys import _warm
from sdfphys.scene import read_scene
from sdfphys.sdf import base

calls = []
evaluate = base._EVALUATOR[0]
base._EVALUATOR[0] = lambda *a, **k: calls.append(1) or evaluate(*a, **k)
scene = read_scene("scenes/showcase.toml")
parsed = len(calls)
world = _warm.placeholder_world(scene)
print(parsed, len(calls), len(world), len(scene.bodies))
"""


def test_the_early_child_s_world_evaluates_no_field():
    """A scene's parse integrates no SDF body's mass (so ``start_early`` can fork before
    the quadratures compile the field evaluator), and the child's placeholder world is
    built without evaluating a field: every body is there."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run([sys.executable, "-c", EARLY], capture_output=True, text=True,
                         check=True, timeout=900, cwd=root,
                         env={**os.environ, "SDFPHYS_COMPILE_NOTICE": "0"}).stdout.split()
    assert out[:2] == ["0", "0"] and out[2] == out[3] and int(out[2]) > 30


def test_the_early_child_only_while_sdf_masses_are_unknown(monkeypatch):
    from sdfphys import _warm
    from sdfphys.scene import read_scene

    forks = []
    monkeypatch.setattr(_warm, "_fork", lambda make_world, early: forks.append(make_world))
    scene = read_scene({"version": 1, "body": [{"shape": {"type": "sdf", "field": {
        "type": "circle", "radius": 0.3125}}}]})
    scene.build()                               # forks (here: recorded), then integrates
    assert len(forks) == 1
    _warm.start_early(scene)                    # the mass is known now: no child
    scene.build()
    assert len(forks) == 1
    boxes = read_scene({"version": 1, "body": [{"shape": {"type": "box", "size": [1, 1]}}]})
    boxes.build()                               # nothing to integrate: no early child
    assert len(forks) == 1


def test_the_child_compiles_the_substep_kernel_before_the_row_softness(monkeypatch):
    """``compile_ahead`` runs the substep kernel alone first, then the collisions that
    are no closed form meeting now, later, then the row softness, which the parent
    meets first in its step (and compiles while it waits: ``compile_behind``); the
    substep kernel alone is refused for rows it would run without their softness."""
    import numpy as np

    import sdfphys
    from sdfphys import world_stages
    from sdfphys.solver import substeps

    calls = []
    kernel, loaded = substeps._substeps_kernel, substeps.loaded_rows
    monkeypatch.setattr(substeps, "_substeps_kernel",
                        lambda *a: calls.append("kernel") or kernel(*a))
    monkeypatch.setattr(substeps, "loaded_rows",
                        lambda *a: calls.append("softness") or loaded(*a))
    ahead = world_stages.collide_ahead
    monkeypatch.setattr(world_stages, "collide_ahead",
                        lambda *a, later=False: calls.append(("collide", later))
                        or ahead(*a, later=later))
    w = sdfphys.World()
    w.add_body({"type": "box", "size": [4.0, 1.0]}, kind="static")
    w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 0.9))
    world_stages.compile_ahead(w)
    assert calls == ["kernel", ("collide", False), ("collide", True), "softness", "kernel"]
    bodies = world_stages.body_state(w)
    rows = world_stages.prepare(w, world_stages.collide(w, bodies, None), bodies)
    assert len(rows) > 0                            # the box rests on the ground
    with pytest.raises(ValueError, match="kernel_only"):
        substeps.solve_substeps(bodies, rows, np.array([0.0, -9.81]), w.settings, True,
                                kernel_only=True)


def test_the_parent_s_share_compiles_what_its_step_calls_and_changes_nothing(monkeypatch):
    """``compile_behind``'s jobs (the contact cache's store, the reduction, the end of
    the mesh-in-field path, the row softness, the preparation, the restitution, on
    copies and no contacts; then the later steps' warm-start match and falling asleep,
    ``compile_later``) leave the
    world as it was and call each kernel with argument types its steps call it with
    (an sdf box resting on the ground goes through the cache and the reduction, and
    falls asleep): no kernel compiled for a job that a step does not use."""
    import numba
    import numpy as np

    import sdfphys
    from sdfphys import world_sleep, world_stages
    from sdfphys.collide import contact_cache, mesh_contacts, reduce
    from sdfphys.solver import restitution, rows, softness, warm_start

    w = sdfphys.World()
    w.add_body({"type": "box", "size": [4.0, 1.0]}, kind="static")
    w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(-1.0, 1.2), velocity=(0.5, -1.0),
               restitution=0.5)
    w.add_body({"type": "sdf", "field": {"type": "box", "size": [0.8, 0.4]}}, position=(1.0, 0.7))
    kernels = ((contact_cache, "_merged"), (reduce, "_reduce"), (mesh_contacts, "_finish"),
               (softness, "_row_softness_kernel"), (rows, "_prepare_kernel"),
               (restitution, "_restitution_kernel"), (warm_start, "_match_sorted"),
               (world_sleep, "falling_asleep"))
    calls = {name: [] for _, name in kernels}
    for module, name in kernels:
        kernel = getattr(module, name)

        def typed(*args, _kernel=kernel, _name=name):
            calls[_name].append(tuple(numba.typeof(a) for a in args))
            return _kernel(*args)
        monkeypatch.setattr(module, name, typed)
    before = (w.position.copy(), w.velocity.copy(), dict(w.stage_counts), w.step_count)
    jobs = world_stages.compile_behind(w)
    for job in jobs:
        job()
    assert len(jobs) == 7
    boxes = sdfphys.World()                           # closed-form pairs only: no cache
    boxes.add_body({"type": "box", "size": [4.0, 1.0]}, kind="static")
    boxes.add_body({"type": "circle", "radius": 0.5}, position=(0.0, 1.0))
    assert len(world_stages.compile_behind(boxes)) == 3      # softness, preparation, later
    np.testing.assert_array_equal(w.position, before[0])
    np.testing.assert_array_equal(w.velocity, before[1])
    assert (dict(w.stage_counts), w.step_count) == before[2:]
    by_jobs = {name: set(types) for name, types in calls.items()}
    assert all(len(types) == 1 for types in by_jobs.values())
    for types in calls.values():
        types.clear()
    for _ in range(30):
        w.step()
    assert w.contacts.body_b.tolist().count(2) >= 2                 # the sdf box rests
    for _ in range(90):
        w.step()
    assert w.asleep[2]
    assert {n: by_jobs[n] - set(t) for n, t in calls.items() if not by_jobs[n] <= set(t)} == {}


def test_the_child_compiles_the_field_evaluator_where_a_step_may_evaluate_a_field(
        monkeypatch):
    """``collide.compile_evaluator``: one field evaluated (the evaluator compiled) where a
    circle's predicted contacts, an sdf body or a concave mesh will evaluate fields,
    none for circles alone or boxes alone, nor while another process compiles it;
    ``compile_ahead`` runs it after the substep kernel unless the child was forked early
    (the parent compiles it then)."""
    import sdfphys
    from sdfphys import _compile_lock, collide, world_stages
    from sdfphys.sdf import compiled

    evaluated = []
    evaluate = compiled.evaluate
    monkeypatch.setattr(compiled, "evaluate",
                        lambda f, p, *a: evaluated.append(len(p)) or evaluate(f, p, *a))

    def world(*specs):
        w = sdfphys.World()
        for i, spec in enumerate(specs):
            w.add_body(spec, position=(3.0 * i, 5.0))
        return w

    circle, box = {"type": "circle", "radius": 0.5}, {"type": "box", "size": [1.0, 1.0]}
    l_shape = {"type": "polygon", "points": [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]}
    for specs, expected in (((circle, circle), []), ((box, box), []), ((circle, box), [1]),
                            ((l_shape, box), [1]),
                            (({"type": "sdf", "field": {"type": "circle", "radius": 0.5}},),
                             [1])):
        evaluated.clear()
        collide.compile_evaluator(world_stages.collision_shapes(world(*specs)))
        assert evaluated == expected, specs
    evaluated.clear()                       # another process compiles it: no wait
    monkeypatch.setattr(_compile_lock, "held_elsewhere", lambda kernel: kernel is compiled.run)
    collide.compile_evaluator(world_stages.collision_shapes(world(circle, box)))
    assert evaluated == []
    calls = []
    monkeypatch.setattr(world_stages, "compile_evaluator", lambda shapes: calls.append(1))
    world_stages.compile_ahead(world(circle, box), early=True)
    assert calls == []
    world_stages.compile_ahead(world(circle, box))
    assert calls == [1]


def test_the_child_runs_one_pair_of_each_path_that_meets_only_later(monkeypatch):
    """Concave polygons falling apart onto a box ground: no pair meets at the start, so
    ``compile_ahead`` runs no pair function for now; with ``later`` it runs one pair of
    each path (a concave polygon on the ground box, two concave polygons), the second
    body placed on the first, and nothing for the closed forms (two boxes)."""
    import numpy as np

    import sdfphys
    from sdfphys import collide, world_stages

    calls = []
    for kinds, function in list(collide.PAIR_FUNCTIONS.items()):
        monkeypatch.setitem(collide.PAIR_FUNCTIONS, kinds, lambda *a, _f=function, _k=kinds:
                            calls.append((_k, len(a[2]), a[4].copy(), a[5].copy()))
                            or _f(*a))
    w = sdfphys.World()
    w.add_body({"type": "box", "size": [20.0, 1.0]}, kind="static")
    l_shape = {"type": "polygon", "points": [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]}
    for x in (-6.0, -2.0, 2.0, 6.0):
        w.add_body(l_shape, position=(x, 4.0))
    w.add_body({"type": "box", "size": [1.0, 1.0]}, position=(0.0, 8.0))
    shapes = (world_stages.collision_shapes(w), w.shape_id, w.position,
              np.asarray(w.angle), np.array([False] + [True] * 5), w.settings)
    collide.compile_ahead(*shapes)
    assert calls == []
    collide.compile_ahead(*shapes, later=True)
    assert [(kinds, n) for kinds, n, _, _ in calls] == [(("mesh", "mesh"), 1)] * 3
    for _, _, pose_a, pose_b in calls:
        np.testing.assert_array_equal(pose_a, pose_b)
