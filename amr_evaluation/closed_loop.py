"""Global localization while exploring, without ROS: simulator + wall follower + particle filter, lockstep.

Each period the filter gets the encoder odometry pose and the scan, the wall
follower the odometry twist and the scan, and its command advances the
simulator by dt: the node stack's loop minus the transport, as parts of the
lockstep harness (amr_util.harness: the filter's odometry, the filter, the
trace, the wall follower). The tests and
bench/bench_localization.py run it; `kidnap` teleports the robot mid-run
without telling the filter (the odometry it is given carries on as if nothing
happened, which is what a kidnapped robot's wheels report).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import WallFollowerConfig
from amr_localization.particle_filter import Estimate, ParticleFilter
from amr_simulation.simulator import Simulator
from amr_util.geometry import compose, wrap_angle
from amr_util.harness import Frame, Harness, OneRobot, drive, localize


@dataclass
class Trace:
    """Per-step record of a run."""

    time: list[float] = field(default_factory=list)
    localized: list[bool] = field(default_factory=list)
    position_error: list[float] = field(default_factory=list)
    heading_error: list[float] = field(default_factory=list)
    update_time: list[float] = field(default_factory=list)
    truth: list[tuple[float, float, float]] = field(default_factory=list)
    """the true pose (x, y, theta) at each step."""
    kidnapped_at: float | None = None

    def arrays(self):
        return (
            np.array(self.time),
            np.array(self.localized, dtype=bool),
            np.array(self.position_error),
            np.array(self.heading_error),
        )

    def first_localized(self, after: float = -1.0) -> int | None:
        """Index of the first localized step after time `after` (None if never)."""
        t, localized, _, _ = self.arrays()
        index = np.flatnonzero(localized & (t > after))
        return int(index[0]) if index.size else None


def run(
    sim: Simulator,
    pf: ParticleFilter,
    follower_config: WallFollowerConfig,
    seconds: float,
    kidnap: tuple[float, tuple[float, float, float]] | None = None,
    stop_when_localized: bool = False,
    until: Callable[[Simulator, Estimate], bool] | None = None,
) -> Trace:
    """Drive for `seconds` of simulated time; kidnap = (time, pose) teleports the robot once; `until`, called
    after each step's estimate, ends the run early when it returns True. The harness's parts: the odometry as the
    filter's frame has it, the filter, the trace, the wall follower."""
    trace = Trace()
    odometry_frame = np.zeros(3)  # what the filter's odometry frame is in the simulator's odometry frame

    def kidnapping() -> None:
        nonlocal odometry_frame
        if kidnap is not None and trace.kidnapped_at is None and sim.time >= kidnap[0]:
            before = compose(odometry_frame[None, :], np.array(sim.odom_pose))[0]
            sim.set_pose(*kidnap[1])  # the simulator's odometry restarts at the new pose ...
            odometry_frame = _frame_mapping(before, np.array(sim.odom_pose))  # ... the filter's carries on
            trace.kidnapped_at = sim.time

    def filter_odometry(frame: Frame) -> None:
        odometry = compose(odometry_frame[None, :], np.array(frame.observation.odometry))[0]
        frame.observation = frame.observation.with_odometry(tuple(odometry))

    def record(frame: Frame) -> None:
        estimate, truth = frame.estimate, sim.pose
        trace.time.append(frame.observation.stamp)
        trace.localized.append(estimate.localized)
        trace.position_error.append(math.hypot(estimate.pose.x - truth.x, estimate.pose.y - truth.y))
        trace.heading_error.append(abs(float(wrap_angle(estimate.pose.theta - truth.theta))))
        trace.update_time.append(estimate.status.update_time)
        trace.truth.append((truth.x, truth.y, truth.theta))
        if (stop_when_localized and estimate.localized) or (until is not None and until(sim, estimate)):
            frame.stop = "until"

    parts = [filter_odometry, localize(pf), record, drive(WallFollower(follower_config))]
    Harness(OneRobot(sim), [parts], before=[kidnapping]).run(seconds)
    return trace


def _frame_mapping(before: np.ndarray, restarted: np.ndarray) -> np.ndarray:
    """The frame F with F (+) restarted = before: maps the restarted odometry onto the old one."""
    c, s = math.cos(before[2] - restarted[2]), math.sin(before[2] - restarted[2])
    theta = float(wrap_angle(before[2] - restarted[2]))
    return np.array(
        [before[0] - (c * restarted[0] - s * restarted[1]), before[1] - (s * restarted[0] + c * restarted[1]), theta]
    )
