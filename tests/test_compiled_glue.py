"""The compiled narrowphase glue gives the numpy reference's contacts, bit for bit.

``mesh_contacts.mesh_in_field`` and ``mesh_sdf.sdf_in_mesh`` run their stages in
compiled kernels when the fields compile and in numpy otherwise (the reference: the
same shapes with their fields hidden from the compiler, ``oracles.opaque_shape``), as
does the tail of
``field_pairs.field_field_contacts`` (``_compiled_field_contacts.field_contacts``) and the
compiled glue of ``field_pairs.placed_field_contacts`` (``_placed_fields``). The bench
scene's pair kinds (boxes on boxes, walls and a half-plane ground, a ring and a
smooth union) and concave meshes, at random poses and margins, must give the same
rows (pair, point, normal, depth, keys) in the same order, with the same bits.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles import Opaque, opaque_shape

from sdfphys.collide import mesh_contacts, mesh_sdf
from sdfphys.settings import Settings
from sdfphys.shapes import shape_from_spec

MESHES = [
    {"type": "box", "size": [0.5, 0.4]},
    {"type": "polygon", "points": [[0, 0], [1, 0], [1, 0.3], [0.3, 0.3], [0.3, 1], [0, 1]]},
    {"type": "polygon", "points": [[0, 0], [1, 0.2], [0.6, 0.8], [0.1, 0.6]]},
]
SDFS = [
    {"type": "sdf", "field": {"op": "smooth_union", "k": 0.1, "of": [
        {"type": "circle", "radius": 0.22, "offset": [-0.18, 0.0]},
        {"type": "box", "size": [0.4, 0.3], "offset": [0.18, 0.0]}]}},
    {"type": "sdf", "field": {"op": "onion", "thickness": 0.08,
                              "of": {"type": "circle", "radius": 0.3}}},
    {"type": "sdf", "field": {"type": "half_plane", "normal": [0.0, 1.0], "distance": 0.0}},
]


def _both(fn, mesh, other, *args):
    """fn with other's field hidden from the compiler (the numpy stages), then as is."""
    return fn(mesh, opaque_shape(other), *args), fn(mesh, other, *args)


def _same(reference, got) -> bool:
    return all(a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
               for a, b in zip(reference, got))


@pytest.mark.parametrize("other_kind", ["mesh", "sdf"])
def test_mesh_in_field_compiled_equals_numpy(other_kind):
    rng = np.random.default_rng(2024 if other_kind == "mesh" else 2025)
    meshes = [shape_from_spec(s) for s in MESHES]
    others = meshes if other_kind == "mesh" else [shape_from_spec(s) for s in SDFS]
    contacts = 0
    for _ in range(120):
        mesh, other = meshes[rng.integers(len(meshes))], others[rng.integers(len(others))]
        n = int(rng.integers(1, 10))
        pose_mesh = np.column_stack([rng.uniform(-0.6, 0.6, (n, 2)), rng.uniform(-4, 4, n)])
        pose_other = np.column_stack([rng.uniform(-0.2, 0.2, (n, 2)), rng.uniform(-4, 4, n)])
        if rng.random() < 0.3:                     # resting: right angles, exact contacts
            pose_mesh[:, 2] = np.round(pose_mesh[:, 2] / (np.pi / 2)) * (np.pi / 2)
            pose_other[:, 2] = 0.0
        margin = float(rng.choice([0.0, 0.01, 0.05]))
        settings = Settings(descent_starts=int(rng.choice([4, 7])))
        reference, got = _both(mesh_contacts.mesh_in_field, mesh, other, pose_mesh,
                               pose_other, margin, settings, other_kind == "mesh")
        assert _same(reference, got)
        contacts += len(reference[0])
    assert contacts > 500


