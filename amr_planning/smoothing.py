"""The course's gradient path smoothing, kept out of the inflated obstacles.

Each interior point y_i moves towards its original position x_i (data term, weight a) and
towards the midpoint of its neighbours (smoothness term, weight b):

    y_i <- y_i + a (x_i - y_i) + b (y_{i-1} + y_{i+1} - 2 y_i)

until no point moves more than `tolerance`. The end points stay put. Updates run in red-black
order (odd points, then even points with their neighbours' new values): Gauss-Seidel like the
course's in-place loop, vectorized, and stable for any weights (a plain simultaneous update
diverges once b > (2 - a) / 4).

Safety: after every half sweep, a point whose move would put it, or a segment to a neighbour, in an
inflated cell of the costmap (closer to a wall than robot radius + safety margin) keeps its previous
position; the path therefore never cuts through an inflated obstacle. A segment of the input that
already crossed the safety margin (a narrow passage) is held to the lethal cells instead, and one
that crossed lethal cells (a start escaping from next to a wall) to nothing.
Before smoothing, points are inserted so that consecutive points are at most `spacing` apart
(the course's "additional smoothing points").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from amr_planning.costmap import Costmap
from amr_util.parameter_spec import Config, parameter


@dataclass(frozen=True)
class SmoothingConfig(Config):
    data_weight: float = parameter(0.1, minimum=0.001, maximum=1.0)
    """a: pull towards the planned point (course: 0.1)."""
    smooth_weight: float = parameter(0.3, minimum=0.0, maximum=0.5)
    """b: pull towards the neighbours' midpoint (course: 0.3; above 0.5 a point overshoots the midpoint)."""
    spacing: float = parameter(0.05, minimum=0.001, maximum=1.0)
    """m, the largest gap left between consecutive points before smoothing."""
    tolerance: float = parameter(1e-5, above=0.0, maximum=1.0)
    """m, stop when no point moves more than this in a sweep."""
    max_iterations: int = parameter(1000, minimum=1, maximum=1_000_000)
    """sweeps at most."""


def densify(points: np.ndarray, spacing: float) -> np.ndarray:
    """The polyline with points inserted evenly so that no gap exceeds spacing."""
    points = np.asarray(points, dtype=float)
    if len(points) < 2:
        return points.copy()
    gaps = np.hypot(*np.diff(points, axis=0).T)
    pieces = np.maximum(np.ceil(gaps / spacing).astype(int), 1)
    owner = np.repeat(np.arange(len(gaps)), pieces)
    first = np.cumsum(pieces) - pieces
    fraction = (np.arange(owner.size) - first[owner]) / pieces[owner]
    inserted = points[owner] + fraction[:, None] * (points[owner + 1] - points[owner])
    return np.vstack([inserted, points[-1:]])


def smooth_path(points: np.ndarray, costmap: Costmap, config: SmoothingConfig | None = None) -> np.ndarray:
    """The smoothed path (M, 2), M >= len(points); never closer to a wall than the planner allowed."""
    config = config or SmoothingConfig()
    original = densify(points, config.spacing)
    count = len(original)
    if count < 3:
        return original
    path = original.copy()
    # The cells each segment must keep out of: the inflated ones, else the lethal ones, else none.
    clear = costmap.segments_free(original[:-1], original[1:], costmap.inflated)
    fits = costmap.segments_free(original[:-1], original[1:])
    keep_out = (clear, fits & ~clear)
    a, b = config.data_weight, config.smooth_weight
    halves = (np.arange(1, count - 1, 2), np.arange(2, count - 1, 2))
    for _ in range(config.max_iterations):
        largest = 0.0
        for index in halves:
            if index.size == 0:
                continue
            previous = path[index]
            proposal = (
                previous + a * (original[index] - previous) + b * (path[index - 1] + path[index + 1] - 2 * previous)
            )
            path[index] = proposal
            _revert_collisions(path, index, previous, costmap, keep_out)
            largest = max(largest, float(np.abs(path[index] - previous).max()))
        if largest < config.tolerance:
            break
    return path


def _revert_collisions(path: np.ndarray, index: np.ndarray, previous: np.ndarray, costmap: Costmap, keep_out) -> None:
    """Put back the moved points (path[index], previously `previous`) whose segments enter cells they must keep out of.

    In a half sweep only every other point moves, so each segment has exactly one moved end:
    reverting it restores a segment that was already clear.
    """
    bad = np.zeros(len(index), dtype=bool)
    for held, mask in zip(keep_out, (costmap.inflated, costmap.lethal), strict=True):
        before = costmap.segments_free(path[index - 1], path[index], mask)
        after = costmap.segments_free(path[index], path[index + 1], mask)
        bad |= (~before & held[index - 1]) | (~after & held[index])
    path[index[bad]] = previous[bad]
