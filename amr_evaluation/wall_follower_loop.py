"""One library-level closed-loop run of the wall follower, and its figures.

The wall-follower episode of amr_evaluation (episode.py) and bench/bench_wall_follower_families.py run it.

The simulator library and the controller in lockstep, as tests/control/test_closed_loop.py
does (minus the synchronizer: lockstep stamps are identical, so every pair is the step's own). The controller reads
the scan as the simulator node's LaserScan carries it (float32 ranges and geometry) and its time as the stamp does
(amr_evaluation.episode.AsSent), so that the run is the ROS stack's to the step: the lockstep harness
(amr_util.harness) over AsSent(simulator), with two parts, the controller and the figures' record.
Options the ROS path has and the library loop lacks are emulated here:

* ``scan_period``: the LiDAR scans only every that many seconds (LDS-01: 0.2 s, 5 Hz); as
  in the node's timer architecture, the controller computes on each new scan and the last
  command is held in between.
* ``outlier_rate``: each beam is, with this probability, replaced by a spurious short return
  (uniform between range_min and 1 m), the single-beam outliers of a real LiDAR.

Figures: goal reached and when, collisions, stalls (amr_evaluation.figures: 30 s without entering
a 0.25 m cell not visited before), time in each state, and the wall distance error two ways:
``wall_error_run``, the MIT RSS wall-follower lab metric, is the mean over the whole run of
|d - target| with d the true distance from the LiDAR to the nearest wall on the followed side
(closest points seen between 30 and 150 deg off the heading, capped at 1 m: searching,
turning and crossing rooms count); ``wall_error_following`` is the mean of the controller's
own |d - target| while it is in FOLLOW (the figure reported before). With a ``grid``
(amr_maps.maze_route.MazeGrid of a grid maze), ``route`` is the sequence of cells entered.
"""

from __future__ import annotations

import dataclasses
import math
from collections import Counter

import numpy as np

from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import WallFollowerConfig
from amr_evaluation.episode import AsSent
from amr_evaluation.figures import path_figures
from amr_maps.maze_route import MazeGrid, cell_route
from amr_maps.world import World
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
from amr_simulation.render import save_png
from amr_simulation.simulator import Simulator
from amr_util.geometry import wrap_angle
from amr_util.harness import Frame, Harness, OneRobot

ERROR_CAP = 1.0  # m


@dataclasses.dataclass
class RunResult:
    goal: bool | None  # None: the world has no goal
    time: float
    collisions: int
    stalls: int
    mean_speed: float
    distance: float  # m, ground truth
    state_time: dict[str, float]  # fraction of the run in each state
    wall_error_run: float
    wall_error_following: float
    commands_with_issues: int
    route: list[tuple[int, int]] | None = None
    """the grid cells entered, in order (amr_maps.maze_route.cell_route), when run with a ``grid``"""


def run(
    world: World,
    config: WallFollowerConfig,
    seconds: float = 600.0,
    lidar_noise: float = 0.01,
    encoder_noise: float = 0.0,
    slip: float = 0.0,
    seed: int = 0,
    beams: int = 240,
    scan_period: float | None = None,
    outlier_rate: float = 0.0,
    render_path: str | None = None,
    grid: MazeGrid | None = None,
) -> RunResult:
    sim = Simulator(
        world,
        SimulationConfig(
            dt=config.dt,
            seed=seed,
            lidar=LidarConfig(beams=beams, noise_std=lidar_noise),
            encoders=EncoderConfig(noise=encoder_noise, slip=slip),
        ),
    )
    follower = WallFollower(config)
    lidar = sim.lidar
    outliers = np.random.default_rng([seed, 14])
    every = 1 if scan_period is None else max(1, round(scan_period / config.dt))
    states: Counter[str] = Counter()
    following_errors, run_errors = [], []
    faces = world.faces
    command, issues = None, 0

    def follow(frame: Frame) -> None:
        """The wall follower on each new scan (every ``every`` steps), its last command held in between."""
        nonlocal command, issues
        if sim.steps % every == 0:
            observation = frame.observation
            ranges = np.array(observation.scan.ranges)
            if outlier_rate > 0.0:
                hit = outliers.random(len(ranges)) < outlier_rate
                ranges[hit] = outliers.uniform(lidar.range_min, 1.0, int(hit.sum()))
            scan = dataclasses.replace(observation.scan, ranges=ranges)
            command = follower.compute(scan, *observation.twist, observation.stamp)
            issues += not command.ok
            if follower.state == "FOLLOW":
                following_errors.append(abs(follower.measurements.wall_distance - config.target_wall_distance))
        frame.command = (command.v, command.w)

    def record(frame: Frame) -> None:
        states[follower.state] += 1
        run_errors.append(
            abs(
                _side_wall_distance(faces, sim.pose, config.lidar_x, follower.followed_wall)
                - config.target_wall_distance
            )
        )

    # the scan and the time as the nodes read them
    Harness(OneRobot(AsSent(sim)), [[follow, record]]).run(seconds, lambda: "goal" if sim.goal_reached else None)

    if render_path is not None:
        save_png(sim, render_path)
    path = path_figures(sim.trajectory, config.dt)
    distance = path["distance"]
    total = sum(states.values()) or 1
    return RunResult(
        goal=sim.goal_reached if sim.goal is not None else None,
        time=sim.time,
        collisions=sim.collisions,
        stalls=path["stalls"],
        mean_speed=distance / max(sim.time, 1e-9),
        distance=distance,
        state_time={state: count / total for state, count in states.items()},
        wall_error_run=float(np.mean(run_errors)) if run_errors else math.nan,
        wall_error_following=float(np.mean(following_errors)) if following_errors else math.nan,
        commands_with_issues=issues,
        route=None if grid is None else cell_route(grid, sim.trajectory[:, :2]),
    )


def _side_wall_distance(faces: np.ndarray, pose, lidar_x: float, side: str) -> float:
    """True distance from the LiDAR to the nearest wall point 30-150 deg off the heading on ``side``."""
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    p = np.array([pose.x + lidar_x * c, pose.y + lidar_x * s])
    a, b = faces[:, :2], faces[:, 2:]
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1), 1e-18), 0.0, 1.0)
    v = a + t[:, None] * ab - p
    d = np.hypot(v[:, 0], v[:, 1])
    bearing = np.arctan2(v[:, 1], v[:, 0]) - pose.theta
    bearing = wrap_angle(bearing)
    sign = -1.0 if side == "right" else 1.0
    on_side = (sign * bearing >= math.radians(30.0)) & (sign * bearing <= math.radians(150.0))
    return float(min(d[on_side].min(), ERROR_CAP)) if on_side.any() else ERROR_CAP
