"""The joints' direct solve (``solver.joint_direct``) against dense numpy linear algebra."""

from __future__ import annotations

import numpy as np
import pytest

import sdfphys
from sdfphys.solver import joint_direct as direct
from sdfphys.solver.joint_direct import kernel_plan
from sdfphys.solver.joints import RELAX, SOLVE, Output, pack, stiffened_softness
from sdfphys.world_stages import body_state


def chain_world(links: int = 5, pinned_end: bool = False, chains: int = 1):
    """``chains`` chains of ``links`` 1 kg planks hinged end to end from the world at
    x = 3 c, stepped 20 times; with ``pinned_end`` the last link is pinned too."""
    bodies, joints = [], []
    for c in range(chains):
        for i in range(links):
            bodies.append({"name": f"l{c}_{i}", "shape": {"type": "box", "size": [0.5, 0.1]},
                           "position": [3.0 * c + 0.25 + 0.5 * i, 0.0], "mass": 1.0})
            joints.append({"type": "revolute",
                           "bodies": [f"l{c}_{i}", "world" if i == 0 else f"l{c}_{i - 1}"],
                           "anchor": [3.0 * c + 0.5 * i, 0.0]})
        if pinned_end:
            joints.append({"type": "revolute", "bodies": [f"l{c}_{links - 1}", "world"],
                           "anchor": [3.0 * c + 0.5 * links, 0.0]})
    world = sdfphys.load_scene({"version": 1, "body": bodies, "joint": joints})
    for _ in range(20):
        world.step()
    return world


def dense_system(p, rows, inv_mass, inv_inertia):
    """(J (R, 3B), M^-1 (3B,), G (R, R)) of plan p's rows as ``factor`` left them."""
    count, bodies = len(p.row_joint), len(inv_mass)
    jac = np.zeros((count, 3 * bodies))
    for r in range(count):
        j = p.row_joint[r]
        ux, uy, a1, a2 = p.jac[r]
        a, b = rows.body_a[j], rows.body_b[j]
        if a >= 0:
            jac[r, 3 * a:3 * a + 3] = (-ux, -uy, -a1)
        if b >= 0:
            jac[r, 3 * b:3 * b + 3] = (ux, uy, a2)
    inverse = np.stack([inv_mass, inv_mass, inv_inertia], 1).reshape(-1)
    a_matrix = jac @ (inverse[:, None] * jac.T)
    g = np.diag(p.scale * np.diag(a_matrix))
    for r in range(1, count):                   # a shared point's 2x2 block
        if p.row_code[r] == 1 and p.row_joint[r - 1] == p.row_joint[r]:
            g[r, r - 1] = g[r - 1, r] = p.scale[r] * a_matrix[r, r - 1]
    return jac, inverse, a_matrix, g


def test_one_direct_pass_is_the_dense_solution_of_the_soft_and_the_rigid_system():
    """(A + G) d_l = -(J v + b C) - G l solved by numpy equals the envelope Cholesky's
    impulses, and the velocities after it satisfy the rows' equations exactly."""
    world = chain_world()
    bodies = body_state(world)
    rows = world._joints.rows
    soft, _ = stiffened_softness(bodies.inv_mass, bodies.inv_inertia, rows, world.settings,
                                 world._gravity, 4.0)
    rng = np.random.default_rng(3)
    ref = pack(rows)
    for phase in (SOLVE, RELAX):
        p = direct.plan(ref, bodies.inv_mass, bodies.inv_inertia)
        direct.factor(kernel_plan(p), bodies.com, bodies.angle, bodies.inv_mass,
                      bodies.inv_inertia, ref, soft, phase)
        assert p.ok.tolist() == [True] and len(p.row_joint) == 10
        jac, _, a_matrix, g = dense_system(p, rows, bodies.inv_mass, bodies.inv_inertia)
        velocity = rng.normal(size=(len(bodies.inv_mass), 2))
        spin = rng.normal(size=len(bodies.inv_mass))
        impulse = ref.impulses[p.row_joint, p.row_code]
        x = np.column_stack([velocity, spin]).reshape(-1)
        expected = np.linalg.solve(a_matrix + g, -(jac @ x + p.rate * p.error) - g @ impulse)
        out = Output(np.zeros((0, 2)), np.zeros(0), np.zeros(2))
        after_ref = pack(rows)
        direct.direct_pass(kernel_plan(p), velocity, spin, bodies.inv_mass, bodies.inv_inertia,
                           after_ref, out)
        got = after_ref.impulses[p.row_joint, p.row_code] - impulse
        np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-12)
        residual = jac @ np.column_stack([velocity, spin]).reshape(-1) + p.rate * p.error \
            + g @ (impulse + got)
        np.testing.assert_allclose(residual, 0.0, atol=1e-9)
        assert out.progress[0] == pytest.approx(np.abs(got).max(), rel=1e-12)


