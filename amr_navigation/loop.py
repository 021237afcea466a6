"""The navigation loop without ROS: the Navigator's decisions carried out with the controller and planner
objects in process, one command per observation, as the `maze_navigation` stack carries them out with nodes.

`NavigationLoop.step` takes one observation (the localizer's estimate, the scan, the odometry twist) and
returns the command that answers it: the Navigator (amr_navigation.navigator) decides who drives and when to
plan; the loop plans (Planner.plan, as the planner node's ~/plan), hands paths to the PathFollower (as the
navigator node's ~/follow_path call), and asks the WallFollower or the PathFollower for the command (as
those nodes do when the navigator's status names them). A localized observation nobody drives (no goal,
no path, reached) gets a zero command here; in the stack nobody answers it and the lockstep simulator holds.

`run_navigation` drives a simulator and a particle filter with a NavigationLoop (the filter's estimate is its
pose in the map moved by the odometry since its last update, which is what the node publishes on /pose)
until the goal, a number of collisions, or a time limit; bench/bench_navigation.py runs it. The simulator is
any object with the Simulator's observation interface (pose, odom_pose, odom_twist, ranges, lidar, time,
goal, goal_reached, collisions, step): this package imports no simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from amr_control.path_follower import FollowCommand, PathError, PathFollower, State
from amr_control.wall_follower import WallFollower
from amr_navigation.navigator import DEFAULT_REPLAN_DISTANCE, Controller, Decision, Mode, Navigator, PlanRequest
from amr_navigation.traffic import Traffic
from amr_navigation.traffic_steps import detour_done, idle_advice
from amr_planning.errors import PlanningError
from amr_planning.planner import Planner, distance_to_path
from amr_util.scan import ScanData, scan_of


@dataclass(frozen=True)
class NavigationCommand:
    v: float
    w: float
    mode: Mode
    follow: FollowCommand | None = None
    """the path follower's command (FOLLOW, REACHED)."""
    events: tuple[str, ...] = ()
    """what happened at this observation: planned, replanned, localization lost, no path, ..."""