def test_sdf_in_mesh_compiled_equals_numpy():
    rng = np.random.default_rng(2026)
    meshes = [shape_from_spec(s) for s in MESHES[:2] + [{"type": "box", "size": [0.5, 9.0]}]]
    sdfs = [shape_from_spec(s) for s in SDFS[:2] + [{"type": "sdf", "field": {
        "type": "box", "size": [0.6, 0.3]}}, {"type": "sdf", "field": {
            "type": "rounded_box", "size": [0.7, 0.4], "radii": 0.1}}]]
    contacts = far_ends = 0
    for _ in range(120):
        mesh, sdf = meshes[rng.integers(len(meshes))], sdfs[rng.integers(len(sdfs))]
        n = int(rng.integers(1, 10))
        pose_mesh = np.column_stack([rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(-4, 4, n)])
        pose_sdf = np.column_stack([rng.uniform(-0.2, 0.2, (n, 2)), rng.uniform(-4, 4, n)])
        if rng.random() < 0.3:
            pose_mesh[:, 2] = np.round(pose_mesh[:, 2] / (np.pi / 2)) * (np.pi / 2)
            pose_mesh[:, 2] += rng.uniform(-0.05, 0.05, n)          # slightly tilted
            pose_sdf[:, 2] = 0.0
        margin = float(rng.choice([0.0, 0.01, 0.05]))
        reference, got = _both(mesh_sdf.sdf_in_mesh, mesh, sdf, pose_mesh, pose_sdf, margin,
                               Settings())
        assert _same(reference, got)
        contacts += len(reference[0])
        far_ends += int(np.sum(reference[5] >= mesh_sdf.FAR_END))
    assert contacts > 500 and far_ends > 20


def test_field_field_contacts_compiled_tail_equals_numpy():
    """The merge, patch ends and second merge after the descent (``_compiled_descent.
    field_contacts``) against the numpy tail (fields hidden from the compiler, which
    also runs the Python-driven descent: the same bits on these fields)."""
    from sdfphys.collide import field_pairs
    from sdfphys.sdf import field

    rng = np.random.default_rng(2027)
    fields = [field(s["field"]) for s in SDFS[:2]] + [field(s) for s in [
        {"type": "box", "size": [0.5, 0.4]}, {"type": "circle", "radius": 0.3},
        {"type": "polygon", "points": MESHES[1]["points"]}]]
    contacts = patch_ends = 0
    for _ in range(100):
        field_a, field_b = fields[rng.integers(len(fields))], fields[rng.integers(len(fields))]
        n = int(rng.integers(1, 8))
        poses = np.column_stack([rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(-4, 4, n)])
        if rng.random() < 0.4:                     # resting on faces: flat patches
            poses[:, 2] = np.round(poses[:, 2] / (np.pi / 2)) * (np.pi / 2)
            poses[:, 2] += rng.choice([0.0, 0.01], n)
            poses[:, 0], poses[:, 1] = 0.0, rng.choice([0.35, 0.4, 0.45], n)
        regions = np.column_stack([rng.uniform(-0.8, -0.2, (n, 2)),
                                   rng.uniform(0.2, 0.8, (n, 2))])
        margin = float(rng.choice([0.0, 0.01, 0.05]))
        args = (poses, regions, 16, 16, margin)
        got = field_pairs.field_field_contacts(field_a, field_b, *args)
        reference = field_pairs.field_field_contacts(Opaque(field_a), Opaque(field_b), *args)
        assert _same(reference, got)
        contacts += len(reference[0])
        patch_ends += int(np.sum(reference[4] >= 16))
    assert contacts > 500 and patch_ends > 100