def test_islands_split_at_the_world_and_redundant_rigid_rows_fall_back():
    """Two chains hung from the world are two islands; a chain pinned at both ends to the
    world has 2 more rows than a free chain's 3 L - 1 degrees of freedom allow rigidly for
    L = 1 (a plank pinned at both ends): solved softly it factors, rigid (relaxing) its
    pivot fails and the island goes back to Gauss-Seidel (mask cleared), and back to the
    direct solve at the next soft phase."""
    world = chain_world(links=3, chains=2)
    bodies, rows = body_state(world), world._joints.rows
    p = direct.plan(pack(rows), bodies.inv_mass, bodies.inv_inertia)
    assert np.diff(p.start).tolist() == [6, 6]

    world = chain_world(links=1, pinned_end=True)
    bodies, rows = body_state(world), world._joints.rows
    soft, _ = stiffened_softness(bodies.inv_mass, bodies.inv_inertia, rows, world.settings,
                                 world._gravity, 4.0)
    ref = pack(rows)
    p = direct.plan(ref, bodies.inv_mass, bodies.inv_inertia)
    for phase, ok in ((SOLVE, True), (RELAX, False), (SOLVE, True)):
        direct.factor(kernel_plan(p), bodies.com, bodies.angle, bodies.inv_mass,
                      bodies.inv_inertia, ref, soft, phase)
        assert p.ok.tolist() == [ok]
        assert (p.mask == (direct.equality_mask(0, False, 0.0, 0.0) if ok else 0)).all()


def test_the_plan_reference_holds_every_field_in_order():
    """``kernel_plan`` lists DirectPlan's fields by hand (a compiled constructor, cached):
    it must follow DirectPlan field for field."""
    import inspect

    assert tuple(inspect.signature(direct._direct_plan_ref.py_func).parameters) == \
        direct.DirectPlan._fields


