"""Worlds: static walls, boxes and ASCII-grid blocks, a start pose and an optional goal.

A world YAML file (config/worlds/*.yaml) holds any mix of:

    name: outer_corridor            # optional, defaults to the file stem
    wall_thickness: 0.02            # m, for every entry of `walls` (required with walls)
    walls:                          # centre lines [x1, y1, x2, y2] in m
      - [-1.2, -1.2, 1.2, -1.2]
    boxes:                          # solid axis-aligned boxes [xmin, ymin, xmax, ymax] in m
      - [0.5, 0.5, 0.9, 0.7]
    grid:                           # solid cells '#', free cells '.'
      cell_size: 0.1                # m
      origin: [-1.8, -1.8]          # world position of the grid's lower-left corner
      rows: ["#####", "#...#", "#####"]   # first string is the top row
    start: [1.0, -1.0, 1.5707963267948966]   # x, y, theta (rad)
    goal: [0.6, -1.0, 0.15]         # optional: x, y, radius (m)

Every solid becomes a convex polygon (a wall is the rectangle around its centre
line, extended by half the thickness past both ends so that walls meeting at a
corner close it). Physics collides against these polygons; the ray casters see
their faces, each oriented counter-clockwise around its solid so that its
outward normal is the right-hand normal of the edge.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import yaml

from amr_simulation.errors import WorldError
from amr_simulation.pose import Pose2D, wrap_angle

WORLD_KEYS = ("name", "wall_thickness", "walls", "boxes", "grid", "start", "goal")
GRID_KEYS = ("cell_size", "origin", "rows")
SOLID_CELL = "#"
FREE_CELL = "."


@dataclass(frozen=True)
class Goal:
    """A circular goal region."""

    x: float
    y: float
    radius: float

    def contains(self, x: float, y: float) -> bool:
        return math.hypot(x - self.x, y - self.y) <= self.radius


@dataclass(frozen=True)
class World:
    """Static geometry plus start and goal; build with load_world or world_from_dict."""

    name: str
    polygons: tuple[np.ndarray, ...]
    """Convex solids, each an (k, 2) array of counter-clockwise vertices."""
    faces: np.ndarray
    """(F, 4) rows [x1, y1, x2, y2]: the solids' boundary, solid on the left of each edge."""
    start: Pose2D
    goal: Goal | None = None
    source: str = "<dict>"

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of all solids."""
        xs = np.concatenate([self.faces[:, 0], self.faces[:, 2]])
        ys = np.concatenate([self.faces[:, 1], self.faces[:, 3]])
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())


def world_search_dirs() -> tuple[Path, ...]:
    """Where world names are looked up: the source tree, then the installed share directory."""
    return (
        Path(__file__).resolve().parents[1] / "config" / "worlds",
        Path(sys.prefix) / "share" / "amr_simulation" / "config" / "worlds",
    )


def resolve_world_path(name: str, search_dirs: Sequence[str | Path] = ()) -> Path:
    """An existing path as given, else the first search directory holding that file name.

    With no search_dirs, world_search_dirs() is used.
    """
    candidate = Path(name).expanduser()
    if candidate.is_file():
        return candidate
    dirs = [Path(d) for d in search_dirs] or list(world_search_dirs())
    for directory in dirs:
        if (directory / name).is_file():
            return directory / name
    raise WorldError(f"world file {name!r} not found as a path nor in {', '.join(map(str, dirs))}")


def load_world(path: str | Path) -> World:
    """Read and validate a world YAML file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise WorldError(f"{path}: cannot read world file ({error.strerror})") from error
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise WorldError(f"{path}: not valid YAML ({error})") from error
    return world_from_dict(data, source=str(path), default_name=path.stem)


