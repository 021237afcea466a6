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
corner made of two walls, is one collision. Each robot of a fleet counts its own,
and separately those with solids and those with each other robot. Two robots in
contact both treat the other as a wall: neither can push the other.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pymunk

ROBOT_MASS = 1.0
"""kg (TurtleBot3 Burger). Velocities are imposed, so mass only scales contact impulses."""
COLLISION_SLOP = 0.001
"""m of overlap pymunk tolerates before pushing the robot out (its default 0.1 suits pixels)."""
COLLISION_BIAS = 0.0
"""Fraction of the overlap left uncorrected after one second: 0 pushes it all out each step."""
ROBOT_CATEGORY, WALL_CATEGORY = 0b01, 0b10
WALL_TYPE = 1
ROBOT_TYPE = 2
"""Robot i's collision type is ROBOT_TYPE + i: a handler per robot (and per pair) knows whose contact it is."""
WALLS_ONLY = pymunk.ShapeFilter(mask=WALL_CATEGORY)


@dataclass
class Contacts:
    """One robot's contacts: what it touches now and how often it has run into something."""

    collisions: int = 0
    """times it went from touching nothing to touching something."""
    wall_collisions: int = 0
    """times it went from touching no solid to touching one."""
    robot_collisions: dict[int, int] = field(default_factory=dict)
    """other robot's index -> times it went from not touching that robot to touching it."""
    walls: int = 0
    """solids touched now (pymunk arbiters)."""
    robots: dict[int, int] = field(default_factory=dict)
    """other robot's index -> arbiters with it now."""
    normals: list[pymunk.Vec2d] = field(default_factory=list)
    """unit normals, from the robot into what it touched, reported by the last substep."""

    @property
    def touching(self) -> int:
        return self.walls + sum(self.robots.values())

    def clear_counts(self) -> None:
        self.collisions = self.wall_collisions = 0
        self.robot_collisions = {}

    def begin(self, other: int | None) -> None:
        """Contact with a solid (other None) or with robot `other` begins."""
        if self.touching == 0:
            self.collisions += 1
        if other is None:
            if self.walls == 0:
                self.wall_collisions += 1
            self.walls += 1
        else:
            if self.robots.get(other, 0) == 0:
                self.robot_collisions[other] = self.robot_collisions.get(other, 0) + 1
            self.robots[other] = self.robots.get(other, 0) + 1

    def separate(self, other: int | None) -> None:
        if other is None:
            self.walls = max(self.walls - 1, 0)
        elif self.robots.get(other, 0) > 0:
            self.robots[other] -= 1


