"""Writes the joint scenes in scenes/ (python tools/make_joint_scenes.py): pendulum,
double_pendulum, chain_bridge, ragdoll, cradle_strings and car. Chains, bridges and
ragdolls are easier to keep right as code than by hand (anchors at plank ends, limits
per limb)."""

from __future__ import annotations

import math
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "scenes"


def fmt(v) -> str:
    """A TOML value."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(round(v, 6))
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(fmt(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {fmt(x)}" for k, x in v.items()) + " }"
    raise TypeError(v)


def write(name: str, header: str, bodies: list[dict], joints: list[dict], sim: dict,
          render: dict) -> None:
    lines = [f"# {line}" if line else "#" for line in header.strip().splitlines()]
    lines += ["", "version = 1", "", "[sim]"] + [f"{k} = {fmt(v)}" for k, v in sim.items()]
    lines += ["", "[render]"] + [f"{k} = {fmt(v)}" for k, v in render.items()] + [""]
    for table, items in (("body", bodies), ("joint", joints)):
        for item in items:
            lines.append(f"[[{table}]]")
            lines += [f"{k} = {fmt(v)}" for k, v in item.items()]
            lines.append("")
    (OUT / f"{name}.toml").write_text("\n".join(lines))


def render(center, scale=50.0) -> dict:
    return {"size": [960, 540], "center": list(center), "scale": scale, "fps": 60}


def ground(width=40.0, friction=0.6) -> dict:
    return {"name": "ground", "shape": {"type": "box", "size": [width, 1.0]},
            "position": [0.0, -0.5], "static": True, "friction": friction}


def pendulum() -> None:
    write("pendulum", """
A pendulum released from 90 degrees: a 1 kg disc on a revolute joint 1 m from its
pivot. Its period is the complete elliptic integral's (2.369 s for this physical
pendulum); tests/test_joints.py checks it within 0.5 %.
Shows: a revolute joint to the world, no energy lost to the joint.""",
          [{"name": "bob", "shape": {"type": "circle", "radius": 0.05},
            "position": [1.0, 3.0], "mass": 1.0}],
          [{"type": "revolute", "name": "pivot", "bodies": ["bob", "world"],
            "anchor": [0.0, 3.0]}],
          {"duration": 8.0}, render((0.0, 2.5), 100.0))


def double_pendulum() -> None:
    write("double_pendulum", """
A double pendulum: two 1 x 0.1 m bars of 1 kg hinged end to end, the first to the
world, released horizontal; chaotic after the first swing.
Shows: revolute joints between two bodies (their contact is turned off).""",
          [{"name": "upper", "shape": {"type": "box", "size": [1.0, 0.1]},
            "position": [0.5, 3.0], "mass": 1.0},
           {"name": "lower", "shape": {"type": "box", "size": [1.0, 0.1]},
            "position": [1.5, 3.0], "mass": 1.0}],
          [{"type": "revolute", "bodies": ["upper", "world"], "anchor": [0.0, 3.0]},
           {"type": "revolute", "bodies": ["lower", "upper"], "anchor": [1.0, 3.0]}],
          {"duration": 10.0}, render((0.0, 2.0), 100.0))


def chain_bridge(planks: int = 40) -> None:
    span = 20.0
    width = span / planks
    bodies = [ground(60.0),
              {"name": "left_post", "shape": {"type": "box", "size": [1.0, 4.0]},
               "position": [-span / 2 - 0.5, 2.0], "static": True},
              {"name": "right_post", "shape": {"type": "box", "size": [1.0, 4.0]},
               "position": [span / 2 + 0.5, 2.0], "static": True}]
    joints = []
    previous = "left_post"
    for i in range(planks):
        x = -span / 2 + (i + 0.5) * width
        bodies.append({"name": f"plank{i}", "shape": {"type": "box", "size": [width, 0.2]},
                       "position": [x, 4.0], "density": 20.0, "friction": 0.6})
        joints.append({"type": "revolute", "bodies": [f"plank{i}", previous],
                       "anchor": [x - width / 2, 4.0]})
        previous = f"plank{i}"
    joints.append({"type": "revolute", "bodies": ["right_post", previous],
                   "anchor": [span / 2, 4.0]})
    for k, x in enumerate((-6.0, -1.0, 3.5, 7.0)):
        bodies.append({"name": f"crate{k}", "shape": {"type": "box", "size": [1.0, 1.0]},
                       "position": [x, 6.0 + k], "density": 50.0, "friction": 0.6})
    write("chain_bridge", """
