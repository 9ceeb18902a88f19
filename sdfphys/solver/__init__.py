"""The soft-step contact solver: Box2D v3's design (docs/solver.md), one numba sweep per phase.

One step, as ``World.step`` runs it:

1. collide once (``sdfphys.collide.find_contacts``);
2. ``prepare_contacts``: anchors, base separations, effective masses, the approach speed
   for restitution and last step's impulses matched by feature key (warm start);
3. ``solve_substeps``: for each substep h = dt / substeps, integrate velocities, warm
   start, solve with soft bias, integrate positions, relax without bias; islands where
   heavy loads rest on light bodies get load-stiffened rows and more passes, until
   converged (``row_softness``); overlap deeper than ``Settings.soft_depth`` is pushed
   out through pseudo-velocities that never enter the velocities (``substeps``, "Split
   push-out");
4. ``apply_restitution``: velocity passes that target vn' = -e vn;
5. ``store_impulses``: the impulses, keyed for the next step's warm start.

References: E. Catto, Box2D v3 (``contact_solver.c``, ``solver.c``: ``b2MakeSoft``,
prepare / warm start / solve / relax / restitution / store), the "Solver2D" post
(soft step versus PGS and TGS) and "SIMD Matters" (substepping with relax);
E. Catto, "Soft Constraints", GDC 2011.

Conventions: SI units; a contact's normal n is a unit vector from body a to body b;
separation s < 0 when overlapping; the tangent is t = (n_y, -n_x) (n turned clockwise);
an impulse lambda along n pushes b by +lambda n and a by -lambda n. Accumulated
impulses are per substep (N s): the warm start applies them once per substep.

The sweeps are sequential Gauss-Seidel loops over the contacts in their given order
(sorted by (body_a, body_b, feature): deterministic; an island over rest_island_limit
is swept in reverse in two substeps of every four, ``substeps``' "Sweep order"),
compiled with numba (``cache=True``); docs/solver.md measures why this beats coloured
numpy batches. Static and kinematic bodies take part through their zero inverse mass
and inertia: impulses leave them as they are.

Modules: ``softness`` (soft constraint coefficients, loaded islands: ``row_softness``),
``rows`` (the body state and the prepared contact rows: ``prepare_contacts``,
``store_impulses``), ``warm_start`` (``ImpulseCache``: last step's impulses matched by
feature key or place), ``substeps`` (integration, warm start, the solve and relax
sweeps, the split push-out: ``solve_substeps``), ``restitution``
(``apply_restitution``), ``pair_rows`` (a pair's velocities and one row's algebra,
shared by those sweeps).
"""

from .restitution import apply_restitution
from .rows import BodyState, ContactConstraints, prepare_contacts, store_impulses
from .softness import (
    CONVERGED,
    LOADED,
    MASS_RATIO,
    REST_SPEED,
    Softness,
    contact_softness,
    row_softness,
    soft_coefficients,
)
from .substeps import MAX_ROTATION, solve_substeps
from .warm_start import ImpulseCache

__all__ = [
    "CONVERGED",
    "LOADED",
    "MASS_RATIO",
    "MAX_ROTATION",
    "REST_SPEED",
    "BodyState",
    "ContactConstraints",
    "ImpulseCache",
    "Softness",
    "apply_restitution",
    "contact_softness",
    "prepare_contacts",
    "row_softness",
    "soft_coefficients",
    "solve_substeps",
    "store_impulses",
]
