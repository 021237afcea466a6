"""Figures of a run's true path, the same for every controller: distance travelled and stalls."""

from __future__ import annotations

import math

import numpy as np

STALL_SECONDS = 30.0
"""s without entering a cell not visited before: one stall (the next needs another 30 s)."""
STALL_CELL = 0.25
"""m, the side of those cells."""


def path_figures(trajectory: np.ndarray, dt: float) -> dict[str, float | int]:
    """``distance`` (m) and ``stalls`` of a simulator's trajectory (rows x, y, ...: one per step from the start;
    a row of NaN marks a teleport, which neither counts as travel nor as a visit)."""
    path = np.asarray(trajectory, dtype=float)[:, :2]
    distance = float(np.nansum(np.hypot(*np.diff(path, axis=0).T))) if len(path) > 1 else 0.0
    visited: set[tuple[int, int]] = set()
    last_new, stalls = 0.0, 0
    for index, (x, y) in enumerate(path):
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        t = index * dt
        cell = (math.floor(x / STALL_CELL), math.floor(y / STALL_CELL))
        if cell not in visited:
            visited.add(cell)
            last_new = t
        elif t - last_new >= STALL_SECONDS:
            stalls += 1
            last_new = t
    return {"distance": distance, "stalls": stalls}
