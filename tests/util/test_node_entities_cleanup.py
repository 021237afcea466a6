"""The node base tracks what a node creates while it configures and destroys it at cleanup: a node's
on_cleanup resets its own fields and ends with the base's; rclpy's own entities (made in __init__) and what is made
outside configure are kept."""

from __future__ import annotations

import pytest
from lifecycle_msgs.msg import Transition
from rclpy.lifecycle import TransitionCallbackReturn
from std_msgs.msg import String
from std_srvs.srv import Trigger

from amr_util.managed_node import ManagedNode


class Maker(ManagedNode):
    """Creates one entity of every kind when it configures; its cleanup is the base's alone."""

    def __init__(self, **kwargs) -> None:
        super().__init__("maker", **kwargs)
        self.kept = self.create_publisher(String, "kept", 10)  # made in __init__: not the configuration's

    def on_configure(self, state) -> TransitionCallbackReturn:
        self.made = [
            self.create_subscription(String, "in", lambda message: None, 10),
            self.create_lifecycle_publisher(String, "out", 10),
            self.create_publisher(String, "plain", 10),
            self.create_service(Trigger, "~/trigger", lambda request, response: response),
            self.create_active_service(Trigger, "~/active", lambda request, response: response),
            self.create_client(Trigger, "other/trigger"),
            self.create_timer(1.0, lambda: None),
            self.create_guard_condition(lambda: None),
        ]
        return TransitionCallbackReturn.SUCCESS


def entities(node) -> set:
    return {
        *node.subscriptions,
        *node.publishers,
        *node.services,
        *node.clients,
        *node.timers,
        *node.guards,
    }


def test_cleanup_destroys_what_configure_made_and_nothing_else(ros_context):
    node = Maker(context=ros_context)
    try:
        before = entities(node)
        for _ in range(2):  # configured again after a cleanup: tracked anew
            assert node.try_transition(Transition.TRANSITION_CONFIGURE)
            assert set(node.made) <= entities(node) and len(node.made) == 8
            assert node.try_transition(Transition.TRANSITION_CLEANUP)
            assert entities(node) == before, "exactly what configure made is gone"
            assert node.kept in set(node.publishers) and not node._managed_entities
        assert node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert node.shut_down() and entities(node) == before, "shutdown from inactive cleans up too"
    finally:
        node.destroy_node()


def _suite_nodes():
    """The suite's lifecycle nodes whose cleanup destroys some entities itself (their configure needs no other node)."""
    from amr_localization.beacon_localizer_node import BeaconLocalizerNode
    from amr_localization.particle_filter_node import ParticleFilterNode
    from amr_mapping.explorer_node import ExplorerNode
    from amr_mapping.slam_node import SlamNode

    return [BeaconLocalizerNode, ParticleFilterNode, ExplorerNode, SlamNode]


@pytest.mark.parametrize("kind", _suite_nodes(), ids=lambda kind: kind.__name__)
def test_a_suite_nodes_cleanup_ends_with_the_bases_and_leaves_nothing_configure_made(ros_context, kind):
    node = kind(context=ros_context)
    try:
        before = entities(node)
        for _ in range(2):
            assert node.try_transition(Transition.TRANSITION_CONFIGURE), getattr(node, "configure_error", "")
            assert entities(node) > before
            assert node.try_transition(Transition.TRANSITION_CLEANUP)
            assert entities(node) == before, "what configure made is gone"
            assert not node._configured_entities and not node._managed_entities, "the base's cleanup ran"
    finally:
        node.destroy_node()
