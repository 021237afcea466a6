"""Lockstep start-up: an observation published before anyone listened is sent again."""

from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from support.ros import spin_for

from amr_simulation.simulator_node import SimulatorNode


def late_listener(ros_context, executor, period: float) -> list[Odometry]:
    simulator = SimulatorNode(
        context=ros_context, parameter_overrides=[Parameter("lockstep_resend_period", value=period)]
    )
    executor.add_node(simulator)
    assert simulator.try_transition(Transition.TRANSITION_CONFIGURE)
    assert simulator.try_transition(Transition.TRANSITION_ACTIVATE)  # the first observation goes out now
    listener = Node("late_listener", context=ros_context)
    received: list[Odometry] = []
    listener.create_subscription(Odometry, "odometry", received.append, 10)
    executor.add_node(listener)
    spin_for(executor, 2.5)
    return received


def test_a_missed_first_observation_is_published_again(ros_context, executor):
    received = late_listener(ros_context, executor, 0.5)
    assert received, "nobody listening at activation, and nothing sent since: the loop would never start"
    assert all(m.header.stamp == received[0].header.stamp for m in received), "a resend must not advance time"


def test_resending_can_be_switched_off(ros_context, executor):
    assert late_listener(ros_context, executor, 0.0) == []
