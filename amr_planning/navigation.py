"""Explore, localize, plan, go: the `maze_navigation` stack's decisions as plain classes (no ROS).

`Navigator` decides, for one observation (the localizer's estimate, the scan, the odometry twist),
which controller answers it and with what command, the way the nodes of `maze_navigation` do in
lockstep:

- wall_follower (`enable_localization`): answers every observation whose pose says not localized;
  its controller keeps its state across hand-overs (the node's does);
- planner: on a localized pose, plans from the estimated pose to the goal when it has no path, when
  the goal changed, or when the pose is more than `replan_distance` from the path it last planned;
  a planning failure leaves it without a path and it tries again at the next localized pose;
- path_follower: answers a localized observation once it has a path (pure pursuit on the estimated
  pose); when the follower asks for a new plan (blocked, strayed) it is planned from the estimated
  pose to the path's end (the planner's ~/plan service) and followed from the next observation; a
  failed request keeps the old path. The service does not change the planner's own path (the node's
  doesn't either), so the planner's stray check keeps measuring against the path it planned itself.

A localized observation with no path is answered by nobody in the stack (the lockstep simulator
waits); here it gets a zero command with mode NO_PATH. `run_navigation` drives a Simulator and a
ParticleFilter with a Navigator (the filter's estimate is its pose in the map moved by the odometry
since its last update, which is what the node publishes on /pose) until the path follower says the
goal is reached, a number of collisions, or a time limit; bench/bench_navigation.py runs it.

This module ties the packages together (amr_control's controllers, amr_localization's filter,
amr_simulation's simulator) the way the bringup stack does; the planning algorithms it calls import
none of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from amr_control.path_follower import FollowCommand, PathError, PathFollower, State
from amr_control.wall_follower import WallFollower
from amr_planning.errors import PlanningError
from amr_planning.planner import Planner, distance_to_path
from amr_util.scan import ScanData, scan_of


class Mode(str, Enum):
    EXPLORE = "EXPLORE"
    """not localized: the wall follower drives."""
    FOLLOW = "FOLLOW"
    """localized with a path: the path follower drives."""
    NO_PATH = "NO_PATH"
    """localized, no path (planning failed): nobody drives."""
    REACHED = "REACHED"
    """the path follower says the goal is reached."""


@dataclass(frozen=True)
class NavigationCommand:
    v: float
    w: float
    mode: Mode
    follow: FollowCommand | None = None
    """the path follower's command (FOLLOW, REACHED)."""
    events: tuple[str, ...] = ()
    """what happened at this observation: planned, replanned, localization lost, planning failed, ..."""


class Navigator:
    """The hand-over between wall following and path following, and the planning around it."""

    def __init__(self, planner: Planner, wall_follower: WallFollower, path_follower: PathFollower,
                 goal: tuple[float, float], replan_distance: float | None = None) -> None:
        self.planner = planner
        self.wall_follower = wall_follower
        self.path_follower = path_follower
        self.replan_distance = planner.config.replan_distance if replan_distance is None else replan_distance
        self.goal = (float(goal[0]), float(goal[1]))
        self.planned_path: np.ndarray | None = None
        """the planner's own path (what its stray check measures against)."""
        self.followed_path: np.ndarray | None = None
        """the path the follower follows (the planner's, or a ~/plan answer)."""
        self._planned_goal: tuple[float, float] | None = None
        self._localized = False
        self.plans = 0
        """paths planned (first plan, goal changes, strays, the follower's requests)."""
        self.planning_failures: list[str] = []
        self.localization_losses = 0

    def set_goal(self, goal: tuple[float, float]) -> None:
        """A new goal (/goal_pose): planned for at the next localized observation."""
        self.goal = (float(goal[0]), float(goal[1]))

    def step(self, pose: tuple[float, float, float], localized: bool, scan: ScanData,
             odometry_v: float, odometry_w: float, stamp: float) -> NavigationCommand:
        events: list[str] = []
        if localized != self._localized:
            if not localized:
                self.localization_losses += 1
            events.append("localized" if localized else "localization withdrawn: exploring again")
            self._localized = localized
        if not localized:
            command = self.wall_follower.compute(scan, odometry_v, odometry_w, stamp)
            return NavigationCommand(command.v, command.w, Mode.EXPLORE, None, tuple(events))
        x, y, theta = pose
        self._planner_on_pose(x, y, events)
        if not self.path_follower.has_path:
            return NavigationCommand(0.0, 0.0, Mode.NO_PATH, None, tuple(events))
        follow = self.path_follower.compute(x, y, theta, scan)
        if follow.replan:
            self._request_plan(x, y, events)
        mode = Mode.REACHED if follow.reached else Mode.FOLLOW
        return NavigationCommand(follow.v, follow.w, mode, follow, tuple(events))

    # -- the planner node's /pose callback and ~/plan service ---------------------------------

    def _planner_on_pose(self, x: float, y: float, events: list[str]) -> None:
        if self.planned_path is not None and self._planned_goal == self.goal:
            if distance_to_path(self.planned_path, x, y) <= self.replan_distance:
                return
            events.append(f"strayed more than {self.replan_distance} m from the planned path: planning again")
        self._planned_goal = self.goal
        try:
            self.planned_path = self.planner.plan((x, y), self.goal)
        except PlanningError as error:
            self.planned_path = None
            self.planning_failures.append(str(error))
            events.append(f"no path: {error}")
            return
        self.plans += 1
        events.append(f"planned {len(self.planned_path)} points")
        self._follow(self.planned_path, events)

    def _request_plan(self, x: float, y: float, events: list[str]) -> None:
        goal = self.path_follower.goal
        try:
            points = self.planner.plan((x, y), (float(goal[0]), float(goal[1])))
        except PlanningError as error:
            self.planning_failures.append(str(error))
            events.append(f"replanning failed: {error}")
            return
        self.plans += 1
        events.append(f"replanned on the follower's request ({len(points)} points)")
        self._follow(points, events)

    def _follow(self, points: np.ndarray, events: list[str]) -> None:
        try:
            self.path_follower.set_path(points)
        except PathError as error:
            self.path_follower.clear()
            self.followed_path = None
            events.append(f"path refused: {error}")
            return
        self.followed_path = np.asarray(points, dtype=float)


