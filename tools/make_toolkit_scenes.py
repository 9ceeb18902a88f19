"""Writes the toolkit scenes in scenes/ (python tools/make_toolkit_scenes.py):
sensor_gate, filtered_crowd and blast (docs/toolkit.md). Rows of balls and crowds
are easier to keep right as code than by hand."""

from __future__ import annotations

from pathlib import Path

from make_joint_scenes import fmt

OUT = Path(__file__).resolve().parents[1] / "scenes"


def write(name: str, header: str, bodies: list[dict], sim: dict, render: dict,
          blasts: tuple[dict, ...] = ()) -> None:
    """scenes/<name>.toml: the header as comments, [sim], [render], the bodies and the
    [[explode]] tables."""
    lines = [f"# {line}" if line else "#" for line in header.strip().splitlines()]
    lines += ["", "version = 1", "", "[sim]"] + [f"{k} = {fmt(v)}" for k, v in sim.items()]
    lines += ["", "[render]"] + [f"{k} = {fmt(v)}" for k, v in render.items()] + [""]
    for table, items in (("body", bodies), ("explode", blasts)):
        for item in items:
            lines.append(f"[[{table}]]")
            lines += [f"{k} = {fmt(v)}" for k, v in item.items()]
            lines.append("")
    (OUT / f"{name}.toml").write_text("\n".join(lines))


def render(center: tuple[float, float], scale: float) -> dict:
    return {"size": [960, 540], "center": list(center), "scale": scale, "fps": 60}


def box(name: str, size: tuple[float, float], position: tuple[float, float],
        angle: float = 0.0, **keys) -> dict:
    b = {"name": name, "shape": {"type": "box", "size": list(size)},
         "position": list(position)}
    if angle:
        b["angle"] = angle
    return {**b, **keys}


def sensor_gate() -> None:
    """Balls dropped into a funnel fall through a sensor gate under its neck into a bin."""
    bodies = [box("gate", (2.0, 0.5), (0.0, 3.2), static=True, sensor=True),
              box("ground", (30.0, 1.0), (0.0, -0.5), static=True, friction=0.6),
              box("bin_left", (0.3, 2.0), (-1.8, 1.0), static=True),
              box("bin_right", (0.3, 2.0), (1.8, 1.0), static=True),
              box("funnel_left", (3.0, 0.25), (-2.1, 4.8), angle=-0.7, static=True),
              box("funnel_right", (3.0, 0.25), (2.1, 4.8), angle=0.7, static=True)]
    for k in range(8):
        side = -1.0 if k % 2 else 1.0
        bodies.append({"name": f"ball{k}",
                       "shape": {"type": "circle", "radius": 0.25 + 0.03 * (k % 3)},
                       "position": [side * (0.3 + 0.5 * (k % 4)), 5.6 + 0.4 * k],
                       "friction": 0.4, "restitution": 0.2})
    write("sensor_gate", """
Eight balls dropped into a funnel fall through a gate under its neck into a bin. The
gate is a static sensor box (sensor = true): it reports each ball entering and leaving
(world.events sensor_begin and sensor_end, once per ball) and gives no contact
response, so the balls cross it as if it were not there.
Shows: sensors on static bodies, sensor events.""", bodies, {"duration": 5.0},
          render((0.0, 4.5), 45.0))


def filtered_crowd() -> None:
    """Two teams of balls thrown across each other: each collides with its own team and
    the ground and walls (category 1), and passes through the other team."""
    team_a = {"category": 2, "mask": 3, "density": 1.0, "friction": 0.4}
    team_b = {"category": 4, "mask": 5, "density": 2.0, "friction": 0.4}
    bodies = [box("ground", (30.0, 1.0), (0.0, -0.5), static=True, friction=0.6),
              box("wall_left", (0.5, 8.0), (-7.5, 4.0), static=True),
              box("wall_right", (0.5, 8.0), (7.5, 4.0), static=True)]
    for team, keys, side in (("a", team_a, -1.0), ("b", team_b, 1.0)):
        for k in range(12):
            row, col = divmod(k, 4)
            bodies.append({"name": f"{team}{k}",
                           "shape": {"type": "circle", "radius": 0.3},
                           "position": [side * (5.6 - 0.7 * col), 1.0 + 0.7 * row],
                           "velocity": [-side * 7.0, 4.0], **keys})
    write("filtered_crowd", """
Two teams of twelve balls thrown at each other: a (category 2, mask 3; from the left)
and b (category 4, mask 5; twice as dense, another colour). Each team collides with itself and with the ground and walls
(category 1, all bits in the mask), and passes through the other: the crowds cross in
the middle, then each piles against the far wall, two piles sharing the floor.
Shows: collision filtering by category and mask (docs/toolkit.md).""", bodies,
          {"duration": 5.0}, render((0.0, 3.2), 55.0))


def blast() -> None:
    """A pyramid of balls and two rows of heavy balls blown apart by a blast at t = 1 s."""
    bodies = [box("ground", (40.0, 1.0), (0.0, -0.5), static=True, friction=0.6),
              box("wall_left", (0.5, 10.0), (-9.0, 5.0), static=True),
              box("wall_right", (0.5, 10.0), (9.0, 5.0), static=True)]
    radius, rows = 0.3, 7
    for row in range(rows):
        for i in range(rows - row):     # hexagonal packing, 0.1 % apart
            bodies.append({"name": f"ball_{row}_{i}",
                           "shape": {"type": "circle", "radius": radius},
                           "position": [(i - (rows - row - 1) / 2) * 2.002 * radius,
                                        radius + row * radius * 3 ** 0.5 * 1.001],
                           "friction": 0.6})
    for side in (-1.0, 1.0):
        for k in range(3):
            bodies.append({"name": f"heavy_{'lr'[side > 0]}{k}",
                           "shape": {"type": "circle", "radius": 0.4},
                           "position": [side * (3.6 + 1.0 * k), 0.4], "density": 4.0,
                           "friction": 0.6})
    write("blast", """
A pyramid of 28 balls between two rows of heavy balls (four times as dense), at rest,
blown apart by a blast at t = 1 s left of the pyramid's foot: [[explode]] runs
world.explode at the first step at or after its time; every dynamic body whose surface
is within 5 m of the centre gets 4 N s per metre of its width facing the blast, away
from the centre (the heavy balls move off slower).
Shows: scheduled blasts ([[explode]]), bodies thrown and landing.""",
          bodies, {"duration": 5.0}, render((0.0, 3.5), 50.0),
          ({"time": 1.0, "center": [-0.6, -0.2], "radius": 5.0, "impulse": 4.0},))


if __name__ == "__main__":
    sensor_gate()
    filtered_crowd()
    blast()
