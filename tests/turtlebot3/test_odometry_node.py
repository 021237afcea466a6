"""The odometry node end to end: as a process started like `ros2 run`, and in-process through its lifecycle."""

import math

import pytest
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from support.ros import spin_for, spin_until
from transforms3d.euler import euler2quat

from amr_turtlebot3.odometry_node import OdometryNode
from amr_util.geometry import wrap_angle

QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
DT = 0.05


def odom_message(t: float, x: float, y: float, yaw: float) -> Odometry:
    message = Odometry()
    message.header.frame_id = "odom"
    message.child_frame_id = "base_footprint"
    message.header.stamp.sec = int(t)
    message.header.stamp.nanosec = int(round((t - int(t)) * 1e9))
    message.pose.pose.position.x = x
    message.pose.pose.position.y = y
    w, qx, qy, qz = euler2quat(0.0, 0.0, yaw)
    message.pose.pose.orientation.w, message.pose.pose.orientation.x = w, qx
    message.pose.pose.orientation.y, message.pose.pose.orientation.z = qy, qz
    return message


def trajectory(v: float, w: float, steps: int, start_yaw: float = 0.0, t0: float = 100.0):
    """Poses of a unicycle integrated exactly along an arc (or a line when w == 0)."""
    x = y = 0.0
    yaw = start_yaw
    poses = []
    for k in range(steps):
        poses.append((t0 + k * DT, x, y, wrap_angle(yaw)))
        if w == 0.0:
            x += v * DT * math.cos(yaw)
            y += v * DT * math.sin(yaw)
        else:
            x += v / w * (math.sin(yaw + w * DT) - math.sin(yaw))
            y -= v / w * (math.cos(yaw + w * DT) - math.cos(yaw))
        yaw += w * DT
    return poses


def expected_twist(v: float, w: float) -> tuple[float, float]:
    chord = 1.0 if w == 0.0 else math.sin(w * DT / 2) / (w * DT / 2)
    return v * chord, w


class StreamProbe(Node):
    """Publishes /odom and collects /odometry."""

    def __init__(self, context):
        super().__init__("odometry_probe", context=context)
        self.publisher = self.create_publisher(Odometry, "odom", QOS)
        self.received: list[Odometry] = []
        self.create_subscription(Odometry, "odometry", self.received.append, QOS)


CASES = {
    "straight": (0.2, 0.0, 0.3),
    "arc": (0.15, 0.8, 0.0),
    "spin": (0.0, -2.0, 1.0),
    "wrap": (0.1, 0.5, math.pi - 0.1),  # crosses +pi -> -pi within the stream
}


def check_stream(received: list[Odometry], poses, v: float, w: float) -> None:
    assert len(received) == len(poses)
    assert received[0].twist.twist.linear.x == 0.0 and received[0].twist.twist.angular.z == 0.0
    want_v, want_w = expected_twist(v, w)
    for message, pose in zip(received[1:], poses[1:], strict=True):
        assert message.pose.pose.position.x == pytest.approx(pose[1])
        assert message.header.frame_id == "odom"
        assert message.twist.twist.linear.x == pytest.approx(want_v, abs=1e-6)
        assert message.twist.twist.angular.z == pytest.approx(want_w, abs=1e-6)


def test_process_started_like_ros2_run_derives_twist(ros_context, executor, node_process):
    # a deep queue: under load the node may lag the 200 Hz test stream, and KEEP_LAST would drop
    node_process("amr_turtlebot3", "odometry_node", "-p", "autostart:=true", "-p", "qos_depth:=100")
    probe = StreamProbe(ros_context)
    executor.add_node(probe)
    assert spin_until(
        executor,
        lambda: "odometry_node" in probe.get_node_names() and probe.publisher.get_subscription_count() > 0,
        timeout=15.0,
    ), "node never appeared"
    # one stream per case, each separated by a stamp jump backwards that the node must drop
    for t0, (name, (v, w, yaw0)) in zip((100.0, 200.0, 300.0, 400.0), CASES.items(), strict=True):
        probe.received.clear()
        poses = trajectory(v, w, 40, yaw0, t0)
        for pose in poses:  # paced, so the stream does not outrun the process
            probe.publisher.publish(odom_message(*pose))
            spin_for(executor, 0.005)
        assert spin_until(executor, lambda poses=poses: len(probe.received) >= len(poses) - 1, timeout=5.0), name
        spin_for(executor, 0.2)
        # the first sample of a new stream is differentiated against the previous stream's last one
        check_stream([Odometry()] + probe.received[1:], poses, v, w)
    if "wrap" in CASES:
        yaws = [pose[3] for pose in trajectory(*CASES["wrap"][:2], 40, CASES["wrap"][2])]
        assert max(yaws) > 3.0 and min(yaws) < -3.0, "the wrap case must cross +-pi"


def test_lifecycle_and_bad_input_in_process(ros_context, executor):
    node = OdometryNode(context=ros_context)
    probe = StreamProbe(ros_context)
    executor.add_node(node)
    executor.add_node(probe)
    client = probe.create_client(ChangeState, "odometry_node/change_state")
    state_client = probe.create_client(GetState, "odometry_node/get_state")
    assert client.wait_for_service(timeout_sec=5.0)

    def call(c, request):
        future = c.call_async(request)
        executor.spin_until_future_complete(future, timeout_sec=5.0)
        return future.result()

    def change(transition_id):
        return call(client, ChangeState.Request(transition=Transition(id=transition_id))).success

    assert not change(Transition.TRANSITION_ACTIVATE), "activate from unconfigured must be refused"
    assert call(state_client, GetState.Request()).current_state.label == "unconfigured"
    assert change(Transition.TRANSITION_CONFIGURE)
    assert not change(Transition.TRANSITION_CONFIGURE)
    assert change(Transition.TRANSITION_ACTIVATE)

    spin_until(executor, lambda: probe.publisher.get_subscription_count() > 0, timeout=5.0)
    stream = [
        odom_message(1.0, 0.0, 0.0, 0.0),
        odom_message(1.0, 9.0, 0.0, 0.0),  # repeated stamp
        odom_message(0.5, 9.0, 0.0, 0.0),
        odom_message(1.1, math.nan, 0.0, 0.0),  # older, NaN
        odom_message(1.1, 0.01, 0.0, 0.0),
    ]
    for message in stream:
        probe.publisher.publish(message)
    assert spin_until(executor, lambda: len(probe.received) >= 2, timeout=5.0)
    spin_for(executor, 0.3)
    assert len(probe.received) == 2
    assert probe.received[1].twist.twist.linear.x == pytest.approx(0.1)

    assert change(Transition.TRANSITION_DEACTIVATE)
    probe.publisher.publish(odom_message(2.0, 0.0, 0.0, 0.0))
    spin_for(executor, 0.3)
    assert len(probe.received) == 2, "an inactive node must not publish"
    assert change(Transition.TRANSITION_CLEANUP)
