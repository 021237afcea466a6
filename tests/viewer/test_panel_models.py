"""The plain models behind the page: parameters from descriptors, graph discovery, what a click means."""

import math

import pytest
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType

from amr_util.geometry import Pose2D
from amr_util.managed_node import descriptor_of
from amr_util.parameter_spec import ParameterSpec
from amr_viewer import topics
from amr_viewer.clicks import GOAL, INITIAL_POSE, OFF, ClickTool
from amr_viewer.parameters import entries_from, entry_from, nice_step, parameter_value, value_of, visible

T = ParameterType


def entry(spec: ParameterSpec, value=None):
    """An entry as the panel gets it: the node's own descriptor (amr_util), its value from GetParameters."""
    descriptor = descriptor_of(spec)
    kind = descriptor.type
    return entry_from(spec.name, descriptor, parameter_value(kind, spec.default if value is None else value))


def test_bounded_numbers_get_sliders_with_the_descriptor_range():
    kp = entry(ParameterSpec("kp", 4.0, "gain", minimum=0.0, maximum=50.0, live=True))
    assert (kp.widget, kp.minimum, kp.maximum, kp.step) == ("slider", 0.0, 50.0, 0.5)
    beams = entry(ParameterSpec("beams", 60, "beams", minimum=1, maximum=720))
    assert (beams.widget, beams.step, beams.is_integer) == ("slider", 1, True)
    assert beams.structural, "our descriptors say which parameters a configured node refuses"
    assert not kp.structural


def test_unbounded_numbers_get_fields():
    assert entry(ParameterSpec("x", 1.0, "half bounded", minimum=0.0)).widget == "number"  # ours: to 1e308
    assert entry(ParameterSpec("seed", 0, "", minimum=0, maximum=2**31 - 1)).widget == "number", "too wide"
    assert entry(ParameterSpec("free", 2.5, "")).widget == "number"
    descriptor = ParameterDescriptor(
        type=T.PARAMETER_DOUBLE, floating_point_range=[FloatingPointRange(from_value=0.0, to_value=1.0, step=0.25)]
    )
    stepped = entry_from("a", descriptor, parameter_value(T.PARAMETER_DOUBLE, 0.5))
    assert (stepped.widget, stepped.step) == ("slider", 0.25)
    outside = entry_from(
        "b",
        ParameterDescriptor(type=T.PARAMETER_INTEGER, integer_range=[IntegerRange(from_value=0, to_value=10, step=0)]),
        parameter_value(T.PARAMETER_INTEGER, 20),
    )
    assert outside.widget == "number", "a value outside its own range cannot sit on a slider"


def test_other_types_and_read_only():
    assert entry(ParameterSpec("on", True, "")).widget == "checkbox"
    assert entry(ParameterSpec("world", "a.yaml", "")).widget == "text"
    names = entry(ParameterSpec("chains", ["arm5", "ur5"], ""))
    assert (names.widget, names.text()) == ("text", "[arm5, ur5]")
    assert entry(ParameterSpec("fixed", 1.0, "", read_only=True)).widget == "readonly"


@pytest.mark.parametrize(
    "spec,given,expected",
    [
        (ParameterSpec("b", True, ""), "false", False),
        (ParameterSpec("b", True, ""), True, True),
        (ParameterSpec("i", 3, ""), 7.0, 7),
        (ParameterSpec("i", 3, ""), "12", 12),
        (ParameterSpec("f", 0.5, ""), "0.25", 0.25),
        (ParameterSpec("s", "x", ""), "hello", "hello"),
        (ParameterSpec("fa", [0.0], ""), "[1, 2.5]", [1.0, 2.5]),
        (ParameterSpec("fa", [0.0], ""), "[]", []),
        (ParameterSpec("ia", [0], ""), "[1, 2]", [1, 2]),
        (ParameterSpec("sa", ["a"], ""), "[a, 'b c']", ["a", "b c"]),
        (ParameterSpec("ba", [True], ""), "[true, false]", [True, False]),
    ],
)
def test_widget_values_become_the_parameters_type(spec, given, expected):
    parsed = entry(spec).parse(given)
    assert parsed == expected and type(parsed) is type(expected)
    message = entry(spec).message(parsed)
    assert message.name == spec.name and value_of(message.value) == expected


@pytest.mark.parametrize(
    "spec,given,words",
    [
        (ParameterSpec("i", 3, ""), 2.5, "an integer"),
        (ParameterSpec("f", 0.5, ""), "fast", "a number"),
        (ParameterSpec("b", True, ""), "maybe", "true or false"),
        (ParameterSpec("ia", [0], ""), "[1.5]", "a list of integers"),
        (ParameterSpec("fa", [0.0], ""), "{a: 1}", "a list of numbers"),
    ],
)
def test_a_bad_value_is_refused_saying_what_was_expected(spec, given, words):
    with pytest.raises(ValueError, match=f"{spec.name}: .* is not {words}"):
        entry(spec).parse(given)


