"""Simulator parameters, each stated once (type, default, range, live or structural, description).

A node hands over its parameters as a flat dict with dotted names, exactly as ROS 2 names nested
YAML keys ("lidar.beams"); nested dicts are accepted too. Unknown names, wrong types and values out
of range raise ConfigError naming the key, so a typo cannot silently fall back to a default. Live
(applied at the next step while the node runs): sensor and encoder noise, slip, the realtime command
timeout; everything else shapes the world, the robot or the node's interfaces and is structural.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from amr_util.parameter_file import dotted, node_parameters
from amr_util.parameter_spec import Config, ConfigError, parameter
from amr_util.robot_description import default_robot

MODES = ("lockstep", "realtime")
RAY_CAST_METHODS = ("numpy", "pymunk")
_ROBOT = default_robot()


def _start_problem(value: Sequence[float]) -> str | None:
    return None if len(value) in (0, 3) else "must be [x, y, theta] or [] (the world's start)"


@dataclass(frozen=True)
class RobotConfig(Config):
    """The robot description's by default (amr_util.robot_description: the TurtleBot3 Burger)."""

    radius: float = parameter(_ROBOT.radius, minimum=0.01, maximum=2.0)
    """m, the circular collision footprint."""
    wheel_radius: float = parameter(_ROBOT.wheel_radius, minimum=0.005, maximum=1.0)
    """m."""
    track: float = parameter(_ROBOT.wheel_separation, minimum=0.01, maximum=2.0)
    """m between the wheels."""
    max_wheel_speed: float = parameter(_ROBOT.max_wheel_speed, minimum=0.01, maximum=1000.0)
    """rad/s, so that both wheels at the limit drive max_linear (the description's)."""
    max_linear: float = parameter(_ROBOT.max_linear_speed, minimum=0.01, maximum=10.0)
    """m/s, the body speed limit (curvature-preserving saturation)."""
    max_angular: float = parameter(_ROBOT.max_angular_speed, minimum=0.01, maximum=20.0)
    """rad/s, the body turn-rate limit."""


@dataclass(frozen=True)
class LidarConfig(Config):
    """A 2D LiDAR; defaults are seed 002's simulated sensor with TurtleBot3 LDS-01 figures.

    Beam i points at angle_min + i * fov / beams in the sensor frame (counter-clockwise,
    beam 0 straight ahead). The sensor sits at (x, y) in the robot frame (base_scan in
    base_footprint; TurtleBot3 Burger: 3.2 cm behind the axle).
    """

    beams: int = parameter(240, minimum=1, maximum=10_000)
    """beams per scan; beam i at angle_min + i * fov / beams, counter-clockwise, beam 0 ahead."""
    angle_min: float = parameter(0.0, minimum=-2 * math.pi, maximum=2 * math.pi)
    """rad, the first beam's angle in the sensor frame."""
    fov: float = parameter(2.0 * math.pi, minimum=0.001, maximum=2 * math.pi)
    """rad, the field of view the beams span."""
    range_min: float = parameter(_ROBOT.lidar_range_min, minimum=0.0, maximum=100.0)
    """m; closer returns read -inf (REP 117)."""
    range_max: float = parameter(_ROBOT.lidar_range_max, minimum=0.01, maximum=1000.0)
    """m; no return within it reads +inf (REP 117)."""
    noise_std: float = parameter(0.01, minimum=0.0, maximum=1.0, live=True)
    """m, standard deviation of the Gaussian range noise."""
    x: float = parameter(_ROBOT.lidar_x, minimum=-2.0, maximum=2.0)
    """m, sensor position ahead of the robot centre (base_scan in base_footprint)."""
    y: float = parameter(_ROBOT.lidar_y, minimum=-2.0, maximum=2.0)
    """m, sensor position to the left of the robot centre."""
    method: str = parameter("numpy", choices=RAY_CAST_METHODS)
    """ray casting: numpy (vectorised faces) or pymunk (one query per beam)."""

    @property
    def angle_increment(self) -> float:
        return self.fov / self.beams

    @property
    def angle_max(self) -> float:
        """The last beam's angle (sensor_msgs/LaserScan convention)."""
        return self.angle_min + (self.beams - 1) * self.angle_increment

    def validate(self) -> None:
        if self.range_max <= self.range_min:
            raise ConfigError(f"range_max: must be above range_min = {self.range_min}, got {self.range_max!r}")


