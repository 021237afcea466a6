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
    means: np.ndarray, points: np.ndarray, reach: float, neighbours: int, min_neighbours: int, flatness: float
) -> tuple[np.ndarray, np.ndarray]:
    """(centres, normals) (K, 2) each: for each of `means`, the centroid and unit normal (the small principal axis)
    of the `neighbours` points nearest it within `reach` m; where fewer than `min_neighbours` are that close, or the
    small axis' spread is above `flatness` times the long one's (a corner, a lone point), the mean itself and a NaN
    normal. A grid of `reach` m squares finds the neighbours (a k-d tree's query of 64 did the same 5-10 times
    slower)."""
    means = np.ascontiguousarray(means, dtype=float).reshape(-1, 2)
    points = np.ascontiguousarray(points, dtype=float).reshape(-1, 2)
    centres, normals = means.copy(), np.full(means.shape, np.nan)
    if len(points) < min_neighbours or not len(means):
        return centres, normals
    low = points.min(axis=0)
    cells = np.floor((points - low) / reach).astype(np.int64)
    width = int(cells[:, 0].max()) + 1
    height = int(cells[:, 1].max()) + 1
    keys = cells[:, 1] * width + cells[:, 0]
    order = np.argsort(keys, kind="stable")
    starts = np.searchsorted(keys[order], np.arange(width * height + 1))
    _lines_kernel(
        means, points[order], starts, width, height, low, reach, neighbours, min_neighbours, flatness, centres, normals
    )
    return centres, normals


@numba.njit(cache=True)
def _lines_kernel(
    means, points, starts, width, height, low, reach, neighbours, min_neighbours, flatness, centres, normals
):  # pragma: no cover - compiled
    buffer_d = np.empty(len(points))
    buffer_i = np.empty(len(points), dtype=np.int64)
    reach2 = reach * reach
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
        sx, sy = 0.0, 0.0
        for p in chosen:
            sx += points[p, 0]
            sy += points[p, 1]
        ax, ay = sx / k, sy / k
        a, b, c = 0.0, 0.0, 0.0
        for p in chosen:
            dx, dy = points[p, 0] - ax, points[p, 1] - ay
            a += dx * dx
            b += dx * dy
            c += dy * dy
        half = 0.5 * (a - c)
        root = math.sqrt(half * half + b * b)
        small = 0.5 * (a + c) - root
        large = 0.5 * (a + c) + root
        if not small <= flatness * flatness * max(large, 1e-12):
            continue
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
        centres[m, 0], centres[m, 1] = ax, ay
        normals[m, 0], normals[m, 1] = ux / norm, uy / norm
