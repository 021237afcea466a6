"""Worlds: static walls, boxes and ASCII-grid blocks, a start pose and an optional goal. No ROS, no pymunk.

The format every package reads a world in: the simulator collides with it, map_server rasterizes it,
the localizers and the planner take their map from it. A relative world name is looked up along
world_search_path() (share/amr_maps/config/worlds, then the source tree's config/worlds).

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
    map: lab.yaml                   # a ROS map_server map (path relative to this file):
                                    # its occupied cells become solids
    start: [1.0, -1.0, 1.5707963267948966]   # x, y, theta (rad)
    goal: [0.6, -1.0, 0.15]         # optional: x, y, radius (m)
    beacons: [[0.0, 0.0], [2.0, 0.5]]  # optional: [x, y] of range beacons (m); the simulator then
                                    # publishes the noisy range to each, in this order, and a compass
    robots:                         # optional, instead of start and goal: several robots (docs/fleet.md)
      - name: r1                    # a ROS name token: the namespace of its topics and nodes
        start: [-1.5, -1.5, 0.0]    # x, y, theta (rad)
        goal: [1.5, 1.5, 0.15]      # optional: x, y, radius (m)

A world without `robots` holds one robot (start, goal) that has no name: its topics are not
namespaced. World.fleet lists the robots either way.

Every solid becomes a convex polygon (a wall is the rectangle around its centre
line, extended by half the thickness past both ends so that walls meeting at a
corner close it). Physics collides against these polygons; the ray casters see
their faces, each oriented counter-clockwise around its solid so that its
outward normal is the right-hand normal of the edge.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from amr_maps.map_io import load_map
from amr_maps.occupancy_grid import MapError
from amr_util.geometry import Pose2D, is_finite_number, wrap_angle
from amr_util.share import share_directory

WORLD_KEYS = ("name", "wall_thickness", "walls", "boxes", "grid", "map", "start", "goal", "beacons", "robots")
ROBOT_KEYS = ("name", "start", "goal", "priority")  # priority: the fleet planner's (amr_navigation.fleet_file)
ROBOT_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
"""A ROS name token (what rclpy's validate_namespace accepts as one namespace level)."""
GRID_KEYS = ("cell_size", "origin", "rows")
SOLID_CELL = "#"
FREE_CELL = "."
SOURCE_WORLDS = Path(__file__).resolve().parents[1] / "config" / "worlds"
"""The worlds of the source tree (installed to share/amr_maps/config/worlds)."""


class WorldError(ValueError):
    """A world description that is malformed or missing; the message names the file and the key."""


@dataclass(frozen=True)
class Goal:
    """A circular goal region."""

    x: float
    y: float
    radius: float

    def contains(self, x: float, y: float) -> bool:
        return math.hypot(x - self.x, y - self.y) <= self.radius


@dataclass(frozen=True)
class RobotSpec:
    """One robot of a world: where it starts and, optionally, where it should go."""

    name: str
    """The namespace of its topics and nodes; "" for the one robot of a world without `robots`."""
    start: Pose2D
    goal: Goal | None = None


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
    beacons: tuple[tuple[float, float], ...] = ()
    """Range beacons (x, y), in the world file's order (BeaconRanges keeps it); () = none."""
    robots: tuple[RobotSpec, ...] = ()
    """The `robots` list of the file, in its order; () for a world of one robot (then start and goal
    are that robot's; with a list they are its first robot's)."""

    def __post_init__(self) -> None:
        # Physics resolves a corner (two solids touched at once) in the order the solids were added,
        # so they are kept sorted by their lower-left then upper-right corner: the same solids give
        # the same run whichever order a file or a map listed them in.
        order = sorted(self.polygons, key=lambda p: (*np.round(p.min(axis=0), 9), *np.round(p.max(axis=0), 9)))
        object.__setattr__(self, "polygons", tuple(order))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of all solids."""
        xs = np.concatenate([self.faces[:, 0], self.faces[:, 2]])
        ys = np.concatenate([self.faces[:, 1], self.faces[:, 3]])
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())

    @property
    def fleet(self) -> tuple[RobotSpec, ...]:
        """Every robot of the world: the `robots` list, or the one unnamed robot of start and goal."""
        return self.robots or (RobotSpec("", self.start, self.goal),)

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """(P,) distance from each point of (P, 2) to the nearest solid, negative inside one."""
        return solid_clearance(self.polygons, self.faces, points)

    def check_footprints(self, radius: float) -> None:
        """Raise WorldError unless every robot of the `robots` list, a disc of `radius`, starts clear of
        the solids and of the other robots (a world of one robot is checked where it is placed)."""
        where = _Where(self.source)
        starts = np.array([[robot.start.x, robot.start.y] for robot in self.robots]).reshape(-1, 2)
        for index, (robot, clear) in enumerate(zip(self.robots, self.clearance(starts), strict=True)):
            if clear < radius:
                raise where.error(
                    f"robots[{index}].start",
                    f"{_pose_text(robot.start)}: {robot.name} (radius "
                    f"{radius} m) overlaps a solid (clearance {clear:.3f} m)",
                )
            for other_index, other in enumerate(self.robots[:index]):
                gap = math.hypot(robot.start.x - other.start.x, robot.start.y - other.start.y)
                if gap < 2.0 * radius:
                    raise where.error(
                        f"robots[{index}].start",
                        f"{_pose_text(robot.start)}: {robot.name} overlaps {other.name} "
                        f"(robots[{other_index}]): centres {gap:.3f} m apart, robots of radius {radius} m need "
                        f"{2.0 * radius:.3f} m",
                    )


def world_search_path() -> tuple[Path, ...]:
    """Where a relative world name is looked up, in order: the installed share/amr_maps/config/worlds
    (from the ament index, else under this Python's prefix), then the source tree's config/worlds."""
    installed = share_directory("amr_maps") / "config" / "worlds"
    return (installed,) if installed == SOURCE_WORLDS else (installed, SOURCE_WORLDS)


def resolve_world_path(name: str, search_dirs: Sequence[str | Path] = ()) -> Path:
    """An existing path as given, else the first search directory holding that file name.

    With no search_dirs, world_search_path() is used.
    """
    candidate = Path(name).expanduser()
    if candidate.is_file():
        return candidate
    dirs = [Path(d) for d in search_dirs] or list(world_search_path())
    for directory in dirs:
        if (directory / name).is_file():
            return directory / name
    raise WorldError(f"world file {name!r} not found as a path nor in {', '.join(map(str, dirs))}")


def world_problem(name: str) -> str | None:
    """Why `name` names no world file along world_search_path(), or None (a parameter check)."""
    try:
        resolve_world_path(name)
    except (WorldError, ValueError, OSError) as problem:
        return str(problem)
    return None


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
    if isinstance(data, dict) and "image" in data and "start" not in data:
        raise WorldError(
            f"{path}: looks like a map_server map, not a world: name it in a world file "
            "(map: <this file>, start: [x, y, theta])"
        )
    return world_from_dict(data, source=str(path), default_name=path.stem, base_dir=path.parent)


def world_from_dict(
    data: Any, source: str = "<dict>", default_name: str = "world", base_dir: str | Path = "."
) -> World:
    """Validate a world description (the parsed YAML) and build its geometry.

    A `map` path is taken relative to base_dir (the world file's directory).
    """
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
    if data.get("map") is not None:
        map_boxes, map_faces = _map(data["map"], Path(base_dir), where)
        polygons.extend(map_boxes)
        faces.append(map_faces)
    if not polygons:
        raise where.error("walls", "the world has no solids: give walls, boxes or a grid")

    all_faces = np.concatenate(faces).astype(float)
    robots: tuple[RobotSpec, ...] = ()
    if "robots" in data:
        robots = _robots(data, polygons, all_faces, where)
        start, goal = robots[0].start, robots[0].goal
    else:
        if "start" not in data:
            raise where.error("start", "is required: [x, y, theta]")
        start = _start(data["start"], "start", where)
        goal = _goal(data["goal"], "goal", where) if data.get("goal") is not None else None
    beacons = _beacons(data["beacons"], where) if "beacons" in data else ()

    return World(
        name=name,
        polygons=tuple(polygons),
        faces=all_faces,
        start=start,
        goal=goal,
        source=source,
        beacons=beacons,
        robots=robots,
    )


def _start(value: Any, key: str, where: _Where) -> Pose2D:
    x, y, theta = _numbers(value, 3, key, where, "[x, y, theta]")
    return Pose2D(x, y, wrap_angle(theta))


def _goal(value: Any, key: str, where: _Where) -> Goal:
    gx, gy, radius = _numbers(value, 3, key, where, "[x, y, radius]")
    if radius <= 0.0:
        raise where.error(key, f"radius must be positive, got {radius}")
    return Goal(gx, gy, radius)


def _pose_text(pose: Pose2D) -> str:
    return f"[{pose.x:g}, {pose.y:g}, {pose.theta:g}]"


def _robots(data: dict, polygons: Sequence[np.ndarray], faces: np.ndarray, where: _Where) -> tuple[RobotSpec, ...]:
    """The `robots` list: named robots, each starting (and ending, if it has a goal) in free space
    within the solids' extent; the footprints are checked by World.check_footprints(radius)."""
    for key in ("start", "goal"):
        if key in data:
            raise where.error(
                key,
                f"a world with `robots` gives each robot its own start and goal: move {key} into the robots' entries",
            )
    value = data["robots"]
    if not isinstance(value, list) or not value:
        raise where.error("robots", f"must be a non-empty list of robots (omit the key for one robot), got {value!r}")
    robots: list[RobotSpec] = []
    names: dict[str, int] = {}
    for index, item in enumerate(value):
        key = f"robots[{index}]"
        if not isinstance(item, dict):
            raise where.error(key, f"must be a mapping with name, start, goal (and optionally priority), got {item!r}")
        unknown = sorted(set(map(str, item)) - set(ROBOT_KEYS))
        if unknown:
            raise where.error(f"{key}.{unknown[0]}", f"unknown key (expected some of {', '.join(ROBOT_KEYS)})")
        for required in ("name", "start"):
            if required not in item:
                raise where.error(f"{key}.{required}", "is required")
        name = item["name"]
        if not isinstance(name, str) or not ROBOT_NAME.match(name):
            raise where.error(
                f"{key}.name", f"must be a ROS name token (a letter or '_', then letters, digits or '_'), got {name!r}"
            )
        if name in names:
            raise where.error(f"{key}.name", f"{name!r} is already the name of robots[{names[name]}]")
        names[name] = index
        goal = _goal(item["goal"], f"{key}.goal", where) if item.get("goal") is not None else None
        robots.append(RobotSpec(name, _start(item["start"], f"{key}.start", where), goal))
    points = [(f"robots[{i}].start", (r.start.x, r.start.y)) for i, r in enumerate(robots)]
    points += [(f"robots[{i}].goal", (r.goal.x, r.goal.y)) for i, r in enumerate(robots) if r.goal is not None]
    xmin, ymin = faces[:, [0, 2]].min(), faces[:, [1, 3]].min()
    xmax, ymax = faces[:, [0, 2]].max(), faces[:, [1, 3]].max()
    clearance = solid_clearance(polygons, faces, np.array([point for _, point in points]))
    for (key, (x, y)), clear in zip(points, clearance, strict=True):
        if not (xmin <= x <= xmax and ymin <= y <= ymax):
            raise where.error(
                key,
                f"({x:g}, {y:g}) lies outside the solids' extent: x in [{xmin:g}, {xmax:g}], y in [{ymin:g}, {ymax:g}]",
            )
        if clear < 0.0:
            raise where.error(key, f"({x:g}, {y:g}) lies inside a solid")
    return tuple(robots)


def solid_clearance(polygons: Sequence[np.ndarray], faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(P,) distance from each point of (P, 2) to the nearest face, negated inside a (convex) solid."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    a, b = faces[None, :, :2], faces[None, :, 2:]
    p = points[:, None, :]
    ab = b - a
    along = np.clip(np.sum((p - a) * ab, axis=2) / np.maximum(np.sum(ab * ab, axis=2), 1e-300), 0.0, 1.0)
    distance = np.linalg.norm(p - (a + along[..., None] * ab), axis=2).min(axis=1, initial=np.inf)
    inside = np.zeros(len(points), dtype=bool)
    by_size: dict[int, list[np.ndarray]] = {}
    for polygon in polygons:
        by_size.setdefault(len(polygon), []).append(polygon)
    for group in by_size.values():
        corners = np.stack(group)  # (S, k, 2), counter-clockwise
        edges = np.roll(corners, -1, axis=1) - corners
        offset = p[:, None, :, :] - corners[None]  # (P, S, k, 2)
        cross = edges[None, ..., 0] * offset[..., 1] - edges[None, ..., 1] * offset[..., 0]
        inside |= np.any(np.all(cross > 0.0, axis=2), axis=1)
    return np.where(inside, -distance, distance)


def _beacons(value: Any, where: _Where) -> tuple[tuple[float, float], ...]:
    """[[x, y], ...]: at least one; an empty list is refused (nothing to measure a range to)."""
    if not isinstance(value, list) or not value:
        raise where.error("beacons", f"must be a non-empty list of [x, y] (omit the key for no beacons), got {value!r}")
    return tuple(tuple(_numbers(item, 2, f"beacons[{index}]", where, "[x, y]")) for index, item in enumerate(value))


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


def _numbers(value: Any, count: int, key: str, where: _Where, form: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != count or not all(map(is_finite_number, value)):
        raise where.error(key, f"expected {form} ({count} finite numbers), got {value!r}")
    return tuple(float(v) for v in value)


def _positive(value: Any, key: str, where: _Where) -> float:
    if not is_finite_number(value) or value <= 0.0:
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
    return solid_cells(solid, size, ox, oy)


def _map(name: Any, base_dir: Path, where: _Where) -> tuple[list[np.ndarray], np.ndarray]:
    """The occupied cells of a map_server map as solids."""
    if not isinstance(name, str) or not name:
        raise where.error("map", f"must be the path of a map_server YAML file, got {name!r}")
    path = Path(name).expanduser()
    try:
        grid = load_map(path if path.is_absolute() else base_dir / path)
    except MapError as error:
        raise where.error("map", str(error)) from error
    solid = grid.occupied()
    if not solid.any():
        raise where.error("map", f"{name} has no occupied cell")
    return solid_cells(solid, grid.resolution, grid.origin[0], grid.origin[1])


def solid_cells(solid: np.ndarray, size: float, ox: float, oy: float) -> tuple[list[np.ndarray], np.ndarray]:
    """Solids for a boolean cell grid (solid[j, i], row j up, cells of `size` m from corner (ox, oy)):
    boxes for physics (runs of cells merged, so a map stays cheap to collide with) and the outline
    faces for the ray casters."""
    return _grid_boxes(solid, size, ox, oy), _grid_outline(solid, size, ox, oy)


def _runs(flags: Sequence[bool]) -> list[tuple[int, int]]:
    """Half-open index ranges [start, stop) of consecutive True values."""
    padded = np.concatenate(([False], np.asarray(flags, dtype=bool), [False]))
    edges = np.flatnonzero(padded[1:] != padded[:-1])
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist(), strict=True))


def _grid_boxes(solid: np.ndarray, size: float, ox: float, oy: float) -> list[np.ndarray]:
    """Boxes covering the solid cells: every straight stretch of wall is one box, so a robot sliding
    along it meets no seam (pymunk can catch a disc on the corner where two boxes meet).

    The row strips (row runs stacked upwards while the same run repeats) and the column strips
    (the same on the transposed grid) together cover every horizontal and vertical stretch whole;
    they overlap, which static solids may, and a box lying inside another is dropped.
    """
    rows = _strips(solid)
    columns = [(j0, i0, j1, i1) for i0, j0, i1, j1 in _strips(solid.T)]
    boxes = sorted(set(rows) | set(columns), key=lambda b: (b[2] - b[0]) * (b[3] - b[1]), reverse=True)
    kept: list[tuple[int, int, int, int]] = []
    for box in boxes:
        if not any(k[0] <= box[0] and k[1] <= box[1] and box[2] <= k[2] and box[3] <= k[3] for k in kept):
            kept.append(box)
    return [_box(ox + i0 * size, oy + j0 * size, ox + i1 * size, oy + j1 * size) for i0, j0, i1, j1 in kept]


def _strips(solid: np.ndarray) -> list[tuple[int, int, int, int]]:
    """(i0, j0, i1, j1) cell boxes: row runs [i0, i1) stacked over rows [j0, j1) while the run repeats."""
    strips, open_runs = [], {}  # run -> first row j
    for j in range(solid.shape[0] + 1):
        runs = set(_runs(solid[j])) if j < solid.shape[0] else set()
        for run in sorted(set(open_runs) - runs):
            strips.append((run[0], open_runs.pop(run), run[1], j))
        for run in runs - set(open_runs):
            open_runs[run] = j
    return strips


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
