"""Generated worlds: maze families with a free start and a goal, no ROS (the `amr-maze` command writes them).

``generate(family, seed, **options)`` returns a world dict that
:func:`amr_maps.world.world_from_dict` accepts (walls with one
``wall_thickness``, axis-aligned ``boxes``, ``start``, ``goal``); the same
family, seed and options always give the same dict. Every value an option does
not fix is drawn from ``numpy.random.default_rng(seed)``.

Families (``FAMILIES``):

* ``perfect``: depth-first (recursive backtracker) maze on square cells; every
  wall piece is connected to the outer wall, so a wall follower reaches every cell.
* ``loops``: a perfect maze with a fraction of its inner walls knocked out:
  loops and free-standing islands a wall follower may circle forever.
* ``rotated``: a perfect or loop maze turned by an arbitrary angle.
* ``bends``: a closed corridor whose legs meet at bends of 15-165 deg (either
  sign): non-orthogonal walls, inner corners mitred, outer corners rounded.
* ``curved``: a closed corridor of straight pieces and circular arcs (walls as polylines).
* ``pillars``: a rectangular room with box pillars, some against the walls.
* ``narrowing``: a bent corridor whose width tapers (default 0.6 m to 0.3-0.4 m).
* ``dead_ends``: a main corridor with long straight dead ends on both sides (a comb).
* ``thin_walls``: a perfect or loop maze with 4-10 mm walls.
* ``open_room``: a large empty room, rotated, corners possibly cut at any angle.

Common options: ``size`` (m, side of a maze or room, 3-8), ``width`` (m, corridor
width, 0.35-0.6), ``thickness`` (m), ``hand`` ('right' or 'left': the goal is
placed where that wall follower reaches it). Family options: ``loop_fraction``
(loops), ``angle`` (rotated, rad), ``bend_deg`` (bends: every bend's magnitude),
``bends`` (bends: count), ``min_width`` / ``max_width`` (narrowing).

Reachability (:func:`goal_reachable`): a right-hand wall follower keeps its hand
on one connected solid, so it travels along that solid's whole boundary (in a
connected free space, the boundary between a connected solid and the free space
is one closed curve) and nowhere else. The followed solid is the one abeam on the
follower's side within ``wall_lost_distance`` of the start, else the nearest one
(a follower in open space drives to the nearest wall). Solids closer than the
robot's diameter count as one: the robot cannot pass between them. The goal is
reachable when its disc holds a point with room for the robot and within
``target_wall_distance`` of that solid. This assumes the free space is connected,
which every generated world is by construction.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from amr_maps.boundary_walk import BoundaryWalk
from amr_maps.world import world_from_dict
from amr_util.robot_description import default_robot

FAMILIES = (
    "perfect",
    "loops",
    "rotated",
    "bends",
    "curved",
    "pillars",
    "narrowing",
    "dead_ends",
    "thin_walls",
    "open_room",
)
HANDS = ("right", "left")
ROBOT_RADIUS = default_robot().radius
"""m, the robot description's footprint: the disc every start keeps clear (plus START_CLEARANCE)."""
START_CLEARANCE = 0.04
"""m of free space around the footprint at the start."""
TARGET_WALL_DISTANCE = 0.2
WALL_LOST_DISTANCE = 0.4
_COMMON = ("size", "width", "thickness", "hand")
_FAMILY_OPTIONS = {
    "perfect": (),
    "loops": ("loop_fraction",),
    "rotated": ("angle", "loop_fraction"),
    "bends": ("bend_deg", "bends"),
    "curved": (),
    "pillars": (),
    "narrowing": ("min_width", "max_width"),
    "dead_ends": (),
    "thin_walls": ("loop_fraction",),
    "open_room": (),
}
_DECISION_MARGIN = 0.05
"""m: a goal closer than this to the reachability boundary is neither placed nor judged."""
WALK_BUDGET = 0.6 * 600.0 * 0.1
"""m of boundary walk from start to goal at most: 60 % of the 600 s run at 0.1 m/s (the shipped
worlds' mean speeds are 0.077-0.113 m/s), so a goal placed is a goal reachable in time."""
WALK_OFFSET = ROBOT_RADIUS
"""m, the offset curve the walk is measured on: it enters every corridor the robot fits in."""
"""m: a goal closer than this to the reachability boundary is neither placed nor judged."""


class MazeError(ValueError):
    """A bad family name or option, or a layout that could not be drawn."""


class _NoGoal(MazeError):
    """A layout drawn without a goal the wall follower surely reaches: the layout is drawn again."""


LAYOUT_DRAWS = 20
"""layouts drawn for one seed at most: one without a reachable goal (a few in a thousand of `dead_ends`' seeds, whose
every dead end the follower walks) is rejected and the next drawn from the same random stream."""


def generate(family: str, seed: int, **options: Any) -> dict:
    """A world dict of ``family`` drawn from ``seed``; see the module docstring for the options."""
    if family not in FAMILIES:
        raise MazeError(f"unknown maze family {family!r} (known: {', '.join(FAMILIES)})")
    unknown = sorted(set(options) - set(_COMMON) - set(_FAMILY_OPTIONS[family]))
    if unknown:
        raise MazeError(
            f"{family}: unknown option {unknown[0]!r} (known: {', '.join(_COMMON + _FAMILY_OPTIONS[family])})"
        )
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise MazeError(f"seed must be a non-negative integer, got {seed!r}")
    hand = options.pop("hand", "right")
    if hand not in HANDS:
        raise MazeError(f"hand must be one of {HANDS}, got {hand!r}")
    rng = np.random.default_rng([int(seed), FAMILIES.index(family)])
    for draw in range(LAYOUT_DRAWS):
        try:
            world = _BUILDERS[family](rng, _Options(family, options), hand)
            break
        except _NoGoal:
            if draw == LAYOUT_DRAWS - 1:
                raise
    world["name"] = f"{family}_{seed}"
    return _rounded(world)