def test_packed_rows_hold_every_field_and_the_impulses_go_back():
    """``pack`` puts every field the kernels read in its column (kinds, bodies, flags,
    geometry, limits, motors: JointRows' values, bit for bit), and ``unpack_impulses``
    writes each packed impulse column back to the JointRows field it came from."""
    from sdfphys.solver import joints

    world = chain_world(links=3)
    rng = np.random.default_rng(2)
    rows = world._joints.rows          # every float and flag distinct (a swapped column shows)
    rows = rows._replace(**{name: (rng.normal(size=value.shape) if value.dtype == float
                                   else rng.random(value.shape) < 0.5)
                            for name, value in rows._asdict().items()
                            if value.dtype in (float, bool)})
    packed = pack(rows)
    columns = [(joints._INT_FIELDS, packed.ints), (joints._REAL_FIELDS, packed.reals),
               (joints._IMPULSE_FIELDS, packed.impulses)]
    names = set()
    for fields, array in columns:
        assert array.shape == (len(rows.kind), len(fields))
        for c, field in enumerate(fields):
            name, column = field if isinstance(field, tuple) else (field, None)
            names.add(name)
            value = getattr(rows, name)
            np.testing.assert_array_equal(array[:, c], value if column is None
                                          else value[:, column])
    solved = set(joints.JointRows._fields) - {"collide_connected", "spring_hertz",
                                                "spring_damping"}
    assert names == solved        # the others are read in Python (spring_softness, pairs)
    # The column constants the kernels index by name the same fields.
    named = {"KIND": ("ints", "kind", None), "BODY_A": ("ints", "body_a", None),
             "BODY_B": ("ints", "body_b", None), "HAS_LIMIT": ("ints", "has_limit", None),
             "HAS_MOTOR": ("ints", "has_motor", None),
             "HAS_SPRING": ("ints", "has_spring", None),
             "LOCAL_AX": ("reals", "local_a", 0), "LOCAL_AY": ("reals", "local_a", 1),
             "LOCAL_BX": ("reals", "local_b", 0), "LOCAL_BY": ("reals", "local_b", 1),
             "AXIS_X": ("reals", "local_axis", 0), "AXIS_Y": ("reals", "local_axis", 1),
             "REFERENCE_ANGLE": ("reals", "reference_angle", None),
             "LENGTH": ("reals", "length", None), "MIN_LENGTH": ("reals", "min_length", None),
             "MAX_LENGTH": ("reals", "max_length", None), "LOWER": ("reals", "lower", None),
             "UPPER": ("reals", "upper", None), "MOTOR_SPEED": ("reals", "motor_speed", None),
             "MAX_MOTOR": ("reals", "max_motor", None),
             "MAX_TORQUE": ("reals", "max_torque", None),
             "MAX_FORCE": ("reals", "max_force", None),
             "LINEAR_X": ("impulses", "linear_impulse", 0),
             "LINEAR_Y": ("impulses", "linear_impulse", 1),
             "ANGULAR_IMPULSE": ("impulses", "angular_impulse", None),
             "PERP_IMPULSE": ("impulses", "perp_impulse", None),
             "AXIAL_IMPULSE": ("impulses", "axial_impulse", None),
             "SPRING_IMPULSE": ("impulses", "spring_impulse", None),
             "MOTOR_IMPULSE": ("impulses", "motor_impulse", None),
             "LOWER_IMPULSE": ("impulses", "lower_impulse", None),
             "UPPER_IMPULSE": ("impulses", "upper_impulse", None)}
    for constant, (array, name, column) in named.items():
        value = getattr(rows, name)
        np.testing.assert_array_equal(getattr(packed, array)[:, getattr(joints, constant)],
                                      value if column is None else value[:, column])
    assert len(named) == joints.INTS + joints.REALS + joints.IMPULSES
    packed.impulses[:] = rng.normal(size=packed.impulses.shape)
    joints.unpack_impulses(packed, rows)
    assert rows.linear_impulse[:, 1].tolist() == packed.impulses[:, joints.LINEAR_Y].tolist()
    assert rows.upper_impulse.tolist() == packed.impulses[:, joints.UPPER_IMPULSE].tolist()
    assert pack(rows).impulses.tolist() == packed.impulses.tolist()


def test_the_substep_joints_hold_their_fields_in_order_and_share_the_arrays():
    """``substep_joints``' compiled maker lists the fields by hand (the report's three
    arrays last, made into its Output), and the bundle shares the bodies' arrays: a pass
    run through it moves the caller's velocities and writes its progress."""
    import inspect

    from sdfphys.solver import joints

    parameters = tuple(inspect.signature(direct._substep_joints.py_func).parameters)
    assert parameters == direct.JOINT_FIELDS[:-1] + joints.Output._fields
    world = chain_world(links=3)
    bodies, rows = body_state(world), world._joints.rows
    soft, stiffening = stiffened_softness(bodies.inv_mass, bodies.inv_inertia, rows,
                                          world.settings, world._gravity, 4.0)
    ref = pack(rows)
    progress = np.zeros(2)
    bundle = direct._substep_joints(
        bodies.com, bodies.angle, bodies.velocity, bodies.angular_velocity, bodies.inv_mass,
        bodies.inv_inertia, ref, soft, joints.spring_softness(rows, 1.0 / 240.0), stiffening,
        kernel_plan(direct.plan(ref, bodies.inv_mass, bodies.inv_inertia)), np.empty((0, 2)),
        np.empty(0), progress)
    bodies.velocity[:] = [[0.0, 5.0], [1.0, -2.0], [0.0, 0.0]]
    before = bodies.velocity.copy()
    direct.joint_passes(bundle, joints.WARM, 240.0, 1, False)
    assert direct.joint_passes(bundle, SOLVE, 240.0, 50, False) >= 1
    assert not np.array_equal(bodies.velocity, before)
    assert progress[1] > 0.0


