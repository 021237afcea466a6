"""Parameters of the wall follower node: defaults, types and validation, no ROS.

One flat dict of ROS 2 parameters (``config/wall_follower_*.yaml``, node name
``wall_follower``) configures both the controller and its node shell; the node
declares every key of :func:`parameter_defaults` and hands the values to
:meth:`WallFollowerConfig.from_params`. Unknown keys and wrong types raise
:class:`ConfigError` naming the key, so a typo never falls back to a default.
Defaults are seed 002's simulation values; angles are in degrees where the
key says ``_deg``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from amr_control.flat_config import ConfigError, FlatConfig

NODE_NAME = "wall_follower"
WALLS = ("right", "left", "random")


@dataclass(frozen=True)
class WallFollowerConfig(FlatConfig):
    # -- node shell --------------------------------------------------------------------
    simulation: bool = True
    """True: /cmd_vel is TwistStamped and commands are computed in the synchronized callback
    (lockstep). False: Twist, and a timer computes every dt from the latest pair (seed 5.2.2)."""
    dt: float = 0.05
    """s, control period (timer period on the real robot)."""
    sync_slop: float = 10.0
    """s, the most the /odometry and /scan stamps of one pair may differ (seed: 10 sim, 0.15 real)."""
    sync_queue_size: int = 10
    """messages kept per topic while waiting for a partner."""
    stamp_jump_threshold: float = 0.5
    """s; a stamp this much older than the last synchronized one means the clock jumped (a simulator
    reset, or normal stamps after one far in the future): synchronizer and controller start afresh."""
    stale_timeout: float = 0.1
    """s without a new synchronized pair before the node publishes zero velocity (2 dt)."""
    flip_angular_sign: bool = False
    """Publish -w: seed 002 section 5.2.1 found the real robot's angular sign clockwise-positive."""
    enable_localization: bool = False
    """Pair /pose (amr_interfaces/LocalizedPose, one per observation) with /odometry and /scan, explore
    while it says not localized and publish nothing once it says localized: the path follower answers
    those observations (issue 12; in lockstep exactly one of the two commands each step)."""
    # -- behaviour -------------------------------------------------------------------
    preferred_wall: str = "right"
    """'right' or 'left': keep that hand on the wall (takes every opening on that side).
    'random': the hand is drawn at start and at every symmetric junction (seed's random choice)."""
    random_seed: int = 0
    """Seeds the choices at symmetric junctions, so runs are reproducible."""
    target_wall_distance: float = 0.2
    """m, from the LiDAR to the followed wall (the middle of a 0.4 m corridor)."""
    front_threshold: float = 0.23
    """m, a return closer than this in the front window stops the robot and starts a turn."""
    kp: float = 4.0
    """rad/s per m of distance error."""
    kd: float = 5.0
    """rad/s per m/s of distance-error rate (derivative over the real time between stamps)."""
    derivative_filter_time: float = 0.0
    """s, time constant of a first-order low-pass on the error rate; 0 = raw difference."""
    linear_speed: float = 0.15
    """m/s while following a wall."""
    turn_speed: float = 0.5
    """rad/s of the in-place turns at corners and dead ends."""
    angular_limit: float = 2.84
    """rad/s, saturation of the PD output (seed: none in simulation, 0.34 on the real robot)."""
    stabilize_speed: float = 0.1
    """m/s, straight ahead after each turn (the seed's Fixed_Front state)."""
    stabilize_time: float = 0.35
    """s of the stabilization phase before wall following resumes."""
    turn_exit_distance: float = 0.423
    """m, a turn ends once its angle is done and the narrow window ahead reads at least this
    (seed: front_threshold * sqrt 2 * 1.3 = 0.423 for 0.23)."""
    wall_lost_distance: float = 0.4
    """m, a side reading beyond this is an opening, not a wall."""
    corner_advance: float = 0.15
    """m driven past the end of the followed wall before turning into the opening."""
    corner_exit_distance: float = 0.45
    """m driven after a turn looking for the followed wall before searching straight on."""
    symmetric_tolerance: float = 0.05
    """m, side readings closer than this count as a symmetric junction (seed: 0.05)."""
    front_window_deg: float = 15.0
    """half width of the front window."""
    side_window_deg: float = 20.0
    """half width of the side windows (centred at +-90 deg) whose minimum is the wall distance."""
    abeam_window_deg: float = 5.0
    """half width of the narrow windows abeam (and ahead) that tell a wall from an opening."""
    line_fit_tolerance: float = 0.03
    """m, the most a side window's returns may scatter about their fitted line for it to count as a
    straight wall (its distance then feeds the PD and its angle aligns straight runs and turns)."""
    max_skew_deg: float = 30.0
    """a fitted wall further than this from parallel is not used as a heading reference."""
    align_gain: float = 1.5
    """1/s, heading correction towards a fitted side wall on straight runs (w = gain * wall angle)."""
    robot_radius: float = 0.105
    """m, the disc the safety check keeps clear (TurtleBot3 Burger)."""
    lidar_x: float = -0.032
    """m, LiDAR position ahead of the rotation centre (Burger: 3.2 cm behind the axle)."""
    safety_margin: float = 0.02
    """m: with less straight-ahead travel before the disc touches a return, the robot turns away in place."""
    max_stamp_gap: float = 0.5
    """s, a longer gap between stamps resets the derivative and caps the progress integration."""
    turn_timeout_factor: float = 2.0
    """a turn also ends after this many times its nominal duration (angle / turn_speed)."""
    scan_median_beams: int = 3
    """odd, >= 1: each scan first goes through a running median over this many beams, which
    removes single-beam outliers (a spurious short return or a dropped one); 1 = off."""
    wall_lost_hysteresis: float = 0.03
    """m, >= 0: while following, the wall counts as lost only beyond wall_lost_distance plus this,
    so LiDAR noise about that distance does not toggle FOLLOW and CORNER."""
    open_travel_distance: float = 0.35
    """m, > 0: with the front blocked, a direction is open when the footprint could drive this far
    along it after turning in place; the turn aims at the middle of an open run of directions."""
    wall_direction_window_deg: float = 40.0
    """half width of the side windows whose fitted lines give the walls' direction (the skew that
    squares the turns); wider than side_window_deg, as a short piece of wall gives a poor
    direction: 0.175 m from a wall at 3 cm LiDAR noise, +-20 deg of it scatter by 16 deg, +-40 deg by 3 deg."""
    open_sweep_deg: float = 150.0
    """deg, in (90, 180): directions within this of ahead are candidates for a turn; with none open
    (front, left and right closed within the turning room) the robot is in a dead end."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.type == "float" and not math.isfinite(value):
                raise ConfigError(f"{f.name}: must be finite, got {value!r}")
        positive = (
            "dt", "sync_queue_size", "stamp_jump_threshold", "stale_timeout", "target_wall_distance", "front_threshold",
            "linear_speed", "turn_speed", "angular_limit", "turn_exit_distance", "wall_lost_distance",
            "corner_exit_distance", "front_window_deg", "side_window_deg", "abeam_window_deg", "line_fit_tolerance",
            "max_skew_deg", "robot_radius", "wall_direction_window_deg",
            "max_stamp_gap", "turn_timeout_factor", "scan_median_beams", "open_travel_distance",
        )
        for name in positive:
            if getattr(self, name) <= 0:
                raise ConfigError(f"{name}: must be positive, got {getattr(self, name)!r}")
        non_negative = (
            "sync_slop", "kp", "kd", "derivative_filter_time", "stabilize_speed", "stabilize_time",
            "corner_advance", "symmetric_tolerance", "safety_margin", "random_seed", "align_gain",
            "wall_lost_hysteresis",
        )
        for name in non_negative:
            if getattr(self, name) < 0:
                raise ConfigError(f"{name}: must be >= 0, got {getattr(self, name)!r}")
        if self.scan_median_beams % 2 == 0:
            raise ConfigError(f"scan_median_beams: must be odd (a median centred on the beam), got {self.scan_median_beams}")
        if not 90.0 < self.open_sweep_deg < 180.0:
            raise ConfigError(f"open_sweep_deg: must be in (90, 180) deg, got {self.open_sweep_deg!r}")
        if self.preferred_wall not in WALLS:
            raise ConfigError(f"preferred_wall: must be one of {WALLS}, got {self.preferred_wall!r}")
        for name in ("front_window_deg", "side_window_deg", "abeam_window_deg", "wall_direction_window_deg"):
            if getattr(self, name) >= 90.0:
                raise ConfigError(f"{name}: a half width must stay below 90 deg, got {getattr(self, name)!r}")
        if self.abeam_window_deg > self.side_window_deg:
            raise ConfigError(
                f"abeam_window_deg ({self.abeam_window_deg}) must not exceed side_window_deg ({self.side_window_deg})"
            )
        if self.turn_exit_distance <= self.front_threshold:
            raise ConfigError(
                f"turn_exit_distance ({self.turn_exit_distance}) must exceed front_threshold "
                f"({self.front_threshold}), or a turn could end facing the wall that started it"
            )
        if self.wall_lost_distance <= self.target_wall_distance:
            raise ConfigError(
                f"wall_lost_distance ({self.wall_lost_distance}) must exceed target_wall_distance "
                f"({self.target_wall_distance})"
            )


def parameter_defaults() -> dict[str, Any]:
    """Every parameter with its default value and ROS type (float, int, bool or str)."""
    return WallFollowerConfig().as_params()


def read_parameter_file(path: str | Path, node_name: str = NODE_NAME) -> WallFollowerConfig:
    """The config in a ROS 2 parameter YAML file (``<node_name>: ros__parameters: ...``)."""
    return WallFollowerConfig.read(path, node_name)
