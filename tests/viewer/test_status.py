"""The status panel's text: node states grouped by namespace, the disc's distance from the true ring."""

import numpy as np

from amr_util.geometry import Pose2D
from amr_viewer.state import Estimate, RobotState
from amr_viewer.status import node_state_table, offset_text, panel_text, robot_line, split_node


def test_node_states_are_grouped_by_namespace_root_first_active_first():
    states = {
        "/r2/navigator": "active",
        "/simulator": "active",
        "/r1/planner": "inactive",
        "/r1/navigator": "active",
        "/r1/path_follower": "active",
        "/map_server": "active",
    }
    rows = node_state_table(states).splitlines()
    assert rows[:2] == ["| namespace | nodes |", "|---|---|"]
    assert rows[2:] == [
        "| / | active: map_server, simulator |",
        "| /r1 | active: navigator, path_follower; **inactive**: planner |",
        "| /r2 | active: navigator |",
    ]
    assert node_state_table({}) == ""


def test_a_node_splits_into_namespace_and_name():
    assert split_node("/r1/navigator") == ("/r1", "navigator")
    assert split_node("/fleet/r1/navigator") == ("/fleet/r1", "navigator")
    assert split_node("/simulator") == ("/", "simulator")


def test_the_offset_is_said_in_centimetres_and_only_when_there_is_one():
    assert offset_text(None) is None
    assert offset_text(0.034) == "disc 3 cm from the true ring (localization error)"


def test_a_robot_line_says_what_is_known_of_it():
    state = RobotState("/r1")
    assert robot_line(state, "blue") == "**robot /r1** (blue)"
    state.on_estimate(Estimate(Pose2D(0.0, 0.0, 0.0), (0.01, 0.0, 0.01), False))
    state.particle_count, state.particles = 500, np.zeros((100, 3))
    state.skipped["map"] = 2
    line = robot_line(state, "blue")
    assert (
        line == "**robot /r1** (blue): not localized; 500 particles (100 drawn); 2 map messages not drawn (see the log)"
    )


def test_the_panel_puts_the_nodes_first_then_the_simulator_the_robots_and_the_arms():
    assert panel_text({}, None, [], {}) == "nothing found yet"
    text = panel_text({"/simulator": "active"}, True, ["**robot /**"], {"/ik_service": ["planar_2r", "puma"]})
    parts = text.split("\n\n")
    assert parts[0].startswith("| namespace | nodes |") and parts[1:] == [
        "**simulator paused**",
        "**robot /**",
        "**arms of /ik_service**: planar_2r, puma",
    ]
    assert panel_text({}, False, [], {}) == "simulator running"
