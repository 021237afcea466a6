"""The simulator node's ROS parameters: one spec each, no ROS.

The library's parameters are SimulationConfig's fields (flat, dotted: "lidar.beams"), described by
their docstrings; the node adds its topics, frames and timers. Live (applied at the next step while
the node runs): sensor and encoder noise, slip, the realtime command timeout, the render path, the pace.
Everything else shapes the world, the robot or the node's interfaces and is refused while
configured.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

from amr_simulation.config import MODES, RAY_CAST_METHODS, BeaconConfig, EncoderConfig, LidarConfig, RobotConfig
from amr_simulation.config import SimulationConfig
from amr_simulation.config import param_defaults
from amr_util.parameter_spec import ParameterSpec, field_docs

LIVE = frozenset({"lidar.noise_std", "encoders.noise", "encoders.slip", "beacons.range_noise_std",
                  "beacons.compass_noise_std", "command_timeout", "render_path", "pace"})
RANGES: dict[str, tuple[float, float]] = {
    "dt": (0.001, 1.0), "seed": (0, 2**31 - 1), "max_substep_distance": (0.0001, 0.1), "rate": (0.01, 1000.0),
    "command_timeout": (0.0, 60.0), "robot.radius": (0.01, 2.0), "robot.wheel_radius": (0.005, 1.0),
    "robot.track": (0.01, 2.0), "robot.max_wheel_speed": (0.01, 1000.0), "robot.max_linear": (0.01, 10.0),
    "robot.max_angular": (0.01, 20.0), "lidar.beams": (1, 10000), "lidar.angle_min": (-2 * math.pi, 2 * math.pi),
    "lidar.fov": (0.001, 2 * math.pi), "lidar.range_min": (0.0, 100.0), "lidar.range_max": (0.01, 1000.0),
    "lidar.noise_std": (0.0, 1.0), "lidar.x": (-2.0, 2.0), "lidar.y": (-2.0, 2.0), "encoders.noise": (0.0, 1.0),
    "encoders.slip": (0.0, 1.0), "beacons.range_noise_std": (0.0, 10.0), "beacons.compass_noise_std": (0.0, 3.2), "qos_depth": (1, 1000), "lockstep_resend_period": (0.0, 60.0),
    "pace": (0.0, 1000.0),
}
CHOICES = {"mode": MODES, "lidar.method": RAY_CAST_METHODS}
NODE_PARAMETERS = {
    "publish_odometry": (True, "odometry: nav_msgs/Odometry, encoder pose and encoder twist"),
    "publish_odom": (True, "odom: nav_msgs/Odometry, encoder pose, zero twist (a real TurtleBot3)"),
    "publish_ground_truth": (True, "ground_truth: nav_msgs/Odometry, true pose and body twist"),
    "publish_scan": (True, "scan: sensor_msgs/LaserScan, sensor-data QoS"),
    "publish_status": (True, "~/status: amr_interfaces/SimulatorStatus, after every observation"),
    "odom_frame": ("odom", "frame of odometry and odom poses (REP 105)"),
    "world_frame": ("map", "frame of ground_truth poses: the world, where odom starts"),
    "base_frame": ("base_footprint", "child frame of the odometry messages"),
    "scan_frame": ("base_scan", "frame of the LaserScan"),
    "publish_clock": (True, "/clock: rosgraph_msgs/Clock, the simulated time, before every observation (nodes "
                            "on use_sim_time follow it)"),
    "publish_tf": (True, "/tf odom_frame -> base_frame (encoder pose, every observation) and /tf_static "
                         "base_frame -> scan_frame (the LiDAR mounting lidar.x, lidar.y; transient local)"),
    "publish_map_to_odom": (False, "/tf world_frame -> odom_frame from the ground truth, so that map-frame views "
                                   "work without a localizer (whose job it is otherwise)"),
    "qos_depth": (10, "queue depth of /cmd_vel and the reliable publishers"),
    "lockstep_resend_period": (1.0, "lockstep: wall-clock s without a /cmd_vel after which the last observation "
                                    "goes out again (one sent before the controller listened); 0 disables"),
    "enable_localization": (False, "compare /pose (a localizer's LocalizedPose) with the ground truth: log the first "
                                   "localization, report the estimate's error in ~/status"),
    "render_path": (str(Path(tempfile.gettempdir()) / "amr_simulator.png"), "PNG file ~/render writes"),
    "pace": (0.0, "simulated seconds per wall-clock second at most: lockstep 0 = each /cmd_vel steps at once (as "
                  "fast as the loop goes), N = a held command steps on a timer at dt / N; realtime 0 = `rate`, "
                  "N = N x real time instead of `rate`"),
}


def _start_problem(value: Sequence[float]) -> str | None:
    return None if len(value) in (0, 3) else "must be [x, y, theta] or [] (the world's start)"


def parameter_specs(world_problem: Callable[[str], str | None] | None = None) -> tuple[ParameterSpec, ...]:
    """Every parameter of the simulator node; `world_problem` checks that a world name resolves."""
    docs = field_docs(SimulationConfig)
    for prefix, section in (("robot.", RobotConfig), ("lidar.", LidarConfig), ("encoders.", EncoderConfig),
                            ("beacons.", BeaconConfig)):
        docs.update({prefix + name: text for name, text in field_docs(section).items()})
    specs = [ParameterSpec("start", [], docs["start"] + " [] = the world's start.", kind="float_array",
                           check=_start_problem)]
    for name, default in param_defaults().items():
        low, high = RANGES.get(name, (None, None))
        specs.append(ParameterSpec(
            name, default, docs.get(name, ""), minimum=low, maximum=high, choices=CHOICES.get(name, ()),
            live=name in LIVE, check=world_problem if name == "world" else None))
    for name, (default, description) in NODE_PARAMETERS.items():
        low, high = RANGES.get(name, (None, None))
        specs.append(ParameterSpec(name, default, description, minimum=low, maximum=high, live=name in LIVE))
    return tuple(specs)
