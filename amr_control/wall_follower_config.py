"""Parameters of the wall follower node, each stated once (type, default, range, live or structural,
description), no ROS.

One flat dict of ROS 2 parameters (``config/wall_follower_*.yaml``, node name ``wall_follower``)
configures both the controller and its node shell; the node declares
``WallFollowerConfig.parameter_specs()`` and hands the values to :meth:`WallFollowerConfig.from_params`.
Unknown keys, wrong types and values out of range raise :class:`ConfigError` naming the key, so a
typo never falls back to a default. Structural parameters shape what configure builds (publisher
type, timer, synchronizer, RNG) and are refused while configured; live ones are applied to the
controller at the next scan. Defaults are seed 002's simulation values; angles are in degrees where
the key says ``_deg``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from amr_control.navigated import STEPPINGS
from amr_util.parameter_spec import Config, ConfigError, parameter
from amr_util.robot_description import default_robot

NODE_NAME = "wall_follower"
WALLS = ("right", "left", "random")


def _odd(beams: int) -> str | None:
    return None if beams % 2 else f"must be odd (a median centred on the beam), got {beams}"


@dataclass(frozen=True)
class WallFollowerConfig(Config):
    # -- node shell --------------------------------------------------------------------
    simulation: bool = parameter(True)
    """True: /cmd_vel is TwistStamped and commands are computed in the synchronized callback
    (lockstep). False: Twist, and a timer computes every dt from the latest pair (seed 5.2.2)."""
    stepping: str = parameter("lockstep", choices=STEPPINGS)
    """How the world steps, as the stack declares it (its mode argument sets the simulator's too); with simulation
    and navigated. lockstep: a command answers only an observation given to this node. realtime: also one zero
    command when the navigator gives the robot to nobody (the explicit hold: nobody else answers, time goes on)."""
    dt: float = parameter(0.05, minimum=0.001, maximum=1.0)
    """s, control period (timer period on the real robot)."""
    sync_slop: float = parameter(10.0, minimum=0.0, maximum=100.0)
    """s, the most the /odometry and /scan stamps of one pair may differ (seed: 10 sim, 0.15 real)."""
    sync_queue_size: int = parameter(10, minimum=1, maximum=1000)
    """messages kept per topic while waiting for a partner."""
    stamp_jump_threshold: float = parameter(0.5, minimum=0.01, maximum=3600.0)
    """s; a stamp this much older than the last synchronized one means the clock jumped (a simulator
    reset, or normal stamps after one far in the future): synchronizer and controller start afresh."""
    stale_timeout: float = parameter(0.1, minimum=0.001, maximum=10.0, live=True)
    """s without a new synchronized pair before the node publishes zero velocity (2 dt)."""
    flip_angular_sign: bool = parameter(False, live=True)
    """Publish -w: seed 002 section 5.2.1 found the real robot's angular sign clockwise-positive."""
    navigated: bool = parameter(False)
    """Pair the navigator's navigator/status (amr_interfaces/NavigatorStatus, one per observation) with
    /odometry and /scan and answer only the observations it gives this node (amr_navigation decides who
    drives; in lockstep exactly one command answers each observation across every hand-over)."""
    # -- behaviour -------------------------------------------------------------------
    preferred_wall: str = parameter("right", choices=WALLS, live=True)
    """'right' or 'left': keep that hand on the wall (takes every opening on that side).
    'random': the hand is drawn at start and at every symmetric junction (seed's random choice)."""
    random_seed: int = parameter(0, minimum=0, maximum=2**31 - 1)
    """Seeds the choices at symmetric junctions, so runs are reproducible."""
    target_wall_distance: float = parameter(0.2, minimum=0.05, maximum=2.0, live=True)
    """m, from the LiDAR to the followed wall (the middle of a 0.4 m corridor)."""
    front_threshold: float = parameter(0.23, minimum=0.05, maximum=2.0, live=True)
    """m, a return closer than this in the front window stops the robot and starts a turn."""
    kp: float = parameter(4.0, minimum=0.0, maximum=100.0, live=True)
    """rad/s per m of distance error."""
    kd: float = parameter(5.0, minimum=0.0, maximum=100.0, live=True)
    """rad/s per m/s of distance-error rate: along a straight wall v sin(skew) from the filtered skew,
    else the derivative over the real time between stamps."""
    derivative_filter_time: float = parameter(0.0, minimum=0.0, maximum=10.0, live=True)
    """s, time constant of a first-order low-pass on the error rate where it is differentiated; 0 = raw difference."""
    linear_speed: float = parameter(0.15, above=0.0, maximum=5.0, live=True)
    """m/s while following a wall."""
    turn_speed: float = parameter(0.5, minimum=0.01, maximum=10.0, live=True)
    """rad/s of the in-place turns at corners and dead ends."""
    angular_limit: float = parameter(default_robot().max_angular_speed, minimum=0.01, maximum=10.0, live=True)
    """rad/s, saturation of the PD output (seed: none in simulation, 0.34 on the real robot; default: the robot
    description's max_angular_speed)."""
    stabilize_speed: float = parameter(0.1, minimum=0.0, maximum=5.0, live=True)
    """m/s, straight ahead after each turn (the seed's Fixed_Front state)."""
    stabilize_time: float = parameter(0.35, minimum=0.0, maximum=10.0, live=True)
    """s of the stabilization phase before wall following resumes."""
    turn_exit_distance: float = parameter(0.423, minimum=0.05, maximum=5.0, live=True)
    """m, a turn ends once its angle is done and the narrow window ahead reads at least this
    (seed: front_threshold * sqrt 2 * 1.3 = 0.423 for 0.23); a square turn also ends there when the
    way ahead is open (open_travel_distance), as at a T-junction with less room ahead than this."""
    wall_lost_distance: float = parameter(0.4, minimum=0.05, maximum=5.0, live=True)
    """m, a side reading beyond this is an opening, not a wall."""
    corner_advance: float = parameter(0.15, minimum=0.0, maximum=2.0, live=True)
    """m driven past the point the followed wall was lost before turning into the opening, where its
    end is not seen; where it is, the turn comes once the rotation centre is target_wall_distance past it."""
    corner_exit_distance: float = parameter(0.45, minimum=0.01, maximum=5.0, live=True)
    """m driven after a turn looking for the followed wall before searching straight on."""
    symmetric_tolerance: float = parameter(0.05, minimum=0.0, maximum=1.0, live=True)
    """m, side readings closer than this count as a symmetric junction (seed: 0.05)."""
    front_window_deg: float = parameter(15.0, minimum=1.0, below=90.0, live=True)
    """half width of the front window."""
    side_window_deg: float = parameter(20.0, minimum=1.0, below=90.0, live=True)
    """half width of the side windows (centred at +-90 deg) whose minimum is the wall distance."""
    abeam_window_deg: float = parameter(5.0, minimum=0.5, below=90.0, live=True)
    """half width of the narrow windows abeam (and ahead) that tell a wall from an opening."""
    line_fit_tolerance: float = parameter(0.03, minimum=0.001, maximum=1.0, live=True)
    """m, the most a side window's returns may scatter about their fitted line for it to count as a
    straight wall (its distance then feeds the PD and its angle aligns straight runs and turns)."""
    wall_direction_window_deg: float = parameter(40.0, minimum=1.0, below=90.0, live=True)
    """half width of the side windows whose fitted lines give the walls' direction (the skew that
    squares the turns and aligns straight runs); wider than side_window_deg, as a short piece of
    wall gives a poor direction: 0.175 m from a wall at 3 cm LiDAR noise, +-20 deg of it scatter
    by 16 deg, +-40 deg by 3 deg."""
    max_skew_deg: float = parameter(30.0, minimum=1.0, maximum=89.0, live=True)
    """a fitted wall further than this from parallel is not used as a heading reference."""
    align_gain: float = parameter(1.5, minimum=0.0, maximum=20.0, live=True)
    """1/s, heading correction towards a fitted side wall on straight runs (w = gain * wall angle)."""
    robot_radius: float = parameter(default_robot().radius, minimum=0.01, maximum=2.0, live=True)
    """m, the disc the safety check keeps clear (default: the robot description's footprint)."""
    lidar_x: float = parameter(default_robot().lidar_x, minimum=-1.0, maximum=1.0, live=True)
    """m, LiDAR position ahead of the rotation centre (default: the robot description's mount)."""
    safety_margin: float = parameter(0.02, minimum=0.0, maximum=1.0, live=True)
    """m: with less straight-ahead travel before the disc touches a return, the robot turns away in place."""
    max_stamp_gap: float = parameter(0.5, minimum=0.01, maximum=60.0, live=True)
    """s, a longer gap between stamps resets the derivative and caps the progress integration."""
    turn_timeout_factor: float = parameter(2.0, minimum=1.0, maximum=20.0, live=True)
    """a turn also ends after this many times its nominal duration (angle / turn_speed)."""
    scan_median_beams: int = parameter(3, above=0, maximum=15, check=_odd, live=True)
    """odd, >= 1: each scan first goes through a running median over this many beams, which
    removes single-beam outliers (a spurious short return or a dropped one); 1 = off."""
    wall_lost_hysteresis: float = parameter(0.03, minimum=0.0, maximum=0.5, live=True)
    """m, >= 0: while following, the wall counts as lost only beyond wall_lost_distance plus this,
    so LiDAR noise about that distance does not toggle FOLLOW and CORNER."""
    open_travel_distance: float = parameter(0.35, above=0.0, maximum=3.0, live=True)
    """m, > 0: with the front blocked, a direction is open when the footprint could drive this far
    along it after turning in place; the turn aims at the middle of an open run of directions."""
    open_sweep_deg: float = parameter(150.0, above=90.0, below=180.0, live=True)
    """deg, in (90, 180): directions within this of ahead are candidates for a turn; with none open
    (front, left and right closed within the turning room) the robot is in a dead end."""

    def validate(self) -> None:
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
