"""Odometry motion model: sample_motion_model_odometry (Thrun, Burgard, Fox, Probabilistic Robotics, table 5.6).

The odometry increment between two odometry poses (x, y, theta) -> (x', y', theta')
is split into a first rotation, a translation and a second rotation:

    d_rot1  = atan2(y' - y, x' - x) - theta        (0 when the robot barely moved)
    d_trans = sqrt((x' - x)^2 + (y' - y)^2)
    d_rot2  = theta' - theta - d_rot1

Each particle gets its own noisy copy (AMCL's alpha1..alpha4, differential drive):

    d_rot1^  = d_rot1  - N(0, alpha1 d_rot1^2 + alpha2 d_trans^2)
    d_trans^ = d_trans - N(0, alpha3 d_trans^2 + alpha4 (d_rot1^2 + d_rot2^2))
    d_rot2^  = d_rot2  - N(0, alpha1 d_rot2^2 + alpha2 d_trans^2)

and moves by it from its own pose. A robot driving backwards would make d_rot1
near pi; as AMCL does, the smaller of the two equivalent rotations is used for
the noise so that reversing does not read as a half turn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_localization.errors import LocalizationError
from amr_util.geometry import odometry_covariance, odometry_turns, off_line, wrap_angle


@dataclass(frozen=True)
class OdometryNoise:
    """AMCL's alpha1..alpha4: rotation from rotation, rotation from translation, translation from
    translation, translation from rotation (variances per squared unit)."""

    alpha1: float = 0.2
    alpha2: float = 0.2
    alpha3: float = 0.2
    alpha4: float = 0.2

    def __post_init__(self) -> None:
        for name in ("alpha1", "alpha2", "alpha3", "alpha4"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0.0:
                raise LocalizationError(f"{name}: must be a finite number >= 0, got {value!r}")


def sample_motion_model_odometry(
    particles: np.ndarray,
    previous: tuple[float, float, float],
    current: tuple[float, float, float],
    noise: OdometryNoise,
    rng: np.random.Generator,
) -> np.ndarray:
    """New (N, 3) poses: each particle moved by its own noisy sample of the odometry increment."""
    d_rot1, d_trans, d_rot2 = odometry_turns(previous, current)
    variances = _noise_variances(d_rot1, d_trans, d_rot2, noise)
    count = len(particles)
    draws = rng.standard_normal((count, 3))
    rot1 = d_rot1 - draws[:, 0] * math.sqrt(variances[0])
    trans = d_trans - draws[:, 1] * math.sqrt(variances[1])
    rot2 = d_rot2 - draws[:, 2] * math.sqrt(variances[2])
    moved = np.empty_like(particles)
    heading = particles[:, 2] + rot1
    moved[:, 0] = particles[:, 0] + trans * np.cos(heading)
    moved[:, 1] = particles[:, 1] + trans * np.sin(heading)
    moved[:, 2] = wrap_angle(heading + rot2)
    return moved


def motion_variance(increment, noise: OdometryNoise, heading_variance: float = 0.0) -> tuple[float, float]:
    """(m^2, rad^2) the position's and the heading's variance that sample_motion_model_odometry's noise adds over
    one odometry `increment` (x, y, theta in the frame it began in), first order in the alphas: the heading's from
    both rotations' noise, the position's along the travel (the translation's noise) and across it by the heading's
    variance already held (`heading_variance`) carried over the distance:

        var(rot1) = alpha1 rot1^2 + alpha2 trans^2,   var(rot2) = alpha1 rot2^2 + alpha2 trans^2
        heading   = var(rot1) + var(rot2)
        position  = alpha3 trans^2 + alpha4 (rot1^2 + rot2^2) + heading_variance trans^2

    with rot1, rot2 the turns off the line of travel, as the sampler takes them: a turn in place whose odometry slid a
    few centimetres sideways is a quarter turn off the line each way for the sampler, and so here (its heading's
    noise several times the net turn's). The step's own first rotation also moves the position across the travel,
    by var(rot1) trans^2, which this one isotropic variance leaves to the heading: its users search the heading, which
    moves a scan across, and taken as isotropic it would widen their window along a corridor the travel runs down
    (orebro's 3 m keyframes: 0.8 m of sigma)."""
    _, d_trans, _ = turns = odometry_turns((0.0, 0.0, 0.0), tuple(float(v) for v in increment))
    rot1, along, rot2 = _noise_variances(*turns, noise)
    return along + heading_variance * d_trans**2, rot1 + rot2


def motion_covariance(increment, noise: OdometryNoise) -> np.ndarray:
    """(3, 3) the covariance of the pose sample_motion_model_odometry reaches over one odometry `increment` (x, y,
    theta in the frame it began in; the covariance in that frame), first order in the alphas: the noises of rot1,
    trans and rot2 (motion_variance's) through the end pose's Jacobian (amr_util.geometry.odometry_covariance, the
    propagation the SLAM front end's odometry model shares): across the travel the first rotation's noise over the
    distance, correlated with the heading's: what the particles spread by, anisotropic (a 3 m keyframe's odometry is
    off across its travel and in heading together, much less along it); no direction of the position tighter than
    var(trans) (a turn on the spot slips sideways too, though the first order moves nothing there)."""
    d_rot1, d_trans, d_rot2 = odometry_turns((0.0, 0.0, 0.0), tuple(float(v) for v in increment))
    variances = _noise_variances(d_rot1, d_trans, d_rot2, noise)
    covariance = odometry_covariance(d_rot1, d_trans, variances)
    # no direction of the position tighter than the travel's own noise: at first order a turn on the spot moves
    # nothing sideways, which a real base does by slipping (raising the position block keeps it positive definite)
    values, vectors = np.linalg.eigh(covariance[:2, :2])
    covariance[:2, :2] = (vectors * np.maximum(values, variances[1])) @ vectors.T
    return covariance


def _noise_variances(d_rot1: float, d_trans: float, d_rot2: float, noise: OdometryNoise) -> tuple[float, float, float]:
    """(var(rot1), var(trans), var(rot2)) of the sampler's noise (the module docstring's), each rotation's noise
    measured on its turn off the line of travel: a backwards move is not a half turn of noise."""
    rot1, rot2 = off_line(d_rot1), off_line(d_rot2)
    return (
        noise.alpha1 * rot1**2 + noise.alpha2 * d_trans**2,
        noise.alpha3 * d_trans**2 + noise.alpha4 * (rot1**2 + rot2**2),
        noise.alpha1 * rot2**2 + noise.alpha2 * d_trans**2,
    )
