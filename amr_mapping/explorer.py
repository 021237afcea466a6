"""Frontier exploration's state, without ROS: a map and the robot's pose in, the next goal (or done) out.

`Explorer.update(grid, pose, now)` finds the frontiers (amr_mapping.frontiers: free cells beside unknown ones,
8-connected, at least min_frontier_size long), reaches them from the robot over the cells its disc fits in, and
  - keeps the current goal while a frontier cell still lies within approach_distance of it (the robot is on its
    way; the frontier recedes as it sees more) and the robot makes progress: goal_timeout has not passed since
    the path to that frontier's goal was last a cell shorter than ever (explore_lite's progress_timeout: a far goal
    the robot is still nearing is kept);
  - else chooses the reachable, not blacklisted frontier of least cost (explore_lite's rule:
    potential_scale * path length - gain_scale * frontier length) and returns its goal as new;
  - with none left, is `done` (state "done", no goal); a later map with new frontiers makes it explore again.
Giving up (amr_mapping.frontiers, reach_frontiers):
  - a goal the navigator could not plan to or reach (`failed`), or without progress for goal_timeout: the point;
    frontiers whose goal lies within blacklist_radius of it are never chosen again;
  - a goal reached (`reached`): the frontier it was chosen for, as it was then, from there; a frontier mostly of
    the same cells (it is still there: what lay beyond could not be seen from there) whose goal lies within
    blacklist_radius of that one is never chosen again; a frontier mostly of new cells (an opening seen as the
    robot arrived), or the same one with its goal elsewhere (the map grew: another view), is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from amr_mapping.frontiers import (
    Frontier,
    FrontierConfig,
    best_frontier,
    detect_frontiers,
    frontier_points,
    reach_frontiers,
    with_robot_free,
)
from amr_maps.occupancy_grid import OccupancyGrid
from amr_util.geometry import all_finite
from amr_util.parameter_spec import parameter

WAITING, EXPLORING, DONE = "waiting", "exploring", "done"


@dataclass(frozen=True)
class ExplorerConfig(FrontierConfig):
    """FrontierConfig's choice and reach, and when a goal is given up."""

    goal_timeout: float = parameter(120.0, above=0.0, maximum=1e6, live=True)
    """s (of the pose's stamps) without progress (the path to the goal's frontier a cell shorter than ever) after
    which a goal is given up and blacklisted (explore_lite progress_timeout)."""


@dataclass(frozen=True)
class Step:
    """What the explorer says after a map or a pose: its state, the goal to drive to, whether it is new."""

    state: str
    goal: tuple[float, float] | None = None
    new_goal: bool = False
    reason: str = ""
    frontiers: tuple[Frontier, ...] = ()
    chosen: int = -1