def world_from_dict(data: Any, source: str = "<dict>", default_name: str = "world") -> World:
    """Validate a world description (the parsed YAML) and build its geometry."""
    where = _Where(source)
    if not isinstance(data, dict):
        raise WorldError(f"{source}: a world must be a mapping of keys, got {type(data).__name__}")
    unknown = sorted(set(map(str, data)) - set(WORLD_KEYS))
    if unknown:
        raise where.error(unknown[0], f"unknown key (expected some of {', '.join(WORLD_KEYS)})")

    name = data.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise where.error("name", f"must be a non-empty string, got {name!r}")

    polygons: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    walls = _list(data, "walls", where)
    if walls:
        thickness = _positive(data.get("wall_thickness"), "wall_thickness", where)
        for index, item in enumerate(walls):
            x1, y1, x2, y2 = _numbers(item, 4, f"walls[{index}]", where, "[x1, y1, x2, y2]")
            if math.hypot(x2 - x1, y2 - y1) == 0.0:
                raise where.error(f"walls[{index}]", "has zero length")
            polygons.append(_wall_rectangle(x1, y1, x2, y2, thickness))
    elif "wall_thickness" in data:
        _positive(data["wall_thickness"], "wall_thickness", where)
    for index, item in enumerate(_list(data, "boxes", where)):
        xmin, ymin, xmax, ymax = _numbers(item, 4, f"boxes[{index}]", where, "[xmin, ymin, xmax, ymax]")
        if not (xmin < xmax and ymin < ymax):
            raise where.error(f"boxes[{index}]", f"needs xmin < xmax and ymin < ymax, got {item}")
        polygons.append(_box(xmin, ymin, xmax, ymax))
    faces.extend(_polygon_faces(polygon) for polygon in polygons)
    if "grid" in data:
        grid_boxes, grid_faces = _grid(data["grid"], where)
        polygons.extend(grid_boxes)
        faces.append(grid_faces)
    if not polygons:
        raise where.error("walls", "the world has no solids: give walls, boxes or a grid")

    if "start" not in data:
        raise where.error("start", "is required: [x, y, theta]")
    x, y, theta = _numbers(data["start"], 3, "start", where, "[x, y, theta]")
    goal = None
    if data.get("goal") is not None:
        gx, gy, radius = _numbers(data["goal"], 3, "goal", where, "[x, y, radius]")
        if radius <= 0.0:
            raise where.error("goal", f"radius must be positive, got {radius}")
        goal = Goal(gx, gy, radius)

    return World(
        name=name,
        polygons=tuple(polygons),
        faces=np.concatenate(faces).astype(float),
        start=Pose2D(x, y, wrap_angle(theta)),
        goal=goal,
        source=source,
    )


