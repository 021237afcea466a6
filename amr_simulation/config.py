"""Simulator parameters: defaults, validation and the flat ROS 2 parameter dict.

A node hands over its parameters as a flat dict with dotted names, exactly as
ROS 2 names nested YAML keys ("lidar.beams"); nested dicts are accepted too.
Unknown names raise, so a typo cannot silently fall back to a default.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from amr_util.parameter_file import dotted, node_parameters
from amr_simulation.errors import ConfigError

MODES = ("lockstep", "realtime")
RAY_CAST_METHODS = ("numpy", "pymunk")


def _require(ok: bool, key: str, problem: str, value: Any) -> None:
    if not ok:
        raise ConfigError(f"{key}: {problem}, got {value!r}")


@dataclass(frozen=True)
class RobotConfig:
    """TurtleBot3 Burger by default (ROBOTIS e-Manual figures)."""

    radius: float = 0.105
    """m, the circular collision footprint."""
    wheel_radius: float = 0.033
    """m."""
    track: float = 0.160
    """m between the wheels."""
    max_wheel_speed: float = 0.22 / 0.033
    """rad/s, so that both wheels at the limit drive 0.22 m/s."""
    max_linear: float = 0.22
    """m/s, the body speed limit (curvature-preserving saturation)."""
    max_angular: float = 2.84
    """rad/s, the body turn-rate limit."""

    def validate(self, prefix: str = "robot.") -> None:
        for name in ("radius", "wheel_radius", "track", "max_wheel_speed", "max_linear", "max_angular"):
            value = getattr(self, name)
            _require(math.isfinite(value) and value > 0.0, prefix + name, "must be a positive number", value)


@dataclass(frozen=True)
class LidarConfig:
    """A 2D LiDAR; defaults are seed 002's simulated sensor with TurtleBot3 LDS-01 figures.

    Beam i points at angle_min + i * fov / beams in the sensor frame (counter-clockwise,
    beam 0 straight ahead). The sensor sits at (x, y) in the robot frame (base_scan in
    base_footprint; TurtleBot3 Burger: 3.2 cm behind the axle).
    """

    beams: int = 240
    """beams per scan; beam i at angle_min + i * fov / beams, counter-clockwise, beam 0 ahead."""
    angle_min: float = 0.0
    """rad, the first beam's angle in the sensor frame."""
    fov: float = 2.0 * math.pi
    """rad, the field of view the beams span."""
    range_min: float = 0.12
    """m; closer returns read -inf (REP 117)."""
    range_max: float = 3.5
    """m; no return within it reads +inf (REP 117)."""
    noise_std: float = 0.01
    """m, standard deviation of the Gaussian range noise."""
    x: float = -0.032
    """m, sensor position ahead of the robot centre (base_scan in base_footprint)."""
    y: float = 0.0
    """m, sensor position to the left of the robot centre."""
    method: str = "numpy"
    """ray casting: numpy (vectorised faces) or pymunk (one query per beam)."""

    @property
    def angle_increment(self) -> float:
        return self.fov / self.beams

    @property
    def angle_max(self) -> float:
        """The last beam's angle (sensor_msgs/LaserScan convention)."""
        return self.angle_min + (self.beams - 1) * self.angle_increment

    def validate(self, prefix: str = "lidar.") -> None:
        _require(self.beams >= 1, prefix + "beams", "must be at least 1", self.beams)
        _require(0.0 < self.fov <= 2.0 * math.pi + 1e-12, prefix + "fov", "must be in (0, 2 pi] rad", self.fov)
        _require(math.isfinite(self.angle_min), prefix + "angle_min", "must be finite", self.angle_min)
        _require(0.0 <= self.range_min, prefix + "range_min", "must be >= 0", self.range_min)
        _require(
            math.isfinite(self.range_max) and self.range_max > self.range_min,
            prefix + "range_max", f"must be finite and above range_min = {self.range_min}", self.range_max,
        )
        _require(self.noise_std >= 0.0, prefix + "noise_std", "must be >= 0", self.noise_std)
        for name in ("x", "y"):
            _require(math.isfinite(getattr(self, name)), prefix + name, "must be finite", getattr(self, name))
        _require(self.method in RAY_CAST_METHODS, prefix + "method", f"must be one of {RAY_CAST_METHODS}", self.method)


@dataclass(frozen=True)
class EncoderConfig:
    """Wheel encoder imperfections, both 0 (ideal) by default.

    noise: standard deviation of each increment relative to its size (0.01 = 1 %).
    slip: standard deviation of the fraction of wheel travel lost to the floor each
    step; the lost fraction is |N(0, slip)| capped at 1, so slip only ever loses ground.
    """

    noise: float = 0.0
    """standard deviation of each wheel increment relative to its size (0.01 = 1 %)."""
    slip: float = 0.0
    """standard deviation of the fraction of wheel travel lost to the floor each step."""

    def validate(self, prefix: str = "encoders.") -> None:
        _require(self.noise >= 0.0, prefix + "noise", "must be >= 0", self.noise)
        _require(self.slip >= 0.0, prefix + "slip", "must be >= 0", self.slip)


@dataclass(frozen=True)
class BeaconConfig:
    """The range beacons and compass of a world that declares `beacons` (seed 000)."""

    range_noise_std: float = 0.01
    """m, standard deviation of the Gaussian noise on each beacon range."""
    compass_noise_std: float = 0.01
    """rad, standard deviation of the Gaussian noise on the compass heading."""

    def validate(self, prefix: str = "beacons.") -> None:
        for name in ("range_noise_std", "compass_noise_std"):
            value = getattr(self, name)
            _require(math.isfinite(value) and value >= 0.0, prefix + name, "must be a finite number >= 0", value)


