"""Writes the scene files in scenes/ (python tools/make_scenes.py): the generated ones
(pyramid, circles, rows) are easier to keep right as code than by hand."""
import math
import random
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "scenes"
OUT.mkdir(exist_ok=True)

def fmt(v):
    if isinstance(v, bool): return "true" if v else "false"
    if isinstance(v, (int,)): return str(v)
    if isinstance(v, float): return repr(round(v, 6))
    if isinstance(v, str): return f'"{v}"'
    if isinstance(v, (list, tuple)): return "[" + ", ".join(fmt(x) for x in v) + "]"
    if isinstance(v, dict): return "{ " + ", ".join(f"{k} = {fmt(x)}" for k, x in v.items()) + " }"
    raise TypeError(v)

def scene(name, header, bodies, sim=None, render=None, world=None):
    lines = [f"# {l}" if l else "#" for l in header.strip().splitlines()]
    lines += ["", "version = 1", ""]
    if world:
        lines += ["[world]"] + [f"{k} = {fmt(v)}" for k, v in world.items()] + [""]
    lines += ["[sim]"] + [f"{k} = {fmt(v)}" for k, v in (sim or {"duration": 5.0}).items()] + [""]
    r = {"size": [960, 540], "center": [0.0, 4.0], "scale": 50.0, "fps": 60}
    r.update(render or {})
    lines += ["[render]"] + [f"{k} = {fmt(v)}" for k, v in r.items()] + [""]
    for b in bodies:
        lines.append("[[body]]")
        lines += [f"{k} = {fmt(v)}" for k, v in b.items()]
        lines.append("")
    (OUT / f"{name}.toml").write_text("\n".join(lines))

def ground(width=40.0, y=0.0, friction=0.6, name="ground"):
    return {"name": name, "shape": {"type": "box", "size": [width, 1.0]}, "position": [0.0, y - 0.5],
            "static": True, "friction": friction}

def wall(x, h=10.0, name=None):
    b = {"shape": {"type": "box", "size": [0.5, h]}, "position": [x, h / 2], "static": True}
    if name: b = {"name": name, **b}
    return b

# 1. stack
scene("box_stack", """
A vertical stack of ten 1 m boxes on the ground.
Shows: resting contact, warm starting, stability of a tall stack (it must stand).
""", [ground()] + [{"name": f"box{i}", "shape": {"type": "box", "size": [1.0, 1.0]},
                     "position": [0.0, 0.5 + i * 1.0], "friction": 0.6} for i in range(10)],
      sim={"duration": 10.0}, render={"center": [0.0, 5.0], "scale": 45.0})

# 2. pyramid
bodies = [ground(60.0)]
n = 20
for row in range(n):
    for i in range(n - row):
        x = (i - (n - row - 1) / 2) * 1.0
        bodies.append({"name": f"box_{row}_{i}", "shape": {"type": "box", "size": [1.0, 1.0]},
                       "position": [x, 0.5 + row * 1.0], "friction": 0.6})
scene("pyramid", """
A pyramid of 210 boxes with a base of 20.
Shows: many resting contacts solved together; the top box must stay put.
""", bodies, sim={"duration": 10.0}, render={"center": [0.0, 9.75], "scale": 24.0})

# 3. circles into a box
random.seed(7)
bodies = [ground(16.0), wall(-8.0, 14.0, "left"), wall(8.0, 14.0, "right")]
for i in range(150):
    row, col = divmod(i, 15)
    bodies.append({"shape": {"type": "circle", "radius": round(random.uniform(0.2, 0.4), 3)},
                   "position": [round(-6.3 + col * 0.9 + random.uniform(-0.03, 0.03), 3),
                                round(2.0 + row * 0.95, 3)],
                   "friction": 0.5})
scene("circles_in_box", """
150 circles of mixed radii poured into a static container.
Shows: circle-circle and circle-box contacts at scale, piling, friction.
""", bodies, sim={"duration": 6.0}, render={"center": [0.0, 6.0], "scale": 36.0})

