"""Low-variance (systematic) resampling and the effective sample size that decides when to resample.

Systematic resampling (Thrun et al., table 4.4) draws one offset u ~ U(0, 1/M)
and takes the particles under the M equally spaced pointers u + m/M on the
cumulative weights. Every particle of weight w gets floor(M w) or ceil(M w)
copies, so the share of each mode of the distribution survives a resampling
almost exactly: in a symmetric world the modes are not lost by chance.

    N_eff = 1 / sum_i w_i^2     (normalized weights; N for equal weights, 1 when one particle has all)
"""

from __future__ import annotations

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
