"""The planner node's ROS parameters: one spec per PlannerConfig field, no ROS.

Descriptions are PlannerConfig's field docstrings. Structural parameters shape what configure
builds (the map source, its resolution, the search and its roadmap) and are refused while
configured; the others (costmap and smoothing weights, snapping) are live: the costmap is
rebuilt from the current map and used from the next plan.
"""

from __future__ import annotations

import dataclasses

from amr_planning.planner import PLANNERS, PlannerConfig
from amr_util.parameter_spec import ParameterSpec, field_docs

STRUCTURAL = frozenset({"world", "resolution", "planner", "prm_node_count", "prm_connection_distance", "prm_seed"})
RANGES: dict[str, tuple[float, float]] = {
    "resolution": (0.005, 1.0), "snap_distance": (0.0, 5.0),
    "robot_radius": (0.01, 2.0), "safety_margin": (0.0, 1.0), "cost_weight": (0.0, 1000.0),
    "cost_distance": (0.001, 5.0), "margin_cost": (0.0, 1e6), "prm_node_count": (1, 1_000_000),
    "prm_connection_distance": (0.01, 100.0), "prm_seed": (0, 2**31 - 1), "smoothing_data_weight": (0.001, 1.0),
    "smoothing_smooth_weight": (0.0, 0.5), "smoothing_spacing": (0.001, 1.0),
}


def parameter_specs() -> tuple[ParameterSpec, ...]:
    """Every parameter of the planner node, with its default from PlannerConfig."""
    docs = field_docs(PlannerConfig)
    defaults = PlannerConfig()
    specs = []
    for field in dataclasses.fields(PlannerConfig):
        low, high = RANGES.get(field.name, (None, None))
        specs.append(ParameterSpec(
            field.name, getattr(defaults, field.name), docs.get(field.name, ""), minimum=low, maximum=high,
            choices=PLANNERS if field.name == "planner" else (), live=field.name not in STRUCTURAL))
    return tuple(specs)
