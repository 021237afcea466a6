"""Parameters of the path follower (pure pursuit): defaults, types and validation, no ROS.

One flat dict of ROS 2 parameters (node name ``path_follower``) configures both the controller and
its node shell, as for the wall follower: unknown keys and wrong types raise :class:`ConfigError`
naming the key. Angles are in degrees where the key says ``_deg``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from amr_control.flat_config import ConfigError, FlatConfig

NODE_NAME = "path_follower"

__all__ = ["ConfigError", "NODE_NAME", "PathFollowerConfig", "parameter_defaults", "read_parameter_file"]


@dataclass(frozen=True)
class PathFollowerConfig(FlatConfig):
    # -- node shell --------------------------------------------------------------------
    simulation: bool = True
    """True: /cmd_vel is TwistStamped and one command answers each observation (lockstep).
    False: Twist, and a timer computes every dt from the latest pose and scan."""
    dt: float = 0.05
    """s, control period (timer period on the real robot)."""
    stale_timeout: float = 0.5
    """s without a fresh localized /pose + /scan before the timer architecture publishes zero velocity
    (2.5 periods of the LDS-01's 5 Hz scans)."""
    flip_angular_sign: bool = False
    """Publish -w: seed 002 section 5.2.1 found the real robot's angular sign clockwise-positive."""
    navigated: bool = False
    """Pair the navigator's navigator/status (amr_interfaces/NavigatorStatus) with /pose and /scan and answer
    only the observations it gives this node; the path comes from the navigator (~/follow_path), and
    requests for a new plan go to it through ~/status. False: follow /path, answer every localized pair."""
    # -- pure pursuit ----------------------------------------------------------------
    lookahead_distance: float = 0.15
    """m along the path ahead of the closest point: the point the robot steers to (course: 0.2-0.3;
    shorter cuts corners less, which 0.35 m corridors need)."""
    linear_speed: float = 0.2
    """m/s on straight stretches."""
    min_linear_speed: float = 0.03
    """m/s, the least forward speed while tracking (slowing never stalls the robot)."""
    curve_angular_speed: float = 0.8
    """rad/s: in a curve of curvature k the speed is at most this / |k| (slowing in curves)."""
    approach_gain: float = 1.0
    """1/s: near the goal the speed is at most this times the distance left along the path."""
    angular_limit: float = 2.84
    """rad/s, saturation (curvature kept: the whole twist is scaled)."""
    turn_speed: float = 1.5
    """rad/s, the fastest in-place turn (towards the path, and to the goal heading)."""
    turn_gain: float = 2.0
    """rad/s per rad of heading error in in-place turns, capped at turn_speed."""
    align_angle_deg: float = 75.0
    """a lookahead point further than this off the heading (the path starts behind): turn in place."""
    aligned_angle_deg: float = 15.0
    """an in-place turn towards the path ends within this."""
    goal_tolerance: float = 0.05
    """m from the path's last point at which the goal is reached."""
    heading_tolerance_deg: float = 10.0
    """when the goal has a heading: the final in-place turn ends within this."""
    # -- safety ------------------------------------------------------------------------
    robot_radius: float = 0.105
    """m, the disc the scan check keeps clear (TurtleBot3 Burger)."""
    lidar_x: float = -0.032
    """m, LiDAR position ahead of the rotation centre (Burger: 3.2 cm behind the axle)."""
    safety_margin: float = 0.01
    """m: the robot stops rather than move its disc closer to a return that is (or would get) within
    this (0.35 m corridors leave the robot 5-6 cm a side: 0.02 m already stalls in their bends)."""
    blocked_replan_time: float = 0.5
    """s of being blocked before the follower asks for a new plan."""
    stray_distance: float = 0.25
    """m from the path (a pose that jumped, a robot pushed off): stop and ask for a new plan."""
    progress_window: float = 0.5
    """m of path ahead of the last closest point searched for the next one (a path passing close to
    itself is not short-cut)."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.type == "float" and not math.isfinite(value):
                raise ConfigError(f"{f.name}: must be finite, got {value!r}")
        positive = (
            "dt", "stale_timeout", "lookahead_distance", "linear_speed", "min_linear_speed", "curve_angular_speed", "approach_gain",
            "angular_limit", "turn_speed", "turn_gain", "align_angle_deg", "aligned_angle_deg", "goal_tolerance",
            "heading_tolerance_deg", "robot_radius", "stray_distance", "progress_window", "blocked_replan_time",
        )
        for name in positive:
            if getattr(self, name) <= 0:
                raise ConfigError(f"{name}: must be positive, got {getattr(self, name)!r}")
        if self.safety_margin < 0:
            raise ConfigError(f"safety_margin: must be >= 0, got {self.safety_margin!r}")
        if self.min_linear_speed > self.linear_speed:
            raise ConfigError(
                f"min_linear_speed ({self.min_linear_speed}) must not exceed linear_speed ({self.linear_speed})"
            )
        if not self.aligned_angle_deg < self.align_angle_deg <= 180.0:
            raise ConfigError(
                f"need aligned_angle_deg ({self.aligned_angle_deg}) < align_angle_deg ({self.align_angle_deg}) <= 180"
            )
        if self.heading_tolerance_deg >= 180.0:
            raise ConfigError(f"heading_tolerance_deg: must be below 180, got {self.heading_tolerance_deg!r}")
        if self.stray_distance <= self.goal_tolerance:
            raise ConfigError(
                f"stray_distance ({self.stray_distance}) must exceed goal_tolerance ({self.goal_tolerance})"
            )


def parameter_defaults() -> dict[str, Any]:
    """Every parameter with its default value and ROS type (float, int, bool or str)."""
    return PathFollowerConfig().as_params()


def read_parameter_file(path: str | Path, node_name: str = NODE_NAME) -> PathFollowerConfig:
    """The config in a ROS 2 parameter YAML file (``<node_name>: ros__parameters: ...``)."""
    return PathFollowerConfig.read(path, node_name)
