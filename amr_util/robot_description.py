"""The robot, stated once: footprint, wheel geometry, speed and acceleration limits, LiDAR mount, sensor rates.

One YAML file (shipped: config/robot/turtlebot3_burger.yaml, installed to share/amr_util/config/robot) holds
the facts of the robot; every library default that is a fact of the robot (a costmap's inflation radius, a
follower's LiDAR offset, the simulator's wheels) is read from it, and a node's `robot_description` parameter
names another file with the same keys. Plain Python, no rclpy:

    robot = default_robot()                       # the shipped TurtleBot3 Burger
    robot.radius, robot.lidar_x, robot.max_linear_speed
    other = load_robot_description("my_robot.yaml")   # RobotDescriptionError naming file, key and value

`robot_parameters(robot)` maps the description onto the parameter names the suite's configurations use
(`robot_radius`, `lidar_x`, the simulator's `robot.radius`, ...), so a node can lay another robot over its
defaults.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import yaml

from amr_util.share import share_directory

DEFAULT_FILE = "turtlebot3_burger.yaml"
SOURCE_ROBOTS = Path(__file__).resolve().parent.parent / "config" / "robot"


class RobotDescriptionError(ValueError):
    """A robot description that is missing, unreadable, or has a missing, unknown or invalid key (named)."""


@dataclass(frozen=True)
class RobotDescription:
    """The facts of one differential-drive robot with a 2D LiDAR (SI units, REP 103)."""

    name: str
    radius: float
    """m, the circular footprint."""
    wheel_radius: float
    """m."""
    wheel_separation: float
    """m between the wheels."""
    max_linear_speed: float
    """m/s."""
    max_angular_speed: float
    """rad/s."""
    max_linear_acceleration: float
    """m/s^2."""
    max_angular_acceleration: float
    """rad/s^2."""
    lidar_x: float
    """m, the LiDAR ahead of the rotation centre (negative: behind)."""
    lidar_y: float
    """m, to the left."""
    lidar_z: float
    """m, above the floor."""
    lidar_beams: int
    """beams per scan."""
    lidar_rate: float
    """Hz, scans per second."""
    lidar_range_min: float
    """m."""
    lidar_range_max: float
    """m."""
    odometry_rate: float
    """Hz, odometry messages per second."""
    path: str = ""
    """The file it was read from."""

    @property
    def max_wheel_speed(self) -> float:
        """rad/s of a wheel driving max_linear_speed."""
        return self.max_linear_speed / self.wheel_radius

    @property
    def scan_period(self) -> float:
        """s between scans."""
        return 1.0 / self.lidar_rate


_KEYS = {  # field: (section, key, minimum, maximum)
    "radius": ("footprint", "radius", 0.01, 2.0),
    "wheel_radius": ("wheels", "radius", 0.005, 1.0),
    "wheel_separation": ("wheels", "separation", 0.01, 2.0),
    "max_linear_speed": ("limits", "max_linear_speed", 0.01, 10.0),
    "max_angular_speed": ("limits", "max_angular_speed", 0.01, 20.0),
    "max_linear_acceleration": ("limits", "max_linear_acceleration", 0.01, 100.0),
    "max_angular_acceleration": ("limits", "max_angular_acceleration", 0.01, 100.0),
    "lidar_x": ("lidar", "x", -2.0, 2.0),
    "lidar_y": ("lidar", "y", -2.0, 2.0),
    "lidar_z": ("lidar", "z", 0.0, 5.0),
    "lidar_beams": ("lidar", "beams", 1, 10_000),
    "lidar_rate": ("lidar", "rate", 0.1, 1000.0),
    "lidar_range_min": ("lidar", "range_min", 0.0, 100.0),
    "lidar_range_max": ("lidar", "range_max", 0.01, 1000.0),
    "odometry_rate": ("odometry", "rate", 0.1, 10_000.0),
}


def robot_search_path() -> tuple[Path, ...]:
    """Where a relative description name is looked up: share/amr_util/config/robot, then the source tree's."""
    installed = share_directory("amr_util") / "config" / "robot"
    return (installed,) if installed == SOURCE_ROBOTS else (installed, SOURCE_ROBOTS)


