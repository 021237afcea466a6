"""The route through a grid maze as the sequence of cells entered, and the route a hand follower must take.

In a perfect (tree) maze every right-hand follower walks the same route, the boundary of the
solid beside its start (amr_maps.boundary_walk measures its length); a follower that skips a
side opening or turns back has left it, whether or not it still stumbles on the goal. Comparing
routes cell by cell catches that (bench/bench_wall_follower_families.py --route).

* :class:`MazeGrid` reads the cell grid back from a grid maze's walls (amr_maps.maze_families
  ``perfect``, ``loops``, ``rotated``, ``thin_walls``, ``dead_ends``): walls on the lines of a
  square grid of some pitch, possibly turned as a whole, and which neighbouring cells are open
  to each other.
* :func:`hand_tour` is the ideal route: from the start cell and heading, keep the hand on the
  wall (right-hand: right, else straight, else left, else back). In a tree maze it is the walk
  round the tree; in any maze it is the route along the boundary of the solid beside the start.
* :func:`cell_route` turns a trajectory into the cells entered, each once per visit. A cell
  counts as entered only when the robot's centre is ``margin`` inside it: turning in place
  near a cell's edge, a centre a few cm across the line has not taken the passage.
* :func:`first_difference` compares two routes.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

Cell = tuple[int, int]
STEPS = ((1, 0), (0, 1), (-1, 0), (0, -1))
"""Grid directions, counter-clockwise from +x of the grid."""
HANDS = ("right", "left")
ON_LINE = 1e-3
"""m: wall ends this close to a grid line lie on it."""
ENTRY_MARGIN = 0.05
"""m the robot's centre must be inside a cell for it to count as entered (see cell_route)."""


class NotAGridMaze(ValueError):
    """The world's walls do not lie on the lines of one square grid."""


