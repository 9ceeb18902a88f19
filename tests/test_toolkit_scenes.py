"""The toolkit's example scenes (scenes/sensor_gate.toml, filtered_crowd.toml,
blast.toml; docs/toolkit.md) do what their headers say, checked exactly: events per
ball, no contact across teams, the blast at its step bit for bit."""

from pathlib import Path

import numpy as np

from sdfphys.scene import read_scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def _steps(scene) -> int:
    return round(scene.duration / scene.settings.dt)


def test_sensor_gate_sees_each_ball_enter_and_leave_once_and_moves_none():
    """Over the scene's duration the gate (body 0) reports every ball once entering and
    once leaving, after it entered; every body moves bit for bit as in the scene
    without the gate."""
    scene = read_scene(SCENES / "sensor_gate.toml")
    world = scene.build()
    data = dict(scene.data, body=[b for b in scene.data["body"] if b["name"] != "gate"])
    bare = read_scene(data).build()
    assert world.names[0] == "gate" and bare.names == world.names[1:]
    balls = [i for i, name in enumerate(world.names) if name.startswith("ball")]
    entered, left = [], []
    for _ in range(_steps(scene)):
        world.step()
        bare.step()
        assert world.position[1:].tolist() == bare.position.tolist()
        assert world.angle[1:].tolist() == bare.angle.tolist()
        events = world.events
        for rows, seen in ((events.sensor_begin, entered), (events.sensor_end, left)):
            assert np.all(rows[:, 0] == 0)
            seen.extend(rows[:, 1].tolist())
        assert all(v in entered for v in events.sensor_end[:, 1])
    assert sorted(entered) == sorted(left) == balls


def test_filtered_crowd_teams_pass_through_each_other_and_collide_within():
    """No contact between a ball of team a and one of team b at any step, although
    their discs overlap while they cross; contacts within each team; at the end team a
    lies right of the middle and team b left."""
    scene = read_scene(SCENES / "filtered_crowd.toml")
    world = scene.build()
    team = np.array([name[0] if name[1:].isdigit() else "" for name in world.names])
    a, b = team == "a", team == "b"
    assert a.sum() == b.sum() == 12
    crossed = within = 0
    for _ in range(_steps(scene)):
        world.step()
        c = world.contacts
        ta, tb = team[c.body_a], team[c.body_b]
        assert not np.any((ta != "") & (tb != "") & (ta != tb))
        within += int(np.sum((ta != "") & (ta == tb)))
        p = world.position
        gap = np.hypot(*(p[a][:, None] - p[b][None]).transpose(2, 0, 1))
        crossed += int(np.sum(gap < 0.6))            # two radii of 0.3 m
    assert crossed > 0 and within > 0
    assert np.all(world.position[a, 0] > 0.0) and np.all(world.position[b, 0] < 0.0)


def test_blast_scene_runs_its_explode_table_at_its_step():
    """The scene equals the scene without [[explode]] bit for bit until t = 1 s, and
    equals it with ``explode`` called by hand (the table's values) before step 61 from
    then on."""
    scene = read_scene(SCENES / "blast.toml")
    (blast,) = scene.data["explode"]
    world = scene.build()
    plain = read_scene({k: v for k, v in scene.data.items() if k != "explode"}).build()
    for _ in range(60):
        world.step()
        plain.step()
        assert world.position.tolist() == plain.position.tolist()
    pushed = plain.explode(blast["center"], blast["radius"], blast["impulse"])
    # Every dynamic body is a ball: pushed when its surface is within the radius.
    dynamic = np.flatnonzero(np.asarray(plain.kind) == "dynamic")
    radius = np.array([plain.shapes[s].radius for s in plain.shape_id[dynamic]])
    reach = np.hypot(*(plain.position[dynamic] - blast["center"]).T) - radius
    assert pushed.tolist() == dynamic[reach < blast["radius"]].tolist()
    assert 0 < len(pushed) < len(dynamic)
    for _ in range(20):
        world.step()
        plain.step()
        assert world.position.tolist() == plain.position.tolist()
        assert world.velocity.tolist() == plain.velocity.tolist()
    assert np.max(np.hypot(*world.velocity.T)) > 1.0