def test_mesh_in_field_kink_on_a_face_compiled_equals_numpy():
    """Two crossing corners (scenes/concave_polygons.toml, poly7 and poly12 at t = 2.30
    s): a descent minimum on the L's medial axis takes the face the arrow's edge runs
    along (``mesh_contacts._face_normals``), and the L's corner is measured below the
    arrow's side, 1.8 cm: both paths give the same rows, bit for bit."""
    arrow = shape_from_spec({"type": "polygon", "points": [
        [-0.65, 0.25], [0.15, 0.25], [0.15, 0.5], [0.65, 0.0], [0.15, -0.5], [0.15, -0.25],
        [-0.65, -0.25]]})
    piece = shape_from_spec({"type": "polygon", "points": [
        [-0.6, -0.6], [0.6, -0.6], [0.6, -0.2], [-0.2, -0.2], [-0.2, 0.6], [-0.6, 0.6]]})
    pose_arrow = np.array([[-0.44188065759161116, 1.4314755117100781, 2.569280654727023]])
    pose_l = np.array([[-0.3104870539715962, 2.082024956753468, 3.5972444198103384]])
    deepest = 0.0
    for mesh, other, pose_mesh, pose_other in [(arrow, piece, pose_arrow, pose_l),
                                               (piece, arrow, pose_l, pose_arrow)]:
        reference, got = _both(mesh_contacts.mesh_in_field, mesh, other, pose_mesh, pose_other,
                               0.01, Settings(), True)
        assert _same(reference, got)
        deepest = max(deepest, float(np.max(reference[3], initial=0.0)))
    assert deepest > 0.0179



def test_mesh_in_field_vertex_across_a_plank_compiled_equals_numpy():
    """A clamp's spike 0.02 into a plank, its other spike's tip across the plank within
    the margin (tests/test_narrowphase.py, PLANK and CLAMP): that tip does not cut the
    plank's top face (``mesh_contacts._reference_faces``), in both paths, bit for bit,
    and the spike's 0.02 row is there."""
    plank = shape_from_spec({"type": "box", "size": [2.0, 0.1]})
    clamp = shape_from_spec({"type": "polygon", "points": [
        [-0.2, 0.15], [-0.1, 0.15], [0.0, 0.03], [0.1, 0.15], [1.1, 0.15], [1.1, -0.15],
        [0.4, -0.15], [0.3, -0.06], [0.2, -0.15], [0.2, -0.35], [1.3, -0.35], [1.3, 0.35],
        [-0.2, 0.35]]})
    pose_plank = np.array([[0.0, 0.0, 0.0]])
    pose_clamp = np.array([[*-clamp.origin, 0.0]])      # the clamp's points where given
    for margin in (0.02, 0.05):
        reference, got = _both(mesh_contacts.mesh_in_field, clamp, plank, pose_clamp,
                               pose_plank, margin, Settings(), True)
        assert _same(reference, got)
        assert np.isclose(np.max(reference[3]), 0.02, atol=1e-9)

def test_placed_field_contacts_compiled_glue_equals_the_numpy_glue():
    """``field_pairs.placed_field_contacts`` through its compiled glue (``_placed_fields``)
    gives the contacts of the numpy glue (``field_field_contacts`` over the same
    regions), bit for bit: sdf-sdf placements (a bounded or a half-plane), mesh fields
    placed in sdfs, pairs whose regions are empty among them."""
    from sdfphys.collide import field_pairs

    rng = np.random.default_rng(2026)
    sdfs = [shape_from_spec(s) for s in SDFS]
    meshes = [shape_from_spec(s) for s in MESHES]
    contacts = empty = 0
    for _ in range(80):
        a = sdfs[rng.integers(len(sdfs))]
        b = (meshes + sdfs[:2])[rng.integers(len(meshes) + 2)]
        n = int(rng.integers(1, 8))
        offset = rng.uniform(-0.9, 0.9, (n, 2))
        angle = rng.uniform(-4.0, 4.0, n)
        margin = float(rng.choice([0.0, 0.02]))
        args = (offset, angle, a.bounds(), b.bounds(), margin, 7, 24)
        reference = field_pairs.placed_field_contacts(Opaque(a.field), Opaque(b.field), *args)
        got = field_pairs.placed_field_contacts(a.field, b.field, *args)
        assert _same(reference, got)
        contacts += len(got[1])
        empty += int(np.sum(np.any(got[0][:, 2:] < got[0][:, :2], axis=1)))
    assert contacts > 150 and empty > 5