def grid_pitch(world: dict) -> float:
    """m from one cell of a grid maze (`perfect`, `loops`) to the next: the least gap, over 5 cm, between the
    distinct coordinates of its axis-aligned walls' ends (the lattice spacing that puts a robot on each cell when
    the fleet is planned together, amr_planning.fleet_lattice)."""
    values = np.unique(np.round(np.asarray(world["walls"], dtype=float).ravel(), 4))
    gaps = np.diff(values)
    gaps = gaps[gaps > 0.05]
    if len(gaps) == 0:
        raise ValueError("no two walls of the world lie 5 cm apart or more: not a grid maze")
    return float(gaps.min())


def family_options(family: str) -> tuple[str, ...]:
    """The options ``generate`` takes for ``family``: the common ones, then the family's own."""
    if family not in FAMILIES:
        raise MazeError(f"unknown maze family {family!r} (known: {', '.join(FAMILIES)})")
    return _COMMON + _FAMILY_OPTIONS[family]


def goal_reachable(
    world: dict,
    hand: str = "right",
    target_wall_distance: float = TARGET_WALL_DISTANCE,
    robot_radius: float = ROBOT_RADIUS,
    wall_lost_distance: float = WALL_LOST_DISTANCE,
) -> bool | None:
    """Whether a ``hand`` wall follower started at the world's start reaches its goal.

    None when the goal lies within a few cm of the boundary of that set (too close to call).
    """
    built, geometry = _follower_geometry(world, hand, robot_radius)
    solid = geometry.followed_component(built.start.x, built.start.y, built.start.theta, hand, wall_lost_distance)
    return geometry.goal_on_contour(solid, built.goal.x, built.goal.y, built.goal.radius, target_wall_distance)


def walk_length(
    world: dict, hand: str = "right", robot_radius: float = ROBOT_RADIUS, wall_lost_distance: float = WALL_LOST_DISTANCE
) -> float:
    """Metres an ideal ``hand`` wall follower walks from the world's start to its goal (inf: never).

    Measured on the followed solid's offset curve (amr_maps.boundary_walk); generated
    goals are placed within WALK_BUDGET of it.
    """
    built, geometry = _follower_geometry(world, hand, robot_radius)
    walk = geometry.walk(built.start.x, built.start.y, built.start.theta, hand, wall_lost_distance)
    return walk.length_to(built.goal.x, built.goal.y, _goal_reach(built.goal.radius))


def _follower_geometry(world: dict, hand: str, robot_radius: float):
    """The built world (it must have a goal) and its geometry for a ``hand`` follower of ``robot_radius``."""
    if hand not in HANDS:
        raise MazeError(f"hand must be one of {HANDS}, got {hand!r}")
    built = world_from_dict(world)
    if built.goal is None:
        raise MazeError(f"{built.name}: has no goal")
    return built, _Geometry(built.polygons, robot_radius)


def _goal_reach(radius: float) -> float:
    """The robot, on a path about target - WALK_OFFSET outside the offset curve, enters a goal this near to it."""
    return radius + TARGET_WALL_DISTANCE - WALK_OFFSET


# -- options -------------------------------------------------------------------------------


class _Options:
    """The caller's options, drawn from the rng where missing, validated by range."""

    def __init__(self, family: str, values: dict[str, Any]) -> None:
        self.family, self.values = family, values

    def get(self, name: str, draw: Callable[[], float], low: float, high: float) -> float:
        value = self.values[name] if name in self.values else draw()
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float, np.floating, np.integer))
            or not (low <= float(value) <= high)
        ):
            raise MazeError(f"{self.family}: option {name} must be a number in [{low}, {high}], got {value!r}")
        return float(value)


# -- grid mazes ----------------------------------------------------------------------------


@dataclass
class _GridMaze:
    """n x m square cells; ``open`` holds the passages as frozensets of two cells (i, j)."""

    n: int
    m: int
    open: set

    def neighbours(self, cell: tuple[int, int]) -> list[tuple[int, int]]:
        i, j = cell
        return [
            (a, b) for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)) if 0 <= a < self.n and 0 <= b < self.m
        ]

    def connected(self, a: tuple[int, int], b: tuple[int, int]) -> bool:
        return frozenset((a, b)) in self.open

    def distances(self, start: tuple[int, int]) -> dict:
        """Breadth-first path length in cells from start."""
        dist, frontier = {start: 0}, [start]
        while frontier:
            nxt = []
            for cell in frontier:
                for other in self.neighbours(cell):
                    if other not in dist and self.connected(cell, other):
                        dist[other] = dist[cell] + 1
                        nxt.append(other)
            frontier = nxt
        return dist

    def walls(self, pitch: float) -> list[list[float]]:
        """Wall centre lines on the grid lines, collinear pieces merged, centred on the origin."""
        ox, oy = -0.5 * self.n * pitch, -0.5 * self.m * pitch
        walls = []
        for j in range(self.m + 1):  # horizontal lines y = j
            closed = [j in (0, self.m) or not self.connected((i, j - 1), (i, j)) for i in range(self.n)]
            walls += [[ox + a * pitch, oy + j * pitch, ox + b * pitch, oy + j * pitch] for a, b in _runs(closed)]
        for i in range(self.n + 1):  # vertical lines x = i
            closed = [i in (0, self.n) or not self.connected((i - 1, j), (i, j)) for j in range(self.m)]
            walls += [[ox + i * pitch, oy + a * pitch, ox + i * pitch, oy + b * pitch] for a, b in _runs(closed)]
        return walls

    def centre(self, cell: tuple[int, int], pitch: float) -> tuple[float, float]:
        return ((cell[0] + 0.5 - 0.5 * self.n) * pitch, (cell[1] + 0.5 - 0.5 * self.m) * pitch)


