"""Pure pursuit along a planned path, as a plain class (no ROS).

Each call to :meth:`PathFollower.compute` takes the localized pose (x, y, theta in the path's
frame) and, if there is one, the latest LiDAR scan, and returns the velocity command:

1. Closest point: the pose is projected on the path's segments within ``progress_window`` ahead of
   the last projection (so a path that passes close to itself is not short-cut); the distance to
   it is the cross-track error. Further than ``stray_distance`` (the pose jumped, the robot was
   pushed): stop and ask for a new plan (``STRAYED``).
2. Lookahead point: ``lookahead_distance`` further along the path (the last point near the end).
   In the robot frame it lies at distance l and angle alpha; the arc through it has curvature

       k = 2 sin(alpha) / l,   w = v k.

3. Speed: ``linear_speed``, at most ``curve_angular_speed / |k|`` in curves and
   ``approach_gain * s`` with s the distance left along the path, never below ``min_linear_speed``;
   the twist is then saturated keeping its curvature (amr_util.diff_drive.DiffDrive).
4. Turn in place (``ALIGN``) while the lookahead point is more than ``align_angle_deg`` off the
   heading (a path that starts behind the robot), until it is within ``aligned_angle_deg``.
5. Goal: within ``goal_tolerance`` of the last point, turn in place to the goal heading if the
   path has one (``HEADING``), then stop: ``REACHED``.
6. Safety: if this period's motion along the commanded arc would bring the disc closer to a
   return of the scan, and within ``safety_margin`` of it, the robot stops (``BLOCKED``) and
   turns in place towards the lookahead point (a disc turning on the spot approaches nothing;
   facing the point the way on is often clear). A block that lasts
   ``blocked_replan_time`` asks for a new plan. Returns are read per REP 117 (NaN and out-of-range
   ignored, -inf counted at range_min).
7. Escape (``ESCAPE``): a block with nothing to turn towards (the lookahead point within
   BLOCKED_TURN_DEG of the heading) by a return at least GRAZE_BEARING_DEG off the heading is a
   graze: the robot is beside a wall or corner, closer than the margin (a pose estimate a few cm
   off, a corner cut), and every forward arc towards the path approaches it. A new plan from the
   same pose is the same path, so waiting would last for ever; instead the robot turns in place
   away from that return until it lies ESCAPE_BEARING_DEG off the heading (at most
   ESCAPE_MAX_TURN_DEG), drives straight on, away from it, for ``robot_radius / 2`` at
   ``min_linear_speed`` (stopping early if a period's motion would enter the margin of any other
   return), and pursues again.

No input makes it raise or return a NaN command: a bad pose or scan stops the robot with the
reason in :attr:`FollowCommand.message`; a bad path is refused by :meth:`set_path`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from amr_control.path_follower_config import PathFollowerConfig
from amr_util.diff_drive import DiffDrive
from amr_util.geometry import is_finite_number, wrap_angle
from amr_util.scan import ScanData

BLOCKED_TURN_DEG = 3.0
"""A blocked robot turns in place towards the lookahead point while it is further off than this."""
CONFIRMING_RETURNS = 3
"""Beams that must agree before a return stops the robot (a 2 cm post 0.3 m away spans 3 at 1.5 deg)."""
GRAZE_BEARING_DEG = 45.0
"""A block by a return at least this far off the heading, with the path straight ahead, is a graze (see ESCAPE)."""
ESCAPE_BEARING_DEG = 100.0
"""An escape turns until the grazed return lies this far off the heading: driving on then moves away from it."""
ESCAPE_MAX_TURN_DEG = 120.0
"""An escape turns away at most this far before giving up (the block then stands and a replan is asked)."""


class PathError(ValueError):
    """A path that cannot be followed, with what is wrong with it."""


class State(StrEnum):
    IDLE = "IDLE"
    """no path to follow."""
    ALIGN = "ALIGN"
    TRACK = "TRACK"
    HEADING = "HEADING"
    REACHED = "REACHED"
    BLOCKED = "BLOCKED"
    ESCAPE = "ESCAPE"
    """grazing a wall with the path straight ahead: turning away from it, then straight on a little."""
    STRAYED = "STRAYED"
    WAITING = "WAITING"
    """the caller's speed limit is 0 (an obstacle in the way): standing still on the path."""