def test_one_sided_depths_and_tangent_samples_compiled_equal_numpy():
    """``field_pairs.one_sided_depths`` and ``tangent_samples`` through their compiled
    kernels (``_compiled_samples``) give the numpy glue's rows, bit for bit, on the
    contacts of random placements: contacts re-measured at a feature and left as they
    were, samples kept and dropped, pairs in and out of order."""
    from sdfphys.collide import field_pairs

    rng = np.random.default_rng(11)
    sdfs = [shape_from_spec(s) for s in SDFS]
    meshes = [shape_from_spec(s) for s in MESHES]
    changed = samples = 0
    for _ in range(120):
        a = sdfs[rng.integers(len(sdfs))]
        b = (meshes + sdfs[:2])[rng.integers(len(meshes) + 2)]
        n = int(rng.integers(1, 6))
        offset = rng.uniform(-0.6, 0.6, (n, 2))
        angle = rng.uniform(-4.0, 4.0, n)
        margin = float(rng.choice([0.02, 0.1]))
        _, pair, point, depth, normal, start = field_pairs.placed_field_contacts(
            a.field, b.field, offset, angle, a.bounds(), b.bounds(), margin, 7, 24)
        fields = (Opaque(a.field), Opaque(b.field)), (a.field, b.field)
        one = [field_pairs.one_sided_depths(*f, offset, angle, pair, point, depth, normal)
               for f in fields]
        assert _same(*one)
        changed += int(np.sum(one[1][1] != depth))
        per_side = int(rng.integers(1, 4))
        extent = float(rng.uniform(0.05, 0.4))
        tangent = [field_pairs.tangent_samples(*f, offset, angle, pair, *one[1], start,
                                               margin, extent, per_side) for f in fields]
        assert _same(*tangent)
        samples += len(tangent[1][0]) - len(pair)
    assert changed > 5 and samples > 50


def test_overlap_regions_are_the_rotated_corners_extremes():
    """``_placed_fields.overlap_regions``: b's box rotated and moved, its four corners'
    extremes computed one by one (the same rounded operations, so the same bits),
    clipped to a's bounds (finite or a half-plane's) and grown by the margin."""
    from sdfphys.collide._placed_fields import overlap_regions

    rng = np.random.default_rng(7)
    for bounds_a in ([-1.0, -0.5, 2.0, 1.5], [-np.inf, -np.inf, np.inf, 0.0]):
        bounds_a = np.array(bounds_a)
        bounds_b = np.array([-0.4, -0.2, 0.6, 0.3])
        offset = rng.uniform(-2.0, 2.0, (50, 2))
        angle = rng.uniform(-4.0, 4.0, 50)
        cos, sin = np.cos(angle), np.sin(angle)
        got = overlap_regions(np.tile(bounds_a, (50, 1)), np.tile(bounds_b, (50, 1)), offset,
                              cos, sin, np.full(50, 0.01))
        for k in range(50):
            xs = [(cos[k] * x - sin[k] * y) + offset[k, 0]
                  for x in bounds_b[[0, 2]] for y in bounds_b[[1, 3]]]
            ys = [(sin[k] * x + cos[k] * y) + offset[k, 1]
                  for x in bounds_b[[0, 2]] for y in bounds_b[[1, 3]]]
            expected = [max(min(xs), bounds_a[0]) - 0.01, max(min(ys), bounds_a[1]) - 0.01,
                        min(max(xs), bounds_a[2]) + 0.01, min(max(ys), bounds_a[3]) + 0.01]
            assert got[k].tolist() == expected
        assert np.any(got[:, 2] < got[:, 0]) or np.any(got[:, 3] < got[:, 1])