def _runs(flags: list[bool]) -> list[tuple[int, int]]:
    """Half-open ranges [a, b) of consecutive True values."""
    runs, start = [], None
    for index, flag in enumerate(flags + [False]):
        if flag and start is None:
            start = index
        elif not flag and start is not None:
            runs.append((start, index))
            start = None
    return runs


def _perfect(rng: np.random.Generator, n: int, m: int) -> _GridMaze:
    """Recursive backtracker (iterative): a spanning tree of the cells, long winding corridors."""
    maze = _GridMaze(n, m, set())
    seen, stack = {(0, 0)}, [(0, 0)]
    while stack:
        cell = stack[-1]
        fresh = [c for c in maze.neighbours(cell) if c not in seen]
        if not fresh:
            stack.pop()
            continue
        nxt = fresh[int(rng.integers(len(fresh)))]
        maze.open.add(frozenset((cell, nxt)))
        seen.add(nxt)
        stack.append(nxt)
    return maze


def _knock_out(rng: np.random.Generator, maze: _GridMaze, fraction: float) -> None:
    """Open that fraction of the remaining inner walls: loops, and islands where a wall piece is cut free."""
    closed = sorted(
        {frozenset((c, d)) for c in ((i, j) for i in range(maze.n) for j in range(maze.m)) for d in maze.neighbours(c)}
        - maze.open,
        key=lambda pair: sorted(pair),
    )
    count = int(round(fraction * len(closed)))
    for index in rng.permutation(len(closed))[:count]:
        maze.open.add(closed[int(index)])


