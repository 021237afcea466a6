"""How far a localizer's estimate is from the ground truth (seed 002's _check_estimated_pose), no ROS.

The simulator remembers the true pose of its last observations by stamp; an estimate arrives
stamped with the observation it used (possibly after the simulator stepped on, in lockstep), and
is compared with the truth at that stamp:

    position_error = || (x, y) - (x*, y*) ||,   heading_error = | wrap(theta - theta*) |
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

from amr_util.geometry import Pose2D, wrap_angle

HISTORY = 200
"""Observations remembered (10 s at dt = 0.05): an estimate older than that is not judged."""


@dataclass
class LocalizationReport:
    """The check's state, as ~/status reports it."""

    localized: bool = False
    first_localized_time: float = -1.0
    """simulated s of the first localized estimate; -1 until then."""
    position_error: float = math.nan
    heading_error: float = math.nan


class LocalizationCheck:
    def __init__(self) -> None:
        self._truth: OrderedDict[int, tuple[Pose2D, float]] = OrderedDict()
        self.state = LocalizationReport()

    def reset(self) -> None:
        self._truth.clear()
        self.state = LocalizationReport()

    def observed(self, stamp_ns: int, truth: Pose2D, sim_time: float) -> None:
        """Remember the true pose of the observation stamped stamp_ns."""
        self._truth[stamp_ns] = (truth, sim_time)
        while len(self._truth) > HISTORY:
            self._truth.popitem(last=False)

    def estimate(self, stamp_ns: int, x: float, y: float, theta: float, localized: bool) -> str | None:
        """Judge an estimate; returns the line to log when it is the first localized one, else None.
        Raises ValueError for a non-finite estimate or an unknown stamp."""
        if not all(map(math.isfinite, (x, y, theta))):
            raise ValueError(f"estimate ({x}, {y}, {theta}) is not finite")
        if stamp_ns not in self._truth:
            raise ValueError(f"no observation stamped {stamp_ns * 1e-9:.3f} s among the last {HISTORY}")
        truth, sim_time = self._truth[stamp_ns]
        state = self.state
        state.position_error = math.hypot(x - truth.x, y - truth.y)
        state.heading_error = abs(wrap_angle(theta - truth.theta))
        state.localized = bool(localized)
        if localized and state.first_localized_time < 0.0:
            state.first_localized_time = sim_time
            return (
                f"localized at t = {sim_time:.2f} s, error {state.position_error:.3f} m, "
                f"{math.degrees(state.heading_error):.1f} deg"
            )
        return None