@dataclass
class Explorer:
    """The frontier explorer's state between maps: the goal being driven to, the points and frontiers given up."""

    config: ExplorerConfig = field(default_factory=ExplorerConfig)
    goal: tuple[float, float] | None = None
    goal_since: float = 0.0
    """s, when the goal was chosen or last progressed to (its frontier's path a cell shorter than ever)."""
    goal_best: float = math.inf
    """m, the shortest path to the goal's frontier so far."""
    goal_frontier: np.ndarray | None = None
    """(K, 2) x, y of the cells of the frontier the goal was chosen for, as they were then."""
    blacklist: list[tuple[float, float]] = field(default_factory=list)
    """goals given up (failed, timed out): points."""
    given_up: list[tuple[tuple[float, float], np.ndarray]] = field(default_factory=list)
    """frontiers given up from a goal (reached, they stayed): (the goal, goal_frontier's cells) each."""
    state: str = WAITING
    goals_sent: int = 0
    reached_count: int = 0
    events: list[str] = field(default_factory=list)

    def update(self, grid: OccupancyGrid | None, pose, now: float) -> Step:
        """The state and goal for this map and pose (x, y, theta) at time `now` (s)."""
        if grid is None or pose is None or not all_finite(tuple(pose)[:2]):
            self.state = WAITING
            return Step(WAITING, reason="no map yet" if grid is None else "no pose yet")
        robot = (float(pose[0]), float(pose[1]))
        config = self.config
        seen = with_robot_free(grid, robot, config.footprint_radius)
        found = detect_frontiers(seen, config.min_frontier_size, config.free_threshold)
        frontiers = reach_frontiers(seen, found, robot, config, self.blacklist, self.given_up)
        if self.goal is not None:
            kept = self._frontier_at_goal(seen, frontiers)
            if kept >= 0 and frontiers[kept].distance <= self.goal_best - grid.resolution:
                self.goal_best, self.goal_since = frontiers[kept].distance, now
            if now - self.goal_since > config.goal_timeout:
                self.failed(f"no progress within goal_timeout ({config.goal_timeout:g} s)")
                frontiers = reach_frontiers(seen, found, robot, config, self.blacklist, self.given_up)
            elif kept >= 0:
                self.state = EXPLORING
                return Step(EXPLORING, self.goal, False, "driving to the frontier", tuple(frontiers), kept)
            else:
                self._say(f"frontier at ({self.goal[0]:.2f}, {self.goal[1]:.2f}) explored")
                self.goal, self.goal_frontier = None, None
        chosen = best_frontier(frontiers)
        if chosen < 0:
            self.state = DONE
            unreachable = sum(1 for f in frontiers if not f.reachable)
            reason = (
                f"no reachable frontier left ({len(frontiers)} frontiers: {unreachable} unreachable, "
                f"{sum(1 for f in frontiers if f.blacklisted)} blacklisted; {len(self.blacklist)} points and "
                f"{len(self.given_up)} frontiers given up)"
            )
            return Step(DONE, None, False, reason, tuple(frontiers), -1)
        frontier = frontiers[chosen]
        self.goal, self.goal_since, self.goal_best, self.state = frontier.goal, now, frontier.distance, EXPLORING
        self.goal_frontier = frontier_points(seen, frontier)
        self.goals_sent += 1
        reason = (
            f"frontier of {frontier.length:.2f} m at ({frontier.centroid[0]:.2f}, {frontier.centroid[1]:.2f}), "
            f"{frontier.distance:.2f} m away: goal ({frontier.goal[0]:.2f}, {frontier.goal[1]:.2f})"
        )
        self._say(reason)
        return Step(EXPLORING, self.goal, True, reason, tuple(frontiers), chosen)

    @property
    def given_up_count(self) -> int:
        """Points and frontiers given up."""
        return len(self.blacklist) + len(self.given_up)

    def reached(self) -> None:
        """The robot reached the goal: the frontier it was chosen for is given up (if it is still there, what lies
        beyond cannot be seen from there), and the next update chooses again."""
        if self.goal is not None:
            self.reached_count += 1
            if self.goal_frontier is not None:
                self.given_up.append((self.goal, self.goal_frontier))
            self.goal, self.goal_frontier = None, None

    def failed(self, reason: str) -> None:
        """The goal could not be planned to or reached: blacklisted, and the next update chooses again."""
        if self.goal is not None:
            self._say(f"goal ({self.goal[0]:.2f}, {self.goal[1]:.2f}) given up: {reason}")
            self.blacklist.append(self.goal)
            self.goal, self.goal_frontier = None, None

    def take_events(self) -> list[str]:
        events, self.events = self.events, []
        return events

    def _frontier_at_goal(self, grid: OccupancyGrid, frontiers: list[Frontier]) -> int:
        """Index of a frontier (not blacklisted) with a cell within approach_distance of the goal, else -1."""
        gx, gy = self.goal
        reach = max(self.config.approach_distance, grid.resolution) + 0.5 * grid.resolution
        for index, frontier in enumerate(frontiers):
            if frontier.blacklisted:
                continue
            x, y = grid.cell_to_world(frontier.cells[:, 0], frontier.cells[:, 1])
            if float(((x - gx) ** 2 + (y - gy) ** 2).min()) <= reach**2:
                return index
        return -1

    def _say(self, event: str) -> None:
        self.events.append(event)