class _Where:
    """Formats errors as '<file>: <key>: <problem>'."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, key: str, problem: str) -> WorldError:
        return WorldError(f"{self.source}: {key}: {problem}")


def _list(data: dict, key: str, where: _Where) -> list:
    value = data.get(key)
    if value is None:
        return []
    if not isinstance(value, list):
        raise where.error(key, f"must be a list, got {type(value).__name__}")
    return value


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _numbers(value: Any, count: int, key: str, where: _Where, form: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != count or not all(map(_is_number, value)):
        raise where.error(key, f"expected {form} ({count} finite numbers), got {value!r}")
    return tuple(float(v) for v in value)


def _positive(value: Any, key: str, where: _Where) -> float:
    if not _is_number(value) or value <= 0.0:
        raise where.error(key, f"must be a positive number, got {value!r}")
    return float(value)


def _box(xmin: float, ymin: float, xmax: float, ymax: float) -> np.ndarray:
    return np.array([[xmin, ymin], [xmax, ymin], [xmax, ymax], [xmin, ymax]])


def _wall_rectangle(x1: float, y1: float, x2: float, y2: float, thickness: float) -> np.ndarray:
    """The rectangle around the centre line, extended by thickness / 2 past both ends."""
    a, b = np.array([x1, y1]), np.array([x2, y2])
    along = (b - a) / np.linalg.norm(b - a)
    half = 0.5 * thickness
    left = np.array([-along[1], along[0]]) * half
    a, b = a - along * half, b + along * half
    return np.array([a - left, b - left, b + left, a + left])


def _polygon_faces(polygon: np.ndarray) -> np.ndarray:
    return np.hstack([polygon, np.roll(polygon, -1, axis=0)])


def _grid(grid: Any, where: _Where) -> tuple[list[np.ndarray], np.ndarray]:
    """Boxes for physics (runs of solid cells merged) and the outline faces of the solid cells."""
    if not isinstance(grid, dict):
        raise where.error("grid", f"must be a mapping with {', '.join(GRID_KEYS)}")
    unknown = sorted(set(map(str, grid)) - set(GRID_KEYS))
    if unknown:
        raise where.error(f"grid.{unknown[0]}", f"unknown key (expected {', '.join(GRID_KEYS)})")
    size = _positive(grid.get("cell_size"), "grid.cell_size", where)
    ox, oy = _numbers(grid.get("origin"), 2, "grid.origin", where, "[x, y]")
    rows = grid.get("rows")
    if not isinstance(rows, list) or not rows or not all(isinstance(r, str) for r in rows):
        raise where.error("grid.rows", "must be a non-empty list of strings")
    width = len(rows[0])
    for index, row in enumerate(rows):
        if len(row) != width:
            raise where.error(f"grid.rows[{index}]", f"has {len(row)} cells, row 0 has {width}")
        bad = set(row) - {SOLID_CELL, FREE_CELL}
        if bad:
            allowed = f"only '{SOLID_CELL}' and '{FREE_CELL}' allowed"
            raise where.error(f"grid.rows[{index}]", f"{allowed}, got {sorted(bad)}")
    solid = np.array([[c == SOLID_CELL for c in row] for row in reversed(rows)])  # solid[j, i], j up
    if not solid.any():
        raise where.error("grid.rows", f"has no solid '{SOLID_CELL}' cell")
    return _grid_boxes(solid, size, ox, oy), _grid_outline(solid, size, ox, oy)


def _runs(flags: Sequence[bool]) -> list[tuple[int, int]]:
    """Half-open index ranges [start, stop) of consecutive True values."""
    runs, start = [], None
    for index, flag in enumerate(list(flags) + [False]):
        if flag and start is None:
            start = index
        elif not flag and start is not None:
            runs.append((start, index))
            start = None
    return runs


def _grid_boxes(solid: np.ndarray, size: float, ox: float, oy: float) -> list[np.ndarray]:
    """Row runs of solid cells, stacked upwards while the same run repeats."""
    boxes, open_runs = [], {}  # run -> first row j
    for j in range(solid.shape[0] + 1):
        runs = set(_runs(solid[j])) if j < solid.shape[0] else set()
        for run in sorted(set(open_runs) - runs):
            j0 = open_runs.pop(run)
            boxes.append(_box(ox + run[0] * size, oy + j0 * size, ox + run[1] * size, oy + j * size))
        for run in runs - set(open_runs):
            open_runs[run] = j
    return boxes


def _grid_outline(solid: np.ndarray, size: float, ox: float, oy: float) -> np.ndarray:
    """Maximal boundary edges between solid and free cells, counter-clockwise around the solid."""
    padded = np.pad(solid, 1)
    faces = []
    for j in range(solid.shape[0] + 1):  # horizontal boundary at y = oy + j * size
        below, above = padded[j, 1:-1], padded[j + 1, 1:-1]
        y = oy + j * size
        for i0, i1 in _runs(above & ~below):  # solid above: the edge runs left to right
            faces.append([ox + i0 * size, y, ox + i1 * size, y])
        for i0, i1 in _runs(below & ~above):  # solid below: right to left
            faces.append([ox + i1 * size, y, ox + i0 * size, y])
    for i in range(solid.shape[1] + 1):  # vertical boundary at x = ox + i * size
        left, right = padded[1:-1, i], padded[1:-1, i + 1]
        x = ox + i * size
        for j0, j1 in _runs(right & ~left):  # solid to the right: downwards
            faces.append([x, oy + j1 * size, x, oy + j0 * size])
        for j0, j1 in _runs(left & ~right):  # solid to the left: upwards
            faces.append([x, oy + j0 * size, x, oy + j1 * size])
    return np.array(faces, dtype=float)
