"""odometry_node: /odom (pose only, as a real TurtleBot3 publishes) -> /odometry (pose + twist)."""

from __future__ import annotations

from nav_msgs.msg import Odometry
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.time import Time

from amr_turtlebot3.odometry import PoseDifferentiator, PoseSample, Verdict
from amr_util.geometry import yaw_from_quaternion
from amr_util.managed_node import ManagedNode, run, topic_name_problem
from amr_util.parameter_spec import ParameterSpec
from amr_util.qos import reliable

PARAMETERS = (
    ParameterSpec(
        "input_topic", "odom", "nav_msgs/Odometry with pose only (a real TurtleBot3's /odom)", check=topic_name_problem
    ),
    ParameterSpec(
        "output_topic",
        "odometry",
        "the same messages with the twist derived from consecutive poses",
        check=topic_name_problem,
    ),
    ParameterSpec("qos_depth", 10, "queue depth of both topics (reliable)", minimum=1, maximum=1000),
)


def pose_sample(message: Odometry) -> PoseSample:
    """Stamp, position and yaw of an Odometry message."""
    pose = message.pose.pose
    stamp = Time.from_msg(message.header.stamp).nanoseconds * 1e-9
    return PoseSample(stamp, pose.position.x, pose.position.y, yaw_from_quaternion(pose.orientation))


class OdometryNode(ManagedNode):
    """Republishes every accepted /odom message with its twist filled in."""

    def __init__(self, **kwargs) -> None:
        super().__init__("odometry_node", **kwargs)
        self.declare_specs(PARAMETERS)
        self._differentiator = PoseDifferentiator()
        self._warned: set[Verdict] = set()
        self._publisher = None
        self._subscription = None

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if problems:
            return self.fail_configure(problems)
        values = self.parameter_values()
        qos = reliable(values["qos_depth"])
        self._publisher = self.create_lifecycle_publisher(Odometry, values["output_topic"], qos)
        self._subscription = self.create_subscription(Odometry, values["input_topic"], self._on_odom, qos)
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._differentiator.reset()
        return super().on_activate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._subscription = self._publisher = None
        return super().on_cleanup(state)  # destroys what configure made

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
