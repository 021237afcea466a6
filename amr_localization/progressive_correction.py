"""Progressive correction: a whole measurement applied in stages the particles can follow.

One scan or beacon reading can be far narrower than the spacing of the particles that must represent the
posterior: at the first update of a global localization, a few particles in thousands explain the data at
all, and weighing them by the full likelihood at once leaves one of them with all the weight, a particle's
spacing from the truth, with nothing near it to move to. Following Oudjane and Musso's progressive
correction (2000) and the annealed particle filters, the likelihood is applied as

    p(z | x) = p(z | x)^lambda_1 p(z | x)^lambda_2 ... p(z | x)^lambda_k,    lambda_1 + ... + lambda_k = 1,

each lambda_j the largest that keeps the effective sample size at min_ess_ratio N or above (bisection: N_eff
falls as lambda grows), the particles resampled and moved by the regularized filter's kernel between stages,
and the last stage taking whatever is left. Unlike tempering, no part of the measurement is dropped: a sparse
keyframe counts fully, in as many stages as its sharpness needs (at most MAX_STAGES).
"""

from __future__ import annotations

import math

import numba
import numpy as np

MAX_STAGES = 6
"""stages of one measurement at most; the last takes the rest of the likelihood."""
BISECTION_STEPS = 12


def stage_exponent(log_prior: np.ndarray, log_likelihood: np.ndarray, remaining: float, min_ess_ratio: float) -> float:
    """The largest lambda in (0, remaining] with N_eff of exp(log_prior + lambda log_likelihood) >= min_ess_ratio N
    (at least remaining / 2^BISECTION_STEPS, so that every stage moves on)."""
    alive = np.isfinite(log_prior)
    prior, likelihood = log_prior[alive], log_likelihood[alive]
    target = min_ess_ratio * len(log_prior) / len(prior)
    return _bisection(
        np.ascontiguousarray(prior, dtype=float), np.ascontiguousarray(likelihood, dtype=float), remaining, target
    )


@numba.njit(cache=True, nogil=True)
def _share(prior, likelihood, exponent):
    """N_eff / N of the normalized exp(prior + exponent likelihood), in two passes without temporaries."""
    peak = -np.inf
    for i in range(prior.shape[0]):
        peak = max(peak, prior[i] + exponent * likelihood[i])
    total = squares = 0.0
    for i in range(prior.shape[0]):
        weight = math.exp(prior[i] + exponent * likelihood[i] - peak)
        total += weight
        squares += weight * weight
    return total * total / squares / prior.shape[0]


@numba.njit(cache=True, nogil=True)
def _bisection(prior, likelihood, remaining, target):
    """stage_exponent's bisection on the live particles (compiled: 5,000 particles a step, up to 13 steps a stage,
    several stages an update)."""
    if _share(prior, likelihood, remaining) >= target:
        return remaining
    low, high = 0.0, remaining
    for _ in range(BISECTION_STEPS):
        middle = 0.5 * (low + high)
        if _share(prior, likelihood, middle) >= target:
            low = middle
        else:
            high = middle
    return max(low, remaining / 2**BISECTION_STEPS)
