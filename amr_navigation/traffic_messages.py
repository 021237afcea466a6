"""amr_navigation.traffic_board.TrafficPost <-> amr_interfaces/TrafficPost (the fleet's /traffic topic), and the
navigator's speed limit message (amr_interfaces/SpeedLimit).

`post_message` writes a post (refusing one that is not finite: no NaN is published); `post_from_message` reads
one back, field for field, and raises `PostError` naming what is wrong with a post that is garbage (an empty or
over-long name, a pose or path point that is not finite, a path longer than MAX_PATH_POINTS, a priority below 0).
The navigator node drops and logs such a post from another robot; it never raises in its callback.

A posted path is the rules' path resampled every POST_SPACING m (hundreds of points for a long way): every post
goes to every other navigator, and each point is a geometry_msgs/Point built, serialized and rebuilt in Python.
The navigator node posts it thinned (`post_message(..., tolerance=POST_TOLERANCE)`: `thin_path` keeps the points
that bend it by more than that) and reads it filled (`post_from_message(..., spacing=POST_SPACING)`: `fill_path`
cuts each segment into equal parts no longer than that): what a receiver's rules get lies within POST_TOLERANCE of
what the sender's rules posted, both ways, with the same spacing (on a straight run the same points).
"""

from __future__ import annotations

import math
from operator import attrgetter

import numba
import numpy as np
from builtin_interfaces.msg import Time as TimeMessage
from geometry_msgs.msg import Point

from amr_interfaces.msg import SpeedLimit
from amr_interfaces.msg import TrafficPost as TrafficPostMessage
from amr_navigation.traffic_board import TrafficPost

TRAFFIC_TOPIC = "/traffic"
"""the fleet's board: absolute, shared by every robot's navigator (each publishes its post, reads everyone's)."""
MAX_PATH_POINTS = 5000
"""a posted path longer than this is refused (0.05 m spacing: 250 m of path)."""
MAX_NAME = 256
POST_SPACING = 0.05
"""m: the largest gap between the points of a path a navigator reads from /traffic (the rules post their path
resampled this far apart: Traffic.advise)."""
POST_TOLERANCE = 0.002
"""m: a path posted on /traffic keeps the points farther than this from the chord between the points kept around
them (a tenth of the map's 0.025 m cells)."""


class PostError(ValueError):
    """A traffic post that cannot be used (the reason names the field and the value)."""


def post_message(
    post: TrafficPost, stamp: TimeMessage, frame_id: str = "map", tolerance: float = 0.0
) -> TrafficPostMessage:
    """The message of `post`, stamped `stamp` (the node clock); PostError for a post that is not finite. With a
    `tolerance` (m) > 0 its path is thinned (thin_path)."""
    _check_name(post.name, "name")
    message = TrafficPostMessage(
        name=post.name,
        priority=int(post.priority),
        blocked_by=post.blocked_by,
        yielding_to=list(post.yielding_to),
        passive=bool(post.passive),
        cannot_yield=bool(post.cannot_yield),
    )
    message.header.stamp, message.header.frame_id = stamp, frame_id
    if post.pose is not None:
        if len(post.pose) != 3 or not all(math.isfinite(float(v)) for v in post.pose):
            raise PostError(f"{post.name}: pose {tuple(post.pose)!r} is not three finite numbers")
        message.has_pose = True
        message.pose.x, message.pose.y, message.pose.theta = (float(v) for v in post.pose)
    if post.path is not None:
        path = _points(post.path, post.name)
        if tolerance > 0.0:
            path = thin_path(path, tolerance)
        message.has_path = True
        message.path = [Point(x=x, y=y) for x, y in path.tolist()]
    return message


def post_from_message(message: TrafficPostMessage, spacing: float | None = None) -> TrafficPost:
    """The post in `message`; PostError naming the field for a malformed one. With a `spacing` (m) its path is
    filled (fill_path): no two points farther apart (PostError if that makes it longer than MAX_PATH_POINTS)."""
    name = message.name
    _check_name(name, "name")
    if message.priority < 0:
        raise PostError(f"{name}: priority {message.priority} is negative")
    if message.blocked_by:
        _check_name(message.blocked_by, "blocked_by")
    for other in message.yielding_to:
        _check_name(other, "yielding_to")
    pose = None
    if message.has_pose:
        pose = (message.pose.x, message.pose.y, message.pose.theta)
        if not all(math.isfinite(v) for v in pose):
            raise PostError(f"{name}: pose {pose!r} is not finite")
    path = None
    if message.has_path:
        if len(message.path) > MAX_PATH_POINTS:
            raise PostError(f"{name}: path of {len(message.path)} points (at most {MAX_PATH_POINTS})")
        path = _points(np.array(list(map(_XY, message.path)), dtype=float).reshape(-1, 2), name)
        if spacing is not None:
            path = fill_path(path, spacing, name)
    return TrafficPost(
        name,
        int(message.priority),
        pose,
        path,
        message.blocked_by,
        tuple(message.yielding_to),
        bool(message.passive),
        bool(message.cannot_yield),
    )


