"""lockstep_pose_wait: a lockstep step waits for the localizer's /pose of the last observation as well."""

from __future__ import annotations

from geometry_msgs.msg import TwistStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from support.ros import spin_for, spin_until

from amr_interfaces.msg import LocalizedPose
from amr_simulation.simulator_node import SimulatorNode

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


class DriverAndLocalizer(Node):
    """Answers every observation with a /cmd_vel at once; answers with a /pose only when the test says so."""

    def __init__(self, context) -> None:
        super().__init__("pose_wait_probe", context=context)
        self.observations: list[Odometry] = []
        self.cmd_vel = self.create_publisher(TwistStamped, "cmd_vel", RELIABLE)
        self.pose = self.create_publisher(LocalizedPose, "pose", RELIABLE)
        self.create_subscription(Odometry, "odometry", self._on_odometry, RELIABLE)
        self.answer_poses = False

    def _on_odometry(self, message: Odometry) -> None:
        self.observations.append(message)
        command = TwistStamped()
        command.header.stamp = message.header.stamp
        command.twist.linear.x = 0.1
        self.cmd_vel.publish(command)
        if self.answer_poses:
            self.answer(message.header.stamp)

    def answer(self, stamp) -> None:
        estimate = LocalizedPose()
        estimate.header.stamp, estimate.header.frame_id = stamp, "map"
        estimate.pose.pose.orientation.w = 1.0
        self.pose.publish(estimate)


def start(ros_context, executor, **parameters) -> DriverAndLocalizer:
    probe = DriverAndLocalizer(ros_context)
    executor.add_node(probe)
    simulator = SimulatorNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("lockstep_resend_period", value=0.5),
            Parameter("enable_localization", value=True),
            *(Parameter(name, value=value) for name, value in parameters.items()),
        ],
    )
    executor.add_node(simulator)
    assert simulator.try_transition(Transition.TRANSITION_CONFIGURE)
    spin_until(
        executor,
        lambda: (
            simulator.count_subscribers("odometry") > 0
            and probe.count_subscribers("pose") > 0
            and probe.count_subscribers("cmd_vel") > 0
        ),
        5.0,
    )
    assert simulator.try_transition(Transition.TRANSITION_ACTIVATE)  # the first observation goes out now
    return probe


def stamps(probe: DriverAndLocalizer) -> list[int]:
    return sorted({message.header.stamp.sec * 10**9 + message.header.stamp.nanosec for message in probe.observations})


def test_a_step_waits_for_the_pose_of_the_last_observation(ros_context, executor):
    probe = start(ros_context, executor, lockstep_pose_wait=30.0)
    assert spin_until(executor, lambda: probe.observations, 5.0), "no first observation"
    spin_for(executor, 1.5)
    assert len(stamps(probe)) == 1, "the /cmd_vel came at once, the /pose did not: no step may be taken yet"
    first = probe.observations[-1].header.stamp
    probe.answer(first)
    assert spin_until(executor, lambda: len(stamps(probe)) == 2, 5.0), "the /pose came: the step must be taken"
    spin_for(executor, 0.5)
    assert len(stamps(probe)) == 2, "one /pose answers one observation: one step"
    probe.answer_poses = True
    probe.answer(probe.observations[-1].header.stamp)
    assert spin_until(executor, lambda: len(stamps(probe)) >= 50, 20.0), "answered at once, the loop runs on"


def test_without_a_localizer_a_step_goes_once_the_wait_is_over(ros_context, executor):
    probe = start(ros_context, executor, lockstep_pose_wait=0.2)
    assert spin_until(executor, lambda: len(stamps(probe)) >= 3, 10.0), "the wait is at most 0.2 s a step"


def test_the_localizer_is_not_waited_for_by_default(ros_context, executor):
    probe = start(ros_context, executor)
    assert spin_until(executor, lambda: len(stamps(probe)) >= 50, 20.0)
