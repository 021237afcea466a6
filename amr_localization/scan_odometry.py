"""Scan-matched odometry: where a scan was taken relative to the one before it (the window's geometry).

The filter scores a new place on a window of recent scans (a few metres of travel: particle_filter.WINDOW), and its
place search matches their end points at once; the window's scans must be placed relative to each other. Wheel
odometry drifts over those metres (5 % noise on keyframes a metre apart is 4 deg a scan), and a window placed by it
fits a look-alike place better than the true one. Each scan's increment from the one before it is therefore the mean
of its posterior over a lattice of poses within 3 sigma of the odometry's increment (the motion model's own noise,
motion_model.motion_covariance):

    p(x | scans, odometry)  ~  s(x)^N  exp(-1/2 (x - x_odom)^T Sigma_odom^-1 (x - x_odom))

s(x) the mean likelihood-field lookup of the scan's end points at x against the previous scan's (Olson's rasterized
scan: amr_maps.scan_matcher), N the independent ones among them (beam_correlation.independent_count with the beam
correlation length, as in the filter's measurement model: counting every point made a corridor's faint texture outweigh
the odometry along it, 20-40 cm a scan on aces), Sigma_odom the motion model's covariance of the increment:
anisotropic, wide across a long step's travel and in heading together (its first rotation's noise), narrow along it
(an isotropic one as wide as the along error missed orebro's 3 m keyframe 0.6 m across and 21 deg off, and one as
wide as the across error let the match slide along a corridor). Where the walls tell the pose (a room) the match
decides; where they do not (along a corridor) the odometry does.

Where the previous scan did not look (beyond its reach, outside its field of view) it saw no wall, and no wall there
is no evidence: the posterior is taken over the end points that stay within its view wherever the window moves them
(scored beyond it, a turn in place seen by a 180-degree scanner matched 45 cm and 13 deg off on fhw). A wide window
(a keyframe metres away) can leave too few of them to place the scan: the posterior over all the end points is taken
too, and of the two increments the one whose posterior is higher on the end points both keep within that scan's view
is chosen (the same data for both: a likelihood ratio). A motion whose 3 sigma moves no point by a cell is the
odometry's alone (a dense stream's scans, centimetres apart).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from amr_localization.beam_correlation import independent_count
from amr_maps.scan_matcher import CorrelativeMatcher, ScoreMap, default_angular_step
from amr_util.geometry import one_per_cell, transform_points, wrap_angle

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
    covariance: np.ndarray,
    resolution: float,
    correlation_length: float,
) -> np.ndarray:
    """(x, y, theta) of the scan `points` in the frame of the scan `reference` ((K, 2) end points, each in its own
    robot frame): the odometry's increment `prior` with its (3, 3) covariance (that frame's:
    motion_model.motion_covariance), fused with the scan match within SIGMAS of it, on cells of `resolution`; end
    points correlated over `correlation_length` (m)."""
    prior = np.asarray(prior, dtype=float).reshape(3)
    reference, points = np.asarray(reference, dtype=float), np.asarray(points, dtype=float)
    if len(reference) < MIN_POINTS or len(points) < MIN_POINTS:
        return prior
    covariance = np.asarray(covariance, dtype=float).reshape(3, 3)
    sigmas = np.sqrt(np.maximum(np.diag(covariance), 0.0))
    position_sigma, heading_sigma = float(max(sigmas[0], sigmas[1])), float(sigmas[2])
    farthest = float(np.hypot(points[:, 0], points[:, 1]).max())
    if SIGMAS * (position_sigma + heading_sigma * farthest) < resolution:
        return prior
    linear = max(min(SIGMAS * position_sigma, MAX_LINEAR), resolution)
    angular = min(SIGMAS * heading_sigma, MAX_ANGULAR)
    in_view = _within_view(reference, transform_points(prior, points), linear + resolution, angular)
    sets = [points[in_view]] if in_view.all() else [points[in_view], points]
    odometry = _Odometry(prior, covariance)
    # the reference scan's field on the two lattices (twice the cell, the cell), shared by both point sets
    coarse, fine = (
        CorrelativeMatcher(ScoreMap.from_points(reference, cell, cell, 4.0 * cell), levels=1)
        for cell in (2 * resolution, resolution)
    )
    found = []
    for chosen in sets:
        if len(chosen) < MIN_POINTS:
            continue
        independent = independent_count(chosen, max(correlation_length, resolution))
        # the window at twice the cell, then the cell around the coarse posterior's mean
        centre = _posterior_mean(coarse, chosen, independent, prior, odometry, linear, angular)
        found.append(_posterior_mean(fine, chosen, independent, centre, odometry, 4 * resolution, angular, 2))
    if len(found) < 2:
        return found[0] if found else prior
    return found[int(np.argmax(_log_posteriors(reference, fine, points, found, odometry, correlation_length)))]


class _Odometry(NamedTuple):
    """The odometry's increment and its covariance: the match's Gaussian prior."""

    increment: np.ndarray
    covariance: np.ndarray

    @property
    def information(self) -> np.ndarray:
        """(3, 3) Sigma^-1, its eigenvalues at most 1e12 (a motion without noise in some direction)."""
        values, vectors = np.linalg.eigh(0.5 * (self.covariance + self.covariance.T))
        return (vectors / np.maximum(values, 1e-12)) @ vectors.T

    def log_density(self, poses: np.ndarray) -> np.ndarray:
        """(M,) the prior's log-density (up to a constant) at each (M, 3) pose."""
        offsets = np.atleast_2d(poses) - self.increment
        offsets[:, 2] = wrap_angle(offsets[:, 2])
        return -0.5 * np.einsum("mi,ij,mj->m", offsets, self.information, offsets)


