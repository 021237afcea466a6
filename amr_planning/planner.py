"""One planner for the node and the benchmarks: costmap, search (grid A* or the roadmap), smoothing.

`PlannerConfig` is the flat parameter dict of the `planner` node, each parameter stated once
(amr_util.parameter_spec; the costmap, roadmap and smoothing limits by their own configs). Structural:
the map source, its resolution, the search and its roadmap; live: the costmap and smoothing weights and
snapping (the node rebuilds the costmap from the current map). When to plan and to which goal is the
navigator's decision (amr_navigation), not the planner's. `Planner` builds the costmap of
one map once and answers plan(start, goal) with a smoothed path, or a PlanningError naming why there is
none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_maps.occupancy_grid import OccupancyGrid
from amr_planning.astar import GridAStar
from amr_planning.costmap import Costmap, CostmapConfig
from amr_planning.roadmap import Roadmap, RoadmapConfig
from amr_planning.smoothing import SmoothingConfig, smooth_path
from amr_util.parameter_spec import Config, parameter, parameter_like

NODE_NAME = "planner"
PLANNERS = ("astar", "prm")


@dataclass(frozen=True)
class PlannerConfig(Config):
    """The planner node's parameters; the costmap, roadmap and smoothing ones are stated by CostmapConfig,
    RoadmapConfig and SmoothingConfig (limits, defaults) under the node's flat names."""

    # -- where the map comes from (node shell) ------------------------------------------------------
    world: str = parameter("")
    """a world file (name in the worlds directory or a path) rasterized as the map; "" = the /map topic."""
    resolution: float = parameter(0.025, minimum=0.005, maximum=1.0)
    """m/cell when rasterizing a world (0.35 m corridors need 0.025: the map's estimate is conservative)."""
    # -- the search --------------------------------------------------------------------------------
    planner: str = parameter("astar", choices=PLANNERS)
    """'astar' (grid A*, the default) or 'prm' (the course's probabilistic roadmap)."""
    snap_distance: float = parameter_like(RoadmapConfig, "snap_distance", live=True)
    """m a start or goal closer to a wall than the robot's radius may be moved to the nearest free cell."""
    robot_radius: float = parameter_like(CostmapConfig, "robot_radius", live=True)
    """m, the disc footprint: cells closer to an obstacle are lethal."""
    safety_margin: float = parameter_like(CostmapConfig, "safety_margin", live=True)
    """m kept from obstacles where there is room; inside it cells cost margin_cost more."""
    cost_weight: float = parameter_like(CostmapConfig, "cost_weight", live=True)
    """extra cost at the margin's edge, fading over cost_distance: paths keep to corridor middles."""
    cost_distance: float = parameter_like(CostmapConfig, "cost_distance", live=True)
    """m beyond the margin over which the extra cost fades to zero."""
    margin_cost: float = parameter_like(CostmapConfig, "margin_cost", live=True)
    """extra cost of a cell inside the safety margin (used only where there is no other way)."""
    prm_node_count: int = parameter_like(RoadmapConfig, "node_count")
    """roadmap nodes (course: 250)."""
    prm_connection_distance: float = parameter_like(RoadmapConfig, "connection_distance")
    """m, the longest roadmap edge tried."""
    prm_seed: int = parameter_like(RoadmapConfig, "seed")
    """the same seed and map give the same roadmap."""
    smoothing_data_weight: float = parameter_like(SmoothingConfig, "data_weight", live=True)
    """gradient smoothing's pull towards the planned points (course: 0.1)."""
    smoothing_smooth_weight: float = parameter_like(SmoothingConfig, "smooth_weight", live=True)
    """gradient smoothing's pull towards the neighbours' midpoint (course: 0.3; at most 0.5)."""
    smoothing_spacing: float = parameter_like(SmoothingConfig, "spacing", live=True)
    """m, the largest gap between path points before smoothing."""

    @property
    def costmap(self) -> CostmapConfig:
        return CostmapConfig(
            self.robot_radius, self.safety_margin, self.cost_weight, self.cost_distance, self.margin_cost
        )

    @property
    def roadmap(self) -> RoadmapConfig:
        return RoadmapConfig(self.prm_node_count, self.prm_connection_distance, self.prm_seed, self.snap_distance)

    @property
    def smoothing(self) -> SmoothingConfig:
        return SmoothingConfig(self.smoothing_data_weight, self.smoothing_smooth_weight, self.smoothing_spacing)


class Planner:
    """The costmap of one map and the configured search; plan() gives smoothed paths."""

    def __init__(
        self, grid: OccupancyGrid, config: PlannerConfig | None = None, costmap: Costmap | None = None
    ) -> None:
        self.config = config or PlannerConfig()
        self.costmap = costmap if costmap is not None else Costmap(grid, self.config.costmap)
        if self.config.planner == "prm":
            self._search = Roadmap(self.costmap, self.config.roadmap)
        else:
            self._search = GridAStar(self.costmap, self.config.snap_distance)

    def with_obstacles(self, points, radius: float) -> Planner:
        """A planner of the same config on a copy of this map with discs of `radius` around `points` (N, 2)
        marked occupied (Costmap.with_obstacles): to plan around obstacles seen but not on the map."""
        return Planner(self.costmap.grid, self.config, self.costmap.with_obstacles(points, radius))

    def plan(self, start, goal) -> np.ndarray:
        """The smoothed path (N, 2) from start (x, y) to goal (x, y); PlanningError if there is none."""
        raw = self._search.plan(start, goal)
        return smooth_path(raw.points, self.costmap, self.config.smoothing)


def distance_to_path(points: np.ndarray, x: float, y: float) -> float:
    """m from (x, y) to the polyline `points` (N, 2)."""
    points = np.asarray(points, dtype=float)
    if len(points) == 1:
        return float(math.hypot(x - points[0, 0], y - points[0, 1]))
    starts, vectors = points[:-1], np.diff(points, axis=0)
    lengths = (vectors**2).sum(axis=1)
    rel = np.array([x, y]) - starts
    t = np.clip(np.divide((rel * vectors).sum(axis=1), lengths, out=np.zeros_like(lengths), where=lengths > 0), 0, 1)
    return float(np.hypot(*(starts + t[:, None] * vectors - (x, y)).T).min())