# -- the loop with a simulator and a particle filter --------------------------------------------


@dataclass
class NavigationRun:
    """What one run did (times in simulated seconds)."""

    reached: bool = False
    """the true pose entered the world's goal region (where the simulator stops the robot, as the
    stack's simulator does), or the path follower said REACHED within that region."""
    follower_reached: bool = False
    """the path follower said REACHED (its estimate within goal_tolerance of the goal)."""
    time: float = 0.0
    """when the run stopped."""
    reason: str = ""
    """why it stopped: goal reached, time limit, collisions."""
    first_localized: float | None = None
    localization_losses: int = 0
    collisions: int = 0
    plans: int = 0
    planning_failures: list[str] = field(default_factory=list)
    goal_distance: float = math.nan
    """m from the true pose to the goal when the run stopped."""
    estimate_error: float = math.nan
    """m between the estimate and the true pose when the run stopped."""
    cross_track: list[float] = field(default_factory=list)
    """m from the TRUE pose to the followed path at each step the follower tracked (state TRACK)."""
    estimated_cross_track: list[float] = field(default_factory=list)
    """the follower's own cross-track error (from the estimated pose) at those steps."""
    max_localized_error: float = 0.0
    """m, the largest estimate error at a step the filter said localized."""
    steps: dict = field(default_factory=dict)
    """steps per Mode."""

    @property
    def mean_cross_track(self) -> float:
        return float(np.mean(self.cross_track)) if self.cross_track else math.nan


def run_navigation(sim, particle_filter, navigator: Navigator, limit: float = 600.0,
                   max_collisions: int = 5) -> NavigationRun:
    """Lockstep: each period the filter gets the odometry pose and the scan, the navigator the estimate,
    the scan and the odometry twist, and its command advances the simulator by dt. Stops when the true
    pose enters the world's goal region (the simulator stops the robot there), when the path follower
    says REACHED, at max_collisions, or at `limit` s."""
    result = NavigationRun()
    steps = {mode: 0 for mode in Mode}
    error = math.nan
    while True:
        truth = sim.pose
        if sim.goal_reached:
            result.reached, result.reason = True, "goal region reached"
            break
        if sim.collisions >= max_collisions:
            result.reason = f"{sim.collisions} collisions"
            break
        if sim.time >= limit:
            result.reason = f"time limit {limit:.0f} s"
            break
        scan = scan_of(sim)
        estimate = particle_filter.update(tuple(sim.odom_pose), scan)
        pose = (estimate.pose.x, estimate.pose.y, estimate.pose.theta)
        error = math.hypot(pose[0] - truth.x, pose[1] - truth.y)
        if estimate.localized:
            if result.first_localized is None:
                result.first_localized = sim.time
            result.max_localized_error = max(result.max_localized_error, error)
        command = navigator.step(pose, estimate.localized, scan, *sim.odom_twist, sim.time)
        steps[command.mode] += 1
        if command.follow is not None and command.follow.state is State.TRACK and navigator.followed_path is not None:
            result.cross_track.append(distance_to_path(navigator.followed_path, truth.x, truth.y))
            result.estimated_cross_track.append(command.follow.cross_track)
        if command.mode is Mode.REACHED:
            result.follower_reached = True
            result.reached = sim.goal is None or sim.goal.contains(truth.x, truth.y)
            result.reason = "goal reached" if result.reached else "the follower stopped outside the goal region"
            break
        sim.step(command.v, command.w)
    truth = sim.pose
    result.time = sim.time
    result.collisions = sim.collisions
    result.localization_losses = navigator.localization_losses
    result.plans = navigator.plans
    result.planning_failures = list(navigator.planning_failures)
    result.goal_distance = math.hypot(truth.x - navigator.goal[0], truth.y - navigator.goal[1])
    result.estimate_error = error  # at the last observation
    result.steps = {mode.value: count for mode, count in steps.items()}
    return result
