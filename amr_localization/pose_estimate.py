"""A pose and its covariance from weighted particles: weighted mean, circular mean heading.

    x = sum w_i x_i,  y = sum w_i y_i,  theta = atan2(sum w_i sin theta_i, sum w_i cos theta_i)
    cov = sum w_i (p_i - p)(p_i - p)^T,  with theta_i - theta wrapped to [-pi, pi)

(weights normalized over the particles given).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from amr_util.geometry import wrap_angle


@dataclass(frozen=True)
class PoseEstimate:
    x: float
    y: float
    theta: float
    covariance: np.ndarray
    """3x3 over (x, y, theta)."""

    @property
    def position_std(self) -> float:
        """m, the larger standard deviation of the position (largest eigenvalue's root)."""
        return math.sqrt(max(float(np.linalg.eigvalsh(self.covariance[:2, :2])[-1]), 0.0))

    @property
    def heading_std(self) -> float:
        return math.sqrt(max(float(self.covariance[2, 2]), 0.0))


def weighted_pose(particles: np.ndarray, weights: np.ndarray) -> PoseEstimate:
    """The weighted mean pose and covariance; equal weights where they sum to nothing (every particle weighed 0, as
    those the motion update moved into a wall are): the estimate is always finite for finite particles."""
    if len(particles) == 0:
        raise ValueError("weighted_pose: no particles")
    total = float(np.sum(weights))
    w = weights / total if total > 0.0 and math.isfinite(total) else np.full(len(particles), 1.0 / len(particles))
    mean, covariance = np.empty(3), np.zeros((3, 3))
    _moments(np.asarray(particles, dtype=float), np.asarray(w, dtype=float), mean, covariance)
    return PoseEstimate(float(mean[0]), float(mean[1]), float(wrap_angle(float(mean[2]))), covariance)


@numba.njit(cache=True)
def _moments(particles, w, mean, covariance):
    """The module's formulas in two passes over the particles, no temporaries (it runs several times an update, on
    thousands of particles)."""
    x = y = s = c = 0.0
    for i in range(particles.shape[0]):
        x += w[i] * particles[i, 0]
        y += w[i] * particles[i, 1]
        s += w[i] * math.sin(particles[i, 2])
        c += w[i] * math.cos(particles[i, 2])
    theta = math.atan2(s, c)
    mean[0], mean[1], mean[2] = x, y, theta
    d = np.empty(3)
    for i in range(particles.shape[0]):
        d[0], d[1] = particles[i, 0] - x, particles[i, 1] - y
        d[2] = (particles[i, 2] - theta + math.pi) % (2.0 * math.pi) - math.pi
        for a in range(3):
            for b in range(a, 3):
                covariance[a, b] += w[i] * d[a] * d[b]
    for a in range(3):
        for b in range(a):
            covariance[a, b] = covariance[b, a]