def test_nice_steps_and_hidden_names():
    assert [nice_step(span) for span in (1.0, 2.84, 50.0, 1000.0, 0.0)] == pytest.approx([0.005, 0.02, 0.5, 5.0, 1.0])
    assert not visible("qos_overrides./tf.publisher.depth") and visible("kp")


GRAPH = [
    ("/scan", ["sensor_msgs/msg/LaserScan"]),
    ("/map", ["nav_msgs/msg/OccupancyGrid"]),
    ("/robot1/ground_truth", ["nav_msgs/msg/Odometry"]),
    ("/robot1/tf", ["tf2_msgs/msg/TFMessage"]),
    ("/fleet/robot2/pose", ["amr_interfaces/msg/LocalizedPose"]),
    ("/other/scan", ["std_msgs/msg/String"]),  # not a robot: wrong type
    ("/ik_service/joint_states", ["sensor_msgs/msg/JointState"]),
    ("/joint_states", ["sensor_msgs/msg/JointState"]),
    ("/simulator/status", ["amr_interfaces/msg/SimulatorStatus"]),
]
SERVICES = [
    (f"/simulator/{leaf}", ["std_srvs/srv/Trigger"]) for leaf in ("pause", "resume", "step", "reset", "render")
] + [
    ("/robot1/simulator/pause", ["std_srvs/srv/Trigger"]),  # not every control: not a simulator to steer
    ("/simulator/get_state", ["lifecycle_msgs/srv/GetState"]),
    ("/planner/get_state", ["lifecycle_msgs/srv/GetState"]),
    ("/x/get_state", ["std_srvs/srv/Trigger"]),
    ("/particle_filter/reinitialize_global_localization", ["std_srvs/srv/Empty"]),
    ("/y/reinitialize_global_localization", ["std_srvs/srv/Trigger"]),  # not the standard type: not a localizer
]


def test_every_namespace_with_robot_topics_is_a_robot():
    assert topics.robot_namespaces(GRAPH) == ["", "/fleet/robot2", "/robot1"]
    assert topics.RobotTopics("/robot1").scan == "/robot1/scan" and topics.RobotTopics("").tf == "/tf"
    assert topics.RobotTopics("").label == "/"


def test_simulators_arms_and_lifecycle_nodes_are_found():
    assert topics.simulators(SERVICES) == ["/simulator"]
    assert topics.lifecycle_nodes(SERVICES) == ["/planner", "/simulator"]
    assert topics.localizers(SERVICES) == ["/particle_filter"]
    assert topics.joint_state_nodes(GRAPH) == ["/ik_service"]
    assert topics.simulator_status_topics(GRAPH) == ["/simulator/status"]
    assert topics.split("/a/b/c") == ("/a/b", "c") and topics.join("", "goal_pose") == "/goal_pose"


def test_one_click_goal_faces_away_from_the_robot_and_an_estimate_keeps_its_heading():
    tool, robot = ClickTool(), Pose2D(1.0, 1.0, 0.3)
    assert tool.click(2.0, 2.0, robot) == (GOAL, Pose2D(2.0, 2.0, math.pi / 4))
    assert tool.click(1.0, 1.0, robot) == (GOAL, Pose2D(1.0, 1.0, 0.3)), "on the robot: its own heading"
    assert tool.click(2.0, 2.0, None) == (GOAL, Pose2D(2.0, 2.0, 0.0))
    tool.set_mode(INITIAL_POSE)
    assert tool.click(-1.0, 0.5, robot) == (INITIAL_POSE, Pose2D(-1.0, 0.5, 0.3))
    assert tool.click(math.nan, 0.5, robot) is None
    tool.set_mode(OFF)
    assert tool.click(0.0, 0.0, robot) is None
    with pytest.raises(ValueError, match="click mode 'drag'"):
        tool.set_mode("drag")


def test_two_clicks_give_position_then_heading():
    tool = ClickTool(mode=INITIAL_POSE, two_clicks=True)
    assert tool.click(1.0, 1.0, None) is None and tool.pending == (1.0, 1.0)
    assert tool.click(1.0, 3.0, Pose2D(0, 0, 0)) == (INITIAL_POSE, Pose2D(1.0, 1.0, math.pi / 2))
    assert tool.pending is None
    tool.click(0.0, 0.0, None)
    tool.set_mode(GOAL)
    assert tool.pending is None, "changing mode forgets a first click"


def test_a_nodes_entries_come_in_its_names_order_or_not_at_all_when_the_counts_differ():
    names = ["kp", "enabled"]
    descriptors = [ParameterDescriptor(type=T.PARAMETER_DOUBLE), ParameterDescriptor(type=T.PARAMETER_BOOL)]
    values = [parameter_value(T.PARAMETER_DOUBLE, 2.0), parameter_value(T.PARAMETER_BOOL, True)]
    entries = entries_from(names, descriptors, values)
    assert [(e.name, e.value, e.widget) for e in entries] == [("kp", 2.0, "number"), ("enabled", True, "checkbox")]
    assert entries_from(names, descriptors, []) is None, "rclpy answers no value for all when one is unset"
    assert entries_from(names, descriptors[:1], values) is None
