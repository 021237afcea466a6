"""The navigation loop without ROS: the navigator core's effects carried out with the controller and planner objects
in process, one command per observation, as the `maze_navigation` stack carries them out with nodes.

`NavigationLoop.step` takes one observation (the localizer's estimate, its confidence, the scan, the odometry) and
returns the command that answers it. Everything that decides is the navigator core's
(amr_navigation.navigator_core.NavigatorCore, which the navigator node runs too): the loop answers its calls (a
plan: Planner.plan, as the planner node's ~/plan: the loop's Planner is the robot's planner node, and the core
reads its costmap for the traffic rules as the navigator node reads the planner's shared one; a path to hand over:
PathFollower.set_path, as the path follower's ~/follow_path), asks the controller the decision names for the
command (with the decision's speed limit), and gives the path follower's report back to the core. A localized
observation nobody drives (no goal, no path, reached) gets a zero command here, as the navigator node answers it
with `nobody_drives: zero`.

`run_navigation` drives a simulator and a particle filter with a NavigationLoop (the filter's estimate is its
pose in the map moved by the odometry since its last update, which is what the node publishes on /pose)
until the goal, a number of collisions, or a time limit; bench/bench_navigation.py runs it. It is the lockstep
harness (amr_util.harness) with two parts, the filter and the loop. The simulator is
any object with the Simulator's observation interface (pose, odom_pose, odom_twist, ranges, lidar, time,
goal, goal_reached, collisions, step): this package imports no simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from amr_control.path_follower import FollowCommand, PathError, PathFollower, State
from amr_control.wall_follower import WallFollower
from amr_navigation.fleet_coordinator import Route
from amr_navigation.navigator import DEFAULT_REPLAN_DISTANCE, Controller, Decision, Mode, Navigator
from amr_navigation.navigator_core import (
    DEFAULT_DRIVE_CONFIDENCE,
    DEFAULT_RELEASE_CONFIDENCE,
    FollowerReport,
    NavigatorCore,
    Observation,
    Outcome,
    PlanAnswer,
    PlanCall,
    run_job,
)
from amr_navigation.traffic import Traffic
from amr_planning.errors import PlanningError
from amr_planning.planner import Planner, distance_to_path
from amr_util.harness import Frame, Harness, OneRobot, localize
from amr_util.scan import ScanData


@dataclass(frozen=True)
class NavigationCommand:
    v: float
    w: float
    mode: Mode
    follow: FollowCommand | None = None
    """the path follower's command (FOLLOW, REACHED)."""
    events: tuple[str, ...] = ()
    """what happened at this observation: planned, replanned, localization lost, no path, ..."""
    decision: Decision | None = None
    """the core's decision for the observation (what the navigator node publishes on ~/status)."""
    speed_limit: float | None = None
    """the speed limit the path follower drove with (traffic rules; None: none)."""
    confidence: float = 0.0
    """the localizer's confidence as the navigator read it (ConfidenceGate.confidence) ..."""
    confident: bool = False
    """... and the navigator's verdict: sure enough to drive a path (both on the node's ~/status)."""


