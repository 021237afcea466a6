"""A pose and its covariance from weighted particles: weighted mean, circular mean heading.

    x = sum w_i x_i,  y = sum w_i y_i,  theta = atan2(sum w_i sin theta_i, sum w_i cos theta_i)
    cov = sum w_i (p_i - p)(p_i - p)^T,  with theta_i - theta wrapped to [-pi, pi)

(weights normalized over the particles given).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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
    x, y = w @ particles[:, 0], w @ particles[:, 1]
    theta = math.atan2(w @ np.sin(particles[:, 2]), w @ np.cos(particles[:, 2]))
    deviation = np.column_stack([particles[:, 0] - x, particles[:, 1] - y, wrap_angle(particles[:, 2] - theta)])
    covariance = (deviation * w[:, None]).T @ deviation
    return PoseEstimate(float(x), float(y), float(wrap_angle(theta)), covariance)
