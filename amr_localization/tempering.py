"""Adaptive likelihood tempering: how much of one measurement to believe at once.

A scan of 60 beams on a known map is so informative that, during global
localization, a single update can give one particle almost all the weight
(N_eff of a few out of thousands): the filter then bets everything on the
place that happened to fit best, which in a maze of repeating corridors is
often wrong, and the particles elsewhere are gone. Following the annealed /
tempered particle filters (and the adaptive likelihood of Pfaff, Burgard and
Fox 2006: smooth while global, peaked while tracking), each update uses

    w_i <- w_i p(z | x_i)^beta,   beta = the largest value in (0, beta_max]
                                          with N_eff(w) >= min_ess_ratio * N

found by bisection (N_eff decreases as beta grows). While the particles are
spread over many candidate places beta is small and the evidence builds up over
several scans; once they agree (tracking), beta reaches beta_max.
"""

from __future__ import annotations

import numpy as np

BISECTION_STEPS = 12


def _normalized(log_weights: np.ndarray) -> np.ndarray:
    weights = np.exp(log_weights - log_weights.max())
    return weights / weights.sum()


def tempered_exponent(log_prior: np.ndarray, log_likelihood: np.ndarray, beta_max: float, min_ess_ratio: float) -> float:
    """beta in (0, beta_max] keeping N_eff of exp(log_prior + beta log_likelihood) >= min_ess_ratio N_eff(prior)."""
    alive = np.isfinite(log_prior)
    prior, likelihood = log_prior[alive], log_likelihood[alive]

    def ess(beta: float) -> float:
        weights = _normalized(prior + beta * likelihood)
        return 1.0 / float(weights @ weights)

    target = min_ess_ratio * ess(0.0)

    if ess(beta_max) >= target:
        return beta_max
    low, high = 0.0, beta_max
    for _ in range(BISECTION_STEPS):
        middle = 0.5 * (low + high)
        if ess(middle) >= target:
            low = middle
        else:
            high = middle
    return max(low, beta_max / 2**BISECTION_STEPS)
