"""The submaps' likelihood field and lines, computed around the points instead of over the whole box.

`point_field` is `amr_maps.scan_matcher.ScoreMap.from_points(..., to_points=True)`'s field, stamped: the same box
and the same exp(-d^2 / (2 sigma^2)), d from a cell's centre to the mean of the points in the nearest cell holding
any (by the cells' centres; of cells equally near, the lowest column then row, as scipy's transform), computed only
within FIELD_REACH sigmas of the points' cells (0 beyond: below exp(-18), under the matcher's uint16 quantum; cell for
cell the same value within). from_points' distance
transform of the box a submap's 20 m beams span (about 800 x 800 cells) was 40-60 % of GraphSlam's time on the
logs; the stamps cost the points' cells times a square of FIELD_REACH sigmas. The field measured to the nearest mean
itself instead (not the nearest cell's) was tried: intel 0.060 -> 0.056 m, but orebro's weak matches found rivals
in its smoother field (ATE 0.10 -> 0.27 m); not kept.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from amr_maps.scan_matcher import FIELD_REACH, ScoreMap


def point_field(points: np.ndarray, resolution: float, sigma: float, pad: float, cover: np.ndarray) -> ScoreMap:
    """The likelihood field of `points` (K, 2) on cells of `resolution` m covering them and the `cover` points,
    `pad` m around (ScoreMap.from_points' box), every cell a candidate; see the module docstring."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    points = points[np.all(np.isfinite(points), axis=1)]
    cover = np.asarray(cover, dtype=float).reshape(-1, 2)
    extent = np.vstack([points, cover[np.all(np.isfinite(cover), axis=1)]])
    if not len(extent):
        raise ValueError("point field: no finite point to rasterize or cover")
    low = np.floor((extent.min(axis=0) - pad) / resolution) * resolution
    shape = np.ceil((extent.max(axis=0) + pad - low) / resolution).astype(int) + 1
    cols, rows = int(shape[0]), int(shape[1])
    if not len(points):
        return ScoreMap(np.zeros((rows, cols), dtype=np.float32), resolution, (float(low[0]), float(low[1])))
    cells = np.floor((points - low) / resolution).astype(int)
    flat = cells[:, 1] * cols + cells[:, 0]
    occupied, group = np.unique(flat, return_inverse=True)
    group = group.reshape(-1)
    count = np.bincount(group)
    mean_x = np.bincount(group, weights=points[:, 0]) / count
    mean_y = np.bincount(group, weights=points[:, 1]) / count
    reach = int(math.ceil(FIELD_REACH * sigma / resolution))
    x = low[0] + (np.arange(cols) + 0.5) * resolution
    y = low[1] + (np.arange(rows) + 0.5) * resolution
    d2 = _nearest_cell_means(occupied // cols, occupied % cols, mean_x, mean_y, x, y, reach)
    table = np.zeros((rows, cols), dtype=np.float32)
    near = np.isfinite(d2)
    table[near] = np.exp(-0.5 * d2[near] / (sigma * sigma))
    return ScoreMap(table, resolution, (float(low[0]), float(low[1])))


@numba.njit(cache=True)
def _nearest_cell_means(rows, cols, mean_x, mean_y, x, y, reach):  # pragma: no cover - compiled
    """Squared distance (m^2) from each cell's centre (x[col], y[row]) to the mean of the nearest occupied cell
    within `reach` cells (rows, cols; by the cells' centres; of cells equally near, the lowest column, then row:
    scipy's distance transform's choice), infinite beyond every one."""
    n_rows, n_cols = len(y), len(x)
    table = np.full((n_rows, n_cols), np.inf)
    best = np.full((n_rows, n_cols), -1)
    for k in range(len(rows)):
        for i in range(max(rows[k] - reach, 0), min(rows[k] + reach + 1, n_rows)):
            di = i - rows[k]
            for j in range(max(cols[k] - reach, 0), min(cols[k] + reach + 1, n_cols)):
                dj = j - cols[k]
                b = best[i, j]
                if b >= 0:
                    step = di * di + dj * dj
                    other = (i - rows[b]) ** 2 + (j - cols[b]) ** 2
                    if step > other or (step == other and (cols[k], rows[k]) > (cols[b], rows[b])):
                        continue
                best[i, j] = k
                dx = x[j] - mean_x[k]
                dy = y[i] - mean_y[k]
                table[i, j] = dx * dx + dy * dy
    return table


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
