"""Covariance ellipses, scans in the plane, the floor under a click and the top-down camera: no ROS, no viser.

Poses are amr_util.geometry's Pose2D (x, y, theta; REP 103) and composed with its compose/inverse; `wxyz` is
viser's quaternion order (ROS's is x, y, z, w).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from amr_util.geometry import Pose2D, all_finite, quaternion_from_yaw

IDENTITY = Pose2D(0.0, 0.0, 0.0)


def wxyz_of(theta: float) -> tuple[float, float, float, float]:
    """viser's (w, x, y, z) of a rotation by `theta` about z."""
    x, y, z, w = quaternion_from_yaw(theta)
    return w, x, y, z


def finite(*values: float) -> bool:
    return all_finite(values)


def scan_points(
    ranges: np.ndarray, angle_min: float, angle_increment: float, range_min: float, range_max: float
) -> np.ndarray:
    """(N, 2) end points of a LaserScan's valid returns in the scan frame (NaN, inf and out-of-range dropped)."""
    ranges = np.asarray(ranges, dtype=float)
    angles = angle_min + angle_increment * np.arange(len(ranges))
    valid = np.isfinite(ranges) & (ranges >= range_min) & (ranges <= range_max)
    r, a = ranges[valid], angles[valid]
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def covariance_ellipse(
    x: float, y: float, cov_xx: float, cov_xy: float, cov_yy: float, sigmas: float = 2.0, segments: int = 48
) -> np.ndarray | None:
    """(segments + 1, 2) points of the `sigmas`-sigma ellipse of a 2D Gaussian, closed; None when the covariance is
    not finite or not positive semi-definite (nothing sensible to draw)."""
    if not finite(x, y, cov_xx, cov_xy, cov_yy):
        return None
    values, vectors = np.linalg.eigh(np.array([[cov_xx, cov_xy], [cov_xy, cov_yy]]))
    if values[0] < -1e-12:
        return None
    axes = sigmas * np.sqrt(np.clip(values, 0.0, None))
    angles = np.linspace(0.0, 2.0 * math.pi, segments + 1)
    circle = np.column_stack([np.cos(angles) * axes[0], np.sin(angles) * axes[1]])
    return circle @ vectors.T + np.array([x, y])


def floor_point(ray_origin, ray_direction, height: float = 0.0) -> tuple[float, float] | None:
    """Where a ray meets the plane z = height, or None when it runs parallel to it or points away."""
    ox, oy, oz = (float(v) for v in ray_origin)
    dx, dy, dz = (float(v) for v in ray_direction)
    if not finite(ox, oy, oz, dx, dy, dz) or abs(dz) < 1e-9:
        return None
    t = (height - oz) / dz
    if t <= 0.0:
        return None
    return ox + t * dx, oy + t * dy


class Camera(NamedTuple):
    """A viser camera: position and look-at point in the world, vertical field of view (rad)."""

    position: tuple[float, float, float]
    look_at: tuple[float, float, float]
    fov: float


TOP_DOWN_FOV = math.radians(50.0)
TOP_DOWN_TILT = 1e-4
"""m the camera sits south of the point it looks at: straight down is degenerate for an orbit camera whose up is
+z; this keeps +y up on the screen (an angle of 1e-4 / height rad, far below a pixel)."""


PANEL_PIXELS = 350
"""px of the canvas's right edge under the control panel: viser 1.1's floating panel, 20 em of 16 px
(control_width "medium") 15 px from the edge, and 15 px of air on its left."""


def free_share(canvas_width: float, panel: float = PANEL_PIXELS) -> float:
    """The share of a canvas `canvas_width` px wide left of the control panel (at least a third; 1 when the width is
    not known yet)."""
    if not (canvas_width > 0.0 and math.isfinite(canvas_width)):
        return 1.0
    return min(1.0, max(1.0 / 3.0, 1.0 - panel / canvas_width))


def top_down_camera(
    bounds: tuple[float, float, float, float],
    aspect: float,
    margin: float = 0.1,
    fov: float = TOP_DOWN_FOV,
    free: float = 1.0,
) -> Camera:
    """A camera looking straight down at the box (xmin, ymin, xmax, ymax), high enough that the box plus `margin`
    (a fraction of each side) fills the left `free` share of a canvas of width / height = `aspect` (the rest is under
    the control panel, free_share), centred there; +x right, +y up on the screen."""
    xmin, ymin, xmax, ymax = bounds
    if not (
        finite(xmin, ymin, xmax, ymax, free) and xmax >= xmin and ymax >= ymin and aspect > 0.0 and 0.0 < free <= 1.0
    ):
        raise ValueError(f"top_down_camera: bad bounds {bounds}, aspect {aspect} or free share {free}")
    width = max(xmax - xmin, 0.1) * (1.0 + 2.0 * margin)
    height = max(ymax - ymin, 0.1) * (1.0 + 2.0 * margin)
    half_height = max(0.5 * height, 0.5 * width / (aspect * free))
    distance = half_height / math.tan(0.5 * fov)
    cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
    cx += (1.0 - free) * aspect * half_height  # the box's centre at the centre of the free share
    return Camera((cx, cy - TOP_DOWN_TILT, distance), (cx, cy, 0.0), fov)


def outgrown(framed: tuple[float, float, float, float], now: tuple[float, float, float, float], margin=0.05) -> bool:
    """Whether the box `now` (xmin, ymin, xmax, ymax) reaches beyond `framed` by more than `margin` of framed's
    longer side: a SLAM map grown out of the view fitted to it."""
    reach = margin * max(framed[2] - framed[0], framed[3] - framed[1], 0.1)
    return (
        framed[0] - now[0] > reach
        or framed[1] - now[1] > reach
        or now[2] - framed[2] > reach
        or now[3] - framed[3] > reach
    )


def oblique_camera(bounds: tuple[float, float, float, float], fov: float = TOP_DOWN_FOV) -> Camera:
    """A camera looking down at 45 degrees from the south-east at the box (for the arms)."""
    xmin, ymin, xmax, ymax = bounds
    size = max(xmax - xmin, ymax - ymin, 0.2)
    cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
    distance = 1.2 * size / math.tan(0.5 * fov)
    offset = distance / math.sqrt(3.0)
    return Camera((cx + 0.3 * offset, cy - offset, 0.25 * size + offset), (cx, cy, 0.25 * size), fov)
