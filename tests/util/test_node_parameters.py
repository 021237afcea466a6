"""Every node's parameters as a ROS user meets them through the parameter services.

`ros2 param describe` answers with each parameter's own name, real type and a description;
a live tunable set while active changes behaviour at the next step; a structural set while
configured is refused with the reason; a wrong value is refused naming the key.
"""

import numpy as np
import pytest
from lifecycle_msgs.msg import Transition
from rcl_interfaces.msg import Parameter as ParameterMessage
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters, SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter
from support.ros import spin_until

from amr_bringup.lifecycle_manager import LifecycleManager
from amr_control.path_follower_node import PathFollowerNode
from amr_control.wall_follower_node import WallFollowerNode
from amr_kinematics.ik_service_node import IKServiceNode
from amr_planning.planner_node import PlannerNode
from amr_simulation.simulator_node import SimulatorNode
from amr_turtlebot3.odometry_node import OdometryNode

VALUE_FIELDS = {
    ParameterType.PARAMETER_BOOL: "bool_value",
    ParameterType.PARAMETER_INTEGER: "integer_value",
    ParameterType.PARAMETER_DOUBLE: "double_value",
    ParameterType.PARAMETER_STRING: "string_value",
    ParameterType.PARAMETER_BOOL_ARRAY: "bool_array_value",
    ParameterType.PARAMETER_INTEGER_ARRAY: "integer_array_value",
    ParameterType.PARAMETER_DOUBLE_ARRAY: "double_array_value",
    ParameterType.PARAMETER_STRING_ARRAY: "string_array_value",
}
NODES = {
    "simulator": lambda context: SimulatorNode(context=context),
    "wall_follower": lambda context: WallFollowerNode(context=context),
    "odometry_node": lambda context: OdometryNode(context=context),
    "ik_service": lambda context: IKServiceNode(context=context),
    "planner": lambda context: PlannerNode(context=context),
    "path_follower": lambda context: PathFollowerNode(context=context),
    "lifecycle_manager": lambda context: LifecycleManager(
        context=context,
        parameter_overrides=[Parameter("node_startup_order", value=["a", "b"]), Parameter("autostart", value=False)],
    ),
}


def call(executor, client, request, timeout=10.0):
    assert client.wait_for_service(timeout_sec=timeout), client.srv_name
    future = client.call_async(request)
    assert spin_until(executor, future.done, timeout), client.srv_name
    return future.result()


@pytest.mark.parametrize("name", NODES)
def test_describe_gives_every_parameter_its_own_name_type_and_description(ros_context, multi_executor, name):
    node = NODES[name](ros_context)
    probe = Node("probe", context=ros_context)
    for each in (node, probe):
        multi_executor.add_node(each)
    names = call(
        multi_executor, probe.create_client(ListParameters, f"/{name}/list_parameters"), ListParameters.Request()
    ).result.names
    names = [n for n in names if n not in ("use_sim_time", "start_type_description_service")]
    assert len(names) >= 3
    described = call(
        multi_executor,
        probe.create_client(DescribeParameters, f"/{name}/describe_parameters"),
        DescribeParameters.Request(names=names),
    ).descriptors
    values = call(
        multi_executor,
        probe.create_client(GetParameters, f"/{name}/get_parameters"),
        GetParameters.Request(names=names),
    ).values
    for asked, descriptor, value in zip(names, described, values, strict=True):
        assert descriptor.name == asked, f"{name}: describe {asked!r} answered {descriptor.name!r}"
        assert descriptor.type == value.type != ParameterType.PARAMETER_NOT_SET, asked
        assert descriptor.type != ParameterType.PARAMETER_BYTE_ARRAY, asked
        assert descriptor.description, f"{name}.{asked} has no description"
    ranged = [d for d in described if d.floating_point_range or d.integer_range]
    if name != "lifecycle_manager":
        assert ranged, f"{name}: no parameter states its range"


def set_remote(executor, probe, node_name, name, value):
    message = ParameterMessage(name=name, value=Parameter(name, value=value).get_parameter_value())
    client = probe.create_client(SetParameters, f"/{node_name}/set_parameters")
    return call(executor, client, SetParameters.Request(parameters=[message])).results[0]


def test_simulator_refuses_structural_sets_while_configured_and_applies_noise_live(ros_context, multi_executor):
    node, probe = SimulatorNode(context=ros_context), Node("probe", context=ros_context)
    for each in (node, probe):
        multi_executor.add_node(each)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    result = set_remote(multi_executor, probe, "simulator", "dt", 0.1)
    assert not result.successful
    assert result.reason == "dt is read-only while configured; cleanup, set, configure"
    assert node.get_parameter("dt").value == 0.05 and node._sim.config.dt == 0.05
    for name, bad, words in (
        ("mode", "bogus", "mode: must be one of lockstep, realtime"),
        ("lidar.noise_std", -1.0, "out of range"),
    ):
        result = set_remote(multi_executor, probe, "simulator", name, bad)
        assert not result.successful and words in result.reason, result.reason
    assert set_remote(multi_executor, probe, "simulator", "lidar.noise_std", 0.0).successful
    assert node._sim.config.lidar.noise_std == 0.0
    node._sim.step(0.0, 0.0)
    first = node._sim.ranges.copy()
    node._sim.step(0.0, 0.0)
    assert np.array_equal(node._sim.ranges, first), "with the noise set to 0 live, a still robot reads the same ranges"
    assert node.try_transition(Transition.TRANSITION_CLEANUP)
    assert set_remote(multi_executor, probe, "simulator", "dt", 0.1).successful, (
        "unconfigured: structural sets are fine"
    )
    assert node.try_transition(Transition.TRANSITION_CONFIGURE) and node._sim.config.dt == 0.1


def test_simulator_configure_reports_every_bad_key_at_once(ros_context, executor):
    node = SimulatorNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("dt", value=-1.0),
            Parameter("mode", value="bogus"),
            Parameter("world", value="nowhere.yaml"),
            Parameter("lidar.beamz", value=10),
        ],
    )
    executor.add_node(node)
    problems = node.parameter_problems()
    assert [p.split(":")[0] for p in problems] == ["world", "dt", "mode", "lidar.beamz"], problems
    assert "lidar.beams" in problems[-1], "an unknown key names the known ones"
    assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.state_label == "unconfigured"
