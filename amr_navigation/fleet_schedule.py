"""Following a fleet plan (amr_planning.fleet_execution) together: which waypoints each robot may drive to now.

A fleet plan gives every robot a list of waypoints (its lattice vertices, waits dropped) and, for each waypoint,
the moves of other robots that must be done first (the action dependencies: a robot may drive into a vertex only
once every robot the plan puts there earlier has moved on). `Schedule` keeps each robot's progress (the last
waypoint it reached, in order) and says how far along its list a robot may go: up to the first waypoint whose
dependencies are not all done. Robots driven this way at any speeds never meet at a vertex and never wait on one
another in a cycle (Hoenig et al. 2016). What following a route needs, shared by the navigator node and the library
level (amr_navigation.navigator_core.NavigatorCore, which asks the planner for the legs through the waypoints):
`HandOver` (when a new path is due), `DeadReckoning` (the pose to drive by). No ROS.
"""

from __future__ import annotations

import math

import numpy as np

from amr_control.path_follower import State
from amr_planning.fleet_execution import dependencies
from amr_planning.fleet_paths import FleetPlan
from amr_util.geometry import compose, relative_pose


class Schedule:
    """Every robot's progress along a fleet plan, and how far each may go."""

    def __init__(
        self, plan: FleetPlan, goals: list[tuple[float, float]] | None = None, reach: float | None = None
    ) -> None:
        self.reach = 0.45 * plan.graph.spacing if reach is None else float(reach)
        """m: a robot this close to its next waypoint has reached it (under half the spacing: a robot that has
        reached its next vertex has left the one before, which a robot waiting for it may then enter)."""
        self.plan = plan
        self.needs = dependencies(plan)
        self.waypoints = [plan.waypoints(robot) for robot in range(len(plan.paths))]
        if goals is not None:  # the last waypoint is the robot's own goal, not the vertex nearest to it
            for robot, goal in enumerate(goals):
                self.waypoints[robot] = self.waypoints[robot].copy()
                self.waypoints[robot][-1] = goal
        self.progress = [0] * len(self.waypoints)
        """the index of the last waypoint each robot reached (0: its start vertex, where it begins)."""

    def allowed(self, robot: int) -> int:
        """The farthest waypoint the robot may drive to now: its progress, then each next waypoint whose
        dependencies are all done."""
        last = self.progress[robot]
        while last + 1 < len(self.waypoints[robot]) and all(
            self.progress[other] >= action for other, action in self.needs[robot][last + 1]
        ):
            last += 1
        return last

    def report(self, robot: int, x: float, y: float) -> bool:
        """The robot is at (x, y): it has reached its next waypoint if that lies within `reach` (one at a time, in
        order, never one it may not drive to yet: a waypoint passed by is reached, one skipped is not). True if
        its progress moved."""
        if self.progress[robot] >= self.allowed(robot):
            return False
        target = self.waypoints[robot][self.progress[robot] + 1]
        if math.hypot(target[0] - x, target[1] - y) > self.reach:
            return False
        self.progress[robot] += 1
        return True

    def route(self, robot: int, x: float, y: float) -> np.ndarray:
        """(K, 2) the way from (x, y) through the waypoints the robot may drive to now, as far as it does not come
        back near a point of it already (a path follower ends a path that returns to its start at once); just
        (x, y) and its last reached waypoint when it may go no farther."""
        first, last = self.progress[robot], self.allowed(robot)
        points = [np.array([x, y], dtype=float)]
        for index in range(first + 1, last + 1):
            point = self.waypoints[robot][index]
            if len(points) > 1 and min(math.hypot(*(point - seen)) for seen in points) <= self.reach:
                break
            points.append(point)
        if len(points) == 1:
            points.append(self.waypoints[robot][first])
        return np.array(points)


BLOCKED_RETRY = 1.0
"""s a robot whose path follower stopped short (of something in the way, or strayed from its path) waits before
setting off again from where it stands (its route planned anew)."""
STOPPED_SHORT = (State.BLOCKED, State.STRAYED)
"""the path follower's states that BLOCKED_RETRY answers."""


class HandOver:
    """When a robot's path follower is due a new path along its route: when what it may drive to changed (`key`:
    any value that changes with it), or BLOCKED_RETRY s after the follower stopped short of something."""

    def __init__(self) -> None:
        self._key: object = None
        self._blocked_since: float | None = None

    def due(self, key: object, blocked: bool, stamp: float) -> bool:
        """For an observation at `stamp` (s) whose route is `key`, the follower `blocked` or not: hand a new path
        over now? (True at most once per change, and once per BLOCKED_RETRY while blocked.)"""
        if not blocked:
            self._blocked_since = None
        elif self._blocked_since is None:
            self._blocked_since = stamp
        retry = blocked and stamp - self._blocked_since >= BLOCKED_RETRY
        if key != self._key or retry:
            self._key, self._blocked_since = key, None
            return True
        return False

    def reset(self) -> None:
        """Forget the route handed over: the next observation is due a path."""
        self._key, self._blocked_since = None, None


class DeadReckoning:
    """The pose a robot on a fleet plan drives by: its estimate while the localizer is sure of it, else its last
    sure estimate moved on by odometry since (standing still, an unsure filter would stay unsure; driving on by
    odometry gives it new views)."""

    def __init__(self) -> None:
        self.sure: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
        """(the last estimate the navigator was sure of, the odometry pose then)."""

    def pose(self, estimate, sure: bool, odometry) -> tuple[float, float, float]:
        """The pose to drive by for one observation (the estimate in the map frame and whether the navigator is
        sure of it: its ConfidenceGate, the odometry pose in the odom frame of the same observation)."""
        estimate = tuple(float(v) for v in estimate)
        if sure or self.sure is None:
            if sure:
                self.sure = (estimate, tuple(float(v) for v in odometry))
            return estimate
        last, then = self.sure
        return tuple(float(v) for v in compose(last, relative_pose(then, tuple(odometry))))