def _log_posteriors(
    reference: np.ndarray,
    field: CorrelativeMatcher,
    points: np.ndarray,
    increments: list[np.ndarray],
    odometry: _Odometry,
    correlation_length: float,
) -> np.ndarray:
    """The log-posterior of each increment on the same data: the end points every increment puts within the reference
    scan's view (its reach and field of view), scored on its `field` (bilinear), to the power of the independent ones,
    times the odometry's prior."""
    common = np.ones(len(points), dtype=bool)
    for increment in increments:
        common &= _within_view(reference, transform_points(increment, points), 0.0, 0.0)
    if np.count_nonzero(common) < MIN_POINTS:
        common[:] = True
    shared = points[common]
    independent = independent_count(shared, max(correlation_length, field.resolution))
    fits = np.array([max(field.score_interpolated(shared, increment), 1e-6) for increment in increments])
    return independent * np.log(fits) + odometry.log_density(np.array(increments))


def _posterior_mean(
    matcher: CorrelativeMatcher,
    points: np.ndarray,
    independent: float,
    centre: np.ndarray,
    odometry: _Odometry,
    linear: float,
    angular: float,
    angle_steps: int | None = None,
) -> np.ndarray:
    """The posterior's mean over the `matcher`'s lattice within linear and angular (or angle_steps of the lattice's
    angular step) of centre: the score to the power of the `independent` points times the odometry's prior."""
    cloud = one_per_cell(points, matcher.resolution)
    step = default_angular_step(cloud, matcher.resolution)
    if angle_steps is not None:
        angular = angle_steps * step
    lattice = matcher.window_lattice(cloud, centre, linear, angular, step)
    mean = odometry.increment + _weighted_offset(
        lattice.prior,
        lattice.offsets,
        lattice.turns,
        lattice.totals,
        lattice.denominator,
        float(independent),
        odometry.increment,
        odometry.information,
    )
    mean[2] = wrap_angle(mean[2])
    return mean


@numba.njit(cache=True, nogil=True)
def _weighted_offset(prior, offsets, turns, totals, denominator, independent, increment, information):
    """The posterior's mean offset from the odometry's `increment` over the lattice (amr_maps' WindowLattice: pose
    [a, y, x] at prior + (offsets[x], offsets[y], turns[a]), score totals[a, y, x] / denominator), with weights

        w_m ~ max(score_m, 1e-6)^independent exp(-1/2 (x_m - increment)^T Sigma^-1 (x_m - increment))

    (Sigma^-1: _Odometry.information; the exponent is _Odometry.log_density, pose by pose),

    headings' offsets wrapped: two passes (the largest log-weight, then the weighted sums) over the lattice's poses
    in window_scores' order, none of them spelled out (numpy made a dozen (M,) temporaries for tens of thousands)."""
    angles, size = totals.shape[0], totals.shape[1]
    log_weights = np.empty(totals.size)
    top = -np.inf
    m = 0
    for a in range(angles):
        da = (prior[2] + turns[a] - increment[2] + math.pi) % (2.0 * math.pi) - math.pi
        for y in range(size):
            dy = prior[1] + offsets[y] - increment[1]
            for x in range(size):
                dx = prior[0] + offsets[x] - increment[0]
                value = independent * math.log(max(totals[a, y, x] / denominator, 1e-6)) - 0.5 * (
                    information[0, 0] * dx * dx
                    + information[1, 1] * dy * dy
                    + information[2, 2] * da * da
                    + 2.0 * (information[0, 1] * dx * dy + information[0, 2] * dx * da + information[1, 2] * dy * da)
                )
                log_weights[m] = value
                top = max(top, value)
                m += 1
    total = 0.0
    mean = np.zeros(3)
    m = 0
    for a in range(angles):
        da = (prior[2] + turns[a] - increment[2] + math.pi) % (2.0 * math.pi) - math.pi
        for y in range(size):
            dy = prior[1] + offsets[y] - increment[1]
            for x in range(size):
                dx = prior[0] + offsets[x] - increment[0]
                weight = math.exp(log_weights[m] - top)
                total += weight
                mean[0] += weight * dx
                mean[1] += weight * dy
                mean[2] += weight * da
                m += 1
    return mean / total


def _within_view(reference: np.ndarray, moved: np.ndarray, linear: float, angular: float) -> np.ndarray:
    """(K,) whether each point (in the reference scan's frame) stays within what that scan saw, its reach and its
    field of view (unless it saw all around), wherever the window (linear m, angular rad) moves it."""
    reach = float(np.hypot(reference[:, 0], reference[:, 1]).max())
    ranges = np.hypot(moved[:, 0], moved[:, 1])
    keep = ranges <= reach - linear
    bearings = np.arctan2(reference[:, 1], reference[:, 0])
    low, high = float(bearings.min()), float(bearings.max())
    if high - low < 2.0 * math.pi - 2.0 * angular:
        margin = angular + np.arcsin(np.clip(linear / np.maximum(ranges, linear), 0.0, 1.0))
        bearing = np.arctan2(moved[:, 1], moved[:, 0])
        keep &= (bearing >= low + margin) & (bearing <= high - margin)
    return keep
