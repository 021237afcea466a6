"""Several robots navigating in one world at library level: the simulator's Fleet in lockstep, and
per robot the navigation loop (amr_navigation.loop.NavigationLoop: explore, localize, plan, follow) with its
own particle filter, wall follower, path follower and traffic rules (amr_navigation.traffic), the robots'
traffic posts on one shared board.

Each period every robot's filter gets its odometry pose and scan, its loop the estimate, the scan and the
odometry twist; the commands of all robots then advance the fleet by dt together: the lockstep harness
(amr_util.harness) over the fleet, each robot's parts its filter (none with the truth) and its navigation.
`localization="truth"` gives each loop its true pose, localized from the start (the traffic rules' own tests);
`"filter"` (the default) runs a particle filter per robot, seeded per robot.

A robot's goal counts as reached when its true centre first enters its goal region (the simulator's latch);
the simulator runs with `stop_at_goal: false` so that a robot at its goal can still make way for another
(the traffic rules' passive robots). The run ends when every robot has reached its goal, or at the time
limit. A *false localized* is a step at which a robot's filter said localized with its estimate farther
than FALSE_LOCALIZED_ERROR from the true pose.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from amr_control.path_follower import PathFollower
from amr_control.path_follower_config import PathFollowerConfig
from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import WallFollowerConfig
from amr_maps.rasterize import rasterize_world
from amr_maps.world import World
from amr_navigation.fleet_coordinator import NONE, Route
from amr_navigation.fleet_planner_config import FleetPlannerConfig
from amr_navigation.loop import NavigationLoop
from amr_navigation.traffic import Traffic, TrafficConfig
from amr_navigation.traffic_board import TrafficBoard
from amr_planning.planner import Planner, PlannerConfig
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
from amr_simulation.fleet import Fleet
from amr_util.harness import Frame, Harness, Robots, localize

FALSE_LOCALIZED_ERROR = 0.3
"""m: an estimate said localized this far from the true pose is a false localized."""
LOCALIZATIONS = ("filter", "truth")
COORDINATIONS = ("rules", "plan")


@dataclass
class RobotRun:
    name: str
    reached: bool = False
    time_to_goal: float | None = None
    wall_collisions: int = 0
    robot_collisions: int = 0
    """times it began touching another robot."""
    first_localized: float | None = None
    false_localized_steps: int = 0
    falsely_localized: bool = False
    """at the last step (the run's events say when it began and ended)."""
    max_localized_error: float = 0.0
    withdrawals: int = 0
    """times the filter withdrew localized after declaring it."""
    unsure_time: float = 0.0
    """s simulated not localized after the first declaration (while unsure a robot posts no position on the
    traffic board: the others' right-of-way rules do not see it, only their LiDAR stop rule)."""
    longest_unsure: float = 0.0
    """s, the longest of those spans (one still open at the end counts up to the end)."""
    plans: int = 0
    stops: int = 0
    replans_around: int = 0
    yields: int = 0
    cannot_yield: int = 0
    distance: float = 0.0
    events: list[str] = field(default_factory=list)
    _unsure_since: float | None = field(default=None, repr=False)

    def note_localized(self, time: float, localized: bool, dt: float) -> None:
        """Count one step of `dt` s at `time` that the filter said `localized` (or not): the first declaration,
        withdrawals and the time unsure after the first declaration."""
        if localized:
            if self.first_localized is None:
                self.first_localized = time
            self._unsure_since = None
            return
        if self.first_localized is None:
            return
        if self._unsure_since is None:
            self._unsure_since = time
            self.withdrawals += 1
        self.unsure_time += dt
        self.longest_unsure = max(self.longest_unsure, time + dt - self._unsure_since)


@dataclass
class FleetRun:
    robots: list[RobotRun]
    time: float
    wall_time: float
    reason: str

    @property
    def reached(self) -> int:
        return sum(robot.reached for robot in self.robots)

    @property
    def robot_contacts(self) -> int:
        """robot-robot contacts (each counted once, not once per robot)."""
        return sum(robot.robot_collisions for robot in self.robots) // 2

    @property
    def wall_contacts(self) -> int:
        return sum(robot.wall_collisions for robot in self.robots)

    @property
    def withdrawals(self) -> int:
        """localized withdrawn after a declaration, all robots."""
        return sum(robot.withdrawals for robot in self.robots)

    @property
    def unsure_time(self) -> float:
        """s not localized after the first declaration, summed over the robots."""
        return sum(robot.unsure_time for robot in self.robots)

    @property
    def false_localized(self) -> int:
        """robots that were ever falsely localized."""
        return sum(robot.false_localized_steps > 0 for robot in self.robots)

    def as_dict(self) -> dict[str, Any]:
        return {
            "reached": self.reached,
            "robots": len(self.robots),
            "robot_contacts": self.robot_contacts,
            "wall_contacts": self.wall_contacts,
            "false_localized": self.false_localized,
            "time": self.time,
            "wall_time": self.wall_time,
            "reason": self.reason,
            "withdrawals": self.withdrawals,
            "unsure_time": self.unsure_time,
            "per_robot": [
                {k: v for k, v in vars(r).items() if k != "events" and not k.startswith("_")} for r in self.robots
            ],
        }


GRID_MAZES = ("perfect", "loops")
LATTICE_SPACING = 0.4
"""m, the lattice of the worlds that are not grid mazes (rooms with pillars, other layouts): two robot diameters
less a little."""


def lattice_spacing(data: dict, family: str) -> float:
    """m between the lattice points robots are planned on together (coordination "plan") in a world of
    amr_maps.maze_families: a grid maze's pitch (`grid_pitch`), else LATTICE_SPACING."""
    from amr_maps.maze_families import grid_pitch

    return grid_pitch(data) if family in GRID_MAZES else LATTICE_SPACING


def _particle_filter(parameters: dict, world: World, seed: int):
    from amr_localization.particle_filter import ParticleFilter
    from amr_localization.particle_filter_parameters import config_of

    params = {**parameters["particle_filter"], "seed": seed}
    return ParticleFilter(
        rasterize_world(world, params["map_resolution"]), config_of(params), range_max=params.get("laser_max_range")
    )


def run_fleet(
    world: World,
    parameters: dict | None = None,
    *,
    seed: int = 0,
    lidar_noise: float = 0.01,
    encoder_noise: float = 0.0,
    slip: float = 0.0,
    duration: float = 300.0,
    localization: str = "filter",
    traffic: TrafficConfig | None = None,
    use_traffic: bool = True,
    map_world: World | None = None,
    log: bool = False,
    coordination: str = "rules",
    lattice_spacing: float = 0.4,
) -> FleetRun:
    """Run every robot of `world` (its `robots` list, each with a goal) to its goal; see the module docstring.

    parameters: node name -> {parameter: value} for wall_follower, path_follower, planner, navigator and
    particle_filter (amr_evaluation.configs.resolve("navigation", "default")[1] when None), and optionally
    fleet_planner (with "plan": the fleet_planner node's parameters, its defaults for those not given). map_world: the
    world the robots' map is made of (planner, filter; default `world`): one without some of `world`'s solids
    gives obstacles that are not on the map.

    coordination: "rules" (each robot's navigation loop with the traffic rules) or "plan" (the fleet planned
    together as the fleet_planner node plans it: amr_navigation.fleet_coordinator.FleetCoordinator fed every
    robot's pose, its navigator's verdict (confident) and goal each step, on a lattice `lattice_spacing` m apart;
    each robot's path follower driven along the route it was last told by its navigation loop's core, as the
    navigator node's coordination "plan" does).
    With "plan" and the particle filters, the robots go as with "rules" (explore until localized, then the traffic
    rules) until every robot's navigator is confident at once; the fleet is then planned from the estimates, and a
    robot whose navigator is no longer confident goes on by odometry from its last sure estimate until it is sure
    again."""
    if localization not in LOCALIZATIONS:
        raise ValueError(f"localization {localization!r}: expected one of {', '.join(LOCALIZATIONS)}")
    if coordination not in COORDINATIONS:
        raise ValueError(f"coordination {coordination!r}: expected one of {', '.join(COORDINATIONS)}")

    if parameters is None:
        from amr_evaluation.configs import resolve

        parameters = resolve("navigation", "default")[1]
    missing = [spec.name or "(unnamed)" for spec in world.fleet if spec.goal is None]
    if missing:
        raise ValueError(f"{world.source}: robots without a goal: {', '.join(missing)}")
    began = time.perf_counter()
    wall = WallFollowerConfig.from_params(parameters["wall_follower"])
    follower = PathFollowerConfig.from_params(parameters["path_follower"])
    planner_config = PlannerConfig.from_params({**parameters["planner"], "world": ""})
    known = map_world if map_world is not None else world
    planner = Planner(rasterize_world(known, planner_config.resolution), planner_config)
    fleet = Fleet(
        world,
        SimulationConfig(
            dt=follower.dt,
            seed=seed,
            stop_at_goal=False,
            lidar=LidarConfig(noise_std=lidar_noise),
            encoders=EncoderConfig(noise=encoder_noise, slip=slip),
        ),
    )
    board = TrafficBoard()
    loops, filters, runs = [], [], []
    replan_distance = float(parameters["navigator"]["replan_distance"])
    confidences = {  # the navigator's confidence rule, as the node reads it
        key: float(parameters["navigator"][key])
        for key in ("drive_confidence", "release_confidence")
        if key in parameters["navigator"]
    }
    for index, robot in enumerate(fleet.robots):
        rules = Traffic(robot.name, index, board, traffic) if use_traffic else None
        loops.append(
            NavigationLoop(
                planner,
                WallFollower(wall),
                PathFollower(follower),
                (robot.goal.x, robot.goal.y),
                replan_distance,
                traffic=rules,
                **confidences,
            )
        )
        filters.append(_particle_filter(parameters, known, seed * 1000 + index) if localization == "filter" else None)
        runs.append(RobotRun(robot.name))
    planned = coordination == "plan"
    coordinator = (
        FleetPlannerConfig.from_params(
            {
                **parameters.get("fleet_planner", {}),
                "robots": [robot.name for robot in fleet.robots],
                "lattice_spacing": lattice_spacing,
                "follower_speed": follower.linear_speed,
            }
        ).coordinator([robot.name for robot in fleet.robots])
        if planned
        else None
    )
    """with "plan": the fleet_planner node's logic (when to plan, what each robot is told, routes renewed before they
    expire), made from its parameters as the node makes it."""
    if planned:
        coordinator.set_costmap(planner.costmap)
    told: dict[str, Route] = {}
    """with "plan": what each robot was last told (NONE or none: the traffic rules)."""

    def all_reached() -> str | None:
        for robot, run in zip(fleet.robots, runs, strict=True):
            if robot.goal_reached and not run.reached:
                run.reached, run.time_to_goal = True, fleet.time
        return "every robot reached its goal" if all(run.reached for run in runs) else None

    def navigate(robot, loop: NavigationLoop, run: RobotRun):
        """A part: the robot's estimate (its filter's, or the truth) to its navigation loop (with the fleet plan's
        coordinator first, coordination "plan"), the loop's command to the robot; the run's figures and events."""

        def part(frame: Frame) -> None:
            observation = frame.observation
            scan = observation.scan
            truth = robot.pose
            confidence = None
            if frame.estimate is None:
                pose, localized = (truth.x, truth.y, truth.theta), True
            else:
                estimate = frame.estimate
                pose, localized = (estimate.pose.x, estimate.pose.y, estimate.pose.theta), estimate.localized
                confidence = estimate.confidence
            false = False
            run.note_localized(fleet.time, localized, follower.dt)
            if localized:
                error = math.hypot(pose[0] - truth.x, pose[1] - truth.y)
                run.max_localized_error = max(run.max_localized_error, error)
                if error > FALSE_LOCALIZED_ERROR:
                    run.false_localized_steps += 1
                    false = True
            odometry = observation.odometry if planned else None
            if planned:  # the navigator node's coordination "plan", the fleet_planner node's coordinator
                driving = loop.driving_pose(pose, localized, odometry, confidence)  # the pose its status carries
                confident = loop.confident(localized, confidence)  # ... and its verdict (NavigatorStatus.confident)
                routes = coordinator.observe(
                    robot.name, fleet.time, driving[0], driving[1], confident, (robot.goal.x, robot.goal.y)
                )
                told.update({**coordinator.renewals(), **routes})  # as the node publishes them
                run.events.extend(f"{fleet.time:.2f} {event}" for event in coordinator.take_events())
                if coordinator.plan_due():
                    told.update(coordinator.hold())
                    told.update(coordinator.plan())
                    run.events.append(
                        f"{fleet.time:.2f} fleet plan {coordinator.plans}: " + (told[robot.name].reason or "made")
                    )
            route = told.get(robot.name)
            command = loop.step(
                pose,
                localized,
                scan,
                *observation.twist,
                observation.stamp,
                confidence=confidence,
                route=route,
                odometry=odometry,
            )
            if route is not None and route.state != NONE:
                pose = driving  # unsure: on by odometry from the last sure estimate
            if false != run.falsely_localized:  # the episode's own events: when a false localized begins and ends
                run.falsely_localized = false
                event = (
                    f"falsely localized: estimate ({pose[0]:.2f}, {pose[1]:.2f}) is {error:.2f} m from the "
                    f"true pose ({truth.x:.2f}, {truth.y:.2f})"
                    if false
                    else "no longer falsely localized"
                )
                command = replace(command, events=command.events + (event,))
            if log:
                for event in command.events:
                    print(f"{fleet.time:7.2f} {robot.name}: {event}")
            run.events.extend(f"{fleet.time:.2f} {event}" for event in command.events)
            frame.command = (command.v, command.w)

        return part

    parts = [
        ([] if pf is None else [localize(pf)]) + [navigate(robot, loop, run)]
        for robot, loop, pf, run in zip(fleet.robots, loops, filters, runs, strict=True)
    ]
    reason = Harness(Robots(fleet), parts).run(duration, all_reached) or f"time limit {duration:g} s"
    for robot, loop, run in zip(fleet.robots, loops, runs, strict=True):
        run.wall_collisions = robot.wall_collisions
        run.robot_collisions = sum(robot.robot_collisions.values())
        run.plans = loop.plans
        trajectory = robot.trajectory
        steps = np.diff(trajectory[:, :2], axis=0)
        run.distance = float(np.nansum(np.hypot(steps[:, 0], steps[:, 1])))
        if loop.traffic is not None:
            counters = loop.traffic.counters
            run.stops, run.replans_around, run.yields, run.cannot_yield = (
                counters.stops,
                counters.replans_around,
                counters.yields,
                counters.cannot_yield,
            )
    return FleetRun(runs, fleet.time, time.perf_counter() - began, reason)
