"""Low-variance (systematic) resampling and the effective sample size that decides when to resample.

Systematic resampling (Thrun et al., table 4.4) draws one offset u ~ U(0, 1/M)
and takes the particles under the M equally spaced pointers u + m/M on the
cumulative weights. Every particle of weight w gets floor(M w) or ceil(M w)
copies, so the share of each mode of the distribution survives a resampling
almost exactly: in a symmetric world the modes are not lost by chance.

    N_eff = 1 / sum_i w_i^2     (normalized weights; N for equal weights, 1 when one particle has all)
"""

from __future__ import annotations

import math

import numba
import numpy as np


def effective_sample_size(weights: np.ndarray) -> float:
    """1 / sum(w^2) of normalized weights."""
    return float(1.0 / np.sum(np.square(weights)))


def systematic_resample(weights: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of `count` particles drawn by low-variance resampling from normalized weights."""
    pointers = (rng.random() + np.arange(count)) / count
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0  # rounding must not leave the last pointer past the end
    return np.searchsorted(cumulative, pointers, side="right").clip(max=len(weights) - 1)


@numba.njit(cache=True, nogil=True)
def jitter(poses, owner, places, factors, draws, bandwidth, free, origin_x, origin_y, resolution):
    """The regularized filter's kernel move, in place: the poses whose owner is places[g] (place by place, each
    place's poses in their order, taking the rows of `draws` in turn) moved by bandwidth * factors[g] @ draw, where the
    move ends in a True cell of `free` (rows y, columns x, cells of `resolution` from the origin); heading wrapped."""
    d = 0
    for g in range(places.shape[0]):
        f = factors[g]
        for i in range(poses.shape[0]):
            if owner[i] != places[g]:
                continue
            z0, z1, z2 = draws[d, 0], draws[d, 1], draws[d, 2]
            d += 1
            x = poses[i, 0] + bandwidth * (f[0, 0] * z0 + f[0, 1] * z1 + f[0, 2] * z2)
            y = poses[i, 1] + bandwidth * (f[1, 0] * z0 + f[1, 1] * z1 + f[1, 2] * z2)
            theta = poses[i, 2] + bandwidth * (f[2, 0] * z0 + f[2, 1] * z1 + f[2, 2] * z2)
            col = math.floor((x - origin_x) / resolution)
            row = math.floor((y - origin_y) / resolution)
            if 0 <= row < free.shape[0] and 0 <= col < free.shape[1] and free[row, col]:
                poses[i, 0], poses[i, 1] = x, y
                poses[i, 2] = (theta + math.pi) % (2.0 * math.pi) - math.pi
