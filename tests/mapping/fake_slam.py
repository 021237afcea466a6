"""A stand-in for amr_mapping.slam with its API (SlamConfig, GraphSlam, SlamUpdate), used by the node tests only
while the library has not landed (tests/mapping/conftest.py installs it then): poses by odometry alone, the map a
fixed square of cells the beams cross (free) and end in (occupied)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from amr_maps.map_io import save_map
from amr_maps.occupancy_grid import MapError, OccupancyGrid
from amr_mapping.errors import MappingError
from amr_util.geometry import compose, inverse
from amr_util.parameter_spec import Config, parameter


@dataclass(frozen=True)
class SlamConfig(Config):
    resolution: float = parameter(0.05, minimum=0.01, maximum=1.0)
    """m/cell of the map."""
    map_size: float = parameter(8.0, minimum=1.0, maximum=100.0)
    """m, the side of the square map centred on the start."""
    node_distance: float = parameter(0.1, minimum=0.0, maximum=10.0)
    """m of travel between two graph nodes."""


@dataclass(frozen=True)
class SlamUpdate:
    pose: tuple[float, float, float]
    node_added: bool
    loop_closures: int
    map_changed: bool
    time: float


class GraphSlam:
    def __init__(self, config: SlamConfig | None = None) -> None:
        self.config = config or SlamConfig()
        cells = int(round(self.config.map_size / self.config.resolution))
        self._data = np.full((cells, cells), -1, dtype=np.int8)
        self._origin = (-0.5 * cells * self.config.resolution,) * 2 + (0.0,)
        self._start = None
        self.pose = (0.0, 0.0, 0.0)
        self.map_to_odom = (0.0, 0.0, 0.0)
        self._poses: list[tuple[float, float, float]] = []
        self.node_stamps: list[int] = []

    def add(self, stamp_ns: int, odometry, scan) -> SlamUpdate:
        ranges = np.asarray(scan.ranges, dtype=float)
        if ranges.size < 2:
            raise MappingError(f"scan of {ranges.size} beams")
        if self._start is None:
            self._start = tuple(odometry)
            self.map_to_odom = tuple(inverse(self._start))
        self.pose = tuple(compose(self.map_to_odom, odometry))
        added = not self._poses or math.dist(self._poses[-1][:2], self.pose[:2]) >= self.config.node_distance
        if added:
            self._poses.append(self.pose)
            self.node_stamps.append(int(stamp_ns))
            self._mark(ranges, scan)
        return SlamUpdate(self.pose, added, 0, added, 0.0)

    def _mark(self, ranges, scan) -> None:
        grid = self.occupancy_grid()
        x, y, theta = self.pose
        angles = theta + scan.angle_min + scan.angle_increment * np.arange(ranges.size)
        hit = np.isfinite(ranges) & (ranges < scan.range_max)
        reach = np.where(np.isfinite(ranges), np.minimum(ranges, scan.range_max), scan.range_max)
        for angle, distance, ends in zip(angles, reach, hit):
            steps = np.arange(0.0, distance, 0.5 * self.config.resolution)
            rows, cols = grid.world_to_cell(x + steps * math.cos(angle), y + steps * math.sin(angle))
            inside = grid.inside(rows, cols)
            self._data[rows[inside], cols[inside]] = 0
            if ends:
                row, col = grid.world_to_cell(x + distance * math.cos(angle), y + distance * math.sin(angle))
                if grid.inside(row, col):
                    self._data[row, col] = 100

    def occupancy_grid(self) -> OccupancyGrid:
        return OccupancyGrid(self._data.copy(), self.config.resolution, self._origin)

    def graph(self):
        poses = np.array(self._poses, dtype=float).reshape(-1, 3)
        edges = np.column_stack([np.arange(len(poses) - 1), np.arange(1, len(poses))]).reshape(-1, 2)
        return poses, edges, np.zeros(len(edges), dtype=bool)

    def save(self, path) -> list[Path]:
        path = Path(path)
        try:
            yaml_path = save_map(self.occupancy_grid(), path)
            poses = path.with_name(path.name + ".poses.csv")
            poses.write_text("".join(f"{s},{x},{y},{t}\n" for s, (x, y, t) in zip(self.node_stamps, self._poses)))
        except (OSError, MapError) as error:
            raise MappingError(f"{path}: cannot write the map ({error})") from error
        return [yaml_path, yaml_path.with_suffix(".pgm"), poses]
