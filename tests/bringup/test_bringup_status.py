"""The pieces of --status and of the composed crash report that need no running stack."""

import pytest
from geometry_msgs.msg import Twist

from amr_bringup.bringup import ComposedStack
from amr_bringup.status import TopicRow, format_table, message_class


def test_message_classes_come_from_the_graph_type_names():
    assert message_class("geometry_msgs/msg/Twist") is Twist
    with pytest.raises(ImportError):
        message_class("no_such_msgs/msg/Thing")
    with pytest.raises(AttributeError):
        message_class("geometry_msgs/msg/NoSuchType")


def test_table_lists_states_and_rates_in_aligned_columns():
    text = format_table(
        "amr-bringup maze_sim  3 s",
        [("wall_follower", "active"), ("simulator", "inactive")],
        [
            TopicRow("/cmd_vel", "geometry_msgs/msg/TwistStamped", 19.96, ("wall_follower",)),
            TopicRow("/weird", "x_msgs/msg/Y", None, ("simulator", "other")),
        ],
    )
    assert text.splitlines() == [
        "amr-bringup maze_sim  3 s",
        "NODE           STATE",
        "wall_follower  active",
        "simulator      inactive",
        "",
        "TOPIC     TYPE                            RATE (Hz)  PUBLISHERS",
        "/cmd_vel  geometry_msgs/msg/TwistStamped       20.0  wall_follower",
        "/weird    x_msgs/msg/Y                            ?  simulator, other",
    ]
    assert format_table("t", [], []).endswith("(no topic published by the stack yet)")


class FakeNode:
    def __init__(self, name):
        self.name = name

    def get_name(self):
        return self.name

    def callback(self):
        raise RuntimeError("boom")


def test_a_composed_crash_names_the_node_whose_callback_raised():
    stack = ComposedStack.__new__(ComposedStack)
    stack.nodes, stack.crash = [FakeNode("simulator"), FakeNode("wall_follower")], None

    def executor_step(node):
        node.callback()

    try:
        executor_step(stack.nodes[1])
    except RuntimeError as error:
        stack.record_crash(error)
    assert stack.failure() == "node wall_follower raised RuntimeError: boom"
