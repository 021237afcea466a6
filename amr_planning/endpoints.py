"""Where a plan may start and end on a costmap: checks shared by every planner.

A start or goal off the map, not finite, or inside an obstacle cell is refused. One that lies in
a lethal cell (closer to an obstacle than the robot's radius by the map's conservative estimate,
e.g. a localized pose a little off, or a goal drawn next to a wall) is moved to the nearest
non-lethal cell if that is within `snap_distance`: the plan then leaves the true start straight
towards that cell, or ends at the free cell nearest the goal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_maps.occupancy_grid import UNKNOWN
from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError, Reason


@dataclass(frozen=True)
class Endpoint:
    """A checked start or goal: the point asked for and the free cell the search uses."""

    point: np.ndarray
    """(x, y) as asked."""
    cell: tuple[int, int]
    """the non-lethal cell the search starts or ends at."""
    snapped: bool
    """True when the asked point's own cell is lethal and `cell` is a nearby free one."""


def resolve(costmap: Costmap, point, what: str, snap_distance: float) -> Endpoint:
    """Check a start or goal (`what` names it in errors) and find the free cell the search uses."""
    try:
        x, y = (float(v) for v in point)
    except (TypeError, ValueError) as error:
        raise PlanningError(Reason.INVALID, f"{what} must be two numbers (x, y), got {point!r}", what) from error
    row, col = costmap.cell(x, y, what)
    blocked = Reason.START_BLOCKED if what == "start" else Reason.GOAL_BLOCKED
    if costmap.obstacle[row, col]:
        kind = "an unknown (never seen)" if costmap.grid.data[row, col] == UNKNOWN else "an occupied"
        raise PlanningError(blocked, f"{what} ({x:.3f}, {y:.3f}) lies in {kind} cell of the map", what)
    if not costmap.lethal[row, col]:
        return Endpoint(np.array([x, y]), (row, col), False)
    free_row, free_col = costmap.nearest_free(row, col)
    if free_row < 0:
        raise PlanningError(blocked, "the map has no cell where the robot fits with its safety margin", what)
    distance = math.hypot(*(costmap.centre(free_row, free_col) - (x, y)))
    if distance > snap_distance:
        raise PlanningError(
            blocked,
            f"{what} ({x:.3f}, {y:.3f}) is {costmap.clearance[row, col]:.3f} m from an obstacle, closer than "
            f"{costmap.config.robot_radius:.3f} m (the robot's radius), and the nearest cell clear enough is "
            f"{distance:.3f} m away "
            f"(more than {snap_distance:.3f} m)",
            what,
        )
    return Endpoint(np.array([x, y]), (free_row, free_col), True)


def assemble(costmap: Costmap, start: Endpoint, goal: Endpoint, cells: np.ndarray) -> np.ndarray:
    """The path's points (N, 2): the true start, the cells' centres, and the true goal unless it was snapped."""
    points = [start.point[None, :], costmap.centre(cells[:, 0], cells[:, 1])]
    if not goal.snapped:
        points.append(goal.point[None, :])
    path = np.concatenate(points)
    keep = np.ones(len(path), dtype=bool)
    keep[1:] = np.hypot(*np.diff(path, axis=0).T) > 1e-9  # a start at its cell's centre is not repeated
    return path[keep]