class Physics:
    """A pymunk space holding the world's solids and one disc per robot (robot i in ShapeFilter group
    i + 1, so that a query in that group, such as robot i's LiDAR, passes through its own disc)."""

    def __init__(self, polygons: Sequence[np.ndarray], robot_radius: float, robots: int = 1) -> None:
        self.space = pymunk.Space()
        self.space.collision_slop = COLLISION_SLOP
        self.space.collision_bias = COLLISION_BIAS
        for polygon in polygons:
            shape = pymunk.Poly(self.space.static_body, [tuple(p) for p in polygon])
            shape.filter = pymunk.ShapeFilter(categories=WALL_CATEGORY)
            shape.collision_type = WALL_TYPE
            shape.friction = 0.0
            self.space.add(shape)
        self.bodies: list[pymunk.Body] = []
        self.shapes: list[pymunk.Circle] = []
        for index in range(robots):
            body = pymunk.Body(ROBOT_MASS, pymunk.moment_for_circle(ROBOT_MASS, 0.0, robot_radius))
            shape = pymunk.Circle(body, robot_radius)
            shape.filter = pymunk.ShapeFilter(group=index + 1, categories=ROBOT_CATEGORY)
            shape.collision_type = ROBOT_TYPE + index
            shape.friction = 0.0
            self.space.add(body, shape)
            self.bodies.append(body)
            self.shapes.append(shape)
        self.body, self.shape = self.bodies[0], self.shapes[0]
        self.radius = robot_radius
        self.contacts = [Contacts() for _ in range(robots)]
        for index, contacts in enumerate(self.contacts):
            self.space.on_collision(ROBOT_TYPE + index, WALL_TYPE, **_wall_handlers(contacts))
            for other in range(index + 1, robots):
                self.space.on_collision(
                    ROBOT_TYPE + index,
                    ROBOT_TYPE + other,
                    **_robot_handlers(contacts, index, self.contacts[other], other),
                )

    @property
    def collisions(self) -> int:
        """Robot 0's collisions (the one robot of a one-robot world)."""
        return self.contacts[0].collisions

    @property
    def in_contact(self) -> bool:
        """Robot 0 touches something."""
        return self.contacts[0].touching > 0

    def clearance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest solid (negative inside one), up to the robot radius."""
        hit = self.space.point_query_nearest((x, y), self.radius, WALLS_ONLY)
        return self.radius if hit is None else hit.distance

    def place(self, x: float, y: float, theta: float, robot: int = 0) -> None:
        """Teleport a robot, at rest."""
        body = self.bodies[robot]
        body.position = (x, y)
        body.angle = theta
        body.velocity = (0.0, 0.0)
        body.angular_velocity = 0.0
        self.space.reindex_shapes_for_body(body)
        self.contacts[robot].normals = []

    def pose(self, robot: int = 0) -> tuple[float, float, float]:
        body = self.bodies[robot]
        x, y = body.position
        return x, y, body.angle

    def advance(self, velocities: Sequence[tuple[float, float, float]], dt: float) -> None:
        """One substep of every robot at its world velocity (vx, vy) and turn rate w, minus pushes into
        what it touches."""
        for body, contacts, (vx, vy, w) in zip(self.bodies, self.contacts, velocities, strict=True):
            for normal in contacts.normals:  # the contacts the last substep left
                into = vx * normal.x + vy * normal.y
                if into > 0.0:
                    vx -= into * normal.x
                    vy -= into * normal.y
            contacts.normals = []
            body.velocity = (vx, vy)
            body.angular_velocity = w
        self.space.step(dt)


def _wall_handlers(contacts: Contacts) -> dict:
    """pymunk callbacks for one robot's contacts with the solids."""

    def begin(arbiter: pymunk.Arbiter, space: pymunk.Space, data: dict) -> None:
        contacts.begin(None)

    def pre_solve(arbiter: pymunk.Arbiter, space: pymunk.Space, data: dict) -> None:
        # shapes are ordered as the handler's types: the normal points from the robot into the wall
        contacts.normals.append(arbiter.normal)

    def separate(arbiter: pymunk.Arbiter, space: pymunk.Space, data: dict) -> None:
        contacts.separate(None)

    return {"begin": begin, "pre_solve": pre_solve, "separate": separate}


def _robot_handlers(first: Contacts, index: int, second: Contacts, other: int) -> dict:
    """pymunk callbacks for the contacts between robots `index` and `other` (index < other)."""

    def begin(arbiter: pymunk.Arbiter, space: pymunk.Space, data: dict) -> None:
        first.begin(other)
        second.begin(index)

    def pre_solve(arbiter: pymunk.Arbiter, space: pymunk.Space, data: dict) -> None:
        # the normal points from the first robot into the second: each treats the other as a wall for
        # the next substep (a robot cannot push another)
        first.normals.append(arbiter.normal)
        second.normals.append(-arbiter.normal)

    def separate(arbiter: pymunk.Arbiter, space: pymunk.Space, data: dict) -> None:
        first.separate(other)
        second.separate(index)

    return {"begin": begin, "pre_solve": pre_solve, "separate": separate}


def substeps(distance: float, max_substep_distance: float) -> int:
    """How many substeps keep each one's travel within max_substep_distance."""
    return max(1, math.ceil(distance / max_substep_distance - 1e-9))
