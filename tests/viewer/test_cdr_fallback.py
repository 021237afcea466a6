"""The viewer reads its busy topics straight from their CDR bytes (amr_viewer.cdr); bytes in another encapsulation
(XCDR2, as another middleware may send) are deserialized by rclpy instead and draw the same."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import Point, Pose, Pose2D, PoseArray, TransformStamped
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from support.xcdr import serialized
from tf2_msgs.msg import TFMessage

from amr_interfaces.msg import Frontiers, PoseGraph
from amr_viewer import cdr
from amr_viewer.viewer_node import RobotLink, ViewerNode


def yawed(message, yaw: float) -> None:
    message.z, message.w = math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def messages() -> dict:
    tf = TFMessage()
    for parent, child, x, yaw in (("map", "odom", 0.5, 0.1), ("odom", "base_footprint", 1.0, 0.3)):
        transform = TransformStamped(child_frame_id=child)
        transform.header.frame_id = parent
        transform.header.stamp.sec, transform.header.stamp.nanosec = 3, 250_000_000
        transform.transform.translation.x = x
        yawed(transform.transform.rotation, yaw)
        tf.transforms.append(transform)
    truth = Odometry(child_frame_id="base_footprint")
    truth.header.frame_id = "map"
    truth.header.stamp.sec = 3
    truth.pose.pose.position.x, truth.pose.pose.position.y = 1.6, -0.2
    yawed(truth.pose.pose.orientation, 0.4)
    particles = cdr_pose_array([(1.5, -0.1, 0.35), (1.7, -0.3, 0.45), (1.6, -0.2, -3.0)])
    graph = PoseGraph(
        poses=[Pose2D(x=0.0, y=0.0, theta=0.0), Pose2D(x=1.0, y=0.0, theta=0.5), Pose2D(x=1.0, y=1.0, theta=1.5)],
        edge_from=[0, 1, 2],
        edge_to=[1, 2, 0],
        loop_closure=[False, False, True],
    )
    graph.header.frame_id = "map"
    frontiers = Frontiers(centroids=[Point(x=2.0, y=1.0), Point(x=-1.0, y=3.0)], sizes=[12, 40], chosen=1, state="x")
    frontiers.header.frame_id = "map"
    return {
        "tf": tf,
        "ground_truth": truth,
        "particle_cloud": particles,
        "slam/graph": graph,
        "explorer/frontiers": frontiers,
    }


def cdr_pose_array(poses):
    message = PoseArray()
    message.header.frame_id = "map"
    for x, y, yaw in poses:
        pose = Pose()
        pose.position.x, pose.position.y = x, y
        yawed(pose.orientation, yaw)
        message.poses.append(pose)
    return message


@pytest.fixture
def node(ros_context):
    made = ViewerNode(context=ros_context, parameter_overrides=[Parameter("port", value=0)])
    yield made
    made.destroy_node()


def drawn(node, version: int) -> RobotLink:
    link = RobotLink(node, "", set())
    for leaf, message in messages().items():
        data = serialized(message, version)
        assert cdr.fast_path_applies(data) is (version == 1)
        link.raw[leaf].append(data)
    link.decode()
    return link


def test_bytes_the_cdr_reader_cannot_read_are_deserialized_by_rclpy_and_draw_the_same(node):
    plain, other = drawn(node, 1), drawn(node, 2)
    assert (plain.deserialized, other.deserialized) == (0, 5)
    first, second = plain.state, other.state
    assert first.robot_pose() is not None and second.robot_pose() == pytest.approx(first.robot_pose())
    assert second.truth == pytest.approx(first.truth) and first.truth.theta == pytest.approx(0.4)
    assert len(first.particles) == 3 and np.allclose(second.particles, first.particles)
    for name in ("poses", "edges"):
        assert np.allclose(getattr(second.graph, name), getattr(first.graph, name)), name
    assert first.graph.loop_closures == second.graph.loop_closures == 1
    assert np.allclose(second.frontiers.centroids, first.frontiers.centroids)
    assert second.frontiers.chosen_centroid == pytest.approx(first.frontiers.chosen_centroid) == (-1.0, 3.0)
