"""KLD-sampling: how many particles the posterior needs (Fox, "Adapting the sample size in particle filters
through KLD-sampling", IJRR 2003; AMCL's pf_err / pf_z).

With k histogram bins of (x, y, theta) holding at least one particle, the number
of samples that keeps the Kullback-Leibler distance between the sample-based and
the true posterior below epsilon with probability 1 - delta is

    n = (k - 1) / (2 epsilon) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z_{1-delta})^3

(z the standard normal quantile, the standard library's: scipy.stats's import alone is 0.7 s of every
particle filter process's start): many particles while the belief is spread over many bins, few once it has
collapsed to one place.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

_STANDARD_NORMAL = NormalDist()


def kld_sample_count(occupied_bins: int, epsilon: float, delta: float) -> int:
    """Particles needed for `occupied_bins` non-empty bins (1 bin or fewer: 1)."""
    if occupied_bins <= 1:
        return 1
    k = occupied_bins - 1
    z = _STANDARD_NORMAL.inv_cdf(1.0 - delta)
    a = 2.0 / (9.0 * k)
    return math.ceil(k / (2.0 * epsilon) * (1.0 - a + math.sqrt(a) * z) ** 3)


def occupied_bins(particles: np.ndarray, bin_size: float, bin_angle: float) -> int:
    """How many (x, y, theta) bins of the given sizes hold at least one particle."""
    keys = np.floor(
        np.column_stack([particles[:, 0] / bin_size, particles[:, 1] / bin_size, particles[:, 2] / bin_angle])
    )
    return len(np.unique(keys.astype(np.int64), axis=0))
