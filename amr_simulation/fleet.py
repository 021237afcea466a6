"""Several robots in one world: one pymunk space stepped in lockstep, no ROS.

Every Fleet.step(commands) advances exactly config.dt seconds for every robot at once:
  1. each robot's (v, w) -> wheel speeds by the diff-drive inverse kinematics, saturated
     keeping the curvature (DiffDrive.command); slip takes its share of each wheel's ground speed;
  2. the bodies follow their twists in pymunk, in shared substeps (as many as the fastest robot
     needs), stopped and deflected by the walls and by each other: a robot cannot push another;
  3. each robot's encoders report its commanded wheel rotation (plus noise) and its encoder
     odometry integrates it;
  4. every LiDAR scans from its robot's new pose: it sees the walls and the other robots (discs of
     the robot radius), never its own body; each robot's goal region is checked.
A robot that has reached its goal ignores its commands and stays put until reset (unless stop_at_goal is false); the
others go on.

Each robot has its own random streams (LiDAR noise, encoder noise and slip, beacons), seeded from the
config's seed and the robot's name: robot `name` draws from SeedSequence(seed, spawn_key=name's UTF-8
bytes).spawn(3). The unnamed robot of a one-robot world thus gets SeedSequence(seed).spawn(3), what the
one-robot simulator always had, and a named robot keeps its noise when the list is reordered.

A world without a `robots` list is one robot, exactly the one amr_simulation.simulator.Simulator
(a Fleet of one) has always simulated: same physics, same streams, bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pymunk

from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import Goal, RobotSpec, World, load_world, resolve_world_path
from amr_simulation.beacon_sensor import BeaconSensor
from amr_simulation.config import LidarConfig, SimulationConfig
from amr_simulation.encoders import Encoders
from amr_simulation.errors import SimulationError
from amr_simulation.lidar import Lidar, readings
from amr_simulation.physics import ROBOT_CATEGORY, WALL_CATEGORY, Physics, substeps
from amr_simulation.raycast import PymunkRayCaster, cast_discs
from amr_util.diff_drive import DiffDrive
from amr_util.geometry import Pose2D, arc_twist, chord_factor, integrate_arc, wrap_angle
from amr_util.parameter_spec import ConfigError

Command = tuple[float, float]
"""(v m/s, w rad/s) for one robot."""


class SimulatedRobot:
    """One robot of a Fleet: its random streams, state and observations.

    Read its properties; move it through the Fleet (step, set_pose, reset_robot).
    """

    def __init__(self, fleet: Fleet, index: int, spec: RobotSpec) -> None:
        config = fleet.config
        self.index = index
        self.name = spec.name
        """The namespace of its topics; "" for the one robot of a world without a `robots` list."""
        self.start = Pose2D(*config.start) if config.start is not None else spec.start
        """Where reset puts it (the config's start overrides a one-robot world's)."""
        self.goal: Goal | None = spec.goal
        streams = np.random.SeedSequence(config.seed, spawn_key=tuple(self.name.encode()))
        lidar_seed, encoder_seed, beacon_seed = streams.spawn(3)
        caster = (
            _Sighted(fleet, index)
            if config.lidar.method == "numpy"
            else PymunkRayCaster(
                fleet._physics.space, pymunk.ShapeFilter(group=index + 1, mask=WALL_CATEGORY | ROBOT_CATEGORY)
            )
        )
        self._lidar = Lidar(config.lidar, caster, np.random.default_rng(lidar_seed))
        self._encoders = Encoders(config.encoders, np.random.default_rng(encoder_seed))
        self._beacons = (
            BeaconSensor(fleet.world.beacons, config.beacons, np.random.default_rng(beacon_seed))
            if fleet.world.beacons
            else None
        )
        self._contacts = fleet._physics.contacts[index]
        self._names = fleet.names
        self._trajectory: list[tuple[float, float, float]] = []
        self._pose = self._odom = self.start
        self._twist = (0.0, 0.0, 0.0)
        self._odom_twist = (0.0, 0.0)
        self._wheel_speeds = (0.0, 0.0)
        self._increments = (0.0, 0.0)
        self._goal_reached = False
        self._ranges = np.empty(0)

    def __repr__(self) -> str:
        return f"SimulatedRobot({self.name!r}, pose={tuple(round(v, 3) for v in self._pose)})"

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
        """(v, w) from the last encoder increments by forward kinematics."""
        return self._odom_twist

    @property
    def ranges(self) -> np.ndarray:
        """The last LiDAR scan (read-only), beam i at lidar.angle_min + i * lidar.angle_increment."""
        view = self._ranges.view()
        view.flags.writeable = False
        return view

    @property
    def sensor_pose(self) -> Pose2D:
        """Ground-truth pose of the LiDAR."""
        return self._lidar.sensor_pose(self._pose)

    @property
    def collisions(self) -> int:
        """Times it went from touching nothing to touching something (a solid or a robot) since reset."""
        return self._contacts.collisions

    @property
    def wall_collisions(self) -> int:
        """Times it went from touching no solid to touching one since reset."""
        return self._contacts.wall_collisions

    @property
    def robot_collisions(self) -> dict[str, int]:
        """Other robot's name -> times it went from not touching that robot to touching it, since reset."""
        return {self._names[other]: count for other, count in sorted(self._contacts.robot_collisions.items())}

    @property
    def in_contact(self) -> bool:
        """It touches a solid or another robot now."""
        return self._contacts.touching > 0

    @property
    def goal_reached(self) -> bool:
        """True once its centre has entered its goal region (until reset)."""
        return self._goal_reached

    @property
    def trajectory(self) -> np.ndarray:
        """(N, 3) rows [x, y, speed] since the last reset; a NaN row marks a set_pose jump."""
        return np.array(self._trajectory)

    def beacon_reading(self) -> tuple[np.ndarray, np.ndarray, float] | None:
        """(beacon positions (B, 2), noisy ranges (B,), noisy compass heading) at the true pose, each call
        a new draw from this robot's stream; None when the world declares no beacons."""
        if self._beacons is None:
            return None
        ranges, compass = self._beacons.measure(self._pose)
        return self._beacons.positions, ranges, compass

    def _check_goal(self, x: float, y: float) -> None:
        if self.goal is not None and self.goal.contains(x, y):
            self._goal_reached = True


