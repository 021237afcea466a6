"""Shutdown from every state, for every node, through its /<node>/change_state service (amr_util.managed_node).

From unconfigured, inactive and active the node answers success and ends finalized; from active a
controller's last command is a zero one; afterwards nothing is published (every publish of the process
is recorded), and no timer, subscription or node service is left. The real-robot wall follower is the
case the issue found: its 20 Hz timer kept publishing /cmd_vel after shutdown from active.

The three states of a node are tried side by side, each node in an rclpy context and DDS domain of its own (they
share a name), so that one window watches all three after their shutdowns; a message counts against a node unless
it came from one of the other two's publishers.
"""

from __future__ import annotations

import time

import pytest
import rclpy
from geometry_msgs.msg import Twist, TwistStamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from support.ros import close, fresh_domain

from amr_bringup.demo import config_file, params_file_args
from amr_control.path_follower_node import PathFollowerNode
from amr_control.wall_follower_node import WallFollowerNode
from amr_kinematics.ik_service_node import IKServiceNode
from amr_localization.beacon_localizer_node import BeaconLocalizerNode
from amr_localization.particle_filter_node import ParticleFilterNode
from amr_maps.map_server_node import MapServerNode
from amr_navigation.navigator_node import NavigatorNode
from amr_planning.planner_node import PlannerNode
from amr_simulation.simulator_node import SimulatorNode
from amr_turtlebot3.odometry_node import OdometryNode
from amr_util.lean_executor import LeanExecutor

SHUTDOWN = {
    "unconfigured": Transition.TRANSITION_UNCONFIGURED_SHUTDOWN,
    "inactive": Transition.TRANSITION_INACTIVE_SHUTDOWN,
    "active": Transition.TRANSITION_ACTIVE_SHUTDOWN,
}
KEPT_SERVICES = (
    "change_state",
    "get_state",
    "get_available_states",
    "get_available_transitions",
    "get_transition_graph",
    "describe_parameters",
    "get_parameters",
    "get_parameter_types",
    "list_parameters",
    "set_parameters",
    "set_parameters_atomically",
    "get_type_description",
)
"""The services rclpy gives every lifecycle node: the only ones left after shutdown."""
QUIET = 1.2
"""s watched after shutdown: longer than the simulator's 1 s lockstep resend and 20 periods of a 20 Hz timer."""


def files(package: str, name: str, *overrides: str) -> dict:
    return {"cli_args": params_file_args(config_file(package, name), *overrides)}


NODES = {
    "simulator": (SimulatorNode, {"parameter_overrides": [Parameter("world", value="outer_corridor.yaml")]}),
    "wall_follower_sim": (WallFollowerNode, files("amr_control", "wall_follower_sim.yaml")),
    "wall_follower_real": (WallFollowerNode, files("amr_control", "wall_follower_real.yaml")),
    "path_follower_sim": (PathFollowerNode, files("amr_control", "path_follower_sim.yaml")),
    "path_follower_real": (PathFollowerNode, files("amr_control", "path_follower_real.yaml")),
    "odometry_node": (OdometryNode, {}),
    "particle_filter": (
        ParticleFilterNode,
        files("amr_localization", "particle_filter.yaml", "world:=outer_corridor.yaml", "max_particles:=500"),
    ),
    "beacon_localizer": (BeaconLocalizerNode, files("amr_localization", "beacon_localizer.yaml")),
    "map_server": (MapServerNode, {"parameter_overrides": [Parameter("world", value="outer_corridor.yaml")]}),
    "planner": (PlannerNode, {"parameter_overrides": [Parameter("world", value="outer_corridor.yaml")]}),
    "navigator": (NavigatorNode, files("amr_navigation", "navigator.yaml")),
    "ik_service": (IKServiceNode, files("amr_kinematics", "ik_chains.yaml")),
}
COMMANDS = {
    "wall_follower_sim": TwistStamped,
    "wall_follower_real": Twist,
    "path_follower_sim": TwistStamped,
    "path_follower_real": Twist,
}


