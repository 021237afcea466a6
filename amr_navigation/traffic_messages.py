"""amr_navigation.traffic_board.TrafficPost <-> amr_interfaces/TrafficPost (the fleet's /traffic topic), and the
navigator's speed limit message (amr_interfaces/SpeedLimit).

`post_message` writes a post (refusing one that is not finite: no NaN is published); `post_from_message` reads
one back, field for field, and raises `PostError` naming what is wrong with a post that is garbage (an empty or
over-long name, a pose or path point that is not finite, a path longer than MAX_PATH_POINTS, a priority below 0).
The navigator node drops and logs such a post from another robot; it never raises in its callback.
"""

from __future__ import annotations

import math

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


class PostError(ValueError):
    """A traffic post that cannot be used (the reason names the field and the value)."""


def post_message(post: TrafficPost, stamp: TimeMessage, frame_id: str = "map") -> TrafficPostMessage:
    """The message of `post`, stamped `stamp` (the node clock); PostError for a post that is not finite."""
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
        message.has_path = True
        message.path = [Point(x=float(x), y=float(y)) for x, y in path]
    return message


def post_from_message(message: TrafficPostMessage) -> TrafficPost:
    """The post in `message`; PostError naming the field for a malformed one."""
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
        path = _points(np.array([(p.x, p.y) for p in message.path], dtype=float).reshape(-1, 2), name)
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
