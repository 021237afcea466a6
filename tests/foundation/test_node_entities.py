"""Every node keeps rclpy's own entities: an attribute named like rclpy's internal lists
(`_services`, `_subscriptions`, ...) silently hides the lifecycle services or the /clock subscription."""

import pytest
from lifecycle_msgs.msg import Transition

from amr_control.wall_follower_node import WallFollowerNode
from amr_kinematics.ik_service_node import IKServiceNode
from amr_maps.map_server_node import MapServerNode
from amr_simulation.simulator_node import SimulatorNode
from amr_turtlebot3.odometry_node import OdometryNode
from amr_viewer.viewer_node import ViewerNode

LIFECYCLE_SERVICES = {
    "change_state",
    "get_state",
    "get_available_states",
    "get_available_transitions",
    "get_transition_graph",
}


REQUIRED = {MapServerNode: {"world": "open_room.yaml"}, ViewerNode: {"port": 0}}
"""Parameters a node cannot configure without."""


@pytest.mark.parametrize(
    "node_class", [OdometryNode, SimulatorNode, WallFollowerNode, IKServiceNode, MapServerNode, ViewerNode]
)
def test_lifecycle_services_and_clock_survive_configure_and_activate(ros_context, node_class):
    from rclpy.parameter import Parameter

    given = {"use_sim_time": True, **REQUIRED.get(node_class, {})}
    node = node_class(context=ros_context, parameter_overrides=[Parameter(k, value=v) for k, v in given.items()])
    try:
        for transition in (Transition.TRANSITION_CONFIGURE, Transition.TRANSITION_ACTIVATE):
            assert node.try_transition(transition), node.get_name()
            served = {service.srv_name.rsplit("/", 1)[-1] for service in node.services}
            assert LIFECYCLE_SERVICES <= served, f"{node.get_name()} lost its lifecycle services"
            topics = {subscription.topic_name for subscription in node.subscriptions}
            assert "/clock" in topics, f"{node.get_name()} lost its /clock subscription"
    finally:
        node.destroy_node()
