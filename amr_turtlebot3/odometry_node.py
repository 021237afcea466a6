"""odometry_node: /odom (pose only, as a real TurtleBot3 publishes) -> /odometry (pose + twist)."""

from __future__ import annotations

from nav_msgs.msg import Odometry
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from transforms3d.euler import quat2euler

from amr_control.managed_node import ManagedNode, run
from amr_turtlebot3.odometry import PoseDifferentiator, PoseSample, Verdict


def pose_sample(message: Odometry) -> PoseSample:
    """Stamp, position and yaw of an Odometry message (yaw through transforms3d's quat2euler)."""
    pose = message.pose.pose
    q = pose.orientation
    _, _, yaw = quat2euler((q.w, q.x, q.y, q.z))
    stamp = Time.from_msg(message.header.stamp).nanoseconds * 1e-9
    return PoseSample(stamp, pose.position.x, pose.position.y, yaw)


class OdometryNode(ManagedNode):
    """Republishes every accepted /odom message with its twist filled in."""

    def __init__(self, **kwargs) -> None:
        super().__init__("odometry_node", **kwargs)
        self.declare_parameter("input_topic", "odom")
        self.declare_parameter("output_topic", "odometry")
        self.declare_parameter("qos_depth", 10)
        self._differentiator = PoseDifferentiator()
        self._warned: set[Verdict] = set()
        self._publisher = None
        self._subscription = None

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        depth = self.get_parameter("qos_depth").value
        qos = QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)
        self._publisher = self.create_lifecycle_publisher(Odometry, self.get_parameter("output_topic").value, qos)
        self._subscription = self.create_subscription(
            Odometry, self.get_parameter("input_topic").value, self._on_odom, qos)
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._differentiator.reset()
        return super().on_activate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self.destroy_subscription(self._subscription)
        self.destroy_lifecycle_publisher(self._publisher)
        self._subscription = self._publisher = None
        return TransitionCallbackReturn.SUCCESS

    def _on_odom(self, message: Odometry) -> None:
        if self.state_label != "active":
            return
        estimate = self._differentiator.update(pose_sample(message))
        if not estimate.accepted:
            if estimate.verdict not in self._warned:
                self._warned.add(estimate.verdict)
                self.get_logger().warning(f"dropped an /odom message: {estimate.verdict.value} (warned once)")
            return
        message.twist.twist.linear.x = estimate.linear
        message.twist.twist.angular.z = estimate.angular
        self._publisher.publish(message)


def main(args=None) -> None:
    run(OdometryNode, args=args)


if __name__ == "__main__":
    main()
