"""The log_player node: lockstep with a consumer answering each scan (and without one), a SLAM node's pace type,
realtime at the log's stamps, and configure refusing a missing or malformed log."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from support.carmen_logs import write_log
from support.ros import spin_for, spin_until
from tf2_msgs.msg import TFMessage

from amr_datasets.carmen import read_carmen
from amr_datasets.player_node import LogPlayerNode
from amr_interfaces.msg import LocalizedPose, PoseGraph
from amr_util.geometry import yaw_from_quaternion
from amr_util.qos import LATCHED
from amr_util.stamps import stamp_seconds


class Consumer(Node):
    """Records what the player publishes; answers each scan on `pose` (or a PoseGraph on `pose_graph`) with its
    stamp, unless `answer` is False."""

    def __init__(self, context, answer: bool = True, graph: bool = False) -> None:
        super().__init__("consumer", context=context)
        self.answer = answer
        self.scans: list[LaserScan] = []
        self.odometry: list[Odometry] = []
        self.truth: list[Odometry] = []
        self.clock: list[float] = []
        self.status: list[str] = []
        self.static: list[TFMessage] = []
        self.tf: list[TFMessage] = []
        self.received_at: list[float] = []
        kind, topic = (PoseGraph, "pose_graph") if graph else (LocalizedPose, "pose")
        self.kind = kind
        self.pose = self.create_publisher(kind, topic, 10)
        self.create_subscription(LaserScan, "scan", self._on_scan, qos_profile_sensor_data)
        self.create_subscription(Odometry, "odometry", self.odometry.append, 100)
        self.create_subscription(Odometry, "ground_truth", self.truth.append, 100)
        self.create_subscription(Clock, "/clock", lambda m: self.clock.append(stamp_seconds(m.clock)), 100)
        self.create_subscription(String, "log_player/status", lambda m: self.status.append(m.data), LATCHED)
        self.create_subscription(TFMessage, "tf_static", self.static.append, LATCHED)
        self.create_subscription(TFMessage, "tf", self.tf.append, 100)

    def _on_scan(self, message: LaserScan) -> None:
        self.scans.append(message)
        self.received_at.append(time.monotonic())
        if self.answer:
            answer = self.kind()
            answer.header.stamp = message.header.stamp
            self.pose.publish(answer)


class Warnings:
    """What a node logs at warning level (still logged)."""

    def __init__(self, node: Node) -> None:
        self.lines: list[str] = []
        self._logger = node._logger
        node._logger = self

    def __getattr__(self, name):
        return getattr(self._logger, name)

    def warning(self, message, **kwargs):
        self.lines.append(message)
        return self._logger.warning(message, **kwargs)

    def error(self, message, **kwargs):
        self.lines.append(message)
        return self._logger.error(message, **kwargs)


def player(context, **params) -> LogPlayerNode:
    return LogPlayerNode(context=context, parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])


def start(executor, node: LogPlayerNode, consumer: Consumer) -> None:
    executor.add_node(node)
    executor.add_node(consumer)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert spin_until(executor, lambda: node.count_subscribers("scan") and consumer.count_publishers("scan"), 5.0)
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)


def test_lockstep_plays_every_scan_once_in_order_as_the_consumer_answers(executor, tmp_path):
    path = tmp_path / "small.log"
    write_log(path, count=30, period=0.5)
    log = read_carmen(path)
    node = player(executor.context, log=str(path), seed=3)
    consumer = Consumer(executor.context)
    start(executor, node, consumer)
    assert spin_until(executor, lambda: "done" in consumer.status and len(consumer.truth) == 30, 20.0), (
        len(consumer.scans),
        consumer.status,
    )
    assert node.timeouts == 0 and node.state_label == "active" and consumer.status[-1] == "done"
    stamps = [stamp_seconds(m.header.stamp) for m in consumer.scans]
    assert stamps == pytest.approx(log.stamps()) and len(consumer.odometry) == 30
    assert consumer.clock[-1] == pytest.approx(log.stamps()[-1])
    scan = consumer.scans[4]
    assert scan.header.frame_id == "laser" and len(scan.ranges) == 181
    assert scan.angle_min == pytest.approx(-math.pi / 2) and scan.angle_max == pytest.approx(math.pi / 2)
    ranges = np.array(scan.ranges)
    assert not np.isnan(ranges).any() and np.isposinf(ranges).any()
    np.testing.assert_allclose(ranges[np.isfinite(ranges)], log.scans[4].scan.ranges[np.isfinite(ranges)], rtol=1e-6)
    truth = consumer.truth[7]
    assert truth.header.frame_id == "map" and truth.child_frame_id == "base_footprint"
    pose = (truth.pose.pose.position.x, truth.pose.pose.position.y, yaw_from_quaternion(truth.pose.pose.orientation))
    assert pose == pytest.approx(log.scans[7].pose, abs=1e-6)
    odometry = consumer.odometry[0]
    assert (odometry.header.frame_id, odometry.child_frame_id) == ("odom", "base_footprint")
    assert odometry.pose.pose.position.x == 0.0 and odometry.pose.pose.orientation.w == 1.0
    mount = consumer.static[-1].transforms[0]
    assert (mount.header.frame_id, mount.child_frame_id, mount.transform.rotation.w) == ("base_footprint", "laser", 1.0)
    assert consumer.tf[-1].transforms[0].child_frame_id == "base_footprint"
    spin_for(executor, 0.2)
    assert len(consumer.scans) == 30  # done: nothing more


def test_without_a_consumer_it_warns_naming_the_topic_and_goes_on(executor, tmp_path):
    path = tmp_path / "small.log"
    write_log(path, count=5)
    node = player(executor.context, log=str(path), pace_timeout=0.05)
    warnings = Warnings(node)
    consumer = Consumer(executor.context, answer=False)
    start(executor, node, consumer)
    assert spin_until(executor, lambda: "done" in consumer.status, 5.0)
    assert node.timeouts == 5 and len(consumer.scans) == 5  # the last scan waited too
    assert any("/pose" in line and "amr_interfaces/msg/LocalizedPose" in line for line in warnings.lines)


def test_a_slam_node_paces_it_with_pose_graphs_and_a_slice_is_played(executor, tmp_path):
    path = tmp_path / "small.log"
    write_log(path, count=20, stamps=False)
    node = player(
        executor.context,
        log=str(path),
        pace_type="amr_interfaces/msg/PoseGraph",
        pace_topic="pose_graph",
        start=5,
        count=6,
    )
    consumer = Consumer(executor.context, graph=True)
    start(executor, node, consumer)
    assert spin_until(executor, lambda: "done" in consumer.status, 10.0)
    assert node.timeouts == 0
    assert [stamp_seconds(m.header.stamp) for m in consumer.scans] == [5.0, 6.0, 7.0, 8.0, 9.0, 10.0]


def test_realtime_plays_at_the_logs_stamps_times_rate(executor, tmp_path):
    path = tmp_path / "small.log"
    write_log(path, count=6, period=0.2)
    node = player(executor.context, log=str(path), mode="realtime", rate=2.0)  # 0.1 s apart
    consumer = Consumer(executor.context, answer=False)
    start(executor, node, consumer)
    started = time.monotonic()  # activated: the first scan goes out now
    assert spin_until(executor, lambda: "done" in consumer.status and len(consumer.scans) == 6, 5.0)
    # 1 s of log at rate 2: the last scan 0.5 s of wall time after the first at the earliest (a loaded machine can
    # deliver the first late, so the span between receipts is no lower bound), and not much after
    assert consumer.received_at[-1] - started >= 0.4, consumer.received_at[-1] - started
    assert consumer.received_at[-1] - consumer.received_at[0] < 1.5
    assert consumer.clock == sorted(consumer.clock) and len(consumer.clock) > 6  # ticks between the scans


@pytest.mark.parametrize(
    "given, words",
    [
        ({"log": "{tmp}/missing.log"}, "missing.log: no such file"),
        ({"log": "{tmp}/bad.log"}, "bad.log:2: FLASER"),
        ({}, "log: give the path of a CARMEN log"),
        ({"log": "{tmp}/good.log", "start": 99}, "start: 99 is past the log's last scan"),
        ({"log": "{tmp}/good.log", "pace_type": "amr_interfaces/msg/NoSuchThing"}, "no such message type"),
    ],
)
def test_configure_fails_on_bad_input_saying_why(executor, tmp_path, given, words):
    write_log(tmp_path / "good.log", count=3)
    (tmp_path / "bad.log").write_text("# fine\nFLASER 181 1 2 3\n")
    params = {name: value.format(tmp=tmp_path) if isinstance(value, str) else value for name, value in given.items()}
    node = player(executor.context, **params)
    warnings = Warnings(node)
    executor.add_node(node)
    assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.state_label == "unconfigured"
    assert any(words in line for line in warnings.lines), warnings.lines