@dataclass(frozen=True)
class SimulationConfig:
    """Everything the simulator (library and node) is configured with."""

    world: str = "outer_corridor.yaml"
    """A world file name (looked up in the worlds directories) or a path."""
    start: tuple[float, float, float] | None = None
    """Overrides the world's start pose when given (x, y, theta)."""
    dt: float = 0.05
    """s, the period one step advances."""
    seed: int = 0
    """Seeds every random stream (LiDAR noise, encoder noise and slip)."""
    max_substep_distance: float = 0.01
    """m, the most the robot moves in one physics substep: bounds wall penetration."""
    mode: str = "lockstep"
    """Node: 'lockstep' (one step per command) or 'realtime' (a timer at dt / rate)."""
    rate: float = 1.0
    """Node, realtime mode: simulated seconds per wall-clock second."""
    command_timeout: float = 0.5
    """Node, realtime mode: s without a command before the robot stops; 0 disables."""
    cmd_vel_stamped: bool = True
    """Node: /cmd_vel is geometry_msgs/TwistStamped (else plain Twist)."""
    stop_at_goal: bool = True
    """Entering the world's goal region stops the robot until reset (the wall-following task ends there). False:
    the goal is only judged and reported (goal_reached), and commands keep moving the robot (a navigator
    stops it at its own goals and takes new ones)."""
    robot: RobotConfig = field(default_factory=RobotConfig)
    lidar: LidarConfig = field(default_factory=LidarConfig)
    encoders: EncoderConfig = field(default_factory=EncoderConfig)
    beacons: BeaconConfig = field(default_factory=BeaconConfig)

    def __post_init__(self) -> None:
        _require(isinstance(self.world, str) and bool(self.world), "world", "must be a file name", self.world)
        if self.start is not None:
            _require(
                len(self.start) == 3 and all(math.isfinite(v) for v in self.start),
                "start", "must be [x, y, theta]", self.start,
            )
        for name in ("dt", "max_substep_distance", "rate"):
            value = getattr(self, name)
            _require(math.isfinite(value) and value > 0.0, name, "must be a positive number", value)
        _require(self.command_timeout >= 0.0, "command_timeout", "must be >= 0 (0 disables)", self.command_timeout)
        _require(self.mode in MODES, "mode", f"must be one of {MODES}", self.mode)
        self.robot.validate()
        self.lidar.validate()
        self.encoders.validate()
        self.beacons.validate()

    @classmethod
    def from_params(cls, params: Mapping[str, Any], ignore: Iterable[str] = ()) -> "SimulationConfig":
        """Build from a flat dotted-name dict (or nested dicts); names in ignore are skipped."""
        flat = {key: value for key, value in dotted(params).items() if key not in set(ignore)}
        sections = {"robot": RobotConfig, "lidar": LidarConfig, "encoders": EncoderConfig, "beacons": BeaconConfig}
        top: dict[str, Any] = {}
        nested: dict[str, dict[str, Any]] = {name: {} for name in sections}
        top_fields = {f.name: f for f in dataclasses.fields(cls) if f.name not in sections}
        for key, value in flat.items():
            section, _, name = key.partition(".")
            if section in sections and name:
                fields = {f.name: f for f in dataclasses.fields(sections[section])}
                if name not in fields:
                    raise ConfigError(f"{key}: unknown parameter (known: {', '.join(sorted(fields))})")
                nested[section][name] = _typed(value, fields[name], key)
            elif key in top_fields:
                top[key] = _typed(value, top_fields[key], key)
            else:
                known = sorted(set(top_fields) | {f"{s}.*" for s in sections})
                raise ConfigError(f"{key}: unknown parameter (known: {', '.join(known)})")
        return cls(**top, **{name: sections[name](**values) for name, values in nested.items()})


def param_defaults() -> dict[str, Any]:
    """Every parameter with its default, flat and ROS-typed: what a node declares.

    'start' is left out: its default is 'use the world's start', which a ROS
    parameter cannot express; a node may declare it when a launch file sets it.
    """
    config = SimulationConfig()
    params = {}
    for key, value in dotted(dataclasses.asdict(config)).items():
        if key != "start":
            params[key] = value
    return params


def read_parameter_file(path: str | Path, node_name: str = "simulator") -> dict[str, Any]:
    """The flat parameters of one node from a ROS 2 parameter YAML file."""
    return dotted(node_parameters(path, node_name, ConfigError))


def _typed(value: Any, spec: dataclasses.Field, key: str) -> Any:
    """The value checked against the field's annotated type (ints pass as floats)."""
    kind = spec.type if isinstance(spec.type, str) else spec.type.__name__
    if kind == "float":
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        _require(ok, key, "must be a number", value)
        return float(value)
    if kind == "int":
        _require(isinstance(value, int) and not isinstance(value, bool), key, "must be an integer", value)
        return value
    if kind == "bool":
        _require(isinstance(value, bool), key, "must be true or false", value)
        return value
    if kind == "str":
        _require(isinstance(value, str), key, "must be a string", value)
        return value
    # start: three numbers (a list, or the array.array rclpy hands out), or empty for the world's own
    ok = isinstance(value, Sequence) and not isinstance(value, str) and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
    )
    _require(ok and len(value) in (0, 3), key, "must be [x, y, theta] or []", value)
    return tuple(float(v) for v in value) if value else None
