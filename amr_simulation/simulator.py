"""The simulator: a world, a TurtleBot3-like robot, its encoders and LiDAR, stepped by (v, w).

Each step(v, w) advances exactly config.dt seconds:
  1. (v, w) -> wheel speeds by the diff-drive inverse kinematics, saturated
     keeping the curvature (amr_util.diff_drive.DiffDrive.command);
  2. slip takes its share of each wheel's ground speed; the body follows the
     resulting twist in pymunk, in substeps, stopped and deflected by walls;
  3. the encoders report the commanded wheel rotation (plus noise) and the
     encoder odometry integrates it;
  4. the LiDAR scans from the new pose; the goal region is checked.
After the goal is reached the robot ignores commands and stays put until reset (unless stop_at_goal is false).

A Simulator is a Fleet (amr_simulation.fleet) of the world's one robot, seen as that robot: a world
with a `robots` list of several robots is simulated by a Fleet.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from amr_maps.world import Goal, World, load_world, resolve_world_path
from amr_simulation.config import LidarConfig, SimulationConfig
from amr_simulation.errors import SimulationError
from amr_simulation.fleet import Fleet, SimulatedRobot
from amr_util.diff_drive import DiffDrive
from amr_util.geometry import Pose2D


def _robot_property(name: str) -> property:
    """The property `name` of the simulator's one robot."""
    return property(lambda self: getattr(self._fleet.robots[0], name), doc=getattr(SimulatedRobot, name).__doc__)


class Simulator:
    """One robot in one world; no ROS. Build with Simulator(world, config) or from_params."""

    def __init__(self, world: World, config: SimulationConfig | None = None) -> None:
        if len(world.fleet) != 1:
            names = ", ".join(spec.name for spec in world.fleet)
            raise SimulationError(
                f"{world.source} lists {len(world.fleet)} robots ({names}): the one-robot "
                "Simulator cannot run it, amr_simulation.fleet.Fleet does"
            )
        self._fleet = Fleet(world, config)

    @classmethod
    def from_params(
        cls, params: Mapping[str, Any], worlds_dirs: Sequence[str | Path] = (), ignore: Iterable[str] = ()
    ) -> Simulator:
        """Build from a node's flat parameter dict; the world name is looked up in worlds_dirs (default:
        amr_maps.world.world_search_path())."""
        config = SimulationConfig.from_params(params, ignore)
        return cls(load_world(resolve_world_path(config.world, worlds_dirs)), config)

    # -- control ---------------------------------------------------------------------------

    def reset(self) -> None:
        """Back to the start pose at time 0, counters cleared, random streams reseeded."""
        self._fleet.reset()

    def retune(self, config: SimulationConfig) -> None:
        """Take new sensor noise and slip (a live parameter change); the random streams go on.

        Raises SimulationError if anything else differs: that needs a new simulator.
        """
        self._fleet.retune(config)

    def set_pose(self, x: float, y: float, theta: float) -> None:
        """Teleport the robot (at rest); the encoder odometry restarts from the new pose.

        Raises SimulationError if the pose is not finite, lies outside the world's bounds (where
        no wall could ever come within LiDAR range), or the robot's footprint would overlap a wall.
        """
        self._fleet.set_pose(x, y, theta)

    def step(self, v: float, w: float) -> None:
        """Advance one period dt with the commanded linear (m/s) and angular (rad/s) velocity."""
        if not (math.isfinite(v) and math.isfinite(w)):
            raise SimulationError(f"step: command must be finite, got v={v}, w={w}")
        self._fleet.step([(v, w)])

    def beacon_reading(self) -> tuple[np.ndarray, np.ndarray, float] | None:
        """(beacon positions (B, 2), noisy ranges (B,), noisy compass heading) at the true pose, each call
        a new draw; None when the world declares no beacons."""
        return self._fleet.robots[0].beacon_reading()

    # -- the world -------------------------------------------------------------------------

    @property
    def fleet(self) -> Fleet:
        """The Fleet of one robot this simulator steps."""
        return self._fleet

    @property
    def world(self) -> World:
        return self._fleet.world

    @property
    def config(self) -> SimulationConfig:
        return self._fleet.config

    @property
    def drive(self) -> DiffDrive:
        return self._fleet.drive

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) where the robot may be: the walls' extent plus the LiDAR range."""
        return self._fleet.bounds

    @property
    def time(self) -> float:
        """Simulated seconds since the last reset."""
        return self._fleet.time

    @property
    def steps(self) -> int:
        return self._fleet.steps

    @property
    def lidar(self) -> LidarConfig:
        """Beam geometry for sensor_msgs/LaserScan: angle_min, angle_increment, range_min, ..."""
        return self._fleet.lidar

    @property
    def goal(self) -> Goal | None:
        return self._fleet.robots[0].goal

    @property
    def _physics(self):  # the pymunk world (tests probe its clearance)
        return self._fleet._physics

    @property
    def _lidar(self):  # the robot's LiDAR (tests draw extra scans from it)
        return self._fleet.robots[0]._lidar

    # -- the robot -------------------------------------------------------------------------

    pose: Pose2D = _robot_property("pose")
    twist = _robot_property("twist")
    wheel_speeds = _robot_property("wheel_speeds")
    encoder_increments = _robot_property("encoder_increments")
    odom_pose = _robot_property("odom_pose")
    odom_twist = _robot_property("odom_twist")
    ranges = _robot_property("ranges")
    sensor_pose = _robot_property("sensor_pose")
    collisions = _robot_property("collisions")
    in_contact = _robot_property("in_contact")
    goal_reached = _robot_property("goal_reached")
    trajectory = _robot_property("trajectory")

    # -- rendering -------------------------------------------------------------------------

    def draw(self, ax: Any) -> None:
        """Draw world, trajectory, robot and scan onto a matplotlib Axes."""
        from amr_simulation.render import draw_simulation  # matplotlib only when drawing

        draw_simulation(ax, self)

    def render(self, path: str | Path, dpi: int = 120) -> Path:
        """Write a PNG of the current state; returns its path."""
        from amr_simulation.render import save_png  # matplotlib only when drawing

        return save_png(self, path, dpi=dpi)