@dataclass(frozen=True)
class EncoderConfig(Config):
    """Wheel encoder imperfections, both 0 (ideal) by default.

    noise: standard deviation of each increment relative to its size (0.01 = 1 %).
    slip: standard deviation of the fraction of wheel travel lost to the floor each
    step; the lost fraction is |N(0, slip)| capped at 1, so slip only ever loses ground.
    """

    noise: float = parameter(0.0, minimum=0.0, maximum=1.0, live=True)
    """standard deviation of each wheel increment relative to its size (0.01 = 1 %)."""
    slip: float = parameter(0.0, minimum=0.0, maximum=1.0, live=True)
    """standard deviation of the fraction of wheel travel lost to the floor each step."""


@dataclass(frozen=True)
class BeaconConfig(Config):
    """The range beacons and compass of a world that declares `beacons` (seed 000)."""

    range_noise_std: float = parameter(0.01, minimum=0.0, maximum=10.0, live=True)
    """m, standard deviation of the Gaussian noise on each beacon range."""
    compass_noise_std: float = parameter(0.01, minimum=0.0, maximum=3.2, live=True)
    """rad, standard deviation of the Gaussian noise on the compass heading."""


@dataclass(frozen=True)
class SimulationConfig(Config):
    """Everything the simulator (library and node) is configured with."""

    world: str = parameter("outer_corridor.yaml", nonempty=True)
    """A world file name (looked up in the worlds directories) or a path."""
    start: tuple[float, float, float] | None = parameter(None, kind="float_array", check=_start_problem)
    """[x, y, theta] overriding the world's start pose; [] (None in the library) = the world's start."""
    dt: float = parameter(0.05, minimum=0.001, maximum=1.0)
    """s, the period one step advances."""
    seed: int = parameter(0, minimum=0, maximum=2**31 - 1)
    """Seeds every random stream (LiDAR noise, encoder noise and slip)."""
    max_substep_distance: float = parameter(0.01, minimum=0.0001, maximum=0.1)
    """m, the most the robot moves in one physics substep: bounds wall penetration."""
    mode: str = parameter("lockstep", choices=MODES)
    """Node: 'lockstep' (one step per command) or 'realtime' (a timer at dt / rate)."""
    rate: float = parameter(1.0, minimum=0.01, maximum=1000.0)
    """Node, realtime mode: simulated seconds per wall-clock second."""
    command_timeout: float = parameter(0.5, minimum=0.0, maximum=60.0, live=True)
    """Node, realtime mode: s without a command before the robot stops; 0 disables."""
    cmd_vel_stamped: bool = parameter(True)
    """Node: /cmd_vel is geometry_msgs/TwistStamped (else plain Twist)."""
    stop_at_goal: bool = parameter(True)
    """Entering the world's goal region stops the robot until reset (the wall-following task ends there). False:
    the goal is only judged and reported (goal_reached), and commands keep moving the robot (a navigator
    stops it at its own goals and takes new ones)."""
    robot: RobotConfig = field(default_factory=RobotConfig)
    lidar: LidarConfig = field(default_factory=LidarConfig)
    encoders: EncoderConfig = field(default_factory=EncoderConfig)
    beacons: BeaconConfig = field(default_factory=BeaconConfig)


def param_defaults() -> dict[str, Any]:
    """Every parameter with its default, flat and ROS-typed ('start' left out: its default, the world's
    own, is no value)."""
    return SimulationConfig().as_params()


def read_parameter_file(path: str | Path, node_name: str = "simulator") -> dict[str, Any]:
    """The flat parameters of one node from a ROS 2 parameter YAML file."""
    return dotted(node_parameters(path, node_name, ConfigError))
