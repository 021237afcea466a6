"""The wall follower's ROS parameters: one spec per WallFollowerConfig field, no ROS.

Descriptions are the field docstrings of WallFollowerConfig; ranges are the physically sensible
limits a ROS user sees in `ros2 param describe` (the config's own checks, e.g. turn_exit_distance
above front_threshold, still apply to the whole set). Structural parameters shape what configure
builds (publisher type, timer, synchronizer, RNG) and are refused while configured; every other
one is live: validated and applied to the controller at the next scan.
"""

from __future__ import annotations

import dataclasses

from amr_control.wall_follower_config import WALLS, WallFollowerConfig
from amr_util.parameter_spec import ParameterSpec, field_docs

STRUCTURAL = frozenset({"simulation", "enable_localization", "dt", "sync_slop", "sync_queue_size", "stamp_jump_threshold", "random_seed"})
RANGES: dict[str, tuple[float, float]] = {
    "dt": (0.001, 1.0), "sync_slop": (0.0, 100.0), "sync_queue_size": (1, 1000), "stamp_jump_threshold": (0.01, 3600.0), "stale_timeout": (0.001, 10.0),
    "random_seed": (0, 2**31 - 1), "target_wall_distance": (0.05, 2.0), "front_threshold": (0.05, 2.0),
    "kp": (0.0, 100.0), "kd": (0.0, 100.0), "derivative_filter_time": (0.0, 10.0), "linear_speed": (0.001, 5.0),
    "turn_speed": (0.01, 10.0), "angular_limit": (0.01, 10.0), "stabilize_speed": (0.0, 5.0),
    "stabilize_time": (0.0, 10.0), "turn_exit_distance": (0.05, 5.0), "wall_lost_distance": (0.05, 5.0),
    "corner_advance": (0.0, 2.0), "corner_exit_distance": (0.01, 5.0), "symmetric_tolerance": (0.0, 1.0),
    "front_window_deg": (1.0, 89.0), "side_window_deg": (1.0, 89.0), "abeam_window_deg": (0.5, 89.0),
    "line_fit_tolerance": (0.001, 1.0), "max_skew_deg": (1.0, 89.0), "align_gain": (0.0, 20.0),
    "robot_radius": (0.01, 2.0), "lidar_x": (-1.0, 1.0), "safety_margin": (0.0, 1.0), "max_stamp_gap": (0.01, 60.0),
    "turn_timeout_factor": (1.0, 20.0), "scan_median_beams": (1, 15), "wall_lost_hysteresis": (0.0, 0.5),
    "open_travel_distance": (0.05, 3.0), "open_sweep_deg": (91.0, 179.0),
    "wall_direction_window_deg": (1.0, 89.0),
}


def parameter_specs() -> tuple[ParameterSpec, ...]:
    """Every parameter of the wall_follower node, with its default from WallFollowerConfig."""
    docs = field_docs(WallFollowerConfig)
    defaults = WallFollowerConfig()
    specs = []
    for field in dataclasses.fields(WallFollowerConfig):
        low, high = RANGES.get(field.name, (None, None))
        specs.append(ParameterSpec(
            field.name, getattr(defaults, field.name), docs.get(field.name, ""), minimum=low, maximum=high,
            choices=WALLS if field.name == "preferred_wall" else (), live=field.name not in STRUCTURAL))
    return tuple(specs)
