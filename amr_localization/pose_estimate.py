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
    particles = np.asarray(particles, dtype=float).reshape(-1, 3)
    means, covariances = np.empty((1, 3)), np.zeros((1, 3, 3))
    one = np.zeros(len(particles), dtype=np.int64)  # every particle in group 0
    _grouped(particles, np.asarray(weights, dtype=float), one, means, covariances, np.zeros(1, dtype=np.int64))
    return PoseEstimate(float(means[0, 0]), float(means[0, 1]), float(wrap_angle(float(means[0, 2]))), covariances[0])


def grouped_covariances(
    particles: np.ndarray, weights: np.ndarray, owner: np.ndarray, groups: int
) -> tuple[np.ndarray, np.ndarray]:
    """weighted_pose's covariance of the particles of each group 0..groups-1 (owner[i]: particle i's group, -1 for
    none), all groups at once; and (groups,) the particles in each."""
    means, covariances, counts = np.empty((groups, 3)), np.zeros((groups, 3, 3)), np.zeros(groups, dtype=np.int64)
    _grouped(np.asarray(particles, dtype=float), np.asarray(weights, dtype=float), owner, means, covariances, counts)
    return covariances, counts


@numba.njit(cache=True, nogil=True)
def _grouped(particles, weights, owner, means, covariances, counts):
    """The module's formulas for each group at once, in three passes over the particles without temporaries (they
    run several times an update, on thousands of particles): counts and weights, means, covariances."""
    groups = counts.shape[0]
    sums = np.zeros((groups, 5))  # weight, w x, w y, w sin, w cos
    for i in range(particles.shape[0]):
        g = owner[i]
        if g < 0 or g >= groups:
            continue
        counts[g] += 1
        w = weights[i]
        sums[g, 0] += w
    # weighted_pose's normalization: equal weights where a group's sum is not positive and finite
    scale = np.zeros(groups)
    equal = np.zeros(groups, dtype=np.bool_)
    for g in range(groups):
        total = sums[g, 0]
        if total > 0.0 and math.isfinite(total):
            scale[g] = 1.0 / total
        elif counts[g] > 0:
            equal[g] = True
            scale[g] = 1.0 / counts[g]
    for i in range(particles.shape[0]):
        g = owner[i]
        if g < 0 or g >= groups:
            continue
        w = scale[g] if equal[g] else weights[i] * scale[g]
        sums[g, 1] += w * particles[i, 0]
        sums[g, 2] += w * particles[i, 1]
        sums[g, 3] += w * math.sin(particles[i, 2])
        sums[g, 4] += w * math.cos(particles[i, 2])
    theta = np.empty(groups)
    for g in range(groups):
        theta[g] = math.atan2(sums[g, 3], sums[g, 4])
        means[g, 0], means[g, 1], means[g, 2] = sums[g, 1], sums[g, 2], theta[g]
    d = np.empty(3)
    for i in range(particles.shape[0]):
        g = owner[i]
        if g < 0 or g >= groups:
            continue
        w = scale[g] if equal[g] else weights[i] * scale[g]
        d[0], d[1] = particles[i, 0] - sums[g, 1], particles[i, 1] - sums[g, 2]
        d[2] = (particles[i, 2] - theta[g] + math.pi) % (2.0 * math.pi) - math.pi
        for a in range(3):
            for b in range(a, 3):
                covariances[g, a, b] += w * d[a] * d[b]
    for g in range(groups):
        for a in range(3):
            for b in range(a):
                covariances[g, a, b] = covariances[g, b, a]
