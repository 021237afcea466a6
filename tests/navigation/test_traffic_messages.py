"""The traffic rules' messages (amr_navigation.traffic_messages): a TrafficPost through amr_interfaces/TrafficPost
and back is the same post; a post that is not finite is never published; a malformed one is refused naming the
field; the speed limit message never carries a NaN."""

from __future__ import annotations

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point

from amr_interfaces.msg import TrafficPost as TrafficPostMessage
from amr_navigation.traffic_board import TrafficPost
from amr_navigation.traffic_messages import (
    MAX_PATH_POINTS,
    PostError,
    post_from_message,
    post_message,
    speed_limit_message,
)

STAMP = Time(sec=12, nanosec=500)


def same(a: TrafficPost, b: TrafficPost) -> bool:
    paths_equal = (a.path is None and b.path is None) or (
        a.path is not None and b.path is not None and np.array_equal(np.asarray(a.path), np.asarray(b.path))
    )
    return paths_equal and (a.name, a.priority, a.pose, a.blocked_by, a.yielding_to, a.passive, a.cannot_yield) == (
        b.name,
        b.priority,
        b.pose,
        b.blocked_by,
        b.yielding_to,
        b.passive,
        b.cannot_yield,
    )


@pytest.mark.parametrize(
    "post",
    [
        TrafficPost(
            "r2",
            1,
            (0.5, -0.25, 3.0),
            np.array([[0.5, -0.25], [0.75, -0.25], [1.0, 0.0]]),
            "r1",
            ("r1", "r3"),
            True,
            False,
        ),
        TrafficPost("r1", 0),  # exploring: no pose, no path
        TrafficPost("robot_7", 6, (1.0, 2.0, -1.5), None, "", (), False, True),
        TrafficPost("r3", 2, (0.0, 0.0, 0.0), np.zeros((0, 2))),  # an empty path is not no path
    ],
)
def test_a_post_goes_through_the_message_and_back_unchanged(post):
    message = post_message(post, STAMP, "map")
    assert message.header.stamp == STAMP and message.header.frame_id == "map"
    back = post_from_message(message)
    assert same(back, post), (back, post)
    assert (back.path is None) == (post.path is None)


@pytest.mark.parametrize(
    "post, field",
    [
        (TrafficPost("r1", 0, (math.nan, 0.0, 0.0)), "pose"),
        (TrafficPost("r1", 0, (0.0, 0.0, math.inf)), "pose"),
        (TrafficPost("r1", 0, (0.0, 0.0, 0.0), np.array([[0.0, 0.0], [math.nan, 1.0]])), "path"),
        (TrafficPost("", 0), "name"),
    ],
)
def test_a_post_that_is_not_finite_is_never_published(post, field):
    with pytest.raises(PostError, match=field):
        post_message(post, STAMP)


def garbage(**changes) -> TrafficPostMessage:
    message = post_message(TrafficPost("r2", 1, (0.0, 0.0, 0.0), np.array([[0.0, 0.0], [1.0, 0.0]])), STAMP)
    for key, value in changes.items():
        setattr(message, key, value)
    return message


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"name": ""}, "name"),
        ({"name": "x" * 300}, "name"),
        ({"priority": -1}, "priority"),
        ({"blocked_by": "\x00"}, "blocked_by"),
        ({"yielding_to": ["r1", ""]}, "yielding_to"),
        ({"path": [Point(x=0.0, y=math.nan)]}, "path"),
        ({"path": [Point(x=0.0, y=0.0)] * (MAX_PATH_POINTS + 1)}, "path"),
    ],
)
def test_a_malformed_post_is_refused_naming_the_field(changes, field):
    with pytest.raises(PostError, match=field):
        post_from_message(garbage(**changes))


def test_a_pose_that_is_not_finite_is_refused():
    message = garbage()
    message.pose.x = math.nan
    with pytest.raises(PostError, match="pose"):
        post_from_message(message)
    message.has_pose = False  # not localized: the pose field is not read
    assert post_from_message(message).pose is None


def test_the_speed_limit_message_caps_stops_and_lifts_and_never_carries_nan():
    assert not speed_limit_message(None, STAMP).limited
    capped = speed_limit_message(0.07, STAMP)
    assert capped.limited and capped.speed == pytest.approx(0.07) and capped.header.stamp == STAMP
    for stop in (0.0, -1.0, math.nan):
        message = speed_limit_message(stop, STAMP)
        assert message.limited and message.speed == 0.0
