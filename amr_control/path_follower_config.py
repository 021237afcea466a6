"""Parameters of the path follower (pure pursuit), each stated once (type, default, range, live or
structural, description), no ROS.

One flat dict of ROS 2 parameters (node name ``path_follower``) configures both the controller and
its node shell, as for the wall follower: unknown keys, wrong types and values out of range raise
:class:`ConfigError` naming the key. Structural parameters shape what configure builds (publisher
type, timer, planner client) and are refused while configured; every other one is live: validated
with the whole configuration and used from the next observation. Angles are in degrees where the
key says ``_deg``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from amr_control.navigated import STEPPINGS
from amr_util.parameter_spec import Config, ConfigError, parameter
from amr_util.robot_description import default_robot

NODE_NAME = "path_follower"

__all__ = ["ConfigError", "NODE_NAME", "PathFollowerConfig", "parameter_defaults", "read_parameter_file"]


@dataclass(frozen=True)
class PathFollowerConfig(Config):
    # -- node shell --------------------------------------------------------------------
    simulation: bool = parameter(True)
    """True: /cmd_vel is TwistStamped and one command answers each observation (lockstep).
    False: Twist, and a timer computes every dt from the latest pose and scan."""
    stepping: str = parameter("lockstep", choices=STEPPINGS)
    """How the world steps, as the stack declares it (its mode argument sets the simulator's too); with simulation
    and navigated. lockstep: a command answers only an observation given to this node. realtime: also one zero
    command when the navigator gives the robot to nobody (the explicit hold: nobody else answers, time goes on)."""
    dt: float = parameter(0.05, minimum=0.001, maximum=1.0)
    """s, control period (timer period on the real robot)."""
    stale_timeout: float = parameter(0.5, minimum=0.001, maximum=10.0, live=True)
    """s without a fresh localized /pose + /scan before the timer architecture publishes zero velocity
    (2.5 periods of the LDS-01's 5 Hz scans)."""
    flip_angular_sign: bool = parameter(False, live=True)
    """Publish -w: seed 002 section 5.2.1 found the real robot's angular sign clockwise-positive."""
    navigated: bool = parameter(False)
    """Pair the navigator's navigator/status (amr_interfaces/NavigatorStatus) with /pose and /scan and answer
    only the observations it gives this node; the path comes from the navigator (~/follow_path), and
    requests for a new plan go to it through ~/status. False: follow /path, answer every localized pair."""
    # -- pure pursuit ----------------------------------------------------------------
    lookahead_distance: float = parameter(0.15, minimum=0.01, maximum=5.0, live=True)
    """m along the path ahead of the closest point: the point the robot steers to (course: 0.2-0.3;
    shorter cuts corners less, which 0.35 m corridors need)."""
    linear_speed: float = parameter(0.2, minimum=0.001, maximum=5.0, live=True)
    """m/s on straight stretches."""
    min_linear_speed: float = parameter(0.03, above=0.0, maximum=5.0, live=True)
    """m/s, the least forward speed while tracking (slowing never stalls the robot)."""
    curve_angular_speed: float = parameter(0.8, minimum=0.01, maximum=100.0, live=True)
    """rad/s: in a curve of curvature k the speed is at most this / |k| (slowing in curves)."""
    approach_gain: float = parameter(1.0, minimum=0.01, maximum=100.0, live=True)
    """1/s: near the goal the speed is at most this times the distance left along the path."""
    angular_limit: float = parameter(default_robot().max_angular_speed, minimum=0.01, maximum=10.0, live=True)
    """rad/s, saturation (curvature kept: the whole twist is scaled; default: the robot description's
    max_angular_speed)."""
    turn_speed: float = parameter(1.5, minimum=0.01, maximum=10.0, live=True)
    """rad/s, the fastest in-place turn (towards the path, and to the goal heading)."""
    turn_gain: float = parameter(2.0, minimum=0.01, maximum=100.0, live=True)
    """rad/s per rad of heading error in in-place turns, capped at turn_speed."""
    align_angle_deg: float = parameter(75.0, minimum=1.0, maximum=180.0, live=True)
    """a lookahead point further than this off the heading (the path starts behind): turn in place."""
    aligned_angle_deg: float = parameter(15.0, minimum=0.1, maximum=179.0, live=True)
    """an in-place turn towards the path ends within this."""
    goal_tolerance: float = parameter(0.05, minimum=0.001, maximum=2.0, live=True)
    """m from the path's last point at which the goal is reached."""
    heading_tolerance_deg: float = parameter(10.0, minimum=0.1, maximum=179.0, live=True)
    """when the goal has a heading: the final in-place turn ends within this."""
    # -- safety ------------------------------------------------------------------------
    robot_radius: float = parameter(default_robot().radius, minimum=0.01, maximum=2.0, live=True)
    """m, the disc the scan check keeps clear (default: the robot description's footprint)."""
    lidar_x: float = parameter(default_robot().lidar_x, minimum=-1.0, maximum=1.0, live=True)
    """m, LiDAR position ahead of the rotation centre (default: the robot description's mount)."""
    safety_margin: float = parameter(0.01, minimum=0.0, maximum=1.0, live=True)
    """m: the robot stops rather than move its disc closer to a return that is (or would get) within
    this (0.35 m corridors leave the robot 5-6 cm a side: 0.02 m already stalls in their bends)."""
    blocked_replan_time: float = parameter(0.5, minimum=0.01, maximum=60.0, live=True)
    """s of being blocked before the follower asks for a new plan."""
    stray_distance: float = parameter(0.25, minimum=0.01, maximum=10.0, live=True)
    """m from the path (a pose that jumped, a robot pushed off): stop and ask for a new plan."""
    progress_window: float = parameter(0.5, minimum=0.01, maximum=100.0, live=True)
    """m of path ahead of the last closest point searched for the next one (a path passing close to
    itself is not short-cut)."""
    speed_limit_timeout: float = parameter(1.0, minimum=0.01, maximum=60.0, live=True)
    """s (the observations' clock): a speed limit on speed_limit (amr_interfaces/SpeedLimit, the navigator's
    traffic rules) applies to observations at most this much newer than its stamp; older it has expired and
    the path follower goes uncapped (a navigator that stopped advising cannot hold the robot for ever; under a
    navigator nothing drives without its fresh status anyway)."""

    def validate(self) -> None:
        if self.min_linear_speed > self.linear_speed:
            raise ConfigError(
                f"min_linear_speed ({self.min_linear_speed}) must not exceed linear_speed ({self.linear_speed})"
            )
        if not self.aligned_angle_deg < self.align_angle_deg:
            raise ConfigError(
                f"need aligned_angle_deg ({self.aligned_angle_deg}) < align_angle_deg ({self.align_angle_deg}) <= 180"
            )
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
