"""Planar pose arithmetic on (x, y, theta) arrays: angle wrapping, composition, relative pose."""

from __future__ import annotations

import math

import numpy as np


def wrap(angle):
    """Angles in [-pi, pi)."""
    return np.mod(np.asarray(angle) + math.pi, 2.0 * math.pi) - math.pi


def compose(poses: np.ndarray, relative: np.ndarray) -> np.ndarray:
    """poses (N, 3) composed with one relative pose (3,): p (+) r."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    return np.column_stack([
        poses[:, 0] + c * relative[0] - s * relative[1],
        poses[:, 1] + s * relative[0] + c * relative[1],
        wrap(poses[:, 2] + relative[2]),
    ])


def relative_pose(origin: tuple[float, float, float], target: tuple[float, float, float]) -> np.ndarray:
    """target expressed in origin's frame: origin^-1 (+) target."""
    c, s = math.cos(origin[2]), math.sin(origin[2])
    dx, dy = target[0] - origin[0], target[1] - origin[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, float(wrap(target[2] - origin[2]))])


def map_to_odom(estimate: tuple[float, float, float], odometry: tuple[float, float, float]) -> np.ndarray:
    """The map -> odom transform that places the robot at `estimate` when odometry says `odometry`:
    map_T_odom = map_T_base (+) (odom_T_base)^-1 (REP 105: the localizer publishes map -> odom)."""
    inverse = relative_pose(odometry, (0.0, 0.0, 0.0))
    return compose(np.array([estimate], dtype=float), inverse)[0]
