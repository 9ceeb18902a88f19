"""Numerical stability at the extremes: every case's figure, its bound, and pymunk beside it.

Prints ONE markdown table on stdout: the case, what is measured, sdfphys's figure, the
bound, pass/fail, and the same case in pymunk at its defaults (10 iterations,
collision_slop 0.1, default collision_bias) with whether pymunk meets the same bound,
and for the joint cases Box2D v3 (pyb2d3) at its defaults.
The scenes, figures and bounds are those of ``tests/stability/stability_*.py`` (the slow
test suite asserts the same bounds on sdfphys). A sdfphys run that crashes or produces
a non-finite state is reported as such and fails. Progress, run times and the count of
failures go to stderr.

Usage: python tools/stability_report.py (about a minute on a 2-core machine once the
numba cache is filled; the base-40 pyramid is the longest case, 20 s).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "stability"))

import stability_energy as energy
import stability_input as bad_input
import stability_joints as joints
import stability_speed as speed
import stability_stacking as stacking
from stability_common import Bound, NonFiniteState

Figures = Callable[[], dict[str, float]]


@dataclass(frozen=True)
class Row:
    """One line of the table: ``ours``/``theirs`` (pymunk)/``box2d`` return a case's
    figures, ``key`` picks one."""

    case: str
    figure: str
    key: str
    bound: Bound
    ours: Figures
    theirs: Figures | None
    box2d: Figures | None = None


def rows() -> list[Row]:
    """Every case of the study in the table's order."""
    out = [Row(f"mass ratio {r}:1, 1 kg unit box under a {r} kg one", "heavy box sink, max "
               "over 5 s", "sink", stacking.NOT_CRUSHED, lambda r=r: stacking.ours_mass_ratio(r),
               lambda r=r: stacking.pymunk_mass_ratio(r)) for r in (10, 100, 1000)]
    out.append(Row("4 x 1 box, 400 kg, dropped 0.5 m on two 1 kg unit boxes", "big box sink, "
                   "max over 5 s", "sink", stacking.NOT_CRUSHED, stacking.ours_big_box_drop,
                   stacking.pymunk_big_box_drop))
    out += [Row(f"base-5 pyramid of 1 kg unit boxes, top box {r} kg, 10 s", "top box "
                "displacement", "top", stacking.STANDS,
                lambda r=r: stacking.ours_heavy_top_pyramid(r),
                lambda r=r: stacking.pymunk_heavy_top_pyramid(r)) for r in (100, 300)]
    out.append(Row("20-box stack, 30 s", "top box displacement", "top", stacking.STANDS,
                   stacking.ours_tall_stack, stacking.pymunk_tall_stack))
    for base in (20, 40):
        case = f"pyramid of base {base} ({base * (base + 1) // 2} boxes), 5 s"
        out += [Row(case, "top box displacement", "top", stacking.STANDS,
                    lambda b=base: stacking.ours_pyramid(b),
                    lambda b=base: stacking.pymunk_pyramid(b)),
                Row(case, "deepest contact", "penetration", stacking.NOT_SUNK,
                    lambda b=base: stacking.ours_pyramid(b),
                    lambda b=base: stacking.pymunk_pyramid(b))]
    wide = stacking.SYMMETRY_BASE
    case = (f"pyramid of base {wide} ({wide * (wide + 1) // 2} boxes), "
            f"{stacking.SYMMETRY_SECONDS:g} s")
    out += [Row(case, "mean horizontal displacement", "lean", stacking.SYMMETRIC,
                stacking.ours_pyramid_symmetry, stacking.pymunk_pyramid_symmetry,
                stacking.box2d_pyramid_symmetry),
            Row(case, "fastest box at the end", "speed", stacking.SETTLED,
                stacking.ours_pyramid_symmetry, stacking.pymunk_pyramid_symmetry,
                stacking.box2d_pyramid_symmetry)]
    out += [Row(f"base-5 pyramid of {side:g} m boxes, 10 s", "largest displacement / side",
                "relative", stacking.STANDS_RELATIVE,
                lambda s=side: stacking.ours_scaled_pyramid(s),
                lambda s=side: stacking.pymunk_scaled_pyramid(s)) for side in (0.05, 20.0)]
    out.append(Row("base-5 pyramid at (1e5, 1e5) m vs at the origin, 10 s", "largest "
                   "relative position difference", "difference", stacking.SAME_FAR_AWAY,
                   stacking.ours_far_pyramid, stacking.pymunk_far_pyramid))
    out.append(Row("the issue's: circle r 0.1 at 200 m/s into a 1 cm segment, 200 phases",
                   "fraction tunnelled", "tunnelled", speed.NO_TUNNELLING,
                   lambda: speed.ours_thin_wall(*speed.ISSUE_BULLETS),
                   lambda: speed.pymunk_thin_wall(*speed.ISSUE_BULLETS)))
    out += [Row(f"300 m/s {bullet}{' spinning 100 rad/s' if 'plank' in bullet else ''} into "
                "2 cm box and 1 cm segment walls at 0 and 45 deg, 100 phases each",
                "fraction tunnelled", "tunnelled", speed.NO_TUNNELLING,
                lambda b=bullet: speed.ours_thin_wall(bullets=(b,)),
                lambda b=bullet: speed.pymunk_thin_wall(bullets=(b,))) for bullet in speed.BULLETS]
    out.append(Row("300 m/s circles r 0.05 into 5-box stacks, 20 phases", "fraction tunnelled",
                   "tunnelled", speed.NO_TUNNELLING, speed.ours_stack_bullets,
                   speed.pymunk_stack_bullets))
    out.append(Row("the same with time_of_impact off (pymunk has none)", "fastest body's "
                   "speed over the bullets'", "gained", speed.NO_SPEED_GAINED,
                   lambda: speed.ours_stack_bullets(time_of_impact=False),
                   speed.pymunk_stack_bullets))
    out.append(Row("1 x 0.02 planks falling at 100 m/s spinning 20 rad/s, 50 phases",
                   "lowest corner height over 2 s", "lowest", speed.ABOVE_GROUND,
                   speed.ours_spinning_plank, speed.pymunk_spinning_plank))
    out += [Row(f"dt = {dt:g} s: box stack, dropped box and balls, {seconds:g} s",
                "max energy gain / E0", "gain", energy.ENERGY_MARGIN,
                lambda d=dt, s=seconds: energy.ours_time_step(d, s),
                lambda d=dt, s=seconds: energy.pymunk_time_step(d, s))
            for dt, seconds in ((1e-4, 0.5), (0.1, 10.0))]
    for case, ours, theirs in (
            ("unit boxes overlapping by 25 %, 5 s", energy.ours_overlapping_boxes,
             energy.pymunk_overlapping_boxes),
            ("625 circles r 0.5 packed 0.2 m deep in a 20 m box, 5 s",
             energy.ours_packed_circles, energy.pymunk_packed_circles)):
        out += [Row(case, "max separation speed", "separation", energy.PUSH_OUT, ours, theirs),
                Row(case, "max body speed (ejection)", "speed", energy.PUSH_OUT, ours, theirs),
                Row(case, "kinetic energy, last second / peak", "decay", energy.DECAYS, ours,
                    theirs)]
    case = "e = 1 balls dropped from 1 ... 5.5 m, 10,000 steps"
    out += [Row(case, "max height above the drop", "above", energy.NO_HIGHER,
                energy.ours_elastic_balls, energy.pymunk_elastic_balls),
            Row(case, "max energy gain / E0", "gain", energy.NO_GAIN, energy.ours_elastic_balls,
                energy.pymunk_elastic_balls)]
    out.append(Row("5-box stack and base-5 pyramid, 2 ... 10 s", "fastest box point", "speed",
                   stacking.AT_REST, stacking.ours_resting_stacks,
                   stacking.pymunk_resting_stacks))
    chain = "20-link chain of 1 kg links (0.5 x 0.1 m) holding 100 kg"
    out += [Row(f"{chain}, released horizontal, 1 ... 10 s", "largest joint gap", "gap",
                joints.JOINT_GAP, joints.ours_heavy_chain, joints.pymunk_heavy_chain,
                joints.box2d_heavy_chain),
            Row(f"{chain}, hanging, after 3 s", "largest joint gap", "hanging",
                joints.JOINT_GAP, joints.ours_heavy_chain, joints.pymunk_heavy_chain,
                joints.box2d_heavy_chain),
            Row("ragdoll (scenes/ragdoll.toml) with a 100 kg torso and 1 kg limbs, dropped "
                "tumbling, 5 s", "largest joint gap", "gap", joints.JOINT_GAP,
                joints.ours_ragdoll, joints.pymunk_ragdoll, joints.box2d_ragdoll)]
    out.append(Row(f"{len(bad_input.DEGENERATE)} degenerate or non-finite scene values",
                   "not rejected with a SpecError naming the key", "accepted",
                   bad_input.ALL_REJECTED, bad_input.ours_degenerate, None))
    return out


