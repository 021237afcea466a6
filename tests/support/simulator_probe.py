"""Shared helpers for the simulator node tests: a driver node that records every observation."""

from __future__ import annotations

import weakref

import pytest
from geometry_msgs.msg import Twist, TwistStamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Trigger

from amr_interfaces.msg import SimulatorStatus
from amr_interfaces.srv import SetPose
from amr_simulation.simulator_node import SimulatorNode
from amr_util.stamps import stamp_seconds
from support.ros import spin_for, spin_until

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
TIMEOUT = 10.0
"""s to wait for anything that should happen at once (generous for a loaded 2-core machine)."""


def seconds(stamp) -> float:
    return stamp_seconds(stamp)


class Probe(Node):
    """Publishes /cmd_vel, records /odometry, /odom, /ground_truth, /scan, ~/status and /clock."""

    def __init__(self, context, stamped: bool = True, use_sim_time: bool = False, robot: str = "") -> None:
        super().__init__(
            f"simulator_probe_{robot}" if robot else "simulator_probe",
            context=context,
            parameter_overrides=[Parameter("use_sim_time", value=use_sim_time)],
        )
        self.stamped = stamped
        self.robot = robot
        """A robot of a fleet world: its topics in its namespace (/<robot>/scan, /<robot>/status, ...)."""
        ns = f"/{robot}/" if robot else ""
        self.expected = {"status", "odometry", "odom", "ground_truth", "scan"}
        """The observation topics the simulator under test publishes."""
        self.cmd_vel = self.create_publisher(TwistStamped if stamped else Twist, f"{ns}cmd_vel", RELIABLE)
        self.odometry: list[Odometry] = []
        self.odom: list[Odometry] = []
        self.ground_truth: list[Odometry] = []
        self.scans: list[LaserScan] = []
        self.statuses: list[SimulatorStatus] = []
        self.clocks: list[Clock] = []
        self.observation_subscriptions = {
            "status": self.create_subscription(
                SimulatorStatus, f"{ns}status" if robot else "simulator/status", self.statuses.append, RELIABLE
            ),
            "odometry": self.create_subscription(Odometry, f"{ns}odometry", self.odometry.append, RELIABLE),
            "odom": self.create_subscription(Odometry, f"{ns}odom", self.odom.append, RELIABLE),
            "ground_truth": self.create_subscription(Odometry, f"{ns}ground_truth", self.ground_truth.append, RELIABLE),
            "scan": self.create_subscription(LaserScan, f"{ns}scan", self.scans.append, qos_profile_sensor_data),
        }
        self.clock_subscription = self.create_subscription(Clock, "/clock", self.clocks.append, RELIABLE)
        self.reset = self.create_client(Trigger, f"{ns}reset" if robot else "simulator/reset")
        self.set_pose = self.create_client(SetPose, f"{ns}set_pose" if robot else "simulator/set_pose")
        self.render = self.create_client(Trigger, "simulator/render")
        self.change_state = self.create_client(ChangeState, "simulator/change_state")
        self.get_state = self.create_client(GetState, "simulator/get_state")

    def send(self, v: float, w: float = 0.0) -> None:
        twist = Twist()
        twist.linear.x, twist.angular.z = v, w
        if self.stamped:
            message = TwistStamped()
            message.header.stamp = self.get_clock().now().to_msg()
            message.twist = twist
            self.cmd_vel.publish(message)
        else:
            self.cmd_vel.publish(twist)

    def streams(self) -> dict[str, list]:
        return {
            "status": self.statuses,
            "odometry": self.odometry,
            "odom": self.odom,
            "ground_truth": self.ground_truth,
            "scan": self.scans,
        }

    def connected(self) -> bool:
        """/cmd_vel and every observation topic the simulator publishes are matched."""
        return self.cmd_vel.get_subscription_count() > 0 and all(
            self.observation_subscriptions[name].get_publisher_count() > 0 for name in self.expected
        )

    def observations(self) -> int:
        """Complete observations received: every expected topic has delivered its message."""
        streams = self.streams()
        return min(len(streams[name]) for name in self.expected)


MATCH_DELAY = 0.3
"""s to spin after a service first shows up in the graph: the graph can run ahead of the DDS
matching, and a request sent before the match is lost (volatile durability)."""
_matched_clients: weakref.WeakSet = weakref.WeakSet()


def call(executor, client, request, timeout: float = TIMEOUT, attempts: int = 1):
    """The service's answer; an idempotent request (a query) may be sent `attempts` times: on a loaded machine
    the first request of a new client can still be lost after MATCH_DELAY (the reply's reader not yet matched)."""
    if client not in _matched_clients:
        assert client.wait_for_service(timeout_sec=timeout), f"{client.srv_name} not available"
        spin_for(executor, MATCH_DELAY)
        _matched_clients.add(client)
    for _ in range(attempts):
        future = client.call_async(request)
        executor.spin_until_future_complete(future, timeout_sec=timeout)
        if future.done():
            return future.result()
        client.remove_pending_request(future)
    raise AssertionError(f"{client.srv_name} did not answer ({attempts} request(s), {timeout:g} s each)")


def change_state(executor, probe: Probe, transition_id: int) -> bool:
    return call(executor, probe.change_state, ChangeState.Request(transition=Transition(id=transition_id))).success


def state_of(executor, probe: Probe) -> str:
    return call(executor, probe.get_state, GetState.Request(), attempts=3).current_state.label


def drive(executor, probe: Probe, commands) -> None:
    """Closed loop, as a lockstep driver runs: each command waits for the observation it causes."""
    for v, w in commands:
        count = probe.observations()
        probe.send(v, w)
        assert spin_until(executor, lambda count=count: probe.observations() > count, TIMEOUT), (
            "no observation came back"
        )


def settle(executor, duration: float = 0.2) -> None:
    """Spin a little longer so that anything extra (which would be a bug) has time to arrive."""
    spin_for(executor, duration)


@pytest.fixture
def nodes():
    """Nodes made in a test, destroyed at its end: a DDS participant lives as long as its nodes, and
    leftover participants take the low participant ids that localhost discovery probes, so that later
    processes are not found; nor does any pymunk space outlive the test."""
    made: list[Node] = []
    yield made
    for node in made:
        node.destroy_node()


@pytest.fixture
def simulator(ros_context, nodes):
    """Makes simulator nodes in this process (dotted names through a dict: **{'lidar.beams': 60})."""

    def make(**params) -> SimulatorNode:
        nodes.append(
            SimulatorNode(context=ros_context, parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
        )
        return nodes[-1]

    return make


@pytest.fixture
def probe(ros_context, nodes):
    """Makes Probe nodes: probe(stamped=True, use_sim_time=False)."""

    def make(**options) -> Probe:
        nodes.append(Probe(ros_context, **options))
        return nodes[-1]

    return make


def start(executor, node: SimulatorNode, probe: Probe) -> None:
    """Configure, wait until the probe is connected, activate, and take the first observation."""
    executor.add_node(node)
    executor.add_node(probe)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE), "configure failed"
    assert spin_until(executor, probe.connected, TIMEOUT)
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: probe.observations() >= 1, TIMEOUT), "no first observation"
