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
from amr_util.geometry import wrap_angle

STILL = 1e-4
"""m: below this translation d_rot1 is undefined and taken as 0 (the whole turn goes into d_rot2)."""


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


def odometry_increment(previous: tuple[float, float, float], current: tuple[float, float, float]):
    """(d_rot1, d_trans, d_rot2) between two odometry poses."""
    dx, dy = current[0] - previous[0], current[1] - previous[1]
    d_trans = math.hypot(dx, dy)
    d_rot1 = float(wrap_angle(math.atan2(dy, dx) - previous[2])) if d_trans >= STILL else 0.0
    d_rot2 = float(wrap_angle(current[2] - previous[2] - d_rot1))
    return d_rot1, d_trans, d_rot2


def sample_motion_model_odometry(
    particles: np.ndarray,
    previous: tuple[float, float, float],
    current: tuple[float, float, float],
    noise: OdometryNoise,
    rng: np.random.Generator,
) -> np.ndarray:
    """New (N, 3) poses: each particle moved by its own noisy sample of the odometry increment."""
    d_rot1, d_trans, d_rot2 = odometry_increment(previous, current)
    # noise of a backwards move: measured on the rotation that does not turn around
    rot1_noise = min(abs(d_rot1), abs(float(wrap_angle(d_rot1 - math.pi))))
    rot2_noise = min(abs(d_rot2), abs(float(wrap_angle(d_rot2 - math.pi))))
    count = len(particles)
    draws = rng.standard_normal((count, 3))
    rot1 = d_rot1 - draws[:, 0] * math.sqrt(noise.alpha1 * rot1_noise**2 + noise.alpha2 * d_trans**2)
    trans = d_trans - draws[:, 1] * math.sqrt(
        noise.alpha3 * d_trans**2 + noise.alpha4 * (rot1_noise**2 + rot2_noise**2)
    )
    rot2 = d_rot2 - draws[:, 2] * math.sqrt(noise.alpha1 * rot2_noise**2 + noise.alpha2 * d_trans**2)
    moved = np.empty_like(particles)
    heading = particles[:, 2] + rot1
    moved[:, 0] = particles[:, 0] + trans * np.cos(heading)
    moved[:, 1] = particles[:, 1] + trans * np.sin(heading)
    moved[:, 2] = wrap_angle(heading + rot2)
    return moved


def motion_variance(increment, noise: OdometryNoise, heading_variance: float = 0.0) -> tuple[float, float]:
    """(m^2, rad^2) the position's and the heading's variance that sample_motion_model_odometry's noise adds over
    one odometry `increment` (x, y, theta in the frame it began in), first order in the alphas: the heading's from
    both rotations' noise, the position's along the travel (the translation's noise) and across it (the first
    rotation's noise, and the heading's variance already held, `heading_variance`, carried over the distance):

        var(rot1) = alpha1 rot1^2 + alpha2 trans^2,   var(rot2) = alpha1 rot2^2 + alpha2 trans^2
        heading   = var(rot1) + var(rot2)
        position  = alpha3 trans^2 + alpha4 (rot1^2 + rot2^2) + (var(rot1) + heading_variance) trans^2

    with rot1, rot2 the turns off the line of travel, as the sampler takes them. A turn in place whose reference
    slid a few centimetres sideways is a quarter turn off the line each way for the sampler, and so here: its heading
    noise is several times the net turn's (the variance must be the one the particles spread by)."""
    d_rot1, d_trans, d_rot2 = odometry_increment((0.0, 0.0, 0.0), tuple(float(v) for v in increment))
    rot1 = min(abs(d_rot1), abs(float(wrap_angle(d_rot1 - math.pi))))
    rot2 = min(abs(d_rot2), abs(float(wrap_angle(d_rot2 - math.pi))))
    rot1_variance = noise.alpha1 * rot1**2 + noise.alpha2 * d_trans**2
    rot2_variance = noise.alpha1 * rot2**2 + noise.alpha2 * d_trans**2
    along = noise.alpha3 * d_trans**2 + noise.alpha4 * (rot1**2 + rot2**2)
    return along + (rot1_variance + heading_variance) * d_trans**2, rot1_variance + rot2_variance
