"""A path on /traffic is posted thinned and read filled (amr_navigation.traffic_messages: thin_path, fill_path,
POST_TOLERANCE, POST_SPACING): what a receiver's rules get lies within the tolerance of what the sender
posted, both ways, no two points farther apart than the spacing, a straight run the same points; and whole runs
of the traffic rules whose every post goes through the message that way decide as with the posts themselves."""

from __future__ import annotations

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from rclpy.serialization import deserialize_message, serialize_message

import amr_evaluation.fleet_navigation as fleet_navigation
from amr_interfaces.msg import TrafficPost as TrafficPostMessage
from amr_maps.world import load_world, resolve_world_path, world_from_dict
from amr_navigation.traffic_board import TrafficBoard, TrafficPost
from amr_navigation.traffic_geometry import path_ahead
from amr_navigation.traffic_messages import (
    MAX_PATH_POINTS,
    POST_SPACING,
    POST_TOLERANCE,
    PostError,
    fill_path,
    post_from_message,
    post_message,
    thin_path,
)


def wandering_path(seed: int) -> np.ndarray:
    """Straight legs and arcs (radius 0.2-2 m) 0.025 m apart, resampled every 0.05 m as the rules post a path."""
    rng = np.random.default_rng(seed)
    points, heading = [np.zeros(2)], rng.uniform(-math.pi, math.pi)
    for _ in range(10):
        for _ in range(int(rng.uniform(0.2, 2.0) / 0.025)):
            points.append(points[-1] + 0.025 * np.array([math.cos(heading), math.sin(heading)]))
        turn, radius = rng.uniform(-1.5, 1.5), rng.uniform(0.2, 2.0)
        steps = max(1, int(abs(turn) * radius / 0.025))
        for _ in range(steps):
            heading += turn / steps
            points.append(points[-1] + abs(turn) * radius / steps * np.array([math.cos(heading), math.sin(heading)]))
    return path_ahead(np.array(points), 0.0, 0.0, math.inf, spacing=POST_SPACING)


