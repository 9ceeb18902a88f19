"""Stability at the extremes, joints: a 100 kg weight on a chain of 1 kg links, and a
ragdoll whose 100 kg torso carries 1 kg limbs; in sdfphys, pymunk and Box2D v3.

Figure: the largest joint gap (distance between a revolute joint's two anchors, m),
once the chain has swung down (from 1 s to 10 s after its release from the
horizontal) and over the ragdoll's fall and tumble (5 s). pymunk: PivotJoint (and
RotaryLimitJoint for the ragdoll's limits) with collide_bodies off, 10 iterations.
Box2D v3 (pyb2d3, the ``[bench]`` extra, imported when a Box2D case runs; ``PEERS.md``):
revolute joints at its defaults (4 substeps, joint
hertz 60, damping ratio 2 in the solver; jointed bodies do not collide). Every engine
lets non-adjacent links and limbs collide with each other.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pymunk
from stability_common import (
    DT,
    Bound,
    advance,
    b2_ground_world,
    ground_world,
    pm_ground,
    pm_space,
    pm_steps,
)

from sdfphys.world import World

#: The issue's bound on every joint gap of the chain (Box2D v3 at its defaults: 56 mm).
JOINT_GAP = Bound(0.01, "m", "issue 18: every joint gap under 1 cm once swung down")
LINKS, LINK, WEIGHT, TOP = 20, (0.5, 0.1), 100.0, 20.0
RAGDOLL = Path(__file__).resolve().parents[2] / "scenes" / "ragdoll.toml"
TORSO, LIMB = 100.0, 1.0


def _chain_layout(hanging: bool) -> list[tuple[tuple[float, float], float, tuple[float, float]]]:
    """(centre, angle, joint anchor above it) of each link then of the weight (a circle
    of radius 0.5), from the world pin at (0, TOP): straight down or laid out to +x."""
    out = []
    for i in range(LINKS + 1):
        along, half = LINK[0] * i, (0.5 if i == LINKS else 0.5 * LINK[0])
        if hanging:
            out.append(((0.0, TOP - along - half), -0.5 * math.pi, (0.0, TOP - along)))
        else:
            out.append(((along + half, TOP), 0.0, (along, TOP)))
    return out


def ours_chain_world(hanging: bool) -> World:
    world = ground_world()
    previous = "world"
    for i, (centre, angle, anchor) in enumerate(_chain_layout(hanging)):
        shape = ({"type": "circle", "radius": 0.5} if i == LINKS
                 else {"type": "box", "size": list(LINK)})
        world.add_body(shape, position=centre, angle=angle, name=f"part{i}",
                       mass=WEIGHT if i == LINKS else 1.0)
        world.add_joint({"type": "revolute", "bodies": [f"part{i}", previous],
                         "anchor": list(anchor)})
        previous = f"part{i}"
    return world


def _ours_gap(world: World) -> float:
    first, second = world.joint_anchors()
    return float(np.hypot(*(first - second).T).max())


def ours_heavy_chain() -> dict[str, float]:
    world = ours_chain_world(hanging=False)
    worst = 0.0
    for k in advance(world, round(10.0 / DT)):
        if k > round(1.0 / DT):
            worst = max(worst, _ours_gap(world))
    hanging = ours_chain_world(hanging=True)
    for _ in advance(hanging, round(3.0 / DT)):
        pass
    return {"gap": worst, "hanging": _ours_gap(hanging)}


def pymunk_heavy_chain() -> dict[str, float]:
    def build(hanging: bool) -> tuple[pymunk.Space, list[pymunk.Constraint]]:
        space = pm_space()
        pm_ground(space)
        previous, joints = space.static_body, []
        for i, (centre, angle, anchor) in enumerate(_chain_layout(hanging)):
            if i == LINKS:
                body = pymunk.Body(WEIGHT, pymunk.moment_for_circle(WEIGHT, 0.0, 0.5))
                shape = pymunk.Circle(body, 0.5)
            else:
                body = pymunk.Body(1.0, pymunk.moment_for_box(1.0, LINK))
                shape = pymunk.Poly.create_box(body, LINK)
            body.position, body.angle = centre, angle
            joint = pymunk.PivotJoint(previous, body, anchor)
            joint.collide_bodies = False
            space.add(body, shape, joint)
            previous = body
            joints.append(joint)
        return space, joints

    def gap(joints: list[pymunk.PivotJoint]) -> float:
        return max((j.a.local_to_world(j.anchor_a) - j.b.local_to_world(j.anchor_b)).length
                   for j in joints)

    space, joints = build(hanging=False)
    worst = 0.0
    for k in pm_steps(space, round(10.0 / DT)):
        if k > round(1.0 / DT):
            worst = max(worst, gap(joints))
    space, hanging = build(hanging=True)
    for _ in pm_steps(space, round(3.0 / DT)):
        pass
    return {"gap": worst, "hanging": gap(hanging)}


def _b2_revolute(world, a, b, anchor, limits=None):
    """A revolute joint of ``a`` and ``b`` at world ``anchor``; (a, b, local anchors)."""
    import pyb2d3 as b2

    d = b2.RevoluteJointDef()
    d.body_a, d.body_b = a, b
    d.local_anchor_a, d.local_anchor_b = a.local_point(anchor), b.local_point(anchor)
    if limits is not None:
        d.enable_limit = True
        d.lower_angle, d.upper_angle = limits
    world.create_revolute_joint(d)
    return a, b, d.local_anchor_a, d.local_anchor_b


def _b2_gap(joints) -> float:
    return max(float(np.hypot(*(np.array(a.world_point(la)) - np.array(b.world_point(lb)))))
               for a, b, la, lb in joints)


def box2d_heavy_chain() -> dict[str, float]:
    import pyb2d3 as b2

    def build(hanging: bool):
        world, previous = b2_ground_world()
        joints = []
        for i, (centre, angle, anchor) in enumerate(_chain_layout(hanging)):
            body = world.create_dynamic_body(position=centre, rotation=angle)
            if i == LINKS:
                body.create_circle_shape(b2.shape_def(density=WEIGHT / (math.pi * 0.25)),
                                         b2.circle(radius=0.5))
            else:
                body.create_polygon_shape(b2.shape_def(density=1.0 / (LINK[0] * LINK[1])),
                                          b2.box(0.5 * LINK[0], 0.5 * LINK[1]))
            joints.append(_b2_revolute(world, previous, body, anchor))
            previous = body
        return world, joints

    world, joints = build(hanging=False)
    worst = 0.0
    for k in range(1, round(10.0 / DT) + 1):
        world.step(DT, 4)
        if k > round(1.0 / DT):
            worst = max(worst, _b2_gap(joints))
    world, hanging = build(hanging=True)
    for _ in range(round(3.0 / DT)):
        world.step(DT, 4)
    return {"gap": worst, "hanging": _b2_gap(hanging)}


# ---------------------------------------------------------------------------------------
# The 100:1 ragdoll: scenes/ragdoll.toml's parts and joints, torso 100 kg, limbs 1 kg,
# dropped tumbling from 2 m onto flat ground.
# ---------------------------------------------------------------------------------------


def _ragdoll() -> tuple[list[dict], list[dict]]:
    """The ragdoll's bodies (masses replaced, 3 m lower) and joints from the scene."""
    data = tomllib.loads(RAGDOLL.read_text())
    bodies = [dict(b, mass=TORSO if b["name"] == "torso" else LIMB,
                   position=[b["position"][0], b["position"][1] - 3.0])
              for b in data["body"] if not b.get("static")]
    joints = [dict(j, anchor=[j["anchor"][0], j["anchor"][1] - 3.0]) for j in data["joint"]]
    return bodies, joints


