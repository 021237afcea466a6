"""The path follower's ROS parameters: one spec per PathFollowerConfig field, no ROS.

Descriptions are PathFollowerConfig's field docstrings. Structural parameters shape what configure
builds (publisher type, timer, inputs) and are refused while configured; every other one is
live: validated with the whole configuration and used from the next observation.
"""

from __future__ import annotations

import dataclasses

from amr_control.path_follower_config import PathFollowerConfig
from amr_util.parameter_spec import ParameterSpec, field_docs

STRUCTURAL = frozenset({"simulation", "dt", "navigated"})
RANGES: dict[str, tuple[float, float]] = {
    "dt": (0.001, 1.0), "stale_timeout": (0.001, 10.0), "lookahead_distance": (0.01, 5.0),
    "linear_speed": (0.001, 5.0), "min_linear_speed": (0.0, 5.0), "curve_angular_speed": (0.01, 10.0),
    "approach_gain": (0.01, 100.0), "angular_limit": (0.01, 10.0), "turn_speed": (0.01, 10.0),
    "turn_gain": (0.01, 100.0), "align_angle_deg": (1.0, 180.0), "aligned_angle_deg": (0.1, 179.0),
    "goal_tolerance": (0.001, 2.0), "heading_tolerance_deg": (0.1, 179.0), "robot_radius": (0.01, 2.0),
    "lidar_x": (-1.0, 1.0), "safety_margin": (0.0, 1.0), "blocked_replan_time": (0.01, 60.0),
    "stray_distance": (0.01, 10.0), "progress_window": (0.01, 100.0),
}


def parameter_specs() -> tuple[ParameterSpec, ...]:
    """Every parameter of the path_follower node, with its default from PathFollowerConfig."""
    docs = field_docs(PathFollowerConfig)
    defaults = PathFollowerConfig()
    return tuple(
        ParameterSpec(field.name, getattr(defaults, field.name), docs.get(field.name, ""),
                      minimum=RANGES.get(field.name, (None, None))[0], maximum=RANGES.get(field.name, (None, None))[1],
                      live=field.name not in STRUCTURAL)
        for field in dataclasses.fields(PathFollowerConfig))
