"""Velocities from consecutive poses: the odometry a real TurtleBot3's /odom lacks (seed 002, 5.1).

    v = (dx cos(theta_mid) + dy sin(theta_mid)) / dt                       (9)
    w = atan2(sin(theta_k - theta_k-1), cos(theta_k - theta_k-1)) / dt     (10)

theta_mid is the heading half-way through the turn, theta_k-1 + dtheta / 2. The seed's
(theta_k-1 + theta_k) / 2 points backwards when the heading wraps at +-pi
(179 deg and -179 deg average to 0 deg), which flips the sign of v.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from amr_util.geometry import wrap_angle


class Verdict(Enum):
    """What happened to a pose sample."""

    FIRST = "first sample: zero twist"
    OK = "ok"
    NON_FINITE = "pose or stamp is NaN or infinite"
    NOT_LATER = "stamp is not later than the previous sample (dt <= 0)"
    OVERFLOW = "velocity overflows (a huge jump over a tiny dt)"


@dataclass(frozen=True)
class PoseSample:
    stamp: float  # seconds
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class Estimate:
    verdict: Verdict
    linear: float = 0.0
    angular: float = 0.0

    @property
    def accepted(self) -> bool:
        return self.verdict in (Verdict.FIRST, Verdict.OK)


class PoseDifferentiator:
    """Turns a stream of poses into twists; rejected samples leave the last good state untouched."""

    def __init__(self) -> None:
        self._previous: PoseSample | None = None

    def reset(self) -> None:
        self._previous = None

    def update(self, sample: PoseSample) -> Estimate:
        if not all(math.isfinite(value) for value in (sample.stamp, sample.x, sample.y, sample.yaw)):
            return Estimate(Verdict.NON_FINITE)
        previous = self._previous
        if previous is None:
            self._previous = sample
            return Estimate(Verdict.FIRST)
        dt = sample.stamp - previous.stamp
        if dt <= 0.0:
            return Estimate(Verdict.NOT_LATER)
        dtheta = wrap_angle(sample.yaw - previous.yaw)
        heading = previous.yaw + dtheta / 2.0
        linear = ((sample.x - previous.x) * math.cos(heading) + (sample.y - previous.y) * math.sin(heading)) / dt
        angular = dtheta / dt
        if not (math.isfinite(linear) and math.isfinite(angular)):
            return Estimate(Verdict.OVERFLOW)
        self._previous = sample
        return Estimate(Verdict.OK, linear, angular)