def ours_ragdoll() -> dict[str, float]:
    world = ground_world()
    bodies, joints = _ragdoll()
    for b in bodies:
        world.add_body(b["shape"], position=b["position"], mass=b["mass"], name=b["name"],
                       friction=b["friction"], angular_velocity=b.get("angular_velocity", 0.0))
    for j in joints:
        world.add_joint(j)
    worst = 0.0
    for _ in advance(world, round(5.0 / DT)):
        worst = max(worst, _ours_gap(world))
    return {"gap": worst}


def pymunk_ragdoll() -> dict[str, float]:
    space = pm_space()
    pm_ground(space)
    bodies, joints = _ragdoll()
    made = {}
    for b in bodies:
        shape = b["shape"]
        if shape["type"] == "circle":
            body = pymunk.Body(b["mass"], pymunk.moment_for_circle(b["mass"], 0.0,
                                                                    shape["radius"]))
            made_shape = pymunk.Circle(body, shape["radius"])
        else:
            body = pymunk.Body(b["mass"], pymunk.moment_for_box(b["mass"], shape["size"]))
            made_shape = pymunk.Poly.create_box(body, shape["size"])
        body.position = b["position"]
        body.angular_velocity = b.get("angular_velocity", 0.0)
        made_shape.friction = math.sqrt(b["friction"])
        space.add(body, made_shape)
        made[b["name"]] = body
    pivots = []
    for j in joints:
        part, parent = made[j["bodies"][0]], made[j["bodies"][1]]
        pivot = pymunk.PivotJoint(parent, part, j["anchor"])
        limit = pymunk.RotaryLimitJoint(parent, part, *j["limits"])
        for c in (pivot, limit):
            c.collide_bodies = False
        space.add(pivot, limit)
        pivots.append(pivot)
    worst = 0.0
    for _ in pm_steps(space, round(5.0 / DT)):
        worst = max(worst, max((p.a.local_to_world(p.anchor_a)
                                - p.b.local_to_world(p.anchor_b)).length for p in pivots))
    return {"gap": worst}


def box2d_ragdoll() -> dict[str, float]:
    import pyb2d3 as b2

    world, _ = b2_ground_world()
    bodies, joints = _ragdoll()
    made = {}
    for b in bodies:
        shape = b["shape"]
        body = world.create_dynamic_body(position=tuple(b["position"]))
        body.angular_velocity = b.get("angular_velocity", 0.0)
        material = b2.surface_material(friction=b["friction"])
        if shape["type"] == "circle":
            area = math.pi * shape["radius"] ** 2
            body.create_circle_shape(b2.shape_def(density=b["mass"] / area, material=material),
                                     b2.circle(radius=shape["radius"]))
        else:
            w, h = shape["size"]
            body.create_polygon_shape(b2.shape_def(density=b["mass"] / (w * h),
                                                   material=material), b2.box(w / 2, h / 2))
        made[b["name"]] = body
    made_joints = [_b2_revolute(world, made[j["bodies"][1]], made[j["bodies"][0]],
                                tuple(j["anchor"]), tuple(j["limits"])) for j in joints]
    worst = 0.0
    for _ in range(round(5.0 / DT)):
        world.step(DT, 4)
        worst = max(worst, _b2_gap(made_joints))
    return {"gap": worst}