def distance_to_polyline(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """Each point's distance to the polyline (its segments)."""
    a, b = polyline[:-1][None], polyline[1:][None]
    ab, ap = b - a, points[:, None] - a
    t = np.clip((ap * ab).sum(axis=2) / np.maximum((ab * ab).sum(axis=2), 1e-300), 0.0, 1.0)
    return np.hypot(*(ap - t[..., None] * ab).transpose(2, 0, 1)).min(axis=1)


def through_ros(post: TrafficPost) -> TrafficPost:
    """`post` as a navigator node publishes it and another reads it (bytes on the wire in between)."""
    data = serialize_message(post_message(post, Time(sec=3), "map", tolerance=POST_TOLERANCE))
    return post_from_message(deserialize_message(data, TrafficPostMessage), spacing=POST_SPACING)


@pytest.mark.parametrize("seed", range(6))
def test_a_path_thinned_and_filled_stays_within_the_tolerance_both_ways(seed):
    path = wandering_path(seed)
    thinned = thin_path(path, POST_TOLERANCE)
    assert len(thinned) < len(path) / 2, (len(thinned), len(path))  # it is worth doing
    filled = fill_path(thinned, POST_SPACING)
    assert np.array_equal(filled[0], path[0]) and np.array_equal(filled[-1], path[-1])
    assert distance_to_polyline(path, filled).max() <= POST_TOLERANCE + 1e-12
    assert distance_to_polyline(filled, path).max() <= POST_TOLERANCE + 1e-12
    assert np.hypot(*np.diff(filled, axis=0).T).max() <= POST_SPACING + 1e-12
    assert abs(len(filled) - len(path)) <= 0.05 * len(path), (len(filled), len(path))
    assert set(map(tuple, thinned)) <= set(map(tuple, filled))  # the points kept are kept exactly


def test_a_straight_run_comes_back_as_the_same_points():
    path = path_ahead(np.array([[0.0, 0.0], [2.0, 1.0], [2.0, 3.0]]), 0.01, 0.0, math.inf, spacing=POST_SPACING)
    thinned = thin_path(path, POST_TOLERANCE)
    assert len(thinned) == 5  # start, the corner's two neighbours, the last two (the last gap is the remainder)
    filled = fill_path(thinned, POST_SPACING)
    assert filled.shape == path.shape and np.allclose(filled, path, rtol=0.0, atol=1e-12)


def test_a_post_through_the_wire_keeps_every_field_and_its_path_within_the_tolerance():
    path = wandering_path(7)
    post = TrafficPost("r2", 1, (0.5, -0.25, 3.0), path, "r1", ("r1", "r3"), True, False)
    message = post_message(post, Time(sec=3), "map", tolerance=POST_TOLERANCE)
    assert len(message.path) < len(path) / 2
    back = through_ros(post)
    assert (back.name, back.priority, back.pose, back.blocked_by, back.yielding_to, back.passive) == (
        post.name,
        post.priority,
        post.pose,
        post.blocked_by,
        post.yielding_to,
        post.passive,
    )
    assert distance_to_polyline(path, back.path).max() <= POST_TOLERANCE + 1e-12
    for kept in (TrafficPost("r1", 0), TrafficPost("r3", 2, (0.0, 0.0, 0.0), np.zeros((0, 2)))):
        again = through_ros(kept)
        assert again.path is None if kept.path is None else again.path.shape == (0, 2)


def test_a_path_that_fills_past_the_limit_is_refused_naming_it():
    message = post_message(TrafficPost("r2", 1, (0.0, 0.0, 0.0), np.array([[0.0, 0.0], [1.0, 0.0]])), Time())
    message.path = [Point(x=0.0, y=0.0), Point(x=POST_SPACING * MAX_PATH_POINTS, y=0.0)]
    assert len(post_from_message(message).path) == 2  # as it came
    with pytest.raises(PostError, match="r2: path of"):
        post_from_message(message, spacing=POST_SPACING)


class WireBoard(TrafficBoard):
    """The library's shared board, every post on it as another robot's node would read it from /traffic."""

    def post(self, post: TrafficPost) -> None:
        super().post(through_ros(post))


def corridor_with_pocket():
    """tests/evaluation/test_fleet_traffic_runs.py's corridor(0.8): two robots face to face, one goes aside."""
    walls = [[-2.0, -0.2, 2.0, -0.2], [-2.0, 0.2, 0.6, 0.2], [1.0, 0.2, 2.0, 0.2], [0.6, 0.2, 0.6, 0.7]]
    walls += [[1.0, 0.2, 1.0, 0.7], [-2.0, -0.2, -2.0, 0.2], [2.0, -0.2, 2.0, 0.2], [0.6, 0.7, 1.0, 0.7]]
    robots = [
        {"name": "r1", "start": [-1.7, 0.0, 0.0], "goal": [1.7, 0.0, 0.1]},
        {"name": "r2", "start": [1.7, 0.0, math.pi], "goal": [-1.7, 0.0, 0.1]},
    ]
    return world_from_dict({"name": "corridor", "wall_thickness": 0.05, "walls": walls, "robots": robots})


@pytest.mark.parametrize("world", ["corridor", "fleets/crossing.yaml"])
def test_the_rules_decide_the_same_on_posts_read_from_the_wire(monkeypatch, world):
    world = corridor_with_pocket() if world == "corridor" else load_world(resolve_world_path(world))
    plain = fleet_navigation.run_fleet(world, localization="truth", duration=60.0, seed=2)
    monkeypatch.setattr(fleet_navigation, "TrafficBoard", WireBoard)
    wire = fleet_navigation.run_fleet(world, localization="truth", duration=60.0, seed=2)
    assert plain.reached == len(world.fleet)
    for a, b in zip(plain.robots, wire.robots, strict=True):
        assert (a.reached, a.time_to_goal, a.yields, a.stops, a.events) == (
            b.reached,
            b.time_to_goal,
            b.yields,
            b.stops,
            b.events,
        ), a.name