class NavigationLoop:
    """A Navigator with its planner and controllers in process."""

    def __init__(
        self,
        planner: Planner,
        wall_follower: WallFollower,
        path_follower: PathFollower,
        goal: tuple[float, float] | None,
        replan_distance: float = DEFAULT_REPLAN_DISTANCE,
        traffic: Traffic | None = None,
    ) -> None:
        self.planner = planner
        self.wall_follower = wall_follower
        self.path_follower = path_follower
        self.navigator = Navigator(goal, replan_distance)
        self.traffic = traffic
        """the traffic rules among other robots (amr_navigation.traffic); None: a robot alone, as before."""

    # what the bench and the tests read
    @property
    def goal(self) -> tuple[float, float] | None:
        return self.navigator.goal

    @property
    def planned_path(self) -> np.ndarray | None:
        return self.navigator.planned_path

    @property
    def followed_path(self) -> np.ndarray | None:
        return self.navigator.followed_path

    @property
    def plans(self) -> int:
        return self.navigator.counters.plans

    @property
    def planning_failures(self) -> list[str]:
        return self.navigator.counters.planning_failures

    @property
    def localization_losses(self) -> int:
        return self.navigator.counters.localization_losses

    def set_goal(self, goal: tuple[float, float]) -> None:
        """A new goal (/goal_pose): planned for at the next localized observation."""
        self.navigator.set_goal(goal)

    def step(
        self,
        pose: tuple[float, float, float],
        localized: bool,
        scan: ScanData,
        odometry_v: float,
        odometry_w: float,
        stamp: float,
    ) -> NavigationCommand:
        decision = self._carry_out(self.navigator.decide(pose, localized))
        events = list(decision.events)
        traffic = self.traffic
        if decision.controller is not Controller.PATH_FOLLOWER:
            advice = None
            if traffic is not None:  # posted; at the goal: make way for a robot it blocks
                advice = idle_advice(traffic, decision, pose, self.planner.costmap, stamp)
            if decision.controller is Controller.WALL_FOLLOWER:
                command = self.wall_follower.compute(scan, odometry_v, odometry_w, stamp)
                return NavigationCommand(command.v, command.w, decision.mode, None, tuple(events))
            if advice is None:
                return NavigationCommand(0.0, 0.0, decision.mode, None, tuple(events))
            events += advice.events
            events += self._carry_out(self.navigator.detour(advice.detour, "going aside")).events
        limit = None
        if traffic is not None:
            advice = traffic.advise(
                pose,
                scan,
                self.navigator.followed_path,
                self.planner.costmap,
                self.path_follower.config.linear_speed,
                stamp,
            )
            events += advice.events
            if advice.hold:
                return NavigationCommand(0.0, 0.0, Mode.FOLLOW, None, tuple(events))
            if advice.replan:
                self.navigator.plan_again("traffic: plan to the goal again")
                events += self.navigator.take_events()
                return NavigationCommand(0.0, 0.0, Mode.FOLLOW, None, tuple(events))
            if advice.detour is not None:
                events += self._carry_out(self.navigator.detour(advice.detour, "going aside")).events
            if advice.replan_around is not None:
                events += self._plan_around(pose, advice.replan_around)
            limit = advice.speed_limit
        follow = self.path_follower.compute(pose[0], pose[1], pose[2], scan, speed_limit=limit)
        if detour_done(traffic, self.navigator, follow.reached, stamp):
            return NavigationCommand(0.0, 0.0, Mode.FOLLOW, follow, tuple(events))
        request = self.navigator.followed(follow.reached, follow.replan, follow.message)
        if request is not None:
            events += self._carry_out(self._plan(request)).events
        events += self.navigator.take_events()
        mode = Mode.REACHED if follow.reached else Mode.FOLLOW
        return NavigationCommand(follow.v, follow.w, mode, follow, tuple(events))

    def _carry_out(self, decision: Decision) -> Decision:
        """Plan what the decision asks to, hand its path to the path follower; the decision to act on."""
        events = list(decision.events)
        while decision.plan is not None:
            decision = self._plan(decision.plan)
            events += decision.events
        if decision.path is not None:
            try:
                self.path_follower.set_path(decision.path)
            except PathError as error:
                self.path_follower.clear()
                decision = self.navigator.path_refused(str(error))
                events += decision.events
        return Decision(decision.mode, decision.controller, None, decision.path, decision.reason, tuple(events))

    def _plan_around(self, pose: tuple[float, float, float], marks: np.ndarray) -> list[str]:
        """Plan to the goal with `marks` (unmapped returns) on a copy of the costmap; the events."""
        goal = self.navigator.goal
        planner = self.planner.with_obstacles(marks, self.traffic.config.mark_radius)
        try:
            points = planner.plan((pose[0], pose[1]), goal)
        except PlanningError as error:
            self.traffic.replanned_around(marks, False)
            return [f"no way around the obstacle: {error}"]
        self.traffic.replanned_around(marks, True)
        return list(self._carry_out(self.navigator.adopt(points, "around an obstacle not on the map")).events)

    def _plan(self, request: PlanRequest) -> Decision:
        planner = self.planner if self.traffic is None else self.traffic.planner(self.planner)
        try:
            points = planner.plan(request.start, request.goal)
        except PlanningError as error:
            return self.navigator.planned(request, None, str(error), goal_refused=error.goal_refused)
        return self.navigator.planned(request, points)


# -- the loop with a simulator and a particle filter --------------------------------------------


@dataclass
class NavigationRun:
    """What one run did (times in simulated seconds)."""

    reached: bool = False
    """the true pose entered the world's goal region (where the run stops, as the demo's does), or the path
    follower said REACHED within that region."""
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


def run_navigation(
    sim, particle_filter, loop: NavigationLoop, limit: float = 600.0, max_collisions: int = 5
) -> NavigationRun:
    """Lockstep: each period the filter gets the odometry pose and the scan, the loop the estimate, the scan
    and the odometry twist, and its command advances the simulator by dt. Stops when the true pose enters the
    world's goal region, when the path follower says REACHED, at max_collisions, or at `limit` s."""
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
        command = loop.step(pose, estimate.localized, scan, *sim.odom_twist, sim.time)
        steps[command.mode] += 1
        if command.follow is not None and command.follow.state is State.TRACK and loop.followed_path is not None:
            result.cross_track.append(distance_to_path(loop.followed_path, truth.x, truth.y))
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
    result.localization_losses = loop.localization_losses
    result.plans = loop.plans
    result.planning_failures = list(loop.planning_failures)
    goal = loop.goal if loop.goal is not None else (math.nan, math.nan)
    result.goal_distance = math.hypot(truth.x - goal[0], truth.y - goal[1])
    result.estimate_error = error  # at the last observation
    result.steps = {mode.value: count for mode, count in steps.items()}
    return result
