"""Helpers of the IK service node tests: the source config as overrides, a client probe, calls."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
import yaml
from geometry_msgs.msg import Pose
from lifecycle_msgs.msg import Transition
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from amr_interfaces.srv import ComputeFK, SolveIK
from amr_kinematics.config import flatten_parameters
from amr_kinematics.ik_service_node import IKServiceNode

CONFIG = Path(__file__).resolve().parents[2] / "config" / "ik_chains.yaml"
CALL_TIMEOUT = 10.0  # s; a reply that takes this long is a hang


def config_overrides(**changes) -> list[Parameter]:
    """The shipped chain parameters (source tree) as node overrides, with ``changes`` applied."""
    flat = flatten_parameters(yaml.safe_load(CONFIG.read_text(encoding="utf-8")))
    flat.update(changes)
    return [Parameter(name, value=value) for name, value in flat.items()]


class Probe(Node):
    """A client of both services, and a listener of ~/joint_states."""

    def __init__(self, context) -> None:
        super().__init__("ik_probe", context=context)
        self.solve = self.create_client(SolveIK, "/solve_ik")
        self.fk = self.create_client(ComputeFK, "/compute_fk")
        self.joint_states: list[JointState] = []
        self.create_subscription(JointState, "/ik_service/joint_states", self.joint_states.append, 10)


def call(executor, client, request):
    """The reply to one request; fails the test if none comes.

    A spin_once loop: rclpy 7.1.6's spin_until_future_complete with a timeout leaves
    a task behind at every call, and calls get slower and slower (3 ms -> 25 ms in 500).
    """
    future = client.call_async(request)
    deadline = time.monotonic() + CALL_TIMEOUT
    while not future.done() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    assert future.done(), f"no reply from {client.srv_name} within {CALL_TIMEOUT} s"
    return future.result()


def connect(executor, probe: Probe, timeout: float = 10.0) -> None:
    """Return once both services have answered a harmless request (unknown chain)."""
    reached(executor, probe.solve, SolveIK.Request(), timeout)
    reached(executor, probe.fk, ComputeFK.Request(), timeout)


def reached(executor, client, harmless_request, timeout: float = 10.0) -> None:
    """Return once the server has answered ``harmless_request``, resent every 0.5 s.

    wait_for_service alone is not enough: the graph may still list the services of a
    node an earlier test destroyed, and a request sent before the new server has
    matched the client is lost.
    """
    deadline = time.monotonic() + timeout
    while True:
        assert client.wait_for_service(timeout_sec=max(0.0, deadline - time.monotonic())), client.srv_name
        future = client.call_async(harmless_request)
        attempt_end = time.monotonic() + 0.5
        while not future.done() and time.monotonic() < attempt_end:
            executor.spin_once(timeout_sec=0.05)
        if future.done():
            return
        client.remove_pending_request(future)
        assert time.monotonic() < deadline, f"{client.srv_name} never answered"


def pose(x: float, y: float, z: float = 0.0, quaternion=(1.0, 0.0, 0.0, 0.0)) -> Pose:
    """A Pose from a position and a (w, x, y, z) quaternion."""
    message = Pose()
    message.position.x, message.position.y, message.position.z = float(x), float(y), float(z)
    w, qx, qy, qz = quaternion
    message.orientation.w, message.orientation.x = float(w), float(qx)
    message.orientation.y, message.orientation.z = float(qy), float(qz)
    return message


def solve_request(chain: str, target: Pose, **fields) -> SolveIK.Request:
    return SolveIK.Request(chain=chain, target=target, **fields)


def start(context, executor, overrides=None, activate: bool = True) -> tuple[IKServiceNode, Probe]:
    """The node built from the source config (or ``overrides``), configured and activated."""
    node = IKServiceNode(context=context, parameter_overrides=config_overrides() if overrides is None else overrides)
    probe = Probe(context)
    executor.add_node(node)
    executor.add_node(probe)
    if activate:
        assert node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
        connect(executor, probe)
    return node, probe


def stop(executor, nodes) -> None:
    """Remove and destroy the nodes: a node left alive keeps its services visible in the
    DDS graph (nobody answering), and a later client would take it for the real server."""
    for node in nodes:
        executor.remove_node(node)
        node.destroy_node()


@pytest.fixture
def launch(ros_context, multi_executor):
    """start(...) on this test's context and 4-thread executor; the nodes destroyed after the test."""
    created = []

    def launch_node(overrides=None, activate: bool = True) -> tuple[IKServiceNode, Probe]:
        node, probe = start(ros_context, multi_executor, overrides, activate)
        created.extend((node, probe))
        return node, probe

    yield launch_node
    stop(multi_executor, created)


def quaternion_angle(a, b) -> float:
    """Rotation angle between two (w, x, y, z) unit quaternions."""
    dot = abs(sum(x * y for x, y in zip(a, b, strict=True)))
    return 2.0 * math.acos(min(1.0, dot))