# 4. Newton's cradle (no strings: five balls on a frictionless rail, 5 cm apart)
r = 0.5
gap = 0.05
bodies = [ground(30.0, friction=0.0)]
for i in range(5):
    bodies.append({"name": f"ball{i}", "shape": {"type": "circle", "radius": r},
                   "position": [i * (2 * r + gap), r], "friction": 0.0, "restitution": 1.0})
bodies.append({"name": "striker", "shape": {"type": "circle", "radius": r},
               "position": [-4.0, r], "velocity": [4.0, 0.0], "friction": 0.0, "restitution": 1.0})
scene("newtons_cradle", """
Newton's cradle on a frictionless rail: a striker hits a row of five balls set
5 cm apart, with restitution 1; each collision passes the whole speed on, and the
last ball leaves with the striker's 4 m/s while the others stop.
Shows: elastic collisions, momentum transfer, the restitution pass. (Touching
balls would need simultaneous impacts, which a sequential impulse solver resolves
as partly inelastic: the gaps make the impacts one at a time, as in a real cradle.)
""", bodies, sim={"duration": 4.0}, render={"center": [2.0, 1.5], "scale": 60.0})

# 5. ramp with friction
ang = math.radians(25)
bodies = [ground(40.0),
          {"name": "ramp", "shape": {"type": "box", "size": [14.0, 0.5]}, "position": [0.0, 3.0],
           "angle": -ang, "static": True, "friction": 1.0}]
for i, mu in enumerate([0.05, 0.3, 0.6]):
    s = -4.5 + i * 1.6
    x = s * math.cos(ang)
    y = 3.0 - s * math.sin(ang) + (0.25 + 0.4) / math.cos(ang)
    bodies.append({"name": f"box_mu_{mu}", "shape": {"type": "box", "size": [0.8, 0.8]},
                   "position": [x, y], "angle": -ang, "friction": mu})
scene("ramp_friction", """
Three boxes on a 25 degree ramp with friction 0.05, 0.3 and 0.6 (mixed with the
ramp's 1.0 as sqrt(a*b)). tan(25 deg) = 0.466: the first two slide, the third sticks.
Shows: Coulomb friction, sliding against sticking.
""", bodies, sim={"duration": 5.0}, render={"center": [0.0, 3.0], "scale": 45.0})

# 6. restitution row
bodies = [ground(30.0)]
for i, e in enumerate([0.0, 0.2, 0.4, 0.6, 0.8, 0.95]):
    bodies.append({"name": f"ball_e{e}", "shape": {"type": "circle", "radius": 0.4},
                   "position": [-5.0 + 2.0 * i, 6.0], "restitution": e})
scene("restitution_row", """
Six balls dropped from 6 m with restitution 0, 0.2, 0.4, 0.6, 0.8 and 0.95.
Shows: restitution (bounce height about e^2 times the drop height), the
restitution threshold ending the bounces.
""", bodies, sim={"duration": 6.0}, render={"center": [0.0, 3.5], "scale": 60.0})


# 7. concave polygons
L = [[0, 0], [1.2, 0], [1.2, 0.4], [0.4, 0.4], [0.4, 1.2], [0, 1.2]]
U = [[0, 0], [1.4, 0], [1.4, 1.0], [1.0, 1.0], [1.0, 0.4], [0.4, 0.4], [0.4, 1.0], [0, 1.0]]
star = [[round(math.cos(math.pi / 2 + k * math.pi / 5) * (0.7 if k % 2 == 0 else 0.3), 4),
         round(math.sin(math.pi / 2 + k * math.pi / 5) * (0.7 if k % 2 == 0 else 0.3), 4)]
        for k in range(10)]
arrow = [[0, 0.25], [0.8, 0.25], [0.8, 0.5], [1.3, 0], [0.8, -0.5], [0.8, -0.25], [0, -0.25]]


def centred(points):
    """The outline moved so that its bounding-box centre is the origin."""
    cx = (min(p[0] for p in points) + max(p[0] for p in points)) / 2
    cy = (min(p[1] for p in points) + max(p[1] for p in points)) / 2
    return [[round(x - cx, 4), round(y - cy, 4)] for x, y in points]


