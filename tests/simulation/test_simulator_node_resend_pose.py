"""lockstep_pose_wait with a resent observation: one whose /pose came is not waited for again.

A localizer drops a repeated stamp (amr_util.sync), so a /pose for an observation sent again never comes twice. When
the /cmd_vel is slow (a navigator planning, a controller's first command compiling its kernels) the simulator sends
the observation again after lockstep_resend_period; the step must still go as soon as the /cmd_vel comes, not after
lockstep_pose_wait (ros_episode's episodes wait 20 s)."""

from __future__ import annotations

from geometry_msgs.msg import TwistStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from support.ros import spin_until

from amr_interfaces.msg import LocalizedPose
from amr_simulation.simulator_node import SimulatorNode

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


class SlowDriver(Node):
    """A localizer that answers each observation's stamp once, at once, and a driver that answers when told."""

    def __init__(self, context) -> None:
        super().__init__("resend_pose_probe", context=context)
        self.observations: list[Odometry] = []
        self.cmd_vel = self.create_publisher(TwistStamped, "cmd_vel", RELIABLE)
        self.pose = self.create_publisher(LocalizedPose, "pose", RELIABLE)
        self.create_subscription(Odometry, "odometry", self._on_odometry, RELIABLE)
        self.answered: set[int] = set()

    def _on_odometry(self, message: Odometry) -> None:
        self.observations.append(message)
        stamp = _ns(message.header.stamp)
        if stamp not in self.answered:  # as a synchronizer: a repeated stamp is dropped
            self.answered.add(stamp)
            estimate = LocalizedPose()
            estimate.header.stamp, estimate.header.frame_id = message.header.stamp, "map"
            estimate.pose.pose.orientation.w = 1.0
            self.pose.publish(estimate)

    def drive(self) -> None:
        command = TwistStamped()
        command.header.stamp = self.observations[-1].header.stamp
        command.twist.linear.x = 0.1
        self.cmd_vel.publish(command)

    def stamps(self) -> list[int]:
        return sorted({_ns(message.header.stamp) for message in self.observations})


def _ns(stamp) -> int:
    return stamp.sec * 10**9 + stamp.nanosec


def test_a_resent_observation_whose_pose_came_steps_as_soon_as_its_command_comes(ros_context, executor):
    probe = SlowDriver(ros_context)
    executor.add_node(probe)
    simulator = SimulatorNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("lockstep_resend_period", value=0.3),
            Parameter("enable_localization", value=True),
            Parameter("lockstep_pose_wait", value=30.0),
        ],
    )
    executor.add_node(simulator)
    assert simulator.try_transition(Transition.TRANSITION_CONFIGURE)
    assert spin_until(
        executor,
        lambda: simulator.count_subscribers("odometry") and probe.count_subscribers("pose"),
        5.0,
    )
    assert simulator.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: len(probe.observations) >= 3, 10.0), "the observation was not sent again"
    assert len(probe.stamps()) == 1, "no step without a /cmd_vel"
    probe.drive()  # the /cmd_vel comes late; its /pose came before the first resend
    assert spin_until(executor, lambda: len(probe.stamps()) >= 2, 5.0), (
        "the step waited for a /pose of the resent observation, which the localizer never sends twice"
    )
    for _ in range(3):  # and the loop goes on, a /pose and a /cmd_vel per observation
        count = len(probe.stamps())
        probe.drive()
        assert spin_until(executor, lambda count=count: len(probe.stamps()) > count, 5.0)
