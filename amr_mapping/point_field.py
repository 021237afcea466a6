"""The submaps' lines, found around the points on a grid.

`neighbourhood_lines` gives each voxel mean the centroid and normal of its nearest points (a grid of `reach` m
squares finds them: a k-d tree's query did the same 5-10 times slower). The submaps' likelihood field is
amr_maps.scan_matcher.ScoreMap.from_points(..., to_points=True), stamped around the points. The field measured to
the nearest mean itself instead (not the nearest cell's) was tried: intel 0.060 -> 0.056 m, but orebro's weak
matches found rivals in its smoother field (ATE 0.10 -> 0.27 m); not kept.
"""

from __future__ import annotations

import math

import numba
import numpy as np


def neighbourhood_lines(
    means: np.ndarray,
    points: np.ndarray,
    reach: float,
    neighbours: int,
    min_neighbours: int,
    flatness: float,
    sensors: np.ndarray | None = None,
    mean_sensors: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(centres, normals) (K, 2) each: for each of `means`, the centroid and unit normal (the small principal axis)
    of the `neighbours` points nearest it within `reach` m; where fewer than `min_neighbours` are that close, or the
    small axis' spread is above `flatness` times the long one's (a corner, a lone point), the mean itself and a NaN
    normal. A grid of `reach` m squares finds the neighbours (a k-d tree's query of 64 did the same 5-10 times
    slower).

    With `sensors` (where the sensor that saw each point stood, (N, 2)) and `mean_sensors` (each mean's: the average
    of its points'), a surface is seen from one side: the neighbours whose sensor lies on the other side of the line
    first fitted than the mean's (the two faces of a thin wall, 5.5 cm apart in a generated maze, both within
    `reach`) are left out and the line fitted again to the rest, and the normal points to the mean's sensors' side
    (the side a scan point must be seen from to lie on this surface: GraphSlam's refinement pairs no others). The
    sensor's position, not the beam's direction, decides a side: at a grazing beam a point's noise can put it on
    the far side of its own line."""
    means = np.ascontiguousarray(means, dtype=float).reshape(-1, 2)
    points = np.ascontiguousarray(points, dtype=float).reshape(-1, 2)
    centres, normals = means.copy(), np.full(means.shape, np.nan)
    if len(points) < min_neighbours or not len(means):
        return centres, normals
    if (sensors is None) != (mean_sensors is None):
        raise ValueError("neighbourhood_lines: sensors and mean_sensors go together")
    if sensors is None:
        sensors, mean_sensors = np.zeros((0, 2)), np.zeros((0, 2))
    else:
        sensors = np.ascontiguousarray(sensors, dtype=float).reshape(-1, 2)
        mean_sensors = np.ascontiguousarray(mean_sensors, dtype=float).reshape(-1, 2)
        if sensors.shape != points.shape or mean_sensors.shape != means.shape:
            raise ValueError(
                f"neighbourhood_lines: sensors {sensors.shape} and mean_sensors {mean_sensors.shape} must match "
                f"points {points.shape} and means {means.shape}"
            )
    low = points.min(axis=0)
    cells = np.floor((points - low) / reach).astype(np.int64)
    width = int(cells[:, 0].max()) + 1
    height = int(cells[:, 1].max()) + 1
    keys = cells[:, 1] * width + cells[:, 0]
    order = np.argsort(keys, kind="stable")
    starts = np.searchsorted(keys[order], np.arange(width * height + 1))
    _lines_kernel(
        means,
        points[order],
        sensors[order] if len(sensors) else sensors,
        mean_sensors,
        starts,
        width,
        height,
        low,
        reach,
        neighbours,
        min_neighbours,
        flatness,
        centres,
        normals,
    )
    return centres, normals


@numba.njit(cache=True)
def _fit_line(points, chosen, count):  # pragma: no cover - compiled
    """(centroid x, y, unit normal x, y, small spread, large spread) of points[chosen[:count]]."""
    sx, sy = 0.0, 0.0
    for i in range(count):
        sx += points[chosen[i], 0]
        sy += points[chosen[i], 1]
    ax, ay = sx / count, sy / count
    a, b, c = 0.0, 0.0, 0.0
    for i in range(count):
        dx, dy = points[chosen[i], 0] - ax, points[chosen[i], 1] - ay
        a += dx * dx
        b += dx * dy
        c += dy * dy
    half = 0.5 * (a - c)
    root = math.sqrt(half * half + b * b)
    small = 0.5 * (a + c) - root
    large = 0.5 * (a + c) + root
    # the small axis: (b, small - a) or (small - c, b), whichever is the longer (the same line)
    ux, uy = b, small - a
    vx, vy = small - c, b
    if ux * ux + uy * uy >= vx * vx + vy * vy:
        norm = math.sqrt(ux * ux + uy * uy)
    else:
        ux, uy = vx, vy
        norm = math.sqrt(ux * ux + uy * uy)
    if norm == 0.0:  # isotropic spread or a single point: any direction; a degenerate line
        ux, uy, norm = 1.0, 0.0, 1.0
    return ax, ay, ux / norm, uy / norm, small, large


@numba.njit(cache=True)
def _lines_kernel(
    means,
    points,
    sensors,
    mean_sensors,
    starts,
    width,
    height,
    low,
    reach,
    neighbours,
    min_neighbours,
    flatness,
    centres,
    normals,
):  # pragma: no cover - compiled
    buffer_d = np.empty(len(points))
    buffer_i = np.empty(len(points), dtype=np.int64)
    same = np.empty(len(points), dtype=np.int64)
    reach2 = reach * reach
    oriented = len(sensors) > 0
    for m in range(len(means)):
        mx, my = means[m, 0], means[m, 1]
        cx = int(math.floor((mx - low[0]) / reach))
        cy = int(math.floor((my - low[1]) / reach))
        n = 0
        for gy in range(max(cy - 1, 0), min(cy + 2, height)):
            for gx in range(max(cx - 1, 0), min(cx + 2, width)):
                key = gy * width + gx
                for p in range(starts[key], starts[key + 1]):
                    dx, dy = points[p, 0] - mx, points[p, 1] - my
                    d2 = dx * dx + dy * dy
                    if d2 < reach2:
                        buffer_d[n] = d2
                        buffer_i[n] = p
                        n += 1
        if n < min_neighbours:
            continue
        if n > neighbours:
            chosen = buffer_i[:n][np.argsort(buffer_d[:n])[:neighbours]]
        else:
            chosen = buffer_i[:n]
        k = len(chosen)
        ax, ay, nx, ny, small, large = _fit_line(points, chosen, k)
        if oriented:
            # the mean's sensors' side of the line; the neighbours seen from the other side are another surface
            if (mean_sensors[m, 0] - ax) * nx + (mean_sensors[m, 1] - ay) * ny < 0.0:
                nx, ny = -nx, -ny
            kept = 0
            for i in range(k):
                p = chosen[i]
                if (sensors[p, 0] - ax) * nx + (sensors[p, 1] - ay) * ny >= 0.0:
                    same[kept] = p
                    kept += 1
            if kept < k:
                if kept < min_neighbours:
                    continue
                ax, ay, nx, ny, small, large = _fit_line(points, same, kept)
                if (mean_sensors[m, 0] - ax) * nx + (mean_sensors[m, 1] - ay) * ny < 0.0:
                    nx, ny = -nx, -ny
        if not small <= flatness * flatness * max(large, 1e-12):
            continue
        centres[m, 0], centres[m, 1] = ax, ay
        normals[m, 0], normals[m, 1] = nx, ny
