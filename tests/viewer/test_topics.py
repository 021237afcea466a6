"""topics.leaf_topic: which topic the viewer reads each of a robot's layers from, as the graph grows."""

from __future__ import annotations

from amr_viewer.topics import POSE_GRAPH, leaf_topic


def test_the_root_robot_reads_its_own_names():
    assert leaf_topic("", "scan", set()) == "/scan"
    assert leaf_topic("", "tf", set()) == "/tf"
    assert leaf_topic("", "simulator/status", set()) == "/simulator/status"


def test_a_fleet_robot_reads_the_roots_tree_and_map_until_its_own_appear_then_keeps_them():
    assert leaf_topic("/r1", "scan", set()) == "/r1/scan"
    assert leaf_topic("/r1", "tf", {"/tf"}) == "/tf"
    assert leaf_topic("/r1", "map", {"/map"}) == "/map"
    assert leaf_topic("/r1", "tf", {"/tf", "/r1/tf"}, "/tf") == "/r1/tf"
    assert leaf_topic("/r1", "tf", {"/tf"}, "/r1/tf") == "/r1/tf", "once its own, kept"


def test_a_fleet_robots_simulator_status_is_its_namespaces_status_once_that_appears():
    assert leaf_topic("/r1", "simulator/status", set()) == "/r1/simulator/status"
    assert leaf_topic("/r1", "simulator/status", {"/r1/status"}) == "/r1/status"
    assert leaf_topic("/r1", "simulator/status", set(), "/r1/status") == "/r1/status"


def test_the_slam_graph_is_found_by_type_under_another_node_name():
    graph = {"/r1/mapper/graph": {POSE_GRAPH}, "/r1/scan": {"sensor_msgs/msg/LaserScan"}}
    assert leaf_topic("/r1", "slam/graph", graph) == "/r1/mapper/graph"
    assert leaf_topic("/r1", "slam/graph", {**graph, "/r1/slam/graph": {POSE_GRAPH}}) == "/r1/slam/graph"
    assert leaf_topic("/r1", "slam/graph", {}, "/r1/mapper/graph") == "/r1/mapper/graph", "gone: kept"
    assert leaf_topic("/r1", "slam/graph", {}) == "/r1/slam/graph"
