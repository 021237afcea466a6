"""amr_util.executors.NodeSpinners: every composed node's clock fed by one /clock subscription (share_clock)."""

from __future__ import annotations

import time

import rclpy
from builtin_interfaces.msg import Time
from rclpy.clock import ROSClock
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Empty

from amr_util.executors import CLOCK_NODE, NodeSpinners, SharedTimeSource


def sim_time_node(context, name: str, namespace: str = ""):
    return rclpy.create_node(
        name, namespace=namespace, context=context, parameter_overrides=[Parameter("use_sim_time", value=True)]
    )


def clock_subscriptions(node) -> int:
    return sum(1 for subscription in node.subscriptions if subscription.topic_name == "/clock")


def wait_for(condition, timeout: float = 10.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(0.02)
    return condition()


def test_nodes_share_one_clock_subscription(ros_context):
    spinners = NodeSpinners(ros_context)
    nodes = [
        sim_time_node(ros_context, "simulator"),
        sim_time_node(ros_context, "map_server"),
        sim_time_node(ros_context, "navigator", "/r1"),
        sim_time_node(ros_context, "filter", "/r1"),
        sim_time_node(ros_context, "navigator", "/r2"),
    ]
    wall = rclpy.create_node("wall_time_node", context=ros_context)
    heard: dict[str, int] = {}
    for node in nodes:
        key = node.get_fully_qualified_name()
        node.create_subscription(Empty, "/tick", lambda _, key=key: heard.__setitem__(key, heard.get(key, 0) + 1), 10)
    try:
        for node in [*nodes, wall]:
            spinners.add_node(node)
        assert [clock_subscriptions(node) for node in [*nodes, wall]] == [0] * 6
        assert not wall.get_clock().ros_time_is_active

        source = rclpy.create_node("source", context=ros_context)
        clock = source.create_publisher(Clock, "/clock", 10)
        tick = source.create_publisher(Empty, "/tick", 10)
        stamp = Time(sec=12, nanosec=500_000_000)

        def all_at_stamp() -> bool:
            clock.publish(Clock(clock=stamp))
            tick.publish(Empty())
            return all(node.get_clock().now().nanoseconds == 12_500_000_000 for node in nodes)

        assert wait_for(all_at_stamp), [node.get_clock().now() for node in nodes]
        assert wait_for(lambda: len(heard) == len(nodes)), heard  # every node still spins
        assert wall.get_clock().now().nanoseconds > 1e18  # wall time untouched
        assert spinners._clock[0].get_name() == CLOCK_NODE
    finally:
        spinners.shutdown()
        for node in [*nodes, wall]:
            node.destroy_node()
    spinners.shutdown()  # twice is fine


def test_without_share_clock_each_node_keeps_its_subscription(ros_context):
    spinners = NodeSpinners(ros_context, share_clock=False)
    node = sim_time_node(ros_context, "navigator", "/r1")
    try:
        spinners.add_node(node)
        assert clock_subscriptions(node) == 1
    finally:
        spinners.shutdown()
        node.destroy_node()


def test_a_clock_attached_while_the_clocks_are_updated():
    """A node added (its clock attached) from another thread while a /clock message is handled: rclpy's own loop
    over the set of clocks raises "Set changed size during iteration"; the shared source's does not, and the new
    clock gets the next message's time."""
    source = SharedTimeSource()
    source.ros_time_is_active = True
    late = ROSClock()

    class Attacher:  # stands for the other thread: attaches a clock in the middle of the loop
        def set_ros_time_override(self, time) -> None:
            if late not in source._associated_clocks:
                source.attach_clock(late)

    source._associated_clocks.add(Attacher())
    first = ROSClock()
    source.attach_clock(first)
    source.clock_callback(Clock(clock=Time(sec=3)))
    source.clock_callback(Clock(clock=Time(sec=4)))
    assert first.now().nanoseconds == late.now().nanoseconds == 4_000_000_000
