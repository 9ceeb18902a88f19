"""The instruction set of compiled field programs (``sdf.compiled``).

Each opcode names one node operation of a field tree; a program row is (opcode, a,
b, offset into the constant table), with the meaning of a, b and the constants given
beside each opcode below. ``compiled._emit`` writes programs, ``compiled.run`` and
the kernels of ``primitive_kernels`` evaluate them.
"""

from __future__ import annotations

CIRCLE = 0          # consts: r
BOX = 1             # consts: hx, hy
ROUNDED_BOX = 2     # consts: hx, hy, r0, r1, r2, r3
HALF_PLANE = 3      # consts: nx, ny, level
POLYGON = 4         # a = M edges; consts: eps, then per edge ax, ay, ex, ey, by, 1/|e|^2, nx, ny
SEGMENT = 5         # consts: ax, ay, bax, bay, |ba|^2, left x, left y, radius
PUSH_T = 6          # consts: ox, oy, c, s, -s (rotation R = [[c, -s], [s, c]])
POP_T = 7           # consts: as PUSH_T
PUSH_S = 8          # consts: factor
POP_S = 9           # consts: factor
SELECT = 10         # a = n operands, b = 0 min / 1 max / 2 max(a, -b1, -b2, ...)
XOR = 11            # binary fold
SMOOTH = 12         # a = 0 union / 1 intersection / 2 difference, b = blend; consts: k
ROUND = 13          # consts: r
ONION = 14          # consts: thickness
# More primitives (each pushes one entry): ELLIPSE runs its solver over the whole
# batch (``_ellipse``), the opcodes after it are evaluated point by point by ``_shape``.
# An "edge" below is 7 consts: ax, ay, ex, ey (e = b - a), e.e, then the outward unit
# normal nx, ny.
ELLIPSE = 15        # a = 1: axes swapped (taller than wide); consts: a, b (semi-axes, a >= b)
ARC = 16            # consts: cx, cy (end direction), radius, half width
RING = 17           # a = 1: full annulus; consts: cx, cy, radius, half width
PIE = 18            # a = 1: full disk; consts: cx, cy, radius
CUT_DISK = 19       # consts: radius, cut height h, half chord w
HORSESHOE = 20      # consts: radius, half width, length, nx, ny, dx, dy
VESICA = 21         # consts: radius, centre distance, half height
MOON = 22           # consts: ra, rb, centre distance, horn x, y, horn x / ra, horn y / ra
EGG = 23            # consts: core r, apex y = sqrt(3) r, 2 r, top radius, sqrt(3)
HEART = 24          # consts: scale, lobe centre x, y, lobe radius, edge normal x, y
UNEVEN_CAPSULE = 25  # consts: r1, r2, height, sin t, cos t, c * height
STAR = 26           # consts: an, 2 an, eps, edge end bx, by, one edge
ORIENTED_BOX = 27   # consts: centre x, y, axis ux, uy, half length, half thickness
RHOMBUS = 28        # consts: bx, by, bx * by, eps, one edge
TRAPEZOID = 29      # a = M edges; consts: he, eps, side ax, ay, nx, ny, then M edges
CONVEX = 30         # a = M edges; consts: eps, then M edges (parallelogram, triangle)
SYM_TRIANGLE = 31   # consts: y base, eps, side ax, ay, nx, ny, then 2 edges (base, side)
MIRRORED = 32       # a = K mirrors, b = 1: fold y too; consts: radius, eps, K (nx, ny), one edge
CROSS = 33          # a = M edges; consts: bx, by, rounding, eps, then M edges
ROUNDED_CROSS = 34  # consts: h, k, radius, k - h
GRID = 35           # a, b = node counts nx, ny; consts: origin x, y, cell, margins (4), band
                    # (inf: none), then the nx * ny node values (row i = x index)
QUADRATIC_BEZIER = 36  # consts: a, A = b - a, B = a - 2b + c (2 each), B.B, 3 A.B, 2 A.A,
                       # radius, |A x B|, 1 if the cubic term is used
# Control (not primitives; ``run`` takes them before ``_shape``):
SKIP_FAR = 37       # a = rows to skip (the guarded operand and its blend); consts: the
                    # operand's box xmin, ymin, xmax, ymax in this frame, blend width k
EXTERNAL = 38       # a = index in Program.externals: a field of the user's own, which
                    # Python evaluates at the current points (``run`` returns there)

#: Blend kernels by index (``SMOOTH``'s b), as in ``operators.BLENDS``.
BLEND_INDEX = {"polynomial": 0, "cubic": 1, "circular": 2, "exponential": 3}
_POLYGON_EDGE = 8