@dataclass(frozen=True)
class FollowCommand:
    """A velocity command (m/s, rad/s, counter-clockwise positive) and the follower's view of it."""

    v: float
    w: float
    state: State
    cross_track: float = math.nan
    """m from the path (NaN without a path)."""
    remaining: float = math.nan
    """m left along the path."""
    replan: bool = False
    """the path can no longer be followed from here: the planner should plan again."""
    message: str = ""

    @property
    def reached(self) -> bool:
        return self.state is State.REACHED


class PathFollower:
    """Pure pursuit: construct from a parameter dict or a PathFollowerConfig, then set_path and compute."""

    def __init__(self, params: Mapping[str, Any] | PathFollowerConfig | None = None) -> None:
        if params is None:
            config = PathFollowerConfig()
        elif isinstance(params, PathFollowerConfig):
            config = params
        else:
            config = PathFollowerConfig.from_params(params)
        self.reconfigure(config)
        self._blocked_turn = math.radians(BLOCKED_TURN_DEG)
        self._graze_bearing = math.radians(GRAZE_BEARING_DEG)
        self._escape_bearing = math.radians(ESCAPE_BEARING_DEG)
        self._escape_max_turn = math.radians(ESCAPE_MAX_TURN_DEG)
        self.clear()

    def reconfigure(self, config: PathFollowerConfig) -> None:
        """New tunables (a live parameter set), used from the next compute; the path and progress stay."""
        self.config = config
        self._drive = DiffDrive(max_linear=config.linear_speed, max_angular=config.angular_limit)
        self._align = math.radians(config.align_angle_deg)
        self._aligned = math.radians(config.aligned_angle_deg)
        self._heading_tolerance = math.radians(config.heading_tolerance_deg)

    # -- path --------------------------------------------------------------------------

    def clear(self) -> None:
        """Forget the path: IDLE, zero commands."""
        self._points: np.ndarray | None = None
        self._goal_heading: float | None = None
        self._escape: _Escape | None = None
        self._state = State.IDLE

    def set_path(self, points, goal_heading: float | None = None) -> None:
        """Follow a new path (N, 2) from its start; PathError if it is empty, not finite or a single point
        with nowhere to go. Consecutive duplicates are dropped."""
        try:
            array = np.asarray(points, dtype=float)
        except (TypeError, ValueError) as error:
            raise PathError(f"path points must be numbers, got {error}") from error
        if array.ndim != 2 or array.shape[1] != 2 or len(array) == 0:
            raise PathError(f"a path must be a non-empty list of (x, y) points, got shape {array.shape}")
        if not np.isfinite(array).all():
            raise PathError("a path must have finite coordinates (NaN or inf found)")
        if goal_heading is not None and not math.isfinite(goal_heading):
            raise PathError(f"goal heading must be finite or absent, got {goal_heading!r}")
        keep = np.ones(len(array), dtype=bool)
        keep[1:] = np.hypot(*np.diff(array, axis=0).T) > 1e-9
        array = array[keep]
        if len(array) == 1:
            array = np.vstack([array, array])  # a one-point path: its "segment" has zero length
        self._points = array
        starts, ends = array[:-1], array[1:]
        self._segment_start = starts
        self._segment_vector = ends - starts
        self._segment_length = np.hypot(*self._segment_vector.T)
        self._arc = np.concatenate([[0.0], np.cumsum(self._segment_length)])  # arc length at each point
        self._goal_heading = goal_heading
        self._progress: float | None = None  # arc length of the last projection; None: search it all
        self._blocked_steps = 0
        self._escape: _Escape | None = None
        self._state = State.TRACK  # until the first compute decides

    @property
    def state(self) -> State:
        return self._state

    @property
    def has_path(self) -> bool:
        return self._points is not None

    @property
    def points(self) -> np.ndarray | None:
        """The path followed (N, 2), None without one."""
        return None if self._points is None else self._points.copy()

    @property
    def goal(self) -> np.ndarray | None:
        """The path's last point (x, y), None without a path."""
        return None if self._points is None else self._points[-1].copy()

    # -- control -----------------------------------------------------------------------

    def compute(
        self, x: float, y: float, theta: float, scan: ScanData | None = None, speed_limit: float | None = None
    ) -> FollowCommand:
        """The command for the localized pose (x, y, theta) and the latest scan (None: no safety check).

        speed_limit (m/s, None: none) caps the forward speed while tracking, as nav2's speed limits do (the
        navigator's traffic rules slow the robot for an obstacle ahead); 0 stands the robot still on the path
        (WAITING) while in-place turns (towards the path, to the goal heading) go on."""
        if self._points is None:
            return FollowCommand(0.0, 0.0, State.IDLE, message="no path")
        if not all(is_finite_number(v) for v in (x, y, theta)):
            return self._halt(
                State(self._state), math.nan, math.nan, False, f"non-finite pose ({x}, {y}, {theta}): stopping"
            )
        if self._state is State.REACHED:
            return FollowCommand(0.0, 0.0, State.REACHED, message="goal reached")

        cross_track, progress = self._project(x, y)
        remaining = float(self._arc[-1] - progress)
        if cross_track > self.config.stray_distance and self._arc[-1] > 0.0:
            self._state = State.STRAYED
            return self._halt(
                State.STRAYED,
                cross_track,
                remaining,
                True,
                f"{cross_track:.3f} m from the path (more than {self.config.stray_distance} m): "
                "stopping, replan needed",
            )
        self._progress = progress

        goal = self._points[-1]
        to_goal = math.hypot(goal[0] - x, goal[1] - y)
        if to_goal <= self.config.goal_tolerance or self._state is State.HEADING:
            return self._finish(theta, cross_track, remaining)

        if self._escape is not None:
            returns = _returns(scan, self.config.lidar_x)
            if isinstance(returns, str):
                return self._halt(self._state, cross_track, remaining, False, returns)
            command = self._escaping(x, y, theta, returns, cross_track, remaining)
            if command is not None:
                return command

        target = self._lookahead_point(progress)
        dx, dy = target[0] - x, target[1] - y
        distance = math.hypot(dx, dy)
        alpha = wrap_angle(math.atan2(dy, dx) - theta) if distance > 1e-9 else 0.0
        limit = self._aligned if self._state is State.ALIGN else self._align
        if abs(alpha) > limit:
            self._state = State.ALIGN
            return self._emit(0.0, self._turn(alpha), cross_track, remaining, "turning in place towards the path")

        curvature = 2.0 * math.sin(alpha) / max(distance, 1e-6)
        v = self.config.linear_speed
        if curvature != 0.0:
            v = min(v, self.config.curve_angular_speed / abs(curvature))
        v = min(v, self.config.approach_gain * max(remaining, to_goal))
        v = max(v, self.config.min_linear_speed)
        if speed_limit is not None:
            if not speed_limit > 0.0:  # 0, negative or NaN: stand still
                self._state = State.WAITING
                return self._emit(0.0, 0.0, cross_track, remaining, "waiting: speed limit 0 (something in the way)")
            v = min(v, speed_limit)

        w = v * curvature
        returns = _returns(scan, self.config.lidar_x)
        if isinstance(returns, str):
            return self._halt(self._state, cross_track, remaining, False, returns)
        closest, point = self._approached(returns, v, w)
        if closest < self.config.robot_radius + self.config.safety_margin:
            bearing = math.atan2(point[1], point[0])
            if abs(alpha) <= self._blocked_turn and abs(bearing) >= self._graze_bearing:
                c, s = math.cos(theta), math.sin(theta)  # the grazed return in the path's frame
                self._escape = _Escape(
                    -math.copysign(1.0, bearing),
                    theta,
                    x + c * point[0] - s * point[1],
                    y + s * point[0] + c * point[1],
                )
                command = self._escaping(x, y, theta, returns, cross_track, remaining)
                if command is not None:
                    return command
            self._state = State.BLOCKED
            self._blocked_steps += 1
            replan = self._blocked_steps * self.config.dt >= self.config.blocked_replan_time
            gap = closest - self.config.robot_radius
            # Turning in place approaches nothing: face the lookahead point, from where the arc may be clear.
            turn = self._turn(alpha) if abs(alpha) > self._blocked_turn else 0.0
            return self._emit(
                0.0,
                turn,
                cross_track,
                remaining,
                f"driving on would bring the footprint within {gap:.3f} m of a return (margin "
                f"{self.config.safety_margin} m): stopped" + (", replan needed" if replan else ""),
                replan=replan,
            )
        self._blocked_steps = 0
        self._state = State.TRACK
        return self._emit(v, w, cross_track, remaining, "")

    # -- geometry --------------------------------------------------------------------------

    def _project(self, x: float, y: float) -> tuple[float, float]:
        """(distance to the path, arc length of the closest point) within the progress window
        (over the whole path at the first pose after set_path)."""
        if self._progress is None:
            window = np.ones(len(self._segment_length), dtype=bool)
        else:
            window = (self._arc[:-1] <= self._progress + self.config.progress_window) & (
                self._arc[1:] >= self._progress - self.config.progress_window
            )
        starts = self._segment_start[window]
        vectors = self._segment_vector[window]
        lengths = self._segment_length[window]
        rel = np.array([x, y]) - starts
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.where(lengths > 0.0, (rel * vectors).sum(axis=1) / lengths**2, 0.0)
        t = np.clip(t, 0.0, 1.0)
        nearest = starts + t[:, None] * vectors
        distances = np.hypot(*(nearest - (x, y)).T)
        best = int(np.argmin(distances))
        arc = self._arc[:-1][window][best] + t[best] * lengths[best]
        return float(distances[best]), float(arc)

    def _lookahead_point(self, progress: float) -> np.ndarray:
        """The path point lookahead_distance along the path from the closest point (the end at most)."""
        s = progress + self.config.lookahead_distance
        if s >= self._arc[-1]:
            return self._points[-1]
        index = int(np.searchsorted(self._arc, s, side="right")) - 1
        t = (s - self._arc[index]) / self._segment_length[index]
        return self._points[index] + t * self._segment_vector[index]

    def _approached(self, returns: np.ndarray, v: float, w: float) -> tuple[float, tuple[float, float]]:
        """The distance, after one period along the arc (v, w), to the returns that the motion approaches,
        and that return (x, y in the robot frame).

        The CONFIRMING_RETURNS-th smallest counts: one or two noisy beams do not stop the robot,
        any real obstacle in reach spans more beams than that.

        With curvature k = w / v and travel d = v dt the robot's centre ends at
        (sin(k d) / k, (1 - cos(k d)) / k) in its present frame; a return counts when it ends
        closer than it started. (inf, (nan, nan)) when no return is approached.
        """
        if len(returns) == 0:
            return math.inf, (math.nan, math.nan)
        travel = max(v * self.config.dt, 1e-3)
        turn = (w / v) * travel if v > 0.0 else 0.0
        if abs(turn) < 1e-9:
            end = (travel, 0.0)
        else:
            radius = travel / turn
            end = (radius * math.sin(turn), radius * (1.0 - math.cos(turn)))
        before = np.hypot(returns[:, 0], returns[:, 1])
        after = np.hypot(returns[:, 0] - end[0], returns[:, 1] - end[1])
        approached = np.flatnonzero(after < before)
        if len(approached) < CONFIRMING_RETURNS:
            return math.inf, (math.nan, math.nan)
        index = approached[np.argsort(after[approached])[CONFIRMING_RETURNS - 1]]
        return float(after[index]), (float(returns[index, 0]), float(returns[index, 1]))

    def _escaping(
        self, x: float, y: float, theta: float, returns: np.ndarray, cross_track: float, remaining: float
    ) -> FollowCommand | None:
        """The escape's command (see the module's item 7), or None once it is over or has given up."""
        escape = self._escape
        speed = self.config.min_linear_speed
        if escape.driving:
            clear = self._approached(returns, speed, 0.0)[0] >= self.config.robot_radius + self.config.safety_margin
            if clear and math.hypot(x - escape.start_x, y - escape.start_y) < 0.5 * self.config.robot_radius:
                return self._emit(speed, 0.0, cross_track, remaining, "escaping a graze: driving away from it")
            self._escape = None  # done (or blocked again: pursuit decides)
            return None
        bearing = wrap_angle(math.atan2(escape.y - y, escape.x - x) - theta)
        if abs(bearing) >= self._escape_bearing:
            escape.driving, escape.start_x, escape.start_y = True, x, y
            self._state = State.ESCAPE
            self._blocked_steps = 0
            return self._emit(speed, 0.0, cross_track, remaining, "escaping a graze: driving away from it")
        if escape.sign * wrap_angle(theta - escape.theta) >= self._escape_max_turn:
            self._escape = None  # turned as far as it may: the block stands
            return None
        self._state = State.ESCAPE
        return self._emit(
            0.0,
            escape.sign * self.config.turn_speed,
            cross_track,
            remaining,
            "grazing a return beside the path: turning away from it",
        )

    # -- commands --------------------------------------------------------------------------

    def _finish(self, theta: float, cross_track: float, remaining: float) -> FollowCommand:
        if self._goal_heading is not None:
            error = wrap_angle(self._goal_heading - theta)
            if abs(error) > self._heading_tolerance:
                self._state = State.HEADING
                return self._emit(0.0, self._turn(error), cross_track, remaining, "at the goal: turning to its heading")
        self._state = State.REACHED
        return FollowCommand(0.0, 0.0, State.REACHED, cross_track, remaining, message="goal reached")

    def _turn(self, error: float) -> float:
        return math.copysign(min(self.config.turn_speed, self.config.turn_gain * abs(error)), error)

    def _emit(
        self, v: float, w: float, cross_track: float, remaining: float, message: str, replan: bool = False
    ) -> FollowCommand:
        v, w = self._drive.saturate(v, w)
        return FollowCommand(v, w, self._state, cross_track, remaining, replan, message)

    @staticmethod
    def _halt(state: State, cross_track: float, remaining: float, replan: bool, message: str) -> FollowCommand:
        return FollowCommand(0.0, 0.0, state, cross_track, remaining, replan, message)