@pytest.fixture
def publishes(monkeypatch):
    """Every message published in this process: (monotonic time, topic, message, publisher)."""
    seen: list[tuple[float, str, object, Publisher]] = []
    original = Publisher.publish

    def recording(self, message):
        seen.append((time.monotonic(), self.topic_name, message, self))
        return original(self, message)

    monkeypatch.setattr(Publisher, "publish", recording)
    return seen


def is_zero(message) -> bool:
    twist = message.twist if isinstance(message, TwistStamped) else message
    return all(
        v == 0.0
        for v in (twist.linear.x, twist.linear.y, twist.linear.z, twist.angular.x, twist.angular.y, twist.angular.z)
    )


def bring_to(node, state: str) -> None:
    if state in ("inactive", "active"):
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), getattr(node, "configure_error", "")
    if state == "active":
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert node.state_label == state


def spin_all_until(executors, condition, timeout: float) -> bool:
    """Spin every executor in turn until condition() holds or the timeout passes; returns whether it held."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        for executor in executors:
            executor.spin_once(timeout_sec=0.005)
    return condition()


@pytest.fixture
def contexts():
    """One rclpy context per state, each in a DDS domain of its own; their executors closed and contexts shut down
    afterwards."""
    made: list[tuple[rclpy.Context, LeanExecutor]] = []

    def make() -> tuple[rclpy.Context, LeanExecutor]:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=fresh_domain())
        made.append((context, LeanExecutor(context=context)))
        return made[-1]

    yield make
    for context, executor in made:
        close(executor)
        context.try_shutdown()


@pytest.mark.parametrize("name", NODES)
def test_shutdown_from_every_state_leaves_a_silent_finalized_node(name, contexts, publishes):
    node_class, kwargs = NODES[name]
    nodes, executors, clients = {}, [], {}
    for state in SHUTDOWN:
        context, executor = contexts()
        client_node = Node("lifecycle_probe", context=context)
        node = node_class(context=context, **kwargs)
        executor.add_node(client_node)
        executor.add_node(node)
        bring_to(node, state)
        nodes[state] = node
        executors.append(executor)
        clients[state] = client_node.create_client(ChangeState, f"{node.get_fully_qualified_name()}/change_state")
    spin_all_until(executors, lambda: False, 0.3)  # timers and first messages run
    assert spin_all_until(executors, lambda: all(c.service_is_ready() for c in clients.values()), 5.0)
    own = {state: {id(publisher): publisher for publisher in node.publishers} for state, node in nodes.items()}
    asked, answered = {}, {}
    for state, node in nodes.items():
        asked[state] = time.monotonic()
        future = clients[state].call_async(ChangeState.Request(transition=Transition(id=SHUTDOWN[state])))
        assert spin_all_until(executors, future.done, 10.0), f"{name}: no answer to shutdown from {state}"
        answered[state] = time.monotonic()
        assert future.result().success, f"{name}: shutdown from {state} refused"
        assert node.state_label == "finalized"
    spin_all_until(executors, lambda: False, QUIET)
    for state, node in nodes.items():
        others = set().union(*(publishers for other, publishers in own.items() if other != state))
        mine = [(t, topic, message) for t, topic, message, publisher in publishes if id(publisher) not in others]
        late = [(topic, message) for t, topic, message in mine if t > answered[state] and topic != "/rosout"]
        assert not late, f"{name}: published after shutdown from {state}: {[topic for topic, _ in late]}"
        if name in COMMANDS and state == "active":
            commands = [m for t, topic, m in mine if topic == "/cmd_vel" and asked[state] <= t <= answered[state]]
            assert commands and is_zero(commands[-1]), f"{name}: no zero command on shutdown from active"
            assert all(isinstance(message, COMMANDS[name]) for message in commands)
        assert not list(node.timers), f"{name}: timers left after shutdown from {state}"
        assert not list(node.subscriptions), f"{name}: subscriptions left: {[s.topic_name for s in node.subscriptions]}"
        left = [s.srv_name for s in node.services if s.srv_name.rsplit("/", 1)[-1] not in KEPT_SERVICES]
        assert not left, f"{name}: services left after shutdown from {state}: {left}"
