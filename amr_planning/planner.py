"""One planner for the node and the benchmarks: costmap, search (grid A* or the roadmap), smoothing.

`PlannerConfig` is the flat parameter dict of the `planner` node (validated by name, as the
controllers' configs); `Planner` builds the costmap of one map once and answers plan(start, goal)
with a smoothed path, or a PlanningError naming why there is none.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from amr_maps.occupancy_grid import OccupancyGrid
from amr_planning.astar import GridAStar
from amr_planning.costmap import Costmap, CostmapConfig, CostmapConfigError
from amr_planning.errors import PlanningError
from amr_planning.roadmap import Roadmap, RoadmapConfig, RoadmapConfigError
from amr_planning.smoothing import SmoothingConfig, SmoothingConfigError, smooth_path
from amr_util.geometry import is_finite_number

NODE_NAME = "planner"
PLANNERS = ("astar", "prm")


class PlannerConfigError(ValueError):
    """A planner parameter with the wrong name, type or value, named."""


@dataclass(frozen=True)
class PlannerConfig:
    # -- where the map and the goal come from (node shell) -----------------------------------------
    world: str = ""
    """a world file (name in the worlds directory or a path) rasterized as the map; "" = the /map topic."""
    resolution: float = 0.025
    """m/cell when rasterizing a world (0.35 m corridors need 0.025: the map's estimate is conservative)."""
    goal: list = dataclasses.field(default_factory=list)
    """[x, y] overriding the world's goal; [] = the world's goal, then /goal_pose."""
    replan_distance: float = 0.25
    """m off the path at which the robot counts as strayed and the planner plans again."""
    # -- the search --------------------------------------------------------------------------------
    planner: str = "astar"
    """'astar' (grid A*, the default) or 'prm' (the course's probabilistic roadmap)."""
    snap_distance: float = 0.3
    """m a start or goal closer to a wall than the robot's radius may be moved to the nearest free cell."""
    robot_radius: float = 0.105
    """m, the disc footprint: cells closer to an obstacle are lethal."""
    safety_margin: float = 0.02
    """m kept from obstacles where there is room; inside it cells cost margin_cost more."""
    cost_weight: float = 3.0
    """extra cost at the margin's edge, fading over cost_distance: paths keep to corridor middles."""
    cost_distance: float = 0.2
    """m beyond the margin over which the extra cost fades to zero."""
    margin_cost: float = 50.0
    """extra cost of a cell inside the safety margin (used only where there is no other way)."""
    prm_node_count: int = 400
    """roadmap nodes (course: 250)."""
    prm_connection_distance: float = 0.6
    """m, the longest roadmap edge tried."""
    prm_seed: int = 0
    """the same seed and map give the same roadmap."""
    smoothing_data_weight: float = 0.1
    """gradient smoothing's pull towards the planned points (course: 0.1)."""
    smoothing_smooth_weight: float = 0.3
    """gradient smoothing's pull towards the neighbours' midpoint (course: 0.3)."""
    smoothing_spacing: float = 0.05
    """m, the largest gap between path points before smoothing."""

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise PlannerConfigError(f"planner: must be one of {PLANNERS}, got {self.planner!r}")
        if len(self.goal) not in (0, 2) or not all(is_finite_number(v) for v in self.goal):
            raise PlannerConfigError(f"goal: must be [] or [x, y] (finite numbers), got {self.goal!r}")
        for name in ("resolution", "replan_distance", "snap_distance"):
            value = getattr(self, name)
            if not (is_finite_number(value) and value > 0.0):
                raise PlannerConfigError(f"{name}: must be a positive number, got {value!r}")
        try:  # the parts validate their own values; their messages name the parameter
            self.costmap, self.roadmap, self.smoothing
        except (CostmapConfigError, RoadmapConfigError, SmoothingConfigError) as error:
            raise PlannerConfigError(str(error)) from error

    @property
    def costmap(self) -> CostmapConfig:
        return CostmapConfig(self.robot_radius, self.safety_margin, self.cost_weight, self.cost_distance,
                             self.margin_cost)

    @property
    def roadmap(self) -> RoadmapConfig:
        return RoadmapConfig(self.prm_node_count, self.prm_connection_distance, self.prm_seed, self.snap_distance)

    @property
    def smoothing(self) -> SmoothingConfig:
        return SmoothingConfig(self.smoothing_data_weight, self.smoothing_smooth_weight, self.smoothing_spacing)

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> "PlannerConfig":
        """Build from a flat parameter dict; every key must be known and typed like its default."""
        defaults = cls().as_params()
        values: dict[str, Any] = {}
        for key, value in params.items():
            if key not in defaults:
                raise PlannerConfigError(f"{key}: unknown parameter (known: {', '.join(sorted(defaults))})")
            values[key] = _typed(key, defaults[key], value)
        return cls(**values)

    def as_params(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


class Planner:
    """The costmap of one map and the configured search; plan() gives smoothed paths."""

    def __init__(self, grid: OccupancyGrid, config: PlannerConfig | None = None) -> None:
        self.config = config or PlannerConfig()
        self.costmap = Costmap(grid, self.config.costmap)
        if self.config.planner == "prm":
            self._search = Roadmap(self.costmap, self.config.roadmap)
        else:
            self._search = GridAStar(self.costmap, self.config.snap_distance)

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


def _typed(key: str, default: Any, value: Any) -> Any:
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise PlannerConfigError(f"{key}: must be true or false, got {value!r}")
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise PlannerConfigError(f"{key}: must be an integer, got {value!r}")
        return value
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise PlannerConfigError(f"{key}: must be a number, got {value!r}")
        return float(value)
    if isinstance(default, list):
        if not isinstance(value, (list, tuple)):
            raise PlannerConfigError(f"{key}: must be a list, got {value!r}")
        return [float(v) if is_finite_number(v) else v for v in value]
    if not isinstance(value, str):
        raise PlannerConfigError(f"{key}: must be a string, got {value!r}")
    return value