A bridge of 40 planks (0.5 x 0.2 m, 2 kg) hinged end to end between two posts, with
four 50 kg crates dropped on it. The bridge sags into a catenary and holds them.
Shows: a long chain of revolute joints carrying loads many times its planks' weight
(load-stiffened, converged joint rows), contacts on jointed bodies.""",
          bodies, joints, {"duration": 6.0}, render((0.0, 3.0), 40.0))


def ragdoll(x0: float = 0.0, y0: float = 6.0) -> tuple[list[dict], list[dict]]:
    """A 1.8 m ragdoll standing at (x0, y0) (its feet's level), limbs with angle limits."""
    parts = {  # name: (shape, centre, mass)
        "head": ({"type": "circle", "radius": 0.12}, (0.0, 1.68), 5.0),
        "torso": ({"type": "box", "size": [0.34, 0.6]}, (0.0, 1.24), 30.0),
        "pelvis": ({"type": "box", "size": [0.3, 0.16]}, (0.0, 0.88), 10.0),
        "upper_arm_l": ({"type": "box", "size": [0.1, 0.3]}, (-0.22, 1.36), 2.0),
        "lower_arm_l": ({"type": "box", "size": [0.08, 0.3]}, (-0.22, 1.06), 1.5),
        "upper_arm_r": ({"type": "box", "size": [0.1, 0.3]}, (0.22, 1.36), 2.0),
        "lower_arm_r": ({"type": "box", "size": [0.08, 0.3]}, (0.22, 1.06), 1.5),
        "thigh_l": ({"type": "box", "size": [0.14, 0.4]}, (-0.09, 0.6), 8.0),
        "shin_l": ({"type": "box", "size": [0.11, 0.4]}, (-0.09, 0.2), 4.0),
        "thigh_r": ({"type": "box", "size": [0.14, 0.4]}, (0.09, 0.6), 8.0),
        "shin_r": ({"type": "box", "size": [0.11, 0.4]}, (0.09, 0.2), 4.0),
    }
    hinges = [  # (part, parent, anchor, limits rad)
        ("head", "torso", (0.0, 1.56), (-0.5, 0.5)),
        ("pelvis", "torso", (0.0, 0.94), (-0.3, 0.3)),
        ("upper_arm_l", "torso", (-0.22, 1.5), (-2.5, 2.5)),
        ("lower_arm_l", "upper_arm_l", (-0.22, 1.21), (0.0, 2.5)),
        ("upper_arm_r", "torso", (0.22, 1.5), (-2.5, 2.5)),
        ("lower_arm_r", "upper_arm_r", (0.22, 1.21), (-2.5, 0.0)),
        ("thigh_l", "pelvis", (-0.09, 0.8), (-1.5, 0.6)),
        ("shin_l", "thigh_l", (-0.09, 0.4), (0.0, 2.3)),
        ("thigh_r", "pelvis", (0.09, 0.8), (-1.5, 0.6)),
        ("shin_r", "thigh_r", (0.09, 0.4), (0.0, 2.3)),
    ]
    bodies = [{"name": name, "shape": shape, "position": [x0 + cx, y0 + cy], "mass": mass,
               "friction": 0.6} for name, (shape, (cx, cy), mass) in parts.items()]
    joints = [{"type": "revolute", "bodies": [part, parent],
               "anchor": [x0 + ax, y0 + ay], "limits": list(limits)}
              for part, parent, (ax, ay), limits in hinges]
    return bodies, joints


def ragdoll_scene() -> None:
    bodies, joints = ragdoll(0.0, 5.0)
    bodies[1]["angular_velocity"] = 1.5          # the torso: it tumbles as it falls
    steps = [{"name": f"step{k}", "shape": {"type": "box", "size": [2.0, 1.0]},
              "position": [1.0 + 2.0 * k, 3.5 - k], "static": True} for k in range(4)]
    write("ragdoll", """
A ragdoll of 11 parts (a 77 kg body: 30 kg torso, 1.5 kg forearms) with revolute joints
and angle limits at neck, waist, shoulders, elbows, hips and knees, tumbling down
four steps.
Shows: joint limits, a tree of joints with mass ratios of 20:1, contacts on jointed
bodies, jointed bodies falling asleep together.""",
          [ground(40.0)] + steps + bodies, joints, {"duration": 6.0},
          render((3.0, 3.0), 60.0))


def cradle_strings(balls: int = 5) -> None:
    radius, length, top = 0.25, 2.0, 3.0
    bodies, joints = [], []
    for i in range(balls):
        x = (2.0 * radius + 0.05) * i       # 5 cm apart: one impact at a time
        pulled = i == 0
        angle = math.radians(45.0) if pulled else 0.0
        px, py = x - length * math.sin(angle), top - length * math.cos(angle)
        bodies.append({"name": f"ball{i}", "shape": {"type": "circle", "radius": radius},
                       "position": [px, py], "mass": 1.0, "friction": 0.0,
                       "restitution": 1.0})
        joints.append({"type": "distance", "bodies": [f"ball{i}", "world"],
                       "anchors": [[px, py], [x, top]]})
    write("cradle_strings", """
Newton's cradle on strings: five 1 kg balls of radius 0.25 m in a row 5 cm apart, each
hung from a 2 m rigid string (a distance joint), restitution 1; the first is
pulled back 45 degrees and let go. Its momentum passes through the row and the last
ball swings out.
Shows: distance joints, elastic collisions between jointed bodies, restitution.""",
          bodies, joints, {"duration": 4.0}, render((1.0, 2.0), 120.0))


def car() -> None:
    terrain = {"name": "terrain", "shape": {"type": "sdf", "field": {
        "op": "smooth_union", "k": 1.0, "of": [
            {"type": "box", "size": [80.0, 2.0], "offset": [20.0, -1.0]},
            {"type": "circle", "radius": 3.0, "offset": [8.0, -2.0]},
            {"type": "ellipse", "size": [6.0, 1.2], "offset": [18.0, 0.0]},
            {"type": "circle", "radius": 4.0, "offset": [30.0, -2.5]}]}},
        "position": [0.0, 0.0], "static": True, "friction": 0.9}
    chassis = {"name": "chassis", "shape": {"type": "box", "size": [2.4, 0.4]},
               "position": [0.0, 1.4], "density": 40.0, "friction": 0.6}
    wheels = [{"name": name, "shape": {"type": "circle", "radius": 0.4},
               "position": [x, 0.8], "density": 20.0, "friction": 0.9}
              for name, x in (("rear_wheel", -0.8), ("front_wheel", 0.8))]
    joints = [{"type": "wheel", "bodies": [w["name"], "chassis"], "anchor": w["position"],
               "axis": [0.0, 1.0], "limits": [-0.25, 0.25],
               "spring": {"hertz": 4.0, "damping_ratio": 0.7},
               "motor": {"speed": -8.0, "max_torque": 60.0}} for w in wheels]
    write("car", """
A car on wheel joints: a 38 kg chassis and two wheels of radius 0.4 m on vertical
suspension springs (4 Hz, damping ratio 0.7, travel +-0.25 m), both driven at
-8 rad/s with 60 N m, over SDF terrain (a smooth union of a slab, two buried
circles and an ellipse).
Shows: wheel joints (spring, limits, motor), SDF contacts on jointed bodies.""",
          [terrain, chassis] + wheels, joints, {"duration": 5.0}, render((10.0, 3.0), 36.0))


if __name__ == "__main__":
    pendulum()
    double_pendulum()
    chain_bridge()
    ragdoll_scene()
    cradle_strings()
    car()
