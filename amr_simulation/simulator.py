"""The simulator: a world, a TurtleBot3-like robot, its encoders and LiDAR, stepped by (v, w).

Each step(v, w) advances exactly config.dt seconds:
  1. (v, w) -> wheel speeds by the diff-drive inverse kinematics, saturated
     keeping the curvature (amr_kinematics.DiffDrive.command);
  2. slip takes its share of each wheel's ground speed; the body follows the
     resulting twist in pymunk, in substeps, stopped and deflected by walls;
  3. the encoders report the commanded wheel rotation (plus noise) and the
     encoder odometry integrates it;
  4. the LiDAR scans from the new pose; the goal region is checked.
After the goal is reached the robot ignores commands and stays put until reset.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import Goal, World, load_world, resolve_world_path
from amr_simulation.beacon_sensor import BeaconSensor
from amr_simulation.config import LidarConfig, SimulationConfig
from amr_simulation.encoders import Encoders
from amr_simulation.errors import SimulationError
from amr_simulation.lidar import Lidar
from amr_simulation.physics import WALLS_ONLY, Physics, substeps
from amr_simulation.raycast import PymunkRayCaster
from amr_util.diff_drive import DiffDrive
from amr_util.geometry import Pose2D, arc_twist, chord_factor, integrate_arc, wrap_angle


class Simulator:
    """One robot in one world; no ROS. Build with Simulator(world, config) or from_params."""

    def __init__(self, world: World, config: SimulationConfig | None = None) -> None:
        self.world = world
        self.config = config or SimulationConfig()
        robot = self.config.robot
        self.drive = DiffDrive(
            wheel_radius=robot.wheel_radius,
            track=robot.track,
            max_wheel_speed=robot.max_wheel_speed,
            max_linear=robot.max_linear,
            max_angular=robot.max_angular,
        )
        self._numpy_caster = NumpyRayCaster(world.faces)
        self.reset()

    @classmethod
    def from_params(
        cls, params: Mapping[str, Any], worlds_dirs: Sequence[str | Path] = (), ignore: Iterable[str] = ()
    ) -> "Simulator":
        """Build from a node's flat parameter dict; the world name is looked up in worlds_dirs (default:
        amr_maps.world.world_search_path())."""
        config = SimulationConfig.from_params(params, ignore)
        return cls(load_world(resolve_world_path(config.world, worlds_dirs)), config)

    # -- control ---------------------------------------------------------------------------

    def reset(self) -> None:
        """Back to the start pose at time 0, counters cleared, random streams reseeded."""
        self._physics = Physics(self.world.polygons, self.config.robot.radius)
        lidar_seed, encoder_seed, beacon_seed = np.random.SeedSequence(self.config.seed).spawn(3)
        caster = (
            self._numpy_caster
            if self.config.lidar.method == "numpy"
            else PymunkRayCaster(self._physics.space, WALLS_ONLY)
        )
        self._lidar = Lidar(self.config.lidar, caster, np.random.default_rng(lidar_seed))
        self._encoders = Encoders(self.config.encoders, np.random.default_rng(encoder_seed))
        self._beacons = (BeaconSensor(self.world.beacons, self.config.beacons, np.random.default_rng(beacon_seed))
                         if self.world.beacons else None)
        self._steps = 0
        self._trajectory: list[tuple[float, float, float]] = []
        self.set_pose(*(self.config.start or self.world.start))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) where the robot may be: the walls' extent plus the LiDAR range."""
        margin = self.config.lidar.range_max
        xmin, ymin, xmax, ymax = self.world.bounds
        return xmin - margin, ymin - margin, xmax + margin, ymax + margin

    def retune(self, config: SimulationConfig) -> None:
        """Take new sensor noise and slip (a live parameter change); the random streams go on.

        Raises SimulationError if anything else differs: that needs a new simulator.
        """
        changed = self.config.structural_changes(config)
        if changed:
            live = ", ".join(spec.name for spec in config.parameter_specs() if spec.live)
            raise SimulationError(f"retune: {', '.join(changed)} cannot change on a running simulator (only {live})")
        self.config = config
        self._lidar.config = config.lidar
        self._encoders.config = config.encoders
        if self._beacons is not None:
            self._beacons.config = config.beacons

    def beacon_reading(self) -> tuple[np.ndarray, np.ndarray, float] | None:
        """(beacon positions (B, 2), noisy ranges (B,), noisy compass heading) at the true pose, each call
        a new draw; None when the world declares no beacons."""
        if self._beacons is None:
            return None
        ranges, compass = self._beacons.measure(self.pose)
        return self._beacons.positions, ranges, compass

    def set_pose(self, x: float, y: float, theta: float) -> None:
        """Teleport the robot (at rest); the encoder odometry restarts from the new pose.

        Raises SimulationError if the pose is not finite, lies outside the world's bounds (where
        no wall could ever come within LiDAR range), or the robot's footprint would overlap a wall.
        """
        if not all(map(math.isfinite, (x, y, theta))):
            raise SimulationError(f"set_pose: pose must be finite, got ({x}, {y}, {theta})")
        xmin, ymin, xmax, ymax = self.bounds
        if not (xmin <= x <= xmax and ymin <= y <= ymax):
            raise SimulationError(
                f"set_pose: ({x:.3f}, {y:.3f}) lies outside the bounds of {self.world.source}: "
                f"x in [{xmin:.3f}, {xmax:.3f}], y in [{ymin:.3f}, {ymax:.3f}] (its walls plus the "
                f"LiDAR range, {self.config.lidar.range_max} m)")
        clearance = self._physics.clearance(x, y)
        if clearance < self.config.robot.radius:
            raise SimulationError(
                f"set_pose: the robot (radius {self.config.robot.radius} m) at ({x:.3f}, {y:.3f}) "
                f"overlaps a wall of {self.world.source} (clearance {clearance:.3f} m)"
            )
        self._physics.place(x, y, theta)
        self._pose = self._odom = Pose2D(x, y, wrap_angle(theta))
        self._twist = (0.0, 0.0, 0.0)
        self._odom_twist = (0.0, 0.0)
        self._wheel_speeds = (0.0, 0.0)
        self._increments = (0.0, 0.0)
        if self._trajectory:
            self._trajectory.append((math.nan, math.nan, math.nan))  # a break in the drawn path
        self._trajectory.append((x, y, 0.0))
        self._goal_reached = self.world.goal is not None and self.world.goal.contains(x, y)
        self._ranges = self._lidar.scan(self._pose)

    def step(self, v: float, w: float) -> None:
        """Advance one period dt with the commanded linear (m/s) and angular (rad/s) velocity."""
        if not (math.isfinite(v) and math.isfinite(w)):
            raise SimulationError(f"step: command must be finite, got v={v}, w={w}")
        if self._goal_reached:
            v = w = 0.0
        dt = self.config.dt
        left, right = self.drive.command(v, w)
        ground_v, ground_w = self.drive.body_twist(*self._encoders.ground_speeds(left, right))

        count = substeps(abs(ground_v) * dt, self.config.max_substep_distance)
        h = dt / count
        chord_speed = ground_v * chord_factor(ground_w * h)  # straight-line speed that ends on the arc
        physics = self._physics
        for _ in range(count):
            mid = physics.body.angle + 0.5 * ground_w * h
            physics.advance(chord_speed * math.cos(mid), chord_speed * math.sin(mid), ground_w, h)

        self._steps += 1
        x, y, theta = physics.pose()
        previous, self._pose = self._pose, Pose2D(x, y, wrap_angle(theta))
        self._twist = arc_twist(previous, self._pose, dt)
        self._wheel_speeds = (left, right)
        self._increments = self._encoders.increments(left, right, dt)
        ds, dtheta = self.drive.body_twist(*self._increments)
        self._odom = integrate_arc(self._odom, ds, dtheta)
        self._odom_twist = (ds / dt, dtheta / dt)
        self._trajectory.append((x, y, math.hypot(self._twist[0], self._twist[1])))
        if self.world.goal is not None and self.world.goal.contains(x, y):
            self._goal_reached = True
        self._ranges = self._lidar.scan(self._pose)

    # -- observations ----------------------------------------------------------------------

    @property
    def time(self) -> float:
        """Simulated seconds since the last reset."""
        return self._steps * self.config.dt

    @property
    def steps(self) -> int:
        return self._steps

    @property
    def pose(self) -> Pose2D:
        """Ground-truth pose in the world frame."""
        return self._pose

    @property
    def twist(self) -> tuple[float, float, float]:
        """Ground-truth body-frame (vx, vy, w) over the last step; vy is a slide along a wall."""
        return self._twist

    @property
    def wheel_speeds(self) -> tuple[float, float]:
        """(left, right) rad/s the motors ran at during the last step (after saturation)."""
        return self._wheel_speeds

    @property
    def encoder_increments(self) -> tuple[float, float]:
        """(left, right) wheel rotation in rad measured during the last step."""
        return self._increments

    @property
    def odom_pose(self) -> Pose2D:
        """Pose integrated from the encoders, starting at the start (or last set) pose."""
        return self._odom

    @property
    def odom_twist(self) -> tuple[float, float]:
        """(v, w) from the last encoder increments by forward kinematics: seed 002's /odometry."""
        return self._odom_twist

    @property
    def ranges(self) -> np.ndarray:
        """The last LiDAR scan (read-only), beam i at lidar.angle_min + i * lidar.angle_increment."""
        view = self._ranges.view()
        view.flags.writeable = False
        return view

    @property
    def lidar(self) -> LidarConfig:
        """Beam geometry for sensor_msgs/LaserScan: angle_min, angle_increment, range_min, ..."""
        return self.config.lidar

    @property
    def sensor_pose(self) -> Pose2D:
        """Ground-truth pose of the LiDAR."""
        return self._lidar.sensor_pose(self._pose)

    @property
    def collisions(self) -> int:
        """How many times the robot has run into something since the last reset."""
        return self._physics.collisions

    @property
    def in_contact(self) -> bool:
        return self._physics.in_contact

    @property
    def goal(self) -> Goal | None:
        return self.world.goal

    @property
    def goal_reached(self) -> bool:
        """True once the robot's centre has entered the goal region (until reset)."""
        return self._goal_reached

    @property
    def trajectory(self) -> np.ndarray:
        """(N, 3) rows [x, y, speed] since the last reset; a NaN row marks a set_pose jump."""
        return np.array(self._trajectory)

    # -- rendering -------------------------------------------------------------------------

    def draw(self, ax: Any) -> None:
        """Draw world, trajectory, robot and scan onto a matplotlib Axes."""
        from amr_simulation.render import draw_simulation  # matplotlib only when drawing

        draw_simulation(ax, self)

    def render(self, path: str | Path, dpi: int = 120) -> Path:
        """Write a PNG of the current state; returns its path."""
        from amr_simulation.render import save_png  # matplotlib only when drawing

        return save_png(self, path, dpi=dpi)
