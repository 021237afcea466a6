"""Planar poses and constant-twist (arc) motion, shared by physics and odometry.

A differential drive holding (v, w) for dt travels an arc of length ds = v dt
turning dtheta = w dt. Its end point lies along the chord at the mid heading:

    x' = x + c cos(theta + dtheta / 2),   y' = y + c sin(theta + dtheta / 2)
    c  = ds * sin(dtheta / 2) / (dtheta / 2)          (chord length)

Integrating this way is exact for constant twists, so the ground truth and the
encoder odometry agree to rounding when the wheels neither slip nor are blocked.
"""

from __future__ import annotations

import math
from typing import NamedTuple


class Pose2D(NamedTuple):
    """x, y in metres and theta in radians, theta wrapped to [-pi, pi)."""

    x: float
    y: float
    theta: float


def wrap_angle(angle: float) -> float:
    """The angle in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def chord_factor(dtheta: float) -> float:
    """sin(dtheta / 2) / (dtheta / 2): chord length over arc length, 1 for a straight line."""
    half = 0.5 * dtheta
    return 1.0 - half * half / 6.0 if abs(half) < 1e-6 else math.sin(half) / half


def integrate_arc(pose: Pose2D, ds: float, dtheta: float) -> Pose2D:
    """The pose after an arc of length ds turning dtheta."""
    chord = ds * chord_factor(dtheta)
    mid = pose.theta + 0.5 * dtheta
    return Pose2D(
        pose.x + chord * math.cos(mid),
        pose.y + chord * math.sin(mid),
        wrap_angle(pose.theta + dtheta),
    )


def arc_twist(start: Pose2D, end: Pose2D, dt: float) -> tuple[float, float, float]:
    """Body-frame (vx, vy, w) of the constant twist that moves start to end in dt.

    The inverse of integrate_arc: the displacement is expressed in the frame of
    the mid heading and stretched from chord to arc; vy is the sideways slide a
    wall forces on the body, 0 in free motion.
    """
    dtheta = wrap_angle(end.theta - start.theta)
    mid = start.theta + 0.5 * dtheta
    dx, dy = end.x - start.x, end.y - start.y
    along = dx * math.cos(mid) + dy * math.sin(mid)
    across = -dx * math.sin(mid) + dy * math.cos(mid)
    stretch = 1.0 / chord_factor(dtheta)
    return along * stretch / dt, across * stretch / dt, dtheta / dt


def compose(a: Pose2D, b: Pose2D) -> Pose2D:
    """a (+) b: pose b, given in the frame of pose a, expressed in a's parent frame.

        x = a.x + cos(a.theta) b.x - sin(a.theta) b.y,   y = a.y + sin(a.theta) b.x + cos(a.theta) b.y
        theta = a.theta + b.theta
    """
    c, s = math.cos(a.theta), math.sin(a.theta)
    return Pose2D(a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrap_angle(a.theta + b.theta))


def inverse(a: Pose2D) -> Pose2D:
    """The pose whose composition with `a` is the identity: the parent frame seen from a."""
    c, s = math.cos(a.theta), math.sin(a.theta)
    return Pose2D(-c * a.x - s * a.y, s * a.x - c * a.y, wrap_angle(-a.theta))


def map_to_odom(true_pose: Pose2D, odom_pose: Pose2D) -> Pose2D:
    """The odom frame in the map frame, from where the robot is (map) and where odometry puts it (odom).

    map->base = map->odom (+) odom->base, so map->odom = map->base (+) inverse(odom->base).
    """
    return compose(true_pose, inverse(odom_pose))