#: One joint of each kind and option on its own pair of boxes, and whether the direct
#: solve takes all its rows (``joints._all_direct``: SOLVE and RELAX passes skip it).
#: Limits start at their lower end, where random velocities engage them.
_ALONE = [
    ({"type": "revolute"}, True),
    ({"type": "revolute", "motor": {"speed": 2.0, "max_torque": 50.0}}, False),
    ({"type": "revolute", "limits": [0.0, 0.5]}, False),
    ({"type": "weld"}, True),
    ({"type": "weld", "spring": {"hertz": 4.0, "damping_ratio": 0.5}}, False),
    ({"type": "prismatic", "axis": [1.0, 0.0]}, True),
    ({"type": "prismatic", "axis": [1.0, 0.0], "limits": [0.0, 0.2]}, False),
    ({"type": "wheel", "axis": [0.0, 1.0]}, True),
    ({"type": "wheel", "axis": [0.0, 1.0], "spring": {"hertz": 4.0, "damping_ratio": 0.7}},
     False),
    ({"type": "distance", "anchors": [[0.0, 0.0], [1.0, 0.0]]}, True),
    ({"type": "distance", "anchors": [[0.0, 0.0], [1.0, 0.0]], "min_length": 1.0,
      "max_length": 1.5}, False),
]


@pytest.mark.parametrize("spec, all_direct", _ALONE)
def test_a_joint_all_of_whose_rows_are_direct_is_skipped_and_left_unchanged(spec, all_direct):
    """``_all_direct`` is true exactly for the joints with no row left to Gauss-Seidel, and
    for those ``_joint`` leaves any velocities and the progress as they were (so skipping
    them changes no number)."""
    from sdfphys.solver import joints

    spec = {**spec, "bodies": ["a", "b"]}
    if spec["type"] != "distance":
        spec.setdefault("anchor", [0.5, 0.0])
    world = sdfphys.load_scene({"version": 1, "world": {"gravity": [0.0, 0.0]}, "body": [
        {"name": "a", "shape": {"type": "box", "size": [0.4, 0.4]}, "position": [0.0, 0.0]},
        {"name": "b", "shape": {"type": "box", "size": [0.4, 0.4]}, "position": [1.0, 0.0]}],
        "joint": [spec]})
    bodies, rows = body_state(world), world._joints.rows
    ref = pack(rows)
    mask = direct.plan(ref, bodies.inv_mass, bodies.inv_inertia).mask
    assert joints._all_direct(ref.ints, 0, mask[0]) == all_direct
    soft, _ = stiffened_softness(bodies.inv_mass, bodies.inv_inertia, rows, world.settings,
                                 world._gravity, 4.0)
    spring = joints.spring_softness(rows, world.settings.dt / world.settings.substeps)
    rng = np.random.default_rng(5)
    changed = False
    for phase in (SOLVE, RELAX):
        for _ in range(5):
            v = tuple(rng.normal(scale=3.0, size=6))
            g = joints.joint_geometry(*bodies.com[0], bodies.angle[0], *bodies.com[1],
                                      bodies.angle[1], ref.reals, 0)
            out = Output(np.zeros((0, 2)), np.zeros(0), np.zeros(2))
            masses = (bodies.inv_mass[0], bodies.inv_inertia[0], bodies.inv_mass[1],
                      bodies.inv_inertia[1])
            after = joints._joint(v, masses, g, ref, 0, phase, soft, spring, 240.0, out,
                                  mask[0])
            changed |= tuple(after) != v or out.progress.any()
    assert changed != all_direct