def measure(run: Figures, key: str) -> tuple[float | None, str]:
    """(figure or None, text): the figure ``key`` of ``run()``, or why there is none."""
    try:
        value = run()[key]
    except NonFiniteState as err:
        return None, f"non-finite state ({err})"
    except Exception as err:  # noqa: BLE001 - a crash is a result of the study
        return None, f"crash: {type(err).__name__}"
    return value, f"{value:.3g}"


def main() -> None:
    """Measure every row and print the table."""
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    lines = ["| case | figure | sdfphys | bound | pass | pymunk (same bound) | Box2D v3 |",
             "|---|---|---|---|---|---|---|"]
    failed = 0
    for row in rows():
        t0 = time.perf_counter()
        ours, ours_text = measure(row.ours, row.key)
        t1 = time.perf_counter()
        ok = ours is not None and row.bound.holds(ours)
        failed += not ok
        theirs_text = "n/a"
        if row.theirs is not None:
            theirs, theirs_text = measure(row.theirs, row.key)
            if theirs is not None:
                theirs_text += " (pass)" if row.bound.holds(theirs) else " (fail)"
        box2d_text = "n/a"
        if row.box2d is not None:
            box2d, box2d_text = measure(row.box2d, row.key)
            if box2d is not None:
                box2d_text += " (pass)" if row.bound.holds(box2d) else " (fail)"
        print(f"{row.case}: {row.figure}: sdfphys {ours_text} ({t1 - t0:.1f} s), pymunk "
              f"{theirs_text}, Box2D {box2d_text} ({time.perf_counter() - t1:.1f} s)",
              file=sys.stderr, flush=True)
        lines.append(f"| {row.case} | {row.figure} | {ours_text} | {row.bound} | "
                     f"{'pass' if ok else 'FAIL'} | {theirs_text} | {box2d_text} |")
    print("\n".join(lines))
    print(f"{failed} of {len(lines) - 2} sdfphys figures outside their bounds", file=sys.stderr)


if __name__ == "__main__":
    main()
