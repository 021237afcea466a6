"""amr_util.managed_node.ManagedNode: on simulated time its lifecycle publishers add no QoS-event waitables (every
wake-up of the node's executor visits each one); on wall time rclpy's default handlers stay."""

from __future__ import annotations

import pytest
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.parameter import Parameter
from std_msgs.msg import Empty

from amr_util.managed_node import ManagedNode


@pytest.mark.parametrize(("sim_time", "added"), [(True, 0), (False, 2)])
def test_lifecycle_publisher_waitables(ros_context, sim_time, added):
    node = ManagedNode(
        "quiet_publisher_probe", context=ros_context, parameter_overrides=[Parameter("use_sim_time", value=sim_time)]
    )
    try:
        before = len(list(node.waitables))
        node.create_lifecycle_publisher(Empty, "quiet_publisher_topic", 10)
        assert len(list(node.waitables)) - before == added
        asked = PublisherEventCallbacks(matched=lambda _: None, use_default_callbacks=False)
        node.create_lifecycle_publisher(Empty, "other", 10, event_callbacks=asked)  # kept when asked for
        assert len(list(node.waitables)) - before == added + 1
    finally:
        node.destroy_node()