def speed_limit_message(limit: float | None, stamp: TimeMessage, frame_id: str = "map") -> SpeedLimit:
    """The cap `limit` (m/s; None: no cap) for the observation of `stamp`; a NaN or negative cap is a stop."""
    message = SpeedLimit()
    message.header.stamp, message.header.frame_id = stamp, frame_id
    if limit is not None:
        message.limited = True
        message.speed = float(limit) if limit > 0.0 else 0.0  # NaN compares false: stop, never published
    return message


def thin_path(path: np.ndarray, tolerance: float = POST_TOLERANCE) -> np.ndarray:
    """The points of `path` (N, 2) that Douglas-Peucker keeps at `tolerance` m (the first, the last, and every
    point farther than `tolerance` from the segment between the points kept around it), and the last but one (a
    resampled path's last gap is the remainder: so fill_path gives a straight run its own points back). Every point
    dropped lies within `tolerance` of the thinned path, and every point of the thinned path within `tolerance` of
    `path`."""
    path = np.ascontiguousarray(path, dtype=float).reshape(-1, 2)
    if len(path) < 3:
        return path
    kept = _kept(path, float(tolerance))
    kept[-2] = True
    return path[kept]


def fill_path(path: np.ndarray, spacing: float = POST_SPACING, name: str = "path") -> np.ndarray:
    """`path` (N, 2) with each segment longer than `spacing` m cut into the fewest equal parts no longer than it
    (the points of `path` kept; a thinned straight run gets its points back). PostError, naming `name`, if that
    makes more than MAX_PATH_POINTS points."""
    path = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(path) < 2:
        return path
    segments = np.diff(path, axis=0)
    parts = np.maximum(1, np.ceil(np.hypot(segments[:, 0], segments[:, 1]) / spacing - 1e-9)).astype(np.int64)
    count = int(parts.sum()) + 1
    if count > MAX_PATH_POINTS:
        raise PostError(f"{name}: path of {count} points every {spacing} m (at most {MAX_PATH_POINTS})")
    if count == len(path):
        return path
    step = np.repeat(segments / parts[:, None], parts, axis=0)
    index = np.arange(count - 1) - np.repeat(np.cumsum(parts) - parts, parts)
    return np.vstack([np.repeat(path[:-1], parts, axis=0) + index[:, None] * step, path[-1:]])


_XY = attrgetter("x", "y")


@numba.njit(cache=True, error_model="numpy")
def _kept(path, tolerance):  # pragma: no cover - compiled
    """Douglas-Peucker's mask of the points of `path` (N >= 2, 2) kept at `tolerance` (distances to segments)."""
    n = len(path)
    keep = np.zeros(n, dtype=np.bool_)
    keep[0] = keep[n - 1] = True
    stack = np.empty((n, 2), dtype=np.int64)
    stack[0, 0], stack[0, 1] = 0, n - 1
    top = 1
    while top > 0:
        top -= 1
        first, last = stack[top, 0], stack[top, 1]
        ax, ay = path[first, 0], path[first, 1]
        dx, dy = path[last, 0] - ax, path[last, 1] - ay
        length2 = dx * dx + dy * dy
        worst, farthest = tolerance, -1
        for k in range(first + 1, last):
            px, py = path[k, 0] - ax, path[k, 1] - ay
            t = 0.0
            if length2 > 0.0:
                t = min(1.0, max(0.0, (px * dx + py * dy) / length2))
            ex, ey = px - t * dx, py - t * dy
            distance = math.sqrt(ex * ex + ey * ey)
            if distance > worst:
                worst, farthest = distance, k
        if farthest >= 0:
            keep[farthest] = True
            stack[top, 0], stack[top, 1] = first, farthest
            stack[top + 1, 0], stack[top + 1, 1] = farthest, last
            top += 2
    return keep


def _points(points, name: str) -> np.ndarray:
    array = np.asarray(points, dtype=float)
    if array.ndim != 2 or array.shape[1] != 2:
        raise PostError(f"{name}: path of shape {array.shape} is not (N, 2)")
    if len(array) > MAX_PATH_POINTS:
        raise PostError(f"{name}: path of {len(array)} points (at most {MAX_PATH_POINTS})")
    if not np.isfinite(array).all():
        raise PostError(f"{name}: path has a point that is not finite")
    return array


def _check_name(name: str, field: str) -> None:
    if not name or len(name) > MAX_NAME or not name.isprintable():
        raise PostError(f"{field} {name[:40]!r} is not a robot name (1-{MAX_NAME} printable characters)")
