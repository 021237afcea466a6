"""Differential-drive kinematics (seed 002, sections 1-2): the simulator's wheels and the controllers' limits.

Forward:  v = r (w_r + w_l) / 2,   w = r (w_r - w_l) / b
Inverse:  w_r = (v + w b / 2) / r,  w_l = (v - w b / 2) / r
with r the wheel radius and b the track (distance between the wheels).

Saturation scales the whole command by one factor, so the commanded
curvature w / v survives it: the robot drives the same arc, only slower.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from amr_util.geometry import is_finite_number
from amr_util.robot_description import default_robot


class DiffDriveError(ValueError):
    """A drive that cannot exist (a non-positive radius, track or limit) or a non-finite speed."""


def _finite(name: str, *values: float) -> None:
    """Non-finite speeds would turn into NaN wheel commands: refuse them."""
    if not all(map(is_finite_number, values)):
        raise DiffDriveError(f"DiffDrive.{name}: speeds must be finite numbers, got {values!r}")


@dataclass(frozen=True)
class DiffDrive:
    """A differential-drive base; limits of math.inf mean unlimited; the wheels by default the robot description's."""

    wheel_radius: float = default_robot().wheel_radius
    track: float = default_robot().wheel_separation
    max_wheel_speed: float = math.inf
    max_linear: float = math.inf
    max_angular: float = math.inf

    def __post_init__(self) -> None:
        for name in ("wheel_radius", "track", "max_wheel_speed", "max_linear", "max_angular"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or math.isnan(value) or value <= 0.0:
                raise DiffDriveError(f"DiffDrive.{name} must be a positive number, got {value!r}")
        if math.isinf(self.wheel_radius) or math.isinf(self.track):
            raise DiffDriveError("DiffDrive wheel_radius and track must be finite")

    def wheel_speeds(self, linear: float, angular: float) -> tuple[float, float]:
        """(left, right) wheel angular speeds in rad/s for a body twist, unsaturated."""
        _finite("wheel_speeds", linear, angular)
        half = angular * self.track / 2.0
        return (linear - half) / self.wheel_radius, (linear + half) / self.wheel_radius

    def body_twist(self, left: float, right: float) -> tuple[float, float]:
        """(linear m/s, angular rad/s) of the body for wheel angular speeds."""
        _finite("body_twist", left, right)
        r = self.wheel_radius
        return r * (right + left) / 2.0, r * (right - left) / self.track

    def saturation_scale(self, linear: float, angular: float) -> float:
        """The factor in (0, 1] that brings a twist within every limit.

        The body limits are applied first, so that an absurd but finite twist (1e308 m/s) is
        scaled like any other instead of overflowing in the wheel speeds.
        """
        scale = 1.0  # limit / value, never value / limit: 1e308 / 0.22 would overflow
        for value, limit in ((linear, self.max_linear), (angular, self.max_angular)):
            if abs(value) > limit:
                scale = min(scale, limit / abs(value))
        left, right = self.wheel_speeds(linear * scale, angular * scale)
        wheels = max(abs(left), abs(right))
        return scale * (self.max_wheel_speed / wheels) if wheels > self.max_wheel_speed else scale

    def saturate(self, linear: float, angular: float) -> tuple[float, float]:
        """The twist scaled to the limits, keeping its curvature."""
        _finite("saturate", linear, angular)
        scale = self.saturation_scale(linear, angular)
        return linear * scale, angular * scale

    def command(self, linear: float, angular: float) -> tuple[float, float]:
        """(left, right) wheel speeds for a twist after curvature-preserving saturation."""
        return self.wheel_speeds(*self.saturate(linear, angular))