def resolve_robot_path(name: str | Path) -> Path:
    """An existing path as given, else the first directory of robot_search_path() holding that file name."""
    candidate = Path(name).expanduser()
    if candidate.is_file():
        return candidate
    for directory in robot_search_path():
        if (directory / str(name)).is_file():
            return directory / str(name)
    raise RobotDescriptionError(
        f"robot description {str(name)!r} not found as a path nor in {', '.join(map(str, robot_search_path()))}"
    )


def load_robot_description(name: str | Path = DEFAULT_FILE) -> RobotDescription:
    """The description in `name` (a path, or a file name in robot_search_path()); RobotDescriptionError naming
    the file, the key and the value of any problem."""
    path = resolve_robot_path(name)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as error:
        raise RobotDescriptionError(f"{path}: cannot read the robot description: {error}") from error
    if not isinstance(data, dict):
        raise RobotDescriptionError(f"{path}: a robot description is a mapping of sections, got {data!r}")
    known = {"name"} | {section for section, _, _, _ in _KEYS.values()}
    for section in data:
        if section not in known:
            raise RobotDescriptionError(f"{path}: unknown section {section!r} (known: {', '.join(sorted(known))})")
    values: dict[str, Any] = {"name": str(data.get("name", path.stem)), "path": str(path)}
    for section in known - {"name"}:
        entries = data.get(section)
        if not isinstance(entries, dict):
            raise RobotDescriptionError(f"{path}: {section}: must be a mapping, got {entries!r}")
        allowed = {key for s, key, _, _ in _KEYS.values() if s == section}
        for key in entries:
            if key not in allowed:
                raise RobotDescriptionError(
                    f"{path}: unknown key {section}.{key} (known: "
                    f"{', '.join(f'{section}.{k}' for k in sorted(allowed))})"
                )
    for field_name, (section, key, low, high) in _KEYS.items():
        if key not in data[section]:
            raise RobotDescriptionError(f"{path}: {section}.{key}: missing")
        value = data[section][key]
        integer = isinstance(low, int) and isinstance(high, int)
        if (
            isinstance(value, bool)
            or not isinstance(value, int if integer else (int, float))
            or not math.isfinite(value)
            or not low <= value <= high
        ):
            raise RobotDescriptionError(
                f"{path}: {section}.{key}: must be {'an integer' if integer else 'a number'} "
                f"in [{low:g}, {high:g}], got {value!r}"
            )
        values[field_name] = int(value) if integer else float(value)
    if values["lidar_range_min"] >= values["lidar_range_max"]:
        raise RobotDescriptionError(
            f"{path}: lidar.range_min ({values['lidar_range_min']}) must be below "
            f"lidar.range_max ({values['lidar_range_max']})"
        )
    return RobotDescription(**values)


@functools.cache
def default_robot() -> RobotDescription:
    """The shipped description (the TurtleBot3 Burger), read once."""
    return load_robot_description(DEFAULT_FILE)


def robot_parameters(robot: RobotDescription) -> dict[str, float]:
    """The description under the parameter names of the suite's configurations (flat, dotted where nested):
    what a node with a `robot_description` lays over its defaults (the keys it does not know are skipped)."""
    return {
        "robot_radius": robot.radius,
        "lidar_x": robot.lidar_x,
        "lidar_y": robot.lidar_y,
        "laser_max_range": robot.lidar_range_max,
        "angular_limit": robot.max_angular_speed,
        "costmap.robot_radius": robot.radius,
        "traffic_rules.robot_radius": robot.radius,
        "traffic_rules.lidar_x": robot.lidar_x,
        "robot.radius": robot.radius,
        "robot.wheel_radius": robot.wheel_radius,
        "robot.track": robot.wheel_separation,
        "robot.max_wheel_speed": robot.max_wheel_speed,
        "robot.max_linear": robot.max_linear_speed,
        "robot.max_angular": robot.max_angular_speed,
        "lidar.x": robot.lidar_x,
        "lidar.y": robot.lidar_y,
        "lidar.range_min": robot.lidar_range_min,
        "lidar.range_max": robot.lidar_range_max,
    }


FIELDS = tuple(f.name for f in fields(RobotDescription))
