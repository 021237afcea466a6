"""The navigator node's traffic rules option: off by default (nothing of it exists, a robot alone as before); on, the
posts of the others come onto its board, its own is ignored, a malformed one is dropped and logged (never raised
in the callback), a stale one is forgotten."""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time
from lifecycle_msgs.msg import Transition
from rclpy.parameter import Parameter
from support.ros import published_topics

from amr_navigation.navigator_node import NavigatorNode
from amr_navigation.traffic_board import TrafficPost
from amr_navigation.traffic_messages import post_message


def navigator(context, **parameters) -> NavigatorNode:
    node = NavigatorNode(
        context=context, namespace="/r1", parameter_overrides=[Parameter(k, value=v) for k, v in parameters.items()]
    )
    assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
    return node


def test_without_traffic_the_navigator_has_no_rules_and_no_traffic_topics(ros_context):
    node = navigator(ros_context)
    try:
        assert node.traffic is None and node.board is None
        topics = set(published_topics(node, "navigator", "/r1", expected=["/r1/path"]))
        assert "/traffic" not in topics and "/r1/speed_limit" not in topics, topics
    finally:
        node.destroy_node()


def test_posts_come_onto_the_board_and_a_garbage_one_is_dropped_not_raised(ros_context):
    node = navigator(ros_context, traffic=True, priority=3, post_timeout=2.0)
    try:
        assert node.traffic.name == "r1" and node.traffic.priority == 3
        topics = set(published_topics(node, "navigator", "/r1", expected=["/traffic", "/r1/speed_limit"]))
        assert {"/traffic", "/r1/speed_limit"} <= topics, topics
        good = TrafficPost("r2", 1, (1.0, 0.5, math.pi), np.array([[1.0, 0.5], [0.5, 0.5]]), "r1", (), False, False)
        node._on_post(post_message(good, Time(sec=10)))
        assert node.board.get("r2") is not None and node.board.get("r2").pose == (1.0, 0.5, math.pi)

        garbage = post_message(TrafficPost("r3", 2, (0.0, 0.0, 0.0)), Time(sec=10))
        garbage.pose.y = math.nan
        node._on_post(garbage)  # must not raise
        nameless = post_message(TrafficPost("r4", 3), Time(sec=10))
        nameless.name = ""
        node._on_post(nameless)
        assert node.posts_dropped == 2 and node.board.get("r3") is None

        node._on_post(post_message(TrafficPost("r1", 0, (9.0, 9.0, 0.0)), Time(sec=10)))  # its own: ignored
        assert node.board.get("r1") is None

        assert [post.name for post in node.board.others("r1")] == ["r2"]
        assert node.board.prune(11.5) == [] and node.board.get("r2") is not None
        assert node.board.prune(12.5) == ["r2"] and node.board.others("r1") == []  # gone quiet: forgotten
    finally:
        node.destroy_node()


def test_the_traffic_costmap_is_built_with_the_costmap_parameters_not_the_defaults(ros_context):
    """The rules' costmap (places aside, detours, unmapped returns) must be the planner's: the navigator takes
    the planner's costmap parameters as costmap.* (the fleet_navigation stack ties them)."""
    from amr_maps.messages import grid_message
    from amr_maps.rasterize import rasterize_world
    from amr_maps.world import load_world, resolve_world_path
    from amr_planning.costmap import Costmap, CostmapConfig

    grid = rasterize_world(load_world(resolve_world_path("fleets/crossing.yaml")), 0.025)
    node = navigator(ros_context, traffic=True, **{"costmap.robot_radius": 0.2, "costmap.safety_margin": 0.05})
    try:
        node._on_map(grid_message(grid, Time(sec=1)))
        costmap = node.core.costmap
        assert costmap.config.robot_radius == 0.2 and costmap.config.safety_margin == 0.05
        wanted = Costmap(grid, CostmapConfig(robot_radius=0.2, safety_margin=0.05))
        default = Costmap(grid, CostmapConfig())
        assert np.array_equal(costmap.lethal, wanted.lethal) and np.array_equal(costmap.inflated, wanted.inflated)
        assert costmap.lethal.sum() > default.lethal.sum(), "a wider robot has more lethal cells"
    finally:
        node.destroy_node()
