"""Frontier exploration's state, without ROS: a map and the robot's pose in, the next goal (or done) out.

`Explorer.update(grid, pose, now)` finds the frontiers (amr_mapping.frontiers: free cells beside unknown ones,
8-connected, at least min_frontier_size long), reaches them from the robot over the cells its disc fits in, and
  - keeps the current goal while a frontier cell still lies within approach_distance of it (the robot is on its
    way; the frontier recedes as it sees more) and goal_timeout has not passed since it was chosen;
  - else chooses the reachable, not blacklisted frontier of least cost (explore_lite's rule:
    potential_scale * path length - gain_scale * frontier length) and returns its goal as new;
  - with none left, is `done` (state "done", no goal); a later map with new frontiers makes it explore again.
Blacklisting: a goal the navigator could not plan to or reach (`failed`), one not reached within goal_timeout,
and one reached whose frontier is still there (`reached`: what lay beyond could not be seen from there) are
given up; frontiers whose goal lies within blacklist_radius of a point given up are never chosen again.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from amr_mapping.frontiers import (
    Frontier,
    FrontierConfig,
    best_frontier,
    detect_frontiers,
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
    """s (of the pose's stamps) a goal may take before it is given up and blacklisted (explore_lite
    progress_timeout, here per goal)."""


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
    """The frontier explorer's state between maps: the goal being driven to, and the points given up on."""

    config: ExplorerConfig = field(default_factory=ExplorerConfig)
    goal: tuple[float, float] | None = None
    goal_since: float = 0.0
    blacklist: list[tuple[float, float]] = field(default_factory=list)
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
        if self.goal is not None and now - self.goal_since > config.goal_timeout:
            self.failed(f"not reached within goal_timeout ({config.goal_timeout:g} s)")
        seen = with_robot_free(grid, robot, config.footprint_radius)
        frontiers = reach_frontiers(
            seen, detect_frontiers(seen, config.min_frontier_size, config.free_threshold), robot, config, self.blacklist
        )
        if self.goal is not None:
            kept = self._frontier_at_goal(seen, frontiers)
            if kept >= 0:
                self.state = EXPLORING
                return Step(EXPLORING, self.goal, False, "driving to the frontier", tuple(frontiers), kept)
            self._say(f"frontier at ({self.goal[0]:.2f}, {self.goal[1]:.2f}) explored")
            self.goal = None
        chosen = best_frontier(frontiers)
        if chosen < 0:
            self.state = DONE
            unreachable = sum(1 for f in frontiers if not f.reachable)
            reason = (
                f"no reachable frontier left ({len(frontiers)} frontiers: {unreachable} unreachable, "
                f"{sum(1 for f in frontiers if f.blacklisted)} blacklisted; {len(self.blacklist)} points "
                "given up)"
            )
            return Step(DONE, None, False, reason, tuple(frontiers), -1)
        frontier = frontiers[chosen]
        self.goal, self.goal_since, self.state = frontier.goal, now, EXPLORING
        self.goals_sent += 1
        reason = (
            f"frontier of {frontier.length:.2f} m at ({frontier.centroid[0]:.2f}, {frontier.centroid[1]:.2f}), "
            f"{frontier.distance:.2f} m away: goal ({frontier.goal[0]:.2f}, {frontier.goal[1]:.2f})"
        )
        self._say(reason)
        return Step(EXPLORING, self.goal, True, reason, tuple(frontiers), chosen)

    def reached(self) -> None:
        """The robot reached the goal: the point is given up (if its frontier is still there, it cannot be seen
        from there), and the next update chooses again."""
        if self.goal is not None:
            self.reached_count += 1
            self.blacklist.append(self.goal)
            self.goal = None

    def failed(self, reason: str) -> None:
        """The goal could not be planned to or reached: blacklisted, and the next update chooses again."""
        if self.goal is not None:
            self._say(f"goal ({self.goal[0]:.2f}, {self.goal[1]:.2f}) given up: {reason}")
            self.blacklist.append(self.goal)
            self.goal = None

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