class Fleet:
    """The robots of one world in one pymunk space; no ROS. Build with Fleet(world, config) or from_params.

    robots[i] is the world's i-th robot (World.fleet order); every robot is a TurtleBot3-like disc with
    the config's drive, LiDAR and encoders.
    """

    def __init__(self, world: World, config: SimulationConfig | None = None) -> None:
        self.world = world
        self.config = config or SimulationConfig()
        specs = world.fleet
        if self.config.start is not None and world.robots:
            raise ConfigError(
                f"start: overrides the start of a world of one unnamed robot; {world.source} "
                f"lists its robots ({', '.join(s.name for s in specs)}) with their starts"
            )
        world.check_footprints(self.config.robot.radius)
        robot = self.config.robot
        self.drive = DiffDrive(
            wheel_radius=robot.wheel_radius,
            track=robot.track,
            max_wheel_speed=robot.max_wheel_speed,
            max_linear=robot.max_linear,
            max_angular=robot.max_angular,
        )
        self.names: tuple[str, ...] = tuple(spec.name for spec in specs)
        self._index = {name: index for index, name in enumerate(self.names)}
        self._numpy_caster = NumpyRayCaster(world.faces)
        self.reset()

    @classmethod
    def from_params(
        cls, params: Mapping[str, Any], worlds_dirs: Sequence[str | Path] = (), ignore: Iterable[str] = ()
    ) -> Fleet:
        """Build from a node's flat parameter dict; the world name is looked up in worlds_dirs (default:
        amr_maps.world.world_search_path())."""
        config = SimulationConfig.from_params(params, ignore)
        return cls(load_world(resolve_world_path(config.world, worlds_dirs)), config)

    # -- control ---------------------------------------------------------------------------

    def reset(self) -> None:
        """Every robot back to its start at time 0, counters cleared, random streams reseeded."""
        self._physics = Physics(self.world.polygons, self.config.robot.radius, len(self.names))
        self._steps = 0
        self.robots: tuple[SimulatedRobot, ...] = tuple(
            SimulatedRobot(self, index, spec) for index, spec in enumerate(self.world.fleet)
        )
        for robot in self.robots:
            self._place(robot, robot.start, others=self.robots[: robot.index])
        self._scan(self.robots)

    def reset_robot(self, robot: int | str) -> None:
        """One robot back to its start: its counters, trajectory and random streams as after reset; the
        world's time and the other robots go on. Raises SimulationError if another robot is in the way."""
        old = self.robot(robot)
        new = SimulatedRobot(self, old.index, RobotSpec(old.name, old.start, old.goal))
        self._place(new, new.start, others=[r for r in self.robots if r is not old])
        self._physics.contacts[old.index].clear_counts()
        self.robots = self.robots[: old.index] + (new,) + self.robots[old.index + 1 :]
        self._scan([new])

    def set_pose(self, x: float, y: float, theta: float, robot: int | str = 0) -> None:
        """Teleport a robot (at rest); its encoder odometry restarts from the new pose and it scans again.

        Raises SimulationError if the pose is not finite, lies outside the world's bounds (where
        no wall could ever come within LiDAR range), or the robot's footprint would overlap a wall
        or another robot.
        """
        target = self.robot(robot)
        self._place(target, (x, y, theta), others=[r for r in self.robots if r is not target])
        self._scan([target])

    def step(self, commands: Sequence[Command] | Mapping[str, Command]) -> None:
        """Advance one period dt: every robot with its commanded (v m/s, w rad/s).

        commands: one (v, w) per robot, in robots order, or a mapping from every robot's name to its
        (v, w). Raises SimulationError (and does not step) for a missing, extra or non-finite command.
        """
        commands = self._commands(commands)
        dt = self.config.dt
        drive = self.drive
        plans = []
        fastest = 0.0
        for robot, (v, w) in zip(self.robots, commands, strict=True):
            if robot._goal_reached and self.config.stop_at_goal:
                v = w = 0.0
            left, right = drive.command(v, w)
            ground_v, ground_w = drive.body_twist(*robot._encoders.ground_speeds(left, right))
            plans.append((left, right, ground_v, ground_w))
            fastest = max(fastest, abs(ground_v))

        count = substeps(fastest * dt, self.config.max_substep_distance)
        h = dt / count
        turns = [
            (ground_v * chord_factor(ground_w * h), ground_w)  # straight-line speed that ends on the arc
            for _, _, ground_v, ground_w in plans
        ]
        physics = self._physics
        bodies = physics.bodies
        for _ in range(count):
            velocities = []
            for body, (chord_speed, ground_w) in zip(bodies, turns, strict=True):
                mid = body.angle + 0.5 * ground_w * h
                velocities.append((chord_speed * math.cos(mid), chord_speed * math.sin(mid), ground_w))
            physics.advance(velocities, h)

        self._steps += 1
        for robot, (left, right, _, _) in zip(self.robots, plans, strict=True):
            x, y, theta = physics.pose(robot.index)
            previous, robot._pose = robot._pose, Pose2D(x, y, wrap_angle(theta))
            robot._twist = arc_twist(previous, robot._pose, dt)
            robot._wheel_speeds = (left, right)
            robot._increments = robot._encoders.increments(left, right, dt)
            ds, dtheta = drive.body_twist(*robot._increments)
            robot._odom = integrate_arc(robot._odom, ds, dtheta)
            robot._odom_twist = (ds / dt, dtheta / dt)
            robot._trajectory.append((x, y, math.hypot(robot._twist[0], robot._twist[1])))
            robot._check_goal(x, y)
        self._scan(self.robots)

    def retune(self, config: SimulationConfig) -> None:
        """Take new sensor noise and slip for every robot (a live parameter change); the streams go on.

        Raises SimulationError if anything else differs: that needs a new simulator.
        """
        changed = self.config.structural_changes(config)
        if changed:
            live = ", ".join(spec.name for spec in config.parameter_specs() if spec.live)
            raise SimulationError(f"retune: {', '.join(changed)} cannot change on a running simulator (only {live})")
        self.config = config
        for robot in self.robots:
            robot._lidar.config = config.lidar
            robot._encoders.config = config.encoders
            if robot._beacons is not None:
                robot._beacons.config = config.beacons

    # -- observations ----------------------------------------------------------------------

    def robot(self, robot: int | str) -> SimulatedRobot:
        """A robot by index or name; raises SimulationError for neither."""
        if isinstance(robot, str):
            if robot not in self._index:
                raise SimulationError(
                    f"no robot named {robot!r} in {self.world.source} (robots: {', '.join(map(repr, self.names))})"
                )
            return self.robots[self._index[robot]]
        if isinstance(robot, bool) or not isinstance(robot, int) or not 0 <= robot < len(self.robots):
            raise SimulationError(
                f"no robot {robot!r}: {self.world.source} has {len(self.robots)} (indices 0 .. {len(self.robots) - 1})"
            )
        return self.robots[robot]

    def __len__(self) -> int:
        return len(self.robots)

    @property
    def time(self) -> float:
        """Simulated seconds since the last reset."""
        return self._steps * self.config.dt

    @property
    def steps(self) -> int:
        return self._steps

    @property
    def lidar(self) -> LidarConfig:
        """Every robot's beam geometry for sensor_msgs/LaserScan: angle_min, angle_increment, range_min, ..."""
        return self.config.lidar

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) where a robot may be: the walls' extent plus the LiDAR range."""
        margin = self.config.lidar.range_max
        xmin, ymin, xmax, ymax = self.world.bounds
        return xmin - margin, ymin - margin, xmax + margin, ymax + margin

    # -- rendering -------------------------------------------------------------------------

    def draw(self, ax: Any) -> None:
        """Draw world, every robot's trajectory, footprint and scan onto a matplotlib Axes."""
        from amr_simulation.render import draw_fleet  # matplotlib only when drawing

        draw_fleet(ax, self)

    def render(self, path: str | Path, dpi: int = 120) -> Path:
        """Write a PNG of the current state; returns its path."""
        from amr_simulation.render import draw_fleet, save_png  # matplotlib only when drawing

        return save_png(self, path, dpi=dpi, draw=draw_fleet)

    # -- internals -------------------------------------------------------------------------

    def _commands(self, commands: Sequence[Command] | Mapping[str, Command]) -> list[Command]:
        if isinstance(commands, Mapping):
            missing = [name for name in self.names if name not in commands]
            extra = [name for name in commands if name not in self._index]
            if missing or extra:
                raise SimulationError(
                    f"step: commands must name every robot ({', '.join(map(repr, self.names))}); "
                    f"missing {missing}, unknown {extra}"
                )
            commands = [commands[name] for name in self.names]
        elif len(commands) != len(self.robots):
            raise SimulationError(f"step: {len(commands)} commands for {len(self.robots)} robots")
        checked = []
        for name, command in zip(self.names, commands, strict=True):
            try:
                v, w = command
                ok = math.isfinite(v) and math.isfinite(w)
            except (TypeError, ValueError):
                ok = False
            if not ok:
                who = f" of robot {name!r}" if name else ""
                raise SimulationError(f"step: command{who} must be finite (v, w), got {command!r}")
            checked.append((v, w))
        return checked

    def _place(self, robot: SimulatedRobot, pose: Sequence[float], others: Iterable[SimulatedRobot]) -> None:
        """Check and teleport a robot, at rest, its state restarted at the pose (no scan yet)."""
        x, y, theta = pose
        who = f"robot {robot.name!r}" if robot.name else "the robot"
        if not all(map(math.isfinite, (x, y, theta))):
            raise SimulationError(f"set_pose: pose must be finite, got ({x}, {y}, {theta})")
        xmin, ymin, xmax, ymax = self.bounds
        if not (xmin <= x <= xmax and ymin <= y <= ymax):
            raise SimulationError(
                f"set_pose: ({x:.3f}, {y:.3f}) lies outside the bounds of {self.world.source}: "
                f"x in [{xmin:.3f}, {xmax:.3f}], y in [{ymin:.3f}, {ymax:.3f}] (its walls plus the "
                f"LiDAR range, {self.config.lidar.range_max} m)"
            )
        radius = self.config.robot.radius
        clearance = self._physics.clearance(x, y)
        if clearance < radius:
            raise SimulationError(
                f"set_pose: {who} (radius {radius} m) at ({x:.3f}, {y:.3f}) "
                f"overlaps a wall of {self.world.source} (clearance {clearance:.3f} m)"
            )
        for other in others:
            gap = math.hypot(x - other._pose.x, y - other._pose.y)
            if gap < 2.0 * radius:
                raise SimulationError(
                    f"set_pose: {who} at ({x:.3f}, {y:.3f}) overlaps robot {other.name!r} at "
                    f"({other._pose.x:.3f}, {other._pose.y:.3f}): centres {gap:.3f} m apart, {2.0 * radius:.3f} m "
                    "needed"
                )
        self._physics.place(x, y, theta, robot.index)
        robot._pose = robot._odom = Pose2D(x, y, wrap_angle(theta))
        robot._twist = (0.0, 0.0, 0.0)
        robot._odom_twist = (0.0, 0.0)
        robot._wheel_speeds = (0.0, 0.0)
        robot._increments = (0.0, 0.0)
        if robot._trajectory:
            robot._trajectory.append((math.nan, math.nan, math.nan))  # a break in the drawn path
        robot._trajectory.append((x, y, 0.0))
        robot._goal_reached = robot.goal is not None and robot.goal.contains(x, y)

    def _scan(self, robots: Sequence[SimulatedRobot]) -> None:
        """New scans for these robots from where every robot is now; each draws its own noise."""
        c = self.config.lidar
        if c.method != "numpy":
            for robot in robots:
                robot._ranges = robot._lidar.scan(robot._pose)
            return
        sensors = np.array([robot._lidar.sensor_pose(robot._pose) for robot in robots])
        true = self._cast(
            sensors[:, 0], sensors[:, 1], sensors[:, 2] + c.angle_min, np.array([robot.index for robot in robots])
        )
        noise = None
        if c.noise_std > 0.0:
            noise = np.empty_like(true)
            for row, robot in enumerate(robots):
                noise[row] = robot._lidar.noise()
        for robot, scan in zip(robots, readings(true, noise, c), strict=True):
            robot._ranges = scan

    def _cast(self, x: np.ndarray, y: np.ndarray, phi0: np.ndarray, observers: np.ndarray) -> np.ndarray:
        """(N, beams) true ranges from sensors at (x, y) with first beams at phi0: the world's faces and
        every robot's disc but the observer's own."""
        c = self.config.lidar
        ranges = self._numpy_caster.cast_many(x, y, phi0, c.angle_increment, c.beams, c.range_max)
        if len(self.robots) > 1:
            centres = np.array([(robot._pose.x, robot._pose.y) for robot in self.robots])
            cast_discs(ranges, x, y, phi0, c.angle_increment, c.range_max, centres, self.config.robot.radius, observers)
        return ranges


class _Sighted:
    """Robot i's numpy caster (for Lidar.true_ranges): the faces and the other robots' discs."""

    def __init__(self, fleet: Fleet, index: int) -> None:
        self._fleet = fleet
        self._index = index

    def cast(self, x: float, y: float, phi0: float, increment: float, count: int, max_range: float) -> np.ndarray:
        c = self._fleet.config.lidar
        if (increment, count, max_range) != (c.angle_increment, c.beams, c.range_max):
            raise SimulationError("a fleet robot's LiDAR casts with the fleet's beam geometry")
        return self._fleet._cast(np.array([x]), np.array([y]), np.array([phi0]), np.array([self._index]))[0]