L, U, arrow = centred(L), centred(U), centred(arrow)
bodies = [ground(30.0), wall(-7.0, 10.0, "left"), wall(7.0, 10.0, "right")]
shapes = [L, U, star, arrow]
for i in range(16):
    pts = shapes[i % 4]
    bodies.append({"name": f"poly{i}", "shape": {"type": "polygon", "points": pts},
                   "position": [-5.0 + (i % 5) * 2.4, 1.5 + (i // 5) * 2.4],
                   "angle": round(0.4 * i, 3), "friction": 0.5})
scene("concave_polygons", """
Concave polygons (L, U, five-pointed star, arrow) triangulated and dropped in a bin.
Shows: triangulated bodies, triangle-field contacts both ways, concave
corners interlocking.
""", bodies, sim={"duration": 6.0}, render={"center": [0.0, 4.0], "scale": 45.0})

# 8. analytic SDF bodies
fields = [
    {"type": "heart", "scale": 1.0},
    {"type": "moon", "radius": 0.6, "bite_radius": 0.5, "distance": 0.35},
    {"type": "egg", "radius": 0.5, "top_radius": 0.2},
    {"type": "star", "radius": 0.7, "points": 5, "m": 3.0},
    {"type": "arc", "half_angle": 2.0, "radius": 0.5, "thickness": 0.12},
    {"type": "vesica", "radius": 0.8, "distance": 0.5},
    {"type": "ellipse", "size": [1.4, 0.7]},
    {"type": "hexagram", "radius": 0.35},
    {"type": "pie", "half_angle": 0.8, "radius": 0.7},
    {"type": "uneven_capsule", "bottom_radius": 0.35, "top_radius": 0.15, "height": 0.8},
    {"type": "horseshoe", "half_opening": 0.8, "radius": 0.45, "length": 0.2, "thickness": 0.12},
    {"type": "rounded_cross", "h": 0.6, "radius": 0.6},
]
bodies = [ground(30.0), wall(-7.5, 10.0, "left"), wall(7.5, 10.0, "right")]
for i, f in enumerate(fields):
    bodies.append({"name": f["type"], "shape": {"type": "sdf", "field": f},
                   "position": [-5.5 + (i % 6) * 2.2, 1.5 + (i // 6) * 2.5],
                   "angle": round(0.3 * i, 3), "friction": 0.5})
scene("sdf_primitives", """
Twelve exact analytic SDF bodies (heart, moon, egg, star, arc, vesica, ellipse,
hexagram, pie, uneven capsule, horseshoe, rounded cross) falling onto the ground.
Shows: SDF bodies colliding with each other (field-field) and with a
triangulated ground (triangle-field).
""", bodies, sim={"duration": 6.0}, render={"center": [0.0, 4.0], "scale": 45.0})

# 9. CSG bodies
csg = [
    {"op": "smooth_union", "k": 0.3, "of": [{"type": "circle", "radius": 0.5, "offset": [-0.45, 0.0]},
                                            {"type": "circle", "radius": 0.4, "offset": [0.45, 0.1]}]},
    {"op": "difference", "of": [{"type": "box", "size": [1.4, 1.0]}, {"type": "circle", "radius": 0.3}]},
    {"op": "smooth_difference", "k": 0.15, "blend": "cubic",
     "of": [{"type": "rounded_box", "size": [1.4, 0.9], "radii": 0.2}, {"type": "circle", "radius": 0.35, "offset": [0.0, 0.45]}]},
    {"op": "onion", "thickness": 0.08, "of": {"type": "hexagon", "radius": 0.5}},
    {"op": "round", "r": 0.1, "of": {"type": "star", "radius": 0.55, "points": 4, "m": 2.5}},
    {"op": "smooth_union", "k": 0.25, "blend": "exponential",
     "of": [{"type": "box", "size": [1.6, 0.3]}, {"type": "box", "size": [0.3, 1.2]}]},
    {"op": "intersection", "of": [{"type": "circle", "radius": 0.7}, {"type": "box", "size": [1.0, 1.6]}]},
    {"op": "xor", "of": [{"type": "circle", "radius": 0.6}, {"type": "box", "size": [0.8, 0.8]}]},
]
bodies = [ground(30.0), wall(-7.0, 10.0, "left"), wall(7.0, 10.0, "right")]
for i, f in enumerate(csg):
    bodies.append({"name": f"csg{i}", "shape": {"type": "sdf", "field": f},
                   "position": [-4.5 + (i % 4) * 3.0, 1.5 + (i // 4) * 2.6],
                   "angle": round(0.5 * i, 3), "friction": 0.5})
scene("csg_bodies", """
CSG bodies built from primitives: smooth unions (polynomial and exponential
blends), a box with a hole, a smooth difference, an onion (hollow hexagon), a
rounded star, an intersection and an xor (a body in four pieces).
Shows: operators with analytic gradients as rigid bodies, mass properties
integrated from the field.
""", bodies, sim={"duration": 6.0}, render={"center": [0.0, 4.0], "scale": 45.0})

# 10. baked grid terrain
terrain = {"op": "bake", "cell": 0.1, "band": 1.0, "of": {"op": "smooth_union", "k": 1.0, "of": [
    {"type": "box", "size": [24.0, 2.0], "offset": [0.0, -1.0]},
    {"type": "circle", "radius": 2.5, "offset": [-6.0, -1.2]},
    {"type": "circle", "radius": 1.8, "offset": [1.0, -0.8]},
    {"type": "ellipse", "size": [6.0, 2.0], "offset": [6.5, 0.0]}]}}
bodies = [{"name": "terrain", "shape": {"type": "sdf", "field": terrain}, "static": True, "friction": 0.7},
          wall(-12.25, 10.0, "left"), wall(12.25, 10.0, "right")]
random.seed(3)
for i in range(24):
    kind = i % 3
    shape = ({"type": "circle", "radius": 0.35} if kind == 0 else
             {"type": "box", "size": [0.6, 0.6]} if kind == 1 else
             {"type": "polygon", "points": [[0, 0], [0.8, 0], [0.4, 0.6]]})
    bodies.append({"shape": shape, "position": [-10.0 + i * 0.85, 4.0 + (i % 4) * 0.9],
                   "friction": 0.5})
scene("grid_terrain", """
A terrain baked into a grid (cell 0.1 m, narrow band 1 m) from a smooth union of
a box, two hills and an ellipse, with circles, boxes and triangles rolling over it.
Shows: baked-grid fields (bilinear value and gradient) as static colliders.
""", bodies, sim={"duration": 6.0}, render={"center": [0.0, 2.5], "scale": 38.0})

# 11. mixed pairs: every kind against every kind
bodies = [ground(30.0)]
kinds = [("circle", {"type": "circle", "radius": 0.45}),
         ("box", {"type": "box", "size": [0.9, 0.9]}),
         ("polygon", {"type": "polygon", "points": L}),
         ("sdf", {"type": "sdf", "field": {"type": "rounded_box", "size": [1.0, 0.8], "radii": 0.2}})]
col = 0
for i, (na, sa) in enumerate(kinds):
    for nb, sb in kinds[i:]:
        x = -7.5 + col * 1.6
        bodies.append({"name": f"{na}_under_{nb}_{col}", "shape": sa, "position": [x, 0.7]})
        bodies.append({"name": f"{nb}_over_{na}_{col}", "shape": sb, "position": [x + 0.2, 2.3], "angle": 0.4})
        col += 1
scene("mixed_pairs", """
Every pair of body kinds (circle, box, concave polygon, SDF) dropped one on the
other: ten columns, one per pair of kinds.
Shows: the narrowphase dispatch table: circle-circle, circle-mesh, circle-sdf,
mesh-mesh, mesh-sdf and sdf-sdf contacts.
""", bodies, sim={"duration": 4.0}, render={"center": [0.0, 2.5], "scale": 46.0})

# 12. marble run over an SDF landscape
run = {"op": "smooth_union", "k": 0.3, "of": [
    {"type": "capsule", "a": [-9.0, 9.0], "b": [-1.0, 6.5], "radius": 0.2},
    {"type": "capsule", "a": [1.0, 5.5], "b": [8.5, 3.5], "radius": 0.2},
    {"type": "arc", "half_angle": 1.2, "radius": 1.6, "thickness": 0.2, "offset": [8.0, 5.0], "angle": 3.14159},
    {"type": "capsule", "a": [6.5, 1.8], "b": [-6.0, 0.3], "radius": 0.2},
    {"type": "box", "size": [24.0, 0.6], "offset": [0.0, -0.3]}]}
bodies = [{"name": "track", "shape": {"type": "sdf", "field": run}, "static": True, "friction": 0.6},
          wall(-10.25, 12.0, "left")]
for i in range(10):
    bodies.append({"name": f"marble{i}", "shape": {"type": "circle", "radius": 0.25},
                   "position": [-8.6 + i * 0.55, 9.5 + 0.2 * i], "friction": 0.4, "restitution": 0.2})
scene("marble_run", """
Marbles rolling down a track carved as one static SDF: a smooth union of capsule
ramps and an arc that turns them back.
Shows: circle-field contacts on curved, blended surfaces; rolling.
""", bodies, sim={"duration": 8.0}, render={"center": [0.0, 5.0], "scale": 40.0})

# 13. bullet
bodies = [ground(30.0),
          {"name": "wall", "shape": {"type": "box", "size": [0.1, 4.0]}, "position": [3.0, 2.0], "static": True},
          {"name": "bullet", "shape": {"type": "circle", "radius": 0.1}, "position": [-6.0, 1.0],
           "velocity": [200.0, 0.0], "friction": 0.2}]
scene("bullet", """
A 0.1 m circle fired at 200 m/s at a static wall 0.1 m thick.
Shows: time of impact by conservative advancement on the SDF: no tunnelling.
""", bodies, world={"gravity": [0.0, -9.81]}, sim={"duration": 2.0},
      render={"center": [0.0, 2.0], "scale": 60.0})

# 14. kinematic platform
bodies = [ground(30.0),
          {"name": "platform", "shape": {"type": "box", "size": [3.0, 0.3]}, "position": [-4.0, 2.0],
           "velocity": [1.5, 0.0], "kinematic": True, "friction": 0.9}]
for i in range(3):
    bodies.append({"name": f"crate{i}", "shape": {"type": "box", "size": [0.6, 0.6]},
                   "position": [-5.0 + i * 0.8, 2.5], "friction": 0.9})
scene("kinematic_platform", """
A kinematic platform moving at 1.5 m/s carries three crates on friction.
Shows: kinematic bodies (infinite mass, prescribed velocity), friction transport.
""", bodies, sim={"duration": 5.0}, render={"center": [0.0, 2.5], "scale": 55.0})

# 15. showcase
bodies = [{"name": "terrain", "shape": {"type": "sdf", "field": {"op": "smooth_union", "k": 0.8, "of": [
            {"type": "box", "size": [26.0, 1.0], "offset": [0.0, -0.5]},
            {"type": "circle", "radius": 2.0, "offset": [-5.0, -1.0]},
            {"type": "ellipse", "size": [5.0, 1.6], "offset": [5.0, 0.0]}]}}, "static": True, "friction": 0.7},
          wall(-13.25, 12.0, "left"), wall(13.25, 12.0, "right")]
for row in range(4):
    for i in range(4 - row):
        bodies.append({"shape": {"type": "box", "size": [0.8, 0.8]},
                       "position": [0.2 + (i - (3 - row) / 2) * 0.8, 0.4 + row * 0.8], "friction": 0.6})
for i, f in enumerate(fields[:6]):
    bodies.append({"name": f"sdf_{f['type']}", "shape": {"type": "sdf", "field": f},
                   "position": [-9.0 + i * 3.4, 7.0], "angle": 0.5 * i, "friction": 0.5})
for i in range(12):
    bodies.append({"shape": {"type": "circle", "radius": 0.3}, "position": [-10.0 + i * 1.7, 9.5],
                   "friction": 0.4, "restitution": 0.3})
for i, pts in enumerate([L, U, star]):
    bodies.append({"shape": {"type": "polygon", "points": pts}, "position": [3.0 + i * 2.5, 5.0],
                   "angle": 0.7 * i, "friction": 0.5})
scene("showcase", """
Everything at once: a smooth-union terrain, a small pyramid of boxes, analytic
SDF bodies, bouncing circles and concave polygons.
Shows: every body kind and pair kind in one scene.
""", bodies, sim={"duration": 8.0}, render={"center": [0.0, 5.0], "scale": 36.0, "hud": True})

