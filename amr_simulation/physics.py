"""The pymunk world: static solids and a dynamic disc robot driven by velocity commands.

The robot is a dynamic body whose velocity is set before every substep, so it
follows the commanded twist exactly in free space while the solver keeps it
out of the walls. pymunk integrates positions before it detects and resolves
contacts, so a freshly set velocity would push into a wall it already touches;
the command is therefore first stripped of its component into every contact
normal the last substep reported (pre_solve callback): what the contact solver
would do, friction-free, so the robot slides along walls. Penetration is then
bounded by one substep of travel, which `max_substep_distance` bounds.

A collision is counted when the robot goes from touching nothing to touching
something (pymunk begin/separate callbacks): sliding along a wall, or into a
corner made of two walls, is one collision.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import pymunk

ROBOT_MASS = 1.0
"""kg (TurtleBot3 Burger). Velocities are imposed, so mass only scales contact impulses."""
COLLISION_SLOP = 0.001
"""m of overlap pymunk tolerates before pushing the robot out (its default 0.1 suits pixels)."""
COLLISION_BIAS = 0.0
"""Fraction of the overlap left uncorrected after one second: 0 pushes it all out each step."""
ROBOT_CATEGORY, WALL_CATEGORY = 0b01, 0b10
ROBOT_TYPE, WALL_TYPE = 1, 2
WALLS_ONLY = pymunk.ShapeFilter(mask=WALL_CATEGORY)


class Physics:
    """A pymunk space holding the world's solids and the robot disc."""

    def __init__(self, polygons: Sequence[np.ndarray], robot_radius: float) -> None:
        self.space = pymunk.Space()
        self.space.collision_slop = COLLISION_SLOP
        self.space.collision_bias = COLLISION_BIAS
        for polygon in polygons:
            shape = pymunk.Poly(self.space.static_body, [tuple(p) for p in polygon])
            shape.filter = pymunk.ShapeFilter(categories=WALL_CATEGORY)
            shape.collision_type = WALL_TYPE
            shape.friction = 0.0
            self.space.add(shape)
        self.body = pymunk.Body(ROBOT_MASS, pymunk.moment_for_circle(ROBOT_MASS, 0.0, robot_radius))
        self.shape = pymunk.Circle(self.body, robot_radius)
        self.shape.filter = pymunk.ShapeFilter(categories=ROBOT_CATEGORY)
        self.shape.collision_type = ROBOT_TYPE
        self.shape.friction = 0.0
        self.space.add(self.body, self.shape)
        self.radius = robot_radius
        self.collisions = 0
        self._touching = 0
        self._normals: list[pymunk.Vec2d] = []
        self.space.on_collision(
            ROBOT_TYPE, WALL_TYPE, begin=self._begin, pre_solve=self._pre_solve, separate=self._separate
        )

    def _begin(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: dict) -> None:
        if self._touching == 0:
            self.collisions += 1
        self._touching += 1

    def _pre_solve(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: dict) -> None:
        # shapes are ordered as the handler's types: the normal points from the robot into the wall
        self._normals.append(arbiter.normal)

    def _separate(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: dict) -> None:
        self._touching = max(self._touching - 1, 0)

    @property
    def in_contact(self) -> bool:
        return self._touching > 0

    def clearance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest solid (negative inside one), up to the robot radius."""
        hit = self.space.point_query_nearest((x, y), self.radius, WALLS_ONLY)
        return self.radius if hit is None else hit.distance

    def place(self, x: float, y: float, theta: float) -> None:
        """Teleport the robot, at rest."""
        self.body.position = (x, y)
        self.body.angle = theta
        self.body.velocity = (0.0, 0.0)
        self.body.angular_velocity = 0.0
        self.space.reindex_shapes_for_body(self.body)
        self._normals = []

    def pose(self) -> tuple[float, float, float]:
        x, y = self.body.position
        return x, y, self.body.angle

    def advance(self, vx: float, vy: float, w: float, dt: float) -> None:
        """One substep at world velocity (vx, vy) and turn rate w, minus pushes into walls."""
        for normal in self._normals:  # the contacts the last substep left
            into = vx * normal.x + vy * normal.y
            if into > 0.0:
                vx -= into * normal.x
                vy -= into * normal.y
        self._normals = []
        self.body.velocity = (vx, vy)
        self.body.angular_velocity = w
        self.space.step(dt)


def substeps(distance: float, max_substep_distance: float) -> int:
    """How many substeps keep each one's travel within max_substep_distance."""
    return max(1, math.ceil(distance / max_substep_distance - 1e-9))
