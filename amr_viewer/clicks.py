"""A click on the floor as RViz's 2D Goal Pose or 2D Pose Estimate: which pose it means; no rclpy, no viser.

One click gives the position; its heading is the direction from the robot to the point for a goal, the robot's
heading as drawn for a pose estimate (0 without a robot). With `two_clicks`, a second click gives the heading
instead: the direction from the first point to the second (RViz's drag, for a browser where a drag turns the view).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from amr_util.geometry import Pose2D
from amr_viewer.geometry import finite, floor_point
from amr_viewer.topics import join

GOAL, INITIAL_POSE, OFF = "goal", "initial pose", "off"
MODES = (GOAL, INITIAL_POSE, OFF)
MIN_HEADING_DISTANCE = 1e-3
"""m between two clicks for them to give a heading (closer: heading 0)."""


class ClickTool:
    def __init__(self, mode: str = GOAL, two_clicks: bool = False) -> None:
        self.mode = mode
        self.two_clicks = two_clicks
        self.pending: tuple[float, float] | None = None
        """The first click of two, waiting for the heading."""

    def set_mode(self, mode: str) -> None:
        if mode not in MODES:
            raise ValueError(f"click mode {mode!r}: expected one of {MODES}")
        self.mode, self.pending = mode, None

    def set_two_clicks(self, two_clicks: bool) -> None:
        self.two_clicks, self.pending = bool(two_clicks), None

    def click(self, x: float, y: float, robot: Pose2D | None) -> tuple[str, Pose2D] | None:
        """(mode, pose) to send, or None (off, a first click of two, or a point that is not finite)."""
        if self.mode == OFF or not finite(x, y):
            return None
        if self.two_clicks:
            if self.pending is None:
                self.pending = (x, y)
                return None
            (px, py), self.pending = self.pending, None
            return self.mode, Pose2D(px, py, heading(px, py, x, y, 0.0))
        if robot is None or not finite(*robot):
            return self.mode, Pose2D(x, y, 0.0)
        if self.mode == GOAL:
            return self.mode, Pose2D(x, y, heading(robot.x, robot.y, x, y, robot.theta))
        return self.mode, Pose2D(x, y, robot.theta)

    def ray(
        self, origin, direction, robot: Callable[[], Pose2D | None]
    ) -> tuple[tuple[str, Pose2D] | None, str | None]:
        """A click as the browser gives it, a ray from the camera: (mode, pose) to send or None, and the line to
        say meanwhile (a first click of two), or None. A ray that misses the floor is no click (and `robot()`, the
        robot's pose as drawn, is not asked for)."""
        point = floor_point(origin, direction)
        if point is None:
            return None, None
        chosen = self.click(point[0], point[1], robot())
        if chosen is None and self.pending is not None:
            return None, f"({point[0]:.2f}, {point[1]:.2f}): now click the heading"
        return chosen, None


def heading(x0: float, y0: float, x1: float, y1: float, default: float) -> float:
    """The direction from (x0, y0) to (x1, y1), `default` when they (nearly) coincide."""
    if math.hypot(x1 - x0, y1 - y0) < MIN_HEADING_DISTANCE:
        return default
    return math.atan2(y1 - y0, x1 - x0)


def pose_topic(mode: str, namespace: str = "") -> str:
    """Where a click's pose goes: a goal to `<ns>/goal_pose`, a pose estimate to `<ns>/initialpose` (RViz's)."""
    return join(namespace, "goal_pose" if mode == GOAL else "initialpose")


def sent_text(topic: str, pose: Pose2D) -> str:
    return f"sent {topic}: ({pose.x:.2f}, {pose.y:.2f}), {math.degrees(pose.theta):.0f} deg"
