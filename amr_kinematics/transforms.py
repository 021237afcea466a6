"""Homogeneous transforms, rotations and the orientation error (numpy, SI units).

Quaternions are (x, y, z, w) as in geometry_msgs/Quaternion; roll-pitch-yaw
follow REP 103 / URDF: R = Rz(yaw) Ry(pitch) Rx(roll).
"""

from __future__ import annotations

import math

import numpy as np

from .errors import InvalidRequestError


def rot_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0, 0.0], [0.0, c, -s, 0.0], [0.0, s, c, 0.0], [0.0, 0.0, 0.0, 1.0]])


def rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0, 0.0], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def trans(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = (x, y, z)
    return t


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """3x3 rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_rpy(rotation: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) of a 3x3 rotation (inverse of ``rpy_matrix``)."""
    r = np.asarray(rotation, dtype=float)
    pitch = math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0]))
    if math.hypot(r[0, 0], r[1, 0]) < 1e-12:  # gimbal lock: put everything in roll
        return math.atan2(-r[1, 2], r[1, 1]), pitch, 0.0
    return math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])


def xyz_rpy_matrix(values) -> np.ndarray:
    """4x4 transform from [x, y, z, roll, pitch, yaw]."""
    x, y, z, roll, pitch, yaw = (float(v) for v in values)
    t = np.eye(4)
    t[:3, :3] = rpy_matrix(roll, pitch, yaw)
    t[:3, 3] = (x, y, z)
    return t


def quaternion_matrix(quaternion) -> np.ndarray:
    """3x3 rotation of a quaternion (x, y, z, w); it is normalised first."""
    x, y, z, w = (float(v) for v in quaternion)
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not norm > 1e-12 or not math.isfinite(norm):
        raise InvalidRequestError(f"quaternion {tuple(quaternion)!r} is zero or not finite")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_quaternion(rotation: np.ndarray) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w), w >= 0, of a 3x3 rotation (Shepperd's method, on floats)."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(rotation, dtype=float).tolist()
    trace = r00 + r11 + r22
    if trace > 0.0:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = ((r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s, 0.25 * s)
    elif r00 > r11 and r00 > r22:
        s = 2.0 * math.sqrt(1.0 + r00 - r11 - r22)
        q = (0.25 * s, (r01 + r10) / s, (r02 + r20) / s, (r21 - r12) / s)
    elif r11 > r22:
        s = 2.0 * math.sqrt(1.0 + r11 - r00 - r22)
        q = ((r01 + r10) / s, 0.25 * s, (r12 + r21) / s, (r02 - r20) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + r22 - r00 - r11)
        q = ((r02 + r20) / s, (r12 + r21) / s, 0.25 * s, (r10 - r01) / s)
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[3] < 0.0:
        norm = -norm
    return (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)


def pose_matrix(position, quaternion=(0.0, 0.0, 0.0, 1.0)) -> np.ndarray:
    """4x4 pose from a position (x, y, z) and a quaternion (x, y, z, w)."""
    t = np.eye(4)
    t[:3, :3] = quaternion_matrix(quaternion)
    t[:3, 3] = np.asarray(position, dtype=float)
    return t


def rotation_error(
    r00, r01, r02, r10, r11, r12, r20, r21, r22, d00, d01, d02, d10, d11, d12, d20, d21, d22
) -> tuple[float, float, float]:
    """World-frame rotation vector (axis * angle) taking R to Rd, scalar math.

    Re = Rd R^T;  angle = atan2(|v|, (trace(Re) - 1) / 2), v = vee(Re - Re^T) / 2.
    Written with plain floats because the solvers call it every iteration.
    """
    # Re = Rd * R^T (row i of Rd dotted with row j of R)
    e00 = d00 * r00 + d01 * r01 + d02 * r02
    e11 = d10 * r10 + d11 * r11 + d12 * r12
    e22 = d20 * r20 + d21 * r21 + d22 * r22
    e01 = d00 * r10 + d01 * r11 + d02 * r12
    e10 = d10 * r00 + d11 * r01 + d12 * r02
    e02 = d00 * r20 + d01 * r21 + d02 * r22
    e20 = d20 * r00 + d21 * r01 + d22 * r02
    e12 = d10 * r20 + d11 * r21 + d12 * r22
    e21 = d20 * r10 + d21 * r11 + d22 * r12
    vx, vy, vz = 0.5 * (e21 - e12), 0.5 * (e02 - e20), 0.5 * (e10 - e01)
    sin_angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    cos_angle = 0.5 * (e00 + e11 + e22 - 1.0)
    if sin_angle > 1e-7:
        k = math.atan2(sin_angle, cos_angle) / sin_angle
        return vx * k, vy * k, vz * k
    if cos_angle > 0.0:  # angle ~ 0: the rotation vector is v itself
        return vx, vy, vz
    # angle ~ pi: axis from the symmetric part, R ~ 2 a a^T - I
    ax = math.sqrt(max(0.0, (e00 + 1.0) / 2.0))
    ay = math.sqrt(max(0.0, (e11 + 1.0) / 2.0))
    az = math.sqrt(max(0.0, (e22 + 1.0) / 2.0))
    if ax >= ay and ax >= az:
        ay, az = math.copysign(ay, e01 + e10), math.copysign(az, e02 + e20)
    elif ay >= az:
        ax, az = math.copysign(ax, e01 + e10), math.copysign(az, e12 + e21)
    else:
        ax, ay = math.copysign(ax, e02 + e20), math.copysign(ay, e12 + e21)
    return ax * math.pi, ay * math.pi, az * math.pi
