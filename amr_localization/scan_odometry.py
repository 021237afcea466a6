"""Scan-matched odometry: where a scan was taken relative to the one before it (the window's geometry).

The filter scores a new place on a window of recent scans (a few metres of travel: particle_filter.WINDOW), and its
place search matches their end points at once; the window's scans must be placed relative to each other. Wheel
odometry drifts over those metres (5 % noise on keyframes a metre apart is 4 deg a scan), and a window placed by it
fits a look-alike place better than the true one. Each scan's increment from the one before it is therefore the mean
of its posterior over a lattice of poses within 3 sigma of the odometry's increment (the motion model's own noise,
motion_model.motion_variance):

    p(x | scans, odometry)  ~  s(x)^N  exp(-1/2 (x - x_odom)^T Sigma_odom^-1 (x - x_odom))

s(x) the mean likelihood-field lookup of the scan's end points at x against the previous scan's (Olson's rasterized
scan: amr_maps.scan_matcher), N the independent ones among them (end points within the beam correlation length
count as one, as in the filter's measurement model: counting every point made a corridor's faint texture outweigh
the odometry along it, 20-40 cm a scan on aces), Sigma_odom = diag(sigma_p^2, sigma_p^2, sigma_theta^2). Where the
walls tell the pose (a room) the match decides; where they do not (along a corridor) the odometry does. An end point
that x puts where the previous scan did not look (beyond its reach, outside its field of view) is no evidence either
way: it scores what the points where that scan looked score at the best match (their mean lookup there), so that no
increment gains by moving points out of its view (a turn in place seen by a 180-degree scanner) and none loses by
moving them into it (a keyframe metres away, most of whose points that scan never saw). A motion whose 3 sigma moves
no point by a cell is the odometry's alone (a dense stream's scans, centimetres apart).
"""

from __future__ import annotations

import math

import numpy as np

from amr_maps.scan_matcher import CorrelativeMatcher, ScoreMap, default_angular_step
from amr_util.geometry import one_per_cell, wrap_angle

SIGMAS = 3.0
"""the match's window, in standard deviations of the odometry's increment ..."""
MAX_LINEAR = 1.0
"""m ... at most this in x and y ..."""
MAX_ANGULAR = math.radians(30.0)
"""rad ... and this in heading."""
MIN_POINTS = 20
"""end points each scan needs for a match (fewer: the odometry's increment)."""


def matched_increment(
    reference: np.ndarray,
    points: np.ndarray,
    prior,
    position_variance: float,
    heading_variance: float,
    resolution: float,
    correlation_length: float,
) -> np.ndarray:
    """(x, y, theta) of the scan `points` in the frame of the scan `reference` ((K, 2) end points, each in its own
    robot frame): the odometry's increment `prior` with its variances (m^2, rad^2), fused with the scan match within
    SIGMAS of it, on cells of `resolution`; end points within `correlation_length` (m) count as one."""
    prior = np.asarray(prior, dtype=float).reshape(3)
    reference, points = np.asarray(reference, dtype=float), np.asarray(points, dtype=float)
    if len(reference) < MIN_POINTS or len(points) < MIN_POINTS:
        return prior
    position_sigma = math.sqrt(max(position_variance, 0.0))
    heading_sigma = math.sqrt(max(heading_variance, 0.0))
    farthest = float(np.hypot(points[:, 0], points[:, 1]).max())
    if SIGMAS * (position_sigma + heading_sigma * farthest) < resolution:
        return prior
    linear = max(min(SIGMAS * position_sigma, MAX_LINEAR), resolution)
    angular = min(SIGMAS * heading_sigma, MAX_ANGULAR)
    independent = len(one_per_cell(points, max(correlation_length, resolution)))
    # the window at twice the cell, then the cell around the coarse posterior's mean
    coarse = _posterior_mean(
        reference, points, independent, prior, prior, position_sigma, heading_sigma, linear, angular, 2 * resolution
    )
    increment = _posterior_mean(
        reference,
        points,
        independent,
        coarse,
        prior,
        position_sigma,
        heading_sigma,
        4 * resolution,
        angular,
        resolution,
        2,
    )
    increment[2] = wrap_angle(increment[2])
    return increment


def _posterior_mean(
    reference: np.ndarray,
    points: np.ndarray,
    independent: int,
    centre: np.ndarray,
    prior: np.ndarray,
    position_sigma: float,
    heading_sigma: float,
    linear: float,
    angular: float,
    resolution: float,
    angle_steps: int | None = None,
) -> np.ndarray:
    """The posterior's mean over the lattice of `resolution` within linear and angular (or angle_steps of the
    lattice's angular step) of centre; the odometry's increment `prior` the Gaussian prior, the score to the power
    of the `independent` points."""
    field = ScoreMap.from_points(reference, resolution, resolution, 4.0 * resolution)
    cloud = one_per_cell(points, resolution)
    step = default_angular_step(cloud, resolution)
    if angle_steps is not None:
        angular = angle_steps * step
    poses, scores = CorrelativeMatcher(field, levels=1).window_scores(cloud, centre, linear, angular, step)
    view = ScoreMap(_view(reference, field), resolution, field.origin)
    _, seen = CorrelativeMatcher(view, levels=1).window_scores(cloud, centre, linear, angular, step)
    best = int(np.argmax(scores))
    unseen = min(scores[best] / max(seen[best], 1e-9), 1.0)  # what a point where the scan looked scores at the best
    scores = scores + unseen * (1.0 - seen)
    offsets = poses - prior
    offsets[:, 2] = wrap_angle(offsets[:, 2])
    log_posterior = independent * np.log(np.maximum(scores, 1e-6)) - 0.5 * (
        (offsets[:, 0] ** 2 + offsets[:, 1] ** 2) / max(position_sigma**2, 1e-12)
        + offsets[:, 2] ** 2 / max(heading_sigma**2, 1e-12)
    )
    weights = np.exp(log_posterior - log_posterior.max())
    mean = prior + weights @ offsets / weights.sum()
    mean[2] = wrap_angle(mean[2])
    return mean


def _view(reference: np.ndarray, field: ScoreMap) -> np.ndarray:
    """On the cells of `field` (the reference scan's likelihood field), 1 where the `reference` scan looked: within
    its reach and its field of view (all around if its end points span the circle); 0 elsewhere, as beyond the
    field's cells."""
    rows, cols = field.table.shape
    x = field.origin[0] + (np.arange(cols) + 0.5) * field.resolution
    y = (field.origin[1] + (np.arange(rows) + 0.5) * field.resolution)[:, None]
    reach = float(np.hypot(reference[:, 0], reference[:, 1]).max())
    seen = x[None, :] ** 2 + y**2 <= reach**2
    bearings = np.arctan2(reference[:, 1], reference[:, 0])
    low, high = float(bearings.min()), float(bearings.max())
    if high - low < 2.0 * math.pi - 0.1:
        # between the two extreme bearings, counter-clockwise from low to high (half-planes through the sensor)
        after_low = math.cos(low) * y - math.sin(low) * x[None, :] >= 0.0
        before_high = math.cos(high) * y - math.sin(high) * x[None, :] <= 0.0
        seen &= (after_low & before_high) if high - low <= math.pi else (after_low | before_high)
    return seen.astype(np.float32)