@dataclass
class _Escape:
    sign: float
    """+1 turns left (counter-clockwise), -1 right: away from the grazed return."""
    theta: float
    """heading when the escape began."""
    x: float
    y: float
    """the grazed return, in the path's frame."""
    driving: bool = False
    start_x: float = 0.0
    start_y: float = 0.0
    """where the drive away began."""


def _returns(scan: ScanData | None, lidar_x: float) -> np.ndarray | str:
    """The scan's returns (N, 2) in the robot frame, or why the scan is unusable; none without a scan."""
    if scan is None:
        return np.zeros((0, 2))
    try:
        ranges = np.asarray(scan.ranges, dtype=float)
        angle_min, increment = float(scan.angle_min), float(scan.angle_increment)
        range_min, range_max = float(scan.range_min), float(scan.range_max)
    except (TypeError, ValueError) as error:
        return f"unreadable scan ({error}): stopping"
    if ranges.ndim != 1 or ranges.size == 0:
        return f"scan ranges must be a non-empty list, got shape {ranges.shape}: stopping"
    if not (math.isfinite(angle_min) and math.isfinite(increment) and math.isfinite(range_min)):
        return "scan with non-finite angle_min, angle_increment or range_min: stopping"
    ranges = np.where(ranges == -np.inf, range_min, ranges)  # REP 117: closer than range_min
    valid = (ranges >= range_min) & (ranges <= range_max)  # NaN, +inf and out of range drop out
    angles = angle_min + increment * np.flatnonzero(valid)
    r = ranges[valid]
    return np.stack([lidar_x + r * np.cos(angles), r * np.sin(angles)], axis=1)
