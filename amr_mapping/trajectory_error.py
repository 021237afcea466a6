"""How far an estimated trajectory is from a reference one: the relative displacement metric of Kümmerle et al.,
"On measuring the accuracy of SLAM algorithms" (Autonomous Robots, 2009), and the absolute trajectory error
after a rigid alignment (Horn 1987 / Umeyama 1991 in SE(2), no scale). No ROS.

Both take (N, 3) arrays of poses (x, y, theta), the estimate's row k the same instant as the reference's.

Relative error: for every pair (i, j), i < j, whose path length along the reference lies in
[min_distance, max_distance] (1..10 m by default), the relative motions delta = relative_pose(p_i, p_j) of both
trajectories are compared, e = relative_pose(delta_ref, delta_est): the translational error is |(e_x, e_y)| (m),
the rotational |e_theta| (deg); the means (and the largest) over the pairs. It does not depend on the
frame either trajectory is given in, and it does not let one early error count at every later pose.

Absolute error: the rotation R and translation t minimizing sum |R p_est + t - p_ref|^2 over the positions
(the SVD of the cross-covariance, with the reflection guard), then the RMS, mean and largest distance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_mapping.errors import MappingError
from amr_util.geometry import wrap_angle


@dataclass(frozen=True)
class RelativeError:
    """Kümmerle's relative displacement error: mean (and largest) translational (m) and rotational (deg)
    error of the relative motions of `pairs` pose pairs."""

    translation: float
    rotation_deg: float
    max_translation: float
    max_rotation_deg: float
    pairs: int


@dataclass(frozen=True)
class AbsoluteError:
    """Absolute trajectory error after the rigid alignment `alignment` (x, y, theta: applied to the estimate):
    RMS, mean and largest position error (m)."""

    rmse: float
    mean: float
    max: float
    alignment: tuple[float, float, float]


def _checked(estimate, reference) -> tuple[np.ndarray, np.ndarray]:
    estimate = np.asarray(estimate, dtype=float)
    reference = np.asarray(reference, dtype=float)
    if estimate.ndim != 2 or estimate.shape[1] != 3 or estimate.shape != reference.shape:
        raise MappingError(
            f"trajectory error: need two (N, 3) pose arrays of one shape, got {estimate.shape} and {reference.shape}"
        )
    if not (np.all(np.isfinite(estimate)) and np.all(np.isfinite(reference))):
        raise MappingError("trajectory error: poses must be finite")
    return estimate, reference


def relative_motions(poses: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """(K, 3) relative_pose(poses[i], poses[j]) for index arrays i, j."""
    a, b = poses[i], poses[j]
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, wrap_angle(b[:, 2] - a[:, 2])])


def relative_pairs(reference: np.ndarray, min_distance: float, max_distance: float) -> tuple[np.ndarray, np.ndarray]:
    """Index arrays (i, j), i < j, of the pairs whose path length along the reference lies in
    [min_distance, max_distance]."""
    steps = np.hypot(*np.diff(reference[:, :2], axis=0).T)
    travelled = np.concatenate([[0.0], np.cumsum(steps)])
    first = np.searchsorted(travelled, travelled + min_distance, side="left")
    last = np.searchsorted(travelled, travelled + max_distance, side="right")
    counts = np.maximum(last - first, 0)
    i = np.repeat(np.arange(len(reference)), counts)
    offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    j = np.repeat(first, counts) + offsets
    keep = j > i
    return i[keep], j[keep]


def relative_error(estimate, reference, min_distance: float = 1.0, max_distance: float = 10.0) -> RelativeError:
    """Kümmerle's relative displacement error over the pairs 1..10 m of reference path apart (see the module
    docstring). No such pair: MappingError."""
    estimate, reference = _checked(estimate, reference)
    if not 0.0 <= min_distance <= max_distance:
        raise MappingError(
            f"relative error: need 0 <= min_distance <= max_distance, got {min_distance}, {max_distance}"
        )
    i, j = relative_pairs(reference, min_distance, max_distance)
    if len(i) == 0:
        raise MappingError(
            f"relative error: no pose pair {min_distance}..{max_distance} m of path apart among {len(reference)} poses"
        )
    d_est = relative_motions(estimate, i, j)
    d_ref = relative_motions(reference, i, j)
    c, s = np.cos(d_ref[:, 2]), np.sin(d_ref[:, 2])
    dx, dy = d_est[:, 0] - d_ref[:, 0], d_est[:, 1] - d_ref[:, 1]
    translation = np.hypot(c * dx + s * dy, -s * dx + c * dy)
    rotation = np.degrees(np.abs(wrap_angle(d_est[:, 2] - d_ref[:, 2])))
    return RelativeError(
        float(translation.mean()), float(rotation.mean()), float(translation.max()), float(rotation.max()), int(len(i))
    )


def rigid_alignment(source: np.ndarray, target: np.ndarray) -> tuple[float, float, float]:
    """(x, y, theta) of the rigid motion T minimizing sum |T(source_k) - target_k|^2 over (N, 2) points."""
    source = np.asarray(source, dtype=float)[:, :2]
    target = np.asarray(target, dtype=float)[:, :2]
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    cross = (target - mu_t).T @ (source - mu_s)
    u, _, vt = np.linalg.svd(cross)
    sign = np.sign(np.linalg.det(u @ vt)) or 1.0
    rotation = u @ np.diag([1.0, sign]) @ vt
    theta = math.atan2(rotation[1, 0], rotation[0, 0])
    t = mu_t - rotation @ mu_s
    return float(t[0]), float(t[1]), float(theta)


def absolute_error(estimate, reference) -> AbsoluteError:
    """Absolute trajectory error of the positions after the best rigid alignment of the estimate."""
    estimate, reference = _checked(estimate, reference)
    if len(estimate) == 0:
        raise MappingError("absolute error: no poses")
    x, y, theta = rigid_alignment(estimate, reference)
    c, s = math.cos(theta), math.sin(theta)
    ex, ey = estimate[:, 0], estimate[:, 1]
    aligned = np.column_stack([c * ex - s * ey + x, s * ex + c * ey + y])
    distance = np.hypot(*(aligned - reference[:, :2]).T)
    return AbsoluteError(
        float(np.sqrt(np.mean(distance**2))), float(distance.mean()), float(distance.max()), (x, y, theta)
    )
