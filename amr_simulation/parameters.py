"""The simulator node's ROS parameters: SimulationConfig's (flat, dotted: "lidar.beams"; stated there) plus
the node's own topics, frames and timers below, no ROS.

Live (applied at the next step while the node runs): sensor and encoder noise, slip, the realtime command
timeout, the render path, the pace. Everything else shapes the world, the robot or the node's interfaces and is
refused while configured.
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Callable
from pathlib import Path

from amr_simulation.config import SimulationConfig
from amr_util.parameter_spec import ParameterSpec

NODE_SPECS = (
    ParameterSpec("publish_odometry", True, "odometry: nav_msgs/Odometry, encoder pose and encoder twist"),
    ParameterSpec("publish_odom", True, "odom: nav_msgs/Odometry, encoder pose, zero twist (a real TurtleBot3)"),
    ParameterSpec("publish_ground_truth", True, "ground_truth: nav_msgs/Odometry, true pose and body twist"),
    ParameterSpec("publish_scan", True, "scan: sensor_msgs/LaserScan, sensor-data QoS"),
    ParameterSpec("publish_status", True, "~/status: amr_interfaces/SimulatorStatus, after every observation"),
    ParameterSpec("odom_frame", "odom", "frame of odometry and odom poses (REP 105)"),
    ParameterSpec("world_frame", "map", "frame of ground_truth poses: the world, where odom starts"),
    ParameterSpec("base_frame", "base_footprint", "child frame of the odometry messages"),
    ParameterSpec("scan_frame", "base_scan", "frame of the LaserScan"),
    ParameterSpec(
        "publish_clock",
        True,
        "/clock: rosgraph_msgs/Clock, the simulated time, before every observation (nodes on use_sim_time follow it)",
    ),
    ParameterSpec(
        "publish_tf",
        True,
        "/tf odom_frame -> base_frame (encoder pose, every observation) and /tf_static "
        "base_frame -> scan_frame (the LiDAR mounting lidar.x, lidar.y; transient local)",
    ),
    ParameterSpec(
        "publish_map_to_odom",
        False,
        "/tf world_frame -> odom_frame from the ground truth, so that map-frame "
        "views work without a localizer (whose job it is otherwise)",
    ),
    ParameterSpec(
        "one_tf_tree",
        False,
        "a world with `robots`: every robot's transforms on the one /tf and /tf_static "
        "with frames prefixed by its name (<name>/odom, <name>/base_footprint; world_frame shared), as "
        "Stage's one_tf_tree, for views of the whole fleet; false: /<name>/tf and /<name>/tf_static with "
        "plain frame names, as nav2's multi-robot bringup. No effect on a one-robot world",
    ),
    ParameterSpec("qos_depth", 10, "queue depth of /cmd_vel and the reliable publishers", minimum=1, maximum=1000),
    ParameterSpec(
        "lockstep_resend_period",
        1.0,
        "lockstep: wall-clock s without a /cmd_vel after which the last "
        "observation goes out again (one sent before the controller listened); 0 disables",
        minimum=0.0,
        maximum=60.0,
    ),
    ParameterSpec(
        "enable_localization",
        False,
        "compare /pose (a localizer's LocalizedPose) with the ground truth: "
        "log the first localization, report the estimate's error in ~/status",
    ),
    ParameterSpec(
        "lockstep_pose_wait",
        0.0,
        "lockstep with enable_localization: wall-clock s at most that each step "
        "also waits for the localizer's /pose answering the last observation (a filter outside the loop "
        "starves when the loop runs faster than it); 0 = the localizer is not waited for",
        minimum=0.0,
        maximum=60.0,
    ),
    ParameterSpec(
        "scan_period",
        0.0,
        "realtime mode: s between two published scans, the nearest whole number of "
        "steps (0.2: a 5 Hz LDS-01 while odometry goes out every step); 0 = every step, as lockstep always "
        "does (a lockstep observation is odometry and scan together)",
        minimum=0.0,
        maximum=60.0,
    ),
    ParameterSpec(
        "render_path", str(Path(tempfile.gettempdir()) / "amr_simulator.png"), "PNG file ~/render writes", live=True
    ),
    ParameterSpec(
        "pace",
        0.0,
        "simulated seconds per wall-clock second at most: lockstep 0 = each /cmd_vel steps at "
        "once (as fast as the loop goes), N = each command held until a steady timer at dt / N releases it; "
        "realtime 0 = `rate`, N = N x real time instead of `rate`",
        minimum=0.0,
        maximum=1000.0,
        live=True,
    ),
)
"""The node's own parameters (topics, frames, timers): the library's are SimulationConfig's."""
NODE_PARAMETERS = frozenset(spec.name for spec in NODE_SPECS)


def parameter_specs(world_problem: Callable[[str], str | None] | None = None) -> tuple[ParameterSpec, ...]:
    """Every parameter of the simulator node; `world_problem` checks that a world name resolves."""
    specs = SimulationConfig.parameter_specs()
    if world_problem is not None:
        specs = tuple(
            dataclasses.replace(spec, check=world_problem) if spec.name == "world" else spec for spec in specs
        )
    return specs + NODE_SPECS
