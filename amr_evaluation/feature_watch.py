"""When the feature that breaks a room's symmetry is in the LiDAR's view, from the true pose.

A localization episode given its world's symmetric counterpart (amr_maps.symmetry_families: the same
room without the doorway, notch or pillar) watches every step of the run with a FeatureWatch: the
feature is *seen* when `beams` noise-free beams (3: 4.5 deg of the LDS's 240) see it (their ranges
differ by more than 5 cm from the counterpart's at the same sensor pose), *glimpsed* when one does, and
every quarter turn of the pose is *told apart* once `beams` beams have differed from that turn's at
least once (the feature seen, or a wall where a turned copy would see it: about the earliest any
observer could rule every copy out). Localization goals are counted from `seen`.
"""

from __future__ import annotations

import math

from amr_maps.symmetry_families import FeatureView


class FeatureWatch:
    """Per step, from the true pose and the LiDAR's geometry: the first times the feature is seen and
    glimpsed, and by when every quarter turn has been told apart."""

    def __init__(self, view: FeatureView, lidar, beams: int = 3) -> None:
        """lidar: the simulator's LidarConfig (mount, beams, angles, range)."""
        self.view, self.lidar, self.beams = view, lidar, beams
        self.seen: float | None = None
        self.glimpsed: float | None = None
        self._apart: list[float | None] = [None, None, None]

    @property
    def apart(self) -> float | None:
        """s: the time every quarter turn had been told apart by, None while one has not."""
        return None if None in self._apart else max(self._apart)  # type: ignore[type-var]

    def step(self, t: float, pose: tuple[float, float, float]) -> None:
        if self.seen is not None and self.apart is not None:
            return
        lidar, (x, y, theta) = self.lidar, pose
        scan = (
            x + lidar.x * math.cos(theta) - lidar.y * math.sin(theta),
            y + lidar.x * math.sin(theta) + lidar.y * math.cos(theta),
            theta + lidar.angle_min,
            lidar.angle_increment,
            lidar.beams,
            lidar.range_max,
        )
        if self.seen is None:
            seeing = self.view.differing_beams(*scan)
            if self.glimpsed is None and seeing >= 1:
                self.glimpsed = t
            if seeing >= self.beams:
                self.seen = t
        if self.apart is None:
            self._apart = [
                a if a is not None or n < self.beams else t
                for a, n in zip(self._apart, self.view.told_apart(*scan), strict=True)
            ]

    def stop_after(self, seconds: float):
        """A closed_loop.run `until`: watches each step; True once localized `seconds` ago with the feature seen."""
        first: list[float] = []

        def until(sim, estimate) -> bool:
            pose = sim.pose
            self.step(sim.time, (pose.x, pose.y, pose.theta))
            if estimate.localized and not first:
                first.append(sim.time)
            return bool(first) and self.seen is not None and sim.time >= first[0] + seconds

        return until
