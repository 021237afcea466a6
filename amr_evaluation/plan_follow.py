"""Plan on the map from the true pose, follow with pure pursuit on the true pose: the planner and the path
follower without localization (bench/bench_planning.py's closed loop, now an episode of amr_evaluation).

The world is rasterized at the planner configuration's ``resolution`` and planned on by the planner node's own
class (amr_planning.planner.Planner: its costmap, search and smoothing, from the same parameters); the path
follower answers each step with the true pose and the scan. When it asks for a new plan (blocked, strayed), the
planner plans again from where the robot is, as the planner node does, at most ``max_replans`` times. Stops at the
goal region, at the follower's REACHED, or at ``limit``. The loop is the lockstep harness (amr_util.harness) with one
part, the path follower on the true pose.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from amr_control.path_follower import PathFollower, State
from amr_control.path_follower_config import PathFollowerConfig
from amr_maps.rasterize import rasterize_world
from amr_planning.errors import PlanningError
from amr_planning.planner import Planner, PlannerConfig
from amr_simulation.simulator import Simulator
from amr_util.harness import Frame, Harness, OneRobot

MAX_REPLANS = 20


@dataclasses.dataclass
class PlanFollowRun:
    planned: bool
    reached: bool
    collisions: int
    time: float
    cross_track: float
    """m, mean of the follower's cross-track error while tracking (NaN: never tracked)."""
    message: str = ""
    replans: int = 0
    planning_time: float = 0.0
    """s of wall-clock time in A* and smoothing."""


def plan_and_follow(
    sim: Simulator,
    goal: tuple[float, float],
    follower_config: PathFollowerConfig | None = None,
    planner_config: PlannerConfig | None = None,
    limit: float = 600.0,
    max_replans: int = MAX_REPLANS,
) -> PlanFollowRun:
    """Run ``sim`` (its world, start and noise) to ``goal``; see the module docstring."""
    config = planner_config or PlannerConfig()
    planner = Planner(rasterize_world(sim.world, config.resolution), config)
    follower = PathFollower(follower_config or PathFollowerConfig())
    errors: list[float] = []
    replans = 0
    planning = [0.0]

    def plan(start) -> np.ndarray:
        began = time.perf_counter()
        try:
            return planner.plan(start, goal)
        finally:
            planning[0] += time.perf_counter() - began

    start = sim.pose
    try:
        follower.set_path(plan((start.x, start.y)))
    except PlanningError as error:
        return PlanFollowRun(False, False, 0, math.nan, math.nan, str(error), planning_time=planning[0])
    failure: list[str] = []

    def follow(frame: Frame) -> None:
        """The path follower on the true pose; a new plan from there when it asks for one."""
        nonlocal replans
        pose = sim.pose
        command = follower.compute(pose.x, pose.y, pose.theta, frame.observation.scan)
        if command.state is State.TRACK:
            errors.append(command.cross_track)
        if command.reached:
            frame.stop = "reached"
            return
        if command.replan:
            if replans == max_replans:
                frame.stop = "replans"
                return
            replans += 1
            try:
                follower.set_path(plan((pose.x, pose.y)))
            except PlanningError as error:
                failure.append(f"replan failed: {error}")
                frame.stop = "replan failed"
                return
        frame.command = (command.v, command.w)

    Harness(OneRobot(sim), [[follow]]).run(limit, lambda: "goal" if sim.goal_reached else None)
    if failure:
        return PlanFollowRun(True, False, sim.collisions, sim.time, math.nan, failure[0], replans, planning[0])
    message = "" if sim.goal_reached else f"stopped in {follower.state.value} at t={sim.time:.1f} s"
    if replans:
        message += f" ({replans} replans)"
    mean_error = float(np.mean(errors)) if errors else math.nan
    return PlanFollowRun(
        True, sim.goal_reached, sim.collisions, sim.time, mean_error, message.strip(), replans, planning[0]
    )
