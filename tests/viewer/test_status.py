"""The status panel's text: node states grouped by namespace, the disc's distance from the true ring."""

from amr_viewer.status import node_state_table, offset_text, split_node


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
