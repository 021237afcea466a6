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
    w = weights / weights.sum()
    x, y = w @ particles[:, 0], w @ particles[:, 1]
    theta = math.atan2(w @ np.sin(particles[:, 2]), w @ np.cos(particles[:, 2]))
    deviation = np.column_stack([particles[:, 0] - x, particles[:, 1] - y, wrap_angle(particles[:, 2] - theta)])
    covariance = (deviation * w[:, None]).T @ deviation
    return PoseEstimate(float(x), float(y), float(wrap_angle(theta)), covariance)
