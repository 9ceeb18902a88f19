"""Drawing joints over the bodies (``Renderer.draw``): anchors, links, axes and springs.

As Box2D's debug draw: each body's centre of mass is joined to its anchor by a thin
line, the anchors are dots (a gap between the two dots of a point joint is its error),
a distance joint is a line between its anchors (dashed while a rope is slack) or a
zigzag spring, a prismatic or wheel joint draws its axis through the second body's
anchor (and a wheel's spring as a zigzag from the axis' far end to the wheel), a mouse
joint a line to its target.
A drawing step, not a physics one: it loops over the joints in Python.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pygame

from .solver.joints import DISTANCE, MOUSE, PRISMATIC, WHEEL

__all__ = ["draw_joints"]

#: Half-length of a drawn axis, m; turns and width of a drawn spring (m).
AXIS_HALF_LENGTH = 0.5
SPRING_TURNS = 6
SPRING_WIDTH = 0.08


def _zigzag(start: np.ndarray, end: np.ndarray, width: float) -> np.ndarray:
    """(2 SPRING_TURNS + 3, 2) world points of a zigzag from ``start`` to ``end``."""
    t = np.linspace(0.0, 1.0, 2 * SPRING_TURNS + 1)
    axis = end - start
    length = float(np.hypot(*axis))
    normal = np.array([-axis[1], axis[0]]) / length if length > 0 else np.zeros(2)
    side = np.where(np.arange(len(t)) % 2 == 1, width, -width)
    side[0] = side[-1] = 0.0
    middle = start + 0.1 * axis + np.outer(0.8 * t, axis) + np.outer(side, normal)
    return np.vstack([start, middle, end])


def draw_joints(surface: pygame.Surface, camera: Any, world: Any, palette: Any) -> None:
    """Draw every joint of ``world`` onto ``surface`` through ``camera`` (``render.Camera``)
    in ``palette.joint`` and ``palette.spring``."""
    rows = world._joints.rows
    if not len(rows.kind):
        return
    first, second = world.joint_anchors()
    com = world.center_of_mass
    pixels = camera.world_to_screen

    def line(a: np.ndarray, b: np.ndarray, colour, width: int = 1) -> None:
        pa, pb = pixels(np.array([a, b]))
        pygame.draw.line(surface, colour, pa, pb, width)

    for j, kind in enumerate(rows.kind.tolist()):
        for body, anchor in ((rows.body_b[j], first[j]), (rows.body_a[j], second[j])):
            if body >= 0 and kind != MOUSE:
                line(com[body], anchor, palette.joint)
        if kind == DISTANCE:
            length = float(np.hypot(*(first[j] - second[j])))
            if rows.has_spring[j]:
                points = pixels(_zigzag(second[j], first[j], SPRING_WIDTH))
                pygame.draw.lines(surface, palette.spring, False, points.tolist(), 2)
            elif length < rows.max_length[j] - 1e-3 and rows.min_length[j] < rows.max_length[j]:
                for k in range(0, 10, 2):              # a slack rope: dashed
                    line(second[j] + k / 10 * (first[j] - second[j]),
                         second[j] + (k + 1) / 10 * (first[j] - second[j]), palette.joint, 2)
            else:
                line(second[j], first[j], palette.joint, 2)
        elif kind in (PRISMATIC, WHEEL):
            angle = world.angle[rows.body_a[j]] if rows.body_a[j] >= 0 else 0.0
            c, s = np.cos(angle), np.sin(angle)
            axis = np.array([c * rows.local_axis[j, 0] - s * rows.local_axis[j, 1],
                             s * rows.local_axis[j, 0] + c * rows.local_axis[j, 1]])
            line(second[j] - AXIS_HALF_LENGTH * axis, second[j] + AXIS_HALF_LENGTH * axis,
                 palette.joint)
            if kind == WHEEL and rows.has_spring[j]:     # from the axis' top to the wheel
                along = second[j] + float(np.dot(first[j] - second[j], axis)) * axis
                points = pixels(_zigzag(second[j] + AXIS_HALF_LENGTH * axis, along,
                                        SPRING_WIDTH))
                pygame.draw.lines(surface, palette.spring, False, points.tolist(), 2)
        elif kind == MOUSE:
            line(first[j], second[j], palette.spring, 2)
        for point in (first[j], second[j]):
            pygame.draw.circle(surface, palette.joint, pixels(point[None])[0], 3)