def _grid_world(
    rng: np.random.Generator, opts: _Options, hand: str, loops: float, thin: bool = False, angle: float = 0.0
) -> dict:
    size = opts.get("size", lambda: rng.uniform(3.0, 8.0), 1.5, 20.0)
    width = opts.get("width", lambda: rng.uniform(0.35, 0.6), 0.3, 1.5)
    low, high = (0.004, 0.01) if thin else (0.02, 0.08)
    thickness = opts.get("thickness", lambda: rng.uniform(low, high), 0.001, 0.5)
    pitch = width + thickness
    n = max(2, int(size // pitch))
    maze = _perfect(rng, n, n)
    if loops > 0.0:
        _knock_out(rng, maze, loops)
    walls = maze.walls(pitch)
    start_cell = (0, 0)
    heading = 0.0 if maze.connected((0, 0), (1, 0)) else 0.5 * math.pi
    if hand == "left":  # keep the outer wall on the followed side
        heading = 0.5 * math.pi if maze.connected((0, 0), (0, 1)) else 0.0
    sx, sy = maze.centre(start_cell, pitch)
    distances = maze.distances(start_cell)
    far = sorted(distances, key=lambda c: (-distances[c], c))
    candidates = [maze.centre(c, pitch) for c in far[: max(1, len(far) // 3)]]
    candidates += [maze.centre(c, pitch) for c in far[len(far) // 3 :]]
    world = {"wall_thickness": thickness, "walls": walls, "start": [sx, sy, heading]}
    world = _place_goal(world, candidates, 0.4 * width, hand, rng, shuffle_first=max(1, len(far) // 3))
    return _rotate(world, angle) if angle else world


def _perfect_family(rng, opts, hand):
    return _grid_world(rng, opts, hand, 0.0)


def _loops_family(rng, opts, hand):
    return _grid_world(rng, opts, hand, opts.get("loop_fraction", lambda: rng.uniform(0.1, 0.3), 0.0, 1.0))


def _rotated_family(rng, opts, hand):
    angle = opts.get("angle", lambda: rng.uniform(0.0, 2.0 * math.pi), -2.0 * math.pi, 2.0 * math.pi)
    loops = opts.get("loop_fraction", lambda: float(rng.choice([0.0, rng.uniform(0.1, 0.25)])), 0.0, 1.0)
    return _grid_world(rng, opts, hand, loops, angle=angle)


def _thin_family(rng, opts, hand):
    loops = opts.get("loop_fraction", lambda: float(rng.choice([0.0, rng.uniform(0.1, 0.25)])), 0.0, 1.0)
    return _grid_world(rng, opts, hand, loops, thin=True)


def _dead_ends_family(rng, opts, hand):
    """A main corridor along the middle row; every column above and below it is a straight dead end."""
    size = opts.get("size", lambda: rng.uniform(4.0, 8.0), 1.5, 20.0)
    width = opts.get("width", lambda: rng.uniform(0.35, 0.6), 0.3, 1.5)
    thickness = opts.get("thickness", lambda: rng.uniform(0.02, 0.08), 0.001, 0.5)
    pitch = width + thickness
    n = max(3, int(size // pitch))
    m = max(3, int(size // pitch)) | 1
    row = m // 2
    maze = _GridMaze(n, m, set())
    for i in range(n - 1):
        maze.open.add(frozenset(((i, row), (i + 1, row))))
    for i in range(n):
        up = int(rng.integers(0, m - row))  # cells of the dead end above the main corridor
        down = int(rng.integers(0, row + 1))
        for j in range(row, row + up):
            maze.open.add(frozenset(((i, j), (i, j + 1))))
        for j in range(row, row - down, -1):
            maze.open.add(frozenset(((i, j), (i, j - 1))))
    sx, sy = maze.centre((0, row), pitch)
    world = {"wall_thickness": thickness, "walls": maze.walls(pitch), "start": [sx, sy, 0.0]}
    goal_cells = [(i, row) for i in range(n - 1, 0, -1)]  # the farthest within the walk budget
    return _place_goal(world, [maze.centre(c, pitch) for c in goal_cells], 0.4 * width, hand, rng)


# -- corridors -----------------------------------------------------------------------------


def _corridor_walls(points: np.ndarray, half: np.ndarray) -> list[list[float]]:
    """Both walls of a corridor along the centre polyline ``points`` (half widths per vertex), ends capped.

    At each vertex turning by phi the inner wall is mitred (the offset lines meet
    half / cos(phi / 2) from the vertex) and the outer wall is rounded (an arc of
    radius half about the vertex, in steps of at most 15 deg).
    """
    sides = {1.0: [], -1.0: []}  # +1: left wall, -1: right wall
    directions = np.diff(points, axis=0)
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    normals = np.stack([-directions[:, 1], directions[:, 0]], axis=1)  # left normals
    for side, polyline in sides.items():
        polyline.append(points[0] + side * half[0] * normals[0])
        for k in range(1, len(points) - 1):
            turn = math.atan2(float(_cross(directions[k - 1], directions[k])), float(directions[k - 1] @ directions[k]))
            before, after = normals[k - 1] * side, normals[k] * side
            if turn * side > 1e-9:  # the corridor turns towards this wall: inner corner, mitre
                bisector = (before + after) / np.linalg.norm(before + after)
                polyline.append(points[k] + bisector * half[k] / math.cos(0.5 * turn))
            elif abs(turn) <= 1e-9:
                polyline.append(points[k] + before * half[k])
            else:  # outer corner: round it
                start = math.atan2(before[1], before[0])
                steps = max(1, math.ceil(abs(turn) / math.radians(15.0)))
                for s in range(steps + 1):
                    a = start + turn * s / steps
                    polyline.append(points[k] + half[k] * np.array([math.cos(a), math.sin(a)]))
        polyline.append(points[-1] + side * half[-1] * normals[-1])
    walls = []
    for polyline in sides.values():
        walls += [[*a, *b] for a, b in itertools.pairwise(polyline) if np.linalg.norm(b - a) > 1e-6]
    walls.append([*sides[1.0][0], *sides[-1.0][0]])
    walls.append([*sides[1.0][-1], *sides[-1.0][-1]])
    return walls


def _pieces_clear(pieces: list[np.ndarray], clearance: float) -> bool:
    """Whether centre-line pieces that are not neighbours stay ``clearance`` apart."""
    for a in range(len(pieces)):
        for b in range(a + 2, len(pieces)):
            if _polyline_distance(pieces[a], pieces[b]) < clearance:
                return False
    return True


def _polyline_distance(p: np.ndarray, q: np.ndarray) -> float:
    a0, a1 = p[:-1, None, :], p[1:, None, :]
    b0, b1 = q[None, :-1, :], q[None, 1:, :]
    return float(_segment_segment_distance(a0, a1, b0, b1).min())


def _corridor_world(
    points: np.ndarray, half: np.ndarray, thickness: float, hand: str, rng: np.random.Generator
) -> dict:
    """A capped corridor: start just inside the first end, goal at the last end."""
    heading = points[1] - points[0]
    start = points[0] + heading / np.linalg.norm(heading) * max(0.35, half[0] + 0.15)
    world = {
        "wall_thickness": thickness,
        "walls": _corridor_walls(points, half),
        "start": [float(start[0]), float(start[1]), math.atan2(heading[1], heading[0])],
    }
    back = points[-2] - points[-1]
    goal = points[-1] + back / np.linalg.norm(back) * max(0.3, half[-1])
    return _place_goal(world, [tuple(goal)], 0.8 * float(half[-1]), hand, rng)


def _draw_corridor(
    rng: np.random.Generator, draw_pieces: Callable[[], list[np.ndarray]], clearance: float, family: str
) -> list[np.ndarray]:
    for _ in range(200):
        pieces = draw_pieces()
        if _pieces_clear(pieces, clearance):
            return pieces
    raise MazeError(f"{family}: no corridor without self-overlap in 200 draws; try a smaller width or fewer bends")


def _join(pieces: list[np.ndarray]) -> np.ndarray:
    return np.concatenate([pieces[0]] + [p[1:] for p in pieces[1:]])


def _bends_family(rng, opts, hand):
    width = opts.get("width", lambda: rng.uniform(0.35, 0.6), 0.3, 1.5)
    thickness = opts.get("thickness", lambda: rng.uniform(0.02, 0.06), 0.001, 0.3)
    count = int(opts.get("bends", lambda: rng.integers(3, 7), 1, 20))
    fixed = opts.values.get("bend_deg")
    if fixed is not None:
        opts.get("bend_deg", lambda: 0.0, 1.0, 170.0)
    half = 0.5 * width

    def draw() -> list[np.ndarray]:
        turns = [
            math.radians(fixed if fixed is not None else rng.uniform(15.0, 165.0)) * rng.choice([-1.0, 1.0])
            for _ in range(count)
        ]
        heading, point, pieces = rng.uniform(0.0, 2.0 * math.pi), np.zeros(2), []
        for k in range(count + 1):
            # each leg leaves room for the mitres at both its ends, plus a straight stretch
            ends = sum(half * math.tan(0.5 * abs(turns[i])) for i in (k - 1, k) if 0 <= i < count)
            length = ends + rng.uniform(0.8, 1.6)
            nxt = point + length * np.array([math.cos(heading), math.sin(heading)])
            pieces.append(np.stack([point, nxt]))
            point = nxt
            if k < count:
                heading += turns[k]
        return pieces

    pieces = _draw_corridor(rng, draw, width + thickness + 0.15, "bends")
    points = _join(pieces)
    return _corridor_world(points, np.full(len(points), half), thickness, hand, rng)


def _curved_family(rng, opts, hand):
    width = opts.get("width", lambda: rng.uniform(0.35, 0.6), 0.3, 1.5)
    thickness = opts.get("thickness", lambda: rng.uniform(0.02, 0.06), 0.001, 0.3)
    half = 0.5 * width

    def draw() -> list[np.ndarray]:
        heading, point, pieces = rng.uniform(0.0, 2.0 * math.pi), np.zeros(2), []
        for k in range(2 * int(rng.integers(2, 5)) + 1):  # straight pieces at both ends
            if k % 2 == 0:  # straight
                length = rng.uniform(0.5, 1.5)
                nxt = point + length * np.array([math.cos(heading), math.sin(heading)])
                pieces.append(np.stack([point, nxt]))
                point = nxt
                continue
            radius = rng.uniform(half + 0.2, 1.5)
            sweep = math.radians(rng.uniform(30.0, 180.0)) * rng.choice([-1.0, 1.0])
            centre = point + radius * np.sign(sweep) * np.array([-math.sin(heading), math.cos(heading)])
            steps = max(2, math.ceil(abs(sweep) / math.radians(10.0)))
            a0 = math.atan2(point[1] - centre[1], point[0] - centre[0])
            angles = a0 + sweep * np.arange(steps + 1) / steps
            arc = centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
            arc[0] = point
            pieces.append(arc)
            point, heading = arc[-1], heading + sweep
        return pieces

    pieces = _draw_corridor(rng, draw, width + thickness + 0.15, "curved")
    points = _join(pieces)
    return _corridor_world(points, np.full(len(points), half), thickness, hand, rng)


def _narrowing_family(rng, opts, hand):
    wide = opts.get("max_width", lambda: 0.6, 0.3, 1.5)
    narrow = opts.get("min_width", lambda: rng.uniform(0.3, 0.4), 0.25, wide)
    thickness = opts.get("thickness", lambda: rng.uniform(0.02, 0.06), 0.001, 0.3)
    half = 0.5 * wide

    def draw() -> list[np.ndarray]:
        heading, point, pieces = rng.uniform(0.0, 2.0 * math.pi), np.zeros(2), []
        count = int(rng.integers(2, 5))
        for _ in range(count + 1):
            turn = math.radians(rng.choice([90.0, rng.uniform(30.0, 120.0)])) * rng.choice([-1.0, 1.0])
            length = rng.uniform(1.2, 2.2) + 2.0 * half * math.tan(0.5 * abs(turn))
            nxt = point + length * np.array([math.cos(heading), math.sin(heading)])
            pieces.append(np.stack([point, nxt]))
            point, heading = nxt, heading + turn
        return pieces

    pieces = _draw_corridor(rng, draw, wide + thickness + 0.15, "narrowing")
    points = _join(pieces)
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    widths = wide + (narrow - wide) * along / along[-1]  # linear taper along the centre line
    return _corridor_world(points, 0.5 * widths, thickness, hand, rng)


# -- rooms ---------------------------------------------------------------------------------


def _room_walls(corners: np.ndarray) -> list[list[float]]:
    return [[*a, *b] for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True)]


def _pillars_family(rng, opts, hand):
    size = opts.get("size", lambda: rng.uniform(3.0, 8.0), 1.5, 20.0)
    width = opts.get("width", lambda: rng.uniform(0.35, 0.6), 0.3, 1.5)
    thickness = opts.get("thickness", lambda: rng.uniform(0.02, 0.08), 0.001, 0.5)
    w, h = size, size * rng.uniform(0.7, 1.0)
    inner = np.array([0.5 * w - 0.5 * thickness, 0.5 * h - 0.5 * thickness])  # free half extents
    pillars: list[list[float]] = []
    wanted = max(1, int(w * h * rng.uniform(0.15, 0.35)))  # pillars per square metre: 0.15-0.35
    for _ in range(50 * wanted):
        if len(pillars) >= wanted:
            break
        sx, sy = rng.uniform(0.1, 0.5, size=2)
        if rng.random() < 0.25:  # against a wall
            side = int(rng.integers(4))
            cx = rng.uniform(-inner[0] + sx / 2, inner[0] - sx / 2)
            cy = rng.uniform(-inner[1] + sy / 2, inner[1] - sy / 2)
            if side == 0:
                cx = -inner[0] + sx / 2
            elif side == 1:
                cx = inner[0] - sx / 2
            elif side == 2:
                cy = -inner[1] + sy / 2
            else:
                cy = inner[1] - sy / 2
            box = [cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2]
            if any(_box_gap(box, other) < width for other in pillars):
                continue
        else:
            cx, cy = rng.uniform(-inner + width + 0.5 * np.array([sx, sy]), inner - width - 0.5 * np.array([sx, sy]))
            box = [cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2]
            if any(_box_gap(box, other) < width for other in pillars):
                continue
        pillars.append(box)
    corners = np.array([[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
    world = {"wall_thickness": thickness, "walls": _room_walls(corners), "boxes": pillars}
    return _room_start_and_goal(world, rng, hand, inner, corners)


def _box_gap(a: list[float], b: list[float]) -> float:
    dx = max(b[0] - a[2], a[0] - b[2], 0.0)
    dy = max(b[1] - a[3], a[1] - b[3], 0.0)
    return math.hypot(dx, dy)


def _open_room_family(rng, opts, hand):
    size = opts.get("size", lambda: rng.uniform(3.0, 8.0), 1.5, 20.0)
    thickness = opts.get("thickness", lambda: rng.uniform(0.02, 0.08), 0.001, 0.5)
    w, h = size, size * rng.uniform(0.6, 1.0)
    rectangle = np.array([[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
    corners = []
    for k, corner in enumerate(rectangle):
        if rng.random() < 0.5:  # cut the corner by a chamfer at an arbitrary angle
            before, after = rectangle[k - 1], rectangle[(k + 1) % 4]
            a, b = rng.uniform(0.3, 0.3 * min(w, h), size=2)
            corners.append(corner + a * (before - corner) / np.linalg.norm(before - corner))
            corners.append(corner + b * (after - corner) / np.linalg.norm(after - corner))
        else:
            corners.append(corner)
    angle = rng.uniform(0.0, 0.5 * math.pi)
    c, s = math.cos(angle), math.sin(angle)
    corners = np.array(corners) @ np.array([[c, s], [-s, c]])  # rotated by angle
    world = {"wall_thickness": thickness, "walls": _room_walls(corners)}
    return _room_start_and_goal(world, rng, hand, np.array([0.5, 0.5]) * math.hypot(w, h), corners)


def _inside_polygon(x: float, y: float, corners: np.ndarray) -> bool:
    """Even-odd rule: a ray to +x crosses the outline an odd number of times."""
    inside = False
    for (x1, y1), (x2, y2) in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


def _room_start_and_goal(
    world: dict, rng: np.random.Generator, hand: str, half_extent: np.ndarray, corners: np.ndarray
) -> dict:
    """A random free start with a random heading whose followed solid is unambiguous, a far goal on it."""
    world = dict(world, start=[0.0, 0.0, 0.0])
    geometry = _Geometry(world_from_dict(world).polygons, ROBOT_RADIUS)
    outer = geometry.largest_component()
    for _ in range(500):
        x, y = rng.uniform(-half_extent, half_extent)
        theta = rng.uniform(-math.pi, math.pi)
        clearance = geometry.clearance(np.array([[x, y]]))[0]
        if clearance < ROBOT_RADIUS + 0.15 or not _inside_polygon(x, y, corners):
            continue
        if not geometry.unambiguous_start(x, y, theta, hand, WALL_LOST_DISTANCE):
            continue
        if geometry.followed_component(x, y, theta, hand, WALL_LOST_DISTANCE) != outer and rng.random() < 0.7:
            continue  # mostly start by the outer wall, sometimes on a pillar
        world["start"] = [float(x), float(y), float(theta)]
        break
    else:
        raise MazeError("no unambiguous free start found in 500 draws")
    candidates = [
        tuple(p) for p in rng.uniform(-half_extent, half_extent, size=(300, 2)) if _inside_polygon(*p, corners)
    ]
    candidates.sort(key=lambda c: -math.hypot(c[0] - world["start"][0], c[1] - world["start"][1]))
    return _place_goal(world, candidates, 0.2, hand, rng)


# -- shared placement and transforms -------------------------------------------------------


def _place_goal(
    world: dict,
    candidates: list[tuple[float, float]],
    radius: float,
    hand: str,
    rng: np.random.Generator,
    shuffle_first: int = 0,
) -> dict:
    """The first candidate the ``hand`` follower surely reaches (the first ``shuffle_first`` tried in random order)."""
    order = list(range(len(candidates)))
    if shuffle_first:
        head = [order[int(i)] for i in rng.permutation(min(shuffle_first, len(order)))]
        order = head + order[len(head) :]
    built = world_from_dict(dict(world, goal=[0.0, 0.0, 1.0]))
    geometry = _Geometry(built.polygons, ROBOT_RADIUS)
    solid = geometry.followed_component(built.start.x, built.start.y, built.start.theta, hand, WALL_LOST_DISTANCE)
    if geometry.clearance(np.array([[built.start.x, built.start.y]]))[0] < ROBOT_RADIUS + START_CLEARANCE:
        raise MazeError(f"internal: start {world['start']} is not free")
    walk = geometry.walk(built.start.x, built.start.y, built.start.theta, hand, WALL_LOST_DISTANCE)
    for index in order:
        gx, gy = candidates[index]
        if math.hypot(gx - built.start.x, gy - built.start.y) < radius + 0.3:
            continue
        if geometry.clearance(np.array([[gx, gy]]))[0] < ROBOT_RADIUS:
            continue  # the robot's centre must fit at the goal's centre
        if walk.length_to(gx, gy, _goal_reach(radius)) > WALK_BUDGET:
            continue
        if geometry.goal_on_contour(solid, gx, gy, radius, TARGET_WALL_DISTANCE) is True:
            return dict(world, goal=[float(gx), float(gy), float(radius)])
    raise _NoGoal(
        f"no goal candidate is surely reachable by the wall follower within {WALK_BUDGET:.0f} m of walk "
        f"in {LAYOUT_DRAWS} layouts drawn"
    )


def _rotate(world: dict, angle: float) -> dict:
    """The world turned by angle (rad) about the origin (walls, start, goal; no boxes)."""
    c, s = math.cos(angle), math.sin(angle)

    def turn(x: float, y: float) -> list[float]:
        return [c * x - s * y, s * x + c * y]

    out = dict(world)
    out["walls"] = [turn(x1, y1) + turn(x2, y2) for x1, y1, x2, y2 in world["walls"]]
    x, y, theta = world["start"]
    out["start"] = turn(x, y) + [math.atan2(math.sin(theta + angle), math.cos(theta + angle))]
    if "goal" in world:
        gx, gy, radius = world["goal"]
        out["goal"] = turn(gx, gy) + [radius]
    return out


def _rounded(world: dict) -> dict:
    """Plain Python floats rounded to 0.01 mm (YAML-friendly), keys in a fixed order."""

    def r(values):
        return [round(float(v), 5) for v in values]

    out = {"name": world["name"]}
    if world.get("walls"):
        out["wall_thickness"] = round(float(world["wall_thickness"]), 5)
        out["walls"] = [r(w) for w in world["walls"]]
    if world.get("boxes"):
        out["boxes"] = [r(b) for b in world["boxes"]]
    out["start"] = r(world["start"])
    out["goal"] = r(world["goal"])
    return out


# -- geometry on convex solids -------------------------------------------------------------


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|p - closest point of segment ab|, broadcasting over leading axes (last axis: x, y)."""
    ab = b - a
    length2 = np.maximum(np.sum(ab * ab, axis=-1), 1e-18)
    t = np.clip(np.sum((p - a) * ab, axis=-1) / length2, 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _segment_segment_distance(a0, a1, b0, b1) -> np.ndarray:
    """0 where the segments cross, else the least endpoint-to-segment distance (broadcasting)."""
    d1, d2 = _cross(a1 - a0, b0 - a0), _cross(a1 - a0, b1 - a0)
    d3, d4 = _cross(b1 - b0, a0 - b0), _cross(b1 - b0, a1 - b0)
    crossing = (d1 * d2 <= 0) & (d3 * d4 <= 0) & ~((d1 == 0) & (d2 == 0))
    ends = np.minimum(
        np.minimum(_point_segment_distance(a0, b0, b1), _point_segment_distance(a1, b0, b1)),
        np.minimum(_point_segment_distance(b0, a0, a1), _point_segment_distance(b1, a0, a1)),
    )
    return np.where(crossing, 0.0, ends)


class _Geometry:
    """Convex solids (quads), grouped into the connected solids a robot cannot pass between."""

    def __init__(self, polygons: tuple[np.ndarray, ...], robot_radius: float) -> None:
        if any(len(p) != 4 for p in polygons):
            raise MazeError("reachability needs walls and boxes (four-sided solids) only")
        self.quads = np.stack(polygons).astype(float)  # (N, 4, 2), counter-clockwise
        self.a = self.quads.reshape(-1, 2)
        self.b = np.roll(self.quads, -1, axis=1).reshape(-1, 2)
        self.owner = np.repeat(np.arange(len(self.quads)), 4)  # solid of each edge
        self.robot_radius = robot_radius
        self.component = self._components(2.0 * robot_radius + 0.01)

    def _components(self, gap: float) -> np.ndarray:
        """Union-find over solids closer than ``gap`` (the robot cannot pass between them)."""
        lo, hi = self.quads.min(axis=1), self.quads.max(axis=1)
        near = np.all((lo[:, None, :] - gap <= hi[None, :, :]) & (lo[None, :, :] - gap <= hi[:, None, :]), axis=2)
        i, j = np.nonzero(np.triu(near, 1))
        parent = list(range(len(self.quads)))

        def find(k: int) -> int:
            while parent[k] != k:
                parent[k] = parent[parent[k]]
                k = parent[k]
            return k

        if len(i):
            qa, qb = self.quads[i], self.quads[j]
            a0, a1 = qa[:, :, None, :], np.roll(qa, -1, axis=1)[:, :, None, :]
            b0, b1 = qb[:, None, :, :], np.roll(qb, -1, axis=1)[:, None, :, :]
            distance = _segment_segment_distance(a0, a1, b0, b1).min(axis=(1, 2))
            contained = self._inside(qa[:, 0], qb) | self._inside(qb[:, 0], qa)
            for p, q in zip(i[(distance < gap) | contained], j[(distance < gap) | contained], strict=True):
                parent[find(int(p))] = find(int(q))
        return np.array([find(k) for k in range(len(self.quads))])

    @staticmethod
    def _inside(points: np.ndarray, quads: np.ndarray) -> np.ndarray:
        """points[k] inside quads[k] (counter-clockwise)."""
        edges = np.roll(quads, -1, axis=1) - quads
        return np.all(_cross(edges, points[:, None, :] - quads) >= 0.0, axis=1)

    def _inside_any(self, points: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        quads = self.quads if mask is None else self.quads[mask]
        edges = np.roll(quads, -1, axis=1) - quads
        rel = points[:, None, None, :] - quads[None]
        return np.any(np.all(_cross(edges[None], rel) >= 0.0, axis=2), axis=1)

    def clearance(self, points: np.ndarray, component: int | None = None) -> np.ndarray:
        """Distance from each point to the solids (of one component if given); 0 inside."""
        edge_mask = np.ones(len(self.a), bool) if component is None else self.component[self.owner] == component
        solid_mask = None if component is None else self.component == component
        d = _point_segment_distance(points[:, None, :], self.a[edge_mask][None], self.b[edge_mask][None]).min(axis=1)
        return np.where(self._inside_any(points, solid_mask), 0.0, d)

    def largest_component(self) -> int:
        labels, counts = np.unique(self.component, return_counts=True)
        return int(labels[np.argmax(counts)])

    @staticmethod
    def _ray_hits(origin: np.ndarray, direction: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Distances along the ray at which it crosses the segments ab."""
        e = b - a
        denom = _cross(direction[None], e)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = _cross(a - origin, e) / denom
            u = _cross(a - origin, direction[None]) / denom
        ok = (np.abs(denom) > 1e-12) & (t > 0.0) & (u >= 0.0) & (u <= 1.0)
        return t[ok]

    def followed_component(self, x: float, y: float, theta: float, hand: str, lost_distance: float) -> int:
        """The solid abeam on the hand's side within lost_distance, else the nearest one."""
        side = -0.5 * math.pi if hand == "right" else 0.5 * math.pi
        direction = np.array([math.cos(theta + side), math.sin(theta + side)])
        e = self.b - self.a
        origin = np.array([x, y])
        denom = _cross(direction[None], e)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = _cross(self.a - origin, e) / denom
            u = _cross(self.a - origin, direction[None]) / denom
        t = np.where((np.abs(denom) > 1e-12) & (t > 0.0) & (u >= 0.0) & (u <= 1.0), t, np.inf)
        if t.min() <= lost_distance:
            return int(self.component[self.owner[int(np.argmin(t))]])
        d = _point_segment_distance(origin[None], self.a, self.b)
        return int(self.component[self.owner[int(np.argmin(d))]])

    def walk(self, x: float, y: float, theta: float, hand: str, lost_distance: float) -> BoundaryWalk:
        """The boundary walk of the solid a ``hand`` follower started at (x, y, theta) keeps on its side."""
        component = self.followed_component(x, y, theta, hand, lost_distance)
        return BoundaryWalk(self.quads[self.component == component], (x, y), hand, offset=WALK_OFFSET)

    def unambiguous_start(self, x: float, y: float, theta: float, hand: str, lost_distance: float) -> bool:
        """No second solid nearly as near, nor a side wall just at the lost distance."""
        d = _point_segment_distance(np.array([x, y])[None], self.a, self.b)
        by_component = {}
        for comp, dist in zip(self.component[self.owner], d, strict=True):
            by_component[int(comp)] = min(by_component.get(int(comp), math.inf), float(dist))
        near = sorted(by_component.values())
        if len(near) > 1 and near[1] - near[0] < 0.3:
            return False
        side = -0.5 * math.pi if hand == "right" else 0.5 * math.pi
        hits = self._ray_hits(
            np.array([x, y]), np.array([math.cos(theta + side), math.sin(theta + side)]), self.a, self.b
        )
        return not (len(hits) and abs(hits.min() - lost_distance) < 0.15)

    def goal_on_contour(self, component: int, gx: float, gy: float, radius: float, target: float) -> bool | None:
        """True: the disc surely holds a free point within target of the component; False: surely not."""
        reach = radius + _DECISION_MARGIN
        step = 0.015
        offsets = np.arange(-reach, reach + step, step)
        grid = np.stack(np.meshgrid(offsets, offsets), axis=-1).reshape(-1, 2)
        grid = grid[np.hypot(grid[:, 0], grid[:, 1]) <= reach]
        points = grid + np.array([gx, gy])
        room = self.clearance(points) >= self.robot_radius
        to_solid = self.clearance(points, component)
        centre_distance = np.hypot(grid[:, 0], grid[:, 1])
        if np.any(room & (to_solid <= target + 0.03) & (centre_distance <= radius - _DECISION_MARGIN)):
            return True
        if not np.any(room & (to_solid <= target + 0.15)):
            return False
        return None


_BUILDERS: dict[str, Callable[[np.random.Generator, _Options, str], dict]] = {
    "perfect": _perfect_family,
    "loops": _loops_family,
    "rotated": _rotated_family,
    "bends": _bends_family,
    "curved": _curved_family,
    "pillars": _pillars_family,
    "narrowing": _narrowing_family,
    "dead_ends": _dead_ends_family,
    "thin_walls": _thin_family,
    "open_room": _open_room_family,
}