class NavigationLoop:
    """A NavigatorCore with its planner and controllers in process."""

    def __init__(
        self,
        planner: Planner,
        wall_follower: WallFollower,
        path_follower: PathFollower,
        goal: tuple[float, float] | None,
        replan_distance: float = DEFAULT_REPLAN_DISTANCE,
        traffic: Traffic | None = None,
        drive_confidence: float = DEFAULT_DRIVE_CONFIDENCE,
        release_confidence: float = DEFAULT_RELEASE_CONFIDENCE,
    ) -> None:
        self.wall_follower = wall_follower
        self.path_follower = path_follower
        self.core = NavigatorCore(
            Navigator(goal, replan_distance),
            traffic=traffic,
            follower_speed=path_follower.config.linear_speed,
            drive_confidence=drive_confidence,
            release_confidence=release_confidence,
        )
        self.planner = planner
        self._route: Route | None = None

    @property
    def planner(self) -> Planner:
        """the robot's planner (the planner node's part): it answers the core's plans, and its costmap is the one the
        core's traffic rules read."""
        return self._planner

    @planner.setter
    def planner(self, planner: Planner) -> None:
        self._planner = planner
        self.core.set_map(planner.costmap if planner is not None else None)

    # what the bench and the tests read
    @property
    def navigator(self) -> Navigator:
        return self.core.navigator

    @property
    def traffic(self) -> Traffic | None:
        """the traffic rules among other robots (amr_navigation.traffic); None: a robot alone."""
        return self.core.traffic

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
        self.core.set_goal(goal)

    def confident(self, localized: bool, confidence: float | None = None) -> bool:
        """The navigator's verdict on this observation, without taking it: what its status will say (the fleet
        planner's coordinator plans when every robot's says so)."""
        return self.core.gate.peek(localized, confidence)

    def driving_pose(self, pose, localized: bool, odometry, confidence: float | None = None):
        """The pose this robot drives by on a fleet route for this observation (see NavigatorCore.driving_pose)."""
        return self.core.driving_pose(pose, localized, odometry, confidence)

    def step(
        self,
        pose: tuple[float, float, float],
        localized: bool,
        scan: ScanData,
        odometry_v: float,
        odometry_w: float,
        stamp: float,
        *,
        confidence: float | None = None,
        route: Route | None = None,
        odometry: tuple[float, float, float] | None = None,
    ) -> NavigationCommand:
        """The command for one observation. confidence: the localizer's (None: from localized alone); route: the
        fleet planner's latest word for this robot (None: its own planning); odometry: the observation's odometry
        pose (on a route, what the pose to drive by moves on with while the localizer is unsure)."""
        events: list[str] = []
        if route is not self._route:
            self._route = route
            events += self.core.set_route(route)
        observation = Observation(stamp, tuple(pose), bool(localized), confidence, odometry, scan)
        outcome = run_job(self.core.step(observation), self._answer)
        events += outcome.events
        decision = outcome.decision
        gate = {"confidence": outcome.confidence, "confident": outcome.confident}
        if decision.controller is Controller.WALL_FOLLOWER:
            command = self.wall_follower.compute(scan, odometry_v, odometry_w, stamp)
            return NavigationCommand(command.v, command.w, decision.mode, None, tuple(events), decision, **gate)
        if decision.controller is Controller.NONE:
            return NavigationCommand(0.0, 0.0, decision.mode, None, tuple(events), decision, **gate)
        x, y, theta = outcome.pose
        follow = self.path_follower.compute(x, y, theta, scan, speed_limit=outcome.speed_limit)
        report = self.core.report(
            FollowerReport(stamp, follow.reached, follow.replan, follow.message, follow.state.value)
        )
        if not isinstance(report, Outcome):
            report = run_job(report, self._answer)
        events += report.events
        if report.detour_end:
            return NavigationCommand(
                0.0, 0.0, Mode.FOLLOW, follow, tuple(events), decision, outcome.speed_limit, **gate
            )
        reached = follow.reached and not self.navigator.on_detour
        mode = Mode.REACHED if reached else decision.mode
        return NavigationCommand(follow.v, follow.w, mode, follow, tuple(events), decision, outcome.speed_limit, **gate)

    def _answer(self, call):
        """A call of the core answered in process: a plan (Planner.plan), or a path handed to the path follower."""
        if isinstance(call, PlanCall):
            planner = self.planner
            if call.marks is not None and len(call.marks):
                planner = planner.with_obstacles(call.marks, call.mark_radius)
            try:
                return PlanAnswer(planner.plan(call.start, call.goal))
            except PlanningError as error:
                return PlanAnswer(None, str(error), error.goal_refused)
        try:
            self.path_follower.set_path(call.path)
        except PathError as error:
            self.path_follower.clear()
            return str(error)
        return ""


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

    def stop() -> str | None:
        if sim.goal_reached:
            result.reached = True
            return "goal region reached"
        if sim.collisions >= max_collisions:
            return f"{sim.collisions} collisions"
        return None

    def navigate(frame: Frame) -> None:
        """The filter's estimate to the navigation loop, its command to the robot; the figures against the truth."""
        nonlocal error
        truth, estimate, observation = sim.pose, frame.estimate, frame.observation
        pose = (estimate.pose.x, estimate.pose.y, estimate.pose.theta)
        error = math.hypot(pose[0] - truth.x, pose[1] - truth.y)
        if estimate.localized:
            if result.first_localized is None:
                result.first_localized = observation.stamp
            result.max_localized_error = max(result.max_localized_error, error)
        command = loop.step(
            pose,
            estimate.localized,
            observation.scan,
            *observation.twist,
            observation.stamp,
            confidence=estimate.confidence,
        )
        steps[command.mode] += 1
        if command.follow is not None and command.follow.state is State.TRACK and loop.followed_path is not None:
            result.cross_track.append(distance_to_path(loop.followed_path, truth.x, truth.y))
            result.estimated_cross_track.append(command.follow.cross_track)
        if command.mode is Mode.REACHED:
            result.follower_reached = True
            result.reached = sim.goal is None or sim.goal.contains(truth.x, truth.y)
            frame.stop = "goal reached" if result.reached else "the follower stopped outside the goal region"
            return
        frame.command = (command.v, command.w)

    harness = Harness(OneRobot(sim), [[localize(particle_filter), navigate]])
    result.reason = harness.run(limit, stop) or f"time limit {limit:.0f} s"
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