@dataclass(frozen=True)
class MazeGrid:
    """Square cells of side ``pitch``; cell (i, j) spans [i, i+1) x [j, j+1) pitches from ``origin``
    in the grid frame, which is the world frame turned by ``angle``."""

    angle: float
    origin: tuple[float, float]
    pitch: float
    n: int
    m: int
    passages: frozenset
    """frozensets of two neighbouring cells with no wall between them"""

    @classmethod
    def from_world(cls, world: dict) -> MazeGrid:
        """The grid of a world dict whose walls (centre lines) all lie on one square grid's lines."""
        walls = np.asarray(world.get("walls") or [], dtype=float).reshape(-1, 4)
        if len(walls) < 4:
            raise NotAGridMaze(f"{world.get('name', 'world')}: {len(walls)} walls, a grid maze has at least 4")
        d = walls[:, 2:] - walls[:, :2]
        angle = math.atan2(d[0, 1], d[0, 0]) % (0.5 * math.pi)
        if angle > 0.25 * math.pi:
            angle -= 0.5 * math.pi
        c, s = math.cos(angle), math.sin(angle)
        x = c * walls[:, 0::2] + s * walls[:, 1::2]  # into the grid frame: turn by -angle
        y = -s * walls[:, 0::2] + c * walls[:, 1::2]
        origin = (float(x.min()), float(y.min()))
        lines = np.unique(np.concatenate([(x - origin[0]).ravel(), (y - origin[1]).ravel()]))
        gaps = np.diff(lines)
        gaps = gaps[gaps > ON_LINE]
        if len(gaps) == 0:
            raise NotAGridMaze(f"{world.get('name', 'world')}: the walls span no cell")
        pitch = float(gaps.min())
        u, v = (x - origin[0]) / pitch, (y - origin[1]) / pitch
        if max(np.abs(u - np.round(u)).max(), np.abs(v - np.round(v)).max()) * pitch > ON_LINE:
            raise NotAGridMaze(f"{world.get('name', 'world')}: a wall end is off the grid of pitch {pitch:.4f} m")
        if not np.all((np.abs(u[:, 0] - u[:, 1]) * pitch < ON_LINE) | (np.abs(v[:, 0] - v[:, 1]) * pitch < ON_LINE)):
            raise NotAGridMaze(f"{world.get('name', 'world')}: a wall is not along a grid line")
        n, m = int(round(u.max())), int(round(v.max()))
        u, v = np.round(u).astype(int), np.round(v).astype(int)
        blocked = set()
        for (u1, u2), (v1, v2) in zip(u, v, strict=True):
            if u1 == u2:  # on the vertical line x = u1: closes (u1 - 1, j) | (u1, j)
                blocked |= {frozenset(((u1 - 1, j), (u1, j))) for j in range(min(v1, v2), max(v1, v2))}
            else:
                blocked |= {frozenset(((i, v1 - 1), (i, v1))) for i in range(min(u1, u2), max(u1, u2))}
        passages = set()
        for i in range(n):
            for j in range(m):
                for a, b in ((i + 1, j), (i, j + 1)):
                    pair = frozenset(((i, j), (a, b)))
                    if a < n and b < m and pair not in blocked:
                        passages.add(pair)
        return cls(angle, origin, pitch, n, m, frozenset(passages))

    def coordinates(self, x: float, y: float) -> tuple[float, float]:
        """(x, y) in m, world frame -> position in pitches from the origin, grid frame."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        return ((c * x + s * y - self.origin[0]) / self.pitch, (-s * x + c * y - self.origin[1]) / self.pitch)

    def cell(self, x: float, y: float) -> Cell:
        u, v = self.coordinates(x, y)
        return (math.floor(u), math.floor(v))

    def open_between(self, a: Cell, b: Cell) -> bool:
        return frozenset((a, b)) in self.passages


def hand_tour(grid: MazeGrid, start: Sequence[float], hand: str = "right") -> list[Cell]:
    """The cells a ``hand`` follower enters from ``start`` (x, y, theta), the start's cell first,
    for one lap: until it would step through the same passage the same way again."""
    if hand not in HANDS:
        raise ValueError(f"hand must be one of {HANDS}, got {hand!r}")
    x, y, theta = start
    cell = grid.cell(x, y)
    heading = round(((theta - grid.angle) % (2.0 * math.pi)) / (0.5 * math.pi)) % 4
    order = (-1, 0, 1, 2) if hand == "right" else (1, 0, -1, 2)
    taken: set = set()
    tour = [cell]
    while True:
        for turn in order:
            d = (heading + turn) % 4
            nxt = (cell[0] + STEPS[d][0], cell[1] + STEPS[d][1])
            if grid.open_between(cell, nxt):
                cell, heading = nxt, d
                break
        else:  # a single closed cell
            break
        if (tour[-1], cell) in taken:
            break
        taken.add((tour[-1], cell))
        tour.append(cell)
    return tour


def cell_route(grid: MazeGrid, points: Iterable[Sequence[float]], margin: float = ENTRY_MARGIN) -> list[Cell]:
    """The cells a trajectory (x, y per sample, m) enters, in order, each once per visit.

    The route moves to a new cell once the point is at least ``margin`` inside it (from every
    side of it), so that a centre hovering about a cell's edge neither enters nor flickers.
    """
    route: list[Cell] = []
    for x, y in points:
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        u, v = grid.coordinates(x, y)
        cell = (math.floor(u), math.floor(v))
        if route and cell == route[-1]:
            continue
        inside = min(u - cell[0], cell[0] + 1 - u, v - cell[1], cell[1] + 1 - v) * grid.pitch
        if not route or inside >= margin:
            route.append(cell)
    return route


def first_difference(route: Sequence[Cell], reference: Sequence[Cell]) -> int | None:
    """Index of the first cell where ``route`` leaves ``reference``; None when it is a prefix of it.

    A route longer than the reference differs where the reference ends.
    """
    for index, (a, b) in enumerate(zip(route, reference, strict=False)):
        if a != b:
            return index
    return None if len(route) <= len(reference) else len(reference)
