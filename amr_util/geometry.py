"""Planar geometry every package shares: angles, 2D poses, yaw quaternions, finite checks. No ROS, no rclpy.

Poses are (x, y, theta) in metres and radians, theta wrapped to [-pi, pi). One pose is a Pose2D (a
NamedTuple, so any (x, y, theta) sequence works too); many poses are an (N, 3) numpy array, and
`compose` and `wrap_angle` take either.

Constant-twist (arc) motion, shared by the simulator's physics and its odometry: a differential drive
holding (v, w) for dt travels an arc of length ds = v dt turning dtheta = w dt. Its end point lies
along the chord at the mid heading:

    x' = x + c cos(theta + dtheta / 2),   y' = y + c sin(theta + dtheta / 2)
    c  = ds * sin(dtheta / 2) / (dtheta / 2)          (chord length)

Integrating this way is exact for constant twists, so the ground truth and the encoder odometry agree
to rounding when the wheels neither slip nor are blocked.

Yaw quaternions: a rotation theta about z is (x, y, z, w) = (0, 0, sin(theta / 2), cos(theta / 2)).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable
from typing import Any, NamedTuple

import numpy as np

TWO_PI = 2.0 * math.pi


class Pose2D(NamedTuple):
    """x, y in metres and theta in radians, theta wrapped to [-pi, pi)."""

    x: float
    y: float
    theta: float


# -- numbers -----------------------------------------------------------------------------------------


def is_finite_number(value: Any) -> bool:
    """A real number (not a bool) that is neither NaN nor infinite: what a parameter, a YAML value or a
    speed must be before arithmetic turns it into a NaN on the wire."""
    if type(value) is float:  # the common case first: the abstract-class checks cost microseconds
        return math.isfinite(value)
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def all_finite(values: Iterable[float]) -> bool:
    """True when every value is finite (numbers only: math.isfinite raises on anything else)."""
    return all(map(math.isfinite, values))


# -- angles ------------------------------------------------------------------------------------------


def wrap_angle(angle):
    """The angle in [-pi, pi): a float for a Python number, an array for an array, a sequence or a numpy scalar."""
    if isinstance(angle, (int, float)) and not isinstance(angle, np.generic):
        return (angle + math.pi) % TWO_PI - math.pi
    return np.mod(np.asarray(angle) + math.pi, TWO_PI) - math.pi


def yaw_from_quaternion(q) -> float:
    """The yaw (rotation about z, static z-y-x Euler angles) of a quaternion with fields x, y, z, w
    (a geometry_msgs/Quaternion or anything like it); it need not be normalised.

        yaw = atan2(2 (w z + x y), w^2 + x^2 - y^2 - z^2)

    which is atan2(R[1, 0], R[0, 0]) of its rotation matrix (transforms3d's quat2euler, 'sxyz').
    """
    w, x, y, z = float(q.w), float(q.x), float(q.y), float(q.z)
    return math.atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)


def quaternion_from_yaw(theta: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of the rotation theta about z."""
    half = 0.5 * float(theta)
    return 0.0, 0.0, math.sin(half), math.cos(half)


# -- poses -------------------------------------------------------------------------------------------


def compose(a, b):
    """a (+) b: pose b, given in the frame of pose a, expressed in a's parent frame.

        x = a.x + cos(a.theta) b.x - sin(a.theta) b.y,   y = a.y + sin(a.theta) b.x + cos(a.theta) b.y
        theta = a.theta + b.theta

    `a` is one pose (the result is a Pose2D) or an (N, 3) array of poses each composed with the one
    pose `b` (the result is an (N, 3) array).
    """
    if isinstance(a, np.ndarray) and a.ndim == 2:
        c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
        return np.column_stack(
            [
                a[:, 0] + c * b[0] - s * b[1],
                a[:, 1] + s * b[0] + c * b[1],
                wrap_angle(a[:, 2] + b[2]),
            ]
        )
    ax, ay, atheta = a
    bx, by, btheta = b
    c, s = math.cos(atheta), math.sin(atheta)
    return Pose2D(ax + c * bx - s * by, ay + s * bx + c * by, wrap_angle(atheta + btheta))


def inverse(a) -> Pose2D:
    """The pose whose composition with `a` is the identity: the parent frame seen from a."""
    x, y, theta = a
    c, s = math.cos(theta), math.sin(theta)
    return Pose2D(-c * x - s * y, s * x - c * y, wrap_angle(-theta))


def relative_pose(origin, target) -> Pose2D:
    """target expressed in origin's frame: inverse(origin) (+) target (the motion from origin to target)."""
    c, s = math.cos(origin[2]), math.sin(origin[2])
    dx, dy = target[0] - origin[0], target[1] - origin[1]
    return Pose2D(float(c * dx + s * dy), float(-s * dx + c * dy), float(wrap_angle(target[2] - origin[2])))


def transform_points(pose, points: np.ndarray) -> np.ndarray:
    """(N, 2) points given in the frame `pose` (x, y, theta) places, in its parent frame."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return np.column_stack(
        [pose[0] + c * points[:, 0] - s * points[:, 1], pose[1] + s * points[:, 0] + c * points[:, 1]]
    )


def one_per_cell(points: np.ndarray, resolution: float) -> np.ndarray:
    """(M, 2) the first of the points in each square cell of `resolution` m, in their order (a voxel filter that
    keeps measured points rather than cell centres or means)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if not len(points):
        return points
    cells = np.floor(points / resolution).astype(np.int64)
    cells -= cells.min(axis=0)
    # one key per cell (row-major over the points' box): a 1-D unique, several times faster than rows'
    _, first = np.unique(cells[:, 0] * (int(cells[:, 1].max()) + 1) + cells[:, 1], return_index=True)
    return points[np.sort(first)]


def map_to_odom(true_pose, odom_pose) -> Pose2D:
    """The odom frame in the map frame, from where the robot is (map) and where odometry puts it (odom):
    the map -> odom transform a localizer publishes (REP 105).

    map->base = map->odom (+) odom->base, so map->odom = map->base (+) inverse(odom->base).
    """
    return compose(Pose2D(*true_pose), inverse(odom_pose))


# -- constant-twist motion ---------------------------------------------------------------------------


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


# -- the odometry motion model's decomposition ---------------------------------------------------------

STILL = 1e-4
"""m: below this translation the first rotation is undefined and taken as 0 (the whole turn is the second)."""


def odometry_turns(previous, current, still: float = STILL) -> tuple[float, float, float]:
    """(rot1, trans, rot2) between two poses (Probabilistic Robotics, table 5.6): a first rotation to the line of
    travel, the translation along it, a second rotation to the end heading; rot1 = 0 below `still` m."""
    dx, dy = current[0] - previous[0], current[1] - previous[1]
    trans = math.hypot(dx, dy)
    rot1 = float(wrap_angle(math.atan2(dy, dx) - previous[2])) if trans >= still else 0.0
    return rot1, trans, float(wrap_angle(current[2] - previous[2] - rot1))


def off_line(angle):
    """|angle| as a turn off the line of travel, forwards or backwards (the smaller of the two equivalent rotations,
    as AMCL's motion model takes it): reversing is not a half turn. A float for a Python number, an array for an
    array (the odometry synthesizer's many steps at once)."""
    magnitude = abs(wrap_angle(angle))
    return np.minimum(magnitude, math.pi - magnitude)


def odometry_covariance(rot1: float, trans: float, variances) -> np.ndarray:
    """(3, 3) the covariance (the frame the motion starts in) of the pose a first rotation `rot1`, a translation
    `trans` and a second rotation reach when the three err independently with `variances` (var(rot1), var(trans),
    var(rot2)), to first order (the end pose's Jacobian in the three):

        (x, y, theta) = (trans cos rot1, trans sin rot1, rot1 + rot2)
        Sigma = J diag(var(rot1), var(trans), var(rot2)) J^T,   J = [[-trans sin rot1, cos rot1, 0],
                                                                     [ trans cos rot1, sin rot1, 0],
                                                                     [ 1,              0,        1]]

    along the line of travel the translation's error; across it the first rotation's over the distance, correlated
    with the heading's. The odometry motion model's propagation, one place for the particle filter's prior
    (amr_localization.motion_model.motion_covariance: var(rot) = alpha1 rot^2 + alpha2 trans^2, ...) and the SLAM
    front end's (amr_mapping.slam: standard deviations that grow with the distance and the turns)."""
    var_rot1, var_trans, var_rot2 = (float(v) for v in variances)
    c, s = math.cos(rot1), math.sin(rot1)
    jacobian = np.array([[-trans * s, c, 0.0], [trans * c, s, 0.0], [1.0, 0.0, 1.0]])
    return jacobian @ np.diag([var_rot1, var_trans, var_rot2]) @ jacobian.T
