"""amr_util.managed_node.ManagedNode: on simulated time its subscriptions add no QoS-event waitables."""

from __future__ import annotations

import pytest
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.parameter import Parameter
from std_msgs.msg import Empty

from amr_util.managed_node import ManagedNode


@pytest.mark.parametrize(("sim_time", "added"), [(True, 0), (False, 2)])
def test_subscription_waitables(ros_context, sim_time, added):
    node = ManagedNode(
        "quiet_probe", context=ros_context, parameter_overrides=[Parameter("use_sim_time", value=sim_time)]
    )
    try:
        before = len(list(node.waitables))
        node.create_subscription(Empty, "quiet_probe_topic", lambda _: None, 10)
        assert len(list(node.waitables)) - before == added
        assert len(list(node.subscriptions)) == 1 + int(sim_time)  # and /clock's (sim time)
        # event callbacks asked for are kept
        node.create_subscription(
            Empty,
            "other",
            lambda _: None,
            10,
            event_callbacks=SubscriptionEventCallbacks(matched=lambda _: None, use_default_callbacks=False),
        )
        assert len(list(node.waitables)) - before == added + 1
    finally:
        node.destroy_node()
