"""Grid searches for the position minimizing a cost, seed 000 chapter 4 ("Localización").

exhaustive: every point of a square grid of side 2 radius and spacing `step`
around `centre`: (2 radius / step + 1)^2 evaluations.

pyramidal ("incremento piramidal"): a (2 k + 1)^2 grid of spacing radius / k
around the centre; then again around the best point with half the spacing (the
square shrinks with it, still reaching k cells each way), until the spacing is
`step`: about (2 k + 1)^2 log2(radius / (k step)) evaluations. It assumes the
cost has one basin at the coarse spacing (true of range errors to well spread
beacons), which the exhaustive search does not.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

Cost = Callable[[np.ndarray], np.ndarray]
"""(N, 2) positions -> (N,) costs."""


@dataclass(frozen=True)
class SearchResult:
    position: np.ndarray
    cost: float
    evaluations: int


def _square(centre: np.ndarray, half_cells: int, step: float) -> np.ndarray:
    offsets = np.arange(-half_cells, half_cells + 1) * step
    gx, gy = np.meshgrid(centre[0] + offsets, centre[1] + offsets, indexing="ij")
    return np.column_stack([gx.ravel(), gy.ravel()])


def exhaustive_search(cost: Cost, centre, radius: float, step: float, batch: int = 250_000) -> SearchResult:
    centre = np.asarray(centre, dtype=float)
    half_cells = math.ceil(radius / step - 1e-9)
    offsets = np.arange(-half_cells, half_cells + 1) * step
    best, best_cost, evaluations = centre, math.inf, 0
    rows = max(1, batch // offsets.size)
    for start in range(0, offsets.size, rows):  # in strips, so a fine grid over a big square fits in memory
        gx, gy = np.meshgrid(centre[0] + offsets[start : start + rows], centre[1] + offsets, indexing="ij")
        points = np.column_stack([gx.ravel(), gy.ravel()])
        costs = cost(points)
        evaluations += len(points)
        index = int(np.argmin(costs))
        if costs[index] < best_cost:
            best, best_cost = points[index], float(costs[index])
    return SearchResult(best, best_cost, evaluations)


def pyramidal_search(cost: Cost, centre, radius: float, step: float, half_cells: int = 4) -> SearchResult:
    best = np.asarray(centre, dtype=float)
    spacing = radius / half_cells
    evaluations = 0
    while True:
        points = _square(best, half_cells, spacing)
        costs = cost(points)
        evaluations += len(points)
        index = int(np.argmin(costs))
        best, best_cost = points[index], float(costs[index])
        if spacing <= step * (1.0 + 1e-9):
            return SearchResult(best, best_cost, evaluations)
        spacing = max(spacing / 2.0, step)
