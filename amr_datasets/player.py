"""Playing a log as a robot's stream, without ROS: which scans, at which stamps, with which odometry.

A LogPlayer takes a slice of a CarmenLog's scans (`start`, `count`) and gives step k as a PlayerStep: the scan,
its stamp, the reference (corrected) pose and the synthesized odometry pose (amr_datasets.odometry, seeded), with
the twists between consecutive steps. A stamp of 0 or less (a log starting at 0, or synthesized stamps) is moved
so that the first stamp is 1 s: ROS reads a time of 0 as "no time yet".

`loop`: after the last scan the first comes again, the stamps carrying on (each lap starts one mean scan period
after the last one ended) and the robot carried from the last pose to the first: the reference jumps, and the
odometry moves by the same relative motion without noise (a kidnapping the odometry saw), then goes on with the
next lap's noise (seed + lap).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_datasets.carmen import CarmenLog
from amr_datasets.odometry import OdometryNoiseModel, synthesize_odometry
from amr_util.geometry import Pose2D, arc_twist, compose, relative_pose
from amr_util.scan import ScanData

FIRST_STAMP = 1.0
"""s: the first stamp when the log's is 0 or less."""


@dataclass(frozen=True)
class PlayerStep:
    """One scan as the robot publishes it."""

    index: int
    """Steps played before this one (counting every lap)."""
    scan_index: int
    """Its scan in the log (CarmenLog.scans)."""
    lap: int
    stamp: float
    """s, strictly increasing from step to step."""
    scan: ScanData
    pose: Pose2D
    """The reference pose of base_footprint (= the laser) in the map frame."""
    odom: Pose2D
    """The synthesized odometry pose in the odom frame."""
    odom_twist: tuple[float, float, float]
    """Body-frame (vx, vy, w) of the odometry since the previous step (0 at the first step of a lap)."""
    pose_twist: tuple[float, float, float]
    """The same of the reference."""


class LogPlayer:
    """The steps of a log slice, lap after lap when looping."""

    def __init__(
        self,
        log: CarmenLog,
        noise: OdometryNoiseModel | None = None,
        seed: int = 0,
        start: int = 0,
        count: int = 0,
        loop: bool = False,
    ) -> None:
        """count 0: to the end of the log. ValueError when the slice is empty."""
        if start < 0 or count < 0:
            raise ValueError(f"start and count must be >= 0, got start {start}, count {count}")
        if start >= len(log.scans):
            raise ValueError(f"start: {start} is past the log's last scan ({len(log.scans)} scans, from 0)")
        self.log = log
        self.noise = OdometryNoiseModel() if noise is None else noise
        self.seed = int(seed)
        self.loop = bool(loop)
        self.first = start
        self.scans = log.scans[start : start + count] if count else log.scans[start:]
        self.poses = np.array([scan.pose for scan in self.scans], dtype=float).reshape(-1, 3)
        stamps = np.array([scan.stamp for scan in self.scans], dtype=float)
        offset = FIRST_STAMP - stamps[0] if stamps[0] <= 0.0 else 0.0
        self.stamps = stamps + offset
        span = self.stamps[-1] - self.stamps[0]
        self.period = span / (len(self.scans) - 1) if len(self.scans) > 1 else 1.0
        """Mean s between scans."""
        self.lap_span = span + self.period
        """s from the first stamp of a lap to the first of the next."""
        self._lap = -1
        self._odometry = np.zeros((0, 3))
        self._lap_end = Pose2D(0.0, 0.0, 0.0)

    def __len__(self) -> int:
        """Scans per lap."""
        return len(self.scans)

    def has(self, index: int) -> bool:
        """Whether step `index` exists (always when looping)."""
        return index >= 0 and (self.loop or index < len(self.scans))

    def stamp(self, index: int) -> float:
        lap, i = divmod(index, len(self.scans))
        return float(self.stamps[i] + lap * self.lap_span)

    def odometry(self, lap: int) -> np.ndarray:
        """(N, 3) odometry poses of one lap (laps computed in order; the latest is kept)."""
        if lap < self._lap:
            self._lap, self._lap_end = -1, Pose2D(0.0, 0.0, 0.0)
        while self._lap < lap:
            self._lap += 1
            path = synthesize_odometry(self.poses, self.noise, self.seed + self._lap)
            if self._lap > 0:
                carried = relative_pose(self.poses[-1], self.poses[0])
                anchor = compose(self._lap_end, carried)
                path = _compose_each(anchor, path)
            self._odometry = path
            self._lap_end = Pose2D(*(float(v) for v in path[-1]))
        return self._odometry

    def step(self, index: int) -> PlayerStep:
        if not self.has(index):
            raise IndexError(f"step {index}: the slice has {len(self.scans)} scans and does not loop")
        lap, i = divmod(index, len(self.scans))
        odometry = self.odometry(lap)
        stamp = self.stamp(index)
        pose = Pose2D(*(float(v) for v in self.poses[i]))
        odom = Pose2D(*(float(v) for v in odometry[i]))
        if i > 0:
            dt = stamp - self.stamp(index - 1)
            odom_twist = _finite(arc_twist(Pose2D(*odometry[i - 1]), odom, dt))
            pose_twist = _finite(arc_twist(Pose2D(*self.poses[i - 1]), pose, dt))
        else:
            odom_twist = pose_twist = (0.0, 0.0, 0.0)
        return PlayerStep(index, self.first + i, lap, stamp, self.scans[i].scan, pose, odom, odom_twist, pose_twist)


def _compose_each(anchor, poses: np.ndarray) -> np.ndarray:
    """anchor (+) each of the (N, 3) poses."""
    c, s = math.cos(anchor[2]), math.sin(anchor[2])
    x = anchor[0] + c * poses[:, 0] - s * poses[:, 1]
    y = anchor[1] + s * poses[:, 0] + c * poses[:, 1]
    theta = np.mod(poses[:, 2] + anchor[2] + math.pi, 2.0 * math.pi) - math.pi
    return np.column_stack([x, y, theta])


def _finite(twist) -> tuple[float, float, float]:
    values = tuple(float(v) for v in twist)
    return values if all(math.isfinite(v) for v in values) else (0.0, 0.0, 0.0)
