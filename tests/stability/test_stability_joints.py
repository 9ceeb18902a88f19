"""Stability at the extremes, joints: the bound of ``stability_joints`` on the heavy chain
and the 100:1 ragdoll (figures beside pymunk's and Box2D's in tools/stability_report.py)."""

import pytest
import stability_joints as cases

pytestmark = pytest.mark.slow


def test_heavy_chain_keeps_every_joint_gap_under_1_cm():
    """20 links of 1 kg holding 100 kg, released horizontal: 6.2 mm once swung down,
    0.6 mm hanging at rest (Box2D v3: 70 mm and 16 mm; pymunk 2.2 m and 1.7 m)."""
    figures = cases.ours_heavy_chain()
    assert figures["gap"] <= cases.JOINT_GAP.limit
    assert figures["hanging"] <= cases.JOINT_GAP.limit


@pytest.mark.xfail(strict=True, reason="measured 51 mm (Box2D v3 94 mm, pymunk 277 mm): "
                   "1 kg limbs between a 100 kg torso and the ground; the joints are solved "
                   "exactly per island, but the contacts by Gauss-Seidel passes alternating "
                   "with them, which do not converge at 100:1 within the passes")
def test_ragdoll_100_to_1_keeps_every_joint_gap_under_1_cm():
    assert cases.ours_ragdoll()["gap"] <= cases.JOINT_GAP.limit
