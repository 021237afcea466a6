"""Wheel odometry synthesized from a log's corrected poses: the odometry motion model with noise, scale and drift.

Corrected logs carry no raw odometry, so it is made from consecutive reference poses p_{k-1}, p_k, as
Probabilistic Robotics (Thrun, Burgard, Fox), table 5.6, samples it: each increment is

    rot1  = atan2(y_k - y_{k-1}, x_k - x_{k-1}) - theta_{k-1}
    trans = |(x_k, y_k) - (x_{k-1}, y_{k-1})|
    rot2  = theta_k - theta_{k-1} - rot1

and the odometry reports, with e ~ N(0, 1) drawn independently for each term,

    rot1'  = rot1  + (alpha1 |rot1| + alpha2 trans) e1 + heading_bias trans / 2
    trans' = (trans + (alpha3 trans + alpha4 (|rot1| + |rot2|)) e2) (1 + scale_error)
    rot2'  = rot2  + (alpha1 |rot2| + alpha2 trans) e3 + heading_bias trans / 2

(the book's first printing: the alphas scale standard deviations, so alpha = 0.05 is 5 % of the motion, a 1 m
step has a 5 cm sigma). `|rot1|` and `|rot2|` are taken as turns off the line of travel, forwards or backwards
(min(|a|, pi - |a|), as AMCL does), so reversing is not a half turn of noise; below MIN_TRANSLATION the
increment is a turn on the spot (rot1 = 0 in the noise terms). The odometry poses compose the reported increments
from (0, 0, 0): the odom frame starts at the first pose. heading_bias turns the odometry by that many radians per
metre driven (half before, half after each step: an arc), scale_error stretches every distance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from amr_util.geometry import off_line, wrap_angle

MIN_TRANSLATION = 1e-3
"""m: a shorter step is a turn on the spot for the noise terms."""


@dataclass(frozen=True)
class OdometryNoiseModel:
    """The synthesized odometry's errors. Defaults: 5 % noise, +1 % scale, 0.5 deg/m heading bias."""

    alpha1: float = 0.05
    """rotation noise per rotation (rad/rad, a standard deviation)."""
    alpha2: float = 0.05
    """rotation noise per translation (rad/m)."""
    alpha3: float = 0.05
    """translation noise per translation (m/m)."""
    alpha4: float = 0.05
    """translation noise per rotation (m/rad)."""
    scale_error: float = 0.01
    """Every reported distance is (1 + scale_error) times the true one (+1 %: the wheels seem larger)."""
    heading_bias: float = math.radians(0.5)
    """rad of heading drift per metre driven (0.5 deg/m), to the left when positive."""

    def __post_init__(self) -> None:
        for item in fields(self):
            value = getattr(self, item.name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"{item.name}: must be a finite number, got {value!r}")
        for name in ("alpha1", "alpha2", "alpha3", "alpha4"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"{name}: must be >= 0, got {getattr(self, name)!r}")
        if self.scale_error <= -1.0:
            raise ValueError(f"scale_error: must be > -1, got {self.scale_error!r}")

    @classmethod
    def perfect(cls) -> OdometryNoiseModel:
        """No noise, no scale error, no bias: the odometry increments are the reference's."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    @property
    def is_perfect(self) -> bool:
        return all(getattr(self, item.name) == 0.0 for item in fields(self))


def increments(poses: np.ndarray) -> np.ndarray:
    """(N - 1, 3) (rot1, trans, rot2) between consecutive poses (table 5.6's first three lines)."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    dx, dy = np.diff(poses[:, 0]), np.diff(poses[:, 1])
    trans = np.hypot(dx, dy)
    rot1 = np.where(trans > 0.0, wrap_angle(np.arctan2(dy, dx) - poses[:-1, 2]), 0.0)
    rot2 = wrap_angle(np.diff(poses[:, 2]) - rot1)
    return np.column_stack([rot1, trans, rot2])


def noisy_increments(steps: np.ndarray, noise: OdometryNoiseModel, rng: np.random.Generator) -> np.ndarray:
    """The (rot1, trans, rot2) the odometry reports for the true `steps` (module docstring's formulas)."""
    steps = np.asarray(steps, dtype=float).reshape(-1, 3)
    rot1, trans, rot2 = steps[:, 0], steps[:, 1], steps[:, 2]
    turning = trans < MIN_TRANSLATION
    turn1 = np.where(turning, 0.0, off_line(rot1))
    turn2 = np.where(turning, np.abs(wrap_angle(rot1 + rot2)), off_line(rot2))
    e = rng.standard_normal((steps.shape[0], 3))
    bias = 0.5 * noise.heading_bias * trans
    noisy_rot1 = rot1 + (noise.alpha1 * turn1 + noise.alpha2 * trans) * e[:, 0] + bias
    trans_sigma = noise.alpha3 * trans + noise.alpha4 * (turn1 + turn2)
    noisy_trans = (trans + trans_sigma * e[:, 1]) * (1.0 + noise.scale_error)
    noisy_rot2 = rot2 + (noise.alpha1 * turn2 + noise.alpha2 * trans) * e[:, 2] + bias
    return np.column_stack([noisy_rot1, noisy_trans, noisy_rot2])


def integrate(steps: np.ndarray, start=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(N + 1, 3) poses from `start` moved by each (rot1, trans, rot2) in turn."""
    steps = np.asarray(steps, dtype=float).reshape(-1, 3)
    x0, y0, theta0 = (float(v) for v in start)
    headings = theta0 + np.concatenate([[0.0], np.cumsum(steps[:, 0] + steps[:, 2])])
    travel = headings[:-1] + steps[:, 0]
    x = x0 + np.concatenate([[0.0], np.cumsum(steps[:, 1] * np.cos(travel))])
    y = y0 + np.concatenate([[0.0], np.cumsum(steps[:, 1] * np.sin(travel))])
    return np.column_stack([x, y, wrap_angle(headings)])


def synthesize_odometry(poses: np.ndarray, noise: OdometryNoiseModel | None = None, seed: int = 0) -> np.ndarray:
    """(N, 3) odometry poses in an odom frame starting at (0, 0, 0), one per reference pose (N, 3): the increments
    between consecutive poses as the noise model reports them, drawn from `seed` (the same seed, the same
    odometry). With OdometryNoiseModel.perfect() every increment is the reference's to rounding."""
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise ValueError(f"poses: expected an (N, 3) array, got shape {poses.shape}")
    if not np.isfinite(poses).all():
        raise ValueError("poses: not all finite")
    if poses.shape[0] == 0:
        return np.zeros((0, 3))
    noise = OdometryNoiseModel() if noise is None else noise
    steps = increments(poses)
    if not noise.is_perfect:
        steps = noisy_increments(steps, noise, np.random.default_rng(seed))
    return integrate(steps)
